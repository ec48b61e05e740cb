//! A program's history: its revisions (`GET /v1/programs/{id}/history`), the program as of one
//! (`GET /v1/programs/{id}/revisions/{revision}`), what changed between two
//! (`GET /v1/programs/{id}/diff`) and a restore (`POST /v1/programs/{id}/restore`).

use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::{MotionType, PoseValues, Program};

/// Which revisions to list.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct HistoryQuery {
    /// Only revisions older than this one: the `next` of the page before.
    #[param(minimum = 1)]
    #[serde(default, deserialize_with = "super::integral::optional")]
    pub before: Option<i64>,
    /// Revisions per page, 1 to 1000 (default 100).
    #[param(minimum = 1, maximum = 1000)]
    #[serde(default, deserialize_with = "super::integral::optional")]
    pub limit: Option<u32>,
}

/// A program's revisions, newest first.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ProgramHistory {
    pub program_id: i64,
    /// The program's last revision (0: unchanged since its history began).
    pub revision: i64,
    pub revisions: Vec<Revision>,
    /// The `before` of the next (older) page; null on the last page.
    pub next: Option<i64>,
}

/// One revision: who made it, when, and what it changed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Revision {
    /// 1, 2, … within the program.
    pub revision: i64,
    /// When it was committed (UTC, RFC 3339 with milliseconds).
    pub at: String,
    /// The name of the token that made it (null: made without a request, e.g. by the
    /// command line).
    pub token: Option<String>,
    pub request_id: Option<String>,
    /// REST: the method and route; gRPC: the method.
    pub operation: Option<String>,
    /// In the order made.
    pub changes: Vec<RevisionChange>,
}

/// What a change did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum ChangeKind {
    WaypointAdded,
    WaypointRemoved,
    WaypointModified,
    RoutineAdded,
    RoutineRemoved,
    RoutineRenamed,
    RoutineMoved,
    RoutineFinished,
    RoutinesReordered,
}

/// One change of a revision.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct RevisionChange {
    pub change: ChangeKind,
    /// The routine changed, or whose waypoint changed (null for a reordering).
    pub routine_id: Option<i64>,
    /// The waypoint changed (removed or modified; an added waypoint is named by its place).
    pub waypoint_id: Option<i64>,
    /// The place the change was made at: a waypoint's (1 = first of its routine), a
    /// routine's (1 = first of the program; where a moved routine went).
    pub place: Option<i64>,
    /// For a routine added or removed: how many waypoints it had.
    pub waypoints: Option<i64>,
}

/// A program as of a revision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ProgramRevision {
    pub program: Program,
    /// The revision shown.
    pub revision: i64,
    /// The program's last revision.
    pub last_revision: i64,
    /// In program order.
    pub routines: Vec<RoutineRevision>,
}

/// A routine as of a revision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct RoutineRevision {
    pub id: i64,
    /// Order within the program (1, 2, …).
    pub position: i64,
    pub name: Option<String>,
    /// Finished by the operator, or imported.
    pub finished: bool,
    /// Part of the cell's model.
    pub learned: bool,
    pub imported: bool,
    pub waypoints: Vec<WaypointRevision>,
}

/// A waypoint as of a revision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct WaypointRevision {
    pub id: i64,
    /// Order within the routine (1, 2, …).
    pub seq: i64,
    pub pose: PoseValues,
    pub joints: Option<Vec<f64>>,
    pub motion: Option<MotionType>,
    pub name: Option<String>,
    pub reachable: Option<bool>,
}

/// Which revisions to compare.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct DiffQuery {
    /// The earlier revision (0: the program when its history began).
    #[param(minimum = 0)]
    #[serde(deserialize_with = "super::integral::required")]
    pub from: i64,
    /// The later revision (default: the last).
    #[param(minimum = 0)]
    #[serde(default, deserialize_with = "super::integral::optional")]
    pub to: Option<i64>,
}

/// What changed from one revision of a program to another: the routines and waypoints that
/// are in one and not the other (by id), and those in both whose values differ.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ProgramDiff {
    pub program_id: i64,
    pub from: i64,
    pub to: i64,
    pub routines_added: Vec<RoutineSummary>,
    pub routines_removed: Vec<RoutineSummary>,
    /// Routines in both whose name or place differ.
    pub routines_changed: Vec<RoutineChanged>,
    /// Waypoints in `to` and not in `from` (those of added routines included).
    pub waypoints_added: Vec<WaypointSummary>,
    /// Waypoints in `from` and not in `to` (those of removed routines included).
    pub waypoints_removed: Vec<WaypointSummary>,
    /// Waypoints in both whose values differ.
    pub waypoints_changed: Vec<WaypointChanged>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct RoutineSummary {
    pub id: i64,
    pub name: Option<String>,
    pub position: i64,
    pub waypoints: i64,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct RoutineChanged {
    pub id: i64,
    pub name_from: Option<String>,
    pub name_to: Option<String>,
    pub position_from: i64,
    pub position_to: i64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct WaypointSummary {
    pub id: i64,
    pub routine_id: i64,
    pub seq: i64,
    pub pose: PoseValues,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct WaypointChanged {
    pub id: i64,
    pub routine_id: i64,
    /// Its place in `from` and in `to` (other waypoints put in or taken out move it).
    pub seq_from: i64,
    pub seq_to: i64,
    /// How far its position moved (mm) and its orientation turned (degrees).
    pub moved_mm: f64,
    pub turned_degrees: f64,
    /// The fields whose values differ: `pose`, `joints`, `motion`, `name`, `reachable`.
    pub fields: Vec<String>,
}

/// A restore: the program is made equal to revision `revision` (its routines, their names,
/// order and waypoints), as a new revision.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RestoreProgram {
    #[schema(minimum = 0)]
    pub revision: i64,
}

/// What a restore did.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct Restored {
    pub program_id: i64,
    /// The revision restored.
    pub restored: i64,
    /// The program's revision now: the new one, or the last when nothing differed.
    pub revision: i64,
    /// Whether anything changed (false: the program was already equal to `restored`).
    pub changed: bool,
    /// The cell's model version after the restore (advanced when a learned routine changed;
    /// the model is learned again from the stored routines).
    pub model_version: i64,
}
