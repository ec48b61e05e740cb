//! `nextpose patterns` (issue 30's benchmark, `sim::pattern`): both sets are written as corpus
//! JSON that `load_paths` reads back exactly, with their repository, arm and routines; a
//! directory that already holds corpus files is refused and left as it was. Everything is
//! written to temporary directories.

use clap::Parser;
use nextpose::cli::{Cli, run_cli};
use nextpose::replay::load_paths;
use nextpose::sim::pattern::{self, PatternSet};

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
