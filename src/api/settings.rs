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
    pub psi_min: f64,
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
    /// Teaching noise, one sigma per axis of a taught waypoint (0 for exact, offline programs;
    /// for a joystick operator, the scatter of a calibration routine: one point recorded several
    /// times). The experts match within the tolerance widened by it.
    #[serde(default)]
    pub noise: Noise,
    /// Acceptance tolerance: a suggestion this close to what is then taught counts as right
    /// (the seed's 1 mm / 0.1 rad by default; a joystick cell's is the operator's "close
    /// enough"). The offer rule's calibration learns from it.
    #[serde(default)]
    pub tolerance: Tolerance,
    /// The offer rule's threshold: a suggestion is offered when its `p_useful` reaches it
    /// (0–1; the default profile's 0.7 gives ≥ 90 % precision on exact programs; a joystick
    /// cell may take less, since a near miss still saves most of a jog). None for a profile
    /// without an offer rule (seed).
    #[serde(default)]
    pub offer_threshold: Option<f64>,
    /// Speed, zone, work object and tool written into exported controller programs.
    #[serde(default)]
    pub export: ExportSettings,
}

/// Settings given when a cell is created; anything left out takes the profile's value.
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CellSettingsInput {
    pub profile: Option<Profile>,
    pub delta: Option<f64>,
    pub phi_min: Option<f64>,
    pub horizon: Option<usize>,
    pub sigma_t_mm: Option<f64>,
    pub sigma_q: Option<f64>,
    pub scale: Option<ScaleSettings>,
    pub robot: Option<String>,
    pub base: Option<PoseValues>,
    pub tool: Option<PoseValues>,
    pub reach_policy: Option<ReachPolicy>,
    pub noise: Option<Noise>,
    pub tolerance: Option<Tolerance>,
    pub offer_threshold: Option<f64>,
    pub export: Option<ExportSettings>,
}
