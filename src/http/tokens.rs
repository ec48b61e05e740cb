//! `/v1/tokens` (an admin's: bearer tokens with a role and cells) and `/v1/whoami` (anyone's
//! who is known). Who may call what is [`super::access`]'s.

use std::sync::Arc;

use axum::Extension;
use axum::extract::State;
use axum::http::StatusCode;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::{Json, Path};
use crate::api::{CreatedToken, ErrorBody, NewToken, Token, WhoAmI};
use crate::app::{App, Caller};

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(list_tokens, create_token))
        .routes(routes!(revoke_token))
        .routes(routes!(whoami))
}

/// Create a token (admin). The answer holds its secret, shown this once: only its SHA-256 is
/// stored.
#[utoipa::path(post, path = "/v1/tokens", tag = "system",
    request_body = NewToken,
    responses(
        (status = 201, description = "Created; the secret is shown this once", body = CreatedToken),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 401, description = "No known token", body = ErrorBody),
        (status = 403, description = "Not an admin, or one limited to some cells", body = ErrorBody),
        (status = 404, description = "A cell it names does not exist", body = ErrorBody),
        (status = 409, description = "An unrevoked token has that name", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Bad name or role", body = ErrorBody),
    ))]
async fn create_token(
    State(app): State<Arc<App>>,
    Json(body): Json<NewToken>,
) -> Result<(StatusCode, axum::Json<CreatedToken>), ApiError> {
    let created = app.create_token(body).await?;
    Ok((StatusCode::CREATED, axum::Json(created)))
}

/// The unrevoked tokens (admin), by name, without their secrets.
#[utoipa::path(get, path = "/v1/tokens", tag = "system",
    responses(
        (status = 200, description = "The tokens", body = Vec<Token>),
        (status = 401, description = "No known token", body = ErrorBody),
        (status = 403, description = "Not an admin, or one limited to some cells", body = ErrorBody),
    ))]
async fn list_tokens(State(app): State<Arc<App>>) -> Result<axum::Json<Vec<Token>>, ApiError> {
    Ok(axum::Json(app.tokens().await?))
}

/// Revoke a token (admin): from now on it is refused (401).
#[utoipa::path(delete, path = "/v1/tokens/{name}", tag = "system",
    params(("name" = String, Path, description = "Token name")),
    responses(
        (status = 204, description = "Revoked"),
        (status = 401, description = "No known token", body = ErrorBody),
        (status = 403, description = "Not an admin, or one limited to some cells", body = ErrorBody),
        (status = 404, description = "No unrevoked token of that name", body = ErrorBody),
    ))]
async fn revoke_token(
    State(app): State<Arc<App>>,
    Path(name): Path<String>,
) -> Result<StatusCode, ApiError> {
    app.revoke_token(&name).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Who the request's token says the caller is: name, role and cells.
#[utoipa::path(get, path = "/v1/whoami", tag = "system",
    responses(
        (status = 200, description = "The caller", body = WhoAmI),
        (status = 401, description = "No known token", body = ErrorBody),
    ))]
async fn whoami(
    State(app): State<Arc<App>>,
    caller: Option<Extension<Caller>>,
) -> axum::Json<WhoAmI> {
    let caller = caller.map_or_else(Caller::anonymous, |Extension(c)| c);
    axum::Json(app.whoami(&caller))
}
