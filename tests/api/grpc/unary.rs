//! Unary calls: every resource created, read, changed and deleted over gRPC, and what REST
//! reads back; editing, export and re-targeting give what REST gives.

use nextpose::grpc::pb;
use tonic::Code;

use super::client::{Client, client, create_cell, pb_pose, waypoint};
use crate::helpers::*;

#[tokio::test]
async fn unary_calls_cover_every_resource() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let cell = cells(&app, &mut c).await;
    let program = programs(&mut c, &cell).await;
    let offered_id = two_seams_taught(&mut c, &program).await;
    feedback_stats_and_rebuild(&mut c, &cell, offered_id).await;
    an_open_routine_deleted(&mut c, &program).await;
    robots(&mut c).await;
}

/// Cells: created (with settings), listed, read, and the same cell through REST.
async fn cells(app: &TestApp, c: &mut Client) -> pb::Cell {
    let cell = create_cell(c, "grpc-cell").await;
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
    cell
}

/// Programs: created in the cell, listed, read.
async fn programs(c: &mut Client, cell: &pb::Cell) -> pb::Program {
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
    program
}

/// Routines and teaching: two copies of a seam, the second one predicted; returns the id of
/// the first prediction offered.
async fn two_seams_taught(c: &mut Client, program: &pb::Program) -> Option<i64> {
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
                        seq: None,
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
    offered_id
}

/// Feedback on an offered prediction; the stats count it, and a rebuild gives the same model.
async fn feedback_stats_and_rebuild(c: &mut Client, cell: &pb::Cell, offered_id: Option<i64>) {
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
}

/// An open routine deleted: reading it again is NOT_FOUND.
async fn an_open_routine_deleted(c: &mut Client, program: &pb::Program) {
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
}

/// Robots: listed, and one read with its joints and solver.
async fn robots(c: &mut Client) {
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
                revision: None,
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
            revision: None,
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

/// A calibration routine over gRPC sets the noise that the same routine sets over REST; fewer
/// than three poses are refused with INVALID_ARGUMENT.
#[tokio::test]
async fn a_calibration_routine_over_grpc_sets_what_rest_sets() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let poses: Vec<serde_json::Value> = [[1.0, 0.0, 0.0], [-1.0, 0.5, 0.0], [0.0, -0.5, 1.5]]
        .iter()
        .map(|o| pose([300.0 + o[0], o[1], 200.0 + o[2]], [0.0, 3.0, 0.0]))
        .collect();
    let rest_cell = app.create_cell("rest").await;
    let rest = app
        .post_ok(
            &format!("/v1/cells/{rest_cell}/calibration"),
            &serde_json::json!({ "poses": poses }),
            reqwest::StatusCode::OK,
        )
        .await;
    let cell = create_cell(&mut c, "grpc").await;
    let calibrated = c
        .calibrate_cell(pb::CalibrateCellRequest {
            cell_id: cell.id,
            poses: poses.iter().map(pb_pose).collect(),
        })
        .await
        .expect("calibrate")
        .into_inner();
    let noise = calibrated.settings.unwrap().noise.expect("noise set");
    assert_eq!(rest["settings"]["noise"]["mm"].as_f64(), Some(noise.mm));
    assert_eq!(rest["settings"]["noise"]["rad"].as_f64(), Some(noise.rad));
    assert!(noise.mm > 0.0);
    let e = c
        .calibrate_cell(pb::CalibrateCellRequest {
            cell_id: cell.id,
            poses: poses[..2].iter().map(pb_pose).collect(),
        })
        .await
        .expect_err("two poses");
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
}

/// A program's history over gRPC is REST's: the revisions, the program as of one, a diff and a
/// restore answer the same, and a revision the program does not have is INVALID_ARGUMENT.
#[tokio::test]
async fn history_over_grpc_matches_rest() {
    use nextpose::api::{ProgramDiff, ProgramHistory, ProgramRevision, Restored};

    let app = spawn_app().await;
    let cell = app.create_cell("history-grpc").await;
    let program = app.create_program(cell, "p").await;
    let (routine, _) = app
        .teach_routine(program, &u_seam([400.0, 0.0, 300.0], 0.0))
        .await;
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    let w = detail["waypoints"][2]["id"].as_i64().expect("id");
    let moved = pose([420.0, 10.0, 300.0], [3.1, 0.0, 0.3]);
    app.patch(
        &format!("/v1/waypoints/{w}"),
        &serde_json::json!({ "pose": moved }),
    )
    .await;
    let mut c = client(&app).await;

    let rest: ProgramHistory =
        serde_json::from_value(app.get_ok(&format!("/v1/programs/{program}/history")).await)
            .expect("history");
    let grpc = c
        .list_program_history(pb::ListProgramHistoryRequest {
            program_id: program,
            before: None,
            limit: None,
        })
        .await
        .expect("history")
        .into_inner();
    assert_eq!(ProgramHistory::try_from(grpc).expect("converts"), rest);

    let rest: ProgramRevision = serde_json::from_value(
        app.get_ok(&format!("/v1/programs/{program}/history/3"))
            .await,
    )
    .expect("revision");
    let grpc = c
        .get_program_revision(pb::GetProgramRevisionRequest {
            program_id: program,
            revision: 3,
        })
        .await
        .expect("revision")
        .into_inner();
    assert_eq!(ProgramRevision::try_from(grpc).expect("converts"), rest);

    let rest: ProgramDiff = serde_json::from_value(
        app.get_ok(&format!("/v1/programs/{program}/diff?from=2"))
            .await,
    )
    .expect("diff");
    let grpc = c
        .diff_program(pb::DiffProgramRequest {
            program_id: program,
            from: 2,
            to: None,
        })
        .await
        .expect("diff")
        .into_inner();
    assert_eq!(ProgramDiff::try_from(grpc).expect("converts"), rest);

    let missing = c
        .get_program_revision(pb::GetProgramRevisionRequest {
            program_id: program,
            revision: 99,
        })
        .await
        .expect_err("no revision 99");
    assert_eq!(missing.code(), Code::NotFound);

    let last = rest.to;
    let restored = c
        .restore_program(pb::RestoreProgramRequest {
            program_id: program,
            revision: last - 1,
        })
        .await
        .expect("restore")
        .into_inner();
    let restored = Restored::try_from(restored).expect("converts");
    assert!(restored.changed);
    assert_eq!(restored.revision, last + 1);
    let now = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(now["waypoints"][2]["pose"], detail["waypoints"][2]["pose"]);
}
