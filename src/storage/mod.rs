//! Storage: cells, programs, routines, waypoints, predictions and feedback, in SQLite or
//! PostgreSQL through sqlx's Any driver (one set of queries; see [`backend`]).
//!
//! The database is the source of truth; the models in memory are rebuilt from it. Every
//! write is one transaction; appends share theirs with the other cells' appends queued at the
//! same time ([`group_commit`]). Every write to a cell advances the cell's revision
//! ([`CellWrite`]), so that models of it in several instances follow the database. SQLite runs
//! in WAL mode with `synchronous = NORMAL`: a committed transaction survives the process being
//! killed (it is in the WAL, which the OS holds); only a power loss can take back the last
//! commits (use `synchronous = FULL` via [`Durability::Full`] when that matters more than
//! latency). Queries are checked at run time (`query_as` + `FromRow`), so building needs no
//! live database.

mod backend;
mod binds;
mod group_commit;
mod rows;

use sqlx::AnyPool;

pub use backend::{Backend, Location};
use binds::Binds;
pub use rows::{
    CellRow, CellState, FeedbackCounts, NewFeedback, NewImportedRoutine, NewPrediction,
    NewWaypoint, PoseColumns, PredictionRow, ProgramRow, RobotRow, RoutineRow, WaypointRow,
    WaypointValues,
};
use rows::{flag, real};

/// How hard commits try to reach the disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Durability {
    /// Survives a crash of the process (WAL, `synchronous = NORMAL`).
    #[default]
    Process,
    /// Survives a power loss too (`synchronous = FULL`), at the cost of an fsync per commit.
    /// (PostgreSQL: as the server is configured; its default survives a power loss.)
    Full,
}

/// Storage failures, as the application sees them.
#[derive(Debug, thiserror::Error)]
pub enum StorageError {
    /// A uniqueness constraint was violated (e.g. a name already taken).
    #[error("already exists: {0}")]
    Conflict(String),
    /// A referenced row does not exist.
    #[error("not found")]
    NotFound,
    /// The cell was written by another instance since this one's model of it was read: the
    /// write was not made; catch up and try again.
    #[error("cell {cell} changed since revision {expected}")]
    Stale { cell: i64, expected: i64 },
    /// The store cannot take writes (it is shutting down).
    #[error("storage unavailable: {0}")]
    Unavailable(String),
    #[error("database error: {0}")]
    Database(#[from] sqlx::Error),
    #[error("migration failed: {0}")]
    Migration(#[from] sqlx::migrate::MigrateError),
}

fn classify(e: sqlx::Error) -> StorageError {
    if let sqlx::Error::Database(db) = &e
        && db.is_unique_violation()
    {
        return StorageError::Conflict(db.message().to_string());
    }
    if let sqlx::Error::RowNotFound = e {
        return StorageError::NotFound;
    }
    StorageError::Database(e)
}

type Result<T> = std::result::Result<T, StorageError>;

/// What a write does to its cell's row (see [`CellState`]): every write to a cell advances its
/// revision, and holds the row until it commits, so writes to one cell are serialised across
/// instances; the engine needs no lock of its own (a conditional update of a version row holds
/// on PostgreSQL and on the distributed engines that speak its protocol).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellWrite {
    /// The write follows the model in memory, which was at this revision: refused
    /// ([`StorageError::Stale`]) when the cell's revision is another.
    pub expected: Option<i64>,
    /// Advance the model version by this much (a learned routine changed).
    pub advance: i64,
    /// Another instance's model of the cell cannot follow this write incrementally.
    pub reload: bool,
}

impl CellWrite {
    /// A write the model in memory made at revision `expected` and follows itself.
    pub fn following(expected: i64) -> CellWrite {
        CellWrite {
            expected: Some(expected),
            advance: 0,
            reload: false,
        }
    }

    /// An edit: models elsewhere learn the cell again (and this one is rebuilt) when `reload`.
    pub fn edit(advance: bool, reload: bool) -> CellWrite {
        CellWrite {
            expected: None,
            advance: i64::from(advance),
            reload,
        }
    }
}

pub use group_commit::{Append, Appended};
type Tx<'c> = sqlx::Transaction<'c, sqlx::Any>;

/// The store: SQLite (one file, this process the only writer) or PostgreSQL (shared by several
/// instances). Appends go through one group-commit writer ([`group_commit`]); everything else
/// is a transaction of its own on the pool.
#[derive(Debug, Clone)]
pub struct Store {
    pool: AnyPool,
    backend: Backend,
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

    // ---- cells ------------------------------------------------------------------------------

    pub async fn insert_cell(&self, name: &str, settings_json: &str) -> Result<CellRow> {
        sqlx::query_as::<_, CellRow>(
            "INSERT INTO cells (name, settings) VALUES ($1, $2) \
             RETURNING id, name, settings, created_at, model_version, settings_changed_at, revision, \
             reload_revision",
        )
        .bind(name)
        .bind(settings_json)
        .fetch_one(&self.pool)
        .await
        .map_err(classify)
    }

    pub async fn cell(&self, id: i64) -> Result<Option<CellRow>> {
        Ok(sqlx::query_as::<_, CellRow>(
            "SELECT id, name, settings, created_at, model_version, settings_changed_at, revision, \
             reload_revision FROM cells WHERE id = $1",
        )
        .bind(id)
        .fetch_optional(&self.pool)
        .await?)
    }

    pub async fn cells(&self) -> Result<Vec<CellRow>> {
        Ok(sqlx::query_as::<_, CellRow>(
            "SELECT id, name, settings, created_at, model_version, settings_changed_at, revision, \
             reload_revision FROM cells ORDER BY id",
        )
        .fetch_all(&self.pool)
        .await?)
    }

    // ---- programs ---------------------------------------------------------------------------

    pub async fn insert_program(&self, cell_id: i64, name: &str) -> Result<ProgramRow> {
        sqlx::query_as::<_, ProgramRow>(
            "INSERT INTO programs (cell_id, name) VALUES ($1, $2) \
             RETURNING id, cell_id, name, created_at",
        )
        .bind(cell_id)
        .bind(name)
        .fetch_one(&self.pool)
        .await
        .map_err(classify)
    }

    pub async fn program(&self, id: i64) -> Result<Option<ProgramRow>> {
        Ok(sqlx::query_as::<_, ProgramRow>(
            "SELECT id, cell_id, name, created_at FROM programs WHERE id = $1",
        )
        .bind(id)
        .fetch_optional(&self.pool)
        .await?)
    }

    pub async fn programs(&self, cell_id: i64) -> Result<Vec<ProgramRow>> {
        Ok(sqlx::query_as::<_, ProgramRow>(
            "SELECT id, cell_id, name, created_at FROM programs WHERE cell_id = $1 ORDER BY id",
        )
        .bind(cell_id)
        .fetch_all(&self.pool)
        .await?)
    }

    // ---- routines ---------------------------------------------------------------------------

    const ROUTINE_COLUMNS: &'static str = "r.id, r.program_id, r.cell_id, r.position, r.name, \
        r.finish_seq, r.finished_at, r.created_at, r.imported, \
        (SELECT COUNT(*) FROM waypoints w WHERE w.routine_id = r.id) AS waypoints";

    /// Adds a routine at the end of a program. Fails with `Conflict` when the cell already has
    /// a routine being taught.
    pub async fn insert_routine(
        &self,
        program: &ProgramRow,
        name: Option<&str>,
        expected: i64,
    ) -> Result<(i64, CellState)> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, program.cell_id, CellWrite::following(expected)).await?;
        let row: (i64,) = sqlx::query_as(
            "INSERT INTO routines (program_id, cell_id, position, name) \
             VALUES ($1, $2, (SELECT COALESCE(MAX(position), 0) + 1 FROM routines \
                              WHERE program_id = $1), $3) \
             RETURNING id",
        )
        .bind(program.id)
        .bind(program.cell_id)
        .bind(name)
        .fetch_one(&mut *tx)
        .await
        .map_err(classify)?;
        tx.commit().await?;
        Ok((row.0, state))
    }

    pub async fn routine(&self, id: i64) -> Result<Option<RoutineRow>> {
        let sql = match_routine_sql(Self::ROUTINE_COLUMNS, "WHERE r.id = $1");
        Ok(sqlx::query_as::<_, RoutineRow>(sqlx::AssertSqlSafe(sql))
            .bind(id)
            .fetch_optional(&self.pool)
            .await?)
    }

    pub async fn routines(&self, program_id: i64) -> Result<Vec<RoutineRow>> {
        let sql = match_routine_sql(
            Self::ROUTINE_COLUMNS,
            "WHERE r.program_id = $1 ORDER BY r.position",
        );
        Ok(sqlx::query_as::<_, RoutineRow>(sqlx::AssertSqlSafe(sql))
            .bind(program_id)
            .fetch_all(&self.pool)
            .await?)
    }

    /// The cell of a routine and whether it is finished (a point lookup for the hot path).
    pub async fn routine_cell(&self, id: i64) -> Result<Option<(i64, bool)>> {
        let row: Option<(i64, Option<i64>)> = sqlx::query_as(
            "SELECT cell_id, CASE WHEN finish_seq IS NOT NULL OR imported = 1 THEN 1 END \
                 FROM routines WHERE id = $1",
        )
        .bind(id)
        .fetch_optional(&self.pool)
        .await?;
        Ok(row.map(|(cell, seq)| (cell, seq.is_some())))
    }

    /// The routine of a cell that is being taught, if any.
    pub async fn open_routine(&self, cell_id: i64) -> Result<Option<RoutineRow>> {
        let sql = match_routine_sql(
            Self::ROUTINE_COLUMNS,
            "WHERE r.cell_id = $1 AND r.finish_seq IS NULL AND r.imported = 0",
        );
        Ok(sqlx::query_as::<_, RoutineRow>(sqlx::AssertSqlSafe(sql))
            .bind(cell_id)
            .fetch_optional(&self.pool)
            .await?)
    }

    /// The finished routines of a cell in the order the model assimilated them.
    pub async fn finished_routines(&self, cell_id: i64) -> Result<Vec<RoutineRow>> {
        let sql = match_routine_sql(
            Self::ROUTINE_COLUMNS,
            "WHERE r.cell_id = $1 AND r.finish_seq IS NOT NULL ORDER BY r.finish_seq",
        );
        Ok(sqlx::query_as::<_, RoutineRow>(sqlx::AssertSqlSafe(sql))
            .bind(cell_id)
            .fetch_all(&self.pool)
            .await?)
    }

    /// Marks a routine finished (the model at revision `expected` learned it); returns its
    /// place in the cell's assimilation order and the cell's state after.
    pub async fn finish_routine(
        &self,
        cell_id: i64,
        routine_id: i64,
        expected: i64,
    ) -> Result<(i64, CellState)> {
        let mut tx = self.pool.begin().await?;
        let write = CellWrite {
            advance: 1,
            ..CellWrite::following(expected)
        };
        let state = touch_cell(&mut tx, cell_id, write).await?;
        let sql = format!(
            "UPDATE routines SET \
               finish_seq = (SELECT COALESCE(MAX(finish_seq), 0) + 1 FROM routines \
                             WHERE cell_id = $1), \
               finished_at = {} \
             WHERE id = $2 AND finish_seq IS NULL \
             RETURNING finish_seq",
            self.backend.now()
        );
        let row: (i64,) = sqlx::query_as(sqlx::AssertSqlSafe(sql))
            .bind(cell_id)
            .bind(routine_id)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        tx.commit().await?;
        Ok((row.0, state))
    }

    /// The finished routines of a cell learned after `finish_seq` (catching up).
    pub async fn routines_finished_after(
        &self,
        cell_id: i64,
        finish_seq: i64,
    ) -> Result<Vec<RoutineRow>> {
        let sql = match_routine_sql(
            Self::ROUTINE_COLUMNS,
            "WHERE r.cell_id = $1 AND r.finish_seq > $2 ORDER BY r.finish_seq",
        );
        Ok(sqlx::query_as::<_, RoutineRow>(sqlx::AssertSqlSafe(sql))
            .bind(cell_id)
            .bind(finish_seq)
            .fetch_all(&self.pool)
            .await?)
    }

    /// Where a cell's writes stand (None: no such cell).
    pub async fn cell_state(&self, cell_id: i64) -> Result<Option<CellState>> {
        Ok(sqlx::query_as::<_, CellState>(
            "SELECT id, revision, reload_revision, model_version FROM cells WHERE id = $1",
        )
        .bind(cell_id)
        .fetch_optional(&self.pool)
        .await?)
    }

    /// Stores imported programs with their routines and waypoints in one transaction. With
    /// `learn`, the routines are marked finished in order (the model must learn them in that
    /// order). Returns each program's row and routine ids.
    pub async fn import_programs(
        &self,
        cell_id: i64,
        programs: &[(String, Vec<NewImportedRoutine>)],
        learn: bool,
    ) -> Result<(Vec<(ProgramRow, Vec<i64>)>, CellState, Option<i64>)> {
        let mut tx = self.pool.begin().await?;
        let learned = if learn {
            programs.iter().map(|(_, r)| r.len() as i64).sum()
        } else {
            0
        };
        let write = CellWrite {
            expected: None,
            advance: learned,
            reload: learned > 0,
        };
        let state = touch_cell(&mut tx, cell_id, write).await?;
        let mut last_finish = None;
        let mut out = Vec::with_capacity(programs.len());
        let insert_routine = format!(
            "INSERT INTO routines (program_id, cell_id, position, name, imported, \
               finish_seq, finished_at) \
             VALUES ($1, $2, $3, $4, 1, \
               CASE WHEN $5 = 1 THEN (SELECT COALESCE(MAX(finish_seq), 0) + 1 FROM routines \
                                      WHERE cell_id = $2) END, \
               CASE WHEN $5 = 1 THEN {} END) \
             RETURNING id, finish_seq",
            self.backend.now()
        );
        for (name, routines) in programs {
            let program = sqlx::query_as::<_, ProgramRow>(
                "INSERT INTO programs (cell_id, name) VALUES ($1, $2) \
                 RETURNING id, cell_id, name, created_at",
            )
            .bind(cell_id)
            .bind(name)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
            let mut ids = Vec::with_capacity(routines.len());
            for (position, r) in routines.iter().enumerate() {
                let (id, finish_seq): (i64, Option<i64>) =
                    sqlx::query_as(sqlx::AssertSqlSafe(insert_routine.clone()))
                        .bind(program.id)
                        .bind(cell_id)
                        .bind(position as i64 + 1)
                        .bind(&r.name)
                        .bind(flag(learn))
                        .fetch_one(&mut *tx)
                        .await
                        .map_err(classify)?;
                insert_waypoints(&mut tx, id, &r.waypoints).await?;
                last_finish = finish_seq.or(last_finish);
                ids.push(id);
            }
            out.push((program, ids));
        }
        tx.commit().await?;
        Ok((out, state, last_finish))
    }

    /// Deletes a routine that is being taught (with its waypoints and predictions); the model
    /// at revision `expected` forgets it.
    pub async fn delete_open_routine(
        &self,
        routine_id: i64,
        cell_id: i64,
        expected: i64,
    ) -> Result<CellState> {
        let mut tx = self.pool.begin().await?;
        let write = CellWrite {
            reload: true,
            ..CellWrite::following(expected)
        };
        let state = touch_cell(&mut tx, cell_id, write).await?;
        let done = sqlx::query(
            "DELETE FROM routines WHERE id = $1 AND finish_seq IS NULL AND imported = 0",
        )
        .bind(routine_id)
        .execute(&mut *tx)
        .await?;
        if done.rows_affected() == 0 {
            return Err(StorageError::NotFound);
        }
        tx.commit().await?;
        Ok(state)
    }

    // ---- waypoints --------------------------------------------------------------------------

    pub(super) const WAYPOINT_COLUMNS: &'static str =
        "id, routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, reachable, created_at";

    pub async fn waypoints(&self, routine_id: i64) -> Result<Vec<WaypointRow>> {
        let sql = format!(
            "SELECT {} FROM waypoints WHERE routine_id = $1 ORDER BY seq",
            Self::WAYPOINT_COLUMNS
        );
        Ok(sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(routine_id)
            .fetch_all(&self.pool)
            .await?)
    }

    /// The ids of a routine's waypoints in order.
    pub async fn waypoint_ids(&self, routine_id: i64) -> Result<Vec<i64>> {
        let rows: Vec<(i64,)> =
            sqlx::query_as("SELECT id FROM waypoints WHERE routine_id = $1 ORDER BY seq")
                .bind(routine_id)
                .fetch_all(&self.pool)
                .await?;
        Ok(rows.into_iter().map(|(id,)| id).collect())
    }

    /// A routine's waypoints after the first `seq` ones.
    pub async fn waypoints_after(&self, routine_id: i64, seq: i64) -> Result<Vec<WaypointRow>> {
        let sql = format!(
            "SELECT {} FROM waypoints WHERE routine_id = $1 AND seq > $2 ORDER BY seq",
            Self::WAYPOINT_COLUMNS
        );
        Ok(sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(routine_id)
            .bind(seq)
            .fetch_all(&self.pool)
            .await?)
    }

    /// Appends a waypoint and, when one is offered, the prediction made after it, in one
    /// transaction shared with other cells' appends queued at the same time (group commit).
    /// Answers once committed.
    pub async fn append_waypoint(&self, append: Append) -> Result<Appended> {
        self.appends.append(append).await
    }

    /// Appends several waypoints to a routine of `cell_id`, each with the prediction offered
    /// after it (when one was), in one transaction of their own, all or nothing: a trajectory
    /// taught at once. The model in memory made them at revision `expected` (refused with
    /// [`StorageError::Stale`] when the cell has moved on); the revision advances once. Not
    /// through the group-commit writer: its batches hold one append per cell.
    pub async fn append_waypoints(
        &self,
        cell_id: i64,
        expected: i64,
        appends: &[(NewWaypoint, Option<NewPrediction>)],
    ) -> Result<Vec<Appended>> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, CellWrite::following(expected)).await?;
        let mut out = Vec::with_capacity(appends.len());
        for (waypoint, prediction) in appends {
            let row = insert_waypoint_row(&mut tx, waypoint).await?;
            let prediction_id = match prediction {
                Some(p) => Some(insert_prediction(&mut tx, p, Some(row.id)).await?),
                None => None,
            };
            out.push(Appended {
                row,
                prediction_id,
                revision: state.revision,
                batch: 1,
            });
        }
        tx.commit().await?;
        Ok(out)
    }

    /// Deletes the last waypoint of a routine; returns it. Predictions made after it stay
    /// recorded: they were offered, and feedback may refer to them.
    pub async fn delete_last_waypoint(
        &self,
        routine_id: i64,
        cell_id: i64,
        expected: i64,
    ) -> Result<(Option<WaypointRow>, CellState)> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, CellWrite::following(expected)).await?;
        let sql = format!(
            "DELETE FROM waypoints WHERE id = (SELECT id FROM waypoints WHERE routine_id = $1 \
             ORDER BY seq DESC LIMIT 1) RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let row = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(routine_id)
            .fetch_optional(&mut *tx)
            .await?;
        if row.is_none() {
            // Nothing to undo: nothing changed (the revision stays).
            return Ok((None, state));
        }
        tx.commit().await?;
        Ok((row, state))
    }

    // ---- edits -------------------------------------------------------------------------------
    //
    // Every edit is one transaction; one that changes a learned routine advances the cell's
    // model version in it (`advance`). Places (`seq`, `position`) stay 1, 2, …: rows after the
    // place are shifted through negative values, since SQLite checks `UNIQUE` per row.

    pub async fn waypoint(&self, id: i64) -> Result<Option<WaypointRow>> {
        let sql = format!(
            "SELECT {} FROM waypoints WHERE id = $1",
            Self::WAYPOINT_COLUMNS
        );
        Ok(sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(id)
            .fetch_optional(&self.pool)
            .await?)
    }

    /// Sets a waypoint's values. Returns the row before and after, and the model version.
    pub async fn update_waypoint(
        &self,
        id: i64,
        v: &WaypointValues,
        cell_id: i64,
        write: CellWrite,
    ) -> Result<(WaypointRow, WaypointRow, i64)> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, write).await?;
        let select = format!(
            "SELECT {} FROM waypoints WHERE id = $1",
            Self::WAYPOINT_COLUMNS
        );
        let before = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(select))
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?
            .ok_or(StorageError::NotFound)?;
        let sql = format!(
            "UPDATE waypoints SET x = $1, y = $2, z = $3, qw = $4, qx = $5, qy = $6, qz = $7, \
             joints = $8, motion = $9, name = $10, reachable = $11 WHERE id = $12 RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let after = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .waypoint_values(&v.pose, &v.joints, &v.motion, &v.name, v.reachable)
            .bind(id)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        let version = state.model_version;
        tx.commit().await?;
        Ok((before, after, version))
    }

    /// Inserts a waypoint at place `seq` of a routine (1 = first); the waypoints from there on
    /// move one place down. Returns the stored row and the model version.
    pub async fn insert_waypoint(
        &self,
        routine_id: i64,
        seq: i64,
        v: &WaypointValues,
        cell_id: i64,
        write: CellWrite,
    ) -> Result<(WaypointRow, i64)> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, write).await?;
        sqlx::query("UPDATE waypoints SET seq = -seq - 1 WHERE routine_id = $1 AND seq >= $2")
            .bind(routine_id)
            .bind(seq)
            .execute(&mut *tx)
            .await?;
        sqlx::query("UPDATE waypoints SET seq = -seq WHERE routine_id = $1 AND seq < 0")
            .bind(routine_id)
            .execute(&mut *tx)
            .await?;
        let sql = format!(
            "INSERT INTO waypoints (routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, \
             reachable) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13) RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let row = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(routine_id)
            .bind(seq)
            .waypoint_values(&v.pose, &v.joints, &v.motion, &v.name, v.reachable)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        let version = state.model_version;
        tx.commit().await?;
        Ok((row, version))
    }

    /// Deletes a waypoint; the ones after it move one place up. Returns the deleted row and
    /// the model version.
    pub async fn delete_waypoint(
        &self,
        id: i64,
        cell_id: i64,
        write: CellWrite,
    ) -> Result<(WaypointRow, i64)> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, write).await?;
        let sql = format!(
            "DELETE FROM waypoints WHERE id = $1 RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let row = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?
            .ok_or(StorageError::NotFound)?;
        sqlx::query("UPDATE waypoints SET seq = -(seq - 1) WHERE routine_id = $1 AND seq > $2")
            .bind(row.routine_id)
            .bind(row.seq)
            .execute(&mut *tx)
            .await?;
        sqlx::query("UPDATE waypoints SET seq = -seq WHERE routine_id = $1 AND seq < 0")
            .bind(row.routine_id)
            .execute(&mut *tx)
            .await?;
        let version = state.model_version;
        tx.commit().await?;
        Ok((row, version))
    }

    /// Appends a finished routine that the model does not learn (a copy made by the service,
    /// e.g. re-targeted to a moved fixture: it was not taught, like an import without learning)
    /// to a program. Returns its id.
    pub async fn insert_unlearned_routine(
        &self,
        program: &ProgramRow,
        name: Option<&str>,
        waypoints: &[WaypointValues],
    ) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let (id,): (i64,) = sqlx::query_as(
            "INSERT INTO routines (program_id, cell_id, position, name, imported) \
             VALUES ($1, $2, (SELECT COALESCE(MAX(position), 0) + 1 FROM routines \
                              WHERE program_id = $1), $3, 1) \
             RETURNING id",
        )
        .bind(program.id)
        .bind(program.cell_id)
        .bind(name)
        .fetch_one(&mut *tx)
        .await
        .map_err(classify)?;
        insert_waypoints(&mut tx, id, waypoints).await?;
        tx.commit().await?;
        Ok(id)
    }

    /// Renames a routine (None: no name).
    pub async fn rename_routine(&self, id: i64, name: Option<&str>) -> Result<()> {
        let done = sqlx::query("UPDATE routines SET name = $1 WHERE id = $2")
            .bind(name)
            .bind(id)
            .execute(&self.pool)
            .await
            .map_err(classify)?;
        if done.rows_affected() == 0 {
            return Err(StorageError::NotFound);
        }
        Ok(())
    }

    /// Moves a routine to place `position` of its program (1 = first, clamped to the last);
    /// the others keep their order.
    pub async fn move_routine(&self, id: i64, position: i64) -> Result<()> {
        let mut tx = self.pool.begin().await?;
        let (program_id, from): (i64, i64) =
            sqlx::query_as("SELECT program_id, position FROM routines WHERE id = $1")
                .bind(id)
                .fetch_optional(&mut *tx)
                .await?
                .ok_or(StorageError::NotFound)?;
        let (count,): (i64,) =
            sqlx::query_as("SELECT COUNT(*) FROM routines WHERE program_id = $1")
                .bind(program_id)
                .fetch_one(&mut *tx)
                .await?;
        let to = position.clamp(1, count.max(1));
        // Out of the way (place 0), the others closed up, opened at `to`, then back in.
        sqlx::query("UPDATE routines SET position = 0 WHERE id = $1")
            .bind(id)
            .execute(&mut *tx)
            .await?;
        close_up_routines(&mut tx, program_id, from).await?;
        sqlx::query(
            "UPDATE routines SET position = -(position + 1) WHERE program_id = $1 AND position >= $2",
        )
        .bind(program_id)
        .bind(to)
        .execute(&mut *tx)
        .await?;
        sqlx::query(
            "UPDATE routines SET position = -position WHERE program_id = $1 AND position < 0",
        )
        .bind(program_id)
        .execute(&mut *tx)
        .await?;
        sqlx::query("UPDATE routines SET position = $1 WHERE id = $2")
            .bind(to)
            .bind(id)
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(())
    }

    /// Deletes a routine, finished or not, with its waypoints, predictions and feedback; the
    /// routines after it in its program move one place up. Returns the model version.
    pub async fn delete_routine(&self, id: i64, cell_id: i64, write: CellWrite) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, write).await?;
        let (program_id, position): (i64, i64) =
            sqlx::query_as("DELETE FROM routines WHERE id = $1 RETURNING program_id, position")
                .bind(id)
                .fetch_optional(&mut *tx)
                .await?
                .ok_or(StorageError::NotFound)?;
        close_up_routines(&mut tx, program_id, position).await?;
        let version = state.model_version;
        tx.commit().await?;
        Ok(version)
    }

    pub async fn rename_program(&self, id: i64, name: &str) -> Result<ProgramRow> {
        sqlx::query_as::<_, ProgramRow>(
            "UPDATE programs SET name = $1 WHERE id = $2 RETURNING id, cell_id, name, created_at",
        )
        .bind(name)
        .bind(id)
        .fetch_optional(&self.pool)
        .await
        .map_err(classify)?
        .ok_or(StorageError::NotFound)
    }

    /// Deletes a program with its routines; returns the model version (advanced when a
    /// learned routine went with it).
    pub async fn delete_program(&self, id: i64, cell_id: i64, write: CellWrite) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, write).await?;
        let done = sqlx::query("DELETE FROM programs WHERE id = $1")
            .bind(id)
            .execute(&mut *tx)
            .await?;
        if done.rows_affected() == 0 {
            return Err(StorageError::NotFound);
        }
        let version = state.model_version;
        tx.commit().await?;
        Ok(version)
    }

    /// Renames a cell and/or sets its settings (then `settings_changed_at` is now and the
    /// model version advances, as the model is learned again with them).
    pub async fn update_cell(
        &self,
        id: i64,
        name: Option<&str>,
        settings_json: Option<&str>,
    ) -> Result<CellRow> {
        let mut tx = self.pool.begin().await?;
        let sql = format!(
            "UPDATE cells SET name = COALESCE($1, name), settings = COALESCE($2, settings), \
               settings_changed_at = CASE WHEN $2 IS NULL THEN settings_changed_at \
                 ELSE {} END, \
               model_version = model_version + CASE WHEN $2 IS NULL THEN 0 ELSE 1 END, \
               revision = revision + 1, \
               reload_revision = CASE WHEN $2 IS NULL THEN reload_revision ELSE revision + 1 END \
             WHERE id = $3 \
             RETURNING id, name, settings, created_at, model_version, settings_changed_at, revision, \
             reload_revision",
            self.backend.now()
        );
        let row = sqlx::query_as::<_, CellRow>(sqlx::AssertSqlSafe(sql))
            .bind(name)
            .bind(settings_json)
            .bind(id)
            .fetch_optional(&mut *tx)
            .await
            .map_err(classify)?
            .ok_or(StorageError::NotFound)?;
        tx.commit().await?;
        Ok(row)
    }

    /// Deletes a cell with everything it holds.
    pub async fn delete_cell(&self, id: i64) -> Result<()> {
        let done = sqlx::query("DELETE FROM cells WHERE id = $1")
            .bind(id)
            .execute(&self.pool)
            .await?;
        if done.rows_affected() == 0 {
            return Err(StorageError::NotFound);
        }
        Ok(())
    }

    // ---- uploaded robots --------------------------------------------------------------------

    /// Stores an uploaded arm model; a name already taken is a [`StorageError::Conflict`].
    pub async fn insert_robot(
        &self,
        name: &str,
        urdf: &str,
        maker: Option<&str>,
        product: Option<&str>,
        payload_kg: Option<f64>,
    ) -> Result<RobotRow> {
        sqlx::query_as::<_, RobotRow>(
            "INSERT INTO robots (name, urdf, maker, product, payload_kg) VALUES ($1, $2, $3, $4, $5) \
             RETURNING name, urdf, maker, product, payload_kg, created_at",
        )
        .bind(name)
        .bind(urdf)
        .bind(maker)
        .bind(product)
        .bind(real(payload_kg))
        .fetch_one(&self.pool)
        .await
        .map_err(classify)
    }

    /// The uploaded arm models, by name.
    pub async fn robots(&self) -> Result<Vec<RobotRow>> {
        Ok(sqlx::query_as::<_, RobotRow>(
            "SELECT name, urdf, maker, product, payload_kg, created_at FROM robots ORDER BY name",
        )
        .fetch_all(&self.pool)
        .await?)
    }

    /// Deletes an uploaded arm model.
    pub async fn delete_robot(&self, name: &str) -> Result<()> {
        let done = sqlx::query("DELETE FROM robots WHERE name = $1")
            .bind(name)
            .execute(&self.pool)
            .await?;
        if done.rows_affected() == 0 {
            return Err(StorageError::NotFound);
        }
        Ok(())
    }

    // ---- predictions and feedback -----------------------------------------------------------

    /// Records an offered prediction unless the same one is already recorded: made after the
    /// same waypoint (ids are never reused, so after an undo and a re-teach it is a new one),
    /// by the same model version, at the same pose. Returns its id either way.
    pub async fn record_prediction(&self, pr: &NewPrediction) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let (last,): (Option<i64>,) = sqlx::query_as(
            "SELECT (SELECT id FROM waypoints WHERE routine_id = $1 ORDER BY seq DESC LIMIT 1)",
        )
        .bind(pr.routine_id)
        .fetch_one(&mut *tx)
        .await?;
        let existing: Option<(i64,)> = sqlx::query_as(
            "SELECT id FROM predictions WHERE routine_id = $1 AND after_seq = $2 \
             AND after_waypoint_id IS NOT DISTINCT FROM $3 AND model_version = $4 \
             AND x = $5 AND y = $6 AND z = $7 AND qw = $8 AND qx = $9 AND qy = $10 AND qz = $11 \
             ORDER BY id LIMIT 1",
        )
        .bind(pr.routine_id)
        .bind(pr.after_seq)
        .bind(last)
        .bind(pr.model_version)
        .bind(pr.pose.x)
        .bind(pr.pose.y)
        .bind(pr.pose.z)
        .bind(pr.pose.qw)
        .bind(pr.pose.qx)
        .bind(pr.pose.qy)
        .bind(pr.pose.qz)
        .fetch_optional(&mut *tx)
        .await?;
        let id = match existing {
            Some((id,)) => id,
            None => insert_prediction(&mut tx, pr, last).await?,
        };
        tx.commit().await?;
        Ok(id)
    }

    pub async fn prediction(&self, id: i64) -> Result<Option<PredictionRow>> {
        Ok(sqlx::query_as::<_, PredictionRow>(
            "SELECT p.id, p.cell_id, p.routine_id, p.after_seq, \
               p.x, p.y, p.z, p.qw, p.qx, p.qy, p.qz, p.phi, p.psi, p.misfit, \
               p.end_probability, p.model_version, p.created_at, f.verdict \
             FROM predictions p LEFT JOIN feedback f ON f.prediction_id = p.id WHERE p.id = $1",
        )
        .bind(id)
        .fetch_optional(&self.pool)
        .await?)
    }

    /// Stores feedback on a prediction; `Conflict` when it already has some.
    pub async fn insert_feedback(&self, fb: &NewFeedback) -> Result<()> {
        let p = fb.pose.as_ref();
        sqlx::query(
            "INSERT INTO feedback (prediction_id, verdict, x, y, z, qw, qx, qy, qz, adjustment_mm) \
             VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10)",
        )
        .bind(fb.prediction_id)
        .bind(fb.verdict)
        .bind(real(p.map(|p| p.x)))
        .bind(real(p.map(|p| p.y)))
        .bind(real(p.map(|p| p.z)))
        .bind(real(p.map(|p| p.qw)))
        .bind(real(p.map(|p| p.qx)))
        .bind(real(p.map(|p| p.qy)))
        .bind(real(p.map(|p| p.qz)))
        .bind(real(fb.adjustment_mm))
        .execute(&self.pool)
        .await
        .map_err(classify)?;
        Ok(())
    }

    /// Offered/accepted/adjusted/rejected counts and the adjustment distances of a cell.
    pub async fn feedback_counts(&self, cell_id: i64) -> Result<FeedbackCounts> {
        let (offered,): (i64,) =
            sqlx::query_as("SELECT COUNT(*) FROM predictions WHERE cell_id = $1")
                .bind(cell_id)
                .fetch_one(&self.pool)
                .await?;
        let verdicts: Vec<(String, Option<f64>)> = sqlx::query_as(
            "SELECT f.verdict, f.adjustment_mm FROM feedback f \
             JOIN predictions p ON p.id = f.prediction_id WHERE p.cell_id = $1",
        )
        .bind(cell_id)
        .fetch_all(&self.pool)
        .await?;
        let mut counts = FeedbackCounts {
            offered,
            ..FeedbackCounts::default()
        };
        for (verdict, adjustment) in verdicts {
            match verdict.as_str() {
                "accepted" => counts.accepted += 1,
                "adjusted" => {
                    counts.adjusted += 1;
                    if let Some(a) = adjustment {
                        counts.adjustments_mm.push(a);
                    }
                }
                _ => counts.rejected += 1,
            }
        }
        Ok(counts)
    }
}

fn match_routine_sql(columns: &str, tail: &str) -> String {
    format!("SELECT {columns} FROM routines r {tail}")
}

/// Opens a write on a cell (see [`CellWrite`]): the first statement of the write's transaction,
/// so the cell's row is held until it commits. Returns the cell's state after the write.
async fn touch_cell(tx: &mut Tx<'_>, cell_id: i64, write: CellWrite) -> Result<CellState> {
    let state = sqlx::query_as::<_, CellState>(
        "UPDATE cells SET revision = revision + 1, model_version = model_version + $2, \
           reload_revision = CASE WHEN $3 = 1 THEN revision + 1 ELSE reload_revision END \
         WHERE id = $1 AND ($4 IS NULL OR revision = $4) \
         RETURNING id, revision, reload_revision, model_version",
    )
    .bind(cell_id)
    .bind(write.advance)
    .bind(flag(write.reload))
    .bind(write.expected)
    .fetch_optional(&mut **tx)
    .await?;
    if let Some(state) = state {
        return Ok(state);
    }
    match write.expected {
        Some(expected) => {
            let exists: Option<(i64,)> = sqlx::query_as("SELECT id FROM cells WHERE id = $1")
                .bind(cell_id)
                .fetch_optional(&mut **tx)
                .await?;
            match exists {
                Some(_) => Err(StorageError::Stale {
                    cell: cell_id,
                    expected,
                }),
                None => Err(StorageError::NotFound),
            }
        }
        None => Err(StorageError::NotFound),
    }
}

/// Inserts a taught waypoint; returns it as stored.
async fn insert_waypoint_row(tx: &mut Tx<'_>, wp: &NewWaypoint) -> Result<WaypointRow> {
    let sql = format!(
        "INSERT INTO waypoints (routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, \
         reachable) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13) RETURNING {}",
        Store::WAYPOINT_COLUMNS
    );
    sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
        .bind(wp.routine_id)
        .bind(wp.seq)
        .waypoint_values(&wp.pose, &wp.joints, &wp.motion, &wp.name, wp.reachable)
        .fetch_one(&mut **tx)
        .await
        .map_err(classify)
}

/// Stores a new routine's waypoints, numbered 1, 2, … in order.
async fn insert_waypoints(
    tx: &mut Tx<'_>,
    routine_id: i64,
    waypoints: &[WaypointValues],
) -> Result<()> {
    for (i, v) in waypoints.iter().enumerate() {
        sqlx::query(
            "INSERT INTO waypoints (routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, \
               name, reachable) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13)",
        )
        .bind(routine_id)
        .bind(i as i64 + 1)
        .waypoint_values(&v.pose, &v.joints, &v.motion, &v.name, v.reachable)
        .execute(&mut **tx)
        .await
        .map_err(classify)?;
    }
    Ok(())
}

/// Closes the gap a routine left at `position` of its program.
async fn close_up_routines(tx: &mut Tx<'_>, program_id: i64, position: i64) -> Result<()> {
    sqlx::query(
        "UPDATE routines SET position = -(position - 1) WHERE program_id = $1 AND position > $2",
    )
    .bind(program_id)
    .bind(position)
    .execute(&mut **tx)
    .await?;
    sqlx::query("UPDATE routines SET position = -position WHERE program_id = $1 AND position < 0")
        .bind(program_id)
        .execute(&mut **tx)
        .await?;
    Ok(())
}

pub(super) async fn insert_prediction(
    tx: &mut Tx<'_>,
    pr: &NewPrediction,
    after_waypoint: Option<i64>,
) -> Result<i64> {
    let (id,): (i64,) = sqlx::query_as(
        "INSERT INTO predictions (cell_id, routine_id, after_seq, after_waypoint_id, x, y, z, \
           qw, qx, qy, qz, phi, psi, misfit, end_probability, model_version) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16) RETURNING id",
    )
    .bind(pr.cell_id)
    .bind(pr.routine_id)
    .bind(pr.after_seq)
    .bind(after_waypoint)
    .prediction_values(pr)
    .fetch_one(&mut **tx)
    .await
    .map_err(classify)?;
    Ok(id)
}
