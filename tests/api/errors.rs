//! Every client mistake gets a JSON error with the right status, never a 500.

use std::time::Duration;

use nextpose::server::{Application, Database, ServerSettings};
use nextpose::transport::TransportOptions;
use reqwest::StatusCode;
use serde_json::json;

use crate::helpers::*;

#[tokio::test]
async fn unknown_ids_and_routes_are_404() {
    let app = spawn_app().await;
    for path in [
        "/v1/cells/42",
        "/v1/cells/42/stats",
        "/v1/cells/42/programs",
        "/v1/programs/7",
        "/v1/programs/7/routines",
        "/v1/routines/9",
        "/v1/routines/9/prediction",
    ] {
        expect_error(app.get(path).await, StatusCode::NOT_FOUND, "not_found").await;
    }
    for path in [
        "/v1/cells/42/programs",
        "/v1/programs/7/routines",
        "/v1/routines/9/finish",
        "/v1/cells/42/rebuild",
    ] {
        let r = app.post(path, &json!({"name": "x"})).await;
        expect_error(r, StatusCode::NOT_FOUND, "not_found").await;
    }
    let r = app
        .post(
            "/v1/routines/9/waypoints",
            &json!({"pose": pose([0.0; 3], [0.0; 3])}),
        )
        .await;
    expect_error(r, StatusCode::NOT_FOUND, "not_found").await;
    let r = app.get("/v1/nothing-here").await;
    expect_error(r, StatusCode::NOT_FOUND, "route_not_found").await;
    let r = app.delete("/v1/cells").await;
    expect_error(r, StatusCode::METHOD_NOT_ALLOWED, "method_not_allowed").await;
    let r = app.get("/v1/cells/not-a-number").await;
    expect_error(r, StatusCode::BAD_REQUEST, "bad_request").await;
}

#[tokio::test]
async fn malformed_and_invalid_bodies() {
    let app = spawn_app().await;
    let cell = app.create_cell("errors").await;
    let program = app.create_program(cell, "p").await;
    let routine = app.create_routine(program).await;
    let url = app.url(&format!("/v1/routines/{routine}/waypoints"));

    // Not JSON at all, and JSON without the content type.
    let r = app
        .client
        .post(&url)
        .header("content-type", "application/json")
        .body("{\"pose\": ")
        .send()
        .await
        .unwrap();
    expect_error(r, StatusCode::BAD_REQUEST, "bad_request").await;
    let r = app.client.post(&url).body("{}").send().await.unwrap();
    expect_error(
        r,
        StatusCode::UNSUPPORTED_MEDIA_TYPE,
        "unsupported_media_type",
    )
    .await;

    let good = pose([1.0, 2.0, 3.0], [0.0; 3]);
    let cases = [
        // Unknown field at the top and inside the pose.
        (json!({"pose": good, "colour": "red"}), "unprocessable"),
        (
            json!({"pose": {"x": 1, "y": 2, "z": 3, "qw": 1, "qx": 0, "qy": 0, "qz": 0, "w": 1}}),
            "unprocessable",
        ),
        // Missing field, wrong type.
        (json!({"pose": {"x": 1, "y": 2, "z": 3}}), "unprocessable"),
        (
            json!({"pose": {"x": "1", "y": 2, "z": 3, "qw": 1, "qx": 0, "qy": 0, "qz": 0}}),
            "unprocessable",
        ),
        // A quaternion far from unit length, and the zero quaternion.
        (
            json!({"pose": {"x": 1, "y": 2, "z": 3, "qw": 1.1, "qx": 0, "qy": 0, "qz": 0}}),
            "invalid_pose",
        ),
        (
            json!({"pose": {"x": 1, "y": 2, "z": 3, "qw": 0, "qx": 0, "qy": 0, "qz": 0}}),
            "invalid_pose",
        ),
        // Joints: empty, too many.
        (json!({"pose": good, "joints": []}), "invalid"),
        (json!({"pose": good, "joints": vec![0.0; 13]}), "invalid"),
        (json!({"pose": good, "motion": "teleport"}), "unprocessable"),
        (json!({"pose": good, "name": ""}), "invalid"),
    ];
    for (body, code) in cases {
        let r = app
            .post(&format!("/v1/routines/{routine}/waypoints"), &body)
            .await;
        expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, code).await;
    }
    // Numbers JSON cannot carry (1e999 overflows to infinity) are refused, not stored.
    let r = app
        .client
        .post(&url)
        .header("content-type", "application/json")
        .body(r#"{"pose": {"x": 1e999, "y": 2, "z": 3, "qw": 1, "qx": 0, "qy": 0, "qz": 0}}"#)
        .send()
        .await
        .unwrap();
    assert!(r.status().is_client_error(), "{}", r.status());
    let body: serde_json::Value = r.json().await.unwrap();
    assert!(body["error"]["code"].is_string());

    // A quaternion within 1e-3 of unit norm is normalised and accepted.
    let nearly = json!({"pose": {"x": 1, "y": 2, "z": 3, "qw": 1.0005, "qx": 0, "qy": 0, "qz": 0}});
    let t = app
        .post_ok(
            &format!("/v1/routines/{routine}/waypoints"),
            &nearly,
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(t["waypoint"]["pose"]["qw"], 1.0);
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["waypoints"].as_array().unwrap().len(), 1);

    // Settings and names.
    for body in [
        json!({"name": "c", "settings": {"delta": 0.0}}),
        json!({"name": "c", "settings": {"horizon": 0}}),
        json!({"name": "c", "settings": {"phi_min": 2}}),
        json!({"name": "c", "settings": {"scale": {"enabled": true, "psi_min": 2, "psi_max": 3}}}),
        json!({"name": ""}),
    ] {
        let r = app.post("/v1/cells", &body).await;
        assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY, "{body}");
    }
    let r = app
        .post(
            "/v1/cells",
            &json!({"name": "c", "settings": {"dleta": 0.5}}),
        )
        .await;
    expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "unprocessable").await;
    let r = app.post("/v1/cells", &json!({"name": "errors"})).await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    let r = app
        .post(&format!("/v1/cells/{cell}/programs"), &json!({"name": "p"}))
        .await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    // Query overrides out of range or malformed.
    for q in ["horizon=0", "horizon=51", "phi_min=-1", "k=101"] {
        let r = app
            .get(&format!("/v1/routines/{routine}/prediction?{q}"))
            .await;
        expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    }
    for q in ["horizon=abc", "bogus=1"] {
        let r = app
            .get(&format!("/v1/routines/{routine}/prediction?{q}"))
            .await;
        expect_error(r, StatusCode::BAD_REQUEST, "bad_request").await;
    }
}

#[tokio::test]
async fn oversized_bodies_are_413() {
    let app = spawn_with(TransportOptions {
        body_limit: 4096,
        ..TransportOptions::default()
    })
    .await;
    let big = json!({"name": "x".repeat(10_000)});
    let r = app.post("/v1/cells", &big).await;
    expect_error(r, StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large").await;
    // Streamed without a length: still refused.
    let r = app
        .client
        .post(app.url("/v1/cells"))
        .header("content-type", "application/json")
        .body(reqwest::Body::wrap_stream(futures_stream(
            serde_json::to_vec(&big).unwrap(),
        )))
        .send()
        .await
        .unwrap();
    expect_error(r, StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large").await;
}

fn futures_stream(
    bytes: Vec<u8>,
) -> impl futures_core::Stream<Item = Result<Vec<u8>, std::io::Error>> + Send + 'static {
    tokio_stream::iter(
        bytes
            .chunks(1000)
            .map(|c| Ok(c.to_vec()))
            .collect::<Vec<_>>(),
    )
}

#[tokio::test]
async fn bearer_token_guards_everything_but_healthz() {
    let mut app = spawn_with(TransportOptions {
        token: Some("s3cret".into()),
        request_timeout: Duration::from_secs(30),
        ..TransportOptions::default()
    })
    .await;
    // With the token (the helper sends it), everything works.
    app.create_cell("guarded").await;
    app.token = None;
    assert_eq!(app.get("/healthz").await.status(), StatusCode::OK);
    expect_error(
        app.get("/v1/cells").await,
        StatusCode::UNAUTHORIZED,
        "unauthorized",
    )
    .await;
    expect_error(
        app.get("/metrics").await,
        StatusCode::UNAUTHORIZED,
        "unauthorized",
    )
    .await;
    let r = app
        .client
        .get(app.url("/v1/cells"))
        .bearer_auth("wrong")
        .send()
        .await
        .unwrap();
    expect_error(r, StatusCode::UNAUTHORIZED, "unauthorized").await;
    // The scheme is case-insensitive (RFC 7235); the token and the space after the scheme are
    // not optional.
    for (authorization, status) in [
        ("bearer s3cret", StatusCode::OK),
        ("BEARER s3cret", StatusCode::OK),
        ("Bearer  s3cret", StatusCode::OK),
        ("Bearers3cret", StatusCode::UNAUTHORIZED),
        ("Bearer S3CRET", StatusCode::UNAUTHORIZED),
        ("Basic s3cret", StatusCode::UNAUTHORIZED),
    ] {
        let r = app
            .client
            .get(app.url("/v1/cells"))
            .header("authorization", authorization)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), status, "{authorization}");
    }
    // A browser pendant's CORS preflight is answered without the token.
    let r = app
        .client
        .request(reqwest::Method::OPTIONS, app.url("/v1/cells"))
        .header("origin", "http://pendant.local")
        .header("access-control-request-method", "POST")
        .send()
        .await
        .unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    assert!(r.headers().contains_key("access-control-allow-origin"));
}

/// Settings that would make a cell unusable, names with control characters and joint lists
/// that do not fit the cell's arm are refused up front, and nothing is created.
#[tokio::test]
async fn unusable_settings_control_characters_and_wrong_joint_counts_are_refused() {
    let app = spawn_app().await;
    for (field, value) in [
        ("sigma_t_mm", 1e300),
        ("sigma_t_mm", 1e-300),
        ("sigma_q", 1e300),
        ("sigma_q", 1e-300),
    ] {
        let r = app
            .post(
                "/v1/cells",
                &json!({ "name": "tight", "settings": { field: value } }),
            )
            .await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
        assert!(message.contains(field), "{message}");
    }
    // The name was not taken by any of them.
    let cell = app.create_cell("tight").await;
    let r = app.get(&format!("/v1/cells/{cell}/stats")).await;
    expect(r, StatusCode::OK).await;

    for name in ["nul\u{0}name", "line\nbreak"] {
        let r = app.post("/v1/cells", &json!({ "name": name })).await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
        assert!(message.contains("control characters"), "{message}");
        let r = app
            .post(
                &format!("/v1/cells/{cell}/programs"),
                &json!({ "name": name }),
            )
            .await;
        expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    }
    let cells = app.get_ok("/v1/cells").await;
    assert_eq!(cells.as_array().unwrap().len(), 1);

    // The cell's IRB 140 has six joints: five or seven values are refused, six are kept.
    let program = app.create_program(cell, "p").await;
    let routine = app.create_routine(program).await;
    let p = pose([400.0, 0.0, 300.0], [std::f64::consts::PI, 0.0, 0.0]);
    for n in [1, 5, 7, 12] {
        let r = app
            .post(
                &format!("/v1/routines/{routine}/waypoints"),
                &json!({ "pose": p, "joints": vec![0.1; n] }),
            )
            .await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
        assert!(message.contains("6 values"), "{message}");
    }
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["waypoint_count"], 0);
    let six = [0.1, -0.2, 0.3, 0.0, 0.5, 0.0];
    let t = app
        .post_ok(
            &format!("/v1/routines/{routine}/waypoints"),
            &json!({ "pose": p, "joints": six }),
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(t["waypoint"]["joints"], json!(six));
    assert_eq!(t["waypoint"]["seq"], 1);
}

#[tokio::test]
async fn an_empty_token_is_refused_at_start_up() {
    // An empty token used to turn authentication off without a word.
    for token in ["", "   "] {
        let settings = ServerSettings {
            database: Database::Memory,
            addr: "127.0.0.1:0".into(),
            http: TransportOptions {
                token: Some(token.into()),
                ..TransportOptions::default()
            },
            ..ServerSettings::default()
        };
        let e = Application::build(settings)
            .await
            .err()
            .unwrap_or_else(|| panic!("a server started with the token {token:?}"));
        assert!(e.to_string().contains("empty"), "{e:#}");
    }
    // The same through `nextpose serve` with NEXTPOSE_TOKEN set to "". The database is in a
    // folder that does not exist, so a server that let the token pass stops there (with
    // another message) instead of serving.
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nextpose"))
        .args(["serve", "--addr", "127.0.0.1:0", "--db"])
        .arg(dir.path().join("missing").join("nextpose.db"))
        .env("NEXTPOSE_TOKEN", "")
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "served with an empty token: {stderr}"
    );
    assert!(stderr.contains("NEXTPOSE_TOKEN"), "{stderr}");
}

#[tokio::test]
async fn arrays_are_not_objects_at_any_level() {
    let app = spawn_app().await;
    let cell = app.create_cell("shapes").await;
    let program = app.create_program(cell, "p").await;
    let routine = app.create_routine(program).await;
    let waypoints = format!("/v1/routines/{routine}/waypoints");
    // serde's derive takes an array of a struct's fields in order; the spec says object.
    let cases = [
        ("/v1/cells", json!(["array cell"]), "."),
        (
            "/v1/cells",
            json!({"name": "c", "settings": {"base": [0, 0, 0, 1, 0, 0, 0]}}),
            "settings.base",
        ),
        (
            waypoints.as_str(),
            json!({"pose": [1, 2, 3, 1, 0, 0, 0]}),
            "pose",
        ),
        (
            waypoints.as_str(),
            json!([{"x": 1, "y": 2, "z": 3, "qw": 1, "qx": 0, "qy": 0, "qz": 0}]),
            ".",
        ),
        (
            &format!("/v1/cells/{cell}/imports"),
            json!({"files": [["a.mod", "MODULE A\nENDMODULE"]]}),
            "files[0]",
        ),
        (
            "/v1/replays",
            json!({"files": [["a.mod", "x"]]}),
            "files[0]",
        ),
        (
            "/v1/predictions/1/feedback",
            json!({"verdict": "adjusted", "pose": [1, 2, 3, 1, 0, 0, 0]}),
            "pose",
        ),
    ];
    for (path, body, at) in cases {
        let message = expect_error(
            app.post(path, &body).await,
            StatusCode::UNPROCESSABLE_ENTITY,
            "unprocessable",
        )
        .await;
        let problem = "invalid type: sequence, expected an object";
        let want = match at {
            "." => problem.to_string(),
            _ => format!("{at}: {problem}"),
        };
        assert!(message.contains(&want), "{path} {body}: {message}");
    }
    let cells = app.get_ok("/v1/cells").await;
    assert_eq!(cells.as_array().unwrap().len(), 1, "{cells}");
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["waypoints"], json!([]));

    // Objects still work, and numbers arrive bit-identical (float_roundtrip).
    let text = r#"{"pose": {"x": 0.30000000000000004, "y": 123.45678901234567,
                   "z": 2.2250738585072014e-308, "qw": 1, "qx": 0, "qy": 0, "qz": 0}}"#;
    let r = app
        .client
        .post(app.url(&waypoints))
        .header("content-type", "application/json")
        .body(text)
        .send()
        .await
        .unwrap();
    let taught = expect(r, StatusCode::CREATED).await;
    let p = &taught["waypoint"]["pose"];
    for (k, want) in [
        ("x", 0.30000000000000004_f64),
        ("y", 123.45678901234567),
        ("z", 2.2250738585072014e-308),
    ] {
        assert_eq!(p[k].as_f64().unwrap().to_bits(), want.to_bits(), "{k}: {p}");
    }
}

/// An id in a path is an integer written as a JSON number (the spec's `type: integer`, which
/// JSON Schema reads as any number of integral value): `1`, `1.0` and `1e0` are cell 1; a sign
/// `+`, leading zeros or spaces make a malformed id.
#[tokio::test]
async fn path_ids_are_integers_written_as_json_numbers() {
    let app = spawn_app().await;
    let cell = app.create_cell("one").await;
    assert_eq!(cell, 1);
    for path in [
        "/v1/cells/1",
        "/v1/cells/1.0",
        "/v1/cells/1e0",
        "/v1/cells/10E-1",
    ] {
        assert_eq!(app.get_ok(path).await["id"], 1, "{path}");
    }
    for path in [
        "/v1/cells/01",
        "/v1/cells/+1",
        "/v1/cells/ 1",
        "/v1/cells/1.5",
        "/v1/cells/0x1",
        "/v1/cells/001/stats",
        "/v1/cells/01/programs",
    ] {
        expect_error(app.get(path).await, StatusCode::BAD_REQUEST, "bad_request").await;
    }
    let r = app
        .post("/v1/cells/01/programs", &json!({"name": "p"}))
        .await;
    expect_error(r, StatusCode::BAD_REQUEST, "bad_request").await;
    assert_eq!(app.get_ok("/v1/cells/1/programs").await, json!([]));
    // Negative ids (and -0, which is 0) are well-formed; there are none.
    for path in ["/v1/cells/-1", "/v1/cells/-0"] {
        expect_error(app.get(path).await, StatusCode::NOT_FOUND, "not_found").await;
    }
}

/// Integer query parameters follow the same rule.
#[tokio::test]
async fn integer_query_parameters_may_be_written_with_a_zero_fraction() {
    let app = spawn_app().await;
    let cell = app.create_cell("one").await;
    let all = app.get_ok("/v1/audit").await;
    let written = app
        .get_ok(&format!("/v1/audit?cell_id={cell}.0&limit=1e1"))
        .await;
    assert_eq!(
        written,
        app.get_ok(&format!("/v1/audit?cell_id={cell}&limit=10"))
            .await
    );
    assert!(!all["entries"].as_array().unwrap().is_empty());
    assert!(
        !written["entries"].as_array().unwrap().is_empty(),
        "{written}"
    );
    for query in ["cell_id=1.5", "limit=01", "cell_id=-9223372036854775809"] {
        expect_error(
            app.get(&format!("/v1/audit?{query}")).await,
            StatusCode::BAD_REQUEST,
            "bad_request",
        )
        .await;
    }
}
