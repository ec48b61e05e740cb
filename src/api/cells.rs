//! Cells: a robot work cell with its own model and settings, and what it has learned
//! (`/v1/cells`).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::PoseValues;
use super::settings::{CellSettings, CellSettingsInput};
use crate::engine::{Noise, Tolerance};

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateCell {
    /// Unique name of the work cell (not blank; at most 200 characters).
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub name: String,
    /// Engine, robot and frame settings; anything left out takes the profile's default.
    #[serde(default)]
    pub settings: CellSettingsInput,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Cell {
    pub id: i64,
    pub name: String,
    pub settings: CellSettings,
    pub created_at: String,
    /// When the settings last changed (`null`: as created).
    pub settings_changed_at: Option<String>,
}

/// Changes to a cell: its name, and settings given as at creation (only the fields given
/// change; the rest keep their values, except that a new profile brings its own offer rule
/// unless `offer_threshold` is given too). New settings are validated like a new cell's; the
/// model is learned again with them and its version advances.
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CellPatch {
    /// Not blank; at most 200 characters; unique.
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub name: Option<String>,
    pub settings: Option<CellSettingsInput>,
}

/// The learned model of a cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ModelInfo {
    pub states: usize,
    /// Distinct transitions between states.
    pub edges: usize,
    /// Mean out-degree (edges / states).
    pub perplexity: f64,
    /// Finished routines assimilated.
    pub routines: u32,
    /// Longest routine assimilated, in moves.
    pub depth: usize,
    /// Moves assimilated.
    pub observations: u64,
    /// Increases by one with every finished routine; predictions record it.
    pub version: i64,
}

/// What operators did with the offered predictions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct FeedbackStats {
    /// Predictions offered (recorded).
    pub offered: i64,
    pub accepted: i64,
    pub adjusted: i64,
    pub rejected: i64,
    /// Offered predictions without feedback yet.
    pub pending: i64,
    /// (accepted + adjusted) / predictions with feedback; null without feedback.
    pub acceptance: Option<f64>,
    /// Median distance (mm) between adjusted predictions and the pose finally taught.
    pub median_adjustment_mm: Option<f64>,
}

/// What the cell makes of its operator and how it offers now: each value set in the cell's
/// settings, or learned from what it was taught.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TeachingStats {
    /// Teaching noise, one sigma per axis of a taught waypoint.
    pub noise: Noise,
    /// The noise is learned from the repeats in the cell's routines (not set).
    pub noise_learned: bool,
    /// What counts as right: a suggestion this close to what is then taught.
    pub tolerance: Tolerance,
    /// The tolerance follows the noise (not set).
    pub tolerance_learned: bool,
    /// The threshold on `p_useful` a suggestion must reach to be offered now; null for a
    /// profile without an offer rule (seed).
    pub offer_threshold: Option<f64>,
    /// The cell steers the threshold itself, for `target_precision` (not set).
    pub threshold_steered: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct CellStats {
    pub cell_id: i64,
    pub model: ModelInfo,
    pub teaching: TeachingStats,
    pub feedback: FeedbackStats,
}

/// A calibration routine: one point recorded again and again by the cell's operator (jogging
/// away and back each time). The scatter of the poses about their mean becomes the cell's
/// teaching noise (set, no longer learned), and its tolerance follows unless set.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CalibrationRoutine {
    /// The recorded poses of the one point, in the cell's work frame (at least 3).
    #[schema(min_items = 3)]
    pub poses: Vec<PoseValues>,
}
