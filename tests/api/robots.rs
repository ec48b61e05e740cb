//! Arm models uploaded through the API: checked like the bundled ones (a clear 422 otherwise),
//! stored, named by cells, kept across a restart, deleted only when no cell names them; the
//! same through gRPC.

use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use reqwest::StatusCode;
use serde_json::{Value, json};
use tonic::Code;

use crate::helpers::*;

/// A bundled URDF as text, to upload under another name.
fn bundled_urdf(name: &str) -> String {
    let path = nextpose::kinematics::bundled_robots_dir().join(format!("{name}.urdf"));
    std::fs::read_to_string(path).expect("bundled URDF")
}

fn names(list: &Value) -> Vec<String> {
    list.as_array()
        .expect("robots")
        .iter()
        .map(|r| r["name"].as_str().expect("name").to_string())
        .collect()
}

#[tokio::test]
async fn an_uploaded_arm_is_checked_stored_used_by_a_cell_and_kept_across_a_restart() {
    let app = spawn_app().await;
    let body = json!({
        "name": "my_irb140",
        "urdf": bundled_urdf("abb_irb140"),
        "maker": "ABB",
        "product": "IRB 140 (site copy)",
        "payload_kg": 6.0,
    });
    let robot = expect(app.post("/v1/robots", &body).await, StatusCode::CREATED).await;
    assert_eq!(robot["name"], "my_irb140");
    assert_eq!(robot["source"], "uploaded");
    assert_eq!(robot["solver"], "opw");
    assert_eq!(robot["payload_kg"], 6.0);
    assert_eq!(robot["joints"].as_array().expect("joints").len(), 6);
    let listed = app.get_ok("/v1/robots").await;
    assert!(names(&listed).contains(&"my_irb140".to_string()));
    let bundled = app.get_ok("/v1/robots/abb_irb140").await;
    assert_eq!(bundled["source"], "bundled");

    // A cell on the uploaded arm checks its predictions against it.
    let cell = app
        .create_cell_with("site", json!({"robot": "my_irb140"}))
        .await;
    let program = app.create_program(cell, "p").await;
    let routine = app.create_routine(program).await;
    let taught = app
        .append(
            routine,
            &pose([450.0, 0.0, 400.0], [0.0, std::f64::consts::PI, 0.0]),
        )
        .await;
    assert_eq!(taught["waypoint"]["reachable"], true, "{taught}");
    let far = app
        .append(
            routine,
            &pose([3000.0, 0.0, 400.0], [0.0, std::f64::consts::PI, 0.0]),
        )
        .await;
    assert_eq!(far["waypoint"]["reachable"], false, "{far}");

    // The name is taken now, and a cell names the arm, so it cannot go.
    let r = app.post("/v1/robots", &body).await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    let r = app.delete("/v1/robots/my_irb140").await;
    let message = expect_error(r, StatusCode::CONFLICT, "conflict").await;
    assert!(message.contains("site"), "{message}");

    // Across a restart: still there, and the cell still uses it.
    let app = app.restart().await;
    let robot = app.get_ok("/v1/robots/my_irb140").await;
    assert_eq!(robot["source"], "uploaded");
    assert_eq!(robot["product"], "IRB 140 (site copy)");
    let next = app
        .append(
            routine,
            &pose([460.0, 0.0, 400.0], [0.0, std::f64::consts::PI, 0.0]),
        )
        .await;
    assert_eq!(next["waypoint"]["reachable"], true, "{next}");

    // Once no cell names it, it can be deleted; then it is gone, after a restart too.
    let r = app.delete(&format!("/v1/cells/{cell}")).await;
    assert!(r.status().is_success(), "{}", r.status());
    let r = app.delete("/v1/robots/my_irb140").await;
    assert_eq!(r.status(), StatusCode::NO_CONTENT);
    expect_error(
        app.get("/v1/robots/my_irb140").await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    let app = app.restart().await;
    assert!(!names(&app.get_ok("/v1/robots").await).contains(&"my_irb140".to_string()));
}

#[tokio::test]
async fn unusable_uploads_are_refused_with_what_is_wrong_and_change_nothing() {
    let app = spawn_app().await;
    let before = app.get_ok("/v1/robots").await;
    let irb = bundled_urdf("abb_irb140");
    // Five joints: joint_6 fixed.
    let five = irb.replacen(
        r#"<joint name="joint_6" type="revolute">"#,
        r#"<joint name="joint_6" type="fixed">"#,
        1,
    );
    assert_ne!(five, irb);
    // A wrist axis tilted off the OPW geometry (and not a UR arm either).
    let tilted = irb.replacen(r#"<axis xyz="1 0 0"/>"#, r#"<axis xyz="1 0.3 0"/>"#, 1);
    assert_ne!(tilted, irb);
    // Equal limits on joint 1.
    let stuck = irb.replacen(
        r#"lower="-3.1415926536" upper="3.1415926536""#,
        r#"lower="0" upper="0""#,
        1,
    );
    assert_ne!(stuck, irb);
    let cases: Vec<(Value, &str, &str)> = vec![
        (
            json!({"name": "x", "urdf": five}),
            "invalid_robot",
            "revolute joints",
        ),
        (
            json!({"name": "x", "urdf": tilted}),
            "invalid_robot",
            "solver",
        ),
        (
            json!({"name": "x", "urdf": stuck}),
            "invalid_robot",
            "limits",
        ),
        (
            json!({"name": "x", "urdf": "<robot"}),
            "invalid_robot",
            "URDF",
        ),
        (json!({"name": "x", "urdf": ""}), "invalid_robot", "URDF"),
        (
            json!({"name": "no spaces", "urdf": irb}),
            "invalid",
            "robot name",
        ),
        (
            json!({"name": "../etc", "urdf": irb}),
            "invalid",
            "robot name",
        ),
        (json!({"name": "", "urdf": irb}), "invalid", "robot name"),
        (
            json!({"name": "x", "urdf": irb, "payload_kg": -1.0}),
            "invalid",
            "payload_kg",
        ),
        (
            json!({"name": "x", "urdf": irb, "maker": ""}),
            "invalid",
            "maker",
        ),
    ];
    for (body, code, says) in cases {
        let r = app.post("/v1/robots", &body).await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, code).await;
        assert!(message.contains(says), "{body}: {message}");
    }
    // Unknown fields and a missing URDF are the body's shape: 422 too, named.
    let r = app
        .post("/v1/robots", &json!({"name": "x", "urdf": irb, "mass": 1}))
        .await;
    assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY);
    let r = app.post("/v1/robots", &json!({"name": "x"})).await;
    assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY);
    // A bundled name is taken; bundled models cannot be deleted; unknown ones are not found.
    let r = app
        .post("/v1/robots", &json!({"name": "ur5e", "urdf": irb}))
        .await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    let r = app.delete("/v1/robots/ur5e").await;
    let message = expect_error(r, StatusCode::CONFLICT, "conflict").await;
    assert!(message.contains("bundled"), "{message}");
    let r = app.delete("/v1/robots/nope").await;
    expect_error(r, StatusCode::NOT_FOUND, "not_found").await;
    assert_eq!(app.get_ok("/v1/robots").await, before);
}

#[tokio::test]
async fn uploads_through_grpc_match_rest() {
    let app = spawn_app().await;
    let mut c = NextposeClient::connect(app.base.clone())
        .await
        .expect("connect");
    let robot = c
        .upload_robot(pb::UploadRobotRequest {
            name: "grpc_ur5e".into(),
            urdf: bundled_urdf("ur5e"),
            maker: Some("Universal Robots".into()),
            product: None,
            payload_kg: Some(5.0),
        })
        .await
        .expect("upload")
        .into_inner();
    assert_eq!(robot.source, "uploaded");
    assert_eq!(robot.solver, "ur");
    let rest = app.get_ok("/v1/robots/grpc_ur5e").await;
    assert_eq!(rest["maker"], "Universal Robots");
    assert_eq!(rest["payload_kg"], 5.0);
    assert_eq!(
        rest["joints"].as_array().expect("joints").len(),
        robot.joints.len()
    );
    let taken = c
        .upload_robot(pb::UploadRobotRequest {
            name: "grpc_ur5e".into(),
            urdf: bundled_urdf("ur5e"),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(taken.code(), Code::AlreadyExists);
    let bad = c
        .upload_robot(pb::UploadRobotRequest {
            name: "bad".into(),
            urdf: "<robot name='x'/>".into(),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(bad.code(), Code::InvalidArgument);
    let bundled = c
        .delete_robot(pb::DeleteRobotRequest {
            name: "abb_irb140".into(),
        })
        .await
        .unwrap_err();
    assert_eq!(bundled.code(), Code::FailedPrecondition);
    c.delete_robot(pb::DeleteRobotRequest {
        name: "grpc_ur5e".into(),
    })
    .await
    .expect("delete");
    expect_error(
        app.get("/v1/robots/grpc_ur5e").await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
}

/// `GET /v1/robots` lists the bundled library with each arm's data sheet: maker, product,
/// payload and reach, and the reach computed from its kinematics close to the data sheet's.
#[tokio::test]
async fn the_library_is_listed_with_reach_and_payload() {
    let app = spawn_app().await;
    let list = app.get_ok("/v1/robots").await;
    let all = list.as_array().expect("robots");
    assert!(all.len() >= 18, "{} robots", all.len());
    for want in [
        "abb_irb1200",
        "abb_irb2600",
        "abb_irb6700",
        "kuka_kr210_r2700",
        "fanuc_r2000ic",
        "ur16e",
    ] {
        assert!(all.iter().any(|r| r["name"] == want), "{want} missing");
    }
    for r in all {
        assert_eq!(r["source"], "bundled", "{r}");
        let payload = r["payload_kg"].as_f64().expect("payload_kg");
        let reach = r["reach_mm"].as_f64().expect("reach_mm");
        let computed = r["computed_reach_mm"].as_f64().expect("computed_reach_mm");
        assert!(payload > 0.0 && reach > 300.0, "{r}");
        // Within 7 %: the UR10e's data sheet counts its wrist turned outward (robots/README.md).
        assert!(
            (computed - reach).abs() <= 0.07 * reach,
            "{}: computed {computed} vs {reach}",
            r["name"]
        );
        assert!(r["maker"].is_string() && r["product"].is_string(), "{r}");
        assert!(
            !r["languages"].as_array().expect("languages").is_empty(),
            "{r}"
        );
    }
}

/// A layout search for a program the cell's arm cannot reach from where it stands: the best
/// placement reaches every waypoint, and a cell whose base is put there reaches them all when
/// they are taught; the same search through gRPC gives the same placements; bad requests are
/// refused with what is wrong.
#[tokio::test]
async fn a_placement_found_for_a_program_reaches_it_when_the_base_is_put_there() {
    let app = spawn_app().await;
    let cell = app.create_cell("far").await;
    let program = app.create_program(cell, "seams").await;
    let seam = u_seam([1500.0, 800.0, 300.0], 0.4);
    let routine = app.create_routine(program).await;
    for p in &seam {
        let t = app.append(routine, p).await;
        assert_eq!(
            t["waypoint"]["reachable"], false,
            "the arm at the origin: {t}"
        );
    }
    app.finish(routine).await;

    let body = json!({"program_id": program, "keep": 2});
    let found = app
        .post_ok("/v1/robots/abb_irb140/placements", &body, StatusCode::OK)
        .await;
    assert_eq!(found["targets"], seam.len());
    let best = &found["placements"][0];
    assert_eq!(best["reached"], seam.len(), "{found}");
    assert_eq!(best["unreached_waypoints"], json!([]));
    assert!(best["min_joint_margin_deg"].as_f64().expect("margin") > 0.0);
    let scores: Vec<f64> = found["placements"]
        .as_array()
        .expect("placements")
        .iter()
        .map(|p| p["score"].as_f64().expect("score"))
        .collect();
    assert!(scores.windows(2).all(|w| w[0] >= w[1]), "{scores:?}");

    // Stand the arm there: every waypoint of the program is reachable.
    let placed = app
        .create_cell_with("placed", json!({"base": best["base"]}))
        .await;
    let copy = app.create_program(placed, "seams").await;
    let routine = app.create_routine(copy).await;
    for p in &seam {
        let t = app.append(routine, p).await;
        assert_eq!(t["waypoint"]["reachable"], true, "placed there: {t}");
    }

    // Given poses instead of a program: the same search.
    let by_poses = app
        .post_ok(
            "/v1/robots/abb_irb140/placements",
            &json!({"targets": seam, "keep": 2}),
            StatusCode::OK,
        )
        .await;
    assert_eq!(by_poses["placements"][0]["reached"], seam.len());
    assert_eq!(
        by_poses["placements"][0]["unreached_waypoints"],
        Value::Null
    );

    // gRPC: the same placements for the same request.
    let mut c = NextposeClient::connect(app.base.clone())
        .await
        .expect("connect");
    let g = c
        .search_placements(pb::SearchPlacementsRequest {
            robot: "abb_irb140".into(),
            program_id: Some(program),
            keep: Some(2),
            ..Default::default()
        })
        .await
        .expect("search")
        .into_inner();
    assert_eq!(
        g.placements.len(),
        found["placements"].as_array().expect("p").len()
    );
    let gb = g.placements[0].base.expect("base");
    assert!((gb.x - best["base"]["x"].as_f64().expect("x")).abs() < 1e-9);
    assert_eq!(g.placements[0].reached, seam.len() as u64);
    let bad = c
        .search_placements(pb::SearchPlacementsRequest {
            robot: "abb_irb140".into(),
            program_id: Some(program),
            mounting: "wall".into(),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(bad.code(), Code::InvalidArgument);

    let refused: Vec<(&str, Value, StatusCode, &str)> = vec![
        (
            "abb_irb140",
            json!({}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "exactly one",
        ),
        (
            "abb_irb140",
            json!({"program_id": program, "cell_id": cell}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "exactly one",
        ),
        (
            "abb_irb140",
            json!({"targets": []}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "targets is empty",
        ),
        (
            "abb_irb140",
            json!({"program_id": program, "keep": 0}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "keep",
        ),
        (
            "abb_irb140",
            json!({"program_id": program, "evaluations": 5}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "evaluations",
        ),
        (
            "abb_irb140",
            json!({"targets": [{"x": 0, "y": 0, "z": 0, "qw": 0, "qx": 0, "qy": 0, "qz": 0}]}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "quaternion",
        ),
        (
            "abb_irb140",
            json!({"program_id": 999_999}),
            StatusCode::NOT_FOUND,
            "program",
        ),
        (
            "nope",
            json!({"program_id": program}),
            StatusCode::NOT_FOUND,
            "robot",
        ),
    ];
    for (robot, body, status, says) in refused {
        let r = app
            .post(&format!("/v1/robots/{robot}/placements"), &body)
            .await;
        assert_eq!(r.status(), status, "{body}");
        let e: Value = r.json().await.expect("error body");
        let message = e["error"]["message"]
            .as_str()
            .unwrap_or_default()
            .to_string();
        assert!(message.contains(says), "{body}: {e}");
    }
}
