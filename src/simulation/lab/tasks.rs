//! The tasks a lab teaches, as waypoints in the work piece's frame: the dissertation's four
//! ([`Task::DISSERTATION`]), four variants ([`Task::VARIANTS`]) and a welding cell's parts
//! ([`Task::WELDING`]).
//!
//! **The repertoire** (§4.5, Figure 4.17: "two planar geometric movements" of 13 and 6
//! waypoints and "two standard arc-welding tasks" of 10 waypoints each; "the mean distance
//! between waypoints was 186 millimeters"). The dissertation gives the counts and the mean spacing,
//! not the shapes (the figure is a photograph); the shapes here are our assumption, each with a
//! mean step of exactly 186 mm so that the repertoire's is 186 mm too:
//!
//! - [`Task::Dodecagram`], 13 waypoints: the star polygon {12/5} (12 points on a circle of
//!   radius 96 mm, each stroke to the fifth point on, 186 mm long), back to the start; the
//!   tool points straight down throughout.
//! - [`Task::Pentagram`], 6 waypoints: the star polygon {5/2} (five 186 mm strokes, radius
//!   98 mm), back to the start; tool down.
//! - [`Task::PipeSeam`], 10 waypoints: a fillet weld around a pipe standing on a plate: a point
//!   375 mm straight above the seam's start, 8 seam points every 45° (315° of the
//!   circumference; 7 chords of 132 mm, pipe radius 172 mm), a retract 375 mm above the last.
//!   The torch keeps a 45° work angle to the joint, its x axis along the travel, and turns
//!   with the seam.
//! - [`Task::BoxSeam`], 10 waypoints: the same around a square tube (side 264 mm): approach,
//!   8 seam points at the corners and the middles of the sides (3½ sides), retract. At a corner
//!   the torch bisects the two sides.
//!
//! Both seams start (and their approach and retract points stand) on the side of the work
//! piece facing the arm. The sizes are what the dissertation's IRB 140 (810 mm reach), placed as
//! the simulation places it, can reach: compact star polygons rather than wide outlines, and the
//! welds' spacing made up by high clearance points rather than long seams. Even so the far side of
//! the pipe seam is at the edge of the reach (in the lab of random seed 1, 1 of 431 waypoints is
//! beyond it).

use std::f64::consts::{FRAC_PI_4, PI};

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::super::operator::DISSERTATION_SPACING_MM;
use crate::engine::Pose;

/// Height of a weld's approach and retract points above the seam's first and last points, mm.
pub const WELD_CLEARANCE_MM: f64 = 375.0;

/// How far a weld's approach and retract points stand back from the seam along the torch, mm.
pub const WELD_STANDOFF_MM: f64 = 50.0;

/// One task of the repertoire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Task {
    Dodecagram,
    Pentagram,
    PipeSeam,
    BoxSeam,
    /// Variant: a pick and a place (approach, down, lift at each), the part turned 90° between.
    PickPlace,
    /// Variant: a rectangular pocket's contour, plunged into and retracted from.
    Pocket,
    /// Variant: three weld stitches along a straight fillet joint, lifting between them.
    Stitches,
    /// Variant: a 2 × 3 grid of places, approached from above each (palletising).
    Grid,
    /// Welding cell: two fillet seams along either side of an upright plate.
    Bracket,
    /// Welding cell: a fillet seam around a flange (six points over 300°).
    Flange,
    /// Welding cell: a horizontal seam and a vertical seam up the inside corner of a gusset.
    Gusset,
    /// Welding cell: a short seam in each inside corner of a rectangular frame.
    Frame,
}

impl Task {
    /// The dissertation's repertoire in its order (Figure 4.17: 13, 6, 10, 10 waypoints).
    pub const DISSERTATION: [Task; 4] = [
        Task::Dodecagram,
        Task::Pentagram,
        Task::PipeSeam,
        Task::BoxSeam,
    ];

    /// The variant repertoire ([`Repertoire::Variants`]): 6, 7, 10 and 12 waypoints.
    pub const VARIANTS: [Task; 4] = [Task::PickPlace, Task::Pocket, Task::Stitches, Task::Grid];

    /// The welding cell's parts ([`Repertoire::Welding`]): 8, 8, 8 and 16 waypoints at the
    /// part, 2 more for home.
    pub const WELDING: [Task; 4] = [Task::Bracket, Task::Flange, Task::Gusset, Task::Frame];

    pub fn name(self) -> &'static str {
        match self {
            Task::Dodecagram => "dodecagram",
            Task::Pentagram => "pentagram",
            Task::PipeSeam => "pipe_seam",
            Task::BoxSeam => "box_seam",
            Task::PickPlace => "pick_place",
            Task::Pocket => "pocket",
            Task::Stitches => "stitches",
            Task::Grid => "grid",
            Task::Bracket => "bracket",
            Task::Flange => "flange",
            Task::Gusset => "gusset",
            Task::Frame => "frame",
        }
    }

    /// Whether it is a welding cell's part: its program starts and ends at [`HOME_MM`], and
    /// its size varies per program ([`WELD_SIZE_RANGE`]).
    pub fn is_welding_cell(self) -> bool {
        matches!(
            self,
            Task::Bracket | Task::Flange | Task::Gusset | Task::Frame
        )
    }

    /// Whether it is an arc-welding task (the dissertation's two seams, the stitches).
    pub fn is_weld(self) -> bool {
        matches!(self, Task::PipeSeam | Task::BoxSeam | Task::Stitches) || self.is_welding_cell()
    }

    /// Its waypoints in the work piece's frame (z up, the table at z = 0), noiseless, at
    /// nominal size.
    pub fn waypoints(self) -> Vec<Pose> {
        self.waypoints_sized(1.0)
    }

    /// Its waypoints with the part `size` times nominal (the welding cell's parts; the other
    /// tasks have one size and ignore it). Approach and retract distances do not scale.
    pub fn waypoints_sized(self, size: f64) -> Vec<Pose> {
        match self {
            Task::Bracket => bracket(size),
            Task::Flange => flange(size),
            Task::Gusset => gusset(size),
            Task::Frame => frame(size),
            Task::Dodecagram => dodecagram(),
            Task::Pentagram => pentagram(),
            Task::PipeSeam => turned(pipe_seam(), SEAM_TURN_RAD),
            Task::BoxSeam => turned(box_seam(), SEAM_TURN_RAD),
            Task::PickPlace => pick_place(),
            Task::Pocket => pocket(),
            Task::Stitches => stitches(),
            Task::Grid => grid(),
        }
    }
}

/// Pick at (0, −150), place at (0, 150), each approached and left 120 mm above; the tool turns
/// 90° about its axis between them.
fn pick_place() -> Vec<Pose> {
    let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_4 * 2.0);
    let (pick, place) = (tool_down(), turn * tool_down());
    let at = |y: f64, z: f64, q: UnitQuaternion<f64>| pose(Vector3::new(0.0, y, z), q);
    vec![
        at(-150.0, 120.0, pick),
        at(-150.0, 0.0, pick),
        at(-150.0, 120.0, pick),
        at(150.0, 120.0, place),
        at(150.0, 0.0, place),
        at(150.0, 120.0, place),
    ]
}

/// A 160 × 100 mm pocket 10 mm deep: above a corner, plunge, the contour around, retract.
fn pocket() -> Vec<Pose> {
    let at = |x: f64, y: f64, z: f64| pose(Vector3::new(x, y, z), tool_down());
    vec![
        at(-80.0, -50.0, 60.0),
        at(-80.0, -50.0, -10.0),
        at(80.0, -50.0, -10.0),
        at(80.0, 50.0, -10.0),
        at(-80.0, 50.0, -10.0),
        at(-80.0, -50.0, -10.0),
        at(-80.0, -50.0, 60.0),
    ]
}

/// Three 50 mm stitches 40 mm apart along a fillet joint running in x (the wall on the +y side),
/// each approached 40 mm above its start, and a retract above the last end.
fn stitches() -> Vec<Pose> {
    let (n, t) = (-Vector3::y(), Vector3::x());
    let mut out = Vec::new();
    for k in 0..3 {
        let x0 = -115.0 + 90.0 * f64::from(k);
        out.push(torch(Vector3::new(x0, 0.0, 40.0), n, t));
        out.push(torch(Vector3::new(x0, 0.0, 0.0), n, t));
        out.push(torch(Vector3::new(x0 + 50.0, 0.0, 0.0), n, t));
    }
    out.push(torch(Vector3::new(85.0, 0.0, 40.0), n, t));
    out
}

/// A 2 × 3 grid of places 120 mm apart, each approached 50 mm above and set down.
fn grid() -> Vec<Pose> {
    let mut out = Vec::new();
    for row in 0..2 {
        for col in 0..3 {
            let (x, y) = (
                -120.0 + 120.0 * f64::from(col),
                -60.0 + 120.0 * f64::from(row),
            );
            out.push(pose(Vector3::new(x, y, 50.0), tool_down()));
            out.push(pose(Vector3::new(x, y, 0.0), tool_down()));
        }
    }
    out
}

/// A torch at `p` pointing along `into` (tool z), its x axis along `travel` (made
/// perpendicular to `into`).
fn torch_into(p: Vector3<f64>, into: Vector3<f64>, travel: Vector3<f64>) -> Pose {
    let z = into.normalize();
    let x = (travel - z * z.dot(&travel)).normalize();
    let y = z.cross(&x);
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    pose(p, UnitQuaternion::from_rotation_matrix(&r))
}

/// A seam as a welding program teaches it: approach [`WELD_STANDOFF_MM`] back along the torch
/// from the first point, the seam's points, retract as far back from the last.
fn seam(points: Vec<Pose>) -> Vec<Pose> {
    let back = |p: &Pose| {
        let axis = p.rotation() * Vector3::z();
        pose(p.position() - axis * WELD_STANDOFF_MM, p.rotation())
    };
    let mut out = vec![back(&points[0])];
    let last = back(&points[points.len() - 1]);
    out.extend(points);
    out.push(last);
    out
}

/// An upright plate 200 mm long (× size) along x standing on a base plate: a fillet seam along
/// its −y side in +x, then one along its +y side back in −x.
fn bracket(size: f64) -> Vec<Pose> {
    let h = 100.0 * size;
    let mut out = Vec::new();
    for (n, t, x0) in [
        (-Vector3::y(), Vector3::x(), -h),
        (Vector3::y(), -Vector3::x(), h),
    ] {
        let a = torch(Vector3::new(x0, 10.0 * n.y, 0.0), n, t);
        let b = torch(Vector3::new(-x0, 10.0 * n.y, 0.0), n, t);
        out.extend(seam(vec![a, b]));
    }
    out
}

/// A pipe of radius 50 mm (× size) standing on a flange: a fillet seam from the side facing the
/// arm, six points 60° apart.
fn flange(size: f64) -> Vec<Pose> {
    let r = 50.0 * size;
    let points = (0..6)
        .map(|k| {
            let a = PI - f64::from(k) * PI / 3.0;
            let n = Vector3::new(a.cos(), a.sin(), 0.0);
            let t = Vector3::new(a.sin(), -a.cos(), 0.0);
            torch(n * r, n, t)
        })
        .collect();
    seam(points)
}

/// A gusset in the corner of a base plate and a wall (its face at y = 0, facing −y): a seam
/// 120 mm (× size) along the foot of the wall, then one up the wall's corner with the gusset's
/// side (at x = 0, facing −x), the torch into the corner.
fn gusset(size: f64) -> Vec<Pose> {
    let l = 120.0 * size;
    let mut out = seam(vec![
        torch(Vector3::new(-l, 0.0, 0.0), -Vector3::y(), Vector3::x()),
        torch(Vector3::new(0.0, 0.0, 0.0), -Vector3::y(), Vector3::x()),
    ]);
    let into = Vector3::new(1.0, 1.0, 0.0);
    out.extend(seam(vec![
        torch_into(Vector3::new(0.0, 0.0, 10.0), into, Vector3::z()),
        torch_into(Vector3::new(0.0, 0.0, 10.0 + l), into, Vector3::z()),
    ]));
    out
}

/// A rectangular frame 300 × 200 mm (× size) of upright bars: in each inside corner, counter-
/// clockwise from the one nearest the arm, a 40 mm seam along the base plate out of the corner
/// along the side that follows, the torch into the corner and tilted 45° down.
fn frame(size: f64) -> Vec<Pose> {
    let (hx, hy) = (150.0 * size, 100.0 * size);
    // Each corner, the way into it from inside the frame, and the side that follows.
    let corners = [
        (
            Vector3::new(-hx, -hy, 0.0),
            Vector3::new(-1.0, -1.0, 0.0),
            Vector3::x(),
        ),
        (
            Vector3::new(hx, -hy, 0.0),
            Vector3::new(1.0, -1.0, 0.0),
            Vector3::y(),
        ),
        (
            Vector3::new(hx, hy, 0.0),
            Vector3::new(1.0, 1.0, 0.0),
            -Vector3::x(),
        ),
        (
            Vector3::new(-hx, hy, 0.0),
            Vector3::new(-1.0, 1.0, 0.0),
            -Vector3::y(),
        ),
    ];
    let mut out = Vec::new();
    for (corner, outward, along) in corners {
        let outward = outward.normalize();
        let into = (outward - Vector3::z()).normalize();
        let a = corner - outward * 10.0;
        out.extend(seam(vec![
            torch_into(a, into, along),
            torch_into(a + along * 40.0, into, along),
        ]));
    }
    out
}

/// The tool pointing straight down (its z axis along −z of the work piece).
pub(in crate::simulation) fn tool_down() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI)
}

/// The welds' seams start on the side facing the arm's base, where the approach point above
/// them is in the IRB 140's reach (the work piece's −x side faces the base).
const SEAM_TURN_RAD: f64 = TURN_DEG * PI / 180.0;
const TURN_DEG: f64 = 180.0;

/// `poses` turned about the work piece's vertical axis.
fn turned(poses: Vec<Pose>, angle: f64) -> Vec<Pose> {
    let turn = Isometry3::rotation(Vector3::z() * angle);
    poses
        .iter()
        .map(|p| Pose::from_isometry(turn * p.isometry()))
        .collect()
}

/// A pose from a position and a rotation.
pub(in crate::simulation) fn pose(p: Vector3<f64>, q: UnitQuaternion<f64>) -> Pose {
    Pose::from_isometry(Isometry3::from_parts(Translation3::from(p), q))
}

/// The star polygon {n/k}: n vertices on a circle, each stroke to the vertex k further on, back
/// to the start (n + 1 waypoints), every stroke one spacing long; tool down.
fn star_polygon(n: usize, k: usize) -> Vec<Pose> {
    let step = std::f64::consts::TAU / n as f64;
    // Vertices k apart on a circle of radius r are a chord 2 r sin(k·step/2) apart.
    let r = DISSERTATION_SPACING_MM / (2.0 * (k as f64 * step / 2.0).sin());
    (0..=n)
        .map(|i| {
            let t = PI / 2.0 + ((i * k) % n) as f64 * step;
            pose(Vector3::new(r * t.cos(), r * t.sin(), 0.0), tool_down())
        })
        .collect()
}

fn dodecagram() -> Vec<Pose> {
    star_polygon(12, 5)
}

fn pentagram() -> Vec<Pose> {
    star_polygon(5, 2)
}

/// The seam's chord such that approach, 7 chords and retract average the dissertation's spacing.
fn seam_chord_mm() -> f64 {
    (9.0 * DISSERTATION_SPACING_MM - 2.0 * WELD_CLEARANCE_MM) / 7.0
}

/// A torch at `p` on a fillet joint whose outward normal (in the plate's plane) is `n` and
/// along which it travels in `t`: 45° work angle, pointing into the joint (tool z), tool x
/// along the travel.
fn torch(p: Vector3<f64>, n: Vector3<f64>, t: Vector3<f64>) -> Pose {
    let z = -(n * FRAC_PI_4.cos() + Vector3::z() * FRAC_PI_4.sin());
    let x = t.normalize();
    let y = z.cross(&x);
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    pose(p, UnitQuaternion::from_rotation_matrix(&r))
}

/// Approach, the seam's poses, retract: the clearance points straight above the seam's first
/// and last points, the torch as there.
fn with_clearance(seam: Vec<Pose>) -> Vec<Pose> {
    let back = |p: &Pose| {
        pose(
            p.position() + Vector3::z() * WELD_CLEARANCE_MM,
            p.rotation(),
        )
    };
    let mut out = vec![back(&seam[0])];
    let last = back(&seam[seam.len() - 1]);
    out.extend(seam);
    out.push(last);
    out
}

fn pipe_seam() -> Vec<Pose> {
    let step = FRAC_PI_4;
    let r = seam_chord_mm() / (2.0 * (step / 2.0).sin());
    let seam = (0..8)
        .map(|k| {
            let a = k as f64 * step;
            let n = Vector3::new(a.cos(), a.sin(), 0.0);
            let t = Vector3::new(-a.sin(), a.cos(), 0.0);
            torch(n * r, n, t)
        })
        .collect();
    with_clearance(seam)
}

fn box_seam() -> Vec<Pose> {
    // Corners and side middles of a square of side 2·chord, from the corner (+h, −h) along
    // +y, counter-clockwise: 3½ sides.
    let h = seam_chord_mm();
    let sides = [
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.0, 1.0, 0.0),
        Vector3::new(-1.0, 0.0, 0.0),
        Vector3::new(0.0, -1.0, 0.0),
    ];
    let seam = (0..8)
        .map(|k| {
            let side = k / 2;
            let (n, p) = if k % 2 == 0 {
                // A corner between the previous side and this one: the normals' bisector.
                let prev = sides[(side + 3) % 4];
                let n = (sides[side] + prev).normalize();
                (n, (sides[side] + prev) * h)
            } else {
                let n = sides[side];
                (n, n * h)
            };
            let t = Vector3::z().cross(&n);
            torch(p, n, t)
        })
        .collect();
    with_clearance(seam)
}

/// Mean distance between consecutive waypoints of `poses`, mm (0 for fewer than two).
pub fn mean_spacing_mm(poses: &[Pose]) -> f64 {
    if poses.len() < 2 {
        return 0.0;
    }
    let total: f64 = poses.windows(2).map(|w| w[0].distance_to(&w[1])).sum();
    total / (poses.len() - 1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_repertoire_has_the_dissertations_counts_and_spacing() {
        let counts: Vec<usize> = Task::DISSERTATION
            .iter()
            .map(|t| t.waypoints().len())
            .collect();
        assert_eq!(counts, [13, 6, 10, 10]);
        for t in Task::DISSERTATION {
            let m = mean_spacing_mm(&t.waypoints());
            assert!(
                (m - DISSERTATION_SPACING_MM).abs() < 1e-9,
                "{}: {m}",
                t.name()
            );
        }
    }

    #[test]
    fn torches_point_into_the_joint_at_45_degrees() {
        for t in [Task::PipeSeam, Task::BoxSeam] {
            let w = t.waypoints();
            for p in &w[1..9] {
                let z = p.rotation() * Vector3::z();
                assert!((z.z + FRAC_PI_4.sin()).abs() < 1e-12, "{}", t.name());
                // Pointing inwards: towards the pipe's or tube's axis.
                assert!(z.xy().dot(&p.position().xy()) < 0.0);
            }
            assert!((w[0].distance_to(&w[1]) - WELD_CLEARANCE_MM).abs() < 1e-9);
        }
    }
}
