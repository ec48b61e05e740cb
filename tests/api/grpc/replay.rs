//! A replay through gRPC is the REST replay: the same scoreboard, oracle bounds, calibration
//! and configuration, for uploaded files and for a cell's stored programs.

use nextpose::grpc::pb;
use reqwest::StatusCode;
use serde_json::{Value, json};

use super::client::{client, pb_files};
use crate::helpers::*;
use crate::import::upload;

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
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
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
    app.import(cell, &json!({ "files": files, "learn": false }))
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
