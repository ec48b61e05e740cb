//! The pose as clients send and see it (both adapters): position in mm and a unit quaternion
//! `w, x, y, z` in the cell's work frame. A leaf of the application's wire types.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::engine::{Pose, PoseValues};

/// A pose: position in mm, orientation as a unit quaternion `w, x, y, z`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PoseDto {
    /// mm
    pub x: f64,
    /// mm
    pub y: f64,
    /// mm
    pub z: f64,
    pub qw: f64,
    pub qx: f64,
    pub qy: f64,
    pub qz: f64,
}

impl PoseDto {
    /// The engine pose (typed error for non-finite numbers or a quaternion far from unit).
    pub fn to_pose(&self) -> Result<Pose, crate::engine::PoseError> {
        Pose::new(
            [self.x, self.y, self.z],
            [self.qw, self.qx, self.qy, self.qz],
        )
    }
}

impl From<PoseValues> for PoseDto {
    fn from(v: PoseValues) -> PoseDto {
        PoseDto {
            x: v.x,
            y: v.y,
            z: v.z,
            qw: v.qw,
            qx: v.qx,
            qy: v.qy,
            qz: v.qz,
        }
    }
}

impl From<&Pose> for PoseDto {
    fn from(p: &Pose) -> PoseDto {
        p.values().into()
    }
}
