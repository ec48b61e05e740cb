//! `nextpose patterns` (issue 30's benchmark, `simulation::pattern`): both sets are written as corpus
//! JSON that `load_paths` reads back exactly, with their repository, arm and routines; a
//! directory that already holds corpus files is refused and left as it was. Everything is
//! written to temporary directories.

use clap::Parser;
use nextpose::cli::{Cli, run_cli};
use nextpose::replay::load_paths;
use nextpose::simulation::pattern::{self, PatternSet};

fn write(dir: &std::path::Path, set: &str) -> anyhow::Result<()> {
    let cli = Cli::try_parse_from([
        "nextpose",
        "patterns",
        dir.to_str().unwrap(),
        "--set",
        set,
        "--seed",
        "4",
    ])
    .expect("arguments");
    run_cli(cli)
}

#[test]
fn both_pattern_sets_round_trip_through_load_paths() {
    for (arg, set) in [
        ("tuning", PatternSet::Tuning),
        ("held-out", PatternSet::HeldOut),
    ] {
        let dir = tempfile::tempdir().expect("temporary directory");
        write(dir.path(), arg).expect("nextpose patterns");
        let loaded = load_paths(&[dir.path()]).expect("the set loads as a corpus directory");
        let generated = pattern::generate(set, 4);
        assert_eq!(loaded.len(), generated.len());
        for (l, g) in loaded.iter().zip(&generated) {
            let g = &g.program;
            assert_eq!(l.name, g.name);
            assert_eq!(l.repo.as_deref(), Some(pattern::repository(set).as_str()));
            assert_eq!(
                l.arm.as_ref().map(|a| a.designation.as_str()),
                Some(pattern::PATTERN_ARM)
            );
            assert_eq!(l.routines.len(), g.routines.len());
            assert_eq!(l.waypoint_count(), g.waypoint_count());
            for (a, b) in l.poses().zip(g.poses()) {
                assert!(a.distance_to(b) < 1e-9 && a.angle_to(b) < 1e-9);
            }
        }

        // Writing again into the same directory is refused, and nothing is added or changed.
        let before: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        let err = write(dir.path(), arg).expect_err("refused").to_string();
        assert!(err.contains("already holds corpus files"), "{err}");
        let after: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert_eq!(before.len(), after.len());
    }
}

/// The lattice walk (`engine::experts::lattice`, read by the lattice expert) follows every layer of
/// the tuning set's pallets, grids and tray: from its slot points alone, once the second row
/// has a point (the three corners settle the order: the tuning set's lattices are square),
/// each next slot is predicted to within 1e-6 mm.
#[test]
fn the_lattice_walk_follows_every_layer_of_the_tuning_set() {
    use nalgebra::Vector3;
    use nextpose::engine::experts::lattice::LatticeWalk;
    use nextpose::simulation::pattern::Job;
    for p in pattern::generate(PatternSet::Tuning, 4) {
        let per = p.spec.job.waypoints_per_item();
        // The slot's pose within an item: the place, the touch, the raw tray's pick.
        let slot = match p.spec.job {
            Job::Palletise => 4,
            Job::Grid | Job::Tending => 1,
        };
        let mut layers: Vec<Vec<Vector3<f64>>> = Vec::new();
        for r in &p.program.routines {
            let items = (r.waypoints.len() - 2) / per;
            for m in 0..items {
                let at = r.waypoints[1 + m * per + slot].position();
                match layers.last_mut() {
                    Some(l) if (l[0].z - at.z).abs() < 1e-6 => l.push(at),
                    _ => layers.push(vec![at]),
                }
            }
        }
        assert_eq!(layers.len(), p.spec.counts[2], "{}", p.program.name);
        let mut predicted = 0;
        for layer in &layers {
            assert!(LatticeWalk::fit(layer, 1.0).is_some(), "a layer is a walk");
            for k in 3..layer.len() {
                let fit = LatticeWalk::fit(&layer[..k], 1.0);
                let w = fit.unwrap_or_else(|| panic!("{}: no walk through {k}", p.program.name));
                if w.rows.is_some() {
                    let err = (w.next() - layer[k]).norm();
                    assert!(err < 1e-6, "{} after {k}: {err} mm", p.program.name);
                    predicted += 1;
                }
            }
        }
        assert!(predicted > 0, "{}", p.program.name);
    }
}
