//! Metrics of gRPC calls, the counterpart of REST's `http::middleware::track`: every call is
//! counted by service, method and status code (`nextpose_grpc_requests_total`) and its latency
//! observed (`nextpose_grpc_request_duration_seconds`; for a stream, its whole life).
//!
//! A call's status travels in the response headers when it fails before any message
//! (trailers-only: every error of a unary call, `UNAUTHENTICATED`, `UNIMPLEMENTED`), otherwise
//! in the trailers after the last message. The call is recorded as soon as its status is known:
//! the trailers are recorded when the response body yields them, before they are sent, so a
//! client holding its answer finds the call counted. A body dropped before its trailers (the
//! client went away mid-stream) counts as `CANCELLED`.

use std::sync::Arc;
use std::time::Instant;

use axum::body::Body;
use axum::extract::{Request, State};
use axum::http::HeaderMap;
use axum::middleware::Next;
use axum::response::Response;
use http_body_util::BodyExt;
use tonic::Code;

use crate::telemetry::Metrics;

/// A call being answered; recorded once, at the latest when dropped.
struct Call {
    metrics: Arc<Metrics>,
    /// `(service, method)` from the path `/service/method`.
    name: Option<(String, String)>,
    start: Instant,
    done: bool,
}

impl Call {
    fn finish(&mut self, code: Code) {
        if self.done {
            return;
        }
        self.done = true;
        // Made-up service or method names are answered UNIMPLEMENTED: they do not become
        // label values.
        let (service, method) = match &self.name {
            Some((s, m)) if code != Code::Unimplemented => (s.as_str(), m.as_str()),
            _ => ("unknown", "unknown"),
        };
        self.metrics.record_grpc(
            service,
            method,
            code_name(code),
            self.start.elapsed().as_secs_f64(),
        );
    }
}

impl Drop for Call {
    fn drop(&mut self) {
        self.finish(Code::Cancelled);
    }
}

/// The canonical name of a status code, as in the gRPC specification.
pub fn code_name(code: Code) -> &'static str {
    match code {
        Code::Ok => "OK",
        Code::Cancelled => "CANCELLED",
        Code::Unknown => "UNKNOWN",
        Code::InvalidArgument => "INVALID_ARGUMENT",
        Code::DeadlineExceeded => "DEADLINE_EXCEEDED",
        Code::NotFound => "NOT_FOUND",
        Code::AlreadyExists => "ALREADY_EXISTS",
        Code::PermissionDenied => "PERMISSION_DENIED",
        Code::ResourceExhausted => "RESOURCE_EXHAUSTED",
        Code::FailedPrecondition => "FAILED_PRECONDITION",
        Code::Aborted => "ABORTED",
        Code::OutOfRange => "OUT_OF_RANGE",
        Code::Unimplemented => "UNIMPLEMENTED",
        Code::Internal => "INTERNAL",
        Code::Unavailable => "UNAVAILABLE",
        Code::DataLoss => "DATA_LOSS",
        Code::Unauthenticated => "UNAUTHENTICATED",
    }
}

fn status_in(headers: &HeaderMap) -> Option<Code> {
    headers
        .get("grpc-status")
        .map(|v| Code::from_bytes(v.as_bytes()))
}

/// Counts the call and observes its latency once its status is known.
pub async fn track(State(metrics): State<Arc<Metrics>>, request: Request, next: Next) -> Response {
    let name = request
        .uri()
        .path()
        .strip_prefix('/')
        .and_then(|p| p.split_once('/'))
        .map(|(s, m)| (s.to_string(), m.to_string()));
    let mut call = Call {
        metrics,
        name,
        start: Instant::now(),
        done: false,
    };
    let response = next.run(request).await;
    if let Some(code) = status_in(response.headers()) {
        call.finish(code);
        return response;
    }
    let mut call = Some(call);
    response.map(|body| {
        Body::new(body.map_frame(move |frame| {
            if let Some(trailers) = frame.trailers_ref()
                && let Some(mut c) = call.take()
            {
                c.finish(status_in(trailers).unwrap_or(Code::Unknown));
            }
            frame
        }))
    })
}
