//! `spawn_app()`: the real application on 127.0.0.1:0 with a fresh SQLite file, plus small
//! clients for the routes the tests use.

use nalgebra::UnitQuaternion;
use nextpose::server::{Application, Database, Running, ServerSettings};
use nextpose::storage::Durability;
use nextpose::transport::TransportOptions;
use reqwest::{Response, StatusCode};
use serde_json::{Value, json};

pub struct TestApp {
    pub base: String,
    pub client: reqwest::Client,
    pub db: Database,
    pub token: Option<String>,
    _dir: Option<tempfile::TempDir>,
    server: Option<Running>,
}

pub async fn spawn_app() -> TestApp {
    spawn_with(TransportOptions::default()).await
}

pub async fn spawn_with(http: TransportOptions) -> TestApp {
    let dir = tempfile::tempdir().expect("temp dir");
    let db = test_database(dir.path()).await;
    let mut app = start(db, http).await;
    app._dir = Some(dir);
    app
}

/// The application on an existing database (kept by the caller).
pub async fn spawn_on(db: Database) -> TestApp {
    start(db, TransportOptions::default()).await
}

/// Whether the tests run on PostgreSQL (`NEXTPOSE_TEST_DB=postgres`, with the cluster of
/// `scripts/with-postgres.sh` in `NEXTPOSE_TEST_POSTGRES`) instead of SQLite files.
pub fn on_postgres() -> bool {
    std::env::var("NEXTPOSE_TEST_DB").is_ok_and(|v| v == "postgres")
}

/// A new, empty database for one test: an SQLite file in `dir`, or (on PostgreSQL) a database
/// of its own in the test cluster.
pub async fn test_database(dir: &std::path::Path) -> Database {
    if on_postgres() {
        Database::Postgres(postgres_database().await)
    } else {
        Database::File(dir.join("nextpose.db"))
    }
}

/// Creates a database in the test cluster; returns its URL. Needs `NEXTPOSE_TEST_POSTGRES`
/// (`bash scripts/with-postgres.sh cargo test …` sets it).
pub async fn postgres_database() -> String {
    use sqlx::Connection;
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let cluster = std::env::var("NEXTPOSE_TEST_POSTGRES").expect(
        "NEXTPOSE_TEST_POSTGRES is unset: run the tests with `bash scripts/test.sh`, which starts \
         a throwaway PostgreSQL cluster (scripts/with-postgres.sh)",
    );
    let mut conn = sqlx::PgConnection::connect(&cluster)
        .await
        .expect("connect to the test cluster");
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("clock")
        .subsec_nanos();
    let name = format!(
        "t{}_{}_{nanos}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    );
    sqlx::query(sqlx::AssertSqlSafe(format!("CREATE DATABASE {name}")))
        .execute(&mut conn)
        .await
        .expect("create a test database");
    let mut url = url::Url::parse(&cluster).expect("cluster URL");
    url.set_path(&name);
    url.to_string()
}

/// `db` as `nextpose serve --db` takes it.
pub fn db_setting(db: &Database) -> std::ffi::OsString {
    match db {
        Database::File(path) => path.clone().into_os_string(),
        Database::Memory => "sqlite::memory:".into(),
        Database::Postgres(url) => url.into(),
    }
}

async fn start(db: Database, http: TransportOptions) -> TestApp {
    let token = http.token.clone();
    let settings = ServerSettings {
        database: db.clone(),
        durability: Durability::Process,
        addr: "127.0.0.1:0".into(),
        http,
        robots: None,
        backup_dir: None,
    };
    let server = Application::build(settings)
        .await
        .expect("build")
        .spawn()
        .expect("addr");
    TestApp {
        base: server.base_url(),
        client: reqwest::Client::new(),
        db,
        token,
        _dir: None,
        server: Some(server),
    }
}

impl TestApp {
    /// A client for a server running elsewhere (e.g. the real binary).
    pub fn remote(base: &str) -> TestApp {
        TestApp {
            base: base.trim_end_matches('/').to_string(),
            client: reqwest::Client::new(),
            db: Database::Memory,
            token: None,
            _dir: None,
            server: None,
        }
    }

    /// Stops the server gracefully and starts a new one on the same database file.
    pub async fn restart(mut self) -> TestApp {
        self.stop().await;
        let mut next = start(
            self.db.clone(),
            TransportOptions {
                token: self.token.clone(),
                ..TransportOptions::default()
            },
        )
        .await;
        next._dir = self._dir.take();
        next
    }

    pub async fn stop(&mut self) {
        if let Some(mut server) = self.server.take() {
            server.stop().await.expect("serve");
        }
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{}", self.base, path)
    }

    fn auth(&self, rb: reqwest::RequestBuilder) -> reqwest::RequestBuilder {
        match &self.token {
            Some(t) => rb.bearer_auth(t),
            None => rb,
        }
    }

    pub async fn get(&self, path: &str) -> Response {
        self.auth(self.client.get(self.url(path)))
            .send()
            .await
            .expect("request")
    }

    pub async fn post(&self, path: &str, body: &Value) -> Response {
        self.auth(self.client.post(self.url(path)).json(body))
            .send()
            .await
            .expect("request")
    }

    pub async fn patch(&self, path: &str, body: &Value) -> Response {
        self.auth(self.client.patch(self.url(path)).json(body))
            .send()
            .await
            .expect("request")
    }

    pub async fn delete(&self, path: &str) -> Response {
        self.auth(self.client.delete(self.url(path)))
            .send()
            .await
            .expect("request")
    }

    /// Rebuilds a cell's model from the database (`POST /v1/cells/{cell}/rebuild`): the model
    /// a rebuild gives.
    pub async fn rebuild(&self, cell: i64) -> Value {
        self.post_ok(
            &format!("/v1/cells/{cell}/rebuild"),
            &json!({}),
            StatusCode::OK,
        )
        .await
    }

    /// Imports files into a cell (`POST /v1/cells/{cell}/imports`, `body` with its `files`);
    /// returns the import's answer, asserting it was made.
    pub async fn import(&self, cell: i64, body: &Value) -> Value {
        self.post_ok(
            &format!("/v1/cells/{cell}/imports"),
            body,
            StatusCode::CREATED,
        )
        .await
    }

    /// POSTs and returns the JSON body, asserting the status.
    pub async fn post_ok(&self, path: &str, body: &Value, status: StatusCode) -> Value {
        let r = self.post(path, body).await;
        expect(r, status).await
    }

    pub async fn get_ok(&self, path: &str) -> Value {
        expect(self.get(path).await, StatusCode::OK).await
    }

    /// Waits until the unlabelled sample `name` of `/metrics` reads `value` (a condition the
    /// server reaches on its own, e.g. a session task ending after its client went away).
    /// Gives up after 30 s.
    pub async fn wait_for_metric(&self, name: &str, value: f64) {
        let reached = async {
            loop {
                let text = self
                    .client
                    .get(self.url("/metrics"))
                    .send()
                    .await
                    .unwrap()
                    .text()
                    .await
                    .unwrap();
                if sample(&text, name) == Some(value) {
                    return;
                }
                tokio::time::sleep(std::time::Duration::from_millis(5)).await;
            }
        };
        tokio::time::timeout(std::time::Duration::from_secs(30), reached)
            .await
            .unwrap_or_else(|_| panic!("{name} never reached {value}"));
    }

    /// A cell whose predictions are offered even where its arm (the default IRB 140 at the
    /// work-frame origin) cannot reach them, flagged: most tests are about the teaching loop,
    /// not about reach (tests/api/reach.rs is).
    pub async fn create_cell(&self, name: &str) -> i64 {
        self.create_cell_with(name, json!({ "reach_policy": "flag" }))
            .await
    }

    pub async fn create_cell_with(&self, name: &str, settings: Value) -> i64 {
        self.post_ok(
            "/v1/cells",
            &json!({ "name": name, "settings": settings }),
            StatusCode::CREATED,
        )
        .await["id"]
            .as_i64()
            .expect("cell id")
    }

    pub async fn create_program(&self, cell: i64, name: &str) -> i64 {
        self.post_ok(
            &format!("/v1/cells/{cell}/programs"),
            &json!({ "name": name }),
            StatusCode::CREATED,
        )
        .await["id"]
            .as_i64()
            .expect("program id")
    }

    pub async fn create_routine(&self, program: i64) -> i64 {
        self.post_ok(
            &format!("/v1/programs/{program}/routines"),
            &json!({}),
            StatusCode::CREATED,
        )
        .await["id"]
            .as_i64()
            .expect("routine id")
    }

    /// Appends a waypoint; returns the response body (`waypoint`, `prediction`).
    pub async fn append(&self, routine: i64, pose: &Value) -> Value {
        self.post_ok(
            &format!("/v1/routines/{routine}/waypoints"),
            &json!({ "pose": pose }),
            StatusCode::CREATED,
        )
        .await
    }

    pub async fn finish(&self, routine: i64) -> Value {
        self.post_ok(
            &format!("/v1/routines/{routine}/finish"),
            &json!({}),
            StatusCode::OK,
        )
        .await
    }

    /// Teaches a whole routine in a program and finishes it; returns the predictions made.
    pub async fn teach_routine(&self, program: i64, poses: &[Value]) -> (i64, Vec<Value>) {
        let r = self.create_routine(program).await;
        let mut predictions = Vec::new();
        for p in poses {
            predictions.push(self.append(r, p).await["prediction"].clone());
        }
        self.finish(r).await;
        (r, predictions)
    }
}

/// Asserts the status (showing the body when it differs) and returns the JSON body.
pub async fn expect(r: Response, status: StatusCode) -> Value {
    let got = r.status();
    let text = r.text().await.expect("body");
    assert_eq!(got, status, "body: {text}");
    if text.is_empty() {
        Value::Null
    } else {
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("not JSON ({e}): {text}"))
    }
}

/// Asserts an error response: status, JSON error shape and code.
pub async fn expect_error(r: Response, status: StatusCode, code: &str) -> String {
    let body = expect(r, status).await;
    assert_eq!(body["error"]["code"], code, "body: {body}");
    let message = body["error"]["message"].as_str().expect("message");
    assert!(!message.is_empty());
    message.to_string()
}

pub fn pose(p: [f64; 3], rpy: [f64; 3]) -> Value {
    let q = UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    json!({ "x": p[0], "y": p[1], "z": p[2], "qw": q.w, "qx": q.i, "qy": q.j, "qz": q.k })
}

/// A U-shaped seam with approach and retract, placed at `origin` and turned by `yaw`.
pub fn u_seam(origin: [f64; 3], yaw: f64) -> Vec<Value> {
    let local: [([f64; 3], [f64; 3]); 8] = [
        ([0.0, 0.0, 100.0], [0.0, 0.0, 0.0]),
        ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        ([120.0, 0.0, 0.0], [0.0, 0.2, 0.0]),
        ([120.0, 60.0, 0.0], [0.0, 0.2, 0.5]),
        ([0.0, 60.0, 0.0], [0.0, 0.0, 0.5]),
        ([0.0, 60.0, 40.0], [0.1, 0.0, 0.5]),
        ([-30.0, 60.0, 90.0], [0.1, 0.0, 0.0]),
        ([-30.0, 0.0, 150.0], [0.0, 0.0, 0.0]),
    ];
    let turn = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
    local
        .iter()
        .map(|(p, rpy)| {
            let v = turn * nalgebra::Vector3::new(p[0], p[1], p[2]);
            let q = turn * UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]);
            json!({
                "x": v.x + origin[0], "y": v.y + origin[1], "z": v.z + origin[2],
                "qw": q.w, "qx": q.i, "qy": q.j, "qz": q.k
            })
        })
        .collect()
}

/// A pose as the API writes it (`{x, y, z, qw, qx, qy, qz}`), as the engine's type.
/// Runs `cases` cases of `strategy` (no failure file; proptest shrinks a failing one), each
/// with its number: `case(n, value)` panics on a failure.
pub fn each_case<S: proptest::strategy::Strategy>(
    cases: u32,
    strategy: S,
    case: impl Fn(usize, S::Value),
) {
    let n = std::sync::atomic::AtomicUsize::new(0);
    let mut runner = proptest::test_runner::TestRunner::new(proptest::test_runner::Config {
        cases,
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    });
    let result = runner.run(&strategy, |value| {
        case(n.fetch_add(1, std::sync::atomic::Ordering::Relaxed), value);
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// A pose (JSON) moved by `by` (mm).
pub fn moved(p: &Value, by: [f64; 3]) -> Value {
    let mut q = p.clone();
    for (k, d) in ["x", "y", "z"].into_iter().zip(by) {
        q[k] = json!(q[k].as_f64().expect("coordinate") + d);
    }
    q
}

pub fn pose_of(v: &Value) -> nextpose::engine::Pose {
    let f = |k: &str| v[k].as_f64().expect(k);
    nextpose::engine::Pose::new(
        [f("x"), f("y"), f("z")],
        [f("qw"), f("qx"), f("qy"), f("qz")],
    )
    .expect("pose")
}

pub fn distance(a: &Value, b: &Value) -> f64 {
    let d = |k: &str| a[k].as_f64().expect(k) - b[k].as_f64().expect(k);
    (d("x").powi(2) + d("y").powi(2) + d("z").powi(2)).sqrt()
}

/// The value of a sample line of `/metrics` (`name{labels} value`), if present.
pub fn sample(metrics: &str, name_and_labels: &str) -> Option<f64> {
    metrics.lines().find_map(|l| {
        l.strip_prefix(name_and_labels)
            .and_then(|rest| rest.strip_prefix(' '))
            .and_then(|v| v.trim().parse().ok())
    })
}
