//! The gRPC adapter through a real tonic client against the real server on its loopback port
//! (the same port as REST): unary calls for every resource, `Teach` sessions (same predictions
//! as the REST loop, cancellation), import and replay (same results as REST), error mapping,
//! metrics and request ids, token, health and reflection.

use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use nextpose::grpc::pb::teach_request::Command;
use nextpose::grpc::pb::teach_response::Event;
use nextpose::transport::TransportOptions;
use reqwest::StatusCode;
use serde_json::{Value, json};
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::transport::Channel;
use tonic::{Code, Streaming};

use crate::helpers::*;
use crate::import::upload;

type Client = NextposeClient<Channel>;

async fn channel(app: &TestApp) -> Channel {
    Channel::from_shared(app.base.clone())
        .expect("uri")
        .connect()
        .await
        .expect("connect")
}

async fn client(app: &TestApp) -> Client {
    NextposeClient::new(channel(app).await)
}

pub(crate) fn pb_pose(v: &Value) -> pb::Pose {
    let f = |k: &str| v[k].as_f64().expect(k);
    pb::Pose {
        x: f("x"),
        y: f("y"),
        z: f("z"),
        qw: f("qw"),
        qx: f("qx"),
        qy: f("qy"),
        qz: f("qz"),
    }
}

fn waypoint(v: &Value) -> pb::NewWaypoint {
    pb::NewWaypoint {
        pose: Some(pb_pose(v)),
        ..Default::default()
    }
}

/// A cell offering predictions its arm cannot reach, flagged (as `TestApp::create_cell`).
async fn create_cell(c: &mut Client, name: &str) -> pb::Cell {
    c.create_cell(pb::CreateCellRequest {
        name: name.into(),
        settings: Some(pb::CellSettingsInput {
            reach_policy: pb::ReachPolicy::Flag.into(),
            ..Default::default()
        }),
    })
    .await
    .expect("create cell")
    .into_inner()
}

/// An open teach session: commands go in, one event comes back per command.
struct Teach {
    tx: mpsc::Sender<pb::TeachRequest>,
    rx: Streaming<pb::TeachResponse>,
    tag: u64,
}

impl Teach {
    async fn open(c: &mut Client) -> Teach {
        let (tx, rx) = mpsc::channel(16);
        let stream = c
            .teach(ReceiverStream::new(rx))
            .await
            .expect("teach")
            .into_inner();
        Teach {
            tx,
            rx: stream,
            tag: 0,
        }
    }

    async fn send(&mut self, command: Command) -> u64 {
        self.tag += 1;
        self.tx
            .send(pb::TeachRequest {
                tag: self.tag,
                command: Some(command),
            })
            .await
            .expect("send");
        self.tag
    }

    async fn next(&mut self) -> (u64, Event) {
        let r = self
            .rx
            .message()
            .await
            .expect("stream ok")
            .expect("an event");
        (r.tag, r.event.expect("event set"))
    }

    async fn call(&mut self, command: Command) -> Event {
        let tag = self.send(command).await;
        let (got, event) = self.next().await;
        assert_eq!(got, tag);
        event
    }

    async fn start(&mut self, routine_id: i64) -> pb::Routine {
        match self
            .call(Command::Start(pb::StartCommand { routine_id }))
            .await
        {
            Event::Started(s) => s.routine.expect("routine"),
            other => panic!("expected started, got {other:?}"),
        }
    }

    async fn waypoint(&mut self, pose: &Value) -> pb::Taught {
        match self.call(Command::Waypoint(waypoint(pose))).await {
            Event::Taught(t) => t,
            other => panic!("expected taught, got {other:?}"),
        }
    }

    async fn finish(&mut self) -> pb::Finished {
        match self.call(Command::Finish(pb::FinishCommand {})).await {
            Event::Finished(f) => f,
            other => panic!("expected finished, got {other:?}"),
        }
    }
}

#[tokio::test]
async fn unary_calls_cover_every_resource() {
    let app = spawn_app().await;
    let mut c = client(&app).await;

    // Cells.
    let cell = create_cell(&mut c, "grpc-cell").await;
    let settings = cell.settings.as_ref().expect("settings");
    assert_eq!(settings.robot, "abb_irb140");
    assert_eq!(settings.reach_policy(), pb::ReachPolicy::Flag);
    assert_eq!(settings.profile(), pb::Profile::Default);
    let cells = c
        .list_cells(pb::ListCellsRequest {})
        .await
        .unwrap()
        .into_inner();
    assert_eq!(cells.cells.len(), 1);
    let got = c
        .get_cell(pb::GetCellRequest { cell_id: cell.id })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(got, cell);
    // The same cell through REST.
    let rest = app.get_ok(&format!("/v1/cells/{}", cell.id)).await;
    assert_eq!(rest["name"], "grpc-cell");
    assert_eq!(rest["settings"]["delta"].as_f64(), Some(settings.delta));

    // Programs.
    let program = c
        .create_program(pb::CreateProgramRequest {
            cell_id: cell.id,
            name: "bracket".into(),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(program.cell_id, cell.id);
    let programs = c
        .list_programs(pb::ListProgramsRequest { cell_id: cell.id })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(programs.programs, vec![program.clone()]);
    let got = c
        .get_program(pb::GetProgramRequest {
            program_id: program.id,
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(got, program);

    // Routines and teaching: two copies of a seam, the second one predicted.
    let mut offered_id = None;
    for (i, seam) in [
        u_seam([0.0, 0.0, 0.0], 0.0),
        u_seam([300.0, -200.0, 20.0], 0.7),
    ]
    .iter()
    .enumerate()
    {
        let routine = c
            .create_routine(pb::CreateRoutineRequest {
                program_id: program.id,
                name: Some(format!("pass {}", i + 1)),
            })
            .await
            .unwrap()
            .into_inner();
        assert!(!routine.finished);
        assert_eq!(routine.position, i as i64 + 1);
        for (j, p) in seam.iter().enumerate() {
            let taught = c
                .append_waypoint(pb::AppendWaypointRequest {
                    routine_id: routine.id,
                    waypoint: Some(pb::NewWaypoint {
                        pose: Some(pb_pose(p)),
                        joints: vec![],
                        motion: pb::Motion::Linear.into(),
                        name: Some(format!("p{j}")),
                    }),
                })
                .await
                .unwrap()
                .into_inner();
            let w = taught.waypoint.unwrap();
            assert_eq!(w.seq, j as i64 + 1);
            assert_eq!(w.motion(), pb::Motion::Linear);
            let prediction = taught.prediction.unwrap();
            if prediction.offered {
                offered_id = offered_id.or(prediction.id);
                assert!(prediction.pose.is_some());
                assert!(prediction.reachability.is_some());
            } else {
                assert!(!prediction.withheld.unwrap().reason.is_empty());
            }
        }
        // Predict with an open-loop completion, then undo and re-teach the last waypoint.
        let set = c
            .predict(pb::PredictRequest {
                routine_id: routine.id,
                k: Some(3),
                ..Default::default()
            })
            .await
            .unwrap()
            .into_inner();
        assert_eq!(set.routine_id, routine.id);
        assert!(!set.predictions.is_empty());
        let undone = c
            .undo(pb::UndoRequest {
                routine_id: routine.id,
            })
            .await
            .unwrap()
            .into_inner();
        assert_eq!(undone.removed.unwrap().seq, seam.len() as i64);
        c.append_waypoint(pb::AppendWaypointRequest {
            routine_id: routine.id,
            waypoint: Some(waypoint(seam.last().unwrap())),
        })
        .await
        .unwrap();
        let detail = c
            .get_routine(pb::GetRoutineRequest {
                routine_id: routine.id,
            })
            .await
            .unwrap()
            .into_inner();
        assert_eq!(detail.waypoints.len(), seam.len());
        assert_eq!(detail.routine.unwrap().waypoint_count, seam.len() as i64);
        let finished = c
            .finish_routine(pb::FinishRoutineRequest {
                routine_id: routine.id,
            })
            .await
            .unwrap()
            .into_inner();
        assert!(finished.routine.unwrap().finished);
        assert_eq!(finished.model.unwrap().version, i as i64 + 1);
    }
    let routines = c
        .list_routines(pb::ListRoutinesRequest {
            program_id: program.id,
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(routines.routines.len(), 2);
    assert_eq!(routines.routines[1].finish_seq, Some(2));

    // Feedback on an offered prediction; the stats count it.
    let id = offered_id.expect("the second pass offers predictions");
    let recorded = c
        .feedback(pb::FeedbackRequest {
            prediction_id: id,
            verdict: pb::Verdict::Accepted.into(),
            pose: None,
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(recorded.verdict(), pb::Verdict::Accepted);
    assert_eq!(recorded.adjustment_mm, Some(0.0));
    let stats = c
        .get_cell_stats(pb::GetCellStatsRequest { cell_id: cell.id })
        .await
        .unwrap()
        .into_inner();
    let model = stats.model.unwrap();
    assert_eq!(model.routines, 2);
    assert_eq!(stats.feedback.unwrap().accepted, 1);
    let rebuilt = c
        .rebuild_model(pb::RebuildModelRequest { cell_id: cell.id })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(rebuilt, model);

    // Delete an open routine.
    let routine = c
        .create_routine(pb::CreateRoutineRequest {
            program_id: program.id,
            name: None,
        })
        .await
        .unwrap()
        .into_inner();
    c.delete_routine(pb::DeleteRoutineRequest {
        routine_id: routine.id,
    })
    .await
    .unwrap();
    let gone = c
        .get_routine(pb::GetRoutineRequest {
            routine_id: routine.id,
        })
        .await
        .unwrap_err();
    assert_eq!(gone.code(), Code::NotFound);

    // Robots.
    let robots = c
        .list_robots(pb::ListRobotsRequest {})
        .await
        .unwrap()
        .into_inner();
    assert!(robots.robots.iter().any(|r| r.name == "abb_irb140"));
    let robot = c
        .get_robot(pb::GetRobotRequest {
            name: "abb_irb140".into(),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(robot.joints.len(), 6);
    assert_eq!(robot.solver, "opw");
}

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
}

/// Compares a REST prediction (JSON) with a gRPC one.
fn assert_same_prediction(rest: &Value, grpc: &pb::Prediction, at: &str) {
    assert_eq!(
        rest["offered"].as_bool(),
        Some(grpc.offered),
        "{at}: offered"
    );
    assert_eq!(
        rest["withheld"]["reason"].as_str(),
        grpc.withheld.as_ref().map(|w| w.reason.as_str()),
        "{at}: withheld reason"
    );
    assert!(same(rest["phi"].as_f64().unwrap(), grpc.phi), "{at}: phi");
    assert_eq!(rest["after_waypoints"].as_i64(), Some(grpc.after_waypoints));
    assert_eq!(rest["model_version"].as_i64(), Some(grpc.model_version));
    match (&rest["pose"], &grpc.pose) {
        (Value::Null, None) => {}
        (r, Some(g)) => {
            for (k, v) in [
                ("x", g.x),
                ("y", g.y),
                ("z", g.z),
                ("qw", g.qw),
                ("qx", g.qx),
                ("qy", g.qy),
                ("qz", g.qz),
            ] {
                assert!(same(r[k].as_f64().unwrap(), v), "{at}: pose.{k}");
            }
        }
        (r, g) => panic!("{at}: pose {r} vs {g:?}"),
    }
}

#[tokio::test]
async fn a_teach_stream_predicts_what_the_rest_loop_predicts() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let routines = [
        u_seam([0.0, 0.0, 0.0], 0.0),
        u_seam([800.0, -300.0, 50.0], 1.0),
        u_seam([-200.0, 400.0, 0.0], -0.6),
        u_seam([100.0, 100.0, 300.0], 2.2),
    ];

    // Cell A through REST.
    let rest_cell = app.create_cell("rest").await;
    let rest_program = app.create_program(rest_cell, "p").await;
    let mut rest = Vec::new();
    for r in &routines {
        rest.push(app.teach_routine(rest_program, r).await.1);
    }

    // Cell B through one Teach session.
    let cell = create_cell(&mut c, "grpc").await;
    let program = app.create_program(cell.id, "p").await;
    let mut session = Teach::open(&mut c).await;
    let mut offered = 0;
    for (i, r) in routines.iter().enumerate() {
        let routine = app.create_routine(program).await;
        let started = session.start(routine).await;
        assert_eq!(started.id, routine);
        assert_eq!(started.waypoint_count, 0);
        for (j, p) in r.iter().enumerate() {
            let taught = session.waypoint(p).await;
            assert_eq!(taught.waypoint.unwrap().seq, j as i64 + 1);
            let prediction = taught.prediction.unwrap();
            offered += usize::from(prediction.offered);
            assert_same_prediction(&rest[i][j], &prediction, &format!("routine {i} wp {j}"));
        }
        let finished = session.finish().await;
        assert_eq!(finished.model.unwrap().version, i as i64 + 1);
    }
    assert!(offered >= 8, "only {offered} predictions offered");
    drop(session);

    // Both cells learned the same model.
    let a = app.get_ok(&format!("/v1/cells/{rest_cell}/stats")).await;
    let b = app.get_ok(&format!("/v1/cells/{}/stats", cell.id)).await;
    assert_eq!(a["model"], b["model"]);
}

#[tokio::test]
async fn a_dropped_teach_stream_leaves_the_routine_open_and_consistent() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let cell = app.create_cell("drop").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let seam = u_seam([500.0, 0.0, 0.0], 0.3);
    let routine = app.create_routine(program).await;

    let mut session = Teach::open(&mut c).await;
    session.start(routine).await;
    for p in &seam[..3] {
        session.waypoint(p).await;
    }
    // Two more commands go out, then the client disappears without reading the answers.
    session.send(Command::Waypoint(waypoint(&seam[3]))).await;
    session.send(Command::Waypoint(waypoint(&seam[4]))).await;
    drop(session);
    // The server's session task has applied its last command once it stops counting itself.
    app.wait_for_metric("nextpose_grpc_teach_sessions", 0.0)
        .await;

    // The routine is still open, with the waypoints sent before the drop (the three answered
    // and whichever of the two in flight the server had applied), numbered without gaps.
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["finished"], false);
    let waypoints = detail["waypoints"].as_array().unwrap();
    let n = waypoints.len();
    assert!((3..=5).contains(&n), "{n} waypoints");
    assert_eq!(detail["waypoint_count"], n as i64);
    for (i, w) in waypoints.iter().enumerate() {
        assert_eq!(w["seq"], i as i64 + 1);
        assert!(distance(&w["pose"], &seam[i]) < 1e-9);
    }

    // Teaching goes on through REST, and through a new session.
    let next = app.append(routine, &seam[n]).await;
    assert_eq!(next["waypoint"]["seq"], n as i64 + 1);
    let mut session = Teach::open(&mut c).await;
    let started = session.start(routine).await;
    assert_eq!(started.waypoint_count, n as i64 + 1);
    let taught = session.waypoint(&seam[n + 1]).await;
    assert_eq!(taught.waypoint.unwrap().seq, n as i64 + 2);
    let finished = session.finish().await;
    assert_eq!(finished.routine.unwrap().waypoint_count, n as i64 + 2);
}

#[tokio::test]
async fn errors_map_to_status_codes() {
    let app = spawn_app().await;
    let mut c = client(&app).await;

    // NOT_FOUND, with the service's error code in metadata.
    let e = c
        .get_cell(pb::GetCellRequest { cell_id: 999 })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::NotFound, "{e:?}");
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "not_found");
    let e = c
        .get_robot(pb::GetRobotRequest {
            name: "nope".into(),
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::NotFound);

    // INVALID_ARGUMENT: an empty name, a quaternion far from unit, a missing pose.
    let e = c
        .create_cell(pb::CreateCellRequest {
            name: " ".into(),
            settings: None,
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument);
    let cell = create_cell(&mut c, "errors").await;
    let program = app.create_program(cell.id, "p").await;
    let routine = app.create_routine(program).await;
    let mut bad = pb_pose(&pose([0.0; 3], [0.0; 3]));
    bad.qw = 2.0;
    let e = c
        .append_waypoint(pb::AppendWaypointRequest {
            routine_id: routine,
            waypoint: Some(pb::NewWaypoint {
                pose: Some(bad),
                ..Default::default()
            }),
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument);
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "invalid_pose");
    let e = c
        .append_waypoint(pb::AppendWaypointRequest {
            routine_id: routine,
            waypoint: None,
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument);

    // FAILED_PRECONDITION: a second open routine, undo with nothing taught, a finished routine.
    let e = c
        .create_routine(pb::CreateRoutineRequest {
            program_id: program,
            name: None,
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::FailedPrecondition);
    let e = c
        .undo(pb::UndoRequest {
            routine_id: routine,
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::FailedPrecondition);
    app.append(routine, &pose([0.0; 3], [0.0; 3])).await;
    app.finish(routine).await;
    let e = c
        .append_waypoint(pb::AppendWaypointRequest {
            routine_id: routine,
            waypoint: Some(waypoint(&pose([1.0, 0.0, 0.0], [0.0; 3]))),
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::FailedPrecondition);
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "conflict");

    // ALREADY_EXISTS: a name taken (REST: 409 `conflict`, like the state conflicts above).
    let e = c
        .create_program(pb::CreateProgramRequest {
            cell_id: cell.id,
            name: "p".into(),
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::AlreadyExists, "{e:?}");
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "conflict");
    let e = c
        .create_cell(pb::CreateCellRequest {
            name: "errors".into(),
            settings: None,
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::AlreadyExists, "{e:?}");
    let r = app.post("/v1/cells", &json!({"name": "errors"})).await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;

    // In a Teach session an error answers its command and the session goes on.
    let routine = app.create_routine(program).await;
    let mut session = Teach::open(&mut c).await;
    let error = |e: Event| match e {
        Event::Error(e) => e,
        other => panic!("expected an error, got {other:?}"),
    };
    let e = error(session.call(Command::Undo(pb::UndoCommand {})).await);
    assert_eq!(e.code, Code::FailedPrecondition as i32);
    assert_eq!(e.reason, "no_routine");
    let e = error(
        session
            .call(Command::Start(pb::StartCommand { routine_id: 12345 }))
            .await,
    );
    assert_eq!(e.code, Code::NotFound as i32);
    assert_eq!(e.reason, "not_found");
    session.start(routine).await;
    let mut far = pb::NewWaypoint {
        pose: Some(bad),
        ..Default::default()
    };
    let e = error(session.call(Command::Waypoint(far.clone())).await);
    assert_eq!(e.code, Code::InvalidArgument as i32);
    assert_eq!(e.reason, "invalid_pose");
    far.pose = None;
    let e = error(session.call(Command::Waypoint(far)).await);
    assert_eq!(e.code, Code::InvalidArgument as i32);
    let e = error(session.call(Command::Undo(pb::UndoCommand {})).await);
    assert_eq!(e.code, Code::FailedPrecondition as i32);
    assert_eq!(e.reason, "conflict");
    let taught = session.waypoint(&pose([0.0; 3], [0.0; 3])).await;
    assert_eq!(taught.waypoint.unwrap().seq, 1);
    session.finish().await;
    let e = error(
        session
            .call(Command::Start(pb::StartCommand {
                routine_id: routine,
            }))
            .await,
    );
    assert_eq!(e.code, Code::FailedPrecondition as i32);
}

#[tokio::test]
async fn the_bearer_token_applies_to_grpc_metadata() {
    let app = spawn_with(TransportOptions {
        token: Some("s3cret".into()),
        ..TransportOptions::default()
    })
    .await;
    let ch = channel(&app).await;

    let mut anonymous = NextposeClient::new(ch.clone());
    let e = anonymous
        .list_cells(pb::ListCellsRequest {})
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::Unauthenticated, "{e:?}");
    let e = anonymous
        .teach(tokio_stream::empty())
        .await
        .map(|_| ())
        .unwrap_err();
    assert_eq!(e.code(), Code::Unauthenticated);

    let mut wrong = NextposeClient::with_interceptor(ch.clone(), |mut r: tonic::Request<()>| {
        r.metadata_mut()
            .insert("authorization", "Bearer nope".parse().unwrap());
        Ok(r)
    });
    let e = wrong.list_cells(pb::ListCellsRequest {}).await.unwrap_err();
    assert_eq!(e.code(), Code::Unauthenticated);

    let mut authorised =
        NextposeClient::with_interceptor(ch.clone(), |mut r: tonic::Request<()>| {
            r.metadata_mut()
                .insert("authorization", "Bearer s3cret".parse().unwrap());
            Ok(r)
        });
    let cells = authorised
        .list_cells(pb::ListCellsRequest {})
        .await
        .unwrap()
        .into_inner();
    assert!(cells.cells.is_empty());
    // The scheme is case-insensitive (RFC 7235), as over REST.
    for scheme in ["bearer", "BEARER"] {
        let value: tonic::metadata::MetadataValue<_> = format!("{scheme} s3cret").parse().unwrap();
        let mut c =
            NextposeClient::with_interceptor(ch.clone(), move |mut r: tonic::Request<()>| {
                r.metadata_mut().insert("authorization", value.clone());
                Ok(r)
            });
        c.list_cells(pb::ListCellsRequest {})
            .await
            .unwrap_or_else(|e| panic!("{scheme}: {e:?}"));
    }

    // Health checks need no token, like /healthz.
    let mut health = tonic_health::pb::health_client::HealthClient::new(ch);
    let status = health
        .check(tonic_health::pb::HealthCheckRequest {
            service: "nextpose.v1.Nextpose".into(),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(
        status.status(),
        tonic_health::pb::health_check_response::ServingStatus::Serving
    );

    // REST is unchanged: JSON errors without the token.
    let mut rest = TestApp::remote(&app.base);
    rest.token = None;
    expect_error(
        rest.get("/v1/cells").await,
        StatusCode::UNAUTHORIZED,
        "unauthorized",
    )
    .await;
}

#[tokio::test]
async fn reflection_lists_the_service() {
    use tonic_reflection::pb::v1::ServerReflectionRequest;
    use tonic_reflection::pb::v1::server_reflection_client::ServerReflectionClient;
    use tonic_reflection::pb::v1::server_reflection_request::MessageRequest;
    use tonic_reflection::pb::v1::server_reflection_response::MessageResponse;

    let app = spawn_app().await;
    let mut c = ServerReflectionClient::new(channel(&app).await);
    let request = ServerReflectionRequest {
        host: String::new(),
        message_request: Some(MessageRequest::ListServices(String::new())),
    };
    let mut stream = c
        .server_reflection_info(tokio_stream::iter([request]))
        .await
        .unwrap()
        .into_inner();
    let response = stream.message().await.unwrap().unwrap();
    let Some(MessageResponse::ListServicesResponse(list)) = response.message_response else {
        panic!("unexpected {response:?}");
    };
    let names: Vec<_> = list.service.iter().map(|s| s.name.as_str()).collect();
    assert!(names.contains(&"nextpose.v1.Nextpose"), "{names:?}");
    // The health service is described too (grpcurl calls it by reflection).
    assert!(names.contains(&"grpc.health.v1.Health"), "{names:?}");

    // A plain REST request on the same port still gets REST.
    let health = app.get_ok("/healthz").await;
    assert_eq!(health["status"], "ok");
}

fn pb_files(files: &[Value]) -> Vec<pb::UploadedFile> {
    files
        .iter()
        .map(|f| pb::UploadedFile {
            name: f["name"].as_str().expect("name").into(),
            content: f["content"].as_str().expect("content").into(),
        })
        .collect()
}

#[tokio::test]
#[cfg_attr(
    not(corpus),
    ignore = "needs the shared corpus (../shared/corpus) beside the checkout"
)]
async fn an_import_through_grpc_teaches_what_the_rest_import_teaches() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let files = upload("ravenorb__abb-robot-welder");

    // Cell A imports through REST, cell B through gRPC.
    let rest_cell = app.create_cell("rest").await;
    let rest = app
        .post_ok(
            &format!("/v1/cells/{rest_cell}/imports"),
            &json!({ "files": files }),
            StatusCode::CREATED,
        )
        .await;
    let cell = create_cell(&mut c, "grpc").await;
    let imported = c
        .import_programs(pb::ImportProgramsRequest {
            cell_id: cell.id,
            files: pb_files(&files),
            learn: None,
        })
        .await
        .expect("import")
        .into_inner();

    // The same programs, skipped items and model.
    let rest_programs = rest["programs"].as_array().unwrap();
    assert_eq!(imported.programs.len(), rest_programs.len());
    for (g, r) in imported.programs.iter().zip(rest_programs) {
        let program = g.program.as_ref().unwrap();
        assert_eq!(program.cell_id, cell.id);
        assert_eq!(r["program"]["name"], program.name.as_str());
        assert_eq!(r["language"], g.language.as_str());
        assert_eq!(r["source"], g.source.as_str());
        assert_eq!(r["routines"], g.routines);
        assert_eq!(r["waypoints"], g.waypoints);
    }
    let rest_skipped = rest["skipped"].as_array().unwrap();
    assert_eq!(imported.skipped.len(), rest_skipped.len());
    for (g, r) in imported.skipped.iter().zip(rest_skipped) {
        assert_eq!(r["file"], g.file.as_str());
        assert_eq!(r["line"], g.line);
        assert_eq!(r["routine"].as_str(), g.routine.as_deref());
        assert_eq!(r["reason"], g.reason.as_str());
        assert_eq!(r["text"], g.text.as_str());
    }
    let model = imported.model.unwrap();
    assert!(model.routines >= 2);
    assert_eq!(rest["model"]["routines"], model.routines);
    assert_eq!(rest["model"]["states"], model.states);
    assert_eq!(rest["model"]["version"], model.version);
    let a = app.get_ok(&format!("/v1/cells/{rest_cell}/stats")).await;
    let b = app.get_ok(&format!("/v1/cells/{}/stats", cell.id)).await;
    assert_eq!(a["model"], b["model"]);

    // The imported routines are immutable and learned, in both adapters' words.
    let program_id = imported.programs[0].program.as_ref().unwrap().id;
    let routines = c
        .list_routines(pb::ListRoutinesRequest { program_id })
        .await
        .unwrap()
        .into_inner()
        .routines;
    let first = &routines[0];
    assert!(first.imported && first.learned && first.finished);
    let rest_first = &app
        .get_ok(&format!("/v1/programs/{program_id}/routines"))
        .await[0];
    assert_eq!(rest_first["imported"], true);
    assert_eq!(rest_first["learned"], true);

    // Teaching an imported routine again: cell B (gRPC) predicts what cell A (REST) predicts.
    let detail = app.get_ok(&format!("/v1/routines/{}", first.id)).await;
    let poses: Vec<Value> = detail["waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["pose"].clone())
        .collect();
    assert!(poses.len() >= 3);
    let rest_program = app.create_program(rest_cell, "retaught").await;
    let (_, rest_predictions) = app.teach_routine(rest_program, &poses).await;
    let program = app.create_program(cell.id, "retaught").await;
    let mut session = Teach::open(&mut c).await;
    session.start(app.create_routine(program).await).await;
    let mut offered = 0;
    for (i, p) in poses.iter().enumerate() {
        let prediction = session.waypoint(p).await.prediction.unwrap();
        offered += usize::from(prediction.offered);
        assert_same_prediction(&rest_predictions[i], &prediction, &format!("wp {i}"));
    }
    assert!(offered >= 1, "nothing offered");
    session.finish().await;

    // The same upload again: the program names are taken, nothing is imported.
    let e = c
        .import_programs(pb::ImportProgramsRequest {
            cell_id: cell.id,
            files: pb_files(&files),
            learn: Some(false),
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::AlreadyExists, "{e:?}");
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "conflict");
}

/// A REST scoreboard line (`totals.<method>`) as the gRPC message carries it; the time per
/// waypoint is measured, so it is left out of comparisons.
fn metrics_json(m: &pb::ReplayMetrics) -> Value {
    json!({
        "predictable": m.predictable, "offered": m.offered, "useful": m.useful,
        "offered_pct": m.offered_pct, "useful_pct": m.useful_pct,
        "precision_pct": m.precision_pct, "saved_pct": m.saved_pct,
        "median_cart_mm": m.median_cart_mm, "median_angle_rad": m.median_angle_rad,
        "median_cart_pct_travel": m.median_cart_pct_travel,
        "median_angle_pct_travel": m.median_angle_pct_travel,
        "spearman_conf_err": m.spearman_conf_err, "pearson_conf_err": m.pearson_conf_err,
        "spearman_phi_err": m.spearman_phi_err,
        "predictable_n1": m.predictable_n1, "offered_n1": m.offered_n1,
        "useful_n1": m.useful_n1, "offered_pct_n1": m.offered_pct_n1,
        "useful_pct_n1": m.useful_pct_n1, "precision_pct_n1": m.precision_pct_n1,
        "saved_pct_n1": m.saved_pct_n1, "median_cart_mm_n1": m.median_cart_mm_n1,
        "median_angle_rad_n1": m.median_angle_rad_n1,
        "spearman_conf_err_n1": m.spearman_conf_err_n1,
        "states": m.states, "edges": m.edges, "perplexity": m.perplexity,
        "reachable_pct": m.reachable_pct, "taught_reachable_pct": m.taught_reachable_pct,
    })
}

/// The same fields, the same integers and nulls, and the same real numbers up to the last
/// digit or two (serde_json's default parser does not round-trip every double).
fn assert_same_figures(rest: &Value, grpc: &Value, at: &str) {
    let (r, g) = (rest.as_object().unwrap(), grpc.as_object().unwrap());
    assert_eq!(
        r.keys().collect::<Vec<_>>(),
        g.keys().collect::<Vec<_>>(),
        "{at}"
    );
    for (k, rv) in r {
        let gv = &g[k];
        match (rv.as_f64(), gv.as_f64()) {
            (Some(a), Some(b)) if !(rv.is_u64() && gv.is_u64()) => {
                assert!(
                    (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs())),
                    "{at}: {k}: {a} vs {b}"
                )
            }
            _ => assert_eq!(rv, gv, "{at}: {k}"),
        }
    }
}

fn without_timing(v: &Value) -> Value {
    let mut v = v.clone();
    v.as_object_mut()
        .expect("a scoreboard line")
        .remove("us_per_waypoint")
        .expect("us_per_waypoint");
    v
}

/// Asserts that a gRPC scoreboard is the REST one: the same methods (in run order, engine
/// first) with the same figures, in the totals and per program.
fn assert_same_scoreboard(rest: &Value, grpc: &pb::ReplayReport) {
    let same_lines = |rest: &Value, grpc: &[pb::MethodMetrics], at: &str| {
        let rest = rest.as_object().expect("methods");
        let names: Vec<&str> = grpc.iter().map(|m| m.method.as_str()).collect();
        assert_eq!(names, crate::import::scoreboard_methods(), "{at}");
        // (serde_json's map here is sorted by key, not in the order REST wrote it.)
        let mut sorted = names.clone();
        sorted.sort_unstable();
        assert_eq!(
            rest.keys().map(String::as_str).collect::<Vec<_>>(),
            sorted,
            "{at}"
        );
        for m in grpc {
            let line = metrics_json(m.metrics.as_ref().expect("metrics"));
            let rest = without_timing(&rest[&m.method]);
            assert_same_figures(&rest, &line, &format!("{at}: {}", m.method));
        }
    };
    same_lines(&rest["totals"], &grpc.totals, "totals");
    let programs = rest["programs"].as_array().unwrap();
    assert!(!programs.is_empty());
    assert_eq!(programs.len(), grpc.programs.len());
    for (r, g) in programs.iter().zip(&grpc.programs) {
        assert_eq!(r["program"], g.program.as_str());
        assert_eq!(r["language"], g.language.as_str());
        same_lines(&r["methods"], &g.methods, &g.program);
    }
    // The oracle bounds' section and the calibration of p_useful.
    let oracles = grpc.oracles.as_ref().expect("oracles");
    let kinds = rest["oracles"]["kinds"].as_array().unwrap();
    assert_eq!(kinds.len(), oracles.kinds.len());
    for (r, g) in kinds.iter().zip(&oracles.kinds) {
        assert_eq!(r["name"], g.name.as_str());
        assert_eq!(r["covered"], g.covered);
        assert_eq!(r["predictable"], g.predictable);
    }
    assert_eq!(rest["oracles"]["meaning"], oracles.meaning.as_str());
    match rest.get("calibration") {
        None => assert!(grpc.calibration.is_empty()),
        Some(calibration) => {
            let rest = calibration.as_object().unwrap();
            assert_eq!(rest.len(), grpc.calibration.len());
            for c in &grpc.calibration {
                let r = &rest[&c.method];
                let bins: Vec<Value> = c
                    .bins
                    .iter()
                    .map(|b| {
                        json!({
                            "from": b.from, "to": b.to, "candidates": b.candidates,
                            "useful": b.useful, "mean_p_useful": b.mean_p_useful,
                            "observed": b.observed, "gap": b.gap,
                            "within_target": b.within_target,
                        })
                    })
                    .collect();
                let rest_bins = r["bins"].as_array().unwrap();
                assert_eq!(rest_bins.len(), bins.len());
                for (rb, gb) in rest_bins.iter().zip(&bins) {
                    assert_same_figures(rb, gb, &format!("{}: bin", c.method));
                }
                assert_eq!(r["candidates"], c.candidates);
                assert_eq!(r["meets_target"], c.meets_target);
                assert_same_figures(
                    &json!({ "ece": r["ece"], "spearman": r["spearman_p_err"] }),
                    &json!({ "ece": c.ece, "spearman": c.spearman_p_err }),
                    &c.method,
                );
                let curve = r["risk_coverage"].as_array().unwrap();
                assert_eq!(curve.len(), c.risk_coverage.len());
                for (rp, gp) in curve.iter().zip(&c.risk_coverage) {
                    assert_eq!(rp["offered"], gp.offered);
                    assert_eq!(rp["useful"], gp.useful);
                }
                let best = &r["threshold_for_target_precision"]["point"];
                let g = c.threshold_for_target_precision.as_ref();
                assert_eq!(best.is_null(), g.is_none());
                if let Some(g) = g {
                    assert_eq!(best["offered"], g.offered);
                }
            }
        }
    }
    let config = grpc.config.as_ref().unwrap();
    let json: Value = serde_json::from_str(&config.json).unwrap();
    assert_eq!(json, rest["config"]);
    assert_eq!(rest["config"]["profile"], config.profile.as_str());
    assert_eq!(rest["config"]["delta"].as_f64(), Some(config.delta));
    assert_eq!(rest["config"]["horizon"], config.horizon);
}

#[tokio::test]
#[cfg_attr(
    not(corpus),
    ignore = "needs the shared corpus (../shared/corpus) beside the checkout"
)]
async fn a_replay_through_grpc_is_the_rest_replay() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let files = upload("ravenorb__abb-robot-welder");

    // Uploaded files, with settings.
    let rest = app
        .post_ok(
            "/v1/replays",
            &json!({ "files": files, "horizon": 2 }),
            StatusCode::OK,
        )
        .await;
    let grpc = c
        .replay(pb::ReplayRequest {
            files: pb_files(&files),
            horizon: Some(2),
            ..Default::default()
        })
        .await
        .expect("replay")
        .into_inner();
    assert_eq!(grpc.totals[0].method, "engine");
    assert!(grpc.totals[0].metrics.as_ref().unwrap().predictable > 10);
    assert_eq!(grpc.config.as_ref().unwrap().horizon, 2);
    assert_same_scoreboard(&rest, &grpc);

    // A cell's stored programs.
    let cell = app.create_cell("replayed").await;
    app.post_ok(
        &format!("/v1/cells/{cell}/imports"),
        &json!({ "files": files, "learn": false }),
        StatusCode::CREATED,
    )
    .await;
    let rest = app
        .post_ok(
            "/v1/replays",
            &json!({ "cell_id": cell, "profile": "seed" }),
            StatusCode::OK,
        )
        .await;
    let grpc = c
        .replay(pb::ReplayRequest {
            cell_id: Some(cell),
            profile: pb::Profile::Seed.into(),
            ..Default::default()
        })
        .await
        .expect("replay")
        .into_inner();
    assert_eq!(grpc.config.as_ref().unwrap().profile, "seed");
    assert_same_scoreboard(&rest, &grpc);
}

#[tokio::test]
#[cfg_attr(
    not(corpus),
    ignore = "needs the shared corpus (../shared/corpus) beside the checkout"
)]
async fn import_and_replay_errors_map_to_status_codes() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let cell = create_cell(&mut c, "import-errors").await;
    let import = |cell_id: i64, name: &str, content: &str| pb::ImportProgramsRequest {
        cell_id,
        files: vec![pb::UploadedFile {
            name: name.into(),
            content: content.into(),
        }],
        learn: None,
    };

    // A malformed robtarget: INVALID_ARGUMENT naming file, line and column; nothing imported.
    let broken = "MODULE M\n  CONST robtarget p:=[[1,2],[1,0,0,0]];\nENDMODULE";
    let e = c
        .import_programs(import(cell.id, "M.mod", broken))
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    assert!(e.message().contains("M.mod:2:22"), "{}", e.message());
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "invalid");
    let programs = c
        .list_programs(pb::ListProgramsRequest { cell_id: cell.id })
        .await
        .unwrap()
        .into_inner();
    assert!(programs.programs.is_empty());
    // An unsupported file, and no file at all.
    let e = c
        .import_programs(import(cell.id, "a.txt", "hello"))
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    let e = c
        .import_programs(pb::ImportProgramsRequest {
            cell_id: cell.id,
            files: vec![],
            learn: None,
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");

    // An unknown cell: NOT_FOUND, for an import and for a replay.
    let empty = "MODULE M\nENDMODULE\n";
    let e = c
        .import_programs(import(999, "m.mod", empty))
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::NotFound, "{e:?}");
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "not_found");
    let e = c
        .replay(pb::ReplayRequest {
            cell_id: Some(999),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::NotFound, "{e:?}");

    // Learning while a routine is being taught: FAILED_PRECONDITION (REST: 409).
    let program = app.create_program(cell.id, "p").await;
    app.create_routine(program).await;
    let files = pb_files(&upload("ravenorb__abb-robot-welder"));
    let e = c
        .import_programs(pb::ImportProgramsRequest {
            cell_id: cell.id,
            files: files.clone(),
            learn: Some(true),
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::FailedPrecondition, "{e:?}");

    // Replays: neither files nor a cell, both, bad settings, a broken file, an unknown profile.
    let e = c.replay(pb::ReplayRequest::default()).await.unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    let e = c
        .replay(pb::ReplayRequest {
            files: files.clone(),
            cell_id: Some(cell.id),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    let e = c
        .replay(pb::ReplayRequest {
            cell_id: Some(cell.id),
            delta: Some(2.0),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    assert_eq!(
        e.metadata().get("x-error-code").unwrap(),
        "invalid_settings"
    );
    let e = c
        .replay(pb::ReplayRequest {
            files: import(cell.id, "M.mod", broken).files,
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    assert!(e.message().contains("M.mod:2:22"), "{}", e.message());
    let e = c
        .replay(pb::ReplayRequest {
            cell_id: Some(cell.id),
            profile: 7,
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
}

#[tokio::test]
async fn grpc_messages_are_limited_like_rest_bodies() {
    let app = spawn_with(TransportOptions {
        body_limit: 4096,
        ..TransportOptions::default()
    })
    .await;
    let mut c = client(&app).await;
    let cell = create_cell(&mut c, "limits").await;
    // A module with a malformed target on line 2, padded with a comment.
    let request = |padding: usize| pb::ImportProgramsRequest {
        cell_id: cell.id,
        files: vec![pb::UploadedFile {
            name: "M.mod".into(),
            content: format!(
                "MODULE M\n  CONST robtarget p:=[[1,2],[1,0,0,0]];\n!{}\nENDMODULE\n",
                "-".repeat(padding)
            ),
        }],
        learn: None,
    };
    let e = c.import_programs(request(8000)).await.unwrap_err();
    assert_eq!(e.code(), Code::OutOfRange, "{e:?}");
    assert!(e.message().contains("4096"), "{}", e.message());
    // Under the limit the same upload reaches the importer.
    let e = c.import_programs(request(1000)).await.unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    assert!(e.message().contains("M.mod:2:22"), "{}", e.message());

    // A Teach stream ends with OUT_OF_RANGE at an oversized command.
    let program = app.create_program(cell.id, "p").await;
    let routine = app.create_routine(program).await;
    let mut session = Teach::open(&mut c).await;
    session.start(routine).await;
    let mut big = waypoint(&pose([0.0; 3], [0.0; 3]));
    big.name = Some("n".repeat(8000));
    session.send(Command::Waypoint(big)).await;
    let e = session.rx.message().await.unwrap_err();
    assert_eq!(e.code(), Code::OutOfRange, "{e:?}");
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["waypoint_count"], 0);
}

#[tokio::test]
async fn grpc_calls_are_counted_in_metrics_and_carry_request_ids() {
    let app = spawn_app().await;
    let mut c = client(&app).await;

    // A call that succeeds, one that fails, a Teach stream closed by the client, and a call
    // to a method that does not exist.
    let response = c
        .create_cell(pb::CreateCellRequest {
            name: "counted".into(),
            settings: None,
        })
        .await
        .unwrap();
    let id = response
        .metadata()
        .get("x-request-id")
        .expect("a request id");
    assert!(!id.is_empty());
    let cell = response.into_inner();
    let mut request = tonic::Request::new(pb::GetCellRequest { cell_id: 999 });
    request
        .metadata_mut()
        .insert("x-request-id", "pendant-42".parse().unwrap());
    let e = c.get_cell(request).await.unwrap_err();
    assert_eq!(e.code(), Code::NotFound);
    assert_eq!(e.metadata().get("x-request-id").unwrap(), "pendant-42");
    c.get_cell(pb::GetCellRequest { cell_id: cell.id })
        .await
        .unwrap();

    let program = app.create_program(cell.id, "p").await;
    let routine = app.create_routine(program).await;
    let mut session = Teach::open(&mut c).await;
    session.start(routine).await;
    let Teach { tx, mut rx, .. } = session;
    drop(tx);
    // The server ends the stream with its status once the client's side is closed.
    assert!(rx.message().await.unwrap().is_none());

    let mut raw = tonic::client::Grpc::new(channel(&app).await);
    raw.ready().await.unwrap();
    let e = raw
        .unary::<_, pb::ListCellsResponse, _>(
            tonic::Request::new(pb::ListCellsRequest {}),
            "/nextpose.v1.Nextpose/NoSuchMethod".parse().unwrap(),
            tonic_prost::ProstCodec::default(),
        )
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::Unimplemented);

    let metrics = app.client.get(app.url("/metrics")).send().await.unwrap();
    let metrics = metrics.text().await.unwrap();
    let calls = |method: &str, code: &str| {
        sample(
            &metrics,
            &format!(
                "nextpose_grpc_requests_total{{service=\"nextpose.v1.Nextpose\",method=\"{method}\",code=\"{code}\"}}"
            ),
        )
    };
    assert_eq!(calls("CreateCell", "OK"), Some(1.0), "{metrics}");
    assert_eq!(calls("GetCell", "NOT_FOUND"), Some(1.0), "{metrics}");
    assert_eq!(calls("GetCell", "OK"), Some(1.0), "{metrics}");
    assert_eq!(calls("Teach", "OK"), Some(1.0), "{metrics}");
    assert_eq!(
        sample(
            &metrics,
            "nextpose_grpc_request_duration_seconds_count{service=\"nextpose.v1.Nextpose\",method=\"GetCell\"}"
        ),
        Some(2.0),
        "{metrics}"
    );
    assert_eq!(
        sample(
            &metrics,
            "nextpose_grpc_requests_total{service=\"unknown\",method=\"unknown\",code=\"UNIMPLEMENTED\"}"
        ),
        Some(1.0),
        "{metrics}"
    );
    assert!(!metrics.contains("NoSuchMethod"), "{metrics}");
    // The REST requests of this test are counted as before.
    assert!(
        metrics.contains("nextpose_http_requests_total{method=\"POST\",route=\"/v1/cells/{cell_id}/programs\",status=\"201\"} 1"),
        "{metrics}"
    );
}

/// Editing over gRPC: the same operations as REST over the same application, the same
/// answers (REST reads back what gRPC changed), the same refusals.
#[tokio::test]
async fn editing_over_grpc_changes_what_rest_reads_back() {
    let app = spawn_app().await;
    let cell = app.create_cell("edited over grpc").await;
    let program = app.create_program(cell, "p").await;
    let (r, _) = app
        .teach_routine(program, &u_seam([400.0, 0.0, 300.0], 0.0))
        .await;
    let before = app.get_ok(&format!("/v1/routines/{r}")).await;
    let w = before["waypoints"][1]["id"].as_i64().expect("id");
    let mut c = client(&app).await;
    let moved = pose([410.0, 5.0, 305.0], [0.0; 3]);
    let edit = c
        .modify_waypoint(pb::ModifyWaypointRequest {
            waypoint_id: w,
            pose: Some(pb_pose(&moved)),
            name: Some("corner".into()),
            ..Default::default()
        })
        .await
        .expect("modify")
        .into_inner();
    let version = edit.model_version;
    assert_eq!(
        edit.previous.expect("previous").pose,
        Some(pb_pose(&before["waypoints"][1]["pose"]))
    );
    let now = app.get_ok(&format!("/v1/routines/{r}")).await;
    assert_eq!(now["waypoints"][1]["name"], "corner");
    assert!(distance(&now["waypoints"][1]["pose"], &moved) < 1e-9);
    let inserted = c
        .insert_waypoint(pb::InsertWaypointRequest {
            waypoint_id: w,
            side: pb::Side::Before.into(),
            waypoint: Some(waypoint(&moved)),
        })
        .await
        .expect("insert")
        .into_inner();
    assert_eq!(inserted.waypoint.as_ref().expect("waypoint").seq, 2);
    assert_eq!(inserted.model_version, version + 1);
    let id = inserted.waypoint.expect("waypoint").id;
    let deleted = c
        .delete_waypoint(pb::DeleteWaypointRequest { waypoint_id: id })
        .await
        .expect("delete")
        .into_inner();
    assert_eq!(deleted.previous.expect("previous").id, id);
    assert_eq!(deleted.model_version, version + 2);
    assert_eq!(
        app.get_ok(&format!("/v1/routines/{r}")).await["waypoints"]
            .as_array()
            .expect("waypoints")
            .len(),
        before["waypoints"].as_array().expect("waypoints").len()
    );
    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    assert_eq!(stats["model"]["version"], version + 2);
    let unknown = c
        .modify_waypoint(pb::ModifyWaypointRequest {
            waypoint_id: 999_999,
            ..Default::default()
        })
        .await
        .expect_err("no such waypoint");
    assert_eq!(unknown.code(), tonic::Code::NotFound);
    let no_side = c
        .insert_waypoint(pb::InsertWaypointRequest {
            waypoint_id: w,
            side: pb::Side::Unspecified.into(),
            waypoint: Some(waypoint(&moved)),
        })
        .await
        .expect_err("no side");
    assert_eq!(no_side.code(), tonic::Code::InvalidArgument);
    let renamed = c
        .edit_routine(pb::EditRoutineRequest {
            routine_id: r,
            name: Some("seam".into()),
            position: None,
        })
        .await
        .expect("rename")
        .into_inner();
    assert_eq!(
        renamed.routine.expect("routine").name.as_deref(),
        Some("seam")
    );
    c.delete_program(pb::DeleteProgramRequest {
        program_id: program,
    })
    .await
    .expect("delete program");
    assert_eq!(
        app.get(&format!("/v1/programs/{program}")).await.status(),
        reqwest::StatusCode::NOT_FOUND
    );
}

/// Export over gRPC gives the files REST gives; an unknown format is INVALID_ARGUMENT.
#[tokio::test]
async fn export_over_grpc_gives_the_files_rest_gives() {
    let app = spawn_app().await;
    let cell = app.create_cell("exported over grpc").await;
    let program = app.create_program(cell, "Seam").await;
    app.teach_routine(program, &u_seam([400.0, 0.0, 300.0], 0.0))
        .await;
    let mut c = client(&app).await;
    for format in ["rapid", "krl", "fanuc"] {
        let rest = app
            .get_ok(&format!("/v1/programs/{program}/export?format={format}"))
            .await;
        let grpc = c
            .export_program(pb::ExportProgramRequest {
                program_id: program,
                format: format.into(),
            })
            .await
            .expect("export")
            .into_inner();
        assert_eq!(grpc.format, format);
        assert_eq!(
            grpc.files.len(),
            rest["files"].as_array().expect("files").len()
        );
        for (g, r) in grpc
            .files
            .iter()
            .zip(rest["files"].as_array().expect("files"))
        {
            assert_eq!(g.file_name, r["file_name"].as_str().expect("name"));
            assert_eq!(g.text, r["text"].as_str().expect("text"));
        }
    }
    let bad = c
        .export_program(pb::ExportProgramRequest {
            program_id: program,
            format: "basic".into(),
        })
        .await
        .expect_err("unknown format");
    assert_eq!(bad.code(), tonic::Code::InvalidArgument);
}

/// Re-targeting over gRPC stores the moved copy REST reads back; neither frame nor points is
/// INVALID_ARGUMENT.
#[tokio::test]
async fn retarget_over_grpc_stores_the_moved_copy() {
    let app = spawn_app().await;
    let cell = app.create_cell("moved over grpc").await;
    let program = app.create_program(cell, "p").await;
    let (r, _) = app
        .teach_routine(program, &u_seam([400.0, 0.0, 300.0], 0.0))
        .await;
    let mut c = client(&app).await;
    let copy = c
        .retarget_routine(pb::RetargetRequest {
            id: r,
            frame: Some(pb_pose(&pose([0.0, 25.0, 0.0], [0.0; 3]))),
            points: None,
            name: Some("shifted".into()),
        })
        .await
        .expect("retarget")
        .into_inner();
    let routine = &copy.routines[0];
    let id = routine.routine.as_ref().expect("routine").id;
    let rest = app.get_ok(&format!("/v1/routines/{id}")).await;
    assert_eq!(rest["name"], "shifted");
    let original = app.get_ok(&format!("/v1/routines/{r}")).await;
    let dy = rest["waypoints"][0]["pose"]["y"].as_f64().expect("y")
        - original["waypoints"][0]["pose"]["y"].as_f64().expect("y");
    assert!((dy - 25.0).abs() < 1e-6, "{dy}");
    let neither = c
        .retarget_program(pb::RetargetRequest {
            id: program,
            ..Default::default()
        })
        .await
        .expect_err("neither frame nor points");
    assert_eq!(neither.code(), tonic::Code::InvalidArgument);
}
