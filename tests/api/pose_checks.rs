//! Poses are checked once, where they enter (issue 46): every number finite, each coordinate
//! within ±100,000 mm of its frame, a unit quaternion. A pose that is not is a 422 (gRPC:
//! `INVALID_ARGUMENT`) naming the field and the value, or for an import the file, the line and
//! the value; nothing is stored or learned.

use nextpose::grpc::pb;
use reqwest::StatusCode;
use serde_json::{Value, json};
use tonic::Code;

use super::grpc::client::{client, pb_pose};
use crate::helpers::*;

/// What a refused request must leave as it was: the cell's programs (with their routines'
/// waypoint counts) and its model.
async fn state_of(app: &TestApp, cell: i64) -> (Value, Value) {
    let programs = app.get_ok(&format!("/v1/cells/{cell}/programs")).await;
    let mut routines = Vec::new();
    for p in programs.as_array().expect("programs") {
        let id = p["id"].as_i64().expect("id");
        routines.push(app.get_ok(&format!("/v1/programs/{id}/routines")).await);
    }
    let model = app.get_ok(&format!("/v1/cells/{cell}/stats")).await["model"].clone();
    (json!({ "programs": programs, "routines": routines }), model)
}

/// A cell with one learned routine and an open one of two waypoints.
async fn taught_cell(app: &TestApp) -> (i64, i64) {
    let cell = app.create_cell("checked").await;
    let program = app.create_program(cell, "taught").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let routine = app.create_routine(program).await;
    for p in &u_seam([300.0, 0.0, 0.0], 0.0)[..2] {
        app.append(routine, p).await;
    }
    (cell, routine)
}

#[tokio::test]
async fn a_taught_pose_out_of_range_is_refused_naming_the_field_and_value() {
    let app = spawn_app().await;
    let (cell, routine) = taught_cell(&app).await;
    let before = state_of(&app, cell).await;
    assert_eq!(before.1["version"], 1);
    let url = format!("/v1/routines/{routine}/waypoints");
    let cases = [
        ("x", json!(-1e308), "x = -1e308 is outside ±100000 mm"),
        ("y", json!(100_000.5), "y = 100000.5 is outside ±100000 mm"),
        ("z", json!(1e300), "z = 1e300 is outside ±100000 mm"),
    ];
    for (field, value, said) in cases {
        let mut p = pose([0.0; 3], [0.0; 3]);
        p[field] = value;
        let r = app.post(&url, &json!({ "pose": p })).await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid_pose").await;
        assert!(message.contains(said), "{message}");
        assert_eq!(state_of(&app, cell).await, before, "{field}");
    }
    // A number JSON cannot hold as a double is refused by the parser, as a 4xx.
    let body = r#"{"pose": {"x": 1e999, "y": 0, "z": 0, "qw": 1, "qx": 0, "qy": 0, "qz": 0}}"#;
    let r = app
        .client
        .post(app.url(&url))
        .header("content-type", "application/json")
        .body(body)
        .send()
        .await
        .unwrap();
    assert!(r.status().is_client_error(), "{}", r.status());
    assert_eq!(state_of(&app, cell).await, before);
    // The bound itself is accepted.
    let at_bound = pose([-100_000.0, 100_000.0, 0.0], [0.0; 3]);
    let taught = app.append(routine, &at_bound).await;
    assert_eq!(taught["waypoint"]["pose"]["x"], -100_000.0);
    // An edit is checked by the same rule.
    let id = taught["waypoint"]["id"].as_i64().unwrap();
    let mut far = at_bound.clone();
    far["x"] = json!(-100_001.0);
    let r = app
        .patch(&format!("/v1/waypoints/{id}"), &json!({ "pose": far }))
        .await;
    let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid_pose").await;
    assert!(message.contains("x = -100001.0 is outside"), "{message}");
}

#[tokio::test]
async fn grpc_refuses_non_finite_and_far_poses_and_joints_with_invalid_argument() {
    let app = spawn_app().await;
    let (cell, routine) = taught_cell(&app).await;
    let before = state_of(&app, cell).await;
    let mut c = client(&app).await;
    let good = pb_pose(&pose([0.0; 3], [0.0; 3]));
    let cases: [(pb::Pose, Vec<f64>, &str); 5] = [
        (
            pb::Pose {
                x: f64::NAN,
                ..good
            },
            vec![],
            "x = NaN is not a finite number",
        ),
        (
            pb::Pose {
                z: f64::NEG_INFINITY,
                ..good
            },
            vec![],
            "z = -inf is not a finite number",
        ),
        (
            pb::Pose { y: -1e308, ..good },
            vec![],
            "y = -1e308 is outside ±100000 mm",
        ),
        (
            pb::Pose {
                qx: f64::NAN,
                ..good
            },
            vec![],
            "qx = NaN is not a finite number",
        ),
        (
            good,
            vec![0.0, 0.1, f64::NAN, 0.0, 0.0, 0.0],
            "joints[2] = NaN is not a finite number",
        ),
    ];
    for (p, joints, said) in cases {
        let e = c
            .append_waypoint(pb::AppendWaypointRequest {
                routine_id: routine,
                waypoint: Some(pb::NewWaypoint {
                    pose: Some(p),
                    joints,
                    ..Default::default()
                }),
            })
            .await
            .unwrap_err();
        assert_eq!(e.code(), Code::InvalidArgument, "{said}: {e:?}");
        assert!(e.message().contains(said), "{said}: {}", e.message());
        assert_eq!(state_of(&app, cell).await, before, "{said}");
    }
}

/// A program whose second move goes to `x = -1e308`, in each language; the 422 names the file,
/// the line of the move and the value, and the cell is as it was.
#[tokio::test]
async fn an_import_with_a_pose_out_of_range_is_refused_naming_file_line_and_value() {
    let app = spawn_app().await;
    let (cell, routine) = taught_cell(&app).await;
    // Learning needs no routine open; finish it.
    app.finish(routine).await;
    let first = state_of(&app, cell).await;
    let mut before = first.clone();
    let rapid = "MODULE Weld\n\
        CONST robtarget p1:=[[10,20,30],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n\
        CONST robtarget p2:=[[-1e308,20,30],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n\
        PROC main()\n\
          MoveL p1, v100, fine, tool0;\n\
          MoveL p2, v100, fine, tool0;\n\
          MoveL p1, v100, fine, tool0;\n\
        ENDPROC\n\
        ENDMODULE\n";
    let krl = "DEF seam()\n\
        LIN {X 10, Y 20, Z 30, A 0, B 0, C 0}\n\
        LIN {X 10, Y 1e999, Z 30, A 0, B 0, C 0}\n\
        END\n";
    let fanuc = "/PROG SEAM\n/MN\n 1:L P[1] 100mm/sec FINE ;\n 2:L P[2] 100mm/sec FINE ;\n/POS\n\
        P[1]{\n GP1:\n UF : 0, UT : 1,\n X = 1 mm, Y = 2 mm, Z = 3 mm,\n W = 0 deg, P = 0 deg, R = 0 deg\n};\n\
        P[2]{\n GP1:\n UF : 0, UT : 1,\n X = 1 mm, Y = 2 mm, Z = 250000 mm,\n W = 0 deg, P = 0 deg, R = 0 deg\n};\n/END\n";
    let cases = [
        (
            "weld.mod",
            rapid,
            "weld.mod line 6: x = -1e308 is outside ±100000 mm (target p2)",
        ),
        (
            "r1/seam.src",
            krl,
            "r1/seam.src line 3: y = inf is not a finite number",
        ),
        (
            "cell/stitch/SEAM.LS",
            fanuc,
            "cell/stitch/SEAM.LS line 4: z = 250000.0 is outside ±100000 mm (target P[2])",
        ),
    ];
    for (name, content, said) in cases {
        let files = json!({ "files": [{ "name": name, "content": content }] });
        let r = app.post(&format!("/v1/cells/{cell}/imports"), &files).await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
        assert!(message.contains(said), "{name}: {message}");
        assert_eq!(state_of(&app, cell).await, before, "{name}");
        // The same program with the number repaired is imported and learned.
        let repaired = content
            .replace("-1e308", "-130")
            .replace("1e999", "25")
            .replace("250000", "250");
        let files = json!({ "files": [{ "name": name, "content": repaired }] });
        let done = app.import(cell, &files).await;
        assert_eq!(
            done["programs"].as_array().unwrap().len(),
            1,
            "{name}: {done}"
        );
        before = state_of(&app, cell).await;
    }
    let learned = |s: &(Value, Value)| s.1["routines"].as_u64().expect("routines");
    assert_eq!(learned(&before), learned(&first) + 3);
}

#[tokio::test]
async fn a_trajectory_sample_out_of_range_is_refused_naming_it() {
    let app = spawn_app().await;
    let (cell, routine) = taught_cell(&app).await;
    let before = state_of(&app, cell).await;
    let samples: Vec<Value> = (0..20)
        .map(|i| {
            let x = if i == 7 {
                2e5
            } else {
                300.0 + 10.0 * f64::from(i)
            };
            json!({ "t": 0.1 * f64::from(i), "pose": pose([x, 0.0, 300.0], [0.0; 3]) })
        })
        .collect();
    let r = app
        .post(
            &format!("/v1/routines/{routine}/trajectory"),
            &json!({ "samples": samples }),
        )
        .await;
    let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid_pose").await;
    assert!(
        message.contains("sample 7") && message.contains("x = 200000.0 is outside ±100000 mm"),
        "{message}"
    );
    assert_eq!(state_of(&app, cell).await, before);
}
