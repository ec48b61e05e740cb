//! The edge cases an outside check of the kinematics against Pinocchio found (issue 31): a
//! spherical wrist a hair from singular that lost its solution, joint limits compared exactly,
//! and `near` joints the arm cannot take.

use nextpose::engine::Pose;
use nextpose::kinematics::{
    DOF, Joints, KinematicsError, Mounting, ReachConfig, Robot, SolverKind, Unreachable,
    bundled_robots_dir, check_reach, load_robots,
};
use rand::SeedableRng;
use rand::rngs::StdRng;

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
