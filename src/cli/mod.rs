//! The `nextpose` command line: one module per command, each holding its arguments and a thin
//! `run` over the library.
//!
//! - `replay` / `sweep` ([`replay`]): the scoreboard of the engine and the baselines over
//!   corpus programs, and the engine over a grid of δ, φ_min and h.
//! - `serve` ([`serve`]): the service until SIGINT/SIGTERM.
//! - `backup` ([`backup`]): a consistent copy of an SQLite database, served or not.
//! - `import` ([`import`]): offline program files into a cell of a running server.
//! - `simulate` ([`simulate`]): simulated operators teaching corpus programs.
//! - `lab` ([`lab`]): the dissertation's online lab study as corpus JSON, for `simulate`.
//! - `patterns` ([`patterns`]): pallets, trays and grids as corpus JSON, a tuning and a
//!   held-out set.
//! - `layout` ([`layout`]): robot base placements for program files.
//! - `segment` ([`segment`]): recorded trajectories cut into LDSs and their attractors.
//! - `openapi`: the REST API's description.
//!
//! Engine settings ([`engine_args`]) start from a named profile; each flag overrides one
//! field, and the result is validated before anything runs, so a bad value is a one-line
//! error, not a panic.

mod backup;
mod engine_args;
mod export;
mod import;
mod lab;
mod layout;
mod patterns;
mod replay;
mod segment;
mod serve;
mod simulate;
mod token;

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use serde::Serialize;
use serde_json::{Value, json};

pub use backup::BackupArgs;
pub use engine_args::{EngineArgs, GateArg, Limit, MergeArg, ProfileArg, Switch};
pub use export::ExportArgs;
pub use import::ImportArgs;
pub use lab::LabArgs;
pub use layout::{LayoutArgs, MountingArg};
pub use patterns::{PatternsArgs, SetArg};
pub use replay::{ReplayArgs, SweepArgs};
pub use segment::{CriterionArg, SegmentArgs};
pub use serve::ServeArgs;
pub use simulate::{HistoryArg, OperatorArg, ReachPolicyArg, SimulateArgs, TransportArg};
pub use token::{RoleArg, TokenArgs, TokenCommand};

#[derive(Debug, Parser)]
#[command(
    name = "nextpose",
    version,
    about = "Teach-pendant next-waypoint prediction for industrial robot arms"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Replay corpus programs through the engine and the baselines; print the scoreboard.
    Replay(ReplayArgs),
    /// Replay the engine over a grid of delta, phi_min and horizon; print one line per setting.
    Sweep(SweepArgs),
    /// Run the service (REST API) until SIGINT/SIGTERM.
    Serve(ServeArgs),
    /// Write a consistent copy of an SQLite database to OUT, while a server may serve it.
    Backup(BackupArgs),
    /// Create, list or revoke bearer tokens with a role (operator, engineer, admin) and the
    /// cells they are limited to, in the database directly.
    Token(TokenArgs),
    /// Print the OpenAPI description of the REST API (YAML), as committed in openapi.yaml.
    Openapi,
    /// Import offline program files (RAPID, KRL, FANUC TP) into a cell of a running server.
    Import(ImportArgs),
    /// Export a stored program of a running server as controller files (RAPID, KRL, FANUC TP).
    Export(ExportArgs),
    /// Simulated operators teach corpus programs against the service; print the
    /// programming-time table (the shape of the seed's Table 4.1).
    Simulate(SimulateArgs),
    /// Search robot base placements that reach the waypoints of program files (locally).
    Layout(LayoutArgs),
    /// Write the seed's online lab (4 tasks, 3 users, 44 programs, joystick error) as corpus
    /// JSON files, for `simulate --history repository`.
    Lab(LabArgs),
    /// Write pallets, machine-tending trays and grids taught by hand (a tuning set, or the
    /// held-out set) as corpus JSON files, for `replay` and `simulate`.
    Patterns(PatternsArgs),
    /// Cut recorded TCP trajectories (CSV) into linear dynamical systems; their attractors are
    /// the waypoints hand-guided teaching would append (locally, no server).
    Segment(SegmentArgs),
}

/// Parses the process arguments and runs the command.
pub fn run() -> Result<()> {
    run_cli(Cli::parse())
}

/// Runs a parsed command line (separate from [`run`] so tests can drive it).
pub fn run_cli(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Replay(args) => replay::run_replay(&args),
        Command::Sweep(args) => replay::run_sweep(&args),
        Command::Serve(args) => serve::run_serve(args),
        Command::Backup(args) => backup::run_backup(&args),
        Command::Token(args) => token::run_token(args),
        Command::Import(args) => import::run_import(args),
        Command::Export(args) => export::run_export(args),
        Command::Simulate(args) => simulate::run_simulate(&args),
        Command::Lab(args) => lab::run_lab(&args),
        Command::Patterns(args) => patterns::run_patterns(&args),
        Command::Layout(args) => layout::run_layout(&args),
        Command::Segment(args) => segment::run_segment(&args),
        Command::Openapi => {
            let yaml = crate::http::openapi()
                .to_yaml()
                .context("rendering the OpenAPI description")?;
            print!("{yaml}");
            Ok(())
        }
    }
}

pub(crate) fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let file = File::create(path).with_context(|| format!("{}: cannot create", path.display()))?;
    let mut w = BufWriter::new(file);
    serde_json::to_writer_pretty(&mut w, value)
        .with_context(|| format!("{}: cannot write JSON", path.display()))?;
    writeln!(w)
        .and_then(|()| w.flush())
        .with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(())
}

/// The first `*.json` file in `dir`, if any (the commands that write corpus files refuse a
/// directory that already holds some).
pub(crate) fn first_json(dir: &Path) -> Result<Option<PathBuf>> {
    for entry in
        std::fs::read_dir(dir).with_context(|| format!("{}: cannot read", dir.display()))?
    {
        let path = entry
            .with_context(|| format!("{}: cannot read", dir.display()))?
            .path();
        if path.is_file()
            && path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        {
            return Ok(Some(path));
        }
    }
    Ok(None)
}

/// A program's routines in the corpus's JSON format (`name`, `kind`, `waypoints[]` with
/// `x y z qw qx qy qz` and the motion: the first `MoveJ`, the others `MoveL`).
pub(crate) fn routines_json(program: &crate::program::Program) -> Vec<Value> {
    program
        .routines
        .iter()
        .map(|r| {
            let waypoints: Vec<Value> = r
                .waypoints
                .iter()
                .enumerate()
                .map(|(i, w)| {
                    let v = w.values();
                    json!({
                        "name": format!("p{}", 10 * (i + 1)),
                        "x": v.x, "y": v.y, "z": v.z,
                        "qw": v.qw, "qx": v.qx, "qy": v.qy, "qz": v.qz,
                        "motion": if i == 0 { "MoveJ" } else { "MoveL" },
                    })
                })
                .collect();
            json!({ "name": r.name, "kind": "PROC", "waypoints": waypoints })
        })
        .collect()
}
