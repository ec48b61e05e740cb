//! Backups: a backup asked for (a file name, or none) and the backup written.

use crate::api::{Backup, BackupRequest};

use super::wire::both_ways;

both_ways!(plain BackupRequest => CreateBackupRequest { name });
both_ways!(plain Backup => Backup { name, path, bytes, took_ms });
