//! `nextpose backup OUT`: a consistent copy of an SQLite database file, taken from a read-only
//! connection of its own, so a server may go on serving the file meanwhile (the same copy as
//! `POST /v1/backups`: [`crate::storage::backup_database`]).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;

use crate::storage::{Location, backup_database};

#[derive(Debug, Args)]
pub struct BackupArgs {
    /// The file to write: it must not exist (a backup never overwrites), its directory must.
    pub out: PathBuf,
    /// The database to back up: an SQLite file (a PostgreSQL URL is refused: use pg_dump).
    #[arg(long, env = "NEXTPOSE_DB", default_value = "nextpose.db")]
    pub db: String,
}

pub(super) fn run_backup(args: &BackupArgs) -> Result<()> {
    let db = Location::parse(&args.db);
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let started = Instant::now();
    let written = runtime
        .block_on(backup_database(&db, &args.out))
        .with_context(|| format!("backing up {}", db.describe()))?;
    println!(
        "wrote {} ({} bytes, integrity check ok) from {} in {} ms",
        written.path.display(),
        written.bytes,
        db.describe(),
        started.elapsed().as_millis()
    );
    Ok(())
}
