//! The reads every table makes the same way: its rows picked by ids ([`Store::find`],
//! [`Store::list`], or [`select`] inside a transaction), spelled once for each row type by
//! [`Stored`]; and the check that a write by id found its row ([`found`]).

use sqlx::any::AnyQueryResult;

use super::Store;
use super::error::{Result, StorageError};
use super::rows::Stored;

impl Store {
    /// The row of `R` that `tail` (`WHERE …`) picks, with `keys` bound as `$1, $2, …`.
    pub(super) async fn find<R: Stored>(&self, tail: &str, keys: &[i64]) -> Result<Option<R>> {
        Ok(select::<R>(tail, keys).fetch_optional(&self.pool).await?)
    }

    /// The rows of `R` that `tail` (`WHERE … ORDER BY …`) picks, with `keys` bound as `$1, $2, …`.
    pub(super) async fn list<R: Stored>(&self, tail: &str, keys: &[i64]) -> Result<Vec<R>> {
        Ok(select::<R>(tail, keys).fetch_all(&self.pool).await?)
    }
}

pub(super) type Select<R> = sqlx::query::QueryAs<'static, sqlx::Any, R, sqlx::any::AnyArguments>;

/// `SELECT` of `R` with `tail` and `keys` (see [`Store::find`]), to run in a transaction.
pub(super) fn select<R: Stored>(tail: &str, keys: &[i64]) -> Select<R> {
    let sql = format!("SELECT {} FROM {} {tail}", R::COLUMNS, R::FROM);
    keys.iter().fold(
        sqlx::query_as::<_, R>(sqlx::AssertSqlSafe(sql)),
        |q, key| q.bind(*key),
    )
}

/// A write by id that touched no row: there is no such row.
pub(super) fn found(done: AnyQueryResult) -> Result<()> {
    if done.rows_affected() == 0 {
        return Err(StorageError::NotFound);
    }
    Ok(())
}
