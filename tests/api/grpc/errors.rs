//! Errors map to status codes, with the service's error code in metadata, for unary calls and
//! for commands in a `Teach` session; messages are limited like REST bodies.

use nextpose::grpc::pb;
use nextpose::grpc::pb::teach_request::Command;
use nextpose::grpc::pb::teach_response::Event;
use nextpose::transport::TransportOptions;
use reqwest::StatusCode;
use serde_json::json;
use tonic::Code;

use super::client::{client, create_cell, pb_files, pb_pose, waypoint};
use super::session::Teach;
use crate::helpers::*;
use crate::import::upload;

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
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
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
