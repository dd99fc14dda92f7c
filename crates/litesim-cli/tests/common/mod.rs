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

/// A command's stdout and stderr, for assertion messages.
pub fn text(o: &std::process::Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Runs `tests/python/SCRIPT ARGS…` with python3 and returns what it
/// printed; a failure shows its output and what `.ci/run` installs for
/// these scripts (playwright with Debian's chromium, xmlschema, mcap,
/// mcap-protobuf-support, osi-python).
pub fn python_script<S: AsRef<std::ffi::OsStr>>(script: &str, args: &[S]) -> String {
    let s = workspace()
        .join("crates/litesim-cli/tests/python")
        .join(script);
    let o = Command::new("python3").arg(s).args(args).output().unwrap();
    assert!(
        o.status.success(),
        "{script} failed (needs python3 with what .ci/run installs: playwright and Debian's chromium, xmlschema, mcap, mcap-protobuf-support, osi-python):\n{}",
        text(&o)
    );
    text(&o)
}
