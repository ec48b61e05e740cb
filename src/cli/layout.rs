//! `nextpose layout`: where to stand an arm so that it reaches the waypoints of program files
//! (corpus JSON or raw RAPID/KRL/FANUC files), by the layout search the service runs
//! (`POST /v1/robots/{name}/placements`), locally and without a server.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};

use crate::engine::Pose;
use crate::kinematics::layout::{BaseMounting, LayoutOptions, search_layout};
use crate::kinematics::{bundled_robot, load_robot};
use crate::replay::corpus::load_paths;

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MountingArg {
    Floor,
    Ceiling,
}

#[derive(Debug, Args)]
pub struct LayoutArgs {
    /// Program files or directories (corpus JSON, or raw .mod/.prg/.src/.dat/.ls files); the
    /// waypoints of all of them are placed together.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// The arm (a model of `robots/`, e.g. `abb_irb2600`).
    #[arg(long)]
    pub robot: String,
    /// Directory of robot models; default: the bundled ones the binary carries.
    #[arg(long)]
    pub robots: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "floor")]
    pub mounting: MountingArg,
    /// How many distinct placements to print, best first.
    #[arg(long, default_value_t = 3)]
    pub keep: usize,
    /// Seed of the search's random stage.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print the placements as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub(super) fn run_layout(args: &LayoutArgs) -> Result<()> {
    let robot = match &args.robots {
        Some(dir) => load_robot(dir, &args.robot)
            .with_context(|| format!("loading robot {} from {}", args.robot, dir.display()))?,
        None => bundled_robot(&args.robot)
            .with_context(|| format!("loading the bundled robot {}", args.robot))?,
    };
    let programs = load_paths(&args.files).context("reading the program files")?;
    let targets: Vec<Pose> = programs.iter().flat_map(|p| p.poses().copied()).collect();
    let options = LayoutOptions {
        mounting: match args.mounting {
            MountingArg::Floor => BaseMounting::Floor,
            MountingArg::Ceiling => BaseMounting::Ceiling,
        },
        keep: args.keep,
        seed: args.seed,
        ..LayoutOptions::default()
    };
    let found = search_layout(&robot, &targets, &options).context("layout search")?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&found)?);
        return Ok(());
    }
    println!(
        "{} waypoints of {} program(s), arm {}",
        targets.len(),
        programs.len(),
        args.robot
    );
    println!(
        "{:>4} {:>9} {:>9} {:>9} {:>7} {:>8} {:>11} {:>7}",
        "rank", "x mm", "y mm", "z mm", "yaw °", "reached", "margin °", "σ_min"
    );
    for (i, p) in found.iter().enumerate() {
        let v = p.base.values();
        let yaw = (2.0 * (v.qw * v.qz + v.qx * v.qy))
            .atan2(1.0 - 2.0 * (v.qy * v.qy + v.qz * v.qz))
            .to_degrees();
        let opt = |x: Option<f64>, f: fn(f64) -> String| x.map_or("-".to_string(), f);
        println!(
            "{:>4} {:>9.1} {:>9.1} {:>9.1} {:>7.1} {:>4}/{:<4} {:>10} {:>7}",
            i + 1,
            v.x,
            v.y,
            v.z,
            yaw,
            p.reached,
            p.total,
            opt(p.min_joint_margin_rad, |m| format!("{:.1}", m.to_degrees())),
            opt(p.min_sigma, |s| format!("{s:.3}")),
        );
    }
    Ok(())
}
