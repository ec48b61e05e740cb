//! Kinematics cost per predicted pose: all IK solutions, and the full reachability check (IK,
//! limits and multi-turn variants, nearest solution, Jacobian SVD, limit margin) that the
//! service runs on every offered prediction. Poses are random reachable targets in a cell with
//! a base placement and a tool.
//!
//! Run: `cargo bench --bench kinematics` (figures in docs/results/performance.md).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nextpose::engine::Pose;
use nextpose::kinematics::{
    DOF, Joints, Mounting, ReachConfig, Robot, bundled_robots_dir, check_reach, load_robot,
};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// `n` (previous joints, target TCP pose in the work frame) pairs of random in-limit joints.
fn targets(robot: &Robot, cell: &Mounting, n: usize) -> Vec<(Joints, Pose)> {
    let mut rng = StdRng::seed_from_u64(17);
    (0..n)
        .map(|_| {
            let mut q = [0.0; DOF];
            for (v, j) in q.iter_mut().zip(robot.joints()) {
                *v = rng.random_range(j.lower..=j.upper);
            }
            let flange = robot.fk(&q);
            let target = Pose::from_isometry(
                cell.base.isometry() * flange.isometry() * cell.tool.isometry(),
            );
            // The previous waypoint's joints: near, not equal.
            let mut prev = q;
            for v in prev.iter_mut() {
                *v += rng.random_range(-0.05..0.05);
            }
            (prev, target)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let base = Pose::new([800.0, 200.0, 0.0], [0.9238795, 0.0, 0.0, 0.3826834]).unwrap();
    let tool = Pose::new([0.0, 0.0, 150.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
    let cell = Mounting::new(base, tool);
    let config = ReachConfig::default();
    for name in ["abb_irb140", "kuka_kr16_2", "ur5e"] {
        let robot = load_robot(&bundled_robots_dir(), name).unwrap();
        let poses = targets(&robot, &cell, 1000);
        let mut i = 0;
        c.bench_function(&format!("{name}/ik_all"), |b| {
            b.iter(|| {
                i = (i + 1) % poses.len();
                black_box(robot.ik(&cell.flange_target(&poses[i].1)))
            })
        });
        c.bench_function(&format!("{name}/reach_check"), |b| {
            b.iter(|| {
                i = (i + 1) % poses.len();
                let (prev, target) = &poses[i];
                black_box(check_reach(&robot, &cell, target, Some(prev), &config))
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
