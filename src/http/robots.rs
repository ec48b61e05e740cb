//! `/v1/robots`: the arm models cells can name.

use std::sync::Arc;

use axum::extract::State;
use axum::http::StatusCode;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::{Json, Path};
use crate::api::{ErrorBody, PlacementSearch, Placements, Robot, RobotUpload};
use crate::app::App;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(list_robots, upload_robot))
        .routes(routes!(get_robot, delete_robot))
        .routes(routes!(search_placements))
}

/// List the robot models.
#[utoipa::path(get, path = "/v1/robots", tag = "robots",
    responses((status = 200, description = "The robot models", body = [Robot])))]
async fn list_robots(State(app): State<Arc<App>>) -> axum::Json<Vec<Robot>> {
    axum::Json(app.robots())
}

/// One robot model: joint names and limits.
#[utoipa::path(get, path = "/v1/robots/{name}", tag = "robots",
    params(("name" = String, Path, description = "Robot model name")),
    responses(
        (status = 200, description = "The robot model", body = Robot),
        (status = 404, description = "No such robot", body = ErrorBody),
    ))]
async fn get_robot(
    State(app): State<Arc<App>>,
    Path(name): Path<String>,
) -> Result<axum::Json<Robot>, ApiError> {
    Ok(axum::Json(app.robot(&name)?))
}

/// Upload an arm model (URDF). It is checked as the bundled ones are: a serial chain of six
/// revolute joints with limits and velocities, and a closed-form solver (OPW: ortho-parallel
/// with a spherical wrist; UR) derived from it and checked against its forward kinematics.
#[utoipa::path(post, path = "/v1/robots", tag = "robots",
    request_body = RobotUpload,
    responses(
        (status = 201, description = "Uploaded; cells may name it", body = Robot),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 409, description = "Name taken", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Bad name, or a URDF that is not a usable arm (`invalid_robot` says what)", body = ErrorBody),
    ))]
async fn upload_robot(
    State(app): State<Arc<App>>,
    Json(body): Json<RobotUpload>,
) -> Result<(StatusCode, axum::Json<Robot>), ApiError> {
    let robot = app.upload_robot(body).await?;
    Ok((StatusCode::CREATED, axum::Json(robot)))
}

/// Delete an uploaded arm model that no cell names.
#[utoipa::path(delete, path = "/v1/robots/{name}", tag = "robots",
    params(("name" = String, Path, description = "Robot model name")),
    responses(
        (status = 204, description = "Deleted"),
        (status = 404, description = "No such robot", body = ErrorBody),
        (status = 409, description = "Bundled, or the arm of a cell", body = ErrorBody),
    ))]
async fn delete_robot(
    State(app): State<Arc<App>>,
    Path(name): Path<String>,
) -> Result<StatusCode, ApiError> {
    app.delete_robot(&name).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Search robot base placements that reach a program's waypoints (or a cell's, or given
/// poses), with margins from joint limits and singularities: best first.
#[utoipa::path(post, path = "/v1/robots/{name}/placements", tag = "robots",
    params(("name" = String, Path, description = "Robot model name")),
    request_body = PlacementSearch,
    responses(
        (status = 200, description = "The placements found, best first", body = Placements),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 404, description = "No such robot, program or cell", body = ErrorBody),
        (status = 409, description = "The program or cell has no waypoints yet", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Not exactly one source of targets, no targets, a bad pose or option", body = ErrorBody),
    ))]
async fn search_placements(
    State(app): State<Arc<App>>,
    Path(name): Path<String>,
    Json(body): Json<PlacementSearch>,
) -> Result<axum::Json<Placements>, ApiError> {
    Ok(axum::Json(app.search_placements(&name, body).await?))
}
