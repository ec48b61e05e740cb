//! `nextpose export`: a stored program of a running server as controller files (RAPID, KRL,
//! FANUC TP), through the typed REST client.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The program's id.
    pub program: i64,
    /// `rapid`, `krl` or `fanuc`.
    #[arg(long)]
    pub format: String,
    /// Directory to write the files into (created if missing; FANUC files go into a folder
    /// named after the program). Without it, the files are printed.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The server.
    #[arg(long, env = "NEXTPOSE_URL", default_value = "http://127.0.0.1:8080")]
    pub server: String,
    /// Bearer token, when the server requires one.
    #[arg(long, env = "NEXTPOSE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
}

pub(super) fn run_export(args: ExportArgs) -> Result<()> {
    use crate::client::RestClient;

    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let exported = runtime.block_on(async {
        RestClient::new(&args.server, args.token.clone())
            .export(args.program, &args.format)
            .await
    })?;
    for f in &exported.files {
        match &args.out {
            Some(dir) => {
                let path = dir.join(&f.file_name);
                // The server names files; refuse anything that would leave the directory.
                if f.file_name
                    .split('/')
                    .any(|part| part == ".." || part.is_empty())
                {
                    bail!("refusing the file name {:?}", f.file_name);
                }
                if let Some(parent) = path.parent() {
                    std::fs::create_dir_all(parent)
                        .with_context(|| format!("creating {}", parent.display()))?;
                }
                std::fs::write(&path, &f.text)
                    .with_context(|| format!("writing {}", path.display()))?;
                println!("wrote {}", path.display());
            }
            None => {
                println!("// ---- {} ----", f.file_name);
                print!("{}", f.text);
            }
        }
    }
    for w in &exported.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}
