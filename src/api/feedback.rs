//! What an operator did with an offered prediction (`POST /v1/predictions/{id}/feedback`).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::PoseValues;
pub use crate::engine::experts::acceptance::Verdict;

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(as = FeedbackDto)]
pub struct Feedback {
    pub verdict: Verdict,
    /// The pose finally taught; required when `adjusted`, refused otherwise.
    pub pose: Option<PoseValues>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct FeedbackRecorded {
    pub prediction_id: i64,
    pub verdict: Verdict,
    /// Distance (mm) from the prediction to the final pose (0 when accepted as is).
    pub adjustment_mm: Option<f64>,
}
