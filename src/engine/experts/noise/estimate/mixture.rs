//! The noise the pairs of stretches show ([`super`]'s module doc): each pair's misfit read as
//! drawn from a mixture of a repeat (a χ² in the noise) and not one (even over the log of the
//! misfit), fitted by expectation-maximisation.

use statrs::function::gamma::ln_gamma;

use super::super::Noise;

/// Pairs read as repeats before there is an estimate.
pub const MIN_REPEATS: f64 = 10.0;
/// The misfits of stretches that are not repeats spread from this, mm² (a pair of unrelated
/// stretches does not fit within a tenth of a millimetre) …
pub const OTHER_MIN_MM2: f64 = 1e-2;
/// … to this.
pub const OTHER_MAX_MM2: f64 = 1e7;
/// The smallest σ the fit goes down to, mm (an exact program's).
pub(super) const SIGMA_FLOOR_MM: f64 = 1e-3;
/// The largest, mm per axis: beyond a 45 mm RMS operator, repeats cannot be told from other
/// stretches of the same step lengths ([`super::STEP_GATE_MM`]).
pub(super) const SIGMA_CAP_MM: f64 = 25.0;
/// EM iterations (it converges in a handful; the cap bounds the cost).
const EM_STEPS: usize = 50;

/// One pair of stretches: its squared misfits and their degrees of freedom ([`super`]'s module
/// doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    /// Sum of squared position residuals after the rigid fit, mm².
    pub(super) ss_mm: f64,
    /// Sum of squared angles between corresponding relative rotations, rad².
    pub(super) ss_rad: f64,
    /// Degrees of freedom of `ss_mm` (`3n − 6` for `n` waypoints) …
    pub(super) nu_mm: f64,
    /// … and of `ss_rad` (`3(n − 1)`).
    pub(super) nu_rad: f64,
}

impl Pair {
    /// Whether the pair could be a repeat: its misfit reads as a per-axis error no larger than
    /// the largest the fit believes ([`SIGMA_CAP_MM`]). Unrelated stretches fit far worse.
    pub fn could_repeat(&self) -> bool {
        self.nu_mm > 0.0 && self.ss_mm / (2.0 * self.nu_mm) <= SIGMA_CAP_MM * SIGMA_CAP_MM
    }
}

/// The noise the pairs show ([`super`]'s module doc), or `None` when too few read as repeats; and the
/// mixture fitted (σ², share of repeats), starting from `start` when given.
pub(super) fn fit_mixture(
    pairs: &[Pair],
    start: Option<(f64, f64)>,
) -> (Option<Noise>, Option<(f64, f64)>) {
    if (pairs.len() as f64) < MIN_REPEATS {
        return (None, None);
    }
    // ln of the χ²(ν) density.
    let chi_ln_pdf = |x: f64, nu: f64| {
        let half = nu / 2.0;
        (half - 1.0) * x.ln() - x / 2.0 - half * 2f64.ln() - ln_gamma(half)
    };
    let ln_range = (OTHER_MAX_MM2 / OTHER_MIN_MM2).ln();
    // Log-density of a pair's misfit if it is not a repeat.
    let other = |ss: f64| {
        if (OTHER_MIN_MM2..=OTHER_MAX_MM2).contains(&ss) {
            -ss.ln() - ln_range.ln()
        } else {
            f64::NEG_INFINITY
        }
    };
    // Start from the last fit's σ, or from the lowest decile's, and an even mixture (the last
    // share could be near 0 before the first repeats, and EM would not leave it). From below:
    // a task's repeats are the pairs that fit best, and stretches of about the same shape that
    // are no repeats (welds of another pitch) fit worse; EM climbs to the first cluster.
    let floor = SIGMA_FLOOR_MM * SIGMA_FLOOR_MM;
    let mut var = start.map_or_else(
        || {
            let mut sorted: Vec<f64> = pairs.iter().map(|p| p.ss_mm / (2.0 * p.nu_mm)).collect();
            sorted.sort_by(f64::total_cmp);
            sorted[sorted.len() / 10].max(floor)
        },
        |(v, _)| v,
    );
    let mut share: f64 = 0.5;
    let mut weights = vec![0.0; pairs.len()];
    for _ in 0..EM_STEPS {
        let scale = 2.0 * var;
        for (w, p) in weights.iter_mut().zip(pairs) {
            let repeat = share.ln() + chi_ln_pdf(p.ss_mm.max(1e-300) / scale, p.nu_mm) - scale.ln();
            let not = (1.0 - share).ln() + other(p.ss_mm);
            *w = if not == f64::NEG_INFINITY {
                1.0
            } else {
                1.0 / (1.0 + (not - repeat).exp())
            };
        }
        let total: f64 = weights.iter().sum();
        if total <= 0.0 {
            return (None, None);
        }
        let next = weights
            .iter()
            .zip(pairs)
            .map(|(w, p)| w * p.ss_mm)
            .sum::<f64>()
            / (2.0
                * weights
                    .iter()
                    .zip(pairs)
                    .map(|(w, p)| w * p.nu_mm)
                    .sum::<f64>());
        share = (total / pairs.len() as f64).clamp(1e-6, 1.0 - 1e-6);
        let next = next.clamp(floor, SIGMA_CAP_MM * SIGMA_CAP_MM);
        let converged = (next / var - 1.0).abs() < 1e-6;
        var = next;
        if converged {
            break;
        }
    }
    let mixture = Some((var, share));
    let total: f64 = weights.iter().sum();
    if total < MIN_REPEATS {
        return (None, mixture);
    }
    // The rotations: the median over the pairs read surely as repeats (a few pairs read
    // wrongly would otherwise carry their large turns into the mean).
    // Each pair's squared angles over the median of its χ² (Wilson–Hilferty), so that pairs
    // of other lengths read alike.
    let median_chi = |nu: f64| nu * (1.0 - 2.0 / (9.0 * nu)).powi(3);
    let mut rad: Vec<f64> = weights
        .iter()
        .zip(pairs)
        .filter(|(w, _)| **w >= 0.9)
        .map(|(_, p)| p.ss_rad / (4.0 * median_chi(p.nu_rad)))
        .collect();
    rad.sort_by(f64::total_cmp);
    let var_rad = rad.get(rad.len() / 2).copied().unwrap_or(0.0);
    let mm = var.sqrt();
    let noise = Noise {
        mm: if mm <= SIGMA_FLOOR_MM { 0.0 } else { mm },
        rad: var_rad.sqrt(),
    };
    (Some(noise), mixture)
}
