//! The one place where application errors become gRPC status codes (the gRPC counterpart of
//! `http::error`). `Teach` error events use the same mapping.

use tonic::{Code, Status};

use crate::app::{AppError, ErrorKind};

/// The status code of an application error.
///
/// REST answers both a name taken and a state conflict (a finished routine, a second open
/// routine, nothing to undo) with 409; gRPC has a code for each: `ALREADY_EXISTS` and
/// `FAILED_PRECONDITION`.
pub fn code(e: &AppError) -> Code {
    match e.kind() {
        ErrorKind::NotFound => Code::NotFound,
        ErrorKind::Exists => Code::AlreadyExists,
        ErrorKind::Conflict => Code::FailedPrecondition,
        ErrorKind::Stale => Code::Aborted,
        ErrorKind::Invalid => Code::InvalidArgument,
        ErrorKind::Unauthenticated => Code::Unauthenticated,
        ErrorKind::PermissionDenied => Code::PermissionDenied,
        ErrorKind::Internal => Code::Internal,
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
