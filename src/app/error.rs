//! The application's errors. Adapters (HTTP, gRPC) map them to their status codes once, at the
//! edge; nothing here knows about either.

use crate::engine::lead_through::segment::TrajectoryError;
use crate::engine::{ConfigError, PoseError};
use crate::import::ImportError;
use crate::kinematics::KinematicsError;
use crate::storage::{BackupError, StorageError};

#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// A resource that does not exist.
    #[error("{what} {id} does not exist")]
    NotFound { what: &'static str, id: i64 },
    /// A named resource that does not exist.
    #[error("{what} {name:?} does not exist")]
    NotFoundName { what: &'static str, name: String },
    /// A part of a resource that does not exist, described (a program's revision).
    #[error("{0}")]
    NoSuch(String),
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
    /// A hand-guided trajectory that cannot be segmented (too few or too many samples, times
    /// not increasing, settings out of range), or a sample that cannot be taught (its place
    /// in the request and the problem).
    #[error("invalid trajectory: {0}")]
    Trajectory(#[from] TrajectoryError),
    /// A trajectory sample whose pose is invalid, by its place in the request (from 0).
    #[error("sample {index}: invalid pose: {source}")]
    SamplePose {
        index: usize,
        #[source]
        source: PoseError,
    },
    /// Files of an upload that cannot be imported (syntax, not text, nesting too deep, two
    /// programs of one name), with the file and place.
    #[error("cannot import: {0}")]
    Import(#[from] ImportError),
    /// An uploaded arm model that cannot be used (not six revolute joints, limits or
    /// velocities missing, no closed-form solver fits it), with what is wrong.
    #[error("unusable robot model: {0}")]
    Robot(#[from] KinematicsError),
    /// The cell was written by another instance at the same time, again and again: the
    /// request changed nothing and can be sent again.
    #[error("{0}")]
    Stale(String),
    /// A backup that was not written: the file exists (409), the database is PostgreSQL or in
    /// memory (409 `backup_unsupported`), or the copy failed (ours: 500).
    #[error(transparent)]
    Backup(#[from] BackupError),
    /// The database failed. The storage error is kept as the source, so the edge logs the
    /// whole chain (down to sqlx's) once.
    #[error("the database failed")]
    Storage(#[source] StorageError),
    /// No bearer token, or one the service does not know (never issued, or revoked), while
    /// the service authenticates.
    #[error("a valid bearer token is required")]
    Unauthenticated,
    /// A known token whose role or cells do not allow the operation: nothing was done.
    #[error("{0}")]
    PermissionDenied(String),
    /// A failure of ours (corrupted stored data, a task that died).
    #[error("internal error: {0}")]
    Internal(String),
}

/// What kind of failure an [`AppError`] is, the one classification both adapters map to their
/// status codes (HTTP in `http::error`, gRPC in `grpc::status`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The resource does not exist.
    NotFound,
    /// The name of a resource being created is taken.
    Exists,
    /// The request conflicts with the resource's state.
    Conflict,
    /// Written by another instance at the same time: nothing was done; send it again.
    Stale,
    /// The client's input cannot be used.
    Invalid,
    /// No valid token (401, `UNAUTHENTICATED`).
    Unauthenticated,
    /// A known token not allowed the operation (403, `PERMISSION_DENIED`).
    PermissionDenied,
    /// A failure of ours or of the database.
    Internal,
}

impl AppError {
    /// What kind of failure this is, for the adapters' status codes.
    pub fn kind(&self) -> ErrorKind {
        match self {
            AppError::NotFound { .. } | AppError::NotFoundName { .. } | AppError::NoSuch(_) => {
                ErrorKind::NotFound
            }
            AppError::Exists(_) => ErrorKind::Exists,
            AppError::Conflict(_) => ErrorKind::Conflict,
            AppError::Unauthenticated => ErrorKind::Unauthenticated,
            AppError::PermissionDenied(_) => ErrorKind::PermissionDenied,
            AppError::Stale(_) => ErrorKind::Stale,
            AppError::Invalid(_)
            | AppError::Import(_)
            | AppError::Pose(_)
            | AppError::Config(_)
            | AppError::Trajectory(_)
            | AppError::SamplePose { .. }
            | AppError::Robot(_) => ErrorKind::Invalid,
            AppError::Backup(e) => match e {
                BackupError::Exists(_) => ErrorKind::Exists,
                BackupError::Postgres | BackupError::InMemory => ErrorKind::Conflict,
                BackupError::NoDatabase(_)
                | BackupError::BadPath(_)
                | BackupError::Corrupt(_)
                | BackupError::Io { .. }
                | BackupError::Database(_) => ErrorKind::Internal,
            },
            AppError::Storage(_) | AppError::Internal(_) => ErrorKind::Internal,
        }
    }

    /// A short stable code for API clients.
    pub fn code(&self) -> &'static str {
        match self {
            AppError::NotFound { .. } | AppError::NotFoundName { .. } | AppError::NoSuch(_) => {
                "not_found"
            }
            AppError::Conflict(_) | AppError::Exists(_) => "conflict",
            AppError::Stale(_) => "busy",
            AppError::Unauthenticated => "unauthorized",
            AppError::PermissionDenied(_) => "forbidden",
            AppError::Invalid(_) | AppError::Import(_) => "invalid",
            AppError::Pose(_) => "invalid_pose",
            AppError::Config(_) | AppError::Trajectory(TrajectoryError::Settings(_)) => {
                "invalid_settings"
            }
            AppError::Trajectory(_) => "invalid_trajectory",
            AppError::SamplePose { .. } => "invalid_pose",
            AppError::Robot(_) => "invalid_robot",
            AppError::Backup(BackupError::Exists(_)) => "conflict",
            AppError::Backup(BackupError::Postgres | BackupError::InMemory) => "backup_unsupported",
            AppError::Backup(_) | AppError::Storage(_) | AppError::Internal(_) => "internal",
        }
    }

    /// The error and every source under it, for the log: `a: b: c`.
    pub fn chain(&self) -> String {
        let mut out = self.to_string();
        let mut source = std::error::Error::source(self);
        while let Some(e) = source {
            out.push_str(": ");
            out.push_str(&e.to_string());
            source = e.source();
        }
        out
    }

    pub(crate) fn not_found(what: &'static str, id: i64) -> AppError {
        AppError::NotFound { what, id }
    }
}

impl From<StorageError> for AppError {
    fn from(e: StorageError) -> AppError {
        match e {
            StorageError::Conflict(m) => AppError::Conflict(m),
            e @ StorageError::Stale { .. } => AppError::Stale(e.to_string()),
            other => AppError::Storage(other),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A database failure keeps the storage error as its typed source (it was flattened into
    /// a string), and the log line carries the whole chain.
    #[test]
    fn database_failures_keep_their_source() {
        let e = AppError::from(StorageError::Database(sqlx::Error::PoolClosed));
        let source = std::error::Error::source(&e).expect("a source");
        assert!(source.downcast_ref::<StorageError>().is_some());
        assert_eq!(e.code(), "internal");
        let chain = e.chain();
        assert!(
            chain.starts_with("the database failed: database error: "),
            "{chain}"
        );
        assert!(
            chain.contains(&sqlx::Error::PoolClosed.to_string()),
            "{chain}"
        );
        // A name taken stays a conflict the client can act on.
        let taken = AppError::from(StorageError::Conflict("UNIQUE".into()));
        assert!(matches!(taken, AppError::Conflict(_)));
    }
}
