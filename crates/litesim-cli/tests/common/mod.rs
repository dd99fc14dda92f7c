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

/// Makes sure every module in `imports` is importable by `python3`,
/// installing `packages` from PyPI when one is not: into the user site,
/// else (inside a virtual environment, which has no user site) into the
/// interpreter's own. A fresh machine has Rust and Python with pip, and
/// `cargo test --workspace` is all it needs: the tests fetch what they use.
/// Serialised, so that parallel tests of one binary do not run pip at once.
pub fn ensure_python(imports: &str, packages: &[&str]) {
    static PIP: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = PIP.lock().unwrap_or_else(|e| e.into_inner());
    let ok = |c: &mut Command| c.status().is_ok_and(|s| s.success());
    let check = format!("import {imports}");
    if ok(Command::new("python3").args(["-c", &check])) {
        return;
    }
    let pip = |user: bool| {
        let mut c = Command::new("python3");
        c.args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
        ]);
        if user {
            c.arg("--user");
        }
        ok(c.args(packages))
    };
    let installed = pip(true) || pip(false);
    assert!(
        installed && ok(Command::new("python3").args(["-c", &check])),
        "could not install {} with pip (wanted: import {imports})",
        packages.join(" ")
    );
}

/// Makes sure `grpcio`, `grpcio-tools` and `grpcio-reflection` are importable.
pub fn ensure_grpcio() {
    ensure_python(
        "grpc, grpc_tools, grpc_reflection",
        &["grpcio", "grpcio-tools", "grpcio-reflection"],
    );
}

/// The Chromium the browser tests drive: `$LITESIM_CHROMIUM`, else
/// Debian's `/usr/bin/chromium`, installed with apt-get (as root, or with
/// `sudo -n`) when it is missing (`playwright install` cannot download
/// browsers on these machines).
pub fn ensure_chromium() {
    static APT: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = APT.lock().unwrap_or_else(|e| e.into_inner());
    let browser = std::env::var("LITESIM_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    if Path::new(&browser).exists() {
        return;
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout.starts_with(b"0\n"));
    let apt = |args: &[&str]| {
        let mut c = if root {
            Command::new("apt-get")
        } else {
            let mut c = Command::new("sudo");
            c.args(["-n", "apt-get"]);
            c
        };
        c.env("DEBIAN_FRONTEND", "noninteractive")
            .args(args)
            .status()
            .is_ok_and(|s| s.success())
    };
    let installed = apt(&["update", "-qq"]) && apt(&["install", "-y", "-qq", "chromium"]);
    assert!(
        installed && Path::new(&browser).exists(),
        "{browser} is missing and `apt-get install chromium` failed (run it as root, or set LITESIM_CHROMIUM to a Chromium binary)"
    );
}

/// What the checker scripts in `tests/python` import, with the PyPI
/// packages that provide it (the same list `.ci/run` installs).
const SCRIPT_IMPORTS: &str = "playwright, xmlschema, mcap, mcap_protobuf, osi3";
const SCRIPT_PACKAGES: &[&str] = &[
    "playwright",
    "xmlschema",
    "mcap",
    "mcap-protobuf-support",
    "osi-python==3.8.0",
];

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
/// printed, after making sure that what the scripts use is there
/// (playwright with Debian's chromium, xmlschema, mcap,
/// mcap-protobuf-support, osi-python); a failure shows the script's output.
pub fn python_script<S: AsRef<std::ffi::OsStr>>(script: &str, args: &[S]) -> String {
    ensure_python(SCRIPT_IMPORTS, SCRIPT_PACKAGES);
    if script.contains("report") || script.contains("viewer") {
        ensure_chromium();
    }
    let s = workspace()
        .join("crates/litesim-cli/tests/python")
        .join(script);
    let o = Command::new("python3").arg(s).args(args).output().unwrap();
    assert!(o.status.success(), "{script} failed:\n{}", text(&o));
    text(&o)
}
