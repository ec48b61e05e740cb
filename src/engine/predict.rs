//! Prediction and confidence (ALGORITHM §3, seed §3.10–3.11, §4.5.1).
//!
//! Given the moves of the routine being taught, the predictor conditions on the last `h` of
//! them (the *window*), runs the HMM forward recursion in log space, turns the posterior over the
//! current state into a pmf ν over the next state, and proposes the most likely next move: the
//! mode of the mixture `Σ_j ν_j N(mean_j, C⁻¹)`, found by mean-shift.
//!
//! Whether the proposal is *offered* is decided by gates, each reported with its figure:
//!
//! - **end of routine**: the probability that the matched states are where routines end (or that
//!   nothing is known about what follows them). Renormalising ν hides this mass; predictions made
//!   through it were ~400 mm off on the corpus.
//! - **match quality** (`misfit`): the window's mean squared Mahalanobis distance to the states the
//!   forward pass put it in. The log-space recursion yields a sharp posterior even for a window
//!   the model has never seen; the misfit says whether it was seen.
//! - **confidence φ** = `1 − H(ν)/log₂|Q|`, the seed's gate: how unambiguous the next state is.
//! - **spread**: the expected squared Mahalanobis distance between the proposal and the moves
//!   that followed the matched states (the spread of ν around the mode plus each state's own
//!   scatter). A proposal from a loosely merged state is not precise enough to offer.
//!
//! With `match_radius` set, states farther than that from a window move are treated as not
//! explaining it at all, which bounds the forward pass to states that matter (a k-d tree finds
//! them). The seed profile evaluates every state.

use std::collections::HashMap;

use serde::Serialize;

use super::config::{EngineConfig, RecallGate, ScaleConfig, WindowPrior};
use super::hmm::Hmm;
use super::learner::{ObservationGraph, TRACE_END};
use super::pose::{Move, Observation, Pose, scale_translation};
use super::scale;

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

/// Where the forward recursion starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Prior {
    Initial,
    Occupancy,
    Uniform,
}

/// Forward variables after the last window move, sparse and sorted by state.
#[derive(Debug, Clone)]
struct Forward {
    /// (state, log α)
    last: Vec<(usize, f64)>,
    log_likelihood: f64,
    misfit: f64,
    /// Posterior-weighted mean of the state means at each window step (whitened).
    expected: Vec<Observation>,
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
    let entropy_bits: f64 = nu
        .iter()
        .filter(|(_, p)| *p > 0.0)
        .map(|(_, p)| -p * p.log2())
        .sum();
    let phi = (1.0 - entropy_bits / (states as f64).log2()).clamp(0.0, 1.0);

    let mut mode = mixture_mode(hmm, &nu);
    let mut recalled = None;
    let spread: f64 = nu
        .iter()
        .map(|&(j, p)| {
            let n = hmm.node(j);
            p * ((n.mean() - mode).norm_squared() + n.scatter() / f64::from(n.count()))
        })
        .sum();
    let support = if moves.is_empty() {
        nu.iter()
            .filter(|(j, _)| (hmm.node(*j).mean() - mode).norm_squared() <= 1.0)
            .map(|(j, _)| f64::from(hmm.node(*j).initial()))
            .sum()
    } else {
        agreeing_continuations(&own, &matched, &mode)
    };
    let mut withheld = if opts.max_end_prob.is_some_and(|m| end_probability > m) {
        Some(Withheld::LikelyEnd { end_probability })
    } else if let (Some(m), Some(v)) = (opts.max_misfit, misfit)
        && v > m
    {
        Some(Withheld::PoorMatch { misfit: v })
    } else if phi < opts.phi_min {
        Some(Withheld::LowConfidence { phi })
    } else if opts.max_spread.is_some_and(|m| spread > m) {
        Some(Withheld::WideSpread { spread })
    } else if window_moves < opts.horizon.min(moves.len()) && support < opts.backoff_min_support {
        Some(Withheld::LittleEvidence { support })
    } else {
        None
    };
    // The HMM merges contexts into states, so an ambiguous next state may still be settled by
    // where this exact context was seen last (what the nearest-sequence baselines do).
    let recallable = matches!(
        withheld,
        Some(
            Withheld::LowConfidence { .. }
                | Withheld::WideSpread { .. }
                | Withheld::LittleEvidence { .. }
        )
    );
    if let Some(gate) = opts.recall
        && recallable
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
    }
}

/// Runs the forward pass on the window at ψ = 1 and, when scale estimation is on and ψ = 1 does
/// not already fit, at the best ψ; returns the pass to predict from and its ψ.
fn forward_with_scale(
    hmm: &Transitions,
    window: &[Observation],
    prior: Prior,
    opts: &PredictOptions,
) -> Option<(Forward, f64)> {
    let metric = hmm.hmm.graph().metric();
    let whitened = |psi: f64| -> Vec<Observation> {
        window
            .iter()
            .map(|x| metric.whiten(&scale_translation(x, psi)))
            .collect()
    };
    let radius_sq = opts.match_radius.map(|r| r * r);
    let unscaled = forward(hmm, &whitened(1.0), prior, radius_sq);
    let sc = &opts.scale;
    let has_translation = window.iter().any(|x| x.fixed_rows::<3>(0).norm() > 1e-9);
    if !sc.enabled || !has_translation {
        return unscaled.map(|f| (f, 1.0));
    }
    // A window that already fits the model at ψ = 1 is not searched (the common case, and it
    // keeps prediction cheap); the seed profile has no fit limit and always searches.
    if let (Some(limit), Some(f)) = (opts.max_misfit, &unscaled)
        && f.misfit <= limit
    {
        return unscaled.map(|f| (f, 1.0));
    }
    let estimate = match radius_sq {
        Some(r2) => sparse_scale_search(hmm, window, prior, sc, r2),
        None => scale::maximise(sc.psi_min, sc.psi_max, |psi| {
            forward(hmm, &whitened(psi), prior, radius_sq)
                .map_or(f64::NEG_INFINITY, |f| f.log_likelihood)
        }),
    };
    let base = unscaled
        .as_ref()
        .map_or(f64::NEG_INFINITY, |f| f.log_likelihood);
    if let Some(est) = estimate
        && est.objective - base >= sc.min_gain
        && let Some(scaled) = forward(hmm, &whitened(est.psi), prior, radius_sq)
        && scaled.misfit <= opts.max_misfit.unwrap_or(SCALED_FIT_LIMIT)
    {
        return Some((scaled, est.psi));
    }
    unscaled.map(|f| (f, 1.0))
}

/// Most ψ values a sparse scale search starts from (the best-fitting ones).
const SCALE_STARTS: usize = 4;
/// Most EM steps refining ψ from the best start.
const SCALE_EM_STEPS: usize = 8;

/// ψ search with a match radius: the window's likelihood is −∞ unless every move has a state
/// within the radius, so only ψ values that put the window's largest move within reach of some
/// state can win. Each such state proposes the ψ that fits it best (a closed form: the whitened
/// scaled move is `u + ψ·v`, linear in ψ); the forward pass is run from those (at most
/// [`SCALE_STARTS`]) instead of a 33-point grid, and the best is refined by EM — ψ maximising the
/// expected fit to the states the forward pass put each move in, again a closed form — instead
/// of 40 golden-section steps. A window no state can reach at any ψ costs one scan of the
/// state means and no forward pass.
fn sparse_scale_search(
    trans: &Transitions,
    window: &[Observation],
    prior: Prior,
    sc: &ScaleConfig,
    radius_sq: f64,
) -> Option<scale::ScaleEstimate> {
    let graph = trans.hmm.graph();
    let metric = graph.metric();
    // Each move as u + ψ·v in whitened space (only the translation scales).
    let parts: Vec<(Observation, Observation)> = window
        .iter()
        .map(|x| {
            let mut v = Observation::zeros();
            v.fixed_rows_mut::<3>(0).copy_from(&x.fixed_rows::<3>(0));
            (metric.whiten(&(x - v)), metric.whiten(&v))
        })
        .collect();
    let at = |psi: f64| -> Vec<Observation> { parts.iter().map(|(u, v)| u + v * psi).collect() };
    let (u, v) = parts
        .iter()
        .max_by(|a, b| a.1.norm_squared().total_cmp(&b.1.norm_squared()))?;
    let vv = v.norm_squared();
    if vv <= 0.0 {
        return None;
    }
    let mut starts: Vec<(f64, f64)> = graph
        .means()
        .iter()
        .filter_map(|mean| {
            let d = mean - u;
            let vd = v.dot(&d);
            // Distance from the whole line u + ψv first: most states are off it.
            if d.norm_squared() - vd * vd / vv > radius_sq {
                return None;
            }
            let psi = (vd / vv).clamp(sc.psi_min, sc.psi_max);
            let fit = (v * psi - d).norm_squared();
            (fit <= radius_sq).then_some((fit, psi))
        })
        .collect();
    if starts.is_empty() {
        return None;
    }
    starts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut tried: Vec<f64> = Vec::new();
    let mut best: Option<(f64, f64, Forward)> = None;
    for &(_, psi) in starts.iter() {
        if tried.len() >= SCALE_STARTS {
            break;
        }
        if tried.iter().any(|t| (t / psi).ln().abs() < 1e-3) {
            continue;
        }
        tried.push(psi);
        if let Some(f) = forward(trans, &at(psi), prior, Some(radius_sq))
            && best.as_ref().is_none_or(|b| f.log_likelihood > b.1)
        {
            best = Some((psi, f.log_likelihood, f));
        }
    }
    let (mut psi, mut objective, mut f) = best?;
    let den: f64 = parts.iter().map(|(_, v)| v.norm_squared()).sum();
    for _ in 0..SCALE_EM_STEPS {
        let num: f64 = parts
            .iter()
            .zip(&f.expected)
            .map(|((u, v), e)| v.dot(&(e - u)))
            .sum();
        let next = (num / den).clamp(sc.psi_min, sc.psi_max);
        if (next / psi).ln().abs() < 1e-12 {
            break;
        }
        match forward(trans, &at(next), prior, Some(radius_sq)) {
            Some(g) if g.log_likelihood > objective => {
                (psi, objective, f) = (next, g.log_likelihood, g);
            }
            _ => break,
        }
    }
    Some(scale::ScaleEstimate { psi, objective })
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

/// Mean misfit per move a scaled window must reach when no match gate is configured:
/// the 99 % quantile of χ²(7). A likelihood gain alone accepts wrong ψ when the window holds a
/// move that does not scale.
const SCALED_FIT_LIMIT: f64 = 18.475_306_906_582_357;

/// The log-space forward recursion `α_0(j) = b_j(x_0)·prior_j`,
/// `α_k(j) = b_j(x_k) Σ_i a(j|i) α_{k−1}(i)`, sparse over states with non-zero α.
fn forward(
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
fn next_state(trans: &Transitions, last: &[(usize, f64)]) -> (Vec<(usize, f64)>, f64) {
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

/// Σ_i γ(i) Σ_j f(i→j)·[‖mean_j − ẑ‖ ≤ 1]: how many earlier continuations of the matched
/// states, weighted by the posterior, led to (within one σ of) the proposal.
fn agreeing_continuations(trans: &Transitions, last: &[(usize, f64)], mode: &Observation) -> f64 {
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

/// Most components the mean-shift starts from (by ν); the rest carry negligible mass.
const MODE_STARTS: usize = 16;
/// Most components (the heaviest by ν) the mode is sought among. A flat ν over thousands of
/// states (the first move of a routine, ν = π, in a large model) made each prediction cost
/// milliseconds; such a ν is ambiguous and withheld anyway, and a mode is decided by its heavy
/// components when ν is sharp.
const MODE_COMPONENTS: usize = 64;

/// `argmax_z Σ_j ν_j N(z; mean_j, I)` in whitened space by mean-shift fixed-point iterations
/// started from each heavy component's mean.
fn mixture_mode(hmm: &Hmm, nu: &[(usize, f64)]) -> Observation {
    let mut comps: Vec<(f64, Observation)> = nu
        .iter()
        .filter(|(_, p)| *p > 0.0)
        .map(|&(j, p)| (p, *hmm.node(j).mean()))
        .collect();
    comps.sort_by(|a, b| b.0.total_cmp(&a.0));
    comps.truncate(MODE_COMPONENTS);
    if comps.len() == 1 {
        return comps[0].1;
    }
    let log_density = |z: &Observation| {
        log_sum_exp(
            comps
                .iter()
                .map(|(p, m)| p.ln() - 0.5 * (z - m).norm_squared()),
        )
    };
    let mut best: Option<(f64, Observation)> = None;
    for (_, start) in comps.iter().take(MODE_STARTS) {
        let mut z = *start;
        for _ in 0..100 {
            let logs: Vec<f64> = comps
                .iter()
                .map(|(p, m)| p.ln() - 0.5 * (z - m).norm_squared())
                .collect();
            let max = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let (mut num, mut den) = (Observation::zeros(), 0.0);
            for ((_, m), l) in comps.iter().zip(&logs) {
                let w = (l - max).exp();
                num += m * w;
                den += w;
            }
            let next = num / den;
            let step = (next - z).norm_squared();
            z = next;
            if step < 1e-20 {
                break;
            }
        }
        let d = log_density(&z);
        if best.as_ref().is_none_or(|(b, _)| d > *b) {
            best = Some((d, z));
        }
    }
    best.map_or(comps[0].1, |(_, z)| z)
}

fn log_sum_exp(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = values.clone().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return max;
    }
    max + values.map(|v| (v - max).exp()).sum::<f64>().ln()
}

/// The HMM's transitions less the current routine's own edges inside the window.
///
/// With within-routine learning at a lag shorter than the window, the model already holds the
/// window's own path, which is no evidence for the window (it would always match itself): its
/// edges are discounted, and a state made only of window moves explains nothing.
struct Transitions<'h, 'g> {
    hmm: &'h Hmm<'g>,
    /// The window's own edges (i, j), repeated as often as they occur.
    own: Vec<(usize, usize)>,
    /// The window's own moves' states, repeated as often as they occur.
    own_states: Vec<usize>,
}

impl<'h, 'g> Transitions<'h, 'g> {
    fn new(hmm: &'h Hmm<'g>, own: Vec<(usize, usize)>) -> Transitions<'h, 'g> {
        Transitions {
            hmm,
            own,
            own_states: Vec::new(),
        }
    }

    /// For a window of the last `window` of `moves` moves, `path` being the states of the
    /// routine's moves assimilated so far.
    fn for_window(
        hmm: &'h Hmm<'g>,
        path: &[usize],
        moves: usize,
        window: usize,
    ) -> Transitions<'h, 'g> {
        let start = moves.saturating_sub(window).min(path.len());
        let inside = &path[start..];
        Transitions {
            hmm,
            own: inside.windows(2).map(|e| (e[0], e[1])).collect(),
            own_states: inside.to_vec(),
        }
    }

    /// Whether every member of state j is one of the window's own moves.
    fn self_only(&self, j: usize) -> bool {
        !self.own_states.is_empty()
            && self.own_states.iter().filter(|&&s| s == j).count() as u32
                >= self.hmm.node(j).count()
    }

    /// How many own edges leave `i` (towards `j`, or anywhere with None).
    fn own_count(&self, i: usize, j: Option<usize>) -> f64 {
        self.own
            .iter()
            .filter(|&&(a, b)| a == i && j.is_none_or(|j| j == b))
            .count() as f64
    }

    /// Calls `f(j, a(j|i))` for each successor j of i.
    fn for_each(&self, i: usize, mut f: impl FnMut(usize, f64)) {
        let own_out = self.own_count(i, None);
        if own_out == 0.0 {
            for (j, a) in self.hmm.transitions(i) {
                f(j, a);
            }
            return;
        }
        let node = self.hmm.node(i);
        let total = node.outcome_weight() - own_out;
        if total <= 1e-9 {
            return;
        }
        for (j, w) in node.weighted_successors() {
            let w = w - self.own_count(i, Some(j));
            if w > 1e-9 {
                f(j, w / total);
            }
        }
    }
}

/// Most recent occurrences of a node looked at when searching for the window's context.
const RECENT_OCCURRENCES: usize = 256;

/// Where the window's context was seen before and what followed it.
#[derive(Debug, Clone, Copy)]
struct Recall {
    /// The node that followed the most recent occurrence.
    next: usize,
    /// Mean squared distance of the window to that occurrence's states.
    cost: f64,
    /// Occurrences of the context (with a known continuation) found.
    seen: usize,
    /// Of those, how many were followed by (a node within one σ of) `next`.
    agree: usize,
}

/// The continuation of the most recent place in the trace whose last `k` states fit the
/// window `zs` (whitened, `k` moves) with mean squared distance at most `limit`.
/// Contexts do not cross routine boundaries.
fn recall(graph: &ObservationGraph, zs: &[Observation], limit: f64) -> Option<Recall> {
    let trace = graph.trace();
    let nodes = graph.nodes();
    let k = zs.len();
    let last = zs.last()?;
    let budget = limit * k as f64;
    let mut candidates = Vec::new();
    graph.candidates(last, budget, &mut candidates);
    // (position, next, cost) of every matching occurrence
    let mut found: Vec<(usize, usize, f64)> = Vec::new();
    for i in candidates {
        if (last - nodes[i].mean()).norm_squared() > budget {
            continue;
        }
        for &t in nodes[i].occurrences().iter().rev().take(RECENT_OCCURRENCES) {
            let t = t as usize;
            let Some(&next) = trace.get(t + 1) else {
                continue;
            };
            if next == TRACE_END || t + 1 < k {
                continue;
            }
            let context = &trace[t + 1 - k..=t];
            let mut cost = 0.0;
            for (z, &s) in zs.iter().zip(context) {
                if s == TRACE_END {
                    cost = f64::INFINITY;
                    break;
                }
                cost += (z - nodes[s as usize].mean()).norm_squared();
            }
            if cost <= budget {
                found.push((t, next as usize, cost / k as f64));
            }
        }
    }
    let &(_, next, cost) = found.iter().max_by_key(|e| e.0)?;
    let target = nodes[next].mean();
    let agree = found
        .iter()
        .filter(|e| (nodes[e.1].mean() - target).norm_squared() <= 1.0)
        .count();
    Some(Recall {
        next,
        cost,
        seen: found.len(),
        agree,
    })
}
