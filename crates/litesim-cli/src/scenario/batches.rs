//! `litesim batch` and `litesim merge`: seeds and shards on the command
//! line, the batch in-process or on Ray, coverage holes.

use super::*;

/// `litesim batch --ray ADDRESS`: the batch on a Ray cluster through the
/// Python package (`python3 -m litesim.ray`), which writes the same folder.
#[allow(clippy::too_many_arguments)]
pub(super) fn ray_batch(
    address: &str,
    tests: &[PathBuf],
    common: &Common,
    (a, b): (u64, u64),
    shard_text: &str,
    out: &Path,
    force_new: bool,
    quiet: bool,
) -> Result<Outcome> {
    if shard(shard_text)? != (0, 1) {
        bail!(
            "--ray runs the whole job list: --shard does not apply (the cluster spreads the runs)"
        );
    }
    if !common.include.is_empty() || common.map.is_some() || common.sut_timeout.is_some() {
        bail!(
            "--ray: -I, --map and --sut-timeout are not passed to Ray workers yet; run without --ray"
        );
    }
    if common.npc() != litesim_scenario::Npc::Driver {
        bail!(
            "--ray: --npc planned is not passed to Ray workers yet (they run drivers); run without --ray"
        );
    }
    common.sut()?;
    let mut cmd = std::process::Command::new("python3");
    cmd.args(["-m", "litesim.ray", "--ray", address, "--seeds"])
        .arg(format!("{a}..{b}"))
        .arg("-o")
        .arg(out);
    if common.sut != "planned" {
        cmd.args(["--sut", &common.sut]);
    }
    match common.mode() {
        Some(litesim_scenario::DriveMode::Kinematic) => {
            cmd.args(["--mode", "kinematic"]);
        }
        Some(litesim_scenario::DriveMode::Dynamic) => {
            cmd.args(["--mode", "dynamic"]);
        }
        None => {}
    }
    if force_new {
        cmd.arg("--force-new");
    }
    if quiet {
        cmd.arg("-q");
    }
    cmd.args(tests);
    let status = cmd.status().map_err(|e| {
        anyhow!("--ray needs python3 with the litesim package (pip install ./python[ray]): {e}")
    })?;
    match status.code() {
        Some(0) => Ok(Outcome::Pass),
        Some(2) => Ok(Outcome::Fail),
        Some(3) => Ok(Outcome::Invalid),
        _ => Ok(Outcome::CouldNotRun),
    }
}

/// Parses `A..B` (inclusive) or a single seed.
pub fn seeds(text: &str) -> Result<(u64, u64)> {
    let parse = |s: &str| {
        s.trim()
            .parse::<u64>()
            .map_err(|_| usage!("--seeds {text}: '{s}' is not a seed (expected A..B)"))
    };
    match text.split_once("..") {
        Some((a, b)) => {
            let (a, b) = (parse(a)?, parse(b.trim_start_matches('='))?);
            if b < a {
                return Err(usage!("--seeds {text}: the range is empty"));
            }
            if b - a >= batch::MAX_SEEDS {
                return Err(usage!(
                    "--seeds {text}: {} seeds; a batch takes at most {} (split it with --shard or several folders)",
                    (b - a) as u128 + 1,
                    batch::MAX_SEEDS
                ));
            }
            Ok((a, b))
        }
        None => {
            let a = parse(text)?;
            Ok((a, a))
        }
    }
}

/// Parses `i/N`.
pub fn shard(text: &str) -> Result<(u64, u64)> {
    let bad = || usage!("--shard {text}: expected i/N with 0 ≤ i < N");
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let (i, n) = (
        i.trim().parse::<u64>().map_err(|_| bad())?,
        n.trim().parse::<u64>().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

/// `litesim batch`.
#[allow(clippy::too_many_arguments)]
pub fn batch(
    tests: Vec<PathBuf>,
    common: &Common,
    seed_range: &str,
    shard_text: &str,
    threads: Option<usize>,
    out: PathBuf,
    resume: bool,
    force_new: bool,
    quiet: bool,
    save_failed: bool,
    save_failed_mcap: bool,
    junit: Option<PathBuf>,
    fail_on_holes: bool,
    fail_on_invalid: bool,
    ray: Option<&str>,
) -> Result<Outcome> {
    let (a, b) = seeds(seed_range)?;
    if let Some(address) = ray {
        return ray_batch(
            address,
            &tests,
            common,
            (a, b),
            shard_text,
            &out,
            force_new,
            quiet,
        );
    }
    let spec = batch::BatchSpec {
        tests,
        seed_from: a,
        seed_to: b,
        shard: shard(shard_text)?,
        threads,
        out: out.clone(),
        resume,
        force_new,
        mode: common.mode(),
        load: common.load(),
        calibration_dir: common.calibration_dir.clone(),
        sut: common.sut()?,
        npc: common.npc(),
        sut_timeout: common.sut_timeout()?,
        step_ms: common.step_ms,
        save_failed,
        save_failed_mcap,
        precomputed: Default::default(),
    };
    let bar = indicatif::ProgressBar::new(0);
    if quiet {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs  {per_sec}  eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let started = std::time::Instant::now();
    let report = batch::run_batch(&spec, &|done, total| {
        if bar.length() != Some(total) {
            bar.set_length(total);
        }
        bar.set_position(done);
    })?;
    bar.finish_and_clear();
    let secs = started.elapsed().as_secs_f64();
    println!(
        "{} runs in this shard ({} resumed, {} run now in {:.2} s, {:.0} runs/s, {} rows of other seeds dropped); {} passed, {} failed ({} invalid, {} errors): {}",
        report.total,
        report.skipped,
        report.ran,
        secs,
        report.ran as f64 / secs.max(1e-9),
        report.foreign,
        report.passed,
        report.failed,
        report.invalid,
        report.errors,
        report.verdict.name()
    );
    println!("wrote {}/results.jsonl and results.csv", out.display());
    if let Some(path) = &junit {
        let lines = batch::read_lines(&out.join("results.jsonl"));
        batch::atomic(path, &batch::junit(&lines))?;
        println!("wrote {}", path.display());
    }
    let holes = coverage_holes(&out)?;
    // The most severe verdict: error, fail, invalid (only with
    // --fail-on-invalid: a scenario that did not happen says nothing of
    // the SUT), pass.
    Ok(
        if report.unreadable > 0 || report.verdict == Verdict::Error {
            Outcome::CouldNotRun
        } else if report.verdict == Verdict::Fail {
            Outcome::Fail
        } else if fail_on_holes && holes > 0 {
            eprintln!("--fail-on-holes: {holes} coverage hole(s)");
            Outcome::Fail
        } else if fail_on_invalid && report.verdict == Verdict::Invalid {
            eprintln!(
                "--fail-on-invalid: {} run(s) whose scenario was not realised",
                report.invalid
            );
            Outcome::Invalid
        } else {
            Outcome::Pass
        },
    )
}

/// The batch's coverage holes (0 without a `coverage.json`), each printed
/// with its item.
pub(super) fn coverage_holes(out: &Path) -> Result<u64> {
    let Ok(text) = crate::read_text(&out.join("coverage.json")) else {
        return Ok(0);
    };
    let c: litesim_scenario::coverage::CoverageFile =
        serde_json::from_str(&text).with_context(|| format!("{}/coverage.json", out.display()))?;
    let holes = c.holes;
    let items = c.items.iter().filter(|i| i.def.kind == "cover").count();
    println!(
        "wrote {}/coverage.json: {items} cover item(s), {holes} hole(s)",
        out.display()
    );
    for i in c.items.iter().filter(|i| !i.holes.is_empty()) {
        println!("  {} {}: not hit {}", i.test, i.def.name, i.holes.join(" "));
    }
    Ok(holes)
}

/// `litesim merge`.
pub fn merge(dirs: &[PathBuf], out: &Path, allow_partial: bool) -> Result<()> {
    let r = batch::merge(dirs, out, allow_partial)?;
    if !r.missing_shards.is_empty() || !r.missing_jobs.is_empty() {
        eprintln!(
            "partial: missing shard(s) [{}], {} run(s) without a result",
            r.missing_shards.join(", "),
            r.missing_jobs.len()
        );
    }
    println!(
        "merged {} runs into {}/results.jsonl and results.csv{}",
        r.runs,
        out.display(),
        if out.join("coverage.json").exists() {
            " (and coverage.json)"
        } else {
            ""
        }
    );
    Ok(())
}
