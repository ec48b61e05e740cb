//! Requests abandoned at random points (the client hangs up, a unary gRPC call is cancelled)
//! must leave a cell's model, its stored routines and the next sequence number consistent:
//! an operation either happens whole (database and model) or not at all.
//!
//! Consistency is checked with what always holds, whatever is still in flight:
//! - every stored routine's waypoints are numbered 1..n;
//! - an append answers with `seq` equal to the number of waypoints its model saw
//!   (`prediction.after_waypoints`);
//! - a rebuild finds the model in memory equal to the one rebuilt from the database
//!   (`nextpose_model_divergences_total` stays 0);
//!
//! and once more after a restart.

use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use reqwest::StatusCode;
use serde_json::{Value, json};
use tonic::Code;
use tonic::transport::Channel;

use crate::grpc::client::pb_pose;
use crate::helpers::*;

/// Poses of a seam taught again and again at other places, so the model has something to
/// predict from and every append does real work.
fn pose_at(i: usize) -> Value {
    let seam = u_seam(
        [400.0 + 7.0 * (i / 8) as f64, -50.0, 300.0],
        0.1 * (i / 8) as f64,
    );
    seam[i % 8].clone()
}

/// What the client does next.
#[derive(Debug, Clone, Copy)]
enum Op {
    Append,
    Undo,
    Predict,
    Finish,
}

fn pick(rng: &mut StdRng) -> Op {
    match rng.random_range(0..100) {
        0..60 => Op::Append,
        60..80 => Op::Undo,
        80..92 => Op::Predict,
        _ => Op::Finish,
    }
}

/// How long a whole request of each kind takes here, counted in turns of the scheduler (the
/// test's runtime is single-threaded, so the server's tasks and the client's take turns), so
/// that hang-ups land at random points across it on a fast or a loaded machine alike. (Timers
/// tick in milliseconds, longer than a whole request.)
struct Latency([f64; 4]);

impl Latency {
    fn new() -> Latency {
        Latency([20.0; 4])
    }

    /// A random point within a typical request of this kind.
    fn point(&self, op: Op, rng: &mut StdRng) -> usize {
        (self.0[op as usize] * rng.random_range(0.0..1.0)) as usize
    }

    /// Runs `request` to its end, learning how many turns it took.
    async fn whole<T>(&mut self, op: Op, request: impl Future<Output = T>) -> T {
        let mut turns = 0usize;
        let counting = async {
            loop {
                tokio::task::yield_now().await;
                turns += 1;
            }
        };
        let out = tokio::select! {
            biased;
            out = request => out,
            _ = counting => unreachable!(),
        };
        let d = &mut self.0[op as usize];
        *d = 0.7 * *d + 0.3 * turns as f64;
        out
    }
}

/// Runs `request` for at most `turns` turns of the scheduler, then drops it.
async fn for_turns<T>(turns: usize, request: impl Future<Output = T>) -> Option<T> {
    let give_up = async {
        for _ in 0..turns {
            tokio::task::yield_now().await;
        }
    };
    tokio::select! {
        biased;
        out = request => Some(out),
        _ = give_up => None,
    }
}

/// A routine's waypoints are numbered 1..n; returns n.
async fn check_seqs(app: &TestApp, routine: i64) -> usize {
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    let seqs: Vec<i64> = detail["waypoints"]
        .as_array()
        .expect("waypoints")
        .iter()
        .map(|w| w["seq"].as_i64().expect("seq"))
        .collect();
    let expected: Vec<i64> = (1..=seqs.len() as i64).collect();
    assert_eq!(
        seqs, expected,
        "routine {routine}: waypoint numbers have gaps"
    );
    assert_eq!(detail["waypoint_count"].as_u64(), Some(seqs.len() as u64));
    seqs.len()
}

/// Every routine of the program is numbered 1..n, and a rebuild finds the model in step.
async fn check_consistent(app: &TestApp, cell: i64, program: i64) {
    let routines = app
        .get_ok(&format!("/v1/programs/{program}/routines"))
        .await;
    for r in routines.as_array().expect("routines") {
        check_seqs(app, r["id"].as_i64().expect("id")).await;
    }
    app.rebuild(cell).await;
    let metrics = app.get("/metrics").await.text().await.unwrap();
    assert_eq!(
        sample(&metrics, "nextpose_model_divergences_total"),
        Some(0.0),
        "a rebuild found the model in memory out of step with the database"
    );
}

/// A cell with two finished seams and a routine open.
async fn setup(app: &TestApp, name: &str) -> (i64, i64, i64) {
    let cell = app.create_cell(name).await;
    let program = app.create_program(cell, "p").await;
    for k in 0..2 {
        let poses: Vec<Value> = (0..8).map(|i| pose_at(8 * k + i)).collect();
        app.teach_routine(program, &poses).await;
    }
    let routine = app.create_routine(program).await;
    (cell, program, routine)
}

/// Keeps the open routine open: when it was finished (by a request whose answer was lost,
/// perhaps), starts the next one.
async fn reopen(app: &TestApp, program: i64, routine: i64) -> i64 {
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    if detail["finished"] == json!(true) {
        let r = app
            .post(&format!("/v1/programs/{program}/routines"), &json!({}))
            .await;
        match r.status() {
            StatusCode::CREATED => {
                return expect(r, StatusCode::CREATED).await["id"].as_i64().unwrap();
            }
            // An abandoned finish of the routine may still be on its way: try again later.
            StatusCode::CONFLICT => {}
            s => panic!("creating a routine answered {s}"),
        }
    }
    routine
}

/// A request answered in full: never a server error; an append's number agrees with its model.
async fn answered(r: reqwest::Response, op: Op) {
    let status = r.status();
    let body = r.text().await.expect("body");
    assert!(
        !status.is_server_error(),
        "{op:?} answered {status}: {body}"
    );
    if let (Op::Append, StatusCode::CREATED) = (op, status) {
        let v: Value = serde_json::from_str(&body).expect("json");
        assert_eq!(
            v["waypoint"]["seq"], v["prediction"]["after_waypoints"],
            "the stored number differs from the model's count: {v}"
        );
    }
}

/// The checks once more, then once more after a restart, when the database alone holds the
/// truth; and the next append gets the next number.
async fn after_restart(app: TestApp, cell: i64, program: i64, routine: i64, pose: usize) {
    check_consistent(&app, cell, program).await;
    let app = app.restart().await;
    check_consistent(&app, cell, program).await;
    let routine = reopen(&app, program, routine).await;
    let n = check_seqs(&app, routine).await;
    let taught = app.append(routine, &pose_at(pose)).await;
    assert_eq!(taught["waypoint"]["seq"], json!(n + 1));
    assert_eq!(taught["prediction"]["after_waypoints"], json!(n + 1));
    check_consistent(&app, cell, program).await;
}

#[tokio::test]
async fn rest_requests_abandoned_at_random_points_leave_model_and_database_in_step() {
    let app = spawn_app().await;
    let (cell, program, mut routine) = setup(&app, "abandoned-rest").await;
    let mut rng = StdRng::seed_from_u64(12);
    let mut abandoned = 0;
    let mut latency = Latency::new();
    let mut next_pose = 16;
    for step in 0..240 {
        let op = pick(&mut rng);
        let request = match op {
            Op::Append => {
                next_pose += 1;
                app.client
                    .post(app.url(&format!("/v1/routines/{routine}/waypoints")))
                    .json(&json!({ "pose": pose_at(next_pose) }))
            }
            Op::Undo => app
                .client
                .delete(app.url(&format!("/v1/routines/{routine}/waypoints/last"))),
            Op::Predict => app
                .client
                .get(app.url(&format!("/v1/routines/{routine}/prediction?k=3"))),
            Op::Finish => app
                .client
                .post(app.url(&format!("/v1/routines/{routine}/finish")))
                .json(&json!({})),
        };
        if rng.random_bool(0.5) {
            // The client hangs up after a random time: before sending, while the server
            // works, or after it answered.
            let turns = latency.point(op, &mut rng);
            if let Some(r) = for_turns(turns, request.send()).await {
                answered(r.expect("request"), op).await;
            } else {
                abandoned += 1;
            }
        } else {
            let r = latency.whole(op, request.send()).await;
            answered(r.expect("request"), op).await;
        }
        routine = reopen(&app, program, routine).await;
        if step % 40 == 39 {
            check_consistent(&app, cell, program).await;
        }
    }
    eprintln!("REST: {abandoned} of 240 requests abandoned");
    assert!(abandoned > 10, "only {abandoned} requests were abandoned");
    after_restart(app, cell, program, routine, next_pose + 1).await;
}

#[tokio::test]
async fn grpc_calls_cancelled_at_random_points_leave_model_and_database_in_step() {
    let app = spawn_app().await;
    let (cell, program, mut routine) = setup(&app, "abandoned-grpc").await;
    let channel = Channel::from_shared(app.base.clone())
        .expect("uri")
        .connect()
        .await
        .expect("connect");
    let client = NextposeClient::new(channel);
    let mut rng = StdRng::seed_from_u64(13);
    let mut cancelled = 0;
    let mut latency = Latency::new();
    let mut next_pose = 16;
    for step in 0..240 {
        let op = pick(&mut rng);
        let cancel = rng.random_bool(0.5).then(|| latency.point(op, &mut rng));
        let mut c = client.clone();
        let call = async {
            match op {
                Op::Append => {
                    next_pose += 1;
                    c.append_waypoint(pb::AppendWaypointRequest {
                        routine_id: routine,
                        waypoint: Some(pb::NewWaypoint {
                            pose: Some(pb_pose(&pose_at(next_pose))),
                            ..Default::default()
                        }),
                    })
                    .await
                    .map(|r| {
                        let t = r.into_inner();
                        let seq = t.waypoint.expect("waypoint").seq;
                        let after = t.prediction.expect("prediction").after_waypoints;
                        assert_eq!(seq, after, "stored number differs from the model's count");
                    })
                }
                Op::Undo => c
                    .undo(pb::UndoRequest {
                        routine_id: routine,
                    })
                    .await
                    .map(|_| ()),
                Op::Predict => c
                    .predict(pb::PredictRequest {
                        routine_id: routine,
                        k: Some(3),
                        ..Default::default()
                    })
                    .await
                    .map(|_| ()),
                Op::Finish => c
                    .finish_routine(pb::FinishRoutineRequest {
                        routine_id: routine,
                    })
                    .await
                    .map(|_| ()),
            }
        };
        let outcome = match cancel {
            Some(turns) => for_turns(turns, call).await,
            None => Some(latency.whole(op, call).await),
        };
        match outcome {
            None => cancelled += 1,
            Some(Ok(())) => {}
            Some(Err(status)) => assert!(
                matches!(status.code(), Code::FailedPrecondition | Code::NotFound),
                "{op:?} answered {status:?}"
            ),
        }
        routine = reopen(&app, program, routine).await;
        if step % 40 == 39 {
            check_consistent(&app, cell, program).await;
        }
    }
    eprintln!("gRPC: {cancelled} of 240 calls cancelled");
    assert!(cancelled > 10, "only {cancelled} calls were cancelled");
    drop(client);
    after_restart(app, cell, program, routine, next_pose + 1).await;
}
