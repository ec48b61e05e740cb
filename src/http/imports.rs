//! `/v1/cells/{cell_id}/imports`: offline programs (ABB RAPID, KUKA KRL, FANUC TP) into a cell.

use std::sync::Arc;

use axum::extract::State;
use axum::http::StatusCode;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::{Id, Json, Path};
use crate::api::{ErrorBody, ImportRequest, ImportResult};
use crate::app::App;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new().routes(routes!(import_programs))
}

/// Import offline program files into a cell as new programs (finished routines), optionally
/// learning them in program order. Everything or nothing: a syntax error names file, line and
/// column and imports nothing. The response lists what was imported and what was skipped and
/// why (joint moves, targets computed at run time, ...).
#[utoipa::path(post, path = "/v1/cells/{cell_id}/imports", tag = "programs",
    params(("cell_id" = i64, Path, description = "Cell id")),
    request_body = ImportRequest,
    responses(
        (status = 201, description = "Imported", body = ImportResult),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such cell", body = ErrorBody),
        (status = 409, description = "A program name is taken, or the cell is teaching a routine", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Unsupported file or syntax error (file:line:column)", body = ErrorBody),
    ))]
async fn import_programs(
    State(app): State<Arc<App>>,
    Path(Id(cell_id)): Path<Id>,
    Json(body): Json<ImportRequest>,
) -> Result<(StatusCode, axum::Json<ImportResult>), ApiError> {
    Ok((
        StatusCode::CREATED,
        axum::Json(app.import(cell_id, body).await?),
    ))
}
