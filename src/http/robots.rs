//! `/v1/robots`: the arm models cells can name.

use std::sync::Arc;

use axum::extract::State;
use axum::http::StatusCode;
use serde::Serialize;
use utoipa::ToSchema;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::extract::{Json, Path};
use super::error::{ApiError, ErrorBody};
use crate::app::App;
use crate::app::resources::{PlacementSearch, Placements};
use crate::app::robots::{RobotInfo, RobotSource, RobotUpload};

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(list_robots, upload_robot))
        .routes(routes!(get_robot, delete_robot))
        .routes(routes!(search_placements))
}

/// One joint: limits (rad) and velocity limit (rad/s).
#[derive(Debug, Serialize, ToSchema)]
pub struct JointDto {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    pub velocity: f64,
}

/// A robot model (a bundled URDF in `robots/`, or one uploaded).
#[derive(Debug, Serialize, ToSchema)]
pub struct RobotDto {
    /// The name cells use (`abb_irb140`).
    pub name: String,
    pub source: RobotSource,
    /// The maker and its designation (`ABB`, `IRB 2600-12/1.65`), when known.
    pub maker: Option<String>,
    pub product: Option<String>,
    /// Rated payload (kg), from the data sheet, when known.
    pub payload_kg: Option<f64>,
    /// Reach (mm): the data sheet's, when known.
    pub reach_mm: Option<f64>,
    /// Reach (mm) computed from the kinematics: from the axis-1 line to the wrist centre at
    /// full stretch (UR arms: to the flange).
    pub computed_reach_mm: f64,
    /// Program languages of the arm's controller (`rapid`, `krl`, `fanuc`, `urscript`).
    pub languages: Vec<String>,
    /// Inverse-kinematics solver: `opw` (spherical wrist) or `ur`.
    pub solver: String,
    pub root: String,
    /// Poses are of this link (the flange) in the root frame, before the cell's tool frame.
    pub tip: String,
    pub joints: Vec<JointDto>,
}

fn dto(info: RobotInfo) -> RobotDto {
    let m = info.model;
    let sheet = info.datasheet;
    RobotDto {
        name: m.name,
        source: info.source,
        maker: sheet.maker,
        product: sheet.product,
        payload_kg: sheet.payload_kg,
        reach_mm: sheet.reach_mm,
        computed_reach_mm: sheet.computed_reach_mm,
        languages: sheet.languages,
        solver: serde_json::to_value(m.solver)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default(),
        root: m.root,
        tip: m.tip,
        joints: m
            .joints
            .into_iter()
            .map(|j| JointDto {
                name: j.name,
                lower: j.lower,
                upper: j.upper,
                velocity: j.velocity,
            })
            .collect(),
    }
}

/// List the robot models.
#[utoipa::path(get, path = "/v1/robots", tag = "robots",
    responses((status = 200, description = "The robot models", body = [RobotDto])))]
async fn list_robots(State(app): State<Arc<App>>) -> axum::Json<Vec<RobotDto>> {
    axum::Json(app.robots().into_iter().map(dto).collect())
}

/// One robot model: joint names and limits.
#[utoipa::path(get, path = "/v1/robots/{name}", tag = "robots",
    params(("name" = String, Path, description = "Robot model name")),
    responses(
        (status = 200, description = "The robot model", body = RobotDto),
        (status = 404, description = "No such robot", body = ErrorBody),
    ))]
async fn get_robot(
    State(app): State<Arc<App>>,
    Path(name): Path<String>,
) -> Result<axum::Json<RobotDto>, ApiError> {
    Ok(axum::Json(dto(app.robot(&name)?)))
}

/// Upload an arm model (URDF). It is checked as the bundled ones are: a serial chain of six
/// revolute joints with limits and velocities, and a closed-form solver (OPW: ortho-parallel
/// with a spherical wrist; UR) derived from it and checked against its forward kinematics.
#[utoipa::path(post, path = "/v1/robots", tag = "robots",
    request_body = RobotUpload,
    responses(
        (status = 201, description = "Uploaded; cells may name it", body = RobotDto),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 409, description = "Name taken", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Bad name, or a URDF that is not a usable arm (`invalid_robot` says what)", body = ErrorBody),
    ))]
async fn upload_robot(
    State(app): State<Arc<App>>,
    Json(body): Json<RobotUpload>,
) -> Result<(StatusCode, axum::Json<RobotDto>), ApiError> {
    let info = app.upload_robot(body).await?;
    Ok((StatusCode::CREATED, axum::Json(dto(info))))
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
