//! Cross-cutting request handling: request ids and tracing (shared with the gRPC adapter),
//! bearer-token check, request metrics, and JSON bodies for errors produced outside the
//! handlers (timeouts, body limits, unknown routes).

use std::sync::Arc;
use std::time::Instant;

use axum::Router;
use axum::body::Body;
use axum::extract::{MatchedPath, Request, State};
use axum::http::{HeaderName, HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use tower::ServiceBuilder;
use tower_http::classify::{GrpcCode, GrpcErrorsAsFailures, SharedClassifier};
use tower_http::request_id::{MakeRequestUuid, PropagateRequestIdLayer, SetRequestIdLayer};
use tower_http::trace::TraceLayer;
use tracing::Span;

use super::error::for_status;
use crate::auth::BearerToken;
use crate::telemetry::Metrics;

/// The header carrying a request's id (for gRPC: the metadata entry).
pub(crate) const REQUEST_ID: HeaderName = HeaderName::from_static("x-request-id");

/// The protocol a router speaks, which decides what the trace log reports as a failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Protocol {
    /// Server errors (5xx) are failures.
    Rest,
    /// Server-side status codes are failures; the client's own (INVALID_ARGUMENT, NOT_FOUND,
    /// ALREADY_EXISTS, FAILED_PRECONDITION, UNAUTHENTICATED, CANCELLED, …) are not, as
    /// REST's 4xx are not.
    Grpc,
}

/// The span a request is traced in: method, path and request id.
fn request_span(request: &Request) -> Span {
    let id = request
        .headers()
        .get(&REQUEST_ID)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("-");
    tracing::info_span!("request", method = %request.method(), uri = %request.uri(), request_id = %id)
}

/// The outermost layers of both adapters: every request gets an `x-request-id` (kept when the
/// client sent one), is traced in a span carrying it, and its response returns it (a response
/// header; for gRPC, a response metadata entry).
pub(crate) fn with_request_ids(router: Router, protocol: Protocol) -> Router {
    let set = SetRequestIdLayer::new(REQUEST_ID, MakeRequestUuid);
    let propagate = PropagateRequestIdLayer::new(REQUEST_ID);
    match protocol {
        Protocol::Rest => router.layer(
            ServiceBuilder::new()
                .layer(set)
                .layer(TraceLayer::new_for_http().make_span_with(request_span))
                .layer(propagate),
        ),
        Protocol::Grpc => {
            let failures = [
                GrpcCode::Cancelled,
                GrpcCode::InvalidArgument,
                GrpcCode::NotFound,
                GrpcCode::AlreadyExists,
                GrpcCode::PermissionDenied,
                GrpcCode::FailedPrecondition,
                GrpcCode::OutOfRange,
                GrpcCode::Unimplemented,
                GrpcCode::Unauthenticated,
            ]
            .into_iter()
            .fold(
                GrpcErrorsAsFailures::new(),
                GrpcErrorsAsFailures::with_success,
            );
            router.layer(
                ServiceBuilder::new()
                    .layer(set)
                    .layer(
                        TraceLayer::new(SharedClassifier::new(failures))
                            .make_span_with(request_span),
                    )
                    .layer(propagate),
            )
        }
    }
}

/// Requires `Authorization: Bearer <token>` on everything but `/healthz` (and CORS
/// preflights, which the CORS layer answers before this runs).
pub async fn require_token(
    State(token): State<BearerToken>,
    request: Request,
    next: Next,
) -> Response {
    if request.uri().path() == "/healthz" {
        return next.run(request).await;
    }
    let given = request
        .headers()
        .get(header::AUTHORIZATION)
        .map(HeaderValue::as_bytes);
    if token.admits(given) {
        return next.run(request).await;
    }
    let mut response = for_status(StatusCode::UNAUTHORIZED).into_response();
    response
        .headers_mut()
        .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
    response
}

/// Counts requests and observes their latency by route template.
pub async fn track(State(metrics): State<Arc<Metrics>>, request: Request, next: Next) -> Response {
    let start = Instant::now();
    let method = request.method().to_string();
    let route = request
        .extensions()
        .get::<MatchedPath>()
        .map(|p| p.as_str().to_string())
        .unwrap_or_else(|| "unmatched".to_string());
    let response = next.run(request).await;
    metrics.record_request(
        &method,
        &route,
        response.status().as_u16(),
        start.elapsed().as_secs_f64(),
    );
    response
}

/// Gives error responses that carry no JSON body (from tower layers or axum's own 404/405)
/// the service's error shape.
pub async fn json_errors(request: Request, next: Next) -> Response {
    let response = next.run(request).await;
    let status = response.status();
    if !(status.is_client_error() || status.is_server_error()) {
        return response;
    }
    let is_json = response
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/json"));
    if is_json {
        return response;
    }
    let (mut parts, _) = response.into_parts();
    let fresh = for_status(status).into_response();
    let (fresh_parts, body) = fresh.into_parts();
    parts.headers.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/json"),
    );
    parts.headers.remove(header::CONTENT_LENGTH);
    drop(fresh_parts);
    Response::from_parts(parts, Body::new(body))
}
