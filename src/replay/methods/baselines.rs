//! The baselines the engine must beat (ALGORITHM §5), measured by the same harness.
//!
//! A learned model is only worth its complexity if it does better than the obvious tricks an
//! operator (or a cheap feature) would use:
//!
//! - [`RepeatLast`] — "do the same move again": `Ŵ_n = W_{n-1} · T_{n-1}`. Strong on grids,
//!   palletising rows and evenly spaced weld points.
//! - [`NearestSeq`] — "this looks like something taught before; do what followed it": find the
//!   place in the history whose preceding elements are closest to the last `h` taught, and
//!   repeat the element that followed there. It is the engine without the generalisation of a
//!   state model: a memory of every sequence.
//!
//! `NearestSeq` works in one of three [`Frame`]s (see [`crate::replay::frames`]): SRHCT tool-frame moves
//! (the engine's reading), work-frame moves, or absolute poses (issue 13). Report names:
//!
//! | frame | ungated | gated |
//! |---|---|---|
//! | tool | `nearest_seq`, `nearest_seq_within` | `nearest_seq_gated`, `nearest_seq_within_gated` (misfit gate) |
//! | absolute | `abs_seq`, `abs_seq_within` | `abs_seq_gated`, `abs_seq_within_gated` (agreement gate) |
//! | work | `work_seq`, `work_seq_within` | `work_seq_gated`, `work_seq_within_gated` (agreement gate) |
//!
//! `_within` also searches the current routine's earlier elements (the engine's
//! `learn_within_routine` counterpart). `_gated` withholds doubtful guesses:
//!
//! - [`Gate::Misfit`] (the original tool-frame variants): withhold when the nearest window's mean
//!   squared Mahalanobis distance per move exceeds the gate (the counterpart of the engine's
//!   misfit gate).
//! - [`Gate::Agreement`] (the absolute and work-frame variants): every place in the history whose
//!   window matches the taught one element by element within the useful tolerance (1 mm,
//!   0.1 rad) is a match; withhold when there is none, or when what followed them does not agree
//!   (each within the tolerance of what followed the most recent match). The confidence is the
//!   number of agreeing matches. `abs_seq_within_gated` is the "30-line predictor" of issue 13:
//!   context the last two taught poses, offer what followed when every such place agrees.
//!
//! Ungated variants rank by Mahalanobis distance with the engine's precision in every frame.

use crate::engine::{EngineConfig, Move, Observation, Pose};

use crate::replay::frames::{Frame, close};
use crate::replay::method::{Guess, Method};

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

/// Context length of the absolute-pose variants, in poses: the last two taught poses (issue 13's
/// predictor). Two poses span one move; the move frames use the engine's horizon (3 moves).
pub const ABS_SEQ_HORIZON: usize = 2;

/// How a gated [`NearestSeq`] decides to withhold (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Gate {
    /// Withhold when the nearest window's mean squared Mahalanobis distance per element exceeds
    /// this.
    Misfit(f64),
    /// Withhold unless some place matches element by element within the useful tolerance and
    /// every such place's follower agrees with the most recent one's.
    Agreement,
}

/// Nearest-sequence baseline: memory of all element sequences in one [`Frame`], 1-nearest-
/// neighbour on the last `h` elements (or, with [`Gate::Agreement`], every close neighbour).
///
/// Distance between two elements is Mahalanobis with the engine's diagonal precision
/// (translation `1/σ_t²`, quaternion components `1/σ_q²`, σ's from the [`EngineConfig`]), so a
/// distance of 1 means the same thing here as in the engine's merge test; the quaternion part is
/// sign-blind (`q` and `−q` are one rotation, which matters for absolute tool orientations near
/// `q_w = 0`). A window of `w` elements is compared with every run of `w` consecutive elements in
/// the history that is followed by one more, aligned at the end; the sum of squared distances
/// ranks the candidates, ties go to the most recent. Cost per prediction: O(history × h), fine
/// for programs of a few thousand waypoints (the whole corpus replays in well under a second).
#[derive(Debug, Clone)]
pub struct NearestSeq {
    name: String,
    frame: Frame,
    /// Diagonal of the precision matrix, in element order `[x y z qw qx qy qz]`.
    weights: [f64; 7],
    horizon: usize,
    /// Search the current routine's earlier elements too.
    within: bool,
    gate: Option<Gate>,
    /// Element sequences of the finished routines of this program, oldest first.
    history: Vec<Vec<Observation>>,
}

impl NearestSeq {
    /// A tool-frame nearest-sequence baseline with the precision and horizon of `config`.
    ///
    /// `within`: also match against the current routine's earlier moves. `gate`: withhold
    /// guesses whose mean squared distance per window move exceeds it (`None`: ungated). The
    /// report name (`nearest_seq…`) follows from the two choices.
    pub fn new(config: &EngineConfig, within: bool, gate: Option<f64>) -> NearestSeq {
        NearestSeq::build(config, Frame::Tool, within, gate.map(Gate::Misfit))
    }

    /// A nearest-sequence baseline in `frame`; `gated` uses [`Gate::Agreement`]. Names:
    /// `abs_seq…` (absolute, horizon [`ABS_SEQ_HORIZON`] poses), `work_seq…` (work frame,
    /// the engine's horizon in moves), `tool_seq…` (tool frame with the agreement gate; ungated,
    /// it is `nearest_seq` under another name).
    pub fn in_frame(config: &EngineConfig, frame: Frame, within: bool, gated: bool) -> NearestSeq {
        let mut m = NearestSeq::build(config, frame, within, gated.then_some(Gate::Agreement));
        if frame == Frame::Absolute {
            m.horizon = ABS_SEQ_HORIZON;
        }
        m
    }

    /// The same baseline with another context length (elements; at least 1).
    pub fn with_horizon(mut self, horizon: usize) -> NearestSeq {
        self.horizon = horizon.max(1);
        self
    }

    fn build(config: &EngineConfig, frame: Frame, within: bool, gate: Option<Gate>) -> NearestSeq {
        let wt = 1.0 / (config.sigma_t * config.sigma_t);
        let wq = 1.0 / (config.sigma_q * config.sigma_q);
        let prefix = match (frame, gate) {
            (Frame::Tool, None | Some(Gate::Misfit(_))) => "nearest_seq",
            (Frame::Tool, Some(Gate::Agreement)) => "tool_seq",
            (Frame::Absolute, _) => "abs_seq",
            (Frame::Work, _) => "work_seq",
        };
        let suffix = match (within, gate.is_some()) {
            (false, false) => "",
            (false, true) => "_gated",
            (true, false) => "_within",
            (true, true) => "_within_gated",
        };
        NearestSeq {
            name: format!("{prefix}{suffix}"),
            frame,
            weights: [wt, wt, wt, wq, wq, wq, wq],
            horizon: config.predict.horizon.max(1),
            within,
            gate,
            history: Vec::new(),
        }
    }

    pub fn frame(&self) -> Frame {
        self.frame
    }

    pub fn horizon(&self) -> usize {
        self.horizon
    }

    /// Squared Mahalanobis distance with the diagonal precision, sign-blind in the quaternion.
    fn distance2(&self, a: &Observation, b: &Observation) -> f64 {
        let part = |range: std::ops::Range<usize>, sign: f64| -> f64 {
            range
                .map(|i| {
                    let d = a[i] - sign * b[i];
                    self.weights[i] * d * d
                })
                .sum()
        };
        part(0..3, 1.0) + part(3..7, 1.0).min(part(3..7, -1.0))
    }

    /// Sum of squared distances between `window` and the `window.len()` elements of `seq` that
    /// precede index `next` (so `seq[next]` is the element that would be predicted).
    fn window_cost(&self, window: &[Observation], seq: &[Observation], next: usize) -> f64 {
        let start = next - window.len();
        window
            .iter()
            .zip(&seq[start..next])
            .map(|(a, b)| self.distance2(a, b))
            .sum()
    }

    /// The sequences to search, oldest first: the finished routines, then (`within`) the
    /// current one. A candidate's follower must exist, which `next < seq.len()` guarantees.
    fn searched<'a>(
        &'a self,
        current: &'a [Observation],
    ) -> impl Iterator<Item = &'a [Observation]> {
        self.history
            .iter()
            .map(Vec::as_slice)
            .chain(self.within.then_some(current))
    }

    /// The best match for `window`: (cost, the element that followed). Candidates are visited
    /// oldest first and replace the best on `≤`, so ties go to the most recent.
    fn best_match(
        &self,
        window: &[Observation],
        current: &[Observation],
    ) -> Option<(f64, Observation)> {
        let w = window.len();
        let mut best: Option<(f64, Observation)> = None;
        for seq in self.searched(current) {
            for next in w..seq.len() {
                let cost = self.window_cost(window, seq, next);
                if best.as_ref().is_none_or(|(b, _)| cost <= *b) {
                    best = Some((cost, seq[next]));
                }
            }
        }
        best
    }

    /// [`Gate::Agreement`]: (number of matching places, the most recent one's follower) when
    /// some place matches `window` element by element within the useful tolerance and every
    /// matching place's follower is within the tolerance of the most recent one's.
    fn agreeing_match(
        &self,
        window: &[Observation],
        current: &[Observation],
    ) -> Option<(usize, Observation)> {
        let w = window.len();
        let mut followers = Vec::new();
        for seq in self.searched(current) {
            for next in w..seq.len() {
                if window
                    .iter()
                    .zip(&seq[next - w..next])
                    .all(|(a, b)| close(a, b))
                {
                    followers.push(seq[next]);
                }
            }
        }
        let latest = *followers.last()?;
        followers
            .iter()
            .all(|f| close(f, &latest))
            .then_some((followers.len(), latest))
    }
}

impl Method for NearestSeq {
    fn name(&self) -> &str {
        &self.name
    }

    fn reset(&mut self) {
        self.history.clear();
    }

    /// With one waypoint taught a move frame has no move yet: the ungated variants guess the
    /// first move of the most recent earlier routine, with no confidence (there is no window to
    /// match); the gated ones have nothing to judge a match by and stay silent. (The absolute
    /// frame always has a window: the taught poses.)
    fn predict(&mut self, taught: &[Pose]) -> Option<Guess> {
        let last = taught.last()?;
        let current = self.frame.elements(taught);
        let (next, confidence) = if current.is_empty() {
            if self.gate.is_some() {
                return None;
            }
            let first = self.history.iter().rev().find_map(|seq| seq.first())?;
            (*first, None)
        } else {
            let w = self.horizon.min(current.len());
            let window = &current[current.len() - w..];
            match self.gate {
                Some(Gate::Agreement) => {
                    let (support, next) = self.agreeing_match(window, &current)?;
                    (next, Some(support as f64))
                }
                gate => {
                    let (cost, next) = self.best_match(window, &current)?;
                    let mean = cost / w as f64;
                    if matches!(gate, Some(Gate::Misfit(g)) if mean > g) {
                        return None;
                    }
                    (next, Some(-mean))
                }
            }
        };
        // The element came from unit quaternions, so this only fails on corrupted history;
        // withholding is the safe answer then.
        Some(Guess {
            pose: self.frame.apply(last, &next)?,
            confidence,
            phi: None,
            psi: None,
        })
    }

    fn observe(&mut self, _taught: &[Pose]) {}

    fn finish_routine(&mut self, routine: &[Pose]) {
        self.history.push(self.frame.elements(routine));
    }
}

/// The five baselines of the original scoreboard in report order, built from the engine's
/// configuration (for σ's and h) and the nearest-sequence gate. The service's replay
/// (`POST /v1/replays`, gRPC `Replay`) reports these.
pub fn all(config: &EngineConfig, gate: f64) -> Vec<Box<dyn Method>> {
    vec![
        Box::new(RepeatLast::new()),
        Box::new(NearestSeq::new(config, false, None)),
        Box::new(NearestSeq::new(config, false, Some(gate))),
        Box::new(NearestSeq::new(config, true, None)),
        Box::new(NearestSeq::new(config, true, Some(gate))),
    ]
}

/// The absolute-pose and work-frame nearest-sequence baselines (issue 13), in report order:
/// `abs_seq`, `abs_seq_gated`, `abs_seq_within`, `abs_seq_within_gated`, then the same four
/// `work_seq…`.
pub fn frames(config: &EngineConfig) -> Vec<Box<dyn Method>> {
    [Frame::Absolute, Frame::Work]
        .into_iter()
        .flat_map(|frame| {
            [(false, false), (false, true), (true, false), (true, true)]
                .map(|(within, gated)| NearestSeq::in_frame(config, frame, within, gated))
        })
        .map(|m| Box::new(m) as Box<dyn Method>)
        .collect()
}

/// Every baseline of `nextpose replay`'s scoreboard: [`all`], then [`frames`].
pub fn scoreboard(config: &EngineConfig, gate: f64) -> Vec<Box<dyn Method>> {
    let mut methods = all(config, gate);
    methods.extend(frames(config));
    methods
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
    fn scoreboard_names_follow_frame_and_variant() {
        let c = EngineConfig::default();
        let names: Vec<String> = scoreboard(&c, 1.0)
            .iter()
            .map(|m| m.name().to_string())
            .collect();
        assert_eq!(names.len(), 13);
        assert_eq!(
            names[5..],
            [
                "abs_seq",
                "abs_seq_gated",
                "abs_seq_within",
                "abs_seq_within_gated",
                "work_seq",
                "work_seq_gated",
                "work_seq_within",
                "work_seq_within_gated"
            ]
        );
        assert_eq!(
            NearestSeq::in_frame(&c, Frame::Tool, true, true).name(),
            "tool_seq_within_gated"
        );
        assert_eq!(
            NearestSeq::in_frame(&c, Frame::Absolute, false, false).horizon(),
            2
        );
        assert_eq!(
            NearestSeq::in_frame(&c, Frame::Work, false, false).horizon(),
            c.predict.horizon
        );
    }

    /// The agreement gate: offers what every matching place agrees on, with their number as
    /// confidence; withholds when they disagree or when nothing matches within tolerance.
    #[test]
    fn agreement_gate_counts_matches_and_withholds_on_disagreement() {
        let c = EngineConfig::default();
        let mut m = NearestSeq::in_frame(&c, Frame::Absolute, false, true);
        m.finish_routine(&[p(0.0, 0.0), p(10.0, 0.0), p(10.0, 10.0)]);
        m.finish_routine(&[p(0.0, 0.0), p(10.0, 0.0), p(10.3, 10.0)]);
        // Context (0,0), (10,0) seen twice, followers 0.3 mm apart: offered, the latest.
        let g = m.predict(&[p(0.0, 0.0), p(10.0, 0.0)]).unwrap();
        assert!(g.pose.distance_to(&p(10.3, 10.0)) < 1e-12);
        assert_eq!(g.confidence, Some(2.0));
        // A context 0.9 mm off still matches; 1.5 mm off does not.
        assert!(m.predict(&[p(0.0, 0.9), p(10.0, 0.0)]).is_some());
        assert!(m.predict(&[p(0.0, 1.5), p(10.0, 0.0)]).is_none());
        // A third place that went elsewhere: the places disagree.
        m.finish_routine(&[p(0.0, 0.0), p(10.0, 0.0), p(50.0, 0.0)]);
        assert!(m.predict(&[p(0.0, 0.0), p(10.0, 0.0)]).is_none());
        // Ungated, the nearest window (the most recent of the tied ones) is offered anyway.
        let mut u = NearestSeq::in_frame(&c, Frame::Absolute, false, false);
        u.finish_routine(&[p(0.0, 0.0), p(10.0, 0.0), p(10.0, 10.0)]);
        u.finish_routine(&[p(0.0, 0.0), p(10.0, 0.0), p(50.0, 0.0)]);
        let g = u.predict(&[p(0.0, 0.0), p(10.0, 0.0)]).unwrap();
        assert!(g.pose.distance_to(&p(50.0, 0.0)) < 1e-12);
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
