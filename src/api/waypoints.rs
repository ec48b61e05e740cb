//! Waypoints: taught, undone, edited and inserted; each answer carries the prediction that
//! follows it.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::predictions::Prediction;
use super::{PoseValues, present};
use crate::program::Motion;

/// How the arm moves to a waypoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum MotionType {
    Joint,
    Linear,
    Circular,
}

/// The wire's motion type is the program model's [`Motion`], mapped here and only here.
impl From<Motion> for MotionType {
    fn from(m: Motion) -> MotionType {
        match m {
            Motion::Joint => MotionType::Joint,
            Motion::Linear => MotionType::Linear,
            Motion::Circular => MotionType::Circular,
        }
    }
}

impl From<MotionType> for Motion {
    fn from(m: MotionType) -> Motion {
        match m {
            MotionType::Joint => Motion::Joint,
            MotionType::Linear => Motion::Linear,
            MotionType::Circular => Motion::Circular,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
#[schema(as = NewWaypointDto)]
pub struct NewWaypoint {
    pub pose: PoseValues,
    /// Taught joint values (rad), when the pendant sends them (1 to 12 values).
    #[schema(min_items = 1, max_items = 12)]
    pub joints: Option<Vec<f64>>,
    pub motion: Option<MotionType>,
    /// Not blank; at most 200 characters.
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub name: Option<String>,
    /// The `seq` this waypoint is to have. An append's is the routine's waypoint count + 1,
    /// which makes the append safe to retry (an insert's must be the place its `side` gives,
    /// else 409). When the routine's last waypoint already has this
    /// seq and the same pose, joints, motion and name, nothing is stored and the answer (200,
    /// `repeat: true`) is that waypoint with the prediction after it. Another waypoint at this
    /// seq, or a seq that is neither the next nor the last, is a 409 with nothing changed. Left
    /// out, the waypoint is appended whatever the count.
    #[schema(minimum = 1)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seq: Option<i64>,
}

impl NewWaypoint {
    /// A waypoint taught by its pose alone.
    pub fn at(pose: &crate::engine::Pose) -> NewWaypoint {
        NewWaypoint {
            pose: pose.into(),
            joints: None,
            motion: None,
            name: None,
            seq: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Waypoint {
    pub id: i64,
    pub routine_id: i64,
    /// Teaching order within the routine (1, 2, ...).
    pub seq: i64,
    pub pose: PoseValues,
    pub joints: Option<Vec<f64>>,
    pub motion: Option<MotionType>,
    pub name: Option<String>,
    /// Whether the cell's arm reaches this waypoint (stored and flagged either way: the
    /// operator is the authority); null when not checked.
    pub reachable: Option<bool>,
    pub created_at: String,
}

/// A taught waypoint and the prediction for the next one.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Taught {
    pub waypoint: Waypoint,
    pub prediction: Prediction,
    /// True when the request repeated an append already stored (the same `seq` and values, a
    /// retry): nothing was stored, and this is the stored waypoint with the prediction after it.
    #[serde(default)]
    pub repeat: bool,
}

/// The waypoint an undo removed and the prediction for the routine as it is now.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Undone {
    pub removed: Waypoint,
    pub prediction: Prediction,
}

/// Changes to a waypoint ("modify position" and more): fields left out stay as they are;
/// `joints`, `motion` and `name` may be cleared with `null`.
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct WaypointPatch {
    pub pose: Option<PoseValues>,
    /// Taught joint values (rad; 1 to 12 values), or `null` to clear them.
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    #[schema(value_type = Option<Vec<f64>>, nullable, min_items = 1, max_items = 12)]
    pub joints: Option<Option<Vec<f64>>>,
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    #[schema(value_type = Option<MotionType>, nullable)]
    pub motion: Option<Option<MotionType>>,
    /// Not blank; at most 200 characters; `null` to clear it.
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    #[schema(value_type = Option<String>, nullable, min_length = 1, max_length = 200, pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$")]
    pub name: Option<Option<String>>,
}

/// Where an inserted waypoint goes, next to an existing one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    Before,
    After,
}

/// A waypoint to insert before or after an existing one of any routine.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct InsertWaypoint {
    pub side: Side,
    pub waypoint: NewWaypoint,
}

/// What an edit of a waypoint did, and what reverts it: `previous` holds the waypoint's
/// values before a change or a delete (re-insert them at its `seq`; `null` after an insert,
/// which a delete of `waypoint` reverts). `model_version` is the cell's model version after
/// the edit: it advances when a learned (finished) routine changed; the model is rebuilt from
/// the stored routines.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct WaypointEdit {
    /// The waypoint as it is now (`null` after a delete).
    pub waypoint: Option<Waypoint>,
    pub previous: Option<Waypoint>,
    pub model_version: i64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wire_names_a_motion_as_the_program_model_does() {
        for m in Motion::ALL {
            let wire = MotionType::from(m);
            assert_eq!(serde_json::to_value(wire).unwrap(), m.as_str());
            assert_eq!(Motion::from(wire), m);
        }
    }
}
