//! The three frames a program repeats itself in, as sequences of 7-vectors.
//!
//! A routine `W_0 … W_N` can be read three ways, and each reading has its own kind of repeat:
//!
//! - [`Frame::Tool`]: the SRHCT moves `T_n = W_{n-1}⁻¹ · W_n`, translation in the frame of the
//!   previous waypoint (the engine's reading, ALGORITHM §1). A repeat is the same move in the
//!   last pose's tool frame: a pattern taught again at another place or angle.
//! - [`Frame::Work`]: work-frame moves, translation `p_n − p_{n−1}` in the work frame and rotation
//!   `q_n q_{n−1}*`. A repeat is the same offset in the work object: `Offs(p, 0, 0, 100)` under a
//!   tool that turns between seams, a pallet row continued.
//! - [`Frame::Absolute`]: the poses `(p_n, q_n)` themselves. A repeat is a return to a known
//!   point: home, approach and retract points, reused targets.
//!
//! Every element is a 7-vector `[x, y, z, q_w, q_x, q_y, q_z]` with the canonical quaternion sign
//! (`q_w ≥ 0`, ties broken by the first non-zero component). [`Frame::elements`] reads a routine,
//! [`Frame::apply`] turns an element back into a guess at the next waypoint given the last one.
//!
//! *Closeness in element space is closeness of the guess.* For all three frames, the guesses two
//! elements give after the same last pose are as far apart (position, and geodesic angle) as the
//! elements are: the tool frame's translation is rotated by the last pose's rotation (a length is
//! kept), the rotations compose with the same last rotation on the same side (an angle between
//! them is kept). So [`Tolerance::holds`] between the element that would have been right ([`Frame::target`])
//! and a candidate element decides whether that candidate's guess is within the tolerance,
//! without building the guess.

use nalgebra::{Quaternion, Translation3, UnitQuaternion, Vector3};

use crate::engine::pose::{Move, Observation, Pose, observations};

/// Which reading of a routine a predictor or an oracle works in (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Frame {
    /// SRHCT relative moves, in the last pose's tool frame.
    Tool,
    /// Moves in the work frame: `p_n − p_{n−1}`, `q_n q_{n−1}*`.
    Work,
    /// The poses themselves.
    Absolute,
}

impl Frame {
    /// The three frames, in the order oracles are reported.
    pub const ALL: [Frame; 3] = [Frame::Tool, Frame::Absolute, Frame::Work];

    /// Name in reports: `tool`, `work`, `absolute`.
    pub fn name(self) -> &'static str {
        match self {
            Frame::Tool => "tool",
            Frame::Work => "work",
            Frame::Absolute => "absolute",
        }
    }

    /// Whether an element is a move applied to the last pose (tool, work), rather than a pose.
    pub fn is_move(self) -> bool {
        !matches!(self, Frame::Absolute)
    }

    /// The routine's elements: one per consecutive pair of waypoints for the move frames, one
    /// per waypoint for [`Frame::Absolute`].
    pub fn elements(self, waypoints: &[Pose]) -> Vec<Observation> {
        match self {
            Frame::Tool => observations(waypoints),
            Frame::Work => waypoints
                .windows(2)
                .map(|w| work_move(&w[0], &w[1]))
                .collect(),
            Frame::Absolute => waypoints.iter().map(pose_vector).collect(),
        }
    }

    /// The element that would have predicted `next` exactly after `last`.
    pub fn target(self, last: &Pose, next: &Pose) -> Observation {
        match self {
            Frame::Tool => Move::between(last, next).observation(),
            Frame::Work => work_move(last, next),
            Frame::Absolute => pose_vector(next),
        }
    }

    /// The guess an element gives after `last`. `None` only for an element whose quaternion part
    /// has no direction or that is not finite (never one read from poses).
    pub fn apply(self, last: &Pose, element: &Observation) -> Option<Pose> {
        if element.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let q = Quaternion::new(element[3], element[4], element[5], element[6]);
        if q.norm() < 1e-9 {
            return None;
        }
        let rotation = UnitQuaternion::new_normalize(q);
        let t = Vector3::new(element[0], element[1], element[2]);
        Some(match self {
            Frame::Tool => last.then(&Move::from_observation(element).ok()?),
            Frame::Work => Pose::from_isometry(nalgebra::Isometry3::from_parts(
                Translation3::from(last.position() + t),
                rotation * last.rotation(),
            )),
            Frame::Absolute => Pose::from_isometry(nalgebra::Isometry3::from_parts(
                Translation3::from(t),
                rotation,
            )),
        })
    }
}

/// The work-frame move from `a` to `b`: `[p_b − p_a, q_b q_a*]`.
pub fn work_move(a: &Pose, b: &Pose) -> Observation {
    let t = b.position() - a.position();
    let q = b.rotation() * a.rotation().inverse();
    vector(t, q)
}

/// A pose as an element: `[p, q]`.
pub fn pose_vector(p: &Pose) -> Observation {
    vector(p.position(), p.rotation())
}

fn vector(t: Vector3<f64>, q: UnitQuaternion<f64>) -> Observation {
    let q = q.into_inner();
    let first_nonzero = [q.w, q.i, q.j, q.k]
        .into_iter()
        .find(|c| *c != 0.0)
        .unwrap_or(1.0);
    let q = if first_nonzero < 0.0 { -q } else { q };
    Observation::from([t.x, t.y, t.z, q.w, q.i, q.j, q.k])
}

/// Distance between the translation (or position) parts of two elements, mm.
pub fn distance(a: &Observation, b: &Observation) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Geodesic angle between the rotation parts of two elements, rad in `[0, π]` (sign-blind:
/// `q` and `−q` are one rotation).
pub fn angle(a: &Observation, b: &Observation) -> f64 {
    let na = (a[3] * a[3] + a[4] * a[4] + a[5] * a[5] + a[6] * a[6]).sqrt();
    let nb = (b[3] * b[3] + b[4] * b[4] + b[5] * b[5] + b[6] * b[6]).sqrt();
    let dot = (a[3] * b[3] + a[4] * b[4] + a[5] * b[5] + a[6] * b[6]) / (na * nb);
    2.0 * dot.abs().min(1.0).acos()
}

/// How close two elements (or two guesses) must be to count as the same: translation in mm and
/// rotation in rad, both bounds inclusive.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerance {
    /// mm
    pub mm: f64,
    /// rad
    pub rad: f64,
}

impl Tolerance {
    /// What counts as a useful prediction: the dissertation's acceptance tolerance (§4.3.1; the
    /// scoreboard's "useful"), 1 mm and 0.1 rad.
    pub const USEFUL: Tolerance = Tolerance { mm: 1.0, rad: 0.1 };

    /// Whether `a` and `b` are within the tolerance of each other.
    pub fn holds(&self, a: &Observation, b: &Observation) -> bool {
        distance(a, b) <= self.mm && angle(a, b) <= self.rad
    }
}

impl Default for Tolerance {
    fn default() -> Tolerance {
        Tolerance::USEFUL
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Observation, b: &Observation) -> bool {
        Tolerance::USEFUL.holds(a, b)
    }
    use nalgebra::Unit;

    fn pose(p: [f64; 3], axis: [f64; 3], angle: f64) -> Pose {
        let q = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::from(axis)), angle);
        Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
    }

    fn poses() -> Vec<Pose> {
        (0..12)
            .map(|i| {
                let t = i as f64;
                pose(
                    [
                        40.0 * t.sin() + 3.0 * t,
                        17.0 * t - t * t,
                        5.0 * (t * 0.7).cos(),
                    ],
                    [0.3 + 0.1 * t, 1.0 - 0.05 * t, 0.2 * t],
                    0.4 * t - 0.02 * t * t,
                )
            })
            .collect()
    }

    /// Applying the target reproduces the next pose, in every frame.
    #[test]
    fn target_then_apply_is_the_next_pose() {
        let w = poses();
        for frame in Frame::ALL {
            for pair in w.windows(2) {
                let g = frame
                    .apply(&pair[0], &frame.target(&pair[0], &pair[1]))
                    .unwrap();
                assert!(g.distance_to(&pair[1]) < 1e-9, "{frame:?}");
                assert!(g.angle_to(&pair[1]) < 1e-7, "{frame:?}");
            }
            let elements = frame.elements(&w);
            assert_eq!(elements.len(), w.len() - usize::from(frame.is_move()));
        }
    }

    /// Element-space distance and angle are the guesses' distance and angle (module doc).
    #[test]
    fn element_distance_is_guess_distance() {
        let w = poses();
        for frame in Frame::ALL {
            for (i, last) in w.iter().enumerate() {
                let a = frame.target(&w[(i + 3) % w.len()], &w[(i + 5) % w.len()]);
                let b = frame.target(&w[(i + 1) % w.len()], &w[(i + 7) % w.len()]);
                let (ga, gb) = (
                    frame.apply(last, &a).unwrap(),
                    frame.apply(last, &b).unwrap(),
                );
                assert!(
                    (ga.distance_to(&gb) - distance(&a, &b)).abs() < 1e-9,
                    "{frame:?}"
                );
                assert!((ga.angle_to(&gb) - angle(&a, &b)).abs() < 1e-6, "{frame:?}");
            }
        }
    }

    /// A work-frame offset under a turned tool: the work element stays, the tool element moves.
    #[test]
    fn a_work_offset_is_one_element_under_any_tool_angle() {
        let a0 = pose([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 0.2);
        let a1 = pose([300.0, 50.0, 0.0], [0.0, 1.0, 0.0], 0.6);
        let up = |p: &Pose| {
            Pose::from_isometry(nalgebra::Isometry3::from_parts(
                Translation3::from(p.position() + Vector3::new(0.0, 0.0, 100.0)),
                p.rotation(),
            ))
        };
        let (w0, w1) = (work_move(&a0, &up(&a0)), work_move(&a1, &up(&a1)));
        assert!(close(&w0, &w1));
        let (t0, t1) = (
            Frame::Tool.target(&a0, &up(&a0)),
            Frame::Tool.target(&a1, &up(&a1)),
        );
        assert!(distance(&t0, &t1) > 30.0);
        assert!(!close(&t0, &t1));
    }

    #[test]
    fn angle_is_sign_blind_and_close_is_inclusive() {
        let a = Observation::from([0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
        let b = Observation::from([1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0]);
        assert!(angle(&a, &b) < 1e-12);
        assert!(close(&a, &b), "1 mm apart is on the boundary");
        let c = Observation::from([1.001, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
        assert!(!close(&a, &c));
    }
}
