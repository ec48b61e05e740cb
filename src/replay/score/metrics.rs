//! The scoreboard figures of replayed records (ALGORITHM §5, dissertation §4.3.1).
//!
//! [`Scores`] turns a set of [`WaypointRecord`]s (from [`replay_program`]) into the scoreboard
//! line of one method. Totals are pooled over waypoints (not averaged over programs): a
//! 6-waypoint program does not weigh as much as the 836-waypoint welding cell.
//!
//! Two populations are reported. The headline one is waypoints with at least two predecessors
//! (`n ≥ 2`): every method, including repeat-last, has a move to go on there, so the comparison is
//! fair. The `*_n1` figures add the second waypoint of each routine (`n = 1`), where only a
//! learned model (or the nearest-sequence fallback) can guess the first move.
//!
//! *Useful* is judged by the record ([`WaypointRecord::useful`]: within 1 mm and 0.1 rad).
//! *Saved* is a rough share of teaching effort saved: each useful guess saves ~90 % of teaching a
//! waypoint, each offered-but-wrong guess costs ~10 % (reading and rejecting it).

use serde::Serialize;
use statrs::statistics::{Data, Median};

use crate::replay::method::ModelSummary;
#[cfg(doc)]
use crate::replay::playback::replay_program;
use crate::replay::playback::{ProgramRecord, WaypointRecord};

/// Accuracy figures of one population of waypoints (see the module doc).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Accuracy {
    pub predictable: usize,
    pub offered: usize,
    pub useful: usize,
    /// Offered / predictable, %.
    pub offered_pct: Option<f64>,
    /// Useful / predictable, %.
    pub useful_pct: Option<f64>,
    /// Useful / offered, % (`None` when nothing was offered).
    pub precision_pct: Option<f64>,
    /// `0.9 · useful_pct − 0.1 · (offered_pct − useful_pct)`.
    pub saved_pct: Option<f64>,
    /// Medians over offered guesses.
    pub median_cart_mm: Option<f64>,
    pub median_angle_rad: Option<f64>,
    /// Median of error / travel × 100 over offered guesses with non-zero travel.
    pub median_cart_pct_travel: Option<f64>,
    pub median_angle_pct_travel: Option<f64>,
    /// Rank correlation of confidence with Cartesian error over offered guesses (a useful
    /// confidence is strongly negative).
    pub spearman_conf_err: Option<f64>,
    pub pearson_conf_err: Option<f64>,
    /// Rank correlation of φ with Cartesian error (engine only).
    pub spearman_phi_err: Option<f64>,
}

impl Accuracy {
    /// Figures over `records` (already restricted to the population).
    pub fn of<'a>(records: impl IntoIterator<Item = &'a WaypointRecord>) -> Accuracy {
        let records: Vec<&WaypointRecord> = records.into_iter().collect();
        let offered: Vec<&WaypointRecord> = records.iter().copied().filter(|r| r.offered).collect();
        let predictable = records.len();
        let useful = records.iter().filter(|r| r.useful()).count();
        let pct = |k: usize, of: usize| (of > 0).then(|| 100.0 * k as f64 / of as f64);
        let offered_pct = pct(offered.len(), predictable);
        let useful_pct = pct(useful, predictable);
        let saved_pct = match (offered_pct, useful_pct) {
            (Some(o), Some(u)) => Some(saved_pct(o, u)),
            _ => None,
        };

        let cart: Vec<f64> = offered.iter().filter_map(|r| r.cart_mm).collect();
        let angle: Vec<f64> = offered.iter().filter_map(|r| r.angle_rad).collect();
        let cart_pct: Vec<f64> = offered
            .iter()
            .filter(|r| r.travel_mm > 0.0)
            .filter_map(|r| r.cart_mm.map(|e| 100.0 * e / r.travel_mm))
            .collect();
        let angle_pct: Vec<f64> = offered
            .iter()
            .filter(|r| r.travel_rad > 0.0)
            .filter_map(|r| r.angle_rad.map(|e| 100.0 * e / r.travel_rad))
            .collect();
        let pairs = |key: fn(&WaypointRecord) -> Option<f64>| -> (Vec<f64>, Vec<f64>) {
            offered
                .iter()
                .filter_map(|r| Some((key(r)?, r.cart_mm?)))
                .filter(|(a, b)| a.is_finite() && b.is_finite())
                .unzip()
        };
        let (conf, conf_err) = pairs(|r| r.confidence);
        let (phi, phi_err) = pairs(|r| r.phi);

        Accuracy {
            predictable,
            offered: offered.len(),
            useful,
            offered_pct,
            useful_pct,
            precision_pct: pct(useful, offered.len()),
            saved_pct,
            median_cart_mm: median(&cart),
            median_angle_rad: median(&angle),
            median_cart_pct_travel: median(&cart_pct),
            median_angle_pct_travel: median(&angle_pct),
            spearman_conf_err: spearman(&conf, &conf_err),
            pearson_conf_err: pearson(&conf, &conf_err),
            spearman_phi_err: spearman(&phi, &phi_err),
        }
    }
}

/// Share of teaching effort saved, %: a useful guess saves 90 % of a waypoint, a wrong one that
/// was offered costs 10 % (the operator reads and rejects it).
pub fn saved_pct(offered_pct: f64, useful_pct: f64) -> f64 {
    0.9 * useful_pct - 0.1 * (offered_pct - useful_pct)
}

/// The scoreboard line of one method on one program or on the whole corpus: the [`Accuracy`]
/// of the two populations (see the module doc) and the model's size and speed. Serialised in
/// the JSON report as one flat object (a stable interface: add fields, do not rename them):
/// the `n ≥ 2` figures under their own names, then the `n ≥ 1` ones with the suffix `_n1`,
/// then the rest. Figures that cannot be computed (nothing offered, too few points) are `null`,
/// never NaN.
#[derive(Debug, Clone, PartialEq)]
pub struct Scores {
    /// Waypoints with at least two predecessors (the headline figures).
    pub n2: Accuracy,
    /// The same with the routines' second waypoints added (at least one predecessor).
    pub n1: Accuracy,
    /// Model size after the program (totals: summed over programs).
    pub states: Option<usize>,
    pub edges: Option<usize>,
    /// Mean out-degree (totals: mean over programs).
    pub perplexity: Option<f64>,
    /// Mean wall-clock time of predict + observe per predicted waypoint (n ≥ 1), µs.
    pub us_per_waypoint: Option<f64>,
    /// Share of offered guesses (n ≥ 2) that the cell's arm can reach, % (`null` when the
    /// program has no arm to check, see [`super::reach`]).
    pub reachable_pct: Option<f64>,
    /// Share of taught waypoints (n ≥ 2) the arm reaches at the same placement, %: where this is
    /// low, the placement does not fit the program and `reachable_pct` means little.
    pub taught_reachable_pct: Option<f64>,
}

impl Serialize for Scores {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let (a, b) = (&self.n2, &self.n1);
        let mut m = s.serialize_struct("Scores", 30)?;
        m.serialize_field("predictable", &a.predictable)?;
        m.serialize_field("offered", &a.offered)?;
        m.serialize_field("useful", &a.useful)?;
        m.serialize_field("offered_pct", &a.offered_pct)?;
        m.serialize_field("useful_pct", &a.useful_pct)?;
        m.serialize_field("precision_pct", &a.precision_pct)?;
        m.serialize_field("saved_pct", &a.saved_pct)?;
        m.serialize_field("median_cart_mm", &a.median_cart_mm)?;
        m.serialize_field("median_angle_rad", &a.median_angle_rad)?;
        m.serialize_field("median_cart_pct_travel", &a.median_cart_pct_travel)?;
        m.serialize_field("median_angle_pct_travel", &a.median_angle_pct_travel)?;
        m.serialize_field("spearman_conf_err", &a.spearman_conf_err)?;
        m.serialize_field("pearson_conf_err", &a.pearson_conf_err)?;
        m.serialize_field("spearman_phi_err", &a.spearman_phi_err)?;
        m.serialize_field("predictable_n1", &b.predictable)?;
        m.serialize_field("offered_n1", &b.offered)?;
        m.serialize_field("useful_n1", &b.useful)?;
        m.serialize_field("offered_pct_n1", &b.offered_pct)?;
        m.serialize_field("useful_pct_n1", &b.useful_pct)?;
        m.serialize_field("precision_pct_n1", &b.precision_pct)?;
        m.serialize_field("saved_pct_n1", &b.saved_pct)?;
        m.serialize_field("median_cart_mm_n1", &b.median_cart_mm)?;
        m.serialize_field("median_angle_rad_n1", &b.median_angle_rad)?;
        m.serialize_field("spearman_conf_err_n1", &b.spearman_conf_err)?;
        m.serialize_field("states", &self.states)?;
        m.serialize_field("edges", &self.edges)?;
        m.serialize_field("perplexity", &self.perplexity)?;
        m.serialize_field("us_per_waypoint", &self.us_per_waypoint)?;
        m.serialize_field("reachable_pct", &self.reachable_pct)?;
        m.serialize_field("taught_reachable_pct", &self.taught_reachable_pct)?;
        m.end()
    }
}

impl Scores {
    /// Figures of one method on one program.
    pub fn of_program(record: &ProgramRecord) -> Scores {
        Scores::of_programs(std::slice::from_ref(record))
    }

    /// Figures pooled over the programs' waypoints; model sizes summed, perplexity averaged.
    pub fn of_programs<'a>(records: impl IntoIterator<Item = &'a ProgramRecord>) -> Scores {
        let records: Vec<&ProgramRecord> = records.into_iter().collect();
        let all = || records.iter().flat_map(|p| p.waypoints.iter());
        let summaries: Vec<&ModelSummary> =
            records.iter().filter_map(|p| p.summary.as_ref()).collect();
        let (states, edges, perplexity) = if summaries.is_empty() {
            (None, None, None)
        } else {
            let perplexities: Vec<f64> = summaries.iter().map(|s| s.perplexity).collect();
            (
                Some(summaries.iter().map(|s| s.states).sum()),
                Some(summaries.iter().map(|s| s.edges).sum()),
                mean(&perplexities),
            )
        };
        let times: Vec<f64> = all().map(|r| r.micros).collect();
        Scores {
            n2: Accuracy::of(all().filter(|r| r.predecessors >= 2)),
            n1: Accuracy::of(all().filter(|r| r.predecessors >= 1)),
            states,
            edges,
            perplexity,
            us_per_waypoint: mean(&times),
            reachable_pct: None,
            taught_reachable_pct: None,
        }
    }
}

/// `Some(x)` when `x` is finite: JSON has no NaN, and a NaN figure means "not computable".
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// Median of finite values; `None` for an empty slice.
pub fn median(values: &[f64]) -> Option<f64> {
    let values: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if values.is_empty() {
        return None;
    }
    finite(Data::new(values).median())
}

fn mean(values: &[f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    finite(values.iter().sum::<f64>() / values.len() as f64)
}

/// Pearson correlation; `None` with fewer than 3 pairs, unequal lengths or zero variance.
pub fn pearson(a: &[f64], b: &[f64]) -> Option<f64> {
    if a.len() != b.len() || a.len() < 3 {
        return None;
    }
    let ma = mean(a)?;
    let mb = mean(b)?;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    if saa <= 0.0 || sbb <= 0.0 {
        return None;
    }
    finite((sab / (saa.sqrt() * sbb.sqrt())).clamp(-1.0, 1.0))
}

/// Spearman rank correlation: Pearson of the ranks, tied values sharing their average rank.
pub fn spearman(a: &[f64], b: &[f64]) -> Option<f64> {
    if a.len() != b.len() || a.len() < 3 {
        return None;
    }
    pearson(&average_ranks(a), &average_ranks(b))
}

/// 1-based ranks; a run of equal values gets the mean of the ranks it spans.
pub fn average_ranks(values: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&i, &j| values[i].total_cmp(&values[j]));
    let mut ranks = vec![0.0; values.len()];
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && values[order[end]] == values[order[start]] {
            end += 1;
        }
        // Positions start..end hold ranks start+1 ..= end; their mean:
        let rank = (start + 1 + end) as f64 / 2.0;
        for &i in &order[start..end] {
            ranks[i] = rank;
        }
        start = end;
    }
    ranks
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranks_average_ties() {
        assert_eq!(
            average_ranks(&[10.0, 20.0, 10.0, 30.0]),
            [1.5, 3.0, 1.5, 4.0]
        );
        assert_eq!(average_ranks(&[]), Vec::<f64>::new());
    }

    #[test]
    fn correlations_need_three_points_and_variance() {
        assert_eq!(pearson(&[1.0, 2.0], &[1.0, 2.0]), None);
        assert_eq!(pearson(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0]), None);
        let r = pearson(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.0]).unwrap();
        assert!((r - 1.0).abs() < 1e-12);
        let s = spearman(&[1.0, 2.0, 3.0, 4.0], &[1.0, 8.0, 27.0, 64.0]).unwrap();
        assert!((s - 1.0).abs() < 1e-12);
    }

    #[test]
    fn median_skips_non_finite_and_empty() {
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[3.0, f64::NAN, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), Some(2.5));
    }
}
