//! The engine's confidence figure (`p_useful` under the experts' offer rule) against the
//! Cartesian error of each offered guess, on a logarithmic error axis.

use std::collections::BTreeMap;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::engine::EngineConfig;
use crate::replay::score::metrics::spearman;

use super::data::{PlotData, confidence_points};
use super::draw::{
    DrawResult, GREEN, GREY, RED, body_and_footer, decimals_for, footer, house_mesh, subtitle,
    x_range,
};
use super::fonts::FONT;

/// Errors shown at a smaller value on the scatter's logarithmic axis, mm.
pub const ERROR_FLOOR_MM: f64 = 1e-3;

/// What the engine reports as its confidence under `config` (see `EngineMethod::predict`).
pub fn confidence_desc(config: &EngineConfig) -> &'static str {
    if config.offer.is_some() {
        "confidence = p_useful (the experts' offer rule)"
    } else if config.predict.max_misfit.is_some() {
        "confidence = −match misfit (higher = surer)"
    } else {
        "confidence = φ"
    }
}

/// Draws the figure on `root`.
pub(super) fn draw<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let points = confidence_points(&data.records);
    let y = |mm: f64| mm.max(ERROR_FLOOR_MM).log10();
    let xr = x_range(points.iter().map(|p| p.confidence));
    let y_hi = points
        .iter()
        .map(|p| y(p.cart_mm))
        .fold(0.0_f64, f64::max)
        .ceil()
        .max(1.0)
        + 0.3;
    let y_lo = ERROR_FLOOR_MM.log10() - 0.3;
    let (conf, err): (Vec<f64>, Vec<f64>) =
        points.iter().map(|p| (p.confidence, p.cart_mm)).unzip();
    let rho = spearman(&conf, &err).map_or_else(|| "–".to_string(), |r| format!("{r:.2}"));
    let useful = points.iter().filter(|p| p.useful).count();

    // Guesses that would land on the same spot (1/150 of the x range, 1/50 of the y range)
    // are drawn as one circle at their mean whose size grows with their number.
    let mut cells: BTreeMap<(bool, i64, i64), (usize, f64, f64)> = BTreeMap::new();
    for p in &points {
        let (px, py) = (p.confidence, y(p.cart_mm));
        let cx = ((px - xr.start) / (xr.end - xr.start) * 150.0).floor() as i64;
        let cy = ((py - y_lo) / (y_hi - y_lo) * 50.0).floor() as i64;
        let cell = cells.entry((p.useful, cx, cy)).or_insert((0, 0.0, 0.0));
        cell.0 += 1;
        cell.1 += px;
        cell.2 += py;
    }
    let circles: Vec<(bool, usize, (f64, f64))> = cells
        .iter()
        .map(|(&(u, _, _), &(n, sx, sy))| (u, n, (sx / n as f64, sy / n as f64)))
        .collect();
    let radius = |n: usize| (3.0 + 2.0 * (n as f64).ln()).round() as i32;
    // The count is written beside the three largest circles of each colour (10 or more).
    let mut labelled: Vec<&(bool, usize, (f64, f64))> = Vec::new();
    for colour in [false, true] {
        let mut mine: Vec<_> = circles
            .iter()
            .filter(|c| c.0 == colour && c.1 >= 10)
            .collect();
        mine.sort_by_key(|c| std::cmp::Reverse(c.1));
        labelled.extend(mine.into_iter().take(3));
    }

    let (body, bottom) = body_and_footer(root);
    let mut chart = ChartBuilder::on(&body)
        .caption(
            format!(
                "Confidence vs error of {} offered guesses: {} useful (green), {} not (red); \
                 Spearman ρ = {rho}",
                points.len(),
                useful,
                points.len() - useful
            ),
            (FONT, 20),
        )
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(xr.clone(), y_lo..y_hi)?;
    let y_labels = |v: &f64| {
        let r = v.round();
        if (v - r).abs() > 1e-9 {
            return String::new();
        }
        let mm = if r >= 0.0 {
            format!("{}", 10_u64.pow(r as u32))
        } else {
            format!("{:.*}", -r as usize, 10f64.powf(r))
        };
        if r == ERROR_FLOOR_MM.log10().round() {
            format!("≤ {mm}")
        } else {
            mm
        }
    };
    house_mesh(
        chart
            .configure_mesh()
            .x_desc(confidence_desc(&data.config))
            .y_desc("Cartesian error, mm (log)")
            .x_labels(10)
            .y_labels(((y_hi - y_lo).ceil() as usize + 1).max(2))
            .x_label_formatter(&decimals_for(xr.end - xr.start))
            .y_label_formatter(&y_labels),
    )
    .draw()?;
    // The useful limit, labelled at its left end.
    chart.draw_series(LineSeries::new(
        [(xr.start, 0.0), (xr.end, 0.0)],
        GREY.stroke_width(1),
    ))?;
    chart.draw_series(std::iter::once(
        EmptyElement::at((xr.start, 0.0))
            + Text::new(
                "1 mm".to_string(),
                (6, -18),
                (FONT, 14).into_font().color(&GREY),
            ),
    ))?;
    for &(useful, n, at) in &circles {
        let colour = if useful { GREEN } else { RED };
        chart.draw_series(std::iter::once(Circle::new(
            at,
            radius(n),
            colour.mix(0.55).filled(),
        )))?;
    }
    let right_edge = xr.end - 0.1 * (xr.end - xr.start);
    chart.draw_series(labelled.iter().map(|&&(_, n, at)| {
        // Left of circles near the right edge, right of the others.
        let dx = if at.0 > right_edge {
            -radius(n) - 40
        } else {
            radius(n) + 3
        };
        EmptyElement::at(at)
            + Text::new(
                format!("{n}"),
                (dx, -8),
                (FONT, 14).into_font().color(&BLACK),
            )
    }))?;
    footer(
        &bottom,
        &format!(
            "{}; errors < {ERROR_FLOOR_MM} mm at {ERROR_FLOOR_MM}; larger circles: several guesses",
            subtitle(data)
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confidence_label_follows_the_engine_method() {
        assert!(confidence_desc(&EngineConfig::default()).contains("p_useful"));
        let no_rule = EngineConfig {
            offer: None,
            ..EngineConfig::default()
        };
        assert!(confidence_desc(&no_rule).contains("misfit"));
        let dissertation = EngineConfig::profile(crate::engine::Profile::Dissertation);
        assert_eq!(confidence_desc(&dissertation), "confidence = φ");
    }
}
