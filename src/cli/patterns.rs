//! `nextpose patterns OUT_DIR`: pallets, machine-tending trays and grids ([`crate::simulation::pattern`])
//! written as corpus JSON, one file per program, for `nextpose replay` and `nextpose simulate`
//! (issue 30's benchmark). `--set tuning` writes what an expert for patterns may be chosen on,
//! `--set held-out` the programs kept for checking it. A `pattern` object per file records how
//! the program was made; readers ignore it.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use serde_json::{Value, json};

use super::{first_json, routines_json, write_json};
use crate::simulation::pattern::{self, PatternProgram, PatternSet};

#[derive(Debug, Args)]
pub struct PatternsArgs {
    /// Directory to write the programs to (created if missing; must hold no *.json files).
    pub out_dir: PathBuf,
    /// Which programs: the tuning set, or the held-out set never looked at while tuning.
    #[arg(long, value_enum, default_value_t = SetArg::Tuning)]
    pub set: SetArg,
    /// Seed of the programs' placements on the table.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// [`PatternSet`] on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SetArg {
    Tuning,
    HeldOut,
}

impl From<SetArg> for PatternSet {
    fn from(s: SetArg) -> PatternSet {
        match s {
            SetArg::Tuning => PatternSet::Tuning,
            SetArg::HeldOut => PatternSet::HeldOut,
        }
    }
}

pub(super) fn run_patterns(args: &PatternsArgs) -> Result<()> {
    let dir = &args.out_dir;
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    if let Some(existing) = first_json(dir)? {
        bail!(
            "{}: already holds corpus files ({}); give an empty or new directory, so the \
             patterns are not mixed with other programs",
            dir.display(),
            existing.display()
        );
    }
    let set: PatternSet = args.set.into();
    let programs = pattern::generate(set, args.seed);
    for p in &programs {
        write_json(
            &dir.join(&p.program.source),
            &corpus_json(p, set, args.seed),
        )?;
    }
    let waypoints: usize = programs.iter().map(|p| p.program.waypoint_count()).sum();
    eprintln!(
        "wrote {} {} programs ({waypoints} waypoints, repository {}) to {}",
        programs.len(),
        set.name(),
        pattern::repository(set),
        dir.display()
    );
    Ok(())
}

/// One program in the corpus's JSON format.
fn corpus_json(p: &PatternProgram, set: PatternSet, seed: u64) -> Value {
    let s = &p.spec;
    let origin = p.placement.translation.vector;
    json!({
        "source": {
            "repo": pattern::repository(set),
            "path": p.program.source.display().to_string(),
            "generator": format!("nextpose patterns --set {} --seed {seed}", set.name()),
            "arm": p.program.arm.as_ref().map(|a| a.designation.clone()),
        },
        "language": p.program.language,
        "units": { "position": "mm", "orientation": "quaternion wxyz" },
        "routines": routines_json(&p.program),
        "stats": { "waypoints": p.program.waypoint_count(), "routines_total": p.program.routines.len() },
        "license": "generated",
        "pattern": {
            "job": s.job.name(),
            "counts": s.counts,
            "pitch_mm": s.pitch_mm,
            "layer_mm": s.layer_mm,
            "skew_deg": s.skew_rad.to_degrees(),
            "order": s.order.name(),
            "turn_layers": s.turn_layers,
            "routine_per_layer": s.routine_per_layer,
            "items": s.items,
            "placement": {
                "x": origin.x, "y": origin.y,
                "yaw_deg": p.placement.rotation.euler_angles().2.to_degrees(),
            },
        },
    })
}
