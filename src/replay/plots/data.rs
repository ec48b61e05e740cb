//! What the figures show, computed once: the engine replayed at the run's settings and over
//! the two sweeps (φ_min, δ), and the curves and points read from those records. Rendering
//! never replays anything; [`plotted_json`] writes these numbers beside the figures.

use serde::Serialize;

use crate::engine::{ConfigError, EngineConfig};
use crate::replay::corpus::Program;
use crate::replay::methods::EngineMethod;
use crate::replay::playback::{ProgramRecord, WaypointRecord, replay_program};
use crate::replay::score::metrics::{median, spearman};
use crate::replay::score::reliability::Calibration;
use crate::replay::sweep::{SweepRow, sweep};

use super::error::PlotError;

/// The grids of the two sweeps.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotGrid {
    pub phi_mins: Vec<f64>,
    pub deltas: Vec<f64>,
}

impl Default for PlotGrid {
    /// φ_min 0, 0.05, …, 1; δ 0.1, 0.2, …, 1.
    fn default() -> PlotGrid {
        PlotGrid {
            phi_mins: (0..=20).map(|i| f64::from(i) / 20.0).collect(),
            deltas: (1..=10).map(|i| f64::from(i) / 10.0).collect(),
        }
    }
}

/// Everything the figures show.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotData {
    /// Profile name, for the captions.
    pub profile: String,
    /// The run's settings; the sweeps vary φ_min or δ from here.
    pub config: EngineConfig,
    /// Number of programs replayed.
    pub programs: usize,
    /// The engine at the run's settings but φ_min, one row per grid value.
    pub phi_sweep: Vec<SweepRow>,
    /// The engine at the run's settings but δ, one row per grid value.
    pub delta_sweep: Vec<SweepRow>,
    /// The engine at the run's settings, program by program.
    pub records: Vec<ProgramRecord>,
}

/// Replays the engine over `programs` at `config` and over the two sweeps of `grid`.
pub fn plot_data(
    programs: &[Program],
    profile: &str,
    config: &EngineConfig,
    grid: &PlotGrid,
) -> Result<PlotData, ConfigError> {
    let phi_sweep = sweep(
        programs,
        config,
        &[config.delta],
        &grid.phi_mins,
        &[config.predict.horizon],
    )?;
    let delta_sweep = sweep(
        programs,
        config,
        &grid.deltas,
        &[config.predict.phi_min],
        &[config.predict.horizon],
    )?;
    let mut engine = EngineMethod::new(config.clone())?;
    let records = programs
        .iter()
        .map(|p| replay_program(p, &mut engine))
        .collect();
    Ok(PlotData {
        profile: profile.to_string(),
        config: config.clone(),
        programs: programs.len(),
        phi_sweep,
        delta_sweep,
        records,
    })
}

/// Waypoints of the learning curve whose model had assimilated `from..to` moves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LearningBin {
    pub from: u64,
    /// Exclusive.
    pub to: u64,
    pub predictable: usize,
    pub offered: usize,
    pub useful: usize,
    pub median_cart_mm: Option<f64>,
    pub median_angle_rad: Option<f64>,
}

impl LearningBin {
    pub fn offered_pct(&self) -> Option<f64> {
        pct(self.offered, self.predictable)
    }

    pub fn useful_pct(&self) -> Option<f64> {
        pct(self.useful, self.predictable)
    }
}

fn pct(k: usize, of: usize) -> Option<f64> {
    (of > 0).then(|| 100.0 * k as f64 / of as f64)
}

/// The headline population: waypoints with at least two predecessors.
pub(super) fn scored(records: &[ProgramRecord]) -> impl Iterator<Item = &WaypointRecord> {
    records
        .iter()
        .flat_map(|p| p.waypoints.iter())
        .filter(|r| r.predecessors >= 2)
}

/// Pools the records (n ≥ 2, with a model) into bins `[1, 2), [2, 4), [4, 8), …` of moves
/// assimilated; waypoints guessed from an empty model are left out. Empty bins are left out.
pub fn learning_curve(records: &[ProgramRecord]) -> Vec<LearningBin> {
    // Bin k holds 2^k ..< 2^(k+1).
    let mut bins: Vec<Vec<&WaypointRecord>> = Vec::new();
    for r in scored(records) {
        let Some(a) = r.assimilated.filter(|&a| a > 0) else {
            continue;
        };
        let k = a.ilog2() as usize;
        if bins.len() <= k {
            bins.resize_with(k + 1, Vec::new);
        }
        bins[k].push(r);
    }
    bins.into_iter()
        .enumerate()
        .filter(|(_, b)| !b.is_empty())
        .map(|(k, b)| {
            let offered: Vec<&&WaypointRecord> = b.iter().filter(|r| r.offered).collect();
            let cart: Vec<f64> = offered.iter().filter_map(|r| r.cart_mm).collect();
            let angle: Vec<f64> = offered.iter().filter_map(|r| r.angle_rad).collect();
            LearningBin {
                from: 1 << k,
                to: 1 << (k + 1),
                predictable: b.len(),
                offered: offered.len(),
                useful: b.iter().filter(|r| r.useful()).count(),
                median_cart_mm: median(&cart),
                median_angle_rad: median(&angle),
            }
        })
        .collect()
}

/// One offered guess of the scatter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScatterPoint {
    pub confidence: f64,
    pub cart_mm: f64,
    pub useful: bool,
}

/// Offered guesses (n ≥ 2) with a finite confidence and error.
pub fn confidence_points(records: &[ProgramRecord]) -> Vec<ScatterPoint> {
    scored(records)
        .filter(|r| r.offered)
        .filter_map(|r| {
            let (confidence, cart_mm) = (r.confidence?, r.cart_mm?);
            (confidence.is_finite() && cart_mm.is_finite()).then_some(ScatterPoint {
                confidence,
                cart_mm,
                useful: r.useful(),
            })
        })
        .collect()
}

/// The plotted numbers, written beside the figures as `plots.json`.
#[derive(Debug, Serialize)]
struct PlottedNumbers<'a> {
    profile: &'a str,
    config: &'a EngineConfig,
    programs: usize,
    phi_sweep: &'a [SweepRow],
    delta_sweep: &'a [SweepRow],
    learning_curve: Vec<LearningBin>,
    /// Offered guesses on the scatter, the useful ones, and Spearman's ρ of confidence with
    /// Cartesian error.
    scatter_points: usize,
    scatter_useful: usize,
    scatter_spearman: Option<f64>,
    /// The reliability table, ECE and risk–coverage curve (`null` without `p_useful`).
    calibration: Option<Calibration>,
}

/// The numbers every figure shows, as pretty JSON.
pub fn plotted_json(data: &PlotData) -> Result<String, PlotError> {
    let points = confidence_points(&data.records);
    let (conf, err): (Vec<f64>, Vec<f64>) =
        points.iter().map(|p| (p.confidence, p.cart_mm)).unzip();
    let numbers = PlottedNumbers {
        profile: &data.profile,
        config: &data.config,
        programs: data.programs,
        phi_sweep: &data.phi_sweep,
        delta_sweep: &data.delta_sweep,
        learning_curve: learning_curve(&data.records),
        scatter_points: points.len(),
        scatter_useful: points.iter().filter(|p| p.useful).count(),
        scatter_spearman: spearman(&conf, &err),
        calibration: Calibration::of_programs(&data.records),
    };
    Ok(serde_json::to_string_pretty(&numbers)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(n: usize, assimilated: Option<u64>, offered: Option<(f64, f64)>) -> WaypointRecord {
        WaypointRecord {
            routine: 0,
            predecessors: n,
            offered: offered.is_some(),
            cart_mm: offered.map(|o| o.0),
            angle_rad: offered.map(|o| o.1),
            travel_mm: 10.0,
            travel_rad: 0.1,
            confidence: offered.map(|o| -o.0),
            phi: None,
            psi: None,
            assimilated,
            micros: 1.0,
            candidate: None,
        }
    }

    fn program(waypoints: Vec<WaypointRecord>) -> ProgramRecord {
        ProgramRecord {
            program: "p".into(),
            language: "rapid".into(),
            method: "engine".into(),
            waypoints,
            summary: None,
        }
    }

    #[test]
    fn learning_curve_bins_double_and_skip_empty_models_and_n1() {
        let records = [program(vec![
            rec(1, Some(5), Some((0.0, 0.0))), // n = 1: not scored
            rec(2, Some(0), None),             // empty model: left out
            rec(2, Some(1), None),             // bin [1, 2)
            rec(2, Some(4), Some((0.5, 0.0))), // bin [4, 8), useful
            rec(3, Some(7), Some((3.0, 0.0))), // bin [4, 8), too far
            rec(3, Some(7), None),             // bin [4, 8)
            rec(4, None, Some((0.0, 0.0))),    // no model: left out
            rec(5, Some(9), Some((2.0, 0.2))), // bin [8, 16)
        ])];
        let bins = learning_curve(&records);
        let edges: Vec<(u64, u64)> = bins.iter().map(|b| (b.from, b.to)).collect();
        assert_eq!(edges, [(1, 2), (4, 8), (8, 16)]);
        assert_eq!((bins[0].predictable, bins[0].offered), (1, 0));
        assert_eq!(bins[0].median_cart_mm, None);
        let b = &bins[1];
        assert_eq!((b.predictable, b.offered, b.useful), (3, 2, 1));
        assert_eq!(b.median_cart_mm, Some(1.75));
        assert_eq!(b.offered_pct(), Some(200.0 / 3.0));
        assert_eq!(bins[2].useful, 0);
    }

    #[test]
    fn scatter_keeps_offered_finite_scored_guesses() {
        let mut odd = rec(2, Some(3), Some((1.0, 0.0)));
        odd.confidence = Some(f64::NAN);
        let records = [program(vec![
            rec(1, Some(3), Some((0.2, 0.0))),
            rec(2, Some(3), Some((0.2, 0.0))),
            rec(2, Some(3), None),
            odd,
            rec(3, Some(3), Some((4.0, 0.0))),
        ])];
        let points = confidence_points(&records);
        assert_eq!(
            points,
            [
                ScatterPoint {
                    confidence: -0.2,
                    cart_mm: 0.2,
                    useful: true
                },
                ScatterPoint {
                    confidence: -4.0,
                    cart_mm: 4.0,
                    useful: false
                }
            ]
        );
    }
}
