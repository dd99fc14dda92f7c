//! Helpers shared by the command-line test binaries.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The `litesim` binary under test.
pub fn litesim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_litesim"))
}

/// The repository root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Makes sure `grpcio` and `grpcio-tools` are importable, installing them
/// from PyPI into the user site when they are not (a fresh machine has pip).
pub fn ensure_grpcio() {
    let ok = |c: &mut Command| c.status().is_ok_and(|s| s.success());
    if ok(Command::new("python3").args(["-c", "import grpc, grpc_tools, grpc_reflection"])) {
        return;
    }
    let installed = ok(Command::new("python3").args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--user",
        "grpcio",
        "grpcio-tools",
        "grpcio-reflection",
    ])) || ok(Command::new("python3").args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "grpcio",
        "grpcio-tools",
        "grpcio-reflection",
    ]));
    assert!(
        installed,
        "could not install grpcio and grpcio-tools with pip"
    );
}

/// Writes `text` as a test in `examples/scenarios` (so that relative
/// imports and map paths resolve like the examples'); removed when dropped.
pub fn example_file(text: &str) -> tempfile::NamedTempFile {
    let f = tempfile::Builder::new()
        .suffix(".osc")
        .tempfile_in(workspace().join("examples/scenarios"))
        .unwrap();
    std::fs::write(f.path(), text).unwrap();
    f
}
