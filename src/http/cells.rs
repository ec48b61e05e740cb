//! `/v1/cells`: work cells, their statistics and model rebuilds.

use std::sync::Arc;

use axum::Extension;
use axum::extract::State;
use axum::http::StatusCode;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::{Id, Json, Path, Query};
use crate::api::{
    ArmFrames, CalibrationRoutine, Cell, CellPatch, CellStats, CreateCell, ErrorBody, FramesQuery,
    ModelInfo, ReachQuery, Reachability,
};
use crate::app::{App, Caller, frames_joints};

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(create_cell, list_cells))
        .routes(routes!(get_cell, edit_cell, delete_cell))
        .routes(routes!(cell_stats))
        .routes(routes!(rebuild_model))
        .routes(routes!(calibrate))
        .routes(routes!(arm_frames))
        .routes(routes!(reach))
}

/// Create a work cell with its own model and settings.
#[utoipa::path(post, path = "/v1/cells", tag = "cells",
    request_body = CreateCell,
    responses(
        (status = 201, description = "Created", body = Cell),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 409, description = "Name taken", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid settings or unknown fields", body = ErrorBody),
    ))]
async fn create_cell(
    State(app): State<Arc<App>>,
    Json(body): Json<CreateCell>,
) -> Result<(StatusCode, axum::Json<Cell>), ApiError> {
    Ok((
        StatusCode::CREATED,
        axum::Json(app.create_cell(body).await?),
    ))
}

/// List the work cells (those the token is limited to, if it is).
#[utoipa::path(get, path = "/v1/cells", tag = "cells",
    responses((status = 200, description = "The cells the token may touch (all when it is not limited)", body = [Cell])))]
async fn list_cells(
    State(app): State<Arc<App>>,
    caller: Option<Extension<Caller>>,
) -> Result<axum::Json<Vec<Cell>>, ApiError> {
    let caller = caller.map_or_else(Caller::anonymous, |Extension(c)| c);
    Ok(axum::Json(app.visible_cells(&caller).await?))
}

/// One work cell.
#[utoipa::path(get, path = "/v1/cells/{cell_id}", tag = "cells",
    params(("cell_id" = i64, Path, description = "Cell id")),
    responses(
        (status = 200, description = "The cell", body = Cell),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
    ))]
async fn get_cell(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
) -> Result<axum::Json<Cell>, ApiError> {
    Ok(axum::Json(app.get_cell(cell_id).await?))
}

/// Model statistics and the feedback operators gave on the cell's predictions.
#[utoipa::path(get, path = "/v1/cells/{cell_id}/stats", tag = "cells",
    params(("cell_id" = i64, Path, description = "Cell id")),
    responses(
        (status = 200, description = "Statistics", body = CellStats),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
    ))]
async fn cell_stats(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
) -> Result<axum::Json<CellStats>, ApiError> {
    Ok(axum::Json(app.cell_stats(cell_id).await?))
}

/// Re-learn the cell's model from its stored finished routines, in the order they were
/// finished (and take up the routine being taught).
#[utoipa::path(post, path = "/v1/cells/{cell_id}/rebuild", tag = "cells",
    params(("cell_id" = i64, Path, description = "Cell id")),
    responses(
        (status = 200, description = "The rebuilt model", body = ModelInfo),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
    ))]
async fn rebuild_model(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
) -> Result<axum::Json<ModelInfo>, ApiError> {
    Ok(axum::Json(app.rebuild(cell_id).await?))
}

/// A calibration routine: one point recorded several times (at least 3) by the cell's
/// operator. The poses' scatter becomes the cell's teaching noise, set (no longer learned), as
/// a settings change: the model is learned again with it and its version advances.
#[utoipa::path(post, path = "/v1/cells/{cell_id}/calibration", tag = "cells",
    params(("cell_id" = i64, Path, description = "Cell id")),
    request_body = CalibrationRoutine,
    responses(
        (status = 200, description = "The cell with its new noise", body = Cell),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Fewer than 3 poses, a pose that is none, or a scatter above the most a cell may have", body = ErrorBody),
    ))]
async fn calibrate(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
    Json(body): Json<CalibrationRoutine>,
) -> Result<axum::Json<Cell>, ApiError> {
    Ok(axum::Json(app.calibrate(cell_id, body).await?))
}

/// Rename a cell and/or change its settings (engine overrides, tolerance and noise, robot,
/// base and tool frames, reach policy, export): only the fields given change, validated like a
/// new cell's. New settings advance the model version and the model is learned again with
/// them; `settings_changed_at` says when.
#[utoipa::path(patch, path = "/v1/cells/{cell_id}", tag = "cells",
    params(("cell_id" = i64, Path, description = "Cell id")),
    request_body = CellPatch,
    responses(
        (status = 200, description = "Changed", body = Cell),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
        (status = 409, description = "Name taken", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid name or settings, or unknown fields", body = ErrorBody),
    ))]
async fn edit_cell(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
    Json(body): Json<CellPatch>,
) -> Result<axum::Json<Cell>, ApiError> {
    Ok(axum::Json(app.edit_cell(cell_id, body).await?))
}

/// Delete a cell with its programs, routines, predictions and feedback.
#[utoipa::path(delete, path = "/v1/cells/{cell_id}", tag = "cells",
    params(("cell_id" = i64, Path, description = "Cell id")),
    responses(
        (status = 204, description = "Deleted"),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
    ))]
async fn delete_cell(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
) -> Result<StatusCode, ApiError> {
    app.delete_cell(cell_id).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// The frames of the cell's arm at a joint vector (its ready position when `joints` is left
/// out), in the cell's work frame: what a pendant draws, so it does no kinematics of its own.
#[utoipa::path(get, path = "/v1/cells/{cell_id}/frames", tag = "robots",
    params(("cell_id" = i64, Path, description = "Cell id"), FramesQuery),
    responses(
        (status = 200, description = "The arm's frames", body = ArmFrames),
        (status = 400, description = "Malformed id or query", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
        (status = 409, description = "The cell's robot model is not installed", body = ErrorBody),
        (status = 422, description = "Not six finite joint values", body = ErrorBody),
    ))]
async fn arm_frames(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
    Query(q): Query<FramesQuery>,
) -> Result<axum::Json<ArmFrames>, ApiError> {
    Ok(axum::Json(
        app.arm_frames(cell_id, frames_joints(&q)?).await?,
    ))
}

/// Whether the cell's arm reaches a TCP pose, and the joint solution nearest where the arm is
/// (`near`): a jog step's target, checked before the arm moves.
#[utoipa::path(post, path = "/v1/cells/{cell_id}/reach", tag = "robots",
    params(("cell_id" = i64, Path, description = "Cell id")),
    request_body = ReachQuery,
    responses(
        (status = 200, description = "The verdict and the solution chosen", body = Reachability),
        (status = 400, description = "Malformed id or JSON", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
        (status = 409, description = "The cell's robot model is not installed", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid pose, joints or unknown fields", body = ErrorBody),
    ))]
async fn reach(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
    Json(body): Json<ReachQuery>,
) -> Result<axum::Json<Reachability>, ApiError> {
    Ok(axum::Json(app.reach(cell_id, body).await?))
}
