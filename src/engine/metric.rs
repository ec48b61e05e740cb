//! The similarity metric: a precision matrix `C` and its whitening transform.
//!
//! Two moves are alike when their Mahalanobis distance `‖x − y‖²_C = (x − y)ᵀ C (x − y)` is small.
//! With the Cholesky factor `C = L Lᵀ`, `‖x − y‖²_C = ‖Lᵀx − Lᵀy‖²`, so the learner and the
//! predictor work on *whitened* vectors `z = Lᵀx`, where the metric is plain Euclidean. That is
//! what lets an ordinary k-d tree find the nodes that may accept a move.

use nalgebra::{SMatrix, SVector};

use super::error::ConfigError;
use super::pose::Observation;

pub type Matrix7 = SMatrix<f64, 7, 7>;

/// A 7×7 symmetric positive-definite precision matrix with its whitening transform.
#[derive(Debug, Clone, PartialEq)]
pub struct Metric {
    precision: Matrix7,
    /// `Lᵀ` where `C = L Lᵀ`: `z = Lᵀ x`.
    whiten: Matrix7,
    /// `(Lᵀ)⁻¹`: `x = (Lᵀ)⁻¹ z`.
    unwhiten: Matrix7,
    /// `log` of the normal density's constant with covariance `C⁻¹`: `½ log det C − 3.5 log 2π`.
    log_norm: f64,
}

impl Metric {
    /// Block-diagonal precision: `1/σ_t²` on the three translation components (mm),
    /// `1/σ_q²` on the four quaternion components.
    pub fn diagonal(sigma_t: f64, sigma_q: f64) -> Result<Metric, ConfigError> {
        for s in [sigma_t, sigma_q] {
            if !(s.is_finite() && s > 0.0) {
                return Err(ConfigError::Sigma(s));
            }
        }
        let t = 1.0 / (sigma_t * sigma_t);
        let q = 1.0 / (sigma_q * sigma_q);
        Metric::from_precision(Matrix7::from_diagonal(&SVector::<f64, 7>::from([
            t, t, t, q, q, q, q,
        ])))
    }

    /// Any symmetric positive-definite precision matrix with finite entries.
    pub fn from_precision(precision: Matrix7) -> Result<Metric, ConfigError> {
        if precision.iter().any(|v| !v.is_finite())
            || (precision - precision.transpose()).abs().max() > 1e-9 * precision.abs().max()
        {
            return Err(ConfigError::Precision);
        }
        let chol = precision.cholesky().ok_or(ConfigError::Precision)?;
        let whiten = chol.l().transpose();
        let unwhiten = whiten.try_inverse().ok_or(ConfigError::Precision)?;
        let log_det: f64 = chol.l().diagonal().iter().map(|d| 2.0 * d.ln()).sum();
        Ok(Metric {
            precision,
            whiten,
            unwhiten,
            log_norm: 0.5 * log_det - 3.5 * (2.0 * std::f64::consts::PI).ln(),
        })
    }

    pub fn precision(&self) -> &Matrix7 {
        &self.precision
    }

    /// `z = Lᵀ x`.
    pub fn whiten(&self, x: &Observation) -> Observation {
        self.whiten * x
    }

    /// `x = (Lᵀ)⁻¹ z`.
    pub fn unwhiten(&self, z: &Observation) -> Observation {
        self.unwhiten * z
    }

    /// `‖x − y‖²_C`.
    pub fn distance_sq(&self, x: &Observation, y: &Observation) -> f64 {
        let d = x - y;
        d.dot(&(self.precision * d))
    }

    /// Log density of `N(mean, C⁻¹)` at a point, given the squared whitened distance.
    pub fn log_density(&self, distance_sq: f64) -> f64 {
        self.log_norm - 0.5 * distance_sq
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whitened_distance_is_mahalanobis() {
        let mut c = Matrix7::identity() * 2.0;
        c[(0, 1)] = 0.5;
        c[(1, 0)] = 0.5;
        c[(3, 3)] = 1e4;
        let m = Metric::from_precision(c).unwrap();
        let x = Observation::from([1.0, -2.0, 0.5, 0.9, 0.1, 0.0, -0.1]);
        let y = Observation::from([0.0, 1.0, 0.5, 1.0, 0.0, 0.0, 0.0]);
        let d = (m.whiten(&x) - m.whiten(&y)).norm_squared();
        assert!((d - m.distance_sq(&x, &y)).abs() < 1e-9 * d);
        assert!((m.unwhiten(&m.whiten(&x)) - x).norm() < 1e-12);
    }

    #[test]
    fn rejects_non_positive_definite_or_asymmetric() {
        let mut c = Matrix7::identity();
        c[(2, 2)] = -1.0;
        assert_eq!(Metric::from_precision(c), Err(ConfigError::Precision));
        let mut c = Matrix7::identity();
        c[(0, 1)] = 0.3;
        assert_eq!(Metric::from_precision(c), Err(ConfigError::Precision));
        let mut c = Matrix7::identity();
        c[(4, 4)] = f64::NAN;
        assert_eq!(Metric::from_precision(c), Err(ConfigError::Precision));
        assert_eq!(Metric::diagonal(0.0, 0.01), Err(ConfigError::Sigma(0.0)));
    }
}
