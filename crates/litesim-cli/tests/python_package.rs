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

/// The wheel (python/dist/, built by `.ci/run`; built here when missing)
/// installs into a fresh venv with nothing but pip, and runs a test.
#[test]
fn the_wheel_installs_and_runs_in_a_fresh_venv() {
    let python = workspace().join("python");
    let dist = python.join("dist");
    let wheel = || {
        std::fs::read_dir(&dist).ok().and_then(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .find(|p| p.extension().is_some_and(|x| x == "whl"))
        })
    };
    if wheel().is_none() {
        assert!(
            ok(Command::new("python3")
                .args(["-m", "pip", "wheel", "--quiet", "--no-deps", "-w"])
                .arg(&dist)
                .arg(&python)),
            "pip wheel ./python failed"
        );
    }
    let wheel = wheel().expect("a wheel in python/dist");
    let name = wheel.file_name().unwrap().to_string_lossy().to_string();
    assert!(
        name.contains("cp39-abi3"),
        "{name}: expected one abi3 wheel for CPython >= 3.9"
    );
    let dir = tempfile::tempdir().unwrap();
    let venv = dir.path().join("venv");
    assert!(ok(Command::new("python3").args(["-m", "venv"]).arg(&venv)));
    let py = venv.join("bin/python");
    assert!(
        ok(Command::new(&py)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check"
            ])
            .arg(&wheel)),
        "pip install {name} into a fresh venv failed"
    );
    let test = workspace().join("examples/scenarios/cut_in.osc");
    let out = Command::new(&py)
        .current_dir(dir.path())
        .args([
            "-c",
            "import sys, litesim; r = litesim.run(sys.argv[1], seed=2); \
             assert r.passed and isinstance(r.log, dict), r; print(r)",
        ])
        .arg(&test)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
