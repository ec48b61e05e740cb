//! What the two adapters (REST in [`crate::http`], gRPC in [`crate::grpc`]) share, so that
//! neither reaches into the other: their options and limits, the bearer token ([`auth`]), and
//! request ids with tracing ([`request_id`]).

pub mod auth;
pub mod request_id;

use std::time::Duration;

/// Limits and options of both adapters (REST and gRPC serve one port with the same body limit
/// and token).
#[derive(Debug, Clone)]
pub struct TransportOptions {
    /// Largest request body accepted (bytes).
    pub body_limit: usize,
    /// Requests taking longer are answered 408.
    pub request_timeout: Duration,
    /// When set, every route but `/healthz` requires `Authorization: Bearer <token>`; an empty
    /// token is refused at start-up ([`BearerToken::from_setting`]).
    pub token: Option<String>,
}

impl Default for TransportOptions {
    fn default() -> Self {
        TransportOptions {
            body_limit: 2 * 1024 * 1024,
            request_timeout: Duration::from_secs(30),
            token: None,
        }
    }
}
