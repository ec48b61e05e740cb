//! Feedback that teaches the cell: a picky operator's verdicts tighten a zero-configuration
//! cell's tolerance, given in either order (judged, then recorded, as the pendant does; recorded,
//! then judged, as the simulation does); an undo takes a verdict back with its waypoint; late
//! feedback is counted and teaches nothing; and a rebuild or a restart gives the same cell.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::helpers::*;

/// A standard normal draw (Box–Muller).
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let (u, v): (f64, f64) = (rng.random_range(f64::EPSILON..1.0), rng.random());
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// `meant` as an operator with `sigma` mm per axis places it.
fn placed(meant: &Value, sigma: f64, rng: &mut ChaCha8Rng) -> Value {
    let mut p = meant.clone();
    for axis in ["x", "y", "z"] {
        p[axis] = json!(p[axis].as_f64().expect(axis) + sigma * gauss(rng));
    }
    p
}

/// What the operator does with a suggestion and where they record.
struct Step {
    pose: Value,
    verdict: Option<Value>,
}

#[tokio::test]
async fn a_picky_operators_verdicts_tighten_the_tolerance_and_a_rebuild_agrees() {
    const SIGMA: f64 = 8.0;
    // The simulated operator accepts within 2.07 σ; this one within half of that.
    const PICKY: f64 = 0.5 * 2.0665 * SIGMA;
    let dir = tempfile::tempdir().expect("temp dir");
    let app = spawn_on(test_database(dir.path()).await).await;
    let cell = app.create_cell("picky").await;
    let program = app.create_program(cell, "seams").await;
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let fb = |id: i64| format!("/v1/predictions/{id}/feedback");
    let (mut judged, mut adjusted, mut undone) = (0, 0, 0);
    // One verdict held back, given two waypoints later: (prediction, verdict, waypoints to go).
    let mut held: Option<(i64, Value, usize)> = None;
    let mut late_checked = false;
    for k in 0..12 {
        let f = f64::from(k);
        let meant = u_seam(
            [300.0 + 25.0 * (f * 1.7).sin(), -40.0 + 10.0 * f, 250.0],
            0.3 * (f * 0.9).cos(),
        );
        let routine = app.create_routine(program).await;
        let mut offer: Option<Value> = None;
        for m in &meant {
            let by_hand = placed(m, SIGMA, &mut rng);
            let step = match &offer {
                Some(p) if distance(&p["pose"], m) <= PICKY => Step {
                    pose: p["pose"].clone(),
                    verdict: Some(json!({ "verdict": "accepted" })),
                },
                Some(_) => Step {
                    pose: by_hand.clone(),
                    verdict: Some(json!({ "verdict": "adjusted", "pose": by_hand })),
                },
                None => Step {
                    pose: by_hand,
                    verdict: None,
                },
            };
            // Odd routines judge first (the pendant), even ones record first (the simulation).
            let mut id = offer.as_ref().and_then(|p| p["id"].as_i64());
            if let (Some(held_id), Some(v), None, true) = (id, &step.verdict, &held, k >= 6) {
                held = Some((held_id, v.clone(), 2));
                id = None;
            }
            let judge_first = k % 2 == 1;
            if let (Some(id), Some(v), true) = (id, &step.verdict, judge_first) {
                app.post_ok(&fb(id), v, StatusCode::CREATED).await;
            }
            let mut taught = app.append(routine, &step.pose).await;
            if let (Some(id), Some(v), false) = (id, &step.verdict, judge_first) {
                app.post_ok(&fb(id), v, StatusCode::CREATED).await;
            }
            if let Some(v) = step.verdict.as_ref().filter(|_| id.is_some()) {
                judged += 1;
                adjusted += usize::from(v["verdict"] == "adjusted");
                // Now and then the operator undoes an adjusted waypoint and records it again:
                // the verdict goes and comes back with it.
                if v["verdict"] == "adjusted" && undone < 6 && rng.random_bool(0.3) {
                    let r = app
                        .delete(&format!("/v1/routines/{routine}/waypoints/last"))
                        .await;
                    expect(r, StatusCode::OK).await;
                    taught = app.append(routine, &step.pose).await;
                    undone += 1;
                }
            }
            offer = (taught["prediction"]["offered"] == true).then(|| taught["prediction"].clone());
            // The held verdict, given two waypoints late: counted, and the cell and its
            // prediction are as before.
            if let Some((held_id, v, 0)) = &held
                && !late_checked
            {
                let before = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
                let next = format!("/v1/routines/{routine}/prediction");
                let prediction = app.get_ok(&next).await;
                app.post_ok(&fb(*held_id), v, StatusCode::CREATED).await;
                let after = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
                assert_eq!(before["teaching"], after["teaching"]);
                let judged_before: i64 = ["accepted", "adjusted", "rejected"]
                    .iter()
                    .map(|k| before["feedback"][k].as_i64().expect(k))
                    .sum();
                let judged_after: i64 = ["accepted", "adjusted", "rejected"]
                    .iter()
                    .map(|k| after["feedback"][k].as_i64().expect(k))
                    .sum();
                assert_eq!(judged_after, judged_before + 1);
                assert_eq!(app.get_ok(&next).await, prediction);
                adjusted += usize::from(v["verdict"] == "adjusted");
                late_checked = true;
            }
            if let Some((_, _, to_go)) = held.as_mut() {
                *to_go = to_go.saturating_sub(1);
            }
        }
        if let Some(p) = &offer {
            // Offered after the routine's last waypoint: dismissed.
            let id = p["id"].as_i64().expect("id");
            app.post_ok(
                &fb(id),
                &json!({ "verdict": "rejected" }),
                StatusCode::CREATED,
            )
            .await;
        }
        app.finish(routine).await;
    }
    assert!(judged >= 15, "{judged} judged");
    assert!(adjusted >= 5, "{adjusted} adjusted");
    assert!(undone >= 1, "{undone} undone");
    assert!(late_checked, "no verdict held back");

    // The verdicts tightened the tolerance the noise implies.
    let stats = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let t = &stats["teaching"];
    let noise = t["noise"]["mm"].as_f64().expect("noise");
    let tolerance = t["tolerance"]["mm"].as_f64().expect("tolerance");
    assert!(noise > 4.0, "{t}");
    assert_eq!(t["tolerance_learned"], true, "{t}");
    assert!(tolerance < 0.85 * 2.0665 * noise, "{t}");
    assert!(tolerance >= noise, "{t}");
    assert_eq!(stats["feedback"]["adjusted"], adjusted as i64, "{stats}");

    // A rebuild from the database finds the model in memory in step with it, and a restart
    // gives the same cell and the same prediction.
    app.rebuild(cell).await;
    let metrics = app.get("/metrics").await.text().await.expect("metrics");
    assert_eq!(
        sample(&metrics, "nextpose_model_divergences_total"),
        Some(0.0)
    );
    let app = app.restart().await;
    let again = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    assert_eq!(again["teaching"], stats["teaching"]);
    assert_eq!(again["model"], stats["model"]);
}
