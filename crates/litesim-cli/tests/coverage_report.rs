//! Coverage across seeds, the JUnit file and the HTML report, as a user
//! runs them: `litesim batch … --junit`, shards merged or resumed
//! (byte-identical coverage), `litesim report` opened in headless Chromium
//! (Debian's `chromium` driven by Playwright for Python), the JUnit XML
//! validated against the JUnit schema (Python's xmlschema). `.ci/run`
//! installs chromium, playwright and xmlschema.

mod common;
use common::{litesim, text, workspace};
use std::path::Path;
use std::process::Output;

const TEST: &str = "examples/scenarios/cut_in_coverage.osc";

/// A batch of the coverage example with its planned cutting car (`--npc
/// planned`): its tight cut-ins fail some seeds, which the report and
/// JUnit tests need (drivers report a missed cut-in as not realised).
fn batch(args: &[&str], out: &Path) -> Output {
    litesim()
        .current_dir(workspace())
        .arg("batch")
        .arg(TEST)
        .args(["--npc", "planned"])
        .args(args)
        .arg("-q")
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn python(script: &str, args: &[&str]) {
    common::python_script(script, args);
}

#[test]
fn coverage_is_identical_whatever_the_shards_threads_or_resume() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole");
    let o = batch(&["--seeds", "1..40", "--threads", "2"], &whole);
    // Some runs of this example fail (the cut-in is tight): exit 2.
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("hole(s)"), "{}", text(&o));
    let cov = read(&whole.join("coverage.json"));
    let c: serde_json::Value = serde_json::from_str(&cov).unwrap();
    let side = c["items"]
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["name"] == "c.side")
        .unwrap();
    // `keep(default it == left)`: right is a hole.
    assert_eq!(side["holes"], serde_json::json!(["right"]));
    assert!(c["holes"].as_u64().unwrap() > 0);
    // Each run's samples are in its results line.
    let first = read(&whole.join("results.jsonl"));
    let line: serde_json::Value = serde_json::from_str(first.lines().next().unwrap()).unwrap();
    assert_eq!(line["coverage"].as_array().unwrap().len(), 10);
    // gap_to at the end of phase b (10 s), ttc_to at the end of phase a (6 s).
    let item = |n: &str| {
        line["coverage"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["item"] == n)
            .unwrap()
            .clone()
    };
    assert!(item("c.gap_after_cut")["value"].as_f64().unwrap() >= 0.0);
    assert_eq!(item("c.gap_after_cut")["t"], 10.0);
    assert_eq!(item("c.ttc_before_cut")["t"], 6.0);

    // Three shards on one thread each, merged.
    let mut shards = Vec::new();
    for i in 0..3 {
        let d = dir.path().join(format!("s{i}"));
        let s = format!("{i}/3");
        batch(&["--seeds", "1..40", "--threads", "1", "--shard", &s], &d);
        shards.push(d);
    }
    let merged = dir.path().join("merged");
    let o = litesim()
        .arg("merge")
        .args(&shards)
        .arg("-o")
        .arg(&merged)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(read(&merged.join("coverage.json")), cov);
    assert_eq!(read(&merged.join("results.jsonl")), first);

    // Half, then --resume for the rest.
    let resumed = dir.path().join("resumed");
    std::fs::create_dir_all(&resumed).unwrap();
    batch(&["--seeds", "1..40", "--threads", "1"], &resumed);
    let half: String = read(&resumed.join("results.jsonl"))
        .lines()
        .take(17)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(resumed.join("results.jsonl"), half).unwrap();
    std::fs::remove_file(resumed.join("coverage.json")).unwrap();
    batch(&["--seeds", "1..40", "--resume"], &resumed);
    assert_eq!(read(&resumed.join("coverage.json")), cov);
}

#[test]
fn junit_validates_and_fail_on_holes_fails() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let junit = dir.path().join("results.xml");
    let o = litesim()
        .current_dir(workspace())
        .args([
            "batch",
            "examples/scenarios/cut_in.osc",
            "--seeds",
            "1..6",
            "-q",
            "--junit",
        ])
        .arg(&junit)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let xsd = workspace().join("crates/litesim-cli/tests/data/junit.xsd");
    let (j, x) = (junit.to_str().unwrap(), xsd.to_str().unwrap());
    python("check_junit.py", &[j, "6", "0", x]);

    // A test whose runs fail: failures with their reasons; and holes
    // fail the batch under --fail-on-holes even where every run passes.
    let out2 = dir.path().join("c");
    let junit2 = dir.path().join("c.xml");
    let o = batch(
        &["--seeds", "1..30", "--junit", junit2.to_str().unwrap()],
        &out2,
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let rows = read(&out2.join("results.jsonl"));
    // Failed runs are JUnit failures; runs whose scenario did not happen
    // (the cutting car could not be placed 15 m behind a sut.car that
    // starts near the road's start) are skipped.
    let count = |v: &str| {
        rows.lines()
            .filter(|l| l.contains(&format!("\"verdict\":\"{v}\"")))
            .count()
    };
    let (failed, invalid) = (count("fail"), count("invalid"));
    assert!(
        failed > 0 && invalid > 0,
        "{failed} failed, {invalid} invalid"
    );
    python(
        "check_junit.py",
        &[
            junit2.to_str().unwrap(),
            "30",
            &failed.to_string(),
            x,
            &invalid.to_string(),
        ],
    );
    let cov = workspace().join("examples/scenarios/cov_pass.osc");
    let _rm = Remove(cov.clone());
    std::fs::write(
        &cov,
        read(&workspace().join("examples/scenarios/cut_in.osc")).replace(
            "    other: vehicle\n",
            "    other: vehicle\n    cover(ego_end, expression: sut.car.speed, unit: kph, range: [0..200], every: 20)\n",
        ),
    )
    .unwrap();
    let o = litesim()
        .current_dir(workspace())
        .args([
            "batch",
            "examples/scenarios/cov_pass.osc",
            "--seeds",
            "1..3",
            "-q",
            "--fail-on-holes",
            "-o",
        ])
        .arg(dir.path().join("d"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--fail-on-holes"), "{}", text(&o));
}

struct Remove(std::path::PathBuf);
impl Drop for Remove {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

#[test]
fn report_renders_in_chromium_with_bad_lines_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let o = batch(&["--seeds", "1..50", "--save-failed"], &out);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let rows = read(&out.join("results.jsonl"));
    // The report's `fail` filter shows failed runs; invalid ones (the
    // cutting car could not be placed) have their own section.
    let failed = rows
        .lines()
        .filter(|l| l.contains("\"verdict\":\"fail\""))
        .count();
    // A truncated line and a foreign one: named, skipped, the rest renders.
    let mut f = rows.clone();
    f += "{\"test\":\"x\",\"seed\":";
    f += "\nnot json at all\n";
    std::fs::write(out.join("results.jsonl"), f).unwrap();
    let o = litesim()
        .current_dir(workspace())
        .arg("report")
        .arg(&out)
        .arg("-q")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("line 51: skipped") && t.contains("line 52: skipped"),
        "{t}"
    );
    let html = out.join("report.html");
    let h = read(&html);
    assert!(
        h.contains("results.jsonl line 51"),
        "the report names skipped lines"
    );
    assert!(
        !h.contains("http://") && !h.contains("https://"),
        "no network in the report"
    );
    // Failed runs got their replay pictures.
    assert!(
        out.join("failed")
            .read_dir()
            .unwrap()
            .any(|e| { e.unwrap().path().extension().is_some_and(|x| x == "png") })
    );
    // ego_speed: [40..120] every 10 kph → 8 buckets; the drawn speeds are
    // in 50..70 kph → 6 holes.
    python(
        "check_report.py",
        &[
            html.to_str().unwrap(),
            "50",
            &failed.to_string(),
            "c.ego_speed",
            "8",
            "6",
        ],
    );
}

#[test]
fn report_of_an_empty_batch_says_so_and_of_no_batch_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("results.jsonl"), "").unwrap();
    let o = litesim()
        .arg("report")
        .arg(dir.path())
        .arg("-q")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let html = dir.path().join("report.html");
    assert!(read(&html).contains("no runs"));
    python(
        "check_report.py",
        &[html.to_str().unwrap(), "0", "0", "-", "0", "0"],
    );
    let o = litesim()
        .arg("report")
        .arg(dir.path().join("nowhere"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(text(&o).contains("not a folder"), "{}", text(&o));
}

/// The coverage example under drivers (the default): some cut-ins cannot
/// be realised within a driver's limits. Those runs are `invalid`, not
/// failures: `run` exits 3, a batch exits 0 (3 with `--fail-on-invalid`),
/// JUnit skips them, and they cover nothing.
#[test]
fn scenarios_that_did_not_happen_are_invalid_apart_from_failures() {
    let dir = tempfile::tempdir().unwrap();
    let o = litesim()
        .current_dir(workspace())
        .args(["run", TEST, "--seed", "6", "--no-pictures", "-o"])
        .arg(dir.path().join("run"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("INVALID cut_in_coverage.osc seed 6: scenario not realised: "));
    let summary = read(&dir.path().join("run/summary.json"));
    assert!(summary.contains("\"verdict\": \"invalid\""), "{summary}");

    let batch = |extra: &[&str], out: &Path, junit: &Path| {
        litesim()
            .current_dir(workspace())
            .args(["batch", TEST, "--seeds", "1..12", "-q", "--junit"])
            .arg(junit)
            .args(extra)
            .arg("-o")
            .arg(out)
            .output()
            .unwrap()
    };
    let (out, junit) = (dir.path().join("b"), dir.path().join("b.xml"));
    let o = batch(&[], &out, &junit);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let rows = read(&out.join("results.jsonl"));
    let invalid = rows
        .lines()
        .filter(|l| l.contains("\"verdict\":\"invalid\""))
        .count();
    assert!(invalid > 0 && invalid < 12, "{rows}");
    assert!(
        text(&o).contains(&format!("({invalid} invalid, 0 errors): invalid")),
        "{}",
        text(&o)
    );
    let csv = read(&out.join("results.csv"));
    assert!(csv.starts_with("test,seed,verdict,pass,"), "{csv}");
    // JUnit: invalid runs are skipped with their reason; the file is valid.
    let xml = read(&junit);
    assert_eq!(
        xml.matches("<skipped message=\"scenario not realised: ")
            .count(),
        invalid
    );
    let xsd = workspace().join("crates/litesim-cli/tests/data/junit.xsd");
    python(
        "check_junit.py",
        &[junit.to_str().unwrap(), "12", "0", xsd.to_str().unwrap()],
    );
    // Coverage counts only the runs that happened.
    let cov: serde_json::Value = serde_json::from_str(&read(&out.join("coverage.json"))).unwrap();
    let side = cov["items"]
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["name"] == "c.side")
        .unwrap();
    let counted: u64 = side["buckets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["count"].as_u64().unwrap())
        .sum();
    assert_eq!(counted as usize, 12 - invalid, "{side}");
    // The report lists them apart, with their reasons.
    let o = litesim()
        .current_dir(workspace())
        .arg("report")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let html = read(&out.join("report.html"));
    assert!(
        html.contains(&format!(
            "<h2>Invalid runs: the scenario was not realised ({invalid})</h2><table id=\"invalid\">"
        )),
        "{html}"
    );
    assert!(html.contains(&format!("<span class=\"invalid\">{invalid} invalid</span>")));
    // --fail-on-invalid makes them fail the batch (exit 3).
    let o = batch(&["--fail-on-invalid", "--force-new"], &out, &junit);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("--fail-on-invalid: "), "{}", text(&o));
}
