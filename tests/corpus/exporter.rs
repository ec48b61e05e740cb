//! The exporter against our importer.
//!
//! - (a) Every program of the shared corpus (`../shared/corpus/raw`, one upload per repository,
//!   as `importer.rs` reads it), imported, exported in all three formats and imported again,
//!   has the same routines, waypoint counts, motion classes and poses within the printed
//!   precision ([`Language::position_tolerance_mm`], [`Language::orientation_tolerance_rad`]); names
//!   that were valid are kept exactly, the others are the ones the warnings announce, and a
//!   second export of the re-imported program renames nothing (a fixpoint).
//! - (b) The same for random programs: random poses (also at and near gimbal lock, which
//!   matters for the Euler formats), motions and names (valid, reserved, messy, none, repeated).
//! - (d) An unreachable waypoint gives a comment in every format and a warning.

use std::collections::HashMap;

use nalgebra::UnitQuaternion;
use nextpose::engine::Pose;
use nextpose::export::{
    ExportSettings, ExportWarning, Exported, export, orientation_tolerance_rad,
    position_tolerance_mm,
};
use nextpose::import::{Imported, parse_files};
use nextpose::program::{Language, Motion, Program, Routine, Waypoint};
use proptest::prelude::*;

use crate::corpus::uploads;

/// The motion a waypoint is moved to with: linear when it has none.
fn motion(w: &Waypoint) -> Motion {
    w.motion.unwrap_or(Motion::Linear)
}

/// The motion each waypoint is written with: circular ones pair up as (via, end), one left
/// alone is moved to linearly.
fn effective_motions(r: &Routine<Waypoint>) -> Vec<Motion> {
    let mut out: Vec<Motion> = r.waypoints.iter().map(motion).collect();
    let mut i = 0;
    while i < out.len() {
        if out[i] == Motion::Circular {
            if out.get(i + 1) == Some(&Motion::Circular) {
                i += 2;
                continue;
            }
            out[i] = Motion::Linear;
        }
        i += 1;
    }
    out
}

/// The routine and waypoint names the export announces: the original unless a warning says.
fn announced(program: &Program<Waypoint>, exported: &Exported) -> Vec<(String, Vec<String>)> {
    let mut routine_names: Vec<String> = program.routines.iter().map(|r| r.name.clone()).collect();
    for w in &exported.warnings {
        if let ExportWarning::RenamedRoutine { position, to, .. } = w {
            routine_names[*position - 1] = to.clone();
        }
    }
    let mut targets: HashMap<(&str, usize), &str> = HashMap::new();
    for w in &exported.warnings {
        if let ExportWarning::RenamedTarget {
            routine, seq, to, ..
        } = w
        {
            targets.insert((routine.as_str(), *seq), to.as_str());
        }
    }
    program
        .routines
        .iter()
        .zip(&routine_names)
        .map(|(r, name)| {
            let names = r
                .waypoints
                .iter()
                .enumerate()
                .map(|(i, w)| match targets.get(&(name.as_str(), i + 1)) {
                    Some(to) => to.to_string(),
                    None => w
                        .name
                        .clone()
                        .expect("an unnamed waypoint is always renamed"),
                })
                .collect();
            (name.clone(), names)
        })
        .collect()
}

/// Exports `program`, imports the files and checks what came back; returns the re-imported
/// program and the announced names.
fn round_trip(
    program: &Program<Waypoint>,
    format: Language,
    settings: &ExportSettings,
) -> (Imported, Vec<(String, Vec<String>)>) {
    let exported = export(program, format, settings).unwrap_or_else(|e| panic!("{e}"));
    let report = parse_files(&exported.as_pairs()).unwrap_or_else(|e| {
        panic!(
            "{format}: {e}\n{}",
            exported.files.first().map_or("", |f| f.text.as_str())
        )
    });
    assert_eq!(report.programs.len(), 1, "{format}: {:?}", report.skipped);
    let back = report.programs.into_iter().next().unwrap();
    let mut expected: Vec<(String, Vec<String>, &Routine<Waypoint>)> =
        announced(program, &exported)
            .into_iter()
            .zip(&program.routines)
            .map(|((n, w), r)| (n, w, r))
            .collect();
    if format == Language::Fanuc {
        // The importer reads a folder's listings in file-name order.
        expected.sort_by(|a, b| format!("{}.ls", a.0).cmp(&format!("{}.ls", b.0)));
    }
    let got: Vec<&str> = back
        .program
        .routines
        .iter()
        .map(|r| r.name.as_str())
        .collect();
    let want: Vec<&str> = expected.iter().map(|e| e.0.as_str()).collect();
    assert_eq!(got, want, "{format}: routines of {}", program.name);
    let (dp, dr) = (
        position_tolerance_mm(format),
        orientation_tolerance_rad(format),
    );
    for ((name, names, original), r) in expected.iter().zip(&back.program.routines) {
        assert_eq!(
            r.waypoints.len(),
            original.waypoints.len(),
            "{format}: {name}"
        );
        let motions = effective_motions(original);
        for (i, (w, o)) in r.waypoints.iter().zip(&original.waypoints).enumerate() {
            let at = format!("{format}: {} {name} #{i}", program.name);
            assert_eq!(w.name.as_deref(), Some(names[i].as_str()), "{at}");
            assert_eq!(motion(w), motions[i], "{at}");
            let (ep, er) = (w.pose.distance_to(&o.pose), w.pose.angle_to(&o.pose));
            assert!(ep <= dp && er <= dr, "{at}: {ep} mm, {er} rad");
        }
    }
    let names = expected.into_iter().map(|(n, w, _)| (n, w)).collect();
    (back, names)
}

/// Round trip, then a second export of what came back: it renames nothing.
fn check(program: &Program<Waypoint>, format: Language) {
    let settings = ExportSettings::default();
    let (back, names) = round_trip(program, format, &settings);
    let again = back.program;
    let (_, names2) = round_trip(&again, format, &settings);
    assert_eq!(names2, names, "{format}: a second export renames");
    let exported = export(&again, format, &settings).unwrap();
    let renamed: Vec<&ExportWarning> = exported
        .warnings
        .iter()
        .filter(|w| {
            matches!(
                w,
                ExportWarning::RenamedTarget { .. }
                    | ExportWarning::RenamedRoutine { .. }
                    | ExportWarning::RenamedProgram { .. }
            )
        })
        .collect();
    assert!(renamed.is_empty(), "{format}: {renamed:?}");
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn every_corpus_program_round_trips_in_every_format() {
    let mut programs = 0;
    let mut waypoints = 0;
    for (repo, files) in uploads() {
        let refs: Vec<(&str, &str)> = files
            .iter()
            .map(|(n, t)| (n.as_str(), t.as_str()))
            .collect();
        let report = parse_files(&refs).unwrap_or_else(|e| panic!("{repo}: {e}"));
        for p in &report.programs {
            for format in Language::ALL {
                check(&p.program, format);
            }
            programs += 1;
            waypoints += p.program.waypoint_count();
        }
    }
    eprintln!("{programs} corpus programs, {waypoints} waypoints: round trip in 3 formats");
    assert_eq!(programs, 36);
}

#[test]
fn valid_names_are_kept_and_others_announced() {
    let pose = |x: f64| Pose::new([x, 0.0, 500.0], [0.0, 0.0, 1.0, 0.0]).unwrap();
    let wp = |name: Option<&str>, x: f64, motion| Waypoint {
        name: name.map(str::to_string),
        pose: pose(x),
        motion: Some(motion),
        configuration: None,
        reachable: None,
    };
    let program = Program::new(
        "Demo",
        vec![Routine {
            name: "main".into(),
            waypoints: vec![
                wp(Some("p10"), 1.0, Motion::Joint),
                wp(Some("Offs(p10,0,0,50)"), 2.0, Motion::Linear),
                wp(None, 3.0, Motion::Linear),
                wp(Some("p10"), 1.0, Motion::Linear),
                wp(Some("p10"), 4.0, Motion::Linear),
                wp(Some("PROC"), 5.0, Motion::Circular),
                wp(Some("main"), 6.0, Motion::Circular),
                wp(Some("v100"), 7.0, Motion::Circular),
            ],
        }],
    );
    let out = export(&program, Language::Rapid, &ExportSettings::default()).unwrap();
    let text = &out.files[0].text;
    assert_eq!(out.files[0].file_name, "Demo.mod");
    for line in [
        "CONST robtarget p10:=[[1.000,0.000,500.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];",
        "MoveJ p10, v100, z10, tool0\\WObj:=wobj0;",
        "MoveL Offs_p10_0_0_50, v100, z10, tool0\\WObj:=wobj0;",
        "MoveL p3, v100",
        "MoveL p10, v100",
        "MoveL p10_2, v100",
        "MoveC PROC_1, main_2, v100",
        "MoveL v100_2, v100",
    ] {
        assert!(text.contains(line), "{line}\n{text}");
    }
    assert_eq!(text.matches("CONST robtarget p10:=").count(), 1, "{text}");
    assert!(
        out.warnings.contains(&ExportWarning::UnpairedCircular {
            routine: "main".into(),
            seq: 8
        }),
        "{:?}",
        out.warnings
    );
    check(&program, Language::Rapid);
    check(&program, Language::Krl);
    check(&program, Language::Fanuc);
}

#[test]
fn unreachable_waypoints_get_a_comment_and_a_warning() {
    let pose = |x: f64| Pose::new([x, 0.0, 500.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
    let program = Program::new(
        "reach",
        vec![Routine {
            name: "reach".into(),
            waypoints: (0..3)
                .map(|i| Waypoint {
                    name: Some(format!("p{i}")),
                    pose: pose(f64::from(i) * 1000.0),
                    motion: Some(Motion::Linear),
                    configuration: None,
                    reachable: Some(i != 2),
                })
                .collect(),
        }],
    );
    for (format, comment) in [
        (Language::Rapid, "! p2: out of the arm's reach"),
        (Language::Krl, "; p2: out of the arm's reach"),
        (Language::Fanuc, "!P[1] OUT OF REACH ;"),
    ] {
        let out = export(&program, format, &ExportSettings::default()).unwrap();
        let text: String = out.files.iter().map(|f| f.text.as_str()).collect();
        let comment = if format == Language::Fanuc {
            // p0, p1, p2 become P[1], P[2], P[3].
            comment.replace("P[1]", "P[3]")
        } else {
            comment.to_string()
        };
        assert!(text.contains(&comment), "{format}:\n{text}");
        let unreachable: Vec<_> = out
            .warnings
            .iter()
            .filter_map(|w| match w {
                ExportWarning::Unreachable { seq, .. } => Some(*seq),
                _ => None,
            })
            .collect();
        assert_eq!(unreachable, [3], "{format}");
        check(&program, format);
    }
}

#[test]
fn krl_writes_a_src_and_its_dat_and_a_main_def_when_needed() {
    let pose = Pose::new([500.0, 0.0, 400.0], [0.5, 0.5, 0.5, 0.5]).unwrap();
    let wp = |n: &str| Waypoint {
        name: Some(n.into()),
        pose,
        motion: Some(Motion::Joint),
        configuration: None,
        reachable: None,
    };
    let routine = |n: &str| Routine {
        name: n.into(),
        waypoints: vec![wp("XP1"), wp("XP1")],
    };
    let program = Program::new("cell", vec![routine("weld"), routine("home")]);
    let out = export(&program, Language::Krl, &ExportSettings::default()).unwrap();
    let names: Vec<&str> = out.files.iter().map(|f| f.file_name.as_str()).collect();
    assert_eq!(names, ["cell.src", "cell.dat"]);
    assert!(
        out.files[0]
            .text
            .contains("DEF cell( )\n  weld( )\n  home( )\nEND")
    );
    assert!(out.files[1].text.contains("DEFDAT cell\n"));
    // When the first routine has the program's name it is the main DEF.
    let program = Program {
        name: "weld".into(),
        ..program
    };
    let out = export(&program, Language::Krl, &ExportSettings::default()).unwrap();
    assert!(
        out.files[0]
            .text
            .starts_with("&ACCESS RVP\n&REL 1\nDEF weld( )\n")
    );
    assert_eq!(out.files[0].text.matches("DEF ").count(), 2);
}

fn name_strategy() -> impl Strategy<Value = Option<String>> {
    prop_oneof![
        Just(None),
        "[A-Za-z][A-Za-z0-9_]{0,40}".prop_map(Some),
        "P\\[[0-9]{1,3}\\]".prop_map(Some),
        "\\PC{0,12}".prop_map(Some),
        prop::sample::select(vec![
            "PROC", "END", "LIN", "p1", "P1", "v100", "XP1", "main"
        ])
        .prop_map(|s| Some(s.to_string())),
    ]
}

fn pose_strategy() -> impl Strategy<Value = Pose> {
    let position = prop::array::uniform3(-3000.0f64..3000.0);
    let quaternion = prop::array::uniform4(-1.0f64..1.0)
        .prop_filter("not too short", |q| {
            q.iter().map(|v| v * v).sum::<f64>() > 0.01
        })
        .prop_map(|q| {
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            q.map(|v| v / n)
        });
    // Near or at gimbal lock: B = ±90° up to a tiny offset, A and C anything.
    let gimbal = (
        -180.0f64..180.0,
        prop::sample::select(vec![90.0f64, -90.0]),
        prop::sample::select(vec![0.0f64, 1e-9, -1e-7, 1e-5, 3e-3]),
        -180.0f64..180.0,
    )
        .prop_map(|(a, b, e, c)| {
            let q = UnitQuaternion::from_euler_angles(
                f64::to_radians(c),
                f64::to_radians(b - b.signum() * e.abs()),
                f64::to_radians(a),
            );
            [q.w, q.i, q.j, q.k]
        });
    (position, prop_oneof![quaternion, gimbal])
        .prop_map(|(p, q)| Pose::new(p, q).expect("a unit quaternion"))
}

fn waypoint_strategy() -> impl Strategy<Value = Waypoint> {
    (
        name_strategy(),
        pose_strategy(),
        prop::sample::select(vec![
            None,
            Some(Motion::Joint),
            Some(Motion::Linear),
            Some(Motion::Circular),
        ]),
    )
        .prop_map(|(name, pose, motion)| Waypoint {
            name,
            pose,
            motion,
            configuration: None,
            reachable: None,
        })
}

fn program_strategy() -> impl Strategy<Value = Program<Waypoint>> {
    let routine = (
        name_strategy().prop_map(|n| n.unwrap_or_default()),
        prop::collection::vec(waypoint_strategy(), 2..8),
    )
        .prop_map(|(name, waypoints)| Routine { name, waypoints });
    (
        "[A-Za-z][A-Za-z0-9_ .-]{0,12}",
        prop::collection::vec(routine, 1..4),
    )
        .prop_map(|(name, routines)| Program::new(name, routines))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn random_programs_round_trip(program in program_strategy()) {
        for format in Language::ALL {
            check(&program, format);
        }
    }

    #[test]
    fn a_waypoint_visited_twice_is_declared_once(
        pose in pose_strategy(),
        name in "[a-z][a-z0-9_]{0,10}",
    ) {
        let wp = |motion| Waypoint {
            name: Some(name.clone()),
            pose,
            motion: Some(motion),
            configuration: None,
            reachable: None,
        };
        let program = Program::new(
            "twice",
            vec![Routine {
                name: "r".into(),
                waypoints: vec![wp(Motion::Joint), wp(Motion::Linear)],
            }],
        );
        let out = export(&program, Language::Rapid, &ExportSettings::default()).unwrap();
        prop_assert_eq!(out.files[0].text.matches("CONST robtarget").count(), 1);
    }
}
