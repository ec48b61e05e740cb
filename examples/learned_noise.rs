//! What a zero-configuration cell learns of its operator from each program given: the programs
//! are taught through the engine (default profile), each in a fresh cell, and the noise,
//! tolerance and offer threshold it ends with are printed, with the routine after which the
//! noise first mattered (widened a tolerance; `VERBOSE=1` prints the noise after each routine).
//!
//! `cargo run --release --example learned_noise -- FILES…` (docs/engine.md, "Teaching noise").

use nextpose::engine::{EngineConfig, Teacher};
use nextpose::replay::load_paths;

fn main() -> anyhow::Result<()> {
    let paths: Vec<std::path::PathBuf> = std::env::args().skip(1).map(Into::into).collect();
    let programs = load_paths(&paths)?;
    println!(
        "{:<60} {:>8} {:>10} {:>9} {:>10} {:>10} {:>9}",
        "program", "routines", "noise mm", "rad", "tol mm", "threshold", "noisy at"
    );
    for p in &programs {
        let mut t = Teacher::new(EngineConfig::default())?;
        let mut noisy_at = None;
        for (i, r) in p.routines.iter().enumerate() {
            for w in &r.waypoints {
                t.teach(*w);
            }
            t.finish_routine();
            if std::env::var_os("VERBOSE").is_some() {
                eprintln!("  after routine {}: {:?}", i + 1, t.noise());
            }
            if noisy_at.is_none() && !t.noise().is_negligible(&t.tolerance()) {
                noisy_at = Some(i + 1);
            }
        }
        let n = t.noise();
        let name: String = p.name.chars().take(60).collect();
        println!(
            "{:<60} {:>8} {:>10.4} {:>9.5} {:>10.2} {:>10.2} {:>9}",
            name,
            p.routines.len(),
            n.mm,
            n.rad,
            t.tolerance().mm,
            t.threshold().unwrap_or(f64::NAN),
            noisy_at.map_or("-".to_string(), |i| i.to_string())
        );
    }
    Ok(())
}
