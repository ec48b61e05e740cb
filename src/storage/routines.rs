//! The `routines` table: a program's routines in order, each taught waypoint by waypoint until
//! it is finished (then the cell's model has learned it, in `finish_seq` order) or imported.

use super::Store;
use super::audit;
use super::cell_write::CellWrite;
use super::error::{Result, StorageError, classify};
use super::history::{self, Change};
use super::rows::{CellState, ProgramRow, RoutineRow, WaypointValues, flag};
use super::transaction::{
    Places, Tx, close_gap, hold_cell, insert_waypoints, make_room, touch_cell,
};

/// Adds a routine at the end of `program` (`imported`: one that takes no teaching) with
/// `waypoints`, as a revision of the program; returns its id.
async fn append_to(
    tx: &mut Tx<'_>,
    program: &ProgramRow,
    name: Option<&str>,
    imported: bool,
    waypoints: &[WaypointValues],
) -> Result<i64> {
    let (id,): (i64,) = sqlx::query_as(
        "INSERT INTO routines (program_id, cell_id, position, name, imported) \
         VALUES ($1, $2, (SELECT COALESCE(MAX(position), 0) + 1 FROM routines \
                          WHERE program_id = $1), $3, $4) \
         RETURNING id",
    )
    .bind(program.id)
    .bind(program.cell_id)
    .bind(name)
    .bind(flag(imported))
    .fetch_one(&mut **tx)
    .await
    .map_err(classify)?;
    insert_waypoints(tx, id, waypoints).await?;
    let change = Change::RoutineAdded {
        routine: id,
        position: history::routine_place(tx, id).await?,
        waypoints: waypoints.len() as i64,
    };
    history::record(tx, program.id, &[change]).await?;
    Ok(id)
}

impl Store {
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
        let id = append_to(&mut tx, program, name, false, &[]).await?;
        tx.commit().await?;
        Ok((id, state))
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
        hold_cell(&mut tx, program.cell_id).await?;
        let id = append_to(&mut tx, program, name, true, waypoints).await?;
        audit::record(&mut tx, Some(program.cell_id)).await?;
        tx.commit().await?;
        Ok(id)
    }

    pub async fn routine(&self, id: i64) -> Result<Option<RoutineRow>> {
        self.find("WHERE r.id = $1", &[id]).await
    }

    pub async fn routines(&self, program_id: i64) -> Result<Vec<RoutineRow>> {
        self.list("WHERE r.program_id = $1 ORDER BY r.position", &[program_id])
            .await
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
        self.find(
            "WHERE r.cell_id = $1 AND r.finish_seq IS NULL AND r.imported = 0",
            &[cell_id],
        )
        .await
    }

    /// The finished routines of a cell in the order the model assimilated them.
    pub async fn finished_routines(&self, cell_id: i64) -> Result<Vec<RoutineRow>> {
        self.list(
            "WHERE r.cell_id = $1 AND r.finish_seq IS NOT NULL ORDER BY r.finish_seq",
            &[cell_id],
        )
        .await
    }

    /// The finished routines of a cell learned after `finish_seq` (catching up).
    pub async fn routines_finished_after(
        &self,
        cell_id: i64,
        finish_seq: i64,
    ) -> Result<Vec<RoutineRow>> {
        self.list(
            "WHERE r.cell_id = $1 AND r.finish_seq > $2 ORDER BY r.finish_seq",
            &[cell_id, finish_seq],
        )
        .await
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
        let program = history::program_of(&mut tx, routine_id).await?;
        let change = Change::RoutineFinished {
            routine: routine_id,
        };
        history::record(&mut tx, program, &[change]).await?;
        tx.commit().await?;
        Ok((row.0, state))
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
        let state = touch_cell(&mut tx, cell_id, CellWrite::following_alone(expected)).await?;
        let (program, removed) = history::removal(&mut tx, routine_id).await?;
        let (position,): (i64,) = sqlx::query_as(
            "DELETE FROM routines WHERE id = $1 AND finish_seq IS NULL AND imported = 0 \
             RETURNING position",
        )
        .bind(routine_id)
        .fetch_optional(&mut *tx)
        .await?
        .ok_or(StorageError::NotFound)?;
        close_gap(&mut tx, Places::Routines, program, position).await?;
        history::record(&mut tx, program, &[removed]).await?;
        tx.commit().await?;
        Ok(state)
    }

    // ---- edits -------------------------------------------------------------------------------
    //
    // Every edit is one transaction; one that changes a learned routine advances the cell's
    // model version in it (`advance`). Places stay 1, 2, … ([`make_room`], [`close_gap`]).

    /// Renames a routine (`name`; `Some(None)`: no name) and/or moves it to place `position`
    /// of its program (1 = first, clamped to the last; the others keep their order), in one
    /// transaction and one revision of the program.
    pub async fn edit_routine(
        &self,
        id: i64,
        name: Option<Option<&str>>,
        position: Option<i64>,
    ) -> Result<()> {
        let mut tx = self.pool.begin().await?;
        let (cell_id, program_id, from, before): (i64, i64, i64, Option<String>) = sqlx::query_as(
            "SELECT cell_id, program_id, position, name FROM routines WHERE id = $1",
        )
        .bind(id)
        .fetch_optional(&mut *tx)
        .await?
        .ok_or(StorageError::NotFound)?;
        hold_cell(&mut tx, cell_id).await?;
        let mut changes = Vec::new();
        if let Some(name) = name {
            sqlx::query("UPDATE routines SET name = $1 WHERE id = $2")
                .bind(name)
                .bind(id)
                .execute(&mut *tx)
                .await
                .map_err(classify)?;
            if before.as_deref() != name {
                changes.push(Change::RoutineRenamed {
                    routine: id,
                    before,
                });
            }
        }
        if let Some(position) = position {
            let (count,): (i64,) =
                sqlx::query_as("SELECT COUNT(*) FROM routines WHERE program_id = $1")
                    .bind(program_id)
                    .fetch_one(&mut *tx)
                    .await?;
            let to = position.clamp(1, count.max(1));
            let was = history::routine_place(&mut tx, id).await?;
            // Out of the way (place 0), the others closed up, opened at `to`, then back in.
            sqlx::query("UPDATE routines SET position = 0 WHERE id = $1")
                .bind(id)
                .execute(&mut *tx)
                .await?;
            close_gap(&mut tx, Places::Routines, program_id, from).await?;
            make_room(&mut tx, Places::Routines, program_id, to).await?;
            sqlx::query("UPDATE routines SET position = $1 WHERE id = $2")
                .bind(to)
                .bind(id)
                .execute(&mut *tx)
                .await?;
            let now = history::routine_place(&mut tx, id).await?;
            if now != was {
                changes.push(Change::RoutineMoved {
                    routine: id,
                    from: was,
                    to: now,
                });
            }
        }
        history::record(&mut tx, program_id, &changes).await?;
        audit::record(&mut tx, None).await?;
        tx.commit().await?;
        Ok(())
    }

    /// Deletes a routine, finished or not, with its waypoints, predictions and feedback; the
    /// routines after it in its program move one place up. Returns the model version.
    pub async fn delete_routine(&self, id: i64, cell_id: i64, write: CellWrite) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, write).await?;
        let (_, removed) = history::removal(&mut tx, id).await?;
        let (program_id, position): (i64, i64) =
            sqlx::query_as("DELETE FROM routines WHERE id = $1 RETURNING program_id, position")
                .bind(id)
                .fetch_optional(&mut *tx)
                .await?
                .ok_or(StorageError::NotFound)?;
        close_gap(&mut tx, Places::Routines, program_id, position).await?;
        history::record(&mut tx, program_id, &[removed]).await?;
        tx.commit().await?;
        Ok(state.model_version)
    }
}
