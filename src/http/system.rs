//! Operations endpoints: `/healthz` (checks the database) and `/metrics` (Prometheus).

use std::sync::Arc;

use axum::Extension;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::IntoResponse;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::middleware::Authentication;
use crate::api::{ErrorBody, Health};
use crate::app::App;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(healthz))
        .routes(routes!(metrics))
}

/// Liveness and readiness: the database answers. Never requires the bearer token.
#[utoipa::path(get, path = "/healthz", tag = "system", security(()),
    responses(
        (status = 200, description = "Healthy", body = Health),
        (status = 503, description = "The database does not answer", body = ErrorBody),
    ))]
async fn healthz(
    State(app): State<Arc<App>>,
    Extension(auth): Extension<Authentication>,
) -> Result<axum::Json<Health>, ApiError> {
    let health = match app.health().await {
        Ok(()) => app.asks_for_token(auth.token_required).await,
        Err(e) => Err(e),
    };
    match health {
        Ok(token_required) => Ok(axum::Json(Health {
            status: "ok".into(),
            token_required,
        })),
        Err(e) => {
            tracing::error!(error = %e, "health check failed");
            Err(ApiError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "unavailable",
                "the database does not answer",
            ))
        }
    }
}

/// Prometheus metrics (OpenMetrics text): requests and latency per route, predictions offered
/// and withheld by reason.
#[utoipa::path(get, path = "/metrics", tag = "system",
    responses((status = 200, description = "OpenMetrics text", content_type = "application/openmetrics-text", body = String)))]
async fn metrics(State(app): State<Arc<App>>) -> impl IntoResponse {
    (
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
        )],
        app.metrics().encode(),
    )
}
