//! Why a figure could not be drawn or written.

use std::path::PathBuf;

use thiserror::Error;

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
