//! The cell's arm as the pendant draws and jogs it (issue 16): `GET /v1/cells/{id}/frames`
//! gives every frame of the arm at a joint vector in the cell's work frame (base and tool
//! applied), `POST /v1/cells/{id}/reach` the joint solution nearest where the arm is; the same
//! over gRPC; bad input is a 4xx that names it. And the page itself: served at `/` without the
//! token, with its security and cache headers.

use std::time::Duration;

use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use nextpose::transport::TransportOptions;
use reqwest::StatusCode;
use reqwest::header;
use serde_json::{Value, json};

use crate::grpc::client::pb_pose;
use crate::helpers::*;

fn joints_of(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("joints")
        .iter()
        .map(|j| j.as_f64().expect("joint"))
        .collect()
}

fn query(q: &[f64]) -> String {
    q.iter().map(f64::to_string).collect::<Vec<_>>().join(",")
}

/// A cell whose robot stands off the work frame's origin, turned, with a 150 mm tool.
async fn mounted_cell(app: &TestApp, name: &str) -> i64 {
    let half = std::f64::consts::FRAC_PI_4.sin();
    app.create_cell_with(
        name,
        json!({
            "reach_policy": "flag",
            "base": { "x": 500.0, "y": -200.0, "z": 100.0,
                      "qw": std::f64::consts::FRAC_PI_4.cos(), "qx": 0.0, "qy": 0.0, "qz": half },
            "tool": { "x": 0.0, "y": 0.0, "z": 150.0, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0 }
        }),
    )
    .await
}

#[tokio::test]
async fn frames_are_the_arm_in_the_work_frame_and_reach_inverts_them() {
    let app = spawn_app().await;
    let cell = mounted_cell(&app, "drawn").await;
    let robot =
        nextpose::kinematics::load_robot(&nextpose::kinematics::bundled_robots_dir(), "abb_irb140")
            .expect("robot");
    let base = pose_of(&json!({ "x": 500.0, "y": -200.0, "z": 100.0,
        "qw": std::f64::consts::FRAC_PI_4.cos(), "qx": 0.0, "qy": 0.0,
        "qz": std::f64::consts::FRAC_PI_4.sin() }));
    let tool = nextpose::engine::Pose::new([0.0, 0.0, 150.0], [1.0, 0.0, 0.0, 0.0]).expect("tool");

    assert_eq!(app.get_ok("/healthz").await["token_required"], false);

    // The ready position: reachable, away from limits, the flange pointing down.
    let ready = app.get_ok(&format!("/v1/cells/{cell}/frames")).await;
    let q_ready = joints_of(&ready["joints"]);
    assert_eq!(q_ready.len(), 6);
    let q: [f64; 6] = q_ready.clone().try_into().expect("six");
    assert!(robot.within_limits(&q));
    assert_eq!(ready["robot"], "abb_irb140");

    for q in [q, [0.4, 0.3, -0.2, 0.5, 0.9, -0.7]] {
        let frames = app
            .get_ok(&format!("/v1/cells/{cell}/frames?joints={}", query(&q)))
            .await;
        assert_eq!(joints_of(&frames["joints"]), q.to_vec());
        let links = frames["links"].as_array().expect("links");
        assert_eq!(links.len(), 7, "the base and six joints");
        assert_eq!(links[0]["name"], "base_link");
        assert!(pose_of(&links[0]["pose"]).distance_to(&base) < 1e-9);
        // The base link, then the joints, each frame in the work frame.
        let in_base = robot.joint_frames(&q);
        for (link, f) in links[1..].iter().zip(&in_base) {
            let want = nextpose::engine::Pose::from_isometry(base.isometry() * f.isometry());
            let got = pose_of(&link["pose"]);
            assert!(got.distance_to(&want) < 1e-6, "{}", link["name"]);
            assert!(got.angle_to(&want) < 1e-9, "{}", link["name"]);
        }
        let flange =
            nextpose::engine::Pose::from_isometry(base.isometry() * robot.fk(&q).isometry());
        assert!(pose_of(&frames["flange"]).distance_to(&flange) < 1e-6);
        let tcp = pose_of(&frames["tcp"]);
        let want = nextpose::engine::Pose::from_isometry(flange.isometry() * tool.isometry());
        assert!(tcp.distance_to(&want) < 1e-6);
        assert!(
            (tcp.distance_to(&flange) - 150.0).abs() < 1e-6,
            "the tool is mounted"
        );

        // Reach from where the arm is gives these joints back.
        let reach = app
            .post_ok(
                &format!("/v1/cells/{cell}/reach"),
                &json!({ "pose": frames["tcp"], "near": q }),
                StatusCode::OK,
            )
            .await;
        assert_eq!(reach["reachable"], true, "{reach}");
        let chosen = joints_of(&reach["chosen"]);
        for (a, b) in chosen.iter().zip(&q) {
            assert!((a - b).abs() < 1e-6, "{chosen:?} vs {q:?}");
        }
    }

    // Far beyond the arm: not reachable, and why.
    let far = app
        .post_ok(
            &format!("/v1/cells/{cell}/reach"),
            &json!({ "pose": pose([4000.0, 0.0, 500.0], [0.0, 0.0, 0.0]) }),
            StatusCode::OK,
        )
        .await;
    assert_eq!(far["reachable"], false);
    assert_eq!(far["unreachable"]["reason"], "outside_reach");
    assert!(far["chosen"].is_null());
}

#[tokio::test]
async fn bad_joints_and_poses_are_422_and_change_nothing() {
    let app = spawn_app().await;
    let cell = app.create_cell("strict arm").await;
    let before = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    for (q, says) in [
        ("1,2", "6 joint values, not 2"),
        ("1,2,3,4,5,x", "value 6"),
        ("1,2,3,4,5,NaN", "not a finite number"),
        ("", "value 1"),
    ] {
        let r = app
            .get(&format!("/v1/cells/{cell}/frames?joints={q}"))
            .await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
        assert!(message.contains(says), "{q:?}: {message}");
    }
    let unknown = app.get(&format!("/v1/cells/{cell}/frames?joint=1")).await;
    assert_eq!(unknown.status(), StatusCode::BAD_REQUEST);
    expect_error(
        app.get("/v1/cells/999/frames").await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    let reach = format!("/v1/cells/{cell}/reach");
    let good = pose([400.0, 0.0, 500.0], [std::f64::consts::PI, 0.0, 0.0]);
    for (body, code, says) in [
        (
            json!({ "pose": good, "near": [0.0, 0.1] }),
            "invalid",
            "near must hold 6",
        ),
        // Joints the arm cannot be at: huge values answered with an arbitrary solution.
        (
            json!({ "pose": good, "near": [1e308, 1e308, 1e308, 1e308, 1e308, 1e308] }),
            "invalid",
            "near: joint 1 (joint_1) is 1.000e308 rad, outside its range",
        ),
        (
            json!({ "pose": good, "near": [0.0, 0.0, 2.0, 0.0, 0.5, 0.0] }),
            "invalid",
            "near: joint 3 (joint_3) is 2.0000 rad, outside its range -4.0143 to 0.8727 rad",
        ),
        (
            json!({ "pose": { "x": 1.0, "y": 0.0, "z": 0.0, "qw": 3.0, "qx": 0.0, "qy": 0.0, "qz": 0.0 } }),
            "invalid_pose",
            "quaternion",
        ),
    ] {
        let message = expect_error(
            app.post(&reach, &body).await,
            StatusCode::UNPROCESSABLE_ENTITY,
            code,
        )
        .await;
        assert!(message.to_lowercase().contains(says), "{body}: {message}");
    }
    let extra = app.post(&reach, &json!({ "pose": good, "speed": 3 })).await;
    assert_eq!(extra.status(), StatusCode::UNPROCESSABLE_ENTITY);
    expect_error(
        app.post("/v1/cells/999/reach", &json!({ "pose": good }))
            .await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    assert_eq!(app.get_ok(&format!("/v1/cells/{cell}/stats")).await, before);
}

#[tokio::test]
async fn grpc_frames_and_reach_are_the_rest_answers() {
    let app = spawn_app().await;
    let cell = mounted_cell(&app, "both wires").await;
    let mut c = NextposeClient::connect(app.base.clone())
        .await
        .expect("connect");
    let q = [0.2, 0.5, -0.3, 0.1, 0.7, 0.4];
    let frames = app
        .get_ok(&format!("/v1/cells/{cell}/frames?joints={}", query(&q)))
        .await;
    let rest = &frames;
    let grpc = c
        .get_arm_frames(pb::GetArmFramesRequest {
            cell_id: cell,
            joints: q.to_vec(),
        })
        .await
        .expect("frames")
        .into_inner();
    assert_eq!(grpc.robot, "abb_irb140");
    assert_eq!(grpc.joints, q.to_vec());
    assert_eq!(grpc.tcp, Some(pb_pose(&rest["tcp"])));
    assert_eq!(grpc.flange, Some(pb_pose(&rest["flange"])));
    let names: Vec<&str> = grpc.links.iter().map(|l| l.name.as_str()).collect();
    let rest_links = rest["links"].as_array().expect("links");
    assert_eq!(names.len(), rest_links.len());
    for (l, r) in grpc.links.iter().zip(rest_links) {
        assert_eq!(l.name, r["name"].as_str().expect("name"));
        assert_eq!(l.pose, Some(pb_pose(&r["pose"])));
    }
    let ready = c
        .get_arm_frames(pb::GetArmFramesRequest {
            cell_id: cell,
            joints: vec![],
        })
        .await
        .expect("ready")
        .into_inner();
    assert_eq!(
        ready.joints,
        joints_of(&app.get_ok(&format!("/v1/cells/{cell}/frames")).await["joints"])
    );

    let rest = app
        .post_ok(
            &format!("/v1/cells/{cell}/reach"),
            &json!({ "pose": frames["tcp"], "near": q }),
            StatusCode::OK,
        )
        .await;
    let grpc = c
        .check_reach(pb::CheckReachRequest {
            cell_id: cell,
            pose: Some(pb_pose(&frames["tcp"])),
            near: q.to_vec(),
        })
        .await
        .expect("reach")
        .into_inner();
    assert!(grpc.reachable);
    assert_eq!(grpc.chosen, joints_of(&rest["chosen"]));
    assert_eq!(
        grpc.solutions,
        rest["solutions"].as_u64().expect("solutions")
    );

    let e = c
        .get_arm_frames(pb::GetArmFramesRequest {
            cell_id: cell,
            joints: vec![1.0],
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument);
    let e = c
        .check_reach(pb::CheckReachRequest {
            cell_id: cell,
            pose: None,
            near: vec![],
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument);
    let e = c
        .check_reach(pb::CheckReachRequest {
            cell_id: cell,
            pose: Some(pb_pose(&frames["tcp"])),
            near: vec![1e308; 6],
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument);
    assert!(e.message().contains("outside its range"), "{}", e.message());
    let e = c
        .check_reach(pb::CheckReachRequest {
            cell_id: 999,
            pose: Some(pb_pose(&pose([400.0, 0.0, 500.0], [0.0, 0.0, 0.0]))),
            near: vec![],
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound);
}

#[tokio::test]
async fn the_page_is_served_without_the_token_with_its_headers() {
    let mut app = spawn_with(TransportOptions {
        token: Some("pendant-secret".into()),
        request_timeout: Duration::from_secs(30),
        ..TransportOptions::default()
    })
    .await;
    app.token = None;
    // The page learns that it must ask for the token without a refused request.
    let health = expect(app.get("/healthz").await, StatusCode::OK).await;
    assert_eq!(health["token_required"], true);
    let page = app.get("/").await;
    assert_eq!(page.status(), StatusCode::OK);
    let h = page.headers().clone();
    assert_eq!(h[header::CONTENT_TYPE], "text/html; charset=utf-8");
    let csp = h[header::CONTENT_SECURITY_POLICY].to_str().expect("csp");
    assert!(csp.contains("script-src 'self'") && csp.contains("frame-ancestors 'none'"));
    assert!(!csp.contains("unsafe-inline"));
    assert_eq!(h[header::X_CONTENT_TYPE_OPTIONS], "nosniff");
    assert_eq!(h[header::CACHE_CONTROL], "no-cache");
    let etag = h[header::ETAG].clone();
    let html = page.text().await.expect("html");
    assert!(
        html.contains("type=\"module\""),
        "the page loads its modules"
    );
    // Every script and stylesheet the page names is served, with its type.
    for asset in ["/pendant/pendant.css", "/pendant/js/main.js"] {
        assert!(html.contains(asset), "index.html names {asset}");
        let r = app.get(asset).await;
        assert_eq!(r.status(), StatusCode::OK, "{asset}");
        let t = r.headers()[header::CONTENT_TYPE]
            .to_str()
            .expect("type")
            .to_string();
        assert!(t.starts_with(if asset.ends_with(".js") {
            "text/javascript"
        } else {
            "text/css"
        }));
    }
    let vendored = app.get("/pendant/vendor/three/three.min.js").await;
    assert_eq!(vendored.status(), StatusCode::OK);
    assert_eq!(
        vendored.headers()[header::CACHE_CONTROL],
        "public, max-age=86400"
    );
    // A reload revalidates: 304 for the same ETag.
    let again = app
        .client
        .get(app.url("/"))
        .header(header::IF_NONE_MATCH, etag)
        .send()
        .await
        .expect("send");
    assert_eq!(again.status(), StatusCode::NOT_MODIFIED);
    // Nothing outside the page's folder is served (the client may normalise the dots away;
    // then the path is the API's, and wants the token).
    for escape in [
        "/pendant/../pendant.rs",
        "/pendant/%2e%2e/pendant.rs",
        "/pendant/js//main.js",
    ] {
        let r = app.get(escape).await;
        assert!(
            [StatusCode::NOT_FOUND, StatusCode::UNAUTHORIZED].contains(&r.status()),
            "{escape}: {}",
            r.status()
        );
    }
    // Missing files are JSON 404s; the API still wants the token.
    expect_error(
        app.get("/pendant/nope.js").await,
        StatusCode::NOT_FOUND,
        "route_not_found",
    )
    .await;
    expect_error(
        app.get("/v1/cells").await,
        StatusCode::UNAUTHORIZED,
        "unauthorized",
    )
    .await;
}
