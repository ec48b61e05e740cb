//! The counts behind `engine::experts::calibration::PRIOR` and `CHOSEN_PRIOR`: the programs given are
//! taught through the engine (default profile), each in a fresh cell, and the outcomes of every
//! candidate are summed per coarse class of evidence, and those of the chosen candidates per
//! band of their first-stage estimate. Printed as the Rust tables the engine holds.
//!
//! The two stages are measured in two passes: `CHOSEN_PRIOR` is counted with the engine's own
//! `PRIOR`, so refit `PRIOR` first, build, and run again for `CHOSEN_PRIOR`.
//!
//! `cargo run --release --example calibration_prior -- FILES…` (docs/results/scoreboard.md,
//! "The offer threshold by halves", says which half of the shared corpus the engine's table was
//! measured on). The lattice expert's rows (`lattice: true`) of `LATTICE_PRIOR` are counted the
//! same way on the pattern tuning set (`nextpose patterns DIR --set tuning`).

use std::collections::BTreeMap;

use nextpose::engine::experts::calibration::{BANDS, Count};
use nextpose::engine::{EngineConfig, Teacher};
use nextpose::replay::load_paths;

fn main() -> anyhow::Result<()> {
    let paths: Vec<std::path::PathBuf> = std::env::args().skip(1).map(Into::into).collect();
    let programs = load_paths(&paths)?;
    let mut total: BTreeMap<_, Count> = BTreeMap::new();
    let mut chosen = [Count::default(); BANDS.len()];
    for p in &programs {
        let mut t = Teacher::new(EngineConfig::default())?;
        for r in &p.routines {
            for w in &r.waypoints {
                t.teach(*w);
            }
            t.finish_routine();
        }
        for (k, c) in t.calibration().coarse_counts() {
            let e = total.entry(k).or_default();
            e.n += c.n;
            e.useful += c.useful;
        }
        for (sum, c) in chosen.iter_mut().zip(t.calibration().chosen_counts()) {
            sum.n += c.n;
            sum.useful += c.useful;
        }
    }
    println!("// {} programs", programs.len());
    println!("pub const PRIOR: &[(Coarse, u32, u32)] = &[");
    for (k, c) in total {
        println!(
            "    (Coarse {{ model: {}, template: {}, lattice: {}, station: {}, follower: {}, agree: {}, in_routine: {}, long_context: {}, several_places: {} }}, {}, {}),",
            k.model,
            k.template,
            k.lattice,
            k.station,
            k.follower,
            k.agree,
            k.in_routine,
            k.long_context,
            k.several_places,
            c.n,
            c.useful
        );
    }
    println!("];");
    println!("pub const CHOSEN_PRIOR: [(u32, u32); {}] = [", BANDS.len());
    for c in chosen {
        println!("    ({}, {}),", c.n, c.useful);
    }
    println!("];");
    Ok(())
}
