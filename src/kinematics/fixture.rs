//! Work-object frames and moved fixtures (pure): the pendant's three-point frame definition
//! (an origin, a point on the x axis, a point in the xy plane), and the rigid move that takes a
//! fixture's taught waypoints from its old place to its new one (the dissertation's chapter 6 idea:
//! subgoals attached to the object they are about).

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::engine::{POSITION_LIMIT_MM, Pose};

/// Points closer than this (mm), or an xy-plane point this close to the x axis, define no frame.
pub const MIN_SPREAD_MM: f64 = 1.0;

/// Why three points define no frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FixtureError {
    #[error("{0} must be finite")]
    NotFinite(&'static str),
    #[error("{what}: coordinate {value} is outside ±{POSITION_LIMIT_MM} mm")]
    OutOfRange { what: &'static str, value: f64 },
    #[error(
        "{what}: the x-axis point is {distance:.3} mm from the origin (at least {MIN_SPREAD_MM} mm)"
    )]
    AxisTooShort { what: &'static str, distance: f64 },
    #[error(
        "{what}: the xy-plane point is {distance:.3} mm from the x axis (at least {MIN_SPREAD_MM} mm)"
    )]
    Collinear { what: &'static str, distance: f64 },
}

/// The frame three points define: origin `o`, x axis towards `x`, xy plane through `xy`
/// (z = x × y, right-handed). `what` names the points in errors ("old", "new").
pub fn frame_from_points(
    what: &'static str,
    [o, x, xy]: [[f64; 3]; 3],
) -> Result<Isometry3<f64>, FixtureError> {
    if [o, x, xy].iter().flatten().any(|v| !v.is_finite()) {
        return Err(FixtureError::NotFinite(what));
    }
    if let Some(&value) = [o, x, xy]
        .iter()
        .flatten()
        .find(|v| v.abs() > POSITION_LIMIT_MM)
    {
        return Err(FixtureError::OutOfRange { what, value });
    }
    let (o, x, xy) = (Point3::from(o), Point3::from(x), Point3::from(xy));
    let ex = x - o;
    let distance = ex.norm();
    if distance < MIN_SPREAD_MM {
        return Err(FixtureError::AxisTooShort { what, distance });
    }
    let ex = ex / distance;
    let v = xy - o;
    let ey = v - ex * v.dot(&ex);
    let off_axis = ey.norm();
    if off_axis < MIN_SPREAD_MM {
        return Err(FixtureError::Collinear {
            what,
            distance: off_axis,
        });
    }
    let ey = ey / off_axis;
    let ez: Vector3<f64> = ex.cross(&ey);
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[ex, ey, ez]));
    Ok(Isometry3::from_parts(
        Translation3::from(o.coords),
        UnitQuaternion::from_rotation_matrix(&rotation),
    ))
}

/// The move of a fixture measured at three points in its old and its new place:
/// `new · old⁻¹`, which takes a pose taught on the fixture to the same place on the moved one.
pub fn fixture_move(
    old: [[f64; 3]; 3],
    new: [[f64; 3]; 3],
) -> Result<Isometry3<f64>, FixtureError> {
    let old = frame_from_points("old", old)?;
    let new = frame_from_points("new", new)?;
    Ok(new * old.inverse())
}

/// A waypoint taught on the fixture, on the moved fixture (`moved` from [`fixture_move`], or the
/// new work-object frame in the old one).
pub fn moved_pose(moved: &Isometry3<f64>, pose: &Pose) -> Pose {
    Pose::from_isometry(moved * pose.isometry())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(t: &Isometry3<f64>, p: [f64; 3]) -> [f64; 3] {
        let q = t * Point3::from(p);
        [q.x, q.y, q.z]
    }

    /// Three points measured on a fixture before and after a known rigid move give that move
    /// back, and a pose on the fixture lands where the move takes it.
    #[test]
    fn three_points_before_and_after_give_the_fixtures_move() {
        let truth = Isometry3::from_parts(
            Translation3::new(250.0, -80.0, 35.0),
            UnitQuaternion::from_euler_angles(0.1, -0.2, 0.9),
        );
        let old = [[10.0, 20.0, 0.0], [310.0, 25.0, 2.0], [15.0, 220.0, -1.0]];
        let new = old.map(|p| apply(&truth, p));
        let moved = fixture_move(old, new).expect("a frame");
        assert!((moved.translation.vector - truth.translation.vector).norm() < 1e-9);
        assert!(moved.rotation.angle_to(&truth.rotation) < 1e-12);
        let pose = Pose::new([100.0, 50.0, 10.0], [0.0, 0.0, 1.0, 0.0]).expect("pose");
        let on_moved = moved_pose(&moved, &pose);
        let expected = Pose::from_isometry(truth * pose.isometry());
        assert!(on_moved.distance_to(&expected) < 1e-9);
        assert!(on_moved.angle_to(&expected) < 1e-12);
    }

    #[test]
    fn degenerate_points_define_no_frame() {
        let same = [[0.0; 3], [0.5, 0.0, 0.0], [0.0, 100.0, 0.0]];
        assert!(matches!(
            frame_from_points("old", same),
            Err(FixtureError::AxisTooShort { .. })
        ));
        let line = [[0.0; 3], [100.0, 0.0, 0.0], [200.0, 0.1, 0.0]];
        assert!(matches!(
            frame_from_points("new", line),
            Err(FixtureError::Collinear { what: "new", .. })
        ));
        let nan = [[f64::NAN, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0]];
        assert!(frame_from_points("old", nan).is_err());
        // Beyond ±100 m: a frame a cell cannot have (and whose lengths would overflow).
        let far = [[0.0; 3], [1e300, 0.0, 0.0], [0.0, 100.0, 0.0]];
        assert_eq!(
            frame_from_points("old", far),
            Err(FixtureError::OutOfRange {
                what: "old",
                value: 1e300
            })
        );
    }
}
