//! What the importer alone knows of a program it read: where each routine and waypoint is in
//! its files, the instruction that moves to a waypoint and the work object it is given in. Kept
//! beside the program model ([`super::Imported`]), not in it: the rest of the service reads the
//! program, a person reading a skip record or an error reads this.

use serde::Serialize;

use super::{SkipReason, Skipped};
use crate::engine::Pose;
use crate::program::{Routine, Waypoint};

/// How a waypoint is used by a circular move.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CircleRole {
    Via,
    To,
}

/// Where an imported routine was read.
#[derive(Debug, Clone, PartialEq)]
pub struct RoutineOrigin {
    /// The file the routine is in.
    pub file: String,
    /// 1-based line of its header.
    pub line: usize,
    /// Each of the routine's waypoints, in the same order.
    pub waypoints: Vec<WaypointOrigin>,
}

/// Where an imported waypoint was read.
#[derive(Debug, Clone, PartialEq)]
pub struct WaypointOrigin {
    /// 1-based line of the instruction in its file.
    pub line: usize,
    /// The instruction (`MoveL`, `ArcLStart`, `LIN`, `J`, ...); its motion class is the
    /// waypoint's [`crate::program::Motion`].
    pub instruction: &'static str,
    /// For a circular instruction: via point or end point.
    pub role: Option<CircleRole>,
    /// Work object (RAPID `\WObj`) or user frame (FANUC `UF`) the position is expressed in.
    pub frame: Option<String>,
}

/// A routine as a parser reads it: the routine and, waypoint by waypoint, where it is.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ReadRoutine {
    pub routine: Routine<Waypoint>,
    pub origin: RoutineOrigin,
}

impl ReadRoutine {
    /// Routine `name`, whose header is at `line` of `file`, with no waypoint yet.
    pub(crate) fn new(name: String, file: &str, line: usize) -> ReadRoutine {
        ReadRoutine {
            routine: Routine {
                name,
                waypoints: Vec::new(),
            },
            origin: RoutineOrigin {
                file: file.to_string(),
                line,
                waypoints: Vec::new(),
            },
        }
    }

    pub(crate) fn push(&mut self, waypoint: Waypoint, origin: WaypointOrigin) {
        self.routine.waypoints.push(waypoint);
        self.origin.waypoints.push(origin);
    }

    /// The pose of the last waypoint read.
    pub(crate) fn last_pose(&self) -> Option<&Pose> {
        self.routine.waypoints.last().map(|w| &w.pose)
    }
}

/// Drops routines with fewer than two waypoints, recording each.
pub(crate) fn drop_short_routines(
    routines: Vec<ReadRoutine>,
    skipped: &mut Vec<Skipped>,
) -> Vec<ReadRoutine> {
    let mut kept = Vec::with_capacity(routines.len());
    for r in routines {
        let n = r.routine.waypoints.len();
        if n < 2 {
            skipped.push(Skipped {
                file: r.origin.file.clone(),
                line: r.origin.line,
                routine: Some(r.routine.name.clone()),
                reason: SkipReason::ShortRoutine,
                text: format!("{} ({n} waypoint(s))", r.routine.name),
            });
        } else {
            kept.push(r);
        }
    }
    kept
}
