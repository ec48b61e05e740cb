//! Teaching: append a waypoint and get the prediction for the next one, undo, predict again
//! with per-request overrides or an open-loop completion.

use super::cell_model::Verdicts;
use super::error::AppError;
use super::offer;
use super::registry::{Locked, OpenRoutine, blocking, stale_check};
use super::rows::{motion_to_store, waypoint};
use super::settings::MAX_HORIZON;
use super::{App, MAX_COMPLETION, Result, check_joints_finite, check_name};
use crate::api::{self, PoseValues, PredictQuery, PredictionSet, Taught, Undone};
use crate::kinematics::Reachability;
use crate::storage::{Append, NewWaypoint};

impl App {
    pub(super) fn validate_waypoint(input: &api::NewWaypoint) -> Result<Option<String>> {
        if let Some(n) = &input.name {
            check_name("waypoint name", n)?;
        }
        if let Some(seq) = input.seq
            && seq < 1
        {
            return Err(AppError::Invalid(format!(
                "seq must be 1 or more (the seq the waypoint is to have), not {seq}"
            )));
        }
        match &input.joints {
            None => Ok(None),
            Some(j) if j.is_empty() || j.len() > 12 => Err(AppError::Invalid(format!(
                "joints must hold 1 to 12 values, not {}",
                j.len()
            ))),
            Some(j) => check_joints_finite(j).and_then(|()| {
                serde_json::to_string(j)
                    .map(Some)
                    .map_err(|e| AppError::Internal(e.to_string()))
            }),
        }
    }

    /// Appends a taught waypoint to an open routine and predicts the next one.
    pub async fn append_waypoint(
        &self,
        routine_id: i64,
        input: api::NewWaypoint,
    ) -> Result<Taught> {
        self.following(move |app| {
            let input = input.clone();
            async move { app.append_waypoint_now(routine_id, input).await }
        })
        .await
    }

    async fn append_waypoint_now(
        &self,
        routine_id: i64,
        input: api::NewWaypoint,
    ) -> Result<Taught> {
        // Everything the client can get wrong is checked before anything changes.
        let joints = Self::validate_waypoint(&input)?;
        let pose = input.pose.to_pose()?;
        let stored = PoseValues::from(&pose);
        // The model learns the pose as it will be read back from the database, so a rebuild
        // gives bit-identical results.
        let pose = stored.to_pose()?;
        let (mut locked, r) = self.lock_open_routine(routine_id).await?;
        // A verdict given before the waypoint is taught (the pendant judges, then records)
        // teaches with it; read with the cell's lock held, as verdicts are stored.
        let verdicts = Verdicts::of(&self.store, routine_id).await?;
        let model = locked.model()?;
        if let (Some(arm), Some(j)) = (&model.arm, &input.joints) {
            arm.check_joints(j)?;
        }
        let count = model.teacher.routine().len() as i64;
        let wp = NewWaypoint {
            routine_id,
            seq: count + 1,
            pose: stored,
            joints,
            motion: motion_to_store(input.motion),
            name: input.name.map(|n| n.trim().to_string()),
            reachable: None,
        };
        match input.seq {
            None => {}
            Some(seq) if seq == count + 1 => {}
            Some(seq) if seq == count && count > 0 => {
                return self.repeated(locked, &r, wp).await;
            }
            Some(seq) => {
                return Err(AppError::Conflict(format!(
                    "routine {routine_id} holds {count} waypoints: an append with seq {seq} \
                     is neither the next ({}) nor a retry of the last; reload the routine",
                    count + 1
                )));
            }
        }
        let taught_reach = model.teach(pose, input.joints.as_deref());
        model.judged(&verdicts);
        let (opts, checked) = offer::next(&model.teacher, model.arm.as_ref());
        let after = model.teacher.routine().len() as i64;
        let record = offer::record(&r, after, model.version, &checked);
        let wp = NewWaypoint {
            reachable: taught_reach.as_ref().map(Reachability::is_reachable),
            ..wp
        };
        let append = Append {
            cell_id: r.cell_id,
            expected_revision: model.revision,
            waypoint: wp,
            prediction: record,
        };
        let done = match self.store.append_waypoint(append).await {
            Ok(done) => done,
            Err(e) => {
                model.take_back();
                stale_check(&mut locked, &e);
                return Err(e.into());
            }
        };
        model.moved_to(done.revision);
        model.open_ids.push(done.row.id);
        let (row, id) = (done.row, done.prediction_id);
        let version = model.version;
        let prediction = offer::dto(model.arm.as_ref(), &checked, &opts, id, after, version);
        self.metrics.record_prediction(checked.reason());
        Ok(Taught {
            waypoint: waypoint(row)?,
            prediction,
            repeat: false,
        })
    }

    /// The answer to a retried append (`seq` of the routine's last waypoint): that waypoint and
    /// the prediction after it, when the retry carries the same values; nothing is stored.
    async fn repeated(
        &self,
        mut locked: Locked,
        r: &OpenRoutine,
        retry: NewWaypoint,
    ) -> Result<Taught> {
        let model = locked.model()?;
        let last = model.open_ids.last().copied().ok_or_else(|| {
            AppError::Internal(format!("routine {} has no waypoint id to repeat", r.id))
        })?;
        let row = self
            .store
            .waypoint(last)
            .await?
            .ok_or_else(|| AppError::Internal(format!("waypoint {last} is not stored")))?;
        // `last` is the routine's last waypoint, so its seq is the one the retry names.
        let same = row.pose == retry.pose
            && row.joints == retry.joints
            && row.motion == retry.motion
            && row.name == retry.name;
        if !same {
            return Err(AppError::Conflict(format!(
                "routine {} already holds waypoint {} (id {last}) with other values: an append \
                 with seq {} repeats only the same waypoint; reload the routine",
                r.id, row.seq, row.seq
            )));
        }
        let (opts, checked) = offer::next(&model.teacher, model.arm.as_ref());
        let after = model.teacher.routine().len() as i64;
        let version = model.version;
        let id = match offer::record(r, after, version, &checked) {
            Some(np) => Some(self.store.record_prediction(&np).await?),
            None => None,
        };
        Ok(Taught {
            waypoint: waypoint(row)?,
            prediction: offer::dto(model.arm.as_ref(), &checked, &opts, id, after, version),
            repeat: true,
        })
    }

    /// Removes the last waypoint of an open routine; the prediction rolls back with it.
    pub async fn undo(&self, routine_id: i64) -> Result<Undone> {
        self.following(move |app| async move { app.undo_now(routine_id).await })
            .await
    }

    async fn undo_now(&self, routine_id: i64) -> Result<Undone> {
        let (mut locked, r) = self.lock_open_routine(routine_id).await?;
        let expected = locked.model()?.revision;
        let (removed, state) = self
            .store
            .delete_last_waypoint(r.id, r.cell_id, expected)
            .await
            .inspect_err(|e| stale_check(&mut locked, e))?;
        let Some(removed) = removed else {
            return Err(AppError::Conflict(format!(
                "routine {routine_id} has no waypoint to undo"
            )));
        };
        let model = locked.model()?;
        model.moved_to(state.revision);
        model.open_ids.pop();
        model.take_back();
        let (opts, checked) = offer::next(&model.teacher, model.arm.as_ref());
        let after = model.teacher.routine().len() as i64;
        let version = model.version;
        let id = match offer::record(&r, after, version, &checked) {
            Some(np) => Some(self.store.record_prediction(&np).await?),
            None => None,
        };
        Ok(Undone {
            removed: waypoint(removed)?,
            prediction: offer::dto(model.arm.as_ref(), &checked, &opts, id, after, version),
        })
    }

    /// The prediction for an open routine as it stands, with per-request overrides; `k > 1`
    /// asks for an open-loop completion of up to k waypoints.
    pub async fn predict(&self, routine_id: i64, q: PredictQuery) -> Result<PredictionSet> {
        self.to_completion(move |app| async move { app.predict_now(routine_id, q).await })
            .await
    }

    async fn predict_now(&self, routine_id: i64, q: PredictQuery) -> Result<PredictionSet> {
        let k = q.k.unwrap_or(1);
        if !(1..=MAX_COMPLETION).contains(&k) {
            return Err(AppError::Invalid(format!(
                "k must be between 1 and {MAX_COMPLETION}"
            )));
        }
        if let Some(h) = q.horizon
            && !(1..=MAX_HORIZON).contains(&h)
        {
            return Err(AppError::Invalid(format!(
                "horizon must be between 1 and {MAX_HORIZON}"
            )));
        }
        if let Some(phi) = q.phi_min
            && !(0.0..=1.0).contains(&phi)
        {
            return Err(AppError::Invalid("phi_min must be between 0 and 1".into()));
        }
        let (locked, r) = self.lock_open_routine(routine_id).await?;
        // Up to k predictions, each checked for reach: CPU work, on a blocking thread (with
        // the cell's lock).
        let (mut locked, opts, checked) = blocking(move || -> Result<_> {
            let mut locked = locked;
            let model = locked.model()?;
            let mut opts = model.teacher.config().predict.clone();
            if let Some(h) = q.horizon {
                opts.horizon = h;
            }
            if let Some(phi) = q.phi_min {
                opts.phi_min = phi;
            }
            if let Some(s) = q.scale {
                opts.scale.enabled = s;
            }
            let arm = model.arm.as_ref();
            let checked = offer::complete(&model.teacher, arm, k, &opts);
            Ok((locked, opts, checked))
        })
        .await??;
        let model = locked.model()?;
        let version = model.version;
        let taught = model.teacher.routine().len() as i64;
        let arm = model.arm.as_ref();
        let mut out = Vec::with_capacity(checked.len());
        for (i, c) in checked.iter().enumerate() {
            let after = taught + i as i64;
            // The first prediction is recorded (once) so that feedback can refer to it.
            let id = match (i, offer::record(&r, after, version, c)) {
                (0, Some(np)) => Some(self.store.record_prediction(&np).await?),
                _ => None,
            };
            out.push(offer::dto(arm, c, &opts, id, after, version));
        }
        drop(locked);
        Ok(PredictionSet {
            routine_id,
            predictions: out,
        })
    }
}
