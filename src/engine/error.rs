//! Typed errors of the engine. Adapters map them to HTTP/gRPC statuses once, at the edge.

use thiserror::Error;

/// A pose or observation that cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PoseError {
    /// A number that is not finite (NaN, ±infinity), by its field (`x`, `qw`, ...).
    #[error("{field} = {value:?} is not a finite number")]
    NonFinite { field: &'static str, value: f64 },
    /// A coordinate farther from its frame's origin than the service accepts
    /// ([`super::pose::POSITION_LIMIT_MM`]).
    #[error("{field} = {value:?} is outside ±{limit} mm")]
    OutOfRange {
        field: &'static str,
        value: f64,
        limit: f64,
    },
    #[error("quaternion norm {norm} is not within 1e-3 of 1")]
    NotUnitQuaternion { norm: f64 },
    #[error("observation has a non-finite component")]
    NonFiniteObservation,
    #[error("observation's quaternion part has near-zero norm {norm}")]
    DegenerateQuaternion { norm: f64 },
}

/// Engine settings that cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ConfigError {
    #[error("delta must be in (0, 1], got {0}")]
    Delta(f64),
    #[error("phi_min must be in [0, 1], got {0}")]
    PhiMin(f64),
    #[error("horizon must be at least 1, got {0}")]
    Horizon(usize),
    #[error("precision matrix must be symmetric positive definite with finite entries")]
    Precision,
    #[error("sigma values must be finite and positive, got {0}")]
    Sigma(f64),
    #[error("scale bracket must satisfy 0 < min < 1 < max, got [{min}, {max}]")]
    ScaleBracket { min: f64, max: f64 },
    #[error("{name} must be finite and non-negative, got {value}")]
    Threshold { name: &'static str, value: f64 },
    #[error("unknown profile {0:?} (expected \"seed\" or \"default\")")]
    Profile(String),
}
