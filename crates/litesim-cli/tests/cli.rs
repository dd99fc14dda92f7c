//! The command line as a user sees it: arguments in, output and exit code out.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

mod common;
use common::{ensure_grpcio, litesim, workspace};

struct Serve {
    child: Child,
    addr: String,
}

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(extra: &[&str]) -> Serve {
    let mut child = litesim()
        .args(["serve", "--addr", "127.0.0.1:0"])
        .args(extra)
        .stdout(Stdio::piped())
        .spawn()
        .expect("litesim serve starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let addr = line
        .split_whitespace()
        .find(|w| w.starts_with("127.0.0.1:"))
        .unwrap_or_else(|| panic!("no address in {line:?}"))
        .to_string();
    Serve { child, addr }
}

#[test]
fn python_grpcio_client_drives_the_server() {
    ensure_grpcio();
    let server = serve(&[]);
    let out = Command::new("python3")
        .arg(workspace().join("crates/litesim-cli/tests/python/ssp_client.py"))
        .arg(&server.addr)
        .arg(workspace().join("proto"))
        .output()
        .expect("python3 runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    if stderr.contains("No module named 'grpc") {
        panic!(
            "grpcio and grpcio-tools are needed: pip install grpcio grpcio-tools (.ci/run installs them)"
        );
    }
    assert!(
        out.status.success(),
        "python client failed:\n{stderr}\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("python client OK"));
}

#[test]
fn demo_in_process_and_over_grpc_write_identical_logs() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a");
    let b = dir.path().join("b");
    let out = litesim()
        .args(["demo", "--in-process", "-o"])
        .arg(&a)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("300 steps of 20 ms") && text.contains("sut.car"),
        "{text}"
    );
    let out = litesim().args(["demo", "-o"]).arg(&b).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Same CSV bytes (the JSON differs only in the transport metadata).
    let csv_a = std::fs::read(a.join("log.csv")).unwrap();
    assert_eq!(csv_a, std::fs::read(b.join("log.csv")).unwrap());
    assert!(csv_a.len() > 300 * 3 * 50);
    let log = litesim_log::SimulationLog::read_json(&b.join("log.json")).unwrap();
    assert_eq!(log.tracks.len(), 3);
}

#[test]
fn client_against_a_running_server() {
    let server = serve(&["--profile", "carla-0.9.15"]);
    let dir = tempfile::tempdir().unwrap();
    let out = litesim()
        .args([
            "client",
            "--addr",
            &server.addr,
            "--profile",
            "carla-0.9.15",
            "--duration",
            "1",
            "-o",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("20 steps of 50 ms"));
}

#[test]
fn bad_names_are_clear_errors() {
    let out = litesim().args(["profiles", "carla-0.8"]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("unknown profile 'carla-0.8'") && err.contains("carla-0.9.15"),
        "{err}"
    );
    let out = litesim()
        .args(["serve", "--model", "warp"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("available: dummy, bicycle, lag"));
    let out = litesim()
        .args(["client", "--addr", "127.0.0.1:1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot connect"));
}

#[test]
fn profiles_and_models_are_listed() {
    let out = litesim().arg("profiles").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for p in [
        "dummy",
        "carla-0.9.12",
        "carla-0.9.13",
        "carla-0.9.15",
        "sumo",
        "dspace",
        "carmaker",
        "drivesim",
        "simian",
        "aisim",
    ] {
        assert!(text.contains(p), "{p} missing from\n{text}");
    }
    let out = litesim()
        .args(["profiles", "carla-0.9.15"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("vehicle.tesla.model3"));
    let out = litesim().arg("models").output().unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("bicycle"));
}

#[test]
fn map_info_and_export() {
    let map = workspace().join("examples/maps/junction.xodr");
    let out = litesim()
        .args(["map", "info"])
        .arg(&map)
        .arg("--roads")
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("roads: 16 (12 in junctions)") && text.contains("4 dynamic"),
        "{text}"
    );
    let dir = tempfile::tempdir().unwrap();
    let (g, c) = (dir.path().join("l.geojson"), dir.path().join("l.csv"));
    let out = litesim()
        .args(["map", "export"])
        .arg(&map)
        .arg("--geojson")
        .arg(&g)
        .arg("--csv")
        .arg(&c)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&g).unwrap()).unwrap();
    assert_eq!(v["features"].as_array().unwrap().len(), 28 * 3);
    assert!(
        std::fs::read_to_string(&c)
            .unwrap()
            .starts_with("road,section,lane,type,line,index,x,y\n")
    );
    // Bad files: a precise message and exit code 1.
    let bad = dir.path().join("bad.xodr");
    std::fs::write(
        &bad,
        "<OpenDRIVE>\n<road id=\"7\" length=\"-5\"></road></OpenDRIVE>",
    )
    .unwrap();
    let out = litesim().args(["map", "info"]).arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("bad.xodr:2:1: OpenDRIVE/road[id=7]: length = -5 must be positive")
    );
    let out = litesim()
        .args(["map", "export"])
        .arg(&map)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn plan_matrix_prints_the_table_and_refuses_bad_input() {
    // One preset over every example: a Markdown row per example.
    let out = litesim()
        .args(["plan-matrix", "--presets", "compact"])
        .arg(workspace().join("examples/plan"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.starts_with("| example | preset | goal |"), "{text}");
    assert_eq!(
        text.lines().filter(|l| l.contains("| compact |")).count(),
        7,
        "{text}"
    );
    assert!(
        text.contains("| single_rect | compact | reached |"),
        "{text}"
    );
    // --check passes a bus that starts inside the margin (its rear on the
    // parking lot's edge: it leaves along an escape leg and arrives) and
    // one proven impossible (the forest's start puts its body off the map).
    let lot = tempfile::tempdir().unwrap();
    for name in ["parking_lot.toml", "forest.toml"] {
        let text = std::fs::read_to_string(workspace().join("examples/plan").join(name)).unwrap();
        std::fs::write(lot.path().join(name), text).unwrap();
    }
    let out = litesim()
        .args(["plan-matrix", "--check", "--presets", "bus"])
        .arg(lot.path())
        .output()
        .unwrap();
    let table = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{table}");
    assert!(table.contains("| parking_lot | bus | reached |"), "{table}");
    assert!(
        table.contains("| forest | bus | **impossible**: ")
            && table.contains("cannot stand at its start (3.00, 5.00)"),
        "{table}"
    );
    // … and fails a run that misses its goal (a horizon too short to get
    // there).
    let text = std::fs::read_to_string(workspace().join("examples/plan/parking_lot.toml"))
        .unwrap()
        .replace("horizon = 70.0", "horizon = 3.0");
    assert!(text.contains("horizon = 3.0"), "{text}");
    std::fs::remove_file(lot.path().join("forest.toml")).unwrap();
    std::fs::write(lot.path().join("parking_lot.toml"), text).unwrap();
    let out = litesim()
        .args(["plan-matrix", "--check", "--presets", "passenger"])
        .arg(lot.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("parking_lot × passenger"), "{err}");
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("| parking_lot | passenger | **missed** |"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    // Bad input: an unknown preset, a missing folder, a folder without
    // configurations.
    let out = litesim()
        .args(["plan-matrix", "--presets", "hovercraft"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        err.contains("unknown vehicle preset 'hovercraft'") && err.contains("passenger"),
        "{err}"
    );
    let out = litesim()
        .args(["plan-matrix", "/nonexistent/plans"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot read /nonexistent/plans"));
    let empty = tempfile::tempdir().unwrap();
    let out = litesim()
        .arg("plan-matrix")
        .arg(empty.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no .toml configurations"));
}

#[test]
fn plan_runs_configs_from_obstacles_png_and_opendrive() {
    let dir = tempfile::tempdir().unwrap();
    // The warehouse (the PNG map): FMT*'s path takes the U-turns round the
    // shelf ends tighter than a compact turns, so the curvature-bounded
    // search plans it; the summary says so and why.
    let out = litesim()
        .arg("plan")
        .arg(workspace().join("examples/plan/warehouse.toml"))
        .arg("-o")
        .arg(dir.path().join("warehouse"))
        .arg("--no-pictures")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}\n{text}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("reached the goal")
            && text.contains("(hybrid A*, turns ≥ 3.92 m")
            && text.contains("FMT*'s path was not drivable: no feasible path for this vehicle: the smoothed path turns with a")
            && text.contains("the compact turns no tighter than 3.14 m"),
        "{text}"
    );
    // The planner views show that search's tree: the log's plan holds its
    // first expanded poses (after start and goal) and their edges.
    let log: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("warehouse/log.json")).unwrap(),
    )
    .unwrap();
    let samples = log["plan"]["samples"].as_array().unwrap().len();
    let edges = log["plan"]["edges"].as_array().unwrap().len();
    assert!(
        samples > 1000 && edges == samples - 3,
        "{samples} samples, {edges} edges"
    );
    for name in ["narrow_passage", "curvy_road"] {
        let cfg = workspace().join(format!("examples/plan/{name}.toml"));
        let out = litesim()
            .arg("plan")
            .arg(&cfg)
            .arg("-o")
            .arg(dir.path().join(name))
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{name}: {}\n{text}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            text.contains("reached the goal") && text.contains("cross-track"),
            "{text}"
        );
        // The goal rule and where the run ended are stated.
        assert!(
            text.contains("(within ") && text.contains(" m/s: "),
            "{text}"
        );
        let log =
            litesim_log::SimulationLog::read_json(&dir.path().join(name).join("log.json")).unwrap();
        assert!(log.plan.is_some() && log.tracking.is_some());
    }
    // Bad configurations: the file, the key and what is wrong.
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[map]\nresolution = -1.0\nsize = [10.0, 10.0]\n[start]\nx = 1.0\ny = 1.0\n[goal]\nx = 5.0\ny = 5.0\n[tracker]\ndt = 0.1\n[simulation]\ndt = 0.05\nhorizon = 10.0\n").unwrap();
    let out = litesim().arg("plan").arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("resolution must be positive"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::write(&bad, "[map]\nresolution = 0.2\nwat = 1\n").unwrap();
    let out = litesim().arg("plan").arg(&bad).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("wat"));
}

#[test]
fn plot_and_animate_logs() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = workspace().join("examples/plan/narrow_passage.toml");
    let run = dir.path().join("run");
    let out = litesim()
        .arg("plan")
        .arg(&cfg)
        .arg("-o")
        .arg(&run)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in ["dashboard.png", "run.gif", "fmt.png", "fmt.gif"] {
        assert!(run.join(f).exists(), "plan wrote no {f}");
    }
    let log = run.join("log.json");
    let ok = |args: &[&str]| {
        let out = litesim().args(args).output().unwrap();
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let p = |name: &str| dir.path().join(name).display().to_string();
    ok(&["plot", &log.display().to_string(), "-o", &p("d.svg")]);
    assert!(
        std::fs::read_to_string(p("d.svg"))
            .unwrap()
            .starts_with("<svg")
    );
    ok(&[
        "plot",
        &log.display().to_string(),
        "--planner",
        "-o",
        &p("f.png"),
    ]);
    ok(&[
        "animate",
        &log.display().to_string(),
        "-o",
        &p("a.gif"),
        "--max-frames",
        "10",
    ]);
    ok(&[
        "animate",
        &log.display().to_string(),
        "--planner",
        "-o",
        &p("e.gif"),
        "--max-frames",
        "5",
    ]);
    let style = dir.path().join("style.toml");
    std::fs::write(&style, "line_width = 3\ntrajectory = \"#000000\"\n").unwrap();
    ok(&[
        "plot",
        &log.display().to_string(),
        "--style",
        &style.display().to_string(),
        "-o",
        &p("s.png"),
    ]);
    // The demo's multi-actor log replays on its road.
    let demo = dir.path().join("demo");
    ok(&["demo", "--in-process", "-o", &demo.display().to_string()]);
    let map = workspace()
        .join("examples/maps/straight.xodr")
        .display()
        .to_string();
    ok(&[
        "animate",
        &demo.join("log.json").display().to_string(),
        "--replay",
        "--map",
        &map,
        "-o",
        &p("r.gif"),
        "--max-frames",
        "8",
    ]);
    // Bad input: clear messages, exit 1, no panic.
    let bad = |args: &[&str], expect: &str| {
        let out = litesim().args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expect), "{args:?}: {err}");
    };
    bad(
        &[
            "plot",
            &demo.join("log.json").display().to_string(),
            "--planner",
            "-o",
            &p("x.png"),
        ],
        "no planner data",
    );
    bad(
        &["animate", &log.display().to_string(), "-o", &p("x.mp4")],
        "animations are GIF",
    );
    std::fs::write(
        dir.path().join("trunc.json"),
        "{\"format_version\": 1, \"dt\": 0.05, \"tick\": [1, 2",
    )
    .unwrap();
    bad(
        &["plot", &p("trunc.json"), "-o", &p("x.png")],
        "trunc.json: line 1",
    );
    std::fs::write(&style, "trajectory = \"blue\"\n").unwrap();
    bad(
        &[
            "plot",
            &log.display().to_string(),
            "--style",
            &style.display().to_string(),
            "-o",
            &p("y.png"),
        ],
        "is not a colour",
    );
}

#[test]
fn check_osc_files() {
    let osc = workspace().join("osc");
    let smoke = osc.join("env/basic/exe_platforms/model_ssp/test/dummy_smoke.osc");
    // The seed's smoke test loads clean with $FTX pointing at litesim's osc/.
    let out = litesim()
        .arg("check")
        .arg(&smoke)
        .env("FTX", &osc)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("11 file(s), 0 error(s)"));
    // As the README shows it: a relative $FTX, from the repository root.
    let out = litesim()
        .current_dir(workspace())
        .args([
            "check",
            "osc/env/basic/exe_platforms/model_ssp/test/dummy_smoke.osc",
        ])
        .env("FTX", "osc")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Without $FTX: a precise error at the import, exit 1.
    let out = litesim()
        .arg("check")
        .arg(&smoke)
        .env_remove("FTX")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("dummy_smoke.osc:2:1: error[E0201]: environment variable $FTX")
    );
    let dir = tempfile::tempdir().unwrap();
    let w = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    // Several errors at once, each with line, column, caret and code; JSON for tools.
    let bad = w(
        "bad.osc",
        "scenario s:\n    x int\n    keep(y == )\n    do car.drive\n",
    );
    let out = litesim().arg("check").arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.osc:2:5: error[E0112]")
            && err.contains("bad.osc:3:15: error[E0107]")
            && err.contains("bad.osc:4:8: error[E0114]"),
        "{err}"
    );
    assert!(err.contains("  |     ^"), "{err}");
    let out = litesim()
        .arg("check")
        .arg(&bad)
        .arg("--json")
        .output()
        .unwrap();
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 3);
    assert_eq!(
        (lines[0]["line"].as_u64(), lines[0]["code"].as_str()),
        (Some(2), Some("E0112"))
    );
    // rustc's JSON diagnostics: what editors and CI annotators read.
    let twice = w(
        "twice.osc",
        "enum color: [red, green]\nenum color: [blue]\n",
    );
    let out = litesim()
        .arg("check")
        .arg(&twice)
        .args(["--format", "json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let d: serde_json::Value =
        serde_json::from_str(String::from_utf8_lossy(&out.stdout).lines().next().unwrap()).unwrap();
    assert_eq!(d["$message_type"], "diagnostic");
    assert_eq!(d["level"], "error");
    assert_eq!(d["code"]["code"], "E0330");
    assert_eq!(d["message"], "enum 'color' is defined twice");
    let sp = &d["spans"][0];
    assert!(sp["file_name"].as_str().unwrap().ends_with("twice.osc"));
    assert_eq!(
        (&sp["line_start"], &sp["column_start"], &sp["is_primary"]),
        (
            &serde_json::json!(2),
            &serde_json::json!(6),
            &serde_json::json!(true)
        )
    );
    assert_eq!(sp["text"][0]["text"], "enum color: [blue]");
    assert_eq!(
        (
            &sp["text"][0]["highlight_start"],
            &sp["text"][0]["highlight_end"]
        ),
        (&serde_json::json!(6), &serde_json::json!(11))
    );
    assert_eq!(d["children"][0]["level"], "note");
    assert_eq!(d["children"][0]["message"], "first defined here");
    assert_eq!(d["children"][0]["spans"][0]["line_start"], 1);
    assert_eq!(d["children"][1]["level"], "help");
    assert!(d["rendered"].as_str().unwrap().contains("error[E0330]"));
    // Import cycles, missing files and search paths.
    w("a.osc", "import \"b.osc\"\nstruct a\n");
    w("b.osc", "import \"a.osc\"\nstruct b\n");
    let out = litesim()
        .arg("check")
        .arg(dir.path().join("a.osc"))
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("import cycle: a.osc → b.osc → a.osc"));
    let lib = tempfile::tempdir().unwrap();
    std::fs::write(lib.path().join("lib.osc"), "struct from_lib\n").unwrap();
    let user = w(
        "user.osc",
        "import \"lib.osc\"\nimport \"nope.osc\"\nstruct u\n",
    );
    let out = litesim()
        .arg("check")
        .arg(&user)
        .arg("-I")
        .arg(lib.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("user.osc:2:1: error[E0202]: cannot find imported file 'nope.osc'")
            && err.contains("2 file(s)"),
        "{err}"
    );
    let out = litesim()
        .arg("check")
        .arg(&user)
        .arg("--dump-ast")
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"decl\": \"Compound\""));
}

#[test]
fn run_writes_log_summary_and_pictures_and_the_smoke_test_runs_with_ftx() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cut");
    let o = litesim()
        .current_dir(workspace())
        .args(["run", "examples/scenarios/cut_in.osc", "--gif", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("PASS cut_in.osc seed 1"), "{text}");
    for f in [
        "log.json",
        "summary.json",
        "replay.png",
        "replay.gif",
        "dashboard.png",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    let png = std::fs::read(out.join("replay.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["pass"], true);
    // A stylesheet restyles the pictures; a bad one fails before the run.
    let style = dir.path().join("style.toml");
    let run_styled = |sheet: &str, out: &str| {
        std::fs::write(&style, sheet).unwrap();
        litesim()
            .current_dir(workspace())
            .args(["run", "examples/scenarios/cut_in.osc", "-o"])
            .arg(dir.path().join(out))
            .arg("--style")
            .arg(&style)
            .output()
            .unwrap()
    };
    let o = run_styled("road = \"#808080\"\n", "styled");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let styled = std::fs::read(dir.path().join("styled/replay.png")).unwrap();
    assert_ne!(styled, png, "the road colour changed the picture");
    let o = run_styled("road = \"grey\"\n", "badstyle");
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("road = 'grey' is not a colour"), "{err}");
    assert!(!dir.path().join("badstyle").exists());
    // The seed's smoke test with only $FTX set.
    let o = litesim()
        .current_dir(workspace())
        .env("FTX", "osc")
        .args([
            "run",
            "osc/env/basic/exe_platforms/model_ssp/test/dummy_smoke.osc",
            "--no-pictures",
            "-o",
        ])
        .arg(dir.path().join("smoke"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A collision is an outcome: exit 2, summary says so.
    let o = litesim()
        .current_dir(workspace())
        .args([
            "run",
            "examples/scenarios/stationary_obstacle.osc",
            "--no-pictures",
            "-o",
        ])
        .arg(dir.path().join("obstacle"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stdout).contains("collision between sut.car and box"));
    // Plan only: printed, drawn, nothing run.
    let o = litesim()
        .current_dir(workspace())
        .args([
            "run",
            "examples/scenarios/overtake.osc",
            "--plan-only",
            "-o",
        ])
        .arg(dir.path().join("plan"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && text.contains("sut.car drive"),
        "{text}"
    );
    assert!(dir.path().join("plan/plan.png").exists());
    // Bad input: precise errors, exit 1.
    let o = litesim()
        .current_dir(workspace())
        .args(["run", "examples/scenarios/too_many_lanes.osc"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("has ≥ 3 lanes"));
    let o = litesim()
        .args(["run", "/no/such/test.osc"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let o = litesim()
        .current_dir(workspace())
        .args(["run", "examples/scenarios/cut_in.osc", "--sim", "tcp://x"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&o.stderr).contains("expected grpc://HOST:PORT"));
}

#[test]
fn batch_shards_merge_and_calibrate_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let tests = [
        "examples/scenarios/follow.osc",
        "examples/scenarios/random_duration.osc",
    ];
    let full = dir.path().join("full");
    let o = litesim()
        .current_dir(workspace())
        .arg("batch")
        .args(tests)
        .args(["--seeds", "1..5", "-q", "-o"])
        .arg(&full)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut shards = Vec::new();
    for i in 0..2 {
        let d = dir.path().join(format!("s{i}"));
        let o = litesim()
            .current_dir(workspace())
            .arg("batch")
            .args(tests)
            .args([
                "--seeds",
                "1..5",
                "-q",
                "--threads",
                "1",
                "--shard",
                &format!("{i}/2"),
                "-o",
            ])
            .arg(&d)
            .output()
            .unwrap();
        assert!(o.status.success());
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
    assert!(o.status.success());
    assert_eq!(
        std::fs::read(full.join("results.csv")).unwrap(),
        std::fs::read(merged.join("results.csv")).unwrap()
    );
    let csv = std::fs::read_to_string(full.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 11);
    for bad in [["--shard", "3/2"], ["--seeds", "9..1"]] {
        let o = litesim()
            .current_dir(workspace())
            .arg("batch")
            .args(tests)
            .args(bad)
            .output()
            .unwrap();
        // A value the command line cannot take: a usage error.
        assert_eq!(o.status.code(), Some(64), "{bad:?}");
    }
    // Failed runs keep their logs for debugging.
    let failing = dir.path().join("failing");
    let o = litesim()
        .current_dir(workspace())
        .args([
            "batch",
            "examples/scenarios/stationary_obstacle.osc",
            "--seeds",
            "1..2",
            "-q",
            "--save-failed",
            "-o",
        ])
        .arg(&failing)
        .output()
        .unwrap();
    // Failed runs make the batch's verdict a failure: exit 2.
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for seed in [1, 2] {
        let p = failing.join(format!("failed/stationary_obstacle-seed{seed}.json"));
        // Each log names its test, seed and the folder's manifest.
        let log: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        assert_eq!(
            log["meta"]["test"],
            "examples/scenarios/stationary_obstacle.osc"
        );
        assert_eq!(log["meta"]["seed"], seed.to_string());
        assert_eq!(log["meta"]["manifest"].as_str().unwrap().len(), 64);
    }
    let cal = dir.path().join("dummy.toml");
    let o = litesim()
        .args(["calibrate", "--profile", "dummy", "-o"])
        .arg(&cal)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = litesim()
        .current_dir(workspace())
        .args([
            "run",
            "examples/scenarios/lane_change.osc",
            "--dynamic",
            "--no-pictures",
            "--calibration",
        ])
        .arg(&cal)
        .arg("-o")
        .arg(dir.path().join("lc"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stdout));
}

#[test]
fn python_reflection_client_lists_the_services_through_v1alpha() {
    ensure_grpcio();
    let server = serve(&[]);
    let out = Command::new("python3")
        .arg(workspace().join("crates/litesim-cli/tests/python/reflection_client.py"))
        .arg(&server.addr)
        .output()
        .expect("python3 runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}\n{text}",
        String::from_utf8_lossy(&out.stderr)
    );
    for s in ["litesim.ssp.v1.SimulatorSupport", "grpc.health.v1.Health"] {
        assert!(text.lines().any(|l| l == s), "{s} missing from:\n{text}");
    }
}

#[test]
fn run_traces_every_ssp_call_in_process_and_over_grpc() {
    let dir = tempfile::tempdir().unwrap();
    let server = serve(&[]);
    let sim = format!("grpc://{}", server.addr);
    let mut traces = Vec::new();
    for (name, extra) in [("local", vec![]), ("remote", vec!["--sim", sim.as_str()])] {
        let trace = dir.path().join(format!("{name}.jsonl"));
        let o = litesim()
            .current_dir(workspace())
            .args([
                "run",
                "examples/scenarios/cut_in.osc",
                "--no-pictures",
                "-o",
            ])
            .arg(dir.path().join(name))
            .args(&extra)
            .arg("--trace-rpc")
            .arg(&trace)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let text = std::fs::read_to_string(&trace).unwrap();
        let lines: Vec<serde_json::Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(lines[0]["method"], "init");
        assert!(lines.iter().all(|l| l["duration_us"].as_f64().is_some()));
        assert!(
            lines
                .iter()
                .any(|l| l["method"] == "create_actor" && l["args"]["actor_id"] == "sut.car")
        );
        traces.push(
            lines
                .iter()
                .map(|l| {
                    (
                        l["method"].as_str().unwrap().to_string(),
                        l.get("error").is_some(),
                    )
                })
                .collect::<Vec<_>>(),
        );
        let s = litesim()
            .arg("trace")
            .arg("summarize")
            .arg(&trace)
            .output()
            .unwrap();
        let table = String::from_utf8_lossy(&s.stdout);
        assert!(s.status.success());
        assert!(
            table
                .lines()
                .any(|l| l.starts_with("create_actor") && l.split_whitespace().nth(1) == Some("2")),
            "{table}"
        );
    }
    // The engine makes the same calls wherever its simulator lives.
    assert_eq!(traces[0], traces[1]);
}

#[test]
fn a_carla_scenario_checks_and_runs_as_written() {
    let test = workspace().join("examples/carla/cut_in.osc");
    // Detected: the summary line names the dialect.
    let out = litesim().arg("check").arg(&test).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("0 error(s)") && err.contains("CARLA dialect"),
        "{err}"
    );
    // Forced off: litesim's dialect has no basic.osc — a precise error as
    // a rustc-style JSON line.
    let out = litesim()
        .arg("check")
        .arg(&test)
        .args(["--dialect", "litesim", "--format", "json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let line = String::from_utf8_lossy(&out.stdout);
    let v: serde_json::Value = serde_json::from_str(line.lines().next().unwrap()).unwrap();
    assert_eq!(v["code"]["code"], "E0202", "{v}");
    assert_eq!(v["spans"][0]["line_start"], 7, "{v}");
    // Runs on the map in the repo (examples/maps, found as ../maps).
    let dir = tempfile::tempdir().unwrap();
    let out = litesim()
        .arg("run")
        .arg(&test)
        .args(["--sut", "acc", "--no-pictures", "-o"])
        .arg(dir.path())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("PASS") && text.contains("profile carla-0.9.15"),
        "{text}"
    );
    // A map folder without the map: the line that asked and where it looked.
    let empty = tempfile::tempdir().unwrap();
    let out = litesim()
        .arg("run")
        .arg(&test)
        .arg("--map-dir")
        .arg(empty.path())
        .args(["-o"])
        .arg(dir.path().join("x"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cut_in.osc:11:5") && err.contains("no straight.xodr in"),
        "{err}"
    );
    // An unknown dialect is refused by the argument parser.
    let out = litesim()
        .arg("check")
        .arg(&test)
        .args(["--dialect", "scenic"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(64));
}

#[test]
fn serve_refuses_a_public_address_without_insecure_and_runs_need_its_token() {
    // Not loopback, no TLS, no --insecure: refused before serving, saying why.
    let out = litesim()
        .args(["serve", "--addr", "0.0.0.0:0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not loopback") && err.contains("--insecure"),
        "{err}"
    );
    // With --insecure it serves, and says what that means.
    let mut child = litesim()
        .args(["serve", "--addr", "0.0.0.0:0", "--insecure"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stderr.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let _ = child.kill();
    let _ = child.wait();
    assert!(line.contains("--insecure: serving in plain text"), "{line}");
    // A server with a token: a run over gRPC without it is refused, with
    // it (LITESIM_TOKEN_FILE) it runs.
    let dir = tempfile::tempdir().unwrap();
    let token = dir.path().join("token");
    std::fs::write(&token, "tok-123\n").unwrap();
    let server = serve(&["--auth-token-file", token.to_str().unwrap()]);
    let sim = format!("grpc://{}", server.addr);
    let run = |with: bool| {
        let mut c = litesim();
        c.current_dir(workspace())
            .args([
                "run",
                "examples/scenarios/cut_in.osc",
                "--no-pictures",
                "--sim",
                &sim,
                "-o",
            ])
            .arg(dir.path().join("out"));
        if with {
            c.env("LITESIM_TOKEN_FILE", &token);
        }
        c.output().unwrap()
    };
    let o = run(false);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("Bearer"), "{err}");
    let o = run(true);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn serve_over_tls_on_a_public_address_and_run_against_it_with_the_ca_and_token() {
    let dir = tempfile::tempdir().unwrap();
    let ck = rcgen::generate_simple_self_signed(vec!["localhost".into()]).unwrap();
    let (cert, key, token) = (
        dir.path().join("cert.pem"),
        dir.path().join("key.pem"),
        dir.path().join("token"),
    );
    std::fs::write(&cert, ck.cert.pem()).unwrap();
    std::fs::write(&key, ck.signing_key.serialize_pem()).unwrap();
    std::fs::write(&token, "tok-tls\n").unwrap();
    let tls = [
        "--tls-cert",
        cert.to_str().unwrap(),
        "--tls-key",
        key.to_str().unwrap(),
        "--auth-token-file",
        token.to_str().unwrap(),
    ];
    // With TLS a public address needs no --insecure.
    let mut child = litesim()
        .args(["serve", "--addr", "0.0.0.0:0"])
        .args(tls)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let _ = child.kill();
    let _ = child.wait();
    assert!(line.contains("serving the SSP API on 0.0.0.0:"), "{line}");
    // A run over TLS: the CA and the token from the environment.
    let server = serve(&tls);
    let port = server.addr.rsplit(':').next().unwrap();
    let o = litesim()
        .current_dir(workspace())
        .args([
            "run",
            "examples/scenarios/cut_in.osc",
            "--no-pictures",
            "--sim",
        ])
        .arg(format!("grpc://localhost:{port}"))
        .arg("-o")
        .arg(dir.path().join("out"))
        .env("LITESIM_TOKEN_FILE", &token)
        .env("LITESIM_CA_FILE", &cert)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
