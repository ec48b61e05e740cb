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
