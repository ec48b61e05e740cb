//! The audit trail (`GET /v1/audit`, gRPC `ListAudit`): a random sequence of requests from
//! several tokens over REST and gRPC, each with a request id of its own, leaves exactly one
//! entry per request that changed something, with its token's name, its request id and its
//! operation, and none for a read, a refused request or a failed one. Pages
//! cover the trail exactly once, newest first; a `Teach` stream records each command.

use std::collections::BTreeMap;

use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use nextpose::transport::TransportOptions;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use reqwest::{Method, StatusCode};
use serde_json::{Value, json};
use tonic::transport::Channel;

use crate::grpc::client::{channel, pb_pose};
use crate::helpers::*;

const BOOTSTRAP: &str = "audit-bootstrap";

/// What a request should have left in the trail: its token's name, operation and answer;
/// None: nothing.
type Expected = Option<(String, String, String)>;

struct Actor {
    name: &'static str,
    secret: Option<String>,
}

fn grpc_request<T>(message: T, secret: Option<&str>, request_id: &str) -> tonic::Request<T> {
    let mut r = tonic::Request::new(message);
    if let Some(s) = secret {
        r.metadata_mut()
            .insert("authorization", format!("Bearer {s}").parse().unwrap());
    }
    r.metadata_mut()
        .insert("x-request-id", request_id.parse().unwrap());
    r
}

async fn rest(
    app: &TestApp,
    method: Method,
    path: &str,
    body: Option<Value>,
    secret: Option<&str>,
    request_id: &str,
) -> StatusCode {
    let mut rb = app
        .client
        .request(method, app.url(path))
        .header("x-request-id", request_id);
    if let Some(b) = body {
        rb = rb.json(&b);
    }
    if let Some(s) = secret {
        rb = rb.bearer_auth(s);
    }
    let r = rb.send().await.expect("request");
    assert_eq!(
        r.headers()["x-request-id"],
        request_id,
        "the request id is kept"
    );
    r.status()
}

/// Every entry of the trail, read in pages of `page` (newest first), by request id.
async fn trail(app: &TestApp, page: u32) -> Vec<Value> {
    let mut all = Vec::new();
    let mut before: Option<i64> = None;
    loop {
        let mut path = format!("/v1/audit?limit={page}");
        if let Some(b) = before {
            path.push_str(&format!("&before={b}"));
        }
        let answer = app.get_ok(&path).await;
        let entries = answer["entries"].as_array().unwrap().clone();
        assert!(entries.len() <= page as usize);
        all.extend(entries);
        match answer["next"].as_i64() {
            Some(next) => before = Some(next),
            None => break,
        }
    }
    let ids: Vec<i64> = all.iter().map(|e| e["id"].as_i64().unwrap()).collect();
    assert!(ids.windows(2).all(|w| w[0] > w[1]), "newest first: {ids:?}");
    all
}

#[tokio::test]
async fn a_random_mix_of_requests_leaves_one_entry_per_change_and_none_for_the_rest() {
    let mut app = spawn_with(TransportOptions {
        token: Some(BOOTSTRAP.into()),
        ..TransportOptions::default()
    })
    .await;
    app.token = Some(BOOTSTRAP.into());
    let cell = app.create_cell("audited").await;
    let other = app.create_cell("other").await;
    let program = app.create_program(cell, "p").await;
    let routine = app.create_routine(program).await;
    let secret = |v: Value| v["secret"].as_str().unwrap().to_string();
    let mut actors = vec![Actor {
        name: "nobody",
        secret: None,
    }];
    for (name, role, cells) in [
        ("op", "operator", Some(vec![cell])),
        ("op-other", "operator", Some(vec![other])),
        ("eng", "engineer", None),
        ("admin", "admin", None),
    ] {
        let created = app
            .post_ok(
                "/v1/tokens",
                &json!({ "name": name, "role": role, "cells": cells }),
                StatusCode::CREATED,
            )
            .await;
        actors.push(Actor {
            name,
            secret: Some(secret(created)),
        });
    }
    // What set-up left in the trail.
    let before: Vec<i64> = trail(&app, 1000)
        .await
        .iter()
        .map(|e| e["id"].as_i64().unwrap())
        .collect();
    assert_eq!(before.len(), 8, "4 cells, programs, routines; 4 tokens");

    let ch: Channel = channel(&app).await;
    let mut grpc = NextposeClient::new(ch);
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let mut expected: BTreeMap<String, Expected> = BTreeMap::new();
    for i in 0..80 {
        let actor = &actors[rng.random_range(0..actors.len())];
        let s = actor.secret.as_deref();
        let over_grpc = rng.random_bool(0.5);
        let id = format!("req-{i:03}");
        let x = 100.0 + 10.0 * i as f64;
        let pose = pose([x, 0.0, 0.0], [0.0; 3]);
        // (operation, REST status or gRPC code name, whether it is a write)
        let (operation, outcome, write): (String, String, bool) = match rng.random_range(0..8) {
            // Teach a waypoint (an operator of the cell may).
            0 | 1 => {
                if over_grpc {
                    let r = grpc
                        .append_waypoint(grpc_request(
                            pb::AppendWaypointRequest {
                                routine_id: routine,
                                waypoint: Some(pb::NewWaypoint {
                                    pose: Some(pb_pose(&pose)),
                                    ..Default::default()
                                }),
                            },
                            s,
                            &id,
                        ))
                        .await;
                    (
                        "/nextpose.v1.Nextpose/AppendWaypoint".into(),
                        code(r.map(drop)),
                        true,
                    )
                } else {
                    let st = rest(
                        &app,
                        Method::POST,
                        &format!("/v1/routines/{routine}/waypoints"),
                        Some(json!({ "pose": pose })),
                        s,
                        &id,
                    )
                    .await;
                    (
                        "POST /v1/routines/{routine_id}/waypoints".into(),
                        st.as_str().into(),
                        true,
                    )
                }
            }
            // Undo (fails when there is nothing to undo).
            2 => {
                if over_grpc {
                    let r = grpc
                        .undo(grpc_request(
                            pb::UndoRequest {
                                routine_id: routine,
                            },
                            s,
                            &id,
                        ))
                        .await;
                    ("/nextpose.v1.Nextpose/Undo".into(), code(r.map(drop)), true)
                } else {
                    let st = rest(
                        &app,
                        Method::DELETE,
                        &format!("/v1/routines/{routine}/waypoints/last"),
                        None,
                        s,
                        &id,
                    )
                    .await;
                    (
                        "DELETE /v1/routines/{routine_id}/waypoints/last".into(),
                        st.as_str().into(),
                        true,
                    )
                }
            }
            // A new program (an engineer's); a name taken fails.
            3 => {
                let name = format!("q{}", rng.random_range(0..6));
                if over_grpc {
                    let r = grpc
                        .create_program(grpc_request(
                            pb::CreateProgramRequest {
                                cell_id: cell,
                                name,
                            },
                            s,
                            &id,
                        ))
                        .await;
                    (
                        "/nextpose.v1.Nextpose/CreateProgram".into(),
                        code(r.map(drop)),
                        true,
                    )
                } else {
                    let st = rest(
                        &app,
                        Method::POST,
                        &format!("/v1/cells/{cell}/programs"),
                        Some(json!({ "name": name })),
                        s,
                        &id,
                    )
                    .await;
                    (
                        "POST /v1/cells/{cell_id}/programs".into(),
                        st.as_str().into(),
                        true,
                    )
                }
            }
            // A waypoint that cannot be (a quaternion of norm 2): fails, changes nothing.
            4 => {
                let bad = json!({ "x": 0, "y": 0, "z": 0, "qw": 2, "qx": 0, "qy": 0, "qz": 0 });
                if over_grpc {
                    let r = grpc
                        .append_waypoint(grpc_request(
                            pb::AppendWaypointRequest {
                                routine_id: routine,
                                waypoint: Some(pb::NewWaypoint {
                                    pose: Some(pb_pose(&bad)),
                                    ..Default::default()
                                }),
                            },
                            s,
                            &id,
                        ))
                        .await;
                    (
                        "/nextpose.v1.Nextpose/AppendWaypoint".into(),
                        code(r.map(drop)),
                        true,
                    )
                } else {
                    let st = rest(
                        &app,
                        Method::POST,
                        &format!("/v1/routines/{routine}/waypoints"),
                        Some(json!({ "pose": bad })),
                        s,
                        &id,
                    )
                    .await;
                    (
                        "POST /v1/routines/{routine_id}/waypoints".into(),
                        st.as_str().into(),
                        true,
                    )
                }
            }
            // Rename the cell (an engineer's).
            5 => {
                let name = format!("audited-{i}");
                if over_grpc {
                    let r = grpc
                        .update_cell(grpc_request(
                            pb::UpdateCellRequest {
                                cell_id: cell,
                                name: Some(name),
                                settings: None,
                            },
                            s,
                            &id,
                        ))
                        .await;
                    (
                        "/nextpose.v1.Nextpose/UpdateCell".into(),
                        code(r.map(drop)),
                        true,
                    )
                } else {
                    let st = rest(
                        &app,
                        Method::PATCH,
                        &format!("/v1/cells/{cell}"),
                        Some(json!({ "name": name })),
                        s,
                        &id,
                    )
                    .await;
                    ("PATCH /v1/cells/{cell_id}".into(), st.as_str().into(), true)
                }
            }
            // Reads, the prediction asked again among them (which stores what it offers).
            _ => {
                if over_grpc {
                    let r = grpc
                        .predict(grpc_request(
                            pb::PredictRequest {
                                routine_id: routine,
                                ..Default::default()
                            },
                            s,
                            &id,
                        ))
                        .await;
                    (
                        "/nextpose.v1.Nextpose/Predict".into(),
                        code(r.map(drop)),
                        false,
                    )
                } else {
                    let st = rest(
                        &app,
                        Method::GET,
                        &format!("/v1/routines/{routine}/prediction"),
                        None,
                        s,
                        &id,
                    )
                    .await;
                    (
                        "GET /v1/routines/{routine_id}/prediction".into(),
                        st.as_str().into(),
                        false,
                    )
                }
            }
        };
        let succeeded = outcome == "OK" || outcome.starts_with('2');
        let entry = (write && succeeded).then(|| (actor.name.to_string(), operation, outcome));
        expected.insert(id, entry);
    }
    let changes = expected.values().filter(|e| e.is_some()).count();
    let refused_or_failed = expected.values().filter(|e| e.is_none()).count();
    assert!(
        changes >= 15 && refused_or_failed >= 15,
        "the mix exercises both: {changes} changes, {refused_or_failed} others"
    );

    // The trail, in small pages: exactly the changes, each once, as made.
    let all = trail(&app, 7).await;
    let mut found: BTreeMap<String, Vec<&Value>> = BTreeMap::new();
    for e in &all {
        found
            .entry(e["request_id"].as_str().unwrap().to_string())
            .or_default()
            .push(e);
    }
    for (id, want) in &expected {
        let got = found.get(id).cloned().unwrap_or_default();
        match want {
            None => assert!(got.is_empty(), "{id} changed nothing but left {got:?}"),
            Some((token, operation, outcome)) => {
                assert_eq!(got.len(), 1, "{id}: {got:?}");
                let e = got[0];
                assert_eq!(e["token"], token.as_str(), "{id}");
                assert_eq!(e["operation"], operation.as_str(), "{id}");
                assert_eq!(e["outcome"], "ok", "{id} was answered {outcome}");
                assert_eq!(e["cell_id"], cell, "{id}");
                assert!(e["at"].as_str().unwrap().ends_with('Z'), "{e}");
            }
        }
    }
    assert_eq!(
        all.len(),
        before.len() + changes,
        "nothing else was recorded"
    );
    // No secret is in the trail.
    let text = serde_json::to_string(&all).unwrap();
    for actor in &actors {
        if let Some(s) = &actor.secret {
            assert!(!text.contains(s.as_str()));
        }
    }

    // The same trail over gRPC, and a cell's part of it.
    let listed = grpc
        .list_audit(grpc_request(
            pb::ListAuditRequest {
                cell_id: Some(cell),
                limit: Some(1000),
                ..Default::default()
            },
            Some(BOOTSTRAP),
            "read-trail",
        ))
        .await
        .expect("list audit")
        .into_inner();
    let of_cell: Vec<i64> = all
        .iter()
        .filter(|e| e["cell_id"] == cell)
        .map(|e| e["id"].as_i64().unwrap())
        .collect();
    assert_eq!(
        listed.entries.iter().map(|e| e.id).collect::<Vec<_>>(),
        of_cell
    );
    assert_eq!(listed.next, None);

    // A backup (of an SQLite file) changes no table but is recorded; reading the trail is not.
    if !on_postgres() {
        let st = rest(
            &app,
            Method::POST,
            "/v1/backups",
            Some(json!({ "name": "audited.db" })),
            Some(BOOTSTRAP),
            "backup-1",
        )
        .await;
        assert_eq!(st, StatusCode::CREATED);
        let newest = &trail(&app, 1).await[0];
        assert_eq!(
            (
                &newest["request_id"],
                &newest["operation"],
                &newest["outcome"],
                &newest["token"]
            ),
            (
                &json!("backup-1"),
                &json!("POST /v1/backups"),
                &json!("ok"),
                &json!("bootstrap")
            )
        );
        assert_eq!(trail(&app, 1000).await.len(), all.len() + 1);
    }

    // What the route refuses, naming the problem; an operator may not read it.
    for (query, want) in [
        ("limit=0", "limit must be 1 to 1000"),
        ("limit=1001", "limit must be 1 to 1000"),
        ("before=0", "before must be"),
        ("since=yesterday", "since must be an RFC 3339 time"),
    ] {
        let r = app.get(&format!("/v1/audit?{query}")).await;
        assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY, "{query}");
        let body: Value = r.json().await.unwrap();
        assert!(
            body["error"]["message"].as_str().unwrap().contains(want),
            "{query}: {body}"
        );
    }
    let since = app.get_ok("/v1/audit?since=2999-01-01T00:00:00Z").await;
    assert_eq!(since["entries"], json!([]));
    let op = actors.iter().find(|a| a.name == "op").unwrap();
    let st = rest(
        &app,
        Method::GET,
        "/v1/audit",
        None,
        op.secret.as_deref(),
        "peek",
    )
    .await;
    assert_eq!(st, StatusCode::FORBIDDEN);
}

/// A gRPC call's answer as the trail names it.
fn code(r: Result<(), tonic::Status>) -> String {
    match r {
        Ok(()) => "OK".into(),
        Err(s) => nextpose::grpc::code_name(s.code()),
    }
}

#[tokio::test]
async fn a_teach_stream_records_each_command_that_changes_something() {
    let app = spawn_app().await;
    let cell = app.create_cell("streamed").await;
    let program = app.create_program(cell, "p").await;
    let routine = app.create_routine(program).await;
    let mut grpc = NextposeClient::new(channel(&app).await);
    let seam = u_seam([0.0; 3], 0.0);
    let command = |tag: u64, c: pb::teach_request::Command| pb::TeachRequest {
        tag,
        command: Some(c),
    };
    use pb::teach_request::Command;
    let commands = vec![
        command(
            1,
            Command::Start(pb::StartCommand {
                routine_id: routine,
            }),
        ),
        command(
            2,
            Command::Waypoint(pb::NewWaypoint {
                pose: Some(pb_pose(&seam[0])),
                ..Default::default()
            }),
        ),
        command(
            3,
            Command::Waypoint(pb::NewWaypoint {
                pose: Some(pb_pose(&seam[1])),
                ..Default::default()
            }),
        ),
        command(4, Command::Undo(pb::UndoCommand {})),
        command(5, Command::Undo(pb::UndoCommand {})),
        // Nothing left to undo: answered with an error, changes nothing.
        command(6, Command::Undo(pb::UndoCommand {})),
    ];
    let n = commands.len();
    let mut answers = grpc
        .teach(grpc_request(tokio_stream::iter(commands), None, "stream-1"))
        .await
        .expect("teach")
        .into_inner();
    for _ in 0..n {
        answers.message().await.expect("answer").expect("an answer");
    }
    let all = trail(&app, 100).await;
    let mine: Vec<(&str, &str, &str)> = all
        .iter()
        .filter(|e| e["request_id"] == "stream-1")
        .rev()
        .map(|e| {
            (
                e["operation"].as_str().unwrap(),
                e["target"].as_str().unwrap(),
                e["outcome"].as_str().unwrap(),
            )
        })
        .collect();
    let target = format!("routine {routine}");
    assert_eq!(
        mine,
        [
            (
                "/nextpose.v1.Nextpose/Teach waypoint",
                target.as_str(),
                "ok"
            ),
            (
                "/nextpose.v1.Nextpose/Teach waypoint",
                target.as_str(),
                "ok"
            ),
            ("/nextpose.v1.Nextpose/Teach undo", target.as_str(), "ok"),
            ("/nextpose.v1.Nextpose/Teach undo", target.as_str(), "ok"),
        ]
    );
    assert!(
        all.iter()
            .filter(|e| e["request_id"] == "stream-1")
            .all(|e| e["token"] == "anonymous")
    );
}

/// Appends from 8 clients at once share the append writer's transactions; each still leaves
/// its one entry, on its own cell.
#[tokio::test]
async fn appends_committed_together_each_leave_their_entry() {
    let app = std::sync::Arc::new(spawn_app().await);
    let mut routines = Vec::new();
    for i in 0..8 {
        let cell = app.create_cell(&format!("c{i}")).await;
        let program = app.create_program(cell, "p").await;
        routines.push((cell, app.create_routine(program).await));
    }
    let mut clients = tokio::task::JoinSet::new();
    for (i, &(_, routine)) in routines.iter().enumerate() {
        let app = app.clone();
        clients.spawn(async move {
            for (k, p) in u_seam([0.0; 3], 0.0).iter().enumerate() {
                let st = rest(
                    &app,
                    Method::POST,
                    &format!("/v1/routines/{routine}/waypoints"),
                    Some(json!({ "pose": p })),
                    None,
                    &format!("c{i}-w{k}"),
                )
                .await;
                assert_eq!(st, StatusCode::CREATED);
            }
        });
    }
    while let Some(done) = clients.join_next().await {
        done.expect("client");
    }
    let all = trail(&app, 1000).await;
    let seam = u_seam([0.0; 3], 0.0).len();
    for (i, &(cell, routine)) in routines.iter().enumerate() {
        for k in 0..seam {
            let id = format!("c{i}-w{k}");
            let got: Vec<&Value> = all.iter().filter(|e| e["request_id"] == id).collect();
            assert_eq!(got.len(), 1, "{id}");
            assert_eq!(got[0]["cell_id"], cell, "{id}");
            assert_eq!(got[0]["target"], format!("routine {routine}"), "{id}");
            assert_eq!(got[0]["outcome"], "ok", "{id}");
        }
    }
}
