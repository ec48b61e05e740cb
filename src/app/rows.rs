//! Stored rows as the resources clients see, and back.

use super::Result;
use super::cell_model;
use super::error::AppError;
use crate::api::{MotionType, Program, Routine, Waypoint};
use crate::program::Motion;
use crate::storage::{ProgramRow, RoutineRow, WaypointRow};

/// A stored waypoint as clients see it. Its joints and motion were validated when taught, so
/// one that does not read back is an internal error, like a bad stored pose.
pub(super) fn waypoint(w: WaypointRow) -> Result<Waypoint> {
    let joints = cell_model::stored_joints(&w)?;
    let motion = stored_motion(w.id, &w.motion)?;
    Ok(Waypoint {
        id: w.id,
        routine_id: w.routine_id,
        seq: w.seq,
        pose: w.pose,
        joints,
        motion,
        name: w.name,
        reachable: w.reachable,
        created_at: w.created_at,
    })
}

/// The motion type of waypoint `id` as stored (the program model's name of it).
pub(super) fn stored_motion(id: i64, motion: &Option<String>) -> Result<Option<MotionType>> {
    motion
        .as_deref()
        .map(|m| {
            Motion::parse(m)
                .map(MotionType::from)
                .ok_or_else(|| AppError::Internal(format!("stored motion {m:?} of waypoint {id}")))
        })
        .transpose()
}

/// A motion type as it is stored.
pub(super) fn motion_to_store(motion: Option<MotionType>) -> Option<String> {
    motion.map(|m| Motion::from(m).as_str().to_string())
}

pub(super) fn routine(r: RoutineRow) -> Routine {
    Routine {
        id: r.id,
        program_id: r.program_id,
        cell_id: r.cell_id,
        position: r.position,
        finished: r.finished(),
        learned: r.learned(),
        imported: r.imported,
        name: r.name,
        finish_seq: r.finish_seq,
        finished_at: r.finished_at,
        waypoint_count: r.waypoints,
        created_at: r.created_at,
    }
}

pub(super) fn program(p: ProgramRow) -> Program {
    Program {
        id: p.id,
        cell_id: p.cell_id,
        name: p.name,
        created_at: p.created_at,
    }
}
