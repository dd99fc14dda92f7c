//! OpenSCENARIO XML 1.0–1.3 for litesim: reads a `.xosc` file into a typed
//! [`Scenario`] — parameters and `${…}` expressions resolved, catalog
//! references replaced by their entries (with parameter assignments), each
//! element checked against the schema's rules for it — or a precise
//! [`XoscError`] (file:line:col, the element path, what was expected).
//!
//! The scenario crate executes the storyboard live on litesim's runtime;
//! this crate only reads. See `docs/xosc.md` for the element-by-element
//! support table.

pub mod distribution;
pub mod error;
pub mod expr;
pub mod model;
mod read;

pub use distribution::{Distribution, is_distribution, read_distribution};
pub use error::XoscError;
pub use model::*;
pub use read::MAX_FILE_BYTES;

use std::path::Path;

/// Reads and checks a scenario file; `overrides` set global parameters
/// (name, value), as a distribution or the command line does.
pub fn read(path: &Path, overrides: &[(String, String)]) -> Result<Scenario, XoscError> {
    read::scenario(path, overrides)
}

/// Reads a scenario from text; `path` names it in errors and anchors the
/// map, catalog and other relative paths.
pub fn read_str(
    text: &str,
    path: &Path,
    overrides: &[(String, String)],
) -> Result<Scenario, XoscError> {
    read::scenario_text(text, path, overrides)
}
