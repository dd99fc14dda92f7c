//! Watching a run: the MCAP file read by third-party Python tools (`mcap`,
//! `mcap-protobuf-support`, osi-python), and the viewer (`litesim view`)
//! in headless Chromium (Debian's `chromium` driven by Playwright for
//! Python). `.ci/run` installs all of them.

mod common;
use common::{litesim, text, workspace};
use std::path::Path;
use std::process::Output;

fn python(script: &str, args: &[&std::ffi::OsStr]) -> String {
    common::python_script(script, args)
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

/// `litesim run` of the README example without pictures, its MCAP file to
/// `mcap`, its folder `out`.
fn run_cut_in_mcap(mcap: &str, out: &Path) -> Output {
    run(
        &[
            "examples/scenarios/cut_in.osc",
            "--no-pictures",
            "--mcap",
            mcap,
        ],
        out,
    )
}

#[test]
fn a_run_writes_mcap_that_foxglove_and_osi_tools_read() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mcap = dir.path().join("cut_in.mcap");
    let o = run_cut_in_mcap(mcap.to_str().unwrap(), &out);
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
    let o = run_cut_in_mcap(again.to_str().unwrap(), &dir.path().join("run2"));
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        std::fs::read(&mcap).unwrap(),
        std::fs::read(&again).unwrap()
    );
}

#[test]
fn a_run_whose_weather_changes_exports_each_change_and_the_osi_conditions() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mcap = dir.path().join("weather.mcap");
    let o = run(
        &[
            "examples/scenarios/weather_change.osc",
            "--no-pictures",
            "--mcap",
            mcap.to_str().unwrap(),
        ],
        &out,
    );
    assert!(o.status.success(), "{}", text(&o));
    let said = python(
        "check_mcap.py",
        &[mcap.as_os_str(), out.join("log.json").as_os_str()],
    );
    assert!(said.contains("8 environment changes"), "{said}");
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
            // Its planned cutting car collides on some seeds.
            "--npc",
            "planned",
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
    let o = run_cut_in_mcap("/proc/litesim/no.mcap", &dir.path().join("run"));
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("/proc/litesim"), "{}", text(&o));
}

/// A bug that was fixed: with `--mcap OUT/run.mcap` the run cleaned its
/// new folder of stale temporary files while the MCAP writer had already
/// made its own there, and the file could not be renamed into place
/// ("No such file or directory", exit 1) — one run in a few. The writer
/// now starts its file once the folder is ready.
#[test]
fn an_mcap_file_in_the_run_folder_is_always_written() {
    let dir = tempfile::tempdir().unwrap();
    for k in 0..8 {
        let out = dir.path().join(format!("run{k}"));
        let mcap = out.join("run.mcap");
        let o = run_cut_in_mcap(mcap.to_str().unwrap(), &out);
        assert_eq!(o.status.code(), Some(0), "run {k}: {}", text(&o));
        assert!(std::fs::metadata(&mcap).unwrap().len() > 1000, "run {k}");
        assert!(out.join("summary.json").is_file(), "run {k}");
    }
}

/// An `--mcap` path that names a folder, or lies below a file, is refused
/// before the run (it used to fail after the whole run, with no summary
/// and the path named twice), and nothing is written.
#[test]
fn an_mcap_path_that_is_a_folder_or_below_a_file_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("afile");
    std::fs::write(&file, "x").unwrap();
    let below = file.join("x.mcap");
    for (mcap, says) in [
        (dir.path().to_path_buf(), "this is a folder; name the file"),
        (below.clone(), "is a file, not a folder"),
    ] {
        let out = dir.path().join("run");
        let o = run_cut_in_mcap(mcap.to_str().unwrap(), &out);
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
        let t = text(&o);
        assert!(t.contains("--mcap") && t.contains(says), "{t}");
        let named = format!("{}:", mcap.display());
        assert_eq!(t.matches(&named).count(), 1, "{t}");
        assert!(!out.exists(), "the run went ahead: {t}");
    }
}

#[test]
fn a_test_that_does_not_load_leaves_no_mcap_file_or_folder() {
    // The writer starts before the test is parsed; an error must still
    // leave nothing behind (no temporary file, no folder made for it).
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.osc");
    std::fs::write(&bad, "scenario top:\n    do serial:\n        nothing(\n").unwrap();
    let mcap = dir.path().join("out").join("run.mcap");
    let o = run(
        &[
            bad.to_str().unwrap(),
            "--no-pictures",
            "--mcap",
            mcap.to_str().unwrap(),
        ],
        &dir.path().join("run"),
    );
    assert_ne!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("bad.osc"), "{}", text(&o));
    assert!(!dir.path().join("out").exists(), "{}", text(&o));
}

/// A `litesim view` server, stopped when dropped.
struct Viewer {
    child: std::process::Child,
    url: String,
}

impl Drop for Viewer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn view(target: &Path) -> Viewer {
    use std::io::BufRead;
    let mut child = litesim()
        .current_dir(workspace())
        .arg("view")
        .arg(target)
        .args(["--port", "0"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://127.0.0.1:"))
        .unwrap_or_else(|| panic!("no URL in {line:?}"))
        .to_string();
    Viewer { child, url }
}

/// A failing run (sut.car drives into the box at 4.50 s, its own failure:
/// a failure marker on the timeline).
fn failing_run(dir: &Path) -> std::path::PathBuf {
    let out = dir.join("run");
    let o = run(
        &[
            "examples/scenarios/obstacle_goal.osc",
            "--seed",
            "1",
            "--no-pictures",
        ],
        &out,
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    out
}

#[test]
fn the_viewer_serves_a_run_that_a_browser_scrubs_plays_and_inspects() {
    let dir = tempfile::tempdir().unwrap();
    let out = failing_run(dir.path());
    let v = view(&out);
    let said = python(
        "check_viewer.py",
        &[v.url.as_ref(), out.join("log.json").as_os_str()],
    );
    // obstacle_goal: its phases and the collision on the timeline.
    assert!(said.contains("3 markers"), "{said}");
}

#[test]
fn an_exported_viewer_works_from_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = failing_run(dir.path());
    let html = dir.path().join("shared.html");
    let o = litesim()
        .current_dir(workspace())
        .arg("view")
        .arg(&out)
        .arg("--export")
        .arg(&html)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    // Moved away from the run (and the map): it still has everything. The
    // log goes along only as the truth the check compares the page with.
    let moved = tempfile::tempdir().unwrap();
    let there = moved.path().join("shared.html");
    let truth = moved.path().join("truth.json");
    std::fs::copy(&html, &there).unwrap();
    std::fs::copy(out.join("log.json"), &truth).unwrap();
    drop(dir);
    python(
        "check_viewer.py",
        &[
            format!("file://{}", there.display()).as_ref(),
            truth.as_os_str(),
        ],
    );
}

/// A synthetic ten-minute log at 20 ms (30,000 ticks) of `actors` cars.
fn long_log(path: &Path, actors: usize) {
    let mut rec = litesim_log::LogRecorder::new(0.02);
    for a in 0..actors {
        rec.actor(&format!("car{a}"), "vehicle/car", "car", 4.5, 1.8, 1500.0);
    }
    for k in 0..30_000u64 {
        let t = k as f64 * 0.02;
        rec.begin(k, t);
        for a in 0..actors {
            let v = 10.0 + a as f64;
            let s = litesim_log::ActorSample::from_kinematics(
                litesim_core::geometry::Pose::planar(v * t, 3.5 * a as f64, 0.0),
                litesim_core::geometry::Vec3::new(v, 0.0, 0.0),
                litesim_core::geometry::Vec3::new(0.0, 0.0, 0.0),
                0.0,
                v,
                1500.0,
            );
            rec.sample(&format!("car{a}"), "trajectory", &s);
        }
    }
    rec.finish().write_json(path).unwrap();
}

#[test]
fn a_ten_minute_run_loads_within_a_second_and_streams() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("long.json");
    long_log(&log, 4);
    let v = view(&log);
    // Plots come decimated (≤ 2,000 points), positions in 2,000-tick chunks.
    let said = python(
        "check_viewer.py",
        &[
            v.url.as_ref(),
            log.as_os_str(),
            "--max-load-ms".as_ref(),
            "1000".as_ref(),
        ],
    );
    println!("{said}");
}

#[test]
fn bad_targets_and_busy_ports_are_clear_errors_and_start_no_server() {
    let dir = tempfile::tempdir().unwrap();
    let view_of = |args: &[&std::ffi::OsStr]| {
        litesim()
            .current_dir(workspace())
            .arg("view")
            .args(args)
            .output()
            .unwrap()
    };
    let missing = dir.path().join("nope");
    let o = view_of(&[missing.as_os_str()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("nope") && !text(&o).contains("viewer:"),
        "{}",
        text(&o)
    );
    // A folder without a log.
    let o = view_of(&[dir.path().as_os_str()]);
    assert!(text(&o).contains("no log.json"), "{}", text(&o));
    // A corrupt log: where and what.
    let bad = dir.path().join("log.json");
    std::fs::write(
        &bad,
        "{\"format_version\": 1, \"dt\": 0.02, \"tick\": [1,2,",
    )
    .unwrap();
    let o = view_of(&[bad.as_os_str()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("line 1"), "{}", text(&o));
    assert!(!text(&o).contains("viewer:"), "{}", text(&o));
    // A port in use: said, with the way out.
    let busy = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = busy.local_addr().unwrap().port().to_string();
    let out = failing_run(dir.path());
    let o = view_of(&[out.as_os_str(), "--port".as_ref(), port.as_ref()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("in use") && text(&o).contains("--port"),
        "{}",
        text(&o)
    );
}
