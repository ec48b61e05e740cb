//! Predictions of the next waypoint, offered or withheld, with the figures that decided
//! them and the check against the cell's arm.

use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::PoseValues;

/// Why no prediction is offered.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[schema(as = WithheldDto)]
pub struct Withheld {
    /// One of `nothing_taught`, `empty_model`, `too_few_states`, `no_match`, `likely_end`,
    /// `poor_match`, `low_confidence`, `wide_spread`, `little_evidence`, `unlikely` (the experts' best
    /// candidate is below the cell's p_useful threshold), `unreachable` (the
    /// cell's arm cannot reach the proposal; see `reachability`).
    pub reason: String,
    pub message: String,
}

/// A prediction of the next waypoint, offered or not, with every figure that decided it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[schema(as = PredictionDto)]
pub struct Prediction {
    /// Id of the recorded prediction, for feedback (offered predictions only).
    pub id: Option<i64>,
    pub offered: bool,
    /// Why it is withheld; null when offered.
    pub withheld: Option<Withheld>,
    /// The proposal checked against the cell's arm (null when nothing was proposed, or the
    /// cell's robot model is not installed).
    pub reachability: Option<Reachability>,
    /// The proposed next pose (null when nothing could be proposed).
    pub pose: Option<PoseValues>,
    /// The relative move from the last waypoint to the proposal, in the last waypoint's frame
    /// (SRHCT 7-vector: mm and a quaternion with `qw ≥ 0`).
    #[schema(value_type = Option<super::schema::mirror::RelativeMove>)]
    pub relative: Option<PoseValues>,
    /// Confidence φ ∈ [0, 1] (entropy of the next-state distribution).
    pub phi: f64,
    /// ψ: the factor mapping the taught window onto the learned pattern.
    pub psi: f64,
    /// Size of the routine relative to the learned pattern (1/ψ: 2 for a 2× copy).
    pub routine_scale: f64,
    /// Probability that the routine ends here.
    pub end_probability: f64,
    /// Match quality: mean squared Mahalanobis misfit of the window to its likeliest states
    /// (null without a window).
    pub misfit: Option<f64>,
    /// Expected squared Mahalanobis distance of the next move from the proposal.
    pub spread: Option<f64>,
    /// Earlier continuations of the matched states that agree with the proposal.
    pub support: f64,
    /// Moves the prediction conditioned on.
    pub window: usize,
    /// States of the model.
    pub states: usize,
    /// Waypoints of the routine when the prediction was made.
    pub after_waypoints: i64,
    pub model_version: i64,
    /// The estimated probability that the proposal is within the cell's tolerance of the next
    /// waypoint: the experts' offer rule offers the likeliest candidate when this reaches the
    /// threshold (null for the seed profile, which uses the model's own gates).
    pub p_useful: Option<f64>,
    /// Who proposed it: `model` (the CDHMM), `tool`, `work` or `absolute` (the sequence
    /// experts over tool-frame moves, work-frame moves and absolute poses), `template` (an
    /// earlier stretch placed anew, in a noisy cell) or `lattice` (the next point of a row or
    /// grid the routine walks); null for the seed profile.
    pub expert: Option<String>,
}

/// Per-request overrides of the cell's settings for `GET .../prediction`.
#[derive(Debug, Clone, Default, Serialize, Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct PredictQuery {
    /// Moves to condition on (1–50).
    #[param(minimum = 1, maximum = 50)]
    #[serde(default, deserialize_with = "super::integral::optional")]
    pub horizon: Option<usize>,
    /// Minimum confidence φ (0–1).
    #[param(minimum = 0, maximum = 1)]
    pub phi_min: Option<f64>,
    /// Estimate the routine's scale.
    pub scale: Option<bool>,
    /// Number of next waypoints to predict (open-loop completion, 1–100; stops at the first
    /// prediction that is not offered).
    #[param(minimum = 1, maximum = 100)]
    #[serde(default, deserialize_with = "super::integral::optional")]
    pub k: Option<usize>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct PredictionSet {
    pub routine_id: i64,
    /// The predictions in order; the last one says why the completion stopped when it is not
    /// offered.
    pub predictions: Vec<Prediction>,
}

/// Why a pose is unreachable, for clients.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[schema(as = UnreachableDto)]
pub struct Unreachable {
    /// `outside_reach`, `joint_limit` or `singular`.
    pub reason: String,
    pub message: String,
}

/// The joint nearest its limit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[schema(as = JointMarginDto)]
pub struct JointMargin {
    pub name: String,
    /// Radians to the nearer limit.
    pub margin_rad: f64,
}

/// Whether the cell's arm reaches a pose, and how.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[schema(as = ReachabilityDto)]
pub struct Reachability {
    pub robot: String,
    pub reachable: bool,
    /// Why not, when not.
    pub unreachable: Option<Unreachable>,
    /// Number of joint solutions within limits (multi-turn variants included).
    pub solutions: usize,
    /// The solution nearest the previous waypoint's joints (rad).
    pub chosen: Option<Vec<f64>>,
    /// Smallest singular value of the Jacobian at the chosen solution (singularity margin).
    pub sigma_min: Option<f64>,
    pub manipulability: Option<f64>,
    pub limiting_joint: Option<JointMargin>,
}
