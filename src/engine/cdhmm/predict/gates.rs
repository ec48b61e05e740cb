//! The gates that decide whether a proposal is offered (ALGORITHM §3, dissertation §3.11), and the
//! figures they read. In order:
//!
//! - **end of routine**: the probability that the matched states are where routines end (or that
//!   nothing is known about what follows them). Renormalising ν hides this mass; predictions made
//!   through it were ~400 mm off on the corpus.
//! - **match quality** (`misfit`): the window's mean squared Mahalanobis distance to the states the
//!   forward pass put it in. The log-space recursion yields a sharp posterior even for a window
//!   the model has never seen; the misfit says whether it was seen.
//! - **confidence φ** = `1 − H(ν)/log₂|Q|`, the dissertation's gate: how unambiguous the next state
//!   is.
//! - **spread**: the expected squared Mahalanobis distance between the proposal and the moves
//!   that followed the matched states (the spread of ν around the mode plus each state's own
//!   scatter). A proposal from a loosely merged state is not precise enough to offer.
//! - **evidence** (`support`, backed-off windows only): how many earlier continuations of the
//!   matched states agree with the proposal.

use super::log_space::log_sum_exp;
use super::prediction::Withheld;
use super::transitions::Transitions;
use crate::engine::cdhmm::hmm::Hmm;
use crate::engine::config::PredictOptions;
use crate::engine::pose::Observation;

/// The figures the gates read.
#[derive(Debug, Clone, Copy)]
pub(super) struct Figures {
    pub(super) end_probability: f64,
    pub(super) misfit: Option<f64>,
    pub(super) phi: f64,
    pub(super) spread: f64,
    pub(super) support: f64,
    /// Moves the prediction conditioned on.
    pub(super) window: usize,
    /// Moves of the routine so far.
    pub(super) moves: usize,
}

/// The first gate the figures fail, in the order of the module docs; None when all pass.
pub(super) fn first_failed(opts: &PredictOptions, f: &Figures) -> Option<Withheld> {
    if opts.max_end_prob.is_some_and(|m| f.end_probability > m) {
        Some(Withheld::LikelyEnd {
            end_probability: f.end_probability,
        })
    } else if let (Some(m), Some(v)) = (opts.max_misfit, f.misfit)
        && v > m
    {
        Some(Withheld::PoorMatch { misfit: v })
    } else if f.phi < opts.phi_min {
        Some(Withheld::LowConfidence { phi: f.phi })
    } else if opts.max_spread.is_some_and(|m| f.spread > m) {
        Some(Withheld::WideSpread { spread: f.spread })
    } else if f.window < opts.horizon.min(f.moves) && f.support < opts.backoff_min_support {
        Some(Withheld::LittleEvidence { support: f.support })
    } else {
        None
    }
}

/// Whether recall may overrule the gate that withheld: only an ambiguous next state, never a
/// window that matched nothing or a likely end.
pub(super) fn recallable(withheld: Option<Withheld>) -> bool {
    matches!(
        withheld,
        Some(
            Withheld::LowConfidence { .. }
                | Withheld::WideSpread { .. }
                | Withheld::LittleEvidence { .. }
        )
    )
}

/// φ = `1 − H(ν)/log₂|Q|` for a normalised ν over a model of `states` states.
pub(super) fn confidence(nu: &[(usize, f64)], states: usize) -> f64 {
    let entropy_bits: f64 = nu
        .iter()
        .filter(|(_, p)| *p > 0.0)
        .map(|(_, p)| -p * p.log2())
        .sum();
    (1.0 - entropy_bits / (states as f64).log2()).clamp(0.0, 1.0)
}

/// Expected squared Mahalanobis distance of the next move from the proposal `mode`: the spread
/// of ν around it plus each state's own scatter.
pub(super) fn spread(hmm: &Hmm, nu: &[(usize, f64)], mode: &Observation) -> f64 {
    nu.iter()
        .map(|&(j, p)| {
            let n = hmm.node(j);
            p * ((n.mean() - mode).norm_squared() + n.scatter() / f64::from(n.count()))
        })
        .sum()
}

/// Evidence for the first move of a routine: how many routines began within one σ of the
/// proposal.
pub(super) fn first_move_support(hmm: &Hmm, nu: &[(usize, f64)], mode: &Observation) -> f64 {
    nu.iter()
        .filter(|(j, _)| (hmm.node(*j).mean() - mode).norm_squared() <= 1.0)
        .map(|(j, _)| f64::from(hmm.node(*j).initial()))
        .sum()
}

/// Σ_i γ(i) Σ_j f(i→j)·[‖mean_j − ẑ‖ ≤ 1]: how many earlier continuations of the matched
/// states, weighted by the posterior, led to (within one σ of) the proposal.
pub(super) fn agreeing_continuations(
    trans: &Transitions,
    last: &[(usize, f64)],
    mode: &Observation,
) -> f64 {
    let hmm = trans.hmm;
    let log_total = log_sum_exp(last.iter().map(|e| e.1));
    last.iter()
        .map(|&(i, a)| {
            let gamma = (a - log_total).exp();
            let agreeing: f64 = hmm
                .node(i)
                .successors()
                .filter(|(j, _)| (hmm.node(*j).mean() - mode).norm_squared() <= 1.0)
                .map(|(j, f)| (f64::from(f) - trans.own_count(i, Some(j))).max(0.0))
                .sum();
            gamma * agreeing
        })
        .sum()
}
