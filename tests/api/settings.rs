//! The settings the command line had and a cell lacked (the merge test, learning within the
//! routine, the misfit, spread and end-of-routine gates, recall) are a cell's settings: each
//! reads back as the profile's until set, is set, kept and reset like the others, and a bad value
//! is a 422 naming it that changes nothing.

use nextpose::api::settings::ADDED_LATER;
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::helpers::*;

/// The added settings of a cell, by name.
fn added(cell: &Value) -> Value {
    ADDED_LATER
        .iter()
        .map(|k| (k.to_string(), cell["settings"][k].clone()))
        .collect::<serde_json::Map<_, _>>()
        .into()
}

#[tokio::test]
async fn the_command_lines_overrides_are_settings_of_a_cell() {
    let app = spawn_app().await;
    // Left out: the profile's values, as the engine has them.
    let cell = app.create_cell("overrides").await;
    let path = format!("/v1/cells/{cell}");
    let default = app.get_ok(&path).await;
    assert_eq!(
        added(&default),
        json!({ "merge": "incremental", "learn_within_routine": true, "max_misfit": 1.0,
                "max_spread": 0.5, "max_end_prob": 0.5,
                "recall": { "max_cost": 0.1, "min_window": 2 } })
    );
    let seed = app
        .create_cell_with("seed overrides", json!({ "profile": "seed" }))
        .await;
    let seed = app.get_ok(&format!("/v1/cells/{seed}")).await;
    assert_eq!(
        added(&seed),
        json!({ "merge": "total", "learn_within_routine": false, "max_misfit": null,
                "max_spread": null, "max_end_prob": null, "recall": null })
    );

    // A bad value is a 422 naming the setting, and nothing changes.
    for (bad, field) in [
        (json!({ "max_misfit": -1.0 }), "max_misfit"),
        (json!({ "max_spread": -0.5 }), "max_spread"),
        (json!({ "max_end_prob": -2.0 }), "max_end_prob"),
        (
            json!({ "recall": { "max_cost": -1.0, "min_window": 2 } }),
            "recall",
        ),
        (json!({ "recall": { "max_cost": 0.1 } }), "recall"),
        (
            json!({ "recall": { "max_cost": 0.1, "min_window": 51 } }),
            "recall.min_window",
        ),
        (
            json!({ "recall": { "max_cost": 0.1, "min_window": 3.6e32 } }),
            "min_window",
        ),
        (json!({ "merge": "sideways" }), "merge"),
        (
            json!({ "learn_within_routine": "yes" }),
            "learn_within_routine",
        ),
    ] {
        let r = app.patch(&path, &json!({ "settings": bad })).await;
        let body = expect(r, StatusCode::UNPROCESSABLE_ENTITY).await;
        let message = body["error"]["message"].as_str().expect("message");
        assert!(message.contains(field), "{bad}: {message}");
    }
    assert_eq!(app.get_ok(&path).await, default);

    // Set: a gate turned off with null, another moved, recall and the learner changed.
    let set = json!({ "merge": "total", "learn_within_routine": false, "max_misfit": null,
                      "max_spread": 0.75, "max_end_prob": 0.5,
                      "recall": { "max_cost": 0.2, "min_window": 3 } });
    let changed = expect(
        app.patch(&path, &json!({ "settings": set })).await,
        StatusCode::OK,
    )
    .await;
    assert_eq!(added(&changed), set);
    assert_eq!(added(&app.get_ok(&path).await), set);
    // Another setting changed keeps them, null gate included.
    let other = expect(
        app.patch(&path, &json!({ "settings": { "delta": 0.6 } }))
            .await,
        StatusCode::OK,
    )
    .await;
    assert_eq!(other["settings"]["delta"], 0.6);
    assert_eq!(added(&other), set);
    // Recall off.
    let off = expect(
        app.patch(&path, &json!({ "settings": { "recall": null } }))
            .await,
        StatusCode::OK,
    )
    .await;
    assert_eq!(off["settings"]["recall"], Value::Null);
    assert_eq!(off["settings"]["max_spread"], 0.75);
    // A new profile brings its own.
    let reset = expect(
        app.patch(&path, &json!({ "settings": { "profile": "seed" } }))
            .await,
        StatusCode::OK,
    )
    .await;
    assert_eq!(added(&reset), added(&seed));
}

/// The settings reach the engine: a cell that learns only finished routines has learned nothing
/// from the routine it is being taught, where one that learns within the routine has.
#[tokio::test]
async fn learning_within_the_routine_is_the_cells_setting() {
    let app = spawn_app().await;
    let mut observed = Vec::new();
    for within in [true, false] {
        let cell = app
            .create_cell_with(
                &format!("within {within}"),
                json!({ "learn_within_routine": within }),
            )
            .await;
        let program = app.create_program(cell, "p").await;
        let routine = app.create_routine(program).await;
        for p in u_seam([400.0, 0.0, 300.0], 0.0) {
            app.append(routine, &p).await;
        }
        let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
        observed.push(
            stats["model"]["observations"]
                .as_u64()
                .expect("observations"),
        );
    }
    assert!(observed[0] > 0, "{observed:?}");
    assert_eq!(observed[1], 0, "{observed:?}");
}
