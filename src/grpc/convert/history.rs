//! A program's history: its revisions, the program as of one, a diff, a restore.

use crate::api::{
    ChangeKind, DiffQuery, HistoryQuery, ProgramDiff, ProgramHistory, ProgramRevision, Restored,
    Revision, RevisionChange, RoutineChanged, RoutineRevision, RoutineSummary, WaypointChanged,
    WaypointRevision, WaypointSummary,
};
use crate::grpc::pb;

use super::wire::{both_ways, enum_both_ways};

enum_both_ways!(ChangeKind => ChangeKind as "change" {
    WaypointAdded, WaypointRemoved, WaypointModified, RoutineAdded, RoutineRemoved,
    RoutineRenamed, RoutineMoved, RoutineFinished, RoutinesReordered,
});
both_ways!(RevisionChange => RevisionChange {
    change, routine_id, waypoint_id, place, waypoints,
});
both_ways!(Revision => Revision { revision, at, token, request_id, operation, changes });
both_ways!(ProgramHistory => ProgramHistory { program_id, revision, revisions, next });
both_ways!(WaypointRevision => WaypointRevision {
    id, seq, pose, joints, motion, name, reachable,
});
both_ways!(RoutineRevision => RoutineRevision {
    id, position, name, finished, learned, imported, waypoints,
});
both_ways!(ProgramRevision => ProgramRevision { program, revision, last_revision, routines });
both_ways!(RoutineSummary => RoutineSummary { id, name, position, waypoints });
both_ways!(RoutineChanged => RoutineChanged {
    id, name_from, name_to, position_from, position_to,
});
both_ways!(WaypointSummary => WaypointSummary { id, routine_id, seq, pose });
both_ways!(WaypointChanged => WaypointChanged {
    id, routine_id, seq_from, seq_to, moved_mm, turned_degrees, fields,
});
both_ways!(ProgramDiff => ProgramDiff {
    program_id, from, to, routines_added, routines_removed, routines_changed,
    waypoints_added, waypoints_removed, waypoints_changed,
});
both_ways!(Restored => Restored { program_id, restored, revision, changed, model_version });

/// Which revisions of the request's program to list.
pub fn history_query(r: &pb::ListProgramHistoryRequest) -> HistoryQuery {
    HistoryQuery {
        before: r.before,
        limit: r.limit,
    }
}

/// Which revisions of the request's program to compare.
pub fn diff_query(r: &pb::DiffProgramRequest) -> DiffQuery {
    DiffQuery {
        from: r.from,
        to: r.to,
    }
}
