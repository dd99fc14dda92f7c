//! One run's line of `results.jsonl`, and what is read back from a
//! results folder: the lines, the coverage items, the JUnit report.

use super::*;

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
