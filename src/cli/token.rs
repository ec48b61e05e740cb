//! `nextpose token create|list|revoke`: bearer tokens with a role and a scope, written to the
//! database directly (like `nextpose backup`, no server needed; a running server sees them at
//! once). Thin over the application's token operations ([`crate::app::App::create_token`]);
//! what each role may do is `app::access`'s.

use std::sync::Arc;

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};

use crate::api::{NewToken, Role};
use crate::app::App;
use crate::app::robots::Robots;
use crate::storage::{Durability, Location, Store};
use crate::telemetry::Metrics;

#[derive(Debug, Args)]
pub struct TokenArgs {
    #[command(subcommand)]
    pub command: TokenCommand,
    /// The database: an SQLite file or a PostgreSQL URL.
    #[arg(
        long,
        env = "NEXTPOSE_DB",
        default_value = "nextpose.db",
        global = true
    )]
    pub db: String,
}

#[derive(Debug, Subcommand)]
pub enum TokenCommand {
    /// Create a token and print its secret (shown this once; only its hash is stored).
    Create {
        /// Who or what holds it (unique among unrevoked tokens).
        #[arg(long)]
        name: String,
        #[arg(long, value_enum)]
        role: RoleArg,
        /// A cell it is limited to (repeat for several); none: every cell.
        #[arg(long = "cell")]
        cells: Vec<i64>,
    },
    /// List the unrevoked tokens (never their secrets).
    List,
    /// Revoke the token of this name: from now on it is refused (401).
    Revoke { name: String },
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum RoleArg {
    Operator,
    Engineer,
    Admin,
}

impl From<RoleArg> for Role {
    fn from(r: RoleArg) -> Role {
        match r {
            RoleArg::Operator => Role::Operator,
            RoleArg::Engineer => Role::Engineer,
            RoleArg::Admin => Role::Admin,
        }
    }
}

pub(super) fn run_token(args: TokenArgs) -> Result<()> {
    let db = Location::parse(&args.db);
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async {
        let store = Store::connect(&db, Durability::Process)
            .await
            .with_context(|| format!("opening database {}", db.describe()))?;
        let app = App::new(
            store.clone(),
            Arc::new(Metrics::new()),
            Arc::new(Robots::default()),
        );
        let done = run_command(&app, args.command).await;
        store.close().await;
        done
    })
}

async fn run_command(app: &App, command: TokenCommand) -> Result<()> {
    match command {
        TokenCommand::Create { name, role, cells } => {
            let created = app
                .create_token(NewToken {
                    name,
                    role: role.into(),
                    cells: (!cells.is_empty()).then_some(cells),
                })
                .await?;
            eprintln!(
                "created token {:?} ({}, {}); its secret, shown this once:",
                created.token.name,
                created.token.role.as_str(),
                scope(&created.token.cells)
            );
            println!("{}", created.secret);
        }
        TokenCommand::List => {
            for t in app.tokens().await? {
                println!(
                    "{}\t{}\t{}\t{}",
                    t.name,
                    t.role.as_str(),
                    scope(&t.cells),
                    t.created_at
                );
            }
        }
        TokenCommand::Revoke { name } => {
            app.revoke_token(&name).await?;
            eprintln!("revoked token {name:?}");
        }
    }
    Ok(())
}

fn scope(cells: &Option<Vec<i64>>) -> String {
    match cells {
        None => "all cells".to_string(),
        Some(cells) if cells.is_empty() => "no cells".to_string(),
        Some(cells) => {
            let ids: Vec<String> = cells.iter().map(i64::to_string).collect();
            format!("cells {}", ids.join(","))
        }
    }
}
