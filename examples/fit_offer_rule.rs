//! Fits the offer rule's logistic model of agreement (`engine::experts::agreement`, issue 48)
//! and reports it out of fold.
//!
//! Every program given is taught through the engine (default profile), each in a fresh cell;
//! at every waypoint after a routine's first, the candidates every expert proposes are grouped
//! by pose, and each group is labelled right when its pose is within 1 mm and 0.1 rad of the
//! waypoint then taught (the scoreboard's "useful"). A logistic regression (features
//! standardised, L2 penalty of weight 1 on the standardised weights, intercept free, Newton's
//! method to convergence) is fitted to every group, and once more per repository with that
//! repository left out, to score it: the report gives, per corpus, the precision and saving of
//! offering the highest-scoring group when it reaches each threshold, out of fold, and the
//! calibration by decile. Deterministic: the same files give the same weights, bit for bit.
//!
//! `cargo run --release --example fit_offer_rule -- ../shared/corpus/json ../shared/corpus2/json`
//! prints the report; `--write src/engine/experts/agreement_weights.rs` also writes the weights
//! fitted on every program.

use std::collections::BTreeMap;
use std::path::PathBuf;

use nalgebra::{DMatrix, DVector};
use nextpose::engine::experts::agreement::{FEATURES, NAMES, groups, sigmoid};
use nextpose::engine::experts::frames::Tolerance;
use nextpose::engine::{EngineConfig, Teacher};
use nextpose::replay::load_paths;

/// One group at one waypoint.
struct Row {
    corpus: String,
    repo: String,
    /// The waypoint (a key shared by the groups at it).
    waypoint: usize,
    /// The waypoint has two predecessors or more (the scoreboard's population).
    scored: bool,
    x: [f64; FEATURES],
    right: bool,
}

/// Every group at every waypoint; and per corpus the scored waypoints.
fn rows(paths: &[PathBuf]) -> anyhow::Result<(Vec<Row>, BTreeMap<String, usize>)> {
    let programs = load_paths(paths)?;
    let mut out = Vec::new();
    let mut population: BTreeMap<String, usize> = BTreeMap::new();
    let mut waypoint = 0;
    for p in &programs {
        let corpus = if p.source.to_string_lossy().contains("corpus2") {
            "corpus2"
        } else {
            "corpus"
        };
        let repo = p
            .repo
            .clone()
            .unwrap_or_else(|| p.name.split("__").next().unwrap_or("").to_string());
        let mut t = Teacher::new(EngineConfig::default())?;
        for r in &p.routines {
            for (n, w) in r.waypoints.iter().enumerate() {
                if n >= 2 {
                    *population.entry(corpus.to_string()).or_default() += 1;
                }
                if n >= 1 {
                    waypoint += 1;
                    let candidates = t.candidates_ahead();
                    let p_first: Vec<f64> = candidates
                        .iter()
                        .map(|c| t.calibration().p_useful(&c.evidence))
                        .collect();
                    for g in groups(candidates, &p_first, Tolerance::USEFUL) {
                        let lead = candidates[g.lead].pose;
                        out.push(Row {
                            corpus: corpus.to_string(),
                            repo: repo.clone(),
                            waypoint,
                            scored: n >= 2,
                            x: g.features.vector(),
                            right: lead.distance_to(w) <= 1.0 && lead.angle_to(w) <= 0.1,
                        });
                    }
                }
                t.teach(*w);
            }
            t.finish_routine();
        }
    }
    Ok((out, population))
}

/// A fitted model on the raw features: intercept and weights.
struct Model {
    intercept: f64,
    weights: [f64; FEATURES],
}

impl Model {
    fn p(&self, x: &[f64; FEATURES]) -> f64 {
        sigmoid(self.intercept + self.weights.iter().zip(x).map(|(w, v)| w * v).sum::<f64>())
    }
}

/// L2-penalised logistic regression on standardised features (see the module doc).
fn fit(rows: &[&Row]) -> anyhow::Result<Model> {
    let n = rows.len() as f64;
    let mut mean = [0.0; FEATURES];
    let mut sd = [0.0; FEATURES];
    for r in rows {
        for (m, v) in mean.iter_mut().zip(r.x) {
            *m += v / n;
        }
    }
    for r in rows {
        for ((s, v), m) in sd.iter_mut().zip(r.x).zip(mean) {
            *s += (v - m).powi(2) / n;
        }
    }
    let sd = sd.map(|v| if v > 0.0 { v.sqrt() } else { 1.0 });
    let k = FEATURES + 1;
    let x = DMatrix::from_fn(rows.len(), k, |i, j| {
        if j == 0 {
            1.0
        } else {
            (rows[i].x[j - 1] - mean[j - 1]) / sd[j - 1]
        }
    });
    let y = DVector::from_iterator(
        rows.len(),
        rows.iter().map(|r| f64::from(u8::from(r.right))),
    );
    let mut beta = DVector::zeros(k);
    for _ in 0..100 {
        let p = (&x * &beta).map(sigmoid);
        let mut gradient = x.transpose() * (&y - &p);
        let weights = p.map(|v| v * (1.0 - v));
        let mut weighted = x.clone();
        for (i, mut row) in weighted.row_iter_mut().enumerate() {
            row *= weights[i];
        }
        let mut hessian = x.transpose() * weighted;
        for j in 1..k {
            gradient[j] -= beta[j];
            hessian[(j, j)] += 1.0;
        }
        let step = hessian
            .cholesky()
            .ok_or_else(|| anyhow::anyhow!("the Hessian is not positive definite"))?
            .solve(&gradient);
        beta += &step;
        if step.amax() < 1e-10 {
            break;
        }
    }
    let mut weights = [0.0; FEATURES];
    let mut intercept = beta[0];
    for j in 0..FEATURES {
        weights[j] = beta[j + 1] / sd[j];
        intercept -= weights[j] * mean[j];
    }
    Ok(Model { intercept, weights })
}

fn main() -> anyhow::Result<()> {
    let mut paths = Vec::new();
    let mut write = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--write" {
            write = args.next().map(PathBuf::from);
        } else {
            paths.push(PathBuf::from(a));
        }
    }
    let (rows, population) = rows(&paths)?;
    // Out of fold: each repository scored by the model fitted without it.
    let mut repos: Vec<&str> = rows.iter().map(|r| r.repo.as_str()).collect();
    repos.sort_unstable();
    repos.dedup();
    let mut score = vec![0.0; rows.len()];
    for repo in &repos {
        let train: Vec<&Row> = rows.iter().filter(|r| r.repo != *repo).collect();
        let m = fit(&train)?;
        for (i, r) in rows.iter().enumerate() {
            if r.repo == *repo {
                score[i] = m.p(&r.x);
            }
        }
    }
    // The highest-scoring group at each scored waypoint.
    let mut best: BTreeMap<usize, (f64, bool, &str)> = BTreeMap::new();
    for (r, s) in rows.iter().zip(&score) {
        if r.scored && best.get(&r.waypoint).is_none_or(|b| *s > b.0) {
            best.insert(r.waypoint, (*s, r.right, r.corpus.as_str()));
        }
    }
    println!(
        "paths: {}; groups: {}; repositories: {}",
        paths.len(),
        rows.len(),
        repos.len()
    );
    println!("out of fold (each repository scored by the model fitted without it):");
    println!("corpus    threshold  offered  right  precision %  saved %");
    for (corpus, n) in &population {
        for t in [0.5, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9] {
            let offered: Vec<bool> = best
                .values()
                .filter(|b| b.2 == corpus && b.0 >= t)
                .map(|b| b.1)
                .collect();
            let right = offered.iter().filter(|r| **r).count() as f64;
            let o = offered.len() as f64;
            println!(
                "{corpus:<9} {t:>9.2}  {o:>7}  {right:>5}  {:>11.1}  {:>7.1}",
                100.0 * right / o.max(1.0),
                100.0 * (0.9 * right - 0.1 * (o - right)) / *n as f64
            );
        }
    }
    println!("calibration of the chosen group's probability, out of fold, by decile:");
    println!("corpus    decile      n  mean p  right %");
    for corpus in population.keys() {
        for d in 0..10 {
            let lo = f64::from(d) / 10.0;
            let hi = lo + 0.1;
            let at: Vec<_> = best
                .values()
                .filter(|b| b.2 == corpus && b.0 >= lo && (b.0 < hi || d == 9))
                .collect();
            if at.is_empty() {
                continue;
            }
            let m = at.len() as f64;
            println!(
                "{corpus:<9} {lo:>6.1}  {:>5}  {:>6.3}  {:>7.1}",
                at.len(),
                at.iter().map(|b| b.0).sum::<f64>() / m,
                100.0 * at.iter().filter(|b| b.1).count() as f64 / m
            );
        }
    }
    let all: Vec<&Row> = rows.iter().collect();
    let m = fit(&all)?;
    let mut text = String::from(
        "//! The offer rule's logistic model of agreement (read by `agreement::Scorer`, which checks\n\
         //! the length), fitted on the shared corpora by `examples/fit_offer_rule.rs` (its module doc\n\
         //! says how). Generated: do not edit by hand; run the example again with `--write` and\n\
         //! commit the result.\n\n",
    );
    text += &format!("pub const INTERCEPT: f64 = {:?};\n\n", m.intercept);
    text += &format!("pub const WEIGHTS: [f64; {FEATURES}] = [\n");
    for (name, w) in NAMES.iter().zip(m.weights) {
        text += &format!("    {w:?}, // {name}\n");
    }
    text += "];\n";
    if let Some(path) = write {
        std::fs::write(&path, &text)?;
        println!("wrote {}", path.display());
    } else {
        print!("{text}");
    }
    Ok(())
}
