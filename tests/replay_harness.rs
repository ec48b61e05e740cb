//! The replay harness on real corpus files and on programs built here.

use std::path::{Path, PathBuf};

use nalgebra::{Unit, UnitQuaternion, Vector3};
use nextpose::engine::{EngineConfig, Pose};
use nextpose::replay::baselines::{self, NearestSeq, RepeatLast};
use nextpose::replay::engine_method::EngineMethod;
use nextpose::replay::metrics::{Scores, spearman};
use nextpose::replay::report::RunConfig;
use nextpose::replay::{
    CorpusError, Method, ModelSummary, Program, ProgramRecord, Routine, WaypointRecord, load_paths,
    replay_all, replay_program,
};

const CORPUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/corpus/json");

fn pose(p: [f64; 3], axis: [f64; 3], angle: f64) -> Pose {
    let q = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::from(axis)), angle);
    Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
}

fn program(routines: Vec<Vec<Pose>>) -> Program {
    Program {
        name: "synthetic".into(),
        source: PathBuf::from("synthetic.json"),
        language: "rapid".into(),
        routines: routines
            .into_iter()
            .enumerate()
            .map(|(i, waypoints)| Routine {
                name: format!("r{i}"),
                waypoints,
            })
            .collect(),
    }
}

/// An irregular routine (no move repeats), so a window matches only its own position.
fn irregular_routine() -> Vec<Pose> {
    (0..9)
        .map(|i| {
            let t = i as f64;
            pose(
                [
                    100.0 + 37.0 * t + t * t,
                    -20.0 + 11.0 * (t * 1.3).sin() * 10.0,
                    300.0 + 5.0 * t * t,
                ],
                [0.2 + t * 0.1, 1.0, 0.3 * t],
                0.1 * t + 0.05 * t * t,
            )
        })
        .collect()
}

/// A unique, not-yet-existing path in the system temp dir.
fn temp_path(name: &str) -> PathBuf {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    std::env::temp_dir().join(format!(
        "nextpose-replay-test-{}-{nanos}-{name}",
        std::process::id()
    ))
}

#[test]
fn whole_corpus_loads() {
    let programs = load_paths(&[Path::new(CORPUS)]).unwrap();
    assert_eq!(programs.len(), 36);
    let routines: usize = programs.iter().map(|p| p.routines.len()).sum();
    let waypoints: usize = programs.iter().map(|p| p.waypoint_count()).sum();
    assert_eq!(routines, 309);
    assert_eq!(waypoints, 3587);
    // Sorted by file name, languages as recorded.
    let names: Vec<&str> = programs.iter().map(|p| p.name.as_str()).collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(names, sorted);
    assert!(
        programs
            .iter()
            .all(|p| ["rapid", "krl", "fanuc"].contains(&p.language.as_str()))
    );
}

#[test]
fn nearest_seq_predicts_a_repeated_routine_exactly() {
    let first = irregular_routine();
    // The same routine taught again elsewhere: a rigid transform keeps every relative move.
    let g = pose([500.0, -250.0, 40.0], [0.0, 0.3, 1.0], 1.1);
    let second: Vec<Pose> = first
        .iter()
        .map(|w| Pose::from_isometry(g.isometry() * w.isometry()))
        .collect();
    let prog = program(vec![first, second]);
    let config = EngineConfig::default();
    for within in [false, true] {
        let mut method = NearestSeq::new(&config, within, None);
        let record = replay_program(&prog, &mut method);
        let repeat: Vec<&WaypointRecord> =
            record.waypoints.iter().filter(|r| r.routine == 1).collect();
        assert_eq!(repeat.len(), 8);
        for r in repeat {
            assert!(r.offered, "{} n={}", method.name(), r.predecessors);
            let err = r.cart_mm.unwrap();
            assert!(
                err < 1e-6,
                "{} n={}: {err} mm",
                method.name(),
                r.predecessors
            );
            assert!(r.angle_rad.unwrap() < 1e-6);
            assert!(r.useful());
        }
        // Nothing is known during the first routine without `within` (its moves never repeat).
        if !within {
            assert!(
                record
                    .waypoints
                    .iter()
                    .filter(|r| r.routine == 0)
                    .all(|r| !r.offered)
            );
        }
    }
}

#[test]
fn repeat_last_is_exact_on_a_straight_line() {
    // Equal steps along a slanted line with a constant turn per step: every move is the same.
    let start = pose([10.0, 20.0, 30.0], [1.0, 2.0, 0.5], 0.4);
    let step = nextpose::engine::Move::between(
        &Pose::identity(),
        &pose([12.5, -3.0, 7.0], [0.0, 0.0, 1.0], 0.05),
    );
    let mut line = vec![start];
    for _ in 0..10 {
        let next = line[line.len() - 1].then(&step);
        line.push(next);
    }
    let record = replay_program(&program(vec![line]), &mut RepeatLast::new());
    assert_eq!(record.waypoints.len(), 10);
    for r in &record.waypoints {
        if r.predecessors == 1 {
            assert!(!r.offered);
        } else {
            assert!(
                r.cart_mm.unwrap() < 1e-9 && r.angle_rad.unwrap() < 1e-9,
                "{r:?}"
            );
        }
    }
    let m = Scores::of_program(&record);
    assert_eq!((m.predictable, m.offered, m.useful), (9, 9, 9));
    assert_eq!(m.precision_pct, Some(100.0));
    assert_eq!(m.spearman_conf_err, None, "repeat_last has no confidence");
}

fn rec(n: usize, offered: Option<(f64, f64)>, travel_mm: f64, conf: Option<f64>) -> WaypointRecord {
    WaypointRecord {
        routine: 0,
        predecessors: n,
        offered: offered.is_some(),
        cart_mm: offered.map(|o| o.0),
        angle_rad: offered.map(|o| o.1),
        travel_mm,
        travel_rad: 0.0,
        confidence: conf,
        phi: None,
        psi: None,
        assimilated: None,
        micros: 2.0,
    }
}

#[test]
fn metrics_arithmetic_on_hand_made_records() {
    let waypoints = vec![
        rec(1, Some((0.5, 0.01)), 10.0, Some(-0.1)), // useful, n = 1 only
        rec(1, None, 10.0, None),
        rec(2, Some((0.2, 0.0)), 10.0, Some(-0.2)), // useful
        rec(2, Some((5.0, 0.0)), 10.0, Some(-3.0)), // too far
        rec(3, Some((0.5, 0.2)), 0.0, Some(-0.5)),  // turned too far; zero travel
        rec(3, None, 10.0, None),
        rec(4, Some((1.0, 0.1)), 10.0, Some(-1.0)), // on the boundary: useful
    ];
    let record = ProgramRecord {
        program: "hand".into(),
        language: "rapid".into(),
        method: "x".into(),
        waypoints,
        summary: Some(ModelSummary {
            states: 4,
            edges: 6,
            perplexity: 1.5,
            observations: 9,
        }),
    };
    let m = Scores::of_program(&record);
    let close = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-9);

    assert_eq!((m.predictable, m.offered, m.useful), (5, 4, 2));
    assert!(close(m.offered_pct, 80.0));
    assert!(close(m.useful_pct, 40.0));
    assert!(close(m.precision_pct, 50.0));
    assert!(close(m.saved_pct, 0.9 * 40.0 - 0.1 * (80.0 - 40.0)));
    assert!(close(m.saved_pct, 32.0));
    // Offered errors 0.2, 5, 0.5, 1.0.
    assert!(close(m.median_cart_mm, 0.75));
    assert!(close(m.median_angle_rad, 0.05));
    // The zero-travel waypoint is skipped: 2 %, 50 %, 10 %.
    assert!(close(m.median_cart_pct_travel, 10.0));
    // Angle travel is zero everywhere: nothing to compare with.
    assert_eq!(m.median_angle_pct_travel, None);
    // Confidence −0.2, −3, −0.5, −1 against error 0.2, 5, 0.5, 1.0: perfectly reversed ranks.
    assert!(close(m.spearman_conf_err, -1.0));
    assert_eq!(m.spearman_phi_err, None);

    assert_eq!((m.predictable_n1, m.offered_n1, m.useful_n1), (7, 5, 3));
    assert!(close(m.offered_pct_n1, 500.0 / 7.0));
    assert!(close(m.useful_pct_n1, 300.0 / 7.0));
    assert!(close(m.precision_pct_n1, 60.0));
    assert!(close(m.saved_pct_n1, 250.0 / 7.0));
    assert!(close(m.us_per_waypoint, 2.0));

    // Totals pool waypoints, sum model sizes, average perplexity.
    let mut other = record.clone();
    other.summary = Some(ModelSummary {
        states: 6,
        edges: 1,
        perplexity: 2.5,
        observations: 9,
    });
    let t = Scores::of_programs([&record, &other]);
    assert_eq!((t.predictable, t.offered, t.useful), (10, 8, 4));
    assert!(close(t.saved_pct, 32.0));
    assert_eq!((t.states, t.edges), (Some(10), Some(7)));
    assert!(close(t.perplexity, 2.0));

    // Nothing offered: precision and medians are null, not NaN.
    let silent = ProgramRecord {
        waypoints: vec![rec(2, None, 1.0, None), rec(3, None, 1.0, None)],
        summary: None,
        ..record
    };
    let s = Scores::of_program(&silent);
    assert_eq!(s.offered_pct, Some(0.0));
    assert_eq!(s.precision_pct, None);
    assert_eq!(s.median_cart_mm, None);
    assert_eq!(s.states, None);
    let json = serde_json::to_value(&s).unwrap();
    assert!(json["precision_pct"].is_null());
    assert_eq!(json["saved_pct"], 0.0);
}

#[test]
fn spearman_with_ties_matches_hand_computation() {
    // Ranks of x with the tie averaged: [1, 2.5, 2.5, 4]; ranks of y: [1, 3, 2, 4].
    // Centred: [−1.5, 0, 0, 1.5] and [−1.5, 0.5, −0.5, 1.5]; Σxy = 4.5, Σx² = 4.5, Σy² = 5,
    // so ρ = 4.5 / √(4.5 · 5) = √0.9.
    let rho = spearman(&[1.0, 2.0, 2.0, 3.0], &[10.0, 30.0, 20.0, 40.0]).unwrap();
    assert!((rho - 0.9f64.sqrt()).abs() < 1e-12, "{rho}");
    // Ties on both sides: x ranks [1.5, 1.5, 3, 4, 5], y ranks [1, 2.5, 2.5, 5, 4].
    // Centred: [−1.5, −1.5, 0, 1, 2] and [−2, −0.5, −0.5, 2, 1]; Σxy = 3 + 0.75 + 0 + 2 + 2 = 7.75,
    // Σx² = 2.25 + 2.25 + 0 + 1 + 4 = 9.5, Σy² = 4 + 0.25 + 0.25 + 4 + 1 = 9.5.
    let rho = spearman(&[1.0, 1.0, 2.0, 3.0, 4.0], &[0.0, 5.0, 5.0, 9.0, 7.0]).unwrap();
    assert!((rho - 7.75 / 9.5).abs() < 1e-12, "{rho}");
    // Constant input has no rank correlation.
    assert_eq!(spearman(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0]), None);
}

#[test]
fn malformed_json_is_an_error_naming_the_file() {
    let dir = temp_path("corpus");
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("broken_program.json");
    std::fs::write(
        &bad,
        "{\"language\": \"rapid\", \"routines\": [ {\"name\": 3 ]}",
    )
    .unwrap();

    let err = load_paths(&[&bad]).unwrap_err();
    assert!(matches!(err, CorpusError::Json { .. }), "{err:?}");
    assert!(err.to_string().contains("broken_program.json"), "{err}");
    // Through the directory too.
    let err = load_paths(&[&dir]).unwrap_err();
    assert!(err.to_string().contains("broken_program.json"), "{err}");

    // A bad quaternion names the routine and waypoint.
    std::fs::write(
        &bad,
        r#"{"language": "krl", "routines": [{"name": "pick", "waypoints": [
            {"x": 0, "y": 0, "z": 0, "qw": 1, "qx": 0, "qy": 0, "qz": 0},
            {"x": 1, "y": 0, "z": 0, "qw": 0.5, "qx": 0, "qy": 0, "qz": 0}]}]}"#,
    )
    .unwrap();
    let err = load_paths(&[&bad]).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("broken_program.json") && msg.contains("pick") && msg.contains("waypoint 1"),
        "{msg}"
    );

    // Missing files and files of no known kind are clear errors too; raw robot source is
    // imported (issue 5).
    let missing = dir.join("missing.json");
    assert!(
        load_paths(&[&missing])
            .unwrap_err()
            .to_string()
            .contains("missing.json")
    );
    let raw = dir.join("MainModule.mod");
    // (With a routine: a module that yields none is no program, see import's tests.)
    std::fs::write(
        &raw,
        "MODULE MainModule\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC main()\n  MoveL p, v1, z1, tool0;\n  MoveL Offs(p,0,0,10), v1, z1, tool0;\n ENDPROC\nENDMODULE\n",
    )
    .unwrap();
    let programs = load_paths(&[&raw]).unwrap();
    assert_eq!(programs.len(), 1);
    assert_eq!(programs[0].language, "rapid");
    let other = dir.join("notes.txt");
    std::fs::write(&other, "hello").unwrap();
    let err = load_paths(&[&other]).unwrap_err();
    assert!(matches!(err, CorpusError::Unsupported { .. }));
    assert!(err.to_string().contains("expected corpus JSON"), "{err}");

    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn report_json_has_the_stable_shape() {
    let prog = program(vec![irregular_routine(), irregular_routine()]);
    let config = EngineConfig::default();
    let mut methods: Vec<Box<dyn Method>> =
        vec![Box::new(EngineMethod::new(config.clone()).unwrap())];
    methods.extend(baselines::all(&config, 1.0));
    let report = replay_all(
        &[prog],
        &mut methods,
        RunConfig::new("default", config, 1.0),
    )
    .expect("the bundled arm loads");
    let json = serde_json::to_value(&report).unwrap();

    assert_eq!(json["config"]["horizon"], 3);
    assert_eq!(json["config"]["nearest_seq_gate"], 1.0);
    let expected = [
        "engine",
        "repeat_last",
        "nearest_seq",
        "nearest_seq_gated",
        "nearest_seq_within",
        "nearest_seq_within_gated",
    ];
    let totals = json["totals"].as_object().unwrap();
    assert_eq!(totals.len(), expected.len());
    for name in expected {
        assert!(totals[name]["predictable"].is_u64(), "{name}");
    }
    let programs = json["programs"].as_array().unwrap();
    assert_eq!(programs.len(), 1);
    assert_eq!(programs[0]["program"], "synthetic");
    assert_eq!(programs[0]["language"], "rapid");
    assert_eq!(
        programs[0]["methods"]["nearest_seq"]["useful"],
        totals["nearest_seq"]["useful"]
    );
    // Tables render one totals row per method.
    let table = report.totals_table();
    for name in expected {
        assert!(table.lines().any(|l| l.starts_with(name)), "{table}");
    }
}
