//! `/v1/audit`: the audit trail (an engineer's or an admin's), newest first, in pages.

use std::sync::Arc;

use axum::extract::State;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::Query;
use crate::api::{AuditPage, AuditQuery, ErrorBody};
use crate::app::App;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new().routes(routes!(audit))
}

/// The audit trail (engineer or admin, not limited to some cells): one entry per request
/// that changed something, who made it and how it was answered, newest first. Page on with
/// `before` = the answer's `next`.
#[utoipa::path(get, path = "/v1/audit", tag = "system",
    params(AuditQuery),
    responses(
        (status = 200, description = "A page of entries, newest first", body = AuditPage),
        (status = 400, description = "Malformed query", body = ErrorBody),
        (status = 401, description = "No known token", body = ErrorBody),
        (status = 403, description = "An operator, or a token limited to some cells", body = ErrorBody),
        (status = 422, description = "A limit out of 1–1000, a `before` below 1 or a `since` that is not RFC 3339", body = ErrorBody),
    ))]
async fn audit(
    State(app): State<Arc<App>>,
    Query(query): Query<AuditQuery>,
) -> Result<axum::Json<AuditPage>, ApiError> {
    Ok(axum::Json(app.audit(query).await?))
}
