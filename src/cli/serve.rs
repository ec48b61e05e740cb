//! `nextpose serve`: the service on one SQLite file until SIGINT/SIGTERM.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The database: an SQLite file (created when missing), or a PostgreSQL URL
    /// (`postgres://user:password@host:5432/name`) that several instances may share.
    #[arg(long, env = "NEXTPOSE_DB", default_value = "nextpose.db")]
    pub db: String,
    /// Address to listen on.
    #[arg(long, env = "NEXTPOSE_ADDR", default_value = "127.0.0.1:8080")]
    pub addr: String,
    /// Bearer token required on every route but /healthz and the pendant page (unset: no authentication).
    #[arg(long, env = "NEXTPOSE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// fsync every commit, so acknowledged writes survive a power loss too (slower). Without
    /// it they survive a crash or kill of the process.
    #[arg(long, env = "NEXTPOSE_SYNC_FULL")]
    pub sync_full: bool,
    /// Largest request body accepted, in bytes.
    #[arg(long, default_value_t = 2 * 1024 * 1024)]
    pub body_limit: usize,
    /// Requests taking longer than this many seconds are answered 408.
    #[arg(long, default_value_t = 30)]
    pub request_timeout_s: u64,
    /// A directory of robot models (*.urdf, and its catalog.json) to add to the bundled ones the
    /// binary carries, or to override them by name.
    #[arg(long, env = "NEXTPOSE_ROBOTS")]
    pub robots: Option<PathBuf>,
    /// Directory POST /v1/backups writes into (created when missing); default: backups/
    /// beside the SQLite file.
    #[arg(long, env = "NEXTPOSE_BACKUP_DIR")]
    pub backup_dir: Option<PathBuf>,
}

pub(super) fn run_serve(args: ServeArgs) -> Result<()> {
    use crate::server::{Application, Database, ServerSettings, shutdown_signal};
    use crate::storage::Durability;
    use std::io::Write;

    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info,sqlx=warn".into()),
        )
        .init();
    let database = Database::parse(&args.db);
    let settings = ServerSettings {
        database: database.clone(),
        durability: if args.sync_full {
            Durability::Full
        } else {
            Durability::Process
        },
        addr: args.addr.clone(),
        http: crate::transport::TransportOptions {
            body_limit: args.body_limit,
            request_timeout: std::time::Duration::from_secs(args.request_timeout_s.max(1)),
            token: args.token.clone(),
        },
        robots: args.robots.clone(),
        backup_dir: args.backup_dir.clone(),
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async move {
        let application = Application::build(settings).await?;
        let addr = application.local_addr()?;
        // Tests and scripts read this line to find the port.
        println!(
            "nextpose listening on http://{addr} (database {})",
            database.describe()
        );
        std::io::stdout().flush().ok();
        tracing::info!(%addr, db = %database.describe(), "serving");
        application.run_until_stopped(shutdown_signal()).await?;
        Ok(())
    })
}
