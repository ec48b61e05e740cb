//! The two database engines behind [`super::Store`]: where a `--db` setting points, how a pool
//! is opened on it (and how hard its commits try to reach the disk), its migrations, and the
//! little SQL that differs between them.
//!
//! Every query is written once, with `$1`-style parameters (SQLite reads them as numbered
//! parameters too), flags as 0/1 integers and `IS NOT DISTINCT FROM` for null-safe equality;
//! only the current-time expression differs ([`Backend::now`]).

use std::path::{Path, PathBuf};
use std::time::Duration;

use sqlx::AnyPool;
use sqlx::ConnectOptions;
use sqlx::any::{AnyConnectOptions, AnyPoolOptions};
use sqlx::sqlite::SqliteConnectOptions;

use super::error::{Result, StorageError};
use super::migrate;

/// Each dialect's schema, applied at start-up, every pending migration or none
/// ([`migrate`]).
static SQLITE_MIGRATIONS: sqlx::migrate::Migrator = sqlx::migrate!("./migrations/sqlite");
static POSTGRES_MIGRATIONS: sqlx::migrate::Migrator = sqlx::migrate!("./migrations/postgres");

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

/// Where the database lives, as `--db` / `NEXTPOSE_DB` give it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// An SQLite file (created when missing).
    File(PathBuf),
    /// An in-memory SQLite database, gone when the process ends (tests and demos).
    Memory,
    /// A PostgreSQL database (`postgres://` or `postgresql://` URL).
    Postgres(String),
}

impl Location {
    /// A setting: a `postgres://…` URL, `sqlite::memory:`, or an SQLite file path.
    pub fn parse(setting: &str) -> Location {
        if setting.starts_with("postgres://") || setting.starts_with("postgresql://") {
            Location::Postgres(setting.to_string())
        } else if setting == "sqlite::memory:" || setting == ":memory:" {
            Location::Memory
        } else {
            Location::File(PathBuf::from(
                setting
                    .strip_prefix("sqlite://")
                    .or_else(|| setting.strip_prefix("sqlite:"))
                    .unwrap_or(setting),
            ))
        }
    }

    /// For logs: the file, or the URL without its password.
    pub fn describe(&self) -> String {
        match self {
            Location::File(p) => p.display().to_string(),
            Location::Memory => "in memory".into(),
            Location::Postgres(url) => match url::Url::parse(url) {
                Ok(mut u) => {
                    if u.password().is_some() {
                        let _ = u.set_password(Some("***"));
                    }
                    u.to_string()
                }
                Err(_) => "postgres (unparsable URL)".into(),
            },
        }
    }
}

/// The engine of an open store.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    /// One process per file: the service is the only writer.
    Sqlite,
    /// Shared by any number of service instances.
    Postgres,
}

impl Backend {
    /// The current UTC time as stored (`2026-12-03T10:00:00.123Z`), as an SQL expression.
    pub fn now(self) -> &'static str {
        match self {
            Backend::Sqlite => "strftime('%Y-%m-%dT%H:%M:%fZ', 'now')",
            Backend::Postgres => {
                "to_char(clock_timestamp() AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"')"
            }
        }
    }

    /// Other processes may write the same database, so a cell's model in memory must be
    /// checked against it before it answers.
    pub fn shared(self) -> bool {
        self == Backend::Postgres
    }
}

/// Opens a pool on `location` and brings its schema up to date.
pub(super) async fn connect(
    location: &Location,
    durability: Durability,
) -> Result<(AnyPool, Backend)> {
    sqlx::any::install_default_drivers();
    match location {
        Location::File(path) => {
            let pool = sqlite_pool(sqlite_url(path), 8, durability).await?;
            migrate::run(&pool, &SQLITE_MIGRATIONS).await?;
            tokio::spawn(checkpoints(pool.clone()));
            Ok((pool, Backend::Sqlite))
        }
        Location::Memory => {
            // One connection: each `:memory:` connection is its own database.
            let pool = sqlite_pool("sqlite::memory:".into(), 1, durability).await?;
            migrate::run(&pool, &SQLITE_MIGRATIONS).await?;
            Ok((pool, Backend::Sqlite))
        }
        Location::Postgres(url) => {
            let options: AnyConnectOptions = url.parse()?;
            let pool = AnyPoolOptions::new()
                .max_connections(16)
                .min_connections(1)
                .acquire_timeout(Duration::from_secs(10))
                .connect_with(options.disable_statement_logging())
                .await?;
            migrate::run(&pool, &POSTGRES_MIGRATIONS).await?;
            Ok((pool, Backend::Postgres))
        }
    }
}

/// How often the WAL is copied back into the database file.
const CHECKPOINT_EVERY: Duration = Duration::from_millis(250);

/// Copies the WAL back into the database file from a connection of its own, beside the
/// writer (a passive checkpoint waits for no one and holds no one up), until the pool closes.
async fn checkpoints(pool: AnyPool) {
    let mut tick = tokio::time::interval(CHECKPOINT_EVERY);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tick.tick().await;
        if pool.is_closed() {
            return;
        }
        if let Err(e) = sqlx::query("PRAGMA wal_checkpoint(PASSIVE)")
            .execute(&pool)
            .await
        {
            if pool.is_closed() {
                return;
            }
            tracing::warn!(error = %e, "WAL checkpoint failed; trying again");
        }
    }
}

/// The URL of an SQLite file, created when missing (the path percent-encoded by sqlx).
fn sqlite_url(path: &Path) -> String {
    SqliteConnectOptions::new()
        .filename(path)
        .create_if_missing(true)
        .to_url_lossy()
        .to_string()
}

async fn sqlite_pool(url: String, max: u32, durability: Durability) -> Result<AnyPool> {
    let options: AnyConnectOptions = url.parse()?;
    let synchronous = match durability {
        Durability::Process => "PRAGMA synchronous = NORMAL",
        Durability::Full => "PRAGMA synchronous = FULL",
    };
    let pool = AnyPoolOptions::new()
        .max_connections(max)
        .min_connections(1)
        .after_connect(move |conn, _meta| {
            Box::pin(async move {
                // WAL: readers never wait for the writer; a committed transaction is in the
                // WAL, which survives the process being killed.
                // Checkpoints are not run by the committing connection (the appends' writer
                // would wait for the database file's fsync) but by `checkpoints`.
                for pragma in [
                    "PRAGMA journal_mode = WAL",
                    synchronous,
                    "PRAGMA foreign_keys = ON",
                    "PRAGMA busy_timeout = 5000",
                    "PRAGMA wal_autocheckpoint = 0",
                ] {
                    sqlx::query(pragma).execute(&mut *conn).await?;
                }
                Ok(())
            })
        })
        .connect_with(options.disable_statement_logging())
        .await
        .map_err(StorageError::Database)?;
    Ok(pool)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_name_the_engine() {
        assert_eq!(
            Location::parse("postgres://u:p@h/db"),
            Location::Postgres("postgres://u:p@h/db".into())
        );
        assert_eq!(
            Location::parse("postgresql://h/db"),
            Location::Postgres("postgresql://h/db".into())
        );
        assert_eq!(Location::parse("sqlite::memory:"), Location::Memory);
        assert_eq!(
            Location::parse("data/cell.db"),
            Location::File(PathBuf::from("data/cell.db"))
        );
        assert_eq!(
            Location::parse("sqlite://data/cell.db"),
            Location::File(PathBuf::from("data/cell.db"))
        );
    }

    #[test]
    fn a_password_is_not_logged() {
        let d = Location::parse("postgres://nextpose:secret@db:5432/site").describe();
        assert!(!d.contains("secret"), "{d}");
        assert!(d.contains("db:5432/site"), "{d}");
    }
}
