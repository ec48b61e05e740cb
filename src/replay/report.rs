//! The replay report: every method on every program, as JSON (a stable interface for scripts
//! and for comparing runs) and as plain text tables (for people).
//!
//! JSON shape:
//!
//! ```text
//! { "config":   { ...EngineConfig fields..., "profile", "nearest_seq_gate", "useful_max_mm", ... },
//!   "totals":   { "<method>": { ...Scores... }, ..., "oracle_tool": { ...Scores... }, ... },
//!   "oracles":  { "meaning": ..., "useful_max_mm", "useful_max_rad",
//!                 "kinds": [ { "name": "oracle_tool", "candidates": ..., "covered", "share_pct", ... } ] },
//!   "calibration": { "<method>": { "meaning", "predictable", "candidates", "bins": [ { "from", "to",
//!                 "candidates", "useful", "mean_p_useful", "observed", "gap", "within_target" } ],
//!                 "ece", "max_abs_gap", "meets_target", "spearman_p_err", "as_offered",
//!                 "risk_coverage": [ { "threshold", "offered", "offered_pct", "precision_pct", ... } ],
//!                 "threshold_for_target_precision": { "target_precision_pct", "point" } } },
//!   "programs": [ { "program": name, "language": ..., "methods": { "<method>": { ...Scores... } } } ] }
//! ```
//!
//! Methods appear in the order they were run (engine first), in JSON objects and tables alike.
//!
//! `oracles` and the `oracle_*` entries are there only when the report was asked for them
//! ([`Report::add_oracles`]; `nextpose replay` does): they are bounds, not methods — an oracle
//! sees the true next waypoint and "offers" exactly where some candidate of its kind from the
//! program's history is within the useful tolerance (see [`super::score::oracle`]). In `totals` and
//! per program they follow every method, as a perfect selector: `offered = useful`, precision
//! 100 %, `useful_pct` the share covered, `saved_pct` the most a method drawing only on those
//! candidates could save. [`Report::totals_table`] lists them in a table of their own.
//!
//! `calibration` is there for the methods that give each candidate a calibrated probability
//! (the engine under the experts' offer rule, whose candidates carry `p_useful`): the
//! reliability table by decile, the expected calibration error and the risk–coverage curve
//! ([`super::score::reliability`]). Absent when no method has one (the seed profile).
//!
//! [`scoreboard`] is the one scoreboard `nextpose replay` and the service's replay both
//! produce: the engine, every baseline, the oracles and the calibration.

use std::path::PathBuf;

use serde::ser::SerializeMap;
use serde::{Serialize, Serializer};

use thiserror::Error;

use crate::engine::{ConfigError, EngineConfig};
use crate::kinematics::KinematicsError;

use super::corpus::Program;
use super::method::Method;
use super::methods::{EngineMethod, baselines};
use super::placements::{CacheUse, PlacementCache};
use super::playback::{ProgramRecord, USEFUL_MAX_MM, USEFUL_MAX_RAD, replay_program};
use super::score::matched::{AtPrecision, at_precision};
use super::score::metrics::{Scores, saved_pct};
use super::score::oracle::{ORACLES, is_oracle, oracle_records};
use super::score::reach::{ReachRecord, ReachRecorder, reach_figures};
use super::score::reliability::Calibration;
use super::table::{Table, fmt};
use crate::engine::Pose;
use crate::kinematics::LayoutError;
use crate::kinematics::placement::{PlacedArm, ProgramArm, ReachCheck, ReachSetup};

/// The settings a report was produced with.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunConfig {
    /// Profile the engine configuration started from (before command-line overrides).
    pub profile: String,
    #[serde(flatten)]
    pub engine: EngineConfig,
    /// Gate of the gated nearest-sequence baselines (mean squared Mahalanobis distance per move).
    pub nearest_seq_gate: f64,
    pub useful_max_mm: f64,
    pub useful_max_rad: f64,
    /// The arm whose reachability of the guesses is reported (`null`: not checked).
    pub reachability: Option<ReachSetup>,
    /// A directory keeping the programs' arm placements between runs
    /// ([`super::placements`]); none: searched on every run. Not part of the report: the
    /// figures are the same with it.
    #[serde(skip)]
    pub placement_cache: Option<PathBuf>,
}

impl RunConfig {
    pub fn new(profile: &str, engine: EngineConfig, nearest_seq_gate: f64) -> RunConfig {
        RunConfig {
            profile: profile.to_string(),
            engine,
            nearest_seq_gate,
            useful_max_mm: USEFUL_MAX_MM,
            useful_max_rad: USEFUL_MAX_RAD,
            reachability: Some(ReachSetup::default()),
            placement_cache: None,
        }
    }
}

/// Something per method, by method name in run order (serialised as a JSON object in that
/// order).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ByMethod<T>(pub Vec<(String, T)>);

impl<T> ByMethod<T> {
    pub fn get(&self, method: &str) -> Option<&T> {
        self.0.iter().find(|(m, _)| m == method).map(|(_, x)| x)
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl<T: Serialize> Serialize for ByMethod<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (name, x) in &self.0 {
            map.serialize_entry(name, x)?;
        }
        map.end()
    }
}

/// Scores by method name, in run order.
pub type MethodMetrics = ByMethod<Scores>;

/// Calibration sections by method name, in run order.
pub type Calibrations = ByMethod<Calibration>;

/// One program's line in the report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProgramReport {
    pub program: String,
    pub language: String,
    /// The arm of the reach figures, where it stands and how many taught waypoints it reaches
    /// (`null`: no arm for the program, or reach not checked).
    pub arm: Option<ProgramArm>,
    pub methods: MethodMetrics,
}

/// Result of replaying a set of programs through a set of methods.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    pub config: RunConfig,
    /// Methods in run order, then (after [`Report::add_oracles`]) the `oracle_*` bounds.
    pub totals: MethodMetrics,
    /// What the `oracle_*` entries mean, and their pooled shares; absent (not `null`) when the
    /// report has none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub oracles: Option<OracleSection>,
    /// The calibration of each method whose candidates carry `p_useful` (the engine with the
    /// experts' offer rule), by name in run order; absent when there is none.
    #[serde(skip_serializing_if = "Calibrations::is_empty")]
    pub calibration: Calibrations,
    pub programs: Vec<ProgramReport>,
    /// Each other method offering only its most confident guesses, at the cut that saves most
    /// with the engine's precision or better ([`super::score::matched`]), most saved first;
    /// absent without an engine or where no method reaches its precision.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub at_engine_precision: Vec<AtPrecision>,
    /// How the arms' placements were found with a cache ([`RunConfig::placement_cache`]);
    /// none without one. Not part of the report's JSON: the figures are the same either way.
    #[serde(skip)]
    pub placements: Option<CacheUse>,
}

/// Why [`scoreboard`] could not be produced.
#[derive(Debug, Error)]
pub enum ScoreboardError {
    #[error("invalid engine settings: {0}")]
    Settings(#[from] ConfigError),
    #[error(transparent)]
    Arm(#[from] ReachError),
}

/// Why the reach figures of a replay could not be computed.
#[derive(Debug, Error)]
pub enum ReachError {
    #[error("loading the arms of the reachability figures: {0}")]
    Arm(#[from] KinematicsError),
    #[error("placing the arm of program {0}: {1}")]
    Layout(String, LayoutError),
}

/// The scoreboard of `nextpose replay` and of the service's replay (`POST /v1/replays`, the
/// gRPC `Replay`), one function so the two cannot drift: the engine at `config` (its profile
/// named `profile`), every baseline ([`baselines::scoreboard`], `gate` for the gated ones), the
/// oracle bounds ([`Report::add_oracles`]) and the engine's calibration.
pub fn scoreboard(
    programs: &[Program],
    profile: &str,
    config: &EngineConfig,
    gate: f64,
) -> Result<Report, ScoreboardError> {
    scoreboard_with(programs, profile, config, gate, Vec::new(), None)
}

/// [`scoreboard`] with further methods, run after the engine and before the baselines (e.g.
/// `nextpose replay --map`'s [`super::methods::MapMethod`]), and the arms' placements kept in
/// `placement_cache` ([`RunConfig::placement_cache`]).
pub fn scoreboard_with(
    programs: &[Program],
    profile: &str,
    config: &EngineConfig,
    gate: f64,
    extra: Vec<Box<dyn Method>>,
    placement_cache: Option<PathBuf>,
) -> Result<Report, ScoreboardError> {
    let mut methods: Vec<Box<dyn Method>> = vec![Box::new(EngineMethod::new(config.clone())?)];
    methods.extend(extra);
    methods.extend(baselines::scoreboard(config, gate));
    let run = RunConfig {
        placement_cache,
        ..RunConfig::new(profile, config.clone(), gate)
    };
    let mut report = replay_all(programs, &mut methods, run)?;
    report.add_oracles(programs);
    Ok(report)
}

/// The report's `oracles` section (see the module doc and [`super::score::oracle`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OracleSection {
    /// The `oracle_*` entries in words: what they are and how to read their figures.
    pub meaning: &'static str,
    pub useful_max_mm: f64,
    pub useful_max_rad: f64,
    pub kinds: Vec<OracleLine>,
}

/// One oracle, pooled over the programs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OracleLine {
    pub name: String,
    pub candidates: String,
    /// Waypoints with ≥ 2 predecessors, and how many of them a candidate covers.
    pub predictable: usize,
    pub covered: usize,
    pub share_pct: Option<f64>,
    /// The same with ≥ 1 predecessor.
    pub predictable_n1: usize,
    pub covered_n1: usize,
    pub share_pct_n1: Option<f64>,
}

/// [`OracleSection::meaning`].
pub const ORACLE_MEANING: &str = "Bounds, not methods: the share of scored waypoints whose true \
     next waypoint is within the useful tolerance of some candidate of that kind from the \
     program's history (earlier routines and the current routine's taught waypoints). In totals \
     and per program an oracle is a perfect selector: offered = useful = covered, precision 100, \
     saved_pct = 0.9 x share, the most a method offering only such candidates could save.";

/// Replays every program through every method and computes per-program and pooled figures.
/// Each method sees each program from an empty model (`reset`). The arm of the reachability
/// figures, when the configuration asks for them, must load: an error, not a report without
/// them.
pub fn replay_all(
    programs: &[Program],
    methods: &mut [Box<dyn Method>],
    config: RunConfig,
) -> Result<Report, ReachError> {
    let check = config
        .reachability
        .clone()
        .map(ReachCheck::new)
        .transpose()?;
    let cache = config.placement_cache.as_ref().map(PlacementCache::new);
    let mut used = CacheUse::default();
    let arms: Vec<Option<PlacedArm>> = match &check {
        None => vec![None; programs.len()],
        Some(check) => programs
            .iter()
            .map(|p| {
                let poses: Vec<Pose> = p.poses().copied().collect();
                let (language, named) = (p.language_name(), p.arm_designation());
                match &cache {
                    Some(cache) => cache.place(check, language, named, &poses, &mut used),
                    None => check.place(language, named, &poses),
                }
                .map_err(|e| ReachError::Layout(p.name.clone(), e))
            })
            .collect::<Result<_, _>>()?,
    };

    // records[m][p], reach[m][p]: method m on program p.
    let (records, reach): (Vec<Vec<ProgramRecord>>, Vec<Vec<Vec<ReachRecord>>>) = methods
        .iter_mut()
        .map(|m| {
            programs
                .iter()
                .zip(&arms)
                .map(|(p, arm)| match (&check, arm) {
                    (Some(check), Some(arm)) => {
                        let mut recorder = ReachRecorder::new(m.as_mut());
                        let record = replay_program(p, &mut recorder);
                        let reach = recorder.check(check, arm);
                        (record, reach)
                    }
                    _ => (replay_program(p, m.as_mut()), Vec::new()),
                })
                .unzip()
        })
        .unzip();
    let with_reach = |mut metrics: Scores, reach: &mut dyn Iterator<Item = &ReachRecord>| {
        (metrics.reachable_pct, metrics.taught_reachable_pct) = reach_figures(reach, 2);
        metrics
    };
    let names: Vec<String> = methods.iter().map(|m| m.name().to_string()).collect();
    let totals = ByMethod(
        names
            .iter()
            .zip(records.iter().zip(&reach))
            .map(|(name, (recs, reach))| {
                let metrics = Scores::of_programs(recs);
                (
                    name.clone(),
                    with_reach(metrics, &mut reach.iter().flatten()),
                )
            })
            .collect(),
    );
    let engine_precision = totals.get("engine").and_then(|m| m.n2.precision_pct);
    let mut at_engine_precision: Vec<AtPrecision> = match engine_precision {
        None => Vec::new(),
        Some(floor) => names
            .iter()
            .zip(&records)
            .filter(|(name, _)| name.as_str() != "engine")
            .filter_map(|(name, recs)| at_precision(name, recs, floor))
            .collect(),
    };
    at_engine_precision.sort_by(|a, b| b.saved_pct.total_cmp(&a.saved_pct));
    let calibration = ByMethod(
        names
            .iter()
            .zip(&records)
            .filter_map(|(name, recs)| Some((name.clone(), Calibration::of_programs(recs)?)))
            .collect(),
    );
    let programs = programs
        .iter()
        .enumerate()
        .map(|(p, program)| ProgramReport {
            program: program.name.clone(),
            language: program.language_name().to_string(),
            arm: arms[p].as_ref().map(|a| a.arm.clone()),
            methods: ByMethod(
                names
                    .iter()
                    .zip(records.iter().zip(&reach))
                    .map(|(name, (recs, reach))| {
                        let metrics = Scores::of_program(&recs[p]);
                        (name.clone(), with_reach(metrics, &mut reach[p].iter()))
                    })
                    .collect(),
            ),
        })
        .collect();
    Ok(Report {
        config,
        totals,
        oracles: None,
        calibration,
        programs,
        at_engine_precision,
        placements: cache.map(|_| used),
    })
}

impl Report {
    /// Adds the oracle bounds ([`super::score::oracle`]) of `programs`, which must be the programs the
    /// report was made from, in the same order: `oracle_*` entries after the methods in
    /// `totals` and in each program's `methods`, and the `oracles` section. Replaces oracles
    /// added before.
    pub fn add_oracles(&mut self, programs: &[Program]) {
        assert_eq!(
            programs.len(),
            self.programs.len(),
            "the oracles' programs are the report's"
        );
        self.totals.0.retain(|(name, _)| !is_oracle(name));
        for p in &mut self.programs {
            p.methods.0.retain(|(name, _)| !is_oracle(name));
        }
        // records[p][o]: oracle o on program p.
        let records: Vec<Vec<ProgramRecord>> = programs.iter().map(oracle_records).collect();
        let scores = |mut s: Scores| {
            // Oracles take no time worth reporting and guess nothing an arm must reach.
            s.us_per_waypoint = None;
            s
        };
        let mut kinds = Vec::new();
        for (o, oracle) in ORACLES.iter().enumerate() {
            let total = scores(Scores::of_programs(records.iter().map(|r| &r[o])));
            kinds.push(OracleLine {
                name: oracle.name.to_string(),
                candidates: oracle.candidates.to_string(),
                predictable: total.n2.predictable,
                covered: total.n2.useful,
                share_pct: total.n2.useful_pct,
                predictable_n1: total.n1.predictable,
                covered_n1: total.n1.useful,
                share_pct_n1: total.n1.useful_pct,
            });
            self.totals.0.push((oracle.name.to_string(), total));
            for (report, record) in self.programs.iter_mut().zip(&records) {
                debug_assert_eq!(report.program, record[o].program);
                let line = scores(Scores::of_program(&record[o]));
                report.methods.0.push((oracle.name.to_string(), line));
            }
        }
        self.oracles = Some(OracleSection {
            meaning: ORACLE_MEANING,
            useful_max_mm: self.config.useful_max_mm,
            useful_max_rad: self.config.useful_max_rad,
            kinds,
        });
    }

    /// Per-program table of one method (the engine in the CLI).
    pub fn program_table(&self, method: &str) -> String {
        let mut t = Table::new(&[
            "program",
            "lang",
            "pred n≥2",
            "offered %",
            "useful %",
            "precision %",
            "saved %",
            "median mm",
            "states",
            "reach %",
            "taught reach %",
        ]);
        for p in &self.programs {
            let Some(m) = p.methods.get(method) else {
                continue;
            };
            t.row(vec![
                p.program.clone(),
                p.language.clone(),
                m.n2.predictable.to_string(),
                fmt(m.n2.offered_pct, 1),
                fmt(m.n2.useful_pct, 1),
                fmt(m.n2.precision_pct, 1),
                fmt(m.n2.saved_pct, 1),
                fmt(m.n2.median_cart_mm, 3),
                m.states.map_or_else(|| "-".to_string(), |s| s.to_string()),
                fmt(m.reachable_pct, 1),
                fmt(m.taught_reachable_pct, 1),
            ]);
        }
        format!("{method}, per program:\n{}", t.render())
    }

    /// The arm of each program's reach figures: which, how it was chosen, where it stands and
    /// how many taught waypoints it reaches (`None` when reach was not checked).
    pub fn arm_table(&self) -> Option<String> {
        let setup = self.config.reachability.as_ref()?;
        let mut t = Table::new(&[
            "program",
            "arm",
            "chosen",
            "named",
            "base x, y, z mm",
            "waypoints",
            "reached",
            "unreached %",
        ]);
        let (mut total, mut reached) = (0, 0);
        for p in &self.programs {
            let Some(a) = &p.arm else {
                t.row(vec![p.program.clone(), "-".into()]);
                continue;
            };
            total += a.waypoints;
            reached += a.reached;
            let [x, y, z] = [a.base.x, a.base.y, a.base.z];
            t.row(vec![
                p.program.clone(),
                a.model.clone().unwrap_or_else(|| a.robot.clone()),
                a.chosen.name().to_string(),
                a.named.clone().unwrap_or_else(|| "-".into()),
                format!("{x:.0}, {y:.0}, {z:.0}"),
                a.waypoints.to_string(),
                a.reached.to_string(),
                fmt(pct(a.waypoints - a.reached, a.waypoints), 1),
            ]);
        }
        let how = match setup {
            ReachSetup::Fitted(_) => {
                "the program's own arm, else the smallest library arm for its language that \
                 reaches every taught waypoint (else the one reaching most), placed by the layout \
                 search"
            }
            ReachSetup::Heuristic(_) => "one arm, placed by the median heuristic",
        };
        Some(format!(
            "Arms of the reach figures ({how}); {} of {total} taught waypoints out of reach ({} %):\n{}",
            total - reached,
            fmt(pct(total - reached, total), 1),
            t.render()
        ))
    }

    /// Totals, one row per method.
    /// The other methods at the engine's precision ([`Report::at_engine_precision`]); `None`
    /// when there are none.
    pub fn matched_table(&self) -> Option<String> {
        let first = self.at_engine_precision.first()?;
        let floor = self.totals.get("engine")?.n2.precision_pct?;
        let mut t = Table::new(&[
            "method",
            "confidence ≥",
            "offered %",
            "precision %",
            "saved %",
        ]);
        for m in &self.at_engine_precision {
            t.row(vec![
                m.method.clone(),
                m.min_confidence
                    .map_or("(all)".to_string(), |c| fmt(Some(c), 3)),
                fmt(pct(m.offered, m.predictable), 1),
                fmt(Some(m.precision_pct), 1),
                fmt(Some(m.saved_pct), 1),
            ]);
        }
        Some(format!(
            "At the engine's precision ({}) or better, each method offering only its most \
             confident guesses (the cut that saves most; best: {}, {} saved):\n{}",
            fmt(Some(floor), 1) + " %",
            first.method,
            fmt(Some(first.saved_pct), 1) + " %",
            t.render()
        ))
    }

    pub fn totals_table(&self) -> String {
        let mut t = Table::new(&[
            "method",
            "pred n≥2",
            "pred n≥1",
            "offered %",
            "useful %",
            "precision %",
            "saved %",
            "median mm",
            "median rad",
            "Spearman",
            "µs/waypoint",
            "reach %",
            "taught reach %",
        ]);
        for (name, m) in self.totals.0.iter().filter(|(name, _)| !is_oracle(name)) {
            t.row(vec![
                name.clone(),
                m.n2.predictable.to_string(),
                m.n1.predictable.to_string(),
                fmt(m.n2.offered_pct, 1),
                fmt(m.n2.useful_pct, 1),
                fmt(m.n2.precision_pct, 1),
                fmt(m.n2.saved_pct, 1),
                fmt(m.n2.median_cart_mm, 3),
                fmt(m.n2.median_angle_rad, 4),
                fmt(m.n2.spearman_conf_err, 2),
                fmt(m.us_per_waypoint, 1),
                fmt(m.reachable_pct, 1),
                fmt(m.taught_reachable_pct, 1),
            ]);
        }
        let programs = self.programs.len();
        let mut text = format!(
            "Totals over {programs} program(s), waypoints with ≥ 2 predecessors \
             (useful: ≤ {} mm and ≤ {} rad; reach: the cell's arm reaches the guess, \
             see replay::reach):\n{}",
            self.config.useful_max_mm,
            self.config.useful_max_rad,
            t.render()
        );
        if let Some(table) = self.matched_table() {
            text.push('\n');
            text.push_str(&table);
        }
        if let Some(table) = self.oracle_table() {
            text.push('\n');
            text.push_str(&table);
        }
        for (method, c) in &self.calibration.0 {
            text.push('\n');
            text.push_str(&c.table(method));
        }
        text
    }

    /// The oracle bounds, one row per oracle (`None` when the report has none).
    pub fn oracle_table(&self) -> Option<String> {
        let section = self.oracles.as_ref()?;
        let mut t = Table::new(&[
            "oracle",
            "pred n≥2",
            "covered",
            "share %",
            "saved ≤ %",
            "share n≥1 %",
        ]);
        for k in &section.kinds {
            t.row(vec![
                k.name.clone(),
                k.predictable.to_string(),
                k.covered.to_string(),
                fmt(k.share_pct, 1),
                fmt(k.share_pct.map(|s| saved_pct(s, s)), 1),
                fmt(k.share_pct_n1, 1),
            ]);
        }
        let lines: Vec<String> = section
            .kinds
            .iter()
            .map(|k| format!("  {}: {}", k.name, k.candidates))
            .collect();
        Some(format!(
            "Oracle bounds, not methods (they see the answer): waypoints within ≤ {} mm and \
             ≤ {} rad of a candidate from the program's history (earlier routines and the \
             routine being taught); saved ≤ is 0.9 × share, the most a method offering only \
             such candidates could save:\n{}{}\n",
            section.useful_max_mm,
            section.useful_max_rad,
            t.render(),
            lines.join("\n")
        ))
    }
}

fn pct(part: usize, whole: usize) -> Option<f64> {
    (whole > 0).then(|| 100.0 * part as f64 / whole as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An arm that does not load is an error, not a report without reach figures.
    #[test]
    fn a_missing_arm_is_an_error() {
        use crate::kinematics::placement::HeuristicSetup;
        let config = crate::engine::EngineConfig::default();
        let mut run = RunConfig::new("default", config, 0.0);
        run.reachability = Some(ReachSetup::Heuristic(HeuristicSetup {
            robot: "no_such_robot".into(),
            ..HeuristicSetup::default()
        }));
        let mut methods: Vec<Box<dyn Method>> = Vec::new();
        assert!(replay_all(&[], &mut methods, run.clone()).is_err());
        run.reachability = Some(ReachSetup::default());
        assert!(replay_all(&[], &mut methods, run).is_ok());
    }
}
