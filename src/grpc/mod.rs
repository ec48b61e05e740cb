//! The gRPC adapter (tonic): the same application service as the REST adapter, on the same
//! port. Handlers ([`service`]) convert messages ([`convert`]), call [`App`] and map its errors
//! once ([`status`]); no business logic lives here. The `Teach` stream is a session that
//! applies commands as they come ([`teach`]); calls are counted and timed ([`track`]).
//!
//! Requests with `content-type: application/grpc*` go to the gRPC router before any REST layer
//! (see [`beside`]), so REST's JSON error bodies, timeouts and body limits never touch gRPC
//! responses. Callers are found from gRPC metadata (`authorization: Bearer …`: the bootstrap
//! token or a stored one, `UNAUTHENTICATED` otherwise), except for the health service, like
//! REST's `/healthz`; each method names its operation and the resource it touches, as REST's
//! routes do, and a caller outside its role or cells is `PERMISSION_DENIED` (`app::access`).
//! Reflection (v1 and v1alpha) and health (`grpc.health.v1`) are served for `grpcurl` and
//! load balancers.

pub mod convert;
pub mod pb;
mod service;
pub mod status;
mod teach;
pub mod track;

use std::convert::Infallible;
use std::pin::Pin;
use std::sync::Arc;

use axum::Router;
use axum::extract::{Request as HttpRequest, State};
use axum::http::header;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response as HttpResponse};
use tower::ServiceExt;

use crate::app::App;
use crate::app::audit::Recorder;
use crate::transport::TransportOptions;
use crate::transport::auth::{BearerToken, identify};
use crate::transport::request_id::request_id;
use crate::transport::request_id::{Protocol, with_request_ids};

use pb::nextpose_server::NextposeServer;
pub use service::Service;
pub use teach::TEACH_BUFFER;

/// The encoded file descriptor set of the API, served by reflection.
pub const FILE_DESCRIPTOR_SET: &[u8] =
    include_bytes!(concat!(env!("OUT_DIR"), "/nextpose_descriptor.bin"));

/// The gRPC router: the API, health and reflection, behind the optional bearer token, with
/// the same request ids and tracing as REST ([`crate::transport::request_id::with_request_ids`])
/// and its own call metrics ([`track`]).
///
/// A request message of the API may be as large as a REST body (`options.body_limit`, 2 MiB by
/// default, instead of tonic's 4 MiB): larger ones are refused with `OUT_OF_RANGE`.
pub async fn router(
    app: Arc<App>,
    options: &TransportOptions,
    token: Option<BearerToken>,
) -> anyhow::Result<Router> {
    let metrics = app.metrics().clone();
    let (health, health_service) = tonic_health::server::health_reporter();
    health.set_serving::<NextposeServer<Service>>().await;
    // Reflection describes the health service too, so that `grpcurl` can call it.
    let reflection = tonic_reflection::server::Builder::configure()
        .register_encoded_file_descriptor_set(FILE_DESCRIPTOR_SET)
        .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
        .build_v1()?;
    let reflection_alpha = tonic_reflection::server::Builder::configure()
        .register_encoded_file_descriptor_set(FILE_DESCRIPTOR_SET)
        .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
        .build_v1alpha()?;
    let app_for_gate = app.clone();
    let api = NextposeServer::new(Service::new(app)).max_decoding_message_size(options.body_limit);
    let mut routes = tonic::service::Routes::new(api)
        .add_service(health_service)
        .add_service(reflection)
        .add_service(reflection_alpha)
        .into_axum_router();
    routes = routes.layer(axum::middleware::from_fn_with_state(
        Gate {
            app: app_for_gate,
            bootstrap: token,
        },
        require_caller,
    ));
    let routes = routes.layer(axum::middleware::from_fn_with_state(metrics, track::track));
    Ok(with_request_ids(routes, Protocol::Grpc))
}

/// What the gate needs: the application and the bootstrap token, if any.
#[derive(Clone)]
struct Gate {
    app: Arc<App>,
    bootstrap: Option<BearerToken>,
}

/// Finds the caller from `authorization: Bearer <token>` metadata on every call but health
/// checks (`UNAUTHENTICATED` without a known token) and hands it to the method in the
/// request's extensions; each method then asks whether the caller may do what it does
/// ([`service`]'s `allow`). Reflection is anyone's who is known.
async fn require_caller(
    State(gate): State<Gate>,
    mut request: HttpRequest,
    next: Next,
) -> HttpResponse {
    if request.uri().path().starts_with("/grpc.health.v1.Health/") {
        return next.run(request).await;
    }
    let given = request
        .headers()
        .get(header::AUTHORIZATION)
        .map(|v| v.as_bytes());
    let caller = match identify(&gate.app, gate.bootstrap.as_ref(), given).await {
        Ok(caller) => caller,
        Err(e) => {
            return status::status(e)
                .into_http::<axum::body::Body>()
                .into_response();
        }
    };
    // A call that may change something is recorded in the audit trail (by its writes, so one
    // that changes nothing leaves no row), then its answer; a `Teach` stream records each
    // command (`teach`).
    let method = request.uri().path().to_string();
    let recorder = changes(&method)
        .then(|| Recorder::new(&caller.name, request_id(request.headers()), &method));
    request.extensions_mut().insert(caller);
    let Some(recorder) = recorder else {
        return next.run(request).await;
    };
    let response = recorder.clone().scope(next.run(request)).await;
    // An error is answered in the headers (trailers-only); a success's status follows the
    // message, in the trailers.
    let code = response
        .headers()
        .get("grpc-status")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<i32>().ok())
        .map_or(tonic::Code::Ok, tonic::Code::from);
    gate.app
        .audit_answer(&recorder, code == tonic::Code::Ok, &code_name(code))
        .await;
    response
}

/// Whether a method of the API may change something (its writes are then audited): not the
/// reads, nor a prediction asked for again (which stores the prediction it offers), nor a
/// `Teach` stream (each of whose commands is recorded on its own).
fn changes(path: &str) -> bool {
    let Some(method) = path.strip_prefix("/nextpose.v1.Nextpose/") else {
        return false;
    };
    !(method.starts_with("Get")
        || method.starts_with("List")
        || matches!(method, "Predict" | "WhoAmI" | "Teach" | "DiffProgram"))
}

/// A status code as the audit trail names it (`OK`, `NOT_FOUND`, …).
pub fn code_name(code: tonic::Code) -> String {
    // `Code`'s Debug is its CamelCase name; the wire's names are upper snake case.
    let camel = format!("{code:?}");
    let mut name = String::new();
    for (i, c) in camel.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            name.push('_');
        }
        name.push(c.to_ascii_uppercase());
    }
    name
}

/// Whether a request is a gRPC call (`content-type: application/grpc`, `application/grpc+proto`…).
pub fn is_grpc<B>(request: &axum::http::Request<B>) -> bool {
    request
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/grpc"))
}

/// One router for both adapters: gRPC calls go to `grpc` before any REST layer sees them,
/// everything else to `rest`.
pub fn beside(rest: Router, grpc: Router) -> Router {
    type Fut = Pin<Box<dyn Future<Output = Result<HttpResponse, Infallible>> + Send>>;
    let dispatch = tower::service_fn(move |request: HttpRequest| -> Fut {
        let target = if is_grpc(&request) {
            grpc.clone()
        } else {
            rest.clone()
        };
        Box::pin(target.oneshot(request))
    });
    Router::new().fallback_service(dispatch)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_named_as_on_the_wire() {
        assert_eq!(code_name(tonic::Code::Ok), "OK");
        assert_eq!(code_name(tonic::Code::NotFound), "NOT_FOUND");
        assert_eq!(
            code_name(tonic::Code::PermissionDenied),
            "PERMISSION_DENIED"
        );
        assert!(changes("/nextpose.v1.Nextpose/AppendWaypoint"));
        assert!(!changes("/nextpose.v1.Nextpose/GetCell"));
        assert!(!changes("/nextpose.v1.Nextpose/Teach"));
        assert!(!changes("/grpc.health.v1.Health/Check"));
    }
}
