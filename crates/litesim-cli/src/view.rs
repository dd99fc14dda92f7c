//! `litesim view`: a run in the browser. The binary serves one embedded page
//! (`assets/viewer.html`, no network) and the run's data from memory:
//!
//! * `GET /meta.json`: actors, the map's areas and lines, the timeline
//!   (failures, phases), and the plots (speed per actor, the ego's gap and
//!   time to collision) decimated to at most [`PLOT_POINTS`] points — small
//!   whatever the run's length;
//! * `GET /chunk/N`: ticks `N·C .. (N+1)·C` of every actor ([`chunk_ticks`]) as
//!   little-endian `f32` ([`FIELDS`] per actor, positions relative to the
//!   meta's origin so that `f32` keeps millimetres), fetched by the page
//!   around the cursor only: an hour-long log streams.
//!
//! `--export FILE` writes the same page with the meta and every chunk
//! (base64) inside: one file that works from `file://`.

use anyhow::{Context, Result, anyhow, bail};
use litesim_log::SimulationLog;
use serde::Serialize;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The page (HTML, CSS and JavaScript in one file, no external resource).
const PAGE: &str = include_str!("../assets/viewer.html");

/// Most ticks per chunk.
pub const CHUNK: usize = 2000;
/// Most bytes per chunk: with many actors a chunk holds fewer ticks.
pub const CHUNK_BYTES: usize = 1 << 20;

/// Ticks per chunk for `actors` actors: [`CHUNK`], fewer when that would
/// exceed [`CHUNK_BYTES`] (50 actors: 655 ticks, 13 s at 20 ms).
pub fn chunk_ticks(actors: usize) -> usize {
    (CHUNK_BYTES / (4 * FIELDS.len() * actors.max(1))).clamp(50, CHUNK)
}
/// Most points of a plot series.
pub const PLOT_POINTS: usize = 2000;
/// Per actor and tick, in this order.
pub const FIELDS: [&str; 8] = [
    "x", "y", "yaw", "speed", "accel", "throttle", "brake", "steering",
];

/// What `litesim view` was pointed at, loaded.
pub struct Run {
    log: SimulationLog,
    /// The run's summary.json, when beside the log.
    summary: Option<serde_json::Value>,
    /// The run's plan.json, when beside the log.
    plan: Option<serde_json::Value>,
    /// The map, when found.
    net: Option<litesim_map::RoadNetwork>,
    /// Why the map is missing (shown on the page), if it is.
    map_note: Option<String>,
    title: String,
}

fn read_json_file(p: &Path) -> Option<serde_json::Value> {
    let text = crate::read_text(p).ok()?;
    serde_json::from_str(&text).ok()
}

impl Run {
    /// Loads a run folder (log.json, and summary.json / plan.json when
    /// there) or a log file; `map` overrides the map the summary names.
    pub fn load(target: &Path, map: Option<&Path>) -> Result<Run> {
        let meta = std::fs::metadata(target)
            .with_context(|| format!("{}: cannot open", target.display()))?;
        let (dir, log_path) = if meta.is_dir() {
            let p = target.join("log.json");
            if !p.is_file() {
                bail!(
                    "{}: no log.json in this folder (expected a run folder written by `litesim run`, or a log file)",
                    target.display()
                );
            }
            (target.to_path_buf(), p)
        } else {
            let dir = target
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
            (dir, target.to_path_buf())
        };
        let log = SimulationLog::read_json(&log_path).map_err(|e| anyhow!("{e}"))?;
        if log.tick.is_empty() || log.tracks.is_empty() {
            bail!(
                "{}: the log has no ticks or no actors: nothing to show",
                log_path.display()
            );
        }
        let (summary, plan) = if log_path.file_name().is_some_and(|n| n == "log.json") {
            (
                read_json_file(&dir.join("summary.json")),
                read_json_file(&dir.join("plan.json")),
            )
        } else {
            (None, None)
        };
        // The map: --map, else the summary's (as written, then relative to
        // the run folder's parents: runs are often made from the repo root).
        let named = map.map(Path::to_path_buf).or_else(|| {
            summary
                .as_ref()
                .and_then(|s| s.get("map"))
                .and_then(|m| m.as_str())
                .filter(|m| !m.is_empty())
                .map(PathBuf::from)
        });
        let (net, map_note) = match named {
            None => (None, None),
            Some(p) => {
                let found = std::iter::once(p.clone())
                    .chain(dir.ancestors().map(|a| a.join(&p)))
                    .find(|c| c.is_file());
                match found {
                    Some(f) => match litesim_map::RoadNetwork::load(&f) {
                        Ok(n) => (Some(n), None),
                        Err(e) if map.is_some() => bail!("--map {}: {e}", f.display()),
                        Err(e) => (None, Some(format!("map {}: {e}", f.display()))),
                    },
                    None if map.is_some() => bail!("--map {}: no such file", p.display()),
                    None => (
                        None,
                        Some(format!(
                            "map {} not found (give it with --map)",
                            p.display()
                        )),
                    ),
                }
            }
        };
        let title = match (log.meta.get("test"), log.meta.get("seed")) {
            (Some(t), Some(s)) => format!("{t} · seed {s}"),
            (Some(t), None) => t.clone(),
            _ => log_path.display().to_string(),
        };
        Ok(Run {
            log,
            summary,
            plan,
            net,
            map_note,
            title,
        })
    }
}

/// The data behind the page: the meta document and the chunk encoder.
pub struct ViewData {
    run: Run,
    chunk: usize,
    origin: (f64, f64),
    index: Vec<Vec<Option<u32>>>,
    meta: String,
}

#[derive(Serialize)]
struct Meta<'a> {
    version: u32,
    title: &'a str,
    dt: f64,
    ticks: usize,
    chunk: usize,
    fields: [&'static str; 8],
    origin: [f64; 2],
    time: TimeAxis,
    ego: usize,
    actors: Vec<ActorMeta<'a>>,
    bounds: [f64; 4],
    map: MapMeta,
    map_note: Option<&'a str>,
    markers: Vec<Marker>,
    plots: Plots,
    verdict: Option<String>,
}

/// Times of the ticks: `t0 + k·dt` when the log is regular (the usual case:
/// the page computes them), else listed.
#[derive(Serialize)]
struct TimeAxis {
    t0: f64,
    step: f64,
    listed: Option<Vec<f64>>,
}

#[derive(Serialize)]
struct ActorMeta<'a> {
    id: &'a str,
    kind: &'a str,
    model: &'a str,
    length: f64,
    width: f64,
    first: f64,
    last: f64,
}

#[derive(Serialize, Default)]
struct MapMeta {
    /// Polygons (flattened x, y relative to the origin, cm), drivable flag.
    areas: Vec<(Vec<f32>, bool)>,
    /// Lines: points, style (border, mark, mark-broken, with -yellow, -double).
    lines: Vec<(Vec<f32>, String)>,
}

#[derive(Serialize)]
struct Marker {
    t: f64,
    kind: &'static str,
    text: String,
}

#[derive(Serialize)]
struct Plots {
    /// Times of the plotted samples.
    t: Vec<f64>,
    /// Speed per actor (m/s), in actor order; `null` where absent.
    speed: Vec<Vec<Option<f32>>>,
    /// The ego's bumper-to-bumper gap to the nearest actor ahead in its
    /// path (m), the smallest in each plotted bucket.
    gap: Vec<Option<f32>>,
    /// The ego's time to collision with that actor (s) while closing, the
    /// smallest in each bucket.
    ttc: Vec<Option<f32>>,
    /// The ego's longitudinal acceleration as it happened (m/s²).
    accel: Vec<Option<f32>>,
    /// The acceleration commanded of it (m/s²): the SUT's command in
    /// closed loop, the plan's otherwise; empty without the log's tracking.
    command: Vec<Option<f32>>,
    /// Whose command (`sut`, `planned`, …).
    command_label: String,
}

fn finite32(v: f64) -> Option<f32> {
    v.is_finite().then_some(v as f32)
}

/// Minimum of two optional values.
fn min_opt(a: Option<f32>, b: Option<f32>) -> Option<f32> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, None) => a,
        (None, b) => b,
    }
}

/// "… at 7.84 s" → 7.84 (the last such time in a failure's text).
fn time_in(text: &str) -> Option<f64> {
    let mut found = None;
    for (i, _) in text.match_indices(" at ") {
        let rest = &text[i + 4..];
        let num: String = rest
            .chars()
            .take_while(|c| c.is_ascii_digit() || *c == '.')
            .collect();
        if rest[num.len()..].starts_with(" s")
            && let Ok(v) = num.parse::<f64>()
        {
            found = Some(v);
        }
    }
    found
}

impl ViewData {
    /// Prepares the meta document (plots decimated, map converted).
    pub fn new(run: Run) -> ViewData {
        let log = &run.log;
        let n = log.tick.len();
        let chunk = chunk_ticks(log.tracks.len());
        let index: Vec<Vec<Option<u32>>> =
            log.tracks.iter().map(|t| log.sample_indices(t)).collect();
        // Bounds of every actor's positions; the origin is their centre.
        let b =
            litesim_viz::path_bounds(log).map_or([0.0; 4], |((x0, x1), (y0, y1))| [x0, y0, x1, y1]);
        let origin = (((b[0] + b[2]) / 2.0).round(), ((b[1] + b[3]) / 2.0).round());
        let bounds = [
            b[0] - origin.0,
            b[1] - origin.1,
            b[2] - origin.0,
            b[3] - origin.1,
        ];

        // Time axis: regular (t0 + k·step) unless the log says otherwise.
        let t0 = log.time[0];
        let step = if n > 1 {
            (log.time[n - 1] - t0) / (n - 1) as f64
        } else {
            log.dt
        };
        let regular = log
            .time
            .iter()
            .enumerate()
            .all(|(k, t)| (t0 + k as f64 * step - t).abs() < 1e-6);
        let time = TimeAxis {
            t0,
            step,
            listed: (!regular).then(|| log.time.clone()),
        };

        let ego = log
            .tracks
            .iter()
            .position(|t| t.id == "sut.car")
            .unwrap_or(0);
        let actors = log
            .tracks
            .iter()
            .map(|t| ActorMeta {
                id: &t.id,
                kind: &t.kind,
                model: &t.model,
                length: if t.length > 0.0 { t.length } else { 4.5 },
                width: if t.width > 0.0 { t.width } else { 1.8 },
                first: t.tick.first().map_or(0.0, |k| *k as f64 * log.dt),
                last: t.tick.last().map_or(0.0, |k| *k as f64 * log.dt),
            })
            .collect();

        // Gap and TTC of the ego to the nearest actor ahead in its path.
        let (gap, ttc) = gap_and_ttc(log, &index, ego);

        let plots = plots(log, &index, ego, (&gap, &ttc));

        // Timeline markers: failures (at the time their text names, else
        // at the end) and the plan's phases.
        let end_t = log.time[n - 1];
        let markers = markers(&run, t0, end_t);

        // The map: what the replay picture draws, relative to the origin.
        let map = map_meta(&run, origin);
        let verdict = run
            .summary
            .as_ref()
            .and_then(|s| s.get("pass"))
            .and_then(|p| p.as_bool())
            .map(|p| {
                if p {
                    "PASS".to_string()
                } else {
                    "FAIL".to_string()
                }
            });
        let meta = Meta {
            version: 1,
            title: &run.title,
            dt: log.dt,
            ticks: n,
            chunk,
            fields: FIELDS,
            origin: [origin.0, origin.1],
            time,
            ego,
            actors,
            bounds,
            map,
            map_note: run.map_note.as_deref(),
            markers,
            plots,
            verdict,
        };
        let meta = serde_json::to_string(&meta).unwrap_or_else(|_| "{}".into());
        ViewData {
            chunk,
            origin,
            index,
            meta,
            run,
        }
    }

    /// The meta document (JSON).
    pub fn meta(&self) -> &str {
        &self.meta
    }

    /// Number of chunks.
    pub fn chunks(&self) -> usize {
        self.run.log.tick.len().div_ceil(self.chunk)
    }

    /// Chunk `c` as little-endian `f32`: per actor, per field of
    /// [`FIELDS`], the chunk's ticks (NaN where the actor is absent).
    pub fn chunk(&self, c: usize) -> Option<Vec<u8>> {
        let log = &self.run.log;
        let n = log.tick.len();
        let start = c.checked_mul(self.chunk).filter(|s| *s < n)?;
        let end = (start + self.chunk).min(n);
        let mut out = Vec::with_capacity(log.tracks.len() * FIELDS.len() * (end - start) * 4);
        for (a, t) in log.tracks.iter().enumerate() {
            let idx = &self.index[a][start..end];
            let col = |f: &dyn Fn(usize) -> f64, out: &mut Vec<u8>| {
                for i in idx {
                    let v = i.map_or(f32::NAN, |i| f(i as usize) as f32);
                    out.extend_from_slice(&v.to_le_bytes());
                }
            };
            let (ox, oy) = self.origin;
            col(&|i| t.state.x[i] - ox, &mut out);
            col(&|i| t.state.y[i] - oy, &mut out);
            col(&|i| t.state.yaw[i], &mut out);
            col(&|i| t.state.speed[i], &mut out);
            col(&|i| t.derived.longitudinal_acceleration[i], &mut out);
            col(&|i| t.control.throttle[i], &mut out);
            col(&|i| t.control.brake[i], &mut out);
            col(&|i| t.control.steering[i], &mut out);
        }
        Some(out)
    }

    /// The page with every chunk inside (for `--export`).
    pub fn export_html(&self) -> String {
        use base64::Engine;
        let chunks: Vec<String> = (0..self.chunks())
            .map(|c| {
                base64::engine::general_purpose::STANDARD.encode(self.chunk(c).unwrap_or_default())
            })
            .collect();
        // `</` cannot appear inside a script element: JSON escapes it.
        let data = format!(
            "{{\"meta\":{},\"chunks\":{}}}",
            self.meta,
            serde_json::to_string(&chunks).unwrap_or_else(|_| "[]".into())
        )
        .replace("</", "<\\/");
        PAGE.replace(
            "<script id=\"embedded\" type=\"application/json\"></script>",
            &format!("<script id=\"embedded\" type=\"application/json\">{data}</script>"),
        )
    }
}

/// Writes the self-contained page to `out`.
pub fn export(data: &ViewData, out: &Path) -> Result<()> {
    let html = data.export_html();
    litesim_log::write_atomic(out, |w| w.write_all(html.as_bytes())).map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// Binds the viewer's address; a port in use is said plainly.
pub fn bind(host: &str, port: u16) -> Result<TcpListener> {
    TcpListener::bind((host, port)).map_err(|e| {
        if e.kind() == std::io::ErrorKind::AddrInUse {
            anyhow!(
                "port {port} on {host} is in use ({e}): choose another with --port (or --port 0 for any free port)"
            )
        } else {
            anyhow!("cannot listen on {host}:{port}: {e}")
        }
    })
}

/// Serves the page and the data until the process is stopped.
pub fn serve(data: ViewData, listener: TcpListener) -> Result<()> {
    let data = Arc::new(data);
    for conn in listener.incoming() {
        let Ok(stream) = conn else { continue };
        let data = Arc::clone(&data);
        // One thread per connection: a browser opens a few.
        std::thread::spawn(move || {
            let _ = handle(&data, stream);
        });
    }
    Ok(())
}

/// Longest request head read (bytes): the page asks for short paths only.
const MAX_HEAD: usize = 16 * 1024;

fn handle(data: &ViewData, stream: TcpStream) -> std::io::Result<()> {
    stream.set_read_timeout(Some(std::time::Duration::from_secs(30)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut out = stream;
    loop {
        // Request line and headers (keep-alive: several requests per connection).
        let mut head = Vec::new();
        loop {
            let mut line = Vec::new();
            let got = (&mut reader)
                .take((MAX_HEAD - head.len().min(MAX_HEAD)) as u64 + 1)
                .read_until(b'\n', &mut line)?;
            if got == 0 {
                return Ok(());
            }
            head.extend_from_slice(&line);
            if head.len() > MAX_HEAD {
                return respond(
                    &mut out,
                    431,
                    "text/plain",
                    b"request head too large",
                    false,
                );
            }
            if line == b"\r\n" || line == b"\n" {
                break;
            }
        }
        let head = String::from_utf8_lossy(&head);
        let mut words = head.lines().next().unwrap_or("").split_whitespace();
        let (method, target) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
        let close = head.lines().any(|l| {
            l.to_ascii_lowercase().starts_with("connection:")
                && l.to_ascii_lowercase().contains("close")
        });
        let keep = !close;
        if method != "GET" {
            respond(&mut out, 405, "text/plain", b"only GET", keep)?;
            continue;
        }
        let path = target.split('?').next().unwrap_or("");
        match path {
            "/" | "/index.html" => respond(
                &mut out,
                200,
                "text/html; charset=utf-8",
                PAGE.as_bytes(),
                keep,
            )?,
            "/meta.json" => respond(
                &mut out,
                200,
                "application/json",
                data.meta().as_bytes(),
                keep,
            )?,
            p if p.starts_with("/chunk/") => match p["/chunk/".len()..]
                .parse::<usize>()
                .ok()
                .and_then(|c| data.chunk(c))
            {
                Some(bytes) => respond(&mut out, 200, "application/octet-stream", &bytes, keep)?,
                None => respond(&mut out, 404, "text/plain", b"no such chunk", keep)?,
            },
            _ => respond(&mut out, 404, "text/plain", b"not found", keep)?,
        }
        if !keep {
            return Ok(());
        }
    }
}

fn respond(
    out: &mut TcpStream,
    code: u16,
    kind: &str,
    body: &[u8],
    keep: bool,
) -> std::io::Result<()> {
    let reason = match code {
        200 => "OK",
        404 => "Not Found",
        405 => "Method Not Allowed",
        _ => "Request Header Fields Too Large",
    };
    write!(
        out,
        "HTTP/1.1 {code} {reason}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: {}\r\n\r\n",
        body.len(),
        if keep { "keep-alive" } else { "close" }
    )?;
    out.write_all(body)?;
    out.flush()
}

/// The plots: buckets of at most [`PLOT_POINTS`] ticks; speed at each
/// bucket's first tick, gap and TTC at their smallest (the critical values
/// survive), the ego's acceleration and the SUT's commanded one.
fn plots(
    log: &litesim_log::SimulationLog,
    index: &[Vec<Option<u32>>],
    ego: usize,
    (gap, ttc): (&[Option<f32>], &[Option<f32>]),
) -> Plots {
    let n = log.tick.len();
    let per = n.div_ceil(PLOT_POINTS).max(1);
    let tracking = log.tracking.as_ref();
    let mut plots = Plots {
        t: Vec::new(),
        speed: vec![Vec::new(); log.tracks.len()],
        gap: Vec::new(),
        ttc: Vec::new(),
        accel: Vec::new(),
        command: Vec::new(),
        command_label: tracking.map_or(String::new(), |t| t.command_label().to_string()),
    };
    // The commanded acceleration at a tick (the tracking columns have
    // their own ticks).
    let command_at = |tick: u64| {
        let tr = tracking?;
        let i = tr.tick.binary_search(&tick).ok()?;
        tr.cmd_acceleration.get(i).copied().and_then(finite32)
    };
    for start in (0..n).step_by(per) {
        let end = (start + per).min(n);
        plots.t.push(log.time[start]);
        for (a, t) in log.tracks.iter().enumerate() {
            plots.speed[a].push(index[a][start].and_then(|i| finite32(t.state.speed[i as usize])));
        }
        plots
            .gap
            .push(gap[start..end].iter().fold(None, |m, v| min_opt(m, *v)));
        plots
            .ttc
            .push(ttc[start..end].iter().fold(None, |m, v| min_opt(m, *v)));
        let e = &log.tracks[ego];
        plots.accel.push(
            index[ego][start]
                .and_then(|i| finite32(e.derived.longitudinal_acceleration[i as usize])),
        );
        if tracking.is_some() {
            plots
                .command
                .push(index[ego][start].and_then(|i| command_at(e.tick[i as usize])));
        }
    }
    plots
}

/// Per tick: the ego's bumper gap to the nearest actor ahead in its path
/// and the time to collision at the closing speed (none where none is
/// ahead or they do not close).
fn gap_and_ttc(
    log: &litesim_log::SimulationLog,
    index: &[Vec<Option<u32>>],
    ego: usize,
) -> (Vec<Option<f32>>, Vec<Option<f32>>) {
    (0..log.tick.len())
        .map(|k| {
            let e = &log.tracks[ego];
            let Some(i) = index[ego][k].map(|i| i as usize) else {
                return (None, None);
            };
            let (ex, ey, eyaw, ev) = (e.state.x[i], e.state.y[i], e.state.yaw[i], e.state.speed[i]);
            if !(ex.is_finite() && ey.is_finite() && eyaw.is_finite()) {
                return (None, None);
            }
            let (s, c) = litesim_core::math::sin_cos(eyaw);
            let mut best: Option<(f64, f64)> = None;
            for (a, t) in log.tracks.iter().enumerate() {
                if a == ego {
                    continue;
                }
                let Some(j) = index[a][k].map(|j| j as usize) else {
                    continue;
                };
                let (dx, dy) = (t.state.x[j] - ex, t.state.y[j] - ey);
                let (along, across) = (dx * c + dy * s, -dx * s + dy * c);
                if !(along > 0.0 && across.abs() < (e.width + t.width) / 2.0 + 0.3) {
                    continue;
                }
                let g = along - (e.length + t.length) / 2.0;
                // The other's speed along the ego's heading.
                let (ovx, ovy) = (t.state.vx[j], t.state.vy[j]);
                let ov = ovx * c + ovy * s;
                if best.is_none_or(|(bg, _)| g < bg) {
                    best = Some((g, ev - ov));
                }
            }
            match best {
                None => (None, None),
                Some((g, closing)) => (
                    finite32(g.max(0.0)),
                    (closing > 1e-6)
                        .then(|| finite32(g.max(0.0) / closing))
                        .flatten(),
                ),
            }
        })
        .unzip()
}

/// The timeline's markers, in time order: failures (at the time their
/// text names, else at the end `end_t`) and the plan's phases.
fn markers(run: &Run, t0: f64, end_t: f64) -> Vec<Marker> {
    let mut markers = Vec::new();
    if let Some(s) = &run.summary {
        for f in s
            .get("failures")
            .and_then(|f| f.as_array())
            .into_iter()
            .flatten()
        {
            let text = f.as_str().map_or_else(|| f.to_string(), str::to_string);
            markers.push(Marker {
                t: time_in(&text).unwrap_or(end_t).clamp(t0, end_t),
                kind: "failure",
                text,
            });
        }
    }
    if let Some(p) = &run.plan {
        for ph in p
            .get("phases")
            .and_then(|f| f.as_array())
            .into_iter()
            .flatten()
        {
            let t = ph.get("t0").and_then(|v| v.as_f64()).unwrap_or(0.0);
            let actor = ph.get("actor").and_then(|v| v.as_str()).unwrap_or("");
            let action = ph.get("action").and_then(|v| v.as_str()).unwrap_or("");
            let label = ph.get("label").and_then(|v| v.as_str());
            markers.push(Marker {
                t: t.clamp(t0, end_t),
                kind: "event",
                text: match label {
                    Some(l) => format!("{actor}.{action} ({l})"),
                    None => format!("{actor}.{action}"),
                },
            });
        }
    }
    markers.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.kind.cmp(b.kind)));
    markers
}

/// The map as the replay picture draws it, relative to `origin`.
fn map_meta(run: &Run, origin: (f64, f64)) -> MapMeta {
    let rel = |x: f64, y: f64| ((x - origin.0) as f32, (y - origin.1) as f32);
    let mut map = MapMeta::default();
    if let Some(net) = &run.net {
        let bg = crate::viz::background(net, false);
        let flat = |pts: &[(f64, f64)]| -> Vec<f32> {
            pts.iter()
                .flat_map(|&(x, y)| {
                    let (x, y) = rel(x, y);
                    [(x * 100.0).round() / 100.0, (y * 100.0).round() / 100.0]
                })
                .collect()
        };
        for a in &bg.areas {
            map.areas.push((flat(&a.outline), a.drivable));
        }
        for l in &bg.lines {
            use litesim_viz::replay::LineKind;
            let style = match l.kind {
                LineKind::Border => "border".to_string(),
                LineKind::Centre => "centre".to_string(),
                LineKind::Mark {
                    broken,
                    double,
                    yellow,
                } => format!(
                    "mark{}{}{}",
                    if broken { "-broken" } else { "" },
                    if double { "-double" } else { "" },
                    if yellow { "-yellow" } else { "" }
                ),
            };
            map.lines.push((flat(&l.points), style));
        }
    }
    map
}

#[cfg(test)]
mod tests {
    use super::*;
    use litesim_log::ActorTrack;

    /// A log of `ticks` at 20 ms of `actors` cars, columns filled directly.
    fn synthetic(ticks: usize, actors: usize) -> SimulationLog {
        let col = |f: &dyn Fn(usize) -> f64| (0..ticks).map(f).collect::<Vec<f64>>();
        let mut log = SimulationLog {
            format_version: 1,
            dt: 0.02,
            tick: (0..ticks as u64).collect(),
            time: col(&|k| k as f64 * 0.02),
            ..SimulationLog::default()
        };
        for a in 0..actors {
            let v = 10.0 + a as f64;
            let mut t = ActorTrack {
                id: format!("car{a}"),
                kind: "vehicle/car".into(),
                length: 4.5,
                width: 1.8,
                tick: log.tick.clone(),
                mode: vec!["trajectory".into(); ticks],
                ..ActorTrack::default()
            };
            t.state.x = col(&|k| v * k as f64 * 0.02);
            t.state.y = vec![3.5 * a as f64; ticks];
            t.state.speed = vec![v; ticks];
            t.state.vx = vec![v; ticks];
            for c in [
                &mut t.state.z,
                &mut t.state.yaw,
                &mut t.state.vy,
                &mut t.state.yaw_rate,
                &mut t.control.throttle,
                &mut t.control.brake,
                &mut t.control.steering,
                &mut t.derived.longitudinal_acceleration,
            ] {
                *c = vec![0.0; ticks];
            }
            log.tracks.push(t);
        }
        log
    }

    fn data(log: SimulationLog) -> ViewData {
        ViewData::new(Run {
            log,
            summary: None,
            plan: None,
            net: None,
            map_note: None,
            title: "synthetic".into(),
        })
    }

    #[test]
    fn what_the_page_loads_first_does_not_grow_with_the_run() {
        // Ten minutes and an hour of ten cars: the meta document (plots
        // decimated to PLOT_POINTS) is the same size within a few per cent,
        // and a chunk is bounded whatever the length.
        let short = data(synthetic(30_000, 10));
        let long = data(synthetic(180_000, 10));
        let (a, b) = (short.meta().len() as f64, long.meta().len() as f64);
        assert!(b < 1.1 * a, "meta grew from {a} to {b} bytes");
        assert!(b < 1_000_000.0, "meta of an hour: {b} bytes");
        assert_eq!(long.chunks(), 180_000usize.div_ceil(chunk_ticks(10)));
        for c in [0, long.chunks() - 1] {
            assert!(long.chunk(c).unwrap().len() <= CHUNK_BYTES);
        }
        assert!(long.chunk(long.chunks()).is_none());
        // Fifty actors: fewer ticks per chunk, still within the bound.
        assert_eq!(chunk_ticks(50), 655);
        let fifty = data(synthetic(2_000, 50));
        assert!(fifty.chunk(0).unwrap().len() <= CHUNK_BYTES);
    }

    #[test]
    fn chunks_hold_positions_relative_to_the_origin_to_a_millimetre() {
        let d = data(synthetic(5_000, 3));
        let meta: serde_json::Value = serde_json::from_str(d.meta()).unwrap();
        let ox = meta["origin"][0].as_f64().unwrap();
        let per = chunk_ticks(3);
        let c = 4321 / per;
        let bytes = d.chunk(c).unwrap();
        let len = per.min(5_000 - c * per);
        let f = |a: usize, field: usize, i: usize| {
            let at = ((a * FIELDS.len() + field) * len + i) * 4;
            f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as f64
        };
        let i = 4321 - c * per;
        let x = f(2, 0, i) + ox;
        assert!((x - 12.0 * 4321.0 * 0.02).abs() < 1e-3, "{x}");
        assert_eq!(f(2, 3, i), 12.0);
    }

    #[test]
    fn failure_times_are_read_from_their_text() {
        assert_eq!(
            time_in("collision between sut.car and other at 7.84 s"),
            Some(7.84)
        );
        assert_eq!(
            time_in("x.osc:56:13: other ended 21.8 m ahead of sut.car at 10.00 s, wanted 17 m"),
            Some(10.0)
        );
        assert_eq!(time_in("at the end"), None);
    }
}
