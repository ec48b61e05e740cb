//! The `programs` table: a cell's named programs, each an ordered list of routines; and an
//! import, which stores whole programs with their routines and waypoints at once.

use sqlx::any::{Any, AnyArguments};
use sqlx::query::QueryAs;

use super::Store;
use super::audit;
use super::cell_write::CellWrite;
use super::error::{Result, StorageError, classify};
use super::history::{self, Change};
use super::query::found;
use super::rows::{CellState, NewImportedRoutine, ProgramRow, Stored, flag};
use super::transaction::{insert_waypoints, touch_cell};

/// `INSERT` of a program, answering with its row (alone or in an import's transaction).
fn insert<'q>(cell_id: i64, name: &'q str) -> QueryAs<'q, Any, ProgramRow, AnyArguments> {
    let sql = format!(
        "INSERT INTO programs (cell_id, name) VALUES ($1, $2) RETURNING {}",
        ProgramRow::COLUMNS
    );
    sqlx::query_as::<_, ProgramRow>(sqlx::AssertSqlSafe(sql))
        .bind(cell_id)
        .bind(name)
}

impl Store {
    pub async fn insert_program(&self, cell_id: i64, name: &str) -> Result<ProgramRow> {
        let mut tx = self.pool.begin().await?;
        let row = insert(cell_id, name)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        audit::record(&mut tx, Some(cell_id)).await?;
        tx.commit().await?;
        Ok(row)
    }

    pub async fn program(&self, id: i64) -> Result<Option<ProgramRow>> {
        self.find("WHERE id = $1", &[id]).await
    }

    pub async fn programs(&self, cell_id: i64) -> Result<Vec<ProgramRow>> {
        self.list("WHERE cell_id = $1 ORDER BY id", &[cell_id])
            .await
    }

    pub async fn rename_program(&self, id: i64, name: &str) -> Result<ProgramRow> {
        let sql = format!(
            "UPDATE programs SET name = $1 WHERE id = $2 RETURNING {}",
            ProgramRow::COLUMNS
        );
        let mut tx = self.pool.begin().await?;
        let row = sqlx::query_as::<_, ProgramRow>(sqlx::AssertSqlSafe(sql))
            .bind(name)
            .bind(id)
            .fetch_optional(&mut *tx)
            .await
            .map_err(classify)?
            .ok_or(StorageError::NotFound)?;
        audit::record(&mut tx, Some(row.cell_id)).await?;
        tx.commit().await?;
        Ok(row)
    }

    /// Deletes a program with its routines; returns the model version (advanced when a
    /// learned routine went with it).
    pub async fn delete_program(&self, id: i64, cell_id: i64, write: CellWrite) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, write).await?;
        found(
            sqlx::query("DELETE FROM programs WHERE id = $1")
                .bind(id)
                .execute(&mut *tx)
                .await?,
        )?;
        tx.commit().await?;
        Ok(state.model_version)
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
            let program = insert(cell_id, name)
                .fetch_one(&mut *tx)
                .await
                .map_err(classify)?;
            let mut ids = Vec::with_capacity(routines.len());
            let mut changes = Vec::with_capacity(routines.len());
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
                changes.push(Change::RoutineAdded {
                    routine: id,
                    position: position as i64 + 1,
                    waypoints: r.waypoints.len() as i64,
                });
            }
            history::record(&mut tx, program.id, &changes).await?;
            out.push((program, ids));
        }
        tx.commit().await?;
        Ok((out, state, last_finish))
    }
}
