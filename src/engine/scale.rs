//! Scale estimation (ALGORITHM §4, seed §4.2.2): how much larger or smaller the taught routine
//! is than a learned pattern.
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
//! cell by golden-section on log ψ.

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
