//! The Python package (`python/`, issue 21) as its users get it: `pip
//! install ./python` (maturin builds the native module), then its pytest
//! suite — runs, your own SUT in-process, the same SUT over gRPC giving
//! identical logs, the gymnasium env under gymnasium's checker, Ray
//! batches equal to `litesim batch` byte for byte (a killed worker
//! included). `.ci/run` installs the package and its test dependencies;
//! when `litesim` cannot be imported this test installs it first.

mod common;
use common::workspace;
use std::process::Command;

fn ok(c: &mut Command) -> bool {
    c.status().is_ok_and(|s| s.success())
}

#[test]
fn the_python_package_passes_its_tests() {
    let python = workspace().join("python");
    let importable = || {
        ok(Command::new("python3")
            .current_dir(std::env::temp_dir())
            .args([
                "-c",
                "import litesim, litesim._native, pytest, gymnasium, ray, pandas",
            ]))
    };
    if !importable() {
        assert!(
            ok(Command::new("python3")
                .args(["-m", "pip", "install", "--quiet"])
                .arg(format!("{}[test]", python.display()))),
            "pip install ./python[test] failed"
        );
    }
    let out = Command::new("python3")
        .current_dir(std::env::temp_dir())
        .env("LITESIM_BIN", env!("CARGO_BIN_EXE_litesim"))
        .args(["-m", "pytest", "-q", "-s", "-p", "no:cacheprovider"])
        .arg(python.join("tests"))
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "pytest failed:\n{text}");
    println!("{text}");
}
