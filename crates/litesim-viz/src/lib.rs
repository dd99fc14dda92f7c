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

/// Writes bytes atomically (temporary file in the same folder, flushed to
/// disk, then renamed).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), VizError> {
    let io = |e: std::io::Error| VizError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(io)?;
    let mut tmp = tempfile::NamedTempFile::new_in(&dir).map_err(io)?;
    std::io::Write::write_all(&mut tmp, bytes).map_err(io)?;
    // On disk before the rename: a crash never leaves a named, empty picture.
    tmp.as_file().sync_all().map_err(io)?;
    // Temporary files are created private (0600); a result is an ordinary file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = tmp
            .as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644));
    }
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(())
}

/// Flushes a finished temporary file to disk before it is renamed into
/// place (GIF writers hold only its path).
pub(crate) fn sync_path(tmp: &Path, target: &Path) -> Result<(), VizError> {
    std::fs::File::open(tmp)
        .and_then(|f| f.sync_all())
        .map_err(|e| VizError::Io {
            path: target.display().to_string(),
            message: e.to_string(),
        })
}

/// A temporary path next to `path` for writers that need a file name (GIF);
/// rename it over `path` when done.
pub(crate) fn temp_sibling(path: &Path) -> Result<tempfile::TempPath, VizError> {
    let t = temp_sibling_raw(path)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = std::fs::set_permissions(&t, std::fs::Permissions::from_mode(0o644));
    }
    Ok(t)
}

fn temp_sibling_raw(path: &Path) -> Result<tempfile::TempPath, VizError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| VizError::Io {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    tempfile::Builder::new()
        .suffix(".gif")
        .tempfile_in(&dir)
        .map(|f| f.into_temp_path())
        .map_err(|e| VizError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })
}

pub(crate) fn check_size(w: u32, h: u32) -> Result<(), VizError> {
    if !(200..=8000).contains(&w) || !(150..=8000).contains(&h) {
        return Err(VizError::Settings(format!(
            "image size {w} × {h} px is outside [200..8000] × [150..8000]"
        )));
    }
    Ok(())
}
