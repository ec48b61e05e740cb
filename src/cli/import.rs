//! `nextpose import`: offline program files (RAPID, KRL, FANUC TP) into a cell of a running
//! server, through the typed REST client.

use std::path::PathBuf;

use crate::api::{CreateCell, ImportRequest, UploadedFile};
use anyhow::{Context, Result};
use clap::Args;

#[derive(Debug, Args)]
pub struct ImportArgs {
    /// Program files of one upload (parsed together).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Name of the cell (created with default settings when it does not exist).
    #[arg(long)]
    pub cell: String,
    /// Store the programs without learning them into the cell's model.
    #[arg(long)]
    pub no_learn: bool,
    /// The server.
    #[arg(long, env = "NEXTPOSE_URL", default_value = "http://127.0.0.1:8080")]
    pub server: String,
    /// Bearer token, when the server requires one.
    #[arg(long, env = "NEXTPOSE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
}

pub(super) fn run_import(args: ImportArgs) -> Result<()> {
    use crate::client::RestClient;

    let mut files = Vec::with_capacity(args.files.len());
    for path in &args.files {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        files.push(UploadedFile {
            name: path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            content: crate::import::decode_text(&bytes),
        });
    }
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async move {
        let client = RestClient::new(&args.server, args.token.clone());
        let cells = client.list_cells().await?;
        let cell = match cells.iter().find(|c| c.name == args.cell) {
            Some(c) => c.id,
            None => {
                let create = CreateCell {
                    name: args.cell.clone(),
                    settings: Default::default(),
                };
                client.create_cell(&create).await?.id
            }
        };
        let request = ImportRequest {
            files,
            learn: Some(!args.no_learn),
        };
        let result = client.import(cell, &request).await?;
        for p in &result.programs {
            println!(
                "imported {} ({}): {} routines, {} waypoints",
                p.program.name, p.language, p.routines, p.waypoints
            );
        }
        for s in &result.skipped {
            println!("skipped {}:{} ({}): {}", s.file, s.line, s.reason, s.text);
        }
        println!(
            "cell {:?}: {} skipped; model now {} states, {} routines",
            args.cell,
            result.skipped.len(),
            result.model.states,
            result.model.routines
        );
        Ok(())
    })
}
