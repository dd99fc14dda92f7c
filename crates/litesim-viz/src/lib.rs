//! # litesim-viz
//!
//! Headless, deterministic pictures of litesim runs (seed 001 §2), drawn
//! with plotters and the embedded DejaVu Sans font — no system fonts, no
//! display:
//!
//! * [`dashboard`] — the nine-panel diagnostic figure (PNG or SVG);
//! * [`animation`] — GIF of the vehicle, its MPC horizon and control traces;
//! * [`planner`] — FMT* samples, accepted edges and corridors (PNG), and an
//!   exploration GIF;
//! * [`replay`] — every actor's track and a replay GIF for multi-actor runs;
//! * [`Style`] — a TOML stylesheet with a built-in default.
//!
//! Everything reads a [`litesim_log::SimulationLog`]; a log that lacks what
//! a view needs gives a view that says so (or a [`VizError`]), never a panic.
//! Files are written atomically.
#![warn(missing_docs)]

pub mod animation;
pub mod dashboard;
mod draw;
mod gif_out;
pub mod planner;
pub mod replay;
pub mod style;

pub use draw::path_bounds;
pub use style::Style;

use std::path::Path;

/// Why a picture could not be made.
#[derive(Debug, thiserror::Error)]
pub enum VizError {
    /// The log has nothing to draw.
    #[error("{0}")]
    Empty(String),
    /// Drawing failed.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// Writing failed.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        message: String,
    },
    /// Bad size or settings.
    #[error("{0}")]
    Settings(String),
}

pub(crate) fn draw_err<E: std::fmt::Display>(e: E) -> VizError {
    VizError::Draw(e.to_string())
}

/// Registers the embedded font once per process.
pub(crate) fn fonts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Normal,
            dejavu::sans::regular(),
        );
        let _ = plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Bold,
            dejavu::sans::bold(),
        );
    });
}

/// Encodes an RGB buffer as PNG bytes.
pub fn encode_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, VizError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        // Fast deflate: a dashboard compresses 30 → ~8 ms, files grow ~20 %.
        enc.set_compression(png::Compression::Fast);
        let mut w = enc.write_header().map_err(draw_err)?;
        w.write_image_data(rgb).map_err(draw_err)?;
    }
    Ok(out)
}

/// Writes bytes atomically ([`litesim_log::AtomicFile`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), VizError> {
    let mut out = litesim_log::AtomicFile::create(path).map_err(log_io)?;
    std::io::Write::write_all(out.file(), bytes).map_err(|e| VizError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    out.commit().map_err(log_io)
}

/// A log crate I/O error as this crate's.
pub(crate) fn log_io(e: litesim_log::LogError) -> VizError {
    match e {
        litesim_log::LogError::Io { path, source } => VizError::Io {
            path: path.display().to_string(),
            message: source.to_string(),
        },
        other => VizError::Io {
            path: String::new(),
            message: other.to_string(),
        },
    }
}

pub(crate) fn check_size(w: u32, h: u32) -> Result<(), VizError> {
    if !(200..=8000).contains(&w) || !(150..=8000).contains(&h) {
        return Err(VizError::Settings(format!(
            "image size {w} × {h} px is outside [200..8000] × [150..8000]"
        )));
    }
    Ok(())
}
