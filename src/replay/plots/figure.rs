//! Which figures there are, and each one drawn: as an SVG document or PNG bytes (pure), or
//! every one written into a directory with the plotted numbers beside them.

use std::error::Error as StdError;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::data::{PlotData, plotted_json};
use super::draw::DrawResult;
use super::error::PlotError;
use super::fonts::register_font;
use super::{confidence_error, delta, learning_curve, phi_min, reliability, risk_coverage};

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
        Figure::PhiMin => phi_min::draw(data, root),
        Figure::Delta => delta::draw(data, root),
        Figure::LearningCurve => learning_curve::draw(data, root),
        Figure::ConfidenceError => confidence_error::draw(data, root),
        Figure::Reliability => reliability::draw(data, root),
        Figure::RiskCoverage => risk_coverage::draw(data, root),
    }
}
