//! The teaching loop as a pendant drives it: cells, programs, routines, waypoints,
//! predictions, undo, completion, feedback and statistics.

use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::helpers::*;

#[tokio::test]
async fn full_teaching_loop_predicts_the_second_routine_from_the_first() {
    let app = spawn_app().await;
    let cell = app.create_cell("weld-cell-1").await;
    let program = app.create_program(cell, "bracket").await;

    // The first routine: nothing learned yet, so nothing is offered.
    let first = u_seam([0.0, 0.0, 0.0], 0.0);
    let (_, predictions) = app.teach_routine(program, &first).await;
    assert_eq!(predictions[0]["withheld"]["reason"], "empty_model");
    assert!(predictions.iter().all(|p| p["offered"] == false));

    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    assert_eq!(stats["model"]["routines"], 1);
    assert_eq!(stats["model"]["version"], 1);
    assert!(stats["model"]["states"].as_u64().unwrap() >= 2);

    // The same seam elsewhere and turned: once the window identifies it, the next waypoint
    // is offered, exactly.
    let second = u_seam([800.0, -300.0, 50.0], 1.0);
    let routine = app.create_routine(program).await;
    let mut offered = 0;
    for (i, p) in second.iter().enumerate() {
        let taught = app.append(routine, p).await;
        assert_eq!(taught["waypoint"]["seq"], i as i64 + 1);
        let prediction = &taught["prediction"];
        assert_eq!(prediction["after_waypoints"], i as i64 + 1);
        if prediction["offered"] == true {
            offered += 1;
            let next = &second[i + 1];
            let err = distance(&prediction["pose"], next);
            assert!(err < 1e-6, "waypoint {}: {err} mm", i + 2);
            assert!(prediction["id"].as_i64().is_some());
            assert!(prediction["phi"].as_f64().unwrap() >= 0.7);
        } else {
            assert!(prediction["id"].is_null());
            assert!(prediction["withheld"]["message"].as_str().unwrap().len() > 5);
        }
    }
    assert!(offered >= 4, "only {offered} predictions offered");

    // The routine as stored.
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    assert_eq!(detail["waypoints"].as_array().unwrap().len(), second.len());
    assert_eq!(detail["finished"], false);
    let finished = app.finish(routine).await;
    assert_eq!(finished["routine"]["finished"], true);
    assert_eq!(finished["model"]["version"], 2);
    let routines = app
        .get_ok(&format!("/v1/programs/{program}/routines"))
        .await;
    assert_eq!(routines.as_array().unwrap().len(), 2);
    assert_eq!(routines[1]["position"], 2);
    assert_eq!(routines[1]["finish_seq"], 2);
}

#[tokio::test]
async fn undo_rolls_the_prediction_back() {
    let app = spawn_app().await;
    let cell = app.create_cell("undo").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let copy = u_seam([100.0, 200.0, 0.0], 0.4);
    let routine = app.create_routine(program).await;
    let mut before = Vec::new();
    for p in &copy[..5] {
        before.push(app.append(routine, p).await["prediction"].clone());
    }
    // A wrong waypoint, then undo: the prediction is the one made before it.
    let wrong = app
        .append(routine, &pose([5000.0, 0.0, 0.0], [0.0, 0.0, 0.0]))
        .await;
    assert_ne!(wrong["prediction"]["pose"], before[4]["pose"]);
    let undone = app
        .delete(&format!("/v1/routines/{routine}/waypoints/last"))
        .await;
    let undone = expect(undone, StatusCode::OK).await;
    assert_eq!(undone["removed"]["seq"], 6);
    let mut a = undone["prediction"].clone();
    let mut b = before[4].clone();
    assert_eq!(a["offered"], true, "{a}");
    for v in [&mut a, &mut b] {
        v.as_object_mut().unwrap().remove("id");
    }
    assert_eq!(a, b);
    // The GET agrees, and teaching goes on as if the wrong waypoint never happened.
    let now = app
        .get_ok(&format!("/v1/routines/{routine}/prediction"))
        .await;
    assert_eq!(now["predictions"][0]["pose"], before[4]["pose"]);
    let next = app.append(routine, &copy[5]).await;
    assert!(distance(&next["prediction"]["pose"], &copy[6]) < 1e-6);

    // Undo down to nothing, then once more: 409.
    for _ in 0..6 {
        let r = app
            .delete(&format!("/v1/routines/{routine}/waypoints/last"))
            .await;
        expect(r, StatusCode::OK).await;
    }
    let r = app
        .delete(&format!("/v1/routines/{routine}/waypoints/last"))
        .await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
}

#[tokio::test]
async fn completion_predicts_the_next_k_waypoints() {
    let app = spawn_app().await;
    let cell = app.create_cell("complete").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let copy = u_seam([-400.0, 10.0, 30.0], -0.7);
    let routine = app.create_routine(program).await;
    for p in &copy[..4] {
        app.append(routine, p).await;
    }
    let set = app
        .get_ok(&format!("/v1/routines/{routine}/prediction?k=3"))
        .await;
    let predictions = set["predictions"].as_array().unwrap();
    assert_eq!(predictions.len(), 3);
    for (i, p) in predictions.iter().enumerate() {
        assert_eq!(p["offered"], true, "{p}");
        assert!(distance(&p["pose"], &copy[4 + i]) < 1e-6);
        assert_eq!(p["after_waypoints"], 4 + i as i64);
    }
    // Per-request overrides of φ_min. A second program whose seam turns the other way after
    // the same start leaves the model short of certainty about what follows (φ ≈ 0.68, below
    // the default φ_min = 0.7): a lower φ_min lets it pass that gate, φ_min = 1 does not.
    let r = app.delete(&format!("/v1/routines/{routine}")).await;
    expect(r, StatusCode::NO_CONTENT).await;
    let other = app.create_program(cell, "q").await;
    let mut turned = u_seam([0.0; 3], 0.0);
    for w in &mut turned[4..] {
        w["y"] = json!(-w["y"].as_f64().unwrap());
    }
    app.teach_routine(other, &turned).await;
    let routine = app.create_routine(other).await;
    for p in &copy[..4] {
        app.append(routine, p).await;
    }
    let at = |phi_min: &str| format!("/v1/routines/{routine}/prediction{phi_min}");
    let usual = app.get_ok(&at("")).await;
    let phi = usual["predictions"][0]["phi"].as_f64().unwrap();
    assert!(
        phi > 0.5 && phi < 0.7,
        "the setup needs 0.5 < φ < 0.7: φ = {phi}"
    );
    assert_eq!(
        usual["predictions"][0]["withheld"]["reason"],
        "low_confidence"
    );
    // With φ_min = 0.5 the φ gate passes (the next gate, on the spread of what followed,
    // still withholds it).
    let lenient = app.get_ok(&at("?phi_min=0.5")).await;
    assert_eq!(lenient["predictions"][0]["phi"], phi);
    assert_eq!(
        lenient["predictions"][0]["withheld"]["reason"],
        "wide_spread"
    );
    let strict = app.get_ok(&at("?phi_min=1.0")).await;
    let p = &strict["predictions"][0];
    assert_eq!(p["phi"], phi);
    assert_eq!(p["offered"], false);
    assert_eq!(p["withheld"]["reason"], "low_confidence");
    let r = app
        .get(&format!("/v1/routines/{routine}/prediction?k=0"))
        .await;
    expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
}

#[tokio::test]
async fn feedback_is_counted_in_the_cell_stats() {
    let app = spawn_app().await;
    let cell = app.create_cell("feedback").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let copy = u_seam([50.0, 50.0, 0.0], 0.2);
    let routine = app.create_routine(program).await;
    let mut ids = Vec::new();
    let mut poses = Vec::new();
    for p in &copy {
        let t = app.append(routine, p).await;
        if let Some(id) = t["prediction"]["id"].as_i64() {
            ids.push(id);
            poses.push(t["prediction"]["pose"].clone());
        }
    }
    assert!(ids.len() >= 3, "{} offered", ids.len());
    let fb = |id: i64| format!("/v1/predictions/{id}/feedback");
    let accepted = app
        .post_ok(
            &fb(ids[0]),
            &json!({"verdict": "accepted"}),
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(accepted["adjustment_mm"], 0.0);
    let mut adjusted_pose = poses[1].clone();
    adjusted_pose["x"] = json!(adjusted_pose["x"].as_f64().unwrap() + 3.0);
    adjusted_pose["z"] = json!(adjusted_pose["z"].as_f64().unwrap() - 4.0);
    let adjusted = app
        .post_ok(
            &fb(ids[1]),
            &json!({"verdict": "adjusted", "pose": adjusted_pose}),
            StatusCode::CREATED,
        )
        .await;
    assert!((adjusted["adjustment_mm"].as_f64().unwrap() - 5.0).abs() < 1e-9);
    app.post_ok(
        &fb(ids[2]),
        &json!({"verdict": "rejected"}),
        StatusCode::CREATED,
    )
    .await;

    // Once per prediction; `adjusted` needs the pose; unknown prediction is 404.
    let again = app.post(&fb(ids[0]), &json!({"verdict": "rejected"})).await;
    expect_error(again, StatusCode::CONFLICT, "conflict").await;
    assert!(ids.len() >= 4, "{} offered", ids.len());
    let r = app.post(&fb(ids[3]), &json!({"verdict": "adjusted"})).await;
    expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    let r = app
        .post(
            &fb(ids[3]),
            &json!({"verdict": "accepted", "pose": poses[0]}),
        )
        .await;
    expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    let r = app
        .post(&fb(999_999), &json!({"verdict": "accepted"}))
        .await;
    expect_error(r, StatusCode::NOT_FOUND, "not_found").await;

    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let f = &stats["feedback"];
    assert_eq!(f["offered"], ids.len() as i64);
    assert_eq!(f["accepted"], 1);
    assert_eq!(f["adjusted"], 1);
    assert_eq!(f["rejected"], 1);
    assert_eq!(f["pending"], ids.len() as i64 - 3);
    assert!((f["median_adjustment_mm"].as_f64().unwrap() - 5.0).abs() < 1e-9);
    assert!((f["acceptance"].as_f64().unwrap() - 2.0 / 3.0).abs() < 1e-12);

    // A GET of the same prediction refers to the same record (not counted twice): undo the
    // last waypoint so that a prediction is offered again.
    let r = app
        .delete(&format!("/v1/routines/{routine}/waypoints/last"))
        .await;
    let undone = expect(r, StatusCode::OK).await;
    assert_eq!(undone["prediction"]["offered"], true, "{undone}");
    let now = app
        .get_ok(&format!("/v1/routines/{routine}/prediction"))
        .await;
    let id = now["predictions"][0]["id"]
        .as_i64()
        .expect("an offered prediction");
    assert_eq!(undone["prediction"]["id"], id);
    let again = app
        .get_ok(&format!("/v1/routines/{routine}/prediction"))
        .await;
    assert_eq!(again["predictions"][0]["id"], id);
}

/// After an undo and the same waypoint taught again, the prediction is a new one: the old
/// one, judged already, is not handed out again (it was, matched on its pose alone, and the
/// operator's feedback was refused with 409).
#[tokio::test]
async fn a_prediction_after_undo_and_reteach_is_a_new_one() {
    let app = spawn_app().await;
    let cell = app.create_cell("reteach").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let copy = u_seam([50.0, 50.0, 0.0], 0.2);
    let routine = app.create_routine(program).await;
    for p in &copy[..4] {
        app.append(routine, p).await;
    }
    let first = app
        .get_ok(&format!("/v1/routines/{routine}/prediction"))
        .await;
    let first_id = first["predictions"][0]["id"].as_i64().expect("offered");
    let fb = |id: i64| format!("/v1/predictions/{id}/feedback");
    app.post_ok(
        &fb(first_id),
        &json!({"verdict": "rejected"}),
        StatusCode::CREATED,
    )
    .await;
    let r = app
        .delete(&format!("/v1/routines/{routine}/waypoints/last"))
        .await;
    expect(r, StatusCode::OK).await;
    let retaught = app.append(routine, &copy[3]).await;
    let again = app
        .get_ok(&format!("/v1/routines/{routine}/prediction"))
        .await;
    let p = &again["predictions"][0];
    assert_eq!(
        p["pose"], first["predictions"][0]["pose"],
        "same state, same pose"
    );
    let id = p["id"].as_i64().expect("offered");
    assert_ne!(id, first_id, "the judged prediction came back");
    assert_eq!(retaught["prediction"]["id"], id, "the append's own record");
    app.post_ok(
        &fb(id),
        &json!({"verdict": "accepted"}),
        StatusCode::CREATED,
    )
    .await;
}

/// Ids are never handed out twice: a routine deleted in one cell does not give its id to a
/// routine of another cell (which then answered 500 on every call, until a restart).
#[tokio::test]
async fn ids_of_deleted_resources_are_never_reused() {
    let app = spawn_app().await;
    let a = app.create_cell("a").await;
    let b = app.create_cell("b").await;
    let pa = app.create_program(a, "p").await;
    let pb = app.create_program(b, "p").await;
    let r = app.create_routine(pa).await;
    let taught = app.append(r, &u_seam([0.0; 3], 0.0)[0]).await;
    let waypoint = taught["waypoint"]["id"].as_i64().unwrap();
    let r2 = app.delete(&format!("/v1/routines/{r}")).await;
    expect(r2, StatusCode::NO_CONTENT).await;
    let other = app.create_routine(pb).await;
    assert_ne!(other, r, "a deleted routine's id was reused");
    let t = app.append(other, &u_seam([0.0; 3], 0.0)[0]).await;
    assert_ne!(t["waypoint"]["id"].as_i64().unwrap(), waypoint);
    assert_eq!(t["waypoint"]["seq"], 1);
    // The routine works in its cell: undo, predict, finish; the deleted one stays gone.
    let r3 = app
        .delete(&format!("/v1/routines/{other}/waypoints/last"))
        .await;
    expect(r3, StatusCode::OK).await;
    for p in &u_seam([0.0; 3], 0.0)[..3] {
        app.append(other, p).await;
    }
    app.get_ok(&format!("/v1/routines/{other}/prediction"))
        .await;
    app.finish(other).await;
    let gone = app.get(&format!("/v1/routines/{r}")).await;
    expect_error(gone, StatusCode::NOT_FOUND, "not_found").await;
    // Undo's deleted waypoint id is not reused either.
    let again = app.create_routine(pa).await;
    let w1 = app.append(again, &u_seam([0.0; 3], 0.0)[0]).await["waypoint"]["id"].clone();
    let r4 = app
        .delete(&format!("/v1/routines/{again}/waypoints/last"))
        .await;
    expect(r4, StatusCode::OK).await;
    let w2 = app.append(again, &u_seam([0.0; 3], 0.0)[0]).await["waypoint"]["id"].clone();
    assert_ne!(w1, w2);
}

#[tokio::test]
async fn one_routine_at_a_time_per_cell_and_finished_routines_take_no_more_teaching() {
    let app = spawn_app().await;
    let cell = app.create_cell("one-at-a-time").await;
    let program = app.create_program(cell, "p").await;
    let open = app.create_routine(program).await;
    let r = app
        .post(&format!("/v1/programs/{program}/routines"), &json!({}))
        .await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    // Another cell is not affected.
    let other = app.create_cell("other").await;
    let other_program = app.create_program(other, "p").await;
    app.create_routine(other_program).await;

    app.append(open, &pose([0.0; 3], [0.0; 3])).await;
    app.finish(open).await;
    let r = app
        .post(
            &format!("/v1/routines/{open}/waypoints"),
            &json!({"pose": pose([1.0, 0.0, 0.0], [0.0; 3])}),
        )
        .await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    for r in [
        app.post(&format!("/v1/routines/{open}/finish"), &json!({}))
            .await,
        app.delete(&format!("/v1/routines/{open}/waypoints/last"))
            .await,
        app.get(&format!("/v1/routines/{open}/prediction")).await,
    ] {
        expect_error(r, StatusCode::CONFLICT, "conflict").await;
    }
    // Deleting an open routine lets the next one start; the model forgets it.
    let scratch = app.create_routine(program).await;
    for p in u_seam([0.0; 3], 0.0) {
        app.append(scratch, &p).await;
    }
    let r = app.delete(&format!("/v1/routines/{scratch}")).await;
    expect(r, StatusCode::NO_CONTENT).await;
    let r = app.get(&format!("/v1/routines/{scratch}")).await;
    expect_error(r, StatusCode::NOT_FOUND, "not_found").await;
    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    assert_eq!(stats["model"]["observations"], 0);
    app.create_routine(program).await;
}

#[tokio::test]
async fn concurrent_appends_to_one_cell_are_serialised() {
    let app = spawn_app().await;
    let cell = app.create_cell("busy").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let routine = app.create_routine(program).await;
    let mut tasks = Vec::new();
    for i in 0..24 {
        let client = app.client.clone();
        let url = app.url(&format!("/v1/routines/{routine}/waypoints"));
        tasks.push(tokio::spawn(async move {
            let body = json!({"pose": pose([i as f64 * 10.0, 0.0, 0.0], [0.0; 3])});
            client.post(url).json(&body).send().await.unwrap().status()
        }));
    }
    for t in tasks {
        assert_eq!(t.await.unwrap(), StatusCode::CREATED);
    }
    let detail = app.get_ok(&format!("/v1/routines/{routine}")).await;
    let seqs: Vec<i64> = detail["waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["seq"].as_i64().unwrap())
        .collect();
    assert_eq!(seqs, (1..=24).collect::<Vec<_>>());
    // The model in memory is the one the database describes.
    let before = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let rebuilt = app.rebuild(cell).await;
    assert_eq!(before["model"], rebuilt);
}

#[tokio::test]
async fn health_and_metrics() {
    let app = spawn_app().await;
    let h = app.get_ok("/healthz").await;
    assert_eq!(h["status"], "ok");
    let cell = app.create_cell("metrics").await;
    let program = app.create_program(cell, "p").await;
    app.teach_routine(program, &u_seam([0.0; 3], 0.0)).await;
    let r = app.get("/metrics").await;
    assert_eq!(r.status(), StatusCode::OK);
    let text = r.text().await.unwrap();
    assert!(
        text.contains("route=\"/v1/routines/{routine_id}/waypoints\""),
        "{text}"
    );
    assert!(text.contains("nextpose_http_request_duration_seconds_bucket"));
    assert!(text.contains("reason=\"empty_model\""));
    // Request ids are set and returned.
    let r = app.get("/healthz").await;
    assert!(r.headers().contains_key("x-request-id"));
}

/// A joystick cell: its settings carry the operator's noise, "close enough" and a lower offer
/// threshold. The U seam is taught six times at other places with 5 mm of scatter (a fixed,
/// deterministic pattern per waypoint), then taught again: the experts, matching within the
/// tolerance widened by the noise (and the template expert aligning whole stretches), offer the
/// next waypoints, within the operator's tolerance of the one meant, although no two noisy
/// moves are alike within 1 mm.
#[tokio::test]
async fn a_joystick_cell_gets_noisy_repeats_offered_within_its_tolerance() {
    let app = spawn_app().await;
    let settings = json!({
        "noise": { "mm": 5.0, "rad": 0.01 },
        "tolerance": { "mm": 15.0, "rad": 0.1 },
        "offer_threshold": 0.5,
        "reach_policy": "flag"
    });
    let cell = app.create_cell_with("joystick", settings).await;
    let stored = app.get_ok(&format!("/v1/cells/{cell}")).await;
    assert_eq!(
        stored["settings"]["noise"],
        json!({ "mm": 5.0, "rad": 0.01 })
    );
    assert_eq!(
        stored["settings"]["tolerance"],
        json!({ "mm": 15.0, "rad": 0.1 })
    );
    assert_eq!(stored["settings"]["offer_threshold"], 0.5);

    // About 5 mm per axis of scatter: a fixed pseudo-random pattern, different per waypoint.
    let scatter = |poses: Vec<serde_json::Value>, k: f64| -> Vec<serde_json::Value> {
        poses
            .into_iter()
            .enumerate()
            .map(|(i, mut p)| {
                for (j, axis) in ["x", "y", "z"].iter().enumerate() {
                    let e = 7.0 * ((k * 12.9898 + i as f64 * 78.233 + j as f64 * 37.719).sin());
                    p[*axis] = json!(p[*axis].as_f64().unwrap() + e);
                }
                p
            })
            .collect()
    };
    let program = app.create_program(cell, "seams").await;
    for k in 0..6 {
        let f = f64::from(k);
        let seam = scatter(
            u_seam([300.0 + 15.0 * f, -40.0 + 10.0 * f, 250.0], 0.05 * f),
            f,
        );
        app.teach_routine(program, &seam).await;
    }
    let meant = u_seam([330.0, 20.0, 250.0], -0.1);
    let taught = scatter(meant.clone(), 11.0);
    let routine = app.create_routine(program).await;
    let (mut offered, mut within, mut errors) = (0, 0, Vec::new());
    for (i, p) in taught.iter().enumerate().take(meant.len() - 1) {
        let prediction = app.append(routine, p).await["prediction"].clone();
        if prediction["offered"] == true {
            offered += 1;
            let err = distance(&prediction["pose"], &meant[i + 1]);
            within += usize::from(err <= 15.0);
            errors.push((i + 2, err, prediction["expert"].clone()));
            assert!(prediction["p_useful"].as_f64().unwrap() >= 0.5);
        }
        if i == 4 {
            assert_eq!(prediction["offered"], true, "{prediction}");
            assert!(prediction["expert"].is_string(), "{prediction}");
        }
    }
    // More likely right than not, as the threshold says.
    assert!(offered >= 4, "only {offered} offered: {errors:?}");
    assert!(2 * within > offered, "{errors:?}");

    // What the cell was told is what it uses: nothing learned, the threshold fixed.
    let t = &app.get_ok(&format!("/v1/cells/{cell}/stats")).await["teaching"];
    assert_eq!(t["noise"], json!({ "mm": 5.0, "rad": 0.01 }));
    assert_eq!(t["tolerance"], json!({ "mm": 15.0, "rad": 0.1 }));
    assert_eq!(t["offer_threshold"], 0.5);
    for learned in ["noise_learned", "tolerance_learned", "threshold_steered"] {
        assert_eq!(t[learned], false, "{t}");
    }

    // A cell created with its arm only is told nothing: it learns noise and tolerance and
    // steers its threshold for 85 % of its offers right.
    let learning = app.create_cell("learning").await;
    let s = &app.get_ok(&format!("/v1/cells/{learning}")).await["settings"];
    assert_eq!(s["noise"], json!(null));
    assert_eq!(s["tolerance"], json!(null));
    assert_eq!(s["offer_threshold"], json!(null));
    assert_eq!(s["target_precision"], 0.85);
    let t = &app.get_ok(&format!("/v1/cells/{learning}/stats")).await["teaching"];
    assert_eq!(
        t["noise"],
        json!({ "mm": 0.0, "rad": 0.0 }),
        "nothing taught: {t}"
    );
    for learned in ["noise_learned", "tolerance_learned", "threshold_steered"] {
        assert_eq!(t[learned], true, "{t}");
    }
    // Taught the seams with independent errors of 5 mm per axis (the pattern above is
    // correlated from one routine to the next), it finds the scatter from the repeats and
    // widens what counts as right to match.
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let program = app.create_program(learning, "seams").await;
    for k in 0..6 {
        let f = f64::from(k);
        let mut seam = u_seam([300.0 + 15.0 * f, -40.0 + 10.0 * f, 250.0], 0.05 * f);
        for p in &mut seam {
            for axis in ["x", "y", "z"] {
                // Box–Muller: one standard normal from two uniforms.
                let (u, v): (f64, f64) = (rng.random_range(f64::EPSILON..1.0), rng.random());
                let e = 5.0 * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos();
                p[axis] = json!(p[axis].as_f64().unwrap() + e);
            }
        }
        app.teach_routine(program, &seam).await;
    }
    let t = &app.get_ok(&format!("/v1/cells/{learning}/stats")).await["teaching"];
    let noise = t["noise"]["mm"].as_f64().expect("noise.mm");
    assert!((3.5..=6.5).contains(&noise), "{t}");
    assert!(
        t["tolerance"]["mm"].as_f64().expect("tolerance.mm") > 2.0 * noise,
        "{t}"
    );

    // Bad values are refused by name, and the seed profile has no offer rule to set.
    for (settings, names) in [
        (json!({ "noise": { "mm": -1.0, "rad": 0.0 } }), "noise.mm"),
        (json!({ "noise": { "mm": 1.0, "rad": 2.0 } }), "noise"),
        (
            json!({ "tolerance": { "mm": 1.0, "rad": -0.1 } }),
            "tolerance.rad",
        ),
        (json!({ "offer_threshold": 1.5 }), "offer_threshold"),
        (json!({ "target_precision": 1.5 }), "target_precision"),
        (
            json!({ "profile": "seed", "offer_threshold": 0.5 }),
            "no offer rule",
        ),
    ] {
        let r = app
            .post("/v1/cells", &json!({ "name": "bad", "settings": settings }))
            .await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
        assert!(message.contains(names), "{message}");
    }
}

/// A calibration routine: one point recorded five times, a few millimetres apart. Its scatter
/// becomes the cell's noise (set, no longer learned), the tolerance follows it, the model's
/// version advances; bad routines are refused by name and change nothing.
#[tokio::test]
async fn a_calibration_routine_sets_the_cells_noise() {
    let app = spawn_app().await;
    let cell = app.create_cell("calibrated").await;
    let version = app.get_ok(&format!("/v1/cells/{cell}/stats")).await["model"]["version"].clone();
    let offsets = [
        [2.0, 0.0, -1.0],
        [-2.0, 1.0, 0.0],
        [0.0, -2.0, 1.0],
        [1.0, 2.0, -2.0],
        [-1.0, -1.0, 2.0],
    ];
    let poses: Vec<Value> = offsets
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let turn = 0.01 * (i as f64 - 2.0);
            pose([400.0 + o[0], o[1], 300.0 + o[2]], [turn, 3.0, 0.0])
        })
        .collect();
    let calibrated = app
        .post_ok(
            &format!("/v1/cells/{cell}/calibration"),
            &json!({ "poses": poses }),
            StatusCode::OK,
        )
        .await;
    let expected =
        nextpose::engine::Noise::from_scatter(&poses.iter().map(pose_of).collect::<Vec<_>>())
            .expect("a scatter");
    // The positions scatter 2 mm at most per axis: about 1.5 mm per axis.
    assert!((1.0..2.0).contains(&expected.mm), "{expected:?}");
    let noise = &calibrated["settings"]["noise"];
    assert!(
        (noise["mm"].as_f64().unwrap() - expected.mm).abs() < 1e-9,
        "{noise}"
    );
    assert!(
        (noise["rad"].as_f64().unwrap() - expected.rad).abs() < 1e-9,
        "{noise}"
    );
    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let t = &stats["teaching"];
    assert_eq!(t["noise_learned"], false, "{t}");
    assert_eq!(t["tolerance_learned"], true, "{t}");
    assert_eq!(t["noise"], *noise);
    assert!(
        t["tolerance"]["mm"].as_f64().unwrap() > 2.0 * expected.mm,
        "{t}"
    );
    assert_ne!(stats["model"]["version"], version);

    // Refused, naming what is wrong; the cell keeps its noise.
    let mut not_a_pose = poses.clone();
    not_a_pose[1]["qw"] = json!(0.0);
    not_a_pose[1]["qx"] = json!(0.0);
    not_a_pose[1]["qy"] = json!(0.0);
    not_a_pose[1]["qz"] = json!(0.0);
    for (body, names) in [
        (json!({ "poses": &poses[..2] }), "at least 3"),
        (json!({ "poses": not_a_pose }), "poses[1]"),
    ] {
        let r = app
            .post(&format!("/v1/cells/{cell}/calibration"), &body)
            .await;
        let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
        assert!(message.contains(names), "{message}");
    }
    let r = app
        .post("/v1/cells/99999/calibration", &json!({ "poses": poses }))
        .await;
    expect_error(r, StatusCode::NOT_FOUND, "not_found").await;
    let after = app.get_ok(&format!("/v1/cells/{cell}")).await;
    assert_eq!(after["settings"]["noise"], *noise);
}
