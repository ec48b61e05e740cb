//! The one place where millimetres (the crate's unit, see [`crate::engine::Pose`]) meet metres
//! (URDF's unit and the solvers').

use nalgebra::{Isometry3, Translation3};

use crate::engine::Pose;

/// Millimetres per metre.
pub const MM_PER_M: f64 = 1000.0;

/// A pose in mm as an isometry in metres.
pub fn pose_to_metres(pose: &Pose) -> Isometry3<f64> {
    let iso = pose.isometry();
    Isometry3::from_parts(
        Translation3::from(iso.translation.vector / MM_PER_M),
        iso.rotation,
    )
}

/// An isometry in metres as a pose in mm.
pub fn metres_to_pose(iso: &Isometry3<f64>) -> Pose {
    Pose::from_isometry(Isometry3::from_parts(
        Translation3::from(iso.translation.vector * MM_PER_M),
        iso.rotation,
    ))
}
