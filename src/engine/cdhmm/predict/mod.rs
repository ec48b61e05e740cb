//! Prediction and confidence (ALGORITHM §3, seed §3.10–3.11, §4.5.1): the orchestration that
//! turns the moves of the routine being taught into a [`Prediction`].
//!
//! The predictor conditions on the last `h` of them (the *window*), runs the HMM forward
//! recursion in log space (`forward`, over the `transitions` less the window's own edges, at the
//! ψ that `scale` finds), turns the posterior over the current state into a pmf ν over the next
//! state, and proposes the most likely next move: the mode of the mixture
//! `Σ_j ν_j N(mean_j, C⁻¹)` (`mixture`). Whether the proposal is *offered* is decided by the
//! `gates`, each reported with its figure; an ambiguous next state may be settled by `recall`.
//! A window that matches nothing is shortened (backoff).

pub(in crate::engine) mod forward;
mod gates;
mod mixture;
mod recall;
pub mod scale;
mod transitions;

use serde::Serialize;

use forward::{Prior, next_state};
use gates::Figures;
use mixture::mixture_mode;
use recall::recall;
use scale::forward_with_scale;
use transitions::Transitions;
use crate::engine::cdhmm::hmm::Hmm;
use crate::engine::cdhmm::learner::ObservationGraph;
use crate::engine::config::{EngineConfig, RecallGate, ScaleConfig, WindowPrior};
use crate::engine::experts::Expert;
use crate::engine::pose::{Move, Observation, Pose, scale_translation};

/// Per-prediction settings (a cell's configuration, possibly overridden per request).
#[derive(Debug, Clone, PartialEq)]
pub struct PredictOptions {
    pub horizon: usize,
    pub phi_min: f64,
    pub max_misfit: Option<f64>,
    pub max_spread: Option<f64>,
    pub max_end_prob: Option<f64>,
    pub match_radius: Option<f64>,
    pub backoff: bool,
    pub backoff_min_support: f64,
    pub recall: Option<RecallGate>,
    pub window_prior: WindowPrior,
    pub scale: ScaleConfig,
}

impl PredictOptions {
    pub fn from_config(c: &EngineConfig) -> PredictOptions {
        PredictOptions {
            horizon: c.horizon,
            phi_min: c.phi_min,
            max_misfit: c.max_misfit,
            max_spread: c.max_spread,
            max_end_prob: c.max_end_prob,
            match_radius: c.match_radius,
            backoff: c.backoff,
            backoff_min_support: c.backoff_min_support,
            recall: c.recall,
            window_prior: c.window_prior,
            scale: c.scale,
        }
    }
}

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
    /// The seed's confidence φ ∈ [0, 1].
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
    pub expert: Option<Expert>,
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
    pub(crate) fn place(mut self, last: &Pose) -> Prediction {
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

/// Predicts the next move of a routine whose moves so far are `moves` (possibly none).
///
/// With `backoff`, a window of `h` moves that matches nothing learned (no match, or a misfit
/// above the gate) is shortened to its last `h − 1` moves, and so on down to one move, like a
/// variable-order Markov model: a long context is preferred when it was seen, a shorter one is
/// used when it was not.
pub fn predict_move(
    graph: &ObservationGraph,
    moves: &[Observation],
    opts: &PredictOptions,
) -> Prediction {
    let hmm = Hmm::new(graph);
    let states = hmm.states();
    if states == 0 {
        return Prediction::withheld(Withheld::EmptyModel, 0);
    }
    if states < 2 {
        return Prediction::withheld(Withheld::TooFewStates { states }, states);
    }
    let longest = opts.horizon.min(moves.len()).max(1);
    let shortest = if opts.backoff { 1 } else { longest };
    let mut h = longest;
    // ψ is estimated on the longest window only: a shortened window carries too little
    // translation to fix a scale (a single move fits any state whose move points the same way),
    // and searching ψ again per backoff step tripled the cost of windows that fit nothing.
    let unscaled = PredictOptions {
        scale: ScaleConfig {
            enabled: false,
            ..opts.scale
        },
        ..opts.clone()
    };
    loop {
        let p = predict_window(&hmm, moves, h, if h == longest { opts } else { &unscaled });
        let unmatched = matches!(
            p.withheld,
            Some(Withheld::NoMatch | Withheld::PoorMatch { .. })
        );
        if !unmatched || h <= shortest {
            return p;
        }
        h -= 1;
    }
}

/// Prediction conditioned on the last `h` moves, from a model of at least two states.
fn predict_window(hmm: &Hmm, moves: &[Observation], h: usize, opts: &PredictOptions) -> Prediction {
    let graph = hmm.graph();
    let states = hmm.states();

    let (nu, psi, misfit, end_probability, matched, own) = if moves.is_empty() {
        // First move of a routine: ν = π.
        let nu: Vec<(usize, f64)> = (0..states)
            .map(|i| (i, hmm.initial(i)))
            .filter(|(_, p)| *p > 0.0)
            .collect();
        (
            nu,
            1.0,
            None,
            0.0,
            Vec::new(),
            Transitions::new(hmm, Vec::new()),
        )
    } else {
        let window = &moves[moves.len() - h.min(moves.len())..];
        let prior = if window.len() == moves.len() {
            Prior::Initial
        } else {
            match opts.window_prior {
                WindowPrior::Occupancy => Prior::Occupancy,
                WindowPrior::Uniform => Prior::Uniform,
            }
        };
        let trans = Transitions::for_window(hmm, graph.open_path(), moves.len(), window.len());
        let Some((fwd, psi)) = forward_with_scale(&trans, window, prior, opts) else {
            return Prediction::withheld(Withheld::NoMatch, states);
        };
        let (nu, cont) = next_state(&trans, &fwd.last);
        (
            nu,
            psi,
            Some(fwd.misfit),
            (1.0 - cont).clamp(0.0, 1.0),
            fwd.last,
            trans,
        )
    };
    let window_moves = h.min(moves.len());

    let total: f64 = nu.iter().map(|(_, p)| p).sum();
    if total.is_nan() || total <= 0.0 {
        let mut p = Prediction::withheld(
            Withheld::LikelyEnd {
                end_probability: 1.0,
            },
            states,
        );
        p.end_probability = 1.0;
        p.psi = psi;
        p.misfit = misfit;
        return p;
    }
    let nu: Vec<(usize, f64)> = nu.into_iter().map(|(j, p)| (j, p / total)).collect();
    let phi = gates::confidence(&nu, states);

    let mut mode = mixture_mode(hmm, &nu);
    let mut recalled = None;
    let spread = gates::spread(hmm, &nu, &mode);
    let support = if moves.is_empty() {
        gates::first_move_support(hmm, &nu, &mode)
    } else {
        gates::agreeing_continuations(&own, &matched, &mode)
    };
    let figures = Figures {
        end_probability,
        misfit,
        phi,
        spread,
        support,
        window: window_moves,
        moves: moves.len(),
    };
    let mut withheld = gates::first_failed(opts, &figures);
    // The HMM merges contexts into states, so an ambiguous next state may still be settled by
    // where this exact context was seen last (what the nearest-sequence baselines do).
    if let Some(gate) = opts.recall
        && gates::recallable(withheld)
        && psi == 1.0
        && window_moves >= gate.min_window.max(1)
    {
        let metric = graph.metric();
        let zs: Vec<Observation> = moves[moves.len() - window_moves..]
            .iter()
            .map(|x| metric.whiten(x))
            .collect();
        if let Some(r) = recall(graph, &zs, gate.max_cost)
            && r.agree == r.seen
        {
            mode = *hmm.node(r.next).mean();
            recalled = Some(r.cost);
            withheld = None;
        }
    }
    // Back to raw units in the taught routine's scale; canonical quaternion.
    let relative = scale_translation(&graph.metric().unwhiten(&mode), 1.0 / psi);
    let relative = Move::from_observation(&relative)
        .map(|m| m.observation())
        .ok();
    if withheld.is_none() && relative.is_none() {
        withheld = Some(Withheld::NoMatch);
    }
    Prediction {
        pose: None,
        relative,
        phi,
        psi,
        end_probability,
        misfit,
        spread: Some(spread),
        support,
        recalled,
        states,
        window: window_moves,
        withheld,
        p_useful: None,
        expert: None,
    }
}
