//! Backups while serving (an admin operation): a consistent copy of the SQLite database written
//! into the server's backup directory while every other request goes on
//! ([`crate::storage::backup_database`] is the same copy for `nextpose backup`).
//!
//! **Where.** A client names a file, never a path: a client-given path on the server's machine
//! could overwrite or fill anything the service may write. Backups go into one directory the
//! operator chose (`--backup-dir`), by default `backups/` beside the SQLite file, created
//! (mode 0700: a backup holds everything) on first use. A name is 1–128 letters, digits, `.`,
//! `_` or `-`, not starting with `.` (so no `..`, no hidden file, and never the temporary
//! `.NAME.XXXXXX.partial` a backup is written under); none given, one is made from the time.
//! An existing file is never replaced (409).
//!
//! **One at a time.** Backups are serialised: each reads the whole database, and two at once
//! would only share the disk. Each runs to completion on a task of its own
//! ([`App::to_completion`]), so a client that hangs up does not leave a copy half-written, and
//! shutdown waits for it.

use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime};

use super::error::AppError;
use super::{App, Result};
use crate::api::{Backup, BackupRequest};

/// Longest backup file name.
pub const MAX_BACKUP_NAME: usize = 128;

/// Where backups go and the lock that takes them one at a time.
#[derive(Debug, Default)]
pub(super) struct Backups {
    /// `--backup-dir`; `None`: `backups/` beside the SQLite file.
    dir: Option<PathBuf>,
    one_at_a_time: tokio::sync::Mutex<()>,
}

impl Backups {
    pub(super) fn new(dir: Option<PathBuf>) -> Backups {
        Backups {
            dir,
            one_at_a_time: tokio::sync::Mutex::new(()),
        }
    }
}

/// A backup's file name as a client may give it (see the module's documentation).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BackupName(String);

impl BackupName {
    pub fn parse(name: &str) -> Result<BackupName> {
        let allowed = |c: char| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-');
        let fits = !name.is_empty()
            && name.len() <= MAX_BACKUP_NAME
            && !name.starts_with('.')
            && name.chars().all(allowed);
        if !fits {
            return Err(AppError::Invalid(format!(
                "backup name {name:?}: a file name of 1 to {MAX_BACKUP_NAME} letters, digits, '.', \
                 '_' or '-', not starting with '.' (backups are written into the server's backup \
                 directory; a path cannot be given)"
            )));
        }
        Ok(BackupName(name.to_string()))
    }

    /// `nextpose-<UTC time>.db`, e.g. `nextpose-20261206T101500.123Z.db`.
    fn at(time: SystemTime) -> BackupName {
        BackupName(format!("nextpose-{}.db", utc_stamp(time)))
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl App {
    /// Sets where [`App::backup`] writes (`--backup-dir`); `None`: `backups/` beside the
    /// SQLite file.
    pub fn with_backup_dir(mut self, dir: Option<PathBuf>) -> App {
        self.backups = std::sync::Arc::new(Backups::new(dir));
        self
    }

    /// The directory backups are written into (absolute, so that answers and logs say where),
    /// if the database is an SQLite file or one was set.
    pub fn backup_dir(&self) -> Option<PathBuf> {
        let dir = match &self.backups.dir {
            Some(dir) => dir.clone(),
            None => {
                let file = self.store.file()?;
                let beside = file.parent().filter(|p| !p.as_os_str().is_empty());
                beside.unwrap_or(Path::new(".")).join("backups")
            }
        };
        Some(std::path::absolute(&dir).unwrap_or(dir))
    }

    /// Writes a consistent copy of the database into the backup directory (an admin
    /// operation; see the module's documentation).
    pub async fn backup(&self, request: BackupRequest) -> Result<Backup> {
        let name = match request.name {
            Some(name) => BackupName::parse(&name)?,
            None => BackupName::at(SystemTime::now()),
        };
        self.store.can_back_up()?;
        let dir = self.backup_dir().ok_or_else(|| {
            AppError::Internal("an SQLite database without a file or backup directory".into())
        })?;
        self.to_completion(move |app| async move {
            let _one = app.backups.one_at_a_time.lock().await;
            create_private_dir(&dir).await?;
            let started = Instant::now();
            let written = app.store.backup_to(&dir.join(name.as_str())).await?;
            let took_ms = u64::try_from(started.elapsed().as_millis()).unwrap_or(u64::MAX);
            tracing::info!(path = %written.path.display(), bytes = written.bytes, took_ms, "backup written");
            // A backup changes no table, but who took one belongs in the audit trail.
            app.store.audit_alone().await?;
            Ok(Backup {
                name: name.0,
                path: written.path.display().to_string(),
                bytes: written.bytes,
                took_ms,
            })
        })
        .await
    }
}

/// Creates `dir` and its parents when missing, the last one readable by its owner only.
async fn create_private_dir(dir: &Path) -> Result<()> {
    let dir = dir.to_path_buf();
    let created = tokio::task::spawn_blocking(move || {
        let mut builder = std::fs::DirBuilder::new();
        builder.recursive(true);
        #[cfg(unix)]
        std::os::unix::fs::DirBuilderExt::mode(&mut builder, 0o700);
        builder
            .create(&dir)
            .map_err(|e| AppError::Internal(format!("cannot create {}: {e}", dir.display())))
    })
    .await;
    created.map_err(|e| AppError::Internal(format!("creating the backup directory: {e}")))?
}

/// `time` in UTC as `YYYYMMDDTHHMMSS.mmmZ` (ISO 8601's basic format: no `:` in a file name).
fn utc_stamp(time: SystemTime) -> String {
    const BASIC: &[time::format_description::BorrowedFormatItem<'_>] = time::macros::format_description!(
        "[year][month][day]T[hour][minute][second].[subsecond digits:3]Z"
    );
    time::OffsetDateTime::from(time)
        .format(BASIC)
        .unwrap_or_else(|_| "unknown-time".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn stamps_are_utc_in_basic_format() {
        let at = |ms: u64| utc_stamp(SystemTime::UNIX_EPOCH + Duration::from_millis(ms));
        assert_eq!(at(0), "19700101T000000.000Z");
        assert_eq!(at(1_733_480_100_123), "20241206T101500.123Z");
        assert_eq!(at(951_782_400_000), "20000229T000000.000Z");
        assert_eq!(at(4_102_444_799_999), "20991231T235959.999Z");
        let name = BackupName::at(SystemTime::UNIX_EPOCH);
        assert_eq!(name.as_str(), "nextpose-19700101T000000.000Z.db");
        assert!(BackupName::parse(name.as_str()).is_ok());
    }

    #[test]
    fn names_are_file_names_only() {
        for good in [
            "nightly.db",
            "a",
            "2026-12-06_cell-3.sqlite",
            "x..y",
            "-",
            "_",
        ] {
            assert!(BackupName::parse(good).is_ok(), "{good}");
        }
        let long = "a".repeat(MAX_BACKUP_NAME + 1);
        for bad in [
            "",
            ".",
            "..",
            ".hidden",
            "../x.db",
            "a/b.db",
            "/etc/passwd",
            "a\\b",
            "a b",
            "é.db",
            "a\n",
            "a\0",
            long.as_str(),
        ] {
            assert!(
                matches!(BackupName::parse(bad), Err(AppError::Invalid(_))),
                "{bad:?}"
            );
        }
        assert!(BackupName::parse(&"a".repeat(MAX_BACKUP_NAME)).is_ok());
    }
}
