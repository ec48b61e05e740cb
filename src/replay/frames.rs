//! The three frames of the engine ([`crate::engine::experts::frames`]), judged at the scoreboard's
//! useful tolerance.

pub use crate::engine::experts::frames::{Frame, angle, distance, pose_vector, work_move};

use super::playback::{USEFUL_MAX_MM, USEFUL_MAX_RAD};
use crate::engine::Observation;
use crate::engine::Tolerance;

/// The scoreboard's useful tolerance ([`USEFUL_MAX_MM`], [`USEFUL_MAX_RAD`]).
pub const USEFUL: Tolerance = Tolerance {
    mm: USEFUL_MAX_MM,
    rad: USEFUL_MAX_RAD,
};

/// Within the scoreboard's useful tolerance of each other (both bounds inclusive as in
/// [`super::playback::WaypointRecord::useful`]).
pub fn close(a: &Observation, b: &Observation) -> bool {
    USEFUL.holds(a, b)
}
