//! Poses, relative moves and the SRHCT observation vector (ALGORITHM §1, dissertation §4.2).
//!
//! A taught waypoint is a [`Pose`]: position in millimetres and a unit quaternion, both in one
//! frame (work object or robot base). The engine never learns poses directly; it learns the
//! *relative move* between consecutive waypoints, `T_n = W_{n-1}⁻¹ · W_n`, expressed in the frame
//! of the previous waypoint. Because `(G·W_{n-1})⁻¹ · (G·W_n) = W_{n-1}⁻¹ · W_n` for any rigid
//! transform `G`, a pattern taught at another place or angle yields the same moves
//! (Theorem 4.1). A move is flattened to the 7-vector `[t_x, t_y, t_z, q_w, q_x, q_y, q_z]`
//! ([`Observation`]) with a canonical quaternion sign, so `q` and `−q` (the same rotation) give
//! one vector.

use nalgebra::{Isometry3, Quaternion, SVector, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::error::PoseError;

/// The 7-vector SRHCT observation: translation (mm) then quaternion `w, x, y, z`.
pub type Observation = SVector<f64, 7>;

/// How far from unit norm an input quaternion may be and still be accepted (it is normalised).
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

/// How far from the origin of its frame (the work object, user frame or base the pose is given
/// in) a position may lie on each axis, mm: ±100 m. No cell is that large; a coordinate beyond
/// it is a corrupted or mistyped number (`-1e308`), and accepting it would only turn the moves
/// learned from it into infinities. [`PoseValues::to_pose`] refuses it.
pub const POSITION_LIMIT_MM: f64 = 100_000.0;

/// A waypoint pose: position in mm and orientation, in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    iso: Isometry3<f64>,
}

/// A pose as plain numbers, as clients send and see it: position in mm and a unit quaternion
/// `w, x, y, z`. The service accepts a pose whose numbers are finite, whose coordinates are
/// within ±100,000 mm (100 m) of the frame's origin and whose quaternion is within 1e-3 of
/// unit norm (it is normalised); anything else is a 422 naming the field and value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseValues {
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

impl Pose {
    /// A pose from a position (mm) and a quaternion `[w, x, y, z]`.
    ///
    /// The quaternion is normalised when its norm is within [`QUATERNION_NORM_TOLERANCE`] of 1 and
    /// rejected otherwise; non-finite numbers are rejected. These are the invariants of the
    /// type; a pose entering the service passes [`PoseValues::to_pose`], which also bounds the
    /// position.
    pub fn new(position: [f64; 3], quaternion_wxyz: [f64; 4]) -> Result<Pose, PoseError> {
        for (field, value) in ["x", "y", "z"].into_iter().zip(position) {
            if !value.is_finite() {
                return Err(PoseError::NonFinite { field, value });
            }
        }
        let rotation = unit_quaternion(quaternion_wxyz)?;
        Ok(Pose {
            iso: Isometry3::from_parts(
                Translation3::new(position[0], position[1], position[2]),
                rotation,
            ),
        })
    }

    /// The identity pose (origin, no rotation).
    pub fn identity() -> Pose {
        Pose {
            iso: Isometry3::identity(),
        }
    }

    /// Wraps an isometry (translation in mm).
    pub fn from_isometry(iso: Isometry3<f64>) -> Pose {
        Pose { iso }
    }

    pub fn isometry(&self) -> &Isometry3<f64> {
        &self.iso
    }

    /// Position in mm.
    pub fn position(&self) -> Vector3<f64> {
        self.iso.translation.vector
    }

    pub fn rotation(&self) -> UnitQuaternion<f64> {
        self.iso.rotation
    }

    /// The pose as plain numbers, quaternion with canonical sign (`q_w ≥ 0`).
    pub fn values(&self) -> PoseValues {
        let p = self.position();
        let q = canonical(self.iso.rotation);
        PoseValues {
            x: p.x,
            y: p.y,
            z: p.z,
            qw: q.w,
            qx: q.i,
            qy: q.j,
            qz: q.k,
        }
    }

    /// The pose reached by applying a relative move in this pose's frame: `self · m`.
    pub fn then(&self, m: &Move) -> Pose {
        Pose {
            iso: self.iso * m.iso,
        }
    }

    /// Distance between positions, mm.
    pub fn distance_to(&self, other: &Pose) -> f64 {
        (self.position() - other.position()).norm()
    }

    /// Geodesic angle between orientations, radians in `[0, π]`.
    pub fn angle_to(&self, other: &Pose) -> f64 {
        self.iso.rotation.angle_to(&other.iso.rotation)
    }
}

impl PoseValues {
    /// The one check of a pose that enters the service, wherever it enters: taught or edited
    /// over REST or gRPC, imported from a RAPID, KRL or FANUC file, read from a recorded
    /// trajectory, given as a cell's base or tool. Every number finite, each coordinate within
    /// ±[`POSITION_LIMIT_MM`] of the frame's origin, the quaternion within
    /// [`QUATERNION_NORM_TOLERANCE`] of unit norm (then normalised). The error names the
    /// offending field and its value (`x = -1e308 is outside ±100000 mm`).
    pub fn to_pose(&self) -> Result<Pose, PoseError> {
        for (field, value) in self.fields() {
            if !value.is_finite() {
                return Err(PoseError::NonFinite { field, value });
            }
        }
        for (field, value) in self.fields().into_iter().take(3) {
            if value.abs() > POSITION_LIMIT_MM {
                return Err(PoseError::OutOfRange {
                    field,
                    value,
                    limit: POSITION_LIMIT_MM,
                });
            }
        }
        Pose::new(
            [self.x, self.y, self.z],
            [self.qw, self.qx, self.qy, self.qz],
        )
    }

    /// The seven numbers by name, position first.
    fn fields(&self) -> [(&'static str, f64); 7] {
        [
            ("x", self.x),
            ("y", self.y),
            ("z", self.z),
            ("qw", self.qw),
            ("qx", self.qx),
            ("qy", self.qy),
            ("qz", self.qz),
        ]
    }
}

impl From<&Pose> for PoseValues {
    fn from(p: &Pose) -> PoseValues {
        p.values()
    }
}

impl TryFrom<PoseValues> for Pose {
    type Error = PoseError;
    /// [`PoseValues::to_pose`]: the check of a pose entering the service.
    fn try_from(v: PoseValues) -> Result<Pose, PoseError> {
        v.to_pose()
    }
}

/// A relative move between two waypoints, in the frame of the first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    iso: Isometry3<f64>,
}

impl Move {
    /// The move from `from` to `to`: `from⁻¹ · to`.
    pub fn between(from: &Pose, to: &Pose) -> Move {
        Move {
            iso: from.iso.inv_mul(&to.iso),
        }
    }

    /// Rebuilds a move from an observation vector (for instance a predicted one). The quaternion
    /// part is re-normalised; a quaternion part of zero length (which a prediction never
    /// produces from a model of unit quaternions) is rejected.
    pub fn from_observation(x: &Observation) -> Result<Move, PoseError> {
        if x.iter().any(|v| !v.is_finite()) {
            return Err(PoseError::NonFiniteObservation);
        }
        let q = Quaternion::new(x[3], x[4], x[5], x[6]);
        let norm = q.norm();
        if norm < 1e-9 {
            return Err(PoseError::DegenerateQuaternion { norm });
        }
        let rotation = UnitQuaternion::new_normalize(q);
        Ok(Move {
            iso: Isometry3::from_parts(Translation3::new(x[0], x[1], x[2]), rotation),
        })
    }

    /// The SRHCT observation vector with canonical quaternion sign.
    pub fn observation(&self) -> Observation {
        let t = self.iso.translation.vector;
        let q = canonical(self.iso.rotation);
        Observation::from([t.x, t.y, t.z, q.w, q.i, q.j, q.k])
    }

    pub fn isometry(&self) -> &Isometry3<f64> {
        &self.iso
    }

    /// Length of the translation, mm.
    pub fn distance(&self) -> f64 {
        self.iso.translation.vector.norm()
    }

    /// Rotation angle, radians.
    pub fn angle(&self) -> f64 {
        self.iso.rotation.angle()
    }
}

/// The mean of poses: positions averaged, rotations by their chordal mean (quaternions summed on
/// `near`'s hemisphere and normalised). None for no poses (or rotations that cancel out).
pub fn mean<'a>(poses: impl Iterator<Item = &'a Pose>, near: &Pose) -> Option<Pose> {
    let reference = near.rotation().into_inner();
    let (mut p, mut q, mut n) = (Vector3::zeros(), Quaternion::new(0.0, 0.0, 0.0, 0.0), 0.0);
    for pose in poses {
        p += pose.position();
        let r = pose.rotation().into_inner();
        q += if r.dot(&reference) < 0.0 { -r } else { r };
        n += 1.0;
    }
    if n == 0.0 || q.norm() < 1e-9 {
        return None;
    }
    Some(Pose::from_isometry(Isometry3::from_parts(
        Translation3::from(p / n),
        UnitQuaternion::new_normalize(q),
    )))
}

/// The observations of a routine: one per consecutive pair of waypoints.
pub fn observations(waypoints: &[Pose]) -> Vec<Observation> {
    waypoints
        .windows(2)
        .map(|w| Move::between(&w[0], &w[1]).observation())
        .collect()
}

/// Scales only the translation part of an observation (the scale matrix `Ψ = diag(ψ,ψ,ψ,1,1,1,1)`).
pub fn scale_translation(x: &Observation, psi: f64) -> Observation {
    let mut y = *x;
    y[0] *= psi;
    y[1] *= psi;
    y[2] *= psi;
    y
}

fn unit_quaternion(q: [f64; 4]) -> Result<UnitQuaternion<f64>, PoseError> {
    for (field, value) in ["qw", "qx", "qy", "qz"].into_iter().zip(q) {
        if !value.is_finite() {
            return Err(PoseError::NonFinite { field, value });
        }
    }
    let quat = Quaternion::new(q[0], q[1], q[2], q[3]);
    let norm = quat.norm();
    if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
        return Err(PoseError::NotUnitQuaternion { norm });
    }
    Ok(UnitQuaternion::new_normalize(quat))
}

/// The quaternion with `w ≥ 0`; when `w = 0`, the first non-zero of `x, y, z` is made positive.
fn canonical(q: UnitQuaternion<f64>) -> Quaternion<f64> {
    let q = q.into_inner();
    let first_nonzero = [q.w, q.i, q.j, q.k]
        .into_iter()
        .find(|c| *c != 0.0)
        .unwrap_or(1.0);
    if first_nonzero < 0.0 { -q } else { q }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pose(p: [f64; 3], axis: [f64; 3], angle: f64) -> Pose {
        let axis = nalgebra::Unit::new_normalize(Vector3::from(axis));
        let q = UnitQuaternion::from_axis_angle(&axis, angle);
        Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
    }

    #[test]
    fn near_unit_quaternion_is_normalised_far_one_rejected() {
        let p = Pose::new([0.0; 3], [1.0005, 0.0, 0.0, 0.0]).unwrap();
        assert!((p.rotation().into_inner().norm() - 1.0).abs() < 1e-12);
        assert!(matches!(
            Pose::new([0.0; 3], [1.01, 0.0, 0.0, 0.0]),
            Err(PoseError::NotUnitQuaternion { .. })
        ));
        assert!(matches!(
            Pose::new([0.0; 3], [0.0; 4]),
            Err(PoseError::NotUnitQuaternion { .. })
        ));
    }

    /// The check of a pose entering the service: each number finite, each coordinate within
    /// ±100 m, the quaternion of unit norm; the error names the field and the value.
    #[test]
    fn an_entering_pose_is_checked_field_by_field() {
        let at = |x: f64, y: f64, z: f64, qw: f64| PoseValues {
            x,
            y,
            z,
            qw,
            qx: 0.0,
            qy: 0.0,
            qz: 0.0,
        };
        // The bounds themselves are accepted; the quaternion is normalised.
        let p = at(-100_000.0, 100_000.0, 0.0, 1.0005).to_pose().unwrap();
        assert_eq!(p.position(), Vector3::new(-100_000.0, 100_000.0, 0.0));
        assert!((p.rotation().into_inner().norm() - 1.0).abs() < 1e-12);
        let err = at(-1e308, 0.0, 0.0, 1.0).to_pose().unwrap_err();
        assert_eq!(
            err,
            PoseError::OutOfRange {
                field: "x",
                value: -1e308,
                limit: POSITION_LIMIT_MM
            }
        );
        assert_eq!(err.to_string(), "x = -1e308 is outside ±100000 mm");
        let err = at(0.0, 0.0, 100_000.5, 1.0).to_pose().unwrap_err();
        assert_eq!(err.to_string(), "z = 100000.5 is outside ±100000 mm");
        let err = at(0.0, f64::NAN, 0.0, 1.0).to_pose().unwrap_err();
        assert_eq!(err.to_string(), "y = NaN is not a finite number");
        let err = at(0.0, 0.0, f64::NEG_INFINITY, 1.0).to_pose().unwrap_err();
        assert_eq!(err.to_string(), "z = -inf is not a finite number");
        let err = at(0.0, 0.0, 0.0, 1e308).to_pose().unwrap_err();
        assert!(matches!(err, PoseError::NotUnitQuaternion { .. }), "{err}");
        let err = at(0.0, 0.0, 0.0, f64::NAN).to_pose().unwrap_err();
        assert_eq!(err.to_string(), "qw = NaN is not a finite number");
        // The wire conversion is the same check.
        assert_eq!(Pose::try_from(at(2e5, 0.0, 0.0, 1.0)).unwrap_err(), {
            PoseError::OutOfRange {
                field: "x",
                value: 2e5,
                limit: POSITION_LIMIT_MM,
            }
        });
    }

    #[test]
    fn non_finite_input_is_rejected() {
        assert!(matches!(
            Pose::new([0.0, f64::NAN, 0.0], [1.0, 0.0, 0.0, 0.0]),
            Err(PoseError::NonFinite { field: "y", value }) if value.is_nan()
        ));
        assert_eq!(
            Pose::new([0.0; 3], [f64::INFINITY, 0.0, 0.0, 0.0]),
            Err(PoseError::NonFinite {
                field: "qw",
                value: f64::INFINITY
            })
        );
        let mut x = Observation::zeros();
        x[3] = f64::NAN;
        assert_eq!(
            Move::from_observation(&x),
            Err(PoseError::NonFiniteObservation)
        );
        assert!(matches!(
            Move::from_observation(&Observation::zeros()),
            Err(PoseError::DegenerateQuaternion { .. })
        ));
    }

    #[test]
    fn canonical_sign() {
        let a = Pose::new([0.0; 3], [1.0, 0.0, 0.0, 0.0]).unwrap();
        // Same rotation given with both signs gives the same observation.
        let b1 = Pose::new([1.0, 2.0, 3.0], [-0.5, -0.5, -0.5, -0.5]).unwrap();
        let b2 = Pose::new([1.0, 2.0, 3.0], [0.5, 0.5, 0.5, 0.5]).unwrap();
        let x1 = Move::between(&a, &b1).observation();
        let x2 = Move::between(&a, &b2).observation();
        assert!((x1 - x2).norm() < 1e-12);
        assert!(x1[3] >= 0.0);
        // w = 0: first non-zero of x, y, z positive.
        let c = Pose::new([0.0; 3], [0.0, 0.0, -1.0, 0.0]).unwrap();
        let x = Move::between(&a, &c).observation();
        assert!(x[3].abs() < 1e-15 && x[5] > 0.0, "{x:?}");
    }

    #[test]
    fn prediction_composes_back_onto_previous_pose() {
        let a = pose([100.0, -50.0, 300.0], [0.3, 1.0, 0.2], 0.7);
        let b = pose([120.0, -40.0, 310.0], [1.0, 0.1, 0.0], -1.2);
        let m = Move::from_observation(&Move::between(&a, &b).observation()).unwrap();
        let b2 = a.then(&m);
        assert!(b2.distance_to(&b) < 1e-9);
        assert!(b2.angle_to(&b) < 1e-9);
    }

    fn arb_pose() -> impl Strategy<Value = Pose> {
        (
            prop::array::uniform3(-2000.0..2000.0f64),
            prop::array::uniform3(-1.0..1.0f64),
            -3.1..3.1f64,
        )
            .prop_filter("axis non-zero", |(_, a, _)| Vector3::from(*a).norm() > 1e-3)
            .prop_map(|(p, a, ang)| pose(p, a, ang))
    }

    proptest! {
        /// Theorem 4.1: the SRHCT sequence does not change when a rigid transform is applied to
        /// the whole routine.
        #[test]
        fn srhct_is_invariant_under_rigid_transforms(
            routine in prop::collection::vec(arb_pose(), 2..12),
            g in arb_pose(),
        ) {
            let moved: Vec<Pose> = routine.iter().map(|w| Pose::from_isometry(g.isometry() * w.isometry())).collect();
            let a = observations(&routine);
            let b = observations(&moved);
            prop_assert_eq!(a.len(), routine.len() - 1);
            for (xa, xb) in a.iter().zip(&b) {
                // Translations are mm of magnitude up to ~4000: compare relative to that.
                prop_assert!((xa.fixed_rows::<3>(0) - xb.fixed_rows::<3>(0)).norm() < 1e-8, "{xa} vs {xb}");
                prop_assert!((xa.fixed_rows::<4>(3) - xb.fixed_rows::<4>(3)).norm() < 1e-9, "{xa} vs {xb}");
            }
        }
    }
}
