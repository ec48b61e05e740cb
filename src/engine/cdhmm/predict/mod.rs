//! Prediction and confidence (ALGORITHM §3, dissertation §3.10–3.11, §4.5.1): the orchestration
//! that turns the moves of the routine being taught into a [`Prediction`].
//!
//! In the order the window meets them: the predictor conditions on the last `h` moves (the
//! *window*) and runs the HMM forward recursion in log space (`forward`, over the
//! `transitions` less the window's own edges, at the ψ that [`scale`] finds; sums in `log_space`).
//! The posterior over the current state gives a pmf ν over the next state, and the proposed move
//! is the mode of the mixture `Σ_j ν_j N(mean_j, C⁻¹)` (`mixture`). The `gates` decide whether
//! it is offered, each reported with its figure; an ambiguous next state may be settled by
//! `recall`. A window that matches nothing is shortened (backoff). What comes out, and why it
//! is withheld, is [`prediction`].

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
use crate::engine::config::{PredictOptions, RecallGate, ScaleConfig, WindowPrior};
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

/// What is known of the next state before any gate, however the window was read (the first
/// move of a routine, or a forward pass over its last moves).
struct NextState<'h, 'g> {
    /// ν, the pmf over the next state as (state, mass), not yet normalised.
    nu: Vec<(usize, f64)>,
    /// The scale the window was read at (1 for the first move).
    psi: f64,
    /// The window's mean squared misfit (None for the first move).
    misfit: Option<f64>,
    /// Probability that the routine ends after the matched states.
    end_probability: f64,
    /// The forward variables after the last window move, (state, log α); none for the first move.
    matched: Vec<(usize, f64)>,
    /// The transitions the window was read over (less its own edges).
    own: Transitions<'h, 'g>,
}

impl<'h, 'g> NextState<'h, 'g> {
    /// First move of a routine: ν = π.
    fn first_move(hmm: &'h Hmm<'g>) -> NextState<'h, 'g> {
        let nu: Vec<(usize, f64)> = (0..hmm.states())
            .map(|i| (i, hmm.initial(i)))
            .filter(|(_, p)| *p > 0.0)
            .collect();
        NextState {
            nu,
            psi: 1.0,
            misfit: None,
            end_probability: 0.0,
            matched: Vec::new(),
            own: Transitions::new(hmm, Vec::new()),
        }
    }

    /// After the last `h` of `moves` (at least one): the forward pass at the ψ that fits; None
    /// when no learned sequence of states can produce the window.
    fn after_window(
        hmm: &'h Hmm<'g>,
        moves: &[Observation],
        h: usize,
        opts: &PredictOptions,
    ) -> Option<NextState<'h, 'g>> {
        let window = &moves[moves.len() - h.min(moves.len())..];
        let prior = if window.len() == moves.len() {
            Prior::Initial
        } else {
            match opts.window_prior {
                WindowPrior::Occupancy => Prior::Occupancy,
                WindowPrior::Uniform => Prior::Uniform,
            }
        };
        let trans =
            Transitions::for_window(hmm, hmm.graph().open_path(), moves.len(), window.len());
        let (fwd, psi) = forward_with_scale(&trans, window, prior, opts)?;
        let (nu, cont) = next_state(&trans, &fwd.last);
        Some(NextState {
            nu,
            psi,
            misfit: Some(fwd.misfit),
            end_probability: (1.0 - cont).clamp(0.0, 1.0),
            matched: fwd.last,
            own: trans,
        })
    }
}

/// The proposed move (whitened) and the verdict of the gates on it, before it is placed.
struct Proposal {
    mode: Observation,
    /// The recalled context's mean squared distance to the window, when recall settled it.
    recalled: Option<f64>,
    withheld: Option<Withheld>,
}

impl Proposal {
    /// The HMM merges contexts into states, so an ambiguous next state may still be settled by
    /// where this exact context was seen last (what the nearest-sequence baselines do): with the
    /// recall gate on, a verdict recall may lift, a window read at ψ = 1 and long enough, and
    /// every earlier place of the context followed by the same move, that move is offered.
    fn settle_by_recall(
        &mut self,
        hmm: &Hmm,
        window: &[Observation],
        psi: f64,
        gate: Option<RecallGate>,
    ) {
        let Some(gate) = gate else {
            return;
        };
        if !(gates::recallable(self.withheld)
            && psi == 1.0
            && window.len() >= gate.min_window.max(1))
        {
            return;
        }
        let graph = hmm.graph();
        let metric = graph.metric();
        let zs: Vec<Observation> = window.iter().map(|x| metric.whiten(x)).collect();
        if let Some(r) = recall(graph, &zs, gate.max_cost)
            && r.agree == r.seen
        {
            self.mode = *hmm.node(r.next).mean();
            self.recalled = Some(r.cost);
            self.withheld = None;
        }
    }
}

/// Prediction conditioned on the last `h` moves, from a model of at least two states.
fn predict_window(hmm: &Hmm, moves: &[Observation], h: usize, opts: &PredictOptions) -> Prediction {
    let graph = hmm.graph();
    let states = hmm.states();

    let next = if moves.is_empty() {
        NextState::first_move(hmm)
    } else {
        match NextState::after_window(hmm, moves, h, opts) {
            Some(next) => next,
            None => return Prediction::withheld(Withheld::NoMatch, states),
        }
    };
    let NextState {
        nu,
        psi,
        misfit,
        end_probability,
        matched,
        own,
    } = next;
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

    let mode = mixture_mode(hmm, &nu);
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
    let mut proposal = Proposal {
        mode,
        recalled: None,
        withheld: gates::first_failed(opts, &figures),
    };
    proposal.settle_by_recall(hmm, &moves[moves.len() - window_moves..], psi, opts.recall);
    let Proposal {
        mode,
        recalled,
        mut withheld,
    } = proposal;
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
