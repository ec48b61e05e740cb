//! Hand-guided (lead-through) teaching: a recorded TCP trajectory is cut into linear dynamical
//! systems ([`crate::engine::lead_through::segment`]) whose attractors are appended to the open routine as
//! taught waypoints, each with the prediction that follows it, as single appends are; with
//! `preview`, the attractors and the segmentation are only shown.
//!
//! **What is appended.** The trajectory's first sample, then each segment's attractor, in
//! order; each waypoint is the recorded sample itself (its pose, and its joints when the
//! samples carry joints). A point closer than `min_step_mm` (position and rotation weighted as
//! in the segmentation) to the waypoint before it (the routine's last one, or the point
//! appended before it) is left out: the first sample is appended when the routine is empty or
//! the trajectory starts elsewhere than the routine's last waypoint, as the program must go
//! through where the operator started.
//!
//! **All or nothing.** Everything the client can get wrong is checked first (the samples, the
//! settings, the joints against the cell's arm), and the segmentation runs before the cell is
//! locked. Under the cell's lock, held for the whole trajectory so that nothing interleaves,
//! each waypoint is checked against the arm, taught and predicted in turn as
//! [`App::append_waypoint`] does; then all of them and their predictions are stored in one
//! transaction. If that fails, the model takes every one of them back: nothing changed.

use std::sync::Arc;

use super::cell_model::Verdicts;
use super::error::AppError;
use super::offer;
use super::registry::{blocking, stale_check};
use super::rows::waypoint;
use super::{App, Result, check_joints_finite};
use crate::api::{
    self, PoseValues, Taught, TrajectoryAnswer, TrajectoryPoint, TrajectoryRequest,
    TrajectorySegment, TrajectorySettings,
};
use crate::engine::Pose;
use crate::engine::lead_through::segment::{
    self, SegmentSettings, Segmentation, TimedPose, TrajectoryError,
};
use crate::kinematics::Reachability;
use crate::storage::{NewPrediction, NewWaypoint};

/// Most samples one request may carry (the engine itself takes up to
/// [`segment::MAX_SAMPLES`]): 20 s at 1 kHz, or several minutes at the rates pendants record.
/// The body limit (`--body-limit`, 2 MiB by default) holds about 6000 samples with joints as
/// JSON and about 15000 as protobuf; raise it for longer recordings.
pub const MAX_TRAJECTORY_SAMPLES: usize = 20_000;

/// Largest weight of rotation against position: the engine's bound
/// ([`segment::MAX_ROTATION_MM_PER_RAD`]). A sample's position is bounded as every entering
/// pose's is ([`crate::engine::POSITION_LIMIT_MM`], well within the engine's
/// [`segment::MAX_COORDINATE_MM`]).
pub use segment::MAX_ROTATION_MM_PER_RAD;

/// Reproduced states the segmentation may compute for one request, over all its segments
/// (48 bytes each): the memory a request may take for its reproduction.
pub const REPRODUCTION_BUDGET: usize = 2_000_000;

/// Distances from a sample to a step of the reproduced path one request may compute for its
/// reproduction error (each sample is measured against the paths of its segment and the two
/// beside it, so this is about 3 × samples × steps per segment): about a second of CPU.
pub const REPRODUCTION_ERROR_BUDGET: usize = 30_000_000;

/// Most joint values a sample may carry (as a single append).
const MAX_JOINTS: usize = 12;

/// A trajectory checked and segmented (nothing here depends on the cell).
#[derive(Debug)]
struct Prepared {
    /// The samples' poses as they are stored (normalised, canonical sign).
    samples: Vec<TimedPose>,
    joints: Vec<Option<Vec<f64>>>,
    settings: SegmentSettings,
    segmentation: Segmentation,
}

/// A sample to append: its place in the request.
type Target = usize;

impl App {
    /// Appends a hand-guided trajectory's attractors to an open routine as taught waypoints
    /// (see the module docs), or with `preview` shows them without storing anything.
    pub async fn append_trajectory(
        &self,
        routine_id: i64,
        input: TrajectoryRequest,
    ) -> Result<TrajectoryAnswer> {
        let preview = input.preview;
        // Checked and segmented before the cell is locked: CPU work, on a blocking thread.
        let prepared = Arc::new(blocking(move || prepare(&input)).await??);
        if preview {
            return self
                .to_completion(move |app| async move {
                    app.preview_trajectory_now(routine_id, &prepared).await
                })
                .await;
        }
        self.following(move |app| {
            let prepared = prepared.clone();
            async move { app.append_trajectory_now(routine_id, prepared).await }
        })
        .await
    }

    async fn preview_trajectory_now(
        &self,
        routine_id: i64,
        prepared: &Prepared,
    ) -> Result<TrajectoryAnswer> {
        let (mut locked, _) = self.lock_open_routine(routine_id).await?;
        let model = locked.model()?;
        if let Some(arm) = &model.arm {
            check_joints_with(arm, prepared)?;
        }
        let targets = targets(prepared, model.teacher.routine().last());
        drop(locked);
        Ok(answer(prepared, &targets, true, Vec::new()))
    }

    async fn append_trajectory_now(
        &self,
        routine_id: i64,
        prepared: Arc<Prepared>,
    ) -> Result<TrajectoryAnswer> {
        let (mut locked, r) = self.lock_open_routine(routine_id).await?;
        // A verdict given before the first waypoint is taught teaches with it (as for one
        // waypoint); the others' predictions are made here.
        let verdicts = Verdicts::of(&self.store, routine_id).await?;
        let targets = {
            let model = locked.model()?;
            if let Some(arm) = &model.arm {
                check_joints_with(arm, &prepared)?;
            }
            targets(&prepared, model.teacher.routine().last())
        };
        if targets.is_empty() {
            return Err(AppError::Invalid(format!(
                "the trajectory does not leave routine {routine_id}'s last waypoint (every \
                 attractor is within min_step_mm of it): nothing to append"
            )));
        }
        // Teaching and predicting each waypoint is CPU work: on a blocking thread, with the
        // cell's lock.
        let work = prepared.clone();
        let order = targets.clone();
        let (mut locked, taught) = blocking(move || -> Result<_> {
            let mut locked = locked;
            let model = locked.model()?;
            let mut taught = Vec::with_capacity(order.len());
            for (k, &i) in order.iter().enumerate() {
                let pose = work.samples[i].pose;
                let joints = work.joints[i].as_deref();
                let reach = model.teach(pose, joints);
                if k == 0 {
                    model.judged(&verdicts);
                }
                let (opts, checked) = offer::next(&model.teacher, model.arm.as_ref());
                taught.push(Step {
                    sample: i,
                    reach,
                    opts,
                    checked,
                });
            }
            Ok((locked, taught))
        })
        .await??;
        let model = locked.model()?;
        let before = model.teacher.routine().len() - taught.len();
        let version = model.version;
        let mut rows = Vec::with_capacity(taught.len());
        for (k, step) in taught.iter().enumerate() {
            let i = step.sample;
            let after = (before + k + 1) as i64;
            let joints = match &prepared.joints[i] {
                Some(j) => {
                    Some(serde_json::to_string(j).map_err(|e| AppError::Internal(e.to_string()))?)
                }
                None => None,
            };
            let wp = NewWaypoint {
                routine_id,
                seq: after,
                pose: (&prepared.samples[i].pose).into(),
                joints,
                motion: None,
                name: None,
                reachable: step.reach.as_ref().map(Reachability::is_reachable),
            };
            let record: Option<NewPrediction> = offer::record(&r, after, version, &step.checked);
            rows.push((wp, record));
        }
        let stored = match self
            .store
            .append_waypoints(r.cell_id, model.revision, &rows)
            .await
        {
            Ok(stored) => stored,
            Err(e) => {
                // Nothing was stored: the model takes every waypoint back.
                for _ in &taught {
                    model.take_back();
                }
                stale_check(&mut locked, &e);
                return Err(e.into());
            }
        };
        if let Some(last) = stored.last() {
            model.moved_to(last.revision);
        }
        model.open_ids.extend(stored.iter().map(|done| done.row.id));
        let mut waypoints = Vec::with_capacity(stored.len());
        for (k, (step, done)) in taught.iter().zip(stored).enumerate() {
            let after = (before + k + 1) as i64;
            let prediction = offer::dto(
                model.arm.as_ref(),
                &step.checked,
                &step.opts,
                done.prediction_id,
                after,
                version,
            );
            self.metrics.record_prediction(step.checked.reason());
            waypoints.push(Taught {
                waypoint: waypoint(done.row)?,
                prediction,
                repeat: false,
            });
        }
        drop(locked);
        let s = &prepared.segmentation;
        tracing::info!(
            routine = routine_id,
            samples = s.samples,
            kept = s.kept,
            segments = s.segments.len(),
            appended = waypoints.len(),
            mean_error_mm = s.mean_error_mm,
            "trajectory taught"
        );
        Ok(answer(&prepared, &targets, false, waypoints))
    }
}

/// One waypoint taught from the trajectory, before it is stored.
struct Step {
    sample: usize,
    reach: Option<Reachability>,
    opts: crate::engine::PredictOptions,
    checked: offer::Checked,
}

/// The samples' joints against the cell's arm (one value per joint); they all have as many
/// as the first (checked in [`prepare`]).
fn check_joints_with(arm: &super::reach::CellArm, prepared: &Prepared) -> Result<()> {
    match prepared.joints.first() {
        Some(Some(j)) => arm.check_joints(j),
        _ => Ok(()),
    }
}

/// The engine's settings from the request's (defaults for what is left out), checked.
fn segment_settings(s: &TrajectorySettings) -> Result<SegmentSettings> {
    let mut out = SegmentSettings::default();
    if let Some(v) = s.epsilon_max {
        out.epsilon_max = v;
    }
    if let Some(v) = s.criterion {
        out.criterion = v;
    }
    if let Some(v) = s.min_step_mm {
        out.min_step_mm = v;
    }
    if let Some(v) = s.rotation_mm_per_rad {
        // Its bound is checked with the others by `SegmentSettings::validate` below.
        out.rotation_mm_per_rad = v;
    }
    if let Some(v) = s.zeta_mm {
        out.zeta_mm = v;
    }
    if let Some(v) = s.min_segment_steps {
        if v > MAX_TRAJECTORY_SAMPLES {
            return Err(AppError::Trajectory(TrajectoryError::Settings(format!(
                "min_segment_steps = {v} is above {MAX_TRAJECTORY_SAMPLES}, the most samples a trajectory may hold"
            ))));
        }
        out.min_segment_steps = v;
    }
    if let Some(v) = s.kappa_max {
        out.fit.kappa_max = v;
    }
    if let Some(v) = s.rank_tolerance {
        out.fit.rank_tolerance = v;
    }
    out.validate()?;
    Ok(out)
}

/// Checks every sample (count, pose, joints, times) and segments the trajectory.
fn prepare(input: &TrajectoryRequest) -> Result<Prepared> {
    let mut settings = segment_settings(&input.settings)?;
    let n = input.samples.len();
    if n > MAX_TRAJECTORY_SAMPLES {
        return Err(AppError::Invalid(format!(
            "a trajectory may hold at most {MAX_TRAJECTORY_SAMPLES} samples, got {n}"
        )));
    }
    if n < 2 {
        return Err(TrajectoryError::TooFewSamples(n).into());
    }
    let joint_count = input.samples[0].joints.as_ref().map(Vec::len);
    let mut samples = Vec::with_capacity(n);
    let mut joints = Vec::with_capacity(n);
    for (index, s) in input.samples.iter().enumerate() {
        let sample_pose = |source| AppError::SamplePose { index, source };
        // The check of every entering pose, which also keeps the engine's segmentation within
        // its bounds (±100 m against its ±1 km).
        let pose = s.pose.to_pose().map_err(sample_pose)?;
        // As it will be read back from the database (see `append_waypoint`).
        let pose = PoseValues::from(&pose).to_pose().map_err(sample_pose)?;
        samples.push(TimedPose { t: s.t, pose });
        check_sample_joints(index, s.joints.as_deref(), joint_count)?;
        joints.push(s.joints.clone());
    }
    segment::validate(&samples)?;
    // Each segment's reproduction stops after its share of the budgets (at most the engine's
    // limit), so that a trajectory of many segments, or a long one, whose reproductions
    // converge slowly takes bounded time and memory: first among as many segments as there
    // can be, again among those there are when that was too little for them to converge.
    // (The attractors do not depend on it; `converged` and the errors do.)
    let most = settings.max_reproduction_steps;
    let states = segment::states(&samples, settings.rotation_mm_per_rad);
    let kept = segment::thin(&states, settings.min_step_mm).len();
    let possible = kept.saturating_sub(1).div_ceil(settings.min_segment_steps);
    let first = reproduction_steps(n, possible, most);
    settings.max_reproduction_steps = first;
    let mut segmentation = segment::segment(&samples, &settings)?;
    let share = reproduction_steps(n, segmentation.segments.len(), most);
    if !segmentation.converged && share > first {
        settings.max_reproduction_steps = share;
        segmentation = segment::segment(&samples, &settings)?;
    }
    Ok(Prepared {
        samples,
        joints,
        settings,
        segmentation,
    })
}

/// Joints on every sample or on none, as many on each as on the first, finite.
fn check_sample_joints(index: usize, joints: Option<&[f64]>, count: Option<usize>) -> Result<()> {
    match (joints, count) {
        (None, None) => Ok(()),
        (None, Some(_)) => Err(AppError::Invalid(format!(
            "sample {index} has no joints but sample 0 has: give joints on every sample or on none"
        ))),
        (Some(_), None) => Err(AppError::Invalid(format!(
            "sample {index} has joints but sample 0 has none: give joints on every sample or on \
             none"
        ))),
        (Some(j), Some(_)) if j.is_empty() || j.len() > MAX_JOINTS => {
            Err(AppError::Invalid(format!(
                "sample {index}: joints must hold 1 to {MAX_JOINTS} values, not {}",
                j.len()
            )))
        }
        (Some(j), Some(k)) if j.len() != k => Err(AppError::Invalid(format!(
            "sample {index}: {} joint values, but sample 0 has {k}",
            j.len()
        ))),
        (Some(j), Some(_)) => {
            check_joints_finite(j).map_err(|e| AppError::Invalid(format!("sample {index}: {e}")))
        }
    }
}

/// Steps each of `segments` segments of a trajectory of `samples` samples may take in its
/// reproduction: its share of [`REPRODUCTION_BUDGET`] and [`REPRODUCTION_ERROR_BUDGET`], at
/// most `most` (the engine's limit).
fn reproduction_steps(samples: usize, segments: usize, most: usize) -> usize {
    let memory = REPRODUCTION_BUDGET / segments.max(1);
    let time = REPRODUCTION_ERROR_BUDGET / (3 * samples.max(1));
    memory.min(time).clamp(1, most)
}

/// The distance between two poses as the segmentation measures a step: position (mm) and
/// rotation angle weighted by `rotation_mm_per_rad`.
fn step_mm(a: &Pose, b: &Pose, rotation_mm_per_rad: f64) -> f64 {
    let angle = a.angle_to(b) * rotation_mm_per_rad;
    a.distance_to(b).hypot(angle)
}

/// The samples appended, in order (see the module docs): the first sample and each attractor,
/// each unless closer than `min_step_mm` to the waypoint before it.
fn targets(prepared: &Prepared, last: Option<&Pose>) -> Vec<Target> {
    let s = &prepared.settings;
    let mut out = Vec::new();
    let mut previous = last.copied();
    let candidates = std::iter::once(0).chain(prepared.segmentation.attractors());
    for i in candidates {
        let pose = prepared.samples[i].pose;
        let far = previous
            .as_ref()
            .is_none_or(|p| step_mm(p, &pose, s.rotation_mm_per_rad) >= s.min_step_mm);
        if far {
            out.push(i);
            previous = Some(pose);
        }
    }
    out
}

fn point(prepared: &Prepared, i: usize, taught: bool) -> TrajectoryPoint {
    let s = &prepared.samples[i];
    TrajectoryPoint {
        sample: i,
        t: s.t,
        pose: PoseValues::from(&s.pose),
        joints: prepared.joints[i].clone(),
        taught,
    }
}

fn answer(
    prepared: &Prepared,
    targets: &[Target],
    preview: bool,
    waypoints: Vec<Taught>,
) -> TrajectoryAnswer {
    let seg = &prepared.segmentation;
    let attractors = seg
        .segments
        .iter()
        .map(|s| point(prepared, s.to, targets.contains(&s.to)))
        .collect();
    let segments = seg
        .segments
        .iter()
        .map(|s| TrajectorySegment {
            from: s.from,
            to: s.to,
            steps: s.steps,
            rank: s.fit.rank,
            condition: Some(s.fit.condition).filter(|c| c.is_finite()),
            identity: s.fit.identity,
            alpha: s.fit.alpha,
            epsilon: s.epsilon,
            // nalgebra stores column-major: the transpose's storage is R row by row.
            r: s.fit.r.transpose().as_slice().to_vec(),
        })
        .collect();
    TrajectoryAnswer {
        preview,
        start: point(prepared, 0, targets.first() == Some(&0)),
        attractors,
        waypoints,
        segmentation: api::Segmentation {
            samples: seg.samples,
            kept: seg.kept,
            segments,
            mean_error_mm: seg.mean_error_mm,
            max_error_mm: seg.max_error_mm,
            converged: seg.converged,
            parameters: seg.parameters(),
            raw_parameters: seg.raw_parameters(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::api::TrajectorySample;

    fn sample(t: f64, x: f64, y: f64) -> TrajectorySample {
        TrajectorySample {
            t,
            pose: PoseValues {
                x,
                y,
                z: 0.0,
                qw: 1.0,
                qx: 0.0,
                qy: 0.0,
                qz: 0.0,
            },
            joints: None,
        }
    }

    fn request(samples: Vec<TrajectorySample>) -> TrajectoryRequest {
        TrajectoryRequest {
            samples,
            preview: false,
            settings: TrajectorySettings::default(),
        }
    }

    /// An L at 10 mm steps: the corner and the end are the attractors, the start comes first.
    #[test]
    fn an_l_gives_its_corner_and_end() {
        let mut samples: Vec<_> = (0..=10)
            .map(|i| sample(i as f64, 10.0 * i as f64, 0.0))
            .collect();
        samples.extend((1..=10).map(|i| sample(10.0 + i as f64, 100.0, 10.0 * i as f64)));
        let p = prepare(&request(samples)).unwrap();
        let t = targets(&p, None);
        assert_eq!(t, vec![0, 10, 20], "{:?}", p.segmentation.segments);
        // Starting where the routine already is: the start is not appended again.
        let here = p.samples[0].pose;
        assert_eq!(targets(&p, Some(&here)), vec![10, 20]);
    }

    #[test]
    fn a_still_arm_is_one_waypoint() {
        let samples = (0..5).map(|i| sample(i as f64, 1.0, 2.0)).collect();
        let p = prepare(&request(samples)).unwrap();
        assert_eq!(targets(&p, None), vec![0]);
    }

    #[test]
    fn mistakes_are_named() {
        let message = |r: TrajectoryRequest| prepare(&r).unwrap_err().to_string();
        assert!(message(request(vec![sample(0.0, 0.0, 0.0)])).contains("at least 2"));
        let backwards = vec![sample(1.0, 0.0, 0.0), sample(1.0, 5.0, 0.0)];
        assert!(message(request(backwards)).contains("sample 1"));
        let mut far = vec![sample(0.0, 0.0, 0.0), sample(1.0, 2e6, 0.0)];
        let said = message(request(far.clone()));
        assert!(
            said.contains("sample 1: invalid pose: x = 2000000.0 is outside ±100000 mm"),
            "{said}"
        );
        far[1].pose.x = 5.0;
        far[1].pose.qw = 0.5;
        let e = prepare(&request(far.clone())).unwrap_err();
        assert_eq!(e.code(), "invalid_pose");
        assert!(e.to_string().starts_with("sample 1: invalid pose"), "{e}");
        far[1].pose.qw = 1.0;
        far[1].joints = Some(vec![0.0; 6]);
        assert!(message(request(far.clone())).contains("sample 1 has joints"));
        let mut r = request(far);
        r.samples[1].joints = None;
        r.settings.epsilon_max = Some(0.0);
        let e = prepare(&r).unwrap_err();
        assert_eq!(e.code(), "invalid_settings");
        assert!(e.to_string().contains("epsilon_max"), "{e}");
        r.settings.epsilon_max = None;
        r.settings.rotation_mm_per_rad = Some(1e300);
        assert!(
            prepare(&r)
                .unwrap_err()
                .to_string()
                .contains("rotation_mm_per_rad")
        );
    }

    #[test]
    fn the_reproduction_budgets_are_shared() {
        let most = SegmentSettings::default().max_reproduction_steps;
        assert_eq!(reproduction_steps(20, 3, most), most);
        // Long: the distances to the reproduced path bound it.
        assert_eq!(reproduction_steps(20_000, 4, most), 500);
        // Many segments: their states bound it.
        assert_eq!(reproduction_steps(1000, 5000, most), 400);
        assert_eq!(reproduction_steps(20_000, 0, most), 500);
    }
}
