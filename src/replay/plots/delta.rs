//! Median Cartesian and angle error of the offered guesses versus the complexity δ (dissertation
//! Fig. 4.10), from the δ sweep.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::data::PlotData;
use super::draw::{
    BLUE, DrawResult, LinePanel, ORANGE, Series, body_and_footer, draw_lines, fixed, footer,
    subtitle, x_range, y_max,
};

/// Draws the figure on `root`.
pub(super) fn draw<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let rows = &data.delta_sweep;
    let c = &data.config;
    let marker = Some((
        c.delta,
        format!("{} profile: δ = {}", data.profile, c.delta),
    ));
    let cart = Series::new(
        "median Cartesian error",
        BLUE,
        rows.iter()
            .filter_map(|r| Some((r.delta, r.median_cart_mm?))),
    );
    let angle = Series::new(
        "median angle error",
        ORANGE,
        rows.iter()
            .filter_map(|r| Some((r.delta, 1e3 * r.median_angle_rad?))),
    );
    let xr = x_range(rows.iter().map(|r| r.delta));
    let (body, bottom) = body_and_footer(root);
    let panels = body.split_evenly((2, 1));
    let (cart_max, angle_max) = (y_max(&[&cart], 1.0), y_max(&[&angle], 1.0));
    draw_lines(
        &panels[0],
        &LinePanel {
            caption: format!(
                "Median error of offered guesses vs complexity δ (φ_min = {}, h = {})",
                c.predict.phi_min, c.predict.horizon
            ),
            x_desc: "δ",
            y_desc: "Cartesian error, mm",
            x_range: xr.clone(),
            y_max: cart_max,
            x_labels: &fixed(1),
            marker: marker.clone(),
            series: vec![cart],
            notes: Vec::new(),
        },
    )?;
    draw_lines(
        &panels[1],
        &LinePanel {
            caption: String::new(),
            x_desc: "δ",
            y_desc: "angle error, mrad",
            x_range: xr,
            y_max: angle_max,
            x_labels: &fixed(1),
            marker,
            series: vec![angle],
            notes: Vec::new(),
        },
    )?;
    footer(
        &bottom,
        &format!("{}; axes reach at least 1 mm and 1 mrad", subtitle(data)),
    )
}
