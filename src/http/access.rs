//! Who may call which route: every route's [`Action`] and the resource its path names
//! ([`Scope`]), in one table ([`operation`]), and the middleware that finds the caller from
//! `Authorization: Bearer …` and asks the application ([`App::authorize`]) before the handler
//! runs, so a refused request changes nothing. The policy itself is `app::access`'s.

use std::sync::Arc;

use axum::RequestPartsExt;
use axum::extract::{MatchedPath, RawPathParams, Request, State};
use axum::http::{HeaderValue, Method, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::error::ApiError;
use crate::app::audit::Recorder;
use crate::app::{Action, App, AppError, Scope};
use crate::transport::auth::{BearerToken, identify};
use crate::transport::request_id::request_id;

/// What the middleware needs: the application and the bootstrap token, if any.
#[derive(Clone)]
pub struct Gate {
    pub app: Arc<App>,
    pub bootstrap: Option<BearerToken>,
}

/// The action a route performs and the resource it touches. A route missing here would be
/// an admin's alone (the tests check that every route is here).
pub fn operation(method: &Method, route: &str, id: Option<i64>) -> Option<(Action, Scope)> {
    use Action::*;
    let on = |scope: fn(i64) -> Scope| id.map_or(Scope::Service, scope);
    let cell = on(Scope::Cell);
    let program = on(Scope::Program);
    let routine = on(Scope::Routine);
    let waypoint = on(Scope::Waypoint);
    let prediction = on(Scope::Prediction);
    let service = Scope::Service;
    let m = |want: Method| *method == want;
    Some(match route {
        "/metrics" | "/v1/whoami" if m(Method::GET) => (Read, service),
        "/v1/audit" if m(Method::GET) => (Inspect, service),
        "/v1/backups" if m(Method::POST) => (Administer, service),
        "/v1/tokens" if m(Method::GET) || m(Method::POST) => (ManageTokens, service),
        "/v1/tokens/{name}" if m(Method::DELETE) => (ManageTokens, service),
        "/v1/cells" if m(Method::GET) => (Read, service),
        "/v1/cells" if m(Method::POST) => (Edit, service),
        "/v1/cells/{cell_id}" if m(Method::GET) => (Read, cell),
        "/v1/cells/{cell_id}" if m(Method::PATCH) => (Edit, cell),
        "/v1/cells/{cell_id}" if m(Method::DELETE) => (Delete, cell),
        "/v1/cells/{cell_id}/calibration" | "/v1/cells/{cell_id}/rebuild" if m(Method::POST) => {
            (Edit, cell)
        }
        "/v1/cells/{cell_id}/imports" if m(Method::POST) => (Edit, cell),
        "/v1/cells/{cell_id}/frames" | "/v1/cells/{cell_id}/stats" if m(Method::GET) => {
            (Read, cell)
        }
        "/v1/cells/{cell_id}/reach" if m(Method::POST) => (Read, cell),
        "/v1/cells/{cell_id}/programs" if m(Method::GET) => (Read, cell),
        "/v1/cells/{cell_id}/programs" if m(Method::POST) => (Edit, cell),
        "/v1/predictions/{prediction_id}/feedback" if m(Method::POST) => (Teach, prediction),
        "/v1/programs/{program_id}" if m(Method::GET) => (Read, program),
        "/v1/programs/{program_id}" if m(Method::PATCH) => (Edit, program),
        "/v1/programs/{program_id}" if m(Method::DELETE) => (Delete, program),
        "/v1/programs/{program_id}/export" if m(Method::GET) => (Edit, program),
        "/v1/programs/{program_id}/history"
        | "/v1/programs/{program_id}/history/{revision}"
        | "/v1/programs/{program_id}/diff"
            if m(Method::GET) =>
        {
            (Read, program)
        }
        "/v1/programs/{program_id}/restore" if m(Method::POST) => (Edit, program),
        "/v1/programs/{program_id}/retarget" if m(Method::POST) => (Edit, program),
        "/v1/programs/{program_id}/routines" if m(Method::GET) => (Read, program),
        // Starting a routine is part of teaching.
        "/v1/programs/{program_id}/routines" if m(Method::POST) => (Teach, program),
        "/v1/replays" if m(Method::POST) => (Edit, service),
        "/v1/robots" | "/v1/robots/{name}" if m(Method::GET) => (Read, service),
        "/v1/robots" if m(Method::POST) => (Edit, service),
        "/v1/robots/{name}" if m(Method::DELETE) => (Edit, service),
        "/v1/robots/{name}/placements" if m(Method::POST) => (Read, service),
        "/v1/routines/{routine_id}" if m(Method::GET) => (Read, routine),
        "/v1/routines/{routine_id}" if m(Method::PATCH) || m(Method::DELETE) => (Edit, routine),
        "/v1/routines/{routine_id}/finish"
        | "/v1/routines/{routine_id}/trajectory"
        | "/v1/routines/{routine_id}/waypoints"
            if m(Method::POST) =>
        {
            (Teach, routine)
        }
        "/v1/routines/{routine_id}/waypoints/last" if m(Method::DELETE) => (Teach, routine),
        "/v1/routines/{routine_id}/prediction" if m(Method::GET) => (Teach, routine),
        "/v1/routines/{routine_id}/retarget" if m(Method::POST) => (Edit, routine),
        "/v1/waypoints/{waypoint_id}" if m(Method::PATCH) || m(Method::DELETE) => (Edit, waypoint),
        "/v1/waypoints/{waypoint_id}/insert" if m(Method::POST) => (Edit, waypoint),
        _ => return None,
    })
}

/// Finds the caller and checks the route's operation before the handler runs; the handler
/// finds the [`Caller`](crate::app::Caller) in the request's extensions. `/healthz` and the pendant page's files
/// are open (the page asks for the token and sends it on its API calls).
pub async fn authorize(State(gate): State<Gate>, request: Request, next: Next) -> Response {
    let (mut parts, body) = request.into_parts();
    let params = parts.extract::<RawPathParams>().await.ok();
    let mut request = Request::from_parts(parts, body);
    let path = request.uri().path();
    if path == "/healthz" || super::pendant::is_page(path) {
        return next.run(request).await;
    }
    let given = request
        .headers()
        .get(header::AUTHORIZATION)
        .map(HeaderValue::as_bytes);
    let caller = match identify(&gate.app, gate.bootstrap.as_ref(), given).await {
        Ok(caller) => caller,
        Err(e) => return refusal(e),
    };
    let route = request
        .extensions()
        .get::<MatchedPath>()
        .map(|p| p.as_str().to_string());
    // The one id a resource's path names; a malformed one is the handler's 400 to give.
    let id = params
        .as_ref()
        .and_then(|p| p.iter().next())
        .and_then(|(_, v)| v.parse::<i64>().ok());
    let (action, scope) = match &route {
        Some(route) => {
            operation(request.method(), route, id).unwrap_or((Action::Administer, Scope::Service))
        }
        // No such route: the 404 (or 405) is anyone's to see who may read.
        None => (Action::Read, Scope::Service),
    };
    if let Err(e) = gate.app.authorize(&caller, action, scope).await {
        return refusal(e);
    }
    // A request that may change something is recorded in the audit trail (by its writes,
    // so one that changes nothing leaves no row), then its answer.
    let recorder = (request.method() != Method::GET).then(|| {
        let operation = format!(
            "{} {}",
            request.method(),
            route.as_deref().unwrap_or(request.uri().path())
        );
        let recorder = Recorder::new(&caller.name, request_id(request.headers()), &operation);
        if scope != Scope::Service {
            recorder.name_target(scope.to_string());
        }
        recorder
    });
    request.extensions_mut().insert(caller);
    let Some(recorder) = recorder else {
        return next.run(request).await;
    };
    let response = recorder.clone().scope(next.run(request)).await;
    gate.app
        .audit_answer(
            &recorder,
            response.status().is_success(),
            response.status().as_str(),
        )
        .await;
    response
}

fn refusal(e: AppError) -> Response {
    let unauthenticated = matches!(e, AppError::Unauthenticated);
    let mut response = ApiError::from(e).into_response();
    if unauthenticated {
        response
            .headers_mut()
            .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
    }
    response
}
