//! Operations: whether the service is up (`/healthz`).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

#[derive(Debug, Serialize, Deserialize, ToSchema)]
pub struct Health {
    /// `ok`
    pub status: String,
    /// Whether the other routes want a bearer token: the service has a bootstrap token
    /// (`NEXTPOSE_TOKEN`) or a stored one not revoked (a page asks for it before calling them).
    pub token_required: bool,
}
