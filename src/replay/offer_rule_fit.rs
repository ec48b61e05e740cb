//! The fit of the offer rule's model of agreement ([`crate::engine::experts::agreement`], issue
//! 48), and its report out of fold.
//!
//! Every program given is taught through the engine (default profile), each in a fresh cell; at
//! every waypoint after a routine's first, the candidates every expert proposes are grouped by
//! pose, and each group is labelled right when its pose is within 1 mm and 0.1 rad of the
//! waypoint then taught (the scoreboard's "useful"). A logistic regression (features
//! standardised, an L2 penalty of weight 1 on the standardised weights, the intercept free,
//! Newton's method to convergence) is fitted to every group, and once more per repository with
//! that repository left out, to score it. From those out-of-fold scores come the precision of
//! offering the best group from each threshold ([`THRESHOLDS`], pooled over every program: the
//! table the engine reads a cell's target in) and the report per set of programs. Deterministic:
//! the same programs give the same file, bit for bit
//! ([`OfferRuleFit::weights_file`], committed as `src/engine/experts/agreement_weights.rs`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{DMatrix, DVector};

use crate::engine::OfferRule;
use crate::engine::experts::agreement::{self, FEATURES, NAMES, groups, sigmoid};
use crate::engine::experts::calibration::Count;
use crate::engine::experts::frames::Tolerance;
use crate::engine::{ConfigError, EngineConfig, Teacher};
use crate::program::Program;

/// The thresholds the precision table holds.
pub const THRESHOLDS: [f64; 10] = [0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95];

/// What can stop a fit.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(
        "the Hessian of the fit is not positive definite (too few groups, or a constant feature)"
    )]
    Singular,
    #[error("no group to fit: the programs gave no candidate")]
    Empty,
}

/// One group at one waypoint.
#[derive(Debug, Clone)]
struct Row {
    /// The program's index among those given.
    program: usize,
    /// The set of programs (the folder above the program's `json` folder, e.g. `corpus2`).
    set: String,
    repo: String,
    /// The waypoint (a key shared by the groups at it), in teaching order.
    waypoint: usize,
    /// The waypoint has two predecessors or more in its routine (the scoreboard's population).
    scored: bool,
    x: [f64; FEATURES],
    right: bool,
}

/// A logistic model on the raw features.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Model {
    pub intercept: f64,
    pub weights: [f64; FEATURES],
}

impl Model {
    fn p(&self, x: &[f64; FEATURES]) -> f64 {
        sigmoid(self.intercept + self.weights.iter().zip(x).map(|(w, v)| w * v).sum::<f64>())
    }
}

/// The best group at one waypoint, scored out of fold.
#[derive(Debug, Clone)]
pub struct Offerable {
    pub program: usize,
    /// The waypoint has two predecessors or more in its routine (the scoreboard's population).
    pub scored: bool,
    pub set: String,
    pub repo: String,
    /// The probability the model fitted without this repository gave the group.
    pub p: f64,
    pub right: bool,
}

/// A fit and its out-of-fold evidence.
#[derive(Debug, Clone)]
pub struct OfferRuleFit {
    /// Fitted on every program.
    pub model: Model,
    /// Per threshold of [`THRESHOLDS`]: the share of the best groups from it that were right,
    /// out of fold, pooled over every program.
    pub precision_from: Vec<(f64, f64)>,
    /// The best group at every waypoint with candidates, in teaching order, out of fold.
    pub best: Vec<Offerable>,
    /// Scored waypoints per set (with or without a candidate).
    pub population: BTreeMap<String, usize>,
    pub groups: usize,
    pub repositories: usize,
}

/// The set a program belongs to: the folder above its `json` folder (the corpus's layout), or
/// its folder.
fn set_of(source: &Path) -> String {
    let folder = source.parent();
    let above = folder
        .filter(|f| f.file_name().is_some_and(|n| n == "json"))
        .and_then(Path::parent);
    above
        .or(folder)
        .and_then(Path::file_name)
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
}

/// The repository of a program: its file's, or the first part of its name.
fn repo_of(p: &Program) -> String {
    p.repo
        .clone()
        .unwrap_or_else(|| p.name.split("__").next().unwrap_or("").to_string())
}

/// Every group at every waypoint of `programs`; and per set the scored waypoints.
fn rows(programs: &[Program]) -> Result<(Vec<Row>, BTreeMap<String, usize>), FitError> {
    let mut out = Vec::new();
    let mut population: BTreeMap<String, usize> = BTreeMap::new();
    let mut waypoint = 0;
    for (program, p) in programs.iter().enumerate() {
        let set = set_of(&p.source);
        let repo = repo_of(p);
        let mut t = Teacher::new(EngineConfig::default())?;
        for r in &p.routines {
            for (n, w) in r.waypoints.iter().enumerate() {
                if n >= 2 {
                    *population.entry(set.clone()).or_default() += 1;
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
                            program,
                            set: set.clone(),
                            repo: repo.clone(),
                            waypoint,
                            scored: n >= 2,
                            x: g.features.vector(),
                            right: lead.distance_to(w) <= Tolerance::USEFUL.mm
                                && lead.angle_to(w) <= Tolerance::USEFUL.rad,
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

/// L2-penalised logistic regression on standardised features (see the module doc).
fn fit(rows: &[&Row]) -> Result<Model, FitError> {
    if rows.is_empty() {
        return Err(FitError::Empty);
    }
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
            .ok_or(FitError::Singular)?
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

/// Right and offered among the scored waypoints of `best` from threshold `t` (of those `keep`
/// keeps).
fn offered_from(best: &[Offerable], t: f64, keep: impl Fn(&Offerable) -> bool) -> (usize, usize) {
    let from: Vec<&Offerable> = best
        .iter()
        .filter(|b| b.scored && keep(b) && b.p >= t)
        .collect();
    (from.iter().filter(|b| b.right).count(), from.len())
}

impl OfferRuleFit {
    /// Fits the model on `programs` and scores each repository out of fold (module doc).
    pub fn new(programs: &[Program]) -> Result<OfferRuleFit, FitError> {
        let (rows, population) = rows(programs)?;
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
        // The highest-scoring group at each waypoint (the first of equals).
        let mut best: BTreeMap<usize, Offerable> = BTreeMap::new();
        for (r, s) in rows.iter().zip(&score) {
            if best.get(&r.waypoint).is_none_or(|b| *s > b.p) {
                let o = Offerable {
                    program: r.program,
                    scored: r.scored,
                    set: r.set.clone(),
                    repo: r.repo.clone(),
                    p: *s,
                    right: r.right,
                };
                best.insert(r.waypoint, o);
            }
        }
        let best: Vec<Offerable> = best.into_values().collect();
        let precision_from = THRESHOLDS
            .iter()
            .map(|&t| {
                let (right, offered) = offered_from(&best, t, |_| true);
                (t, right as f64 / offered.max(1) as f64)
            })
            .collect();
        let all: Vec<&Row> = rows.iter().collect();
        Ok(OfferRuleFit {
            model: fit(&all)?,
            precision_from,
            best,
            population,
            groups: rows.len(),
            repositories: repos.len(),
        })
    }

    /// The whole rule out of fold, per set: each program taught in a fresh cell that offers the
    /// best group from its earned threshold for `target` ([`agreement::earned`] over this fit's
    /// own [`OfferRuleFit::precision_from`]), its record counted as the engine counts it. Right
    /// and offered at the scored waypoints.
    pub fn rule(&self, target: f64) -> BTreeMap<String, (usize, usize)> {
        let own = self
            .precision_from
            .iter()
            .find(|(_, precision)| *precision >= target)
            .map_or(1.0, |(t, _)| *t);
        let mut out: BTreeMap<String, (usize, usize)> = BTreeMap::new();
        let mut record = Count::default();
        let mut program = None;
        for b in &self.best {
            if program != Some(b.program) {
                program = Some(b.program);
                record = Count::default();
            }
            let offered = b.p >= agreement::earned(&record, own);
            if b.scored && offered {
                let e = out.entry(b.set.clone()).or_default();
                e.0 += usize::from(b.right);
                e.1 += 1;
            }
            if b.p >= own {
                record.add(f64::from(u8::from(b.right)));
            }
        }
        out
    }

    /// The report: per set, what offering the best group from each threshold gives, and the
    /// calibration of its probability by decile, out of fold.
    pub fn report(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "groups: {}; repositories: {} (each scored by the model fitted without it)",
            self.groups, self.repositories
        );
        let _ = writeln!(
            s,
            "set       threshold  offered  right  precision %  saved %"
        );
        for (set, n) in &self.population {
            for t in THRESHOLDS {
                let (right, offered) = offered_from(&self.best, t, |b| &b.set == set);
                let (r, o) = (right as f64, offered as f64);
                let _ = writeln!(
                    s,
                    "{set:<9} {t:>9.2}  {offered:>7}  {right:>5}  {:>11.1}  {:>7.1}",
                    100.0 * r / o.max(1.0),
                    100.0 * (0.9 * r - 0.1 * (o - r)) / (*n).max(1) as f64
                );
            }
        }
        let target = OfferRule::TARGET;
        let _ = writeln!(
            s,
            "the rule (earned threshold, cautious start) at its default target {target}:"
        );
        let _ = writeln!(s, "set       offered  right  precision %  saved %");
        for (set, (right, offered)) in self.rule(target) {
            let (r, o) = (right as f64, offered as f64);
            let n = self.population.get(&set).copied().unwrap_or(0).max(1) as f64;
            let _ = writeln!(
                s,
                "{set:<9} {offered:>7}  {right:>5}  {:>11.1}  {:>7.1}",
                100.0 * r / o.max(1.0),
                100.0 * (0.9 * r - 0.1 * (o - r)) / n
            );
        }
        let _ = writeln!(s, "calibration of the best group's probability, by decile:");
        let _ = writeln!(s, "set       decile      n  mean p  right %");
        for set in self.population.keys() {
            for d in 0..10 {
                let lo = f64::from(d) / 10.0;
                let at: Vec<&Offerable> = self
                    .best
                    .iter()
                    .filter(|b| {
                        b.scored && &b.set == set && b.p >= lo && (b.p < lo + 0.1 || d == 9)
                    })
                    .collect();
                if at.is_empty() {
                    continue;
                }
                let m = at.len() as f64;
                let _ = writeln!(
                    s,
                    "{set:<9} {lo:>6.1}  {:>5}  {:>6.3}  {:>7.1}",
                    at.len(),
                    at.iter().map(|b| b.p).sum::<f64>() / m,
                    100.0 * at.iter().filter(|b| b.right).count() as f64 / m
                );
            }
        }
        s
    }

    /// The weights file the engine reads (`src/engine/experts/agreement_weights.rs`).
    pub fn weights_file(&self) -> String {
        let mut text = String::from(
            "//! The offer rule's logistic model of agreement (read by `agreement::Scorer`, which checks\n\
             //! the length) and the precision of its offers from each threshold, out of fold, fitted on\n\
             //! the shared corpora by `cargo run --release --example fit_offer_rule -- ../shared/corpus/json\n\
             //! ../shared/corpus2/json --write src/engine/experts/agreement_weights.rs`\n\
             //! (`replay::offer_rule_fit`). Generated: do not edit by hand; a corpus test checks it.\n\n",
        );
        let m = &self.model;
        let _ = writeln!(text, "pub const INTERCEPT: f64 = {:?};\n", m.intercept);
        let _ = writeln!(text, "pub const WEIGHTS: [f64; {FEATURES}] = [");
        // Laid out as rustfmt lays it out: the comments aligned after the longest number.
        let numbers = m.weights.map(|w| format!("{w:?},"));
        let width = numbers.iter().map(String::len).max().unwrap_or(0);
        for (name, w) in NAMES.iter().zip(numbers) {
            let _ = writeln!(text, "    {w:<width$} // {name}");
        }
        text += "];\n\n";
        let _ = writeln!(
            text,
            "/// (threshold, share of the offers from it that were right), out of fold."
        );
        let _ = writeln!(
            text,
            "pub const PRECISION_FROM: [(f64, f64); {}] = [",
            self.precision_from.len()
        );
        for (t, p) in &self.precision_from {
            let _ = writeln!(text, "    ({t:?}, {p:?}),");
        }
        text += "];\n";
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_program_belongs_to_the_set_above_its_json_folder() {
        let set = |p: &str| set_of(Path::new(p));
        assert_eq!(set("../shared/corpus2/json/a__b.json"), "corpus2");
        assert_eq!(set("/x/corpus/json/a.json"), "corpus");
        assert_eq!(set("/x/programs/a.json"), "programs");
    }
}
