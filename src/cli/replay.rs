//! `nextpose replay` and `nextpose sweep`: the scoreboard of the engine and the baselines
//! over corpus programs, and the engine over a grid of settings.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;

use super::engine_args::EngineArgs;
use super::write_json;
use crate::engine::EngineConfig;
use crate::replay::Method;
use crate::replay::load_paths;
use crate::replay::methods::baselines::DEFAULT_NEAREST_SEQ_GATE;
use crate::replay::methods::map::{MapMethod, MapSettings, comparison as map_comparison};
use crate::replay::placements::PlacementCache;
#[cfg(feature = "plots")]
use crate::replay::plots::{PlotGrid, plot_data, write_plots};
use crate::replay::report::scoreboard_with;
use crate::replay::sweep::{sweep, sweep_table};

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// Corpus JSON files or raw program files (RAPID, KRL, FANUC TP; all raw files named are one
    /// upload), or directories of them (all *.json sorted by name; else the raw files as one
    /// upload; else each subdirectory in turn).
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    #[command(flatten)]
    pub engine: EngineArgs,
    /// Gate of the gated nearest-sequence baselines: mean squared Mahalanobis distance per
    /// window move.
    #[arg(long, default_value_t = DEFAULT_NEAREST_SEQ_GATE)]
    pub gate: f64,
    /// Also write the full report (every program, every method) as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Print only the totals table (no per-program table).
    #[arg(long)]
    pub quiet: bool,
    /// Where the programs' arm placements are kept between runs (the search is most of a
    /// replay's time; an entry's key holds everything it depends on, so none goes stale).
    /// Default: $XDG_CACHE_HOME/nextpose/placements, else ~/.cache/nextpose/placements.
    #[arg(long, value_name = "DIR", conflicts_with = "no_placement_cache")]
    pub placement_cache: Option<PathBuf>,
    /// Search every program's arm placement afresh and keep none.
    #[arg(long)]
    pub no_placement_cache: bool,
    /// Also run `map`, the seed's MAP structure-estimation baseline (best-first state merging,
    /// predicting like the engine at the run's settings), and print its comparison with the
    /// engine by confidence threshold (seed Figure 4.14; use with --profile seed). Off by
    /// default: it replays the engine and `map` once more (about a minute in release).
    #[arg(long)]
    pub map: bool,
    /// With --map: also write the comparison as JSON to this file.
    #[arg(long, value_name = "OUT.json", requires = "map")]
    pub map_json: Option<PathBuf>,
    /// Also write the plots (offered/useful % vs phi_min, median error vs delta, median error
    /// vs moves assimilated, confidence vs error, reliability of p_useful, precision vs offered
    /// share as the p_useful threshold moves) into this directory, each as PNG and SVG, with
    /// the plotted numbers in plots.json.
    /// The two sweeps replay the engine 31 more times.
    #[cfg(feature = "plots")]
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Corpus JSON files or raw program files (RAPID, KRL, FANUC TP; all raw files named are one
    /// upload), or directories of them (all *.json sorted by name; else the raw files as one
    /// upload; else each subdirectory in turn).
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    /// Base engine settings; --delta, --phi-min and --horizon are replaced by the grid.
    #[command(flatten)]
    pub engine: EngineArgs,
    #[arg(long, value_delimiter = ',', default_value = "0.3,0.5,0.7,0.9")]
    pub deltas: Vec<f64>,
    #[arg(long, value_delimiter = ',', default_value = "0.5,0.7,0.9")]
    pub phi_mins: Vec<f64>,
    #[arg(long, value_delimiter = ',', default_value = "1,2,3,4")]
    pub horizons: Vec<usize>,
    /// Also write the rows as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
}

/// The placement cache directory the arguments ask for (none with `--no-placement-cache`).
fn placement_cache(args: &ReplayArgs) -> Option<PathBuf> {
    if args.no_placement_cache {
        return None;
    }
    args.placement_cache
        .clone()
        .or_else(PlacementCache::user_dir)
}

pub(super) fn run_replay(args: &ReplayArgs) -> Result<()> {
    let config = args.engine.config()?;
    if !(args.gate.is_finite() && args.gate >= 0.0) {
        bail!("--gate must be finite and non-negative, got {}", args.gate);
    }
    let programs = load_paths(&args.paths)?;
    let extra: Vec<Box<dyn Method>> = if args.map {
        vec![Box::new(MapMethod::new(
            config.clone(),
            MapSettings::default(),
        )?)]
    } else {
        Vec::new()
    };
    let cache = placement_cache(args);
    let report = scoreboard_with(
        &programs,
        args.engine.profile_name(),
        &config,
        args.gate,
        extra,
        cache.clone(),
    )?;

    if let (Some(used), Some(dir)) = (report.placements, cache) {
        eprintln!(
            "arm placements: {} from the cache in {}, {} searched{}",
            used.hits,
            dir.display(),
            used.searched,
            match used.unwritten {
                0 => String::new(),
                n => format!(" ({n} could not be written there)"),
            }
        );
    }
    let mut out = std::io::stdout().lock();
    if !args.quiet {
        writeln!(out, "{}", report.program_table("engine"))?;
        if let Some(arms) = report.arm_table() {
            writeln!(out, "{arms}")?;
        }
    }
    write!(out, "{}", report.totals_table())?;
    if let Some(path) = &args.json {
        write_json(path, &report)?;
    }
    if args.map {
        let comparison = map_comparison::compare(
            &programs,
            args.engine.profile_name(),
            &config,
            &map_comparison::PHI_GRID,
        )?;
        write!(out, "\n{}", comparison.table())?;
        if let Some(path) = &args.map_json {
            write_json(path, &comparison)?;
        }
    }
    #[cfg(feature = "plots")]
    if let Some(dir) = &args.plots {
        let data = plot_data(
            &programs,
            args.engine.profile_name(),
            &config,
            &PlotGrid::default(),
        )
        .context("invalid plot sweep settings")?;
        let written = write_plots(dir, &data)?;
        writeln!(
            out,
            "wrote {} plot files to {}",
            written.len(),
            dir.display()
        )?;
    }
    Ok(())
}

/// The sweep's JSON file: the base settings and one row per combination.
#[derive(Serialize)]
struct SweepReport<'a> {
    profile: &'a str,
    base: &'a EngineConfig,
    rows: &'a [crate::replay::SweepRow],
}

pub(super) fn run_sweep(args: &SweepArgs) -> Result<()> {
    let base = args.engine.config()?;
    for (name, empty) in [
        ("--deltas", args.deltas.is_empty()),
        ("--phi-mins", args.phi_mins.is_empty()),
        ("--horizons", args.horizons.is_empty()),
    ] {
        if empty {
            bail!("{name} needs at least one value");
        }
    }
    let programs = load_paths(&args.paths)?;
    let rows = sweep(
        &programs,
        &base,
        &args.deltas,
        &args.phi_mins,
        &args.horizons,
    )
    .context("invalid sweep settings")?;
    write!(std::io::stdout().lock(), "{}", sweep_table(&rows))?;
    if let Some(path) = &args.json {
        let report = SweepReport {
            profile: args.engine.profile_name(),
            base: &base,
            rows: &rows,
        };
        write_json(path, &report)?;
    }
    Ok(())
}
