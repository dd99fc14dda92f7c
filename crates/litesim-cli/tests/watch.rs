//! Watching a run: the MCAP file read by third-party Python tools (`mcap`,
//! `mcap-protobuf-support`, osi-python), and the viewer (`litesim view`)
//! in headless Chromium (Debian's `chromium` driven by Playwright for
//! Python). `.ci/run` installs all of them.

mod common;
use common::{litesim, workspace};
use std::path::Path;
use std::process::{Command, Output};

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn python(script: &str, args: &[&std::ffi::OsStr]) -> String {
    let s = workspace()
        .join("crates/litesim-cli/tests/python")
        .join(script);
    let o = Command::new("python3").arg(s).args(args).output().unwrap();
    assert!(
        o.status.success(),
        "{script} failed (needs python3 with mcap, mcap-protobuf-support, osi-python, playwright and Debian's chromium, as .ci/run installs):\n{}",
        text(&o)
    );
    text(&o)
}

fn run(args: &[&str], out: &Path) -> Output {
    litesim()
        .current_dir(workspace())
        .arg("run")
        .args(args)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

#[test]
fn a_run_writes_mcap_that_foxglove_and_osi_tools_read() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mcap = dir.path().join("cut_in.mcap");
    let o = run(
        &[
            "examples/scenarios/cut_in.osc",
            "--no-pictures",
            "--mcap",
            mcap.to_str().unwrap(),
        ],
        &out,
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("cut_in.mcap"), "{}", text(&o));
    let said = python(
        "check_mcap.py",
        &[
            mcap.as_os_str(),
            out.join("log.json").as_os_str(),
            "--map".as_ref(),
        ],
    );
    assert!(said.contains("500 ticks, 2 actors"), "{said}");
    // The same run gives the same bytes.
    let again = dir.path().join("again.mcap");
    let o = run(
        &[
            "examples/scenarios/cut_in.osc",
            "--no-pictures",
            "--mcap",
            again.to_str().unwrap(),
        ],
        &dir.path().join("run2"),
    );
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        std::fs::read(&mcap).unwrap(),
        std::fs::read(&again).unwrap()
    );
}

#[test]
fn a_closed_loop_run_under_dynamic_control_is_exported_too() {
    // Another SUT, dynamic control and more actors than the cut-in.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mcap = dir.path().join("acc.mcap");
    let o = run(
        &[
            "examples/scenarios/cut_in.osc",
            "--sut",
            "acc",
            "--dynamic",
            "--no-pictures",
            "--mcap",
            mcap.to_str().unwrap(),
        ],
        &out,
    );
    assert!(
        o.status.code().is_some_and(|c| c == 0 || c == 2),
        "{}",
        text(&o)
    );
    python(
        "check_mcap.py",
        &[mcap.as_os_str(), out.join("log.json").as_os_str()],
    );
}

#[test]
fn batch_save_failed_writes_failed_runs_as_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let o = litesim()
        .current_dir(workspace())
        .args([
            "batch",
            "examples/scenarios/cut_in_coverage.osc",
            "--seeds",
            "1..12",
            "-q",
            "--save-failed",
            "--mcap",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let failed = out.join("failed");
    let mut logs: Vec<_> = std::fs::read_dir(&failed)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    logs.sort();
    assert!(!logs.is_empty());
    for log in &logs {
        let m = log.with_extension("mcap");
        assert!(m.exists(), "{} has no MCAP", log.display());
    }
    python(
        "check_mcap.py",
        &[
            logs[0].with_extension("mcap").as_os_str(),
            logs[0].as_os_str(),
        ],
    );
    // --mcap means nothing without --save-failed: said at once.
    let o = litesim()
        .current_dir(workspace())
        .args(["batch", "examples/scenarios/cut_in_coverage.osc", "--mcap"])
        .output()
        .unwrap();
    // A usage error (EX_USAGE), naming the missing flag.
    assert_eq!(o.status.code(), Some(64), "{}", text(&o));
    assert!(text(&o).contains("--save-failed"), "{}", text(&o));
}

#[test]
fn an_mcap_path_that_cannot_be_written_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &[
            "examples/scenarios/cut_in.osc",
            "--no-pictures",
            "--mcap",
            "/proc/litesim/no.mcap",
        ],
        &dir.path().join("run"),
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("/proc/litesim"), "{}", text(&o));
}
