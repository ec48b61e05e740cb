//! Throughput of the gRPC `Teach` stream: predictions per second over one session, against
//! the real server on loopback with a temporary SQLite file (`synchronous = NORMAL`).
//!
//! One cell; each routine is an 8-waypoint seam (moved and turned), created by a unary call
//! and taught through the stream (`start`, 8 × `waypoint`, `finish`). Two ways of driving it:
//! - pipelined: the routine's 10 commands are sent without waiting, then the 10 events read
//!   (the stream's throughput; back-pressure keeps at most `TEACH_BUFFER` answers in flight);
//! - lock-step: each command waits for its answer (a pendant's pace; round-trip bound).
//!
//! For comparison, the same lock-step loop over REST (one keep-alive connection).
//!
//! `cargo bench --bench teach_stream`. Environment: `ROUTINES` (200 per mode).

use std::time::Instant;

use nalgebra::{UnitQuaternion, Vector3};
use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use nextpose::grpc::pb::teach_request::Command;
use nextpose::grpc::pb::teach_response::Event;
use nextpose::server::{Application, Database, ServerSettings};
use nextpose::storage::Durability;
use nextpose::transport::TransportOptions;
use serde_json::json;
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::transport::Channel;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// The i-th copy of a U-shaped seam with approach and retract.
fn seam(i: usize) -> Vec<pb::Pose> {
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
    let yaw = (i % 13) as f64 * 0.37;
    let origin = [
        (i % 7) as f64 * 40.0 - 120.0,
        (i % 5) as f64 * 50.0 - 100.0,
        (i % 3) as f64 * 30.0,
    ];
    let turn = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
    local
        .iter()
        .map(|(p, rpy)| {
            let v = turn * Vector3::new(p[0], p[1], p[2]);
            let q = turn * UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]);
            pb::Pose {
                x: v.x + origin[0],
                y: v.y + origin[1],
                z: v.z + origin[2],
                qw: q.w,
                qx: q.i,
                qy: q.j,
                qz: q.k,
            }
        })
        .collect()
}

struct Session {
    tx: mpsc::Sender<pb::TeachRequest>,
    rx: tonic::Streaming<pb::TeachResponse>,
}

impl Session {
    async fn send(&self, command: Command) {
        let request = pb::TeachRequest {
            tag: 0,
            command: Some(command),
        };
        self.tx.send(request).await.expect("send");
    }

    async fn next(&mut self) -> Event {
        let r = self.rx.message().await.expect("stream").expect("event");
        match r.event.expect("event") {
            Event::Error(e) => panic!("teach error: {e:?}"),
            e => e,
        }
    }
}

/// Teaches `routines` seams through one session; returns (predictions, offered, seconds).
async fn teach(
    client: &mut NextposeClient<Channel>,
    program: i64,
    first: usize,
    routines: usize,
    pipelined: bool,
) -> (usize, usize, f64) {
    let (tx, rx) = mpsc::channel(64);
    let stream = client
        .teach(ReceiverStream::new(rx))
        .await
        .expect("teach")
        .into_inner();
    let mut s = Session { tx, rx: stream };
    let (mut predictions, mut offered) = (0, 0);
    let start = Instant::now();
    for i in first..first + routines {
        let routine = client
            .create_routine(pb::CreateRoutineRequest {
                program_id: program,
                name: None,
            })
            .await
            .expect("routine")
            .into_inner();
        let mut commands = vec![Command::Start(pb::StartCommand {
            routine_id: routine.id,
        })];
        commands.extend(seam(i).into_iter().map(|p| {
            Command::Waypoint(pb::NewWaypoint {
                pose: Some(p),
                ..Default::default()
            })
        }));
        commands.push(Command::Finish(pb::FinishCommand {}));
        let mut events = Vec::new();
        if pipelined {
            let n = commands.len();
            for c in commands {
                s.send(c).await;
            }
            for _ in 0..n {
                events.push(s.next().await);
            }
        } else {
            for c in commands {
                s.send(c).await;
                events.push(s.next().await);
            }
        }
        for e in events {
            if let Event::Taught(t) = e {
                predictions += 1;
                offered += usize::from(t.prediction.expect("prediction").offered);
            }
        }
    }
    (predictions, offered, start.elapsed().as_secs_f64())
}

/// The same lock-step loop over REST.
async fn rest(base: &str, program: i64, first: usize, routines: usize) -> (usize, f64) {
    let client = reqwest::Client::new();
    let post = |url: String, body: serde_json::Value| {
        let client = client.clone();
        async move {
            let r = client.post(url).json(&body).send().await.expect("request");
            assert!(r.status().is_success(), "{}", r.status());
            r.json::<serde_json::Value>().await.expect("json")
        }
    };
    let mut predictions = 0;
    let start = Instant::now();
    for i in first..first + routines {
        let routine = post(format!("{base}/v1/programs/{program}/routines"), json!({})).await["id"]
            .as_i64()
            .expect("id");
        for p in seam(i) {
            let pose = json!({"x": p.x, "y": p.y, "z": p.z, "qw": p.qw, "qx": p.qx, "qy": p.qy, "qz": p.qz});
            post(
                format!("{base}/v1/routines/{routine}/waypoints"),
                json!({ "pose": pose }),
            )
            .await;
            predictions += 1;
        }
        post(format!("{base}/v1/routines/{routine}/finish"), json!({})).await;
    }
    (predictions, start.elapsed().as_secs_f64())
}

#[tokio::main]
async fn main() {
    let routines = env("ROUTINES", 200);
    let dir = tempfile::tempdir().expect("temp dir");
    let app = Application::build(ServerSettings {
        database: Database::File(dir.path().join("teach.db")),
        durability: Durability::Process,
        addr: "127.0.0.1:0".into(),
        http: TransportOptions::default(),
        robots: None,
        backup_dir: None,
    })
    .await
    .expect("server");
    let base = format!("http://{}", app.local_addr().expect("addr"));
    tokio::spawn(app.run_until_stopped(std::future::pending()));
    let channel = Channel::from_shared(base.clone())
        .expect("uri")
        .connect()
        .await
        .expect("connect");
    let mut client = NextposeClient::new(channel);

    let cell = client
        .create_cell(pb::CreateCellRequest {
            name: "bench".into(),
            settings: Some(pb::CellSettingsInput {
                reach_policy: pb::ReachPolicy::Flag.into(),
                ..Default::default()
            }),
        })
        .await
        .expect("cell")
        .into_inner();
    let program = client
        .create_program(pb::CreateProgramRequest {
            cell_id: cell.id,
            name: "seams".into(),
        })
        .await
        .expect("program")
        .into_inner()
        .id;

    // Warm-up: a few routines so the model has something to predict from.
    teach(&mut client, program, 0, 5, false).await;
    println!("Teach stream, {routines} routines × 8 waypoints per mode, one session each");
    let mut next = 5;
    for (label, pipelined) in [("pipelined", true), ("lock-step", false)] {
        let (n, offered, secs) = teach(&mut client, program, next, routines, pipelined).await;
        next += routines;
        println!(
            "  gRPC Teach {label:<10} {n:>6} predictions ({offered} offered) in {secs:>6.2} s = {:>7.0} predictions/s",
            n as f64 / secs
        );
    }
    let (n, secs) = rest(&base, program, next, routines).await;
    println!(
        "  REST       lock-step  {n:>6} predictions in {secs:>6.2} s = {:>7.0} predictions/s",
        n as f64 / secs
    );
}
