//! Arm configuration from a joint vector: which of the inverse-kinematics branches a pose was
//! reached with, in the terms robot controllers use to pick a branch — and the converse, picking
//! the IK solution that has a given configuration.
//!
//! A spherical-wrist arm (our OPW arms) reaches a tool pose with up to eight principal joint
//! vectors: wrist centre in front of or behind axis 1 ([`Shoulder`]), elbow up or down
//! ([`Elbow`]), and axis 5 positive or negative ([`Wrist`]). Axes with more than 360° of range
//! add multi-turn variants, which controllers tell apart by the quadrant or the turn of axes 1,
//! 4 and 6. [`ArmConfiguration`] holds the three branch flags, the quadrants `⌊q/90°⌋` of axes
//! 1, 4, 6 and the sign of every axis, so that each controller's notation (the program
//! model's [`Configuration`], [`ArmConfiguration::written`]) follows from it:
//!
//! - **ABB RAPID `confdata`** ([`ArmConfiguration::rapid`]): `cf1`, `cf4`, `cf6` are the
//!   quadrant numbers of axes 1, 4, 6 (`0` for 0…90°, `1` for 90…180°, `-1` for −90…0°, …);
//!   `cfx` numbers the eight branches of a serial arm: `cfx = 4·[wrist centre behind axis 1]
//!   + 2·[wrist centre behind the lower arm] + [axis 5 negative]` (0 = in front / in front /
//!   positive … 7 = behind / behind / negative). Source: ABB, *Technical reference manual —
//!   RAPID Instructions, Functions and Data types*, data type `confdata` (the cfx table for
//!   serial-link robots); the quadrant reading also in RobotStudio's API reference,
//!   `ABB.Robotics.RobotStudio.Stations.ConfigurationData` ("the quadrant of axis 1 …").
//! - **KUKA KRL Status and Turn** ([`ArmConfiguration::krl`]): Status bit 0 is 0 in the basic
//!   area and 1 in the overhead area — the sign of the x of the wrist root point (where the wrist
//!   axes meet) in the A1 coordinate system, the robot root frame turned with axis 1; bit 1 is
//!   the position of A3 relative to the angle φ at which the wrist root point lies on the line
//!   through A2 and A3 (1 for A3 ≥ φ, i.e. the elbow up); bit 2 is 1 when A5 < 0. Turn bit `i` is
//!   1 when axis `i + 1` is negative. Source: KUKA, *KUKA System Software 8 — Operating and
//!   Programming Instructions for System Integrators*, "Status" and "Turn" (as quoted in the
//!   robot-forum.com threads "x value of wrist root point" and "KUKA status bit flip/no-flip").
//! - **FANUC `CONFIG : 'N U T, t1, t4, t6'`** ([`ArmConfiguration::fanuc`]): wrist `N`
//!   (no flip) / `F` (flip, axis 5 negative), elbow `U` / `D`, arm `T` (front, the wrist centre
//!   in front of J1) / `B` (back), then the turn numbers of J1, J4, J6: `0` for −180°…180°, `1`
//!   for 180°…540°, `-1` for −540°…−180°. Sources: onerobotics.com, "The perils of six-axis
//!   robots" (configuration strings); industrialmonitordirect.com, "FANUC robot configuration
//!   from joint angles" (F/N from the sign of J5). FANUC's own manual was not at hand: the sign
//!   convention of J5 for flip is the one those pages give, not checked on a controller.
//!
//! The flags are computed from the chain's geometry, not from per-brand angle thresholds: the
//! wrist centre is where axes 4 and 5 meet; "in front of axis 1" is the side of the plane
//! through axis 1 normal to the arm plane (the x of the wrist centre in the A1 frame); "elbow
//! up" is the side of the line through axes 2 and 3 the wrist centre is on, oriented so that the
//! arm's zero pose (upper arm up, forearm forward) is up. That is ABB's "relative to the lower
//! arm" and KUKA's A3 ≥ φ at once. Exactly on a boundary (a singular pose: wrist centre on axis
//! 1, arm stretched, axis 5 at zero) the flag is the "front / up / no flip" side.
//!
//! UR arms have no spherical wrist and their controllers take joint positions (or the IK
//! solution nearest the current joints) rather than configuration flags, so
//! [`configuration`] refuses them ([`ConfigurationError::NotSphericalWrist`]).
//!
//! Pure computation: no I/O.

use std::f64::consts::FRAC_PI_2;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::urdf::{DOF, Joints};
use super::{Robot, SolverKind};
use crate::program::{Configuration, KrlStatusTurn, Language, RapidConfdata};

/// Where the wrist centre is relative to axis 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Shoulder {
    /// In front of axis 1 (ABB "in front of", KUKA basic area, FANUC `T`).
    Front,
    /// Behind axis 1 (ABB "behind", KUKA overhead area, FANUC `B`).
    Back,
}

/// Which side of the lower arm (the line through axes 2 and 3) the wrist centre is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Elbow {
    /// The side of the zero pose (ABB "in front of the lower arm", KUKA A3 ≥ φ, FANUC `U`).
    Up,
    /// The other side (ABB "behind the lower arm", KUKA A3 < φ, FANUC `D`).
    Down,
}

/// The sign of axis 5.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Wrist {
    /// Axis 5 ≥ 0 (FANUC `N`).
    NoFlip,
    /// Axis 5 < 0 (FANUC `F`).
    Flip,
}

/// The configuration of a six-axis spherical-wrist arm at a joint vector, brand-neutral.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ArmConfiguration {
    pub shoulder: Shoulder,
    pub elbow: Elbow,
    pub wrist: Wrist,
    /// Quadrant numbers `⌊q/90°⌋` of axes 1, 4 and 6 (the turn information controllers use).
    pub quadrants: [i32; 3],
    /// Bit `i` set when axis `i + 1` is negative (KUKA's Turn needs all six).
    pub negative_axes: u8,
}

/// Why a configuration cannot be computed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigurationError {
    /// The arm has no spherical wrist (a UR arm): its controller uses no configuration flags.
    #[error(
        "robot {0} has no spherical wrist: its controller takes joint positions, not configuration flags"
    )]
    NotSphericalWrist(String),
}

/// The quadrant number `⌊q / 90°⌋` of a joint value in radians.
pub fn quadrant(q: f64) -> i32 {
    (q / FRAC_PI_2).floor() as i32
}

/// The FANUC turn number of a joint value in radians: `⌊(q + 180°) / 360°⌋`, i.e. 0 for
/// −180°…180°. It depends only on the quadrant, which is why [`ArmConfiguration`] keeps those.
pub fn turn_of_quadrant(quadrant: i32) -> i32 {
    (quadrant + 2).div_euclid(4)
}

/// Closest point on line `(o1, w1)` to line `(o2, w2)` (they meet for a spherical wrist).
fn meeting_point(
    o1: &Vector3<f64>,
    w1: &Vector3<f64>,
    o2: &Vector3<f64>,
    w2: &Vector3<f64>,
) -> Vector3<f64> {
    let n = w1.cross(w2);
    let nn = n.norm_squared();
    if nn < 1e-12 {
        return *o2;
    }
    let t1 = (o2 - o1).cross(w2).dot(&n) / nn;
    o1 + w1 * t1
}

/// The configuration of `robot` at joints `q` (radians, the controller's axis values).
pub fn configuration(robot: &Robot, q: &Joints) -> Result<ArmConfiguration, ConfigurationError> {
    if robot.solver_kind() != SolverKind::Opw {
        return Err(ConfigurationError::NotSphericalWrist(
            robot.name().to_string(),
        ));
    }
    let chain = robot.chain();
    // Orientation conventions from the zero pose: axis 1 counted "up", axis 2's direction as
    // the arm plane's normal (OPW arms have axis 1 vertical and axis 2 along ±y at zero).
    let (zero, _) = chain.axes_at(&[0.0; DOF]);
    let sign = |v: f64| if v < 0.0 { -1.0 } else { 1.0 };
    let s1 = sign(zero[0].0.z);
    let s2 = sign(zero[1].0.y);
    let (axes, _) = chain.axes_at(q);
    let [(w1, o1), (w2, o2), (_, o3), (w4, o4), (w5, o5), _] = axes;
    let wc = meeting_point(&o4, &w4, &o5, &w5);
    let up = w1 * s1;
    let normal = w2 * s2;
    let forward = normal.cross(&up);
    let shoulder = if (wc - o1).dot(&forward) >= 0.0 {
        Shoulder::Front
    } else {
        Shoulder::Back
    };
    let elbow = if (o3 - o2).cross(&(wc - o2)).dot(&normal) >= 0.0 {
        Elbow::Up
    } else {
        Elbow::Down
    };
    let wrist = if q[4] >= 0.0 {
        Wrist::NoFlip
    } else {
        Wrist::Flip
    };
    let negative_axes = q
        .iter()
        .enumerate()
        .filter(|(_, v)| **v < 0.0)
        .fold(0u8, |bits, (i, _)| bits | (1 << i));
    Ok(ArmConfiguration {
        shoulder,
        elbow,
        wrist,
        quadrants: [quadrant(q[0]), quadrant(q[3]), quadrant(q[5])],
        negative_axes,
    })
}

impl ArmConfiguration {
    /// Whether two configurations name the same IK solution: the same branch and the same
    /// quadrants of axes 1, 4, 6 (the signs of axes 2, 3, 5 are not a branch choice).
    pub fn same_solution(&self, other: &ArmConfiguration) -> bool {
        self.shoulder == other.shoulder
            && self.elbow == other.elbow
            && self.wrist == other.wrist
            && self.quadrants == other.quadrants
    }

    /// ABB's `cfx` branch number, 0–7.
    pub fn cfx(&self) -> i32 {
        4 * i32::from(self.shoulder == Shoulder::Back)
            + 2 * i32::from(self.elbow == Elbow::Down)
            + i32::from(self.wrist == Wrist::Flip)
    }

    /// RAPID `confdata`.
    pub fn rapid(&self) -> RapidConfdata {
        RapidConfdata {
            cf1: self.quadrants[0],
            cf4: self.quadrants[1],
            cf6: self.quadrants[2],
            cfx: self.cfx(),
        }
    }

    /// KRL Status and Turn (both given).
    pub fn krl(&self) -> KrlStatusTurn {
        let status = i32::from(self.shoulder == Shoulder::Back)
            | (i32::from(self.elbow == Elbow::Up) << 1)
            | (i32::from(self.wrist == Wrist::Flip) << 2);
        KrlStatusTurn {
            status: Some(status),
            turn: Some(i32::from(self.negative_axes & 0b11_1111)),
        }
    }

    /// The FANUC configuration string as written in a `/POS` entry, without the quotes:
    /// `N U T, 0, 0, 0`.
    pub fn fanuc(&self) -> String {
        let wrist = match self.wrist {
            Wrist::NoFlip => 'N',
            Wrist::Flip => 'F',
        };
        let elbow = match self.elbow {
            Elbow::Up => 'U',
            Elbow::Down => 'D',
        };
        let arm = match self.shoulder {
            Shoulder::Front => 'T',
            Shoulder::Back => 'B',
        };
        let [t1, t4, t6] = self.quadrants.map(turn_of_quadrant);
        format!("{wrist} {elbow} {arm}, {t1}, {t4}, {t6}")
    }

    /// The configuration in `language`'s notation, as a program in it states it.
    pub fn written(&self, language: Language) -> Configuration {
        match language {
            Language::Rapid => Configuration::Rapid(self.rapid()),
            Language::Krl => Configuration::Krl(self.krl()),
            Language::Fanuc => Configuration::Fanuc(self.fanuc()),
        }
    }
}

/// The solution among `solutions` (e.g. [`Robot::ik`]'s) that has configuration `wanted`, if
/// any: the controller's choice when it is given that configuration.
pub fn pick_solution(
    robot: &Robot,
    wanted: &ArmConfiguration,
    solutions: &[Joints],
) -> Option<Joints> {
    solutions
        .iter()
        .copied()
        .find(|q| configuration(robot, q).is_ok_and(|c| c.same_solution(wanted)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{bundled_robots_dir, load_robot, load_robots};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn deg(v: [f64; 6]) -> Joints {
        v.map(f64::to_radians)
    }

    #[test]
    fn quadrants_and_turns() {
        assert_eq!(quadrant(0.0), 0);
        assert_eq!(quadrant(100f64.to_radians()), 1);
        assert_eq!(quadrant(-10f64.to_radians()), -1);
        assert_eq!(quadrant(-190f64.to_radians()), -3);
        assert_eq!(quadrant(390f64.to_radians()), 4);
        let turn = |d: f64| turn_of_quadrant(quadrant(d.to_radians()));
        assert_eq!(
            [
                turn(0.0),
                turn(179.0),
                turn(181.0),
                turn(-179.0),
                turn(-181.0),
                turn(539.0)
            ],
            [0, 0, 1, 0, -1, 1]
        );
    }

    #[test]
    fn known_poses_give_the_documented_codes() {
        let dir = bundled_robots_dir();
        let abb = load_robot(&dir, "abb_irb140").unwrap();
        // Near the calibration pose: everything in front, axis 5 positive.
        let c = configuration(&abb, &deg([10.0, 0.0, 0.0, 0.0, 30.0, 0.0])).unwrap();
        assert_eq!(
            c.rapid(),
            RapidConfdata {
                cf1: 0,
                cf4: 0,
                cf6: 0,
                cfx: 0
            }
        );
        assert_eq!(c.fanuc(), "N U T, 0, 0, 0");
        let c = configuration(&abb, &deg([-100.0, 0.0, 0.0, 95.0, -30.0, 370.0])).unwrap();
        assert_eq!(
            c.rapid(),
            RapidConfdata {
                cf1: -2,
                cf4: 1,
                cf6: 4,
                cfx: 1
            }
        );
        assert_eq!(c.fanuc(), "F U T, 0, 0, 1");
        // Elbow folded back past the lower arm: wrist centre behind the lower arm.
        let c = configuration(&abb, &deg([0.0, 20.0, -100.0, 0.0, 30.0, 0.0])).unwrap();
        assert_eq!(c.elbow, Elbow::Down);
        assert_eq!(c.cfx(), 2);
        // Upper arm leaning back so far that the wrist centre is behind axis 1.
        let c = configuration(&abb, &deg([0.0, -85.0, -60.0, 0.0, 30.0, 0.0])).unwrap();
        assert_eq!(
            (c.shoulder, c.elbow, c.cfx()),
            (Shoulder::Back, Elbow::Up, 4)
        );

        let kuka = load_robot(&dir, "kuka_kr16_2").unwrap();
        // KUKA's home (A2 −90°, A3 +90°) with A5 positive: basic area, A3 ≥ φ: S 2;
        // A2 negative: T 2.
        let c = configuration(&kuka, &deg([0.0, -90.0, 90.0, 0.0, 30.0, 0.0])).unwrap();
        assert_eq!(
            c.krl(),
            KrlStatusTurn {
                status: Some(2),
                turn: Some(2)
            }
        );
        // A5 negative, A1 and A6 negative too: S 6, T 1 + 2 + 16 + 32.
        let c = configuration(&kuka, &deg([-20.0, -90.0, 90.0, 0.0, -30.0, -5.0])).unwrap();
        assert_eq!(
            c.krl(),
            KrlStatusTurn {
                status: Some(6),
                turn: Some(51)
            }
        );

        let ur = load_robot(&dir, "ur5e").unwrap();
        assert!(matches!(
            configuration(&ur, &[0.0; 6]),
            Err(ConfigurationError::NotSphericalWrist(_))
        ));
    }

    /// Distance of a joint vector from the configuration boundaries (singular poses), where
    /// the flags flip under rounding and IK solutions merge.
    fn clear_of_boundaries(robot: &Robot, q: &Joints) -> bool {
        let (axes, _) = robot.chain().axes_at(q);
        let [(w1, o1), (_, o2), (_, o3), (w4, o4), (w5, o5), _] = axes;
        let wc = meeting_point(&o4, &w4, &o5, &w5);
        let off_axis1 = (wc - o1).cross(&w1).norm();
        let bend = (o3 - o2).normalize().cross(&(wc - o2).normalize()).norm();
        q[4].sin().abs() > 0.02 && off_axis1 > 0.01 && bend > 0.02
    }

    #[test]
    fn exactly_the_solution_with_the_original_configuration_is_the_original() {
        let robots = load_robots(&bundled_robots_dir()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut checked = 0;
        for robot in robots.iter().filter(|r| r.solver_kind() == SolverKind::Opw) {
            let mut n = 0;
            while n < 400 {
                let mut q = [0.0; DOF];
                for (v, j) in q.iter_mut().zip(robot.joints()) {
                    *v = rng.random_range(j.lower..j.upper);
                }
                if !clear_of_boundaries(robot, &q) {
                    continue;
                }
                n += 1;
                let original = configuration(robot, &q).unwrap();
                let solutions = robot.ik(&robot.fk(&q));
                assert!(!solutions.is_empty(), "{}: {q:?}", robot.name());
                let same: Vec<&Joints> = solutions
                    .iter()
                    .filter(|s| configuration(robot, s).unwrap().same_solution(&original))
                    .collect();
                assert_eq!(same.len(), 1, "{}: {q:?} → {same:?}", robot.name());
                let close = |s: &Joints| s.iter().zip(&q).all(|(a, b)| (a - b).abs() < 1e-6);
                assert!(close(same[0]), "{}: {q:?} vs {:?}", robot.name(), same[0]);
                for s in &solutions {
                    if close(s) {
                        assert!(configuration(robot, s).unwrap().same_solution(&original));
                    }
                }
                // The converse: the configuration picks the original back.
                let picked = pick_solution(robot, &original, &solutions).unwrap();
                assert!(close(&picked));
                // Every distinct configuration of the solution set picks its own solution.
                let configs: Vec<ArmConfiguration> = solutions
                    .iter()
                    .map(|s| configuration(robot, s).unwrap())
                    .collect();
                for (i, c) in configs.iter().enumerate() {
                    let matching = configs.iter().filter(|d| d.same_solution(c)).count();
                    assert_eq!(matching, 1, "{}: {:?}", robot.name(), solutions[i]);
                }
            }
            checked += 1;
        }
        assert!(
            checked >= 2,
            "every bundled OPW arm is checked, the IRB 140 and the KR 16 at least"
        );
    }
}
