//! Robots: an arm model (built in or uploaded) with its joints, and an upload.

use crate::api::{Joint, Robot, RobotUpload};
use crate::grpc::pb;

use super::wire::{Wire, both_ways};

both_ways!(plain Joint => Joint { name, lower, upper, velocity });

impl From<Robot> for pb::Robot {
    fn from(r: Robot) -> pb::Robot {
        pb::Robot {
            name: r.name,
            source: r.source.as_str().to_string(),
            maker: r.maker,
            product: r.product,
            payload_kg: r.payload_kg,
            reach_mm: r.reach_mm,
            computed_reach_mm: r.computed_reach_mm,
            languages: r.languages,
            solver: r.solver,
            root: r.root,
            tip: r.tip,
            joints: r.joints.out(),
        }
    }
}

impl From<pb::UploadRobotRequest> for RobotUpload {
    fn from(r: pb::UploadRobotRequest) -> RobotUpload {
        RobotUpload {
            name: r.name,
            urdf: r.urdf,
            maker: r.maker,
            product: r.product,
            payload_kg: r.payload_kg,
        }
    }
}
