//! Backups of the database while the service serves (`POST /v1/backups`, an admin operation).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// A backup to write into the server's backup directory (`--backup-dir`).
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct BackupRequest {
    /// The backup's file name in the server's backup directory: 1 to 128 letters, digits, `.`,
    /// `_` or `-`, not starting with `.` (no path: the server chooses where backups go). It
    /// must not exist there. Default: `nextpose-<UTC time>.db`, e.g.
    /// `nextpose-20261206T101500.123Z.db`.
    #[schema(
        pattern = r"^[A-Za-z0-9_-][A-Za-z0-9._-]{0,127}$",
        min_length = 1,
        max_length = 128
    )]
    pub name: Option<String>,
}

/// A backup written: a consistent copy of the database as it was when the backup started,
/// checked with SQLite's `PRAGMA integrity_check` before it got its name.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct Backup {
    /// Its file name in the backup directory.
    pub name: String,
    /// Where it is on the server's machine.
    pub path: String,
    /// Its size in bytes.
    pub bytes: u64,
    /// How long copying, checking and syncing it took (ms).
    pub took_ms: u64,
}
