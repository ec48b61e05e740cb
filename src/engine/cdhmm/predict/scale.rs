//! Scale estimation (ALGORITHM §4, dissertation §4.2.2): how much larger or smaller the taught
//! routine is than a learned pattern.
//!
//! **Convention.** ψ maps the taught window onto the model: only translations are scaled,
//! `Ψ = diag(ψ, ψ, ψ, 1, 1, 1, 1)`, and the model is asked about `Ψx`. A copy of a learned
//! pattern taught twice as large therefore gives **ψ = 0.5**, and the routine's size relative to
//! the pattern is `1/ψ = 2` (reported as `routine_scale`). The predicted move is computed in the
//! model's scale and its translation divided by ψ before it is composed onto the last pose.
//!
//! The window likelihood as a function of ψ has several peaks (each learned pattern the window
//! could be a scaled copy of gives one), so a plain golden-section search finds local ones. The
//! search here evaluates a coarse log-spaced grid over the bracket, then refines the best grid
//! cell by golden-section on log ψ ([`maximise`]). With a match radius, the search starts instead
//! from the ψ values that put the window's largest move within reach of a state and refines the
//! best by EM. A prediction takes the ψ found only when it gains at least `min_gain` in
//! log-likelihood over ψ = 1 and the scaled window still fits.

use super::forward::{Forward, Prior, forward};
use super::transitions::Transitions;
use crate::engine::config::{PredictOptions, ScaleConfig};
use crate::engine::pose::{Observation, scale_translation};

/// Points of the coarse grid over `[ψ_min, ψ_max]` (log-spaced).
pub const GRID_POINTS: usize = 33;
/// Most golden-section iterations on log ψ (the bracket shrinks by 0.618 each).
pub const REFINE_ITERATIONS: usize = 40;
/// Golden-section stops once the bracket on log ψ is this narrow (ψ known to ~1e-6 relative,
/// 1 µm on a 1 m move): about 26 iterations from a two-cell grid bracket instead of 40.
pub const REFINE_TOLERANCE: f64 = 1e-6;

/// The best ψ found and the objective there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleEstimate {
    pub psi: f64,
    pub objective: f64,
}

/// Maximises `objective(ψ)` over `[psi_min, psi_max]` by grid then golden-section on log ψ.
/// Returns None when the objective is −∞ (or NaN) everywhere on the grid.
pub fn maximise(
    psi_min: f64,
    psi_max: f64,
    mut objective: impl FnMut(f64) -> f64,
) -> Option<ScaleEstimate> {
    let (lo, hi) = (psi_min.ln(), psi_max.ln());
    let step = (hi - lo) / (GRID_POINTS - 1) as f64;
    let mut best: Option<(usize, f64)> = None;
    for k in 0..GRID_POINTS {
        let v = objective((lo + step * k as f64).exp());
        if v.is_finite() && best.is_none_or(|(_, b)| v > b) {
            best = Some((k, v));
        }
    }
    let (k, grid_best) = best?;
    let centre = lo + step * k as f64;
    let (mut a, mut b) = ((centre - step).max(lo), (centre + step).min(hi));
    let inv_phi = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - inv_phi * (b - a);
    let mut d = a + inv_phi * (b - a);
    let neg_inf_to_min = |v: f64| if v.is_nan() { f64::NEG_INFINITY } else { v };
    let mut fc = neg_inf_to_min(objective(c.exp()));
    let mut fd = neg_inf_to_min(objective(d.exp()));
    for _ in 0..REFINE_ITERATIONS {
        if b - a <= REFINE_TOLERANCE {
            break;
        }
        if fc >= fd {
            b = d;
            d = c;
            fd = fc;
            c = b - inv_phi * (b - a);
            fc = neg_inf_to_min(objective(c.exp()));
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + inv_phi * (b - a);
            fd = neg_inf_to_min(objective(d.exp()));
        }
    }
    let (log_psi, v) = if fc >= fd { (c, fc) } else { (d, fd) };
    Some(if v >= grid_best {
        ScaleEstimate {
            psi: log_psi.exp(),
            objective: v,
        }
    } else {
        ScaleEstimate {
            psi: centre.exp(),
            objective: grid_best,
        }
    })
}

/// Runs the forward pass on the window at ψ = 1 and, when scale estimation is on and ψ = 1 does
/// not already fit, at the best ψ; returns the pass to predict from and its ψ.
pub(super) fn forward_with_scale(
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
        None => maximise(sc.psi_min, sc.psi_max, |psi| {
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
) -> Option<ScaleEstimate> {
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
    Some(ScaleEstimate { psi, objective })
}

/// Mean misfit per move a scaled window must reach when no match gate is configured:
/// the 99 % quantile of χ²(7). A likelihood gain alone accepts wrong ψ when the window holds a
/// move that does not scale.
const SCALED_FIT_LIMIT: f64 = 18.475_306_906_582_357;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_global_peak_not_a_local_one() {
        // Two peaks in log ψ: a broad low one at ψ = 0.3 and a sharp high one at ψ = 2.0.
        let f = |psi: f64| {
            let l = psi.ln();
            let p1 = -((l - 0.3f64.ln()) / 0.5).powi(2);
            let p2 = 3.0 - ((l - 2.0f64.ln()) / 0.05).powi(2);
            p1.max(p2)
        };
        let e = maximise(0.2, 5.0, f).unwrap();
        assert!((e.psi - 2.0).abs() < 1e-5, "{e:?}");
    }

    #[test]
    fn minus_infinity_everywhere_gives_none_and_partial_infinity_is_skipped() {
        assert!(maximise(0.2, 5.0, |_| f64::NEG_INFINITY).is_none());
        let e = maximise(0.2, 5.0, |psi| {
            if psi < 1.0 {
                f64::NEG_INFINITY
            } else {
                -(psi - 3.0).powi(2)
            }
        })
        .unwrap();
        assert!((e.psi - 3.0).abs() < 1e-5, "{e:?}");
    }
}
