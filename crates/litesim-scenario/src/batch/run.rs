//! Running a batch: the specification, the jobs over rayon's threads,
//! `--resume`, each run's log.

use super::*;

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
    /// The simulation step (ms), overriding each test's and profile's
    /// (see [`RunOptions::step_ms`]).
    pub step_ms: Option<u32>,
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

/// Runs a batch; `progress(done, total)` is called as runs finish.
pub fn run_batch(
    spec: &BatchSpec,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<BatchReport, ScenarioError> {
    check_spec(spec)?;
    let (si, sn) = spec.shard;
    std::fs::create_dir_all(&spec.out).map_err(|e| ScenarioError::write(&spec.out, e))?;
    let results = spec.out.join("results.jsonl");
    // Each test is parsed and its map loaded once; an OpenSCENARIO XML
    // parameter distribution is one test per variation (`FILE#k`).
    let preps: Vec<(String, Result<Prepared, String>)> = spec
        .tests
        .iter()
        .flat_map(|t| variations(t, &spec.load))
        .map(|(name, path, load)| (name, crate::prepare(&path, &load).map_err(|e| e.chain())))
        .collect();
    let base = RunOptions {
        mode: spec.mode,
        calibration_dir: spec.calibration_dir.clone(),
        calibration_near_test: true,
        sut: spec.sut.clone(),
        npc: spec.npc,
        sut_timeout: spec.sut_timeout,
        step_ms: spec.step_ms,
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

/// The tests a batch entry stands for: itself, or each variation of an
/// OpenSCENARIO XML `ParameterValueDistribution` (named `FILE#k`, its
/// scenario loaded with the variation's parameters). A distribution that
/// cannot be read is one test that fails to load.
fn variations(t: &Path, load: &LoadOptions) -> Vec<(String, PathBuf, LoadOptions)> {
    let name = t.display().to_string();
    if !(crate::load::is_xosc(t) && litesim_xosc::is_distribution(t)) {
        return vec![(name, t.to_path_buf(), load.clone())];
    }
    match litesim_xosc::read_distribution(t) {
        Ok(d) => d
            .variations
            .into_iter()
            .enumerate()
            .map(|(k, v)| {
                let mut l = load.clone();
                l.params.extend(v);
                (format!("{name}#{}", k + 1), d.scenario.clone(), l)
            })
            .collect(),
        // Read again by `prepare`, which reports the error.
        Err(_) => vec![(name, t.to_path_buf(), load.clone())],
    }
}

/// Refuses a shard that is not i/N and a seed range that is empty or too
/// long.
pub(super) fn check_spec(spec: &BatchSpec) -> Result<(), ScenarioError> {
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
pub(super) fn manifest_of(
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
        step_ms: spec.step_ms,
        seeds: format!("{}..{}", spec.seed_from, spec.seed_to),
        shard: format!("{si}/{sn}"),
    }
}

/// The jobs a resumed batch has done already (only this command's: the
/// newest line of a job wins) and how many lines belong to other shards;
/// refuses a folder that holds results but no or another manifest, and
/// one with results when neither `--resume` nor `--force-new` is given.
pub(super) fn resumed(
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
pub(super) fn save_log(
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
