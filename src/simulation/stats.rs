//! Summary statistics of simulated programming times and the Wilcoxon rank-sum test the
//! dissertation used for Table 4.1 (Fraser 1957; equivalently the Mann–Whitney U test).

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, Normal};
use thiserror::Error;

#[derive(Debug, Clone, PartialEq, Error)]
pub enum StatsError {
    #[error("a sample is empty")]
    Empty,
    #[error("a sample holds a value that is not finite")]
    NotFinite,
}

/// Arithmetic mean; `None` for an empty sample.
pub fn mean(x: &[f64]) -> Option<f64> {
    (!x.is_empty()).then(|| x.iter().sum::<f64>() / x.len() as f64)
}

/// Sample standard deviation (n − 1 in the denominator); `None` with fewer than two values.
pub fn std_dev(x: &[f64]) -> Option<f64> {
    let m = mean(x)?;
    (x.len() >= 2).then(|| {
        let ss: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
        (ss / (x.len() - 1) as f64).sqrt()
    })
}

/// The result of a rank-sum test of `x` against `y`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RankSum {
    /// Sum of the ranks of `x` in the pooled sample (mid-ranks for ties).
    pub w: f64,
    /// Mann–Whitney U of `x`: `w − n_x(n_x + 1)/2`.
    pub u: f64,
    /// Standardised statistic (normal approximation, tie and continuity corrected).
    pub z: f64,
    /// Two-sided p-value.
    pub p: f64,
}

/// Wilcoxon rank-sum test, two-sided, by the normal approximation with the tie correction of
/// the variance and a continuity correction of 0.5. Good for samples of about ten or more each;
/// the simulation's samples are in the hundreds.
pub fn rank_sum(x: &[f64], y: &[f64]) -> Result<RankSum, StatsError> {
    if x.is_empty() || y.is_empty() {
        return Err(StatsError::Empty);
    }
    if x.iter().chain(y).any(|v| !v.is_finite()) {
        return Err(StatsError::NotFinite);
    }
    let (nx, ny) = (x.len() as f64, y.len() as f64);
    let n = nx + ny;
    let mut pooled: Vec<(f64, bool)> = x
        .iter()
        .map(|&v| (v, true))
        .chain(y.iter().map(|&v| (v, false)))
        .collect();
    pooled.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut w = 0.0;
    let mut tie_term = 0.0; // Σ (t³ − t) over groups of ties
    let mut i = 0;
    while i < pooled.len() {
        let mut j = i;
        while j + 1 < pooled.len() && pooled[j + 1].0 == pooled[i].0 {
            j += 1;
        }
        let t = (j - i + 1) as f64;
        let rank = (i + j) as f64 / 2.0 + 1.0; // mid-rank, 1-based
        w += rank * pooled[i..=j].iter().filter(|p| p.1).count() as f64;
        tie_term += t * t * t - t;
        i = j + 1;
    }
    let u = w - nx * (nx + 1.0) / 2.0;
    let mean_u = nx * ny / 2.0;
    let var_u = nx * ny / 12.0 * ((n + 1.0) - tie_term / (n * (n - 1.0)));
    let (z, p) = if var_u > 0.0 {
        let diff = u - mean_u;
        let corrected = (diff.abs() - 0.5).max(0.0) * diff.signum();
        let z = corrected / var_u.sqrt();
        let normal = Normal::standard();
        (z, (2.0 * (1.0 - normal.cdf(z.abs()))).min(1.0))
    } else {
        (0.0, 1.0)
    };
    Ok(RankSum { w, u, z, p })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_std() {
        assert_eq!(mean(&[]), None);
        assert_eq!(mean(&[1.0, 2.0, 3.0]), Some(2.0));
        assert_eq!(std_dev(&[5.0]), None);
        let s = std_dev(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]).unwrap();
        assert!((s - 2.138_089_935_299_395).abs() < 1e-12, "{s}");
    }

    #[test]
    fn rank_sum_matches_a_hand_computed_case() {
        // x = 1,2,3 ; y = 4,5,6: W = 6, U = 0; var = 3·3/12·7 = 5.25; z = (0 − 4.5 + 0.5)/√5.25.
        let r = rank_sum(&[1.0, 2.0, 3.0], &[4.0, 5.0, 6.0]).unwrap();
        assert_eq!(r.w, 6.0);
        assert_eq!(r.u, 0.0);
        let z = -4.0 / 5.25f64.sqrt();
        assert!((r.z - z).abs() < 1e-12);
        // Two-sided p of |z| = 1.7457: 0.0809 (normal table).
        assert!((r.p - 0.080_86).abs() < 1e-4, "{}", r.p);
    }

    #[test]
    fn ties_get_mid_ranks_and_a_smaller_variance() {
        // Pooled 1,2,2,3 → ranks 1, 2.5, 2.5, 4. x = {1, 2}: W = 3.5.
        let r = rank_sum(&[1.0, 2.0], &[2.0, 3.0]).unwrap();
        assert_eq!(r.w, 3.5);
        assert_eq!(r.u, 0.5);
        // var = 2·2/12·(5 − 6/12) = 1.5.
        let z = -(1.5f64 - 0.5) / 1.5f64.sqrt();
        assert!((r.z - z).abs() < 1e-12, "{}", r.z);
        // Identical samples: nothing to tell apart.
        let same = rank_sum(&[1.0, 1.0], &[1.0, 1.0]).unwrap();
        assert_eq!(same.p, 1.0);
    }

    #[test]
    fn large_shift_is_significant_and_symmetric() {
        let x: Vec<f64> = (0..50).map(|i| i as f64).collect();
        let y: Vec<f64> = (0..50).map(|i| i as f64 + 30.0).collect();
        let a = rank_sum(&x, &y).unwrap();
        let b = rank_sum(&y, &x).unwrap();
        assert!(a.p < 1e-6, "{}", a.p);
        assert!((a.p - b.p).abs() < 1e-12);
        assert!((a.z + b.z).abs() < 1e-12);
        assert_eq!(rank_sum(&[], &[1.0]), Err(StatsError::Empty));
        assert_eq!(rank_sum(&[f64::NAN], &[1.0]), Err(StatsError::NotFinite));
    }
}
