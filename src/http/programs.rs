//! `/v1/cells/{cell_id}/programs` and `/v1/programs`: programs of a cell.

use std::sync::Arc;

use axum::extract::State;
use axum::http::StatusCode;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::{Id, Json, Path, Query};
use crate::api::{
    CreateProgram, ErrorBody, ExportQuery, Program, ProgramExport, Rename, Retarget, Retargeted,
};
use crate::app::App;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(create_program, list_programs))
        .routes(routes!(get_program, rename_program, delete_program))
        .routes(routes!(export_program))
        .routes(routes!(retarget_program))
}

/// Create a program in a cell.
#[utoipa::path(post, path = "/v1/cells/{cell_id}/programs", tag = "programs",
    params(("cell_id" = i64, Path, description = "Cell id")),
    request_body = CreateProgram,
    responses(
        (status = 201, description = "Created", body = Program),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
        (status = 409, description = "Name taken in this cell", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid name or unknown fields", body = ErrorBody),
    ))]
async fn create_program(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
    Json(body): Json<CreateProgram>,
) -> Result<(StatusCode, axum::Json<Program>), ApiError> {
    Ok((
        StatusCode::CREATED,
        axum::Json(app.create_program(cell_id, body).await?),
    ))
}

/// List a cell's programs.
#[utoipa::path(get, path = "/v1/cells/{cell_id}/programs", tag = "programs",
    params(("cell_id" = i64, Path, description = "Cell id")),
    responses(
        (status = 200, description = "The cell's programs", body = [Program]),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
    ))]
async fn list_programs(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
) -> Result<axum::Json<Vec<Program>>, ApiError> {
    Ok(axum::Json(app.programs(cell_id).await?))
}

/// One program.
#[utoipa::path(get, path = "/v1/programs/{program_id}", tag = "programs",
    params(("program_id" = i64, Path, description = "Program id")),
    responses(
        (status = 200, description = "The program", body = Program),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such program", body = ErrorBody),
    ))]
async fn get_program(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
) -> Result<axum::Json<Program>, ApiError> {
    Ok(axum::Json(app.get_program(program_id).await?))
}

/// Rename a program.
#[utoipa::path(patch, path = "/v1/programs/{program_id}", tag = "programs",
    params(("program_id" = i64, Path, description = "Program id")),
    request_body = Rename,
    responses(
        (status = 200, description = "Renamed", body = Program),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such program", body = ErrorBody),
        (status = 409, description = "Name taken in this cell", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid name or unknown fields", body = ErrorBody),
    ))]
async fn rename_program(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
    Json(body): Json<Rename>,
) -> Result<axum::Json<Program>, ApiError> {
    Ok(axum::Json(app.rename_program(program_id, body).await?))
}

/// Delete a program with its routines; the routines the model learned leave it (the model is
/// rebuilt and its version advances).
#[utoipa::path(delete, path = "/v1/programs/{program_id}", tag = "programs",
    params(("program_id" = i64, Path, description = "Program id")),
    responses(
        (status = 204, description = "Deleted"),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such program", body = ErrorBody),
    ))]
async fn delete_program(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
) -> Result<StatusCode, ApiError> {
    app.delete_program(program_id).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Export a program as a controller file: RAPID (one `.mod`), KRL (a `.src` and its `.dat`) or
/// FANUC TP (one `.ls` per routine), in the cell's work frame, with names, motion types, the
/// cell's speed and zone (`settings.export`), and each target's arm configuration (RAPID
/// `confdata`, KRL `S`/`T`, FANUC `CONFIG`) from the joint solution the service chooses. Targets
/// out of the arm's reach get a comment in the file and are listed in `unreachable`.
#[utoipa::path(get, path = "/v1/programs/{program_id}/export", tag = "programs",
    params(("program_id" = i64, Path, description = "Program id"), ExportQuery),
    responses(
        (status = 200, description = "The files and what the export had to say", body = ProgramExport),
        (status = 400, description = "Malformed id or query", body = ErrorBody),
        (status = 404, description = "No such program, or it has no such revision", body = ErrorBody),
        (status = 422, description = "Unknown format, or a setting the format cannot write", body = ErrorBody),
    ))]
async fn export_program(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
    Query(query): Query<ExportQuery>,
) -> Result<axum::Json<ProgramExport>, ApiError> {
    Ok(axum::Json(app.export_program(program_id, query).await?))
}

/// Re-target a program to a moved fixture: every waypoint moved with it (given the moved work
/// object's `frame`, or three `points` measured on the fixture before and after), checked for
/// reach, and stored as a new program (finished, not learned).
#[utoipa::path(post, path = "/v1/programs/{program_id}/retarget", tag = "editing",
    params(("program_id" = i64, Path, description = "Program id")),
    request_body = Retarget,
    responses(
        (status = 201, description = "The moved copy", body = Retargeted),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such program", body = ErrorBody),
        (status = 409, description = "The copy's name is taken in this cell", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Neither or both of frame and points, degenerate points, invalid name or unknown fields", body = ErrorBody),
    ))]
async fn retarget_program(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
    Json(body): Json<Retarget>,
) -> Result<(StatusCode, axum::Json<Retargeted>), ApiError> {
    Ok((
        StatusCode::CREATED,
        axum::Json(app.retarget_program(program_id, body).await?),
    ))
}
