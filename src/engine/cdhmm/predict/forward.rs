//! The HMM forward recursion over a window of moves, in log space (ALGORITHM §3, dissertation
//! §3.10): the posterior over the current state, the window's likelihood and misfit, and ν, the pmf
//! over the next state.
//!
//! With `match_radius` set, states farther than that from a window move are treated as not
//! explaining it at all, which bounds the forward pass to states that matter (a k-d tree finds
//! them). The seed profile evaluates every state.

use std::collections::HashMap;

use super::log_space::log_sum_exp;
use super::transitions::Transitions;
use crate::engine::cdhmm::hmm::Hmm;
use crate::engine::config::PredictOptions;
use crate::engine::pose::Observation;

/// Where the forward recursion starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Prior {
    Initial,
    Occupancy,
    Uniform,
}

/// Forward variables after the last window move, sparse and sorted by state.
#[derive(Debug, Clone)]
pub(super) struct Forward {
    /// (state, log α)
    pub(super) last: Vec<(usize, f64)>,
    pub(super) log_likelihood: f64,
    pub(super) misfit: f64,
    /// Posterior-weighted mean of the state means at each window step (whitened).
    pub(super) expected: Vec<Observation>,
}

/// Log-likelihood of a whole routine's moves from the routine start (used by Learn-Scaled-HMM);
/// −∞ when the model cannot produce them.
pub(crate) fn window_log_likelihood(
    hmm: &Hmm,
    moves: &[Observation],
    opts: &PredictOptions,
) -> f64 {
    let metric = hmm.graph().metric();
    let whitened: Vec<Observation> = moves.iter().map(|x| metric.whiten(x)).collect();
    forward(
        &Transitions::new(hmm, Vec::new()),
        &whitened,
        Prior::Initial,
        opts.match_radius.map(|r| r * r),
    )
    .map_or(f64::NEG_INFINITY, |f| f.log_likelihood)
}

/// The log-space forward recursion `α_0(j) = b_j(x_0)·prior_j`,
/// `α_k(j) = b_j(x_k) Σ_i a(j|i) α_{k−1}(i)`, sparse over states with non-zero α.
pub(super) fn forward(
    trans: &Transitions,
    window: &[Observation],
    prior: Prior,
    radius_sq: Option<f64>,
) -> Option<Forward> {
    let hmm = trans.hmm;
    let graph = hmm.graph();
    let metric = graph.metric();
    let (first, rest) = window.split_first()?;
    let uniform = 1.0 / hmm.states() as f64;
    let prior_of = |i: usize| match prior {
        Prior::Initial => hmm.initial(i),
        Prior::Occupancy => hmm.occupancy(i),
        Prior::Uniform => uniform,
    };

    // (state, log α, squared distance to the window move)
    let mut current: Vec<(usize, f64, f64)> = Vec::new();
    let mut candidates = Vec::new();
    match radius_sq {
        Some(r2) => graph.candidates(first, r2, &mut candidates),
        None => candidates.extend(0..hmm.states()),
    }
    candidates.sort_unstable();
    for j in candidates {
        let d2 = (first - hmm.node(j).mean()).norm_squared();
        let p = prior_of(j);
        if p > 0.0 && radius_sq.is_none_or(|r2| d2 <= r2) && !trans.self_only(j) {
            current.push((j, p.ln() + metric.log_density(d2), d2));
        }
    }
    let mut expected = Vec::with_capacity(window.len());
    let (m, e) = expected_misfit(hmm, &current)?;
    let mut misfit_sum = m;
    expected.push(e);

    let mut acc: HashMap<usize, f64> = HashMap::new();
    for z in rest {
        let max = current
            .iter()
            .map(|e| e.1)
            .fold(f64::NEG_INFINITY, f64::max);
        acc.clear();
        for &(i, log_alpha, _) in &current {
            let w = (log_alpha - max).exp();
            trans.for_each(i, |j, a| *acc.entry(j).or_insert(0.0) += a * w);
        }
        let mut next: Vec<(usize, f64, f64)> = acc
            .iter()
            .filter(|(j, s)| **s > 0.0 && !trans.self_only(**j))
            .filter_map(|(&j, &s)| {
                let d2 = (z - hmm.node(j).mean()).norm_squared();
                radius_sq
                    .is_none_or(|r2| d2 <= r2)
                    .then(|| (j, max + s.ln() + metric.log_density(d2), d2))
            })
            .collect();
        next.sort_unstable_by_key(|e| e.0);
        let (m, e) = expected_misfit(hmm, &next)?;
        misfit_sum += m;
        expected.push(e);
        current = next;
    }
    let log_likelihood = log_sum_exp(current.iter().map(|e| e.1));
    Some(Forward {
        last: current.iter().map(|&(j, a, _)| (j, a)).collect(),
        log_likelihood,
        misfit: misfit_sum / window.len() as f64,
        expected,
    })
}

/// Posterior-expected squared distance of one window move to its states and the posterior
/// mean of their means; None when no state explains it (the window cannot be produced).
fn expected_misfit(hmm: &Hmm, step: &[(usize, f64, f64)]) -> Option<(f64, Observation)> {
    let max = step.iter().map(|e| e.1).fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return None;
    }
    let (mut num, mut den, mut mean) = (0.0, 0.0, Observation::zeros());
    for &(j, a, d2) in step {
        let w = (a - max).exp();
        num += w * d2;
        den += w;
        mean += hmm.node(j).mean() * w;
    }
    Some((num / den, mean / den))
}

/// ν(j) ∝ Σ_i γ(i) a(j|i) (unnormalised, sorted by state) and the continuation mass Σ_i γ(i) Σ_j a(j|i).
pub(super) fn next_state(trans: &Transitions, last: &[(usize, f64)]) -> (Vec<(usize, f64)>, f64) {
    let log_total = log_sum_exp(last.iter().map(|e| e.1));
    let mut nu: HashMap<usize, f64> = HashMap::new();
    let mut cont = 0.0;
    for &(i, a) in last {
        let gamma = (a - log_total).exp();
        trans.for_each(i, |j, p| {
            cont += gamma * p;
            *nu.entry(j).or_insert(0.0) += gamma * p;
        });
    }
    let mut nu: Vec<(usize, f64)> = nu.into_iter().collect();
    nu.sort_unstable_by_key(|e| e.0);
    (nu, cont)
}
