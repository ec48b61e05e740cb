//! What the CDHMM answers: a [`Prediction`] of the next move, offered or not, with every figure
//! that decided it, and, when it is not offered, the reason ([`Withheld`]). A leaf: the gates
//! name their verdicts with it and the orchestrator ([`super`]) fills it in.

use serde::Serialize;

use crate::engine::experts::Proposer;
use crate::engine::pose::{Move, Observation, Pose};

/// Why a prediction was not offered.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum Withheld {
    /// The routine has no waypoint yet: there is no pose to predict from.
    NothingTaught,
    /// Nothing has been learned in this cell yet.
    EmptyModel,
    /// φ is undefined with fewer than two states.
    TooFewStates { states: usize },
    /// No learned sequence of states can produce the window (or, with a match radius, no state
    /// is near one of its moves).
    NoMatch,
    /// The matched states usually end the routine.
    LikelyEnd { end_probability: f64 },
    /// The window does not look like anything learned.
    PoorMatch { misfit: f64 },
    /// The next state is ambiguous.
    LowConfidence { phi: f64 },
    /// The moves that followed the matched states disagree with each other.
    WideSpread { spread: f64 },
    /// A shortened (backed-off) window was followed by the proposed move too few times.
    LittleEvidence { support: f64 },
    /// The best candidate of the experts is not likely enough to be right (`p_useful` below the
    /// cell's threshold).
    Unlikely { p_useful: f64 },
}

impl Withheld {
    /// A short stable code for APIs and metrics.
    pub fn code(&self) -> &'static str {
        match self {
            Withheld::NothingTaught => "nothing_taught",
            Withheld::EmptyModel => "empty_model",
            Withheld::TooFewStates { .. } => "too_few_states",
            Withheld::NoMatch => "no_match",
            Withheld::LikelyEnd { .. } => "likely_end",
            Withheld::PoorMatch { .. } => "poor_match",
            Withheld::LowConfidence { .. } => "low_confidence",
            Withheld::WideSpread { .. } => "wide_spread",
            Withheld::LittleEvidence { .. } => "little_evidence",
            Withheld::Unlikely { .. } => "unlikely",
        }
    }
}

/// A prediction of the next waypoint, offered or not, with every figure that decided it.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// The proposed next pose (None when nothing could be proposed at all).
    pub pose: Option<Pose>,
    /// The proposed move from the last waypoint (SRHCT 7-vector, canonical sign).
    pub relative: Option<Observation>,
    /// The dissertation's confidence φ ∈ [0, 1].
    pub phi: f64,
    /// ψ: maps the taught window onto the model (a 2× copy of a pattern gives 0.5).
    pub psi: f64,
    /// Probability that the routine ends here (or that nothing is known about what follows).
    pub end_probability: f64,
    /// Match quality: mean squared Mahalanobis misfit of the window (None without a window).
    pub misfit: Option<f64>,
    /// Expected squared Mahalanobis distance of the next move from the proposal.
    pub spread: Option<f64>,
    /// Evidence: the expected number of earlier continuations of the matched states that agree
    /// with the proposal (within one σ).
    pub support: f64,
    /// When the proposal was recalled from the most recent occurrence of the window's context
    /// (see `EngineConfig::recall`): that context's mean squared distance to the window.
    pub recalled: Option<f64>,
    /// Number of states of the model asked.
    pub states: usize,
    /// Number of most recent moves the prediction conditioned on (less than the horizon when
    /// the routine is shorter, or after backing off).
    pub window: usize,
    /// Why the prediction is not offered; None when it is.
    pub withheld: Option<Withheld>,
    /// With the experts' offer rule (`EngineConfig::offer`): the estimated probability that the
    /// proposal is within the cell's tolerance of the next waypoint ([`crate::engine::experts::calibration`]).
    pub p_useful: Option<f64>,
    /// With the experts' offer rule: who proposed it.
    pub expert: Option<Proposer>,
}

impl Prediction {
    pub fn offered(&self) -> bool {
        self.withheld.is_none()
    }

    /// Size of the taught routine relative to the learned pattern: `1/ψ`.
    pub fn routine_scale(&self) -> f64 {
        1.0 / self.psi
    }

    pub(crate) fn withheld(reason: Withheld, states: usize) -> Prediction {
        Prediction {
            pose: None,
            relative: None,
            phi: 0.0,
            psi: 1.0,
            end_probability: 0.0,
            misfit: None,
            spread: None,
            support: 0.0,
            recalled: None,
            states,
            window: 0,
            withheld: Some(reason),
            p_useful: None,
            expert: None,
        }
    }

    /// Composes the proposed move onto the last taught pose.
    pub(crate) fn placed_after(mut self, last: &Pose) -> Prediction {
        if let Some(x) = &self.relative {
            match Move::from_observation(x) {
                Ok(m) => self.pose = Some(last.then(&m)),
                Err(_) => {
                    self.relative = None;
                    self.withheld = Some(Withheld::NoMatch);
                }
            }
        }
        self
    }
}
