//! Feedback on offered predictions: accepted, adjusted (with the pose finally taught), rejected.

use super::cell_model;
use super::error::AppError;
use super::{App, Result};
use crate::api::{Feedback, FeedbackRecorded, PoseValues, Verdict};
use crate::storage::NewFeedback;

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
        self.store
            .insert_feedback(&NewFeedback {
                prediction_id,
                verdict: input.verdict.as_str(),
                pose: final_pose.as_ref().map(PoseValues::from),
                adjustment_mm,
            })
            .await
            .map_err(|e| match AppError::from(e) {
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
}
