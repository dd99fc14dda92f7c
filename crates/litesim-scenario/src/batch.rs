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
use litesim_core::files::{MAX_INPUT_BYTES, ReadError, open_regular, read_text};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Most seeds one batch runs per test: a typo such as `--seeds
/// 1..18446744073709551615` is refused at once instead of filling memory
/// with jobs.
pub const MAX_SEEDS: u64 = 1_000_000;

/// What produced a results folder: written first (`manifest.json`), checked
/// by `--resume` (the same options and tests, or a refusal naming the
/// difference) and by [`merge`] (the same everything but the shard).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// litesim version.
    pub litesim: String,
    /// The tests, in job order.
    pub tests: Vec<ManifestTest>,
    /// `kinematic`, `dynamic` or `as configured` (each test's
    /// `sim_info.dynamic`).
    pub mode: String,
    /// What drove sut.car.
    pub sut: String,
    /// What drove the other vehicles (`driver`, `planned`).
    #[serde(default)]
    pub npc: String,
    /// The SUT's timeout option (s), if given.
    pub sut_timeout: Option<f64>,
    /// Seeds, `A..B`.
    pub seeds: String,
    /// Shard, `i/N`.
    pub shard: String,
}

/// One test of a [`Manifest`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestTest {
    /// Path as given.
    pub path: String,
    /// SHA-256 of its sources (the file and its imports); `None` when it
    /// could not be read.
    pub sources: Option<String>,
    /// SHA-256 of its map's text, if it has one.
    pub map: Option<String>,
    /// The profile its runs use.
    pub profile: Option<String>,
    /// The driver calibration its runs use (`built-in`, `given`, or path
    /// and hash).
    pub calibration: Option<String>,
}

impl Manifest {
    /// What differs from `other` (`other` is the folder's, `self` this
    /// command's), ignoring the seeds and, with `shard_too == false`, the
    /// shard.
    pub fn differences(&self, other: &Manifest, shard_too: bool) -> Vec<String> {
        let mut d = Vec::new();
        let mut cmp = |what: &str, now: String, was: String| {
            if now != was {
                d.push(format!("{what}: {was} there, {now} now"));
            }
        };
        cmp("litesim", self.litesim.clone(), other.litesim.clone());
        cmp("mode", self.mode.clone(), other.mode.clone());
        cmp("sut", self.sut.clone(), other.sut.clone());
        cmp("npc", self.npc.clone(), other.npc.clone());
        cmp(
            "sut timeout",
            format!("{:?}", self.sut_timeout),
            format!("{:?}", other.sut_timeout),
        );
        if shard_too {
            cmp("shard", self.shard.clone(), other.shard.clone());
        }
        let paths = |m: &Manifest| m.tests.iter().map(|t| t.path.clone()).collect::<Vec<_>>();
        if paths(self) != paths(other) {
            d.push(format!(
                "tests: [{}] there, [{}] now",
                paths(other).join(", "),
                paths(self).join(", ")
            ));
        } else {
            for (a, b) in self.tests.iter().zip(&other.tests) {
                if a != b {
                    let what = if a.sources != b.sources {
                        "its sources changed"
                    } else if a.map != b.map {
                        "its map changed"
                    } else if a.profile != b.profile {
                        "its profile changed"
                    } else {
                        "its calibration changed"
                    };
                    d.push(format!("test {}: {what}", a.path));
                }
            }
        }
        d
    }

    /// Reads `dir/manifest.json` (`Ok(None)` when there is none).
    pub fn read(dir: &Path) -> Result<Option<Manifest>, ScenarioError> {
        let p = dir.join("manifest.json");
        match read_text(&p, MAX_INPUT_BYTES) {
            Ok(t) => serde_json::from_str(&t)
                .map(Some)
                .map_err(|e| ScenarioError::format(p.display(), e)),
            Err(ReadError::Io { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => {
                Ok(None)
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Writes `dir/manifest.json` atomically; returns its text's SHA-256
    /// (what the folder's failed-run logs name).
    pub fn write(&self, dir: &Path) -> Result<String, ScenarioError> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| ScenarioError::format("manifest.json", e))?
            + "\n";
        atomic(&dir.join("manifest.json"), &text)?;
        Ok(crate::sha256_hex(text.as_bytes()))
    }

    /// The seed range.
    pub fn seed_range(&self) -> Option<(u64, u64)> {
        let (a, b) = self.seeds.split_once("..")?;
        Some((a.parse().ok()?, b.parse().ok()?))
    }

    /// The shard `(i, N)`.
    pub fn shard_pair(&self) -> Option<(u64, u64)> {
        let (i, n) = self.shard.split_once('/')?;
        Some((i.parse().ok()?, n.parse().ok()?))
    }

    /// Every job `(test path, seed)` of this manifest's shard.
    pub fn jobs(&self) -> Vec<(String, u64)> {
        let (Some((a, b)), Some((si, sn))) = (self.seed_range(), self.shard_pair()) else {
            return Vec::new();
        };
        jobs_of(self.tests.iter().map(|t| t.path.as_str()), a, b, (si, sn))
    }
}

/// Jobs `(test, seed)` of shard `(i, N)`: job j in test-major, seed-minor
/// order belongs to shard `j mod N`.
fn jobs_of<'a>(
    tests: impl Iterator<Item = &'a str>,
    from: u64,
    to: u64,
    (si, sn): (u64, u64),
) -> Vec<(String, u64)> {
    let seeds = to - from + 1;
    let mut out = Vec::new();
    for (ti, name) in tests.enumerate() {
        for k in 0..seeds {
            if (ti as u64 * seeds + k) % sn.max(1) == si {
                out.push((name.to_string(), from + k));
            }
        }
    }
    out
}

/// One run's result line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunLine {
    /// Test path as given.
    pub test: String,
    /// Seed.
    pub seed: u64,
    /// Passed (`verdict` is `pass`).
    pub pass: bool,
    /// What the run came to.
    #[serde(default)]
    pub verdict: crate::Verdict,
    /// Failures (or the error that stopped the run).
    pub failures: Vec<String>,
    /// Why the scenario was not realised.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub invalid: Vec<String>,
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
    /// The ego's largest deceleration (m/s²).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_decel: Option<f64>,
    /// The ego's smallest time headway to an actor it followed (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_thw: Option<f64>,
    /// The ego's largest DRAC to an actor it closed on (m/s²).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_drac: Option<f64>,
    /// The ego's smallest post-encroachment time at a junction (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_pet: Option<f64>,
    /// `cover`/`record` samples.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub coverage: Vec<crate::coverage::Sample>,
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
    /// Skip runs already in `results.jsonl` (same manifest required).
    pub resume: bool,
    /// Start over in a folder that holds results (without it, and without
    /// `resume`, such a folder is refused rather than overwritten).
    pub force_new: bool,
    /// Drive mode (`None`: each test's configuration).
    pub mode: Option<DriveMode>,
    /// Loading options.
    pub load: LoadOptions,
    /// Folder of calibration files (see [`RunOptions::calibration_dir`]).
    pub calibration_dir: Option<PathBuf>,
    /// What drives sut.car.
    pub sut: crate::sut::SutChoice,
    /// What drives the other vehicles.
    pub npc: crate::Npc,
    /// Time the SUT may take per call (s); `None`: the test's, else 1 s.
    pub sut_timeout: Option<f64>,
    /// Keep the log of every failed run as `OUT/failed/TEST-seedN.json`
    /// (failed runs are run again with a recorder; passing runs cost nothing).
    pub save_failed: bool,
    /// Result lines computed elsewhere (a Ray cluster: `litesim.ray`), by
    /// (test, seed): those jobs are not run again, and everything is written
    /// exactly as if they had run here. Jobs missing from it run here.
    pub precomputed: BTreeMap<(String, u64), RunLine>,
    /// With `save_failed`: also write each failed run as
    /// `OUT/failed/TEST-seedN.mcap` (see `litesim_mcap`).
    pub save_failed_mcap: bool,
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
    /// Rows `--resume` found that are not jobs of this command (other
    /// seeds): dropped from the results.
    pub foreign: u64,
    /// Tests that could not be read (their runs are failures).
    pub unreadable: u64,
    /// Passed (over all lines in the folder).
    pub passed: u64,
    /// Failed, invalid or in error (over all lines in the folder).
    pub failed: u64,
    /// Of those: the scenario not realised.
    pub invalid: u64,
    /// Of those: could not be carried out.
    pub errors: u64,
    /// The most severe verdict of all lines in the folder.
    pub verdict: crate::Verdict,
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
        verdict: crate::Verdict::Error,
        failures: Vec::new(),
        invalid: Vec::new(),
        collisions: 0,
        min_distance: -1.0,
        min_ttc: None,
        max_path_error: 0.0,
        duration: 0.0,
        steps: 0,
        roads: String::new(),
        max_decel: None,
        min_thw: None,
        max_drac: None,
        min_pet: None,
        coverage: Vec::new(),
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
            line.verdict = s.verdict;
            line.failures = s.failures;
            line.invalid = s.invalid;
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
            line.max_decel = s.ego.as_ref().map(|e| e.max_decel);
            let leads = s.ego.as_ref().map_or(&[][..], |e| &e.leads[..]);
            line.min_thw = leads
                .iter()
                .map(|l| l.min_thw)
                .filter(|t| *t >= 0.0)
                .reduce(f64::min);
            line.max_drac = leads
                .iter()
                .map(|l| l.max_drac)
                .filter(|d| *d > 0.0)
                .reduce(f64::max);
            line.min_pet = s
                .ego
                .as_ref()
                .and_then(|e| e.pets.iter().map(|p| p.pet).reduce(f64::min));
            line.coverage = s.coverage;
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

/// The result lines of a `results.jsonl` (none when it cannot be read).
pub fn read_lines(path: &Path) -> Vec<RunLine> {
    let Ok(text) = read_text(path, MAX_INPUT_BYTES) else {
        return Vec::new();
    };
    // A run interrupted mid-write leaves a partial last line: skip what does not parse.
    text.lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// The coverage items of the tests, as (test, definition).
pub fn item_defs<'a>(
    preps: impl Iterator<Item = (&'a str, &'a Prepared)>,
) -> Vec<(String, crate::coverage::ItemDef)> {
    preps
        .flat_map(|(name, p)| {
            p.test
                .covers
                .iter()
                .map(move |c| (name.to_string(), c.def()))
        })
        .collect()
}

/// Reads the item definitions of a folder's `coverage.json` (none when it
/// has none).
pub fn read_defs(dir: &Path) -> Result<Vec<(String, crate::coverage::ItemDef)>, ScenarioError> {
    let p = dir.join("coverage.json");
    let Ok(text) = read_text(&p, MAX_INPUT_BYTES) else {
        return Ok(Vec::new());
    };
    let f: crate::coverage::CoverageFile =
        serde_json::from_str(&text).map_err(|e| ScenarioError::format(p.display(), e))?;
    Ok(f.items.into_iter().map(|i| (i.test, i.def)).collect())
}

/// The coverage of `lines` over the items `defs`.
pub fn coverage_of<'a>(
    defs: &[(String, crate::coverage::ItemDef)],
    lines: impl IntoIterator<Item = &'a RunLine>,
) -> crate::coverage::CoverageFile {
    let mut fold = crate::coverage::Fold::default();
    for (t, d) in defs {
        fold.declare(t, d);
    }
    // A run whose scenario did not happen covers nothing.
    for l in lines {
        if l.verdict != crate::Verdict::Invalid {
            fold.add(&l.test, &l.coverage);
        }
    }
    fold.finish()
}

/// JUnit XML of the runs: one testsuite per test, one testcase per seed
/// (a failure element with the reasons for a failed run) — the format
/// GitLab, GitHub and Jenkins read.
pub fn junit(lines: &[RunLine]) -> String {
    let esc = |s: &str| {
        s.chars()
            .filter(|c| !c.is_control() || *c == '\n' || *c == '\t')
            .collect::<String>()
            .replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('"', "&quot;")
    };
    let mut by: BTreeMap<&str, Vec<&RunLine>> = BTreeMap::new();
    for l in lines {
        by.entry(l.test.as_str()).or_default().push(l);
    }
    use crate::Verdict;
    let count = |runs: &[&RunLine], v: Verdict| runs.iter().filter(|l| l.verdict == v).count();
    let all: Vec<&RunLine> = lines.iter().collect();
    let mut x = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"litesim\" tests=\"{}\" failures=\"{}\" errors=\"{}\">\n",
        lines.len(),
        count(&all, Verdict::Fail),
        count(&all, Verdict::Error),
    );
    for (test, mut runs) in by {
        runs.sort_by_key(|l| l.seed);
        x += &format!(
            "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{}\" errors=\"{}\" skipped=\"{}\">\n",
            esc(test),
            runs.len(),
            count(&runs, Verdict::Fail),
            count(&runs, Verdict::Error),
            count(&runs, Verdict::Invalid),
        );
        for l in runs {
            // Simulated time, not wall time: the file is the same on every machine.
            x += &format!(
                "    <testcase name=\"seed {}\" classname=\"{}\" time=\"{}\"",
                l.seed,
                esc(test),
                l.duration
            );
            // fail → <failure>, error → <error>, invalid → <skipped>: the
            // scenario did not happen, so nothing was tested.
            let (tag, kind, reasons) = match l.verdict {
                Verdict::Pass => {
                    x += "/>\n";
                    continue;
                }
                Verdict::Fail => ("failure", "litesim.failure", &l.failures),
                Verdict::Error => ("error", "litesim.error", &l.failures),
                Verdict::Invalid => ("skipped", "litesim.invalid", &l.invalid),
            };
            let first = reasons.first().map_or(l.verdict.name(), String::as_str);
            if tag == "skipped" {
                x += &format!(
                    ">\n      <skipped message=\"{}\">{}</skipped>\n    </testcase>\n",
                    esc(first),
                    esc(&reasons.join("\n"))
                );
            } else {
                x += &format!(
                    ">\n      <{tag} message=\"{}\" type=\"{kind}\">{}</{tag}>\n    </testcase>\n",
                    esc(first),
                    esc(&reasons.join("\n"))
                );
            }
        }
        x += "  </testsuite>\n";
    }
    x + "</testsuites>\n"
}

/// Writes `results.jsonl` and `results.csv` sorted by (test, seed) and
/// `coverage.json` (when there are items) from `lines`; the last line
/// given for a (test, seed) wins.
pub fn write_sorted(
    dir: &Path,
    lines: &[RunLine],
    defs: &[(String, crate::coverage::ItemDef)],
) -> Result<(), ScenarioError> {
    // One line per (test, seed), the last one given winning: the results
    // and the coverage are both made from these.
    let mut by: BTreeMap<(String, u64), &RunLine> = BTreeMap::new();
    for l in lines {
        by.insert((l.test.clone(), l.seed), l);
    }
    let mut w = Sorted::new(dir, defs)?;
    for l in by.values() {
        let text =
            serde_json::to_string(l).map_err(|e| ScenarioError::format("a result line", e))?;
        w.add(l, &text)?;
    }
    w.finish()
}

/// The sorted result files being written, one line at a time: the JSON
/// line, its CSV row, its coverage folded in, the verdicts counted.
struct Sorted<'d> {
    dir: &'d Path,
    jsonl: TempFile,
    csv: TempFile,
    fold: Option<crate::coverage::Fold>,
    /// (passed, failed, invalid, errors, most severe verdict).
    counts: (u64, u64, u64, u64, crate::Verdict),
}

/// A file written line by line and put in place when done
/// ([`litesim_log::AtomicFile`]): the sorted results, and [`atomic`] for a
/// file made in one piece.
struct TempFile {
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    file: litesim_log::AtomicFile,
}

impl TempFile {
    fn new(path: PathBuf) -> Result<Self, ScenarioError> {
        let mut file = litesim_log::AtomicFile::create(&path)?;
        let f = file
            .file()
            .try_clone()
            .map_err(|e| ScenarioError::write(&path, e))?;
        Ok(TempFile {
            path,
            out: std::io::BufWriter::new(f),
            file,
        })
    }

    fn write(&mut self, text: &str) -> Result<(), ScenarioError> {
        self.out
            .write_all(text.as_bytes())
            .map_err(|e| ScenarioError::write(&self.path, e))
    }

    fn finish(self) -> Result<(), ScenarioError> {
        let path = self.path;
        self.out
            .into_inner()
            .map_err(|e| ScenarioError::write(&path, e.into_error()))?;
        Ok(self.file.commit()?)
    }
}

impl<'d> Sorted<'d> {
    fn new(
        dir: &'d Path,
        defs: &[(String, crate::coverage::ItemDef)],
    ) -> Result<Self, ScenarioError> {
        let fold = (!defs.is_empty()).then(|| {
            let mut f = crate::coverage::Fold::default();
            for (t, d) in defs {
                f.declare(t, d);
            }
            f
        });
        let mut csv = TempFile::new(dir.join("results.csv"))?;
        csv.write(
            "test,seed,verdict,pass,collisions,min_distance,min_ttc,max_path_error,duration,steps,roads,failures,invalid\n",
        )?;
        Ok(Sorted {
            dir,
            jsonl: TempFile::new(dir.join("results.jsonl"))?,
            csv,
            fold,
            counts: (0, 0, 0, 0, crate::Verdict::Pass),
        })
    }

    /// The next line in (test, seed) order; `text` is its JSON.
    fn add(&mut self, l: &RunLine, text: &str) -> Result<(), ScenarioError> {
        self.jsonl.write(text)?;
        self.jsonl.write("\n")?;
        let q = |s: &str| format!("\"{}\"", s.replace('"', "\"\""));
        self.csv.write(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            q(&l.test),
            l.seed,
            l.verdict.name(),
            l.pass,
            l.collisions,
            l.min_distance,
            l.min_ttc.map_or(String::new(), |v| v.to_string()),
            l.max_path_error,
            l.duration,
            l.steps,
            q(&l.roads),
            q(&l.failures.join("; ")),
            q(&l.invalid.join("; "))
        ))?;
        // A run whose scenario did not happen covers nothing.
        if let Some(f) = self.fold.as_mut()
            && l.verdict != crate::Verdict::Invalid
        {
            f.add(&l.test, &l.coverage);
        }
        let c = &mut self.counts;
        if l.pass {
            c.0 += 1;
        } else {
            c.1 += 1;
        }
        c.2 += u64::from(l.verdict == crate::Verdict::Invalid);
        c.3 += u64::from(l.verdict == crate::Verdict::Error);
        c.4 = c.4.max(l.verdict);
        Ok(())
    }

    /// Closes the files; gives the counts.
    fn finish_counts(self) -> Result<(u64, u64, u64, u64, crate::Verdict), ScenarioError> {
        if let Some(f) = self.fold {
            let text = serde_json::to_string_pretty(&f.finish())
                .map_err(|e| ScenarioError::format("coverage.json", e))?;
            atomic(&self.dir.join("coverage.json"), &(text + "\n"))?;
        }
        self.jsonl.finish()?;
        self.csv.finish()?;
        Ok(self.counts)
    }

    fn finish(self) -> Result<(), ScenarioError> {
        self.finish_counts().map(|_| ())
    }
}

/// A result line's job, read without the rest of the line.
#[derive(Deserialize)]
struct Key {
    test: String,
    seed: u64,
}

/// Sorts the results file of a batch in place, streaming: only each
/// line's (test, seed) and place in the file are held, not the lines, so
/// a batch's memory does not grow with its runs. The last line of a
/// (test, seed) wins; lines of jobs not `wanted` (test index, seed) are
/// dropped. Gives the verdict counts.
fn sort_results_file(
    dir: &Path,
    tests: &[String],
    wanted: impl Fn(usize, u64) -> bool,
    defs: &[(String, crate::coverage::ItemDef)],
) -> Result<(u64, u64, u64, u64, crate::Verdict), ScenarioError> {
    use std::io::{BufRead, Read, Seek};
    let path = dir.join("results.jsonl");
    let io = |source: std::io::Error| ReadError::Io {
        path: path.clone(),
        source,
    };
    let mut places: BTreeMap<(usize, u64), (u64, usize)> = BTreeMap::new();
    {
        let mut r = std::io::BufReader::new(open_regular(&path)?);
        let (mut at, mut buf) = (0u64, String::new());
        loop {
            buf.clear();
            let n = r.read_line(&mut buf).map_err(io)?;
            if n == 0 {
                break;
            }
            // A run interrupted mid-write leaves a partial last line:
            // what does not parse is skipped.
            if let Ok(k) = serde_json::from_str::<Key>(buf.trim_end())
                && let Some(ti) = tests.iter().position(|t| *t == k.test)
                && wanted(ti, k.seed)
            {
                places.insert((ti, k.seed), (at, n));
            }
            at += n as u64;
        }
    }
    let mut f = open_regular(&path)?;
    let mut w = Sorted::new(dir, defs)?;
    // (test, seed) order is the tests' names' order, then seeds.
    let mut order: Vec<usize> = (0..tests.len()).collect();
    order.sort_by(|a, b| tests[*a].cmp(&tests[*b]));
    let mut line = Vec::new();
    for ti in order {
        for (_, &(at, n)) in places.range((ti, 0)..=(ti, u64::MAX)) {
            line.resize(n, 0);
            f.seek(std::io::SeekFrom::Start(at)).map_err(io)?;
            f.read_exact(&mut line).map_err(io)?;
            let text = String::from_utf8_lossy(&line);
            let text = text.trim_end();
            let l: RunLine =
                serde_json::from_str(text).map_err(|e| ScenarioError::format(path.display(), e))?;
            w.add(&l, text)?;
        }
    }
    w.finish_counts()
}

/// The (test, seed) of each readable line of a results file, in file
/// order (what a resumed batch has done already).
fn read_keys(path: &Path) -> Vec<(String, u64)> {
    use std::io::BufRead;
    let Ok(f) = open_regular(path) else {
        return Vec::new();
    };
    std::io::BufReader::new(f)
        .lines()
        .map_while(Result::ok)
        .filter_map(|l| serde_json::from_str::<Key>(&l).ok())
        .map(|k| (k.test, k.seed))
        .collect()
}

/// Writes `text` to `path` atomically ([`litesim_log::AtomicFile`]): a
/// reader sees the old file or the new one, never a part.
pub fn atomic(path: &Path, text: &str) -> Result<(), ScenarioError> {
    let mut f = TempFile::new(path.to_path_buf())?;
    f.write(text)?;
    f.finish()
}

/// Removes temporary files a killed run left in `dir`: litesim's own
/// (`.tmpXXXX…` from every writer, [`litesim_log::AtomicFile`];
/// `.NAME.tmp` and `results.tmp` from older versions) and nothing else — every
/// writer renames its temporary into place, so one that is still there
/// belongs to a run that did not finish. A user's own files are left alone.
pub fn clean_temporaries(dir: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        let stale = (n.starts_with('.') && n.ends_with(".tmp"))
            || n.starts_with(".tmp")
            || n == "results.tmp";
        if stale && e.file_type().is_ok_and(|t| t.is_file()) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Runs a batch; `progress(done, total)` is called as runs finish.
pub fn run_batch(
    spec: &BatchSpec,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<BatchReport, ScenarioError> {
    check_spec(spec)?;
    let (si, sn) = spec.shard;
    std::fs::create_dir_all(&spec.out).map_err(|e| ScenarioError::write(&spec.out, e))?;
    let results = spec.out.join("results.jsonl");
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
    let base = RunOptions {
        mode: spec.mode,
        calibration_dir: spec.calibration_dir.clone(),
        calibration_near_test: true,
        sut: spec.sut.clone(),
        npc: spec.npc,
        sut_timeout: spec.sut_timeout,
        ..RunOptions::default()
    };
    let manifest = manifest_of(spec, &preps, &base);
    // This command's jobs, (test index, seed): a shard's share of every
    // test's seeds (the rule of `jobs_of`, decided without a list).
    let names: Vec<String> = preps.iter().map(|(n, _)| n.clone()).collect();
    let seeds = spec.seed_to - spec.seed_from + 1;
    let wanted = |ti: usize, seed: u64| {
        (spec.seed_from..=spec.seed_to).contains(&seed)
            && (ti as u64 * seeds + (seed - spec.seed_from)) % sn.max(1) == si
    };
    let (done, foreign) = resumed(spec, &manifest, &results, &names, &wanted)?;
    clean_temporaries(&spec.out);
    clean_temporaries(&spec.out.join("failed"));
    let manifest_hash = manifest.write(&spec.out)?;
    let jobs: Vec<(usize, u64)> = (0..names.len())
        .flat_map(|ti| (spec.seed_from..=spec.seed_to).map(move |seed| (ti, seed)))
        .filter(|&(ti, seed)| wanted(ti, seed) && !done.contains(&(ti, seed)))
        .collect();
    let total = jobs.len() as u64;
    let mut report = BatchReport {
        total: total + done.len() as u64,
        skipped: done.len() as u64,
        foreign,
        unreadable: preps.iter().filter(|(_, p)| p.is_err()).count() as u64,
        ..BatchReport::default()
    };
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&results)
        .map_err(|e| ScenarioError::write(&results, e))?;
    if !spec.resume {
        file.set_len(0)
            .map_err(|e| ScenarioError::write(&results, e))?;
    }
    let sink = Mutex::new((file, 0u64));
    // The map's lanes as MCAP content, sampled once per test, by the first
    // failed run that needs them (not again for every failed seed).
    let mcap_maps: Vec<std::sync::OnceLock<Option<litesim_mcap::McapMap>>> =
        preps.iter().map(|_| std::sync::OnceLock::new()).collect();
    let work = || {
        jobs.par_iter()
            .map(|(ti, seed)| {
                let (name, prep) = &preps[*ti];
                let line = match spec.precomputed.get(&(name.clone(), *seed)) {
                    Some(l) => l.clone(),
                    None => run_line(name, prep, *seed, &base),
                };
                if spec.save_failed
                    && !line.pass
                    && let Ok(p) = prep
                {
                    let mcap = spec.save_failed_mcap.then(|| {
                        mcap_maps[*ti]
                            .get_or_init(|| p.net.as_deref().map(litesim_mcap::McapMap::new))
                            .as_ref()
                    });
                    save_log(&spec.out, name, p, *seed, &base, &manifest_hash, mcap);
                }
                let text = serde_json::to_string(&line).unwrap_or_default();
                let mut g = sink.lock().unwrap_or_else(|e| e.into_inner());
                let _ = writeln!(g.0, "{text}");
                g.1 += 1;
                progress(g.1, total);
            })
            .count()
    };
    let new = match spec.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .map_err(ScenarioError::Threads)?
            .install(work),
        None => work(),
    };
    report.ran = new as u64;
    drop(sink);
    let defs = item_defs(
        preps
            .iter()
            .filter_map(|(n, p)| p.as_ref().ok().map(|p| (n.as_str(), p))),
    );
    let (passed, failed, invalid, errors, verdict) =
        sort_results_file(&spec.out, &names, wanted, &defs)?;
    report.passed = passed;
    report.failed = failed;
    report.invalid = invalid;
    report.errors = errors;
    report.verdict = verdict;
    Ok(report)
}

/// Refuses a shard that is not i/N and a seed range that is empty or too
/// long.
fn check_spec(spec: &BatchSpec) -> Result<(), ScenarioError> {
    let (si, sn) = spec.shard;
    if sn == 0 || si >= sn {
        return Err(ScenarioError::Batch(format!(
            "shard {si}/{sn}: expected i/N with 0 ≤ i < N"
        )));
    }
    if spec.seed_to < spec.seed_from {
        return Err(ScenarioError::Batch(format!(
            "seeds {}..{}: the range is empty",
            spec.seed_from, spec.seed_to
        )));
    }
    if spec.seed_to - spec.seed_from >= MAX_SEEDS {
        return Err(ScenarioError::Batch(format!(
            "seeds {}..{}: a batch takes at most {MAX_SEEDS} seeds",
            spec.seed_from, spec.seed_to
        )));
    }
    Ok(())
}

/// What the batch is: litesim's version, each test's hashes, the options,
/// the seeds and the shard (what `--resume` and `merge` compare).
fn manifest_of(
    spec: &BatchSpec,
    preps: &[(String, Result<Prepared, String>)],
    base: &RunOptions,
) -> Manifest {
    let (si, sn) = spec.shard;
    Manifest {
        litesim: env!("CARGO_PKG_VERSION").to_string(),
        tests: preps
            .iter()
            .map(|(name, p)| ManifestTest {
                path: name.clone(),
                sources: p.as_ref().ok().map(|p| p.source_hash.clone()),
                map: p
                    .as_ref()
                    .ok()
                    .and_then(|p| p.map_text.as_ref())
                    .map(|t| crate::sha256_hex(t.as_bytes())),
                profile: p.as_ref().ok().map(|p| crate::profile_of(p, base)),
                calibration: p.as_ref().ok().map(|p| crate::calibration_used(p, base)),
            })
            .collect(),
        mode: match spec.mode {
            Some(DriveMode::Kinematic) => "kinematic",
            Some(DriveMode::Dynamic) => "dynamic",
            None => "as configured",
        }
        .into(),
        sut: spec.sut.name(),
        npc: spec.npc.name().into(),
        sut_timeout: spec.sut_timeout,
        seeds: format!("{}..{}", spec.seed_from, spec.seed_to),
        shard: format!("{si}/{sn}"),
    }
}

/// The jobs a resumed batch has done already (only this command's: the
/// newest line of a job wins) and how many lines belong to other shards;
/// refuses a folder that holds results but no or another manifest, and
/// one with results when neither `--resume` nor `--force-new` is given.
fn resumed(
    spec: &BatchSpec,
    manifest: &Manifest,
    results: &Path,
    names: &[String],
    wanted: &dyn Fn(usize, u64) -> bool,
) -> Result<(std::collections::BTreeSet<(usize, u64)>, u64), ScenarioError> {
    let mut foreign = 0u64;
    if !spec.resume && !spec.force_new && std::fs::metadata(results).is_ok_and(|m| m.len() > 0) {
        return Err(ScenarioError::Batch(format!(
            "{} already holds results: --resume to continue that batch, --force-new to start over, or a new folder",
            spec.out.display()
        )));
    }
    let done = if spec.resume {
        match Manifest::read(&spec.out)? {
            Some(old) => {
                let diffs = manifest.differences(&old, true);
                if !diffs.is_empty() {
                    return Err(ScenarioError::Batch(format!(
                        "{}: --resume refused, the folder holds results of another batch ({}); --force-new to start over, or use a new folder",
                        spec.out.display(),
                        diffs.join("; ")
                    )));
                }
            }
            None if results.exists() => {
                return Err(ScenarioError::Batch(format!(
                    "{}: --resume refused, the folder has results but no manifest.json (not written by this litesim); --force-new to start over, or use a new folder",
                    spec.out.display()
                )));
            }
            None => {}
        }
        // Only this command's jobs are kept (the others are dropped when
        // the file is sorted at the end); the newest line of a job wins.
        let mut done = std::collections::BTreeSet::new();
        for (test, seed) in read_keys(results) {
            match names.iter().position(|n| *n == test) {
                Some(ti) if wanted(ti, seed) => {
                    done.insert((ti, seed));
                }
                _ => foreign += 1,
            }
        }
        done
    } else {
        std::collections::BTreeSet::new()
    };
    Ok((done, foreign))
}

/// Runs a failed job again with a recorder and writes its log (best effort:
/// a batch does not stop because a debugging aid could not be written).
fn save_log(
    out: &Path,
    name: &str,
    prep: &Prepared,
    seed: u64,
    base: &RunOptions,
    manifest_hash: &str,
    // `Some` to write an MCAP file too, with the test's map content.
    mcap: Option<Option<&litesim_mcap::McapMap>>,
) {
    let opts = RunOptions {
        seed: Some(seed),
        record: true,
        ..base.clone()
    };
    if let Ok(r) = crate::run(prep, &mut crate::in_process(), &opts)
        && let Some(mut log) = r.log
    {
        // The log names its run: test, seed and the folder's manifest.
        log.meta.insert("test".into(), name.to_string());
        log.meta.insert("seed".into(), seed.to_string());
        log.meta
            .insert("manifest".into(), manifest_hash.to_string());
        let stem = Path::new(name)
            .file_stem()
            .map_or("test".into(), |s| s.to_string_lossy().into_owned());
        let dir = out.join("failed");
        if std::fs::create_dir_all(&dir).is_ok() {
            let _ = log.write_json(&dir.join(format!("{stem}-seed{seed}.json")));
            if let Some(map) = mcap {
                let path = dir.join(format!("{stem}-seed{seed}.mcap"));
                let _ = litesim_mcap::write_with(&log, map, &path);
            }
        }
    }
}

/// What [`merge`] wrote.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MergeReport {
    /// Runs written.
    pub runs: usize,
    /// Shards missing (`i/N`), when allowed.
    pub missing_shards: Vec<String>,
    /// Jobs of the present shards without a result, when allowed.
    pub missing_jobs: Vec<(String, u64)>,
}

/// Merges shard folders into `out` (sorted JSON lines, CSV, and a manifest
/// whose shard is `0/1`: all of them). The folders must come from one batch: manifests
/// equal but for the shard. Two different results for one run are an
/// error listing them; missing shards or runs are an error listing them
/// unless `allow_partial`, which still reports them.
pub fn merge(
    dirs: &[PathBuf],
    out: &Path,
    allow_partial: bool,
) -> Result<MergeReport, ScenarioError> {
    let mut first: Option<(PathBuf, Manifest)> = None;
    let mut shards: BTreeMap<u64, PathBuf> = BTreeMap::new();
    let mut expected: Vec<(String, u64)> = Vec::new();
    let mut by: BTreeMap<(String, u64), (RunLine, PathBuf)> = BTreeMap::new();
    let mut conflicts = Vec::new();
    let mut defs: Vec<(String, crate::coverage::ItemDef)> = Vec::new();
    for d in dirs {
        for def in read_defs(d)? {
            if !defs
                .iter()
                .any(|(t, x)| *t == def.0 && x.name == def.1.name)
            {
                defs.push(def);
            }
        }
        let p = d.join("results.jsonl");
        let (m, si) = shard_of(d, &p, first.as_ref())?;
        if first.is_none() {
            first = Some((d.clone(), m.clone()));
        }
        // The same shard twice (run again elsewhere) is fine as long as
        // its results agree: rows are compared below.
        if shards.insert(si, d.clone()).is_none() {
            expected.extend(m.jobs());
        }
        for l in read_lines(&p) {
            let key = (l.test.clone(), l.seed);
            match by.get(&key) {
                Some((old, from)) if *old != l => conflicts.push(format!(
                    "{} seed {}: {} and {} differ",
                    key.0,
                    key.1,
                    from.display(),
                    d.display()
                )),
                _ => {
                    by.insert(key, (l, d.clone()));
                }
            }
        }
    }
    if !conflicts.is_empty() {
        conflicts.sort();
        conflicts.dedup();
        return Err(ScenarioError::Batch(format!(
            "{} run(s) have conflicting results: {}",
            conflicts.len(),
            conflicts.join("; ")
        )));
    }
    let Some((_, m0)) = first else {
        return Err(ScenarioError::Batch("merge: no folders given".into()));
    };
    let n = m0.shard_pair().map_or(1, |x| x.1);
    let mut report = MergeReport {
        missing_shards: (0..n)
            .filter(|i| !shards.contains_key(i))
            .map(|i| format!("{i}/{n}"))
            .collect(),
        missing_jobs: expected
            .into_iter()
            .filter(|k| !by.contains_key(k))
            .collect(),
        ..MergeReport::default()
    };
    if !allow_partial && (!report.missing_shards.is_empty() || !report.missing_jobs.is_empty()) {
        let jobs: Vec<String> = report
            .missing_jobs
            .iter()
            .take(20)
            .map(|(t, s)| format!("{t} seed {s}"))
            .collect();
        return Err(ScenarioError::Batch(format!(
            "incomplete: missing shard(s) [{}], {} run(s) without a result{}{}; pass --allow-partial to merge what is there",
            report.missing_shards.join(", "),
            report.missing_jobs.len(),
            if jobs.is_empty() { "" } else { ": " },
            jobs.join(", ")
        )));
    }
    std::fs::create_dir_all(out).map_err(|e| ScenarioError::write(out, e))?;
    let all: Vec<RunLine> = by.into_values().map(|(l, _)| l).collect();
    let merged = Manifest {
        shard: "0/1".into(),
        ..m0
    };
    merged.write(out)?;
    write_sorted(out, &all, &defs)?;
    report.runs = all.len();
    Ok(report)
}

/// A shard folder's manifest and shard index, checked against the first
/// folder's (`first`): same batch, same seeds, same shard count.
fn shard_of(
    d: &Path,
    p: &Path,
    first: Option<&(PathBuf, Manifest)>,
) -> Result<(Manifest, u64), ScenarioError> {
    if !p.exists() {
        return Err(ScenarioError::Batch(format!(
            "{}: no results.jsonl",
            d.display()
        )));
    }
    let m = Manifest::read(d)?.ok_or_else(|| {
        ScenarioError::Batch(format!(
            "{}: no manifest.json (not a folder written by litesim batch)",
            d.display()
        ))
    })?;
    let (si, sn) = m.shard_pair().ok_or_else(|| {
        ScenarioError::Batch(format!(
            "{}: manifest shard '{}' is not i/N",
            d.display(),
            m.shard
        ))
    })?;
    if let Some((d0, m0)) = first {
        let mut diffs = m.differences(m0, false);
        if m.seeds != m0.seeds {
            diffs.push(format!("seeds: {} there, {} here", m0.seeds, m.seeds));
        }
        if m0.shard_pair().map(|x| x.1) != Some(sn) {
            diffs.push(format!("shard count: {} there, {} here", m0.shard, m.shard));
        }
        if !diffs.is_empty() {
            return Err(ScenarioError::Batch(format!(
                "{} and {} come from different batches: {}",
                d0.display(),
                d.display(),
                diffs.join("; ")
            )));
        }
    }
    Ok((m, si))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cleaning_removes_litesims_temporaries_only() {
        let d = tempfile::tempdir().unwrap();
        let names = [
            ".summary.json.tmp",
            ".tmpAb12Cd.gif",
            "results.tmp",
            "notes.tmp",
            "mine.tmp.txt",
            "summary.json",
        ];
        for n in names {
            std::fs::write(d.path().join(n), "x").unwrap();
        }
        clean_temporaries(d.path());
        let mut left: Vec<String> = std::fs::read_dir(d.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["mine.tmp.txt", "notes.tmp", "summary.json"]);
        // An atomic write leaves only its target.
        atomic(&d.path().join("a.json"), "{}").unwrap();
        assert!(!d.path().join(".a.json.tmp").exists());
        assert_eq!(
            std::fs::read_to_string(d.path().join("a.json")).unwrap(),
            "{}"
        );
    }
}
