//! The `cells` table: a robot cell with its settings, and the counters every write to it
//! advances (see [`super::CellWrite`]).

use super::Store;
use super::audit;
use super::error::{Result, StorageError, classify};
use super::query::found;
use super::rows::{CellRow, CellState, Stored};

impl Store {
    pub async fn insert_cell(&self, name: &str, settings_json: &str) -> Result<CellRow> {
        let sql = format!(
            "INSERT INTO cells (name, settings) VALUES ($1, $2) RETURNING {}",
            CellRow::COLUMNS
        );
        let mut tx = self.pool.begin().await?;
        let row = sqlx::query_as::<_, CellRow>(sqlx::AssertSqlSafe(sql))
            .bind(name)
            .bind(settings_json)
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        audit::record(&mut tx, Some(row.id)).await?;
        tx.commit().await?;
        Ok(row)
    }

    pub async fn cell(&self, id: i64) -> Result<Option<CellRow>> {
        self.find("WHERE id = $1", &[id]).await
    }

    pub async fn cells(&self) -> Result<Vec<CellRow>> {
        self.list("ORDER BY id", &[]).await
    }

    /// Where a cell's writes stand (None: no such cell).
    pub async fn cell_state(&self, cell_id: i64) -> Result<Option<CellState>> {
        self.find("WHERE id = $1", &[cell_id]).await
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
             RETURNING {}",
            self.backend.now(),
            CellRow::COLUMNS
        );
        let row = sqlx::query_as::<_, CellRow>(sqlx::AssertSqlSafe(sql))
            .bind(name)
            .bind(settings_json)
            .bind(id)
            .fetch_optional(&mut *tx)
            .await
            .map_err(classify)?
            .ok_or(StorageError::NotFound)?;
        audit::record(&mut tx, Some(id)).await?;
        tx.commit().await?;
        Ok(row)
    }

    /// Deletes a cell with everything it holds.
    pub async fn delete_cell(&self, id: i64) -> Result<()> {
        let mut tx = self.pool.begin().await?;
        found(
            sqlx::query("DELETE FROM cells WHERE id = $1")
                .bind(id)
                .execute(&mut *tx)
                .await?,
        )?;
        audit::record(&mut tx, Some(id)).await?;
        tx.commit().await?;
        Ok(())
    }
}
