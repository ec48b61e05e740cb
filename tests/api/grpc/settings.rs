//! The settings the command line had are a cell's over gRPC too: set on creation and by an
//! update, read back over gRPC and REST alike, and a bad value refused with INVALID_ARGUMENT
//! naming it, nothing changed.

use nextpose::grpc::pb;
use serde_json::json;
use tonic::Code;

use super::client::client;
use crate::helpers::*;

#[tokio::test]
async fn the_command_lines_overrides_are_settings_of_a_cell_over_grpc() {
    let app = spawn_app().await;
    let mut c = client(&app).await;
    let cell = c
        .create_cell(pb::CreateCellRequest {
            name: "overrides over grpc".into(),
            settings: Some(pb::CellSettingsInput {
                merge: pb::MergeRule::Total.into(),
                learn_within_routine: Some(false),
                max_misfit: Some(pb::GateSetting { max: None }),
                max_spread: Some(pb::GateSetting { max: Some(0.75) }),
                recall: Some(pb::RecallSetting {
                    gate: Some(pb::RecallGate {
                        max_cost: 0.2,
                        min_window: 3,
                    }),
                }),
                ..Default::default()
            }),
        })
        .await
        .expect("create cell")
        .into_inner();
    let settings = cell.settings.clone().expect("settings");
    assert_eq!(settings.merge(), pb::MergeRule::Total);
    assert!(!settings.learn_within_routine);
    assert_eq!(settings.max_misfit, None);
    assert_eq!(settings.max_spread, Some(0.75));
    // Left out: the profile's.
    assert_eq!(settings.max_end_prob, Some(0.5));
    assert_eq!(
        settings.recall,
        Some(pb::RecallGate {
            max_cost: 0.2,
            min_window: 3
        })
    );
    let rest = app.get_ok(&format!("/v1/cells/{}", cell.id)).await;
    assert_eq!(rest["settings"]["merge"], "total");
    assert_eq!(rest["settings"]["learn_within_routine"], false);
    assert_eq!(rest["settings"]["max_misfit"], json!(null));
    assert_eq!(rest["settings"]["max_spread"], 0.75);
    assert_eq!(
        rest["settings"]["recall"],
        json!({ "max_cost": 0.2, "min_window": 3 })
    );

    for (bad, field) in [
        (
            pb::CellSettingsInput {
                max_end_prob: Some(pb::GateSetting { max: Some(-1.0) }),
                ..Default::default()
            },
            "max_end_prob",
        ),
        (
            pb::CellSettingsInput {
                recall: Some(pb::RecallSetting {
                    gate: Some(pb::RecallGate {
                        max_cost: -1.0,
                        min_window: 2,
                    }),
                }),
                ..Default::default()
            },
            "recall",
        ),
        (
            pb::CellSettingsInput {
                merge: 7,
                ..Default::default()
            },
            "merge",
        ),
    ] {
        let e = c
            .update_cell(pb::UpdateCellRequest {
                cell_id: cell.id,
                name: None,
                settings: Some(bad),
            })
            .await
            .unwrap_err();
        assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
        assert!(e.message().contains(field), "{field}: {}", e.message());
    }
    assert_eq!(app.get_ok(&format!("/v1/cells/{}", cell.id)).await, rest);

    // An update sets one and keeps the others; a gate set without a threshold is none.
    let updated = c
        .update_cell(pb::UpdateCellRequest {
            cell_id: cell.id,
            name: None,
            settings: Some(pb::CellSettingsInput {
                max_end_prob: Some(pb::GateSetting { max: None }),
                ..Default::default()
            }),
        })
        .await
        .expect("update")
        .into_inner();
    let now = updated.settings.expect("settings");
    assert_eq!(now.max_end_prob, None);
    assert_eq!(now.max_spread, Some(0.75));
    assert_eq!(now.merge(), pb::MergeRule::Total);
    let rest = app.get_ok(&format!("/v1/cells/{}", cell.id)).await;
    assert_eq!(rest["settings"]["max_end_prob"], json!(null));
}
