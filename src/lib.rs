//! nextpose: suggests the next waypoint while an operator teaches an industrial robot arm.
//!
//! - [`engine`]: the pure prediction engine. No I/O. The CDHMM of the dissertation (learner, HMM,
//!   forward prediction with its gates and scale estimate), the sequence experts and the
//!   calibrated offer rule, the template and the noise model that make up the default profile,
//!   and lead-through teaching (trajectories cut into waypoints).
//! - [`kinematics`]: robot models from URDF, FK, all IK solutions, reachability. No I/O beyond
//!   reading URDF files.
//! - [`program`]: the recorded-program type (program → routines → poses) every part shares.
//! - [`import`]: parses offline programs (ABB RAPID, KUKA KRL, FANUC TP) into waypoints. Pure.
//! - [`export`]: writes programs as ABB RAPID, KUKA KRL and FANUC TP files (the converse of
//!   [`import`]), with arm configurations from [`kinematics`]. Pure.
//! - [`replay`]: replays recorded programs through the engine and baselines and reports accuracy
//!   (the product's scoreboard). Reads corpus files; everything else it does is computation.
//! - [`api`]: the wire types (requests and answers, one file per resource) that the REST and
//!   gRPC adapters, the [`client`] and the tests share, with their OpenAPI schemas.
//! - [`app`]: the application service both adapters call: cells, programs, routines, teaching,
//!   predictions, feedback; one model per cell in memory, kept in step with the database.
//! - [`storage`]: the database via sqlx, SQLite by default or PostgreSQL (migrations in
//!   `migrations/`); the source of truth.
//! - [`http`]: the REST adapter (axum): extraction, routing, error mapping, OpenAPI.
//! - [`grpc`]: the gRPC adapter (tonic) on the same port: the same operations, a streaming
//!   teach session, reflection and health.
//! - [`transport`]: what both adapters share: options and limits, the optional bearer token
//!   (checked the same way by both), request ids and tracing.
//! - [`simulation`]: the simulated arm and operator, the programs they teach, the experiment
//!   plan, statistics and the programming-time table (pure, deterministic given a seed).
//! - [`simulation_driver`]: the driver that runs the simulated operator against a real server.
//! - [`server`]: start-up and graceful shutdown of the service.
//! - [`telemetry`]: Prometheus metrics.
//! - [`client`]: a typed client of a running service, over REST or gRPC (the simulator, the
//!   command line and the tests use it).
//! - [`cli`]: the `nextpose` command line.
//!
//! A taught waypoint enters through [`http`] (or [`grpc`]), is checked and stored by [`app`]
//! through [`storage`], learned and predicted by [`engine`], and the prediction leaves the way
//! it came.
//! The engine never imports the web or the database.

pub mod api;
pub mod app;
#[cfg(test)]
mod architecture;
pub mod cli;
pub mod client;
#[cfg(test)]
mod docs_links;
pub mod engine;
pub mod export;
pub mod grpc;
pub mod http;
pub mod import;
pub mod kinematics;
pub mod program;
pub mod replay;
pub mod server;
pub mod simulation;
pub mod simulation_driver;
pub mod storage;
pub mod telemetry;
pub mod transport;
