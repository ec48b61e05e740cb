//! The library of bundled arms (`robots/`): every model loads and finds its closed-form solver,
//! round-trips 10,000 random poses through IK, has a catalogue entry whose data-sheet reach
//! matches the reach computed from its kinematics, and, where `rs-opw-kinematics` ships a preset
//! for the arm, agrees with that independent model on the geometry.

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use nextpose::kinematics::{
    DOF, Joints, SolverKind, bundled_robots_dir, computed_reach_mm, list_robots, load_catalog,
    pose_error,
};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rs_opw_kinematics::kinematic_traits::Kinematics;
use rs_opw_kinematics::kinematics_impl::OPWKinematics;
use rs_opw_kinematics::parameters::opw_kinematics::Parameters;

use crate::helpers::{random_joints, robot, round_trip};

/// Every bundled model, sorted by name, with the solver it must get.
const ARMS: [(&str, SolverKind); 18] = [
    ("abb_irb1200", SolverKind::Opw),
    ("abb_irb140", SolverKind::Opw),
    ("abb_irb1600", SolverKind::Opw),
    ("abb_irb2600", SolverKind::Opw),
    ("abb_irb4600", SolverKind::Opw),
    ("abb_irb6700", SolverKind::Opw),
    ("fanuc_lrmate200id", SolverKind::Opw),
    ("fanuc_m10ia", SolverKind::Opw),
    ("fanuc_m20ia", SolverKind::Opw),
    ("fanuc_r2000ic", SolverKind::Opw),
    ("kuka_kr10_r1100", SolverKind::Opw),
    ("kuka_kr16_2", SolverKind::Opw),
    ("kuka_kr210_r2700", SolverKind::Opw),
    ("kuka_kr6_r900", SolverKind::Opw),
    ("ur10e", SolverKind::Ur),
    ("ur16e", SolverKind::Ur),
    ("ur3e", SolverKind::Ur),
    ("ur5e", SolverKind::Ur),
];

#[test]
fn every_bundled_arm_loads_with_its_solver() {
    let models = list_robots(&bundled_robots_dir()).unwrap();
    let got: Vec<(&str, SolverKind)> = models.iter().map(|m| (m.name.as_str(), m.solver)).collect();
    assert_eq!(got, ARMS.to_vec());
    for m in &models {
        assert_eq!((m.root.as_str(), m.tip.as_str()), ("base_link", "tool0"));
        assert_eq!(m.joints.len(), DOF);
        for j in &m.joints {
            assert!(j.lower < j.upper && j.velocity > 0.0, "{}: {j:?}", m.name);
        }
    }
}

#[test]
fn the_catalogue_lists_exactly_the_bundled_arms() {
    let facts = load_catalog(&bundled_robots_dir()).unwrap();
    let mut names: Vec<&str> = facts.iter().map(|f| f.name.as_str()).collect();
    names.sort_unstable();
    let urdfs: Vec<&str> = ARMS.iter().map(|(n, _)| *n).collect();
    assert_eq!(names, urdfs);
    for f in &facts {
        let (maker, language) = match f.name.split('_').next() {
            Some("abb") => ("ABB", "rapid"),
            Some("kuka") => ("KUKA", "krl"),
            Some("fanuc") => ("FANUC", "fanuc"),
            _ => ("Universal Robots", "urscript"),
        };
        assert_eq!(f.maker, maker, "{}", f.name);
        assert_eq!(f.languages, vec![language.to_string()], "{}", f.name);
        assert!(f.payload_kg > 0.0 && f.reach_mm > 0.0, "{f:?}");
        assert!(!f.model.is_empty());
    }
}

/// The UR10e's data-sheet 1300 mm is not the flange at the stretched zero pose (1219 mm) but
/// the in-plane sum |a2| + |a3| + d5 = 1304 mm (robots/README.md); every other arm is within 3 %.
#[test]
fn computed_reach_matches_the_data_sheet() {
    let facts = load_catalog(&bundled_robots_dir()).unwrap();
    for f in &facts {
        let r = robot(&f.name);
        let computed = computed_reach_mm(&r);
        let off = (computed - f.reach_mm) / f.reach_mm;
        eprintln!(
            "{:18} computed {computed:7.1} mm, data sheet {:7.1} mm ({:+.2} %)",
            f.name,
            f.reach_mm,
            100.0 * off
        );
        if f.name == "ur10e" {
            let p = r.ur().unwrap().parameters();
            let in_plane = (p.a2.abs() + p.a3.abs() + p.d5) * 1000.0;
            assert!(
                (in_plane - f.reach_mm).abs() / f.reach_mm < 0.01,
                "{in_plane}"
            );
            assert!(off.abs() < 0.07, "{}: {computed} vs {}", f.name, f.reach_mm);
        } else {
            assert!(off.abs() < 0.03, "{}: {computed} vs {}", f.name, f.reach_mm);
        }
    }
}

macro_rules! round_trips {
    ($($test:ident: $name:literal, $seed:literal;)*) => {
        $(
            #[test]
            fn $test() {
                round_trip($name, $seed, 10_000);
            }
        )*
    };
}

round_trips! {
    ik_round_trip_abb_irb1200: "abb_irb1200", 101;
    ik_round_trip_abb_irb140: "abb_irb140", 1;
    ik_round_trip_abb_irb1600: "abb_irb1600", 103;
    ik_round_trip_abb_irb2600: "abb_irb2600", 104;
    ik_round_trip_abb_irb4600: "abb_irb4600", 105;
    ik_round_trip_abb_irb6700: "abb_irb6700", 106;
    ik_round_trip_fanuc_lrmate200id: "fanuc_lrmate200id", 107;
    ik_round_trip_fanuc_m10ia: "fanuc_m10ia", 108;
    ik_round_trip_fanuc_m20ia: "fanuc_m20ia", 109;
    ik_round_trip_fanuc_r2000ic: "fanuc_r2000ic", 110;
    ik_round_trip_kuka_kr10_r1100: "kuka_kr10_r1100", 111;
    ik_round_trip_kuka_kr16_2: "kuka_kr16_2", 2;
    ik_round_trip_kuka_kr210_r2700: "kuka_kr210_r2700", 113;
    ik_round_trip_kuka_kr6_r900: "kuka_kr6_r900", 114;
    ik_round_trip_ur10e: "ur10e", 115;
    ik_round_trip_ur16e: "ur16e", 116;
    ik_round_trip_ur3e: "ur3e", 117;
    ik_round_trip_ur5e: "ur5e", 3;
}

/// How an `rs-opw-kinematics` preset relates to our URDF: `ours(q) = Tz(−base_z) · preset(q) ·
/// Rot(flange)`, with the same joint values (every preset used here is in ROS-Industrial joint
/// coordinates, which for ABB and KUKA are the controller's axis values and for FANUC the raw
/// joints, J3 = controller J3 + J2, as our URDFs).
struct Preset {
    name: &'static str,
    params: Parameters,
    /// Height of the preset's base frame above ours (m): FANUC presets stand on the robot foot,
    /// our FANUC models on FANUC's World frame at the J2 height.
    base_z: f64,
    /// Our tool0 in the preset's flange frame.
    flange: UnitQuaternion<f64>,
}

fn presets() -> Vec<Preset> {
    let same = UnitQuaternion::identity();
    vec![
        Preset {
            name: "abb_irb1200",
            params: Parameters::irb1200_7_70(),
            base_z: 0.0,
            flange: same,
        },
        Preset {
            name: "abb_irb1600",
            params: Parameters::irb1600_6_120(),
            base_z: 0.0,
            flange: same,
        },
        Preset {
            name: "abb_irb2600",
            params: Parameters::irb2600_12_165(),
            base_z: 0.0,
            flange: same,
        },
        Preset {
            name: "abb_irb4600",
            params: Parameters::irb4600_60_205(),
            base_z: 0.0,
            flange: same,
        },
        Preset {
            name: "kuka_kr6_r900",
            params: Parameters::kuka_kr6_r900_2(),
            base_z: 0.0,
            flange: same,
        },
        Preset {
            name: "fanuc_m10ia",
            params: Parameters::fanuc_m10ia(),
            base_z: 0.450,
            flange: same,
        },
        Preset {
            name: "fanuc_m20ia",
            params: Parameters::fanuc_m20ia(),
            base_z: 0.525,
            flange: same,
        },
    ]
}

fn preset_fk(kin: &OPWKinematics, q: &Joints) -> Isometry3<f64> {
    let p = kin.forward(q);
    let (t, r) = (p.translation, p.rotation);
    Isometry3::from_parts(
        Translation3::new(t.x, t.y, t.z),
        UnitQuaternion::new_normalize(Quaternion::new(r.w, r.x, r.y, r.z)),
    )
}

#[test]
fn rs_opw_presets_agree_with_our_urdfs() {
    let mut rng = StdRng::seed_from_u64(31);
    for preset in presets() {
        let r = robot(preset.name);
        let kin = OPWKinematics::new(preset.params);
        let map = |q: &Joints| {
            Translation3::new(0.0, 0.0, -preset.base_z)
                * preset_fk(&kin, q)
                * Isometry3::from_parts(Translation3::identity(), preset.flange)
        };
        // The documented mapping holds at zero …
        let (dt, dr) = pose_error(&map(&[0.0; DOF]), &r.chain().fk(&[0.0; DOF]));
        assert!(
            dt < 1e-9 && dr < 1e-9,
            "{}: zero differs by {dt:e} m, {dr:e} rad",
            preset.name
        );
        // … and at random joints (within limits, and beyond them).
        let mut worst = 0.0f64;
        for i in 0..2000 {
            let q = if i % 2 == 0 {
                random_joints(&r, &mut rng)
            } else {
                std::array::from_fn(|_| rng.random_range(-PI..PI))
            };
            let (dt, dr) = pose_error(&map(&q), &r.chain().fk(&q));
            worst = worst.max(dt).max(dr);
        }
        eprintln!("{}: preset and URDF agree within {worst:.1e}", preset.name);
        assert!(worst < 1e-9, "{}: {worst:e}", preset.name);
    }
}

/// FANUC raw J3 (controller J3 + J2) stays between the folds of the forearm onto the upper arm
/// (−90° and +270°), so no pose has two J3 values (robots/README.md, FANUC J3).
#[test]
fn fanuc_raw_j3_stays_within_one_turn() {
    for (name, _) in ARMS.iter().filter(|(n, _)| n.starts_with("fanuc_")) {
        let r = robot(name);
        let j3 = &r.joints()[2];
        assert!(
            j3.lower >= -FRAC_PI_2 - 1e-9 && j3.upper <= 3.0 * FRAC_PI_2 + 1e-9,
            "{name}: {j3:?}"
        );
    }
}

/// Spot checks of the published geometry at poses that are easy to picture.
#[test]
fn zero_poses_match_the_published_geometry() {
    let at = |name: &str, q: &Joints| {
        let p = robot(name).fk(q);
        Vector3::from(p.position())
    };
    let near = |a: Vector3<f64>, b: [f64; 3]| (a - Vector3::from(b)).norm() < 1e-9;
    // ABB IRB 6700-205/2.80: J2 at (320, 0, 780); wrist 1280 above it and 1182.5 ahead, 200 up.
    assert!(near(
        at("abb_irb6700", &[0.0; DOF]),
        [320.0 + 1182.5 + 200.0, 0.0, 780.0 + 1280.0 + 200.0]
    ));
    // KUKA KR 210 R2700-2 at KUKA's home (A2 = −90°, A3 = +90°): upper arm up, forearm ahead.
    assert!(near(
        at(
            "kuka_kr210_r2700",
            &[0.0, -FRAC_PI_2, FRAC_PI_2, 0.0, 0.0, 0.0]
        ),
        [330.0 + 1220.0 + 215.0, 0.0, 645.0 + 1150.0 + 115.0]
    ));
    // FANUC M-20iA in World (J2 height): zero is (150 + 835 + 100, 0, 790 + 250).
    assert!(near(at("fanuc_m20ia", &[0.0; DOF]), [1085.0, 0.0, 1040.0]));
    // FANUC raw J3: J2 = 30° forward with joint_3 = 30° (controller J3 = 0) keeps the forearm
    // horizontal, so the wrist only moves with the upper arm.
    let j2 = 30f64.to_radians();
    let p = at("fanuc_m20ia", &[0.0, j2, j2, 0.0, 0.0, 0.0]);
    assert!(near(
        p,
        [
            150.0 + 790.0 * j2.sin() + 935.0,
            0.0,
            790.0 * j2.cos() + 250.0
        ]
    ));
    // UR10e at zero: flange at (a2 + a3, −(d4 + d6), d1 − d5).
    assert!(near(at("ur10e", &[0.0; DOF]), [-1184.25, -290.7, 60.85]));
}
