//! Routines: their rows and details, a finished one with the model that learned it, edits
//! (rename, move) and re-targeting a routine or program to a moved fixture.

use crate::api::{
    Finished, FixturePoints, Retarget, Retargeted, Routine, RoutineDetail, RoutineEdit,
    RoutinePatch,
};
use crate::grpc::pb;

use super::wire::both_ways;

both_ways!(Routine => Routine {
    id, program_id, cell_id, position, name, finished, finish_seq, finished_at,
    waypoint_count, created_at, learned, imported,
});
both_ways!(RoutineDetail => RoutineDetail { routine, waypoints });
both_ways!(Finished => Finished { routine, model });
both_ways!(RoutineEdit => RoutineEdit { routine, previous });
both_ways!(Retargeted => Retargeted { program, routines, unreachable });

/// An edit: an empty name is none.
pub fn routine_patch(r: &pb::EditRoutineRequest) -> RoutinePatch {
    RoutinePatch {
        name: r.name.as_ref().map(|n| (!n.is_empty()).then(|| n.clone())),
        position: r.position,
    }
}

pub fn retarget(r: pb::RetargetRequest) -> Retarget {
    let points = |v: Vec<pb::Point>| v.into_iter().map(|p| [p.x, p.y, p.z]).collect();
    Retarget {
        frame: r.frame.map(Into::into),
        points: r.points.map(|p| FixturePoints {
            old: points(p.old),
            new: points(p.new),
        }),
        name: r.name,
    }
}
