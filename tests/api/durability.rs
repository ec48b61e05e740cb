//! The database is the source of truth: a rebuild, a restart and a `kill -9` all give back the
//! same waypoints, the same model and the same predictions.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

use nextpose::replay::load_paths;
use nextpose::server::Database;
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::corpus;
use crate::helpers::*;

/// A real program from the shared corpus, as API poses per routine: the first (by file name)
/// with at least three routines of three or more waypoints and at most 300 waypoints in all.
pub(crate) fn corpus_program() -> Vec<Vec<Value>> {
    let programs = load_paths(&[corpus::json()]).expect("corpus");
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
pub(crate) async fn snapshot(app: &TestApp, cell: i64, open: i64) -> Value {
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
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
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

    let rebuilt = app.rebuild(cell).await;
    assert_eq!(rebuilt, before["stats"]["model"]);
    assert_eq!(snapshot(&app, cell, open).await, before);

    let app = app.restart().await;
    assert_eq!(snapshot(&app, cell, open).await, before);
}

/// The real binary on `db`, started on a free port; returns the child and its base URL.
pub(crate) fn start_binary(db: &Database) -> (Child, String) {
    let mut command = Command::new(env!("CARGO_BIN_EXE_nextpose"));
    command
        .args(["serve", "--addr", "127.0.0.1:0", "--db"])
        .arg(db_setting(db));
    listening(command)
}

/// Starts `command`, a `serve` on port 0, without a token and with a quiet log, and reads the
/// base URL from the line it prints once it listens.
pub(crate) fn listening(mut command: Command) -> (Child, String) {
    let mut child = command
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
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn acknowledged_waypoints_survive_kill_9() {
    let dir = tempfile::tempdir().unwrap();
    let db = test_database(dir.path()).await;
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

/// A database written before ids were made never-reusable (migrations 1–3) upgrades in place:
/// every row keeps its id and contents, feedback stays attached, and new ids continue after
/// the largest id present (the old schema kept no record of deleted ones) and are never reused
/// from then on.
#[tokio::test]
async fn an_older_database_upgrades_with_its_ids_and_rows() {
    use sqlx::sqlite::{SqliteConnectOptions, SqlitePoolOptions};

    let dir = tempfile::tempdir().unwrap();
    let old = dir.path().join("migrations");
    std::fs::create_dir(&old).unwrap();
    let here = Path::new(env!("CARGO_MANIFEST_DIR")).join("migrations/sqlite");
    for name in [
        "0001_init.sql",
        "0002_waypoint_reachable.sql",
        "0003_imported_routines.sql",
    ] {
        std::fs::copy(here.join(name), old.join(name)).unwrap();
    }
    let db = dir.path().join("old.db");
    let pool = SqlitePoolOptions::new()
        .max_connections(1)
        .connect_with(
            SqliteConnectOptions::new()
                .filename(&db)
                .create_if_missing(true)
                .foreign_keys(true),
        )
        .await
        .unwrap();
    sqlx::migrate::Migrator::new(old.as_path())
        .await
        .unwrap()
        .run(&pool)
        .await
        .unwrap();
    let settings = nextpose::api::CellSettingsInput::default()
        .resolve()
        .unwrap();
    let settings = serde_json::to_string(&settings).unwrap();
    for sql in [
        format!("INSERT INTO cells (id, name, settings) VALUES (1, 'c', '{settings}')"),
        "INSERT INTO programs (id, cell_id, name) VALUES (1, 1, 'p')".to_string(),
        "INSERT INTO routines (id, program_id, cell_id, position, finish_seq, finished_at) \
         VALUES (1, 1, 1, 1, 1, 'then')"
            .to_string(),
        "INSERT INTO routines (id, program_id, cell_id, position) VALUES (2, 1, 1, 2)".to_string(),
        "INSERT INTO waypoints (id, routine_id, seq, x, y, z, qw, qx, qy, qz, reachable) VALUES \
         (1, 1, 1, 400, 0, 300, 0, 0, 1, 0, 1), (2, 1, 2, 450, 0, 300, 0, 0, 1, 0, 1), \
         (3, 1, 3, 450, 50, 300, 0, 0, 1, 0, 1), (4, 2, 1, 400, 100, 300, 0, 0, 1, 0, NULL), \
         (9, 2, 2, 450, 100, 300, 0, 0, 1, 0, NULL)"
            .to_string(),
        "INSERT INTO predictions (id, cell_id, routine_id, after_seq, x, y, z, qw, qx, qy, qz, \
         phi, psi, end_probability, model_version) VALUES \
         (7, 1, 2, 2, 450, 150, 300, 0, 0, 1, 0, 0.9, 1, 0, 1)"
            .to_string(),
        "INSERT INTO feedback (prediction_id, verdict, adjustment_mm) VALUES (7, 'accepted', 0)"
            .to_string(),
        // Deleted before the upgrade: the old schema forgets id 9.
        "DELETE FROM waypoints WHERE id = 9".to_string(),
    ] {
        sqlx::query(sqlx::AssertSqlSafe(sql))
            .execute(&pool)
            .await
            .unwrap();
    }
    pool.close().await;

    let app = spawn_on(Database::File(db)).await;
    let cells = app.get_ok("/v1/cells").await;
    assert_eq!(cells[0]["id"], 1);
    assert_eq!(cells[0]["name"], "c");
    let finished = app.get_ok("/v1/routines/1").await;
    assert_eq!(finished["finished"], true);
    let seqs: Vec<i64> = finished["waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["id"].as_i64().unwrap())
        .collect();
    assert_eq!(seqs, [1, 2, 3]);
    assert_eq!(finished["waypoints"][2]["pose"]["y"], 50.0);
    assert_eq!(finished["waypoints"][2]["reachable"], true, "{finished}");
    let stats = app.get_ok("/v1/cells/1/stats").await;
    assert_eq!(stats["feedback"]["offered"], 1);
    assert_eq!(stats["feedback"]["accepted"], 1);
    assert_eq!(stats["model"]["routines"], 1);
    // The open routine goes on; new ids come after the largest present, and an undone one is
    // not given again.
    let p = json!({"x": 450.0, "y": 100.0, "z": 300.0, "qw": 0.0, "qx": 0.0, "qy": 1.0, "qz": 0.0});
    let taught = app.append(2, &p).await;
    assert_eq!(taught["waypoint"]["seq"], 2);
    assert_eq!(taught["waypoint"]["id"], 5);
    let r = app.delete("/v1/routines/2/waypoints/last").await;
    expect(r, StatusCode::OK).await;
    let taught = app.append(2, &p).await;
    assert_eq!(taught["waypoint"]["seq"], 2);
    assert_eq!(taught["waypoint"]["id"], 6);
    let again = app
        .post(
            &format!("/v1/predictions/{}/feedback", 7),
            &json!({"verdict": "rejected"}),
        )
        .await;
    expect_error(again, StatusCode::CONFLICT, "conflict").await;
}
