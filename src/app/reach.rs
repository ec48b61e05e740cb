//! The cell's arm in the teaching loop: every taught waypoint and every prediction is checked
//! against the robot model, and the joints of the taught waypoints are followed so a
//! prediction's solution is the one nearest where the arm is.

use std::sync::Arc;

use super::error::AppError;
use crate::api::{self, CellSettings, JointMargin};
use crate::engine::Pose;
use crate::kinematics::{
    self, Joints, Mounting, ReachConfig, ReachPolicy, Reachability, Robot, Unreachable, check_reach,
};

pub(crate) fn describe(why: &Unreachable) -> api::Unreachable {
    let (reason, message) = match why {
        Unreachable::OutsideReach => (
            "outside_reach",
            "the pose is outside the arm's reach".to_string(),
        ),
        Unreachable::JointLimit {
            name, excess_rad, ..
        } => (
            "joint_limit",
            format!(
                "joint {name} would be {:.1}° beyond its limit",
                excess_rad.to_degrees()
            ),
        ),
        Unreachable::Singular { sigma_min } => (
            "singular",
            format!("the arm would be at a singularity (σ_min = {sigma_min:.4})"),
        ),
    };
    api::Unreachable {
        reason: reason.to_string(),
        message,
    }
}

/// The arm of one cell, and the joints of the routine being taught.
#[derive(Debug, Clone)]
pub(crate) struct CellArm {
    robot: Arc<Robot>,
    frames: Mounting,
    config: ReachConfig,
    /// Per taught waypoint of the open routine: its joints (taught, or the chosen solution).
    trail: Vec<Option<Joints>>,
}

impl CellArm {
    pub fn new(robot: Arc<Robot>, settings: &CellSettings) -> Result<CellArm, AppError> {
        Ok(CellArm {
            robot,
            frames: Mounting::new(settings.base.to_pose()?, settings.tool.to_pose()?),
            config: ReachConfig {
                policy: settings.reach_policy,
                ..ReachConfig::default()
            },
            trail: Vec::new(),
        })
    }

    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// Where the robot stands in the work frame and the tool it holds.
    pub fn mounting(&self) -> &Mounting {
        &self.frames
    }

    pub fn policy(&self) -> ReachPolicy {
        self.config.policy
    }

    /// The joints followed along the open routine, one entry per taught waypoint.
    pub fn trail(&self) -> &[Option<Joints>] {
        &self.trail
    }

    pub fn previous(&self) -> Option<&Joints> {
        self.trail.last().and_then(Option::as_ref)
    }

    pub fn check(&self, pose: &Pose, previous: Option<&Joints>) -> Reachability {
        check_reach(&self.robot, &self.frames, pose, previous, &self.config)
    }

    /// Taught joints must be one value per joint of the arm (they were cut or padded
    /// silently before).
    pub fn check_joints(&self, joints: &[f64]) -> Result<(), AppError> {
        if joints.len() == kinematics::DOF {
            return Ok(());
        }
        Err(AppError::Invalid(format!(
            "joints must hold {} values, one per joint of the cell's {}, not {}",
            kinematics::DOF,
            self.robot.name(),
            joints.len()
        )))
    }

    /// A taught waypoint: checks it and follows the arm's joints (the taught ones when the
    /// pendant sent them, checked by [`CellArm::check_joints`]).
    pub fn taught(&mut self, pose: &Pose, joints: Option<&[f64]>) -> Reachability {
        let reach = self.check(pose, self.previous());
        let taught: Option<Joints> = joints.and_then(|j| j.try_into().ok());
        self.trail.push(taught.or(reach.chosen));
        reach
    }

    pub fn undo(&mut self) {
        self.trail.pop();
    }

    pub fn clear(&mut self) {
        self.trail.clear();
    }

    pub fn dto(&self, r: &Reachability) -> api::Reachability {
        api::Reachability {
            robot: self.robot.name().to_string(),
            reachable: r.is_reachable(),
            unreachable: r.unreachable.as_ref().map(describe),
            solutions: r.solutions.len(),
            chosen: r.chosen.map(|q| q.to_vec()),
            sigma_min: r.sigma_min,
            manipulability: r.manipulability,
            limiting_joint: r.limiting_joint.as_ref().map(|m| JointMargin {
                name: m.name.clone(),
                margin_rad: m.margin_rad,
            }),
        }
    }
}
