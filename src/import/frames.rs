//! Positions and orientations while a target is resolved, and the rotations the languages
//! write (KRL `A B C`, FANUC `W P R`, RAPID quaternions), to the pose a waypoint has.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

use crate::engine::Pose;

/// A position and orientation while a target is being resolved (before it becomes a [`Pose`]).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Frame {
    pub position: Vector3<f64>,
    pub rotation: UnitQuaternion<f64>,
}

impl Frame {
    fn isometry(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.position), self.rotation)
    }

    /// `self ∘ inner`: the frame `inner`, given relative to `self`, expressed where `self` is
    /// (KRL's geometric operator `self:inner`, the product of the two homogeneous transforms).
    pub(crate) fn compose(&self, inner: &Frame) -> Frame {
        let m = self.isometry() * inner.isometry();
        Frame {
            position: m.translation.vector,
            rotation: m.rotation,
        }
    }
}

/// Rotation from ZYX Euler angles in degrees: `Rz(a)·Ry(b)·Rx(c)` — KRL `A B C`, and FANUC
/// `W P R` (fixed XYZ, i.e. the same matrix with `a = R, b = P, c = W`).
pub(crate) fn rotation_zyx_deg(a: f64, b: f64, c: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(c.to_radians(), b.to_radians(), a.to_radians())
}

/// A unit quaternion from `w x y z` as written, if it is close enough to unit norm to be meant
/// as a rotation (the same tolerance [`Pose::new`] applies); `None` when it is not (a target
/// skipped as [`super::SkipReason::InvalidTarget`]). A quaternion with a non-finite number is kept as
/// written, so that the upload's check of poses refuses the upload naming the line that moves to it.
pub(crate) fn quaternion_wxyz(q: [f64; 4]) -> Option<UnitQuaternion<f64>> {
    let [w, x, y, z] = q;
    if q.iter().any(|v| !v.is_finite()) {
        return Some(UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z)));
    }
    Pose::new([0.0; 3], q).ok().map(|p| p.rotation())
}

/// The pose of a resolved frame, with the quaternion's sign chosen so `w ≥ 0`. Not checked
/// here: a waypoint's pose is checked once, by the upload's check of poses, when the upload is parsed.
pub(crate) fn pose_of(frame: &Frame) -> Pose {
    let q = frame.rotation.into_inner();
    let q = if q.w < 0.0 { -q } else { q };
    Pose::from_isometry(Isometry3::from_parts(
        Translation3::from(frame.position),
        UnitQuaternion::new_unchecked(q),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zyx_matches_a_quarter_turn_about_z() {
        let q = rotation_zyx_deg(90.0, 0.0, 0.0);
        let v = q * Vector3::x();
        assert!((v - Vector3::y()).norm() < 1e-12);
    }
}
