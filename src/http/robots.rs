//! `/v1/robots`: the arm models cells can name.

use std::sync::Arc;

use axum::extract::State;
use serde::Serialize;
use utoipa::ToSchema;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::extract::Path;
use super::error::{ApiError, ErrorBody};
use crate::app::App;
use crate::kinematics::RobotModel;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(list_robots))
        .routes(routes!(get_robot))
}

/// One joint: limits (rad) and velocity limit (rad/s).
#[derive(Debug, Serialize, ToSchema)]
pub struct JointDto {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    pub velocity: f64,
}

/// A robot model (from a URDF in `robots/`).
#[derive(Debug, Serialize, ToSchema)]
pub struct RobotDto {
    /// The name cells use (`abb_irb140`).
    pub name: String,
    /// Inverse-kinematics solver: `opw` (spherical wrist) or `ur`.
    pub solver: String,
    pub root: String,
    /// Poses are of this link (the flange) in the root frame, before the cell's tool frame.
    pub tip: String,
    pub joints: Vec<JointDto>,
}

fn dto(m: RobotModel) -> RobotDto {
    RobotDto {
        name: m.name,
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
