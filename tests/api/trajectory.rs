//! Hand-guided teaching: `POST /v1/routines/{id}/trajectory` (and gRPC `AppendTrajectory`)
//! cuts a recorded trajectory into segments whose attractors become taught waypoints, each
//! answered with its prediction; `preview` stores nothing; a refused request changes nothing.

use nalgebra::UnitQuaternion;
use nextpose::api::{TrajectoryAnswer, TrajectoryRequest};
use nextpose::client::{GrpcClient, RestClient};
use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use reqwest::StatusCode;
use serde_json::{Value, json};
use tonic::Code;

use crate::helpers::*;

/// The corners of a 100 mm square at height 300, tool pointing down, placed at `origin`.
fn square(origin: [f64; 2]) -> Vec<[f64; 3]> {
    let [x, y] = origin;
    vec![
        [x, y, 300.0],
        [x + 100.0, y, 300.0],
        [x + 100.0, y + 100.0, 300.0],
        [x, y + 100.0, 300.0],
        [x, y, 300.0],
    ]
}

fn down() -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0)
}

fn pose_at(p: [f64; 3]) -> Value {
    let q = down();
    json!({ "x": p[0], "y": p[1], "z": p[2], "qw": q.w, "qx": q.i, "qy": q.j, "qz": q.k })
}

/// A recording through `corners` at 10 mm steps (0.1 s apart), each sample with six joint
/// values (made up: the arm model does not check taught joints against the pose).
fn recording(corners: &[[f64; 3]]) -> Vec<Value> {
    let mut out = Vec::new();
    let mut t = 0.0;
    let mut push = |p: [f64; 3], out: &mut Vec<Value>| {
        let k = out.len() as f64;
        out.push(json!({
            "t": t,
            "pose": pose_at(p),
            "joints": [0.01 * k, -0.5, 0.5, 0.0, 1.0, 0.001 * k],
        }));
        t += 0.1;
    };
    push(corners[0], &mut out);
    for w in corners.windows(2) {
        let (a, b) = (w[0], w[1]);
        let length = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
        let steps = (length / 10.0).round() as usize;
        for s in 1..=steps {
            let f = s as f64 / steps as f64;
            push(
                [
                    a[0] + f * (b[0] - a[0]),
                    a[1] + f * (b[1] - a[1]),
                    a[2] + f * (b[2] - a[2]),
                ],
                &mut out,
            );
        }
    }
    out
}

fn path(routine: i64) -> String {
    format!("/v1/routines/{routine}/trajectory")
}

/// A cell (reach flagged, as `TestApp::create_cell`), a program and an open routine.
async fn open_routine(app: &TestApp, name: &str) -> (i64, i64, i64) {
    let cell = app.create_cell(name).await;
    let program = app.create_program(cell, "p").await;
    let routine = app.create_routine(program).await;
    (cell, program, routine)
}

fn near(a: &Value, b: [f64; 3], mm: f64) -> bool {
    distance(a, &pose_at(b)) < mm
}

#[tokio::test]
async fn a_square_becomes_its_corners_each_with_a_prediction() {
    let app = spawn_app().await;
    let (_, _, routine) = open_routine(&app, "square").await;
    let corners = square([400.0, -50.0]);
    let samples = recording(&corners);
    assert_eq!(samples.len(), 41);
    let body = json!({ "samples": samples });
    let answer = app
        .post_ok(&path(routine), &body, StatusCode::CREATED)
        .await;

    assert_eq!(answer["preview"], false);
    // The start (the routine was empty), then the four attractors: the corners in order.
    assert_eq!(answer["start"]["sample"], 0);
    assert_eq!(answer["start"]["taught"], true);
    let attractors = answer["attractors"].as_array().unwrap();
    let at: Vec<u64> = attractors
        .iter()
        .map(|a| a["sample"].as_u64().unwrap())
        .collect();
    assert_eq!(at, vec![10, 20, 30, 40], "{answer}");
    let waypoints = answer["waypoints"].as_array().unwrap();
    assert_eq!(waypoints.len(), corners.len());
    for (i, (taught, corner)) in waypoints.iter().zip(&corners).enumerate() {
        let w = &taught["waypoint"];
        assert_eq!(w["seq"], i as i64 + 1);
        assert!(near(&w["pose"], *corner, 1e-6), "{w} is not at {corner:?}");
        // The recorded sample's joints, as recorded.
        let sample = if i == 0 { 0 } else { at[i - 1] as usize };
        assert_eq!(w["joints"], samples[sample]["joints"]);
        assert!(w["reachable"].is_boolean());
        let p = &taught["prediction"];
        assert_eq!(p["after_waypoints"], i as i64 + 1);
        // Nothing learned yet in this cell: withheld, and said why.
        assert_eq!(p["offered"], false, "{p}");
        assert!(p["withheld"]["reason"].is_string(), "{p}");
    }
    let segmentation = &answer["segmentation"];
    assert_eq!(segmentation["samples"], 41);
    assert_eq!(segmentation["segments"].as_array().unwrap().len(), 4);
    for s in segmentation["segments"].as_array().unwrap() {
        assert_eq!(s["r"].as_array().unwrap().len(), 36);
    }
    assert_eq!(segmentation["raw_parameters"], 41 * 6);
    assert_eq!(segmentation["parameters"], 4 * 42);
    assert!(
        segmentation["mean_error_mm"].as_f64().unwrap() < 5.0,
        "{segmentation}"
    );

    // Stored as answered.
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["waypoint_count"], corners.len() as i64);
    let stored: Vec<&Value> = detail["waypoints"].as_array().unwrap().iter().collect();
    for (s, t) in stored.iter().zip(waypoints) {
        assert_eq!(*s, &t["waypoint"]);
    }

    // A second trajectory starting where the routine ends: the start is not appended again.
    let more = recording(&[corners[0], [400.0, -50.0, 400.0]]);
    let answer = app
        .post_ok(
            &path(routine),
            &json!({ "samples": more }),
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(answer["start"]["taught"], false);
    let waypoints = answer["waypoints"].as_array().unwrap();
    assert_eq!(waypoints.len(), 1);
    assert_eq!(waypoints[0]["waypoint"]["seq"], 6);
    assert!(near(
        &waypoints[0]["waypoint"]["pose"],
        [400.0, -50.0, 400.0],
        1e-6
    ));
}

#[tokio::test]
async fn a_preview_stores_nothing_and_shows_what_would_be_appended() {
    let app = spawn_app().await;
    let (cell, _, routine) = open_routine(&app, "preview").await;
    let before = app.get_ok(&format!("/v1/routines/{routine}")).await;
    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let body = json!({
        "samples": recording(&square([0.0, 400.0])),
        "preview": true,
        "settings": { "epsilon_max": 0.6, "criterion": "direction", "min_step_mm": 2.0 },
    });
    let answer = app.post_ok(&path(routine), &body, StatusCode::OK).await;
    assert_eq!(answer["preview"], true);
    assert_eq!(answer["waypoints"], json!([]));
    assert_eq!(answer["start"]["taught"], true);
    let attractors = answer["attractors"].as_array().unwrap();
    assert_eq!(attractors.len(), 4);
    assert!(attractors.iter().all(|a| a["taught"] == true));
    for (a, corner) in attractors.iter().zip(&square([0.0, 400.0])[1..]) {
        assert!(near(&a["pose"], *corner, 1e-6), "{a}");
        assert_eq!(a["joints"].as_array().unwrap().len(), 6);
    }
    let segments = answer["segmentation"]["segments"].as_array().unwrap();
    assert_eq!(segments[0]["from"], 0);
    assert_eq!(segments[0]["to"], 10);
    assert!(segments[0]["epsilon"].as_f64().unwrap() > 0.6);
    assert!(segments[3]["epsilon"].is_null());

    // Nothing changed: the routine, the model, and the next append is the first.
    assert_eq!(app.get_ok(&format!("/v1/routines/{routine}")).await, before);
    assert_eq!(app.get_ok(&format!("/v1/cells/{cell}/stats")).await, stats);
    let taught = app.append(routine, &pose_at([0.0, 0.0, 300.0])).await;
    assert_eq!(taught["waypoint"]["seq"], 1);
}

/// Every mistake is a 4xx naming the problem, and the routine is as it was.
#[tokio::test]
async fn bad_trajectories_are_refused_and_change_nothing() {
    let app = spawn_app().await;
    let (_, program, routine) = open_routine(&app, "refusals").await;
    // One waypoint already, so "unchanged" means something.
    app.append(routine, &pose_at([0.0, 0.0, 250.0])).await;
    let before = app.get_ok(&format!("/v1/routines/{routine}")).await;
    let good = recording(&square([0.0, 0.0]));
    let with = |f: &dyn Fn(&mut Vec<Value>)| {
        let mut s = good.clone();
        f(&mut s);
        json!({ "samples": s })
    };

    let mut bad_quaternion = with(&|s| s[7]["pose"]["qw"] = json!(0.3));
    bad_quaternion["preview"] = json!(true);
    let too_many: Vec<Value> = (0..20_001)
        .map(|i| json!({ "t": i, "pose": { "x": i, "y": 0, "z": 0, "qw": 1, "qx": 0, "qy": 0, "qz": 0 } }))
        .collect();
    let cases: Vec<(&str, Value, StatusCode, &str, &str)> = vec![
        (
            "no samples",
            json!({ "samples": [] }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_trajectory",
            "at least 2",
        ),
        (
            "samples missing",
            json!({}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unprocessable",
            "samples",
        ),
        (
            "one sample",
            json!({ "samples": [good[0]] }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_trajectory",
            "got 1",
        ),
        (
            "time repeated",
            with(&|s| s[5]["t"] = s[4]["t"].clone()),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_trajectory",
            "sample 5",
        ),
        (
            "time backwards",
            with(&|s| s[30]["t"] = json!(-1.0)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_trajectory",
            "sample 30",
        ),
        (
            "bad quaternion",
            bad_quaternion,
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_pose",
            "sample 7",
        ),
        (
            "position too far",
            with(&|s| s[3]["pose"]["x"] = json!(1e300)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_pose",
            "sample 3: invalid pose: x = 1e300 is outside ±100000 mm",
        ),
        (
            "five joints",
            with(&|s| {
                for x in s.iter_mut() {
                    x["joints"] = json!([0, 0, 0, 0, 0])
                }
            }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid",
            "6 values",
        ),
        (
            "joints on some",
            with(&|s| s[9]["joints"] = Value::Null),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid",
            "sample 9",
        ),
        (
            "joints count differs",
            with(&|s| s[2]["joints"] = json!([0, 0, 0])),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid",
            "sample 2",
        ),
        (
            "thirteen joints",
            with(&|s| {
                for x in s.iter_mut() {
                    x["joints"] = json!(vec![0.0; 13])
                }
            }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid",
            "1 to 12",
        ),
        (
            "too many samples",
            json!({ "samples": too_many }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid",
            "at most 20000",
        ),
        (
            "unknown field",
            json!({ "samples": good, "smooth": true }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unprocessable",
            "smooth",
        ),
        (
            "unknown sample field",
            with(&|s| s[1]["speed"] = json!(1)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unprocessable",
            "speed",
        ),
        (
            "unknown setting",
            json!({ "samples": good, "settings": { "epsilon": 1 } }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unprocessable",
            "epsilon",
        ),
        (
            "epsilon_max zero",
            json!({ "samples": good, "settings": { "epsilon_max": 0 } }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_settings",
            "epsilon_max",
        ),
        (
            "min_step_mm negative",
            json!({ "samples": good, "settings": { "min_step_mm": -1 } }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_settings",
            "min_step_mm",
        ),
        (
            "rank_tolerance one",
            json!({ "samples": good, "settings": { "rank_tolerance": 1 } }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_settings",
            "rank_tolerance",
        ),
        (
            "rotation weight huge",
            json!({ "samples": good, "settings": { "rotation_mm_per_rad": 1e6 } }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_settings",
            "rotation_mm_per_rad",
        ),
        (
            "min_segment_steps zero",
            json!({ "samples": good, "settings": { "min_segment_steps": 0 } }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_settings",
            "min_segment_steps",
        ),
        (
            "min_segment_steps above the most samples",
            json!({ "samples": good, "settings": { "min_segment_steps": 20001 } }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_settings",
            "min_segment_steps",
        ),
        (
            "unknown criterion",
            json!({ "samples": good, "settings": { "criterion": "angle" } }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unprocessable",
            "criterion",
        ),
        (
            "pose as an array",
            with(&|s| s[0]["pose"] = json!([0, 0, 0, 1, 0, 0, 0])),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unprocessable",
            "pose",
        ),
        (
            "nothing to append",
            json!({ "samples": [
            { "t": 0, "pose": pose_at([0.0, 0.0, 250.0]) },
            { "t": 1, "pose": pose_at([0.0, 0.0, 250.5]) },
        ] }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid",
            "nothing to append",
        ),
    ];
    for (what, body, status, code, says) in cases {
        let r = app.post(&path(routine), &body).await;
        let message = expect_error(r, status, code).await;
        assert!(
            message.contains(says),
            "{what}: {message:?} does not say {says:?}"
        );
        assert_eq!(
            app.get_ok(&format!("/v1/routines/{routine}")).await,
            before,
            "{what} changed the routine"
        );
    }

    // A number JSON cannot hold, and a body that is not JSON at all.
    for text in [
        r#"{"samples": [{"t": 1e999, "pose": {"x": 0, "y": 0, "z": 0, "qw": 1, "qx": 0, "qy": 0, "qz": 0}}]}"#,
        r#"{"samples": [{"t": NaN}]}"#,
    ] {
        let r = app
            .client
            .post(app.url(&path(routine)))
            .header("content-type", "application/json")
            .body(text)
            .send()
            .await
            .unwrap();
        expect_error(r, StatusCode::BAD_REQUEST, "bad_request").await;
    }

    // No such routine; a finished one.
    let body = json!({ "samples": good });
    let r = app.post(&path(999_999), &body).await;
    expect_error(r, StatusCode::NOT_FOUND, "not_found").await;
    app.finish(routine).await;
    let finished = app.get_ok(&format!("/v1/routines/{routine}")).await;
    let r = app.post(&path(routine), &body).await;
    let message = expect_error(r, StatusCode::CONFLICT, "conflict").await;
    assert!(message.contains("finished"), "{message}");
    let mut preview = body.clone();
    preview["preview"] = json!(true);
    let r = app.post(&path(routine), &preview).await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    assert_eq!(
        app.get_ok(&format!("/v1/routines/{routine}")).await,
        finished
    );

    // The program's next routine takes the same trajectory.
    let next = app.create_routine(program).await;
    app.post_ok(&path(next), &body, StatusCode::CREATED).await;
}

/// gRPC answers what REST answers, for the same trajectory in two fresh cells; gRPC refuses a
/// sample without a pose and a time that is not a number.
#[tokio::test]
async fn grpc_answers_as_rest_does() {
    let app = spawn_app().await;
    let rest = RestClient::new(&app.base, None);
    let grpc = GrpcClient::connect(&app.base, None).await.unwrap();
    let samples = json!(recording(&square([300.0, 300.0])));
    let request: TrajectoryRequest = serde_json::from_value(json!({
        "samples": samples,
        "settings": { "criterion": "seed", "epsilon_max": 0.9, "zeta_mm": 0.25 },
    }))
    .unwrap();
    let mut answers: Vec<TrajectoryAnswer> = Vec::new();
    let mut routines = Vec::new();
    for (i, preview) in [(0, true), (1, true), (0, false), (1, false)] {
        if routines.len() <= i {
            routines.push(open_routine(&app, &format!("parity-{i}")).await.2);
        }
        let request = TrajectoryRequest {
            preview,
            ..request.clone()
        };
        let answer = if i == 0 {
            rest.append_trajectory(routines[i], &request).await.unwrap()
        } else {
            grpc.append_trajectory(routines[i], &request).await.unwrap()
        };
        answers.push(answer);
    }
    for pair in answers.chunks(2) {
        let (a, b) = (&pair[0], &pair[1]);
        assert_eq!(a.preview, b.preview);
        assert_eq!(a.start, b.start);
        assert_eq!(a.attractors, b.attractors);
        assert_eq!(a.segmentation, b.segmentation);
        assert_eq!(a.waypoints.len(), b.waypoints.len());
        for (x, y) in a.waypoints.iter().zip(&b.waypoints) {
            assert_eq!(x.waypoint.seq, y.waypoint.seq);
            assert_eq!(x.waypoint.pose, y.waypoint.pose);
            assert_eq!(x.waypoint.joints, y.waypoint.joints);
            assert_eq!(x.waypoint.reachable, y.waypoint.reachable);
            assert_eq!(x.prediction, y.prediction);
        }
    }
    assert!(answers[0].waypoints.is_empty());
    let taught = answers[2].attractors.iter().filter(|a| a.taught).count();
    assert_eq!(answers[2].waypoints.len(), taught + 1);

    // Errors: the same refusals as REST, by status code.
    let mut raw = NextposeClient::connect(app.base.clone()).await.unwrap();
    let routine = open_routine(&app, "grpc-errors").await.2;
    let mut r = nextpose::grpc::convert::trajectory_request_out(routine, request.clone());
    r.samples[3].t = f64::NAN;
    let e = raw.append_trajectory(r.clone()).await.unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    assert_eq!(
        e.metadata().get("x-error-code").unwrap(),
        "invalid_trajectory"
    );
    assert!(e.message().contains("sample 3"), "{}", e.message());
    r.samples[3].t = 0.35;
    r.samples[3].pose = None;
    let e = raw.append_trajectory(r.clone()).await.unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument);
    assert!(e.message().contains("samples[3].pose"), "{}", e.message());
    r.samples[3].pose = Some(pb::Pose {
        x: f64::INFINITY,
        qw: 1.0,
        ..Default::default()
    });
    let e = raw.append_trajectory(r.clone()).await.unwrap_err();
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "invalid_pose");
    r.routine_id = 999_999;
    let e = raw.append_trajectory(r).await.unwrap_err();
    assert_eq!(
        e.code(),
        Code::InvalidArgument,
        "input is checked first: {e:?}"
    );
    let mut r = nextpose::grpc::convert::trajectory_request_out(999_999, request);
    r.preview = true;
    let e = raw.append_trajectory(r).await.unwrap_err();
    assert_eq!(e.code(), Code::NotFound);
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["waypoint_count"], 0);
}

/// After a trajectory the routine goes on as any other: single appends follow it, the model
/// learned its waypoints (a second routine taught by trajectory is predicted from the first),
/// and a rebuild from the database gives the model in memory.
#[tokio::test]
async fn the_model_learns_taught_trajectories() {
    let app = spawn_app().await;
    let (cell, program, first) = open_routine(&app, "learning").await;
    let corners = square([0.0, 0.0]);
    app.post_ok(
        &path(first),
        &json!({ "samples": recording(&corners) }),
        StatusCode::CREATED,
    )
    .await;
    let taught = app.append(first, &pose_at([0.0, 0.0, 400.0])).await;
    assert_eq!(taught["waypoint"]["seq"], 6);
    app.finish(first).await;

    // The same square elsewhere: once its first moves are taught, the next corner is offered.
    let second = app.create_routine(program).await;
    let moved = square([500.0, 200.0]);
    let answer = app
        .post_ok(
            &path(second),
            &json!({ "samples": recording(&moved) }),
            StatusCode::CREATED,
        )
        .await;
    let waypoints = answer["waypoints"].as_array().unwrap();
    assert_eq!(waypoints.len(), 5);
    let offered: Vec<usize> = (0..4)
        .filter(|&i| waypoints[i]["prediction"]["offered"] == true)
        .collect();
    assert!(!offered.is_empty(), "nothing offered: {waypoints:?}");
    for i in offered {
        let p = &waypoints[i]["prediction"];
        assert!(p["id"].is_i64());
        assert!(
            near(&p["pose"], moved[i + 1], 1.0),
            "after waypoint {}: {p}",
            i + 1
        );
    }
    // What follows the square in the first routine is offered after the square here.
    let last = &waypoints[4]["prediction"];
    assert_eq!(last["offered"], true, "{last}");
    assert!(near(&last["pose"], [500.0, 200.0, 400.0], 1.0), "{last}");

    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let rebuilt = app.rebuild(cell).await;
    assert_eq!(rebuilt, stats["model"]);
    let next = app.append(second, &pose_at([500.0, 200.0, 400.0])).await;
    assert_eq!(next["waypoint"]["seq"], 6);
}

/// Thousands of samples with joints, written at full precision, fit the default body limit.
#[tokio::test]
async fn a_long_recording_fits_the_default_body_limit() {
    let app = spawn_app().await;
    let (_, _, routine) = open_routine(&app, "long").await;
    // A spiral of 5000 samples 1.1 mm apart, with irrational-looking numbers everywhere.
    let samples: Vec<Value> = (0..5000)
        .map(|i| {
            let a = i as f64 * 0.011;
            let q =
                UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.1 * a.sin(), a * 0.01);
            json!({
                "t": i as f64 * 0.004 + 0.123456789,
                "pose": {
                    "x": 400.0 + 100.0 * a.cos() + 0.123456789, "y": 100.0 * a.sin() - 0.987654321,
                    "z": 300.0 + 0.01 * i as f64 + 1e-9,
                    "qw": q.w, "qx": q.i, "qy": q.j, "qz": q.k,
                },
                "joints": [a.sin(), a.cos(), 0.5 + a * 1e-3, -a.sin(), 1.0 / (1.0 + a), a.sqrt()],
            })
        })
        .collect();
    let body = json!({ "samples": samples, "preview": true });
    assert!(serde_json::to_vec(&body).unwrap().len() > 1_500_000);
    let answer = app.post_ok(&path(routine), &body, StatusCode::OK).await;
    assert_eq!(answer["segmentation"]["samples"], 5000);
    assert!(!answer["attractors"].as_array().unwrap().is_empty());
}

/// Single appends sent while a trajectory is appended land before or after its waypoints,
/// never between them: the cell's lock is held for the whole trajectory.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn single_appends_do_not_interleave_with_a_trajectory() {
    let app = spawn_app().await;
    let (_, _, routine) = open_routine(&app, "interleave").await;
    let corners = square([200.0, 200.0]);
    let body = json!({ "samples": recording(&corners) });
    let singles = (0..6).map(|i| {
        let app = &app;
        async move {
            app.append(routine, &pose_at([0.0, 10.0 * i as f64, 500.0]))
                .await
        }
    });
    let at = path(routine);
    let (answer, _) = tokio::join!(
        app.post_ok(&at, &body, StatusCode::CREATED),
        futures_util::future::join_all(singles)
    );
    let seqs: Vec<i64> = answer["waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["waypoint"]["seq"].as_i64().unwrap())
        .collect();
    assert_eq!(seqs.len(), corners.len());
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    let stored = detail["waypoints"].as_array().unwrap();
    assert_eq!(stored.len(), corners.len() + 6);
    for (seq, corner) in seqs.iter().zip(&corners) {
        assert!(near(&stored[*seq as usize - 1]["pose"], *corner, 1e-6));
    }
}

/// Below the API: several appends to one routine commit in one transaction, or none of them
/// does (a stale cell, a place taken in the middle).
#[tokio::test]
async fn the_store_appends_several_waypoints_all_or_nothing() {
    use nextpose::engine::PoseValues;
    use nextpose::storage::{Durability, NewPrediction, NewWaypoint, StorageError, Store};
    let dir = tempfile::tempdir().unwrap();
    let db = test_database(dir.path()).await;
    let store = Store::connect(&db, Durability::Process).await.unwrap();
    let cell = store.insert_cell("all-or-nothing", "{}").await.unwrap();
    let program = store.insert_program(cell.id, "p").await.unwrap();
    let (routine, state) = store
        .insert_routine(&program, None, cell.revision)
        .await
        .unwrap();
    let item = |seq: i64| {
        let pose = PoseValues {
            x: seq as f64,
            y: 0.0,
            z: 0.0,
            qw: 1.0,
            qx: 0.0,
            qy: 0.0,
            qz: 0.0,
        };
        let waypoint = NewWaypoint {
            routine_id: routine,
            seq,
            pose,
            joints: Some("[0.5]".into()),
            motion: None,
            name: None,
            reachable: None,
        };
        let prediction = (seq % 2 == 0).then_some(NewPrediction {
            cell_id: cell.id,
            routine_id: routine,
            after_seq: seq,
            pose,
            phi: 0.8,
            psi: 1.0,
            misfit: None,
            end_probability: 0.0,
            model_version: 0,
        });
        (waypoint, prediction)
    };
    let revision = state.revision;
    let stale = store
        .append_waypoints(cell.id, revision - 1, &[item(1), item(2)])
        .await;
    assert!(
        matches!(stale, Err(StorageError::Stale { .. })),
        "{stale:?}"
    );
    let taken = store
        .append_waypoints(cell.id, revision, &[item(1), item(2), item(1)])
        .await;
    assert!(matches!(taken, Err(StorageError::Conflict(_))), "{taken:?}");
    assert!(store.waypoints(routine).await.unwrap().is_empty());
    assert_eq!(
        store.cell_state(cell.id).await.unwrap().unwrap().revision,
        revision
    );

    let done = store
        .append_waypoints(cell.id, revision, &[item(1), item(2), item(3)])
        .await
        .unwrap();
    let rows = store.waypoints(routine).await.unwrap();
    assert_eq!(rows.len(), 3);
    for (d, row) in done.iter().zip(&rows) {
        assert_eq!(d.row.id, row.id);
        assert_eq!(d.revision, revision + 1);
        assert_eq!(d.prediction_id.is_some(), row.seq == 2);
    }
    let id = done[1].prediction_id.unwrap();
    let p = store.prediction(id).await.unwrap().unwrap();
    assert_eq!(p.after_seq, 2);
}
