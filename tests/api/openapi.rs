//! `openapi.yaml` describes the router exactly: it is generated from the same annotations the
//! router is built from, and must equal the committed file; every route it lists answers.

use reqwest::{Method, StatusCode};

use crate::helpers::*;

#[test]
fn committed_openapi_yaml_is_up_to_date() {
    let generated = nextpose::http::openapi().to_yaml().unwrap();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("openapi.yaml");
    let committed = std::fs::read_to_string(&path).expect("openapi.yaml at the repository root");
    assert!(
        committed == generated,
        "openapi.yaml is stale: regenerate it with `cargo run -- openapi > openapi.yaml`"
    );
}

/// Every operation of the spec, by path with ids that do not exist, and whether it is
/// described for each method (the ones it is not must not be served).
fn operations() -> Vec<(Method, String, String, bool)> {
    let spec = nextpose::http::openapi();
    let mut out = Vec::new();
    for (path, item) in &spec.paths.paths {
        let concrete = path
            .replace("{cell_id}", "999")
            .replace("{program_id}", "999")
            .replace("{routine_id}", "999")
            .replace("{prediction_id}", "999")
            .replace("{waypoint_id}", "999")
            .replace("{revision}", "1")
            .replace("{name}", "nobody");
        for (method, described) in [
            (Method::GET, item.get.is_some()),
            (Method::POST, item.post.is_some()),
            (Method::DELETE, item.delete.is_some()),
            (Method::PUT, item.put.is_some()),
            (Method::PATCH, item.patch.is_some()),
        ] {
            out.push((method, path.clone(), concrete.clone(), described));
        }
    }
    out
}

/// The statuses the spec lists for an operation.
fn listed(path: &str, method: &Method) -> Vec<String> {
    let spec: serde_json::Value = serde_json::to_value(nextpose::http::openapi()).unwrap();
    let op = &spec["paths"][path][method.as_str().to_lowercase()];
    op["responses"]
        .as_object()
        .map(|r| r.keys().cloned().collect())
        .unwrap_or_default()
}

async fn call(app: &TestApp, method: &Method, path: &str) -> (StatusCode, String) {
    let mut rb = app
        .client
        .request(method.clone(), app.url(path))
        .header("content-type", "application/json")
        .body("{}");
    if let Some(token) = &app.token {
        rb = rb.bearer_auth(token);
    }
    let r = rb.send().await.unwrap();
    let status = r.status();
    let body: serde_json::Value = r.json().await.unwrap_or_default();
    (
        status,
        body["error"]["code"].as_str().unwrap_or("").to_string(),
    )
}

/// Every operation of the spec is served, and what it answers to a request it cannot satisfy
/// (ids that do not exist, an empty body), on an open server and on one with a token asked
/// without one, with a wrong one and with an operator's, is a status the spec lists for it.
#[tokio::test]
async fn every_described_route_is_served_and_answers_only_what_the_spec_lists() {
    let open = spawn_app().await;
    let mut guarded = spawn_with(nextpose::transport::TransportOptions {
        token: Some("bootstrap-secret".into()),
        ..Default::default()
    })
    .await;
    guarded.token = Some("bootstrap-secret".into());
    let cell = guarded.create_cell("c").await;
    let operator = guarded
        .post_ok(
            "/v1/tokens",
            &serde_json::json!({ "name": "op", "role": "operator", "cells": [cell] }),
            StatusCode::CREATED,
        )
        .await["secret"]
        .as_str()
        .unwrap()
        .to_string();
    let mut seen = 0;
    for (method, path, concrete, described) in operations() {
        let (status, code) = call(&open, &method, &concrete).await;
        if !described {
            assert!(
                status == StatusCode::METHOD_NOT_ALLOWED || code == "route_not_found",
                "{method} {path} is served ({status}) but not described"
            );
            continue;
        }
        seen += 1;
        assert!(
            code != "route_not_found" && status != StatusCode::METHOD_NOT_ALLOWED,
            "{method} {path} is described but not served ({status} {code})"
        );
        assert!(!status.is_server_error(), "{method} {path}: {status}");
        let statuses = listed(&path, &method);
        let mut answers = vec![("open server", status)];
        for token in [None, Some("npt_wrong"), Some(operator.as_str())] {
            guarded.token = token.map(str::to_string);
            answers.push(("guarded server", call(&guarded, &method, &concrete).await.0));
        }
        if path != "/healthz" {
            assert_eq!(
                answers[1].1,
                StatusCode::UNAUTHORIZED,
                "{method} {path}: no token"
            );
            assert_eq!(
                answers[2].1,
                StatusCode::UNAUTHORIZED,
                "{method} {path}: wrong token"
            );
        }
        for (server, status) in answers {
            assert!(
                statuses.contains(&status.as_u16().to_string()),
                "{method} {path} answered {status} on the {server}, but the spec lists only \
                 {statuses:?}"
            );
        }
    }
    assert!(seen >= 50, "only {seen} operations described");
}

/// Every operation but `/healthz` declares the bearer token (optional: a server without a
/// token asks for none) and documents 401 and 403 with the error body.
#[test]
fn every_operation_but_health_declares_the_token_and_its_refusals() {
    let spec: serde_json::Value = serde_json::to_value(nextpose::http::openapi()).unwrap();
    let mut checked = 0;
    for (path, item) in spec["paths"].as_object().unwrap() {
        for (method, op) in item.as_object().unwrap() {
            if path == "/healthz" {
                assert!(op["responses"].get("401").is_none(), "{method} {path}");
                continue;
            }
            checked += 1;
            let security = op["security"]
                .as_array()
                .unwrap_or_else(|| panic!("{method} {path} declares no security"));
            assert!(
                security.iter().any(|s| s.get("bearer").is_some()),
                "{method} {path}: {security:?}"
            );
            for status in ["401", "403"] {
                let schema = &op["responses"][status]["content"]["application/json"]["schema"];
                assert_eq!(
                    schema["$ref"], "#/components/schemas/ErrorBody",
                    "{method} {path} {status}"
                );
            }
        }
    }
    assert!(checked >= 50, "{checked}");
}

/// The spec states what the server enforces: every POST that takes JSON can answer 413 and 415,
/// and the limits the application checks are in the schemas (so a client, or a schema-based
/// fuzzer, knows them). `schemathesis.rs` checks the server against the spec.
#[test]
fn the_spec_states_the_enforced_limits() {
    use nextpose::app::MAX_COMPLETION;
    use nextpose::app::MAX_NAME;
    use nextpose::app::settings::MAX_HORIZON;
    use serde_json::{Value, json};

    let spec: Value = serde_json::to_value(nextpose::http::openapi()).unwrap();
    let mut json_posts = 0;
    for (path, item) in spec["paths"].as_object().unwrap() {
        let Some(post) = item.get("post") else {
            continue;
        };
        if post.get("requestBody").is_none() {
            continue;
        }
        json_posts += 1;
        for status in ["400", "413", "415", "422"] {
            assert!(
                post["responses"].get(status).is_some(),
                "POST {path} does not say it can answer {status}"
            );
        }
    }
    assert_eq!(json_posts, 18, "POST routes taking JSON");

    let schemas = &spec["components"]["schemas"];
    // A body whose fields exclude each other is an `allOf` of its object and the rule.
    let prop = |schema: &str, field: &str| {
        let s = &schemas[schema];
        let object = s["allOf"].get(0).unwrap_or(s);
        object["properties"][field].clone()
    };
    let limit = |v: &Value, key: &str| v.get(key).and_then(Value::as_f64);
    let names = [
        ("CreateCell", "name"),
        ("CreateProgram", "name"),
        ("CreateRoutine", "name"),
        ("NewWaypointDto", "name"),
        ("UploadedFile", "name"),
    ];
    for (schema, field) in names {
        let p = prop(schema, field);
        assert_eq!(limit(&p, "minLength"), Some(1.0), "{schema}.{field}: {p}");
        assert_eq!(
            limit(&p, "maxLength"),
            Some(MAX_NAME as f64),
            "{schema}.{field}: {p}"
        );
    }
    let joints = prop("NewWaypointDto", "joints");
    assert_eq!(limit(&joints, "minItems"), Some(1.0), "{joints}");
    assert_eq!(limit(&joints, "maxItems"), Some(12.0), "{joints}");
    let samples = prop("TrajectoryRequest", "samples");
    assert_eq!(limit(&samples, "minItems"), Some(2.0), "{samples}");
    assert_eq!(
        limit(&samples, "maxItems"),
        Some(nextpose::app::MAX_TRAJECTORY_SAMPLES as f64),
        "{samples}"
    );
    let joints = prop("TrajectorySample", "joints");
    assert_eq!(limit(&joints, "minItems"), Some(1.0), "{joints}");
    assert_eq!(limit(&joints, "maxItems"), Some(12.0), "{joints}");
    // The bound every entering pose's position is checked against; a relative move has none.
    for field in ["x", "y", "z"] {
        let p = prop("PoseValues", field);
        let bound = nextpose::engine::POSITION_LIMIT_MM;
        assert_eq!(
            limit(&p, "minimum"),
            Some(-bound),
            "PoseValues.{field}: {p}"
        );
        assert_eq!(limit(&p, "maximum"), Some(bound), "PoseValues.{field}: {p}");
        let m = prop("RelativeMove", field);
        assert_eq!((m.get("minimum"), m.get("maximum")), (None, None), "{m}");
    }
    let rotation = prop("TrajectorySettings", "rotation_mm_per_rad");
    assert_eq!(
        limit(&rotation, "maximum"),
        Some(nextpose::app::MAX_ROTATION_MM_PER_RAD),
        "{rotation}"
    );
    for schema in ["ImportRequest", "ReplayRequest"] {
        let files = prop(schema, "files");
        assert_eq!(limit(&files, "minItems"), Some(1.0), "{schema}: {files}");
    }
    let replay = |field: &str| prop("ReplayRequest", field);
    assert_eq!(limit(&replay("horizon"), "minimum"), Some(1.0));
    assert_eq!(
        limit(&replay("horizon"), "maximum"),
        Some(MAX_HORIZON as f64)
    );
    assert_eq!(limit(&replay("phi_min"), "minimum"), Some(0.0));
    assert_eq!(limit(&replay("phi_min"), "maximum"), Some(1.0));
    assert_eq!(limit(&replay("delta"), "exclusiveMinimum"), Some(0.0));
    assert_eq!(limit(&replay("delta"), "maximum"), Some(1.0));

    let params = &spec["paths"]["/v1/routines/{routine_id}/prediction"]["get"]["parameters"];
    let param = |name: &str| {
        params
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .map(|p| p["schema"].clone())
            .unwrap_or_else(|| panic!("no parameter {name}"))
    };
    let range = |v: Value| json!([v["minimum"], v["maximum"]]);
    assert_eq!(range(param("k")), json!([1, MAX_COMPLETION]));
    assert_eq!(range(param("horizon")), json!([1, MAX_HORIZON]));
    assert_eq!(range(param("phi_min")), json!([0, 1]));
}
