//! The one place where application errors become gRPC status codes (the gRPC counterpart of
//! `http::error`). `Teach` error events use the same mapping.

use tonic::{Code, Status};

use crate::app::AppError;

/// The status code of an application error.
///
/// REST answers both a name taken and a state conflict (a finished routine, a second open
/// routine, nothing to undo) with 409; gRPC has a code for each: `ALREADY_EXISTS` and
/// `FAILED_PRECONDITION`.
pub fn code(e: &AppError) -> Code {
    match e {
        AppError::NotFound { .. } | AppError::NotFoundName { .. } => Code::NotFound,
        AppError::Exists(_) => Code::AlreadyExists,
        AppError::Conflict(_) => Code::FailedPrecondition,
        // Changed by another instance at the same time: nothing was done; send it again.
        AppError::Stale(_) => Code::Aborted,
        AppError::Invalid(_)
        | AppError::Import(_)
        | AppError::Pose(_)
        | AppError::Config(_)
        | AppError::Trajectory(_)
        | AppError::SamplePose { .. }
        | AppError::Robot(_) => Code::InvalidArgument,
        AppError::Storage(_) | AppError::Internal(_) => Code::Internal,
    }
}

/// The message a client sees: internal details stay in the server log.
pub fn message(e: &AppError) -> String {
    if code(e) == Code::Internal {
        tracing::error!(error = %e.chain(), "gRPC request failed");
        "internal error; see the server log".to_string()
    } else {
        e.to_string()
    }
}

/// The status for an application error; the service's stable code (`not_found`, `conflict`,
/// …) travels in the `x-error-code` metadata entry.
pub fn status(e: AppError) -> Status {
    let mut s = Status::new(code(&e), message(&e));
    if let Ok(v) = e.code().parse() {
        s.metadata_mut().insert("x-error-code", v);
    }
    s
}

impl From<AppError> for Status {
    fn from(e: AppError) -> Status {
        status(e)
    }
}
