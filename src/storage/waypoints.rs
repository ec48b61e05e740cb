//! The `waypoints` table: a routine's taught poses in order (`seq`), appended while teaching
//! (through the group commit, [`super::group_commit`], which writes them as [`super::append`]
//! describes) and edited in place afterwards.

use super::Store;
use super::append::{Append, Appended};
use super::binds::Binds;
use super::cell_write::CellWrite;
use super::error::{Result, StorageError, classify};
use super::history::{self, Change};
use super::inserts;
use super::query::select;
use super::rows::{CellState, NewPrediction, NewWaypoint, Stored, WaypointRow, WaypointValues};
use super::transaction::{self, Places, UPDATE_WAYPOINT, close_gap, make_room, touch_cell};

impl Store {
    pub async fn waypoints(&self, routine_id: i64) -> Result<Vec<WaypointRow>> {
        self.list("WHERE routine_id = $1 ORDER BY seq", &[routine_id])
            .await
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
        self.list(
            "WHERE routine_id = $1 AND seq > $2 ORDER BY seq",
            &[routine_id, seq],
        )
        .await
    }

    pub async fn waypoint(&self, id: i64) -> Result<Option<WaypointRow>> {
        self.find("WHERE id = $1", &[id]).await
    }

    // ---- teaching ----------------------------------------------------------------------------

    /// Appends a waypoint and, when one is offered, the prediction made after it, in one
    /// transaction shared with other cells' appends queued at the same time (group commit).
    /// Answers once committed.
    pub async fn append_waypoint(&self, append: Append) -> Result<Appended> {
        self.appends.append(append).await
    }

    /// Appends several waypoints to a routine of `cell_id`, each with the prediction offered
    /// after it (when one was), as one append, all or nothing: a trajectory taught at once.
    /// The model in memory made them at revision `expected` (refused with
    /// [`StorageError::Stale`] when the cell has moved on); the revision advances once.
    pub async fn append_waypoints(
        &self,
        cell_id: i64,
        expected: i64,
        appends: &[(NewWaypoint, Option<NewPrediction>)],
    ) -> Result<Vec<Appended>> {
        self.appends.append_all(cell_id, expected, appends).await
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
            WaypointRow::COLUMNS
        );
        let row = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(routine_id)
            .fetch_optional(&mut *tx)
            .await?;
        let Some(undone) = &row else {
            // Nothing to undo: nothing changed (the revision stays).
            return Ok((None, state));
        };
        record_removal(&mut tx, undone).await?;
        tx.commit().await?;
        Ok((row, state))
    }

    // ---- edits -------------------------------------------------------------------------------
    //
    // Every edit is one transaction; one that changes a learned routine advances the cell's
    // model version in it (`advance`). Places stay 1, 2, … ([`make_room`], [`close_gap`]).

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
        let before = select::<WaypointRow>("WHERE id = $1", &[id])
            .fetch_optional(&mut *tx)
            .await?
            .ok_or(StorageError::NotFound)?;
        let sql = format!("{UPDATE_WAYPOINT} RETURNING {}", WaypointRow::COLUMNS);
        let after = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .waypoint_values(&v.pose, &v.joints, &v.motion, &v.name, v.reachable)
            .bind(id)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        let was = WaypointValues::of(&before);
        if was != WaypointValues::of(&after) {
            let program = history::program_of(&mut tx, after.routine_id).await?;
            let change = Change::WaypointModified {
                routine: after.routine_id,
                waypoint: id,
                before: was,
            };
            history::record(&mut tx, program, &[change]).await?;
        }
        tx.commit().await?;
        Ok((before, after, state.model_version))
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
        make_room(&mut tx, Places::Waypoints, routine_id, seq).await?;
        let row = inserts::insert_waypoints(&mut tx, &[v.at(routine_id, seq)])
            .await?
            .pop()
            .ok_or(StorageError::NotFound)?;
        let program = history::program_of(&mut tx, routine_id).await?;
        let change = Change::WaypointAdded {
            routine: routine_id,
            seq: row.seq,
        };
        history::record(&mut tx, program, &[change]).await?;
        tx.commit().await?;
        Ok((row, state.model_version))
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
            WaypointRow::COLUMNS
        );
        let row = sqlx::query_as::<_, WaypointRow>(sqlx::AssertSqlSafe(sql))
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?
            .ok_or(StorageError::NotFound)?;
        close_gap(&mut tx, Places::Waypoints, row.routine_id, row.seq).await?;
        record_removal(&mut tx, &row).await?;
        tx.commit().await?;
        Ok((row, state.model_version))
    }
}

/// The revision of a waypoint taken out of its routine (undone or deleted).
async fn record_removal(tx: &mut transaction::Tx<'_>, row: &WaypointRow) -> Result<()> {
    let program = history::program_of(tx, row.routine_id).await?;
    let change = Change::WaypointRemoved {
        routine: row.routine_id,
        seq: row.seq,
        waypoint: history::WaypointState {
            id: row.id,
            values: WaypointValues::of(row),
        },
    };
    history::record(tx, program, &[change]).await?;
    Ok(())
}
