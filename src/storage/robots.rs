//! The `robots` table: arm models uploaded through the API (URDF and what the maker says of
//! it), beside the built-in ones, by name.

use super::Store;
use super::audit;
use super::error::{Result, classify};
use super::query::found;
use super::rows::{RobotRow, Stored, real};

impl Store {
    /// Stores an uploaded arm model; a name already taken is a
    /// [`super::StorageError::Conflict`].
    pub async fn insert_robot(
        &self,
        name: &str,
        urdf: &str,
        maker: Option<&str>,
        product: Option<&str>,
        payload_kg: Option<f64>,
    ) -> Result<RobotRow> {
        let sql = format!(
            "INSERT INTO robots (name, urdf, maker, product, payload_kg) \
             VALUES ($1, $2, $3, $4, $5) RETURNING {}",
            RobotRow::COLUMNS
        );
        let mut tx = self.pool.begin().await?;
        let row = sqlx::query_as::<_, RobotRow>(sqlx::AssertSqlSafe(sql))
            .bind(name)
            .bind(urdf)
            .bind(maker)
            .bind(product)
            .bind(real(payload_kg))
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        audit::record(&mut tx, None).await?;
        tx.commit().await?;
        Ok(row)
    }

    /// The uploaded arm models, by name.
    pub async fn robots(&self) -> Result<Vec<RobotRow>> {
        self.list("ORDER BY name", &[]).await
    }

    /// Deletes an uploaded arm model.
    pub async fn delete_robot(&self, name: &str) -> Result<()> {
        let mut tx = self.pool.begin().await?;
        found(
            sqlx::query("DELETE FROM robots WHERE name = $1")
                .bind(name)
                .execute(&mut *tx)
                .await?,
        )?;
        audit::record(&mut tx, None).await?;
        tx.commit().await?;
        Ok(())
    }
}
