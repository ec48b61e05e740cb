//! The drawing kit the figures share: colours, a chart of lines with markers and legend
//! ([`LinePanel`], [`draw_lines`]), axis ranges and tick labels, the footer line, and the chart
//! a figure shows when it has nothing to show.

use std::error::Error as StdError;
use std::ops::Range;

use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;

use super::data::PlotData;
use super::fonts::FONT;

pub(super) const BLUE: RGBColor = RGBColor(31, 119, 180);
pub(super) const ORANGE: RGBColor = RGBColor(255, 127, 14);
pub(super) const GREEN: RGBColor = RGBColor(44, 160, 44);
pub(super) const RED: RGBColor = RGBColor(214, 39, 40);
pub(super) const GREY: RGBColor = RGBColor(127, 127, 127);

/// What drawing a figure gives: plotters' errors are of the backend's type, boxed.
pub(super) type DrawResult = Result<(), Box<dyn StdError + Send + Sync>>;

/// The house style of a chart's mesh: label and axis fonts, no light grid, a faint bold one.
pub(super) fn house_mesh<'m, 'a, 'b, X, Y, XT, YT, DB>(
    mesh: &'m mut MeshStyle<'a, 'b, X, Y, DB>,
) -> &'m mut MeshStyle<'a, 'b, X, Y, DB>
where
    X: Ranged<ValueType = XT> + ValueFormatter<XT>,
    Y: Ranged<ValueType = YT> + ValueFormatter<YT>,
    DB: DrawingBackend,
{
    mesh.label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.12))
}

/// A line with markers.
pub(super) struct Series {
    pub(super) label: String,
    pub(super) color: RGBColor,
    pub(super) points: Vec<(f64, f64)>,
}

impl Series {
    pub(super) fn new(
        label: &str,
        color: RGBColor,
        points: impl IntoIterator<Item = (f64, f64)>,
    ) -> Series {
        Series {
            label: label.to_string(),
            color,
            points: points.into_iter().collect(),
        }
    }
}

/// One chart of lines.
pub(super) struct LinePanel<'a> {
    pub(super) caption: String,
    pub(super) x_desc: &'a str,
    pub(super) y_desc: &'a str,
    pub(super) x_range: Range<f64>,
    /// Upper end of y; the lower end is 0.
    pub(super) y_max: f64,
    pub(super) x_labels: &'a dyn Fn(&f64) -> String,
    /// A vertical marker (the run's setting) with its legend text.
    pub(super) marker: Option<(f64, String)>,
    pub(super) series: Vec<Series>,
    /// Text drawn just above a point.
    pub(super) notes: Vec<(f64, f64, String)>,
}

pub(super) fn draw_lines<DB>(area: &DrawingArea<DB, Shift>, p: &LinePanel<'_>) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72);
    if !p.caption.is_empty() {
        builder.caption(&p.caption, (FONT, 22));
    }
    let mut chart = builder.build_cartesian_2d(p.x_range.clone(), 0.0..p.y_max)?;
    let y_labels = decimals_for(p.y_max);
    house_mesh(
        chart
            .configure_mesh()
            .x_desc(p.x_desc)
            .y_desc(p.y_desc)
            .x_labels(12)
            .y_labels(8)
            .x_label_formatter(p.x_labels)
            .y_label_formatter(&y_labels),
    )
    .draw()?;
    if let Some((x, label)) = p.marker.as_ref().filter(|(x, _)| p.x_range.contains(x)) {
        chart
            .draw_series(LineSeries::new(
                [(*x, 0.0), (*x, p.y_max)],
                GREY.stroke_width(1),
            ))?
            .label(label.as_str())
            .legend(|(x, y)| PathElement::new([(x, y), (x + 24, y)], GREY.stroke_width(1)));
    }
    for s in &p.series {
        let color = s.color;
        chart
            .draw_series(LineSeries::new(
                s.points.iter().copied(),
                color.stroke_width(2),
            ))?
            .label(s.label.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 24, y)], color.stroke_width(2)));
        chart.draw_series(
            s.points
                .iter()
                .map(|&(x, y)| Circle::new((x, y), 4, color.filled())),
        )?;
    }
    chart.draw_series(p.notes.iter().map(|(x, y, text)| {
        EmptyElement::at((*x, *y))
            + Text::new(
                text.clone(),
                (-12, -22),
                (FONT, 13).into_font().color(&GREY),
            )
    }))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .draw()?;
    Ok(())
}

/// Upper end of a y axis from 0: room above the largest value for the legend, and at least
/// `floor` (so that errors of a few µm do not fill an axis as if they mattered).
pub(super) fn y_max(series: &[&Series], floor: f64) -> f64 {
    let max = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .fold(0.0_f64, f64::max);
    (max * 1.4).max(floor)
}

pub(super) fn fixed(digits: usize) -> impl Fn(&f64) -> String {
    move |v: &f64| format!("{v:.digits$}")
}

/// Tick labels of an axis `span` long: enough decimals to tell ticks apart, and no "-0.00".
pub(super) fn decimals_for(span: f64) -> impl Fn(&f64) -> String {
    let digits = if span >= 20.0 {
        0
    } else {
        (-(span / 10.0).log10().floor()).clamp(0.0, 6.0) as usize
    };
    let zero = 0.5 * 10f64.powi(-(digits as i32));
    move |v: &f64| {
        let v = if v.abs() < zero { 0.0 } else { *v };
        format!("{v:.digits$}")
    }
}

pub(super) fn x_range(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if lo.is_finite() && hi.is_finite() && hi > lo {
        let pad = (hi - lo) * 0.03;
        (lo - pad)..(hi + pad)
    } else if lo.is_finite() {
        (lo - 0.5)..(lo + 0.5)
    } else {
        0.0..1.0
    }
}

pub(super) fn subtitle(data: &PlotData) -> String {
    format!(
        "{} profile, {} programs, waypoints with ≥ 2 predecessors",
        data.profile, data.programs
    )
}

/// The figure's body and a strip at the bottom for [`footer`].
pub(super) fn body_and_footer<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    let (_, h) = root.dim_in_pixel();
    root.split_vertically(h.saturating_sub(28))
}

pub(super) fn footer<DB>(area: &DrawingArea<DB, Shift>, text: &str) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    area.draw(&Text::new(
        text.to_string(),
        (16, 4),
        (FONT, 14).into_font().color(&GREY),
    ))?;
    Ok(())
}

/// A chart that says why it has nothing to show (no candidate carries `p_useful`).
pub(super) fn draw_nothing<DB>(
    data: &PlotData,
    root: &DrawingArea<DB, Shift>,
    caption: &str,
) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let (body, bottom) = body_and_footer(root);
    let mut chart = ChartBuilder::on(&body)
        .caption(caption, (FONT, 20))
        .margin(12)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)?;
    chart.draw_series(std::iter::once(Text::new(
        "no candidate has a p_useful: this profile has no offer rule".to_string(),
        (0.2, 0.5),
        (FONT, 18).into_font().color(&GREY),
    )))?;
    footer(&bottom, &subtitle(data))
}
