//! `/v1/replays`: the accuracy scoreboard of the engine and the baselines on given programs.

use std::sync::Arc;

use axum::extract::State;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::Json;
use crate::api::{ErrorBody, ReplayRequest};
use crate::app::App;
use crate::replay::report::Report;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new().routes(routes!(replay))
}

/// Replay program files, or a cell's stored programs, through the engine (with the given
/// settings) and every baseline. The answer is the scoreboard of `nextpose replay`, in the form
/// `nextpose replay --json` writes: `config`, `totals` by method (`engine`, `repeat_last`,
/// `nearest_seq`, ..., `abs_seq`, ..., `work_seq`, ..., then the oracle bounds `oracle_tool`,
/// ...), `oracles` (what the bounds mean), `calibration` (with the experts' offer rule: the
/// reliability of the engine's `p_useful` by decile, its expected calibration error and the
/// risk-coverage curve of the offer threshold) and `programs`. Nothing is stored; each program
/// is learned from scratch.
#[utoipa::path(post, path = "/v1/replays", tag = "programs",
    request_body = ReplayRequest,
    responses(
        (status = 200, description = "The scoreboard", body = Object),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Neither or both of files and cell_id, bad settings, or unreadable files", body = ErrorBody),
    ))]
async fn replay(
    State(app): State<Arc<App>>,
    Json(body): Json<ReplayRequest>,
) -> Result<axum::Json<Report>, ApiError> {
    Ok(axum::Json(app.replay(body).await?))
}
