//! `/v1/programs/{program_id}/history`, `…/diff` and `…/restore`: a program's revisions, the
//! program as of one, what changed between two, and a restore.

use std::sync::Arc;

use axum::extract::State;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::{Id, Json, Path, Query};
use crate::api::{
    DiffQuery, ErrorBody, HistoryQuery, ProgramDiff, ProgramHistory, ProgramRevision,
    RestoreProgram, Restored,
};
use crate::app::App;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(program_history))
        .routes(routes!(program_revision))
        .routes(routes!(diff_program))
        .routes(routes!(restore_program))
}

/// A program's revisions, newest first: every change to its routines or waypoints (teach,
/// undo, finish, modify, insert, delete, rename, move, import, re-target, restore) is one,
/// with who made it, when, and what it changed. Page on with `before` = the answer's `next`.
#[utoipa::path(get, path = "/v1/programs/{program_id}/history", tag = "history",
    params(("program_id" = i64, Path, description = "Program id"), HistoryQuery),
    responses(
        (status = 200, description = "A page of revisions, newest first", body = ProgramHistory),
        (status = 400, description = "Malformed id or query", body = ErrorBody),
        (status = 404, description = "No such program", body = ErrorBody),
        (status = 422, description = "A limit out of 1–1000 or a `before` below 1", body = ErrorBody),
    ))]
async fn program_history(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
    Query(query): Query<HistoryQuery>,
) -> Result<axum::Json<ProgramHistory>, ApiError> {
    Ok(axum::Json(app.program_history(program_id, query).await?))
}

/// The program as of a revision (0: when its history began): its routines and waypoints then.
/// `GET /v1/programs/{program_id}/export?revision=` exports it.
#[utoipa::path(get, path = "/v1/programs/{program_id}/history/{revision}", tag = "history",
    params(
        ("program_id" = i64, Path, description = "Program id"),
        ("revision" = i64, Path, minimum = 0, description = "Revision (0, 1, …)"),
    ),
    responses(
        (status = 200, description = "The program as of the revision", body = ProgramRevision),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such program, or the program has no such revision", body = ErrorBody),
        (status = 422, description = "A negative revision", body = ErrorBody),
    ))]
async fn program_revision(
    State(app): State<Arc<App>>,
    Path((Id(program_id), Id(revision))): Path<(Id, Id)>,
) -> Result<axum::Json<ProgramRevision>, ApiError> {
    Ok(axum::Json(
        app.program_revision(program_id, revision).await?,
    ))
}

/// What changed between two revisions of a program: routines and waypoints added and removed
/// (by id), routines renamed or moved, and waypoints changed, with how far each moved (mm)
/// and turned (degrees).
#[utoipa::path(get, path = "/v1/programs/{program_id}/diff", tag = "history",
    params(("program_id" = i64, Path, description = "Program id"), DiffQuery),
    responses(
        (status = 200, description = "The differences", body = ProgramDiff),
        (status = 400, description = "Malformed id or query", body = ErrorBody),
        (status = 404, description = "No such program, or the program has no such revision", body = ErrorBody),
        (status = 422, description = "A negative revision", body = ErrorBody),
    ))]
async fn diff_program(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
    Query(query): Query<DiffQuery>,
) -> Result<axum::Json<ProgramDiff>, ApiError> {
    Ok(axum::Json(app.diff_program(program_id, query).await?))
}

/// Restore a program to a revision: its routines, their names and order, and their waypoints
/// become what they were then (what comes back keeps its ids; a routine there now stays
/// finished if it is), as one new revision. The cell's model is learned again, as after any
/// edit. Nothing is written when the program is already equal to the revision.
#[utoipa::path(post, path = "/v1/programs/{program_id}/restore", tag = "history",
    params(("program_id" = i64, Path, description = "Program id")),
    request_body = RestoreProgram,
    responses(
        (status = 200, description = "Restored (or already equal)", body = Restored),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such program, or the program has no such revision", body = ErrorBody),
        (status = 409, description = "A routine being taught would come back while another is being taught, or the program changed meanwhile", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "A negative revision, or unknown fields", body = ErrorBody),
    ))]
async fn restore_program(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
    Json(body): Json<RestoreProgram>,
) -> Result<axum::Json<Restored>, ApiError> {
    Ok(axum::Json(app.restore_program(program_id, body).await?))
}
