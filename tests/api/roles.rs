//! Roles and scopes over REST: every route × {no token, operator of the cell, operator of
//! another cell, engineer, admin}. No token is 401; a known token outside its role or cells is
//! 403 and changes nothing (every table of the database, and the cell's model, are the same
//! before and after); an allowed one succeeds (on PostgreSQL a backup is refused as
//! unsupported). The expected role of each route is written here from the issue, apart from
//! the table in `http::access` it checks.

use reqwest::{Method, StatusCode};
use serde_json::{Value, json};
use sqlx::{Column, Connection, Row};

use crate::helpers::*;
use nextpose::transport::TransportOptions;

pub(crate) const BOOTSTRAP: &str = "bootstrap-s3cret";

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Need {
    Operator,
    Engineer,
    Admin,
}

/// The resources one request may touch, made afresh in a cell of their own.
pub(crate) struct Fixture {
    pub cell: i64,
    pub program: i64,
    pub finished: i64,
    pub open: i64,
    pub waypoint: i64,
    pub prediction: i64,
    /// An operator limited to this cell.
    pub operator: String,
}

pub(crate) async fn secret(
    app: &TestApp,
    name: &str,
    role: &str,
    cells: Option<Vec<i64>>,
) -> String {
    let created = app
        .post_ok(
            "/v1/tokens",
            &json!({ "name": name, "role": role, "cells": cells }),
            StatusCode::CREATED,
        )
        .await;
    created["secret"].as_str().unwrap().to_string()
}

pub(crate) async fn fixture(app: &TestApp, n: usize) -> Fixture {
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

/// Every route: method, path, a body with which an allowed call succeeds (once [`prepare`]d),
/// and the least role that may call it; `n` makes names unique.
fn routes(f: &Fixture, n: usize) -> Vec<(Method, String, Value, Need)> {
    use Need::*;
    let c = f.cell;
    let p = f.program;
    let r = f.open;
    let done = f.finished;
    let w = f.waypoint;
    let pr = f.prediction;
    let pose = pose([100.0, 0.0, 0.0], [0.0; 3]);
    let far = crate::helpers::pose([400.0, 0.0, 400.0], [0.0; 3]);
    let pose3 = crate::helpers::pose([50.0, 50.0, 0.0], [0.0; 3]);
    let samples: Vec<Value> = (0..10)
        .map(|i| {
            let at = crate::helpers::pose([300.0 + 10.0 * f64::from(i), 0.0, 0.0], [0.0; 3]);
            json!({ "t": f64::from(i) * 0.1, "pose": at })
        })
        .collect();
    let module = json!({ "name": "one.mod", "content": MODULE });
    let urdf = urdf("ur5e");
    vec![
        (Method::GET, "/metrics".into(), json!(null), Operator),
        (Method::GET, "/v1/whoami".into(), json!(null), Operator),
        (Method::GET, "/v1/cells".into(), json!(null), Operator),
        (Method::GET, format!("/v1/cells/{c}"), json!(null), Operator),
        (
            Method::GET,
            format!("/v1/cells/{c}/stats"),
            json!(null),
            Operator,
        ),
        (
            Method::GET,
            format!("/v1/cells/{c}/frames"),
            json!(null),
            Operator,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/reach"),
            json!({ "pose": pose }),
            Operator,
        ),
        (
            Method::GET,
            format!("/v1/cells/{c}/programs"),
            json!(null),
            Operator,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}"),
            json!(null),
            Operator,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}/routines"),
            json!(null),
            Operator,
        ),
        (
            Method::GET,
            format!("/v1/routines/{done}"),
            json!(null),
            Operator,
        ),
        (Method::GET, "/v1/robots".into(), json!(null), Operator),
        (
            Method::GET,
            "/v1/robots/abb_irb140".into(),
            json!(null),
            Operator,
        ),
        (
            Method::POST,
            "/v1/robots/abb_irb140/placements".into(),
            json!({
                "targets": [far], "mounting": "floor", "keep": 1, "evaluations": 100, "seed": 1
            }),
            Operator,
        ),
        (
            Method::GET,
            format!("/v1/routines/{r}/prediction"),
            json!(null),
            Operator,
        ),
        (
            Method::POST,
            format!("/v1/predictions/{pr}/feedback"),
            json!({ "verdict": "rejected" }),
            Operator,
        ),
        (
            Method::POST,
            format!("/v1/routines/{r}/waypoints"),
            json!({ "pose": pose }),
            Operator,
        ),
        (
            Method::DELETE,
            format!("/v1/routines/{r}/waypoints/last"),
            json!(null),
            Operator,
        ),
        (
            Method::POST,
            format!("/v1/routines/{r}/trajectory"),
            json!({ "samples": samples, "preview": true }),
            Operator,
        ),
        (
            Method::POST,
            format!("/v1/routines/{r}/finish"),
            json!(null),
            Operator,
        ),
        (
            Method::POST,
            format!("/v1/programs/{p}/routines"),
            json!({}),
            Operator,
        ),
        (
            Method::POST,
            "/v1/cells".into(),
            json!({ "name": format!("new-cell-{n}") }),
            Engineer,
        ),
        (
            Method::PATCH,
            format!("/v1/cells/{c}"),
            json!({ "name": format!("renamed-{n}") }),
            Engineer,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/rebuild"),
            json!({}),
            Engineer,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/calibration"),
            json!({ "poses": [
                crate::helpers::pose([0.0; 3], [0.0; 3]),
                crate::helpers::pose([1.0, 0.0, 0.0], [0.0; 3]),
                crate::helpers::pose([2.0, 0.0, 0.0], [0.0; 3]),
            ] }),
            Engineer,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/imports"),
            json!({ "files": [module] }),
            Engineer,
        ),
        (
            Method::POST,
            format!("/v1/cells/{c}/programs"),
            json!({ "name": format!("q-{n}") }),
            Engineer,
        ),
        (
            Method::PATCH,
            format!("/v1/programs/{p}"),
            json!({ "name": format!("pp-{n}") }),
            Engineer,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}/export?format=rapid"),
            json!(null),
            Engineer,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}/history"),
            json!(null),
            Operator,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}/history/1"),
            json!(null),
            Operator,
        ),
        (
            Method::GET,
            format!("/v1/programs/{p}/diff?from=0"),
            json!(null),
            Operator,
        ),
        (
            Method::POST,
            format!("/v1/programs/{p}/restore"),
            json!({ "revision": 1 }),
            Engineer,
        ),
        (
            Method::POST,
            format!("/v1/programs/{p}/retarget"),
            json!({ "frame": pose, "name": format!("moved-{n}") }),
            Engineer,
        ),
        (
            Method::PATCH,
            format!("/v1/routines/{done}"),
            json!({ "name": format!("r-{n}") }),
            Engineer,
        ),
        (
            Method::POST,
            format!("/v1/routines/{done}/retarget"),
            json!({ "frame": pose }),
            Engineer,
        ),
        (
            Method::DELETE,
            format!("/v1/routines/{done}"),
            json!(null),
            Engineer,
        ),
        (
            Method::PATCH,
            format!("/v1/waypoints/{w}"),
            json!({ "name": "x" }),
            Engineer,
        ),
        (
            Method::POST,
            format!("/v1/waypoints/{w}/insert"),
            json!({ "side": "after", "waypoint": { "pose": pose3 } }),
            Engineer,
        ),
        (
            Method::DELETE,
            format!("/v1/waypoints/{w}"),
            json!(null),
            Engineer,
        ),
        (
            Method::POST,
            "/v1/robots".into(),
            json!({ "name": format!("arm_{n}"), "urdf": urdf }),
            Engineer,
        ),
        (
            Method::DELETE,
            format!("/v1/robots/doomed_{n}"),
            json!(null),
            Engineer,
        ),
        (
            Method::POST,
            "/v1/replays".into(),
            json!({ "files": [module] }),
            Engineer,
        ),
        (
            Method::GET,
            format!("/v1/audit?cell_id={c}&limit=5"),
            json!(null),
            Engineer,
        ),
        (Method::GET, "/v1/tokens".into(), json!(null), Admin),
        (
            Method::POST,
            "/v1/tokens".into(),
            json!({ "name": format!("another-{n}"), "role": "operator" }),
            Admin,
        ),
        (
            Method::DELETE,
            format!("/v1/tokens/revoked-{n}"),
            json!(null),
            Admin,
        ),
        (
            Method::POST,
            "/v1/backups".into(),
            json!({ "name": format!("copy-{n}.db") }),
            Admin,
        ),
        (
            Method::DELETE,
            format!("/v1/programs/{p}"),
            json!(null),
            Admin,
        ),
        (Method::DELETE, format!("/v1/cells/{c}"), json!(null), Admin),
    ]
}

/// A RAPID module of one move, to import and replay.
pub(crate) const MODULE: &str = "MODULE one\n  CONST robtarget p1 := [[500,0,400],[1,0,0,0],\
    [0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n  PROC main()\n    MoveL p1, v100, fine, tool0;\n  \
    ENDPROC\nENDMODULE\n";

/// A bundled URDF as text, to upload under another name.
pub(crate) fn urdf(name: &str) -> String {
    let path = nextpose::kinematics::bundled_robots_dir().join(format!("{name}.urdf"));
    std::fs::read_to_string(path).expect("bundled URDF")
}

/// Sets up, as the admin, what a route needs beyond the fixture to succeed (before the
/// database is compared): the cell's open routine finished before another is started or a
/// program imported and learned, an arm uploaded to delete (bundled ones cannot be), a token
/// to revoke.
async fn prepare(app: &TestApp, method: &Method, path: &str, f: &Fixture, n: usize) {
    if *method == Method::POST
        && (path == format!("/v1/programs/{}/routines", f.program)
            || path == format!("/v1/cells/{}/imports", f.cell))
    {
        app.finish(f.open).await;
    } else if path == format!("/v1/robots/doomed_{n}") {
        app.post_ok(
            "/v1/robots",
            &json!({ "name": format!("doomed_{n}"), "urdf": urdf("ur5e") }),
            StatusCode::CREATED,
        )
        .await;
    } else if path == format!("/v1/tokens/revoked-{n}") {
        secret(app, &format!("revoked-{n}"), "operator", None).await;
    }
}

/// Every row of every table, as text, in a stable order (SQLite file or PostgreSQL database).
pub(crate) async fn dump(app: &TestApp) -> Vec<String> {
    match &app.db {
        nextpose::server::Database::File(path) => dump_sqlite(path).await,
        nextpose::server::Database::Postgres(url) => dump_postgres(url).await,
        other => panic!("the matrix needs a database it can read: {other:?}"),
    }
}

async fn dump_sqlite(path: &std::path::Path) -> Vec<String> {
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

/// PostgreSQL writes each row as text itself (`CAST(t AS TEXT)`).
async fn dump_postgres(url: &str) -> Vec<String> {
    let mut conn = sqlx::PgConnection::connect(url).await.unwrap();
    let tables: Vec<(String,)> = sqlx::query_as(
        "SELECT table_name::text FROM information_schema.tables \
         WHERE table_schema = 'public' AND table_type = 'BASE TABLE' ORDER BY 1",
    )
    .fetch_all(&mut conn)
    .await
    .unwrap();
    let mut out = Vec::new();
    for (table,) in tables {
        let rows: Vec<(String,)> = sqlx::query_as(sqlx::AssertSqlSafe(format!(
            "SELECT CAST(t AS TEXT) FROM {table} t ORDER BY 1"
        )))
        .fetch_all(&mut conn)
        .await
        .unwrap();
        out.extend(rows.into_iter().map(|(row,)| format!("{table}: {row}")));
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

    let count = routes(&fixture(&app, 0).await, 0).len();
    let mut n = 1;
    for i in 0..count {
        // Refused callers first, on one fixture, then each allowed caller on a fresh one.
        let f = fixture(&app, n).await;
        n += 1;
        let (method, path, body, need) = routes(&f, n)[i].clone();
        prepare(&app, &method, &path, &f, n).await;
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
            let (method, path, body, _) = routes(&f, n)[i].clone();
            prepare(&app, &method, &path, &f, n).await;
            let status = send(&app, &method, &path, &body, token).await;
            if on_postgres() && path == "/v1/backups" {
                // PostgreSQL is backed up with pg_dump (deployment.md).
                assert_eq!(status, StatusCode::CONFLICT, "{method} {path} as {who}");
            } else {
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

/// The matrix is every route: each operation of the service's OpenAPI document has an entry
/// (its template's `{…}` segments matching the entry's ids).
#[tokio::test]
async fn the_matrix_has_every_route_of_the_openapi_document() {
    let mut app = spawn_with(TransportOptions {
        token: Some(BOOTSTRAP.into()),
        ..TransportOptions::default()
    })
    .await;
    app.token = Some(BOOTSTRAP.into());
    let f = fixture(&app, 0).await;
    let entries: Vec<(Method, String)> = routes(&f, 0)
        .into_iter()
        .map(|(m, p, _, _)| (m, p.split('?').next().unwrap_or_default().to_string()))
        .collect();
    let matches = |template: &str, path: &str| {
        let (t, p): (Vec<&str>, Vec<&str>) =
            (template.split('/').collect(), path.split('/').collect());
        t.len() == p.len() && t.iter().zip(&p).all(|(a, b)| a == b || a.starts_with('{'))
    };
    let doc = nextpose::http::openapi();
    let mut missing = Vec::new();
    for (template, item) in &doc.paths.paths {
        if template == "/healthz" {
            // Open to anyone, token or not: a load balancer's liveness probe.
            continue;
        }
        let methods = [
            (Method::GET, item.get.is_some()),
            (Method::POST, item.post.is_some()),
            (Method::PATCH, item.patch.is_some()),
            (Method::PUT, item.put.is_some()),
            (Method::DELETE, item.delete.is_some()),
        ];
        for (method, present) in methods {
            if present
                && !entries
                    .iter()
                    .any(|(m, p)| *m == method && matches(template, p))
            {
                missing.push(format!("{method} {template}"));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "routes missing from the matrix: {missing:?}"
    );
}
