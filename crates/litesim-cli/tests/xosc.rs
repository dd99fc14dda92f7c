//! OpenSCENARIO XML from the command line, as a user runs it: `run` with a
//! SUT and the MCAP, `check`, `batch` over a distribution with JUnit.

mod common;
use common::{litesim, text, workspace};

#[test]
fn run_check_and_batch_an_xosc_file() {
    let dir = tempfile::tempdir().unwrap();
    let xosc = workspace().join("examples/xosc/cut_in.xosc");
    let out = dir.path().join("run");
    let mcap = dir.path().join("run.mcap");
    let o = litesim()
        .args(["run", "--sut", "acc", "--no-pictures", "-o"])
        .arg(&out)
        .arg("--mcap")
        .arg(&mcap)
        .arg(&xosc)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("PASS cut_in.xosc seed 1"), "{}", text(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let triggers = summary["triggers"].as_array().unwrap();
    assert!(
        triggers.iter().any(|t| t["element"] == "CutInEvent"),
        "{triggers:?}"
    );
    assert!(std::fs::metadata(&mcap).unwrap().len() > 1000);
    // Without a SUT the storyboard drives the ego into the cutter: exit 2.
    let o = litesim()
        .args(["run", "--no-pictures", "-o"])
        .arg(dir.path().join("plain"))
        .arg(&xosc)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // --ego names another entity; one that does not exist is an error.
    let o = litesim()
        .args(["run", "--sut", "acc", "--ego", "Nobody", "-o"])
        .arg(dir.path().join("x"))
        .arg(&xosc)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        text(&o)
            .contains("--ego Nobody: the scenario has no entity of that name (it has Ego, Cutter)"),
        "{}",
        text(&o)
    );
    // check: fine, and a broken copy with its place.
    let o = litesim().arg("check").arg(&xosc).output().unwrap();
    assert!(
        o.status.success() && text(&o).contains("2 entities"),
        "{}",
        text(&o)
    );
    let bad = tempfile::Builder::new()
        .suffix(".xosc")
        .tempfile_in(workspace().join("examples/xosc"))
        .unwrap();
    std::fs::write(
        bad.path(),
        std::fs::read_to_string(&xosc)
            .unwrap()
            .replace(r#"value="$CutInGap""#, r#"value="${$CutInGap / 0}""#),
    )
    .unwrap();
    let o = litesim().arg("check").arg(bad.path()).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).contains("division by zero") && text(&o).contains(".xosc:"),
        "{}",
        text(&o)
    );
    // batch: a distribution's six variations, with JUnit.
    let junit = dir.path().join("junit.xml");
    let o = litesim()
        .args(["batch", "--sut", "acc", "--seeds", "1..1", "-o"])
        .arg(dir.path().join("batch"))
        .arg("--junit")
        .arg(&junit)
        .arg(workspace().join("examples/xosc/cut_in_sweep.xosc"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let j = std::fs::read_to_string(&junit).unwrap();
    assert_eq!(j.matches("<testcase").count(), 6, "{j}");
}

/// `batch --step-ms` steps every run at that step (it was once accepted and
/// not passed on: the runs stepped at the profile's 20 ms), the manifest
/// names it, and resuming with another step is refused.
#[test]
fn a_batch_steps_at_the_step_it_is_given() {
    let dir = tempfile::tempdir().unwrap();
    let xosc = workspace().join("examples/xosc/cut_in.xosc");
    let out = dir.path().join("b");
    let batch = |step: &str, extra: &[&str]| {
        litesim()
            .args([
                "batch",
                "--sut",
                "acc",
                "--seeds",
                "1..2",
                "--step-ms",
                step,
            ])
            .args(extra)
            .arg("-o")
            .arg(&out)
            .arg(&xosc)
            .output()
            .unwrap()
    };
    let o = batch("10", &[]);
    assert!(o.status.success(), "{}", text(&o));
    let lines = std::fs::read_to_string(out.join("results.jsonl")).unwrap();
    let steps: Vec<u64> = lines
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["steps"]
                .as_u64()
                .unwrap()
        })
        .collect();
    // 20 s at 10 ms, and the stop trigger's step.
    assert_eq!(steps, vec![2002, 2002], "{lines}");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["step_ms"], 10, "{manifest}");
    let o = batch("20", &["--resume"]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("step: 10 ms there, 20 ms now"),
        "{}",
        text(&o)
    );
    // The same step resumes (nothing left to run).
    let o = batch("10", &["--resume"]);
    assert!(o.status.success(), "{}", text(&o));
}
