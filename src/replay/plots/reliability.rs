//! Observed useful share against mean `p_useful` per decile, over every candidate offered or
//! not, with the diagonal and the ±10-point band of issue 13, and the candidates per decile
//! below ([`crate::replay::score::reliability`]).

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::replay::score::reliability::{Calibration, TARGET_GAP};

use super::data::PlotData;
use super::draw::{
    BLUE, DrawResult, GREY, RED, body_and_footer, decimals_for, draw_nothing, fixed, footer,
    house_mesh, subtitle,
};
use super::fonts::FONT;

/// Draws the figure on `root`.
pub(super) fn draw<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let Some(c) = Calibration::of_programs(&data.records) else {
        return draw_nothing(data, root, "Reliability of p_useful");
    };
    let (body, bottom) = body_and_footer(root);
    let (_, h) = body.dim_in_pixel();
    let (top, lower) = body.split_vertically(h * 72 / 100);
    let pts = |v: Option<f64>| v.map_or_else(|| "–".to_string(), |v| format!("{:.1}", 100.0 * v));
    let mut chart = ChartBuilder::on(&top)
        .caption(
            format!(
                "Reliability of p_useful: {} candidates (offered or not), ECE {} points, \
                 largest gap {} points",
                c.candidates,
                pts(c.ece),
                pts(c.max_abs_gap)
            ),
            (FONT, 20),
        )
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)?;
    house_mesh(
        chart
            .configure_mesh()
            .x_desc("mean p_useful of the decile (predicted)")
            .y_desc("observed useful share")
            .x_labels(11)
            .y_labels(11)
            .x_label_formatter(&fixed(1))
            .y_label_formatter(&fixed(1)),
    )
    .draw()?;
    // Issue 13's band: observed within TARGET_GAP of the mean p_useful.
    let g = TARGET_GAP;
    chart
        .draw_series(std::iter::once(Polygon::new(
            vec![
                (0.0, 0.0),
                (0.0, g),
                (1.0 - g, 1.0),
                (1.0, 1.0),
                (1.0, 1.0 - g),
                (g, 0.0),
            ],
            GREY.mix(0.15).filled(),
        )))?
        .label(format!("within ±{:.0} points", 100.0 * g))
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 24, y + 5)], GREY.mix(0.15).filled()));
    chart
        .draw_series(LineSeries::new(
            [(0.0, 0.0), (1.0, 1.0)],
            GREY.stroke_width(1),
        ))?
        .label("perfect calibration")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 24, y)], GREY.stroke_width(1)));
    let points: Vec<(f64, f64, usize, bool)> = c
        .bins
        .iter()
        .filter_map(|b| {
            Some((
                b.mean_p_useful?,
                b.observed?,
                b.candidates,
                b.within_target.unwrap_or(true),
            ))
        })
        .collect();
    chart
        .draw_series(LineSeries::new(
            points.iter().map(|p| (p.0, p.1)),
            BLUE.stroke_width(2),
        ))?
        .label("observed, per decile of p_useful")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 24, y)], BLUE.stroke_width(2)));
    let radius = |n: usize| (3.0 + 1.5 * (n.max(1) as f64).ln()).round() as i32;
    chart.draw_series(points.iter().map(|&(x, y, n, ok)| {
        let colour = if ok { BLUE } else { RED };
        Circle::new((x, y), radius(n), colour.mix(0.8).filled())
    }))?;
    chart.draw_series(points.iter().map(|&(x, y, n, _)| {
        // Below points high on the chart, above the others.
        let dy = if y > 0.85 { 10 } else { -24 };
        EmptyElement::at((x, y))
            + Text::new(
                format!("n={n}"),
                (-14, dy),
                (FONT, 13).into_font().color(&GREY),
            )
    }))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .draw()?;

    // Below: candidates per decile.
    let most = c
        .bins
        .iter()
        .map(|b| b.candidates)
        .max()
        .unwrap_or(0)
        .max(1) as f64
        * 1.15;
    let mut counts = ChartBuilder::on(&lower)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(72)
        .build_cartesian_2d(0.0..1.0, 0.0..most)?;
    house_mesh(
        counts
            .configure_mesh()
            .x_desc("p_useful decile")
            .y_desc("candidates")
            .x_labels(11)
            .y_labels(4)
            .x_label_formatter(&fixed(1))
            .y_label_formatter(&decimals_for(most)),
    )
    .draw()?;
    counts.draw_series(c.bins.iter().map(|b| {
        Rectangle::new(
            [(b.from + 0.01, 0.0), (b.to - 0.01, b.candidates as f64)],
            BLUE.mix(0.5).filled(),
        )
    }))?;
    counts.draw_series(c.bins.iter().filter(|b| b.candidates > 0).map(|b| {
        EmptyElement::at((b.from + 0.02, b.candidates as f64))
            + Text::new(
                format!("{}", b.candidates),
                (0, -16),
                (FONT, 13).into_font().color(&BLACK),
            )
    }))?;
    footer(
        &bottom,
        &format!(
            "{}; red: a decile outside ±{:.0} points; useful: ≤ 1 mm, ≤ 0.1 rad",
            subtitle(data),
            100.0 * g
        ),
    )
}
