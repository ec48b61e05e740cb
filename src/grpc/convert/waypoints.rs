//! Waypoints: a taught one, a new one to append or insert, the edits of one, and what teaching
//! answers (the waypoint with the prediction after it, or what an undo removed).

use tonic::Status;

use crate::api::{
    InsertWaypoint, MotionType, NewWaypoint, Side, Taught, Undone, Waypoint, WaypointEdit,
    WaypointPatch,
};
use crate::grpc::pb;

use super::wire::{In, Wire, both_ways, enum_both_ways, required};

enum_both_ways!(MotionType => Motion as "motion" { Joint, Linear, Circular });

both_ways!(NewWaypoint => NewWaypoint { pose, joints, motion, name, seq });
both_ways!(Waypoint => Waypoint {
    id, routine_id, seq, pose, joints, motion, name, reachable, created_at,
});
both_ways!(Taught => Taught { waypoint, prediction, repeat });
both_ways!(Undone => Undone { removed, prediction });
both_ways!(WaypointEdit => WaypointEdit { waypoint, previous, model_version });

/// A waypoint to teach: its pose is required; empty joints are none sent.
pub fn new_waypoint(w: pb::NewWaypoint) -> In<NewWaypoint> {
    w.try_into()
}

/// The waypoint as a client sends it.
pub fn new_waypoint_out(w: NewWaypoint) -> pb::NewWaypoint {
    w.into()
}

/// An edit: each field given is set; empty joints or name clear it.
pub fn waypoint_patch(r: &pb::ModifyWaypointRequest) -> In<WaypointPatch> {
    Ok(WaypointPatch {
        pose: r.pose.map(Into::into),
        joints: r
            .joints
            .as_ref()
            .map(|j| (!j.values.is_empty()).then(|| j.values.clone())),
        motion: r.motion.map(|m| Wire::back(m, "motion")).transpose()?,
        name: r.name.as_ref().map(|n| (!n.is_empty()).then(|| n.clone())),
    })
}

pub fn insert_waypoint(r: pb::InsertWaypointRequest) -> In<InsertWaypoint> {
    let side = match pb::Side::try_from(r.side) {
        Ok(pb::Side::Before) => Side::Before,
        Ok(pb::Side::After) => Side::After,
        Ok(pb::Side::Unspecified) => {
            return Err(Status::invalid_argument(
                "side must be SIDE_BEFORE or SIDE_AFTER",
            ));
        }
        Err(_) => return Err(Status::invalid_argument(format!("unknown side {}", r.side))),
    };
    Ok(InsertWaypoint {
        side,
        waypoint: new_waypoint(required(r.waypoint, "waypoint")?)?,
    })
}
