//! Appends that are safe to retry (`seq`, issue 46): a pendant on a plant's Wi-Fi that times
//! out and sends its Record again must not get two waypoints. A repeat of the last append
//! (same `seq`, same values) stores nothing and answers the stored waypoint with its
//! prediction; anything else at a taken `seq` is a 409 with nothing changed.

use std::io::Write;

use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::grpc::client::{channel, pb_pose};
use crate::helpers::*;
use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;

/// A cell with one U-seam learned and a second routine with its first `n` waypoints taught
/// with `seq`; returns (routine, the copy's poses, the last answer).
async fn taught_with_seq(app: &TestApp, n: usize) -> (i64, Vec<Value>, Value) {
    let cell = app.create_cell("retry").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let copy = u_seam([100.0, 200.0, 0.0], 0.4);
    let routine = app.create_routine(program).await;
    let mut last = Value::Null;
    for (i, p) in copy[..n].iter().enumerate() {
        last = app
            .post_ok(
                &format!("/v1/routines/{routine}/waypoints"),
                &json!({ "pose": p, "seq": i + 1 }),
                StatusCode::CREATED,
            )
            .await;
        assert_eq!(last["repeat"], false);
    }
    (routine, copy, last)
}

async fn waypoints(app: &TestApp, routine: i64) -> Vec<Value> {
    app.get_ok(&format!("/v1/routines/{routine}")).await["waypoints"]
        .as_array()
        .expect("waypoints")
        .clone()
}

#[tokio::test]
async fn a_repeated_append_stores_nothing_and_answers_the_stored_waypoint() {
    let app = spawn_app().await;
    let (routine, copy, first) = taught_with_seq(&app, 5).await;
    assert_eq!(first["prediction"]["offered"], true, "{first}");
    let before = waypoints(&app, routine).await;
    let program = app.get_ok(&format!("/v1/routines/{routine}")).await["program_id"]
        .as_i64()
        .unwrap();
    let history = app
        .get_ok(&format!("/v1/programs/{program}/history?limit=100"))
        .await;
    let trail = app.get_ok("/v1/audit?limit=1000").await;

    // The same request again (its answer lost on the way): 200, the same waypoint and
    // prediction, nothing stored.
    let path = format!("/v1/routines/{routine}/waypoints");
    let again = expect(
        app.post(&path, &json!({ "pose": copy[4], "seq": 5 })).await,
        StatusCode::OK,
    )
    .await;
    assert_eq!(again["repeat"], true);
    assert_eq!(again["waypoint"], first["waypoint"]);
    assert_eq!(again["prediction"], first["prediction"]);
    assert_eq!(waypoints(&app, routine).await, before);
    assert_eq!(
        app.get_ok(&format!("/v1/programs/{program}/history?limit=100"))
            .await,
        history,
        "a repeat makes no revision"
    );
    assert_eq!(
        app.get_ok("/v1/audit?limit=1000").await,
        trail,
        "a repeat changes nothing to audit"
    );

    // Anything else at a taken seq is refused, with nothing changed.
    for (body, why) in [
        (
            json!({ "pose": copy[5], "seq": 5 }),
            "other values at seq 5",
        ),
        (
            json!({ "pose": copy[4], "seq": 5, "name": "renamed" }),
            "another name at seq 5",
        ),
        (json!({ "pose": copy[3], "seq": 4 }), "older than the last"),
        (json!({ "pose": copy[5], "seq": 7 }), "beyond the next"),
    ] {
        let message = expect_error(
            app.post(&path, &body).await,
            StatusCode::CONFLICT,
            "conflict",
        )
        .await;
        assert!(message.contains("seq"), "{why}: {message}");
        assert_eq!(waypoints(&app, routine).await, before, "{why}");
    }
    for bad in [json!(0), json!(-1), json!("5"), json!(1.5)] {
        let r = app
            .post(&path, &json!({ "pose": copy[5], "seq": bad }))
            .await;
        assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY, "seq {bad}");
    }
    assert_eq!(waypoints(&app, routine).await, before);

    // The next seq appends; after an undo, the undone seq is the next one again.
    let next = app
        .post_ok(
            &path,
            &json!({ "pose": copy[5], "seq": 6 }),
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(next["waypoint"]["seq"], 6);
    expect(
        app.delete(&format!("/v1/routines/{routine}/waypoints/last"))
            .await,
        StatusCode::OK,
    )
    .await;
    let retaught = app
        .post_ok(
            &path,
            &json!({ "pose": copy[5], "seq": 6 }),
            StatusCode::CREATED,
        )
        .await;
    assert_ne!(retaught["waypoint"]["id"], next["waypoint"]["id"]);
    assert_eq!(waypoints(&app, routine).await.len(), 6);
    // An insert's `seq` must be the place its side gives it.
    let at = retaught["waypoint"]["id"].clone();
    let r = app
        .post(
            &format!("/v1/waypoints/{at}/insert"),
            &json!({ "side": "before", "waypoint": { "pose": copy[0], "seq": 1 } }),
        )
        .await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    assert_eq!(waypoints(&app, routine).await.len(), 6);
    let inserted = app
        .post_ok(
            &format!("/v1/waypoints/{at}/insert"),
            &json!({ "side": "before", "waypoint": { "pose": copy[0], "seq": 6 } }),
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(inserted["waypoint"]["seq"], 6);
}

/// The same request sent twice, the client hanging up on the first before any answer: one
/// waypoint is stored, whichever of the two the server handles first, and the answer read is
/// that waypoint.
#[tokio::test]
async fn a_retry_after_a_dropped_answer_stores_one_waypoint() {
    let app = spawn_app().await;
    let (routine, copy, _) = taught_with_seq(&app, 3).await;
    for (k, p) in copy[3..].iter().enumerate() {
        let seq = 4 + k;
        let body = json!({ "pose": p, "seq": seq }).to_string();
        let url = url::Url::parse(&app.base).unwrap();
        let host = format!("{}:{}", url.host_str().unwrap(), url.port().unwrap());
        // The first request: written whole, then the connection is closed unread.
        let mut stream = std::net::TcpStream::connect(&host).unwrap();
        write!(
            stream,
            "POST /v1/routines/{routine}/waypoints HTTP/1.1\r\nHost: {host}\r\n\
             Content-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
            body.len()
        )
        .unwrap();
        stream.flush().unwrap();
        drop(stream);
        // The retry.
        let r = app
            .post(
                &format!("/v1/routines/{routine}/waypoints"),
                &json!({ "pose": p, "seq": seq }),
            )
            .await;
        let status = r.status();
        let answer: Value = r.json().await.unwrap();
        assert!(
            status == StatusCode::CREATED || status == StatusCode::OK,
            "{status}: {answer}"
        );
        assert_eq!(answer["repeat"], status == StatusCode::OK);
        assert_eq!(answer["waypoint"]["seq"], seq);
        assert!(distance(&answer["waypoint"]["pose"], p) < 1e-9);
        // Whichever came first, the routine holds each waypoint once.
        let stored = waypoints(&app, routine).await;
        assert_eq!(stored.len(), seq, "after seq {seq}: {stored:?}");
        assert_eq!(stored[seq - 1]["id"], answer["waypoint"]["id"]);
    }
}

#[tokio::test]
async fn a_repeated_grpc_append_stores_nothing() {
    let app = spawn_app().await;
    let (routine, copy, first) = taught_with_seq(&app, 4).await;
    let mut c = NextposeClient::new(channel(&app).await);
    let append = |seq: i64, p: &Value| pb::AppendWaypointRequest {
        routine_id: routine,
        waypoint: Some(pb::NewWaypoint {
            pose: Some(pb_pose(p)),
            seq: Some(seq),
            ..Default::default()
        }),
    };
    let again = c
        .append_waypoint(append(4, &copy[3]))
        .await
        .expect("a repeat is answered")
        .into_inner();
    assert!(again.repeat);
    let w = again.waypoint.unwrap();
    assert_eq!(w.id, first["waypoint"]["id"].as_i64().unwrap());
    assert_eq!(
        again.prediction.unwrap().id,
        first["prediction"]["id"].as_i64()
    );
    assert_eq!(waypoints(&app, routine).await.len(), 4);

    let e = c.append_waypoint(append(4, &copy[4])).await.unwrap_err();
    assert_eq!(e.code(), tonic::Code::FailedPrecondition, "{e:?}");
    let e = c.append_waypoint(append(0, &copy[4])).await.unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e:?}");
    assert_eq!(waypoints(&app, routine).await.len(), 4);

    let next = c
        .append_waypoint(append(5, &copy[4]))
        .await
        .unwrap()
        .into_inner();
    assert!(!next.repeat);
    assert_eq!(next.waypoint.unwrap().seq, 5);
    let again = c
        .append_waypoint(append(5, &copy[4]))
        .await
        .unwrap()
        .into_inner();
    assert!(again.repeat);
    assert_eq!(waypoints(&app, routine).await.len(), 5);
}
