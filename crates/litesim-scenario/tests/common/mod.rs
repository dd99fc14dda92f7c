//! Helpers shared by the scenario engine's test binaries.
#![allow(dead_code)]

use litesim_scenario::{LoadOptions, Prepared, prepare};
use std::path::PathBuf;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// An example test (`examples/scenarios/NAME.osc`), prepared.
pub fn example(name: &str) -> Prepared {
    let p = root().join(format!("examples/scenarios/{name}.osc"));
    prepare(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Writes `text` as a test in `examples/scenarios` (so that relative
/// imports and map paths resolve like the examples'); removed when dropped.
pub fn example_file(text: &str) -> tempfile::NamedTempFile {
    let f = tempfile::Builder::new()
        .suffix(".osc")
        .tempfile_in(root().join("examples/scenarios"))
        .unwrap();
    std::fs::write(f.path(), text).unwrap();
    f
}
