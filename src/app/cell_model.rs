//! One cell's model in memory: the engine's [`Teacher`], rebuilt from the database and then
//! kept in step with every write.

use super::error::AppError;
use super::reach::CellArm;
use super::robots::Robots;
use super::settings::parse_settings;
use crate::api::{ModelInfo, TeachingStats};
use crate::engine::experts::acceptance::Verdict;
use crate::engine::{Pose, PoseValues, Teacher};
use crate::kinematics::Reachability;
use crate::storage::{CellRow, CellState, Store, TeachingVerdictRow, WaypointRow};

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
    /// The cell's revision (`cells.revision`) the model is at: a write made from it is
    /// refused when the database has moved on.
    pub revision: i64,
    /// The ids of the open routine's waypoints, in order (what the teacher holds of it).
    pub open_ids: Vec<i64>,
    /// The `finish_seq` of the last routine learned (0: none).
    pub last_finish_seq: i64,
    /// Check the database before the next use (a write of ours found the cell changed, or
    /// advanced its revision without saying to what).
    pub needs_check: bool,
}

/// How a model in memory stands against the database.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Behind {
    /// Up to date (or brought up to date by learning only what is new).
    Caught,
    /// Must be learned again from the database.
    Reload,
}

/// The pose of a stored waypoint. Stored poses were validated when taught, so a failure here
/// means the database was edited behind our back.
pub(crate) fn stored_pose(w: &WaypointRow) -> Result<Pose, AppError> {
    stored_pose_values(&w.pose)
        .map_err(|e| AppError::Internal(format!("stored waypoint {}: {e}", w.id)))
}

/// A pose read back from the database.
pub(crate) fn stored_pose_values(p: &PoseValues) -> Result<Pose, AppError> {
    Pose::new([p.x, p.y, p.z], [p.qw, p.qx, p.qy, p.qz])
        .map_err(|e| AppError::Internal(format!("stored pose is invalid: {e}")))
}

/// The joints of a stored waypoint (validated when taught: a failure here means the database
/// was edited behind our back).
pub(crate) fn stored_joints(w: &WaypointRow) -> Result<Option<Vec<f64>>, AppError> {
    stored_joint_values(w.id, &w.joints)
}

/// The joints of waypoint `id` as stored (a JSON array of radians).
pub(crate) fn stored_joint_values(
    id: i64,
    joints: &Option<String>,
) -> Result<Option<Vec<f64>>, AppError> {
    joints
        .as_deref()
        .map(serde_json::from_str)
        .transpose()
        .map_err(|e| AppError::Internal(format!("stored joints of waypoint {id}: {e}")))
}

/// A verdict on a suggestion, as stored.
fn verdict_of(s: &str) -> Result<Verdict, AppError> {
    Verdict::named(s).ok_or_else(|| AppError::Internal(format!("stored verdict {s:?} is unknown")))
}

/// The feedback that teaches a routine's waypoints (see `app::feedback`), as the model applies
/// it: each verdict right after the waypoint taught after its prediction, at the place the
/// prediction was made and after the waypoint that was then the last.
#[derive(Debug, Default)]
pub(crate) struct Verdicts(Vec<TeachingVerdict>);

#[derive(Debug)]
struct TeachingVerdict {
    index: usize,
    after: Option<i64>,
    offered: Pose,
    verdict: Verdict,
    taught_as: Option<Pose>,
}

impl Verdicts {
    /// Routine `id`'s verdicts that teach.
    pub async fn of(store: &Store, id: i64) -> Result<Verdicts, AppError> {
        store
            .teaching_verdicts(id)
            .await?
            .iter()
            .map(TeachingVerdict::from_row)
            .collect::<Result<_, _>>()
            .map(Verdicts)
    }

    /// Applies to `teacher` the verdicts about waypoint `index` of its routine (just taught),
    /// taught after the waypoint `after` (None: the routine's first).
    pub fn apply(&self, teacher: &mut Teacher, index: usize, after: Option<i64>) {
        for v in self
            .0
            .iter()
            .filter(|v| v.index == index && v.after == after)
        {
            teacher.feedback(index, &v.offered, v.verdict, v.taught_as.as_ref());
        }
    }
}

impl TeachingVerdict {
    fn from_row(r: &TeachingVerdictRow) -> Result<TeachingVerdict, AppError> {
        Ok(TeachingVerdict {
            index: usize::try_from(r.after_seq)
                .map_err(|_| AppError::Internal(format!("stored place {}", r.after_seq)))?,
            after: r.after_waypoint_id,
            offered: stored_pose_values(&r.offered)?,
            verdict: verdict_of(&r.verdict)?,
            taught_as: r.taught_as.as_ref().map(stored_pose_values).transpose()?,
        })
    }
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
        let mut last_finish_seq = 0;
        for r in store.finished_routines(cell.id).await? {
            last_finish_seq = r.finish_seq.unwrap_or(last_finish_seq);
            let waypoints = store
                .waypoints(r.id)
                .await?
                .iter()
                .map(|w| Ok((stored_pose(w)?, w.id)))
                .collect::<Result<Vec<_>, AppError>>()?;
            finished.push((waypoints, Verdicts::of(store, r.id).await?));
        }
        let open = store.open_routine(cell.id).await?;
        let mut taught = Vec::new();
        let mut open_verdicts = Verdicts::default();
        if let Some(r) = &open {
            for w in store.waypoints(r.id).await? {
                taught.push((stored_pose(&w)?, stored_joints(&w)?, w.id));
            }
            open_verdicts = Verdicts::of(store, r.id).await?;
        }
        // The cell's row was read before the routines: what was loaded is at least as new as
        // its revision (catching up from there is idempotent).
        let revision = cell.revision;
        let config = settings.engine_config();
        let open = open.map(|r| r.id);
        let version = cell.model_version;
        super::blocking(move || -> Result<CellModel, AppError> {
            let mut teacher = Teacher::new(config)?;
            for (routine, verdicts) in &finished {
                let mut after = None;
                for (i, (pose, id)) in routine.iter().enumerate() {
                    teacher.teach(*pose);
                    verdicts.apply(&mut teacher, i, after);
                    after = Some(*id);
                }
                teacher.finish_routine();
            }
            let mut model = CellModel {
                arm,
                teacher,
                open,
                version,
                revision,
                open_ids: Vec::new(),
                last_finish_seq,
                needs_check: false,
            };
            for (pose, joints, id) in &taught {
                model.teach_stored(*pose, joints.as_deref(), *id, &open_verdicts);
            }
            Ok(model)
        })
        .await?
    }

    /// Brings the model up to the database's `state` of the cell, learning only what is new:
    /// routines finished since, and the open routine's waypoints from the first that differs
    /// (taught or undone elsewhere). Anything else (an edit, new settings, a deletion) needs
    /// a [`Behind::Reload`].
    pub async fn catch_up(&mut self, store: &Store, state: &CellState) -> Result<Behind, AppError> {
        if state.revision == self.revision {
            self.needs_check = false;
            return Ok(Behind::Caught);
        }
        if state.reload_revision > self.revision {
            return Ok(Behind::Reload);
        }
        let finished = store
            .routines_finished_after(state.id, self.last_finish_seq)
            .await?;
        let version = self.version + finished.len() as i64;
        for r in &finished {
            if self.open.is_some() && self.open != Some(r.id) {
                return Ok(Behind::Reload);
            }
            self.follow_open(store, r.id).await?;
            self.learn_open(r.finish_seq);
        }
        match store.open_routine(state.id).await? {
            Some(r) if self.open.is_none() || self.open == Some(r.id) => {
                self.open = Some(r.id);
                self.follow_open(store, r.id).await?;
            }
            Some(_) => return Ok(Behind::Reload),
            None if self.open.is_some() => return Ok(Behind::Reload),
            None => {}
        }
        if version != state.model_version {
            return Ok(Behind::Reload);
        }
        self.version = version;
        self.revision = state.revision;
        self.needs_check = false;
        Ok(Behind::Caught)
    }

    /// Makes the teacher hold routine `id`'s stored waypoints: undoes those of its own from
    /// the first that is not in the database, then learns the rest.
    async fn follow_open(&mut self, store: &Store, id: i64) -> Result<(), AppError> {
        let ids = store.waypoint_ids(id).await?;
        let common = self
            .open_ids
            .iter()
            .zip(&ids)
            .take_while(|(a, b)| a == b)
            .count();
        for _ in common..self.open_ids.len() {
            self.take_back();
        }
        self.open_ids.truncate(common);
        let verdicts = Verdicts::of(store, id).await?;
        for w in store.waypoints_after(id, common as i64).await? {
            self.teach_stored(
                stored_pose(&w)?,
                stored_joints(&w)?.as_deref(),
                w.id,
                &verdicts,
            );
        }
        Ok(())
    }

    /// Teaches a stored waypoint `id` of the open routine, then the verdicts about it.
    fn teach_stored(&mut self, pose: Pose, joints: Option<&[f64]>, id: i64, verdicts: &Verdicts) {
        self.teach(pose, joints);
        self.judged(verdicts);
        self.open_ids.push(id);
    }

    /// Applies the verdicts about the open routine's last waypoint, just taught (before its id
    /// joins `open_ids`).
    pub fn judged(&mut self, verdicts: &Verdicts) {
        let index = self.teacher.routine().len().saturating_sub(1);
        verdicts.apply(&mut self.teacher, index, self.open_ids.last().copied());
    }

    /// Teaches a pose of the open routine: the teacher learns it and the arm extends its joint
    /// trail (what it says of the pose's reach, when the cell has an arm).
    pub fn teach(&mut self, pose: Pose, joints: Option<&[f64]>) -> Option<Reachability> {
        self.teacher.teach(pose);
        self.arm.as_mut().map(|arm| arm.taught(&pose, joints))
    }

    /// Takes the open routine's last pose back (an undo, or a write that did not happen).
    pub fn take_back(&mut self) {
        self.teacher.undo();
        if let Some(arm) = self.arm.as_mut() {
            arm.undo();
        }
    }

    /// A write of ours moved the cell to `revision` without changing what the model holds.
    pub fn moved_to(&mut self, revision: i64) {
        self.revision = revision;
    }

    /// Routine `id` was created to be taught (at `revision`).
    pub fn opened(&mut self, id: i64, revision: i64) {
        self.open = Some(id);
        self.open_ids.clear();
        self.revision = revision;
    }

    /// The open routine was finished (`finish_seq`, leaving the cell at `state`): the teacher
    /// learns it.
    pub fn finished(&mut self, finish_seq: i64, state: &CellState) {
        self.revision = state.revision;
        self.learn_open(Some(finish_seq));
        self.version = state.model_version;
    }

    /// The open routine was deleted (at `revision`): the teacher forgets it as if never taught.
    pub fn abandoned(&mut self, revision: i64) {
        self.revision = revision;
        self.teacher.abandon_routine();
        self.close_open();
    }

    /// Finished routines were added (imported) and learned in order, leaving the cell at
    /// `state`; `last_finish` is the `finish_seq` of the last (None: none was learned).
    pub fn learned(&mut self, routines: &[Vec<Pose>], state: &CellState, last_finish: Option<i64>) {
        for routine in routines {
            self.teacher.learn_routine(routine);
        }
        self.version = state.model_version;
        self.revision = state.revision;
        self.last_finish_seq = last_finish.unwrap_or(self.last_finish_seq);
    }

    /// The teacher learns the open routine (finished with `finish_seq`, if known).
    fn learn_open(&mut self, finish_seq: Option<i64>) {
        self.teacher.finish_routine();
        self.close_open();
        self.last_finish_seq = finish_seq.unwrap_or(self.last_finish_seq);
    }

    /// No routine is open any more: the arm's joint trail starts again.
    fn close_open(&mut self) {
        self.open_ids.clear();
        if let Some(arm) = self.arm.as_mut() {
            arm.clear();
        }
        self.open = None;
    }

    /// What a rebuild from the database must reproduce: the learned model, the routine being
    /// taught and the arm's joint trail.
    pub fn in_step_with(&self, other: &CellModel) -> bool {
        self.info() == other.info()
            && self.teaching() == other.teaching()
            && self.teacher.calibration() == other.teacher.calibration()
            && self.open == other.open
            && self.teacher.routine() == other.teacher.routine()
            && self.arm.as_ref().map(CellArm::trail) == other.arm.as_ref().map(CellArm::trail)
    }

    /// The operator the cell has learned or been told of, and its offer threshold now.
    pub fn teaching(&self) -> TeachingStats {
        let t = &self.teacher;
        let rule = t.config().offer;
        TeachingStats {
            noise: t.noise(),
            noise_learned: t.learns_noise(),
            tolerance: t.tolerance(),
            tolerance_learned: rule.is_some_and(|r| r.tolerance.is_none()),
            offer_threshold: t.threshold(),
            threshold_steered: rule.is_some_and(|r| r.threshold.is_none()),
        }
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
