//! The application service: what a pendant can ask of nextpose, independent of the wire.
//!
//! Both adapters, REST ([`crate::http`]) and gRPC ([`crate::grpc`]), call these operations and
//! nothing else; they speak the wire types of [`crate::api`]. One file per use case (cells,
//! programs, routines, teaching, editing, imports, exports, trajectory, feedback, replays,
//! backups, ...); the cell's model in memory ([`cell_model`]) owns its own state changes. Each
//! operation checks its input, writes to the database ([`crate::storage`], SQLite or
//! PostgreSQL) in one transaction, and keeps the cell's model in memory in step. The database
//! is the source of truth: a cell's model is rebuilt from it on first use after start-up (and
//! on request), and that rebuild gives the same model as the incremental updates.
//!
//! **Concurrency.** Requests on one cell are serialised by the cell's lock, held from the first
//! read of the routine's state to the last write, so the model and the database never diverge;
//! different cells proceed in parallel. A cell has at most one routine being taught (one arm,
//! one operator); the database enforces it too.
//!
//! **Cancellation.** Every operation that changes a cell's model runs to completion on a task of
//! its own ([`App::to_completion`]): a caller that goes away (a client hanging up, a REST
//! timeout, a cancelled gRPC call) stops waiting for the answer, not the operation, so the
//! model and the database change together or not at all. Shutdown waits for these tasks.
//! CPU-heavy work (predictions on request, open-loop completions, parsing and learning
//! imports, learning a model from the database) runs on blocking threads ([`blocking`]), so one
//! cell's import does not stall other cells' requests.

mod access;
mod arm;
pub mod audit;
mod backups;
mod calibration;
mod cell_model;
mod cells;
mod credentials;
mod editing;
pub mod error;
mod exports;
mod feedback;
mod history;
pub mod imports;
mod layout;
mod offer;
mod programs;
pub mod reach;
mod registry;
mod replays;
mod retarget;
pub mod robots;
mod routines;
mod rows;
pub mod settings;
mod teaching;
mod tokens;
mod trajectory;

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use tokio_util::task::TaskTracker;

use crate::storage::Store;
use crate::telemetry::Metrics;
pub use access::{Action, Caller, Scope};
pub use arm::frames_joints;
use backups::Backups;
pub use backups::{BackupName, MAX_BACKUP_NAME};
pub use error::{AppError, ErrorKind};
use registry::Slot;
pub(crate) use registry::blocking;
use robots::Robots;
pub use tokens::{SECRET_PREFIX, secret_hash};
pub use trajectory::{
    MAX_ROTATION_MM_PER_RAD, MAX_TRAJECTORY_SAMPLES, REPRODUCTION_BUDGET, REPRODUCTION_ERROR_BUDGET,
};

/// Longest open-loop completion a request may ask for.
pub const MAX_COMPLETION: usize = 100;
/// Longest name accepted for cells, programs, routines and waypoints.
pub const MAX_NAME: usize = 200;

type Result<T> = std::result::Result<T, AppError>;

/// The application: storage, the cells' models and the metrics. Cloning is cheap (shared
/// handles), so an operation can own a copy on its own task.
#[derive(Debug, Clone)]
pub struct App {
    store: Store,
    models: Arc<Mutex<HashMap<i64, Slot>>>,
    metrics: Arc<Metrics>,
    robots: Arc<Robots>,
    /// Routine id → cell id (a routine never changes cell), so the hot path finds the cell to
    /// lock without a query. Deleting a routine removes its entry.
    routine_cells: Arc<Mutex<HashMap<i64, i64>>>,
    /// Tokens and the cells of resources, as authentication reads them ([`credentials`]).
    credentials: Arc<credentials::Credentials>,
    /// The operations running to completion (see [`App::to_completion`]).
    tasks: TaskTracker,
    /// Where backups go, taken one at a time ([`backups`]).
    backups: Arc<Backups>,
}

/// Taught joint values are finite; the error names the first that is not, by its place
/// (`joints[2] = NaN is not a finite number`). JSON cannot carry such a value; gRPC can.
fn check_joints_finite(joints: &[f64]) -> Result<()> {
    match joints.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        Some((i, v)) => Err(AppError::Invalid(format!(
            "joints[{i}] = {v:?} is not a finite number"
        ))),
        None => Ok(()),
    }
}

fn check_name(what: &str, name: &str) -> Result<()> {
    if name.trim().is_empty() {
        return Err(AppError::Invalid(format!("{what} must not be empty")));
    }
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return Err(AppError::Invalid(format!(
            "{what} must not contain control characters (found U+{:04X})",
            c as u32
        )));
    }
    if name.chars().count() > MAX_NAME {
        return Err(AppError::Invalid(format!(
            "{what} is longer than {MAX_NAME} characters"
        )));
    }
    Ok(())
}

impl App {
    pub fn new(store: Store, metrics: Arc<Metrics>, robots: Arc<Robots>) -> App {
        App {
            store,
            models: Arc::default(),
            metrics,
            robots,
            routine_cells: Arc::default(),
            credentials: Arc::default(),
            tasks: TaskTracker::new(),
            backups: Arc::default(),
        }
    }

    pub fn store(&self) -> &Store {
        &self.store
    }

    pub fn metrics(&self) -> &Arc<Metrics> {
        &self.metrics
    }

    /// Health: the database answers.
    pub async fn health(&self) -> Result<()> {
        Ok(self.store.ping().await?)
    }
}
