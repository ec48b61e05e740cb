//! The cell's arm: its frames at given joints, whether it reaches a pose, and where to place
//! its base so that it reaches a program's targets.

use tonic::Status;

use crate::api::{ArmFrames, LinkFrame, Placement, PlacementSearch, Placements, ReachQuery};
use crate::grpc::pb;
use crate::kinematics::BaseMounting;

use super::wire::{In, Wire, both_ways, required};

both_ways!(LinkFrame => LinkFrame { name, pose });
both_ways!(ArmFrames => ArmFrames { robot, joints, base, links, flange, tcp });
both_ways!(Placement => Placement {
    base, reached, total, unreached, unreached_waypoints, min_joint_margin_deg, min_sigma, score,
});
both_ways!(Placements => Placements { robot, targets, placements });

/// A reach question: the pose is required; no `near` joints is none given.
pub fn reach_query(r: pb::CheckReachRequest) -> In<ReachQuery> {
    Ok(ReachQuery {
        pose: required(r.pose, "pose")?.into(),
        near: Wire::back(r.near, "near")?,
    })
}

/// The request's search (its robot name is taken apart by the caller). No `targets` means the
/// targets are stored (`program_id` or `cell_id`).
pub fn placement_search(r: pb::SearchPlacementsRequest) -> In<PlacementSearch> {
    let mounting = match r.mounting.as_str() {
        "" | "floor" => BaseMounting::Floor,
        "ceiling" => BaseMounting::Ceiling,
        other => {
            return Err(Status::invalid_argument(format!(
                "unknown mounting {other:?} (floor or ceiling)"
            )));
        }
    };
    let small = |v: Option<u32>, what: &str| Wire::back(v.map(u64::from), what);
    Ok(PlacementSearch {
        program_id: r.program_id,
        cell_id: r.cell_id,
        targets: (!r.targets.is_empty()).then(|| r.targets.into_iter().map(Into::into).collect()),
        mounting,
        tool: r.tool.map(Into::into),
        keep: small(r.keep, "keep")?,
        seed: r.seed,
        evaluations: small(r.evaluations, "evaluations")?,
    })
}
