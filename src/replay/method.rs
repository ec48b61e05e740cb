//! What the replay harness drives: anything that watches waypoints being taught and may guess
//! the next one. The engine and every baseline implement [`Method`], so they are measured by the
//! same code on the same waypoints.

use crate::engine::Pose;

/// A guess at the next waypoint.
#[derive(Debug, Clone, PartialEq)]
pub struct Guess {
    pub pose: Pose,
    /// The figure the method's own gate uses, higher = more sure (the engine's φ or match
    /// quality; a baseline's negated match distance). `None` when the method has none.
    pub confidence: Option<f64>,
    /// Engine only: the dissertation's confidence φ, reported beside `confidence`.
    pub phi: Option<f64>,
    /// Engine only: the estimated ψ (a 2× copy of a learned pattern gives ψ = 0.5).
    pub psi: Option<f64>,
}

/// A method's best candidate for the next waypoint, offered or not, with its calibrated
/// probability of being useful (the engine's `p_useful` under the experts' offer rule). What the
/// reliability table and the risk–coverage curve are computed from ([`super::score::reliability`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    pub pose: Pose,
    pub p_useful: f64,
}

/// What a method answers for the next waypoint: the guess it offers (if any) and, for methods
/// with a calibrated probability, its best candidate whether offered or not.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Proposal {
    pub guess: Option<Guess>,
    pub candidate: Option<Candidate>,
}

/// Size of a method's model after a program, for the report.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModelSummary {
    pub states: usize,
    pub edges: usize,
    /// Mean out-degree of states.
    pub perplexity: f64,
    /// Moves (waypoint to waypoint) assimilated into the model so far.
    pub observations: u64,
}

/// A predictor under replay.
///
/// Call order for one program: `reset`, then, for each routine `w` and each
/// waypoint index `n`: if `n ≥ 1`, `predict(&w[..n])` (guess `w[n]`), then
/// `observe(&w[..=n])`; after the routine's last waypoint, `finish_routine(&w)`.
pub trait Method {
    /// The method's name in reports (`"engine"`, `"repeat_last"`, ...).
    fn name(&self) -> &str;
    /// Forget everything: a new program starts from an empty model.
    fn reset(&mut self);
    /// Guess the waypoint after `taught` (the current routine's waypoints so far, at least one),
    /// or `None` when nothing is offered.
    fn predict(&mut self, taught: &[Pose]) -> Option<Guess>;
    /// [`Method::predict`] with the method's best candidate, offered or not (what replay calls).
    /// By default the guess alone: only a method with a calibrated probability has a candidate
    /// worth recording when it offers nothing.
    fn propose(&mut self, taught: &[Pose]) -> Proposal {
        Proposal {
            guess: self.predict(taught),
            candidate: None,
        }
    }
    /// `taught.last()` has just been taught.
    fn observe(&mut self, taught: &[Pose]);
    /// The routine is finished; `routine` holds all its waypoints.
    fn finish_routine(&mut self, routine: &[Pose]);
    /// Model size, for methods that have a model.
    fn summary(&self) -> Option<ModelSummary> {
        None
    }
}
