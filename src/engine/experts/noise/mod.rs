//! A cell's teaching noise: how far a taught waypoint lies from the one the operator meant.
//!
//! An operator who jogs with a joystick and records when "close enough" places each waypoint
//! with an error; [`Noise`] is its one-sigma per axis, in position (mm) and in rotation (rad,
//! per axis of the rotation vector). Offline programs are exact ([`Noise::EXACT`]).
//!
//! **Where it comes from.** Set from a calibration routine, the dissertation's §4.5.1: the operator
//! jogs to one unreferenced point several times and the scatter of the recorded poses is the noise
//! ([`Noise::from_scatter`]; the simulation's cells are set that way).
//!
//! **What it changes.** Two elements read from noisy waypoints differ even when they mean the
//! same: two poses by the difference of two errors, two moves by four (each move is the
//! difference of two poses). [`Noise::widen`] turns a tolerance for exact elements into one for
//! noisy elements of a frame: the larger of the given tolerance and [`MATCH_SIGMAS`] times the
//! RMS length of that difference. So the experts' gates are in units of the noise, and one
//! profile serves exact and noisy cells: with no noise the tolerance is the given one.

pub mod estimate;

use serde::{Deserialize, Serialize};

use super::frames::{Frame, Tolerance};
use crate::engine::pose::Pose;

/// How many RMS lengths of the difference two noisy elements may differ by and still match. The
/// norm of a 3-D Gaussian difference exceeds 1.5 times its RMS length about 5 % of the time.
pub const MATCH_SIGMAS: f64 = 1.5;

/// Per-axis sigmas from the meant waypoint within which an operator takes a suggestion as is:
/// half the effective target width 4.133 σ (Crossman; MacKenzie 1992), as the simulated
/// operator decides (`simulation/operator.rs`).
pub const ACCEPT_SIGMAS: f64 = 4.133 / 2.0;

/// Teaching noise: one-sigma error per axis of a taught waypoint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// Position, mm per axis.
    pub mm: f64,
    /// Rotation, rad per axis.
    pub rad: f64,
}

impl Default for Noise {
    fn default() -> Noise {
        Noise::EXACT
    }
}

impl Noise {
    /// Exact waypoints (offline programs).
    pub const EXACT: Noise = Noise { mm: 0.0, rad: 0.0 };

    /// Whether both parts are finite and non-negative.
    pub fn is_valid(&self) -> bool {
        [self.mm, self.rad]
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0)
    }

    /// The noise of poses recorded at one point again and again: the sample standard deviation
    /// per axis, pooled over the three axes, of the positions about their mean and of the
    /// rotations about their mean rotation. `None` with fewer than two poses.
    pub fn from_scatter(poses: &[Pose]) -> Option<Noise> {
        if poses.len() < 2 {
            return None;
        }
        let n = poses.len() as f64;
        let centre = crate::engine::pose::mean(poses.iter(), &poses[0])?;
        let (mean, mean_rotation) = (centre.position(), centre.rotation());
        let dof = 3.0 * (n - 1.0);
        let ss_mm: f64 = poses
            .iter()
            .map(|p| (p.position() - mean).norm_squared())
            .sum();
        let ss_rad: f64 = poses
            .iter()
            .map(|p| p.rotation().angle_to(&mean_rotation).powi(2))
            .sum();
        Some(Noise {
            mm: (ss_mm / dof).sqrt(),
            rad: (ss_rad / dof).sqrt(),
        })
    }

    /// How many waypoint errors an element of `frame` is made of: a pose one, a move two.
    fn errors_per_element(frame: Frame) -> f64 {
        if frame.is_move() { 2.0 } else { 1.0 }
    }

    /// The RMS length (mm, rad) of the difference between two elements of `frame` that mean the
    /// same, each read from noisy waypoints.
    pub fn difference_rms(&self, frame: Frame) -> (f64, f64) {
        // Two elements, each of `k` independent errors with per-axis sigma s: a 3-D difference
        // with per-axis sigma s·√(2k), RMS length s·√(6k).
        let k = Noise::errors_per_element(frame);
        let f = (6.0 * k).sqrt();
        (f * self.mm, f * self.rad)
    }

    /// The tolerance an operator with this noise accepts a suggestion within, before any
    /// feedback tells: half the effective target width of their own placements (Crossman's
    /// 4.133 σ, as the simulated operator has it, [`ACCEPT_SIGMAS`]), never tighter than
    /// [`Tolerance::USEFUL`] (1 mm / 0.1 rad).
    pub fn tolerance(&self) -> Tolerance {
        Tolerance {
            mm: Tolerance::USEFUL.mm.max(ACCEPT_SIGMAS * self.mm),
            rad: Tolerance::USEFUL.rad.max(ACCEPT_SIGMAS * self.rad),
        }
    }

    /// Whether the noise is too small to matter at this tolerance: no element's match tolerance
    /// is widened by it (the cell then behaves as an exact one).
    pub fn is_negligible(&self, tolerance: &Tolerance) -> bool {
        self.widen(*tolerance, Frame::Work) == *tolerance
    }

    /// A tolerance for matching noisy elements of `frame` (see the module doc).
    pub fn widen(&self, tolerance: Tolerance, frame: Frame) -> Tolerance {
        let (mm, rad) = self.difference_rms(frame);
        Tolerance {
            mm: tolerance.mm.max(MATCH_SIGMAS * mm),
            rad: tolerance.rad.max(MATCH_SIGMAS * rad),
        }
    }
}

impl Noise {
    /// The tolerance an outcome is judged with against a taught waypoint: the acceptance
    /// tolerance combined with the taught waypoint's own error (root sum of squares with its
    /// RMS length, √3 σ), since the waypoint the operator meant is unknown and lies about the
    /// taught one. A candidate on the meant waypoint then counts as right about nine times in
    /// ten at the simulated online operator's noise; with no noise it is the tolerance itself.
    pub fn judging(&self, tolerance: &Tolerance) -> Tolerance {
        let rms = |s: f64| 3f64.sqrt() * s;
        Tolerance {
            mm: tolerance.mm.hypot(rms(self.mm)),
            rad: tolerance.rad.hypot(rms(self.rad)),
        }
    }

    /// Whether `candidate` counts as right when `taught` is what was then taught (1 or 0): within
    /// [`Noise::judging`]'s tolerance of it.
    pub fn outcome(&self, tolerance: &Tolerance, candidate: &Pose, taught: &Pose) -> f64 {
        let t = self.judging(tolerance);
        let right = candidate.distance_to(taught) <= t.mm && candidate.angle_to(taught) <= t.rad;
        f64::from(u8::from(right))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A standard normal draw (Box–Muller); the engine's tests share it.
    pub(crate) fn gauss(rng: &mut ChaCha8Rng) -> f64 {
        let u: f64 = rng.random_range(1e-12..1.0);
        let v: f64 = rng.random_range(0.0..1.0);
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }

    /// `poses` as an operator with `noise` places them: each one's position and rotation off by
    /// a Gaussian error per axis. The tests of the template expert and the estimator share it.
    pub(crate) fn noisy(poses: &[Pose], noise: &Noise, rng: &mut ChaCha8Rng) -> Vec<Pose> {
        poses
            .iter()
            .map(|p| {
                let dp = Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * noise.mm;
                let dr = Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * noise.rad;
                Pose::from_isometry(nalgebra::Isometry3::from_parts(
                    nalgebra::Translation3::from(p.position() + dp),
                    UnitQuaternion::from_scaled_axis(dr) * p.rotation(),
                ))
            })
            .collect()
    }

    /// An operator with 7 mm and 0.02 rad per axis records one point 400 times: the scatter
    /// recovers both within a few per cent.
    #[test]
    fn the_scatter_of_a_calibration_routine_recovers_a_known_noise() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let centre = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0);
        let poses: Vec<Pose> = (0..400)
            .map(|_| {
                let p = [
                    500.0 + 7.0 * gauss(&mut rng),
                    -20.0 + 7.0 * gauss(&mut rng),
                    300.0 + 7.0 * gauss(&mut rng),
                ];
                let r = Vector3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)) * 0.02;
                let q = UnitQuaternion::from_scaled_axis(r) * centre;
                Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
            })
            .collect();
        let n = Noise::from_scatter(&poses).unwrap();
        assert!((n.mm - 7.0).abs() < 0.35, "{n:?}");
        assert!((n.rad - 0.02).abs() < 0.001, "{n:?}");
        assert!(Noise::from_scatter(&poses[..1]).is_none());
    }

    /// An exact cell judges with its tolerance; a noisy one also lets the taught waypoint's
    /// own error pass: a candidate on the meant waypoint counts as right about nine times in
    /// ten for the online operator's noise.
    #[test]
    fn outcomes_are_judged_with_the_taught_waypoints_error() {
        let at = |x: f64| Pose::new([x, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
        let t = Tolerance::USEFUL;
        assert_eq!(Noise::EXACT.judging(&t), t);
        assert_eq!(Noise::EXACT.outcome(&t, &at(0.9), &at(0.0)), 1.0);
        assert_eq!(Noise::EXACT.outcome(&t, &at(1.1), &at(0.0)), 0.0);
        let noise = Noise {
            mm: 11.55,
            rad: 0.02,
        };
        let accept = Tolerance { mm: 24.0, rad: 0.1 };
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let meant = at(0.0);
        let trials = 20_000;
        let right: f64 = (0..trials)
            .map(|_| {
                let e = Vector3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)) * noise.mm;
                let taught = Pose::from_isometry(nalgebra::Isometry3::translation(e.x, e.y, e.z));
                noise.outcome(&accept, &meant, &taught)
            })
            .sum();
        let share = right / f64::from(trials);
        assert!((0.85..0.97).contains(&share), "{share}");
    }

    #[test]
    fn widening_keeps_an_exact_cells_tolerance_and_grows_with_the_noise() {
        for frame in Frame::ALL {
            assert_eq!(
                Noise::EXACT.widen(Tolerance::USEFUL, frame),
                Tolerance::USEFUL
            );
        }
        let n = Noise {
            mm: 10.0,
            rad: 0.02,
        };
        let pose = n.widen(Tolerance::USEFUL, Frame::Absolute);
        let moves = n.widen(Tolerance::USEFUL, Frame::Work);
        assert!((pose.mm - MATCH_SIGMAS * 6f64.sqrt() * 10.0).abs() < 1e-9);
        assert!(moves.mm > pose.mm, "a move carries two errors");
        assert_eq!(
            pose.rad, 0.1,
            "0.02 rad per axis stays inside the seed's 0.1 rad"
        );
    }
}
