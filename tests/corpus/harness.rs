//! The replay harness on real corpus files and on programs built here.

use std::path::PathBuf;

use nalgebra::{Unit, UnitQuaternion, Vector3};
use nextpose::engine::{EngineConfig, Pose};
use nextpose::program::Language;
use nextpose::replay::frames::Frame;
use nextpose::replay::methods::EngineMethod;
use nextpose::replay::methods::baselines::{self, NearestSeq, RepeatLast};
use nextpose::replay::report::RunConfig;
use nextpose::replay::score::metrics::{Scores, spearman};
use nextpose::replay::score::oracle::oracle_records;
use nextpose::replay::{
    CorpusError, Method, ModelSummary, Program, ProgramRecord, WaypointRecord, load_paths,
    replay_all, replay_program,
};

use crate::corpus;

fn pose(p: [f64; 3], axis: [f64; 3], angle: f64) -> Pose {
    let q = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::from(axis)), angle);
    Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
}

fn program(routines: Vec<Vec<Pose>>) -> Program {
    Program::of_routines("synthetic", routines)
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
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn whole_corpus_loads() {
    let programs = load_paths(&[corpus::json()]).unwrap();
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
    assert!(programs.iter().all(|p| p.language.is_some()));
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
    assert_eq!((m.n2.predictable, m.n2.offered, m.n2.useful), (9, 9, 9));
    assert_eq!(m.n2.precision_pct, Some(100.0));
    assert_eq!(
        m.n2.spearman_conf_err, None,
        "repeat_last has no confidence"
    );
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
        candidate: None,
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

    assert_eq!((m.n2.predictable, m.n2.offered, m.n2.useful), (5, 4, 2));
    assert!(close(m.n2.offered_pct, 80.0));
    assert!(close(m.n2.useful_pct, 40.0));
    assert!(close(m.n2.precision_pct, 50.0));
    assert!(close(m.n2.saved_pct, 0.9 * 40.0 - 0.1 * (80.0 - 40.0)));
    assert!(close(m.n2.saved_pct, 32.0));
    // Offered errors 0.2, 5, 0.5, 1.0.
    assert!(close(m.n2.median_cart_mm, 0.75));
    assert!(close(m.n2.median_angle_rad, 0.05));
    // The zero-travel waypoint is skipped: 2 %, 50 %, 10 %.
    assert!(close(m.n2.median_cart_pct_travel, 10.0));
    // Angle travel is zero everywhere: nothing to compare with.
    assert_eq!(m.n2.median_angle_pct_travel, None);
    // Confidence −0.2, −3, −0.5, −1 against error 0.2, 5, 0.5, 1.0: perfectly reversed ranks.
    assert!(close(m.n2.spearman_conf_err, -1.0));
    assert_eq!(m.n2.spearman_phi_err, None);

    assert_eq!((m.n1.predictable, m.n1.offered, m.n1.useful), (7, 5, 3));
    assert!(close(m.n1.offered_pct, 500.0 / 7.0));
    assert!(close(m.n1.useful_pct, 300.0 / 7.0));
    assert!(close(m.n1.precision_pct, 60.0));
    assert!(close(m.n1.saved_pct, 250.0 / 7.0));
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
    assert_eq!((t.n2.predictable, t.n2.offered, t.n2.useful), (10, 8, 4));
    assert!(close(t.n2.saved_pct, 32.0));
    assert_eq!((t.states, t.edges), (Some(10), Some(7)));
    assert!(close(t.perplexity, 2.0));

    // Nothing offered: precision and medians are null, not NaN.
    let silent = ProgramRecord {
        waypoints: vec![rec(2, None, 1.0, None), rec(3, None, 1.0, None)],
        summary: None,
        ..record
    };
    let s = Scores::of_program(&silent);
    assert_eq!(s.n2.offered_pct, Some(0.0));
    assert_eq!(s.n2.precision_pct, None);
    assert_eq!(s.n2.median_cart_mm, None);
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

/// Writes `text` to `path` and loads it.
fn load_written(path: &std::path::Path, text: &str) -> Result<Vec<Program>, CorpusError> {
    std::fs::write(path, text).unwrap();
    load_paths(&[path])
}

#[test]
fn malformed_json_is_an_error_naming_the_file() {
    let dir = temp_path("corpus");
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("broken_program.json");
    let err = load_written(
        &bad,
        "{\"language\": \"rapid\", \"routines\": [ {\"name\": 3 ]}",
    )
    .unwrap_err();
    assert!(matches!(err, CorpusError::Json { .. }), "{err:?}");
    assert!(err.to_string().contains("broken_program.json"), "{err}");
    // Through the directory too.
    let err = load_paths(&[&dir]).unwrap_err();
    assert!(err.to_string().contains("broken_program.json"), "{err}");

    // A bad quaternion names the routine and waypoint.
    let msg = load_written(
        &bad,
        r#"{"language": "krl", "routines": [{"name": "pick", "waypoints": [
            {"x": 0, "y": 0, "z": 0, "qw": 1, "qx": 0, "qy": 0, "qz": 0},
            {"x": 1, "y": 0, "z": 0, "qw": 0.5, "qx": 0, "qy": 0, "qz": 0}]}]}"#,
    )
    .unwrap_err()
    .to_string();
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
    // (With a routine: a module that yields none is no program, see import's tests.)
    let programs = load_written(
        &dir.join("MainModule.mod"),
        "MODULE MainModule\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC main()\n  MoveL p, v1, z1, tool0;\n  MoveL Offs(p,0,0,10), v1, z1, tool0;\n ENDPROC\nENDMODULE\n",
    )
    .unwrap();
    assert_eq!(programs.len(), 1);
    assert_eq!(programs[0].language, Some(Language::Rapid));
    let err = load_written(&dir.join("notes.txt"), "hello").unwrap_err();
    assert!(matches!(err, CorpusError::Unsupported { .. }));
    assert!(err.to_string().contains("expected corpus JSON"), "{err}");

    std::fs::remove_dir_all(&dir).unwrap();
}

/// The engine and the baselines `nextpose replay` reported first, in their order.
const FIRST_METHODS: [&str; 6] = [
    "engine",
    "repeat_last",
    "nearest_seq",
    "nearest_seq_gated",
    "nearest_seq_within",
    "nearest_seq_within_gated",
];

/// The engine with `config`, then `others`.
fn engine_and(config: &EngineConfig, others: Vec<Box<dyn Method>>) -> Vec<Box<dyn Method>> {
    let mut methods: Vec<Box<dyn Method>> =
        vec![Box::new(EngineMethod::new(config.clone()).unwrap())];
    methods.extend(others);
    methods
}

#[test]
fn report_json_has_the_stable_shape() {
    let prog = program(vec![irregular_routine(), irregular_routine()]);
    let config = EngineConfig::default();
    let mut methods = engine_and(&config, baselines::all(&config, 1.0));
    let report = replay_all(
        &[prog],
        &mut methods,
        RunConfig::new("default", config, 1.0),
    )
    .expect("the bundled arm loads");
    let json = serde_json::to_value(&report).unwrap();

    assert_eq!(json["config"]["horizon"], 3);
    assert_eq!(json["config"]["nearest_seq_gate"], 1.0);
    let expected = FIRST_METHODS;
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

// --- Issue 13: absolute-pose and work-frame baselines, oracle bounds -------------------------

/// `name`'s records among a program's oracle records.
fn oracle<'a>(records: &'a [ProgramRecord], name: &str) -> &'a ProgramRecord {
    records
        .iter()
        .find(|r| r.method == name)
        .unwrap_or_else(|| panic!("{name}"))
}

fn covered(record: &ProgramRecord) -> Vec<bool> {
    record.waypoints.iter().map(|r| r.offered).collect()
}

/// Per waypoint, the union oracle covers exactly where one of the three does, so it is at
/// least each of them.
fn assert_union_is_the_union(records: &[ProgramRecord]) {
    let any = covered(oracle(records, "oracle_any"));
    let kinds: Vec<Vec<bool>> = ["oracle_tool", "oracle_absolute", "oracle_work"]
        .iter()
        .map(|k| covered(oracle(records, k)))
        .collect();
    for (i, a) in any.iter().enumerate() {
        assert_eq!(*a, kinds.iter().any(|k| k[i]), "waypoint {i}");
    }
    let count = |c: &[bool]| c.iter().filter(|c| **c).count();
    for k in &kinds {
        assert!(count(&any) >= count(k));
    }
}

/// Routines that leave home for points that are never the same twice and come back: the
/// return is a known absolute pose, never a known move.
#[test]
fn return_to_home_is_an_absolute_repeat() {
    let home = pose([0.0, 0.0, 800.0], [1.0, 0.0, 0.0], 3.1);
    let routines: Vec<Vec<Pose>> = (0..5)
        .map(|k| {
            let t = k as f64;
            // An approach and a work point near (but never within 1 mm of) the others'.
            let a = pose(
                [600.0 + 9.0 * t, 150.0 - 7.0 * t * t, 400.0 + 5.0 * t],
                [1.0, 0.1 * t, 0.0],
                3.0 - 0.03 * t,
            );
            let b = pose(
                [640.0 + 11.0 * t, 170.0 + 4.0 * t, 300.0 - 6.0 * t],
                [1.0, 0.0, 0.1 * t],
                2.9 + 0.02 * t,
            );
            vec![home, a, b, home]
        })
        .collect();
    let prog = program(routines);
    let records = oracle_records(&prog);
    let returns = |r: &ProgramRecord| -> Vec<bool> {
        r.waypoints
            .iter()
            .filter(|w| w.routine >= 1 && w.predecessors == 3)
            .map(|w| w.offered)
            .collect()
    };
    assert_eq!(returns(oracle(&records, "oracle_absolute")), [true; 4]);
    assert_eq!(returns(oracle(&records, "oracle_tool")), [false; 4]);
    assert_eq!(returns(oracle(&records, "oracle_work")), [false; 4]);
    assert_eq!(returns(oracle(&records, "oracle_any")), [true; 4]);
    assert_union_is_the_union(&records);

    // The absolute nearest-sequence baseline goes home; the tool-frame one repeats an earlier
    // return move from the wrong place.
    let config = EngineConfig::default();
    let useful_returns = |m: &mut dyn Method| -> Vec<bool> {
        let record = replay_program(&prog, m);
        record
            .waypoints
            .iter()
            .filter(|w| w.routine >= 1 && w.predecessors == 3)
            .map(WaypointRecord::useful)
            .collect()
    };
    for within in [false, true] {
        let mut abs = NearestSeq::in_frame(&config, Frame::Absolute, within, false);
        assert_eq!(useful_returns(&mut abs), [true; 4], "{}", abs.name());
        let mut tool = NearestSeq::new(&config, within, None);
        assert_eq!(useful_returns(&mut tool), [false; 4], "{}", tool.name());
    }

    // A known pair of poses reached from a new start: the gated absolute baseline (context: two
    // poses) offers home; the gated tool-frame one (context: the moves so far, the new first
    // one included) withholds.
    let (p, q) = (
        pose([500.0, 0.0, 500.0], [0.0, 1.0, 0.0], 3.0),
        pose([520.0, 40.0, 450.0], [0.0, 1.0, 0.2], 3.0),
    );
    let start = pose([-300.0, 250.0, 600.0], [1.0, 1.0, 0.0], 2.0);
    let prog = program(vec![vec![home, p, q, home], vec![start, p, q, home]]);
    let last = |m: &mut dyn Method| {
        let record = replay_program(&prog, m);
        record.waypoints.last().unwrap().clone()
    };
    let g = last(&mut NearestSeq::in_frame(
        &config,
        Frame::Absolute,
        false,
        true,
    ));
    assert!(g.useful(), "{g:?}");
    assert_eq!(g.confidence, Some(1.0), "one earlier place agrees");
    let t = last(&mut NearestSeq::new(&config, false, Some(1.0)));
    assert!(!t.offered, "{t:?}");
}

/// A seam taught twice: each point's approach is `Offs(p, 0, 0, 100)` and the torch tilts a
/// little more at every point, by another angle the second time. In the work frame both
/// teachings are the same moves; in the tool frame none repeats.
#[test]
fn work_frame_offset_under_a_turning_tool_is_a_work_frame_repeat() {
    let seam = |shift: [f64; 3], tilt: f64| -> Vec<Pose> {
        let mut at = [shift[0], shift[1], shift[2]];
        // A lead-in from a start point, so that the first approach's context is not ambiguous
        // (every approach is the same work-frame move).
        let start = [at[0] - 80.0, at[1] + 30.0, at[2] + 150.0];
        let mut w = vec![pose(start, [0.0, 1.0, 0.0], tilt)];
        for i in 0..6 {
            let t = i as f64;
            let angle = 0.2 * t + tilt;
            w.push(pose(at, [0.0, 1.0, 0.0], angle));
            w.push(pose([at[0], at[1], at[2] + 100.0], [0.0, 1.0, 0.0], angle));
            at = [at[0] + 60.0 + 15.0 * t, at[1] + 8.0 * t, at[2] - 3.0 * t];
        }
        w
    };
    let prog = program(vec![seam([0.0; 3], 0.0), seam([0.0, 500.0, 0.0], 0.15)]);
    let records = oracle_records(&prog);
    let second = |r: &ProgramRecord| -> Vec<bool> {
        r.waypoints
            .iter()
            .filter(|w| w.routine == 1)
            .map(|w| w.offered)
            .collect()
    };
    assert_eq!(second(oracle(&records, "oracle_work")), [true; 12]);
    assert_eq!(second(oracle(&records, "oracle_tool")), [false; 12]);
    assert_eq!(second(oracle(&records, "oracle_absolute")), [false; 12]);
    assert_union_is_the_union(&records);

    let config = EngineConfig::default();
    let second_useful = |m: &mut dyn Method| -> (usize, usize) {
        let record = replay_program(&prog, m);
        let w: Vec<&WaypointRecord> = record
            .waypoints
            .iter()
            .filter(|w| w.routine == 1 && w.predecessors >= 2)
            .collect();
        (
            w.iter().filter(|w| w.offered).count(),
            w.iter().filter(|w| w.useful()).count(),
        )
    };
    // Eleven waypoints with ≥ 2 predecessors: the work-frame baselines offer and get every one.
    for within in [false, true] {
        for gated in [false, true] {
            let mut work = NearestSeq::in_frame(&config, Frame::Work, within, gated);
            assert_eq!(second_useful(&mut work), (11, 11), "{}", work.name());
        }
    }
    // The tool-frame ones get none; gated, they see the mismatch and offer nothing.
    for within in [false, true] {
        let mut tool = NearestSeq::new(&config, within, None);
        assert_eq!(second_useful(&mut tool).1, 0, "{}", tool.name());
        let mut gated = NearestSeq::new(&config, within, Some(1.0));
        assert_eq!(second_useful(&mut gated), (0, 0), "{}", gated.name());
    }
}

/// The whole corpus: the oracles' shares as issue 13 measured them, the union at least each
/// kind, and the absolute-pose predictor of the issue (`abs_seq_within_gated`).
#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn corpus_oracles_and_the_absolute_predictor() {
    let programs = load_paths(&[corpus::json()]).unwrap();
    let config = EngineConfig::default();
    let mut methods = baselines::frames(&config);
    let mut report = replay_all(
        &programs,
        &mut methods,
        RunConfig::new("default", config, 1.0),
    )
    .expect("the bundled arm loads");
    report.add_oracles(&programs);
    let share = |name: &str| report.totals.get(name).unwrap().n2.useful_pct.unwrap();
    for (name, expected) in [
        ("oracle_tool", 33.1),
        ("oracle_absolute", 34.3),
        ("oracle_work", 35.4),
        ("oracle_any", 47.3),
    ] {
        assert_eq!(report.totals.get(name).unwrap().n2.predictable, 2969);
        assert!(
            (share(name) - expected).abs() < 0.05,
            "{name}: {}",
            share(name)
        );
    }
    for name in ["oracle_tool", "oracle_absolute", "oracle_work"] {
        assert!(share("oracle_any") > share(name));
    }
    let a = report.totals.get("abs_seq_within_gated").unwrap();
    let (saved, precision) = (a.n2.saved_pct.unwrap(), a.n2.precision_pct.unwrap());
    assert!((saved - 15.1).abs() < 0.05, "saved {saved}");
    assert!((precision - 87.6).abs() < 0.05, "precision {precision}");
    // A baseline offers candidates of its own kind, so it is useful at most where its oracle
    // covers.
    for (name, s) in report
        .totals
        .0
        .iter()
        .filter(|(n, _)| !n.starts_with("oracle_"))
    {
        let bound = if name.starts_with("abs_") {
            "oracle_absolute"
        } else {
            "oracle_work"
        };
        assert!(
            s.n2.useful_pct.unwrap() <= share(bound) + 1e-9,
            "{name} vs {bound}"
        );
        assert!(s.n2.useful_pct.unwrap() > 10.0, "{name}");
    }
}

/// `nextpose replay`'s report: every original key kept, the new methods after them, the
/// oracles last and described in a section of their own, and tabled apart from the methods.
#[test]
fn report_with_new_baselines_and_oracles() {
    let prog = program(vec![irregular_routine(), irregular_routine()]);
    let config = EngineConfig::default();
    let mut methods = engine_and(&config, baselines::scoreboard(&config, 1.0));
    let mut report = replay_all(
        std::slice::from_ref(&prog),
        &mut methods,
        RunConfig::new("default", config, 1.0),
    )
    .expect("the bundled arm loads");
    assert!(
        serde_json::to_value(&report)
            .unwrap()
            .get("oracles")
            .is_none()
    );
    report.add_oracles(std::slice::from_ref(&prog));
    report.add_oracles(std::slice::from_ref(&prog)); // replaces, does not duplicate
    let json = serde_json::to_value(&report).unwrap();
    let expected: Vec<&str> = FIRST_METHODS
        .into_iter()
        .chain([
            "abs_seq",
            "abs_seq_gated",
            "abs_seq_within",
            "abs_seq_within_gated",
            "work_seq",
            "work_seq_gated",
            "work_seq_within",
            "work_seq_within_gated",
            "oracle_tool",
            "oracle_absolute",
            "oracle_work",
            "oracle_any",
        ])
        .collect();
    let names: Vec<&str> = report.totals.0.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, expected);
    let totals = json["totals"].as_object().unwrap();
    assert_eq!(totals.len(), expected.len());
    for &name in &expected {
        assert!(totals[name]["predictable"].is_u64(), "{name}");
        assert!(totals[name]["saved_pct"].is_number(), "{name}");
    }
    let programs = json["programs"].as_array().unwrap();
    assert_eq!(
        programs[0]["methods"].as_object().unwrap().len(),
        expected.len()
    );

    // The second routine repeats the first exactly: every waypoint is covered by each kind.
    let oracles = &json["oracles"];
    assert!(oracles["meaning"].as_str().unwrap().contains("not methods"));
    assert_eq!(oracles["useful_max_mm"], 1.0);
    let kinds = oracles["kinds"].as_array().unwrap();
    assert_eq!(kinds.len(), 4);
    for k in kinds {
        let name = k["name"].as_str().unwrap();
        assert_eq!(k["covered"], totals[name]["useful"], "{name}");
        assert_eq!(k["covered"], totals[name]["offered"], "{name}");
        assert_eq!(k["predictable"], 14, "{name}");
        assert_eq!(k["covered"], 7, "{name}: the second routine's n ≥ 2");
        assert_eq!(totals[name]["precision_pct"], 100.0, "{name}");
        assert!(totals[name]["us_per_waypoint"].is_null(), "{name}");
    }

    // Methods in the totals table, oracles only in their own table below it.
    let table = report.totals_table();
    let split = table
        .find("Oracle bounds")
        .expect("an oracle table after the methods");
    let (methods_part, oracle_part) = table.split_at(split);
    for &name in &expected {
        let in_methods = methods_part.lines().any(|l| l.starts_with(name));
        let in_oracles = oracle_part.lines().any(|l| l.starts_with(name));
        assert_eq!(
            (in_methods, in_oracles),
            (!name.starts_with("oracle_"), name.starts_with("oracle_")),
            "{name}\n{table}"
        );
    }
}
