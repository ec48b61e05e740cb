//! Routines of a program: taught one at a time, finished, renamed and reordered
//! (`/v1/routines`).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::cells::ModelInfo;
use super::present;
use super::waypoints::Waypoint;

#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateRoutine {
    /// Not blank; at most 200 characters.
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub name: Option<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Routine {
    pub id: i64,
    pub program_id: i64,
    pub cell_id: i64,
    /// Order within the program (1, 2, ...).
    pub position: i64,
    pub name: Option<String>,
    /// Immutable: finished by the operator, or imported.
    pub finished: bool,
    /// Part of the cell's model (finished, or imported with `learn`).
    pub learned: bool,
    /// Imported from an offline program.
    pub imported: bool,
    /// Order in which the cell's model assimilated it (finished routines only).
    pub finish_seq: Option<i64>,
    pub finished_at: Option<String>,
    pub waypoint_count: i64,
    pub created_at: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct RoutineDetail {
    #[serde(flatten)]
    pub routine: Routine,
    pub waypoints: Vec<Waypoint>,
}

/// Changes to a routine: its name (`null` clears it) and its place in its program (1 = first;
/// beyond the last is the last).
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RoutinePatch {
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    #[schema(value_type = Option<String>, nullable, min_length = 1, max_length = 200, pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$")]
    pub name: Option<Option<String>>,
    #[schema(minimum = 1)]
    pub position: Option<i64>,
}

/// A routine after an edit, with its values before (what reverts it).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct RoutineEdit {
    pub routine: Routine,
    pub previous: Routine,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Finished {
    pub routine: Routine,
    pub model: ModelInfo,
}
