//! Several service instances on one PostgreSQL database: a teaching session whose requests
//! alternate between two real `nextpose serve` processes, one of them killed with SIGKILL and
//! restarted midway, stores and predicts exactly what one instance does; appends to one cell
//! sent to both at once are serialised. Needs the cluster of `scripts/with-postgres.sh`
//! (`bash scripts/test.sh` runs these with `--ignored`); the teaching session teaches a corpus
//! program, so it also needs the shared corpus.

use std::process::Child;

use nextpose::server::Database;
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::durability::{corpus_program, snapshot, start_binary};
use crate::helpers::*;

/// A `nextpose serve` process on a database.
struct Instance {
    child: Child,
    app: TestApp,
}

impl Instance {
    async fn start(db: &Database) -> Instance {
        let db = db.clone();
        let (child, base) = tokio::task::spawn_blocking(move || start_binary(&db))
            .await
            .expect("start");
        Instance {
            child,
            app: TestApp::remote(&base),
        }
    }

    /// SIGKILL: no shutdown, no flush.
    fn kill(&mut self) {
        self.child.kill().expect("kill -9");
        self.child.wait().expect("wait");
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        self.child.kill().ok();
        self.child.wait().ok();
    }
}

/// An answer without the times it was made at (two runs differ only there).
fn timeless(mut v: Value) -> Value {
    match &mut v {
        Value::Object(map) => {
            map.remove("created_at");
            map.remove("finished_at");
            for x in map.values_mut() {
                *x = timeless(x.take());
            }
        }
        Value::Array(items) => {
            for x in items.iter_mut() {
                *x = timeless(x.take());
            }
        }
        _ => {}
    }
    v
}

/// The instances of a run, taking requests in turn.
struct Servers {
    db: Database,
    instances: Vec<Instance>,
    /// Before this request, the first instance is killed (SIGKILL) and started again.
    kill_at: Option<usize>,
    requests: usize,
}

impl Servers {
    async fn start(count: usize, kill_at: Option<usize>) -> Servers {
        let db = Database::Postgres(postgres_database().await);
        let mut instances = Vec::new();
        for _ in 0..count {
            instances.push(Instance::start(&db).await);
        }
        Servers {
            db,
            instances,
            kill_at,
            requests: 0,
        }
    }

    /// The instance that takes the next request.
    async fn next(&mut self) -> &TestApp {
        if self.kill_at == Some(self.requests) {
            self.instances[0].kill();
            self.instances[0] = Instance::start(&self.db).await;
        }
        let k = self.requests % self.instances.len();
        self.requests += 1;
        &self.instances[k].app
    }
}

/// The teaching session: a corpus program taught routine by routine (every fifth waypoint
/// undone and taught again, the model's completion asked for now and then), the last routine
/// left half taught. Returns every answer in order, and the cell and the open routine.
async fn session(servers: &mut Servers) -> (Vec<Value>, i64, i64) {
    let routines = corpus_program();
    let mut answers = Vec::new();
    let cell = servers.next().await.create_cell("shared").await;
    let program = servers.next().await.create_program(cell, "corpus").await;
    let mut open = 0;
    for (n, r) in routines.iter().enumerate() {
        let last = n + 1 == routines.len();
        open = servers.next().await.create_routine(program).await;
        let taught = if last { r.len().div_ceil(2) } else { r.len() };
        for (k, p) in r[..taught].iter().enumerate() {
            answers.push(timeless(servers.next().await.append(open, p).await));
            if k % 5 == 4 {
                let app = servers.next().await;
                let undone = app
                    .delete(&format!("/v1/routines/{open}/waypoints/last"))
                    .await;
                answers.push(timeless(expect(undone, StatusCode::OK).await));
                answers.push(timeless(servers.next().await.append(open, p).await));
            }
            if k % 7 == 6 {
                let path = format!("/v1/routines/{open}/prediction?k=3");
                answers.push(timeless(servers.next().await.get_ok(&path).await));
            }
        }
        if !last {
            answers.push(timeless(servers.next().await.finish(open).await));
        }
    }
    (answers, cell, open)
}

#[tokio::test]
#[cfg_attr(
    corpus,
    ignore = "needs PostgreSQL: scripts/test.sh runs it beside a throwaway cluster"
)]
#[cfg_attr(
    not(corpus),
    ignore = "needs PostgreSQL and the shared corpus (../shared/corpus) beside the checkout"
)]
async fn two_instances_alternating_with_a_kill_match_one_instance() {
    let mut alone = Servers::start(1, None).await;
    let (expected, cell, open) = session(&mut alone).await;
    assert!(
        expected.len() > 20,
        "a session of {} answers",
        expected.len()
    );
    let expected_state = timeless(snapshot(alone.next().await, cell, open).await);
    assert!(
        expected
            .iter()
            .any(|a| a["prediction"]["offered"] == json!(true)),
        "the session gets predictions offered"
    );

    // Two instances, request by request; the first killed and started again midway.
    let mut two = Servers::start(2, Some(alone.requests / 2)).await;
    let (answers, cell_2, open_2) = session(&mut two).await;
    assert_eq!((cell_2, open_2), (cell, open));
    assert!(two.kill_at < Some(two.requests), "the kill happened");
    for (i, (got, want)) in answers.iter().zip(&expected).enumerate() {
        assert_eq!(got, want, "answer {i}");
    }
    assert_eq!(answers.len(), expected.len());
    // Stored waypoints, model and predictions, as each instance sees them.
    for k in 0..2 {
        let app = &two.instances[k].app;
        assert_eq!(
            timeless(snapshot(app, cell, open).await),
            expected_state,
            "instance {k}"
        );
        // And its model in memory is the one the database gives.
        app.rebuild(cell).await;
        let metrics = app.get("/metrics").await.text().await.expect("metrics");
        assert_eq!(
            sample(&metrics, "nextpose_model_divergences_total"),
            Some(0.0),
            "instance {k}"
        );
    }
}

/// Appends to one routine sent to two instances at once: each is answered (after a retry when
/// the other instance got there first) or refused as busy, and what is stored is one gapless
/// sequence that both instances' models, and a rebuild, agree on.
#[ignore = "needs PostgreSQL: scripts/test.sh runs it beside a throwaway cluster"]
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn concurrent_appends_on_two_instances_are_serialised() {
    let mut two = Servers::start(2, None).await;
    let cell = two.next().await.create_cell("contended").await;
    let program = two.next().await.create_program(cell, "p").await;
    let warm = two.next().await.create_routine(program).await;
    for p in u_seam([0.0; 3], 0.0) {
        two.next().await.append(warm, &p).await;
    }
    two.next().await.finish(warm).await;
    let open = two.next().await.create_routine(program).await;

    let seam = u_seam([40.0, 30.0, 0.0], 0.3);
    let mut sent = Vec::new();
    for round in 0..6 {
        for (j, p) in seam.iter().enumerate() {
            let app = &two.instances[(round + j) % 2].app;
            let url = app.url(&format!("/v1/routines/{open}/waypoints"));
            sent.push(tokio::spawn(
                app.client.post(url).json(&json!({ "pose": p })).send(),
            ));
        }
    }
    let mut acknowledged = 0;
    for r in sent {
        let r = r.await.expect("task").expect("request");
        match r.status() {
            StatusCode::CREATED | StatusCode::OK => acknowledged += 1,
            StatusCode::CONFLICT => {
                let body: Value = r.json().await.expect("json");
                assert_eq!(body["error"]["code"], "busy", "{body}");
            }
            other => panic!("unexpected {other}: {:?}", r.text().await),
        }
    }
    assert!(acknowledged > 0);
    let a = two.instances[0]
        .app
        .get_ok(&format!("/v1/routines/{open}"))
        .await;
    let seqs: Vec<i64> = a["waypoints"]
        .as_array()
        .expect("waypoints")
        .iter()
        .map(|w| w["seq"].as_i64().expect("seq"))
        .collect();
    assert_eq!(seqs, (1..=acknowledged).collect::<Vec<i64>>());
    // Both models hold what is stored: their next prediction, and their model after a
    // rebuild from the database, agree.
    let path = format!("/v1/routines/{open}/prediction?k=3");
    let p0 = timeless(two.instances[0].app.get_ok(&path).await);
    let p1 = timeless(two.instances[1].app.get_ok(&path).await);
    assert_eq!(p0, p1);
    for k in 0..2 {
        let app = &two.instances[k].app;
        let before = app.get_ok(&format!("/v1/cells/{cell}/stats")).await["model"].clone();
        let rebuilt = app.rebuild(cell).await;
        assert_eq!(rebuilt, before, "instance {k}");
        // The model in memory, caught up, was what the rebuild learned.
        let metrics = app.get("/metrics").await.text().await.expect("metrics");
        assert_eq!(
            sample(&metrics, "nextpose_model_divergences_total"),
            Some(0.0),
            "instance {k}"
        );
    }
}

/// A program changed through two instances at once (routines renamed on one, waypoints taught
/// on the other) keeps one gapless history: every rename is answered and is one revision,
/// every acknowledged append is one, and the revisions are numbered 1, 2, … without a
/// collision (a rename holds the cell's row like every other write to the cell).
#[ignore = "needs PostgreSQL: scripts/test.sh runs it beside a throwaway cluster"]
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_program_changed_on_two_instances_keeps_one_history() {
    let mut two = Servers::start(2, None).await;
    let cell = two.next().await.create_cell("two-histories").await;
    let program = two.next().await.create_program(cell, "p").await;
    let (done, _) = two
        .next()
        .await
        .teach_routine(program, &u_seam([0.0; 3], 0.0))
        .await;
    let open = two.next().await.create_routine(program).await;
    let before = two.instances[0]
        .app
        .get_ok(&format!("/v1/programs/{program}/history?limit=1"))
        .await["revision"]
        .as_i64()
        .expect("revision");

    let (renamer, teacher) = (&two.instances[0].app, &two.instances[1].app);
    let mut renames = Vec::new();
    let mut appends = Vec::new();
    for (i, p) in u_seam([40.0, 30.0, 0.0], 0.3)
        .iter()
        .cycle()
        .take(12)
        .enumerate()
    {
        let url = renamer.url(&format!("/v1/routines/{done}"));
        renames.push(tokio::spawn(
            renamer
                .client
                .patch(url)
                .json(&json!({ "name": format!("name-{i}") }))
                .send(),
        ));
        let url = teacher.url(&format!("/v1/routines/{open}/waypoints"));
        appends.push(tokio::spawn(
            teacher.client.post(url).json(&json!({ "pose": p })).send(),
        ));
    }
    for r in renames {
        let r = r.await.expect("task").expect("request");
        assert_eq!(r.status(), StatusCode::OK, "{:?}", r.text().await);
    }
    let mut acknowledged = 0;
    for r in appends {
        let r = r.await.expect("task").expect("request");
        match r.status() {
            StatusCode::CREATED => acknowledged += 1,
            StatusCode::CONFLICT => {
                let body: Value = r.json().await.expect("json");
                assert_eq!(body["error"]["code"], "busy", "{body}");
            }
            other => panic!("unexpected {other}: {:?}", r.text().await),
        }
    }
    let history = renamer
        .get_ok(&format!("/v1/programs/{program}/history?limit=1000"))
        .await;
    let revisions = history["revisions"].as_array().expect("revisions");
    let numbers: Vec<i64> = revisions
        .iter()
        .map(|r| r["revision"].as_i64().expect("revision"))
        .collect();
    let last = before + 12 + acknowledged;
    assert_eq!(numbers, (1..=last).rev().collect::<Vec<_>>());
    let made = |kind: &str| {
        revisions[..(last - before) as usize]
            .iter()
            .filter(|r| r["changes"][0]["change"] == kind)
            .count() as i64
    };
    assert_eq!(made("routine_renamed"), 12);
    assert_eq!(made("waypoint_added"), acknowledged);
}
