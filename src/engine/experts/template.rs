//! The template expert: the routine being taught is an earlier routine's stretch placed anew.
//!
//! A work piece put down a little elsewhere, or a fixture turned, moves every waypoint of a
//! task by one rigid transform `G`. The sequence experts read such a repeat one element at a
//! time relative to the *last* waypoint, so a noisy last waypoint carries its whole error into
//! the guess. This expert instead fits `G` to the last few waypoints at once: it aligns them
//! (least squares, Kabsch) with every earlier stretch of as many consecutive waypoints whose
//! shape matches, and proposes `G` applied to the waypoint that followed there. With noisy
//! waypoints the fit averages the errors of all the aligned waypoints, and the proposals of
//! several earlier repetitions are averaged too; with exact ones it finds what a long
//! tool-frame context finds.
//!
//! **Alignment.** A pose is four points: its position and the tips of its three axes at a lever
//! `L` (mm per rad: the cell's noise ratio `σ_mm/σ_rad`, so a rotation error weighs what it
//! moves a point by; 100 mm for an exact cell). `G` minimises the squared distances of the
//! points (Kabsch with the reflection fixed). A stretch matches when every aligned pose lies
//! within the cell's tolerance of its counterpart, widened by the noise
//! ([`super::noise::Noise::widen`] for two poses).
//!
//! **Finding stretches.** The length of the move into a waypoint does not change under `G`, so
//! the earlier waypoints are kept sorted by it and only those whose incoming move is about as
//! long as the last taught one are looked at; of those, only the steps back whose lengths and
//! turns match too are aligned.

use nalgebra::{Isometry3, Point3, Vector3};

use super::alignment::rigid_fit;
use super::frames::{Frame, Tolerance};
use super::noise::Noise;
use super::{Candidate, Cell, Evidence, Expert};
use crate::engine::pose::Pose;

/// Most waypoints aligned at once.
pub const MAX_POSES: usize = 8;
/// Fewest: two poses fix `G` (one would only repeat the last move, the tool-frame expert's).
pub const MIN_POSES: usize = 2;
/// Lever of an exact cell, mm per rad.
const EXACT_LEVER_MM: f64 = 100.0;

/// The finished routines, and their waypoints by the length of the move into them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TemplateExpert {
    routines: Vec<Vec<Pose>>,
    /// (length of the move into waypoint `j`, routine, `j`) for every `j` with a predecessor
    /// and a follower, sorted by length.
    by_length: Vec<(f64, u32, u32)>,
}

/// One earlier stretch aligned with the taught one.
#[derive(Debug, Clone, Copy)]
struct Place {
    poses: usize,
    guess: Pose,
    ss_mm: f64,
}

impl TemplateExpert {
    pub fn new() -> TemplateExpert {
        TemplateExpert::default()
    }

    /// Remembers a finished routine.
    pub fn learn(&mut self, routine: &[Pose]) {
        let r = u32::try_from(self.routines.len()).unwrap_or(u32::MAX);
        let mut fresh: Vec<(f64, u32, u32)> = (1..routine.len().saturating_sub(1))
            .map(|j| {
                let len = routine[j].distance_to(&routine[j - 1]);
                (len, r, u32::try_from(j).unwrap_or(u32::MAX))
            })
            .collect();
        fresh.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Merge the routine's few entries into the sorted many, in one pass.
        let old = std::mem::take(&mut self.by_length);
        self.by_length.reserve(old.len() + fresh.len());
        let (mut a, mut b) = (old.into_iter().peekable(), fresh.into_iter().peekable());
        while let (Some(x), Some(y)) = (a.peek(), b.peek()) {
            let next = if x.0.total_cmp(&y.0).is_le() {
                a.next()
            } else {
                b.next()
            };
            self.by_length.extend(next);
        }
        self.by_length.extend(a);
        self.by_length.extend(b);
        self.routines.push(routine.to_vec());
    }

    /// The candidate after `routine` (see the module doc): places aligned on the most poses,
    /// their guesses averaged over those that agree with the best-fitting one.
    pub fn propose(
        &self,
        routine: &[Pose],
        noise: &Noise,
        tolerance: &Tolerance,
    ) -> Option<Candidate> {
        let m = routine.len();
        if m < MIN_POSES {
            return None;
        }
        let gate = noise.widen(*tolerance, Frame::Absolute);
        let lever = if noise.mm > 0.0 && noise.rad > 0.0 {
            (noise.mm / noise.rad).clamp(10.0, 1000.0)
        } else {
            EXACT_LEVER_MM
        };
        let last_len = routine[m - 1].distance_to(&routine[m - 2]);
        // The incoming lengths differ by at most the two endpoints' misfits.
        let lo = self
            .by_length
            .partition_point(|e| e.0 < last_len - 2.0 * gate.mm);
        let mut places: Vec<Place> = Vec::new();
        for &(len, r, j) in &self.by_length[lo..] {
            if len > last_len + 2.0 * gate.mm {
                break;
            }
            let earlier = &self.routines[r as usize];
            let j = j as usize;
            // Rigid moves keep the length and the turn of every step: count the steps back from
            // here that keep them within what two misfits allow, before aligning anything.
            let steps = (1..MAX_POSES.min(m).min(j + 1))
                .take_while(|&i| {
                    let (a0, a1) = (&earlier[j - i], &earlier[j + 1 - i]);
                    let (b0, b1) = (&routine[m - 1 - i], &routine[m - i]);
                    (a0.distance_to(a1) - b0.distance_to(b1)).abs() <= 2.0 * gate.mm
                        && (a0.angle_to(a1) - b0.angle_to(b1)).abs() <= 2.0 * gate.rad
                })
                .count();
            let most = steps + 1;
            if most < MIN_POSES {
                continue;
            }
            if let Some(p) = (MIN_POSES..=most).rev().find_map(|k| {
                align(&earlier[j + 1 - k..=j], &routine[m - k..], lever, &gate).map(|(g, ss_mm)| {
                    Place {
                        poses: k,
                        guess: Pose::from_isometry(g * earlier[j + 1].isometry()),
                        ss_mm,
                    }
                })
            }) {
                places.push(p);
            }
        }
        let poses = places.iter().map(|p| p.poses).max()?;
        places.retain(|p| p.poses == poses);
        let best = *places.iter().min_by(|a, b| a.ss_mm.total_cmp(&b.ss_mm))?;
        // Guesses of two places differ by two placements' errors: the pose gate applies.
        let agree: Vec<&Place> = places
            .iter()
            .filter(|p| {
                p.guess.distance_to(&best.guess) <= gate.mm
                    && p.guess.angle_to(&best.guess) <= gate.rad
            })
            .collect();
        let guess = crate::engine::pose::mean(agree.iter().map(|p| &p.guess), &best.guess)
            .unwrap_or(best.guess);
        Some(Candidate {
            pose: guess,
            evidence: Evidence::Template {
                steps: poses - 1,
                places: places.len(),
                agreeing: agree.len(),
            },
        })
    }
}

impl Expert for TemplateExpert {
    fn learn(&mut self, routine: &[Pose]) {
        TemplateExpert::learn(self, routine);
    }

    /// Its candidate in a cell whose noise matters only: on exact waypoints it finds what a
    /// long tool-frame context finds. It learns every routine all the same, so it is ready
    /// when the cell's noise begins to matter.
    fn propose(&self, routine: &[Pose], cell: &Cell) -> Vec<Candidate> {
        if !cell.noisy {
            return Vec::new();
        }
        TemplateExpert::propose(self, routine, &cell.noise, &cell.tolerance)
            .into_iter()
            .collect()
    }
}

/// The four points of a pose (see the module doc).
fn points(p: &Pose, lever: f64) -> [Point3<f64>; 4] {
    let o = Point3::from(p.position());
    let r = p.rotation();
    [
        o,
        o + r * Vector3::x() * lever,
        o + r * Vector3::y() * lever,
        o + r * Vector3::z() * lever,
    ]
}

/// The rigid transform taking `from` onto `to` (as many poses each), when every aligned pose is
/// within `gate` of its counterpart; with the sum of squared position residuals (mm²).
fn align(
    from: &[Pose],
    to: &[Pose],
    lever: f64,
    gate: &Tolerance,
) -> Option<(Isometry3<f64>, f64)> {
    let a: Vec<Point3<f64>> = from.iter().flat_map(|p| points(p, lever)).collect();
    let b: Vec<Point3<f64>> = to.iter().flat_map(|p| points(p, lever)).collect();
    let g = rigid_fit(&a, &b)?;
    let mut ss_mm = 0.0;
    for (p, q) in from.iter().zip(to) {
        let moved = Pose::from_isometry(g * p.isometry());
        let (dm, da) = (moved.distance_to(q), moved.angle_to(q));
        if dm > gate.mm || da > gate.rad {
            return None;
        }
        ss_mm += dm * dm;
    }
    Some((g, ss_mm))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::experts::noise::tests::noisy;
    use nalgebra::{Translation3, UnitQuaternion};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A pentagram-like task of 6 waypoints, tool down, placed by `(dx, dy, turn)`.
    fn task(dx: f64, dy: f64, turn: f64) -> Vec<Pose> {
        let g = Isometry3::from_parts(
            Translation3::new(500.0 + dx, dy, 200.0),
            UnitQuaternion::from_euler_angles(0.0, 0.0, turn),
        );
        let down = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.3);
        (0..6)
            .map(|i| {
                let a = f64::from(i) * 4.0 * std::f64::consts::PI / 5.0;
                let local = Isometry3::from_parts(
                    Translation3::new(98.0 * a.cos(), 98.0 * a.sin(), 0.0),
                    down,
                );
                Pose::from_isometry(g * local)
            })
            .collect()
    }

    /// Exact: the task placed anew is continued exactly from two waypoints on.
    #[test]
    fn an_exact_task_placed_anew_is_continued() {
        let mut e = TemplateExpert::new();
        e.learn(&task(0.0, 0.0, 0.0));
        let placed = task(40.0, -30.0, 0.25);
        for m in 2..placed.len() {
            let c = e
                .propose(&placed[..m], &Noise::EXACT, &Tolerance::USEFUL)
                .expect("a candidate");
            assert!(c.pose.distance_to(&placed[m]) < 1e-6, "at {m}");
            assert!(c.pose.angle_to(&placed[m]) < 1e-6, "at {m}");
            let Evidence::Template {
                steps,
                places,
                agreeing,
            } = c.evidence
            else {
                panic!("{:?}", c.evidence);
            };
            assert_eq!(steps, m.min(MAX_POSES) - 1);
            assert_eq!((places, agreeing), (1, 1));
        }
        // Another shape does not match.
        let other: Vec<Pose> = task(0.0, 0.0, 0.0)
            .iter()
            .enumerate()
            .map(|(i, p)| {
                Pose::from_isometry(Translation3::new(0.0, 7.0 * i as f64, 0.0) * p.isometry())
            })
            .collect();
        assert!(
            e.propose(&other[..3], &Noise::EXACT, &Tolerance::USEFUL)
                .is_none()
        );
    }

    /// Noisy (7 mm, 0.02 rad per axis): repetitions taught before by other hands, the task
    /// placed anew and taught with the same noise. Aligning several waypoints and averaging
    /// several repetitions puts the guess closer to the waypoint meant than the last taught
    /// waypoint's own error would allow a move-by-move guess to be.
    #[test]
    fn a_noisy_task_is_predicted_within_the_operators_tolerance() {
        let noise = Noise { mm: 7.0, rad: 0.02 };
        let tolerance = Tolerance { mm: 25.0, rad: 0.1 };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut e = TemplateExpert::new();
        for i in 0..8 {
            let t = task(
                10.0 * f64::from(i),
                -5.0 * f64::from(i),
                0.03 * f64::from(i),
            );
            e.learn(&noisy(&t, &noise, &mut rng));
        }
        let (mut within, mut errors, mut total) = (0usize, 0.0, 0usize);
        for trial in 0..40 {
            let meant = task(
                -30.0 + f64::from(trial),
                25.0,
                -0.2 + 0.01 * f64::from(trial),
            );
            let taught = noisy(&meant, &noise, &mut rng);
            for m in 3..meant.len() {
                let c = e
                    .propose(&taught[..m], &noise, &tolerance)
                    .expect("a candidate");
                let d = c.pose.distance_to(&meant[m]);
                errors += d * d;
                total += 1;
                within +=
                    usize::from(d <= tolerance.mm && c.pose.angle_to(&meant[m]) <= tolerance.rad);
            }
        }
        let rms = (errors / total as f64).sqrt();
        // A move-by-move guess is at least the last waypoint's error away: 7·√3 ≈ 12 mm RMS.
        assert!(rms < 10.0, "RMS error {rms} mm");
        assert!(within as f64 >= 0.95 * total as f64, "{within} of {total}");
    }
}
