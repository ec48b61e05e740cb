//! Re-targeting to a moved fixture (issue 14): a corpus program's fixture is moved by a known
//! rigid motion, measured at three points before and after; the copy's waypoints are the
//! originals moved, each checked for reach, stored as a new program (finished, not learned).

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::helpers::*;
use crate::import::upload;

fn waypoints(detail: &Value) -> Vec<Value> {
    detail["waypoints"].as_array().expect("waypoints").clone()
}

#[tokio::test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn a_corpus_program_follows_its_moved_fixture_with_reach_checked() {
    let app = spawn_app().await;
    let cell = app
        .create_cell_with("fixture", json!({ "reach_policy": "flag" }))
        .await;
    let imported = app
        .import(
            cell,
            &json!({ "files": upload("ravenorb__abb-robot-welder"), "learn": false }),
        )
        .await;
    let program = imported["programs"][0]["program"]["id"]
        .as_i64()
        .expect("id");
    let mut originals = Vec::new();
    for r in app
        .get_ok(&format!("/v1/programs/{program}/routines"))
        .await
        .as_array()
        .expect("routines")
    {
        let id = r["id"].as_i64().expect("routine id");
        originals.push(waypoints(&app.get_ok(&format!("/v1/routines/{id}")).await));
    }
    let model = app.get_ok(&format!("/v1/cells/{cell}/stats")).await["model"].clone();

    // The fixture turned 20° about z and shifted; three points measured on it before and after.
    let truth = Isometry3::from_parts(
        Translation3::new(35.0, -20.0, 5.0),
        UnitQuaternion::from_euler_angles(0.0, 0.0, 20f64.to_radians()),
    );
    let old = [[0.0, 0.0, 0.0], [200.0, 0.0, 0.0], [0.0, 150.0, 0.0]];
    let new: Vec<[f64; 3]> = old
        .iter()
        .map(|p| {
            let q = truth * Point3::from(*p);
            [q.x, q.y, q.z]
        })
        .collect();
    let copy = app
        .post_ok(
            &format!("/v1/programs/{program}/retarget"),
            &json!({ "points": { "old": old, "new": new } }),
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(
        copy["program"]["name"],
        format!(
            "{} (moved)",
            imported["programs"][0]["program"]["name"]
                .as_str()
                .expect("name")
        )
    );
    let routines = copy["routines"].as_array().expect("routines");
    assert_eq!(routines.len(), originals.len());
    let mut unreachable = 0;
    for (r, original) in routines.iter().zip(&originals) {
        assert_eq!(r["finished"], true);
        assert_eq!(r["learned"], false);
        let moved = waypoints(r);
        assert_eq!(moved.len(), original.len());
        for (m, o) in moved.iter().zip(original) {
            let expected =
                nextpose::engine::Pose::from_isometry(truth * pose_of(&o["pose"]).isometry());
            let got = pose_of(&m["pose"]);
            assert!(got.distance_to(&expected) < 1e-6, "{m} vs {o}");
            assert!(got.angle_to(&expected) < 1e-9);
            assert_eq!(m["name"], o["name"]);
            assert_eq!(m["motion"], o["motion"]);
            let flag = m["reachable"].as_bool().expect("every waypoint is checked");
            unreachable += usize::from(!flag);
        }
    }
    assert_eq!(copy["unreachable"], unreachable);
    // Not taught, so not learned: the model is as it was.
    let after = app.get_ok(&format!("/v1/cells/{cell}/stats")).await["model"].clone();
    assert_eq!(after, model);

    // The same fixture 10 m away: nothing is within the arm's reach.
    let far = app
        .post_ok(
            &format!("/v1/programs/{program}/retarget"),
            &json!({ "frame": pose([10_000.0, 0.0, 0.0], [0.0; 3]), "name": "far away" }),
            StatusCode::CREATED,
        )
        .await;
    let total: usize = originals.iter().map(Vec::len).sum();
    assert_eq!(far["unreachable"], total);

    // Not moved: the reach flags are the ones the export finds for the original.
    let here = app
        .post_ok(
            &format!("/v1/programs/{program}/retarget"),
            &json!({ "frame": pose([0.0; 3], [0.0; 3]), "name": "in place" }),
            StatusCode::CREATED,
        )
        .await;
    let exported = app
        .get_ok(&format!("/v1/programs/{program}/export?format=rapid"))
        .await;
    assert_eq!(
        here["unreachable"],
        exported["unreachable"]
            .as_array()
            .expect("unreachable")
            .len()
    );

    // A routine alone: a new routine at the end of its program.
    let first = app
        .get_ok(&format!("/v1/programs/{program}/routines"))
        .await[0]
        .clone();
    let id = first["id"].as_i64().expect("id");
    let one = app
        .post_ok(
            &format!("/v1/routines/{id}/retarget"),
            &json!({ "frame": pose([0.0, 0.0, 12.5], [0.0; 3]) }),
            StatusCode::CREATED,
        )
        .await;
    let r = &one["routines"][0];
    assert_eq!(r["position"], originals.len() as i64 + 1);
    assert_eq!(r["program_id"], program);
    let z0 = originals[0][0]["pose"]["z"].as_f64().expect("z");
    let z1 = r["waypoints"][0]["pose"]["z"].as_f64().expect("z");
    assert!((z1 - z0 - 12.5).abs() < 1e-6);
}

#[tokio::test]
async fn bad_retargets_are_refused_and_store_nothing() {
    let app = spawn_app().await;
    let cell = app.create_cell("strict fixture").await;
    let program = app.create_program(cell, "p").await;
    let (r, _) = app
        .teach_routine(program, &u_seam([400.0, 0.0, 300.0], 0.0))
        .await;
    let line = [[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [200.0, 0.0, 0.0]];
    let cases = [
        json!({}),
        json!({ "frame": pose([0.0; 3], [0.0; 3]), "points": { "old": line, "new": line } }),
        json!({ "points": { "old": line, "new": line } }),
        json!({ "points": { "old": [[0.0, 0.0, 0.0]], "new": line } }),
        json!({ "frame": pose([0.0; 3], [0.0; 3]), "name": " " }),
    ];
    for body in cases {
        let res = app.post(&format!("/v1/routines/{r}/retarget"), &body).await;
        let b = expect(res, StatusCode::UNPROCESSABLE_ENTITY).await;
        assert!(b["error"]["message"].is_string(), "{body}");
    }
    let taken = app
        .post(
            &format!("/v1/programs/{program}/retarget"),
            &json!({ "frame": pose([0.0; 3], [0.0; 3]), "name": "p" }),
        )
        .await;
    expect_error(taken, StatusCode::CONFLICT, "conflict").await;
    expect_error(
        app.post(
            "/v1/programs/999999/retarget",
            &json!({ "frame": pose([0.0; 3], [0.0; 3]) }),
        )
        .await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    assert_eq!(
        app.get_ok(&format!("/v1/programs/{program}/routines"))
            .await
            .as_array()
            .expect("routines")
            .len(),
        1
    );
    assert_eq!(
        app.get_ok(&format!("/v1/cells/{cell}/programs"))
            .await
            .as_array()
            .expect("programs")
            .len(),
        1
    );
}
