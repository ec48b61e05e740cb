//! The KRL reader on small programs and on a milling cell's `.src` and `.dat`.

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::import::{CircleRole, SkipReason, parse_files};
use crate::program::{Configuration, KrlStatusTurn, Motion};

/// A KRL Status and Turn, as a configuration.
fn st(status: i32, turn: i32) -> Option<Configuration> {
    Some(Configuration::Krl(KrlStatusTurn {
        status: Some(status),
        turn: Some(turn),
    }))
}

const SRC: &str = "&ACCESS RVP\nDEF demo( )\n;FOLD PTP HOME\nPTP XHOME C_PTP\n;ENDFOLD\nPTP XP1 C_PTP\nLIN xp2 ; comment\nCIRC XP1, {X 10, Y 0, Z 0, A 0, B 0, C 0} C_DIS\nLIN_REL {Z 5}\nLIN {X 1}\nPTP XJ\nEND\n";
const DAT: &str = "DEFDAT demo\nDECL E6POS XP1={x 100.0,y 0.0,z 50.0,a 90.0,b 0.0,c 180.0,s 2,t 35,e1 0.0}\nDECL E6POS XP2={x 1,y 2,z 3,a 0,b 0,c 0,s 6,t 50}\nDECL E6AXIS XJ={a1 0,a2 -90,a3 90,a4 0,a5 0,a6 0}\nENDDAT\n";

#[test]
fn reads_src_with_its_dat() {
    let report = parse_files(&[("R1/demo.src", SRC), ("R1/DEMO.dat", DAT)]).unwrap();
    let (r, at) = (
        &report.programs[0].program.routines[0],
        &report.programs[0].origins[0],
    );
    let names: Vec<_> = r
        .waypoints
        .iter()
        .zip(&at.waypoints)
        .map(|(w, o)| (w.name.as_deref(), o.instruction, w.motion))
        .collect();
    let (j, l, c) = (
        Some(Motion::Joint),
        Some(Motion::Linear),
        Some(Motion::Circular),
    );
    assert_eq!(
        names,
        [
            (Some("XP1"), "PTP", j),
            (Some("xp2"), "LIN", l),
            (Some("XP1"), "CIRC", c),
            (Some("{X 10, Y 0, Z 0, A 0, B 0, C 0}"), "CIRC", c),
            (Some("{Z 5}"), "LIN_REL", l)
        ]
    );
    assert!((r.waypoints[4].pose.position().z - 5.0).abs() < 1e-12);
    assert_eq!(r.waypoints[0].configuration, st(2, 35));
    // A position that gives neither S nor T has no configuration; one S alone is kept.
    assert_eq!(r.waypoints[3].configuration, None);
    let only_s =
        "DEF s()\nLIN {X 1,Y 2,Z 3,A 0,B 0,C 0,S 6}\nLIN {X 2,Y 2,Z 3,A 0,B 0,C 0,T 3}\nEND\n";
    let only = parse_files(&[("s.src", only_s)]).unwrap();
    let configurations: Vec<_> = only.programs[0].program.routines[0]
        .waypoints
        .iter()
        .map(|w| w.configuration.clone())
        .collect();
    let krl = |status, turn| Some(Configuration::Krl(KrlStatusTurn { status, turn }));
    assert_eq!(configurations, [krl(Some(6), None), krl(None, Some(3))]);
    let rot = r.waypoints[0].pose.rotation();
    // A=90 about z, C=180 about x: tool x along base y, tool z down.
    assert!((rot * Vector3::x() - Vector3::y()).norm() < 1e-12);
    assert!((rot * Vector3::z() + Vector3::z()).norm() < 1e-12);
    let reasons: Vec<_> = report.skipped.iter().map(|s| s.reason).collect();
    assert_eq!(
        reasons,
        [
            SkipReason::JointMove,
            SkipReason::ComputedAtRunTime,
            SkipReason::JointMove
        ]
    );
}

#[test]
fn a_src_pairs_with_the_dat_of_its_folder_and_stem() {
    // Stems compare case-insensitively, folders exactly; a `.dat` with no `.src` is skipped.
    let report = parse_files(&[
        ("R2/demo.dat", DAT),
        ("R1/Demo.SRC", SRC),
        ("R1/other.dat", DAT),
        ("R1/demo.DAT", DAT),
    ])
    .unwrap();
    assert_eq!(report.programs.len(), 1);
    assert_eq!(report.programs[0].program.waypoint_count(), 5);
    let data_only: Vec<_> = report
        .skipped
        .iter()
        .filter(|s| s.reason == SkipReason::DataOnly)
        .map(|s| s.file.as_str())
        .collect();
    assert_eq!(data_only, ["R2/demo.dat", "R1/other.dat"]);
    // In another folder the `.dat` does not pair: XP1 is then unresolved.
    let report = parse_files(&[("R1/demo.src", SRC), ("R2/demo.dat", DAT)]).unwrap();
    assert!(
        report
            .skipped
            .iter()
            .any(|s| s.reason == SkipReason::UnresolvedName)
    );
}

/// A KRL position `[X, Y, Z, A, B, C]` as an isometry, built here from KUKA's definition
/// (`Rz(A)·Ry(B)·Rx(C)`, degrees) rather than by the importer's code.
fn krl_frame(v: [f64; 6]) -> Isometry3<f64> {
    let [x, y, z, a, b, c] = v;
    let turn = |axis: Unit<Vector3<f64>>, deg: f64| {
        UnitQuaternion::from_axis_angle(&axis, deg.to_radians())
    };
    Isometry3::from_parts(
        Translation3::new(x, y, z),
        turn(Vector3::z_axis(), a) * turn(Vector3::y_axis(), b) * turn(Vector3::x_axis(), c),
    )
}

const MILL_SRC: &str = include_str!("../../../tests/fixtures/import/krl/mill_pocket.src");
const MILL_DAT: &str = include_str!("../../../tests/fixtures/import/krl/mill_pocket.dat");

#[test]
fn a_milling_cell_moves_to_frame_array_elements_and_their_geometric_products() {
    // The numbers of mill_pocket.dat, composed with nalgebra: `a:b` is `T_a · T_b`.
    let work = [
        [10.0, -5.0, 5.0, 0.0, 0.0, 0.0],
        [130.0, -5.0, 5.0, 0.0, 0.0, 0.0],
        [250.0, -5.0, 5.0, 0.0, 0.0, 0.0],
        [370.0, -5.0, 5.0, 0.0, 0.0, 0.0],
        [10.0, 245.0, 5.0, 180.0, 0.0, 0.0],
        [130.0, 245.0, 5.0, 180.0, 0.0, 0.0],
        [250.0, 245.0, 5.2, 179.5, 0.3, -0.4],
        [370.0, 245.0, 4.8, -178.0, -0.2, 0.6],
        [190.0, 120.0, 80.0, 90.0, 0.0, 0.0],
    ]
    .map(krl_frame);
    let w = |i: usize| work[i - 1];
    let down = krl_frame([0.0, 0.0, 0.0, 0.0, 0.0, 180.0]);
    let slot = krl_frame([0.0, 4.0, 0.0, 0.0, 0.0, 0.0]);
    let cut = [
        [0.0, 4.0, 0.0, 0.0, 0.0, 180.0],
        [20.0, 24.0, -1.5, 0.0, 0.0, 180.0],
        [40.0, 4.0, -1.5, 0.0, 0.0, 180.0],
    ]
    .map(krl_frame);
    let home = krl_frame([400.0, 0.0, 650.0, 0.0, 90.0, 0.0]);
    let frame = None;
    let (via, to) = (Some(CircleRole::Via), Some(CircleRole::To));
    let expected = [
        ("xHome", "PTP", None, home, st(2, 35)),
        ("lfWorkPos[1]", "LIN", None, w(1), frame.clone()),
        (
            "lfWorkPos[1]:{X 0.0,Y 4.0,Z 0,A 0.0,B 0.0,C 0.0}",
            "LIN",
            None,
            w(1) * slot,
            frame.clone(),
        ),
        ("lfWorkPos[2]", "LIN", None, w(2), frame.clone()),
        (
            "lfWorkPos[2]:{X 0.0,Y 4.0,Z 0,A 0.0,B 0.0,C 0.0}",
            "LIN",
            None,
            w(2) * slot,
            frame.clone(),
        ),
        (
            "lfWorkPos[3]:fToolDown",
            "LIN",
            None,
            w(3) * down,
            frame.clone(),
        ),
        (
            "lfWorkPos[4]:fToolDown:{X 20.0,Y 0.0,Z -1.5,A 0.0,B 0.0,C 0.0}",
            "LIN",
            None,
            w(4) * down * krl_frame([20.0, 0.0, -1.5, 0.0, 0.0, 0.0]),
            frame.clone(),
        ),
        (
            "lfWorkPos[5]:xCut[1]",
            "CIRC",
            via,
            w(5) * cut[0],
            st(6, 50),
        ),
        ("lfWorkPos[5]:xCut[2]", "CIRC", to, w(5) * cut[1], st(6, 50)),
        (
            "lfWorkPos[ 6 ]:xCut[3]",
            "LIN",
            None,
            w(6) * cut[2],
            st(6, 18),
        ),
        ("lfWorkPos[7]", "LIN", None, w(7), frame.clone()),
        ("lfWorkPos[8]", "LIN", None, w(8), frame.clone()),
        (
            "lfWorkPos[9]:fToolDown",
            "PTP",
            None,
            w(9) * down,
            frame.clone(),
        ),
        ("xHome", "PTP", None, home, st(2, 35)),
    ];
    let report = parse_files(&[
        ("cell/mill_pocket.src", MILL_SRC),
        ("cell/mill_pocket.dat", MILL_DAT),
    ])
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(report.skipped.is_empty(), "{:?}", report.skipped);
    let (r, at) = (
        &report.programs[0].program.routines[0],
        &report.programs[0].origins[0],
    );
    assert_eq!(r.waypoints.len(), expected.len());
    let got = r.waypoints.iter().zip(&at.waypoints);
    for ((got, origin), (name, instruction, role, pose, config)) in got.zip(&expected) {
        assert_eq!(
            (got.name.as_deref(), origin.instruction, origin.role),
            (Some(*name), *instruction, *role)
        );
        assert_eq!(&got.configuration, config, "{name}");
        let iso = got.pose.isometry();
        let mm = (iso.translation.vector - pose.translation.vector).norm();
        let rad = iso.rotation.angle_to(&pose.rotation);
        assert!(mm < 1e-9 && rad < 1e-9, "{name}: {mm:e} mm, {rad:e} rad");
    }
}

#[test]
fn array_elements_known_only_at_run_time_are_skipped_with_the_reason() {
    let dat = "DEFDAT cell\nDECL FRAME f[4], g[2,2]\nf[1]={X 1,Y 2,Z 3,A 0,B 0,C 0}\nf[2]={X 4,Y 5,Z 6,A 0,B 0,C 0}\ng[2,1]={X 7,Y 8,Z 9,A 90,B 0,C 0}\nDECL E6AXIS ax[2]\nax[1]={A1 0,A2 -90,A3 90,A4 0,A5 0,A6 0}\nENDDAT\n";
    let src = "DEF cell( )\nDECL INT i\nLIN f[1]\nLIN g[2,1]\nLIN f[i]\nLIN f[3]\nLIN h[1]\nLIN f[2]:{X 5}\nPTP ax[1]\nLIN f[1]:ax[1]\nLIN_REL f[2]\nEND\n";
    let report = parse_files(&[("cell.src", src), ("cell.dat", dat)]).unwrap();
    let r = &report.programs[0].program.routines[0];
    let names: Vec<_> = r.waypoints.iter().map(|w| w.name.as_deref()).collect();
    assert_eq!(names, [Some("f[1]"), Some("g[2,1]"), Some("f[2]")]);
    // `LIN_REL f[2]` moves by f[2] from the previous waypoint, g[2,1].
    let p = r.waypoints[2].pose.position();
    assert!((p - Vector3::new(11.0, 13.0, 15.0)).norm() < 1e-12, "{p}");
    let skipped: Vec<_> = report
        .skipped
        .iter()
        .map(|s| (s.text.as_str(), s.reason))
        .collect();
    assert_eq!(
        skipped,
        [
            ("f[i]", SkipReason::ComputedAtRunTime),
            ("f[3]", SkipReason::ComputedAtRunTime),
            ("h[1]", SkipReason::UnresolvedName),
            ("f[2]:{X 5}", SkipReason::ComputedAtRunTime),
            ("ax[1]", SkipReason::JointMove),
            ("f[1]:ax[1]", SkipReason::ComputedAtRunTime),
        ]
    );
    // A malformed element in the data list is an error naming its line, as a declaration.
    let broken = dat.replace("f[2]={X 4,Y 5,", "f[2]={X 4,Y ,");
    let err = parse_files(&[("cell.src", src), ("cell.dat", &broken)]).unwrap_err();
    assert!(err.to_string().starts_with("cell.dat:4:"), "{err}");
}

#[test]
fn broken_aggregate_is_an_error() {
    let dat = DAT.replace("y 2,", "y ,");
    let err = parse_files(&[("demo.src", SRC), ("demo.dat", &dat)]).unwrap_err();
    assert!(err.to_string().starts_with("demo.dat:3:"), "{err}");
}
