//! Resources ↔ protobuf messages, one file per resource as in [`crate::api`]. Outbound
//! conversions are total; inbound ones refuse what the wire allows but the resource cannot hold
//! (a missing pose, an unknown enum value) with `INVALID_ARGUMENT`, as the REST adapter refuses
//! malformed JSON.
//!
//! Both directions live here: the server's (requests → resources, resources → answers) and the
//! client's (`crate::client::grpc`: resources → requests, answers → resources), so that a field
//! added to a resource is added to both at once. A resource whose message has the same fields
//! converts through one list of them ([`wire`]); the functions below are the requests whose
//! shape differs from any resource (an id beside the body, a field protobuf cannot leave out).

mod arm;
mod audit;
mod backups;
mod cells;
mod feedback;
mod history;
mod imports;
mod poses;
mod predictions;
mod programs;
mod replays;
mod robots;
mod routines;
mod settings;
mod tokens;
mod trajectory;
mod waypoints;
mod wire;

pub use arm::{placement_search, reach_query};
pub use cells::{calibration, cell_patch, create_cell, create_cell_request};
pub use feedback::{feedback, feedback_request};
pub use history::{diff_query, history_query};
pub use imports::{import_programs_request, import_request};
pub use predictions::{predict_query, predict_request};
pub use replays::replay_request;
pub use routines::{retarget, routine_patch};
pub use trajectory::{trajectory_request, trajectory_request_out};
pub use waypoints::{insert_waypoint, new_waypoint, new_waypoint_out, waypoint_patch};
