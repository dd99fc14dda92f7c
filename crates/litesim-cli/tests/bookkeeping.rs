//! Results you can trust: manifests, `--resume` and `merge` checks, no
//! hidden inputs from the current directory, exit codes and bounded
//! inputs — each as a user would hit it on the command line.

mod common;
use common::{example_file, litesim, workspace};
use std::path::{Path, PathBuf};
use std::process::Output;

fn test_path(name: &str) -> PathBuf {
    std::fs::canonicalize(workspace().join("examples/scenarios").join(name)).unwrap()
}

fn batch(cwd: &Path, args: &[&str], out: &Path) -> Output {
    litesim()
        .current_dir(cwd)
        .arg("batch")
        .args(args)
        .args(["-q", "--threads", "1", "-o"])
        .arg(out)
        .output()
        .unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn rows(dir: &Path) -> Vec<(String, u64)> {
    std::fs::read_to_string(dir.join("results.jsonl"))
        .unwrap()
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            (
                v["test"].as_str().unwrap().to_string(),
                v["seed"].as_u64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn resume_refuses_other_options_and_keeps_only_the_current_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let t = test_path("cut_in.osc");
    let t = t.to_str().unwrap();
    let o = batch(dir.path(), &[t, "--seeds", "1..6"], &out);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["mode"], "as configured");
    assert_eq!(manifest["seeds"], "1..6");
    assert_eq!(manifest["tests"][0]["sources"].as_str().unwrap().len(), 64);
    // Other options: refused, naming the difference; nothing changed.
    let before = std::fs::read(out.join("results.jsonl")).unwrap();
    let o = batch(
        dir.path(),
        &[t, "--seeds", "1..6", "--resume", "--dynamic"],
        &out,
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("mode: as configured there, dynamic now"),
        "{}",
        text(&o)
    );
    assert_eq!(std::fs::read(out.join("results.jsonl")).unwrap(), before);
    let o = batch(
        dir.path(),
        &[t, "--seeds", "1..6", "--resume", "--sut", "acc"],
        &out,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).contains("sut: planned there, acc now"),
        "{}",
        text(&o)
    );
    // A smaller seed list: nothing runs, only its jobs are kept.
    let o = batch(dir.path(), &[t, "--seeds", "2..3", "--resume"], &out);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("(2 resumed, 0 run now")
            && text(&o).contains("4 rows of other seeds dropped"),
        "{}",
        text(&o)
    );
    assert_eq!(rows(&out), [(t.to_string(), 2), (t.to_string(), 3)]);
    // A larger one runs exactly the missing jobs.
    let o = batch(dir.path(), &[t, "--seeds", "1..4", "--resume"], &out);
    assert!(text(&o).contains("(2 resumed, 2 run now"), "{}", text(&o));
    assert_eq!(rows(&out).len(), 4);
    // A folder with results but no manifest is not resumed blindly.
    let legacy = dir.path().join("legacy");
    std::fs::create_dir_all(&legacy).unwrap();
    std::fs::copy(out.join("results.jsonl"), legacy.join("results.jsonl")).unwrap();
    let o = batch(dir.path(), &[t, "--seeds", "1..4", "--resume"], &legacy);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("no manifest.json"), "{}", text(&o));
}

#[test]
fn merge_refuses_conflicts_and_missing_shards_and_lists_them() {
    let dir = tempfile::tempdir().unwrap();
    let t = test_path("cut_in.osc");
    let t = t.to_str().unwrap();
    let shard = |i: u64, extra: &[&str]| {
        let d = dir.path().join(format!("s{i}{}", extra.join("-")));
        let shard = format!("{i}/3");
        let mut args = vec![t, "--seeds", "1..6", "--shard", shard.as_str()];
        args.extend_from_slice(extra);
        let o = batch(dir.path(), &args, &d);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        d
    };
    let (s0, s1, s2) = (shard(0, &[]), shard(1, &[]), shard(2, &[]));
    let merge = |dirs: &[&PathBuf], extra: &[&str]| {
        litesim()
            .arg("merge")
            .args(dirs)
            .args(extra)
            .arg("-o")
            .arg(dir.path().join("merged"))
            .output()
            .unwrap()
    };
    let o = merge(&[&s0, &s1, &s2], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("merged 6 runs"), "{}", text(&o));
    // Two of three shards: refused with what is missing, unless asked.
    let o = merge(&[&s0, &s2], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("missing shard(s) [1/3]"), "{}", text(&o));
    let o = merge(&[&s0, &s2], &["--allow-partial"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("partial: missing shard(s) [1/3]") && text(&o).contains("merged 4 runs"),
        "{}",
        text(&o)
    );
    // A shard of another batch (other options): refused.
    let other = shard(1, &["--sut", "acc"]);
    let o = merge(&[&s0, &other, &s2], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("different batches"), "{}", text(&o));
    // Two different results for one run: refused, listing the run.
    let forged = dir.path().join("forged");
    std::fs::create_dir_all(&forged).unwrap();
    std::fs::copy(s1.join("manifest.json"), forged.join("manifest.json")).unwrap();
    let mut lines = std::fs::read_to_string(s1.join("results.jsonl")).unwrap();
    lines = lines.replacen("\"pass\":true", "\"pass\":false", 1);
    std::fs::write(forged.join("results.jsonl"), lines).unwrap();
    // The same shard from two places agreeing is fine; disagreeing is
    // refused, naming the run and both folders.
    let again = shard(1, &["--sut", "planned"]);
    let o = merge(&[&s0, &s1, &s2, &again], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = merge(&[&s0, &s1, &s2, &forged], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).contains("1 run(s) have conflicting results") && text(&o).contains("forged"),
        "{}",
        text(&o)
    );
}

#[test]
fn dynamic_batches_give_the_same_bytes_from_any_directory() {
    let dir = tempfile::tempdir().unwrap();
    let t = test_path("lane_change.osc");
    let t = t.to_str().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    // One from the repository root (where calibration/ lives), one from an
    // empty temporary folder.
    let o = batch(&workspace(), &[t, "--seeds", "1..3", "--dynamic"], &a);
    assert!(o.status.code().is_some_and(|c| c != 1), "{}", text(&o));
    let o = batch(dir.path(), &[t, "--seeds", "1..3", "--dynamic"], &b);
    assert!(o.status.code().is_some_and(|c| c != 1), "{}", text(&o));
    for f in ["results.jsonl", "results.csv", "manifest.json"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
    // The manifest names the calibration found beside the test, with its hash.
    let m = std::fs::read_to_string(a.join("manifest.json")).unwrap();
    assert!(m.contains("calibration/dummy.toml sha256:"), "{m}");
}

#[test]
fn exit_codes_follow_the_documented_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        litesim()
            .current_dir(workspace())
            .args(args)
            .output()
            .unwrap()
            .status
            .code()
    };
    let out = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let (x, y, z) = (out("x"), out("y"), out("z"));
    let cut_in = |extra: &[&str]| {
        let mut a = vec![
            "batch",
            "examples/scenarios/cut_in.osc",
            "--seeds",
            "1..2",
            "-q",
        ];
        a.extend_from_slice(extra);
        a.extend_from_slice(&["-o", &x]);
        run(&a)
    };
    // 0: everything passed.
    assert_eq!(cut_in(&[]), Some(0));
    // 2: some run failed its checks.
    let obstacle = "examples/scenarios/stationary_obstacle.osc";
    assert_eq!(
        run(&["batch", obstacle, "--seeds", "1", "-q", "-o", &y]),
        Some(2)
    );
    // 1: a test cannot be read.
    assert_eq!(
        run(&["batch", "no/such/test.osc", "--seeds", "1", "-q", "-o", &z]),
        Some(1)
    );
    // 1: a folder with results is not overwritten unless asked.
    assert_eq!(cut_in(&[]), Some(1));
    assert_eq!(cut_in(&["--force-new"]), Some(0));
    assert_eq!(cut_in(&["--resume"]), Some(0));
    assert_eq!(cut_in(&["--resume", "--force-new"]), Some(64));
    assert_eq!(run(&["run", "no/such/test.osc", "--no-pictures"]), Some(1));
    // 64: the command line itself is wrong — a flag, or a value.
    assert_eq!(run(&["batch", "--no-such-flag"]), Some(64));
    let t = "examples/scenarios/cut_in.osc";
    assert_eq!(run(&["batch", t, "--seeds", "abc", "-o", &z]), Some(64));
    assert_eq!(run(&["batch", t, "--seeds", "5..1", "-o", &z]), Some(64));
    assert_eq!(run(&["batch", t, "--shard", "3/2", "-o", &z]), Some(64));
    assert_eq!(run(&["run", t, "--sut", "turbo", "-o", &z]), Some(64));
    assert_eq!(run(&["run", t, "--sut-timeout", "nan", "-o", &z]), Some(64));
    assert_eq!(run(&["run", t, "--sim", "http://x:1", "-o", &z]), Some(64));
    assert_eq!(run(&["frobnicate"]), Some(64));
    assert_eq!(run(&["run"]), Some(64));
    // Help and version are answers.
    assert_eq!(run(&["--help"]), Some(0));
    assert_eq!(run(&["--version"]), Some(0));
    let help = litesim().arg("--help").output().unwrap();
    assert!(String::from_utf8_lossy(&help.stdout).contains("64 the command line is not valid"));
}

#[test]
fn absurd_seed_ranges_and_durations_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let started = std::time::Instant::now();
    let o = litesim()
        .current_dir(workspace())
        .args([
            "batch",
            "examples/scenarios/cut_in.osc",
            "--seeds",
            "1..18446744073709551615",
            "-o",
        ])
        .arg(dir.path().join("x"))
        .output()
        .unwrap();
    let took = started.elapsed();
    // A value the command line cannot take: a usage error (sysexits'
    // EX_USAGE covers "bad syntax in a parameter").
    assert_eq!(o.status.code(), Some(64));
    assert!(
        text(&o).contains("a batch takes at most 1000000"),
        "{}",
        text(&o)
    );
    // Process start-up included; the check itself is immediate.
    assert!(took.as_secs_f64() < 2.0, "{took:?}");
    for (d, shown) in [("-5s", "-5"), ("0s", "0")] {
        let f = example_file(&format!(
            "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/straight.xodr\"\nextend top.main:\n    do sut.car.drive() with:\n        duration({d})\n"
        ));
        let o = litesim()
            .args(["run", "--no-pictures", "-o"])
            .arg(dir.path().join("y"))
            .arg(f.path())
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
        assert!(
            text(&o).contains(&format!("duration({shown} s) is out of range")),
            "{}",
            text(&o)
        );
    }
}

/// What a run folder says about itself: (run.json seed, summary seed if
/// any, plan seed if any, log seed if any, summary newer than the stamp).
fn folder_state(d: &Path) -> (Option<u64>, Option<u64>, Option<u64>, Option<u64>, bool) {
    let json = |f: &str| -> Option<serde_json::Value> {
        serde_json::from_str(&std::fs::read_to_string(d.join(f)).ok()?).ok()
    };
    let stamp = json("run.json").and_then(|v| v["seed"].as_u64());
    let summary = json("summary.json").and_then(|v| v["seed"].as_u64());
    let plan = json("plan.json").and_then(|v| v["seed"].as_u64());
    let log = json("log.json").and_then(|v| v["meta"]["seed"].as_str()?.parse().ok());
    let newer = match (
        std::fs::metadata(d.join("summary.json")).and_then(|m| m.modified()),
        std::fs::metadata(d.join("run.json")).and_then(|m| m.modified()),
    ) {
        (Ok(s), Ok(r)) => s >= r,
        _ => false,
    };
    (stamp, summary, plan, log, newer)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(6))]
    /// A run killed at any moment into a folder that held a passing run
    /// never leaves a summary that disagrees with the stamp, plan or log
    /// beside it: either the new run's complete set, or no summary.
    #[test]
    fn a_killed_run_never_leaves_a_summary_that_disagrees(kill_ms in 0u64..1500) {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("run");
        // A complete run of the cut-in under `seed` into the folder.
        let complete = |seed: &str| {
            litesim()
                .current_dir(workspace())
                .args(["run", "examples/scenarios/cut_in.osc", "--seed", seed, "--no-pictures", "-o"])
                .arg(&d)
                .output()
                .unwrap()
                .status
                .success()
        };
        proptest::prop_assert!(complete("1"));
        let mut child = litesim()
            .current_dir(workspace())
            .args(["run", "examples/scenarios/cut_in.osc", "--seed", "2", "--gif", "-o"])
            .arg(&d)
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(kill_ms));
        let _ = child.kill(); // SIGKILL
        let finished = child.wait().unwrap().success();
        let (stamp, summary, plan, log, newer) = folder_state(&d);
        match summary {
            Some(seed) => {
                proptest::prop_assert!(newer, "summary older than its stamp");
                proptest::prop_assert_eq!(Some(seed), stamp);
                proptest::prop_assert_eq!(Some(seed), plan);
                proptest::prop_assert_eq!(Some(seed), log);
                // The old complete run (killed before the new one touched
                // the folder) or the new complete one; never a mix.
                proptest::prop_assert!(seed == 1 || seed == 2, "seed {}", seed);
            }
            None => proptest::prop_assert!(!finished, "a finished run has a summary"),
        }
        // The next run into the folder removes what the killed one left.
        proptest::prop_assert!(complete("3"));
        let leftovers: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("tmp"))
            .collect();
        proptest::prop_assert!(leftovers.is_empty(), "{:?}", leftovers);
        proptest::prop_assert_eq!(folder_state(&d).1, Some(3));
    }
}

#[test]
fn a_map_written_in_the_test_is_found_beside_the_test_only() {
    let dir = tempfile::tempdir().unwrap();
    let (tests, cwd) = (dir.path().join("tests"), dir.path().join("cwd"));
    std::fs::create_dir_all(&tests).unwrap();
    std::fs::create_dir_all(&cwd).unwrap();
    let osc = std::fs::canonicalize(workspace().join("osc/domain/config.osc")).unwrap();
    let t = tests.join("t.osc");
    std::fs::write(
        &t,
        format!(
            "import \"{}\"\nextend test_config:\n    set map = \"m.xodr\"\nextend top.main:\n    do sut.car.drive() with:\n        duration(2s)\n",
            osc.display()
        ),
    )
    .unwrap();
    let map = workspace().join("examples/maps/straight.xodr");
    // Only in the current directory: not found (the error names where it looked).
    std::fs::copy(&map, cwd.join("m.xodr")).unwrap();
    let run = || {
        litesim()
            .current_dir(&cwd)
            .args(["run", "--no-pictures", "-o"])
            .arg(dir.path().join("out"))
            .arg(&t)
            .output()
            .unwrap()
    };
    let o = run();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("tests/m.xodr"), "{}", text(&o));
    // Beside the test: found, wherever the command runs.
    std::fs::copy(&map, tests.join("m.xodr")).unwrap();
    let o = run();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn a_plan_failing_post_plan_checks_writes_its_summary_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    // A strict speed the car cannot reach in its phase.
    let f = example_file(
        "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/straight.xodr\"\nextend top.main:\n    do serial():\n        sut.car.drive() with:\n            speed(10kph)\n            duration(1s)\n        sut.car.drive() with:\n            speed(100kph)\n            duration(1s)\n",
    );
    let out = dir.path().join("r");
    let o = litesim()
        .args(["run", "--no-pictures", "-o"])
        .arg(&out)
        .arg(f.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["pass"], false);
    assert!(
        s["failures"][0]
            .as_str()
            .unwrap()
            .contains("post-plan check"),
        "{s}"
    );
    assert!(out.join("plan.json").exists());
}

#[test]
fn a_model_named_in_the_test_is_created_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let run = |model: &str| {
        let f = example_file(&format!(
            "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/straight.xodr\"\nextend sim_info:\n    set profile = \"carla-0.9.15\"\nextend top.main:\n    do sut.pair()\nscenario sut.pair:\n    other: vehicle with:\n        keep(it.model == \"{model}\")\n    do parallel(overlap: equal):\n        sut.car.drive() with:\n            speed(30kph)\n            lane(1, at: start)\n        other.drive() with:\n            speed(30kph)\n            lane(left_of: sut.car, at: start)\n    with: duration(2s)\n"
        ));
        let trace = dir.path().join("t.jsonl");
        let o = litesim()
            .args(["run", "--no-pictures", "--trace-rpc"])
            .arg(&trace)
            .arg("-o")
            .arg(dir.path().join("out"))
            .arg(f.path())
            .output()
            .unwrap();
        (o, std::fs::read_to_string(&trace).unwrap_or_default())
    };
    let (o, trace) = run("vehicle.audi.tt");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let created: Vec<serde_json::Value> = trace
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|l| l["method"] == "create_actor" && l["args"]["actor_id"] == "other")
        .collect();
    assert_eq!(
        created[0]["args"]["spec"]["model_id"], "vehicle.audi.tt",
        "{trace}"
    );
    assert_eq!(created[0]["result"]["model_id"], "vehicle.audi.tt");
    let (o, _) = run("vehicle.flying.carpet");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains(
            "model 'vehicle.flying.carpet' is not in the carla-0.9.15 profile's catalogue"
        ),
        "{}",
        text(&o)
    );
}
