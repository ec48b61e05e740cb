//! The cell's arm on its own, as a pendant draws and jogs it: the frames of its links at a
//! joint vector (so the page does no kinematics), its ready position, and the joint solution
//! that puts its TCP at a pose from where it is.

use super::error::AppError;
use super::reach::CellArm;
use super::settings::parse_settings;
use super::{App, Result};
use crate::api::{
    ArmFrames, CellSettings, FramesQuery, LinkFrame, PoseValues, ReachQuery, Reachability,
};
use crate::kinematics::{self, DOF, Joints, Mounting};

/// Six finite joint values, from a list a client sent (`what` names it in the error).
fn joints_of(what: &str, values: &[f64]) -> Result<Joints> {
    let q: Joints = values.try_into().map_err(|_| {
        AppError::Invalid(format!(
            "{what} must hold {DOF} joint values, not {}",
            values.len()
        ))
    })?;
    if let Some(i) = q.iter().position(|v| !v.is_finite()) {
        return Err(AppError::Invalid(format!(
            "{what}: joint {} is not a finite number",
            i + 1
        )));
    }
    Ok(q)
}

/// The joint values of a frames query (`0,0.3,-0.2,0,0.8,0`), as numbers; `None` when none
/// are given (the arm's ready position). [`App::arm_frames`] checks that there are six.
pub fn frames_joints(query: &FramesQuery) -> Result<Option<Vec<f64>>> {
    let Some(text) = &query.joints else {
        return Ok(None);
    };
    text.split(',')
        .enumerate()
        .map(|(i, v)| {
            v.trim().parse::<f64>().map_err(|_| {
                AppError::Invalid(format!("joints: value {} ({v:?}) is not a number", i + 1))
            })
        })
        .collect::<Result<Vec<f64>>>()
        .map(Some)
}

impl App {
    /// The cell's arm, when its robot model is installed.
    pub(super) fn cell_arm(&self, settings: &CellSettings) -> Result<Option<CellArm>> {
        self.robots
            .get(&settings.robot)
            .map(|robot| CellArm::new(robot, settings))
            .transpose()
    }

    /// The cell's arm, or a conflict naming the missing model.
    async fn installed_arm(&self, cell_id: i64) -> Result<CellArm> {
        let settings = parse_settings(&self.cell_row(cell_id).await?)?;
        match self.cell_arm(&settings)? {
            Some(arm) => Ok(arm),
            None => Err(AppError::Conflict(format!(
                "the cell's robot model {:?} is not installed",
                settings.robot
            ))),
        }
    }

    /// The frames of the cell's arm at `joints` (its ready position when left out).
    pub async fn arm_frames(&self, cell_id: i64, joints: Option<Vec<f64>>) -> Result<ArmFrames> {
        let given = joints
            .as_deref()
            .map(|j| joints_of("joints", j))
            .transpose()?;
        let arm = self.installed_arm(cell_id).await?;
        let robot = arm.robot();
        let q = given.unwrap_or_else(|| kinematics::ready_joints(robot));
        let Mounting { base, tool } = *arm.mounting();
        let in_work = |p: &crate::engine::Pose| -> PoseValues {
            crate::engine::Pose::from_isometry(base.isometry() * p.isometry()).values()
        };
        let mut links = vec![LinkFrame {
            name: robot.chain().root().to_string(),
            pose: base.values(),
        }];
        for (frame, joint) in robot.joint_frames(&q).iter().zip(robot.joints()) {
            links.push(LinkFrame {
                name: joint.name.clone(),
                pose: in_work(frame),
            });
        }
        let flange = robot.fk(&q);
        let tcp = crate::engine::Pose::from_isometry(flange.isometry() * tool.isometry());
        Ok(ArmFrames {
            robot: robot.name().to_string(),
            joints: q.to_vec(),
            base: base.values(),
            links,
            flange: in_work(&flange),
            tcp: in_work(&tcp),
        })
    }

    /// Whether the cell's arm reaches `query.pose`, and the solution nearest `query.near`, which
    /// must be joints the arm can be at (within its ranges).
    pub async fn reach(&self, cell_id: i64, query: ReachQuery) -> Result<Reachability> {
        let pose = query.pose.to_pose()?;
        let near = query
            .near
            .as_deref()
            .map(|n| joints_of("near", n))
            .transpose()?;
        let arm = self.installed_arm(cell_id).await?;
        if let Some(q) = &near {
            arm.robot()
                .check_joints(q)
                .map_err(|e| AppError::Invalid(format!("near: {e}")))?;
        }
        Ok(arm.dto(&arm.check(&pose, near.as_ref())))
    }
}
