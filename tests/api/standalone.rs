//! One file is the service: the built binary, copied into an empty directory with no checkout
//! beside it and started there, serves the pendant page, lists every bundled arm and suggests
//! a reachable next waypoint (the arms are carried by the binary, not read from `robots/`).

use std::process::Command;

use reqwest::StatusCode;

use crate::durability::listening;
use crate::helpers::*;

#[tokio::test]
async fn the_binary_alone_serves_the_pendant_and_suggests_with_no_checkout_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let binary = dir.path().join("nextpose");
    std::fs::copy(env!("CARGO_BIN_EXE_nextpose"), &binary).expect("copy the binary");
    let work = dir.path().join("plant");
    std::fs::create_dir(&work).unwrap();
    let mut command = Command::new(&binary);
    command
        .args(["serve", "--addr", "127.0.0.1:0", "--db", "plant.db"])
        .current_dir(&work)
        .env_remove("NEXTPOSE_ROBOTS")
        .env_remove("NEXTPOSE_DB");
    let (mut child, base) = tokio::task::spawn_blocking(move || listening(command))
        .await
        .unwrap();
    let app = TestApp::remote(&base);

    let page = app.get("/").await;
    assert_eq!(page.status(), StatusCode::OK);
    assert!(page.text().await.unwrap().contains("<html"));
    let robots = app.get_ok("/v1/robots").await;
    let names: Vec<&str> = robots
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    let bundled = nextpose::kinematics::bundled_robots().unwrap();
    assert_eq!(names.len(), bundled.len());
    assert!(
        names.len() >= 18 && names.contains(&"fanuc_m10ia"),
        "{names:?}"
    );

    let cell = app
        .create_cell_with(
            "plant",
            serde_json::json!({ "robot": "abb_irb140", "reach_policy": "flag" }),
        )
        .await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let copy = u_seam([100.0, 200.0, 0.0], 0.4);
    let routine = app.create_routine(program).await;
    let mut last = serde_json::Value::Null;
    for p in &copy[..5] {
        last = app.append(routine, p).await;
    }
    let prediction = &last["prediction"];
    assert_eq!(prediction["offered"], true, "{prediction}");
    assert_eq!(prediction["reachability"]["robot"], "abb_irb140");
    assert!(
        prediction["reachability"]["reachable"].is_boolean(),
        "{prediction}"
    );
    assert!(distance(&prediction["pose"], &copy[5]) < 1e-6);
    assert!(
        work.join("plant.db").is_file(),
        "the database is made where it runs"
    );

    child.kill().ok();
    child.wait().ok();
}
