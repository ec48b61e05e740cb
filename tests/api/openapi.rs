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

#[tokio::test]
async fn every_described_route_is_served() {
    let app = spawn_app().await;
    let spec = nextpose::http::openapi();
    let mut seen = 0;
    for (path, item) in &spec.paths.paths {
        let concrete = path
            .replace("{cell_id}", "999")
            .replace("{program_id}", "999")
            .replace("{routine_id}", "999")
            .replace("{prediction_id}", "999");
        let methods = [
            (Method::GET, item.get.is_some()),
            (Method::POST, item.post.is_some()),
            (Method::DELETE, item.delete.is_some()),
            (Method::PUT, item.put.is_some()),
            (Method::PATCH, item.patch.is_some()),
        ];
        for (method, described) in methods {
            let r = app
                .client
                .request(method.clone(), app.url(&concrete))
                .header("content-type", "application/json")
                .body("{}")
                .send()
                .await
                .unwrap();
            let status = r.status();
            let body: serde_json::Value = r.json().await.unwrap_or_default();
            let code = body["error"]["code"].as_str().unwrap_or("");
            if described {
                seen += 1;
                assert!(
                    code != "route_not_found" && status != StatusCode::METHOD_NOT_ALLOWED,
                    "{method} {path} is described but not served ({status} {code})"
                );
                assert!(!status.is_server_error(), "{method} {path}: {status}");
            } else {
                assert!(
                    status == StatusCode::METHOD_NOT_ALLOWED || code == "route_not_found",
                    "{method} {path} is served ({status}) but not described"
                );
            }
        }
    }
    assert!(seen >= 17, "only {seen} operations described");
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
    let prop = |schema: &str, field: &str| schemas[schema]["properties"][field].clone();
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
