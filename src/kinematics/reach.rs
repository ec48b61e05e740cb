//! Reachability of a predicted pose for one arm in one cell.
//!
//! A cell places the robot base in the work (world) frame and mounts a tool (TCP) on the
//! flange (`tool0`); a target TCP pose in the work frame is reachable when the flange pose
//! `base⁻¹ · target · tool⁻¹` has an IK solution within the joint limits that is not singular.
//! The result says which solutions there are, which one the arm would take (the one nearest the
//! previous waypoint's joints), how far that one is from a singularity and from its tightest
//! joint limit, and, when the pose is unreachable, why.
//!
//! Distance from a singularity is [`Robot::sigma_min`]: the smallest singular value of the
//! Jacobian with its linear rows divided by the arm's reach, so that metres and radians are
//! weighed alike and one threshold ([`ReachConfig::min_singular_value`]) means about the same
//! angle from a singular pose on a 0.5 m cobot and a 2.8 m arm. The plain Jacobian's σ_min,
//! used before, called a UR3e singular at 10 % of random poses against 5 % for a UR10e of the
//! same design.

use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

use crate::engine::{Pose, PoseValues};

use super::urdf::{DOF, Joints};
use super::{Robot, pose_to_metres};

/// How an arm is mounted in its cell: where the robot stands and what it holds. Both poses
/// in mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mounting {
    /// Robot base frame in the work (world) frame.
    pub base: Pose,
    /// TCP in the flange (`tool0`) frame.
    pub tool: Pose,
}

impl Default for Mounting {
    fn default() -> Mounting {
        Mounting {
            base: Pose::identity(),
            tool: Pose::identity(),
        }
    }
}

impl Mounting {
    pub fn new(base: Pose, tool: Pose) -> Mounting {
        Mounting { base, tool }
    }

    /// The flange pose in the robot base frame that puts the TCP at `target` (work frame):
    /// `base⁻¹ · target · tool⁻¹`.
    pub fn flange_target(&self, target: &Pose) -> Pose {
        Pose::from_isometry(
            self.base.isometry().inv_mul(target.isometry()) * self.tool.isometry().inverse(),
        )
    }
}

/// What the service does with a prediction the arm cannot reach.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum ReachPolicy {
    /// Do not offer it (default; the reason is `unreachable`).
    #[default]
    Withhold,
    /// Offer it, with `reachability.reachable = false` and why.
    Flag,
}

/// Settings of the reachability check.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReachConfig {
    pub policy: ReachPolicy,
    /// A chosen solution whose [`Robot::sigma_min`] (the smallest singular value of the flange
    /// Jacobian with its linear rows in units of the arm's reach: dimensionless) is below this
    /// is singular. The default 0.005 flags J5 within about 1° of zero on every bundled arm
    /// (the median over random poses is 0.9°–1.2° for each) and the elbow within about 1.5° of
    /// stretched.
    pub min_singular_value: f64,
}

impl Default for ReachConfig {
    fn default() -> ReachConfig {
        ReachConfig {
            policy: ReachPolicy::Withhold,
            min_singular_value: DEFAULT_MIN_SINGULAR_VALUE,
        }
    }
}

/// Default of [`ReachConfig::min_singular_value`].
pub const DEFAULT_MIN_SINGULAR_VALUE: f64 = 0.005;

/// The joint closest to a limit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointMargin {
    /// 0-based joint index.
    pub joint: usize,
    pub name: String,
    /// Radians to the nearer limit.
    pub margin_rad: f64,
}

/// Why a pose is unreachable.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum Unreachable {
    /// No joint vector at all puts the flange there (too far, too close, behind the arm's
    /// geometry).
    OutsideReach,
    /// Solutions exist, but each has a joint outside its range; this joint blocks the solution
    /// that misses its limits by the least, by `excess_rad`.
    JointLimit {
        joint: usize,
        name: String,
        excess_rad: f64,
    },
    /// The solution the arm would take is at (or too near) a singularity.
    Singular { sigma_min: f64 },
}

/// Outcome of a reachability check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reachability {
    /// Flange (`tool0`) target in the robot base frame, mm.
    pub flange: PoseValues,
    /// Every IK solution within limits (multi-turn variants included), radians.
    pub solutions: Vec<Joints>,
    /// The solution nearest the previous joints (or the range centres when none were given).
    pub chosen: Option<Joints>,
    /// Smallest singular value of the Jacobian at `chosen`, its linear rows in units of the
    /// arm's reach ([`Robot::sigma_min`]).
    pub sigma_min: Option<f64>,
    /// Yoshikawa manipulability `|det J|` at `chosen` (the plain Jacobian: metres, radians).
    pub manipulability: Option<f64>,
    /// The joint of `chosen` nearest a limit.
    pub limiting_joint: Option<JointMargin>,
    /// `None` when reachable.
    pub unreachable: Option<Unreachable>,
}

/// A ready position of the arm: the joints that point the flange down in front of the base,
/// about half its reach out and up, nearest the arm's zero position; where none of a few
/// such poses is reachable away from limits and singularities, the middle of each joint's
/// range.
pub fn ready_joints(robot: &Robot) -> Joints {
    let reach = super::catalog::computed_reach_mm(robot);
    let zero = [0.0; DOF];
    for (fx, fz) in [(0.5, 0.5), (0.5, 0.3), (0.4, 0.6), (0.6, 0.4), (0.3, 0.3)] {
        let Ok(target) = Pose::new([fx * reach, 0.0, fz * reach], [0.0, 0.0, 1.0, 0.0]) else {
            continue;
        };
        let r = check_reach(
            robot,
            &Mounting::default(),
            &target,
            Some(&zero),
            &ReachConfig::default(),
        );
        if let (true, Some(q)) = (r.is_reachable(), r.chosen) {
            return q;
        }
    }
    let mut q = zero;
    for (qi, j) in q.iter_mut().zip(robot.joints()) {
        *qi = 0.5 * (j.lower + j.upper);
    }
    q
}

/// What to do with a prediction, given its reachability and the policy.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "action", rename_all = "snake_case")]
pub enum Offer {
    Offer,
    Flag { why: Unreachable },
    Withhold { why: Unreachable },
}

impl Reachability {
    pub fn is_reachable(&self) -> bool {
        self.unreachable.is_none()
    }

    pub fn offer(&self, policy: ReachPolicy) -> Offer {
        match (&self.unreachable, policy) {
            (None, _) => Offer::Offer,
            (Some(why), ReachPolicy::Flag) => Offer::Flag { why: why.clone() },
            (Some(why), ReachPolicy::Withhold) => Offer::Withhold { why: why.clone() },
        }
    }
}

fn distance_sq(a: &Joints, b: &Joints) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Checks whether `robot` in `cell` can put its TCP at `target` (work frame, mm).
/// `previous`: the joints of the previous waypoint, when known.
pub fn check_reach(
    robot: &Robot,
    cell: &Mounting,
    target: &Pose,
    previous: Option<&Joints>,
    config: &ReachConfig,
) -> Reachability {
    let flange = cell.flange_target(target);
    let tip: Isometry3<f64> = pose_to_metres(&flange);
    let previous = previous.filter(|p| p.iter().all(|v| v.is_finite()));
    let principal = robot.ik_principal(&tip, previous);
    let mut result = Reachability {
        flange: flange.values(),
        solutions: Vec::new(),
        chosen: None,
        sigma_min: None,
        manipulability: None,
        limiting_joint: None,
        unreachable: None,
    };
    if principal.is_empty() {
        result.unreachable = Some(Unreachable::OutsideReach);
        return result;
    }
    let mut solutions = Vec::with_capacity(principal.len() * robot.max_variants());
    for q in &principal {
        robot.push_variants(q, &mut solutions);
    }
    if solutions.is_empty() {
        // The principal solution that misses its limits by the least, and its worst joint.
        let mut best: Option<(f64, usize, f64)> = None;
        for q in &principal {
            let excess = robot.limit_excess(q);
            let total: f64 = excess.iter().sum();
            let (joint, worst) = excess
                .iter()
                .copied()
                .enumerate()
                .fold((0, 0.0), |acc, (i, e)| if e > acc.1 { (i, e) } else { acc });
            if best.is_none_or(|b| total < b.0) {
                best = Some((total, joint, worst));
            }
        }
        if let Some((_, joint, excess_rad)) = best {
            result.unreachable = Some(Unreachable::JointLimit {
                joint,
                name: robot.joints()[joint].name.clone(),
                excess_rad,
            });
        }
        return result;
    }
    let reference: Joints = match previous {
        Some(p) => *p,
        None => {
            let mut c = [0.0; DOF];
            for (ci, j) in c.iter_mut().zip(robot.joints()) {
                *ci = 0.5 * (j.lower + j.upper);
            }
            c
        }
    };
    let chosen = solutions
        .iter()
        .min_by(|a, b| distance_sq(a, &reference).total_cmp(&distance_sq(b, &reference)))
        .copied();
    if let Some(q) = chosen {
        let sigma_min = robot.sigma_min(&q);
        result.sigma_min = Some(sigma_min);
        result.manipulability = Some(robot.jacobian(&q).determinant().abs());
        result.limiting_joint = robot
            .joints()
            .iter()
            .enumerate()
            .map(|(i, j)| JointMargin {
                joint: i,
                name: j.name.clone(),
                margin_rad: j.margin(q[i]),
            })
            .min_by(|a, b| a.margin_rad.total_cmp(&b.margin_rad));
        // NaN (never expected) counts as singular.
        if sigma_min.is_nan() || sigma_min < config.min_singular_value {
            result.unreachable = Some(Unreachable::Singular { sigma_min });
        }
    }
    result.chosen = chosen;
    result.solutions = solutions;
    result
}
