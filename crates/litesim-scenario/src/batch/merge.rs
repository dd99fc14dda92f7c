//! Joining the folders of a sharded batch.

use super::*;

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
pub(super) fn shard_of(
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
