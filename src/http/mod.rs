//! The REST adapter: extracts requests, calls the application service ([`crate::app`]) and
//! maps its errors to HTTP once ([`error`]). No business logic lives here.
//!
//! The router and the OpenAPI description come from the same annotations (utoipa), so a route
//! cannot exist without being described; `openapi.yaml` at the repository root is the
//! generated description, committed, and a test fails when it and the code drift apart
//! (regenerate with `nextpose openapi > openapi.yaml`).

mod access;
mod audit;
mod backups;
mod body_rules;
mod cells;
pub mod error;
mod history;
mod imports;
pub(crate) mod middleware;
pub mod pendant;
mod programs;
mod replays;
mod robots;
mod routines;
pub mod strict;
mod system;
mod tokens;

use crate::transport::TransportOptions;
use std::sync::Arc;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::{Method, StatusCode, header};
use tower::ServiceBuilder;
use tower_http::cors::{Any, CorsLayer};
use tower_http::limit::RequestBodyLimitLayer;
use tower_http::timeout::TimeoutLayer;
use utoipa::openapi::security::{Http, HttpAuthScheme, SecurityScheme};
use utoipa::openapi::{OpenApi as OpenApiDoc, SecurityRequirement};
use utoipa::{Modify, OpenApi};
use utoipa_axum::router::OpenApiRouter;

use crate::app::App;
use crate::transport::auth::BearerToken;

#[derive(OpenApi)]
#[openapi(
    info(
        title = "nextpose",
        description = "Teach-pendant prediction service: suggests the next waypoint while an \
                       operator teaches an industrial robot arm. Poses are in mm with unit \
                       quaternions (w, x, y, z). Errors are `{\"error\": {\"code\", \"message\"}}`."
    ),
    tags(
        (name = "cells", description = "Work cells, each with its own model"),
        (name = "programs", description = "Programs of a cell"),
        (name = "history", description = "A program's revisions, diffs and restores"),
        (name = "routines", description = "Ordered routines of a program"),
        (name = "teaching", description = "Waypoints, predictions, undo, finish and feedback"),
        (name = "robots", description = "Arm models for reachability checks"),
        (name = "system", description = "Health, metrics and backups"),
    )
)]
struct ApiDoc;

/// Declares the bearer token on every operation but `/healthz`, with the answers it brings:
/// a server with a token (the bootstrap one or any stored one) answers 401 to a request
/// without a known token and 403 to a token whose role or cells do not allow the operation
/// (and, on a server with none, 403 to an anonymous call of a token route). The token is
/// optional in the spec (`{}` beside `bearer`): a server started without one asks for none.
struct BearerAuth;

/// The only operation that never asks for the token.
const OPEN_PATH: &str = "/healthz";

impl Modify for BearerAuth {
    fn modify(&self, openapi: &mut OpenApiDoc) {
        use utoipa::openapi::{RefOr, ResponseBuilder, content::ContentBuilder};
        let components = openapi.components.get_or_insert_with(Default::default);
        components.add_security_scheme(
            "bearer",
            SecurityScheme::Http(Http::new(HttpAuthScheme::Bearer)),
        );
        let optional_bearer = || {
            vec![
                SecurityRequirement::default(),
                SecurityRequirement::new("bearer", Vec::<String>::new()),
            ]
        };
        openapi.security = Some(optional_bearer());
        let error = |description: &str| {
            RefOr::T(
                ResponseBuilder::new()
                    .description(description)
                    .content(
                        "application/json",
                        ContentBuilder::new()
                            .schema(Some(RefOr::Ref(
                                utoipa::openapi::schema::Ref::from_schema_name("ErrorBody"),
                            )))
                            .build(),
                    )
                    .build(),
            )
        };
        for (path, item) in openapi.paths.paths.iter_mut() {
            if path == OPEN_PATH {
                continue;
            }
            let operations = [
                &mut item.get,
                &mut item.post,
                &mut item.put,
                &mut item.patch,
                &mut item.delete,
            ];
            for operation in operations.into_iter().flatten() {
                operation.security = Some(optional_bearer());
                let responses = &mut operation.responses.responses;
                responses.entry("401".to_string()).or_insert_with(|| {
                    error(
                        "No known token: the server asks for one (it has a bootstrap token or \
                         a stored one) and the request has none, an unknown or a revoked one",
                    )
                });
                responses.entry("403".to_string()).or_insert_with(|| {
                    error("The token's role or cells do not allow this operation")
                });
            }
        }
    }
}

fn api() -> OpenApiRouter<Arc<App>> {
    OpenApiRouter::with_openapi(ApiDoc::openapi())
        .merge(system::router())
        .merge(cells::router())
        .merge(programs::router())
        .merge(history::router())
        .merge(routines::router())
        .merge(robots::router())
        .merge(imports::router())
        .merge(replays::router())
        .merge(backups::router())
        .merge(tokens::router())
        .merge(audit::router())
}

/// The OpenAPI description of every route.
pub fn openapi() -> OpenApiDoc {
    let mut doc = api().split_for_parts().1;
    // After the routes are merged in: it declares the token on each of them.
    BearerAuth.modify(&mut doc);
    body_rules::BodyRules.modify(&mut doc);
    doc
}

/// The service's router with all its layers; every route but `/healthz` and the pendant
/// page's files asks who the caller is and whether it may (`access`); `token` is the
/// bootstrap admin token (`NEXTPOSE_TOKEN`).
pub fn router(app: Arc<App>, options: &TransportOptions, token: Option<BearerToken>) -> Router {
    let (routes, _) = api().split_for_parts();
    let request_id = crate::transport::request_id::REQUEST_ID;
    let mut routes = routes
        .merge(pendant::router())
        .fallback(|| async { error::for_status(StatusCode::NOT_FOUND) })
        .layer(axum::middleware::from_fn_with_state(
            app.metrics().clone(),
            middleware::track,
        ));
    let auth = middleware::Authentication {
        token_required: token.is_some(),
    };
    // Every route but `/healthz` and the page's files: the caller, and whether its role and
    // cells allow the route's operation (`access`).
    routes = routes.layer(axum::middleware::from_fn_with_state(
        access::Gate {
            app: app.clone(),
            bootstrap: token,
        },
        access::authorize,
    ));
    let cors = CorsLayer::new()
        .allow_origin(Any)
        .allow_methods([
            Method::GET,
            Method::POST,
            Method::PATCH,
            Method::DELETE,
            Method::OPTIONS,
        ])
        .allow_headers([
            header::CONTENT_TYPE,
            header::AUTHORIZATION,
            request_id.clone(),
        ])
        .expose_headers([request_id]);
    let routes = routes
        .layer(
            ServiceBuilder::new()
                .layer(cors)
                .layer(axum::middleware::from_fn(middleware::json_errors))
                .layer(TimeoutLayer::with_status_code(
                    StatusCode::REQUEST_TIMEOUT,
                    options.request_timeout,
                ))
                .layer(RequestBodyLimitLayer::new(options.body_limit))
                .layer(DefaultBodyLimit::max(options.body_limit)),
        )
        .layer(axum::Extension(auth))
        .with_state(app);
    crate::transport::request_id::with_request_ids(
        routes,
        crate::transport::request_id::Protocol::Rest,
    )
}
