//! Roles and scopes over REST: every route × {no token, operator of the cell, operator of
//! another cell, engineer, admin}. No token is 401; a known token outside its role or cells is
//! 403 and changes nothing (every table of the database, and the cell's model, are the same
//! before and after); an allowed one is not refused. The expected role of each route is
//! written here from the issue, apart from the table in `http::access` it checks.

use reqwest::{Method, StatusCode};
use serde_json::{Value, json};
use sqlx::{Column, Connection, Row};

use crate::helpers::*;
use nextpose::transport::TransportOptions;

const BOOTSTRAP: &str = "bootstrap-s3cret";

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Need {
    Operator,
    Engineer,
    Admin,
}

/// The resources one request may touch, made afresh in a cell of their own.
struct Fixture {
    cell: i64,
    program: i64,
    finished: i64,
    open: i64,
    waypoint: i64,
    prediction: i64,
    /// An operator limited to this cell.
    operator: String,
}

async fn secret(app: &TestApp, name: &str, role: &str, cells: Option<Vec<i64>>) -> String {
    let created = app
        .post_ok(
            "/v1/tokens",
            &json!({ "name": name, "role": role, "cells": cells }),
            StatusCode::CREATED,
        )
        .await;
    created["secret"].as_str().unwrap().to_string()
}

async fn fixture(app: &TestApp, n: usize) -> Fixture {
    let cell = app.create_cell(&format!("cell-{n}")).await;
    let program = app.create_program(cell, "p").await;
    let seam = u_seam([0.0; 3], 0.0);
    let (finished, _) = app.teach_routine(program, &seam).await;
    let open = app.create_routine(program).await;
    let mut last = Value::Null;
    for p in &seam[..3] {
        last = app.append(open, p).await;
    }
    let operator = secret(app, &format!("op-{n}"), "operator", Some(vec![cell])).await;
    Fixture {
        cell,
        program,
        finished,
        open,
        waypoint: last["waypoint"]["id"].as_i64().unwrap(),
        prediction: last["prediction"]["id"].as_i64().unwrap(),
        operator,
    }
}

/// Every route: method, path, body, the least role that may call it, and whether an allowed
/// call must succeed (2xx) with this body, or only not be refused.
fn routes(f: &Fixture) -> Vec<(Method, String, Value, Need, bool)> {
    use Need::*;
    let c = f.cell;
    let p = f.program;
    let r = f.open;
    let done = f.finished;
    let w = f.waypoint;
    let pr = f.prediction;
    let pose = pose([100.0, 0.0, 0.0], [0.0; 3]);
    vec![
        (Method::GET, "/metrics".into(), json!(null), Operator, true),
        (
            Method::GET,
            "/v1/whoami".into(),
            json!(null),
            Operator,
            true,
        ),
        (Method::GET, "/v1/cells".into(), json!(null), Operator, true),
        (
            Method::GET,
            format!("/v1/cells/{c}"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::GET,
            format!("/v1/cells/{c}/stats"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::GET,
            format!("/v1/cells/{c}/frames"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/reach"),
            json!({ "pose": pose }),
            Operator,
            false,
        ),
        (
            Method::GET,
            format!("/v1/cells/{c}/programs"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}/routines"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::GET,
            format!("/v1/routines/{done}"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::GET,
            "/v1/robots".into(),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::GET,
            "/v1/robots/abb_irb140".into(),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::POST,
            "/v1/robots/abb_irb140/placements".into(),
            json!({}),
            Operator,
            false,
        ),
        (
            Method::GET,
            format!("/v1/routines/{r}/prediction"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::POST,
            format!("/v1/predictions/{pr}/feedback"),
            json!({ "verdict": "rejected" }),
            Operator,
            true,
        ),
        (
            Method::POST,
            format!("/v1/routines/{r}/waypoints"),
            json!({ "pose": pose }),
            Operator,
            true,
        ),
        (
            Method::DELETE,
            format!("/v1/routines/{r}/waypoints/last"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::POST,
            format!("/v1/routines/{r}/trajectory"),
            json!({ "samples": [] }),
            Operator,
            false,
        ),
        (
            Method::POST,
            format!("/v1/routines/{r}/finish"),
            json!(null),
            Operator,
            true,
        ),
        (
            Method::POST,
            format!("/v1/programs/{p}/routines"),
            json!({}),
            Operator,
            false,
        ),
        (
            Method::POST,
            "/v1/cells".into(),
            json!({ "name": format!("new-cell-{c}") }),
            Engineer,
            true,
        ),
        (
            Method::PATCH,
            format!("/v1/cells/{c}"),
            json!({ "name": format!("renamed-{c}") }),
            Engineer,
            true,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/rebuild"),
            json!({}),
            Engineer,
            true,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/calibration"),
            json!({ "poses": [] }),
            Engineer,
            false,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/imports"),
            json!({ "files": [] }),
            Engineer,
            false,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/programs"),
            json!({ "name": "q" }),
            Engineer,
            true,
        ),
        (
            Method::PATCH,
            format!("/v1/programs/{p}"),
            json!({ "name": "pp" }),
            Engineer,
            true,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}/export"),
            json!(null),
            Engineer,
            false,
        ),
        (
            Method::POST,
            format!("/v1/programs/{p}/retarget"),
            json!({ "frame": pose, "name": "moved" }),
            Engineer,
            false,
        ),
        (
            Method::PATCH,
            format!("/v1/routines/{done}"),
            json!({ "position": 0 }),
            Engineer,
            false,
        ),
        (
            Method::POST,
            format!("/v1/routines/{done}/retarget"),
            json!({ "frame": pose }),
            Engineer,
            false,
        ),
        (
            Method::DELETE,
            format!("/v1/routines/{done}"),
            json!(null),
            Engineer,
            true,
        ),
        (
            Method::PATCH,
            format!("/v1/waypoints/{w}"),
            json!({ "name": "x" }),
            Engineer,
            false,
        ),
        (
            Method::POST,
            format!("/v1/waypoints/{w}/insert"),
            json!({ "side": "after", "pose": pose }),
            Engineer,
            false,
        ),
        (
            Method::DELETE,
            format!("/v1/waypoints/{w}"),
            json!(null),
            Engineer,
            false,
        ),
        (
            Method::POST,
            "/v1/robots".into(),
            json!({}),
            Engineer,
            false,
        ),
        (
            Method::DELETE,
            "/v1/robots/no_such_robot".into(),
            json!(null),
            Engineer,
            false,
        ),
        (
            Method::POST,
            "/v1/replays".into(),
            json!({ "files": [] }),
            Engineer,
            false,
        ),
        (Method::GET, "/v1/tokens".into(), json!(null), Admin, true),
        (
            Method::POST,
            "/v1/tokens".into(),
            json!({ "name": "another", "role": "operator" }),
            Admin,
            true,
        ),
        (
            Method::DELETE,
            "/v1/tokens/nobody".into(),
            json!(null),
            Admin,
            false,
        ),
        (Method::POST, "/v1/backups".into(), json!({}), Admin, false),
        (
            Method::DELETE,
            format!("/v1/programs/{p}"),
            json!(null),
            Admin,
            true,
        ),
        (
            Method::DELETE,
            format!("/v1/cells/{c}"),
            json!(null),
            Admin,
            true,
        ),
    ]
}

/// Every row of every table, as text, in a stable order.
async fn dump(app: &TestApp) -> Vec<String> {
    let nextpose::server::Database::File(path) = &app.db else {
        panic!("the matrix runs on an SQLite file");
    };
    let mut conn = sqlx::SqliteConnection::connect(&format!("sqlite://{}", path.display()))
        .await
        .unwrap();
    let tables: Vec<(String,)> = sqlx::query_as(
        "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%' \
         ORDER BY name",
    )
    .fetch_all(&mut conn)
    .await
    .unwrap();
    let mut out = Vec::new();
    for (table,) in tables {
        let rows = sqlx::query(sqlx::AssertSqlSafe(format!("SELECT * FROM {table}")))
            .fetch_all(&mut conn)
            .await
            .unwrap();
        for row in rows {
            let mut line = format!("{table}:");
            for (i, col) in row.columns().iter().enumerate() {
                let v = row
                    .try_get::<Option<String>, _>(i)
                    .map(|v| format!("{v:?}"))
                    .or_else(|_| row.try_get::<Option<i64>, _>(i).map(|v| format!("{v:?}")))
                    .or_else(|_| row.try_get::<Option<f64>, _>(i).map(|v| format!("{v:?}")))
                    .or_else(|_| {
                        row.try_get::<Option<Vec<u8>>, _>(i)
                            .map(|v| format!("{v:?}"))
                    })
                    .unwrap_or_else(|e| format!("<{e}>"));
                line.push_str(&format!(" {}={v}", col.name()));
            }
            out.push(line);
        }
        out.sort();
    }
    out
}

async fn send(
    app: &TestApp,
    method: &Method,
    path: &str,
    body: &Value,
    token: Option<&str>,
) -> StatusCode {
    let mut rb = app.client.request(method.clone(), app.url(path));
    if !body.is_null() {
        rb = rb.json(body);
    }
    if let Some(t) = token {
        rb = rb.bearer_auth(t);
    }
    rb.send().await.expect("request").status()
}

#[tokio::test]
async fn every_route_answers_each_role_and_scope_as_specified() {
    if on_postgres() {
        return; // the dump reads the SQLite file
    }
    let mut app = spawn_with(TransportOptions {
        token: Some(BOOTSTRAP.into()),
        ..TransportOptions::default()
    })
    .await;
    app.token = Some(BOOTSTRAP.into());
    let elsewhere = app.create_cell("elsewhere").await;
    let outsider = secret(&app, "op-elsewhere", "operator", Some(vec![elsewhere])).await;
    let engineer = secret(&app, "engineer", "engineer", None).await;
    let admin = secret(&app, "admin", "admin", None).await;

    let count = routes(&fixture(&app, 0).await).len();
    let mut n = 1;
    for i in 0..count {
        // Refused callers first, on one fixture, then each allowed caller on a fresh one.
        let f = fixture(&app, n).await;
        n += 1;
        let (method, path, body, need, must_succeed) = routes(&f)[i].clone();
        let callers: [(&str, Option<&str>, Option<Need>, bool); 5] = [
            ("no token", None, None, false),
            (
                "operator of the cell",
                Some(&f.operator),
                Some(Need::Operator),
                true,
            ),
            (
                "operator of another cell",
                Some(&outsider),
                Some(Need::Operator),
                false,
            ),
            ("engineer", Some(&engineer), Some(Need::Engineer), true),
            ("admin", Some(&admin), Some(Need::Admin), true),
        ];
        // Routes on the service as a whole other than reads are an unscoped caller's.
        let scoped_route = path.contains(&format!("/{}", f.cell))
            || [f.program, f.open, f.finished, f.waypoint, f.prediction]
                .iter()
                .any(|id| path.contains(&format!("/{id}")));
        for (who, token, role, in_scope) in callers {
            let allowed = match role {
                None => false,
                // The operators are the only scoped tokens here; what they may do on the
                // service as a whole is read.
                Some(role) => role >= need && (in_scope || role > Need::Operator || !scoped_route),
            };
            if allowed {
                continue;
            }
            let before = (
                dump(&app).await,
                app.get_ok(&format!("/v1/cells/{}/stats", f.cell)).await,
            );
            let status = send(&app, &method, &path, &body, token).await;
            let want = if token.is_none() {
                StatusCode::UNAUTHORIZED
            } else {
                StatusCode::FORBIDDEN
            };
            assert_eq!(status, want, "{method} {path} as {who}");
            let after = (
                dump(&app).await,
                app.get_ok(&format!("/v1/cells/{}/stats", f.cell)).await,
            );
            assert!(
                before == after,
                "{method} {path} as {who} changed something"
            );
        }
        for (who, token, role, in_scope) in callers {
            let Some(role) = role else { continue };
            if role < need || !(in_scope || role > Need::Operator || !scoped_route) {
                continue;
            }
            let f = fixture(&app, n).await;
            n += 1;
            let token = if who == "operator of the cell" {
                Some(f.operator.as_str())
            } else {
                token
            };
            let (method, path, body, _, _) = routes(&f)[i].clone();
            let status = send(&app, &method, &path, &body, token).await;
            assert!(
                status != StatusCode::UNAUTHORIZED && status != StatusCode::FORBIDDEN,
                "{method} {path} as {who}: {status}"
            );
            if must_succeed {
                assert!(status.is_success(), "{method} {path} as {who}: {status}");
            }
        }
    }
}

#[tokio::test]
async fn a_token_limited_to_some_cells_lists_only_those() {
    let mut app = spawn_with(TransportOptions {
        token: Some(BOOTSTRAP.into()),
        ..TransportOptions::default()
    })
    .await;
    app.token = Some(BOOTSTRAP.into());
    let mine = app.create_cell("mine").await;
    app.create_cell("theirs").await;
    let operator = secret(&app, "op", "operator", Some(vec![mine])).await;
    let engineer = secret(&app, "eng", "engineer", None).await;
    let ids = |v: Value| -> Vec<i64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|c| c["id"].as_i64().unwrap())
            .collect()
    };
    app.token = Some(operator);
    assert_eq!(ids(app.get_ok("/v1/cells").await), vec![mine]);
    let me = app.get_ok("/v1/whoami").await;
    assert_eq!(me["name"], "op");
    assert_eq!(me["role"], "operator");
    assert_eq!(me["cells"], json!([mine]));
    app.token = Some(engineer);
    assert_eq!(ids(app.get_ok("/v1/cells").await).len(), 2);
}
