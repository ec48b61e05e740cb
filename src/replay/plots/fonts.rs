//! The font every figure's text is laid out and rasterised with: DejaVu Sans (the `dejavu`
//! crate) through plotters' `ab_glyph` feature, so no system font library is needed. The
//! segmentation figure of `nextpose segment` uses it too.

use std::sync::OnceLock;

use plotters::style::FontStyle;

use super::error::PlotError;

/// The family name the font is registered under; every text style names it.
pub(crate) const FONT: &str = "sans-serif";

/// Registers DejaVu Sans as [`FONT`] (once per process).
pub(crate) fn register_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}
