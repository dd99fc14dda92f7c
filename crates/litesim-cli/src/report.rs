//! `litesim report OUT_DIR`: one self-contained HTML file over a batch
//! folder (built-in batch or merged shards) — the runs table (filter,
//! sort), failure reasons grouped, coverage per item with its holes, the
//! cross-coverage of two items, KPI histograms and links from failed runs
//! to their replay pictures. No network: styles, script and charts (SVG)
//! are inline.

use anyhow::{Context, Result, bail};
use litesim_scenario::batch::RunLine;
use litesim_scenario::coverage::{CoverageFile, SampleValue, bucket_of, buckets};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// Rows the table shows at once (the filter and sort run on all rows).
pub const TABLE_PAGE: usize = 1000;
/// Replay pictures rendered for failed runs that have a saved log but no
/// picture yet.
pub const MAX_PICTURES: usize = 200;

/// What the report read.
pub struct Read {
    /// Runs, in file order.
    pub runs: Vec<RunLine>,
    /// Lines that were not results: (line number, why).
    pub bad: Vec<(usize, String)>,
    /// The coverage file, if any (and why it could not be read).
    pub coverage: Option<CoverageFile>,
    /// Problems with the coverage file.
    pub coverage_error: Option<String>,
}

/// Reads a batch folder; `progress(bytes_read, bytes_total)`.
pub fn read(dir: &Path, progress: &dyn Fn(u64, u64)) -> Result<Read> {
    let p = dir.join("results.jsonl");
    if !dir.is_dir() {
        bail!("{}: not a folder", dir.display());
    }
    let f = litesim_core::files::open_regular(&p)
        .with_context(|| format!("{}: no results.jsonl (not a batch folder?)", dir.display()))?;
    let total = f.metadata().map_or(0, |m| m.len());
    let mut r = std::io::BufReader::with_capacity(1 << 20, f);
    let (mut runs, mut bad) = (Vec::new(), Vec::new());
    let (mut line, mut n, mut done) = (Vec::new(), 0usize, 0u64);
    loop {
        line.clear();
        let k = r.read_until(b'\n', &mut line)?;
        if k == 0 {
            break;
        }
        n += 1;
        done += k as u64;
        if n.is_multiple_of(4096) {
            progress(done, total);
        }
        let text = String::from_utf8_lossy(&line);
        let text = text.trim();
        if text.is_empty() {
            continue;
        }
        match serde_json::from_str::<RunLine>(text) {
            Ok(l) => runs.push(l),
            Err(e) => bad.push((n, e.to_string())),
        }
    }
    progress(total, total);
    let (coverage, coverage_error) = match crate::read_text(&dir.join("coverage.json")) {
        Err(_) => (None, None),
        Ok(t) => match serde_json::from_str::<CoverageFile>(&t) {
            Ok(c) => (Some(c), None),
            Err(e) => (None, Some(format!("coverage.json: {e}"))),
        },
    };
    Ok(Read {
        runs,
        bad,
        coverage,
        coverage_error,
    })
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A failure reason with its numbers taken out, so that alike reasons group.
fn reason_kind(f: &str) -> String {
    let mut out = String::new();
    let mut in_num = false;
    for c in f.chars() {
        if c.is_ascii_digit() || (in_num && c == '.') {
            if !in_num {
                out.push('#');
            }
            in_num = true;
        } else {
            in_num = false;
            out.push(c);
        }
    }
    out
}

/// A histogram as an SVG bar chart.
fn histogram(title: &str, unit: &str, values: &[f64]) -> String {
    let mut s = format!("<div class=\"chart kpi\"><h4>{}</h4>", esc(title));
    if values.is_empty() {
        return s + "<p class=\"none\">no values</p></div>";
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let bins = 20usize;
    let w = if hi > lo {
        (hi - lo) / bins as f64
    } else {
        1.0
    };
    let mut counts = vec![0u64; bins];
    for v in values {
        let k = (((v - lo) / w) as usize).min(bins - 1);
        counts[k] += 1;
    }
    let max = counts.iter().copied().max().unwrap_or(1).max(1) as f64;
    let _ = write!(
        s,
        "<svg viewBox=\"0 0 420 150\" width=\"420\" height=\"150\">"
    );
    for (k, c) in counts.iter().enumerate() {
        let h = 110.0 * *c as f64 / max;
        let _ = write!(
            s,
            "<rect class=\"bin\" x=\"{}\" y=\"{:.1}\" width=\"18\" height=\"{:.1}\"><title>{:.3}..{:.3} {}: {}</title></rect>",
            10 + k * 20,
            120.0 - h,
            h,
            lo + w * k as f64,
            lo + w * (k + 1) as f64,
            esc(unit),
            c
        );
    }
    let _ = write!(
        s,
        "<text x=\"10\" y=\"140\">{lo:.2}</text><text x=\"410\" y=\"140\" text-anchor=\"end\">{hi:.2} {}</text></svg>",
        esc(unit)
    );
    s + &format!("<p>{} runs</p></div>", values.len())
}

/// The bucket index of a run's sample of an item (for cross coverage).
fn bucket_index(def: &litesim_scenario::coverage::ItemDef, v: &SampleValue) -> Option<usize> {
    match v {
        SampleValue::Word(w) => def.values.iter().position(|x| x == w),
        SampleValue::Num(x) => bucket_of(*x, buckets(def)?),
    }
}

/// Writes the report of `dir` to `out` (default `dir/report.html`).
pub fn write(dir: &Path, out: Option<PathBuf>, quiet: bool) -> Result<PathBuf> {
    let bar = indicatif::ProgressBar::new(0);
    if quiet {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(
        indicatif::ProgressStyle::with_template("reading {bar:40} {bytes}/{total_bytes}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let r = read(dir, &|done, total| {
        bar.set_length(total);
        bar.set_position(done);
    })?;
    bar.finish_and_clear();
    for (n, why) in r.bad.iter().take(20) {
        eprintln!("{}/results.jsonl line {n}: skipped ({why})", dir.display());
    }
    if r.bad.len() > 20 {
        eprintln!("… and {} more lines skipped", r.bad.len() - 20);
    }
    let pictures = pictures(dir, &r.runs);
    let html = render(dir, &r, &pictures);
    let path = out.unwrap_or_else(|| dir.join("report.html"));
    litesim_scenario::batch::atomic(&path, &html)?;
    Ok(path)
}

/// For failed runs with a saved log (`failed/STEM-seedN.json`): the replay
/// picture beside it (rendered now when missing, up to [`MAX_PICTURES`]),
/// else the log; by (test, seed), as links relative to the folder.
fn pictures(dir: &Path, runs: &[RunLine]) -> BTreeMap<(String, u64), String> {
    let mut out = BTreeMap::new();
    let mut rendered = 0;
    // The map drawn under the actors, when the test can still be read.
    let mut maps: BTreeMap<String, litesim_viz::replay::Background> = BTreeMap::new();
    let style = litesim_viz::Style::default();
    for l in runs.iter().filter(|l| !l.pass) {
        let stem = Path::new(&l.test)
            .file_stem()
            .map_or("test".into(), |s| s.to_string_lossy().into_owned());
        let json = dir
            .join("failed")
            .join(format!("{stem}-seed{}.json", l.seed));
        let png = json.with_extension("png");
        if !png.exists() && json.exists() && rendered < MAX_PICTURES {
            rendered += 1;
            if let Ok(log) = litesim_log::SimulationLog::read_json(&json) {
                let bg = maps.entry(l.test.clone()).or_insert_with(|| {
                    litesim_scenario::prepare(Path::new(&l.test), &Default::default())
                        .ok()
                        .and_then(|p| p.net.map(|n| crate::viz::background(&n, false)))
                        .unwrap_or_default()
                });
                let _ = litesim_viz::replay::write_png(&log, bg, &style, &png);
            }
        }
        let link = if png.exists() {
            format!("failed/{stem}-seed{}.png", l.seed)
        } else if json.exists() {
            format!("failed/{stem}-seed{}.json", l.seed)
        } else {
            continue;
        };
        out.insert((l.test.clone(), l.seed), link);
    }
    out
}

/// Reasons grouped by their kind (numbers masked), most frequent first,
/// each with an example: a table with the id `id`, empty without reasons.
fn reasons_table<'a>(id: &str, reasons: impl Iterator<Item = &'a String>) -> String {
    let mut by: BTreeMap<String, (u64, String)> = BTreeMap::new();
    for f in reasons {
        let e = by.entry(reason_kind(f)).or_insert((0, f.clone()));
        e.0 += 1;
    }
    if by.is_empty() {
        return String::new();
    }
    let mut v: Vec<(&String, &(u64, String))> = by.iter().collect();
    v.sort_by(|a, b| b.1.0.cmp(&a.1.0).then(a.0.cmp(b.0)));
    let mut h = format!(
        "<table id=\"{id}\"><tr><th>runs</th><th>reason (numbers vary)</th><th>example</th></tr>"
    );
    for (k, (n, ex)) in v.iter().take(100) {
        let _ = write!(
            h,
            "<tr><td>{n}</td><td>{}</td><td>{}</td></tr>",
            esc(k),
            esc(ex)
        );
    }
    h + "</table>"
}

/// The runs whose scenario was not realised: how many, their reasons
/// grouped, and which runs (a section of their own: they say nothing of the
/// SUT).
fn invalid_section(invalid: &[&RunLine]) -> String {
    if invalid.is_empty() {
        return String::new();
    }
    let mut h = format!(
        "<h2>Invalid runs: the scenario was not realised ({})</h2>",
        invalid.len()
    );
    h += &reasons_table("invalid", invalid.iter().flat_map(|l| &l.invalid));
    h += "<p class=\"where\">Runs: ";
    let names: Vec<String> = invalid
        .iter()
        .take(200)
        .map(|l| format!("{} seed {}", esc(&l.test), l.seed))
        .collect();
    h += &names.join(", ");
    if invalid.len() > 200 {
        let _ = write!(h, " … {} more", invalid.len() - 200);
    }
    h + "</p>"
}

/// The HTML text.
pub fn render(dir: &Path, r: &Read, pictures: &BTreeMap<(String, u64), String>) -> String {
    let runs = &r.runs;
    let passed = runs.iter().filter(|l| l.pass).count();
    let invalid: Vec<&RunLine> = runs
        .iter()
        .filter(|l| l.verdict == litesim_scenario::Verdict::Invalid)
        .collect();
    let mut h = String::with_capacity(256 + runs.len() * 160);
    h += "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>litesim report</title><style>";
    h += STYLE;
    h += "</style></head><body>";
    let _ = write!(
        h,
        "<h1>litesim report</h1><p class=\"where\">{}</p>",
        esc(&dir.display().to_string())
    );
    if runs.is_empty() {
        h += "<p id=\"empty\" class=\"empty\">This batch has no runs: nothing to report.</p>";
    } else {
        let _ = write!(
            h,
            "<p id=\"totals\"><b>{}</b> runs: <span class=\"pass\">{passed} passed</span>, <span class=\"fail\">{} failed</span>, <span class=\"invalid\">{} invalid</span> (the scenario was not realised: not counted in coverage or KPIs)</p>",
            runs.len(),
            runs.len() - passed - invalid.len(),
            invalid.len()
        );
    }
    if !r.bad.is_empty() {
        h += "<div id=\"skipped\" class=\"warn\"><b>Lines skipped</b> (not results): <ul>";
        for (n, why) in r.bad.iter().take(50) {
            let _ = write!(h, "<li>results.jsonl line {n}: {}</li>", esc(why));
        }
        if r.bad.len() > 50 {
            let _ = write!(h, "<li>… {} more</li>", r.bad.len() - 50);
        }
        h += "</ul></div>";
    }
    if let Some(e) = &r.coverage_error {
        let _ = write!(h, "<div class=\"warn\">{}</div>", esc(e));
    }
    // Failure reasons, grouped.
    let failed = |l: &&RunLine| !l.pass && l.verdict != litesim_scenario::Verdict::Invalid;
    let table = reasons_table(
        "reasons",
        runs.iter().filter(failed).flat_map(|l| &l.failures),
    );
    if !table.is_empty() {
        h += "<h2>Failure reasons</h2>";
        h += &table;
    }
    h += &invalid_section(&invalid);
    // KPI histograms and crossed coverage: of the runs whose scenario
    // happened.
    let happened: Vec<RunLine> = runs
        .iter()
        .filter(|l| l.verdict != litesim_scenario::Verdict::Invalid)
        .cloned()
        .collect();
    if !happened.is_empty() {
        h += &kpi_charts(&happened);
    }
    // Coverage.
    if let Some(c) = &r.coverage {
        h += &coverage_section(c, &happened);
    }
    // The runs table: data as JSON, rows drawn by the script.
    h += "<h2>Runs</h2><div class=\"controls\"><label>show <select id=\"show\"><option value=\"all\">all</option><option value=\"pass\">passed</option><option value=\"fail\">failed</option><option value=\"invalid\">invalid</option></select></label> <label>filter <input id=\"filter\" placeholder=\"text in test or reason\"></label> <span id=\"count\"></span></div>";
    h += "<table id=\"runs\"><thead><tr><th data-k=\"0\">test</th><th data-k=\"1\">seed</th><th data-k=\"2\">verdict</th><th data-k=\"3\">collisions</th><th data-k=\"4\">min gap (m)</th><th data-k=\"5\">min TTC (s)</th><th data-k=\"6\">max decel (m/s²)</th><th data-k=\"7\">failures</th><th>replay</th></tr></thead><tbody></tbody></table>";
    h += "<script id=\"data\" type=\"application/json\">[";
    for (k, l) in runs.iter().enumerate() {
        if k > 0 {
            h.push(',');
        }
        let row = serde_json::json!([
            l.test,
            l.seed,
            l.verdict.name(),
            l.collisions,
            l.min_distance,
            l.min_ttc,
            l.max_decel,
            if l.verdict == litesim_scenario::Verdict::Invalid {
                l.invalid.join("; ")
            } else {
                l.failures.join("; ")
            },
            pictures.get(&(l.test.clone(), l.seed)),
        ]);
        // `</` would end the script element.
        h += &row.to_string().replace("</", "<\\/");
    }
    let _ = write!(
        h,
        "]</script><script>const PAGE={TABLE_PAGE};{SCRIPT}</script></body></html>"
    );
    h
}

/// The KPI histograms of the runs whose scenario happened.
fn kpi_charts(happened: &[RunLine]) -> String {
    let mut h = String::new();
    h += "<h2>KPIs</h2><div class=\"charts\">";
    let ttc: Vec<f64> = happened.iter().filter_map(|l| l.min_ttc).collect();
    let gap: Vec<f64> = happened
        .iter()
        .map(|l| l.min_distance)
        .filter(|d| *d >= 0.0)
        .collect();
    let decel: Vec<f64> = happened.iter().filter_map(|l| l.max_decel).collect();
    h += &histogram("min time to collision", "s", &ttc);
    h += &histogram("min gap (box to box)", "m", &gap);
    h += &histogram("max deceleration of the ego", "m/s²", &decel);
    let thw: Vec<f64> = happened.iter().filter_map(|l| l.min_thw).collect();
    let drac: Vec<f64> = happened.iter().filter_map(|l| l.max_drac).collect();
    h += &histogram("min time headway of the ego", "s", &thw);
    h += &histogram("max DRAC of the ego", "m/s²", &drac);
    let pet: Vec<f64> = happened.iter().filter_map(|l| l.min_pet).collect();
    h += &histogram("min post-encroachment time of the ego", "s", &pet);
    h += "</div>";
    h
}

/// The coverage section: each test's items as charts, and its two most
/// varied cover items crossed.
fn coverage_section(c: &CoverageFile, happened: &[RunLine]) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<h2>Coverage</h2><p id=\"holes\">{} hole(s) over {} cover item(s)</p>",
        c.holes,
        c.items.iter().filter(|i| i.def.kind == "cover").count()
    );
    let mut by_test: BTreeMap<&str, Vec<&litesim_scenario::coverage::ItemCoverage>> =
        BTreeMap::new();
    for i in &c.items {
        by_test.entry(i.test.as_str()).or_default().push(i);
    }
    for (test, items) in &by_test {
        let _ = write!(h, "<h3>{}</h3><div class=\"charts\">", esc(test));
        for i in items {
            h += &coverage_chart(i);
        }
        h += "</div>";
        // The two cover items that vary most (most buckets hit).
        let mut crossed: Vec<&&litesim_scenario::coverage::ItemCoverage> = items
            .iter()
            .filter(|i| i.def.kind == "cover" && !i.buckets.is_empty())
            .collect();
        crossed
            .sort_by_key(|i| std::cmp::Reverse(i.buckets.iter().filter(|b| b.count > 0).count()));
        crossed.truncate(2);
        if let [a, b] = crossed[..] {
            h += &cross(test, a, b, happened);
        }
    }
    h
}

/// One item's buckets as an SVG bar chart; holes drawn as red marks.
fn coverage_chart(i: &litesim_scenario::coverage::ItemCoverage) -> String {
    let mut s = format!(
        "<div class=\"chart cover\" data-item=\"{}\"><h4>{} <small>{} {}</small></h4>",
        esc(&i.def.name),
        esc(&i.def.name),
        esc(&i.def.kind),
        esc(i.def.unit.as_deref().unwrap_or(""))
    );
    if let Some(t) = &i.def.text {
        let _ = write!(s, "<p>{}</p>", esc(t));
    }
    if i.buckets.is_empty() {
        let stat = |x: Option<f64>| x.map_or("–".into(), |v| format!("{v:.3}"));
        let _ = write!(
            s,
            "<p>{} samples, min {}, mean {}, max {}</p></div>",
            i.samples,
            stat(i.min),
            stat(i.mean),
            stat(i.max)
        );
        return s;
    }
    let n = i.buckets.len();
    let bw = (400.0 / n as f64).clamp(4.0, 60.0);
    let width = bw * n as f64 + 20.0;
    let max = i.buckets.iter().map(|b| b.count).max().unwrap_or(1).max(1) as f64;
    let _ = write!(
        s,
        "<svg viewBox=\"0 0 {width:.0} 160\" width=\"{width:.0}\" height=\"160\">"
    );
    for (k, b) in i.buckets.iter().enumerate() {
        let x = 10.0 + bw * k as f64;
        if b.count == 0 {
            let _ = write!(
                s,
                "<rect class=\"bucket hole\" x=\"{x:.1}\" y=\"110\" width=\"{:.1}\" height=\"10\"><title>{}: hole</title></rect>",
                bw - 2.0,
                esc(&b.label)
            );
        } else {
            let hgt = 110.0 * b.count as f64 / max;
            let _ = write!(
                s,
                "<rect class=\"bucket\" x=\"{x:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{hgt:.1}\"><title>{}: {}</title></rect>",
                120.0 - hgt,
                bw - 2.0,
                esc(&b.label),
                b.count
            );
        }
    }
    let first = i.buckets.first().map_or("", |b| b.label.as_str());
    let last = i.buckets.last().map_or("", |b| b.label.as_str());
    let _ = write!(
        s,
        "<text x=\"10\" y=\"140\">{}</text><text x=\"{:.0}\" y=\"155\" text-anchor=\"end\">{}</text></svg>",
        esc(first),
        width - 10.0,
        esc(last)
    );
    let _ = write!(
        s,
        "<p>{} samples, {} outside, {} not evaluated; holes: {}</p></div>",
        i.samples,
        i.outside,
        i.missing,
        if i.holes.is_empty() {
            "none".into()
        } else {
            esc(&i.holes.join(" "))
        }
    );
    s
}

/// Cross coverage of two items of a test as a heat map (runs that hit
/// both buckets).
fn cross(
    test: &str,
    a: &litesim_scenario::coverage::ItemCoverage,
    b: &litesim_scenario::coverage::ItemCoverage,
    runs: &[RunLine],
) -> String {
    let (na, nb) = (a.buckets.len(), b.buckets.len());
    let mut grid = vec![0u64; na * nb];
    for l in runs.iter().filter(|l| l.test == test) {
        let get = |name: &str| {
            l.coverage
                .iter()
                .find(|s| s.item == name)
                .and_then(|s| s.value.as_ref())
        };
        if let (Some(x), Some(y)) = (get(&a.def.name), get(&b.def.name))
            && let (Some(i), Some(j)) = (bucket_index(&a.def, x), bucket_index(&b.def, y))
        {
            grid[i * nb + j] += 1;
        }
    }
    let max = grid.iter().copied().max().unwrap_or(1).max(1) as f64;
    let c = 22.0;
    let (w, hh) = (120.0 + c * nb as f64, 30.0 + c * na as f64);
    let mut s = format!(
        "<div class=\"chart crossed\"><h4>cross coverage: {} × {}</h4><svg viewBox=\"0 0 {w:.0} {hh:.0}\" width=\"{w:.0}\" height=\"{hh:.0}\">",
        esc(&a.def.name),
        esc(&b.def.name)
    );
    for i in 0..na {
        let _ = write!(
            s,
            "<text x=\"115\" y=\"{:.0}\" text-anchor=\"end\" font-size=\"10\">{}</text>",
            c * i as f64 + 15.0,
            esc(&a.buckets[i].label)
        );
        for j in 0..nb {
            let n = grid[i * nb + j];
            let fill = if n == 0 {
                "#f3d3d3".to_string()
            } else {
                let t = n as f64 / max;
                format!(
                    "rgb({:.0},{:.0},{:.0})",
                    230.0 - 200.0 * t,
                    240.0 - 120.0 * t,
                    255.0 - 60.0 * t
                )
            };
            let _ = write!(
                s,
                "<rect class=\"cell\" x=\"{:.0}\" y=\"{:.0}\" width=\"{}\" height=\"{}\" fill=\"{fill}\"><title>{} × {}: {n}</title></rect>",
                120.0 + c * j as f64,
                c * i as f64,
                c - 2.0,
                c - 2.0,
                esc(&a.buckets[i].label),
                esc(&b.buckets[j].label)
            );
        }
    }
    s + "</svg><p>rows: first item's buckets; columns: the second's; pale red: never hit together</p></div>"
}

const STYLE: &str = "body{font:14px system-ui,sans-serif;margin:24px;color:#222}h1{margin:0}table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 6px;text-align:left;vertical-align:top}th[data-k]{cursor:pointer;background:#f0f0f0}.pass{color:#17803d}.fail{color:#b3261e}.invalid{color:#8a6d00}.warn{background:#fff4d6;padding:8px;border:1px solid #e0c070}.charts{display:flex;flex-wrap:wrap;gap:16px}.chart{border:1px solid #ddd;padding:8px}.chart h4{margin:0 0 4px}rect.bucket{fill:#4a78c2}rect.hole{fill:#d33}rect.bin{fill:#6a9a5b}.where{color:#666}.empty{font-size:18px}tr.fail td:nth-child(3){color:#b3261e;font-weight:bold}";

/// Draws the runs table: filter (verdict, text), sort by column, at most
/// PAGE rows at a time.
const SCRIPT: &str = r#"
const rows = JSON.parse(document.getElementById('data').textContent);
const body = document.querySelector('#runs tbody');
let key = 1, asc = true;
function shown() {
  const v = document.getElementById('show').value;
  const f = document.getElementById('filter').value.toLowerCase();
  // 'failed': the SUT failed or the run could not be carried out.
  const is = r => v === 'all' || v === r[2] || (v === 'fail' && r[2] === 'error');
  return rows.filter(r => is(r) &&
    (!f || r[0].toLowerCase().includes(f) || r[7].toLowerCase().includes(f)));
}
function cmp(a, b) {
  const x = a[key], y = b[key];
  if (x === y) return a[1] - b[1];
  if (x === null) return 1;
  if (y === null) return -1;
  return (x < y ? -1 : 1) * (asc ? 1 : -1);
}
function fmt(x) { return x === null || x === undefined ? '' : (typeof x === 'number' && !Number.isInteger(x) ? x.toFixed(3) : String(x)); }
function draw() {
  const all = shown().sort(cmp);
  body.textContent = '';
  for (const r of all.slice(0, PAGE)) {
    const tr = document.createElement('tr');
    tr.className = r[2] === 'pass' || r[2] === 'invalid' ? r[2] : 'fail';
    const cells = [r[0], r[1], r[2] === 'pass' ? 'pass' : r[2].toUpperCase(), r[3], r[4] < 0 ? '' : fmt(r[4]), fmt(r[5]), fmt(r[6]), r[7]];
    for (const c of cells) { const td = document.createElement('td'); td.textContent = fmt(c); tr.appendChild(td); }
    const td = document.createElement('td');
    if (r[8]) { const a = document.createElement('a'); a.href = r[8]; a.textContent = 'replay'; a.className = 'replay'; td.appendChild(a); }
    tr.appendChild(td);
    body.appendChild(tr);
  }
  document.getElementById('count').textContent = all.length > PAGE
    ? `showing ${PAGE} of ${all.length} runs` : `${all.length} runs`;
}
document.getElementById('show').addEventListener('change', draw);
document.getElementById('filter').addEventListener('input', draw);
for (const th of document.querySelectorAll('th[data-k]')) {
  th.addEventListener('click', () => { const k = +th.dataset.k; asc = key === k ? !asc : true; key = k; draw(); });
}
draw();
"#;
