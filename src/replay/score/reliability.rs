//! How well a method's `p_useful` is calibrated, and what its offer threshold buys (issue 13).
//!
//! Computed from the per-waypoint records of a replay ([`WaypointRecord::candidate`]): every
//! waypoint of the headline population (at least two predecessors) where the method had a
//! candidate with a `p_useful`, offered or not. *Useful* is the scoreboard's tolerance
//! ([`CandidateRecord::useful`]: ≤ 1 mm and ≤ 0.1 rad of the waypoint then taught).
//!
//! - **Reliability table** ([`ReliabilityBin`]): the candidates in ten bins by decile of
//!   `p_useful` (`[0, 0.1)`, …, `[0.9, 1.0]`, the last one closed), each with its count, mean
//!   `p_useful`, observed useful share and the gap (observed − mean). A calibrated `p_useful`
//!   has every gap near 0; issue 13 asks for |gap| ≤ [`TARGET_GAP`] in every decile with data.
//! - **Expected calibration error** (ECE): Σ_b (n_b / N) · |gap_b| over those bins.
//! - **Risk–coverage curve** ([`RiskCoveragePoint`]): offering exactly the candidates with
//!   `p_useful ≥ t`, the offered share of predictable waypoints (coverage) and the precision,
//!   for `t` = 0, 0.01, …, 1 — and the lowest threshold at which the precision reaches
//!   [`TARGET_PRECISION_PCT`] ([`ThresholdChoice`]), searched over every distinct `p_useful`.
//!
//! Everything here is pure arithmetic on the records.

use std::fmt::Write as _;

use serde::Serialize;

use super::metrics::{saved_pct, spearman};
use crate::replay::playback::{ProgramRecord, WaypointRecord};
use crate::replay::table::{Table, fmt};

/// Number of reliability bins (deciles of `p_useful`).
pub const BINS: usize = 10;
/// Issue 13's calibration target: in every bin with data, |observed − mean p_useful| ≤ this.
pub const TARGET_GAP: f64 = 0.10;
/// The precision the reported threshold must reach, %.
pub const TARGET_PRECISION_PCT: f64 = 90.0;
/// Steps of the risk–coverage curve's threshold grid over [0, 1].
pub const CURVE_STEPS: u32 = 100;

/// [`Calibration::meaning`].
pub const CALIBRATION_MEANING: &str = "Calibration of the method's p_useful over every scored \
     waypoint (>= 2 predecessors) where it had a candidate, offered or not; useful = within the \
     scoreboard's tolerance of the waypoint then taught. bins: deciles of p_useful (the last \
     closed), gap = observed - mean_p_useful; ece = sum of n_b/N |gap_b|. risk_coverage: \
     offering exactly the candidates with p_useful >= threshold, offered_pct of the predictable \
     waypoints and precision_pct of those offers.";

/// One decile of `p_useful`: candidates with `from ≤ p < to` (`p ≤ to` in the last one).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReliabilityBin {
    pub from: f64,
    pub to: f64,
    pub candidates: usize,
    /// Of them, within tolerance of the truth.
    pub useful: usize,
    pub mean_p_useful: Option<f64>,
    /// useful / candidates.
    pub observed: Option<f64>,
    /// observed − mean_p_useful (positive: the method is more often right than it says).
    pub gap: Option<f64>,
    /// |gap| ≤ [`TARGET_GAP`] (`null` for an empty bin).
    pub within_target: Option<bool>,
}

/// Offering exactly the candidates with `p_useful ≥ threshold`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RiskCoveragePoint {
    /// `null` for [`Calibration::as_offered`].
    pub threshold: Option<f64>,
    pub offered: usize,
    pub useful: usize,
    /// offered / predictable waypoints, %.
    pub offered_pct: Option<f64>,
    /// useful / offered, % (`null` when nothing is offered).
    pub precision_pct: Option<f64>,
    /// useful / predictable, %.
    pub useful_pct: Option<f64>,
    /// The scoreboard's saved % at this threshold.
    pub saved_pct: Option<f64>,
}

/// The lowest threshold whose offers reach the target precision (the most coverage at it).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ThresholdChoice {
    pub target_precision_pct: f64,
    /// `null` when no threshold reaches the target.
    pub point: Option<RiskCoveragePoint>,
}

/// The calibration section of one method (the report's `calibration.<method>`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    pub meaning: &'static str,
    /// Scored waypoints (≥ 2 predecessors), with or without a candidate.
    pub predictable: usize,
    /// Those with a candidate and a finite `p_useful`; the bins' counts sum to it.
    pub candidates: usize,
    /// Of them, within tolerance of the truth (offered or not).
    pub useful: usize,
    /// Of them, offered by the method.
    pub offered: usize,
    pub target_gap: f64,
    pub bins: Vec<ReliabilityBin>,
    /// Expected calibration error over the bins (`null` without candidates).
    pub ece: Option<f64>,
    /// The largest |gap| of a bin with data.
    pub max_abs_gap: Option<f64>,
    /// Every bin with data within [`TARGET_GAP`].
    pub meets_target: bool,
    /// Spearman's ρ of `p_useful` with the Cartesian error over all candidates, offered or not
    /// (the scoreboard's `spearman_conf_err` is over offered guesses only).
    pub spearman_p_err: Option<f64>,
    /// What the method actually offered: its own offers among the candidates (threshold
    /// `null`), for comparison with the curve.
    pub as_offered: RiskCoveragePoint,
    /// Thresholds 0, 0.01, …, 1.
    pub risk_coverage: Vec<RiskCoveragePoint>,
    pub threshold_for_target_precision: ThresholdChoice,
}

/// One candidate as the figures see it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Scored {
    p: f64,
    useful: bool,
    offered: bool,
    cart_mm: f64,
}

impl Calibration {
    /// The section over the programs' scored waypoints (≥ 2 predecessors); `None` when the
    /// method had no candidate with a `p_useful` there.
    pub fn of_programs<'a>(
        programs: impl IntoIterator<Item = &'a ProgramRecord>,
    ) -> Option<Calibration> {
        Calibration::of(
            programs
                .into_iter()
                .flat_map(|p| p.waypoints.iter())
                .filter(|r| r.predecessors >= 2),
        )
    }

    /// The section over `records` (already restricted to the population); `None` when none has
    /// a candidate with a finite `p_useful`.
    pub fn of<'a>(records: impl IntoIterator<Item = &'a WaypointRecord>) -> Option<Calibration> {
        let mut predictable = 0;
        let mut scored = Vec::new();
        for r in records {
            predictable += 1;
            if let Some(c) = r.candidate.filter(|c| c.p_useful.is_finite()) {
                scored.push(Scored {
                    p: c.p_useful.clamp(0.0, 1.0),
                    useful: c.useful(),
                    offered: r.offered,
                    cart_mm: c.cart_mm,
                });
            }
        }
        if scored.is_empty() {
            return None;
        }
        let bins = bins(&scored);
        let n = scored.len() as f64;
        let ece = bins
            .iter()
            .filter_map(|b| Some(b.candidates as f64 / n * b.gap?.abs()))
            .sum::<f64>();
        let max_abs_gap = bins
            .iter()
            .filter_map(|b| b.gap.map(f64::abs))
            .fold(None, |m: Option<f64>, g| Some(m.map_or(g, |m| m.max(g))));
        let meets_target = bins.iter().all(|b| b.within_target != Some(false));
        let (p, err): (Vec<f64>, Vec<f64>) = scored
            .iter()
            .filter(|s| s.cart_mm.is_finite())
            .map(|s| (s.p, s.cart_mm))
            .unzip();
        let offered: Vec<&Scored> = scored.iter().filter(|s| s.offered).collect();
        let as_offered = point(
            None,
            predictable,
            offered.len(),
            offered.iter().filter(|s| s.useful).count(),
        );
        let risk_coverage = (0..=CURVE_STEPS)
            .map(|i| at_threshold(&scored, predictable, f64::from(i) / f64::from(CURVE_STEPS)))
            .collect();
        Some(Calibration {
            meaning: CALIBRATION_MEANING,
            predictable,
            candidates: scored.len(),
            useful: scored.iter().filter(|s| s.useful).count(),
            offered: offered.len(),
            target_gap: TARGET_GAP,
            bins,
            ece: Some(ece),
            max_abs_gap,
            meets_target,
            spearman_p_err: spearman(&p, &err),
            as_offered,
            risk_coverage,
            threshold_for_target_precision: ThresholdChoice {
                target_precision_pct: TARGET_PRECISION_PCT,
                point: lowest_threshold_for(&scored, predictable, TARGET_PRECISION_PCT),
            },
        })
    }

    /// The reliability table, the ECE and a summary of the risk–coverage curve, for people.
    pub fn table(&self, method: &str) -> String {
        let mut t = Table::new(&[
            "p_useful",
            "candidates",
            "useful",
            "mean p",
            "observed",
            "gap pts",
            "within ±10",
        ]);
        for b in &self.bins {
            t.row(vec![
                format!("{:.1}–{:.1}", b.from, b.to),
                b.candidates.to_string(),
                b.useful.to_string(),
                fmt(b.mean_p_useful, 3),
                fmt(b.observed, 3),
                fmt(b.gap.map(|g| 100.0 * g), 1),
                b.within_target
                    .map_or_else(|| "-".to_string(), |w| if w { "yes" } else { "NO" }.into()),
            ]);
        }
        let mut text = format!(
            "Calibration of {method}'s p_useful: a candidate (offered or not) at {} of {} \
             scored waypoints, {} of them useful (within tolerance), {} offered:\n{}",
            self.candidates,
            self.predictable,
            self.useful,
            self.offered,
            t.render()
        );
        let off: Vec<String> = self
            .bins
            .iter()
            .filter(|b| b.within_target == Some(false))
            .map(|b| {
                format!(
                    "{:.1}–{:.1} by {:.1} pts",
                    b.from,
                    b.to,
                    100.0 * b.gap.map_or(0.0, f64::abs)
                )
            })
            .collect();
        let _ = writeln!(
            text,
            "ECE {} pts; largest |gap| {} pts; target |gap| ≤ {:.0} pts in every decile with \
             data: {}; Spearman ρ(p_useful, error) over all candidates {}",
            fmt(self.ece.map(|e| 100.0 * e), 1),
            fmt(self.max_abs_gap.map(|e| 100.0 * e), 1),
            100.0 * self.target_gap,
            if off.is_empty() {
                "met".to_string()
            } else {
                format!("missed in {}", off.join(", "))
            },
            fmt(self.spearman_p_err, 2),
        );
        let mut rc = Table::new(&[
            "threshold",
            "offered",
            "offered %",
            "precision %",
            "useful %",
            "saved %",
        ]);
        let mut row = |label: String, p: &RiskCoveragePoint| {
            rc.row(vec![
                label,
                p.offered.to_string(),
                fmt(p.offered_pct, 1),
                fmt(p.precision_pct, 1),
                fmt(p.useful_pct, 1),
                fmt(p.saved_pct, 1),
            ]);
        };
        let step = (CURVE_STEPS / 10).max(1) as usize;
        for p in self.risk_coverage.iter().step_by(step) {
            row(format!("≥ {}", fmt(p.threshold, 2)), p);
        }
        row("as offered".to_string(), &self.as_offered);
        let choice = &self.threshold_for_target_precision;
        if let Some(p) = &choice.point {
            row(
                format!(
                    "≥ {} (lowest for ≥ {:.0} %)",
                    fmt(p.threshold, 4),
                    choice.target_precision_pct
                ),
                p,
            );
        }
        let _ = write!(
            text,
            "Risk–coverage: offering the candidates with p_useful ≥ threshold (% of the {} \
             scored waypoints){}:\n{}",
            self.predictable,
            if choice.point.is_none() {
                format!(
                    "; no threshold reaches {:.0} % precision",
                    choice.target_precision_pct
                )
            } else {
                String::new()
            },
            rc.render()
        );
        text
    }
}

fn bins(scored: &[Scored]) -> Vec<ReliabilityBin> {
    let mut sums = vec![(0usize, 0usize, 0.0f64); BINS];
    for s in scored {
        // p ∈ [0, 1]; 1.0 falls in the last bin.
        let b = ((s.p * BINS as f64).floor() as usize).min(BINS - 1);
        sums[b].0 += 1;
        sums[b].1 += usize::from(s.useful);
        sums[b].2 += s.p;
    }
    sums.into_iter()
        .enumerate()
        .map(|(b, (n, useful, sum_p))| {
            let mean = (n > 0).then(|| sum_p / n as f64);
            let observed = (n > 0).then(|| useful as f64 / n as f64);
            let gap = mean.zip(observed).map(|(m, o)| o - m);
            ReliabilityBin {
                from: b as f64 / BINS as f64,
                to: (b + 1) as f64 / BINS as f64,
                candidates: n,
                useful,
                mean_p_useful: mean,
                observed,
                gap,
                // A hair of slack so that a gap of exactly 0.1 in binary counts as within.
                within_target: gap.map(|g| g.abs() <= TARGET_GAP + 1e-12),
            }
        })
        .collect()
}

fn pct(k: usize, of: usize) -> Option<f64> {
    (of > 0).then(|| 100.0 * k as f64 / of as f64)
}

fn point(
    threshold: Option<f64>,
    predictable: usize,
    offered: usize,
    useful: usize,
) -> RiskCoveragePoint {
    let offered_pct = pct(offered, predictable);
    let useful_pct = pct(useful, predictable);
    RiskCoveragePoint {
        threshold,
        offered,
        useful,
        offered_pct,
        precision_pct: pct(useful, offered),
        useful_pct,
        saved_pct: offered_pct.zip(useful_pct).map(|(o, u)| saved_pct(o, u)),
    }
}

fn at_threshold(scored: &[Scored], predictable: usize, threshold: f64) -> RiskCoveragePoint {
    let offers = || scored.iter().filter(|s| s.p >= threshold);
    point(
        Some(threshold),
        predictable,
        offers().count(),
        offers().filter(|s| s.useful).count(),
    )
}

/// The lowest distinct `p_useful` `t` such that offering every candidate with `p ≥ t` is at
/// least `target_pct` precise.
fn lowest_threshold_for(
    scored: &[Scored],
    predictable: usize,
    target_pct: f64,
) -> Option<RiskCoveragePoint> {
    let mut sorted: Vec<&Scored> = scored.iter().collect();
    sorted.sort_by(|a, b| b.p.total_cmp(&a.p));
    let (mut offered, mut useful) = (0usize, 0usize);
    let mut best = None;
    let mut i = 0;
    while i < sorted.len() {
        // All candidates tied at this p are offered together.
        let p = sorted[i].p;
        while i < sorted.len() && sorted[i].p == p {
            offered += 1;
            useful += usize::from(sorted[i].useful);
            i += 1;
        }
        if 100.0 * useful as f64 >= target_pct * offered as f64 {
            best = Some((p, offered, useful));
        }
    }
    best.map(|(p, o, u)| point(Some(p), predictable, o, u))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::playback::CandidateRecord;

    /// A scored waypoint; `candidate`: (p_useful, useful?, offered?).
    fn rec(candidate: Option<(f64, bool, bool)>) -> WaypointRecord {
        WaypointRecord {
            routine: 0,
            predecessors: 2,
            offered: candidate.is_some_and(|c| c.2),
            cart_mm: None,
            angle_rad: None,
            travel_mm: 10.0,
            travel_rad: 0.1,
            confidence: None,
            phi: None,
            psi: None,
            assimilated: None,
            micros: 0.0,
            candidate: candidate.map(|(p, useful, _)| CandidateRecord {
                p_useful: p,
                cart_mm: if useful { 0.5 } else { 5.0 },
                angle_rad: 0.0,
            }),
        }
    }

    /// `n` candidates at `p`, `useful` of them within tolerance, offered when `p ≥ 0.9`.
    fn many(p: f64, n: usize, useful: usize) -> Vec<WaypointRecord> {
        (0..n)
            .map(|i| rec(Some((p, i < useful, p >= 0.9))))
            .collect()
    }

    #[test]
    fn deciles_ece_and_target_on_known_records() {
        let mut records = Vec::new();
        records.extend(many(0.05, 10, 1)); // bin 0: observed 0.1, gap +0.05
        records.extend(many(0.55, 20, 6)); // bin 5: observed 0.3, gap −0.25 (misses)
        records.extend(many(0.95, 20, 19)); // bin 9: observed 0.95, gap 0
        records.extend(many(1.0, 10, 10)); // bin 9 too (closed at 1)
        records.extend((0..40).map(|_| rec(None))); // no candidate
        let mut odd = rec(Some((f64::NAN, true, false)));
        odd.predecessors = 2;
        records.push(odd); // non-finite p: not a candidate
        let c = Calibration::of(&records).unwrap();
        assert_eq!(c.predictable, 101);
        assert_eq!(c.candidates, 60);
        assert_eq!(c.bins.len(), BINS);
        assert_eq!(c.bins.iter().map(|b| b.candidates).sum::<usize>(), 60);
        let counts: Vec<usize> = c.bins.iter().map(|b| b.candidates).collect();
        assert_eq!(counts, [10, 0, 0, 0, 0, 20, 0, 0, 0, 30]);
        let close = |a: Option<f64>, b: f64| (a.unwrap() - b).abs() < 1e-12;
        assert!(close(c.bins[0].observed, 0.1) && close(c.bins[0].gap, 0.05));
        assert!(close(c.bins[5].gap, -0.25));
        let top = &c.bins[9];
        assert_eq!(top.useful, 29);
        assert!(close(top.mean_p_useful, (20.0 * 0.95 + 10.0) / 30.0));
        assert!(close(top.observed, 29.0 / 30.0));
        assert_eq!(c.bins[1].mean_p_useful, None);
        assert_eq!(c.bins[1].within_target, None);
        assert_eq!(
            c.bins.iter().map(|b| b.within_target).collect::<Vec<_>>()[..6],
            [Some(true), None, None, None, None, Some(false)]
        );
        assert!(!c.meets_target);
        assert!(close(c.max_abs_gap, 0.25));
        // ECE: (10·0.05 + 20·0.25 + 30·0) / 60 (the top bin's mean and observed are 29/30).
        assert!(close(c.ece, (10.0 * 0.05 + 20.0 * 0.25) / 60.0));
        // The method offered the 30 candidates at p ≥ 0.9.
        assert_eq!((c.as_offered.offered, c.as_offered.useful), (30, 29));
        assert_eq!(c.as_offered.threshold, None);
        let text = c.table("engine");
        assert!(text.contains("missed in 0.5–0.6 by 25.0 pts"), "{text}");
    }

    #[test]
    fn risk_coverage_on_known_records() {
        let mut records = Vec::new();
        records.extend(many(0.2, 10, 2));
        records.extend(many(0.6, 10, 5));
        records.extend(many(0.95, 10, 10));
        records.extend((0..70).map(|_| rec(None)));
        let c = Calibration::of(&records).unwrap();
        let curve = &c.risk_coverage;
        assert_eq!(curve.len(), CURVE_STEPS as usize + 1);
        assert_eq!(curve[0].threshold, Some(0.0));
        assert_eq!(curve[CURVE_STEPS as usize].threshold, Some(1.0));
        // Offered share never grows with the threshold.
        for w in curve.windows(2) {
            assert!(w[1].offered <= w[0].offered);
            assert!(w[1].threshold > w[0].threshold);
            assert!(w[1].offered_pct <= w[0].offered_pct);
        }
        let at = |t: f64| {
            curve
                .iter()
                .find(|p| p.threshold.is_some_and(|u| (u - t).abs() < 1e-9))
                .unwrap()
        };
        assert_eq!((at(0.0).offered, at(0.0).useful), (30, 17));
        assert_eq!(at(0.0).offered_pct, Some(30.0));
        assert_eq!(at(0.2).offered, 30);
        assert_eq!((at(0.21).offered, at(0.21).useful), (20, 15));
        assert_eq!(at(0.21).precision_pct, Some(75.0));
        assert_eq!((at(0.9).offered, at(0.9).useful), (10, 10));
        assert_eq!(at(0.9).saved_pct, Some(9.0));
        assert_eq!((at(1.0).offered, at(1.0).precision_pct), (0, None));
        // ≥ 90 %: only the top group (75 % at 0.6).
        let best = c.threshold_for_target_precision.point.unwrap();
        assert_eq!(
            (best.threshold, best.offered, best.useful),
            (Some(0.95), 10, 10)
        );
        assert_eq!(best.offered_pct, Some(10.0));
    }

    #[test]
    fn the_lowest_threshold_takes_the_most_coverage_at_the_target() {
        let mut records = many(0.9, 10, 10);
        records.extend(many(0.8, 10, 8)); // 18/20 = 90 % together
        records.extend(many(0.7, 10, 5)); // 23/30 < 90 %
        let c = Calibration::of(&records).unwrap();
        let best = c.threshold_for_target_precision.point.unwrap();
        assert_eq!((best.threshold, best.offered), (Some(0.8), 20));
        let none = Calibration::of(&many(0.5, 10, 1)).unwrap();
        assert_eq!(none.threshold_for_target_precision.point, None);
        assert!(
            none.table("engine")
                .contains("no threshold reaches 90 % precision")
        );
    }

    #[test]
    fn no_candidates_no_section() {
        assert_eq!(Calibration::of(&[rec(None), rec(None)]), None);
        assert_eq!(Calibration::of(&[]), None);
    }
}
