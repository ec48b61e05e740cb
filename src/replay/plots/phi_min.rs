//! Offered % and useful % of predictable waypoints versus the confidence threshold φ_min
//! (dissertation Fig. 4.11), from the φ_min sweep.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::data::PlotData;
use super::draw::{
    BLUE, DrawResult, GREEN, LinePanel, Series, body_and_footer, draw_lines, fixed, footer,
    subtitle, x_range, y_max,
};

/// Draws the figure on `root`.
pub(super) fn draw<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let rows = &data.phi_sweep;
    let offered = Series::new(
        "offered",
        BLUE,
        rows.iter()
            .filter_map(|r| Some((r.phi_min, r.offered_pct?))),
    );
    let useful = Series::new(
        "useful (≤ 1 mm, ≤ 0.1 rad)",
        GREEN,
        rows.iter().filter_map(|r| Some((r.phi_min, r.useful_pct?))),
    );
    let c = &data.config;
    let panel = LinePanel {
        caption: format!(
            "Offered and useful guesses vs confidence threshold φ_min (δ = {}, h = {})",
            c.delta, c.predict.horizon
        ),
        x_desc: "φ_min",
        y_desc: "% of predictable waypoints",
        x_range: x_range(rows.iter().map(|r| r.phi_min)),
        y_max: y_max(&[&offered, &useful], 10.0),
        x_labels: &fixed(2),
        marker: Some((
            c.predict.phi_min,
            format!("{} profile: φ_min = {}", data.profile, c.predict.phi_min),
        )),
        series: vec![offered, useful],
        notes: Vec::new(),
    };
    let (body, bottom) = body_and_footer(root);
    draw_lines(&body, &panel)?;
    footer(&bottom, &subtitle(data))
}
