//! Feedback on offered predictions: accepted, adjusted (with the pose finally taught), rejected.
//! Given while the routine is taught, it teaches the cell (`engine::experts::acceptance`).

use super::cell_model;
use super::error::AppError;
use super::registry::stale_check;
use super::{App, Result};
use crate::api::{Feedback, FeedbackRecorded, PoseValues, Verdict};
use crate::engine::Pose;
use crate::storage::{NewFeedback, PredictionRow};

impl App {
    pub async fn feedback(&self, prediction_id: i64, input: Feedback) -> Result<FeedbackRecorded> {
        let final_pose = match (input.verdict, &input.pose) {
            (Verdict::Adjusted, Some(p)) => Some(p.to_pose()?),
            (Verdict::Adjusted, None) => {
                return Err(AppError::Invalid(
                    "an adjusted prediction needs the pose finally taught".into(),
                ));
            }
            (_, Some(_)) => {
                return Err(AppError::Invalid(format!(
                    "a pose is only given with the verdict \"adjusted\", not {:?}",
                    input.verdict.as_str()
                )));
            }
            (_, None) => None,
        };
        let pr = self
            .store
            .prediction(prediction_id)
            .await?
            .ok_or_else(|| AppError::not_found("prediction", prediction_id))?;
        if let Some(v) = &pr.verdict {
            return Err(AppError::Conflict(format!(
                "prediction {prediction_id} already has feedback ({v})"
            )));
        }
        let predicted = cell_model::stored_pose_values(&pr.pose)?;
        let adjustment_mm = match (input.verdict, &final_pose) {
            (Verdict::Accepted, _) => Some(0.0),
            (Verdict::Adjusted, Some(f)) => Some(predicted.distance_to(f)),
            _ => None,
        };
        let fb = NewFeedback {
            prediction_id,
            verdict: input.verdict.as_str(),
            pose: final_pose.as_ref().map(PoseValues::from),
            adjustment_mm,
            teaches: false,
        };
        let taught = Judged {
            pr,
            predicted,
            verdict: input.verdict,
            taught_as: final_pose,
        };
        self.following(move |app| {
            let (fb, taught) = (fb.clone(), taught.clone());
            async move { app.store_feedback(fb, taught).await }
        })
        .await
        .map_err(|e| match e {
            AppError::Conflict(_) => {
                AppError::Conflict(format!("prediction {prediction_id} already has feedback"))
            }
            other => other,
        })?;
        Ok(FeedbackRecorded {
            prediction_id,
            verdict: input.verdict,
            adjustment_mm,
        })
    }

    /// Stores the feedback; it teaches the cell when given while its routine is being taught,
    /// with the waypoint the prediction was made after still the one before its place, and
    /// either before the next waypoint is taught (the pendant judges, then records) or just
    /// after (judged when recorded). The model applies it with that waypoint (now, or when it
    /// is taught: `cell_model::Verdicts`); a rebuild does the same from the database. Later
    /// feedback is kept and counted and teaches nothing (the waypoints taught since were judged
    /// without it).
    async fn store_feedback(&self, mut fb: NewFeedback, judged: Judged) -> Result<()> {
        let routine = judged.pr.routine_id;
        let (mut locked, r) = match self.lock_open_routine(routine).await {
            Ok(open) => open,
            Err(AppError::Conflict(_) | AppError::NotFound { .. }) => {
                return Ok(self.store.insert_feedback(&fb).await?);
            }
            Err(e) => return Err(e),
        };
        let model = locked.model()?;
        let Some(place) = judged.place(&model.open_ids) else {
            drop(locked);
            return Ok(self.store.insert_feedback(&fb).await?);
        };
        fb.teaches = true;
        let state = self
            .store
            .insert_teaching_feedback(&fb, r.cell_id, model.revision)
            .await
            .inspect_err(|e| stale_check(&mut locked, e))?;
        let model = locked.model()?;
        model.moved_to(state.revision);
        if place < model.open_ids.len() {
            let taught_as = judged.taught_as.as_ref();
            model
                .teacher
                .feedback(place, &judged.predicted, judged.verdict, taught_as);
        }
        Ok(())
    }
}

/// A verdict on a recorded prediction, before it is stored.
#[derive(Debug, Clone)]
struct Judged {
    pr: PredictionRow,
    predicted: Pose,
    verdict: Verdict,
    taught_as: Option<Pose>,
}

impl Judged {
    /// The place of the waypoint the verdict is about in the open routine whose waypoints are
    /// `open`, when the verdict teaches (see [`App::store_feedback`]).
    fn place(&self, open: &[i64]) -> Option<usize> {
        let place = usize::try_from(self.pr.after_seq).ok()?;
        let before = place.checked_sub(1).map(|i| open.get(i).copied());
        let context_holds = match before {
            None => self.pr.after_waypoint_id.is_none(),
            Some(id) => id.is_some() && id == self.pr.after_waypoint_id,
        };
        (context_holds && (open.len() == place || open.len() == place + 1)).then_some(place)
    }
}
