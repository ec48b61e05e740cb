//! The audit trail (`GET /v1/audit`): one entry per request that changed something, newest
//! first, in pages.

use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

/// Which entries to list.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct AuditQuery {
    /// Only changes to this cell.
    #[serde(default, deserialize_with = "super::integral::optional")]
    pub cell_id: Option<i64>,
    /// Only entries at or after this UTC time (RFC 3339, e.g. `2026-12-06T08:00:00Z`).
    #[param(format = DateTime)]
    pub since: Option<String>,
    /// Only entries older than this id: the `next` of the page before.
    #[param(minimum = 1)]
    #[serde(default, deserialize_with = "super::integral::optional")]
    pub before: Option<i64>,
    /// Entries per page, 1 to 1000 (default 100).
    #[param(minimum = 1, maximum = 1000)]
    #[serde(default, deserialize_with = "super::integral::optional")]
    pub limit: Option<u32>,
}

/// A change, as the audit trail keeps it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct AuditEntry {
    /// Increasing with time: a later change has a larger id.
    pub id: i64,
    /// When it was committed (UTC, RFC 3339 with milliseconds).
    pub at: String,
    /// The name of the token that made it (`bootstrap`, `anonymous` or a stored token's),
    /// never its secret.
    pub token: String,
    /// The request's `x-request-id` (as the client sent it, or as the service made it).
    pub request_id: String,
    /// REST: the method and route (`POST /v1/routines/{routine_id}/waypoints`); gRPC: the
    /// method (`/nextpose.v1.Nextpose/AppendWaypoint`).
    pub operation: String,
    /// The resource the request named (`routine 12`), if it named one.
    pub target: Option<String>,
    /// The cell the change was to, if it was to a cell.
    pub cell_id: Option<i64>,
    /// `ok` when the request succeeded; when it failed after a change had committed (a
    /// request of several transactions), its answer: the HTTP status (`500`) or the gRPC code
    /// (`ABORTED`).
    pub outcome: String,
}

/// A page of the audit trail, newest first.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct AuditPage {
    pub entries: Vec<AuditEntry>,
    /// The `before` of the next (older) page; null on the last page.
    pub next: Option<i64>,
}
