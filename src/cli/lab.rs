//! `nextpose lab OUT_DIR`: the dissertation's online lab ([`crate::simulation::lab`]) written as
//! corpus JSON, one file per program, in the shared corpus's format (`source.repo`, `language`,
//! `routines[].waypoints[]` with `x y z qw qx qy qz`), so `load_paths` and `simulate` read it like
//! any corpus directory. File names sort in program order. A `lab` object per file records how the
//! program was made (user, and per routine the task, size and placement; the error); readers ignore
//! it. `source.generator` is the command that writes the same file again.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use serde_json::{Value, json};

use super::{first_json, routines_json, write_json};
use crate::simulation::lab::{self, LAB_REPO, LabConfig, LabProgram};

#[derive(Debug, Args)]
pub struct LabArgs {
    /// Directory to write the programs to (created if missing; must hold no *.json files).
    pub out_dir: PathBuf,
    /// Seed of the placements and the users' errors.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of programs (the seed's lab: 44).
    #[arg(long, default_value_t = 44)]
    pub programs: usize,
    /// Number of users taking turns (the seed's lab: 3).
    #[arg(long, default_value_t = 3)]
    pub users: usize,
    /// The tasks taught: the seed's four (dodecagram, pentagram, pipe seam, box seam); four
    /// variants (pick and place, pocket, stitches, grid) to check settings on tasks they were
    /// not chosen on; or a welding cell's parts (bracket, flange, gusset, frame; home at start
    /// and end, sizes 0.8–1.25), a synthetic welding-like set for the replay.
    #[arg(long, value_enum, default_value_t = RepertoireArg::Seed)]
    pub repertoire: RepertoireArg,
}

/// [`lab::Repertoire`] on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RepertoireArg {
    Seed,
    Variants,
    Welding,
}

impl From<RepertoireArg> for lab::Repertoire {
    fn from(r: RepertoireArg) -> lab::Repertoire {
        match r {
            RepertoireArg::Seed => lab::Repertoire::Dissertation,
            RepertoireArg::Variants => lab::Repertoire::Variants,
            RepertoireArg::Welding => lab::Repertoire::Welding,
        }
    }
}

pub(super) fn run_lab(args: &LabArgs) -> Result<()> {
    if args.programs == 0 {
        bail!("--programs must be at least 1");
    }
    if args.users == 0 {
        bail!("--users must be at least 1");
    }
    let dir = &args.out_dir;
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    if let Some(existing) = first_json(dir)? {
        bail!(
            "{}: already holds corpus files ({}); give an empty or new directory, so the lab \
             is not mixed with other programs",
            dir.display(),
            existing.display()
        );
    }
    let config = LabConfig {
        programs: args.programs,
        users: args.users,
        repertoire: args.repertoire.into(),
        ..LabConfig::default()
    };
    let programs = lab::generate(&config, args.seed);
    for p in &programs {
        let path = dir.join(&p.program.source);
        write_json(&path, &corpus_json(p, &config, args))?;
    }
    let waypoints: usize = programs.iter().map(|p| p.program.waypoint_count()).sum();
    eprintln!(
        "wrote {} programs ({waypoints} waypoints, {} users, repository {LAB_REPO}) to {}",
        programs.len(),
        config.users,
        dir.display()
    );
    Ok(())
}

/// One program in the corpus's JSON format.
fn corpus_json(p: &LabProgram, config: &LabConfig, args: &LabArgs) -> Value {
    let repertoire = args
        .repertoire
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_owned());
    let routines = routines_json(&p.program);
    let parts: Vec<Value> = p
        .routines
        .iter()
        .map(|r| {
            let origin = lab::placement_origin(&r.placement);
            let yaw = r.placement.rotation.euler_angles().2;
            json!({
                "task": r.task.name(),
                "size": r.size,
                "placement": { "x": origin.x, "y": origin.y, "z": origin.z, "yaw_deg": yaw.to_degrees() },
            })
        })
        .collect();
    json!({
        "source": {
            "repo": LAB_REPO,
            "path": format!("user{}/{}", p.user + 1, p.program.source.display()),
            "generator": format!(
                "nextpose lab --seed {} --programs {} --users {} --repertoire {repertoire}",
                args.seed, config.programs, config.users
            ),
            "arm": p.program.arm.as_ref().map(|a| a.designation.clone()),
        },
        "language": p.program.language,
        "units": { "position": "mm", "orientation": "quaternion wxyz" },
        "routines": routines,
        "stats": { "waypoints": p.program.waypoint_count(), "routines_total": p.program.routines.len() },
        "license": "generated",
        "lab": {
            "user": p.user + 1,
            "routines": parts,
            "position_rms_mm": config.position_rms_mm,
            "rotation_rms_rad": config.rotation_rms_rad,
        },
    })
}
