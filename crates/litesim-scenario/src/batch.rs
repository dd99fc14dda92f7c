//! Bulk runs: tests × seeds in parallel (rayon), each run on its own
//! in-process SSP session. Results are JSON lines (appended as runs finish,
//! so an interrupted batch can `--resume`) and, at the end, rewritten in
//! (test, seed) order together with a CSV table — so the merged result is
//! byte-identical whatever the thread count and the shard count.
//!
//! Sharding: job j (in test-major, seed-minor order) belongs to shard
//! `j mod N`; `--shard i/N` runs shard i only. The same command therefore
//! runs as a Kubernetes Indexed Job (`i = $JOB_COMPLETION_INDEX`) or a
//! Slurm array (`i = $SLURM_ARRAY_TASK_ID`); [`merge`] joins the shards'
//! folders.

use crate::{DriveMode, LoadOptions, Prepared, RunOptions, ScenarioError};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// One run's result line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunLine {
    /// Test path as given.
    pub test: String,
    /// Seed.
    pub seed: u64,
    /// Passed.
    pub pass: bool,
    /// Failures (or the error that stopped the run).
    pub failures: Vec<String>,
    /// Collisions.
    pub collisions: usize,
    /// Smallest box distance over all pairs (m); −1 without pairs.
    pub min_distance: f64,
    /// Smallest TTC over all pairs (s).
    pub min_ttc: Option<f64>,
    /// Largest path error (m).
    pub max_path_error: f64,
    /// Planned duration (s).
    pub duration: f64,
    /// Steps.
    pub steps: u64,
    /// Roads chosen, `var=id` joined by `;`.
    pub roads: String,
}

/// A batch.
#[derive(Clone, Debug)]
pub struct BatchSpec {
    /// Test files.
    pub tests: Vec<PathBuf>,
    /// First seed.
    pub seed_from: u64,
    /// Last seed (inclusive).
    pub seed_to: u64,
    /// Shard index and count.
    pub shard: (u64, u64),
    /// Threads (`None`: all cores).
    pub threads: Option<usize>,
    /// Output folder.
    pub out: PathBuf,
    /// Skip runs already in `results.jsonl`.
    pub resume: bool,
    /// Drive mode.
    pub mode: DriveMode,
    /// Loading options.
    pub load: LoadOptions,
    /// Folder of calibration files (see [`RunOptions::calibration_dir`]).
    pub calibration_dir: Option<PathBuf>,
    /// What drives sut.car.
    pub sut: crate::sut::SutChoice,
    /// Time the SUT may take per call (s); `None`: the test's, else 1 s.
    pub sut_timeout: Option<f64>,
    /// Keep the log of every failed run as `OUT/failed/TEST-seedN.json`
    /// (failed runs are run again with a recorder; passing runs cost nothing).
    pub save_failed: bool,
}

/// What a batch did.
#[derive(Clone, Debug, Default)]
pub struct BatchReport {
    /// Runs in this shard.
    pub total: u64,
    /// Runs skipped because `--resume` found them.
    pub skipped: u64,
    /// Runs executed now.
    pub ran: u64,
    /// Passed (over all lines in the folder).
    pub passed: u64,
    /// Failed.
    pub failed: u64,
}

/// Runs one test under one seed in-process (with `base`'s options) and
/// condenses the result.
pub fn run_line(
    name: &str,
    prep: &Result<Prepared, String>,
    seed: u64,
    base: &RunOptions,
) -> RunLine {
    let mut line = RunLine {
        test: name.to_string(),
        seed,
        pass: false,
        failures: Vec::new(),
        collisions: 0,
        min_distance: -1.0,
        min_ttc: None,
        max_path_error: 0.0,
        duration: 0.0,
        steps: 0,
        roads: String::new(),
    };
    let prep = match prep {
        Ok(p) => p,
        Err(e) => {
            line.failures.push(e.clone());
            return line;
        }
    };
    let mut ssp = crate::in_process();
    let opts = RunOptions {
        seed: Some(seed),
        record: false,
        plan_only: false,
        ..base.clone()
    };
    match crate::run(prep, &mut ssp, &opts) {
        Ok(r) => {
            let s = r.summary;
            line.pass = s.pass;
            line.failures = s.failures;
            line.collisions = s.pairs.iter().filter(|p| p.collision_at.is_some()).count();
            line.min_distance = s
                .pairs
                .iter()
                .map(|p| p.min_distance)
                .reduce(f64::min)
                .unwrap_or(-1.0);
            line.min_ttc = s.pairs.iter().filter_map(|p| p.min_ttc).reduce(f64::min);
            line.max_path_error = s
                .actors
                .iter()
                .map(|a| a.max_path_error)
                .fold(0.0, f64::max);
            line.duration = s.duration;
            line.steps = s.steps;
            line.roads = s
                .roads
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(";");
        }
        Err(e) => line.failures.push(e.chain()),
    }
    line
}

fn read_lines(path: &Path) -> Vec<RunLine> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Vec::new();
    };
    // A run interrupted mid-write leaves a partial last line: skip what does not parse.
    text.lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// Writes `results.jsonl` (sorted, one line per (test, seed)) and
/// `results.csv` into `dir`, atomically.
pub fn write_sorted(dir: &Path, lines: &[RunLine]) -> Result<(), ScenarioError> {
    let mut by: BTreeMap<(String, u64), &RunLine> = BTreeMap::new();
    for l in lines {
        by.insert((l.test.clone(), l.seed), l);
    }
    let mut jsonl = String::new();
    let mut csv = String::from(
        "test,seed,pass,collisions,min_distance,min_ttc,max_path_error,duration,steps,roads,failures\n",
    );
    for l in by.values() {
        jsonl += &serde_json::to_string(l).map_err(|e| ScenarioError::Io(e.to_string()))?;
        jsonl.push('\n');
        let q = |s: &str| format!("\"{}\"", s.replace('"', "\"\""));
        csv += &format!(
            "{},{},{},{},{},{},{},{},{},{},{}\n",
            q(&l.test),
            l.seed,
            l.pass,
            l.collisions,
            l.min_distance,
            l.min_ttc.map_or(String::new(), |v| v.to_string()),
            l.max_path_error,
            l.duration,
            l.steps,
            q(&l.roads),
            q(&l.failures.join("; "))
        );
    }
    atomic(&dir.join("results.jsonl"), &jsonl)?;
    atomic(&dir.join("results.csv"), &csv)
}

fn atomic(path: &Path, text: &str) -> Result<(), ScenarioError> {
    let tmp = path.with_extension("tmp");
    let io = |e: std::io::Error| ScenarioError::Io(format!("{}: {e}", path.display()));
    std::fs::write(&tmp, text).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// Runs a batch; `progress(done, total)` is called as runs finish.
pub fn run_batch(
    spec: &BatchSpec,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<BatchReport, ScenarioError> {
    let (si, sn) = spec.shard;
    if sn == 0 || si >= sn {
        return Err(ScenarioError::Io(format!(
            "shard {si}/{sn}: expected i/N with 0 ≤ i < N"
        )));
    }
    if spec.seed_to < spec.seed_from {
        return Err(ScenarioError::Io(format!(
            "seeds {}..{}: the range is empty",
            spec.seed_from, spec.seed_to
        )));
    }
    std::fs::create_dir_all(&spec.out)
        .map_err(|e| ScenarioError::Io(format!("{}: {e}", spec.out.display())))?;
    let results = spec.out.join("results.jsonl");
    let mut lines = if spec.resume {
        read_lines(&results)
    } else {
        Vec::new()
    };
    let done: std::collections::BTreeSet<(String, u64)> =
        lines.iter().map(|l| (l.test.clone(), l.seed)).collect();
    // Each test is parsed and its map loaded once.
    let preps: Vec<(String, Result<Prepared, String>)> = spec
        .tests
        .iter()
        .map(|t| {
            (
                t.display().to_string(),
                crate::prepare(t, &spec.load).map_err(|e| e.chain()),
            )
        })
        .collect();
    let seeds = spec.seed_to - spec.seed_from + 1;
    let mut jobs = Vec::new();
    for (ti, (name, _)) in preps.iter().enumerate() {
        for k in 0..seeds {
            let j = ti as u64 * seeds + k;
            if j % sn == si {
                let seed = spec.seed_from + k;
                if !done.contains(&(name.clone(), seed)) {
                    jobs.push((ti, seed));
                }
            }
        }
    }
    let total = jobs.len() as u64;
    let mut report = BatchReport {
        total: total + done.len() as u64,
        skipped: done.len() as u64,
        ..BatchReport::default()
    };
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&results)
        .map_err(|e| ScenarioError::Io(format!("{}: {e}", results.display())))?;
    if !spec.resume {
        file.set_len(0)
            .map_err(|e| ScenarioError::Io(e.to_string()))?;
    }
    let sink = Mutex::new((file, 0u64));
    let base = RunOptions {
        mode: spec.mode,
        calibration_dir: spec.calibration_dir.clone(),
        sut: spec.sut.clone(),
        sut_timeout: spec.sut_timeout,
        ..RunOptions::default()
    };
    let work = || {
        jobs.par_iter()
            .map(|(ti, seed)| {
                let (name, prep) = &preps[*ti];
                let line = run_line(name, prep, *seed, &base);
                if spec.save_failed
                    && !line.pass
                    && let Ok(p) = prep
                {
                    save_log(&spec.out, name, p, *seed, spec);
                }
                let text = serde_json::to_string(&line).unwrap_or_default();
                let mut g = sink.lock().unwrap_or_else(|e| e.into_inner());
                let _ = writeln!(g.0, "{text}");
                g.1 += 1;
                progress(g.1, total);
                line
            })
            .collect::<Vec<RunLine>>()
    };
    let new = match spec.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .map_err(|e| ScenarioError::Io(e.to_string()))?
            .install(work),
        None => work(),
    };
    report.ran = new.len() as u64;
    lines.extend(new);
    write_sorted(&spec.out, &lines)?;
    report.passed = lines.iter().filter(|l| l.pass).count() as u64;
    report.failed = lines.len() as u64 - report.passed;
    Ok(report)
}

/// Runs a failed job again with a recorder and writes its log (best effort:
/// a batch does not stop because a debugging aid could not be written).
fn save_log(out: &Path, name: &str, prep: &Prepared, seed: u64, spec: &BatchSpec) {
    let opts = RunOptions {
        seed: Some(seed),
        mode: spec.mode,
        record: true,
        calibration_dir: spec.calibration_dir.clone(),
        sut: spec.sut.clone(),
        sut_timeout: spec.sut_timeout,
        ..RunOptions::default()
    };
    if let Ok(r) = crate::run(prep, &mut crate::in_process(), &opts)
        && let Some(log) = r.log
    {
        let stem = Path::new(name)
            .file_stem()
            .map_or("test".into(), |s| s.to_string_lossy().into_owned());
        let dir = out.join("failed");
        if std::fs::create_dir_all(&dir).is_ok() {
            let _ = log.write_json(&dir.join(format!("{stem}-seed{seed}.json")));
        }
    }
}

/// Merges shard folders into `out` (sorted JSON lines and CSV).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<usize, ScenarioError> {
    let mut all = Vec::new();
    for d in dirs {
        let p = d.join("results.jsonl");
        if !p.exists() {
            return Err(ScenarioError::Io(format!(
                "{}: no results.jsonl",
                d.display()
            )));
        }
        all.extend(read_lines(&p));
    }
    std::fs::create_dir_all(out)
        .map_err(|e| ScenarioError::Io(format!("{}: {e}", out.display())))?;
    write_sorted(out, &all)?;
    Ok(all.len())
}
