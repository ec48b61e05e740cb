//! An import through gRPC teaches what the REST import teaches: the same programs, skipped
//! items and model, and the same predictions when an imported routine is taught again.

use nextpose::grpc::pb;
use serde_json::{Value, json};
use tonic::Code;

use super::client::{client, pb_files};
use super::session::Teach;
use super::teach::assert_same_prediction;
use crate::helpers::*;
use crate::import::upload;

#[tokio::test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn an_import_through_grpc_teaches_what_the_rest_import_teaches() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let files = upload("ravenorb__abb-robot-welder");

    // Cell A imports through REST, cell B through gRPC; both with a fixed threshold, so that
    // something is offered to compare (steering its own, a cell with this record offers
    // nothing: tests/api/import.rs).
    let rest_cell = app
        .create_cell_with(
            "rest",
            json!({ "reach_policy": "flag", "offer_threshold": 0.7 }),
        )
        .await;
    let rest = app.import(rest_cell, &json!({ "files": files })).await;
    let cell = c
        .create_cell(pb::CreateCellRequest {
            name: "grpc".into(),
            settings: Some(pb::CellSettingsInput {
                reach_policy: pb::ReachPolicy::Flag.into(),
                offer_threshold: Some(0.7),
                ..Default::default()
            }),
        })
        .await
        .expect("create cell")
        .into_inner();
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
