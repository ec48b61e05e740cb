//! The service, tested through its real HTTP interface: a real server on a loopback port with
//! a temporary SQLite file per test (see `helpers::spawn_app`).

mod arm;
mod audit;
mod backup;
mod cancellation;
#[path = "../common/corpus.rs"]
mod corpus;
mod durability;
mod editing;
mod errors;
mod export;
mod export_pinned;
mod feedback;
mod grpc;
mod helpers;
mod history;
mod import;
mod instances;
mod mutated_imports;
mod openapi;
mod pose_checks;
mod reach;
mod retarget;
mod retry;
mod robots;
mod roles;
mod schemathesis;
mod settings;
mod standalone;
mod storage;
mod teaching;
mod tokens;
mod trajectory;
mod upgrade;
