//! Median error versus the number of moves the model had assimilated when it guessed (dissertation
//! Fig. 4.13), pooled over programs in bins that double in width, with the offered and useful %
//! of each bin below.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::data::{LearningBin, PlotData, learning_curve};
use super::draw::{
    BLUE, DrawResult, GREEN, LinePanel, ORANGE, Series, body_and_footer, draw_lines, footer,
    subtitle, y_max,
};

/// Bins of the learning curve with fewer offered guesses than this get no median point.
pub const MIN_OFFERED_FOR_MEDIAN: usize = 5;

/// Draws the figure on `root`.
pub(super) fn draw<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let bins = learning_curve(&data.records);
    // x = log2 of the bin's lower edge, the point in the middle of its bin.
    let x = |b: &LearningBin| (b.from as f64).log2() + 0.5;
    let enough = |b: &&LearningBin| b.offered >= MIN_OFFERED_FOR_MEDIAN;
    let cart = Series::new(
        "median Cartesian error",
        BLUE,
        bins.iter()
            .filter(enough)
            .filter_map(|b| Some((x(b), b.median_cart_mm?))),
    );
    let angle = Series::new(
        "median angle error",
        ORANGE,
        bins.iter()
            .filter(enough)
            .filter_map(|b| Some((x(b), 1e3 * b.median_angle_rad?))),
    );
    let offered = Series::new(
        "offered",
        BLUE,
        bins.iter().filter_map(|b| Some((x(b), b.offered_pct()?))),
    );
    let useful = Series::new(
        "useful",
        GREEN,
        bins.iter().filter_map(|b| Some((x(b), b.useful_pct()?))),
    );
    let pct_max = y_max(&[&offered, &useful], 10.0);
    let notes = |values: &dyn Fn(&LearningBin) -> Option<(f64, usize)>| {
        bins.iter()
            .filter_map(|b| {
                let (y, n) = values(b)?;
                Some((x(b), y, format!("n={n}")))
            })
            .collect::<Vec<_>>()
    };
    let last = bins.last().map_or(1.0, |b| (b.to as f64).log2());
    let xr = -0.15..last.max(1.0) + 0.15;
    let powers = |v: &f64| {
        let r = v.round();
        if (v - r).abs() < 1e-9 && r >= 0.0 {
            format!("{}", 2_u64.pow(r as u32))
        } else {
            String::new()
        }
    };
    let x_desc = "moves assimilated into the model before the guess (bins 1, 2–3, 4–7, …)";
    let (body, bottom) = body_and_footer(root);
    let panels = body.split_evenly((3, 1));
    draw_lines(
        &panels[0],
        &LinePanel {
            caption: "Median error of offered guesses vs moves learned".to_string(),
            x_desc,
            y_desc: "Cartesian error, mm",
            x_range: xr.clone(),
            y_max: y_max(&[&cart], 1.0),
            x_labels: &powers,
            marker: None,
            notes: notes(&|b| Some((b.median_cart_mm?, b.offered)).filter(|_| enough(&b))),
            series: vec![cart],
        },
    )?;
    draw_lines(
        &panels[1],
        &LinePanel {
            caption: String::new(),
            x_desc,
            y_desc: "angle error, mrad",
            x_range: xr.clone(),
            y_max: y_max(&[&angle], 1.0),
            x_labels: &powers,
            marker: None,
            notes: Vec::new(),
            series: vec![angle],
        },
    )?;
    draw_lines(
        &panels[2],
        &LinePanel {
            caption: String::new(),
            x_desc,
            y_desc: "% of predictable in bin",
            x_range: xr,
            y_max: pct_max,
            x_labels: &powers,
            marker: None,
            notes: notes(&|b| Some((b.offered_pct()?, b.predictable))),
            series: vec![offered, useful],
        },
    )?;
    footer(
        &bottom,
        &format!(
            "{}; n = offered guesses (top; medians need ≥ {MIN_OFFERED_FOR_MEDIAN}), waypoints (bottom)",
            subtitle(data)
        ),
    )
}
