//! The database is the source of truth: a rebuild, a restart and a `kill -9` all give back the
//! same waypoints, the same model and the same predictions.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

use nextpose::replay::load_paths;
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::helpers::*;

/// A real program from the shared corpus, as API poses per routine: the first (by file name)
/// with at least three routines of three or more waypoints and at most 300 waypoints in all.
fn corpus_program() -> Vec<Vec<Value>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/corpus/json");
    let programs = load_paths(&[dir]).expect("corpus");
    let program = programs
        .iter()
        .find(|p| {
            let total: usize = p.routines.iter().map(|r| r.waypoints.len()).sum();
            p.routines.iter().filter(|r| r.waypoints.len() >= 3).count() >= 3 && total <= 300
        })
        .expect("a suitable corpus program");
    program
        .routines
        .iter()
        .map(|r| {
            r.waypoints
                .iter()
                .map(|w| serde_json::to_value(w.values()).unwrap())
                .collect()
        })
        .collect()
}

/// Teaches all routines but the last, and half of the last (left open). Returns the open
/// routine's id and the last prediction made.
async fn teach_corpus_program(app: &TestApp, cell: i64) -> (i64, Value) {
    let routines = corpus_program();
    let program = app.create_program(cell, "corpus").await;
    let (last, earlier) = routines.split_last().unwrap();
    for r in earlier {
        app.teach_routine(program, r).await;
    }
    let open = app.create_routine(program).await;
    let mut prediction = Value::Null;
    for p in &last[..last.len().div_ceil(2)] {
        prediction = app.append(open, p).await["prediction"].clone();
    }
    (open, prediction)
}

/// Everything observable about a cell: its routines, waypoints, model and current prediction.
async fn snapshot(app: &TestApp, cell: i64, open: i64) -> Value {
    let mut routines = Vec::new();
    for p in app
        .get_ok(&format!("/v1/cells/{cell}/programs"))
        .await
        .as_array()
        .unwrap()
    {
        let list = app
            .get_ok(&format!("/v1/programs/{}/routines", p["id"]))
            .await;
        for r in list.as_array().unwrap() {
            routines.push(app.get_ok(&format!("/v1/routines/{}", r["id"])).await);
        }
    }
    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let prediction = app
        .get_ok(&format!("/v1/routines/{open}/prediction?k=3"))
        .await;
    json!({ "routines": routines, "stats": stats, "prediction": prediction })
}

#[tokio::test]
async fn rebuild_and_restart_give_the_same_model_and_predictions() {
    let app = spawn_app().await;
    let cell = app.create_cell("corpus-cell").await;
    // A synthetic routine first, so the corpus program has something to be predicted from
    // even before its own routines are learned.
    let warmup = app.create_program(cell, "warm-up").await;
    app.teach_routine(warmup, &u_seam([0.0; 3], 0.0)).await;
    let (open, last) = teach_corpus_program(&app, cell).await;
    let before = snapshot(&app, cell, open).await;
    assert_eq!(before["prediction"]["predictions"][0]["pose"], last["pose"]);
    assert!(before["stats"]["model"]["states"].as_u64().unwrap() > 10);

    let rebuilt = app
        .post_ok(
            &format!("/v1/cells/{cell}/rebuild"),
            &json!({}),
            StatusCode::OK,
        )
        .await;
    assert_eq!(rebuilt, before["stats"]["model"]);
    assert_eq!(snapshot(&app, cell, open).await, before);

    let app = app.restart().await;
    assert_eq!(snapshot(&app, cell, open).await, before);
}

/// The real binary, started on a free port; returns the child and its base URL.
fn start_binary(db: &Path) -> (Child, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_nextpose"))
        .args(["serve", "--addr", "127.0.0.1:0", "--db"])
        .arg(db)
        .env("RUST_LOG", "warn")
        .env_remove("NEXTPOSE_TOKEN")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start nextpose");
    let stdout = child.stdout.take().expect("stdout");
    let mut line = String::new();
    BufReader::new(stdout)
        .read_line(&mut line)
        .expect("read the listening line");
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no address in {line:?}"))
        .to_string();
    (child, url)
}

#[tokio::test]
async fn acknowledged_waypoints_survive_kill_9() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("durable.db");
    let (mut child, base) = tokio::task::spawn_blocking({
        let db = db.clone();
        move || start_binary(&db)
    })
    .await
    .unwrap();
    let app = TestApp::remote(&base);
    let cell = app.create_cell("durable").await;
    let (open, _) = teach_corpus_program(&app, cell).await;
    let before = snapshot(&app, cell, open).await;

    // No shutdown, no flush: SIGKILL.
    child.kill().expect("kill -9");
    child.wait().unwrap();

    let (mut child, base) = tokio::task::spawn_blocking(move || start_binary(&db))
        .await
        .unwrap();
    let app = TestApp::remote(&base);
    let after = snapshot(&app, cell, open).await;
    child.kill().ok();
    child.wait().ok();
    assert_eq!(after, before);
}
