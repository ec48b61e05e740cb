//! Precision against offered % of predictable waypoints as the offer threshold on `p_useful`
//! moves from 0 to 1.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::replay::score::reliability::{Calibration, TARGET_PRECISION_PCT};

use super::data::PlotData;
use super::draw::{
    BLUE, DrawResult, LinePanel, RED, Series, body_and_footer, decimals_for, draw_lines,
    draw_nothing, footer, subtitle,
};

/// Draws the figure on `root`.
pub(super) fn draw<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let Some(c) = Calibration::of_programs(&data.records) else {
        return draw_nothing(
            data,
            root,
            "Precision vs offered share as the p_useful threshold moves",
        );
    };
    let curve = Series::new(
        "precision of the offers with p_useful ≥ threshold",
        BLUE,
        c.risk_coverage
            .iter()
            .filter_map(|p| Some((p.offered_pct?, p.precision_pct?))),
    );
    let x_hi = curve.points.iter().map(|p| p.0).fold(0.0_f64, f64::max);
    let x_max = (x_hi * 1.08).max(1.0);
    let target = Series::new(
        &format!("{TARGET_PRECISION_PCT:.0} % precision"),
        RED,
        [(0.0, TARGET_PRECISION_PCT), (x_max, TARGET_PRECISION_PCT)],
    );
    // Thresholds written beside the curve (once per distinct point).
    let mut notes: Vec<(f64, f64, String)> = Vec::new();
    for t in [0.0, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99] {
        let Some(p) = c
            .risk_coverage
            .iter()
            .find(|p| p.threshold.is_some_and(|u| (u - t).abs() < 1e-9))
        else {
            continue;
        };
        let (Some(x), Some(y)) = (p.offered_pct, p.precision_pct) else {
            continue;
        };
        if notes
            .iter()
            .all(|n| (n.0 - x).abs() > 0.01 * x_max || (n.1 - y).abs() > 1.0)
        {
            notes.push((x, y, format!("t={t}")));
        }
    }
    let marker = c.as_offered.offered_pct.map(|x| {
        let threshold = data
            .config
            .offer
            .map_or_else(String::new, |o| match o.threshold {
                Some(t) => format!(" (threshold {t})"),
                None => format!(" (the cell's threshold for {} % right)", 100.0 * o.target),
            });
        (
            x,
            format!(
                "{} profile offers {:.1} %{threshold}, precision {}",
                data.profile,
                x,
                fmt_pct(c.as_offered.precision_pct)
            ),
        )
    });
    let best = c.threshold_for_target_precision.point.as_ref().map_or_else(
        || format!("no threshold reaches {TARGET_PRECISION_PCT:.0} %"),
        |p| {
            format!(
                "lowest threshold for ≥ {TARGET_PRECISION_PCT:.0} %: {:.3} ({:.1} % offered)",
                p.threshold.unwrap_or(f64::NAN),
                p.offered_pct.unwrap_or(f64::NAN)
            )
        },
    );
    let panel = LinePanel {
        caption: format!("Risk–coverage of p_useful: {best}"),
        x_desc: "offered, % of predictable waypoints",
        y_desc: "precision of the offers, %",
        x_range: 0.0..x_max,
        y_max: 105.0,
        x_labels: &decimals_for(x_max),
        marker,
        series: vec![curve, target],
        notes,
    };
    let (body, bottom) = body_and_footer(root);
    draw_lines(&body, &panel)?;
    footer(
        &bottom,
        &format!(
            "{}; {} candidates, offered when p_useful ≥ t for t = 0, 0.01, …, 1",
            subtitle(data),
            c.candidates
        ),
    )
}

fn fmt_pct(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_string(), |v| format!("{v:.1} %"))
}
