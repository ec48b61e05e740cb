//! The body of every error answer of the REST API:
//! `{ "error": { "code": "...", "message": "..." } }`, with the matching HTTP status.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// An error response body.
#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct ErrorBody {
    pub error: ErrorDetail,
}

#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct ErrorDetail {
    /// Stable machine-readable code (`not_found`, `conflict`, `busy` (409: the cell was
    /// written by another instance at the same time, again and again; nothing changed, send it
    /// again), `invalid`, `invalid_pose`, `invalid_settings`, `invalid_trajectory`, `bad_request`, `unprocessable`,
    /// `payload_too_large`, `unsupported_media_type`, `unauthorized`, `route_not_found`,
    /// `method_not_allowed`, `timeout`, `internal`).
    pub code: String,
    pub message: String,
}
