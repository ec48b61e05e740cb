//! Request ids and tracing, the same for both adapters: every request gets an `x-request-id`
//! (kept when the client sent one), is traced in a span carrying it, and its response returns
//! it (a response header; for gRPC, a response metadata entry).

use axum::Router;
use axum::extract::Request;
use axum::http::{HeaderMap, HeaderName};
use tower::ServiceBuilder;
use tower_http::classify::{GrpcCode, GrpcErrorsAsFailures, SharedClassifier};
use tower_http::request_id::{MakeRequestUuid, PropagateRequestIdLayer, SetRequestIdLayer};
use tower_http::trace::TraceLayer;
use tracing::Span;

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

/// A request's id as the outermost layer set it (`-` if it is not text).
pub(crate) fn request_id(headers: &HeaderMap) -> &str {
    headers
        .get(&REQUEST_ID)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("-")
}

/// The span a request is traced in: method, path and request id.
fn request_span(request: &Request) -> Span {
    let id = request_id(request.headers());
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
