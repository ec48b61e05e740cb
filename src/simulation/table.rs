//! The programming-time table in the shape of the dissertation's Table 4.1: per condition the mean
//! and standard deviation of the time to teach a routine, the change against the baseline, and the
//! rank-sum test against the baseline, with the dissertation's figures beside them.

use std::fmt::Write;

use serde::Serialize;

use super::SimulationError;
use super::operator::Time;
use super::plan::{Condition, DissertationFigure, RoutineResult};
use super::stats::{RankSum, mean, rank_sum, std_dev};
use crate::kinematics::placement::ProgramArm;

/// One row of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConditionSummary {
    pub key: String,
    pub label: String,
    /// Routines × seeds.
    pub n: usize,
    pub waypoints: usize,
    /// Programming time per routine, s.
    pub mean_s: f64,
    pub std_s: f64,
    /// Sum over every routine and seed, s.
    pub total_s: f64,
    /// Change of the mean against the first condition (the baseline), %.
    pub change_pct: Option<f64>,
    /// Rank-sum test of the routine times against the baseline's.
    pub rank_sum: Option<RankSum>,
    /// Mean time per routine by component.
    pub mean_time: Time,
    pub offered: usize,
    pub accepted: usize,
    pub adjusted: usize,
    pub rejected: usize,
    pub dismissed: usize,
    /// Offered suggestions marked unreachable (policy `flag` only).
    pub offered_unreachable: usize,
    /// Taught waypoints outside the arm's reach.
    pub unreachable_waypoints: usize,
    /// The dissertation's figure for the condition (`seed` in the JSON).
    #[serde(rename = "seed")]
    pub dissertation: Option<DissertationFigure>,
}

/// Summarises `results` per condition; the first condition is the baseline.
pub fn summarise(
    conditions: &[Condition],
    results: &[RoutineResult],
) -> Result<Vec<ConditionSummary>, SimulationError> {
    let Some(baseline) = conditions.first() else {
        return Err(SimulationError::EmptyPlan);
    };
    let times = |key: &str| -> Vec<f64> {
        results
            .iter()
            .filter(|r| r.condition == key)
            .map(|r| r.time_s)
            .collect()
    };
    let base_times = times(&baseline.key);
    let base_mean = mean(&base_times);
    let mut rows = Vec::with_capacity(conditions.len());
    for (i, c) in conditions.iter().enumerate() {
        let rs: Vec<&RoutineResult> = results.iter().filter(|r| r.condition == c.key).collect();
        let t = times(&c.key);
        let m = mean(&t).ok_or_else(|| SimulationError::NoResults(c.key.clone()))?;
        let mut mean_time = Time::default();
        for r in &rs {
            mean_time.add(&r.time);
        }
        let n = rs.len() as f64;
        mean_time.travel_s /= n;
        mean_time.aim_s /= n;
        mean_time.look_s /= n;
        mean_time.record_s /= n;
        let sum = |f: fn(&RoutineResult) -> usize| rs.iter().map(|r| f(r)).sum::<usize>();
        rows.push(ConditionSummary {
            key: c.key.clone(),
            label: c.label.clone(),
            n: rs.len(),
            waypoints: sum(|r| r.waypoints),
            mean_s: m,
            std_s: std_dev(&t).unwrap_or(0.0),
            total_s: t.iter().sum(),
            change_pct: (i > 0)
                .then_some(base_mean)
                .flatten()
                .map(|b| 100.0 * (m - b) / b),
            rank_sum: if i > 0 {
                Some(rank_sum(&t, &base_times)?)
            } else {
                None
            },
            mean_time,
            offered: sum(|r| r.offered),
            accepted: sum(|r| r.accepted),
            adjusted: sum(|r| r.adjusted),
            rejected: sum(|r| r.rejected),
            dismissed: sum(|r| r.dismissed),
            offered_unreachable: sum(|r| r.offered_unreachable),
            unreachable_waypoints: sum(|r| r.unreachable_waypoints),
            dissertation: c.dissertation,
        });
    }
    Ok(rows)
}

fn opt(v: Option<f64>, f: impl Fn(f64) -> String) -> String {
    v.map(f).unwrap_or_else(|| "–".into())
}

fn p_value(p: f64) -> String {
    if p < 1e-4 {
        "< 0.0001".into()
    } else {
        format!("{p:.4}")
    }
}

/// The table as Markdown: our figures, then the dissertation's for the same row.
/// The programs' arms as a Markdown table: which arm, how it was chosen, where it stands and how
/// many of the taught waypoints it reaches, with the total.
pub fn arms_markdown(programs: &[String], arms: &[ProgramArm]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| program | arm | chosen | named in the sources | base x, y, z mm | waypoints | reached | out of reach |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|--:|--:|--:|");
    let (mut total, mut reached) = (0, 0);
    for (name, a) in programs.iter().zip(arms) {
        total += a.waypoints;
        reached += a.reached;
        let _ = writeln!(
            s,
            "| {name} | {} | {} | {} | {:.0}, {:.0}, {:.0} | {} | {} | {:.1} % |",
            a.model.as_deref().unwrap_or(&a.robot),
            a.chosen.name(),
            a.named.as_deref().unwrap_or("-"),
            a.base.x,
            a.base.y,
            a.base.z,
            a.waypoints,
            a.reached,
            100.0 * (a.waypoints - a.reached) as f64 / a.waypoints.max(1) as f64,
        );
    }
    let _ = writeln!(
        s,
        "| all | | | | | {total} | {reached} | {:.1} % |",
        100.0 * (total - reached) as f64 / total.max(1) as f64
    );
    s
}

/// The conditions' summaries as a Markdown table.
pub fn markdown(rows: &[ConditionSummary]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| condition | n | mean s | std s | change | rank-sum p | offered | accepted | adjusted | rejected | seed mean s | seed std s | seed change | seed conf. |"
    );
    let _ = writeln!(
        s,
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {:.1} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.label,
            r.n,
            r.mean_s,
            r.std_s,
            opt(r.change_pct, |c| format!("{c:+.1} %")),
            opt(r.rank_sum.map(|t| t.p), p_value),
            r.offered,
            r.accepted,
            r.adjusted,
            r.rejected,
            opt(r.dissertation.map(|f| f.mean_s), |v| format!("{v:.1}")),
            opt(r.dissertation.map(|f| f.std_s), |v| format!("{v:.2}")),
            opt(r.dissertation.and_then(|f| f.change_pct), |c| format!(
                "{c:+.2} %"
            )),
            opt(r.dissertation.and_then(|f| f.confidence_pct), |c| format!(
                "{c:.2} %"
            )),
        );
    }
    s
}

/// Where the time went, per condition (mean per routine).
pub fn breakdown_markdown(rows: &[ConditionSummary]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| condition | waypoints | travel s | aiming s | looking s | recording s | total s |"
    );
    let _ = writeln!(s, "|---|--:|--:|--:|--:|--:|--:|");
    for r in rows {
        let t = &r.mean_time;
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            r.label,
            r.waypoints,
            t.travel_s,
            t.aim_s,
            t.look_s,
            t.record_s,
            t.total()
        );
    }
    s
}

/// A bar chart (SVG) of the change in mean programming time against the baseline, simulated
/// beside the dissertation's, per condition with predictions. Written by hand (no plotting
/// dependency).
pub fn change_chart_svg(rows: &[ConditionSummary], title: &str) -> String {
    let bars: Vec<(&str, Option<f64>, Option<f64>)> = rows
        .iter()
        .skip(1)
        .map(|r| {
            (
                r.label.as_str(),
                r.change_pct,
                r.dissertation.and_then(|f| f.change_pct),
            )
        })
        .collect();
    let lowest = bars
        .iter()
        .flat_map(|b| [b.1, b.2])
        .flatten()
        .fold(-10.0f64, f64::min);
    let y_min = (lowest / 10.0).floor() * 10.0;
    let (w, h, left, top, bottom) = (760.0, 360.0, 70.0, 40.0, 60.0);
    let plot_h = h - top - bottom;
    // y = 0 at the top of the plot area, y_min at its bottom.
    let y = |v: f64| top + plot_h * (v / y_min).clamp(0.0, 1.0);
    let group = (w - left - 20.0) / bars.len().max(1) as f64;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="20" text-anchor="middle" font-size="14">{}</text>"#,
        w / 2.0,
        escape(title)
    );
    let mut tick = 0.0;
    while tick >= y_min {
        let ty = y(tick);
        let _ = writeln!(
            s,
            r##"<line x1="{left}" x2="{}" y1="{ty:.1}" y2="{ty:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" text-anchor="end">{tick:.0} %</text>"##,
            w - 20.0,
            left - 6.0,
            ty + 4.0
        );
        tick -= 10.0;
    }
    for (i, (label, ours, dissertation)) in bars.iter().enumerate() {
        let x0 = left + group * i as f64;
        let bw = group * 0.3;
        for (j, (v, colour)) in [(ours, "#3b6ea5"), (dissertation, "#aaaaaa")]
            .iter()
            .enumerate()
        {
            let Some(v) = v else { continue };
            let x = x0 + group * 0.15 + bw * j as f64 + 2.0 * j as f64;
            let (ya, yb) = (y(0.0), y(v.min(0.0)));
            let _ = writeln!(
                s,
                r#"<rect x="{x:.1}" y="{ya:.1}" width="{bw:.1}" height="{:.1}" fill="{colour}"/><text x="{:.1}" y="{:.1}" text-anchor="middle">{v:+.1}</text>"#,
                (yb - ya).max(0.5),
                x + bw / 2.0,
                yb + 14.0
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            x0 + group / 2.0,
            h - bottom + 34.0,
            escape(label)
        );
    }
    let _ = writeln!(
        s,
        r##"<rect x="{left}" y="{}" width="12" height="12" fill="#3b6ea5"/><text x="{}" y="{}">simulated</text><rect x="{}" y="{}" width="12" height="12" fill="#aaaaaa"/><text x="{}" y="{}">seed, Table 4.1 (lab operators)</text>"##,
        h - 18.0,
        left + 16.0,
        h - 8.0,
        left + 110.0,
        h - 18.0,
        left + 126.0,
        h - 8.0
    );
    s.push_str("</svg>\n");
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulation::plan::table_4_1_conditions;

    fn result(condition: &str, time_s: f64) -> RoutineResult {
        RoutineResult {
            condition: condition.into(),
            seed: 1,
            program: "p".into(),
            program_index: 0,
            routine: "r".into(),
            routine_index: 0,
            waypoints: 3,
            time_s,
            time: Time {
                aim_s: time_s,
                ..Time::default()
            },
            offered: 1,
            accepted: 1,
            adjusted: 0,
            rejected: 0,
            dismissed: 0,
            offered_unreachable: 0,
            unreachable_waypoints: 0,
        }
    }

    #[test]
    fn summary_has_change_and_test_against_the_baseline() {
        let conditions = table_4_1_conditions();
        let mut results = Vec::new();
        for i in 0..20 {
            results.push(result("none", 100.0 + i as f64));
            results.push(result("seed_phi08_h3", 50.0 + i as f64));
            results.push(result("seed_phi05_h2", 100.0 + i as f64));
            results.push(result("default", 60.0 + i as f64));
            results.push(result("default_calibrated", 58.0 + i as f64));
            results.push(result("default_calibrated_p05", 55.0 + i as f64));
        }
        let rows = summarise(&conditions, &results).unwrap();
        assert_eq!(rows[0].change_pct, None);
        assert!((rows[0].mean_s - 109.5).abs() < 1e-12);
        assert!((rows[1].change_pct.unwrap() - 100.0 * (59.5 - 109.5) / 109.5).abs() < 1e-9);
        assert!(rows[1].rank_sum.unwrap().p < 1e-6);
        assert!(rows[2].rank_sum.unwrap().p > 0.9);
        assert_eq!(rows[3].n, 20);
        assert!((rows[3].mean_time.aim_s - 69.5).abs() < 1e-12);
        let md = markdown(&rows);
        assert!(md.contains("| none | 20 | 109.5 |"), "{md}");
        assert!(md.contains("-33.88 %"), "{md}");
        assert!(breakdown_markdown(&rows).contains("| default profile, arm only | 60 |"));
        let svg = change_chart_svg(&rows, "change <test>");
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(
            svg.contains("-33.9") && svg.contains("change &lt;test&gt;"),
            "{svg}"
        );
        let missing = summarise(&conditions, &results[..1]);
        assert!(matches!(missing, Err(SimulationError::NoResults(_))));
    }
}
