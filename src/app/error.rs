//! The application's errors. Adapters (HTTP, gRPC) map them to their status codes once, at the
//! edge; nothing here knows about either.

use crate::engine::{ConfigError, PoseError};
use crate::storage::StorageError;

#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// A resource that does not exist.
    #[error("{what} {id} does not exist")]
    NotFound { what: &'static str, id: i64 },
    /// A named resource that does not exist.
    #[error("{what} {name:?} does not exist")]
    NotFoundName { what: &'static str, name: String },
    /// The request conflicts with the resource's state (a finished routine, a second open
    /// routine in a cell, nothing to undo).
    #[error("{0}")]
    Conflict(String),
    /// The name of a resource being created is taken (a cell, a program, an imported
    /// program). REST answers it like [`AppError::Conflict`] (409 `conflict`); gRPC tells the
    /// two apart (`ALREADY_EXISTS` vs `FAILED_PRECONDITION`).
    #[error("{0}")]
    Exists(String),
    /// Input that is well-formed but not acceptable.
    #[error("{0}")]
    Invalid(String),
    #[error("invalid pose: {0}")]
    Pose(#[from] PoseError),
    #[error("invalid settings: {0}")]
    Config(#[from] ConfigError),
    /// A failure of ours (database, corrupted stored data).
    #[error("internal error: {0}")]
    Internal(String),
}

impl AppError {
    /// A short stable code for API clients.
    pub fn code(&self) -> &'static str {
        match self {
            AppError::NotFound { .. } | AppError::NotFoundName { .. } => "not_found",
            AppError::Conflict(_) | AppError::Exists(_) => "conflict",
            AppError::Invalid(_) => "invalid",
            AppError::Pose(_) => "invalid_pose",
            AppError::Config(_) => "invalid_settings",
            AppError::Internal(_) => "internal",
        }
    }

    pub(crate) fn not_found(what: &'static str, id: i64) -> AppError {
        AppError::NotFound { what, id }
    }
}

impl From<StorageError> for AppError {
    fn from(e: StorageError) -> AppError {
        match e {
            StorageError::Conflict(m) => AppError::Conflict(m),
            StorageError::NotFound => AppError::Internal("a stored row vanished".into()),
            other => AppError::Internal(other.to_string()),
        }
    }
}
