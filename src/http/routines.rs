//! Routines and teaching: `/v1/programs/{program_id}/routines`, `/v1/routines/...` (waypoints,
//! undo, finish, predictions), `/v1/waypoints/...` (editing) and
//! `/v1/predictions/{prediction_id}/feedback`.

use std::sync::Arc;

use axum::extract::State;
use axum::http::StatusCode;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

use super::error::ApiError;
use super::error::extract::{Id, Json, Path, Query};
use crate::api::{
    CreateRoutine, ErrorBody, Feedback, FeedbackRecorded, Finished, InsertWaypoint, NewWaypoint,
    PredictQuery, PredictionSet, Retarget, Retargeted, Routine, RoutineDetail, RoutineEdit,
    RoutinePatch, Taught, TrajectoryAnswer, TrajectoryRequest, Undone, WaypointEdit, WaypointPatch,
};
use crate::app::App;

pub fn router() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::new()
        .routes(routes!(create_routine, list_routines))
        .routes(routes!(get_routine, edit_routine, delete_routine))
        .routes(routes!(modify_waypoint, delete_waypoint))
        .routes(routes!(insert_waypoint))
        .routes(routes!(retarget_routine))
        .routes(routes!(append_waypoint))
        .routes(routes!(append_trajectory))
        .routes(routes!(undo_waypoint))
        .routes(routes!(finish_routine))
        .routes(routes!(predict))
        .routes(routes!(feedback))
}

/// Start a routine at the end of a program. A cell teaches one routine at a time.
#[utoipa::path(post, path = "/v1/programs/{program_id}/routines", tag = "routines",
    params(("program_id" = i64, Path, description = "Program id")),
    request_body(content = CreateRoutine, description = "Optional name; the body may be `{}`"),
    responses(
        (status = 201, description = "Created", body = Routine),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such program", body = ErrorBody),
        (status = 409, description = "Another routine of the cell is being taught", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid name or unknown fields", body = ErrorBody),
    ))]
async fn create_routine(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
    Json(body): Json<CreateRoutine>,
) -> Result<(StatusCode, axum::Json<Routine>), ApiError> {
    Ok((
        StatusCode::CREATED,
        axum::Json(app.create_routine(program_id, body).await?),
    ))
}

/// List a program's routines in order.
#[utoipa::path(get, path = "/v1/programs/{program_id}/routines", tag = "routines",
    params(("program_id" = i64, Path, description = "Program id")),
    responses(
        (status = 200, description = "The routines", body = [Routine]),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such program", body = ErrorBody),
    ))]
async fn list_routines(
    State(app): State<Arc<App>>,
    Path(Id(program_id)): Path<Id>,
) -> Result<axum::Json<Vec<Routine>>, ApiError> {
    Ok(axum::Json(app.routines(program_id).await?))
}

/// A routine with its waypoints in teaching order.
#[utoipa::path(get, path = "/v1/routines/{routine_id}", tag = "routines",
    params(("routine_id" = i64, Path, description = "Routine id")),
    responses(
        (status = 200, description = "The routine", body = RoutineDetail),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
    ))]
async fn get_routine(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
) -> Result<axum::Json<RoutineDetail>, ApiError> {
    Ok(axum::Json(app.get_routine(routine_id).await?))
}

/// Delete a routine with its waypoints: the one being taught is forgotten at once; a finished
/// one the model learned leaves it (the model is rebuilt and its version advances).
#[utoipa::path(delete, path = "/v1/routines/{routine_id}", tag = "routines",
    params(("routine_id" = i64, Path, description = "Routine id")),
    responses(
        (status = 204, description = "Deleted"),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
    ))]
async fn delete_routine(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
) -> Result<StatusCode, ApiError> {
    app.delete_routine(routine_id).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Append a taught waypoint; the response carries the prediction for the next one (or why
/// there is none). With `seq` (the routine's waypoint count + 1) the append is safe to retry:
/// a repeat of the last one stores nothing and answers it again.
#[utoipa::path(post, path = "/v1/routines/{routine_id}/waypoints", tag = "teaching",
    params(("routine_id" = i64, Path, description = "Routine id")),
    request_body = NewWaypoint,
    responses(
        (status = 200, description = "A retry (`seq` of the last waypoint, same values): nothing stored; the stored waypoint and the prediction after it (`repeat: true`)", body = Taught),
        (status = 201, description = "Stored; the prediction for the next waypoint", body = Taught),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
        (status = 409, description = "The routine is finished, or `seq` is neither the next nor a retry of the last waypoint", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid pose (a number not finite, a coordinate beyond ±100000 mm, a quaternion far from unit; the message names the field and value), joints or unknown fields", body = ErrorBody),
    ))]
async fn append_waypoint(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
    Json(body): Json<NewWaypoint>,
) -> Result<(StatusCode, axum::Json<Taught>), ApiError> {
    let taught = app.append_waypoint(routine_id, body).await?;
    let status = if taught.repeat {
        StatusCode::OK
    } else {
        StatusCode::CREATED
    };
    Ok((status, axum::Json(taught)))
}

/// Teach a hand-guided (lead-through) trajectory: its attractors become taught waypoints.
///
/// The recorded TCP trajectory is cut into linear dynamical systems, and their attractors are
/// appended as taught waypoints, in order, each answered with the prediction that follows it as
/// a single append is. The trajectory's first sample comes first, unless the routine's last
/// waypoint is within `min_step_mm` of it; an attractor within `min_step_mm` of the waypoint
/// before it is not appended. Each waypoint is the recorded sample (pose, and joints when the
/// samples carry them). All or nothing: a request that is refused changes nothing. With
/// `preview`, nothing is stored: the answer (200) shows the attractors, the segments and the
/// reproduction error.
#[utoipa::path(post, path = "/v1/routines/{routine_id}/trajectory", tag = "teaching",
    params(("routine_id" = i64, Path, description = "Routine id")),
    request_body = TrajectoryRequest,
    responses(
        (status = 200, description = "Preview: nothing stored", body = TrajectoryAnswer),
        (status = 201, description = "Stored: the waypoints appended, each with the prediction after it", body = TrajectoryAnswer),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
        (status = 409, description = "The routine is finished", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Too few or too many samples, times not increasing, an invalid pose or joints (named by the sample's place), invalid settings, nothing to append, or unknown fields", body = ErrorBody),
    ))]
async fn append_trajectory(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
    Json(body): Json<TrajectoryRequest>,
) -> Result<(StatusCode, axum::Json<TrajectoryAnswer>), ApiError> {
    let answer = app.append_trajectory(routine_id, body).await?;
    let status = if answer.preview {
        StatusCode::OK
    } else {
        StatusCode::CREATED
    };
    Ok((status, axum::Json(answer)))
}

/// Undo: delete the last waypoint of a routine being taught; the prediction rolls back.
#[utoipa::path(delete, path = "/v1/routines/{routine_id}/waypoints/last", tag = "teaching",
    params(("routine_id" = i64, Path, description = "Routine id")),
    responses(
        (status = 200, description = "The removed waypoint and the prediction now", body = Undone),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
        (status = 409, description = "The routine is finished or empty", body = ErrorBody),
    ))]
async fn undo_waypoint(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
) -> Result<axum::Json<Undone>, ApiError> {
    Ok(axum::Json(app.undo(routine_id).await?))
}

/// Finish a routine: it takes no more teaching (edits still apply) and the cell's model learns it.
#[utoipa::path(post, path = "/v1/routines/{routine_id}/finish", tag = "teaching",
    params(("routine_id" = i64, Path, description = "Routine id")),
    responses(
        (status = 200, description = "Finished; the model after learning it", body = Finished),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
        (status = 409, description = "Already finished", body = ErrorBody),
    ))]
async fn finish_routine(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
) -> Result<axum::Json<Finished>, ApiError> {
    Ok(axum::Json(app.finish_routine(routine_id).await?))
}

/// The prediction for the next waypoint of a routine being taught, with per-request
/// overrides; `k` > 1 asks for the next k waypoints (open-loop completion: each prediction is
/// applied and the next one predicted, stopping at the first that is not offered).
#[utoipa::path(get, path = "/v1/routines/{routine_id}/prediction", tag = "teaching",
    params(("routine_id" = i64, Path, description = "Routine id"), PredictQuery),
    responses(
        (status = 200, description = "The predictions", body = PredictionSet),
        (status = 400, description = "Malformed id or query", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
        (status = 409, description = "The routine is finished", body = ErrorBody),
        (status = 422, description = "Override out of range", body = ErrorBody),
    ))]
async fn predict(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
    Query(q): Query<PredictQuery>,
) -> Result<axum::Json<PredictionSet>, ApiError> {
    Ok(axum::Json(app.predict(routine_id, q).await?))
}

/// Feedback on an offered prediction: accepted as is, accepted after adjustment (with the
/// pose finally taught), or rejected. Once per prediction. Given just before or just after the
/// waypoint it is about, it teaches the cell (a rejection counts as wrong, adjustments tighten
/// the learned tolerance); an undo of that waypoint takes it back.
#[utoipa::path(post, path = "/v1/predictions/{prediction_id}/feedback", tag = "teaching",
    params(("prediction_id" = i64, Path, description = "Prediction id (from a prediction's `id`)")),
    request_body = Feedback,
    responses(
        (status = 201, description = "Recorded", body = FeedbackRecorded),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such prediction", body = ErrorBody),
        (status = 409, description = "Feedback already given", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Pose missing for `adjusted`, or invalid", body = ErrorBody),
    ))]
async fn feedback(
    State(app): State<Arc<App>>,
    Path(Id(prediction_id)): Path<Id>,
    Json(body): Json<Feedback>,
) -> Result<(StatusCode, axum::Json<FeedbackRecorded>), ApiError> {
    Ok((
        StatusCode::CREATED,
        axum::Json(app.feedback(prediction_id, body).await?),
    ))
}

/// Rename a routine and/or move it within its program; the answer carries its values before.
#[utoipa::path(patch, path = "/v1/routines/{routine_id}", tag = "routines",
    params(("routine_id" = i64, Path, description = "Routine id")),
    request_body = RoutinePatch,
    responses(
        (status = 200, description = "Changed; `previous` reverts it", body = RoutineEdit),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid name or position, or unknown fields", body = ErrorBody),
    ))]
async fn edit_routine(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
    Json(body): Json<RoutinePatch>,
) -> Result<axum::Json<RoutineEdit>, ApiError> {
    Ok(axum::Json(app.edit_routine(routine_id, body).await?))
}

/// Modify a waypoint of any routine, finished or being taught ("modify position"): the fields
/// given change. A changed pose in a learned routine rebuilds the cell's model and advances
/// its version; the answer carries the previous values.
#[utoipa::path(patch, path = "/v1/waypoints/{waypoint_id}", tag = "editing",
    params(("waypoint_id" = i64, Path, description = "Waypoint id")),
    request_body = WaypointPatch,
    responses(
        (status = 200, description = "Changed; `previous` reverts it", body = WaypointEdit),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such waypoint", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid pose, joints, name or unknown fields", body = ErrorBody),
    ))]
async fn modify_waypoint(
    State(app): State<Arc<App>>,
    Path(Id(waypoint_id)): Path<Id>,
    Json(body): Json<WaypointPatch>,
) -> Result<axum::Json<WaypointEdit>, ApiError> {
    Ok(axum::Json(app.modify_waypoint(waypoint_id, body).await?))
}

/// Delete a waypoint of any routine; the ones after it move up. The answer carries the deleted
/// values (`previous`), which an insert at its place reverts.
#[utoipa::path(delete, path = "/v1/waypoints/{waypoint_id}", tag = "editing",
    params(("waypoint_id" = i64, Path, description = "Waypoint id")),
    responses(
        (status = 200, description = "Deleted; `previous` holds it", body = WaypointEdit),
        (status = 400, description = "Malformed id", body = ErrorBody),
        (status = 404, description = "No such waypoint", body = ErrorBody),
    ))]
async fn delete_waypoint(
    State(app): State<Arc<App>>,
    Path(Id(waypoint_id)): Path<Id>,
) -> Result<axum::Json<WaypointEdit>, ApiError> {
    Ok(axum::Json(app.delete_waypoint(waypoint_id).await?))
}

/// Insert a waypoint before or after this one, in any routine; the ones after it move down.
#[utoipa::path(post, path = "/v1/waypoints/{waypoint_id}/insert", tag = "editing",
    params(("waypoint_id" = i64, Path, description = "The waypoint to insert next to")),
    request_body = InsertWaypoint,
    responses(
        (status = 201, description = "Inserted; deleting it reverts the insert", body = WaypointEdit),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such waypoint", body = ErrorBody),
        (status = 409, description = "A `seq` that is not the place `side` gives", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Invalid side, pose, joints, name or unknown fields", body = ErrorBody),
    ))]
async fn insert_waypoint(
    State(app): State<Arc<App>>,
    Path(Id(waypoint_id)): Path<Id>,
    Json(body): Json<InsertWaypoint>,
) -> Result<(StatusCode, axum::Json<WaypointEdit>), ApiError> {
    Ok((
        StatusCode::CREATED,
        axum::Json(app.insert_waypoint(waypoint_id, body).await?),
    ))
}

/// Re-target a routine to a moved fixture: its waypoints moved with it (the moved work object's
/// `frame`, or three `points` measured before and after), checked for reach, and stored as a new
/// routine at the end of its program (finished, not learned).
#[utoipa::path(post, path = "/v1/routines/{routine_id}/retarget", tag = "editing",
    params(("routine_id" = i64, Path, description = "Routine id")),
    request_body = Retarget,
    responses(
        (status = 201, description = "The moved copy", body = Retargeted),
        (status = 400, description = "Malformed request", body = ErrorBody),
        (status = 404, description = "No such routine", body = ErrorBody),
        (status = 413, description = "Body too large (see --body-limit)", body = ErrorBody),
        (status = 415, description = "Not JSON (Content-Type is not application/json)", body = ErrorBody),
        (status = 422, description = "Neither or both of frame and points, degenerate points, invalid name or unknown fields", body = ErrorBody),
    ))]
async fn retarget_routine(
    State(app): State<Arc<App>>,
    Path(Id(routine_id)): Path<Id>,
    Json(body): Json<Retarget>,
) -> Result<(StatusCode, axum::Json<Retargeted>), ApiError> {
    Ok((
        StatusCode::CREATED,
        axum::Json(app.retarget_routine(routine_id, body).await?),
    ))
}
