//! The proposed move: the mode of the next-state mixture `Σ_j ν_j N(mean_j, C⁻¹)` (whitened, so
//! `N(mean_j, I)`), found by mean-shift from the heaviest components.

use super::log_space::log_sum_exp;
use crate::engine::cdhmm::hmm::Hmm;
use crate::engine::pose::Observation;

/// Most components the mean-shift starts from (by ν); the rest carry negligible mass.
const MODE_STARTS: usize = 16;
/// Most components (the heaviest by ν) the mode is sought among. A flat ν over thousands of
/// states (the first move of a routine, ν = π, in a large model) made each prediction cost
/// milliseconds; such a ν is ambiguous and withheld anyway, and a mode is decided by its heavy
/// components when ν is sharp.
const MODE_COMPONENTS: usize = 64;

/// `argmax_z Σ_j ν_j N(z; mean_j, I)` in whitened space by mean-shift fixed-point iterations
/// started from each heavy component's mean.
pub(super) fn mixture_mode(hmm: &Hmm, nu: &[(usize, f64)]) -> Observation {
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
