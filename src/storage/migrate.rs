//! Bringing a database's schema up to date at start-up: every pending migration or none.
//!
//! sqlx's migrator gives each pending migration a transaction of its own, so when the third
//! of three pending migrations fails the first two stay: the database is then at a version
//! that neither this release opens (its third migration fails again) nor the release it came
//! from (sqlx refuses a database with a migration it does not know). Here the pending
//! migrations run in one transaction with their bookkeeping rows, in sqlx's own table
//! (`_sqlx_migrations`, the same rows its migrator writes, so a database migrated either way
//! is the same): an upgrade that fails anywhere leaves the schema, its version and every row as
//! they were, and the error names the migration ([`StorageError::MigrationFailed`]).
//!
//! SQLite and PostgreSQL both take DDL in a transaction. A migration marked
//! `-- no-transaction` cannot share one (SQLite's 0004, which turns foreign keys off around
//! rebuilding its tables, something a transaction cannot do): it runs alone, through sqlx,
//! after the migrations before it have committed, so an upgrade across it is all or nothing
//! on either side of it only. On PostgreSQL the migrator's advisory lock is held throughout,
//! so instances starting together migrate one at a time.

use std::collections::{HashMap, HashSet};
use std::time::Instant;

use sqlx::migrate::{Migrate, MigrateError, Migration, Migrator};
use sqlx::{AnyConnection, AnyPool, Connection, Executor};

use super::error::{Result, StorageError};

/// sqlx's bookkeeping table.
const TABLE: &str = "_sqlx_migrations";

/// Applies `migrator`'s pending migrations to the database of `pool`, all or none.
pub(super) async fn run(pool: &AnyPool, migrator: &Migrator) -> Result<()> {
    let mut conn = pool.acquire().await?;
    conn.lock().await?;
    let applied = apply_pending(&mut conn, migrator).await;
    let unlocked = conn.unlock().await;
    applied?;
    unlocked?;
    Ok(())
}

async fn apply_pending(conn: &mut AnyConnection, migrator: &Migrator) -> Result<()> {
    conn.ensure_migrations_table(TABLE).await?;
    if let Some(version) = conn.dirty_version(TABLE).await? {
        return Err(MigrateError::Dirty(version).into());
    }
    let applied: HashMap<i64, Vec<u8>> = conn
        .list_applied_migrations(TABLE)
        .await?
        .into_iter()
        .map(|m| (m.version, m.checksum.into_owned()))
        .collect();
    // A database a later release migrated: this release does not know all it has.
    let known: HashSet<i64> = migrator.iter().map(|m| m.version).collect();
    if let Some(version) = applied.keys().filter(|v| !known.contains(v)).min() {
        return Err(MigrateError::VersionMissing(*version).into());
    }
    let mut pending = Vec::new();
    for m in migrator
        .iter()
        .filter(|m| m.migration_type.is_up_migration())
    {
        match applied.get(&m.version) {
            Some(checksum) if checksum.as_slice() != &*m.checksum => {
                return Err(MigrateError::VersionMismatch(m.version).into());
            }
            Some(_) => {}
            None => pending.push(m),
        }
    }

    let mut at = applied.keys().max().copied().unwrap_or(0);
    // Runs of migrations that take a transaction, each run in one; a `-- no-transaction`
    // migration alone.
    for run in pending.chunk_by(|a, b| !a.no_tx && !b.no_tx) {
        match run {
            [m] if m.no_tx => match conn.apply(TABLE, m).await {
                Ok(_) => {}
                Err(MigrateError::ExecuteMigration(error, _)) => return Err(failed(m, at, error)),
                Err(e) => return Err(e.into()),
            },
            _ => {
                let mut tx = conn.begin().await?;
                for m in run {
                    let started = Instant::now();
                    tx.execute(m.sql.clone())
                        .await
                        .map_err(|error| failed(m, at, error))?;
                    sqlx::query(
                        "INSERT INTO _sqlx_migrations \
                         (version, description, success, checksum, execution_time) \
                         VALUES ($1, $2, TRUE, $3, $4)",
                    )
                    .bind(m.version)
                    .bind(m.description.to_string())
                    .bind(m.checksum.to_vec())
                    .bind(i64::try_from(started.elapsed().as_nanos()).unwrap_or(i64::MAX))
                    .execute(&mut *tx)
                    .await?;
                }
                tx.commit().await?;
            }
        }
        if let Some(last) = run.last() {
            at = last.version;
        }
    }
    Ok(())
}

/// `m` failed; nothing of this upgrade from `at` on was kept.
fn failed(m: &Migration, at: i64, error: sqlx::Error) -> StorageError {
    StorageError::MigrationFailed {
        version: m.version,
        description: m.description.to_string(),
        at,
        error,
    }
}
