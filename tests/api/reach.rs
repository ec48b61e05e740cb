//! Predictions are checked against the cell's arm: never an unreachable suggestion under the
//! default policy, flagged under `flag`; taught waypoints out of reach are stored and flagged.

use nextpose::kinematics::{bundled_robots_dir, load_robot};
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::helpers::*;

/// Poses of the IRB 140's flange along a zigzag in x (60 mm steps, 30 mm across), with the
/// orientation it has at `q = (0, 0.3, 0.2, 0, 1.0, 0)` (pointing down and forward).
fn line(x0: f64, y: f64, n: usize) -> Vec<Value> {
    let robot = load_robot(&bundled_robots_dir(), "abb_irb140").unwrap();
    let reference = robot.fk(&[0.0, 0.3, 0.2, 0.0, 1.0, 0.0]).values();
    (0..n)
        .map(|i| {
            json!({"x": x0 + 60.0 * i as f64, "y": y + 30.0 * (i % 2) as f64, "z": reference.z,
                   "qw": reference.qw, "qx": reference.qx, "qy": reference.qy, "qz": reference.qz})
        })
        .collect()
}

#[tokio::test]
async fn robots_are_listed_and_cells_must_name_one() {
    let app = spawn_app().await;
    let robots = app.get_ok("/v1/robots").await;
    let names: Vec<&str> = robots
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    assert!(
        names.contains(&"abb_irb140") && names.contains(&"ur5e"),
        "{names:?}"
    );
    let irb = app.get_ok("/v1/robots/abb_irb140").await;
    assert_eq!(irb["joints"].as_array().unwrap().len(), 6);
    assert_eq!(irb["solver"], "opw");
    let r = app.get("/v1/robots/nope").await;
    expect_error(r, StatusCode::NOT_FOUND, "not_found").await;
    let r = app
        .post(
            "/v1/cells",
            &json!({"name": "c", "settings": {"robot": "nope"}}),
        )
        .await;
    let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    assert!(message.contains("abb_irb140"), "{message}");
}

#[tokio::test]
async fn unreachable_predictions_are_withheld_or_flagged() {
    let app = spawn_app().await;
    let strict = app.create_cell_with("strict", json!({})).await;
    let lenient = app
        .create_cell_with("lenient", json!({"reach_policy": "flag"}))
        .await;
    let within = line(350.0, 0.0, 6);
    for cell in [strict, lenient] {
        let program = app.create_program(cell, "p").await;
        let routine = app.create_routine(program).await;
        for p in &within {
            let t = app.append(routine, p).await;
            assert_eq!(t["waypoint"]["reachable"], true, "{p}");
        }
        app.finish(routine).await;
    }

    // The same line 60 mm to the side: reachable, offered, with the arm's solution.
    let program = app.create_program(strict, "near").await;
    let routine = app.create_routine(program).await;
    let mut offered = 0;
    for p in &line(350.0, 60.0, 6) {
        let prediction = app.append(routine, p).await["prediction"].clone();
        if prediction["offered"] == true {
            offered += 1;
            let r = &prediction["reachability"];
            assert_eq!(r["reachable"], true, "{prediction}");
            assert_eq!(r["robot"], "abb_irb140");
            assert_eq!(r["chosen"].as_array().unwrap().len(), 6);
            assert!(r["solutions"].as_u64().unwrap() >= 1);
            assert!(r["sigma_min"].as_f64().unwrap() > 0.0);
            assert!(r["limiting_joint"]["name"].is_string());
        }
    }
    assert!(offered >= 2, "{offered} offered");
    app.finish(routine).await;

    // The same line 2 m away: the taught waypoints are stored but flagged; the strict cell
    // withholds what its arm cannot reach, the lenient one offers it flagged.
    let far = line(2000.0, 0.0, 5);
    let mut reasons = Vec::new();
    let mut flagged = 0;
    for (cell, name) in [(strict, "far-strict"), (lenient, "far-lenient")] {
        let program = app.create_program(cell, name).await;
        let routine = app.create_routine(program).await;
        for p in &far {
            let t = app.append(routine, p).await;
            assert_eq!(t["waypoint"]["reachable"], false);
            let prediction = &t["prediction"];
            if cell == strict {
                assert!(
                    prediction["offered"] == false
                        || prediction["reachability"]["reachable"] == true,
                    "{prediction}"
                );
                reasons.push(prediction["withheld"]["reason"].clone());
            } else if prediction["offered"] == true {
                assert_eq!(prediction["reachability"]["reachable"], false);
                assert_eq!(
                    prediction["reachability"]["unreachable"]["reason"],
                    "outside_reach"
                );
                flagged += 1;
            }
        }
        let stored = app.get_ok(&format!("/v1/routines/{routine}")).await;
        assert!(
            stored["waypoints"]
                .as_array()
                .unwrap()
                .iter()
                .all(|w| w["reachable"] == false)
        );
    }
    assert!(reasons.contains(&json!("unreachable")), "{reasons:?}");
    assert!(flagged >= 1);
    let metrics = app.get("/metrics").await.text().await.unwrap();
    assert!(metrics.contains("reason=\"unreachable\""));
}
