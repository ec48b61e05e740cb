//! Stored tokens (`nextpose token`, `app::tokens`): a secret is shown once and only its
//! SHA-256 is stored (the secret never appears in the database file), it names its token's
//! role and cells, a revoked or unknown one is refused, and without any token (and without
//! `NEXTPOSE_TOKEN`) the service does not authenticate.

use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use nextpose::api::{NewToken, Role};
use nextpose::app::robots::Robots;
use nextpose::app::{App, AppError, Caller};
use nextpose::storage::{Durability, Store};
use nextpose::telemetry::Metrics;

async fn app_on(path: &Path) -> App {
    let store = Store::open(path, Durability::Process).await.expect("store");
    let robots = Robots::load(None).expect("robots");
    App::new(store, Arc::new(Metrics::new()), Arc::new(robots))
}

fn token_cli(db: impl AsRef<std::ffi::OsStr>, args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_nextpose"))
        .arg("token")
        .args(args)
        .arg("--db")
        .arg(db)
        .env_remove("NEXTPOSE_DB")
        .output()
        .expect("run nextpose token");
    assert!(
        out.status.success(),
        "nextpose token {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Every byte of the database's files (the main file and its WAL).
fn database_bytes(db: &Path) -> Vec<u8> {
    let mut bytes = std::fs::read(db).expect("database file");
    let wal = db.with_extension("db-wal");
    if let Ok(more) = std::fs::read(wal) {
        bytes.extend(more);
    }
    bytes
}

#[tokio::test]
async fn the_cli_creates_lists_and_revokes_tokens_and_keeps_only_their_hashes() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("nextpose.db");
    let cell = {
        let app = app_on(&db).await;
        // Without any token the service does not authenticate.
        assert_eq!(app.caller(None, false).await.unwrap(), Caller::anonymous());
        let cell = app
            .create_cell(serde_json::from_value(serde_json::json!({"name": "weld-1"})).unwrap())
            .await
            .unwrap()
            .id;
        app.store().close().await;
        cell
    };

    let out = token_cli(
        &db,
        &[
            "create",
            "--name",
            "op-1",
            "--role",
            "operator",
            "--cell",
            &cell.to_string(),
        ],
    );
    let secret = String::from_utf8(out.stdout).unwrap().trim().to_string();
    assert!(secret.starts_with("npt_") && secret.len() == 68, "{secret}");
    let out = token_cli(&db, &["create", "--name", "eng", "--role", "engineer"]);
    let engineer = String::from_utf8(out.stdout).unwrap().trim().to_string();

    let list = String::from_utf8(token_cli(&db, &["list"]).stdout).unwrap();
    let lines: Vec<&str> = list.lines().collect();
    assert_eq!(lines.len(), 2, "{list}");
    assert!(lines[0].starts_with("eng\tengineer\tall cells\t"), "{list}");
    assert!(
        lines[1].starts_with(&format!("op-1\toperator\tcells {cell}\t")),
        "{list}"
    );
    assert!(!list.contains(&secret) && !list.contains(&engineer));

    let app = app_on(&db).await;
    let op = app.caller(Some(secret.as_bytes()), false).await.unwrap();
    assert_eq!(
        (op.name.as_str(), op.role, op.cells.clone()),
        ("op-1", Role::Operator, Some(vec![cell]))
    );
    let eng = app.caller(Some(engineer.as_bytes()), false).await.unwrap();
    assert_eq!((eng.role, eng.cells), (Role::Engineer, None));
    // Unknown secrets, and none at all, are refused now that tokens exist.
    for bad in [None, Some(&b"npt_00"[..]), Some(&secret.as_bytes()[1..])] {
        assert!(matches!(
            app.caller(bad, false).await,
            Err(AppError::Unauthenticated)
        ));
    }
    // A name taken by an unrevoked token is refused; a cell that does not exist too.
    let taken = NewToken {
        name: "op-1".into(),
        role: Role::Admin,
        cells: None,
    };
    assert!(matches!(
        app.create_token(taken).await,
        Err(AppError::Exists(_))
    ));
    let nowhere = NewToken {
        name: "nowhere".into(),
        role: Role::Operator,
        cells: Some(vec![cell + 100]),
    };
    assert!(matches!(
        app.create_token(nowhere).await,
        Err(AppError::NotFound { .. })
    ));
    app.store().close().await;

    // Only the hashes are stored: no secret appears anywhere in the database's files.
    let bytes = database_bytes(&db);
    for s in [&secret, &engineer] {
        let hex = &s["npt_".len()..];
        assert!(
            !bytes.windows(hex.len()).any(|w| w == hex.as_bytes()),
            "a secret is in the database file"
        );
        let hash = nextpose::app::secret_hash(s.as_bytes());
        assert!(bytes.windows(hash.len()).any(|w| w == hash.as_bytes()));
    }

    token_cli(&db, &["revoke", "op-1"]);
    let app = app_on(&db).await;
    assert!(matches!(
        app.caller(Some(secret.as_bytes()), false).await,
        Err(AppError::Unauthenticated)
    ));
    // The name is free again; revoking what is not there says so.
    let again = NewToken {
        name: "op-1".into(),
        role: Role::Operator,
        cells: None,
    };
    let created = app.create_token(again).await.unwrap();
    assert_ne!(created.secret, secret);
    assert!(matches!(
        app.revoke_token("nobody").await,
        Err(AppError::NotFoundName { .. })
    ));
    // Deleting the only cell of a scoped token leaves it with no cells, never all of them.
    let scoped = app
        .create_token(NewToken {
            name: "scoped".into(),
            role: Role::Operator,
            cells: Some(vec![cell]),
        })
        .await
        .unwrap();
    app.delete_cell(cell).await.unwrap();
    let caller = app
        .caller(Some(scoped.secret.as_bytes()), false)
        .await
        .unwrap();
    assert_eq!(caller.cells, Some(vec![]));
    app.store().close().await;
}

/// Over REST, without `NEXTPOSE_TOKEN`: an anonymous client cannot create, list or revoke
/// tokens (403 naming how the first token is made), so it cannot turn authentication on or
/// lock anyone out; the host's operator does, with `nextpose token create`. Then the first
/// stored token turns authentication on (`/healthz` says so, an anonymous call becomes 401); a
/// token limited to no cells, a duplicate name or an unknown cell is refused and stores
/// nothing; a revoked token is 401.
#[tokio::test]
async fn an_anonymous_client_cannot_turn_authentication_on_and_the_host_can() {
    use crate::helpers::*;
    use reqwest::StatusCode;
    use serde_json::json;

    let mut app = spawn_app().await;
    let health = app.get_ok("/healthz").await;
    assert_eq!(health["token_required"], false);
    let cell = app.create_cell("weld-1").await;

    // The take-over of an open server: refused, whatever the request carries.
    for bearer in [None, Some("npt_made_up")] {
        app.token = bearer.map(str::to_string);
        for r in [
            app.post("/v1/tokens", &json!({ "name": "x", "role": "admin" }))
                .await,
            app.get("/v1/tokens").await,
            app.delete("/v1/tokens/x").await,
        ] {
            let message = expect_error(r, StatusCode::FORBIDDEN, "forbidden").await;
            assert!(
                message.contains("nextpose token create") && message.contains("--token"),
                "{message}"
            );
        }
    }
    app.token = None;
    // Nothing changed: the server still asks no one for a token and serves everyone.
    assert_eq!(app.get_ok("/healthz").await["token_required"], false);
    assert_eq!(app.get_ok("/v1/whoami").await["name"], "anonymous");
    app.create_cell("weld-2").await;

    // The host's operator makes the first token, on the server's database, while it serves.
    let out = token_cli(
        db_setting(&app.db),
        &["create", "--name", "admin", "--role", "admin"],
    );
    let admin = String::from_utf8(out.stdout).unwrap().trim().to_string();
    assert_eq!(app.get_ok("/healthz").await["token_required"], true);
    let r = app.get("/v1/cells").await;
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
    assert_eq!(r.headers()["www-authenticate"], "Bearer");
    let r = app
        .post("/v1/tokens", &json!({ "name": "x", "role": "admin" }))
        .await;
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED, "no token, no role");

    app.token = Some(admin.clone());
    for (body, status, code) in [
        (
            json!({ "name": "none", "role": "operator", "cells": [] }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid",
        ),
        (
            json!({ "name": "ghost", "role": "operator", "cells": [cell + 1000] }),
            StatusCode::NOT_FOUND,
            "not_found",
        ),
        (
            json!({ "name": "x", "role": "superuser" }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unprocessable",
        ),
        (
            json!({ "name": "admin", "role": "operator" }),
            StatusCode::CONFLICT,
            "conflict",
        ),
    ] {
        let r = app.post("/v1/tokens", &body).await;
        assert_eq!(r.status(), status, "{body}");
        let error: serde_json::Value = r.json().await.unwrap();
        assert_eq!(error["error"]["code"], code, "{body}: {error}");
    }
    // Nothing was stored by the refusals.
    let names = |tokens: serde_json::Value| -> Vec<String> {
        tokens
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t["name"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(names(app.get_ok("/v1/tokens").await), ["admin"]);
    let op = app
        .post_ok(
            "/v1/tokens",
            &json!({ "name": "op", "role": "operator", "cells": [cell] }),
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(op["token"]["cells"], json!([cell]));
    let op = op["secret"].as_str().unwrap().to_string();
    assert_eq!(names(app.get_ok("/v1/tokens").await), ["admin", "op"]);

    app.token = Some(op.clone());
    assert_eq!(app.get_ok("/v1/whoami").await["name"], "op");
    app.token = Some(admin);
    let r = app.delete("/v1/tokens/op").await;
    assert_eq!(r.status(), StatusCode::NO_CONTENT);
    let r = app.delete("/v1/tokens/op").await;
    assert_eq!(r.status(), StatusCode::NOT_FOUND, "revoked already");
    app.token = Some(op);
    let r = app.get("/v1/whoami").await;
    assert_eq!(
        r.status(),
        StatusCode::UNAUTHORIZED,
        "a revoked token is unknown"
    );
}

/// Over gRPC too: on a server with no token, `CreateToken`, `ListTokens` and `RevokeToken`
/// refuse an anonymous caller (`PERMISSION_DENIED`, saying how the first token is made), and
/// nothing changes.
#[tokio::test]
async fn over_grpc_an_anonymous_client_cannot_turn_authentication_on() {
    use crate::helpers::*;
    use nextpose::grpc::pb;
    use nextpose::grpc::pb::nextpose_client::NextposeClient;
    use tonic::Code;

    let app = spawn_app().await;
    let mut c = NextposeClient::new(crate::grpc::client::channel(&app).await);
    let refusals = [
        c.create_token(pb::CreateTokenRequest {
            name: "x".into(),
            role: pb::Role::Admin.into(),
            cells: vec![],
        })
        .await
        .map(drop),
        c.list_tokens(pb::ListTokensRequest {}).await.map(drop),
        c.revoke_token(pb::RevokeTokenRequest { name: "x".into() })
            .await
            .map(drop),
    ];
    for r in refusals {
        let e = r.expect_err("refused");
        assert_eq!(e.code(), Code::PermissionDenied, "{e:?}");
        assert!(e.message().contains("nextpose token create"), "{e:?}");
    }
    assert_eq!(app.get_ok("/healthz").await["token_required"], false);
    app.create_cell("still-open").await;
}

/// Tokens and the cells of resources are kept in memory (`app::credentials`), and what a caller
/// is told stays what the store says: a token revoked here is refused at once although it was
/// just taken; a resource of a cell the token may not touch is refused, and once deleted the
/// token is told what anyone would be (allowed to ask; the operation then finds nothing).
#[tokio::test]
async fn kept_tokens_and_cells_never_answer_otherwise_than_the_store() {
    use nextpose::api::{CreateCell, CreateProgram, CreateRoutine};
    use nextpose::app::{Action, Scope};
    let dir = tempfile::tempdir().unwrap();
    let app = app_on(&dir.path().join("kept.db")).await;
    let cell = |name: &str| CreateCell {
        name: name.into(),
        settings: Default::default(),
    };
    let mine = app.create_cell(cell("mine")).await.unwrap();
    let other = app.create_cell(cell("other")).await.unwrap();
    let op = app
        .create_token(NewToken {
            name: "op".into(),
            role: Role::Operator,
            cells: Some(vec![mine.id]),
        })
        .await
        .unwrap();
    app.create_token(NewToken {
        name: "admin".into(),
        role: Role::Admin,
        cells: None,
    })
    .await
    .unwrap();
    let program = app
        .create_program(other.id, CreateProgram { name: "p".into() })
        .await
        .unwrap();
    let routine = app
        .create_routine(program.id, CreateRoutine { name: None })
        .await
        .unwrap();

    for _ in 0..2 {
        let caller = app.caller(Some(op.secret.as_bytes()), false).await.unwrap();
        assert_eq!(caller.cells, Some(vec![mine.id]));
        for scope in [Scope::Routine(routine.id), Scope::Program(program.id)] {
            assert!(matches!(
                app.authorize(&caller, Action::Read, scope).await,
                Err(AppError::PermissionDenied(_))
            ));
        }
    }
    let caller = app.caller(Some(op.secret.as_bytes()), false).await.unwrap();
    app.delete_routine(routine.id).await.unwrap();
    app.authorize(&caller, Action::Read, Scope::Routine(routine.id))
        .await
        .expect("a deleted routine belongs to no cell");

    app.revoke_token("op").await.unwrap();
    assert!(matches!(
        app.caller(Some(op.secret.as_bytes()), false).await,
        Err(AppError::Unauthenticated)
    ));
    assert!(matches!(
        app.caller(None, false).await,
        Err(AppError::Unauthenticated)
    ));
    // No token left: the server is open again at once.
    app.revoke_token("admin").await.unwrap();
    let anyone = app.caller(None, false).await.unwrap();
    assert!(!anyone.authenticated);
    app.store().close().await;
}
