//! A cell's settings as clients give and see them: the engine's (a named profile with
//! overrides), the robot model and its frames, the teaching noise and tolerance, and what exported
//! programs carry. The service fills in and checks them (`app::settings`) and stores them
//! resolved, so a cell's behaviour does not change when a default does.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::PoseValues;
use crate::engine::Noise;
use crate::engine::Profile;
use crate::engine::Tolerance;
use crate::export::ExportSettings;
use crate::kinematics::ReachPolicy;

/// Scale estimation settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ScaleSettings {
    pub enabled: bool,
    /// Bracket for ψ (0 < psi_min < 1 < psi_max).
    #[schema(exclusive_minimum = 0.0, exclusive_maximum = 1.0)]
    pub psi_min: f64,
    #[schema(exclusive_minimum = 1.0)]
    pub psi_max: f64,
}

/// A cell's settings, resolved.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CellSettings {
    pub profile: Profile,
    /// Complexity δ ∈ (0, 1]: larger → stricter merging, more states.
    pub delta: f64,
    /// Minimum confidence φ ∈ [0, 1] for a prediction to be offered.
    pub phi_min: f64,
    /// Moves a prediction conditions on (h, 1–50).
    pub horizon: usize,
    /// Translation repeatability σ_t (mm) of the precision matrix.
    pub sigma_t_mm: f64,
    /// Quaternion-component repeatability σ_q of the precision matrix.
    pub sigma_q: f64,
    pub scale: ScaleSettings,
    /// Robot model (a URDF in `robots/`; `GET /v1/robots` lists them).
    pub robot: String,
    /// The robot base in the cell's work frame.
    pub base: PoseValues,
    /// The tool centre point in the flange frame.
    pub tool: PoseValues,
    /// Predictions the arm cannot reach: withheld (default) or offered flagged.
    pub reach_policy: ReachPolicy,
    /// Teaching noise, one sigma per axis of a taught waypoint. Null (a new cell's default):
    /// learned from the repeats in what the cell is taught, exact until they show otherwise
    /// (the cell's stats give the estimate). Given: fixed (0 for exact, offline programs; for
    /// a joystick operator, the scatter of a calibration routine: one point recorded several
    /// times). The experts match within the tolerance widened by it. A cell stored before noise
    /// was a setting reads as exact.
    #[serde(default = "exact_noise")]
    pub noise: Option<Noise>,
    /// Acceptance tolerance: a suggestion this close to what is then taught counts as right.
    /// Null (a new cell's default): learned, the seed's 1 mm / 0.1 rad until the cell's noise
    /// says its operator places less precisely (half their effective target width). Given:
    /// fixed (a joystick cell's is the operator's "close enough"). The offer rule's
    /// calibration learns from it. A cell stored before tolerance was a setting reads as 1 mm /
    /// 0.1 rad.
    #[serde(default = "seed_tolerance")]
    pub tolerance: Option<Tolerance>,
    /// A fixed offer threshold: a suggestion is offered when its `p_useful` reaches it (0–1).
    /// Null: the cell steers its own threshold so that `target_precision` of its offers are
    /// right (the default profile), or the profile has no offer rule (seed).
    #[serde(default)]
    pub offer_threshold: Option<f64>,
    /// The share of offers that should be right (0–1, default 0.85) when the cell steers its
    /// own threshold. Unused with a fixed `offer_threshold` or without an offer rule.
    #[serde(default = "target_precision")]
    pub target_precision: f64,
    /// Speed, zone, work object and tool written into exported controller programs.
    #[serde(default)]
    pub export: ExportSettings,
}

/// Settings given when a cell is created; anything left out takes the profile's value.
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CellSettingsInput {
    pub profile: Option<Profile>,
    /// Complexity δ ∈ (0, 1].
    #[schema(exclusive_minimum = 0.0, maximum = 1.0)]
    pub delta: Option<f64>,
    /// Minimum confidence φ ∈ [0, 1].
    #[schema(minimum = 0.0, maximum = 1.0)]
    pub phi_min: Option<f64>,
    /// Moves a prediction conditions on, 1 to 50.
    #[schema(minimum = 1, maximum = 50)]
    pub horizon: Option<usize>,
    /// Translation repeatability σ_t, 0.001 to 1000 mm.
    #[schema(minimum = 0.001, maximum = 1000.0)]
    pub sigma_t_mm: Option<f64>,
    /// Quaternion-component repeatability σ_q, 0.000001 to 1.
    #[schema(minimum = 0.000001, maximum = 1.0)]
    pub sigma_q: Option<f64>,
    pub scale: Option<ScaleSettings>,
    /// A robot model's name (`GET /v1/robots` lists them).
    #[schema(pattern = r"^[A-Za-z0-9_-]{1,64}$")]
    pub robot: Option<String>,
    pub base: Option<PoseValues>,
    pub tool: Option<PoseValues>,
    pub reach_policy: Option<ReachPolicy>,
    pub noise: Option<Noise>,
    pub tolerance: Option<Tolerance>,
    /// The cell's offer threshold on `p_useful`, 0 to 1 (left out: steered).
    #[schema(minimum = 0.0, maximum = 1.0)]
    pub offer_threshold: Option<f64>,
    /// The precision the cell steers its threshold to, 0 to 1.
    #[schema(minimum = 0.0, maximum = 1.0)]
    pub target_precision: Option<f64>,
    pub export: Option<ExportSettings>,
}

fn exact_noise() -> Option<Noise> {
    Some(Noise::EXACT)
}

fn seed_tolerance() -> Option<Tolerance> {
    Some(Tolerance::SEED)
}

fn target_precision() -> f64 {
    crate::engine::OfferRule::TARGET
}
