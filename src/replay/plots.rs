//! Plots of a replay: the seed's figures 4.10–4.13 and a confidence/error scatter, as PNG and SVG.
//!
//! Six figures ([`Figure`]), all over the scoreboard's headline population (waypoints with at
//! least two predecessors):
//!
//! - [`Figure::PhiMin`]: offered % and useful % of predictable waypoints versus the confidence
//!   threshold φ_min (seed Fig. 4.11).
//! - [`Figure::Delta`]: median Cartesian and angle error of the offered guesses versus the
//!   complexity δ (seed Fig. 4.10).
//! - [`Figure::LearningCurve`]: median error versus the number of moves the model had
//!   assimilated when it guessed (seed Fig. 4.13), pooled over programs in bins that double in
//!   width, with the offered and useful % of each bin below.
//! - [`Figure::ConfidenceError`]: the engine's confidence figure (`p_useful` under the experts'
//!   offer rule) against the Cartesian error of each offered guess.
//! - [`Figure::Reliability`]: observed useful share against mean `p_useful` per decile, over
//!   every candidate offered or not, with the diagonal and the ±10-point band of issue 13, and
//!   the candidates per decile below ([`super::reliability`]).
//! - [`Figure::RiskCoverage`]: precision against offered % of predictable waypoints as the offer
//!   threshold on `p_useful` moves from 0 to 1.
//!
//! The last two need candidates with a `p_useful` (the engine under the experts' offer rule);
//! without them (the seed profile) they say so on an empty chart.
//!
//! [`plot_data`] replays the engine to get what the figures show (the two sweeps and the
//! per-waypoint records at the run's settings). Rendering ([`render_svg`], [`render_png`]) is
//! pure; only [`write_plots`] touches files.
//!
//! Text is laid out and rasterised with DejaVu Sans (the `dejavu` crate) through plotters'
//! `ab_glyph` feature, so no system font library is needed.

use std::collections::BTreeMap;
use std::error::Error as StdError;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use serde::Serialize;
use thiserror::Error;

use crate::engine::{ConfigError, EngineConfig};

use super::corpus::Program;
use super::engine_method::EngineMethod;
use super::metrics::{ProgramRecord, WaypointRecord, median, replay_program, spearman};
use super::reliability::{Calibration, TARGET_GAP, TARGET_PRECISION_PCT};
use super::sweep::{SweepRow, sweep};

/// Bins of the learning curve with fewer offered guesses than this get no median point.
pub const MIN_OFFERED_FOR_MEDIAN: usize = 5;

/// Errors shown at a smaller value on the scatter's logarithmic axis, mm.
pub const ERROR_FLOOR_MM: f64 = 1e-3;

pub(crate) const FONT: &str = "sans-serif";
const BLUE: RGBColor = RGBColor(31, 119, 180);
const ORANGE: RGBColor = RGBColor(255, 127, 14);
const GREEN: RGBColor = RGBColor(44, 160, 44);
const RED: RGBColor = RGBColor(214, 39, 40);
const GREY: RGBColor = RGBColor(127, 127, 127);

#[derive(Debug, Error)]
pub enum PlotError {
    #[error("the plot font (DejaVu Sans) could not be loaded")]
    Font,
    #[error("drawing {figure}: {message}")]
    Draw {
        figure: &'static str,
        message: String,
    },
    #[error("encoding {figure} as PNG: {source}")]
    Png {
        figure: &'static str,
        #[source]
        source: png::EncodingError,
    },
    #[error("writing the plotted figures as JSON: {0}")]
    Json(#[from] serde_json::Error),
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// One of the plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Figure {
    PhiMin,
    Delta,
    LearningCurve,
    ConfidenceError,
    Reliability,
    RiskCoverage,
}

impl Figure {
    pub const ALL: [Figure; 6] = [
        Figure::PhiMin,
        Figure::Delta,
        Figure::LearningCurve,
        Figure::ConfidenceError,
        Figure::Reliability,
        Figure::RiskCoverage,
    ];

    /// Width and height, pixels (PNG) or user units (SVG).
    pub fn size(self) -> (u32, u32) {
        match self {
            Figure::PhiMin | Figure::ConfidenceError | Figure::RiskCoverage => (960, 720),
            Figure::Reliability => (960, 900),
            Figure::Delta => (960, 760),
            Figure::LearningCurve => (960, 1000),
        }
    }

    /// File name without extension.
    pub fn file_stem(self) -> &'static str {
        match self {
            Figure::PhiMin => "offered_useful_vs_phi_min",
            Figure::Delta => "median_error_vs_delta",
            Figure::LearningCurve => "median_error_vs_assimilated",
            Figure::ConfidenceError => "confidence_vs_error",
            Figure::Reliability => "reliability_p_useful",
            Figure::RiskCoverage => "precision_vs_offered_threshold",
        }
    }
}

/// The grids of the two sweeps.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotGrid {
    pub phi_mins: Vec<f64>,
    pub deltas: Vec<f64>,
}

impl Default for PlotGrid {
    /// φ_min 0, 0.05, …, 1; δ 0.1, 0.2, …, 1.
    fn default() -> PlotGrid {
        PlotGrid {
            phi_mins: (0..=20).map(|i| f64::from(i) / 20.0).collect(),
            deltas: (1..=10).map(|i| f64::from(i) / 10.0).collect(),
        }
    }
}

/// Everything the figures show.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotData {
    /// Profile name, for the captions.
    pub profile: String,
    /// The run's settings; the sweeps vary φ_min or δ from here.
    pub config: EngineConfig,
    /// Number of programs replayed.
    pub programs: usize,
    /// The engine at the run's settings but φ_min, one row per grid value.
    pub phi_sweep: Vec<SweepRow>,
    /// The engine at the run's settings but δ, one row per grid value.
    pub delta_sweep: Vec<SweepRow>,
    /// The engine at the run's settings, program by program.
    pub records: Vec<ProgramRecord>,
}

/// Replays the engine over `programs` at `config` and over the two sweeps of `grid`.
pub fn plot_data(
    programs: &[Program],
    profile: &str,
    config: &EngineConfig,
    grid: &PlotGrid,
) -> Result<PlotData, ConfigError> {
    let phi_sweep = sweep(
        programs,
        config,
        &[config.delta],
        &grid.phi_mins,
        &[config.predict.horizon],
    )?;
    let delta_sweep = sweep(
        programs,
        config,
        &grid.deltas,
        &[config.predict.phi_min],
        &[config.predict.horizon],
    )?;
    let mut engine = EngineMethod::new(config.clone())?;
    let records = programs
        .iter()
        .map(|p| replay_program(p, &mut engine))
        .collect();
    Ok(PlotData {
        profile: profile.to_string(),
        config: config.clone(),
        programs: programs.len(),
        phi_sweep,
        delta_sweep,
        records,
    })
}

/// Waypoints of the learning curve whose model had assimilated `from..to` moves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LearningBin {
    pub from: u64,
    /// Exclusive.
    pub to: u64,
    pub predictable: usize,
    pub offered: usize,
    pub useful: usize,
    pub median_cart_mm: Option<f64>,
    pub median_angle_rad: Option<f64>,
}

impl LearningBin {
    pub fn offered_pct(&self) -> Option<f64> {
        pct(self.offered, self.predictable)
    }

    pub fn useful_pct(&self) -> Option<f64> {
        pct(self.useful, self.predictable)
    }
}

fn pct(k: usize, of: usize) -> Option<f64> {
    (of > 0).then(|| 100.0 * k as f64 / of as f64)
}

/// The headline population: waypoints with at least two predecessors.
fn scored(records: &[ProgramRecord]) -> impl Iterator<Item = &WaypointRecord> {
    records
        .iter()
        .flat_map(|p| p.waypoints.iter())
        .filter(|r| r.predecessors >= 2)
}

/// Pools the records (n ≥ 2, with a model) into bins `[1, 2), [2, 4), [4, 8), …` of moves
/// assimilated; waypoints guessed from an empty model are left out. Empty bins are left out.
pub fn learning_curve(records: &[ProgramRecord]) -> Vec<LearningBin> {
    // Bin k holds 2^k ..< 2^(k+1).
    let mut bins: Vec<Vec<&WaypointRecord>> = Vec::new();
    for r in scored(records) {
        let Some(a) = r.assimilated.filter(|&a| a > 0) else {
            continue;
        };
        let k = a.ilog2() as usize;
        if bins.len() <= k {
            bins.resize_with(k + 1, Vec::new);
        }
        bins[k].push(r);
    }
    bins.into_iter()
        .enumerate()
        .filter(|(_, b)| !b.is_empty())
        .map(|(k, b)| {
            let offered: Vec<&&WaypointRecord> = b.iter().filter(|r| r.offered).collect();
            let cart: Vec<f64> = offered.iter().filter_map(|r| r.cart_mm).collect();
            let angle: Vec<f64> = offered.iter().filter_map(|r| r.angle_rad).collect();
            LearningBin {
                from: 1 << k,
                to: 1 << (k + 1),
                predictable: b.len(),
                offered: offered.len(),
                useful: b.iter().filter(|r| r.useful()).count(),
                median_cart_mm: median(&cart),
                median_angle_rad: median(&angle),
            }
        })
        .collect()
}

/// One offered guess of the scatter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScatterPoint {
    pub confidence: f64,
    pub cart_mm: f64,
    pub useful: bool,
}

/// Offered guesses (n ≥ 2) with a finite confidence and error.
pub fn confidence_points(records: &[ProgramRecord]) -> Vec<ScatterPoint> {
    scored(records)
        .filter(|r| r.offered)
        .filter_map(|r| {
            let (confidence, cart_mm) = (r.confidence?, r.cart_mm?);
            (confidence.is_finite() && cart_mm.is_finite()).then_some(ScatterPoint {
                confidence,
                cart_mm,
                useful: r.useful(),
            })
        })
        .collect()
}

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

/// The figure as an SVG document.
pub fn render_svg(figure: Figure, data: &PlotData) -> Result<String, PlotError> {
    register_font()?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, figure.size()).into_drawing_area();
        draw(figure, data, &root)
            .and_then(|()| root.present().map_err(Into::into))
            .map_err(|e| draw_error(figure, e))?;
    }
    Ok(svg)
}

/// The figure as a PNG file's bytes (8-bit RGB).
pub fn render_png(figure: Figure, data: &PlotData) -> Result<Vec<u8>, PlotError> {
    register_font()?;
    let (w, h) = figure.size();
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        draw(figure, data, &root)
            .and_then(|()| root.present().map_err(Into::into))
            .map_err(|e| draw_error(figure, e))?;
    }
    let png_error = |source| PlotError::Png {
        figure: figure.file_stem(),
        source,
    };
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, w, h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Best);
    let mut writer = encoder.write_header().map_err(png_error)?;
    writer.write_image_data(&rgb).map_err(png_error)?;
    writer.finish().map_err(png_error)?;
    Ok(out)
}

/// The plotted numbers, written beside the figures as `plots.json`.
#[derive(Debug, Serialize)]
struct PlottedNumbers<'a> {
    profile: &'a str,
    config: &'a EngineConfig,
    programs: usize,
    phi_sweep: &'a [SweepRow],
    delta_sweep: &'a [SweepRow],
    learning_curve: Vec<LearningBin>,
    /// Offered guesses on the scatter, the useful ones, and Spearman's ρ of confidence with
    /// Cartesian error.
    scatter_points: usize,
    scatter_useful: usize,
    scatter_spearman: Option<f64>,
    /// The reliability table, ECE and risk–coverage curve (`null` without `p_useful`).
    calibration: Option<Calibration>,
}

/// The numbers every figure shows, as pretty JSON.
pub fn plotted_json(data: &PlotData) -> Result<String, PlotError> {
    let points = confidence_points(&data.records);
    let (conf, err): (Vec<f64>, Vec<f64>) =
        points.iter().map(|p| (p.confidence, p.cart_mm)).unzip();
    let numbers = PlottedNumbers {
        profile: &data.profile,
        config: &data.config,
        programs: data.programs,
        phi_sweep: &data.phi_sweep,
        delta_sweep: &data.delta_sweep,
        learning_curve: learning_curve(&data.records),
        scatter_points: points.len(),
        scatter_useful: points.iter().filter(|p| p.useful).count(),
        scatter_spearman: spearman(&conf, &err),
        calibration: Calibration::of_programs(&data.records),
    };
    Ok(serde_json::to_string_pretty(&numbers)?)
}

/// Writes every figure into `dir` (created when missing) as `<stem>.png` and `<stem>.svg`, and
/// the plotted numbers as `plots.json`; returns the files written.
pub fn write_plots(dir: &Path, data: &PlotData) -> Result<Vec<PathBuf>, PlotError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| PlotError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut written = Vec::new();
    for figure in Figure::ALL {
        let png_path = dir.join(format!("{}.png", figure.file_stem()));
        std::fs::write(&png_path, render_png(figure, data)?).map_err(io(&png_path))?;
        written.push(png_path);
        let svg_path = dir.join(format!("{}.svg", figure.file_stem()));
        std::fs::write(&svg_path, render_svg(figure, data)?).map_err(io(&svg_path))?;
        written.push(svg_path);
    }
    let json_path = dir.join("plots.json");
    std::fs::write(&json_path, plotted_json(data)?).map_err(io(&json_path))?;
    written.push(json_path);
    Ok(written)
}

pub(crate) fn register_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

type DrawResult = Result<(), Box<dyn StdError + Send + Sync>>;

fn draw_error(figure: Figure, e: Box<dyn StdError + Send + Sync>) -> PlotError {
    PlotError::Draw {
        figure: figure.file_stem(),
        message: e.to_string(),
    }
}

fn draw<DB>(figure: Figure, data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    match figure {
        Figure::PhiMin => draw_phi_min(data, root),
        Figure::Delta => draw_delta(data, root),
        Figure::LearningCurve => draw_learning_curve(data, root),
        Figure::ConfidenceError => draw_confidence_error(data, root),
        Figure::Reliability => draw_reliability(data, root),
        Figure::RiskCoverage => draw_risk_coverage(data, root),
    }
}

/// A line with markers.
struct Series {
    label: String,
    color: RGBColor,
    points: Vec<(f64, f64)>,
}

impl Series {
    fn new(label: &str, color: RGBColor, points: impl IntoIterator<Item = (f64, f64)>) -> Series {
        Series {
            label: label.to_string(),
            color,
            points: points.into_iter().collect(),
        }
    }
}

/// One chart of lines.
struct LinePanel<'a> {
    caption: String,
    x_desc: &'a str,
    y_desc: &'a str,
    x_range: Range<f64>,
    /// Upper end of y; the lower end is 0.
    y_max: f64,
    x_labels: &'a dyn Fn(&f64) -> String,
    /// A vertical marker (the run's setting) with its legend text.
    marker: Option<(f64, String)>,
    series: Vec<Series>,
    /// Text drawn just above a point.
    notes: Vec<(f64, f64, String)>,
}

fn draw_lines<DB>(area: &DrawingArea<DB, Shift>, p: &LinePanel<'_>) -> DrawResult
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
    chart
        .configure_mesh()
        .x_desc(p.x_desc)
        .y_desc(p.y_desc)
        .x_labels(12)
        .y_labels(8)
        .x_label_formatter(p.x_labels)
        .y_label_formatter(&y_labels)
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.12))
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
fn y_max(series: &[&Series], floor: f64) -> f64 {
    let max = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .fold(0.0_f64, f64::max);
    (max * 1.4).max(floor)
}

fn fixed(digits: usize) -> impl Fn(&f64) -> String {
    move |v: &f64| format!("{v:.digits$}")
}

/// Tick labels of an axis `span` long: enough decimals to tell ticks apart, and no "-0.00".
fn decimals_for(span: f64) -> impl Fn(&f64) -> String {
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

fn x_range(values: impl Iterator<Item = f64>) -> Range<f64> {
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

fn subtitle(data: &PlotData) -> String {
    format!(
        "{} profile, {} programs, waypoints with ≥ 2 predecessors",
        data.profile, data.programs
    )
}

/// The figure's body and a strip at the bottom for [`footer`].
fn body_and_footer<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    let (_, h) = root.dim_in_pixel();
    root.split_vertically(h.saturating_sub(28))
}

fn footer<DB>(area: &DrawingArea<DB, Shift>, text: &str) -> DrawResult
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

fn draw_phi_min<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
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

fn draw_delta<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
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

fn draw_learning_curve<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
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

fn draw_confidence_error<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
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
    chart
        .configure_mesh()
        .x_desc(confidence_desc(&data.config))
        .y_desc("Cartesian error, mm (log)")
        .x_labels(10)
        .y_labels(((y_hi - y_lo).ceil() as usize + 1).max(2))
        .x_label_formatter(&decimals_for(xr.end - xr.start))
        .y_label_formatter(&y_labels)
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.12))
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

/// A chart that says why it has nothing to show (no candidate carries `p_useful`).
fn draw_nothing<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>, caption: &str) -> DrawResult
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

fn draw_reliability<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
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
    chart
        .configure_mesh()
        .x_desc("mean p_useful of the decile (predicted)")
        .y_desc("observed useful share")
        .x_labels(11)
        .y_labels(11)
        .x_label_formatter(&fixed(1))
        .y_label_formatter(&fixed(1))
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.12))
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
    counts
        .configure_mesh()
        .x_desc("p_useful decile")
        .y_desc("candidates")
        .x_labels(11)
        .y_labels(4)
        .x_label_formatter(&fixed(1))
        .y_label_formatter(&decimals_for(most))
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.12))
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

fn draw_risk_coverage<DB>(data: &PlotData, root: &DrawingArea<DB, Shift>) -> DrawResult
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
            .map_or_else(String::new, |o| format!(" (threshold {})", o.threshold));
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

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(n: usize, assimilated: Option<u64>, offered: Option<(f64, f64)>) -> WaypointRecord {
        WaypointRecord {
            routine: 0,
            predecessors: n,
            offered: offered.is_some(),
            cart_mm: offered.map(|o| o.0),
            angle_rad: offered.map(|o| o.1),
            travel_mm: 10.0,
            travel_rad: 0.1,
            confidence: offered.map(|o| -o.0),
            phi: None,
            psi: None,
            assimilated,
            micros: 1.0,
            candidate: None,
        }
    }

    fn program(waypoints: Vec<WaypointRecord>) -> ProgramRecord {
        ProgramRecord {
            program: "p".into(),
            language: "rapid".into(),
            method: "engine".into(),
            waypoints,
            summary: None,
        }
    }

    #[test]
    fn learning_curve_bins_double_and_skip_empty_models_and_n1() {
        let records = [program(vec![
            rec(1, Some(5), Some((0.0, 0.0))), // n = 1: not scored
            rec(2, Some(0), None),             // empty model: left out
            rec(2, Some(1), None),             // bin [1, 2)
            rec(2, Some(4), Some((0.5, 0.0))), // bin [4, 8), useful
            rec(3, Some(7), Some((3.0, 0.0))), // bin [4, 8), too far
            rec(3, Some(7), None),             // bin [4, 8)
            rec(4, None, Some((0.0, 0.0))),    // no model: left out
            rec(5, Some(9), Some((2.0, 0.2))), // bin [8, 16)
        ])];
        let bins = learning_curve(&records);
        let edges: Vec<(u64, u64)> = bins.iter().map(|b| (b.from, b.to)).collect();
        assert_eq!(edges, [(1, 2), (4, 8), (8, 16)]);
        assert_eq!((bins[0].predictable, bins[0].offered), (1, 0));
        assert_eq!(bins[0].median_cart_mm, None);
        let b = &bins[1];
        assert_eq!((b.predictable, b.offered, b.useful), (3, 2, 1));
        assert_eq!(b.median_cart_mm, Some(1.75));
        assert_eq!(b.offered_pct(), Some(200.0 / 3.0));
        assert_eq!(bins[2].useful, 0);
    }

    #[test]
    fn scatter_keeps_offered_finite_scored_guesses() {
        let mut odd = rec(2, Some(3), Some((1.0, 0.0)));
        odd.confidence = Some(f64::NAN);
        let records = [program(vec![
            rec(1, Some(3), Some((0.2, 0.0))),
            rec(2, Some(3), Some((0.2, 0.0))),
            rec(2, Some(3), None),
            odd,
            rec(3, Some(3), Some((4.0, 0.0))),
        ])];
        let points = confidence_points(&records);
        assert_eq!(
            points,
            [
                ScatterPoint {
                    confidence: -0.2,
                    cart_mm: 0.2,
                    useful: true
                },
                ScatterPoint {
                    confidence: -4.0,
                    cart_mm: 4.0,
                    useful: false
                }
            ]
        );
    }

    #[test]
    fn confidence_label_follows_the_engine_method() {
        assert!(confidence_desc(&EngineConfig::default()).contains("p_useful"));
        let no_rule = EngineConfig {
            offer: None,
            ..EngineConfig::default()
        };
        assert!(confidence_desc(&no_rule).contains("misfit"));
        let seed = EngineConfig::profile(crate::engine::Profile::Seed);
        assert_eq!(confidence_desc(&seed), "confidence = φ");
    }
}
