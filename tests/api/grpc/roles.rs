//! Roles and scopes over gRPC: every method of the service × {no token, operator of the cell,
//! operator of another cell, engineer, admin}, as `roles` does for REST's routes. No token is
//! `UNAUTHENTICATED`; a known token outside its role or cells is `PERMISSION_DENIED` and
//! changes nothing (every table of the database, and the cell's model); an allowed one is not
//! refused, and succeeds. The `Teach` stream is refused at its `start` (the routine names the
//! cell). The list of methods is checked against the service's `.proto`, so a method added
//! without a row here fails this test.

use std::collections::BTreeSet;

use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use nextpose::transport::TransportOptions;
use tonic::codegen::InterceptedService;
use tonic::metadata::{AsciiMetadataValue, MetadataValue};
use tonic::service::Interceptor;
use tonic::transport::Channel;
use tonic::{Code, Status};

use super::client::{channel, pb_pose};
use crate::helpers::*;
use crate::roles::{BOOTSTRAP, Fixture, MODULE, Need, dump, fixture, secret, urdf};

/// Sends `authorization: Bearer <secret>` when it has one.
#[derive(Clone)]
struct Bearer(Option<AsciiMetadataValue>);

impl Interceptor for Bearer {
    fn call(&mut self, mut r: tonic::Request<()>) -> Result<tonic::Request<()>, Status> {
        if let Some(v) = &self.0 {
            r.metadata_mut().insert("authorization", v.clone());
        }
        Ok(r)
    }
}

type Client = NextposeClient<InterceptedService<Channel, Bearer>>;

fn client(ch: &Channel, secret: Option<&str>) -> Client {
    let value = secret.map(|s| MetadataValue::try_from(format!("Bearer {s}")).expect("ascii"));
    NextposeClient::with_interceptor(ch.clone(), Bearer(value))
}

/// A RAPID module of one move, to import and replay.
fn module() -> pb::UploadedFile {
    pb::UploadedFile {
        name: "one.mod".into(),
        content: MODULE.into(),
    }
}

/// Every method: its name as in the `.proto`, the least role that may call it, and whether
/// it touches one cell (so an operator of another cell is refused).
const METHODS: &[(&str, Need, bool)] = &[
    ("CreateCell", Need::Engineer, false),
    ("ListCells", Need::Operator, false),
    ("GetCell", Need::Operator, true),
    ("GetCellStats", Need::Operator, true),
    ("RebuildModel", Need::Engineer, true),
    ("UpdateCell", Need::Engineer, true),
    ("CalibrateCell", Need::Engineer, true),
    ("DeleteCell", Need::Admin, true),
    ("CreateProgram", Need::Engineer, true),
    ("ListPrograms", Need::Operator, true),
    ("GetProgram", Need::Operator, true),
    ("RenameProgram", Need::Engineer, true),
    ("ExportProgram", Need::Engineer, true),
    ("DeleteProgram", Need::Admin, true),
    ("CreateRoutine", Need::Operator, true),
    ("ListRoutines", Need::Operator, true),
    ("GetRoutine", Need::Operator, true),
    ("DeleteRoutine", Need::Engineer, true),
    ("EditRoutine", Need::Engineer, true),
    ("FinishRoutine", Need::Operator, true),
    ("AppendWaypoint", Need::Operator, true),
    ("AppendTrajectory", Need::Operator, true),
    ("Undo", Need::Operator, true),
    ("ModifyWaypoint", Need::Engineer, true),
    ("InsertWaypoint", Need::Engineer, true),
    ("DeleteWaypoint", Need::Engineer, true),
    ("RetargetRoutine", Need::Engineer, true),
    ("RetargetProgram", Need::Engineer, true),
    ("Predict", Need::Operator, true),
    ("Feedback", Need::Operator, true),
    ("Teach", Need::Operator, true),
    ("ListRobots", Need::Operator, false),
    ("GetRobot", Need::Operator, false),
    ("UploadRobot", Need::Engineer, false),
    ("DeleteRobot", Need::Engineer, false),
    ("SearchPlacements", Need::Operator, false),
    ("GetArmFrames", Need::Operator, true),
    ("CheckReach", Need::Operator, true),
    ("ImportPrograms", Need::Engineer, true),
    ("Replay", Need::Engineer, false),
    ("CreateBackup", Need::Admin, false),
    ("CreateToken", Need::Admin, false),
    ("ListTokens", Need::Admin, false),
    ("RevokeToken", Need::Admin, false),
    ("WhoAmI", Need::Operator, false),
    ("ListAudit", Need::Engineer, false),
    ("ListProgramHistory", Need::Operator, true),
    ("GetProgramRevision", Need::Operator, true),
    ("DiffProgram", Need::Operator, true),
    ("RestoreProgram", Need::Engineer, true),
];

/// Sets up, as the admin, what `method` needs beyond the fixture to succeed (before the
/// database is compared): the cell's open routine finished before another is started or a
/// program imported and learned, an arm
/// uploaded to delete (bundled ones cannot be), a token to revoke.
async fn prepare(admin: &mut Client, method: &str, f: &Fixture, n: usize) {
    match method {
        "CreateRoutine" | "ImportPrograms" => {
            admin
                .finish_routine(pb::FinishRoutineRequest { routine_id: f.open })
                .await
                .expect("finish");
        }
        "DeleteRobot" => {
            admin
                .upload_robot(pb::UploadRobotRequest {
                    name: format!("doomed_{n}"),
                    urdf: urdf("ur5e"),
                    ..Default::default()
                })
                .await
                .expect("upload");
        }
        "RevokeToken" => {
            admin
                .create_token(pb::CreateTokenRequest {
                    name: format!("revoked-{n}"),
                    role: pb::Role::Operator.into(),
                    cells: vec![],
                })
                .await
                .expect("token");
        }
        _ => {}
    }
}

/// Calls `method` as `c` on the fixture's resources with a request that succeeds for a caller
/// allowed it (once [`prepare`]d); `n` makes names unique.
async fn call(c: &mut Client, method: &str, f: &Fixture, n: usize) -> Result<(), Status> {
    let pose = |p: [f64; 3]| Some(pb_pose(&pose(p, [0.0; 3])));
    match method {
        "CreateCell" => c
            .create_cell(pb::CreateCellRequest {
                name: format!("new-cell-{n}"),
                settings: None,
            })
            .await
            .map(drop),
        "ListCells" => c.list_cells(pb::ListCellsRequest {}).await.map(drop),
        "GetCell" => c
            .get_cell(pb::GetCellRequest { cell_id: f.cell })
            .await
            .map(drop),
        "GetCellStats" => c
            .get_cell_stats(pb::GetCellStatsRequest { cell_id: f.cell })
            .await
            .map(drop),
        "RebuildModel" => c
            .rebuild_model(pb::RebuildModelRequest { cell_id: f.cell })
            .await
            .map(drop),
        "UpdateCell" => c
            .update_cell(pb::UpdateCellRequest {
                cell_id: f.cell,
                name: Some(format!("renamed-{n}")),
                settings: None,
            })
            .await
            .map(drop),
        "CalibrateCell" => c
            .calibrate_cell(pb::CalibrateCellRequest {
                cell_id: f.cell,
                poses: [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
                    .into_iter()
                    .filter_map(pose)
                    .collect(),
            })
            .await
            .map(drop),
        "DeleteCell" => c
            .delete_cell(pb::DeleteCellRequest { cell_id: f.cell })
            .await
            .map(drop),
        "CreateProgram" => c
            .create_program(pb::CreateProgramRequest {
                cell_id: f.cell,
                name: format!("q-{n}"),
            })
            .await
            .map(drop),
        "ListPrograms" => c
            .list_programs(pb::ListProgramsRequest { cell_id: f.cell })
            .await
            .map(drop),
        "GetProgram" => c
            .get_program(pb::GetProgramRequest {
                program_id: f.program,
            })
            .await
            .map(drop),
        "RenameProgram" => c
            .rename_program(pb::RenameProgramRequest {
                program_id: f.program,
                name: format!("pp-{n}"),
            })
            .await
            .map(drop),
        "ExportProgram" => c
            .export_program(pb::ExportProgramRequest {
                program_id: f.program,
                format: "rapid".into(),
                revision: None,
            })
            .await
            .map(drop),
        "ListProgramHistory" => c
            .list_program_history(pb::ListProgramHistoryRequest {
                program_id: f.program,
                before: None,
                limit: None,
            })
            .await
            .map(drop),
        "GetProgramRevision" => c
            .get_program_revision(pb::GetProgramRevisionRequest {
                program_id: f.program,
                revision: 1,
            })
            .await
            .map(drop),
        "DiffProgram" => c
            .diff_program(pb::DiffProgramRequest {
                program_id: f.program,
                from: 0,
                to: None,
            })
            .await
            .map(drop),
        "RestoreProgram" => c
            .restore_program(pb::RestoreProgramRequest {
                program_id: f.program,
                revision: 1,
            })
            .await
            .map(drop),
        "DeleteProgram" => c
            .delete_program(pb::DeleteProgramRequest {
                program_id: f.program,
            })
            .await
            .map(drop),
        "CreateRoutine" => c
            .create_routine(pb::CreateRoutineRequest {
                program_id: f.program,
                name: None,
            })
            .await
            .map(drop),
        "ListRoutines" => c
            .list_routines(pb::ListRoutinesRequest {
                program_id: f.program,
            })
            .await
            .map(drop),
        "GetRoutine" => c
            .get_routine(pb::GetRoutineRequest {
                routine_id: f.finished,
            })
            .await
            .map(drop),
        "DeleteRoutine" => c
            .delete_routine(pb::DeleteRoutineRequest {
                routine_id: f.finished,
            })
            .await
            .map(drop),
        "EditRoutine" => c
            .edit_routine(pb::EditRoutineRequest {
                routine_id: f.finished,
                name: Some(format!("r-{n}")),
                position: None,
            })
            .await
            .map(drop),
        "FinishRoutine" => c
            .finish_routine(pb::FinishRoutineRequest { routine_id: f.open })
            .await
            .map(drop),
        "AppendWaypoint" => c
            .append_waypoint(pb::AppendWaypointRequest {
                routine_id: f.open,
                waypoint: Some(pb::NewWaypoint {
                    pose: pose([100.0, 0.0, 0.0]),
                    ..Default::default()
                }),
            })
            .await
            .map(drop),
        "AppendTrajectory" => c
            .append_trajectory(pb::AppendTrajectoryRequest {
                routine_id: f.open,
                samples: (0..10)
                    .map(|i| pb::TrajectorySample {
                        t: f64::from(i) * 0.1,
                        pose: pose([300.0 + 10.0 * f64::from(i), 0.0, 0.0]),
                        ..Default::default()
                    })
                    .collect(),
                preview: true,
                settings: None,
            })
            .await
            .map(drop),
        "Undo" => c
            .undo(pb::UndoRequest { routine_id: f.open })
            .await
            .map(drop),
        "ModifyWaypoint" => c
            .modify_waypoint(pb::ModifyWaypointRequest {
                waypoint_id: f.waypoint,
                name: Some(format!("w-{n}")),
                ..Default::default()
            })
            .await
            .map(drop),
        "InsertWaypoint" => c
            .insert_waypoint(pb::InsertWaypointRequest {
                waypoint_id: f.waypoint,
                side: pb::Side::After.into(),
                waypoint: Some(pb::NewWaypoint {
                    pose: pose([50.0, 50.0, 0.0]),
                    ..Default::default()
                }),
            })
            .await
            .map(drop),
        "DeleteWaypoint" => c
            .delete_waypoint(pb::DeleteWaypointRequest {
                waypoint_id: f.waypoint,
            })
            .await
            .map(drop),
        "RetargetRoutine" => c
            .retarget_routine(pb::RetargetRequest {
                id: f.finished,
                frame: pose([10.0, 0.0, 0.0]),
                ..Default::default()
            })
            .await
            .map(drop),
        "RetargetProgram" => c
            .retarget_program(pb::RetargetRequest {
                id: f.program,
                frame: pose([10.0, 0.0, 0.0]),
                name: Some(format!("moved-{n}")),
                ..Default::default()
            })
            .await
            .map(drop),
        "Predict" => c
            .predict(pb::PredictRequest {
                routine_id: f.open,
                ..Default::default()
            })
            .await
            .map(drop),
        "Feedback" => c
            .feedback(pb::FeedbackRequest {
                prediction_id: f.prediction,
                verdict: pb::Verdict::Rejected.into(),
                pose: None,
            })
            .await
            .map(drop),
        "Teach" => {
            let start = pb::TeachRequest {
                tag: 1,
                command: Some(pb::teach_request::Command::Start(pb::StartCommand {
                    routine_id: f.open,
                })),
            };
            let mut answers = c.teach(tokio_stream::iter([start])).await?.into_inner();
            let answer = answers.message().await?.expect("an answer to start");
            match answer.event {
                Some(pb::teach_response::Event::Started(_)) => Ok(()),
                Some(pb::teach_response::Event::Error(e)) => {
                    Err(Status::new(Code::from(e.code), e.message))
                }
                other => panic!("start answered {other:?}"),
            }
        }
        "ListRobots" => c.list_robots(pb::ListRobotsRequest {}).await.map(drop),
        "GetRobot" => c
            .get_robot(pb::GetRobotRequest {
                name: "abb_irb140".into(),
            })
            .await
            .map(drop),
        "UploadRobot" => c
            .upload_robot(pb::UploadRobotRequest {
                name: format!("arm_{n}"),
                urdf: urdf("ur5e"),
                ..Default::default()
            })
            .await
            .map(drop),
        "DeleteRobot" => c
            .delete_robot(pb::DeleteRobotRequest {
                name: format!("doomed_{n}"),
            })
            .await
            .map(drop),
        "SearchPlacements" => c
            .search_placements(pb::SearchPlacementsRequest {
                robot: "abb_irb140".into(),
                targets: vec![pose([400.0, 0.0, 400.0]).unwrap_or_default()],
                mounting: "floor".into(),
                keep: Some(1),
                evaluations: Some(100),
                seed: Some(1),
                ..Default::default()
            })
            .await
            .map(drop),
        "GetArmFrames" => c
            .get_arm_frames(pb::GetArmFramesRequest {
                cell_id: f.cell,
                joints: vec![0.0; 6],
            })
            .await
            .map(drop),
        "CheckReach" => c
            .check_reach(pb::CheckReachRequest {
                cell_id: f.cell,
                pose: pose([400.0, 0.0, 400.0]),
                near: vec![],
            })
            .await
            .map(drop),
        "ImportPrograms" => c
            .import_programs(pb::ImportProgramsRequest {
                cell_id: f.cell,
                files: vec![module()],
                learn: Some(true),
            })
            .await
            .map(drop),
        "Replay" => c
            .replay(pb::ReplayRequest {
                files: vec![module()],
                ..Default::default()
            })
            .await
            .map(drop),
        "CreateBackup" => c
            .create_backup(pb::CreateBackupRequest {
                name: Some(format!("copy-{n}.db")),
            })
            .await
            .map(drop),
        "CreateToken" => c
            .create_token(pb::CreateTokenRequest {
                name: format!("made-{n}"),
                role: pb::Role::Operator.into(),
                cells: vec![f.cell],
            })
            .await
            .map(drop),
        "ListTokens" => c.list_tokens(pb::ListTokensRequest {}).await.map(drop),
        "RevokeToken" => c
            .revoke_token(pb::RevokeTokenRequest {
                name: format!("revoked-{n}"),
            })
            .await
            .map(drop),
        "WhoAmI" => c.who_am_i(pb::WhoAmIRequest {}).await.map(drop),
        "ListAudit" => c
            .list_audit(pb::ListAuditRequest {
                cell_id: Some(f.cell),
                limit: Some(5),
                ..Default::default()
            })
            .await
            .map(drop),
        other => panic!("no call for {other}"),
    }
}

/// The methods of the service, from its `.proto`.
fn proto_methods() -> BTreeSet<String> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/proto/nextpose/v1/nextpose.proto"
    );
    std::fs::read_to_string(path)
        .expect("proto")
        .lines()
        .filter_map(|l| l.trim().strip_prefix("rpc "))
        .map(|l| l.split('(').next().unwrap_or_default().trim().to_string())
        .collect()
}

#[tokio::test]
async fn every_method_answers_each_role_and_scope_as_specified() {
    let listed: BTreeSet<String> = METHODS.iter().map(|(m, _, _)| m.to_string()).collect();
    assert_eq!(
        listed,
        proto_methods(),
        "every method of the service is here"
    );
    let mut app = spawn_with(TransportOptions {
        token: Some(BOOTSTRAP.into()),
        ..TransportOptions::default()
    })
    .await;
    app.token = Some(BOOTSTRAP.into());
    let ch = channel(&app).await;
    let mut admin_client = client(&ch, Some(BOOTSTRAP));
    let elsewhere = app.create_cell("elsewhere").await;
    let outsider = secret(&app, "op-elsewhere", "operator", Some(vec![elsewhere])).await;
    let engineer = secret(&app, "engineer", "engineer", None).await;
    let admin = secret(&app, "admin", "admin", None).await;

    let mut n = 0;
    for &(method, need, scoped) in METHODS {
        let f = fixture(&app, n).await;
        n += 1;
        // (who, secret, role, whether the cell of the fixture is the caller's)
        let callers: [(&str, Option<&str>, Option<Need>, bool); 5] = [
            ("no token", None, None, false),
            (
                "operator of the cell",
                Some(&f.operator),
                Some(Need::Operator),
                true,
            ),
            (
                "operator of another cell",
                Some(&outsider),
                Some(Need::Operator),
                false,
            ),
            ("engineer", Some(&engineer), Some(Need::Engineer), true),
            ("admin", Some(&admin), Some(Need::Admin), true),
        ];
        let allowed = |role: Option<Need>, in_scope: bool| {
            role.is_some_and(|role| role >= need && (in_scope || !scoped))
        };
        prepare(&mut admin_client, method, &f, n).await;
        for (who, token, role, in_scope) in callers {
            if allowed(role, in_scope) {
                continue;
            }
            let before = (
                dump(&app).await,
                app.get_ok(&format!("/v1/cells/{}/stats", f.cell)).await,
            );
            let e = call(&mut client(&ch, token), method, &f, n)
                .await
                .expect_err(&format!("{method} as {who} was not refused"));
            let want = if token.is_none() {
                Code::Unauthenticated
            } else {
                Code::PermissionDenied
            };
            assert_eq!(e.code(), want, "{method} as {who}: {e:?}");
            let after = (
                dump(&app).await,
                app.get_ok(&format!("/v1/cells/{}/stats", f.cell)).await,
            );
            assert!(before == after, "{method} as {who} changed something");
        }
        for (who, token, role, in_scope) in callers {
            if !allowed(role, in_scope) {
                continue;
            }
            // Each allowed caller on a fresh fixture (a deletion leaves nothing to repeat on).
            let f = fixture(&app, n).await;
            n += 1;
            let token = if who == "operator of the cell" {
                Some(f.operator.as_str())
            } else {
                token
            };
            prepare(&mut admin_client, method, &f, n).await;
            let answer = call(&mut client(&ch, token), method, &f, n).await;
            if on_postgres() && method == "CreateBackup" {
                // PostgreSQL is backed up with pg_dump (deployment.md).
                let e = answer.expect_err("no backup of PostgreSQL");
                assert_eq!(e.code(), Code::FailedPrecondition, "{method} as {who}");
            } else {
                answer.unwrap_or_else(|e| panic!("{method} as {who}: {e:?}"));
            }
        }
    }
    // What the tokens' names say, over gRPC as over REST.
    let me = client(&ch, Some(&outsider))
        .who_am_i(pb::WhoAmIRequest {})
        .await
        .expect("whoami")
        .into_inner();
    assert_eq!(
        (me.name.as_str(), me.role, me.cells, me.authenticated),
        (
            "op-elsewhere",
            pb::Role::Operator as i32,
            vec![elsewhere],
            true
        )
    );
    let listed = client(&ch, Some(&outsider))
        .list_cells(pb::ListCellsRequest {})
        .await
        .expect("cells")
        .into_inner();
    assert_eq!(
        listed.cells.iter().map(|c| c.id).collect::<Vec<_>>(),
        vec![elsewhere],
        "a token limited to some cells lists only those"
    );
}
