//! Backups of an SQLite database while it serves: a consistent copy written beside the live
//! file, never a half-written one under the backup's name, and never over an existing file.
//!
//! SQLite's `VACUUM INTO` reads the database in one read transaction, so the copy is the
//! database as it was at one commit: every write committed before it started and none that
//! committed after. In WAL mode a reader holds up no writer, so the service keeps answering
//! while it runs (the passive checkpoints cannot move past the reader's snapshot until it
//! ends; the WAL grows for that long and is copied back afterwards).
//!
//! The copy is written to a temporary file beside `OUT` (`.OUT.XXXXXX.partial`), checked with
//! `PRAGMA integrity_check` on a read-only connection, synced to disk, and only then given
//! `OUT`'s name by a rename that refuses to replace a file (and the directory synced). A
//! failure removes the temporary file; a process killed meanwhile leaves it behind (with
//! SQLite's `-journal` of it if killed while SQLite wrote; their names say what they are),
//! never a file named `OUT`. The live database is only read.
//!
//! PostgreSQL databases are not copied here: `pg_dump` does it (docs/deployment.md says how).

use std::future::Future;
use std::path::{Path, PathBuf};

use sqlx::Connection;
use sqlx::sqlite::{SqliteConnectOptions, SqliteConnection};

use super::Store;
use super::backend::Location;

/// A backup written: where, and how large.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BackupFile {
    pub path: PathBuf,
    pub bytes: u64,
}

/// Why a backup was not written. Nothing is left under the backup's name in any case.
#[derive(Debug, thiserror::Error)]
pub enum BackupError {
    /// A backup never replaces a file.
    #[error("{} exists already: a backup never overwrites a file", .0.display())]
    Exists(PathBuf),
    /// PostgreSQL has its own tool for consistent copies.
    #[error(
        "the database is PostgreSQL: back it up with pg_dump (docs/deployment.md, \"Backup and \
         restore\"); this service copies SQLite files only"
    )]
    Postgres,
    /// Nothing outlives the process, so there is nothing to copy.
    #[error("the database is in memory: there is no file to back up")]
    InMemory,
    /// The database to back up does not exist (a backup never creates one).
    #[error("no database file at {}", .0.display())]
    NoDatabase(PathBuf),
    /// A path SQLite cannot be given (not UTF-8) or that names no file.
    #[error("{}: not a path a backup can be written to (a UTF-8 file name is needed)", .0.display())]
    BadPath(PathBuf),
    /// The copy SQLite wrote does not pass its integrity check (it is removed).
    #[error("the copy failed its integrity check: {0}")]
    Corrupt(String),
    /// The file system refused (a missing or read-only directory, a full disk).
    #[error("{what} {}", path.display())]
    Io {
        what: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// SQLite failed to read the database or write the copy.
    #[error("copying the database failed")]
    Database(#[source] sqlx::Error),
}

type Result<T> = std::result::Result<T, BackupError>;

fn io(what: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> BackupError {
    let path = path.to_path_buf();
    move |source| BackupError::Io { what, path, source }
}

impl Store {
    /// The SQLite file this store serves, if it is one.
    pub fn file(&self) -> Option<&Path> {
        match &*self.location {
            Location::File(path) => Some(path),
            Location::Memory | Location::Postgres(_) => None,
        }
    }

    /// Whether [`Store::backup_to`] can copy this database: an SQLite file, not PostgreSQL
    /// or memory.
    pub fn can_back_up(&self) -> Result<()> {
        match &*self.location {
            Location::Postgres(_) => Err(BackupError::Postgres),
            Location::Memory => Err(BackupError::InMemory),
            Location::File(_) => Ok(()),
        }
    }

    /// Writes a consistent copy of the database to `out` (which must not exist) while the
    /// store goes on serving; see the module's documentation. SQLite files only.
    pub async fn backup_to(&self, out: &Path) -> Result<BackupFile> {
        self.can_back_up()?;
        write_copy(out, async |temp| {
            sqlx::query("VACUUM INTO $1")
                .bind(temp)
                .execute(&self.pool)
                .await
                .map(drop)
        })
        .await
    }
}

/// Writes a consistent copy of the SQLite database `db` to `out` (which must not exist), from a
/// read-only connection of its own: a server may be serving the file meanwhile. A PostgreSQL
/// URL or an in-memory database is refused as [`Store::backup_to`] refuses it.
pub async fn backup_database(db: &Location, out: &Path) -> Result<BackupFile> {
    let path = match db {
        Location::Postgres(_) => return Err(BackupError::Postgres),
        Location::Memory => return Err(BackupError::InMemory),
        Location::File(path) => path,
    };
    if !path.is_file() {
        return Err(BackupError::NoDatabase(path.clone()));
    }
    let options = SqliteConnectOptions::new()
        .filename(path)
        .read_only(true)
        .busy_timeout(std::time::Duration::from_secs(5));
    let mut source = SqliteConnection::connect_with(&options)
        .await
        .map_err(BackupError::Database)?;
    let written = write_copy(out, async |temp| {
        sqlx::query("VACUUM INTO $1")
            .bind(temp)
            .execute(&mut source)
            .await
            .map(drop)
    })
    .await;
    source.close().await.ok();
    written
}

/// The steps every backup takes around SQLite's `vacuum_into` of a temporary file beside `out`
/// (see the module's documentation).
async fn write_copy<F>(out: &Path, vacuum_into: impl FnOnce(String) -> F) -> Result<BackupFile>
where
    F: Future<Output = std::result::Result<(), sqlx::Error>>,
{
    let (dir, name) = match (out.parent(), out.file_name().and_then(|n| n.to_str())) {
        (Some(dir), Some(name)) if out.to_str().is_some() => (dir, name),
        _ => return Err(BackupError::BadPath(out.to_path_buf())),
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    // Checked again, atomically, by the rename at the end; this spares a copy made in vain.
    if out.symlink_metadata().is_ok() {
        return Err(BackupError::Exists(out.to_path_buf()));
    }
    // An empty file of our own (mode 0600): SQLite writes the copy into it.
    let temp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".partial")
        .tempfile_in(dir)
        .map_err(io("cannot create a temporary file in", dir))?;
    let temp_name = temp
        .path()
        .to_str()
        .ok_or_else(|| BackupError::BadPath(temp.path().to_path_buf()))?
        .to_string();
    vacuum_into(temp_name)
        .await
        .map_err(BackupError::Database)?;
    check_integrity(temp.path()).await?;
    let (out, dir) = (out.to_path_buf(), dir.to_path_buf());
    let target = out.clone();
    tokio::task::spawn_blocking(move || {
        temp.as_file()
            .sync_all()
            .map_err(io("cannot sync", temp.path()))?;
        let bytes = temp
            .as_file()
            .metadata()
            .map_err(io("cannot read the size of", temp.path()))?
            .len();
        temp.persist_noclobber(&out).map_err(|e| {
            if e.error.kind() == std::io::ErrorKind::AlreadyExists {
                BackupError::Exists(out.clone())
            } else {
                io("cannot rename the copy to", &out)(e.error)
            }
        })?;
        // The new name is durable once the directory is.
        std::fs::File::open(&dir)
            .and_then(|d| d.sync_all())
            .map_err(io("cannot sync the directory", &dir))?;
        Ok(BackupFile { path: out, bytes })
    })
    .await
    .map_err(|e| io("the task naming the copy failed for", &target)(std::io::Error::other(e)))?
}

/// `PRAGMA integrity_check` of the copy at `path`, opened read-only (and immutable: nothing
/// else has it open, so SQLite needs no lock or side file).
async fn check_integrity(path: &Path) -> Result<()> {
    let options = SqliteConnectOptions::new()
        .filename(path)
        .read_only(true)
        .immutable(true);
    let mut conn = SqliteConnection::connect_with(&options)
        .await
        .map_err(BackupError::Database)?;
    let found: Vec<(String,)> = sqlx::query_as("PRAGMA integrity_check")
        .fetch_all(&mut conn)
        .await
        .map_err(BackupError::Database)?;
    conn.close().await.ok();
    let found: Vec<String> = found.into_iter().map(|(line,)| line).collect();
    if found != ["ok"] {
        return Err(BackupError::Corrupt(found.join("; ")));
    }
    Ok(())
}
