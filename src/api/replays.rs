//! A replay of programs through the engine and the baselines: the scoreboard
//! (`POST /v1/replays`).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::imports::UploadedFile;

/// A replay of programs through the engine and the baselines (the scoreboard).
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReplayRequest {
    /// Program files to replay (as for an import). Give these or `cell_id`.
    #[schema(min_items = 1)]
    pub files: Option<Vec<UploadedFile>>,
    /// Replay a cell's stored programs (taught and imported), in the order they were created.
    pub cell_id: Option<i64>,
    /// Engine settings to start from (default `default`).
    pub profile: Option<crate::engine::Profile>,
    /// Complexity δ ∈ (0, 1].
    #[schema(exclusive_minimum = 0, maximum = 1)]
    pub delta: Option<f64>,
    /// Minimum confidence φ ∈ [0, 1].
    #[schema(minimum = 0, maximum = 1)]
    pub phi_min: Option<f64>,
    /// Moves a prediction conditions on (1–50).
    #[schema(minimum = 1, maximum = 50)]
    pub horizon: Option<usize>,
    /// Estimate the scale ψ.
    pub scale: Option<bool>,
}
