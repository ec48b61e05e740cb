//! `Teach` sessions: one stream predicts what the REST loop predicts, and a stream dropped
//! with commands in flight leaves the routine open, consistent and teachable.

use nextpose::grpc::pb;
use nextpose::grpc::pb::teach_request::Command;
use serde_json::Value;

use super::client::{client, create_cell, waypoint};
use super::session::Teach;
use crate::helpers::*;

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
}

/// Compares a REST prediction (JSON) with a gRPC one.
pub(super) fn assert_same_prediction(rest: &Value, grpc: &pb::Prediction, at: &str) {
    assert_eq!(
        rest["offered"].as_bool(),
        Some(grpc.offered),
        "{at}: offered"
    );
    assert_eq!(
        rest["withheld"]["reason"].as_str(),
        grpc.withheld.as_ref().map(|w| w.reason.as_str()),
        "{at}: withheld reason"
    );
    assert!(same(rest["phi"].as_f64().unwrap(), grpc.phi), "{at}: phi");
    assert_eq!(rest["after_waypoints"].as_i64(), Some(grpc.after_waypoints));
    assert_eq!(rest["model_version"].as_i64(), Some(grpc.model_version));
    match (&rest["pose"], &grpc.pose) {
        (Value::Null, None) => {}
        (r, Some(g)) => {
            for (k, v) in [
                ("x", g.x),
                ("y", g.y),
                ("z", g.z),
                ("qw", g.qw),
                ("qx", g.qx),
                ("qy", g.qy),
                ("qz", g.qz),
            ] {
                assert!(same(r[k].as_f64().unwrap(), v), "{at}: pose.{k}");
            }
        }
        (r, g) => panic!("{at}: pose {r} vs {g:?}"),
    }
}

#[tokio::test]
async fn a_teach_stream_predicts_what_the_rest_loop_predicts() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let routines = [
        u_seam([0.0, 0.0, 0.0], 0.0),
        u_seam([800.0, -300.0, 50.0], 1.0),
        u_seam([-200.0, 400.0, 0.0], -0.6),
        u_seam([100.0, 100.0, 300.0], 2.2),
    ];

    // Cell A through REST.
    let rest_cell = app.create_cell("rest").await;
    let rest_program = app.create_program(rest_cell, "p").await;
    let mut rest = Vec::new();
    for r in &routines {
        rest.push(app.teach_routine(rest_program, r).await.1);
    }

    // Cell B through one Teach session.
    let cell = create_cell(&mut c, "grpc").await;
    let program = app.create_program(cell.id, "p").await;
    let mut session = Teach::open(&mut c).await;
    let mut offered = 0;
    for (i, r) in routines.iter().enumerate() {
        let routine = app.create_routine(program).await;
        let started = session.start(routine).await;
        assert_eq!(started.id, routine);
        assert_eq!(started.waypoint_count, 0);
        for (j, p) in r.iter().enumerate() {
            let taught = session.waypoint(p).await;
            assert_eq!(taught.waypoint.unwrap().seq, j as i64 + 1);
            let prediction = taught.prediction.unwrap();
            offered += usize::from(prediction.offered);
            assert_same_prediction(&rest[i][j], &prediction, &format!("routine {i} wp {j}"));
        }
        let finished = session.finish().await;
        assert_eq!(finished.model.unwrap().version, i as i64 + 1);
    }
    assert!(offered >= 8, "only {offered} predictions offered");
    drop(session);

    // Both cells learned the same model.
    let a = app.get_ok(&format!("/v1/cells/{rest_cell}/stats")).await;
    let b = app.get_ok(&format!("/v1/cells/{}/stats", cell.id)).await;
    assert_eq!(a["model"], b["model"]);
}

#[tokio::test]
async fn a_dropped_teach_stream_leaves_the_routine_open_and_consistent() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let cell = app.create_cell("drop").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let seam = u_seam([500.0, 0.0, 0.0], 0.3);
    let routine = app.create_routine(program).await;

    let mut session = Teach::open(&mut c).await;
    session.start(routine).await;
    for p in &seam[..3] {
        session.waypoint(p).await;
    }
    // Two more commands go out, then the client disappears without reading the answers.
    session.send(Command::Waypoint(waypoint(&seam[3]))).await;
    session.send(Command::Waypoint(waypoint(&seam[4]))).await;
    drop(session);
    // The server's session task has applied its last command once it stops counting itself.
    app.wait_for_metric("nextpose_grpc_teach_sessions", 0.0)
        .await;

    // The routine is still open, with the waypoints sent before the drop (the three answered
    // and whichever of the two in flight the server had applied), numbered without gaps.
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["finished"], false);
    let waypoints = detail["waypoints"].as_array().unwrap();
    let n = waypoints.len();
    assert!((3..=5).contains(&n), "{n} waypoints");
    assert_eq!(detail["waypoint_count"], n as i64);
    for (i, w) in waypoints.iter().enumerate() {
        assert_eq!(w["seq"], i as i64 + 1);
        assert!(distance(&w["pose"], &seam[i]) < 1e-9);
    }

    // Teaching goes on through REST, and through a new session.
    let next = app.append(routine, &seam[n]).await;
    assert_eq!(next["waypoint"]["seq"], n as i64 + 1);
    let mut session = Teach::open(&mut c).await;
    let started = session.start(routine).await;
    assert_eq!(started.waypoint_count, n as i64 + 1);
    let taught = session.waypoint(&seam[n + 1]).await;
    assert_eq!(taught.waypoint.unwrap().seq, n as i64 + 2);
    let finished = session.finish().await;
    assert_eq!(finished.routine.unwrap().waypoint_count, n as i64 + 2);
}
