//! Writing results in (test, seed) order: the sorted rewrite of
//! `results.jsonl` with its CSV table, atomic writes, and the clean-up of
//! temporaries a killed run left.

use super::*;

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
pub(super) struct Sorted<'d> {
    pub(super) dir: &'d Path,
    pub(super) jsonl: TempFile,
    pub(super) csv: TempFile,
    pub(super) fold: Option<crate::coverage::Fold>,
    /// (passed, failed, invalid, errors, most severe verdict).
    pub(super) counts: (u64, u64, u64, u64, crate::Verdict),
}

/// A file written line by line and put in place when done
/// ([`litesim_log::AtomicFile`]): the sorted results, and [`atomic`] for a
/// file made in one piece.
pub(super) struct TempFile {
    pub(super) path: PathBuf,
    pub(super) out: std::io::BufWriter<std::fs::File>,
    pub(super) file: litesim_log::AtomicFile,
}

impl TempFile {
    pub(super) fn new(path: PathBuf) -> Result<Self, ScenarioError> {
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

    pub(super) fn write(&mut self, text: &str) -> Result<(), ScenarioError> {
        self.out
            .write_all(text.as_bytes())
            .map_err(|e| ScenarioError::write(&self.path, e))
    }

    pub(super) fn finish(self) -> Result<(), ScenarioError> {
        let path = self.path;
        self.out
            .into_inner()
            .map_err(|e| ScenarioError::write(&path, e.into_error()))?;
        Ok(self.file.commit()?)
    }
}

impl<'d> Sorted<'d> {
    pub(super) fn new(
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
    pub(super) fn add(&mut self, l: &RunLine, text: &str) -> Result<(), ScenarioError> {
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
    pub(super) fn finish_counts(
        self,
    ) -> Result<(u64, u64, u64, u64, crate::Verdict), ScenarioError> {
        if let Some(f) = self.fold {
            let text = serde_json::to_string_pretty(&f.finish())
                .map_err(|e| ScenarioError::format("coverage.json", e))?;
            atomic(&self.dir.join("coverage.json"), &(text + "\n"))?;
        }
        self.jsonl.finish()?;
        self.csv.finish()?;
        Ok(self.counts)
    }

    pub(super) fn finish(self) -> Result<(), ScenarioError> {
        self.finish_counts().map(|_| ())
    }
}

/// A result line's job, read without the rest of the line.
#[derive(Deserialize)]
pub(super) struct Key {
    pub(super) test: String,
    pub(super) seed: u64,
}

/// Sorts the results file of a batch in place, streaming: only each
/// line's (test, seed) and place in the file are held, not the lines, so
/// a batch's memory does not grow with its runs. The last line of a
/// (test, seed) wins; lines of jobs not `wanted` (test index, seed) are
/// dropped. Gives the verdict counts.
pub(super) fn sort_results_file(
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
pub(super) fn read_keys(path: &Path) -> Vec<(String, u64)> {
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
