//! Storage: cells, programs, routines, waypoints, predictions and feedback, and the uploaded arm
//! models, in SQLite (one file, the default) or PostgreSQL (shared by several instances)
//! through sqlx's Any driver: one set of queries for both ([`backend`]).
//!
//! The database is the source of truth; the models in memory are rebuilt from it. Every
//! write is one transaction; appends share theirs with the other cells' appends queued at the
//! same time ([`group_commit`]), written as [`append`] describes. Every write to a cell advances the cell's revision
//! ([`CellWrite`]), so that models of it in several instances follow the database. SQLite runs
//! in WAL mode with `synchronous = NORMAL`: a committed transaction survives the process being
//! killed (it is in the WAL, which the OS holds); only a power loss can take back the last
//! commits (use `synchronous = FULL` via [`Durability::Full`] when that matters more than
//! latency). Queries are checked at run time (`query_as` + `FromRow`), so building needs no
//! live database.
//!
//! Backups of an SQLite file while it serves are [`backup`]'s.
//!
//! [`Store`]'s methods are spread by table: [`cells`], [`programs`], [`routines`],
//! [`waypoints`], [`predictions`], [`feedback`], [`robots`], [`tokens`]; a program's revisions
//! are [`history`]'s. What they share is written once:
//! the reads by id ([`query`]), the statements a write makes in its transaction
//! ([`transaction`]), the `INSERT` of each table an append writes ([`inserts`]), the rows and
//! their columns ([`rows`]), the order values are bound in ([`binds`]) and, for statements
//! built to a batch's size, their parameters' names ([`slots`]).

mod append;
mod audit;
mod backend;
mod backup;
mod binds;
mod cell_write;
mod cells;
mod error;
mod feedback;
mod group_commit;
mod history;
mod inserts;
mod migrate;
mod predictions;
mod programs;
mod query;
mod robots;
mod routines;
mod rows;
mod slots;
mod tokens;
mod transaction;
mod waypoints;

use std::sync::Arc;

use sqlx::AnyPool;

use error::Result;

pub use append::{Append, Appended};
pub use audit::{AuditFilter, Recorder};
pub use backend::{Backend, Durability, Location};
pub use backup::{BackupError, BackupFile, backup_database};
pub use cell_write::CellWrite;
pub use error::StorageError;
pub use history::{RevisionFilter, RevisionRow};
pub use rows::{
    AuditRow, CellRow, CellState, FeedbackCounts, NewFeedback, NewImportedRoutine, NewPrediction,
    NewWaypoint, PredictionRow, ProgramRow, RobotRow, RoutineRow, TeachingVerdictRow, TokenRow,
    WaypointRow,
};
// The program model's revisions, as storage writes and reads them.
pub use crate::program::revisions::{
    Change, ProgramState, RoutineState, WaypointState, WaypointValues,
};

/// The store: SQLite (one file, this process the only writer) or PostgreSQL (shared by several
/// instances). Appends go through one group-commit writer ([`group_commit`]); everything else
/// is a transaction of its own on the pool.
#[derive(Debug, Clone)]
pub struct Store {
    pool: AnyPool,
    backend: Backend,
    /// Where the database is (the SQLite file a backup copies).
    location: Arc<Location>,
    appends: group_commit::Writer,
}

impl Store {
    /// Opens (creating if missing) the database and applies the migrations.
    pub async fn connect(location: &Location, durability: Durability) -> Result<Store> {
        let (pool, backend) = backend::connect(location, durability).await?;
        let appends = group_commit::Writer::start(pool.clone(), backend);
        Ok(Store {
            pool,
            backend,
            location: Arc::new(location.clone()),
            appends,
        })
    }

    /// Opens (creating if missing) the SQLite file at `path` and applies the migrations.
    pub async fn open(path: &std::path::Path, durability: Durability) -> Result<Store> {
        Store::connect(&Location::File(path.to_path_buf()), durability).await
    }

    /// An in-memory SQLite database.
    pub async fn in_memory() -> Result<Store> {
        Store::connect(&Location::Memory, Durability::Process).await
    }

    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// A trivial query: is the database answering?
    pub async fn ping(&self) -> Result<()> {
        sqlx::query("SELECT 1").execute(&self.pool).await?;
        Ok(())
    }

    pub async fn close(&self) {
        self.pool.close().await;
    }
}
