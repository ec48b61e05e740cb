//! `map`, the seed's MAP structure-estimation baseline, through the replay harness: it runs
//! like any method, reports its model, predicts a repeated routine, and the Figure 4.14
//! comparison is computed from it.

use nalgebra::{Unit, UnitQuaternion, Vector3};
use nextpose::engine::{EngineConfig, Pose, Profile};
use nextpose::replay::methods::EngineMethod;
use nextpose::replay::methods::map::MapMethod;
use nextpose::replay::methods::map::MapSettings;
use nextpose::replay::methods::map::comparison::{PHI_GRID, compare};
use nextpose::replay::report::RunConfig;
use nextpose::replay::{Method, Program, load_paths, replay_all, replay_program};

use crate::corpus;

fn pose(p: [f64; 3], axis: [f64; 3], angle: f64) -> Pose {
    let q = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::from(axis)), angle);
    Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
}

/// An irregular routine of 9 waypoints (8 distinct moves), shifted by `dx`.
fn routine(dx: f64) -> Vec<Pose> {
    (0..9)
        .map(|i| {
            let t = f64::from(i);
            pose(
                [
                    dx + 37.0 * t + t * t,
                    11.0 * (t * 1.3).sin() * 10.0,
                    5.0 * t * t,
                ],
                [0.2 + t * 0.1, 1.0, 0.3 * t],
                0.1 * t,
            )
        })
        .collect()
}

fn dissertation() -> EngineConfig {
    EngineConfig::profile(Profile::Dissertation)
}

fn map() -> MapMethod {
    MapMethod::new(dissertation(), MapSettings::default()).unwrap()
}

#[test]
fn map_learns_a_repeated_routine_as_one_chain_and_predicts_it() {
    // The same routine taught three times at different places: the moves are the same.
    let program = Program::of_routines(
        "repeat",
        vec![routine(0.0), routine(500.0), routine(-300.0)],
    );
    let mut m = map();
    let record = replay_program(&program, &mut m);
    let s = record.summary.expect("map reports its model");
    assert_eq!(s.observations, 24);
    assert_eq!((s.states, s.edges), (8, 7), "one state per distinct move");
    assert!((s.perplexity - 7.0 / 8.0).abs() < 1e-12);
    assert!(m.learner().merges() > 0);
    // Nothing is known while the first copy is taught; the later copies are predicted exactly.
    let first = record.waypoints.iter().filter(|w| w.routine == 0);
    assert!(first.clone().all(|w| !w.offered));
    let later: Vec<_> = record
        .waypoints
        .iter()
        .filter(|w| w.routine > 0 && w.predecessors >= 2)
        .collect();
    assert!(!later.is_empty());
    assert!(later.iter().all(|w| w.useful()), "{later:?}");
    // reset: a new program starts from an empty model.
    m.reset();
    assert_eq!(m.summary().map(|s| s.states), Some(0));
}

#[test]
fn map_is_a_scoreboard_method_and_its_comparison_is_computed() {
    let program = Program::of_routines("repeat", vec![routine(0.0), routine(250.0), routine(0.0)]);
    let programs = vec![program];
    let config = dissertation();
    let mut methods: Vec<Box<dyn Method>> = vec![
        Box::new(EngineMethod::new(config.clone()).unwrap()),
        Box::new(map()),
    ];
    let mut run = RunConfig::new("seed", config.clone(), 1.0);
    run.reachability = None;
    let report = replay_all(&programs, &mut methods, run).unwrap();
    let totals = report.totals.get("map").expect("map in the report");
    assert_eq!(totals.states, Some(8));
    assert_eq!(totals.n2.useful, 14, "routines 2 and 3, waypoints 2..8");

    let c = compare(&programs, "seed", &config, &PHI_GRID).unwrap();
    assert_eq!(c.groups.len(), 1, "no repositories named: the corpus only");
    let names: Vec<&str> = c.groups[0]
        .methods
        .iter()
        .map(|m| m.method.as_str())
        .collect();
    assert_eq!(names, ["engine", "map"]);
    for m in &c.groups[0].methods {
        assert_eq!(m.thresholds.len(), PHI_GRID.len());
        // A higher threshold never offers more.
        for w in m.thresholds.windows(2) {
            assert!(w[1].offered <= w[0].offered);
        }
    }
    let map_line = &c.groups[0].methods[1];
    assert_eq!(map_line.states_mean, Some(8.0));
    assert!(c.table().contains("map"));
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn map_runs_on_a_corpus_program() {
    let file = corpus::json().join("jvalta__Robottijarjestelmaprojekti__Module1.mod.json");
    let programs = load_paths(&[file]).expect("corpus file loads");
    let record = replay_program(&programs[0], &mut map());
    let s = record.summary.expect("summary");
    assert!(s.observations > 0);
    assert!(s.states > 0 && s.states as u64 <= s.observations);
    assert!(record.waypoints.iter().all(|w| w.assimilated.is_some()));
}
