//! The `tokens` table and the cells a token is limited to (`token_cells`): bearer tokens by the
//! SHA-256 of their secret, which is all that is kept of it (the policy is `app::access`).

use super::Store;
use super::audit;
use super::error::{Result, StorageError, classify};
use super::query::found;
use super::rows::{Stored, TokenRow, flag};

impl Store {
    /// Stores a token: `cells` None for every cell, else the cells it is limited to. A name
    /// that an unrevoked token has, or a secret already stored, is a
    /// [`StorageError::Conflict`]; a cell that does not exist [`StorageError::NotFound`].
    pub async fn insert_token(
        &self,
        name: &str,
        role: &str,
        secret_sha256: &str,
        cells: Option<&[i64]>,
    ) -> Result<TokenRow> {
        let mut tx = self.pool.begin().await?;
        let sql = format!(
            "INSERT INTO tokens (name, role, secret_sha256, all_cells) VALUES ($1, $2, $3, $4) \
             RETURNING {}",
            TokenRow::COLUMNS
        );
        let row = sqlx::query_as::<_, TokenRow>(sqlx::AssertSqlSafe(sql))
            .bind(name)
            .bind(role)
            .bind(secret_sha256)
            .bind(flag(cells.is_none()))
            .fetch_one(&mut *tx)
            .await
            .map_err(classify)?;
        for cell in cells.unwrap_or_default() {
            sqlx::query(
                "INSERT INTO token_cells (token_id, cell_id) VALUES ($1, $2) ON CONFLICT DO NOTHING",
            )
            .bind(row.id)
            .bind(*cell)
            .execute(&mut *tx)
            .await
            .map_err(missing_cell)?;
        }
        audit::record(&mut tx, None).await?;
        tx.commit().await?;
        Ok(row)
    }

    /// The unrevoked token whose secret has this hash.
    pub async fn token_by_hash(&self, secret_sha256: &str) -> Result<Option<TokenRow>> {
        let sql = format!(
            "SELECT {} FROM {} WHERE secret_sha256 = $1 AND revoked_at IS NULL",
            TokenRow::COLUMNS,
            TokenRow::FROM
        );
        Ok(sqlx::query_as::<_, TokenRow>(sqlx::AssertSqlSafe(sql))
            .bind(secret_sha256)
            .fetch_optional(&self.pool)
            .await?)
    }

    /// The unrevoked tokens, by name.
    pub async fn tokens(&self) -> Result<Vec<TokenRow>> {
        self.list("WHERE revoked_at IS NULL ORDER BY name", &[])
            .await
    }

    /// Whether any unrevoked token exists (without one, and without a bootstrap token, the
    /// service does not authenticate).
    pub async fn any_token(&self) -> Result<bool> {
        let rows: Vec<TokenRow> = self.list("WHERE revoked_at IS NULL LIMIT 1", &[]).await?;
        Ok(!rows.is_empty())
    }

    /// The cells a token is limited to, in id order.
    pub async fn token_cells(&self, token_id: i64) -> Result<Vec<i64>> {
        let rows: Vec<(i64,)> =
            sqlx::query_as("SELECT cell_id FROM token_cells WHERE token_id = $1 ORDER BY cell_id")
                .bind(token_id)
                .fetch_all(&self.pool)
                .await?;
        Ok(rows.into_iter().map(|(c,)| c).collect())
    }

    /// Revokes the unrevoked token of this name.
    pub async fn revoke_token(&self, name: &str) -> Result<()> {
        let sql = format!(
            "UPDATE tokens SET revoked_at = {} WHERE name = $1 AND revoked_at IS NULL",
            self.backend.now()
        );
        let mut tx = self.pool.begin().await?;
        found(
            sqlx::query(sqlx::AssertSqlSafe(sql))
                .bind(name)
                .execute(&mut *tx)
                .await?,
        )?;
        audit::record(&mut tx, None).await?;
        tx.commit().await?;
        Ok(())
    }
}

/// A scope naming a cell that does not exist.
fn missing_cell(e: sqlx::Error) -> StorageError {
    if let sqlx::Error::Database(db) = &e
        && db.is_foreign_key_violation()
    {
        return StorageError::NotFound;
    }
    classify(e)
}
