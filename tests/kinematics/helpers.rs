//! What the kinematics tests share: a bundled arm, random joints within its limits, and the
//! IK round trip.

use nextpose::kinematics::{DOF, Joints, Robot, bundled_robots_dir, load_robot};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// A bundled arm.
pub fn robot(name: &str) -> Robot {
    load_robot(&bundled_robots_dir(), name).expect("bundled robot loads")
}

/// Joints drawn uniformly within the arm's limits.
pub fn random_joints(robot: &Robot, rng: &mut StdRng) -> Joints {
    let mut q = [0.0; DOF];
    for (v, j) in q.iter_mut().zip(robot.joints()) {
        *v = rng.random_range(j.lower..=j.upper);
    }
    q
}

/// Every solution reproduces the pose within 1e-6 mm / 1e-9 rad and lies within limits, and
/// the generating joints are among the solutions.
pub fn round_trip(name: &str, seed: u64, n: usize) {
    let r = robot(name);
    let mut rng = StdRng::seed_from_u64(seed);
    let (mut total, mut max_solutions, mut worst_mm, mut worst_rad) =
        (0usize, 0usize, 0.0f64, 0.0f64);
    for _ in 0..n {
        let q = random_joints(&r, &mut rng);
        let target = r.fk(&q);
        let solutions = r.ik(&target);
        assert!(!solutions.is_empty(), "{name}: no solution for {q:?}");
        total += solutions.len();
        max_solutions = max_solutions.max(solutions.len());
        let mut nearest = f64::INFINITY;
        for s in &solutions {
            assert!(s.iter().all(|v| v.is_finite()));
            assert!(r.within_limits(s), "{name}: {s:?} outside limits");
            let got = r.fk(s);
            let mm = got.distance_to(&target);
            let rad = got.angle_to(&target);
            worst_mm = worst_mm.max(mm);
            worst_rad = worst_rad.max(rad);
            assert!(
                mm <= 1e-6 && rad <= 1e-9,
                "{name}: {s:?} misses by {mm:e} mm, {rad:e} rad"
            );
            let d = s
                .iter()
                .zip(&q)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            nearest = nearest.min(d);
        }
        assert!(
            nearest < 1e-6,
            "{name}: generating {q:?} not among {solutions:?}"
        );
    }
    eprintln!(
        "{name}: {n} poses, {:.1} solutions on average (max {max_solutions}), worst {worst_mm:.1e} mm / {worst_rad:.1e} rad",
        total as f64 / n as f64
    );
}
