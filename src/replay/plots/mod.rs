//! Plots of a replay: the dissertation's figures 4.10–4.13 and a confidence/error scatter, as PNG
//! and SVG.
//!
//! Six figures ([`Figure`]), all over the scoreboard's headline population (waypoints with at
//! least two predecessors), one file each:
//!
//! - [`phi_min`] ([`Figure::PhiMin`]): offered % and useful % of predictable waypoints versus
//!   the confidence threshold φ_min (dissertation Fig. 4.11).
//! - [`delta`] ([`Figure::Delta`]): median Cartesian and angle error of the offered guesses
//!   versus the complexity δ (dissertation Fig. 4.10).
//! - [`learning_curve`] ([`Figure::LearningCurve`]): median error versus the number of moves
//!   the model had assimilated when it guessed (dissertation Fig. 4.13), pooled over programs in
//!   bins that double in width, with the offered and useful % of each bin below.
//! - [`confidence_error`] ([`Figure::ConfidenceError`]): the engine's confidence figure
//!   (`p_useful` under the experts' offer rule) against the Cartesian error of each offered
//!   guess.
//! - [`reliability`] ([`Figure::Reliability`]): observed useful share against mean `p_useful`
//!   per decile, over every candidate offered or not, with the diagonal and the ±10-point band
//!   of issue 13, and the candidates per decile below.
//! - [`risk_coverage`] ([`Figure::RiskCoverage`]): precision against offered % of predictable
//!   waypoints as the offer threshold on `p_useful` moves from 0 to 1.
//!
//! The last two need candidates with a `p_useful` (the engine under the experts' offer rule);
//! without them (the seed profile) they say so on an empty chart.
//!
//! What the figures show is computed once ([`data`]: [`plot_data`] replays the engine for the
//! two sweeps and the per-waypoint records at the run's settings). Rendering ([`figure`]:
//! [`render_svg`], [`render_png`]) is pure, with the drawing kit in [`draw`] and the font in
//! [`fonts`]; only [`write_plots`] touches files.

pub mod confidence_error;
pub mod data;
pub mod delta;
pub mod draw;
pub mod error;
pub mod figure;
pub mod fonts;
pub mod learning_curve;
pub mod phi_min;
pub mod reliability;
pub mod risk_coverage;

pub use data::{
    LearningBin, PlotData, PlotGrid, ScatterPoint, confidence_points, learning_curve, plot_data,
    plotted_json,
};
pub use error::PlotError;
pub use figure::{Figure, render_png, render_svg, write_plots};
