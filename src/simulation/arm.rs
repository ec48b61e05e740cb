//! A simulated six-joint arm in a work cell: where it is (joints and TCP), and how long a jog
//! takes.
//!
//! The arm is a [`Robot`] (URDF chain, all IK solutions) placed in a [`Mounting`]. It moves in two
//! ways, as a pendant moves a real arm:
//!
//! - [`Arm::joint_move`]: an automatic move to a pose (the pendant's "go to" while a button is
//!   held, which is how an accepted suggestion is reached). Every joint moves at once; the move
//!   takes as long as its slowest joint at the jog fraction of its URDF `<limit velocity>`, and
//!   never less than the TCP speed limit allows.
//! - [`Arm::cartesian_jog`]: the operator's jog in the work frame, in small Cartesian steps
//!   (linear in position, spherical in orientation). Each step is solved by IK for the solution
//!   nearest the current joints, and takes as long as the slowest of the TCP speed, the TCP
//!   rotation speed and each joint's speed limit allow, so the arm slows down near a
//!   singularity, where small TCP steps need large joint steps.
//!
//! A pose the arm cannot reach is still "reached" in the simulation (the operator records it
//! and the service stores it, flagged), but its time then comes from the TCP limits only, and
//! the arm's joints are unknown until it is back in reach. [`Jog::reachable`] says so.

use nalgebra::{Isometry3, Translation3};

use crate::engine::Pose;
use crate::kinematics::urdf::{DOF, Joints};
use crate::kinematics::{Mounting, Robot, pose_to_metres};

/// Speed limits of jogging. See docs/simulation.md, "The arm", for the sources.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct JogLimits {
    /// TCP speed, mm/s. ISO 10218-1 limits manual (T1) jogging to 250 mm/s.
    pub tcp_mm_s: f64,
    /// TCP rotation speed, rad/s (our assumption: about 30°/s).
    pub tcp_rad_s: f64,
    /// Fraction of each joint's URDF velocity limit used while jogging (our assumption).
    pub joint_fraction: f64,
    /// Largest Cartesian step of a jog, mm.
    pub step_mm: f64,
    /// Largest rotation step of a jog, rad.
    pub step_rad: f64,
}

impl Default for JogLimits {
    fn default() -> JogLimits {
        JogLimits {
            tcp_mm_s: 250.0,
            tcp_rad_s: 0.5,
            joint_fraction: 0.25,
            step_mm: 10.0,
            step_rad: 0.05,
        }
    }
}

/// What one move of the arm took.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jog {
    /// Simulated seconds.
    pub time_s: f64,
    /// TCP distance, mm.
    pub distance_mm: f64,
    /// TCP rotation, rad.
    pub angle_rad: f64,
    /// Whether the target (and for a Cartesian jog every step) was within the arm's reach.
    pub reachable: bool,
}

/// The simulated arm.
#[derive(Debug, Clone)]
pub struct Arm {
    robot: Robot,
    cell: Mounting,
    limits: JogLimits,
    /// Per-joint speed while jogging, rad/s.
    joint_speed: [f64; DOF],
    /// Current joints, `None` while the arm is at a pose it cannot reach.
    joints: Option<Joints>,
    /// Current TCP pose in the work frame, mm.
    tcp: Pose,
}

impl Arm {
    /// An arm of `robot` placed by `cell`, standing at `start` (work frame).
    pub fn new(robot: Robot, cell: Mounting, limits: JogLimits, start: &Pose) -> Arm {
        let mut joint_speed = [f64::INFINITY; DOF];
        for (s, j) in joint_speed.iter_mut().zip(robot.joints()) {
            if j.velocity.is_finite() && j.velocity > 0.0 {
                *s = j.velocity * limits.joint_fraction;
            }
        }
        let mut arm = Arm {
            robot,
            cell,
            limits,
            joint_speed,
            joints: None,
            tcp: *start,
        };
        arm.joints = arm.solve(start, None);
        arm
    }

    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    pub fn cell(&self) -> &Mounting {
        &self.cell
    }

    pub fn limits(&self) -> &JogLimits {
        &self.limits
    }

    /// The TCP pose in the work frame.
    pub fn tcp(&self) -> &Pose {
        &self.tcp
    }

    /// The joints, when the arm is within reach.
    pub fn joints(&self) -> Option<&Joints> {
        self.joints.as_ref()
    }

    /// Whether the arm can put its TCP at `target` (work frame).
    pub fn reaches(&self, target: &Pose) -> bool {
        self.solve(target, self.joints.as_ref()).is_some()
    }

    /// The IK solution for a TCP pose nearest `near` (or the range centres).
    fn solve(&self, target: &Pose, near: Option<&Joints>) -> Option<Joints> {
        let flange = self.cell.flange_target(target);
        let tip: Isometry3<f64> = pose_to_metres(&flange);
        let solutions = self.robot.ik_metres(&tip, near);
        let reference = match near {
            Some(q) => *q,
            None => {
                let mut c = [0.0; DOF];
                for (ci, j) in c.iter_mut().zip(self.robot.joints()) {
                    *ci = 0.5 * (j.lower + j.upper);
                }
                c
            }
        };
        solutions
            .into_iter()
            .min_by(|a, b| joint_distance(a, &reference).total_cmp(&joint_distance(b, &reference)))
    }

    /// Time the TCP limits allow for a move of `d` mm and `a` rad.
    fn tcp_time(&self, d: f64, a: f64) -> f64 {
        (d / self.limits.tcp_mm_s).max(a / self.limits.tcp_rad_s)
    }

    /// Time the joint limits allow between two joint vectors.
    fn joint_time(&self, from: &Joints, to: &Joints) -> f64 {
        from.iter()
            .zip(to)
            .zip(&self.joint_speed)
            .map(|((a, b), s)| (a - b).abs() / s)
            .fold(0.0, f64::max)
    }

    /// Moves every joint at once to the solution for `target` nearest the current joints.
    pub fn joint_move(&mut self, target: &Pose) -> Jog {
        let d = self.tcp.distance_to(target);
        let a = self.tcp.angle_to(target);
        let next = self.solve(target, self.joints.as_ref());
        let mut time = self.tcp_time(d, a);
        if let (Some(from), Some(to)) = (self.joints.as_ref(), next.as_ref()) {
            time = time.max(self.joint_time(from, to));
        }
        self.joints = next;
        self.tcp = *target;
        Jog {
            time_s: time,
            distance_mm: d,
            angle_rad: a,
            reachable: next.is_some(),
        }
    }

    /// Jogs the TCP to `target` along a straight line (and a great circle of orientations) in
    /// steps of at most [`JogLimits::step_mm`] and [`JogLimits::step_rad`].
    pub fn cartesian_jog(&mut self, target: &Pose) -> Jog {
        let from = self.tcp;
        let d = from.distance_to(target);
        let a = from.angle_to(target);
        let steps = ((d / self.limits.step_mm).max(a / self.limits.step_rad))
            .ceil()
            .max(1.0) as usize;
        let (p0, p1) = (from.position(), target.position());
        let (r0, r1) = (from.rotation(), target.rotation());
        let mut time = 0.0;
        let mut reachable = true;
        let mut previous = from;
        for i in 1..=steps {
            let t = i as f64 / steps as f64;
            let pose = if i == steps {
                *target
            } else {
                let rotation = r0.try_slerp(&r1, t, 1e-9).unwrap_or(r1);
                Pose::from_isometry(Isometry3::from_parts(
                    Translation3::from(p0 + (p1 - p0) * t),
                    rotation,
                ))
            };
            let next = self.solve(&pose, self.joints.as_ref());
            let mut step = self.tcp_time(previous.distance_to(&pose), previous.angle_to(&pose));
            if let (Some(q0), Some(q1)) = (self.joints.as_ref(), next.as_ref()) {
                step = step.max(self.joint_time(q0, q1));
            }
            reachable &= next.is_some();
            time += step;
            self.joints = next;
            previous = pose;
        }
        self.tcp = *target;
        Jog {
            time_s: time,
            distance_mm: d,
            angle_rad: a,
            reachable,
        }
    }
}

fn joint_distance(a: &Joints, b: &Joints) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{bundled_robots_dir, load_robot};

    fn irb140() -> Robot {
        load_robot(&bundled_robots_dir(), "abb_irb140").unwrap()
    }

    /// A TCP pose in front of the IRB 140 (base at the work origin), tool pointing down.
    fn pose(x: f64, y: f64, z: f64) -> Pose {
        Pose::new([x, y, z], [0.0, 0.0, 1.0, 0.0]).unwrap()
    }

    #[test]
    fn a_reachable_jog_is_limited_by_the_tcp_speed_far_from_singularities() {
        let mut arm = Arm::new(
            irb140(),
            Mounting::default(),
            JogLimits::default(),
            &pose(450.0, 0.0, 400.0),
        );
        assert!(arm.joints().is_some());
        let jog = arm.cartesian_jog(&pose(450.0, 100.0, 400.0));
        assert!(jog.reachable);
        assert!((jog.distance_mm - 100.0).abs() < 1e-9);
        // 100 mm at 250 mm/s is 0.4 s; joints may slow it a little, never speed it up.
        assert!(jog.time_s >= 0.4 - 1e-12, "{}", jog.time_s);
        assert!(jog.time_s < 1.0, "{}", jog.time_s);
        assert_eq!(arm.tcp(), &pose(450.0, 100.0, 400.0));
        // The arm is where FK says it is.
        let q = arm.joints().copied().unwrap();
        let flange = arm.robot().fk(&q);
        assert!(flange.distance_to(&pose(450.0, 100.0, 400.0)) < 1e-6);
    }

    #[test]
    fn a_joint_move_takes_the_slowest_joint_time() {
        let limits = JogLimits::default();
        let mut arm = Arm::new(
            irb140(),
            Mounting::default(),
            limits,
            &pose(450.0, 0.0, 400.0),
        );
        let q0 = arm.joints().copied().unwrap();
        // The same pose mirrored across the base: joint 1 turns by about π/2.
        let jog = arm.joint_move(&pose(0.0, 450.0, 400.0));
        let q1 = arm.joints().copied().unwrap();
        let j1 = (q1[0] - q0[0]).abs() / (arm.robot().joints()[0].velocity * limits.joint_fraction);
        assert!(jog.reachable);
        assert!(jog.time_s >= j1 - 1e-12);
        assert!(j1 > 1.0, "{j1}");
    }

    #[test]
    fn an_unreachable_target_is_timed_by_the_tcp_limits_and_reported() {
        let mut arm = Arm::new(
            irb140(),
            Mounting::default(),
            JogLimits::default(),
            &pose(450.0, 0.0, 400.0),
        );
        let jog = arm.cartesian_jog(&pose(3000.0, 0.0, 400.0));
        assert!(!jog.reachable);
        assert!(arm.joints().is_none());
        // At least the TCP limit's 2550 mm / 250 mm/s; the steps still in reach may be slowed
        // by the joints.
        assert!(jog.time_s >= 2550.0 / 250.0 - 1e-9, "{}", jog.time_s);
        assert!(jog.time_s < 2.0 * 2550.0 / 250.0, "{}", jog.time_s);
        // Back in reach, the arm finds its joints again.
        let jog = arm.joint_move(&pose(450.0, 0.0, 400.0));
        assert!(jog.reachable);
        assert!(arm.joints().is_some());
    }
}
