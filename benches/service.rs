//! Load benchmark of the service: append waypoint → prediction, 64 concurrent clients on one
//! cell whose model has ~2,000 states, over real HTTP on loopback against a temporary SQLite
//! file. Prints throughput and latency percentiles.
//!
//! `cargo bench --bench service` (release profile). Environment: `CLIENTS` (64), `REQUESTS`
//! (20000), `STATES` (2000). Client and server share the machine, so on 2 cores the figures
//! include the client's own cost.

use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::UnitQuaternion;
use nextpose::server::{Application, Database, ServerSettings};
use nextpose::storage::Durability;
use nextpose::transport::TransportOptions;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde_json::{Value, json};

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn pose(p: [f64; 3], yaw: f64) -> Value {
    let q = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
    json!({"pose": {"x": p[0], "y": p[1], "z": p[2], "qw": q.w, "qx": q.i, "qy": q.j, "qz": q.k}})
}

async fn post(client: &reqwest::Client, url: &str, body: &Value) -> Value {
    let r = client.post(url).json(body).send().await.expect("request");
    assert!(r.status().is_success(), "{}", r.status());
    r.json().await.expect("json")
}

#[tokio::main(flavor = "current_thread")]
async fn main() {
    let clients = env("CLIENTS", 64);
    let requests = env("REQUESTS", 20_000);
    let target_states = env("STATES", 2_000);

    // The server runs on its own runtime (as it would in its own process); the clients on this
    // one.
    let dir = tempfile::tempdir().expect("temp dir");
    let db = dir.path().join("load.db");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_multi_thread()
            .enable_all()
            .build()
            .expect("server runtime");
        rt.block_on(async move {
            let app = Application::build(ServerSettings {
                database: Database::File(db),
                durability: Durability::Process,
                addr: "127.0.0.1:0".into(),
                http: TransportOptions::default(),
                robots: None,
                backup_dir: None,
            })
            .await
            .expect("server");
            tx.send(app.local_addr().expect("addr")).expect("send");
            app.run_until_stopped(std::future::pending())
                .await
                .expect("serve");
        });
    });
    let base = format!("http://{}", rx.recv().expect("server address"));
    let client = reqwest::Client::builder()
        .pool_max_idle_per_host(clients)
        .build()
        .expect("client");

    // Seed: routines of random moves until the model has ~target_states states.
    // Reachability is checked as usual; `flag` offers unreachable predictions marked, so the
    // synthetic poses (near the base of the default arm) still exercise the whole path.
    let cell = post(
        &client,
        &format!("{base}/v1/cells"),
        &json!({"name": "load", "settings": {"reach_policy": "flag"}}),
    )
    .await;
    let cell = cell["id"].as_i64().expect("id");
    let program = post(
        &client,
        &format!("{base}/v1/cells/{cell}/programs"),
        &json!({"name": "seed"}),
    )
    .await["id"]
        .as_i64()
        .expect("id");
    let mut rng = StdRng::seed_from_u64(7);
    let mut states = 0;
    let filling = Instant::now();
    while states < target_states {
        let routine = post(
            &client,
            &format!("{base}/v1/programs/{program}/routines"),
            &json!({}),
        )
        .await["id"]
            .as_i64()
            .expect("id");
        let mut p = [0.0f64; 3];
        for _ in 0..50 {
            for v in &mut p {
                *v += rng.random_range(-100.0..100.0);
            }
            let yaw = rng.random_range(-3.0..3.0);
            post(
                &client,
                &format!("{base}/v1/routines/{routine}/waypoints"),
                &pose(p, yaw),
            )
            .await;
        }
        let finished = post(
            &client,
            &format!("{base}/v1/routines/{routine}/finish"),
            &json!({}),
        )
        .await;
        states = finished["model"]["states"].as_u64().expect("states") as usize;
    }
    println!(
        "filled the model with {states} states in {:.1} s",
        filling.elapsed().as_secs_f64()
    );

    // Load: one open routine, 64 clients appending a repeating stitch pattern to it.
    let routine = post(
        &client,
        &format!("{base}/v1/programs/{program}/routines"),
        &json!({}),
    )
    .await["id"]
        .as_i64()
        .expect("id");
    let url = Arc::new(format!("{base}/v1/routines/{routine}/waypoints"));
    let per_client = requests.div_ceil(clients);
    let start = Instant::now();
    let mut tasks = Vec::new();
    for c in 0..clients {
        let client = client.clone();
        let url = url.clone();
        tasks.push(tokio::spawn(async move {
            let mut latencies = Vec::with_capacity(per_client);
            let mut offered = 0usize;
            for i in 0..per_client {
                let k = (c * per_client + i) as f64;
                let body = pose(
                    [(k / 3.0).floor() * 50.0, 10.0 * (k % 3.0), 0.0],
                    0.1 * (k % 3.0),
                );
                let t = Instant::now();
                let v = post(&client, &url, &body).await;
                latencies.push(t.elapsed());
                offered += usize::from(v["prediction"]["offered"] == true);
            }
            (latencies, offered)
        }));
    }
    let mut all: Vec<Duration> = Vec::with_capacity(requests);
    let mut offered = 0;
    for t in tasks {
        let (l, o) = t.await.expect("task");
        all.extend(l);
        offered += o;
    }
    let elapsed = start.elapsed();
    all.sort();
    let pct = |p: f64| all[((all.len() as f64 * p) as usize).min(all.len() - 1)];
    let stats = client
        .get(format!("{base}/v1/cells/{cell}/stats"))
        .send()
        .await
        .expect("stats")
        .json::<Value>()
        .await
        .expect("json");
    println!(
        "{} appends by {clients} clients in {:.2} s: {:.0} requests/s; latency p50 {:.2} ms, \
         p90 {:.2} ms, p99 {:.2} ms, max {:.2} ms; {offered} predictions offered; model now {} states",
        all.len(),
        elapsed.as_secs_f64(),
        all.len() as f64 / elapsed.as_secs_f64(),
        pct(0.50).as_secs_f64() * 1e3,
        pct(0.90).as_secs_f64() * 1e3,
        pct(0.99).as_secs_f64() * 1e3,
        all[all.len() - 1].as_secs_f64() * 1e3,
        stats["model"]["states"],
    );
}
