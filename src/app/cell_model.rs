//! One cell's model in memory: the engine's [`Teacher`], rebuilt from the database and then
//! kept in step with every write.

use super::error::AppError;
use super::reach::CellArm;
use super::resources::ModelInfo;
use super::robots::Robots;
use super::settings::parse_settings;
use crate::engine::{Pose, Teacher};
use crate::storage::{CellRow, PoseColumns, Store, WaypointRow};

#[derive(Debug)]
pub(crate) struct CellModel {
    /// The cell's arm; None when the robot model named by the cell is no longer installed
    /// (predictions are then not checked, and say so).
    pub arm: Option<CellArm>,
    pub teacher: Teacher,
    /// The routine being taught (its waypoints are in the teacher).
    pub open: Option<i64>,
    /// The cell's model version (`cells.model_version`: advanced by each routine learned and
    /// each edit of a learned routine).
    pub version: i64,
}

/// The pose of a stored waypoint. Stored poses were validated when taught, so a failure here
/// means the database was edited behind our back.
pub(crate) fn stored_pose(w: &WaypointRow) -> Result<Pose, AppError> {
    stored_pose_columns(&w.pose)
        .map_err(|e| AppError::Internal(format!("stored waypoint {}: {e}", w.id)))
}

/// A pose read back from the database.
pub(crate) fn stored_pose_columns(p: &PoseColumns) -> Result<Pose, AppError> {
    Pose::new([p.x, p.y, p.z], [p.qw, p.qx, p.qy, p.qz])
        .map_err(|e| AppError::Internal(format!("stored pose is invalid: {e}")))
}

/// The joints of a stored waypoint (validated when taught: a failure here means the database
/// was edited behind our back).
pub(crate) fn stored_joints(w: &WaypointRow) -> Result<Option<Vec<f64>>, AppError> {
    w.joints
        .as_deref()
        .map(serde_json::from_str)
        .transpose()
        .map_err(|e| AppError::Internal(format!("stored joints of waypoint {}: {e}", w.id)))
}

impl CellModel {
    /// Learns the cell's finished routines in the order they were finished, then takes up the
    /// routine being taught, exactly as incremental teaching did. The database is read first;
    /// the learning (CPU work) runs on a blocking thread.
    pub async fn load(
        store: &Store,
        cell: &CellRow,
        robots: &Robots,
    ) -> Result<CellModel, AppError> {
        let settings = parse_settings(cell)?;
        let arm = match robots.get(&settings.robot) {
            Some(robot) => Some(CellArm::new(robot, &settings)?),
            None => {
                tracing::warn!(cell = cell.id, robot = %settings.robot, "robot model not installed; predictions are not checked for reachability");
                None
            }
        };
        let mut finished = Vec::new();
        for r in store.finished_routines(cell.id).await? {
            let poses = store
                .waypoints(r.id)
                .await?
                .iter()
                .map(stored_pose)
                .collect::<Result<Vec<_>, _>>()?;
            finished.push(poses);
        }
        let open = store.open_routine(cell.id).await?;
        let mut taught = Vec::new();
        if let Some(r) = &open {
            for w in store.waypoints(r.id).await? {
                taught.push((stored_pose(&w)?, stored_joints(&w)?));
            }
        }
        let config = settings.engine_config();
        let open = open.map(|r| r.id);
        let version = cell.model_version;
        super::blocking(move || -> Result<CellModel, AppError> {
            let mut teacher = Teacher::new(config)?;
            for routine in &finished {
                for pose in routine {
                    teacher.teach(*pose);
                }
                teacher.finish_routine();
            }
            let mut arm = arm;
            for (pose, joints) in &taught {
                teacher.teach(*pose);
                if let Some(arm) = arm.as_mut() {
                    arm.taught(pose, joints.as_deref());
                }
            }
            Ok(CellModel {
                arm,
                teacher,
                open,
                version,
            })
        })
        .await?
    }

    /// What a rebuild from the database must reproduce: the learned model, the routine being
    /// taught and the arm's joint trail.
    pub fn in_step_with(&self, other: &CellModel) -> bool {
        self.info() == other.info()
            && self.open == other.open
            && self.teacher.routine() == other.teacher.routine()
            && self.arm.as_ref().map(CellArm::trail) == other.arm.as_ref().map(CellArm::trail)
    }

    pub fn info(&self) -> ModelInfo {
        let s = self.teacher.stats();
        ModelInfo {
            states: s.states,
            edges: s.edges,
            perplexity: s.perplexity,
            routines: s.routines,
            depth: s.depth,
            observations: s.observations,
            version: self.version,
        }
    }
}
