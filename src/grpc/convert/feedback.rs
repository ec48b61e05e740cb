//! Feedback: the operator's verdict on an offered prediction, with the pose taught instead when
//! it was adjusted.

use crate::api::{Feedback, FeedbackRecorded, Verdict};
use crate::grpc::pb;

use super::wire::{In, Wire, both_ways, enum_both_ways};

enum_both_ways!(Verdict => Verdict as "verdict" { Accepted, Adjusted, Rejected });

both_ways!(FeedbackRecorded => FeedbackRecorded { prediction_id, verdict, adjustment_mm });

/// A verdict is required; a pose comes with an adjustment.
pub fn feedback(r: pb::FeedbackRequest) -> In<Feedback> {
    Ok(Feedback {
        verdict: Wire::back(r.verdict, "verdict")?,
        pose: r.pose.map(Into::into),
    })
}

/// The request as a client sends it.
pub fn feedback_request(prediction_id: i64, f: Feedback) -> pb::FeedbackRequest {
    pb::FeedbackRequest {
        prediction_id,
        verdict: f.verdict.out(),
        pose: f.pose.map(Into::into),
    }
}
