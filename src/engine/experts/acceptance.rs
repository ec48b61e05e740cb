//! What the operator accepts: their verdicts on the cell's suggestions, and the tolerance the
//! verdicts show.
//!
//! An operator takes a suggestion as is when it lies within their tolerance of the waypoint they
//! mean, and otherwise fine-tunes it (`adjusted`, with the waypoint finally taught) or teaches
//! the waypoint by hand (`rejected`). A verdict is about the one suggestion offered before a
//! taught waypoint, so the teacher keeps it with that waypoint ([`crate::engine::Teacher::feedback`]):
//! an undo takes it back with the waypoint, and a rebuild that replays the verdicts with their
//! waypoints gives the same cell.
//!
//! **Calibration.** A suggestion the operator rejected was not worth taking, whatever its
//! distance to what was then taught: its outcome (and that of every candidate at the same pose)
//! counts as wrong, so the cell's `p_useful` learns the operator's own judgement where it
//! differs from the tolerance's. An adjusted one was taken as a head start: its outcome stays
//! what its distance says. (Counted as wrong too, adjusted suggestions cut the simulated
//! joystick operator's savings on the shared corpus from 7.2 % to 5.6 %: near misses are worth
//! offering to them; docs/engine.md.)
//!
//! **Tolerance.** An adjusted suggestion's distance to the waypoint finally taught is a distance
//! the operator did not accept (measured against a taught, noisy waypoint, as the cell judges its
//! outcomes: [`Noise::judging`]). An accepted one says only that the suggestion was close
//! enough, not how close: the verdicts bound the tolerance from above, never from below. So
//! they can only tighten it: once [`MIN_ADJUSTMENTS`] adjustments are known, the tolerance is
//! the smaller of the one the noise implies and the one whose judging radius
//! ([`Noise::judging`]) is the [`ADJUSTED_QUANTILE`] of the adjusted distances, and never below
//! the operator's own per-axis error (a tolerance below it is not told apart).
//! An operator more lenient than the noise implies is not found out this way (their accepted
//! suggestions do not say how far off they were); the cost is offers withheld, not offers wrong.

use serde::{Deserialize, Serialize};

use super::frames::Tolerance;
use super::noise::Noise;

/// What the operator did with a suggestion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Taken as is.
    Accepted,
    /// Taken, then fine-tuned to the waypoint finally taught.
    Adjusted,
    /// Not taken: the waypoint was taught by hand.
    Rejected,
}

impl Verdict {
    pub const ALL: [Verdict; 3] = [Verdict::Accepted, Verdict::Adjusted, Verdict::Rejected];

    /// Its name on the wire and in the database.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Accepted => "accepted",
            Verdict::Adjusted => "adjusted",
            Verdict::Rejected => "rejected",
        }
    }

    /// The verdict of that name.
    pub fn named(name: &str) -> Option<Verdict> {
        Verdict::ALL.into_iter().find(|v| v.as_str() == name)
    }

    /// Whether the operator found the suggestion right as it was.
    pub fn right(self) -> bool {
        self == Verdict::Accepted
    }
}

/// Adjustments known before the verdicts tighten the tolerance.
pub const MIN_ADJUSTMENTS: usize = 3;

/// The share of adjusted distances allowed below the tolerance's judging radius: adjusted
/// distances are measured against noisy waypoints, so a few fall below what the operator really
/// accepts; a low quantile, not the least, marks it (chosen on the stream of the tests below;
/// 0.1 judged 15–20 % tight at the tolerance the noise implies, 0.2 as loose when half of it).
pub const ADJUSTED_QUANTILE: f64 = 0.15;

/// The adjusted distances of the finished routines' suggestions (mm, ascending).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Acceptance {
    adjusted_mm: Vec<f64>,
}

impl Acceptance {
    /// Adds an adjusted suggestion's distance (mm) to the waypoint finally taught.
    pub fn add(&mut self, mm: f64) {
        if !mm.is_finite() {
            return;
        }
        let at = self.adjusted_mm.partition_point(|d| *d <= mm);
        self.adjusted_mm.insert(at, mm);
    }

    /// How many adjustments are known.
    pub fn adjustments(&self) -> usize {
        self.adjusted_mm.len()
    }

    /// The tolerance of an operator with `noise` whose tolerance before any verdict is `prior`
    /// (see the module doc): `prior`, or tighter in position when the adjustments show it.
    pub fn tolerance(&self, prior: Tolerance, noise: &Noise) -> Tolerance {
        let Some(q) = self.quantile(ADJUSTED_QUANTILE) else {
            return prior;
        };
        // The judging radius is hypot(tolerance, √3 σ): the tolerance whose radius is q.
        let own_error = 3.0 * noise.mm * noise.mm;
        // Below the operator's own per-axis error a tolerance is not told apart (adjusted
        // distances are then mostly the taught waypoint's error): that is the floor.
        let mm = (q * q - own_error)
            .max(0.0)
            .sqrt()
            .max(noise.mm)
            .max(Tolerance::USEFUL.mm);
        Tolerance {
            mm: prior.mm.min(mm),
            rad: prior.rad,
        }
    }

    /// The `q` quantile of the adjusted distances (linear between order statistics); None with
    /// fewer than [`MIN_ADJUSTMENTS`].
    fn quantile(&self, q: f64) -> Option<f64> {
        let d = &self.adjusted_mm;
        if d.len() < MIN_ADJUSTMENTS {
            return None;
        }
        let at = q * (d.len() - 1) as f64;
        let (lo, frac) = (at.floor() as usize, at.fract());
        let hi = (lo + 1).min(d.len() - 1);
        Some(d[lo] + frac * (d[hi] - d[lo]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::experts::noise::tests::gauss;
    use nalgebra::Vector3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A stream of suggestions as a noisy cell makes them: most about the meant waypoint with an
    /// error of `spread` σ per axis (a repeat read from noisy waypoints), a third far off. The
    /// operator accepts those within `tolerance` of what they mean and adjusts the rest, teaching
    /// the meant waypoint with their own noise. Returns the adjusted distances and how many
    /// were accepted.
    fn verdicts(
        n: usize,
        sigma: f64,
        spread: f64,
        tolerance: f64,
        rng: &mut ChaCha8Rng,
    ) -> (Acceptance, usize) {
        let mut a = Acceptance::default();
        let mut accepted = 0;
        let v = |rng: &mut ChaCha8Rng, s: f64| Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * s;
        for _ in 0..n {
            let off = if rng.random_bool(1.0 / 3.0) {
                v(rng, 1.0).normalize() * rng.random_range(60.0..300.0)
            } else {
                v(rng, spread * sigma)
            };
            if off.norm() <= tolerance {
                accepted += 1;
            } else {
                a.add((off - v(rng, sigma)).norm());
            }
        }
        (a, accepted)
    }

    /// An operator pickier than their noise implies (half, two thirds and four fifths of the
    /// 2.07 σ the simulated operator accepts within), at the noise of a joystick operator: the
    /// radius the cell then judges its outcomes within ([`Noise::judging`]) is within 20 % of the
    /// one their true tolerance gives, for suggestions off by 1 and 1.4 σ per axis (one and two
    /// waypoints' errors). (The tolerance itself is not identifiable this finely when it is below the
    /// taught waypoints' own error, √3 σ: what decides an outcome is the radius.)
    #[test]
    fn a_picky_operators_tolerance_is_learned_from_their_adjustments() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let noise = Noise { mm: 10.0, rad: 0.0 };
        let prior = noise.tolerance();
        for spread in [1.0, 1.4] {
            for share in [0.5, 0.67, 0.8] {
                let truth = Tolerance {
                    mm: share * prior.mm,
                    rad: prior.rad,
                };
                let (a, accepted) = verdicts(150, noise.mm, spread, truth.mm, &mut rng);
                let learned = a.tolerance(prior, &noise);
                let (got, want) = (noise.judging(&learned).mm, noise.judging(&truth).mm);
                assert!(
                    (got - want).abs() <= 0.2 * want,
                    "spread {spread}, tolerance {:.1} mm: judging radius {got:.1} mm, not {want:.1}, from {} adjustments and {accepted} accepted",
                    truth.mm,
                    a.adjustments()
                );
                assert!(learned.mm < prior.mm);
                assert_eq!(learned.rad, prior.rad);
            }
        }
    }

    /// An operator who accepts what the noise implies: the adjustments leave the tolerance
    /// within 20 % of it (never above it); a lenient one keeps the prior; too few adjustments
    /// change nothing.
    #[test]
    fn adjustments_never_widen_the_tolerance_and_a_few_change_nothing() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let noise = Noise {
            mm: 10.0,
            rad: 0.02,
        };
        let prior = noise.tolerance();
        let (a, _) = verdicts(150, noise.mm, 1.4, prior.mm, &mut rng);
        let learned = a.tolerance(prior, &noise);
        assert!(
            learned.mm <= prior.mm && learned.mm >= 0.8 * prior.mm,
            "{learned:?}"
        );
        let (lenient, _) = verdicts(150, noise.mm, 1.4, 2.0 * prior.mm, &mut rng);
        assert_eq!(lenient.tolerance(prior, &noise), prior);
        let mut few = Acceptance::default();
        few.add(3.0);
        few.add(4.0);
        assert_eq!(few.tolerance(prior, &noise), prior);
        few.add(f64::NAN);
        assert_eq!(few.adjustments(), 2);
        few.add(5.0);
        assert!(few.tolerance(prior, &noise).mm < prior.mm);
    }
}
