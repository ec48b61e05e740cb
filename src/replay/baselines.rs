//! The baselines the engine must beat (ALGORITHM §5), measured by the same harness.
//!
//! A learned model is only worth its complexity if it does better than the obvious tricks an
//! operator (or a cheap feature) would use:
//!
//! - [`RepeatLast`] — "do the same move again": `Ŵ_n = W_{n-1} · T_{n-1}`. Strong on grids,
//!   palletising rows and evenly spaced weld points.
//! - [`NearestSeq`] — "this looks like something taught before; do what followed it": find the
//!   place in the history whose preceding moves are closest (Mahalanobis, the engine's own
//!   precision) to the last `h` moves taught, and repeat the move that followed there. It is the
//!   engine without the generalisation of a state model: a memory of every sequence.
//!
//! `NearestSeq` comes in four variants, named in reports as `nearest_seq`, `nearest_seq_gated`,
//! `nearest_seq_within`, `nearest_seq_within_gated`: `_within` also searches the current
//! routine's earlier moves (the engine's `learn_within_routine` counterpart), `_gated` withholds
//! guesses whose window matched poorly (the counterpart of the engine's misfit gate).

use crate::engine::pose::observations;
use crate::engine::{EngineConfig, Move, Observation, Pose};

use super::method::{Guess, Method};

/// Repeats the last relative move: `Ŵ_n = W_{n-1} · (W_{n-2}⁻¹ · W_{n-1})`.
#[derive(Debug, Clone, Default)]
pub struct RepeatLast;

impl RepeatLast {
    pub fn new() -> RepeatLast {
        RepeatLast
    }
}

impl Method for RepeatLast {
    fn name(&self) -> &str {
        "repeat_last"
    }

    fn reset(&mut self) {}

    /// Needs two taught waypoints (one move to repeat); has no confidence figure.
    fn predict(&mut self, taught: &[Pose]) -> Option<Guess> {
        let [.., before, last] = taught else {
            return None;
        };
        Some(Guess {
            pose: last.then(&Move::between(before, last)),
            confidence: None,
            phi: None,
            psi: None,
        })
    }

    fn observe(&mut self, _taught: &[Pose]) {}

    fn finish_routine(&mut self, _routine: &[Pose]) {}
}

/// Default gate of the gated nearest-sequence variants: mean squared Mahalanobis distance per
/// window move. 1.0 means "on average within one σ in one component", i.e. the window is a
/// re-teach of the matched one within repeatability.
pub const DEFAULT_NEAREST_SEQ_GATE: f64 = 1.0;

/// Nearest-sequence baseline: memory of all observation sequences, 1-nearest-neighbour on the
/// last `h` moves.
///
/// Distance between two observations is Mahalanobis with the engine's diagonal precision
/// (translation `1/σ_t²`, quaternion components `1/σ_q²`, σ's from the [`EngineConfig`]), so a
/// distance of 1 means the same thing here as in the engine's merge test. A window of `w` moves
/// is compared with every run of `w` consecutive moves in the history that is followed by one
/// more move, aligned at the end; the sum of squared distances ranks the candidates, ties go to
/// the most recent. Cost per prediction: O(history × h), fine for programs of a few thousand
/// moves.
#[derive(Debug, Clone)]
pub struct NearestSeq {
    name: &'static str,
    /// Diagonal of the precision matrix, in observation order `[tx ty tz qw qx qy qz]`.
    weights: [f64; 7],
    horizon: usize,
    /// Search the current routine's earlier moves too.
    within: bool,
    /// Offer only when the mean squared distance per window move is at most this.
    gate: Option<f64>,
    /// Observation sequences of the finished routines of this program, oldest first.
    history: Vec<Vec<Observation>>,
}

impl NearestSeq {
    /// A nearest-sequence baseline with the precision and horizon of `config`.
    ///
    /// `within`: also match against the current routine's earlier moves. `gate`: withhold
    /// guesses whose mean squared distance per window move exceeds it (`None`: ungated). The
    /// report name follows from the two choices.
    pub fn new(config: &EngineConfig, within: bool, gate: Option<f64>) -> NearestSeq {
        let wt = 1.0 / (config.sigma_t * config.sigma_t);
        let wq = 1.0 / (config.sigma_q * config.sigma_q);
        let name = match (within, gate.is_some()) {
            (false, false) => "nearest_seq",
            (false, true) => "nearest_seq_gated",
            (true, false) => "nearest_seq_within",
            (true, true) => "nearest_seq_within_gated",
        };
        NearestSeq {
            name,
            weights: [wt, wt, wt, wq, wq, wq, wq],
            horizon: config.horizon.max(1),
            within,
            gate,
            history: Vec::new(),
        }
    }

    /// Squared Mahalanobis distance with the diagonal precision.
    fn distance2(&self, a: &Observation, b: &Observation) -> f64 {
        (0..7)
            .map(|i| {
                let d = a[i] - b[i];
                self.weights[i] * d * d
            })
            .sum()
    }

    /// Sum of squared distances between `window` and the `window.len()` moves of `seq` that
    /// precede index `next` (so `seq[next]` is the move that would be predicted).
    fn window_cost(&self, window: &[Observation], seq: &[Observation], next: usize) -> f64 {
        let start = next - window.len();
        window
            .iter()
            .zip(&seq[start..next])
            .map(|(a, b)| self.distance2(a, b))
            .sum()
    }

    /// The best match for `window`: (cost, the move that followed). Candidates are visited
    /// oldest first and replace the best on `≤`, so ties go to the most recent.
    fn best_match(
        &self,
        window: &[Observation],
        current: &[Observation],
    ) -> Option<(f64, Observation)> {
        let w = window.len();
        let mut best: Option<(f64, Observation)> = None;
        let mut consider = |seq: &[Observation]| {
            for next in w..seq.len() {
                let cost = self.window_cost(window, seq, next);
                if best.as_ref().is_none_or(|(b, _)| cost <= *b) {
                    best = Some((cost, seq[next]));
                }
            }
        };
        for seq in &self.history {
            consider(seq);
        }
        if self.within {
            // `current` holds the moves taught so far; a candidate's following move must exist,
            // which `next < current.len()` guarantees.
            consider(current);
        }
        best
    }
}

impl Method for NearestSeq {
    fn name(&self) -> &str {
        self.name
    }

    fn reset(&mut self) {
        self.history.clear();
    }

    /// With one waypoint taught (no move yet) the ungated variants guess the first move of the
    /// most recent earlier routine, with no confidence (there is no window to match); the gated
    /// ones have nothing to judge a match by and stay silent.
    fn predict(&mut self, taught: &[Pose]) -> Option<Guess> {
        let last = taught.last()?;
        let current = observations(taught);
        let (next_move, confidence) = if current.is_empty() {
            if self.gate.is_some() {
                return None;
            }
            let first = self.history.iter().rev().find_map(|seq| seq.first())?;
            (*first, None)
        } else {
            let w = self.horizon.min(current.len());
            let window = &current[current.len() - w..];
            let (cost, next_move) = self.best_match(window, &current)?;
            let mean = cost / w as f64;
            if self.gate.is_some_and(|g| mean > g) {
                return None;
            }
            (next_move, Some(-mean))
        };
        // The move came from unit quaternions, so this only fails on corrupted history;
        // withholding is the safe answer then.
        let step = Move::from_observation(&next_move).ok()?;
        Some(Guess {
            pose: last.then(&step),
            confidence,
            phi: None,
            psi: None,
        })
    }

    fn observe(&mut self, _taught: &[Pose]) {}

    fn finish_routine(&mut self, routine: &[Pose]) {
        self.history.push(observations(routine));
    }
}

/// The five baselines in report order, built from the engine's configuration (for σ's and h)
/// and the nearest-sequence gate.
pub fn all(config: &EngineConfig, gate: f64) -> Vec<Box<dyn Method>> {
    vec![
        Box::new(RepeatLast::new()),
        Box::new(NearestSeq::new(config, false, None)),
        Box::new(NearestSeq::new(config, false, Some(gate))),
        Box::new(NearestSeq::new(config, true, None)),
        Box::new(NearestSeq::new(config, true, Some(gate))),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Pose {
        Pose::new([x, y, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap()
    }

    #[test]
    fn repeat_last_needs_two_waypoints() {
        let mut m = RepeatLast::new();
        assert!(m.predict(&[p(0.0, 0.0)]).is_none());
        let g = m.predict(&[p(0.0, 0.0), p(3.0, 4.0)]).unwrap();
        assert!(g.pose.distance_to(&p(6.0, 8.0)) < 1e-12);
    }

    #[test]
    fn names_follow_the_variant() {
        let c = EngineConfig::default();
        let names: Vec<String> = all(&c, 1.0).iter().map(|m| m.name().to_string()).collect();
        assert_eq!(
            names,
            [
                "repeat_last",
                "nearest_seq",
                "nearest_seq_gated",
                "nearest_seq_within",
                "nearest_seq_within_gated"
            ]
        );
    }

    #[test]
    fn empty_window_uses_first_move_of_latest_routine_ungated_only() {
        let c = EngineConfig::default();
        let mut ungated = NearestSeq::new(&c, false, None);
        let mut gated = NearestSeq::new(&c, false, Some(1.0));
        for m in [&mut ungated, &mut gated] {
            m.finish_routine(&[p(0.0, 0.0), p(1.0, 0.0)]);
            m.finish_routine(&[p(0.0, 0.0), p(0.0, 5.0), p(1.0, 1.0)]);
        }
        let g = ungated.predict(&[p(10.0, 10.0)]).unwrap();
        assert!(g.pose.distance_to(&p(10.0, 15.0)) < 1e-12);
        assert_eq!(g.confidence, None);
        assert!(gated.predict(&[p(10.0, 10.0)]).is_none());
    }

    #[test]
    fn ties_prefer_the_most_recent_and_gate_withholds_poor_matches() {
        let c = EngineConfig::default();
        let mut m = NearestSeq::new(&c, false, None);
        // Two routines with the same first move and different continuations.
        m.finish_routine(&[p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]);
        m.finish_routine(&[p(0.0, 0.0), p(1.0, 0.0), p(1.0, -1.0)]);
        let g = m.predict(&[p(0.0, 0.0), p(1.0, 0.0)]).unwrap();
        assert!(g.pose.distance_to(&p(1.0, -1.0)) < 1e-12);
        assert_eq!(g.confidence, Some(-0.0));

        let mut gated = NearestSeq::new(&c, false, Some(1.0));
        gated.finish_routine(&[p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]);
        // Window move of 3 mm against a learned 1 mm move: squared distance 4 > 1.
        assert!(gated.predict(&[p(0.0, 0.0), p(3.0, 0.0)]).is_none());
        // 1.5 mm: squared distance 0.25 ≤ 1.
        let g = gated.predict(&[p(0.0, 0.0), p(1.5, 0.0)]).unwrap();
        assert_eq!(g.confidence, Some(-0.25));
    }

    #[test]
    fn within_variant_matches_the_current_routine() {
        let c = EngineConfig::default();
        let mut plain = NearestSeq::new(&c, false, None);
        let mut within = NearestSeq::new(&c, true, None);
        // A zig-zag taught in the current routine, nothing learned before.
        let taught = [
            p(0.0, 0.0),
            p(10.0, 0.0),
            p(10.0, 10.0),
            p(20.0, 10.0),
            p(20.0, 20.0),
        ];
        assert!(plain.predict(&taught).is_none());
        let g = within.predict(&taught).unwrap();
        // Moves so far [+x, +y, +x, +y]; window (h = 3) = [+y, +x, +y]. The only candidate with
        // three predecessors and a known follower is the run [+x, +y, +x] followed by +y.
        assert!(g.pose.distance_to(&p(20.0, 30.0)) < 1e-9);
        assert!(g.confidence.unwrap() < 0.0);
    }
}
