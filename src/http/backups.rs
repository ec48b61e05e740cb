//! `/v1/backups`: a consistent copy of the database while the service serves (an admin
//! operation).

use std::sync::Arc;

use axum::extract::State;
use axum::http::StatusCode;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::Json;
use crate::api::{Backup, BackupRequest, ErrorBody};
use crate::app::App;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new().routes(routes!(create_backup))
}

/// Back up the database while the service serves (an admin route: behind the bearer token
/// like every route until roles exist). SQLite: a consistent copy (`VACUUM INTO`) of the
/// database as it was when the backup started, written into the server's backup directory
/// (`--backup-dir`, default `backups/` beside the database file) under the given file name or
/// `nextpose-<UTC time>.db`, checked with `PRAGMA integrity_check`, synced, and only then given
/// its name; an existing file is never replaced. `nextpose serve --db` on the copy serves the
/// same models and predictions. PostgreSQL is backed up with `pg_dump` instead (409
/// `backup_unsupported`). The copy goes on if the client hangs up or times out.
#[utoipa::path(post, path = "/v1/backups", tag = "system",
    request_body = BackupRequest,
    responses(
        (status = 201, description = "Written and checked", body = Backup),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 409, description = "A file of that name exists (`conflict`), or the database is PostgreSQL or in memory (`backup_unsupported`): nothing written", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Not a file name (a path, `..`, a hidden name, other characters)", body = ErrorBody),
    ))]
async fn create_backup(
    State(app): State<Arc<App>>,
    Json(body): Json<BackupRequest>,
) -> Result<(StatusCode, axum::Json<Backup>), ApiError> {
    let backup = app.backup(body).await?;
    Ok((StatusCode::CREATED, axum::Json(backup)))
}
