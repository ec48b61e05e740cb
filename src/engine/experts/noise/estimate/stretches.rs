//! Two stretches of waypoints aligned ([`super`]'s module doc): which earlier stretches are
//! worth aligning with a new one (every step about as long, every turn about as sharp, and
//! spread enough to fix a rotation) and the misfits of the best rigid alignment, a [`Pair`].

use nalgebra::Point3;

use super::mixture::Pair;
use crate::engine::experts::alignment::rigid_fit;
use crate::engine::pose::Pose;

/// Waypoints in a stretch aligned at once.
pub const STRETCH: usize = 6;
/// How far apart the lengths of two corresponding steps may be, mm: a 20 mm RMS operator's step
/// lengths differ by about 16 mm (one sigma) between two repeats.
pub const STEP_GATE_MM: f64 = 60.0;
/// How far the turns between corresponding steps may differ, rad (only between steps longer than
/// [`STEP_GATE_MM`]).
pub const TURN_GATE_RAD: f64 = 0.6;
/// A stretch spanning less than this about its centroid, mm, fixes no rotation and is passed
/// over.
pub const MIN_EXTENT_MM: f64 = 25.0;

/// The entries of `index` (sorted by length) whose move is within [`STEP_GATE_MM`] of `last`:
/// (routine, end).
pub(super) fn moves_as_long_as(
    index: &[(f64, u32, u32)],
    last: f64,
) -> impl Iterator<Item = (u32, usize)> + '_ {
    let lo = index.partition_point(|e| e.0 < last - STEP_GATE_MM);
    index[lo..]
        .iter()
        .take_while(move |e| e.0 <= last + STEP_GATE_MM)
        .map(|&(_, r, e)| (r, e as usize))
}

/// How far the stretch's positions reach from their centroid, mm (the largest).
pub(super) fn extent(stretch: &[Pose]) -> f64 {
    let n = stretch.len() as f64;
    let c = stretch
        .iter()
        .map(|p| p.position())
        .sum::<nalgebra::Vector3<f64>>()
        / n;
    stretch
        .iter()
        .map(|p| (p.position() - c).norm())
        .fold(0.0, f64::max)
}

/// Whether every step of `a` is within [`STEP_GATE_MM`] as long as `b`'s, and every turn
/// between two steps within [`TURN_GATE_RAD`] of `b`'s (no rigid transform changes either).
pub(super) fn steps_match(a: &[Pose], b: &[Pose]) -> bool {
    let lengths = a
        .windows(2)
        .zip(b.windows(2))
        .all(|(x, y)| (x[0].distance_to(&x[1]) - y[0].distance_to(&y[1])).abs() <= STEP_GATE_MM);
    lengths
        && a.windows(3)
            .zip(b.windows(3))
            .all(|(x, y)| match (turn_angle(x), turn_angle(y)) {
                (Some(tx), Some(ty)) => (tx - ty).abs() <= TURN_GATE_RAD,
                _ => true,
            })
}

/// The angle between the steps into and out of the middle of three poses; `None` when a step
/// is too short to have a direction under the noise.
fn turn_angle(p: &[Pose]) -> Option<f64> {
    let (a, b) = (
        p[1].position() - p[0].position(),
        p[2].position() - p[1].position(),
    );
    (a.norm() >= STEP_GATE_MM && b.norm() >= STEP_GATE_MM).then(|| a.angle(&b))
}

/// The misfits of aligning stretch `a` onto `b` ([`super`]'s module doc).
pub(super) fn compare(a: &[Pose], b: &[Pose]) -> Option<Pair> {
    let pa: Vec<Point3<f64>> = a.iter().map(|p| Point3::from(p.position())).collect();
    let pb: Vec<Point3<f64>> = b.iter().map(|p| Point3::from(p.position())).collect();
    let g = rigid_fit(&pa, &pb)?;
    let n = a.len().min(b.len()) as f64;
    let ss_mm = pa
        .iter()
        .zip(&pb)
        .map(|(p, q)| (g * p - q).norm_squared())
        .sum();
    let ss_rad = a
        .windows(2)
        .zip(b.windows(2))
        .map(|(x, y)| {
            let rx = x[0].rotation().inverse() * x[1].rotation();
            let ry = y[0].rotation().inverse() * y[1].rotation();
            rx.angle_to(&ry).powi(2)
        })
        .sum();
    Some(Pair {
        ss_mm,
        ss_rad,
        nu_mm: 3.0 * n - 6.0,
        nu_rad: 3.0 * (n - 1.0),
    })
}
