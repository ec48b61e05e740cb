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
mod log_space;
mod mixture;
pub mod prediction;
mod recall;
pub mod scale;
mod transitions;

pub use prediction::{Prediction, Withheld};

use crate::engine::cdhmm::hmm::Hmm;
use crate::engine::cdhmm::learner::ObservationGraph;
use crate::engine::config::{PredictOptions, ScaleConfig, WindowPrior};
use crate::engine::pose::{Move, Observation, scale_translation};
use forward::{Prior, next_state};
use gates::Figures;
use mixture::mixture_mode;
use recall::recall;
use scale::forward_with_scale;
use transitions::Transitions;

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
