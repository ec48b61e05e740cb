//! Backups while serving (`POST /v1/backups`, `nextpose backup`): a backup taken while 8
//! clients append to 8 cells is a database that passes SQLite's integrity check, holds every
//! append acknowledged before the backup was asked for, and serves the same models and
//! predictions; a server killed with SIGKILL during a backup leaves its database intact and no
//! file under the backup's name; what cannot be written is refused, naming the problem, with
//! nothing written. On PostgreSQL the route answers that `pg_dump` is the tool, and a dump
//! restored into a new database serves the same predictions (the last test, run beside the
//! cluster of `scripts/with-postgres.sh`).
//!
//! The SQLite tests use SQLite files whichever database the suite runs on. Their databases
//! carry 32 MB of ballast (a table the service does not know), so that a copy takes long
//! enough for appends to be answered while it runs and for a kill to land in the middle of it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use nextpose::server::Database;
use reqwest::StatusCode;
use serde_json::{Value, json};
use sqlx::Connection;
use sqlx::sqlite::{SqliteConnectOptions, SqliteConnection};

use crate::durability::{snapshot, start_binary};
use crate::helpers::*;

/// Ballast, in MiB: enough for a copy to take a while.
const BALLAST_MIB: usize = 32;

/// An SQLite file at `path` with [`BALLAST_MIB`] of incompressible rows in a table of its own,
/// before the service has ever opened it (it adds its schema beside).
async fn database_with_ballast(path: &Path) -> Database {
    let options = SqliteConnectOptions::new()
        .filename(path)
        .create_if_missing(true)
        .journal_mode(sqlx::sqlite::SqliteJournalMode::Wal);
    let mut conn = SqliteConnection::connect_with(&options).await.unwrap();
    sqlx::query("CREATE TABLE ballast (b BLOB NOT NULL)")
        .execute(&mut conn)
        .await
        .unwrap();
    for _ in 0..BALLAST_MIB {
        sqlx::query("INSERT INTO ballast (b) VALUES (randomblob(1048576))")
            .execute(&mut conn)
            .await
            .unwrap();
    }
    conn.close().await.unwrap();
    Database::File(path.to_path_buf())
}

/// A connection to an SQLite file: read-only (a backup, checked as it is), or read-write (a
/// live database after a crash, recovered from its WAL as the service would).
async fn open(path: &Path, read_only: bool) -> SqliteConnection {
    let options = SqliteConnectOptions::new()
        .filename(path)
        .read_only(read_only);
    SqliteConnection::connect_with(&options).await.unwrap()
}

/// `PRAGMA integrity_check` of an SQLite file: `["ok"]` when sound.
async fn integrity(path: &Path, read_only: bool) -> Vec<String> {
    let mut conn = open(path, read_only).await;
    let found: Vec<(String,)> = sqlx::query_as("PRAGMA integrity_check")
        .fetch_all(&mut conn)
        .await
        .unwrap();
    conn.close().await.unwrap();
    found.into_iter().map(|(line,)| line).collect()
}

/// One stored or acknowledged waypoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct Stored {
    routine: i64,
    seq: i64,
    id: i64,
}

/// The waypoints an SQLite file holds.
async fn waypoints_in(path: &Path, read_only: bool) -> BTreeSet<Stored> {
    let mut conn = open(path, read_only).await;
    let rows: Vec<(i64, i64, i64)> = sqlx::query_as("SELECT routine_id, seq, id FROM waypoints")
        .fetch_all(&mut conn)
        .await
        .unwrap();
    conn.close().await.unwrap();
    rows.into_iter()
        .map(|(routine, seq, id)| Stored { routine, seq, id })
        .collect()
}

/// The files of a directory (none when it does not exist).
fn files_in(dir: &Path) -> BTreeSet<String> {
    match std::fs::read_dir(dir) {
        Ok(entries) => entries
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => BTreeSet::new(),
    }
}

/// An append the service acknowledged, with the prediction it answered.
#[derive(Debug, Clone)]
struct Ack {
    waypoint: Stored,
    prediction: Value,
}

/// Clients appending waypoints, each to the open routine of a cell of its own, until stopped
/// or until the server stops answering; what was acknowledged is logged in order.
struct Appenders {
    acks: Arc<Mutex<Vec<Ack>>>,
    /// Appends acknowledged, per client.
    counts: tokio::sync::watch::Receiver<Vec<usize>>,
    stop: Arc<AtomicBool>,
    tasks: Vec<tokio::task::JoinHandle<()>>,
}

impl Appenders {
    /// One client per routine of `routines` (each the open routine of its own cell).
    fn start(base: &str, routines: &[i64]) -> Appenders {
        let acks = Arc::new(Mutex::new(Vec::new()));
        let (counts_tx, counts) = tokio::sync::watch::channel(vec![0; routines.len()]);
        let counts_tx = Arc::new(counts_tx);
        let stop = Arc::new(AtomicBool::new(false));
        let tasks = routines
            .iter()
            .enumerate()
            .map(|(client, &routine)| {
                let (acks, counts_tx, stop) = (acks.clone(), counts_tx.clone(), stop.clone());
                let url = format!("{base}/v1/routines/{routine}/waypoints");
                tokio::spawn(async move {
                    let http = reqwest::Client::new();
                    let mut n = 0usize;
                    while !stop.load(Ordering::SeqCst) {
                        // The same seam again and again, moved along x each time.
                        let pose = &u_seam([200.0 * (n / 8) as f64, 0.0, 0.0], 0.0)[n % 8];
                        let Ok(r) = http.post(&url).json(&json!({ "pose": pose })).send().await
                        else {
                            return; // the server is gone
                        };
                        let Ok(body) = r.json::<Value>().await else {
                            return;
                        };
                        let w = &body["waypoint"];
                        let waypoint = Stored {
                            routine: w["routine_id"].as_i64().expect("routine_id"),
                            seq: w["seq"].as_i64().expect("seq"),
                            id: w["id"].as_i64().expect("id"),
                        };
                        let prediction = body["prediction"].clone();
                        acks.lock().unwrap().push(Ack {
                            waypoint,
                            prediction,
                        });
                        counts_tx.send_modify(|c| c[client] += 1);
                        n += 1;
                    }
                })
            })
            .collect();
        Appenders {
            acks,
            counts,
            stop,
            tasks,
        }
    }

    /// Waits until every client has had `more` appends acknowledged since `since` (counts per
    /// client; `None`: since it started).
    async fn progress(&mut self, since: Option<&[usize]>, more: usize) -> Vec<usize> {
        let base = since.map(<[usize]>::to_vec);
        let reached = self
            .counts
            .wait_for(|c| {
                c.iter()
                    .enumerate()
                    .all(|(i, n)| *n >= base.as_ref().map_or(0, |b| b[i]) + more)
            })
            .await
            .expect("an appender ended early");
        reached.clone()
    }

    /// The appends acknowledged so far.
    fn acknowledged(&self) -> Vec<Ack> {
        self.acks.lock().unwrap().clone()
    }

    /// Stops the clients (each finishes the append it is waiting for) and returns every append
    /// acknowledged.
    async fn stop(self) -> Vec<Ack> {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.tasks {
            t.await.unwrap();
        }
        Arc::try_unwrap(self.acks).unwrap().into_inner().unwrap()
    }
}

/// `n` cells, each with a finished seam (something to predict from) and an open routine;
/// returns the cells and their open routines.
async fn cells_being_taught(app: &TestApp, n: usize) -> Vec<(i64, i64)> {
    let mut out = Vec::new();
    for i in 0..n {
        let cell = app.create_cell(&format!("cell-{i}")).await;
        let program = app.create_program(cell, "seams").await;
        app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
        out.push((cell, app.create_routine(program).await));
    }
    out
}

fn waypoint_set(acks: &[Ack]) -> BTreeSet<Stored> {
    acks.iter().map(|a| a.waypoint).collect()
}

/// Each routine's waypoints in `stored` are numbered 1..n without a gap: the copy of a moment,
/// not of a moving database.
fn assert_gapless(stored: &BTreeSet<Stored>) {
    let mut by_routine: BTreeMap<i64, Vec<i64>> = BTreeMap::new();
    for w in stored {
        by_routine.entry(w.routine).or_default().push(w.seq);
    }
    for (routine, seqs) in by_routine {
        let expected: Vec<i64> = (1..=seqs.len() as i64).collect();
        assert_eq!(seqs, expected, "routine {routine}");
    }
}

/// Backups of a database 8 clients are appending to: every append acknowledged before the
/// backup was asked for is in it, nothing that was never acknowledged is, the copy passes
/// SQLite's integrity check, and a server started on it predicts what the live one predicted
/// at that point; a second backup after the appends stopped gives a server whose routines,
/// models and predictions equal the live one's exactly.
#[tokio::test]
async fn a_backup_taken_while_8_clients_append_holds_every_acknowledged_append() {
    let dir = tempfile::tempdir().unwrap();
    let db = database_with_ballast(&dir.path().join("live.db")).await;
    let backups = dir.path().join("backups");
    let app = spawn_on(db).await;
    let cells = cells_being_taught(&app, 8).await;
    let routines: Vec<i64> = cells.iter().map(|(_, r)| *r).collect();
    let mut appenders = Appenders::start(&app.base, &routines);
    appenders.progress(None, 3).await;

    let before = waypoint_set(&appenders.acknowledged());
    let answer = app
        .post_ok(
            "/v1/backups",
            &json!({ "name": "during.db" }),
            StatusCode::CREATED,
        )
        .await;
    let answered = appenders.acknowledged().len();
    // The service went on answering every client after the backup too.
    let counts = appenders.counts.borrow().clone();
    appenders.progress(Some(&counts), 3).await;
    let acks = appenders.stop().await;
    eprintln!(
        "backup of {} bytes in {} ms; {} appends acknowledged before it was asked for, {} by \
         its answer, {} in all",
        answer["bytes"],
        answer["took_ms"],
        before.len(),
        answered,
        acks.len()
    );

    let copy = backups.join("during.db");
    assert_eq!(answer["name"], "during.db");
    assert_eq!(answer["path"], copy.display().to_string());
    assert_eq!(
        answer["bytes"].as_u64(),
        Some(std::fs::metadata(&copy).unwrap().len())
    );
    assert!(answer["bytes"].as_u64().unwrap() > (BALLAST_MIB as u64) << 20);
    assert_eq!(files_in(&backups), BTreeSet::from(["during.db".into()]));
    assert_eq!(integrity(&copy, true).await, ["ok"]);
    let held = waypoints_in(&copy, true).await;
    let missing: Vec<_> = before.difference(&held).collect();
    assert!(
        missing.is_empty(),
        "acknowledged but not in the backup: {missing:?}"
    );
    let all = waypoint_set(&acks);
    let phantom: Vec<_> = held
        .iter()
        .filter(|w| routines.contains(&w.routine) && !all.contains(w))
        .collect();
    assert!(phantom.is_empty(), "never acknowledged: {phantom:?}");
    assert_gapless(&held);

    // A server on the copy predicts, for each routine, what the live server answered to the
    // append the copy ends with.
    let answered_to: BTreeMap<Stored, &Value> =
        acks.iter().map(|a| (a.waypoint, &a.prediction)).collect();
    let restored = spawn_on(Database::File(copy.clone())).await;
    for &routine in &routines {
        let last = held
            .iter()
            .filter(|w| w.routine == routine)
            .max_by_key(|w| w.seq)
            .expect("the backup holds appends of every routine");
        let live = answered_to[last];
        let again = restored
            .get_ok(&format!("/v1/routines/{routine}/prediction"))
            .await;
        let again = &again["predictions"][0];
        for field in ["pose", "offered", "withheld", "expert", "after_waypoints"] {
            assert_eq!(again[field], live[field], "routine {routine}: {field}");
        }
    }

    // Stopped: a second backup is the live database, and a server on it (the real binary,
    // `nextpose serve --db COPY`) answers exactly as the live one.
    let answer = app
        .post_ok(
            "/v1/backups",
            &json!({ "name": "after.db" }),
            StatusCode::CREATED,
        )
        .await;
    let after = PathBuf::from(answer["path"].as_str().unwrap());
    assert_eq!(integrity(&after, true).await, ["ok"]);
    assert_eq!(waypoints_in(&after, true).await.len(), all.len() + 8 * 8);
    let mut live = Vec::new();
    for &(cell, open) in &cells {
        live.push(snapshot(&app, cell, open).await);
    }
    let (mut child, base) = tokio::task::spawn_blocking({
        let after = Database::File(after.clone());
        move || start_binary(&after)
    })
    .await
    .unwrap();
    let served = TestApp::remote(&base);
    let mut copied = Vec::new();
    for &(cell, open) in &cells {
        copied.push(snapshot(&served, cell, open).await);
    }
    child.kill().ok();
    child.wait().ok();
    assert_eq!(copied, live);
}

/// SIGKILL of the real binary while it writes a backup, with 8 clients appending: the live
/// database passes its integrity check and holds every append acknowledged, nothing is under
/// the backup's name (only the temporary `.NAME.XXXXXX.partial`, perhaps with SQLite's
/// `-journal` of it, which the docs say may be deleted), and the restarted server serves and
/// writes the backup under that name.
///
/// The server is killed once the backup's temporary file holds a quarter of the database. A
/// backup that finished before that is tried again under another name; one whose rename beat the kill is checked
/// as the complete backup it is, and the server started again for another try.
#[tokio::test]
async fn a_server_killed_during_a_backup_leaves_its_database_intact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("live.db");
    let db = database_with_ballast(&path).await;
    let backups = dir.path().join("backups");
    let start = || {
        let db = db.clone();
        async move {
            tokio::task::spawn_blocking(move || start_binary(&db))
                .await
                .unwrap()
        }
    };
    let (mut child, mut base) = start().await;
    let cells = cells_being_taught(&TestApp::remote(&base), 8).await;
    let routines: Vec<i64> = cells.iter().map(|(_, r)| *r).collect();
    let mut acked = BTreeSet::new();
    let mut killed = None;
    for attempt in 0..10 {
        let mut appenders = Appenders::start(&base, &routines);
        appenders.progress(None, 3).await;
        let name = format!("killed-{attempt}.db");
        let prefix = format!(".{name}.");
        let request = tokio::spawn({
            let (http, url) = (reqwest::Client::new(), format!("{base}/v1/backups"));
            let body = json!({ "name": name });
            async move { http.post(url).json(&body).send().await }
        });
        let mut seen = false;
        while !request.is_finished() {
            // Killed a quarter of the way through the copy.
            seen = files_in(&backups).iter().any(|f| {
                f.starts_with(&prefix)
                    && f.ends_with(".partial")
                    && std::fs::metadata(backups.join(f))
                        .is_ok_and(|m| m.len() >= (BALLAST_MIB as u64) << 18)
            });
            if seen {
                child.kill().expect("kill -9");
                child.wait().unwrap();
                break;
            }
            tokio::time::sleep(std::time::Duration::from_millis(1)).await;
        }
        if !seen {
            // Done before its temporary file was seen: a backup, and another try.
            let r = request.await.unwrap().expect("backup request");
            expect(r, StatusCode::CREATED).await;
            acked.extend(waypoint_set(&appenders.stop().await));
            continue;
        }
        acked.extend(waypoint_set(&appenders.stop().await));
        let answer = request.await.unwrap();
        // Whatever the kill interrupted, the live database is whole.
        assert_eq!(integrity(&path, false).await, ["ok"]);
        let held = waypoints_in(&path, false).await;
        let missing: Vec<_> = acked.difference(&held).collect();
        assert!(missing.is_empty(), "acknowledged but lost: {missing:?}");
        assert_gapless(&held);
        if backups.join(&name).exists() {
            // The rename beat the kill: a complete backup; try again.
            assert_eq!(integrity(&backups.join(&name), true).await, ["ok"]);
            (child, base) = start().await;
            continue;
        }
        assert!(answer.is_err(), "answered without a backup: {answer:?}");
        eprintln!(
            "killed during backup {attempt}, {} appends acknowledged",
            acked.len()
        );
        killed = Some(name);
        break;
    }
    let name = killed.expect("no backup was killed midway in 10 tries");
    // Left behind: the temporary file, and SQLite's journal of it if the kill came while it
    // wrote.
    let left: Vec<String> = files_in(&backups)
        .into_iter()
        .filter(|f| f.starts_with(&format!(".{name}.")))
        .collect();
    let temporary = left.iter().filter(|f| f.ends_with(".partial")).count();
    let journals = left
        .iter()
        .filter(|f| f.ends_with(".partial-journal"))
        .count();
    assert!(
        temporary == 1 && journals <= 1 && left.len() == temporary + journals,
        "{:?}",
        files_in(&backups)
    );

    // The server starts again on it, goes on teaching, and writes the backup it was killed in.
    let (mut child, base) = start().await;
    let app = TestApp::remote(&base);
    let (cell, open) = cells[0];
    app.append(open, &u_seam([0.0; 3], 0.0)[0]).await;
    snapshot(&app, cell, open).await;
    let answer = app
        .post_ok("/v1/backups", &json!({ "name": name }), StatusCode::CREATED)
        .await;
    child.kill().ok();
    child.wait().ok();
    assert_eq!(answer["name"], name.as_str());
    assert_eq!(integrity(&backups.join(&name), true).await, ["ok"]);
}

/// What a backup cannot be: a path, a hidden or odd name, a file that exists, a PostgreSQL or
/// in-memory database. Each is refused naming the problem, and nothing is written.
#[tokio::test]
async fn backups_refuse_what_they_cannot_write() {
    let dir = tempfile::tempdir().unwrap();
    let app = spawn_on(test_database(dir.path()).await).await;
    let backups = dir.path().join("backups");
    if on_postgres() {
        for body in [json!({}), json!({ "name": "nightly.db" })] {
            let r = app.post("/v1/backups", &body).await;
            let message = expect_error(r, StatusCode::CONFLICT, "backup_unsupported").await;
            assert!(message.contains("pg_dump"), "{message}");
        }
        assert!(files_in(dir.path()).is_empty());
        return;
    }

    let long = "a".repeat(nextpose::app::MAX_BACKUP_NAME + 1);
    for name in [
        "../escape.db",
        "sub/dir.db",
        "/tmp/absolute.db",
        "..",
        ".hidden.db",
        "",
        "two words.db",
        "back\\slash.db",
        "ünicode.db",
        long.as_str(),
    ] {
        let r = app.post("/v1/backups", &json!({ "name": name })).await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
        assert!(message.contains("backup name"), "{name:?}: {message}");
    }
    for body in [
        json!({ "name": 7 }),
        json!({ "path": "/tmp/x.db" }),
        json!([]),
    ] {
        let r = app.post("/v1/backups", &body).await;
        assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY, "{body}");
    }
    assert!(!backups.exists(), "created by refused requests");
    assert!(!dir.path().join("escape.db").exists());

    // A name taken, by a backup or by anything else, is never overwritten.
    let first = app
        .post_ok(
            "/v1/backups",
            &json!({ "name": "nightly.db" }),
            StatusCode::CREATED,
        )
        .await;
    let written = std::fs::read(backups.join("nightly.db")).unwrap();
    assert_eq!(first["bytes"].as_u64(), Some(written.len() as u64));
    std::fs::write(backups.join("notes.txt"), "keep me").unwrap();
    for name in ["nightly.db", "notes.txt"] {
        let r = app.post("/v1/backups", &json!({ "name": name })).await;
        let message = expect_error(r, StatusCode::CONFLICT, "conflict").await;
        assert!(message.contains("exists already"), "{message}");
    }
    assert_eq!(std::fs::read(backups.join("nightly.db")).unwrap(), written);
    assert_eq!(
        std::fs::read_to_string(backups.join("notes.txt")).unwrap(),
        "keep me"
    );

    // No name: one made from the time.
    let auto = app
        .post_ok("/v1/backups", &json!({}), StatusCode::CREATED)
        .await;
    let auto = auto["name"].as_str().unwrap().to_string();
    let stamp = auto
        .strip_prefix("nextpose-")
        .and_then(|s| s.strip_suffix("Z.db"))
        .unwrap_or_else(|| panic!("{auto}"));
    assert!(
        stamp.len() == 19
            && stamp.chars().enumerate().all(|(i, c)| match i {
                8 => c == 'T',
                15 => c == '.',
                _ => c.is_ascii_digit(),
            }),
        "{auto}"
    );
    assert_eq!(
        files_in(&backups),
        BTreeSet::from([auto, "nightly.db".into(), "notes.txt".into()])
    );
    // The backup directory is the owner's alone.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&backups).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o700, "{mode:o}");
    }

    let memory = spawn_on(Database::Memory).await;
    let r = memory.post("/v1/backups", &json!({})).await;
    let message = expect_error(r, StatusCode::CONFLICT, "backup_unsupported").await;
    assert!(message.contains("in memory"), "{message}");
}

/// An admin route: with a token set, a backup without it is refused and nothing is written.
#[tokio::test]
async fn a_backup_needs_the_token() {
    let mut app = spawn_with(nextpose::transport::TransportOptions {
        token: Some("s3cret".into()),
        ..nextpose::transport::TransportOptions::default()
    })
    .await;
    let token = app.token.take();
    let r = app.post("/v1/backups", &json!({ "name": "x.db" })).await;
    expect_error(r, StatusCode::UNAUTHORIZED, "unauthorized").await;
    app.token = token;
    let r = app.post("/v1/backups", &json!({ "name": "x.db" })).await;
    if on_postgres() {
        expect_error(r, StatusCode::CONFLICT, "backup_unsupported").await;
    } else {
        let written = expect(r, StatusCode::CREATED).await;
        assert_eq!(written["name"], "x.db");
    }
}

/// `nextpose backup OUT --db DB` beside a server serving DB: the copy passes the integrity
/// check, and the server on it answers as the live one; OUT is never overwritten, and a
/// PostgreSQL URL, a missing database or a missing directory is refused with nothing written.
#[tokio::test]
async fn nextpose_backup_copies_a_served_database() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("live.db");
    let db = Database::File(path.clone());
    let (mut child, base) = tokio::task::spawn_blocking({
        let db = db.clone();
        move || start_binary(&db)
    })
    .await
    .unwrap();
    let app = TestApp::remote(&base);
    let cells = cells_being_taught(&app, 2).await;
    for &(_, open) in &cells {
        for p in &u_seam([50.0, 0.0, 0.0], 0.3)[..3] {
            app.append(open, p).await;
        }
    }
    let out = dir.path().join("copy.db");
    let backup = |out: &Path, db: &str| {
        let out = out.to_path_buf();
        let db = db.to_string();
        tokio::task::spawn_blocking(move || {
            Command::new(env!("CARGO_BIN_EXE_nextpose"))
                .arg("backup")
                .arg(&out)
                .args(["--db", &db])
                .env_remove("NEXTPOSE_DB")
                .output()
                .expect("run nextpose backup")
        })
    };
    let done = backup(&out, path.to_str().unwrap()).await.unwrap();
    let stdout = String::from_utf8_lossy(&done.stdout);
    assert!(
        done.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&done.stderr)
    );
    assert!(
        stdout.starts_with(&format!("wrote {}", out.display())),
        "{stdout}"
    );
    assert_eq!(integrity(&out, true).await, ["ok"]);
    let mut live = Vec::new();
    for &(cell, open) in &cells {
        live.push(snapshot(&app, cell, open).await);
    }
    child.kill().ok();
    child.wait().ok();

    let written = std::fs::read(&out).unwrap();
    let missing = dir.path().join("missing.db");
    let refused = [
        (out.clone(), path.to_str().unwrap(), "exists already"),
        (
            dir.path().join("other.db"),
            "postgres://nobody@127.0.0.1:1/none",
            "pg_dump",
        ),
        (
            dir.path().join("other.db"),
            missing.to_str().unwrap(),
            "no database file",
        ),
        (
            dir.path().join("no-such-dir/other.db"),
            path.to_str().unwrap(),
            "cannot create a temporary file",
        ),
    ];
    for (to, from, says) in refused {
        let done = backup(&to, from).await.unwrap();
        let stderr = String::from_utf8_lossy(&done.stderr);
        assert!(!done.status.success(), "{to:?} from {from}");
        assert!(stderr.contains(says), "{to:?} from {from}: {stderr}");
    }
    assert_eq!(std::fs::read(&out).unwrap(), written);
    let others: BTreeSet<String> = files_in(dir.path())
        .into_iter()
        .filter(|f| !f.starts_with("live.db"))
        .collect();
    assert_eq!(others, BTreeSet::from(["copy.db".into()]));

    let served = spawn_on(Database::File(out)).await;
    let mut copied = Vec::new();
    for &(cell, open) in &cells {
        copied.push(snapshot(&served, cell, open).await);
    }
    assert_eq!(copied, live);
}

/// PostgreSQL: `pg_dump` of a database the service serves (while it serves), restored with
/// `pg_restore` into a new database, serves the same routines, models and predictions. Needs
/// the cluster of `scripts/with-postgres.sh` and its client programs (`bash scripts/test.sh`
/// runs it with `--ignored`).
#[tokio::test]
#[ignore = "needs the PostgreSQL cluster of scripts/with-postgres.sh"]
async fn pg_dump_and_pg_restore_give_the_same_models_and_predictions() {
    let source = postgres_database().await;
    let app = spawn_on(Database::Postgres(source.clone())).await;
    let cells = cells_being_taught(&app, 3).await;
    for (i, &(_, open)) in cells.iter().enumerate() {
        for p in &u_seam([40.0 * i as f64, 0.0, 0.0], 0.2 * i as f64)[..4] {
            app.append(open, p).await;
        }
    }
    let r = app.post("/v1/backups", &json!({})).await;
    expect_error(r, StatusCode::CONFLICT, "backup_unsupported").await;
    let mut live = Vec::new();
    for &(cell, open) in &cells {
        live.push(snapshot(&app, cell, open).await);
    }

    let bin = postgres_bin();
    let dir = tempfile::tempdir().unwrap();
    let dump = dir.path().join("nextpose.dump");
    let run = |program: &str, args: Vec<String>| {
        let out = Command::new(bin.join(program))
            .args(&args)
            .output()
            .unwrap_or_else(|e| panic!("{program}: {e}"));
        assert!(
            out.status.success(),
            "{program} {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    run(
        "pg_dump",
        vec![
            "--format=custom".into(),
            format!("--file={}", dump.display()),
            source.clone(),
        ],
    );
    let restored = postgres_database().await;
    run(
        "pg_restore",
        vec![
            "--no-owner".into(),
            "--exit-on-error".into(),
            format!("--dbname={restored}"),
            dump.display().to_string(),
        ],
    );

    let served = spawn_on(Database::Postgres(restored)).await;
    let mut copied = Vec::new();
    for &(cell, open) in &cells {
        copied.push(snapshot(&served, cell, open).await);
    }
    assert_eq!(copied, live);
    // The restored database goes on: ids continue after the dumped ones.
    let (_, open) = cells[0];
    let taught = served.append(open, &u_seam([0.0; 3], 0.0)[4]).await;
    assert_eq!(taught["waypoint"]["seq"], 5);
}

/// The directory of PostgreSQL's programs, as `scripts/with-postgres.sh` finds them: on the
/// `PATH` beside `initdb`, or Debian's newest `/usr/lib/postgresql/*/bin`.
fn postgres_bin() -> PathBuf {
    if let Some(dir) = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .find(|d| d.join("initdb").is_file() && d.join("pg_dump").is_file())
    }) {
        return dir;
    }
    let mut versions: Vec<(u32, PathBuf)> = std::fs::read_dir("/usr/lib/postgresql")
        .expect("PostgreSQL in /usr/lib/postgresql")
        .filter_map(|e| {
            let e = e.ok()?;
            let version = e.file_name().to_str()?.parse().ok()?;
            Some((version, e.path().join("bin")))
        })
        .filter(|(_, bin)| bin.join("pg_dump").is_file())
        .collect();
    versions.sort();
    versions
        .pop()
        .expect("pg_dump in /usr/lib/postgresql/*/bin")
        .1
}
