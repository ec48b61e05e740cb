//! Storage: cells, programs, routines, waypoints, predictions and feedback in SQLite via sqlx.
//!
//! The database is the source of truth; the models in memory are rebuilt from it. Every
//! write is one transaction. SQLite runs in WAL mode with `synchronous = NORMAL`: a committed
//! transaction survives the process being killed (it is in the WAL, which the OS holds); only
//! a power loss can take back the last commits (use `synchronous = FULL` via
//! [`Durability::Full`] when that matters more than latency). Queries are checked at run time
//! (`query_as` + `FromRow`), so building needs no live database.

mod rows;

use std::path::Path;
use std::str::FromStr;
use std::time::Duration;

use sqlx::sqlite::{
    SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteSynchronous,
};

pub use rows::{
    CellRow, FeedbackCounts, NewFeedback, NewImportedRoutine, NewPrediction, NewWaypoint,
    PoseColumns, PredictionRow, ProgramRow, RobotRow, RoutineRow, WaypointRow, WaypointValues,
};

/// How hard commits try to reach the disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Durability {
    /// Survives a crash of the process (WAL, `synchronous = NORMAL`).
    #[default]
    Process,
    /// Survives a power loss too (`synchronous = FULL`), at the cost of an fsync per commit.
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

/// The SQLite store.
#[derive(Debug, Clone)]
pub struct Store {
    pool: SqlitePool,
}

impl Store {
    /// Opens (creating if missing) the database file at `path` and applies the migrations.
    pub async fn open(path: &Path, durability: Durability) -> Result<Store> {
        let options = SqliteConnectOptions::new()
            .filename(path)
            .create_if_missing(true);
        Store::connect(options, 8, durability).await
    }

    /// An in-memory database (one connection: each `:memory:` connection is its own database).
    pub async fn in_memory() -> Result<Store> {
        let options = SqliteConnectOptions::from_str("sqlite::memory:")?;
        Store::connect(options, 1, Durability::Process).await
    }

    async fn connect(
        options: SqliteConnectOptions,
        max_connections: u32,
        durability: Durability,
    ) -> Result<Store> {
        let options = options
            .journal_mode(SqliteJournalMode::Wal)
            .synchronous(match durability {
                Durability::Process => SqliteSynchronous::Normal,
                Durability::Full => SqliteSynchronous::Full,
            })
            .foreign_keys(true)
            .busy_timeout(Duration::from_secs(5));
        let pool = SqlitePoolOptions::new()
            .max_connections(max_connections)
            .min_connections(1)
            .connect_with(options)
            .await?;
        sqlx::migrate!("./migrations").run(&pool).await?;
        Ok(Store { pool })
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
            "INSERT INTO cells (name, settings) VALUES (?, ?) \
             RETURNING id, name, settings, created_at, model_version, settings_changed_at",
        )
        .bind(name)
        .bind(settings_json)
        .fetch_one(&self.pool)
        .await
        .map_err(classify)
    }

    pub async fn cell(&self, id: i64) -> Result<Option<CellRow>> {
        Ok(sqlx::query_as::<_, CellRow>(
            "SELECT id, name, settings, created_at, model_version, settings_changed_at FROM cells WHERE id = ?",
        )
        .bind(id)
        .fetch_optional(&self.pool)
        .await?)
    }

    pub async fn cells(&self) -> Result<Vec<CellRow>> {
        Ok(sqlx::query_as::<_, CellRow>(
            "SELECT id, name, settings, created_at, model_version, settings_changed_at FROM cells ORDER BY id",
        )
        .fetch_all(&self.pool)
        .await?)
    }

    // ---- programs ---------------------------------------------------------------------------

    pub async fn insert_program(&self, cell_id: i64, name: &str) -> Result<ProgramRow> {
        sqlx::query_as::<_, ProgramRow>(
            "INSERT INTO programs (cell_id, name) VALUES (?, ?) \
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
            "SELECT id, cell_id, name, created_at FROM programs WHERE id = ?",
        )
        .bind(id)
        .fetch_optional(&self.pool)
        .await?)
    }

    pub async fn programs(&self, cell_id: i64) -> Result<Vec<ProgramRow>> {
        Ok(sqlx::query_as::<_, ProgramRow>(
            "SELECT id, cell_id, name, created_at FROM programs WHERE cell_id = ? ORDER BY id",
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
    pub async fn insert_routine(&self, program: &ProgramRow, name: Option<&str>) -> Result<i64> {
        let row: (i64,) = sqlx::query_as(
            "INSERT INTO routines (program_id, cell_id, position, name) \
             VALUES (?1, ?2, (SELECT COALESCE(MAX(position), 0) + 1 FROM routines \
                              WHERE program_id = ?1), ?3) \
             RETURNING id",
        )
        .bind(program.id)
        .bind(program.cell_id)
        .bind(name)
        .fetch_one(&self.pool)
        .await
        .map_err(classify)?;
        Ok(row.0)
    }

    pub async fn routine(&self, id: i64) -> Result<Option<RoutineRow>> {
        let sql = match_routine_sql(Self::ROUTINE_COLUMNS, "WHERE r.id = ?");
        Ok(sqlx::query_as::<_, RoutineRow>(sqlx::AssertSqlSafe(sql))
            .bind(id)
            .fetch_optional(&self.pool)
            .await?)
    }

    pub async fn routines(&self, program_id: i64) -> Result<Vec<RoutineRow>> {
        let sql = match_routine_sql(
            Self::ROUTINE_COLUMNS,
            "WHERE r.program_id = ? ORDER BY r.position",
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
                 FROM routines WHERE id = ?",
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
            "WHERE r.cell_id = ? AND r.finish_seq IS NULL AND r.imported = 0",
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
            "WHERE r.cell_id = ? AND r.finish_seq IS NOT NULL ORDER BY r.finish_seq",
        );
        Ok(sqlx::query_as::<_, RoutineRow>(sqlx::AssertSqlSafe(sql))
            .bind(cell_id)
            .fetch_all(&self.pool)
            .await?)
    }

    /// Marks a routine finished; returns its place in the cell's assimilation order.
    pub async fn finish_routine(&self, cell_id: i64, routine_id: i64) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let row: (i64,) = sqlx::query_as(
            "UPDATE routines SET \
               finish_seq = (SELECT COALESCE(MAX(finish_seq), 0) + 1 FROM routines \
                             WHERE cell_id = ?1), \
               finished_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') \
             WHERE id = ?2 AND finish_seq IS NULL \
             RETURNING finish_seq",
        )
        .bind(cell_id)
        .bind(routine_id)
        .fetch_one(&mut *tx)
        .await
        .map_err(classify)?;
        advance_model_version(&mut tx, cell_id, 1).await?;
        tx.commit().await?;
        Ok(row.0)
    }

    /// Stores imported programs with their routines and waypoints in one transaction. With
    /// `learn`, the routines are marked finished in order (the model must learn them in that
    /// order). Returns each program's row and routine ids.
    pub async fn import_programs(
        &self,
        cell_id: i64,
        programs: &[(String, Vec<NewImportedRoutine>)],
        learn: bool,
    ) -> Result<Vec<(ProgramRow, Vec<i64>)>> {
        let mut tx = self.pool.begin().await?;
        let mut out = Vec::with_capacity(programs.len());
        for (name, routines) in programs {
            let program = sqlx::query_as::<_, ProgramRow>(
                "INSERT INTO programs (cell_id, name) VALUES (?, ?) \
                 RETURNING id, cell_id, name, created_at",
            )
            .bind(cell_id)
            .bind(name)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
            let mut ids = Vec::with_capacity(routines.len());
            for (position, r) in routines.iter().enumerate() {
                let (id,): (i64,) = sqlx::query_as(
                    "INSERT INTO routines (program_id, cell_id, position, name, imported, \
                       finish_seq, finished_at) \
                     VALUES (?1, ?2, ?3, ?4, 1, \
                       CASE WHEN ?5 THEN (SELECT COALESCE(MAX(finish_seq), 0) + 1 FROM routines \
                                          WHERE cell_id = ?2) END, \
                       CASE WHEN ?5 THEN strftime('%Y-%m-%dT%H:%M:%fZ', 'now') END) \
                     RETURNING id",
                )
                .bind(program.id)
                .bind(cell_id)
                .bind(position as i64 + 1)
                .bind(&r.name)
                .bind(learn)
                .fetch_one(&mut *tx)
                .await
                .map_err(classify)?;
                insert_waypoints(&mut tx, id, &r.waypoints).await?;
                ids.push(id);
            }
            if learn {
                advance_model_version(&mut tx, cell_id, ids.len() as i64).await?;
            }
            out.push((program, ids));
        }
        tx.commit().await?;
        Ok(out)
    }

    /// Deletes a routine that is being taught (with its waypoints and predictions).
    pub async fn delete_open_routine(&self, routine_id: i64) -> Result<()> {
        let done = sqlx::query(
            "DELETE FROM routines WHERE id = ? AND finish_seq IS NULL AND imported = 0",
        )
        .bind(routine_id)
        .execute(&self.pool)
        .await?;
        if done.rows_affected() == 0 {
            return Err(StorageError::NotFound);
        }
        Ok(())
    }

    // ---- waypoints --------------------------------------------------------------------------

    const WAYPOINT_COLUMNS: &'static str =
        "id, routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, reachable, created_at";

    pub async fn waypoints(&self, routine_id: i64) -> Result<Vec<WaypointRow>> {
        let sql = format!(
            "SELECT {} FROM waypoints WHERE routine_id = ? ORDER BY seq",
            Self::WAYPOINT_COLUMNS
        );
        Ok(sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(routine_id)
            .fetch_all(&self.pool)
            .await?)
    }

    /// Appends a waypoint and, when one is offered, the prediction made after it, in one
    /// transaction. Returns the stored waypoint and the prediction's id.
    pub async fn append_waypoint(
        &self,
        wp: &NewWaypoint,
        prediction: Option<&NewPrediction>,
    ) -> Result<(WaypointRow, Option<i64>)> {
        let sql = format!(
            "INSERT INTO waypoints (routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, \
             reachable) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let p = &wp.pose;
        let insert = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(wp.routine_id)
            .bind(wp.seq)
            .bind(p.x)
            .bind(p.y)
            .bind(p.z)
            .bind(p.qw)
            .bind(p.qx)
            .bind(p.qy)
            .bind(p.qz)
            .bind(&wp.joints)
            .bind(&wp.motion)
            .bind(&wp.name)
            .bind(wp.reachable);
        let Some(pr) = prediction else {
            // One statement is its own transaction.
            let row = insert.fetch_one(&self.pool).await.map_err(classify)?;
            return Ok((row, None));
        };
        let mut tx = self.pool.begin().await?;
        let row = insert.fetch_one(&mut *tx).await.map_err(classify)?;
        let pid = insert_prediction(&mut tx, pr, Some(row.id)).await?;
        tx.commit().await?;
        Ok((row, Some(pid)))
    }

    /// Deletes the last waypoint of a routine; returns it. Predictions made after it stay
    /// recorded: they were offered, and feedback may refer to them.
    pub async fn delete_last_waypoint(&self, routine_id: i64) -> Result<Option<WaypointRow>> {
        let mut tx = self.pool.begin().await?;
        let sql = format!(
            "DELETE FROM waypoints WHERE id = (SELECT id FROM waypoints WHERE routine_id = ? \
             ORDER BY seq DESC LIMIT 1) RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let row = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(routine_id)
            .fetch_optional(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(row)
    }

    // ---- edits -------------------------------------------------------------------------------
    //
    // Every edit is one transaction; one that changes a learned routine advances the cell's
    // model version in it (`advance`). Places (`seq`, `position`) stay 1, 2, …: rows after the
    // place are shifted through negative values, since SQLite checks `UNIQUE` per row.

    pub async fn waypoint(&self, id: i64) -> Result<Option<WaypointRow>> {
        let sql = format!(
            "SELECT {} FROM waypoints WHERE id = ?",
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
        advance: bool,
    ) -> Result<(WaypointRow, WaypointRow, i64)> {
        let mut tx = self.pool.begin().await?;
        let select = format!(
            "SELECT {} FROM waypoints WHERE id = ?",
            Self::WAYPOINT_COLUMNS
        );
        let before = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(select))
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?
            .ok_or(StorageError::NotFound)?;
        let sql = format!(
            "UPDATE waypoints SET x = ?, y = ?, z = ?, qw = ?, qx = ?, qy = ?, qz = ?, \
             joints = ?, motion = ?, name = ?, reachable = ? WHERE id = ? RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let p = &v.pose;
        let after = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(p.x)
            .bind(p.y)
            .bind(p.z)
            .bind(p.qw)
            .bind(p.qx)
            .bind(p.qy)
            .bind(p.qz)
            .bind(&v.joints)
            .bind(&v.motion)
            .bind(&v.name)
            .bind(v.reachable)
            .bind(id)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        let version = advance_model_version(&mut tx, cell_id, i64::from(advance)).await?;
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
        advance: bool,
    ) -> Result<(WaypointRow, i64)> {
        let mut tx = self.pool.begin().await?;
        sqlx::query("UPDATE waypoints SET seq = -seq - 1 WHERE routine_id = ? AND seq >= ?")
            .bind(routine_id)
            .bind(seq)
            .execute(&mut *tx)
            .await?;
        sqlx::query("UPDATE waypoints SET seq = -seq WHERE routine_id = ? AND seq < 0")
            .bind(routine_id)
            .execute(&mut *tx)
            .await?;
        let sql = format!(
            "INSERT INTO waypoints (routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, \
             reachable) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let p = &v.pose;
        let row = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(routine_id)
            .bind(seq)
            .bind(p.x)
            .bind(p.y)
            .bind(p.z)
            .bind(p.qw)
            .bind(p.qx)
            .bind(p.qy)
            .bind(p.qz)
            .bind(&v.joints)
            .bind(&v.motion)
            .bind(&v.name)
            .bind(v.reachable)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        let version = advance_model_version(&mut tx, cell_id, i64::from(advance)).await?;
        tx.commit().await?;
        Ok((row, version))
    }

    /// Deletes a waypoint; the ones after it move one place up. Returns the deleted row and
    /// the model version.
    pub async fn delete_waypoint(
        &self,
        id: i64,
        cell_id: i64,
        advance: bool,
    ) -> Result<(WaypointRow, i64)> {
        let mut tx = self.pool.begin().await?;
        let sql = format!(
            "DELETE FROM waypoints WHERE id = ? RETURNING {}",
            Self::WAYPOINT_COLUMNS
        );
        let row = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?
            .ok_or(StorageError::NotFound)?;
        sqlx::query("UPDATE waypoints SET seq = -(seq - 1) WHERE routine_id = ? AND seq > ?")
            .bind(row.routine_id)
            .bind(row.seq)
            .execute(&mut *tx)
            .await?;
        sqlx::query("UPDATE waypoints SET seq = -seq WHERE routine_id = ? AND seq < 0")
            .bind(row.routine_id)
            .execute(&mut *tx)
            .await?;
        let version = advance_model_version(&mut tx, cell_id, i64::from(advance)).await?;
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
             VALUES (?1, ?2, (SELECT COALESCE(MAX(position), 0) + 1 FROM routines \
                              WHERE program_id = ?1), ?3, 1) \
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
        let done = sqlx::query("UPDATE routines SET name = ? WHERE id = ?")
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
            sqlx::query_as("SELECT program_id, position FROM routines WHERE id = ?")
                .bind(id)
                .fetch_optional(&mut *tx)
                .await?
                .ok_or(StorageError::NotFound)?;
        let (count,): (i64,) = sqlx::query_as("SELECT COUNT(*) FROM routines WHERE program_id = ?")
            .bind(program_id)
            .fetch_one(&mut *tx)
            .await?;
        let to = position.clamp(1, count.max(1));
        // Out of the way (place 0), the others closed up, opened at `to`, then back in.
        sqlx::query("UPDATE routines SET position = 0 WHERE id = ?")
            .bind(id)
            .execute(&mut *tx)
            .await?;
        close_up_routines(&mut tx, program_id, from).await?;
        sqlx::query(
            "UPDATE routines SET position = -(position + 1) WHERE program_id = ? AND position >= ?",
        )
        .bind(program_id)
        .bind(to)
        .execute(&mut *tx)
        .await?;
        sqlx::query(
            "UPDATE routines SET position = -position WHERE program_id = ? AND position < 0",
        )
        .bind(program_id)
        .execute(&mut *tx)
        .await?;
        sqlx::query("UPDATE routines SET position = ? WHERE id = ?")
            .bind(to)
            .bind(id)
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(())
    }

    /// Deletes a routine, finished or not, with its waypoints, predictions and feedback; the
    /// routines after it in its program move one place up. Returns the model version.
    pub async fn delete_routine(&self, id: i64, cell_id: i64, advance: bool) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let (program_id, position): (i64, i64) =
            sqlx::query_as("DELETE FROM routines WHERE id = ? RETURNING program_id, position")
                .bind(id)
                .fetch_optional(&mut *tx)
                .await?
                .ok_or(StorageError::NotFound)?;
        close_up_routines(&mut tx, program_id, position).await?;
        let version = advance_model_version(&mut tx, cell_id, i64::from(advance)).await?;
        tx.commit().await?;
        Ok(version)
    }

    pub async fn rename_program(&self, id: i64, name: &str) -> Result<ProgramRow> {
        sqlx::query_as::<_, ProgramRow>(
            "UPDATE programs SET name = ? WHERE id = ? RETURNING id, cell_id, name, created_at",
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
    pub async fn delete_program(&self, id: i64, cell_id: i64, advance: bool) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let done = sqlx::query("DELETE FROM programs WHERE id = ?")
            .bind(id)
            .execute(&mut *tx)
            .await?;
        if done.rows_affected() == 0 {
            return Err(StorageError::NotFound);
        }
        let version = advance_model_version(&mut tx, cell_id, i64::from(advance)).await?;
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
        let row = sqlx::query_as::<_, CellRow>(
            "UPDATE cells SET name = COALESCE(?1, name), settings = COALESCE(?2, settings), \
               settings_changed_at = CASE WHEN ?2 IS NULL THEN settings_changed_at \
                 ELSE strftime('%Y-%m-%dT%H:%M:%fZ', 'now') END, \
               model_version = model_version + CASE WHEN ?2 IS NULL THEN 0 ELSE 1 END \
             WHERE id = ?3 \
             RETURNING id, name, settings, created_at, model_version, settings_changed_at",
        )
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
        let done = sqlx::query("DELETE FROM cells WHERE id = ?")
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
            "INSERT INTO robots (name, urdf, maker, product, payload_kg) VALUES (?, ?, ?, ?, ?) \
             RETURNING name, urdf, maker, product, payload_kg, created_at",
        )
        .bind(name)
        .bind(urdf)
        .bind(maker)
        .bind(product)
        .bind(payload_kg)
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
        let done = sqlx::query("DELETE FROM robots WHERE name = ?")
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
            "SELECT (SELECT id FROM waypoints WHERE routine_id = ? ORDER BY seq DESC LIMIT 1)",
        )
        .bind(pr.routine_id)
        .fetch_one(&mut *tx)
        .await?;
        let existing: Option<(i64,)> = sqlx::query_as(
            "SELECT id FROM predictions WHERE routine_id = ? AND after_seq = ? \
             AND after_waypoint_id IS ? AND model_version = ? \
             AND x = ? AND y = ? AND z = ? AND qw = ? AND qx = ? AND qy = ? AND qz = ? \
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
             FROM predictions p LEFT JOIN feedback f ON f.prediction_id = p.id WHERE p.id = ?",
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
             VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
        )
        .bind(fb.prediction_id)
        .bind(fb.verdict)
        .bind(p.map(|p| p.x))
        .bind(p.map(|p| p.y))
        .bind(p.map(|p| p.z))
        .bind(p.map(|p| p.qw))
        .bind(p.map(|p| p.qx))
        .bind(p.map(|p| p.qy))
        .bind(p.map(|p| p.qz))
        .bind(fb.adjustment_mm)
        .execute(&self.pool)
        .await
        .map_err(classify)?;
        Ok(())
    }

    /// Offered/accepted/adjusted/rejected counts and the adjustment distances of a cell.
    pub async fn feedback_counts(&self, cell_id: i64) -> Result<FeedbackCounts> {
        let (offered,): (i64,) =
            sqlx::query_as("SELECT COUNT(*) FROM predictions WHERE cell_id = ?")
                .bind(cell_id)
                .fetch_one(&self.pool)
                .await?;
        let verdicts: Vec<(String, Option<f64>)> = sqlx::query_as(
            "SELECT f.verdict, f.adjustment_mm FROM feedback f \
             JOIN predictions p ON p.id = f.prediction_id WHERE p.cell_id = ?",
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

/// Inserts a prediction made after the waypoint `after_waypoint` (None: nothing taught yet).
/// Advances a cell's model version by `by` (0: reads it) in the transaction; returns it.
async fn advance_model_version(
    tx: &mut sqlx::Transaction<'_, sqlx::Sqlite>,
    cell_id: i64,
    by: i64,
) -> Result<i64> {
    let (v,): (i64,) = sqlx::query_as(
        "UPDATE cells SET model_version = model_version + ? WHERE id = ? RETURNING model_version",
    )
    .bind(by)
    .bind(cell_id)
    .fetch_optional(&mut **tx)
    .await?
    .ok_or(StorageError::NotFound)?;
    Ok(v)
}

/// Stores a new routine's waypoints, numbered 1, 2, … in order.
async fn insert_waypoints(
    tx: &mut sqlx::Transaction<'_, sqlx::Sqlite>,
    routine_id: i64,
    waypoints: &[WaypointValues],
) -> Result<()> {
    for (i, v) in waypoints.iter().enumerate() {
        let p = &v.pose;
        sqlx::query(
            "INSERT INTO waypoints (routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, \
               name, reachable) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
        )
        .bind(routine_id)
        .bind(i as i64 + 1)
        .bind(p.x)
        .bind(p.y)
        .bind(p.z)
        .bind(p.qw)
        .bind(p.qx)
        .bind(p.qy)
        .bind(p.qz)
        .bind(&v.joints)
        .bind(&v.motion)
        .bind(&v.name)
        .bind(v.reachable)
        .execute(&mut **tx)
        .await
        .map_err(classify)?;
    }
    Ok(())
}

/// Closes the gap a routine left at `position` of its program.
async fn close_up_routines(
    tx: &mut sqlx::Transaction<'_, sqlx::Sqlite>,
    program_id: i64,
    position: i64,
) -> Result<()> {
    sqlx::query(
        "UPDATE routines SET position = -(position - 1) WHERE program_id = ? AND position > ?",
    )
    .bind(program_id)
    .bind(position)
    .execute(&mut **tx)
    .await?;
    sqlx::query("UPDATE routines SET position = -position WHERE program_id = ? AND position < 0")
        .bind(program_id)
        .execute(&mut **tx)
        .await?;
    Ok(())
}

async fn insert_prediction(
    tx: &mut sqlx::Transaction<'_, sqlx::Sqlite>,
    pr: &NewPrediction,
    after_waypoint: Option<i64>,
) -> Result<i64> {
    let (id,): (i64,) = sqlx::query_as(
        "INSERT INTO predictions (cell_id, routine_id, after_seq, after_waypoint_id, x, y, z, \
           qw, qx, qy, qz, phi, psi, misfit, end_probability, model_version) \
         VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
    )
    .bind(pr.cell_id)
    .bind(pr.routine_id)
    .bind(pr.after_seq)
    .bind(after_waypoint)
    .bind(pr.pose.x)
    .bind(pr.pose.y)
    .bind(pr.pose.z)
    .bind(pr.pose.qw)
    .bind(pr.pose.qx)
    .bind(pr.pose.qy)
    .bind(pr.pose.qz)
    .bind(pr.phi)
    .bind(pr.psi)
    .bind(pr.misfit)
    .bind(pr.end_probability)
    .bind(pr.model_version)
    .fetch_one(&mut **tx)
    .await
    .map_err(classify)?;
    Ok(id)
}
