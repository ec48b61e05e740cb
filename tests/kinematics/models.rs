//! Robot models from `robots/`, FK against published geometry, IK round trips, reachability.

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use nextpose::engine::Pose;
use nextpose::kinematics::{
    DOF, Joints, KinematicsError, Mounting, Offer, ReachConfig, ReachPolicy, Reachability, Robot,
    SolverKind, Unreachable, bundled_robots_dir, check_reach, list_robots, load_robot, pose_error,
    pose_to_metres,
};
use nextpose::program::Language;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::helpers::{random_joints, robot};

fn assert_position_mm(pose: &Pose, expected: [f64; 3]) {
    let p = pose.position();
    for (i, e) in expected.iter().enumerate() {
        assert!((p[i] - e).abs() < 1e-9, "axis {i}: {} vs {e}", p[i]);
    }
}

#[test]
fn bundled_models_are_listed_with_their_solver() {
    // The three models this file tests; tests/robots.rs covers the whole library.
    let models: Vec<_> = list_robots(&bundled_robots_dir())
        .unwrap()
        .into_iter()
        .filter(|m| ANALYTIC.contains(&m.name.as_str()))
        .collect();
    let names: Vec<(&str, SolverKind)> =
        models.iter().map(|m| (m.name.as_str(), m.solver)).collect();
    assert_eq!(
        names,
        vec![
            ("abb_irb140", SolverKind::Opw),
            ("kuka_kr16_2", SolverKind::Opw),
            ("ur5e", SolverKind::Ur)
        ]
    );
    for m in &models {
        assert_eq!(m.joints.len(), 6);
        assert_eq!(m.tip, "tool0");
        for j in &m.joints {
            assert!(j.lower < j.upper && j.velocity > 0.0, "{}: {j:?}", m.name);
        }
    }
    let irb = &models[0];
    assert!((irb.joints[5].upper.to_degrees() - 400.0).abs() < 1e-6);
    assert!((irb.joints[2].lower.to_degrees() + 230.0).abs() < 1e-6);
    assert!(matches!(
        load_robot(&bundled_robots_dir(), "../Cargo"),
        Err(KinematicsError::UnknownRobot(_))
    ));
}

#[test]
fn irb140_fk_matches_published_geometry() {
    let r = robot("abb_irb140");
    // Zero: upper arm vertical, forearm horizontal, tool0 z along base +x.
    let zero = r.fk(&[0.0; DOF]);
    assert_position_mm(&zero, [70.0 + 380.0 + 65.0, 0.0, 352.0 + 360.0]);
    let z_axis = zero.rotation() * Vector3::z();
    assert!((z_axis - Vector3::x()).norm() < 1e-12);
    // J5 = 90°: flange points down.
    assert_position_mm(
        &r.fk(&[0.0, 0.0, 0.0, 0.0, FRAC_PI_2, 0.0]),
        [450.0, 0.0, 712.0 - 65.0],
    );
    // J1 = 90°: the whole arm turns to +y.
    assert_position_mm(
        &r.fk(&[FRAC_PI_2, 0.0, 0.0, 0.0, 0.0, 0.0]),
        [0.0, 515.0, 712.0],
    );
    // J3 = −90°: forearm straight up.
    assert_position_mm(
        &r.fk(&[0.0, 0.0, -FRAC_PI_2, 0.0, 0.0, 0.0]),
        [70.0, 0.0, 712.0 + 380.0 + 65.0],
    );
    let p = r.opw().unwrap().parameters();
    let got = [p.a1, p.a2, p.b, p.c1, p.c2, p.c3, p.c4];
    let want = [0.070, 0.0, 0.0, 0.352, 0.360, 0.380, 0.065];
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-12, "{got:?}");
    }
}

#[test]
fn ur5e_fk_matches_published_geometry() {
    let r = robot("ur5e");
    // Zero: arm stretched along −x; flange at (a2 + a3, −(d4 + d6), d1 − d5).
    assert_position_mm(&r.fk(&[0.0; DOF]), [-817.2, -232.9, 62.8]);
    // [0, −90°, 0, −90°, 0, 0]: arm straight up.
    assert_position_mm(
        &r.fk(&[0.0, -FRAC_PI_2, 0.0, -FRAC_PI_2, 0.0, 0.0]),
        [0.0, -232.9, 162.5 + 425.0 + 392.2 + 99.7],
    );
    let p = r.ur().unwrap().parameters();
    let got = [p.d1, p.a2, p.a3, p.d4, p.d5, p.d6];
    let want = [0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996];
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-12, "{got:?}");
    }
}

#[test]
fn kr16_fk_matches_published_geometry() {
    let r = robot("kuka_kr16_2");
    // KUKA zero: whole arm horizontal along +x.
    assert_position_mm(
        &r.fk(&[0.0; DOF]),
        [260.0 + 680.0 + 670.0 + 158.0, 0.0, 675.0 - 35.0],
    );
    // A2 = −90°, A3 = +90° (KUKA's usual home): upper arm up, forearm forward.
    assert_position_mm(
        &r.fk(&[0.0, -FRAC_PI_2, FRAC_PI_2, 0.0, 0.0, 0.0]),
        [260.0 + 670.0 + 158.0, 0.0, 675.0 + 680.0 - 35.0],
    );
}

#[test]
fn analytic_models_equal_the_urdf_chain() {
    let mut rng = StdRng::seed_from_u64(11);
    for name in ANALYTIC {
        let r = robot(name);
        let mut worst = 0.0f64;
        for _ in 0..2000 {
            let q = random_joints(&r, &mut rng);
            let model = match (r.opw(), r.ur()) {
                (Some(o), _) => o.fk(&q).unwrap(),
                (_, Some(u)) => u.fk(&q),
                _ => unreachable!(),
            };
            let (dt, dr) = pose_error(&model, &r.chain().fk(&q));
            worst = worst.max(dt).max(dr);
        }
        assert!(worst < 1e-12, "{name}: {worst:e}");
    }
}

#[test]
fn irb140_multi_turn_variants_are_enumerated() {
    let r = robot("abb_irb140");
    // J6 = 30° can also be 30° − 360° = −330° (within ±400°); J3 = 40° has no variant, but
    // J3 = −200° is reached only as a variant of the principal 160°.
    let q = [
        0.2,
        0.1,
        (-200.0f64).to_radians(),
        0.3,
        0.8,
        30f64.to_radians(),
    ];
    let solutions = r.ik(&r.fk(&q));
    let has = |v: &Joints| {
        solutions
            .iter()
            .any(|s| s.iter().zip(v).all(|(a, b)| (a - b).abs() < 1e-6))
    };
    assert!(has(&q));
    let mut q2 = q;
    q2[5] -= 2.0 * PI;
    assert!(has(&q2));
    assert!(solutions.iter().all(|s| r.within_limits(s)));
}

#[test]
fn poses_outside_the_reach_sphere_have_no_solution() {
    let mut rng = StdRng::seed_from_u64(5);
    for name in ANALYTIC {
        let r = robot(name);
        for _ in 0..500 {
            let dir = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            // 3.5 m: beyond every bundled arm's reach (the KR 16-2 reaches about 1.8 m).
            let rot = UnitQuaternion::from_euler_angles(
                rng.random_range(-PI..PI),
                rng.random_range(-PI..PI),
                rng.random_range(-PI..PI),
            );
            let far =
                Pose::from_isometry(Isometry3::from_parts(Translation3::from(dir * 3500.0), rot));
            assert!(r.ik(&far).is_empty());
            let reach = reach_at_origin(&r, &far, None);
            assert_eq!(reach.unreachable, Some(Unreachable::OutsideReach));
            assert!(reach.solutions.is_empty());
            assert_eq!(
                reach.offer(ReachPolicy::Withhold),
                Offer::Withhold {
                    why: Unreachable::OutsideReach
                }
            );
            assert_eq!(
                reach.offer(ReachPolicy::Flag),
                Offer::Flag {
                    why: Unreachable::OutsideReach
                }
            );
        }
    }
}

/// The arms with an analytic solver (OPW or UR) besides the URDF chain.
const ANALYTIC: [&str; 3] = ["abb_irb140", "kuka_kr16_2", "ur5e"];

/// The reach of `target` by `r` mounted at the origin, with the default reach settings.
fn reach_at_origin(r: &Robot, target: &Pose, hint: Option<&Joints>) -> Reachability {
    check_reach(
        r,
        &Mounting::default(),
        target,
        hint,
        &ReachConfig::default(),
    )
}

fn assert_no_nan(r: &Robot, target: &Isometry3<f64>) -> usize {
    let hint = [0.0; DOF];
    let solutions = r.ik_metres(target, Some(&hint));
    for s in &solutions {
        assert!(s.iter().all(|v| v.is_finite()), "{s:?}");
        let (dt, dr) = pose_error(&r.chain().fk(s), target);
        assert!(dt <= 1e-9 && dr <= 1e-9);
    }
    solutions.len()
}

#[test]
fn wrist_singularity_is_handled_without_nan() {
    let mut rng = StdRng::seed_from_u64(9);
    for name in ANALYTIC {
        let r = robot(name);
        let mut reported_singular = 0;
        for _ in 0..500 {
            let mut q = random_joints(&r, &mut rng);
            q[4] = 0.0;
            let target = r.chain().fk(&q);
            assert!(assert_no_nan(&r, &target) > 0, "{name}: {q:?}");
            let reach = reach_at_origin(&r, &r.fk(&q), Some(&q));
            let sigma = reach.sigma_min.unwrap();
            assert!(
                sigma.is_finite() && sigma < 1e-6,
                "{name}: σ_min {sigma} q {q:?} chosen {:?} all {:?}",
                reach.chosen,
                r.ik_principal(&target, Some(&q))
            );
            if let Some(Unreachable::Singular { sigma_min }) = reach.unreachable {
                assert!(sigma_min.is_finite());
                reported_singular += 1;
            }
        }
        assert_eq!(reported_singular, 500, "{name}");
    }
}

#[test]
fn shoulder_singularity_is_handled_without_nan() {
    // Wrist centre on the J1 axis, tool pointing up: J1 is free.
    for (name, c4) in [("abb_irb140", 0.065), ("kuka_kr16_2", 0.158)] {
        let r = robot(name);
        for z in [0.6, 0.9, 1.1] {
            let target = Isometry3::translation(0.0, 0.0, z + c4);
            assert_no_nan(&r, &target);
        }
    }
    // UR: wrist-2 centre at distance d4 from the base axis makes both shoulder solutions meet;
    // on the axis itself θ1 is undefined.
    let r = robot("ur5e");
    for rho in [0.1333, 0.0] {
        for z in [0.2, 0.5] {
            let target =
                Isometry3::translation(rho, 0.0, z) * Isometry3::translation(0.0, 0.0, 0.0996);
            assert_no_nan(&r, &target);
            let reach = reach_at_origin(&r, &nextpose::kinematics::metres_to_pose(&target), None);
            if let Some(s) = reach.sigma_min {
                assert!(s.is_finite());
            }
        }
    }
}

#[test]
fn reach_picks_the_solution_nearest_the_previous_joints_in_a_cell() {
    let r = robot("abb_irb140");
    let base = Pose::new([1200.0, -300.0, 150.0], [0.9238795, 0.0, 0.0, 0.3826834]).unwrap();
    let tool = Pose::new([0.0, 0.0, 180.0], [0.9659258, 0.0, 0.2588190, 0.0]).unwrap();
    let cell = Mounting::new(base, tool);
    let mut rng = StdRng::seed_from_u64(21);
    for _ in 0..300 {
        let mut q = random_joints(&r, &mut rng);
        q[4] = q[4].signum() * q[4].abs().max(0.3); // stay clear of the wrist singularity
        let flange = r.fk(&q);
        let target = Pose::from_isometry(base.isometry() * flange.isometry() * tool.isometry());
        // Singularity classification is tested elsewhere; here every in-limit pose is reachable.
        let config = ReachConfig {
            min_singular_value: 0.0,
            ..ReachConfig::default()
        };
        let reach = check_reach(&r, &cell, &target, Some(&q), &config);
        assert!(reach.is_reachable(), "{reach:?}");
        assert_eq!(reach.offer(ReachPolicy::Withhold), Offer::Offer);
        let chosen = reach.chosen.unwrap();
        for (a, b) in chosen.iter().zip(&q) {
            assert!((a - b).abs() < 1e-6, "{chosen:?} vs {q:?}");
        }
        let margin = reach.limiting_joint.clone().unwrap();
        let expected = r
            .joints()
            .iter()
            .zip(&q)
            .map(|(j, v)| j.margin(*v))
            .fold(f64::INFINITY, f64::min);
        assert!((margin.margin_rad - expected).abs() < 1e-6);
        assert_eq!(margin.name, r.joints()[margin.joint].name);
        assert!(reach.sigma_min.unwrap() > 0.0 && reach.manipulability.unwrap() > 0.0);
        // The flange target is base⁻¹ · target · tool⁻¹ (mm).
        let (dt, dr) = pose_error(
            &pose_to_metres(&flange),
            &pose_to_metres(&Pose::try_from(reach.flange).unwrap()),
        );
        assert!(dt < 1e-9 && dr < 1e-9);
    }
}

#[test]
fn joint_limit_is_reported_with_the_blocking_joint() {
    let r = robot("abb_irb140");
    // Tool folded back at J5 = ±150°: beyond ±115° in the configurations that reach it.
    let mut rng = StdRng::seed_from_u64(4);
    let mut by_joint = [0usize; DOF];
    for _ in 0..500 {
        let mut q = random_joints(&r, &mut rng);
        q[4] = if rng.random_bool(0.5) { 2.6 } else { -2.6 };
        let reach = reach_at_origin(&r, &r.fk(&q), None);
        match reach.unreachable {
            Some(Unreachable::JointLimit {
                joint,
                name,
                excess_rad,
            }) => {
                assert_eq!(name, r.joints()[joint].name);
                assert!(excess_rad > 0.0);
                assert!(reach.solutions.is_empty());
                by_joint[joint] += 1;
            }
            None | Some(Unreachable::Singular { .. }) => {
                // Another configuration reaches it within limits.
                assert!(reach.solutions.iter().all(|s| r.within_limits(s)));
            }
            Some(Unreachable::OutsideReach) => panic!("an FK pose is always in reach"),
        }
    }
    assert!(by_joint[4] > 0, "{by_joint:?}");
}

#[test]
fn malformed_urdf_gives_typed_errors() {
    let joint = |name: &str, parent: &str, child: &str, kind: &str| {
        format!(
            r#"<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>
               <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>
               <limit lower="-1" upper="1" effort="0" velocity="1"/></joint>"#
        )
    };
    let links = |n: usize| {
        (0..n)
            .map(|i| format!(r#"<link name="l{i}"/>"#))
            .collect::<String>()
    };
    let chain = |n: usize| {
        (1..n)
            .map(|i| {
                joint(
                    &format!("j{i}"),
                    &format!("l{}", i - 1),
                    &format!("l{i}"),
                    "revolute",
                )
            })
            .collect::<String>()
    };
    let doc = |body: String| format!(r#"<robot name="t">{body}</robot>"#);

    assert!(matches!(
        Robot::from_urdf_str("t", "not xml"),
        Err(KinematicsError::Urdf(_))
    ));
    // Five revolute joints.
    assert!(matches!(
        Robot::from_urdf_str("t", &doc(links(6) + &chain(6))),
        Err(KinematicsError::JointCount { found: 5, .. })
    ));
    // A second moving branch.
    let branched = links(8) + &chain(7) + &joint("extra", "l3", "l7", "revolute");
    let err = Robot::from_urdf_str("t", &doc(branched)).unwrap_err();
    assert!(
        matches!(
            err,
            KinematicsError::NotSerial { .. } | KinematicsError::SeveralParents(_)
        ),
        "{err}"
    );
    let branched = links(9)
        + &chain(7)
        + &joint("extra", "l3", "l7", "revolute")
        + &joint("x2", "l7", "l8", "fixed");
    let err = Robot::from_urdf_str("t", &doc(branched)).unwrap_err();
    assert!(matches!(err, KinematicsError::NotSerial { .. }), "{err}");
    // A prismatic joint.
    let prismatic = links(7) + &chain(6) + &joint("p", "l5", "l6", "prismatic");
    assert!(matches!(
        Robot::from_urdf_str("t", &doc(prismatic)),
        Err(KinematicsError::UnsupportedJointType { .. })
    ));
    // Unknown link.
    let unknown = links(7) + &chain(7) + &joint("u", "l6", "nowhere", "fixed");
    assert!(matches!(
        Robot::from_urdf_str("t", &doc(unknown)),
        Err(KinematicsError::UnknownLink { .. })
    ));
    // `<limit>` without velocity: urdf-rs refuses the file.
    let no_velocity = doc(links(2)
        + r#"<joint name="a" type="revolute"><parent link="l0"/><child link="l1"/><limit lower="-1" upper="1" effort="0"/></joint>"#);
    assert!(matches!(
        Robot::from_urdf_str("t", &no_velocity),
        Err(KinematicsError::Urdf(_))
    ));
    // Six revolute joints all about z: a serial chain, but no closed-form solver fits it.
    assert!(matches!(
        Robot::from_urdf_str("t", &doc(links(7) + &chain(7))),
        Err(KinematicsError::UnsupportedGeometry(_))
    ));
    // A missing file.
    assert!(matches!(
        Robot::from_urdf_file(std::path::Path::new("/nonexistent/x.urdf")),
        Err(KinematicsError::Io { .. })
    ));
}

#[test]
fn replay_report_gains_reachability_figures() {
    use nextpose::engine::EngineConfig;
    use nextpose::kinematics::placement::{HeuristicSetup, ReachSetup};
    use nextpose::replay::methods::RepeatLast;
    use nextpose::replay::report::RunConfig;
    use nextpose::replay::{Method, Program, Routine, replay_all};

    // A RAPID program: a square of 100 mm steps, tool pointing down, then one far outlier.
    // repeat_last's guesses follow the square; after the last point it guesses beyond reach.
    let down = [0.0, 0.0, 1.0, 0.0];
    let mut waypoints: Vec<Pose> = [
        [0.0, 0.0],
        [100.0, 0.0],
        [100.0, 100.0],
        [0.0, 100.0],
        [0.0, 0.0],
    ]
    .iter()
    .map(|[x, y]| Pose::new([*x, *y, 0.0], down).unwrap())
    .collect();
    waypoints.push(Pose::new([2000.0, 0.0, 0.0], down).unwrap());
    let program = |language: Language| Program {
        name: format!("square_{language}"),
        source: "square.json".into(),
        language: Some(language),
        repo: None,
        arm: None,
        routines: vec![Routine {
            name: "main".into(),
            waypoints: waypoints.clone(),
        }],
    };
    let mut methods: Vec<Box<dyn Method>> = vec![Box::new(RepeatLast::new())];
    // Before the library: an IRB 140 for RAPID programs, at the median heuristic.
    let mut config = RunConfig::new("default", EngineConfig::default(), 1.0);
    config.reachability = Some(ReachSetup::Heuristic(HeuristicSetup::default()));
    let report = replay_all(
        &[program(Language::Rapid), program(Language::Fanuc)],
        &mut methods,
        config,
    )
    .expect("the bundled arm loads");
    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["config"]["reachability"]["placement"], "heuristic");
    assert_eq!(json["config"]["reachability"]["robot"], "abb_irb140");
    assert_eq!(json["programs"][0]["arm"]["robot"], "abb_irb140");
    let rapid = &json["programs"][0]["methods"]["repeat_last"];
    // Guesses with n ≥ 2: after points 2, 3, 4 (in reach) and 5 (moves on to 0,−100: in reach).
    assert_eq!(rapid["reachable_pct"], 100.0);
    // Taught with n ≥ 2: points 3, 4, 5 in reach, the outlier 2 m away not.
    assert_eq!(rapid["taught_reachable_pct"], 75.0);
    // No arm stands for FANUC programs here.
    let fanuc = &json["programs"][1]["methods"]["repeat_last"];
    assert!(fanuc["reachable_pct"].is_null() && fanuc["taught_reachable_pct"].is_null());
    assert!(json["programs"][1]["arm"].is_null());
    // Existing keys are untouched.
    assert!(rapid["offered_pct"].is_number() && rapid["us_per_waypoint"].is_number());

    // The default: each program gets the smallest arm of its maker that reaches all of it,
    // where the layout search stands it, so the outlier is in reach too.
    let report = replay_all(
        &[program(Language::Rapid), program(Language::Fanuc)],
        &mut methods,
        RunConfig::new("default", EngineConfig::default(), 1.0),
    )
    .expect("the library loads");
    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["config"]["reachability"]["placement"], "fitted");
    for (p, maker) in [(0, "abb_"), (1, "fanuc_")] {
        let arm = &json["programs"][p]["arm"];
        assert!(arm["robot"].as_str().unwrap().starts_with(maker), "{arm}");
        assert_eq!(arm["chosen"], "fitted", "{arm}");
        assert_eq!(
            (arm["reached"].clone(), arm["waypoints"].clone()),
            (6.into(), 6.into())
        );
        let m = &json["programs"][p]["methods"]["repeat_last"];
        assert_eq!(m["taught_reachable_pct"], 100.0);
    }
    // The IRB 140 and IRB 1200 are too small for a 2 m span: a larger arm was needed.
    assert_ne!(json["programs"][0]["arm"]["robot"], "abb_irb140");
    assert!(report.placements.is_none(), "no cache was asked for");

    // With a placement cache: the first run searches and keeps both placements, the second
    // reads them; the arms and the reach figures are those of the run without it.
    let dir = tempfile::tempdir().unwrap();
    let reach_figures = |json: &serde_json::Value| -> Vec<serde_json::Value> {
        (0..2)
            .flat_map(|p| {
                let m = &json["programs"][p]["methods"]["repeat_last"];
                [
                    json["programs"][p]["arm"].clone(),
                    m["reachable_pct"].clone(),
                    m["taught_reachable_pct"].clone(),
                ]
            })
            .collect()
    };
    for (hits, searched) in [(0, 2), (2, 0)] {
        let mut run = RunConfig::new("default", EngineConfig::default(), 1.0);
        run.placement_cache = Some(dir.path().join("placements"));
        let cached = replay_all(
            &[program(Language::Rapid), program(Language::Fanuc)],
            &mut methods,
            run,
        )
        .expect("the library loads");
        let used = cached.placements.expect("a cache was asked for");
        assert_eq!(
            (used.hits, used.searched, used.unwritten),
            (hits, searched, 0)
        );
        let cached = serde_json::to_value(&cached).unwrap();
        assert_eq!(reach_figures(&cached), reach_figures(&json));
    }
}

#[test]
fn robots_can_be_shared_between_threads() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Robot>();
    assert_send_sync::<Mounting>();
    assert_send_sync::<nextpose::kinematics::Reachability>();
}

#[test]
fn reachability_serialises_with_its_reason() {
    let r = robot("abb_irb140");
    let far = Pose::new([5000.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
    let reach = reach_at_origin(&r, &far, None);
    let json = serde_json::to_value(&reach).unwrap();
    assert_eq!(json["unreachable"]["reason"], "outside_reach");
    assert_eq!(
        serde_json::to_value(reach.offer(ReachPolicy::Flag)).unwrap()["action"],
        "flag"
    );
    let model = serde_json::to_value(r.model()).unwrap();
    assert_eq!(model["solver"], "opw");
    assert_eq!(model["joints"][5]["name"], "joint_6");
}
