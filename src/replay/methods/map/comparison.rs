//! The dissertation's comparison of its learner with MAP structure estimation (§4.4.1, Figure
//! 4.14), on a corpus: for the engine (Learn-HMM at the run's settings) and for [`MapMethod`] (the
//! same prediction over a MAP-merged model), the model size (states, edges, perplexity = mean
//! out-degree, mean over programs as the dissertation reports them), the wall-clock time of
//! learning and predicting every program, and, over a grid of confidence thresholds φ_min, the
//! offered and useful shares and the median errors of what is offered (headline population:
//! waypoints with ≥ 2 predecessors).
//!
//! Each method is replayed once at φ_min = 0 and its offered guesses are filtered by φ ≥ φ_min.
//! Under the `seed` profile φ is the only gate, so this is exactly a replay at each φ_min; under a
//! profile with more gates (or the experts' offer rule) it filters what those gates offered.
//!
//! Figures are given for the whole corpus and, when the programs name their repositories, for
//! the two halves docs/results/scoreboard.md uses (repositories sorted by name, case-blind; the first half of
//! them is A).

use std::fmt::Write as _;
use std::time::Instant;

use serde::Serialize;

use super::merge::MapSettings;
use super::method::MapMethod;
use crate::engine::{ConfigError, EngineConfig};
use crate::replay::corpus::Program;
use crate::replay::method::{Method, ModelSummary};
use crate::replay::methods::engine::EngineMethod;
use crate::replay::playback::{ProgramRecord, WaypointRecord, replay_program};
use crate::replay::score::metrics::{Accuracy, median};

/// Figure 4.14's confidence thresholds.
pub const PHI_GRID: [f64; 10] = [0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95];

/// The comparison: settings, the threshold grid and one block per group of programs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapComparison {
    pub profile: String,
    pub delta: f64,
    pub phi_grid: Vec<f64>,
    pub groups: Vec<Group>,
}

/// One group of programs (the corpus, half A, half B).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Group {
    pub name: String,
    pub programs: usize,
    /// `engine` then `map`.
    pub methods: Vec<Line>,
}

/// One method on one group.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Line {
    pub method: String,
    /// Model size after each program, mean over the group's programs.
    pub states_mean: Option<f64>,
    pub edges_mean: Option<f64>,
    pub perplexity_mean: Option<f64>,
    /// Learning and prediction of the group's programs (whole replays), seconds.
    pub seconds: f64,
    pub thresholds: Vec<Threshold>,
}

/// A method's figures at one confidence threshold.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Threshold {
    pub phi_min: f64,
    pub predictable: usize,
    pub offered: usize,
    pub offered_pct: Option<f64>,
    pub useful_pct: Option<f64>,
    pub precision_pct: Option<f64>,
    /// Pooled over the group's offered guesses.
    pub median_cart_mm: Option<f64>,
    pub median_angle_rad: Option<f64>,
    /// The dissertation's "average median error": the mean over programs of each program's median.
    pub mean_program_median_mm: Option<f64>,
}

/// Replays every program through the engine and the MAP learner at `config` (φ_min set to 0)
/// and computes the comparison over `grid`.
pub fn compare(
    programs: &[Program],
    profile: &str,
    config: &EngineConfig,
    grid: &[f64],
) -> Result<MapComparison, ConfigError> {
    let mut open = config.clone();
    open.predict.phi_min = 0.0;
    let mut methods: Vec<Box<dyn Method>> = vec![
        Box::new(EngineMethod::new(open.clone())?),
        Box::new(MapMethod::new(open, MapSettings::default())?),
    ];
    // runs[m][p]: method m's record of program p and its wall-clock seconds.
    let runs: Vec<Vec<(ProgramRecord, f64)>> = methods
        .iter_mut()
        .map(|m| {
            programs
                .iter()
                .map(|p| {
                    let start = Instant::now();
                    let record = replay_program(p, m.as_mut());
                    (record, start.elapsed().as_secs_f64())
                })
                .collect()
        })
        .collect();
    let names: Vec<String> = methods.iter().map(|m| m.name().to_string()).collect();
    let groups = groups(programs)
        .into_iter()
        .map(|(name, members)| Group {
            name,
            programs: members.len(),
            methods: names
                .iter()
                .zip(&runs)
                .map(|(method, runs)| {
                    let runs: Vec<&(ProgramRecord, f64)> =
                        members.iter().map(|&p| &runs[p]).collect();
                    line(method, &runs, grid)
                })
                .collect(),
        })
        .collect();
    Ok(MapComparison {
        profile: profile.to_string(),
        delta: config.delta,
        phi_grid: grid.to_vec(),
        groups,
    })
}

/// The corpus, then half A and half B when the programs name at least two repositories.
fn groups(programs: &[Program]) -> Vec<(String, Vec<usize>)> {
    let all: Vec<usize> = (0..programs.len()).collect();
    let mut out = vec![("corpus".to_string(), all)];
    let mut repos: Vec<String> = programs
        .iter()
        .filter_map(|p| p.repo.as_ref().map(|r| r.to_lowercase()))
        .collect();
    repos.sort();
    repos.dedup();
    if repos.len() >= 2 {
        let first_half = &repos[..repos.len().div_ceil(2)];
        let in_a = |p: &Program| {
            p.repo
                .as_ref()
                .map(|r| first_half.contains(&r.to_lowercase()))
        };
        for (name, want) in [("half A", true), ("half B", false)] {
            let members = (0..programs.len())
                .filter(|&i| in_a(&programs[i]) == Some(want))
                .collect();
            out.push((name.to_string(), members));
        }
    }
    out
}

fn line(method: &str, runs: &[&(ProgramRecord, f64)], grid: &[f64]) -> Line {
    let summaries: Vec<_> = runs.iter().filter_map(|(r, _)| r.summary).collect();
    let mean = |f: &dyn Fn(&ModelSummary) -> f64| {
        (!summaries.is_empty())
            .then(|| summaries.iter().map(f).sum::<f64>() / summaries.len() as f64)
    };
    Line {
        method: method.to_string(),
        states_mean: mean(&|s| s.states as f64),
        edges_mean: mean(&|s| s.edges as f64),
        perplexity_mean: mean(&|s| s.perplexity),
        seconds: runs.iter().map(|(_, s)| s).sum(),
        thresholds: grid
            .iter()
            .map(|&phi_min| threshold(runs, phi_min))
            .collect(),
    }
}

/// A record as a replay at `phi_min` would have made it: offered only when φ ≥ φ_min.
fn at(r: &WaypointRecord, phi_min: f64) -> WaypointRecord {
    WaypointRecord {
        offered: r.offered && r.phi.is_some_and(|phi| phi >= phi_min),
        ..r.clone()
    }
}

fn threshold(runs: &[&(ProgramRecord, f64)], phi_min: f64) -> Threshold {
    let gated = |r: &ProgramRecord| -> Vec<WaypointRecord> {
        r.waypoints
            .iter()
            .filter(|w| w.predecessors >= 2)
            .map(|w| at(w, phi_min))
            .collect()
    };
    let per_program: Vec<Vec<WaypointRecord>> = runs.iter().map(|(r, _)| gated(r)).collect();
    let pooled = Accuracy::of(per_program.iter().flatten());
    let medians: Vec<f64> = per_program
        .iter()
        .filter_map(|ws| {
            let cart: Vec<f64> = ws
                .iter()
                .filter(|w| w.offered)
                .filter_map(|w| w.cart_mm)
                .collect();
            median(&cart)
        })
        .collect();
    Threshold {
        phi_min,
        predictable: pooled.predictable,
        offered: pooled.offered,
        offered_pct: pooled.offered_pct,
        useful_pct: pooled.useful_pct,
        precision_pct: pooled.precision_pct,
        median_cart_mm: pooled.median_cart_mm,
        median_angle_rad: pooled.median_angle_rad,
        mean_program_median_mm: (!medians.is_empty())
            .then(|| medians.iter().sum::<f64>() / medians.len() as f64),
    }
}

fn num(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(|| "-".to_string(), |x| format!("{x:.decimals$}"))
}

impl MapComparison {
    /// The comparison as plain text: per group, the models and times, then the errors by φ_min.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "MAP structure estimation (map) vs Learn-HMM (engine), profile {}, delta {} \
             (seed 4.4.1, Figure 4.14); waypoints with >= 2 predecessors",
            self.profile, self.delta
        );
        for g in &self.groups {
            let _ = writeln!(out, "\n{} ({} programs)", g.name, g.programs);
            let _ = writeln!(
                out,
                "{:<8}  {:>14}  {:>13}  {:>10}  {:>8}",
                "method", "states/program", "edges/program", "perplexity", "time s"
            );
            for m in &g.methods {
                let _ = writeln!(
                    out,
                    "{:<8}  {:>14}  {:>13}  {:>10}  {:>8.2}",
                    m.method,
                    num(m.states_mean, 1),
                    num(m.edges_mean, 1),
                    num(m.perplexity_mean, 3),
                    m.seconds
                );
            }
            let _ = write!(out, "{:<7}", "phi_min");
            for m in &g.methods {
                let _ = write!(
                    out,
                    "  | {:<6} {:>9} {:>8} {:>10} {:>13} {:>10}",
                    m.method, "offered %", "useful %", "median mm", "mean med. mm", "median rad"
                );
            }
            let _ = writeln!(out);
            for (k, phi) in self.phi_grid.iter().enumerate() {
                let _ = write!(out, "{phi:<7.2}");
                for m in &g.methods {
                    let Some(t) = m.thresholds.get(k) else {
                        continue;
                    };
                    let _ = write!(
                        out,
                        "  | {:<6} {:>9} {:>8} {:>10} {:>13} {:>10}",
                        "",
                        num(t.offered_pct, 1),
                        num(t.useful_pct, 1),
                        num(t.median_cart_mm, 3),
                        num(t.mean_program_median_mm, 3),
                        num(t.median_angle_rad, 4)
                    );
                }
                let _ = writeln!(out);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(phi: Option<f64>, offered: bool) -> WaypointRecord {
        WaypointRecord {
            routine: 0,
            predecessors: 2,
            offered,
            cart_mm: offered.then_some(1.0),
            angle_rad: offered.then_some(0.0),
            travel_mm: 10.0,
            travel_rad: 0.0,
            confidence: phi,
            phi,
            psi: Some(1.0),
            assimilated: Some(1),
            micros: 1.0,
            candidate: None,
        }
    }

    #[test]
    fn a_threshold_keeps_the_offers_whose_phi_reaches_it() {
        assert!(at(&record(Some(0.8), true), 0.8).offered);
        assert!(!at(&record(Some(0.79), true), 0.8).offered);
        assert!(!at(&record(Some(0.9), false), 0.5).offered);
        assert!(!at(&record(None, true), 0.5).offered);
    }
}
