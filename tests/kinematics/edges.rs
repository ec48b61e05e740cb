//! The edge cases an outside check of the kinematics against Pinocchio found (issue 31): a
//! spherical wrist a hair from singular that lost its solution, joint limits compared exactly,
//! `near` joints the arm cannot take, and a singularity measure that mixed metres and radians.

use nalgebra::Vector3;
use nextpose::engine::Pose;
use nextpose::kinematics::{
    DOF, Joints, KinematicsError, Mounting, ReachConfig, Robot, SolverKind, Unreachable,
    bundled_robots_dir, check_reach, load_robots,
};
use rand::SeedableRng;
use rand::rngs::StdRng;
use regex::Regex;

use crate::helpers::{random_joints, robot};

fn close(a: &Joints, b: &Joints, tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < tol)
}

#[test]
fn an_irb140_wrist_a_hair_from_singular_keeps_its_solution() {
    // The case of the issue: J5 = 1e-7 rad, answered `joint_limit` with no solution.
    let r = robot("abb_irb140");
    let near = [
        -2.6775575925003015,
        0.16416852764406853,
        -3.7724917735131176,
        0.34134322828349495,
        1e-07,
        -1.8439007192210193,
    ];
    let pose = Pose::new(
        [240.168964651026, 120.200819894966, 506.923464701681],
        [0.260237232119, 0.47194904077, 0.70869495961, 0.455293465975],
    )
    .unwrap();
    let at = r.fk(&near);
    assert!(at.distance_to(&pose) < 1e-9 && at.angle_to(&pose) < 1e-9);
    let reach = check_reach(
        &r,
        &Mounting::default(),
        &pose,
        Some(&near),
        &ReachConfig::default(),
    );
    // A wrist 1e-7 rad from singular is singular; it is not beyond a limit.
    assert!(
        matches!(reach.unreachable, Some(Unreachable::Singular { .. })),
        "{reach:?}"
    );
    let chosen = reach.chosen.expect("the arm's own solution");
    assert!(close(&chosen, &near, 1e-5), "{chosen:?}");
    let got = r.fk(&chosen);
    assert!(
        got.distance_to(&pose) < 1e-6 && got.angle_to(&pose) < 1e-9,
        "{} mm, {} rad",
        got.distance_to(&pose),
        got.angle_to(&pose)
    );
}

#[test]
fn spherical_wrists_near_singular_keep_their_solutions() {
    // Between |J5| ≈ 1e-9 and 1e-6 rad the solver's J4 and J6 were too far off for the FK
    // check, and the exact-pole candidate (J5 = 0) too: half the poses lost their branch.
    let mut rng = StdRng::seed_from_u64(31);
    let robots = load_robots(&bundled_robots_dir()).unwrap();
    let opw: Vec<&Robot> = robots
        .iter()
        .filter(|r| r.solver_kind() == SolverKind::Opw)
        .collect();
    assert_eq!(opw.len(), 14);
    for r in opw {
        for _ in 0..40 {
            let q0 = random_joints(r, &mut rng);
            for j5 in [1e-10, -1e-9, 3e-9, 1e-8, -1e-7, 1e-6, -1e-5] {
                let mut q = q0;
                q[4] = j5;
                let target = r.chain().fk(&q);
                for hint in [None, Some(&q)] {
                    // Every solution is FK-checked; one must be the arm's own branch (joints 1,
                    // 2, 3 and 5: J4 and J6 alone are barely determined next to the pole).
                    let solutions = r.ik_metres(&target, hint);
                    assert!(
                        solutions
                            .iter()
                            .any(|s| [0, 1, 2, 4].iter().all(|&i| (s[i] - q[i]).abs() < 1e-6)),
                        "{}: J5 {j5:e}, hint {}: {q:?} not among {solutions:?}",
                        r.name(),
                        hint.is_some()
                    );
                }
            }
        }
    }
}

#[test]
fn a_pose_on_a_joint_limit_keeps_its_solution_on_the_limit() {
    // The case of the issue: an IRB 6700 with joint_1 at its upper limit, 2.9670597284 rad.
    // Round-off put about one pose in five a hair beyond it, and its solution was dropped.
    let mut rng = StdRng::seed_from_u64(6700);
    let r = robot("abb_irb6700");
    for _ in 0..100 {
        let mut q = random_joints(&r, &mut rng);
        q[0] = 2.9670597284;
        q[4] = q[4].signum() * q[4].abs().max(0.3);
        let solutions = r.ik(&r.fk(&q));
        assert!(
            solutions
                .iter()
                .any(|s| s[0] <= r.joints()[0].upper && close(s, &q, 1e-9)),
            "{q:?} not among {solutions:?}"
        );
    }
    // Every arm, every joint at either limit: the generating joints are among the solutions,
    // and every solution is within the limits exactly (clamped onto a limit it reached).
    for r in load_robots(&bundled_robots_dir()).unwrap() {
        for _ in 0..10 {
            for (i, j) in r.joints().iter().enumerate() {
                for limit in [j.lower, j.upper] {
                    let mut q = random_joints(&r, &mut rng);
                    // Clear of the wrist singularity, where J4 and J6 are not determined (a UR
                    // J5 limit of ±360° is one).
                    q[4] = q[4].signum() * q[4].abs().max(0.3);
                    q[i] = limit;
                    if q[4].sin().abs() < 0.3 {
                        continue;
                    }
                    let solutions = r.ik(&r.fk(&q));
                    assert!(
                        solutions.iter().any(|s| close(s, &q, 1e-6)),
                        "{}: {q:?} not among {} solutions",
                        r.name(),
                        solutions.len()
                    );
                    for s in &solutions {
                        for (v, j) in s.iter().zip(r.joints()) {
                            assert!(j.lower <= *v && *v <= j.upper, "{}: {s:?}", r.name());
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn joints_the_arm_cannot_take_are_named() {
    let r = robot("kuka_kr210_r2700");
    let (lower, upper) = (r.joints()[1].lower, r.joints()[1].upper);
    // On a limit, or past it by round-off, is a place the arm can be.
    assert_eq!(r.check_joints(&[0.0, lower, 0.0, 0.0, 0.5, 0.0]), Ok(()));
    assert_eq!(
        r.check_joints(&[0.0, upper + 1e-12, 0.0, 0.0, 0.5, 0.0]),
        Ok(())
    );
    // J2 = 0 is outside the KR 210's −140°…−5°.
    let err = r.check_joints(&[0.0, 0.0, 0.0, 0.0, 0.5, 0.0]).unwrap_err();
    assert!(
        matches!(err, KinematicsError::JointOutOfRange { joint: 2, .. }),
        "{err}"
    );
    let err = r.check_joints(&[1e308; DOF]).unwrap_err();
    assert_eq!(
        err.to_string(),
        "joint 1 (joint_a1) is 1.000e308 rad, outside its range -3.2289 to 3.2289 rad"
    );
    assert_eq!(
        r.check_joints(&[f64::NAN; DOF]),
        Err(KinematicsError::NonFiniteJoints)
    );
}

/// The reach of the pose `q` puts the flange at, asked from `q` (the arm stands there).
fn reach_from(r: &Robot, q: &Joints) -> nextpose::kinematics::Reachability {
    check_reach(
        r,
        &Mounting::default(),
        &r.fk(q),
        Some(q),
        &ReachConfig::default(),
    )
}

/// A bundled arm's URDF with every joint origin moved `factor` times as far: the same arm,
/// scaled (or the same arm in another unit of length).
fn scaled_copy(name: &str, factor: f64) -> Robot {
    let path = bundled_robots_dir().join(format!("{name}.urdf"));
    let urdf = std::fs::read_to_string(path).unwrap();
    let origin = Regex::new(r#"(<origin[^>]*\bxyz=")([^"]*)(")"#).unwrap();
    let scaled = origin.replace_all(&urdf, |c: &regex::Captures<'_>| {
        let xyz: Vec<String> = c[2]
            .split_whitespace()
            .map(|v| (v.parse::<f64>().unwrap() * factor).to_string())
            .collect();
        format!("{}{}{}", &c[1], xyz.join(" "), &c[3])
    });
    Robot::from_urdf_str(&format!("{name}_x{factor}"), &scaled).unwrap()
}

#[test]
fn the_singularity_measure_does_not_depend_on_the_arm_size() {
    let mut rng = StdRng::seed_from_u64(3);
    for name in ["ur3e", "abb_irb140"] {
        let arm = robot(name);
        for factor in [0.25, 4.0] {
            let copy = scaled_copy(name, factor);
            for _ in 0..50 {
                let q = random_joints(&arm, &mut rng);
                let (a, b) = (reach_from(&arm, &q), reach_from(&copy, &q));
                let (sa, sb) = (a.sigma_min.unwrap(), b.sigma_min.unwrap());
                assert!(
                    (sa - sb).abs() <= 1e-6 * sa.max(1e-3),
                    "{name} ×{factor}: σ_min {sa} vs {sb} at {q:?}"
                );
                assert_eq!(a.is_reachable(), b.is_reachable(), "{name} ×{factor}");
            }
        }
    }
}

/// Share of random poses (each with the arm standing there) the reach check calls singular.
fn singular_share(r: &Robot, n: usize, rng: &mut StdRng) -> f64 {
    let singular = (0..n)
        .filter(|_| {
            let q = random_joints(r, rng);
            matches!(
                reach_from(r, &q).unreachable,
                Some(Unreachable::Singular { .. })
            )
        })
        .count();
    singular as f64 / n as f64
}

#[test]
fn random_poses_of_a_ur3e_are_rarely_singular() {
    // Metres against radians called a UR3e singular at 10 % of random poses, twice the share of
    // the UR10e, the same design at 2.4 times the size; in reach units the shares agree (each
    // about 6 %: its joints turn ±360°, so many poses lie near one of its singularities).
    let mut rng = StdRng::seed_from_u64(12);
    let small = singular_share(&robot("ur3e"), 2000, &mut rng);
    let large = singular_share(&robot("ur10e"), 2000, &mut rng);
    assert!(small < 0.075, "UR3e: {small}");
    assert!(
        (small / large - 1.0).abs() < 0.25,
        "UR3e {small} vs UR10e {large}"
    );
}

/// The point where the axes of joints 5 and 6 of a UR arm meet, and its distance from the
/// plane of the axes of joints 1 and 2: zero at the shoulder singularity.
fn ur_shoulder_offset(r: &Robot, q: &Joints) -> f64 {
    let (axes, _) = r.chain().axes_at(q);
    let [(w1, o1), (w2, _), _, _, (w5, o5), (w6, o6)] = axes;
    let n = w5.cross(&w6);
    let wrist = o5 + w5 * ((o6 - o5).cross(&w6).dot(&n) / n.norm_squared());
    let normal: Vector3<f64> = w1.cross(&w2).normalize();
    (wrist - o1).dot(&normal)
}

#[test]
fn true_singularities_are_still_singular() {
    let singular = |r: &Robot, q: &Joints| {
        matches!(
            reach_from(r, q).unreachable,
            Some(Unreachable::Singular { .. })
        )
    };
    let mut rng = StdRng::seed_from_u64(5);
    // A wrist within 0.1° of singular, on every arm.
    for r in load_robots(&bundled_robots_dir()).unwrap() {
        for _ in 0..20 {
            let mut q = random_joints(&r, &mut rng);
            q[4] = 0.1f64.to_radians();
            assert!(singular(&r, &q), "{}: {q:?}", r.name());
        }
    }
    let ur3e = robot("ur3e");
    let mut shoulders = 0;
    for _ in 0..20 {
        let mut q = random_joints(&ur3e, &mut rng);
        q[4] = q[4].signum() * q[4].abs().max(0.5);
        // The elbow stretched out.
        let mut stretched = q;
        stretched[2] = 0.0;
        assert!(singular(&ur3e, &stretched), "{stretched:?}");
        // The wrist point in the plane of axes 1 and 2, found by bisection over joint 4 where
        // it crosses the plane.
        let offset = |q4: f64| {
            let mut s = q;
            s[3] = q4;
            ur_shoulder_offset(&ur3e, &s)
        };
        let grid: Vec<f64> = (0..=64)
            .map(|k| -std::f64::consts::PI + k as f64 * std::f64::consts::TAU / 64.0)
            .collect();
        let Some(pair) = grid
            .windows(2)
            .find(|w| offset(w[0]).signum() != offset(w[1]).signum())
        else {
            continue;
        };
        let (mut a, mut b) = (pair[0], pair[1]);
        for _ in 0..60 {
            let m = 0.5 * (a + b);
            if offset(m).signum() == offset(a).signum() {
                a = m;
            } else {
                b = m;
            }
        }
        let mut shoulder = q;
        shoulder[3] = 0.5 * (a + b);
        assert!(offset(shoulder[3]).abs() < 1e-12);
        assert!(singular(&ur3e, &shoulder), "{shoulder:?}");
        shoulders += 1;
    }
    assert!(shoulders >= 5, "{shoulders} shoulder singularities found");
    // Away from all three, the same arm is not singular.
    let clear = [0.3, -1.2, 1.4, -1.0, 1.2, 0.4];
    assert!(!singular(&ur3e, &clear));
}
