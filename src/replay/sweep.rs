//! Parameter sweep: the engine's totals over a grid of δ, φ_min and h.
//!
//! ALGORITHM.md leaves several choices to measurement; the sweep is how they are measured. Only
//! the engine is replayed (the baselines do not depend on δ or φ_min), once per combination, and
//! one line of pooled totals is kept per combination.

use serde::Serialize;

use crate::engine::{ConfigError, EngineConfig, PredictOptions};

use super::corpus::Program;
use super::methods::EngineMethod;
use super::playback::{ProgramRecord, replay_program};
use super::score::Scores;
use super::table::{Table, fmt};

/// Engine totals for one combination of settings (waypoints with ≥ 2 predecessors).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepRow {
    pub delta: f64,
    pub phi_min: f64,
    pub horizon: usize,
    pub saved_pct: Option<f64>,
    pub useful_pct: Option<f64>,
    pub offered_pct: Option<f64>,
    pub precision_pct: Option<f64>,
    pub median_cart_mm: Option<f64>,
    pub median_angle_rad: Option<f64>,
    /// Summed over programs.
    pub states: Option<usize>,
}

/// Replays the engine over `programs` for every combination of `deltas × phi_mins × horizons`
/// (in that nesting order), other settings from `base`. An invalid combination is an error
/// before anything is replayed.
pub fn sweep(
    programs: &[Program],
    base: &EngineConfig,
    deltas: &[f64],
    phi_mins: &[f64],
    horizons: &[usize],
) -> Result<Vec<SweepRow>, ConfigError> {
    let mut configs = Vec::new();
    for &delta in deltas {
        for &phi_min in phi_mins {
            for &horizon in horizons {
                let config = EngineConfig {
                    delta,
                    predict: PredictOptions {
                        phi_min,
                        horizon,
                        ..base.predict.clone()
                    },
                    ..base.clone()
                };
                config.validate()?;
                configs.push(config);
            }
        }
    }
    configs
        .into_iter()
        .map(|config| {
            let (delta, phi_min, horizon) =
                (config.delta, config.predict.phi_min, config.predict.horizon);
            let mut engine = EngineMethod::new(config)?;
            let records: Vec<ProgramRecord> = programs
                .iter()
                .map(|p| replay_program(p, &mut engine))
                .collect();
            let m = Scores::of_programs(&records);
            Ok(SweepRow {
                delta,
                phi_min,
                horizon,
                saved_pct: m.n2.saved_pct,
                useful_pct: m.n2.useful_pct,
                offered_pct: m.n2.offered_pct,
                precision_pct: m.n2.precision_pct,
                median_cart_mm: m.n2.median_cart_mm,
                median_angle_rad: m.n2.median_angle_rad,
                states: m.states,
            })
        })
        .collect()
}

/// The sweep as a text table, one line per combination.
pub fn sweep_table(rows: &[SweepRow]) -> String {
    let mut t = Table::new(&[
        "delta",
        "phi_min",
        "h",
        "saved %",
        "useful %",
        "offered %",
        "precision %",
        "median mm",
        "states",
    ]);
    for r in rows {
        t.row(vec![
            format!("{}", r.delta),
            format!("{}", r.phi_min),
            r.horizon.to_string(),
            fmt(r.saved_pct, 1),
            fmt(r.useful_pct, 1),
            fmt(r.offered_pct, 1),
            fmt(r.precision_pct, 1),
            fmt(r.median_cart_mm, 3),
            r.states.map_or_else(|| "-".to_string(), |s| s.to_string()),
        ]);
    }
    t.render()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_combination_is_an_error_before_replay() {
        let base = EngineConfig::default();
        assert!(matches!(
            sweep(&[], &base, &[0.5, 2.0], &[0.7], &[3]),
            Err(ConfigError::Delta(_))
        ));
        let rows = sweep(&[], &base, &[0.5, 0.7], &[0.7], &[1, 3]).unwrap();
        assert_eq!(rows.len(), 4);
        assert_eq!((rows[1].delta, rows[1].horizon), (0.5, 3));
    }
}
