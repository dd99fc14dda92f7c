//! The tonic server: many independent Model SSP sessions behind one socket.
//!
//! * Each `Init` creates a session; every later call names it. A session
//!   belongs to the connection that created it: while that connection is
//!   open it is never reclaimed, however long it idles. When the
//!   connection closes (the client exited or was killed: at once; the
//!   network dropped: within the HTTP/2 keepalive timeout) its sessions are
//!   detached — they no longer count against `--max-sessions` — and freed
//!   after [`ServerConfig::attach_grace`] unless a client takes one back
//!   with `Attach`. Sessions also end on `Shutdown`, a short while after
//!   `EndSimulation`, and, when the server sets one, after
//!   [`ServerConfig::idle_timeout`] unused.
//! * A session that is gone is answered NOT_FOUND with how it ended (shut
//!   down, freed when its connection closed at a time, expired), and "never
//!   created" only for ids this server never issued.
//! * `Init` reads a `map_path` only from under the server's map roots
//!   (symbolic links and `..` resolved first); any other path is refused
//!   with one PERMISSION_DENIED message, whether or not the file exists.
//! * Limits on sessions, actors, trajectory points, steps per call and
//!   message size answer `RESOURCE_EXHAUSTED`; a bad request never affects
//!   another session.
//! * With a trace file, every call is written as one JSON line: time, session,
//!   method, arguments (in API units) and result or error.

use crate::convert as cv;
use crate::pb;
use crate::pb::simulator_support_server::{SimulatorSupport, SimulatorSupportServer};
use litesim_ssp::{Session, SessionLimits, Ssp, SspError, SspResult};
use serde::Serialize;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio_stream::{Stream, StreamExt};
use tonic::{Request, Response, Status, Streaming};

mod api;
mod config;
mod conn;
mod loopback;
mod metrics;
use api::*;
pub use config::*;
pub use conn::*;
pub use loopback::*;
use metrics::*;

/// Who holds a session.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Owner {
    /// The open connection with this id.
    Conn(u64),
    /// Its connection closed at this instant (server time, s): it waits
    /// for an `Attach`.
    Detached(Instant, f64),
    /// Made without a connection (the service called in-process).
    Local,
}

/// How a session ended: what NOT_FOUND says of it.
#[derive(Clone, Debug)]
enum Ended {
    Shutdown(f64),
    ConnectionClosed(f64),
    Idle(f64),
    AfterEnd(f64),
}

impl Ended {
    fn say(&self, id: &str) -> String {
        match self {
            Ended::Shutdown(t) => {
                format!("session '{id}' was closed by Shutdown at t = {t:.1} s (server time)")
            }
            Ended::ConnectionClosed(t) => format!(
                "session '{id}' was freed when its connection closed at t = {t:.1} s (server time) and no client attached it within the grace period"
            ),
            Ended::Idle(t) => format!(
                "session '{id}' expired at t = {t:.1} s (server time): unused longer than the server's --idle-timeout"
            ),
            Ended::AfterEnd(t) => format!(
                "session '{id}' was freed at t = {t:.1} s (server time), after EndSimulation"
            ),
        }
    }
}

/// Most ended sessions remembered for NOT_FOUND's answer.
const ENDED_KEPT: usize = 1_000_000;

struct Slot {
    session: Mutex<Session>,
    owner: Mutex<Owner>,
    last_used: Mutex<Instant>,
    streaming: AtomicBool,
    /// Paced stepping: the wall-clock instant and simulated time (ms) the
    /// pacing started from (`SetPacing`).
    pacing: Mutex<Option<(Instant, u64)>>,
}

struct Inner {
    cfg: ServerConfig,
    sessions: Mutex<BTreeMap<String, Arc<Slot>>>,
    /// Ended sessions and how (at most [`ENDED_KEPT`], oldest dropped).
    ended: Mutex<(BTreeMap<String, Ended>, std::collections::VecDeque<String>)>,
    /// Connections open now.
    open_conns: Mutex<std::collections::BTreeSet<u64>>,
    /// The map roots, resolved.
    roots: Vec<PathBuf>,
    metrics: Metrics,
    next_id: AtomicU64,
    started: Instant,
    trace: Option<Mutex<std::io::BufWriter<std::fs::File>>>,
}

/// Longest an Init (with its map) may take before the client is answered
/// DEADLINE_EXCEEDED.
pub const INIT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(60);

/// The gRPC service; cheap to clone.
#[derive(Clone)]
pub struct SspService {
    inner: Arc<Inner>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A panic while holding the lock must not take the whole server down.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl SspService {
    /// A service with the given settings; opens the trace file if any.
    pub fn new(cfg: ServerConfig) -> std::io::Result<Self> {
        let trace = match &cfg.trace_rpc {
            Some(p) => Some(Mutex::new(std::io::BufWriter::new(std::fs::File::create(
                p,
            )?))),
            None => None,
        };
        let roots = if cfg.map_roots.is_empty() {
            vec![std::env::current_dir()?]
        } else {
            cfg.map_roots.clone()
        };
        let roots = roots
            .iter()
            .map(|r| {
                std::fs::canonicalize(r).map_err(|e| {
                    std::io::Error::new(e.kind(), format!("map root {}: {e}", r.display()))
                })
            })
            .collect::<std::io::Result<Vec<_>>>()?;
        Ok(Self {
            inner: Arc::new(Inner {
                cfg,
                sessions: Mutex::new(BTreeMap::new()),
                ended: Mutex::new(Default::default()),
                open_conns: Mutex::new(Default::default()),
                roots,
                metrics: Metrics::default(),
                next_id: AtomicU64::new(1),
                started: Instant::now(),
                trace,
            }),
        })
    }

    /// Number of live sessions.
    pub fn session_count(&self) -> usize {
        lock(&self.inner.sessions).len()
    }

    /// Ends detached sessions past their grace, sessions ended by
    /// `EndSimulation` more than 10 s ago, and (with an idle timeout)
    /// sessions unused longer than it; as of `now`.
    pub fn reap_at(&self, now: Instant) -> usize {
        let t = self.server_time(now);
        let mut gone = Vec::new();
        {
            let mut sessions = lock(&self.inner.sessions);
            sessions.retain(|id, slot| {
                let why = self.why_reaped(slot, now, t);
                if let Some(w) = why.clone() {
                    gone.push((id.clone(), w));
                }
                why.is_none()
            });
        }
        let n = gone.len();
        for (id, why) in gone {
            self.bury(id, why);
        }
        n
    }

    /// [`SspService::reap_at`] now.
    pub fn reap(&self) -> usize {
        self.reap_at(Instant::now())
    }

    /// Why a session is reaped at `now` (server time `t`), if it is.
    fn why_reaped(&self, slot: &Slot, now: Instant, t: f64) -> Option<Ended> {
        if let Owner::Detached(since, _) = *lock(&slot.owner)
            && now.saturating_duration_since(since) >= self.inner.cfg.attach_grace
        {
            return Some(Ended::ConnectionClosed(self.server_time(since)));
        }
        if slot.streaming.load(Ordering::SeqCst) {
            return None;
        }
        let idle = now.saturating_duration_since(*lock(&slot.last_used));
        if lock(&slot.session).phase() == litesim_ssp::Phase::Ended
            && idle > Duration::from_secs(10)
        {
            return Some(Ended::AfterEnd(t));
        }
        match self.inner.cfg.idle_timeout {
            Some(lease) if idle >= lease => Some(Ended::Idle(t)),
            _ => None,
        }
    }

    /// Seconds since the server started, at `at`.
    fn server_time(&self, at: Instant) -> f64 {
        at.saturating_duration_since(self.inner.started)
            .as_secs_f64()
    }

    /// Remembers how session `id` ended (the oldest record goes past
    /// [`ENDED_KEPT`]).
    fn bury(&self, id: String, why: Ended) {
        self.inner.metrics.freed(&why);
        let mut g = lock(&self.inner.ended);
        let (map, order) = &mut *g;
        if map.insert(id.clone(), why).is_none() {
            order.push_back(id);
        }
        while order.len() > ENDED_KEPT {
            if let Some(old) = order.pop_front() {
                map.remove(&old);
            }
        }
    }

    /// A connection opened.
    pub fn connection_opened(&self, conn: u64) {
        lock(&self.inner.open_conns).insert(conn);
    }

    /// A connection closed: its sessions are detached (freed after the
    /// grace period unless attached again).
    pub fn connection_closed(&self, conn: u64) {
        lock(&self.inner.open_conns).remove(&conn);
        let now = Instant::now();
        let t = self.server_time(now);
        for slot in lock(&self.inner.sessions).values() {
            let mut o = lock(&slot.owner);
            if *o == Owner::Conn(conn) {
                *o = Owner::Detached(now, t);
            }
        }
    }

    /// Sessions held by open connections or in-process callers (what
    /// `--max-sessions` counts), and of those, held by `conn`.
    fn held(&self, conn: Option<u64>) -> (usize, usize) {
        let sessions = lock(&self.inner.sessions);
        let mut n = (0, 0);
        for slot in sessions.values() {
            match *lock(&slot.owner) {
                Owner::Detached(..) => {}
                o => {
                    n.0 += 1;
                    if conn.is_some_and(|c| o == Owner::Conn(c)) {
                        n.1 += 1;
                    }
                }
            }
        }
        n
    }

    /// Frees the detached session that has waited longest (to make room).
    fn evict_detached(&self) -> bool {
        let victim = {
            let sessions = lock(&self.inner.sessions);
            sessions
                .iter()
                .filter_map(|(id, slot)| match *lock(&slot.owner) {
                    Owner::Detached(since, t) => Some((since, t, id.clone())),
                    _ => None,
                })
                .min_by(|a, b| a.0.cmp(&b.0).then_with(|| a.2.cmp(&b.2)))
        };
        let Some((_, t, id)) = victim else {
            return false;
        };
        lock(&self.inner.sessions).remove(&id);
        self.bury(id, Ended::ConnectionClosed(t));
        true
    }

    /// Writes one trace line (no-op without a trace file).
    fn trace<R: Serialize>(&self, session: &str, method: &str, args: Value, result: &SspResult<R>) {
        if let Some(t) = &self.inner.trace {
            let line = json!({
                "t_ms": self.inner.started.elapsed().as_secs_f64() * 1000.0,
                "session": session,
                "method": method,
                "args": args,
                "result": match result {
                    Ok(v) => json!({ "ok": serde_json::to_value(v).unwrap_or(Value::Null) }),
                    Err(e) => json!({ "error": { "code": e.code, "message": e.message } }),
                },
            });
            let mut w = lock(t);
            let _ = writeln!(w, "{line}");
            let _ = w.flush();
        }
    }

    fn slot(&self, session_id: &str) -> Result<Arc<Slot>, SspError> {
        if session_id.is_empty() {
            return Err(SspError::invalid("session_id is missing"));
        }
        let slot = lock(&self.inner.sessions).get(session_id).cloned();
        let Some(slot) = slot else {
            return Err(SspError::not_found(self.gone(session_id)));
        };
        if let Owner::Detached(_, t) = *lock(&slot.owner) {
            return Err(SspError::precondition(format!(
                "session '{session_id}' was detached when its connection closed at t = {t:.1} s (server time): Attach it to go on (within {} s of the close)",
                self.inner.cfg.attach_grace.as_secs_f64()
            )));
        }
        Ok(slot)
    }

    /// NOT_FOUND's words for a session that is not here.
    fn gone(&self, id: &str) -> String {
        if let Some(e) = lock(&self.inner.ended).0.get(id) {
            return format!("no session: {}", e.say(id));
        }
        // Ids are `sNNNNNN-xxxxxxxx`, N counting up: one this server never
        // reached was never created; an older one it no longer remembers
        // (past the last million) is said so.
        let n = id
            .strip_prefix('s')
            .and_then(|r| r.split('-').next())
            .and_then(|d| d.parse::<u64>().ok());
        match n {
            Some(n)
                if n < self.inner.next_id.load(Ordering::SeqCst)
                    && lock(&self.inner.ended).1.len() >= ENDED_KEPT =>
            {
                format!(
                    "no session '{id}': not created by this server, or ended longer ago than the last {ENDED_KEPT} sessions it remembers"
                )
            }
            _ => format!("no session '{id}': never created by this server"),
        }
    }

    /// Runs `f` on a session, traces the call and maps errors to statuses.
    fn with<R: Serialize>(
        &self,
        session_id: &str,
        method: &'static str,
        args: impl FnOnce() -> Value,
        stepping: bool,
        f: impl FnOnce(&mut Session) -> SspResult<R>,
    ) -> Result<R, Status> {
        let traced = self.inner.trace.is_some();
        let args = if traced { args() } else { Value::Null };
        let result = self.slot(session_id).and_then(|slot| {
            if stepping && slot.streaming.load(Ordering::SeqCst) {
                return Err(SspError::precondition(
                    "this session is driven by an open StepStream; unary stepping is refused",
                ));
            }
            let started = Instant::now();
            *lock(&slot.last_used) = started;
            let mut s = lock(&slot.session);
            let before = s.steps_executed();
            let r = f(&mut s);
            let m = &self.inner.metrics;
            m.steps
                .fetch_add(s.steps_executed() - before, Ordering::Relaxed);
            drop(s);
            m.call(method, started.elapsed());
            r
        });
        if traced {
            self.trace(session_id, method, args, &result);
        }
        result.map_err(cv::status)
    }

    /// Under paced stepping, waits (without holding the session or a
    /// runtime thread) until the wall clock reaches simulated time
    /// `sim_ms` on the session's schedule.
    async fn pace(&self, session_id: &str, sim_ms: u64) {
        let Ok(slot) = self.slot(session_id) else {
            return;
        };
        let due = lock(&slot.pacing).map(|(origin, from_ms)| {
            origin + Duration::from_millis(sim_ms.saturating_sub(from_ms))
        });
        if let Some(due) = due {
            tokio::time::sleep_until(tokio::time::Instant::from_std(due)).await;
        }
    }

    fn init_session(
        &self,
        r: pb::InitRequest,
        conn: Option<u64>,
    ) -> SspResult<litesim_ssp::InitResponse> {
        let map = match r.map {
            Some(pb::init_request::Map::MapPath(p)) => Some(self.map_under_roots(&p)?),
            Some(pb::init_request::Map::MapXodr(x)) => Some(x),
            None => None,
        };
        let req = litesim_ssp::InitRequest {
            client_name: r.client_name,
            step_size_ms: r.step_size_ms,
            map,
            profile: r.profile,
            model: r.model,
            seed: r.seed,
            options: r.options,
            traffic_lights: r
                .traffic_lights
                .into_iter()
                .map(cv::light_box)
                .collect::<SspResult<_>>()?,
            logical_lights: r.logical_lights.into_iter().map(cv::logical).collect(),
        };
        let traced_req = self
            .inner
            .trace
            .as_ref()
            .map(|_| serde_json::to_value(&req).unwrap_or(Value::Null));
        let started = Instant::now();
        let mut session = Session::new(
            &self.inner.cfg.default_profile,
            &self.inner.cfg.default_model,
            self.inner.cfg.limits,
        );
        let result = (|| {
            // At the limit, sessions whose lease ran out go first (the
            // periodic reaper may not have come round yet); detached
            // sessions do not count, but they are freed (longest waiting
            // first) when the whole table would grow past twice the limit.
            let max = self.inner.cfg.max_sessions;
            if self.held(conn).0 >= max {
                self.reap();
            }
            let (held, mine) = self.held(conn);
            if held >= max {
                return Err(SspError::exhausted(format!(
                    "the server already holds {held} sessions, its limit (--max-sessions {max}); {mine} of them belong to this connection: shut one down first"
                )));
            }
            while lock(&self.inner.sessions).len() >= 2 * max.max(1) && self.evict_detached() {}
            let mut resp = session.init(req)?;
            let n = self.inner.next_id.fetch_add(1, Ordering::SeqCst);
            let id = format!(
                "s{n:06}-{:08x}",
                (self.inner.started.elapsed().as_nanos() as u64 ^ n.wrapping_mul(0x9e37_79b9))
                    & 0xffff_ffff
            );
            // A connection that closed while the map loaded leaves its
            // session detached at once.
            let owner = match conn {
                Some(c) if lock(&self.inner.open_conns).contains(&c) => Owner::Conn(c),
                Some(_) => {
                    let now = Instant::now();
                    Owner::Detached(now, self.server_time(now))
                }
                None => Owner::Local,
            };
            if self.held(conn).0 >= max {
                return Err(SspError::exhausted(format!(
                    "the server already holds {max} sessions, its limit (--max-sessions {max})"
                )));
            }
            let mut sessions = lock(&self.inner.sessions);
            sessions.insert(
                id.clone(),
                Arc::new(Slot {
                    session: Mutex::new(std::mem::take(&mut session)),
                    owner: Mutex::new(owner),
                    last_used: Mutex::new(Instant::now()),
                    streaming: AtomicBool::new(false),
                    pacing: Mutex::new(None),
                }),
            );
            resp.session_id = id;
            self.inner.metrics.created.fetch_add(1, Ordering::Relaxed);
            Ok(resp)
        })();
        self.inner.metrics.call("init", started.elapsed());
        if let Some(args) = traced_req {
            self.trace(
                result.as_ref().map_or("", |r| r.session_id.as_str()),
                "init",
                args,
                &result,
            );
        }
        result
    }

    /// Applies one stream command and steps; per-command problems are
    /// collected, step errors are fatal.
    fn stream_step(
        &self,
        session_id: &str,
        cmd: pb::StepCommand,
    ) -> Result<pb::StepResult, Status> {
        let summary = (
            cmd.seq,
            cmd.requested_sim_time_ms,
            cmd.moves.len(),
            cmd.lights.len(),
        );
        let args = move || json!({ "seq": summary.0, "requested_sim_time_ms": summary.1, "moves": summary.2, "lights": summary.3 });
        let seq = cmd.seq;
        self.with(session_id, "step_stream", args, false, move |s| {
            let mut rejected = Vec::new();
            for (i, m) in cmd.moves.iter().enumerate() {
                if let Err(e) = apply_move(s, m) {
                    rejected.push(pb::CommandError {
                        index: i as u32,
                        code: cv::status(e.clone()).code() as i32,
                        message: e.message,
                    });
                }
            }
            for (j, l) in cmd.lights.iter().enumerate() {
                let r = cv::light_request(l).and_then(|(t, st)| s.set_traffic_light_state(t, st));
                if let Err(e) = r {
                    rejected.push(pb::CommandError {
                        index: (cmd.moves.len() + j) as u32,
                        code: cv::status(e.clone()).code() as i32,
                        message: e.message,
                    });
                }
            }
            let filter = cv::filter(cmd.state_filter)?;
            let requested = (cmd.requested_sim_time_ms != 0).then_some(cmd.requested_sim_time_ms);
            let (info, states) = s.step(requested, &filter)?;
            Ok(StreamOut {
                seq,
                sim_time_ms: info.sim_time_ms,
                step_index: info.step_index,
                states,
                rejected,
            })
        })
        .map(|o| pb::StepResult {
            seq: o.seq,
            sim_time_ms: o.sim_time_ms,
            states: o.states.iter().map(cv::state_pb).collect(),
            rejected: o.rejected,
            step_index: o.step_index,
        })
    }
}

/// tonic rejects oversized requests with `OUT_OF_RANGE`; gRPC's convention
/// (and litesim's API) is `RESOURCE_EXHAUSTED`. This rewrites exactly that
/// one case on trailers-only error responses.
fn remap_oversize<B>(mut resp: http::Response<B>) -> http::Response<B> {
    let h = resp.headers();
    let oversize = h.get("grpc-status").is_some_and(|v| v == "11")
        && h.get("grpc-message")
            .and_then(|m| m.to_str().ok())
            .is_some_and(|m| {
                m.contains("message%20length%20too%20large")
                    || m.contains("message length too large")
            });
    if oversize {
        resp.headers_mut()
            .insert("grpc-status", http::HeaderValue::from_static("8"));
    }
    resp
}

/// The encoded descriptor set of the proto (for reflection).
pub const FILE_DESCRIPTOR_SET: &[u8] =
    include_bytes!(concat!(env!("OUT_DIR"), "/ssp_descriptor.bin"));

/// The connections a listener accepts, each with TCP_NODELAY set.
///
/// Lock-step traffic is many tiny messages: without TCP_NODELAY, Nagle and
/// delayed ACKs add tens of milliseconds per call. The tonic builder's own
/// nodelay setting applies only to listeners it binds itself.
impl SspService {
    /// The metrics in Prometheus's text format (version 0.0.4).
    pub fn metrics_text(&self) -> String {
        use std::fmt::Write as _;
        let m = &self.inner.metrics;
        let (mut attached, mut detached) = (0u64, 0u64);
        for slot in lock(&self.inner.sessions).values() {
            match *lock(&slot.owner) {
                Owner::Detached(..) => detached += 1,
                _ => attached += 1,
            }
        }
        let mut t = String::new();
        let head = |t: &mut String, name: &str, kind: &str, help: &str| {
            let _ = writeln!(t, "# HELP {name} {help}");
            let _ = writeln!(t, "# TYPE {name} {kind}");
        };
        head(
            &mut t,
            "litesim_sessions_open",
            "gauge",
            "Sessions held now, by whether their connection is open.",
        );
        let _ = writeln!(t, "litesim_sessions_open{{state=\"attached\"}} {attached}");
        let _ = writeln!(t, "litesim_sessions_open{{state=\"detached\"}} {detached}");
        head(
            &mut t,
            "litesim_sessions_created_total",
            "counter",
            "Sessions created by Init.",
        );
        let _ = writeln!(
            t,
            "litesim_sessions_created_total {}",
            m.created.load(Ordering::Relaxed)
        );
        head(
            &mut t,
            "litesim_sessions_freed_total",
            "counter",
            "Sessions freed, by cause.",
        );
        let causes = ["shutdown", "connection_closed", "idle_timeout", "after_end"];
        for (k, cause) in causes.iter().enumerate() {
            let _ = writeln!(
                t,
                "litesim_sessions_freed_total{{cause=\"{cause}\"}} {}",
                m.freed[k].load(Ordering::Relaxed)
            );
        }
        head(
            &mut t,
            "litesim_steps_total",
            "counter",
            "Simulation steps run, all sessions.",
        );
        let _ = writeln!(t, "litesim_steps_total {}", m.steps.load(Ordering::Relaxed));
        head(
            &mut t,
            "litesim_call_duration_seconds",
            "histogram",
            "Time a call spent on its session, by method.",
        );
        for (method, l) in lock(&m.calls).iter() {
            let mut cum = 0;
            for (k, n) in l.buckets.iter().enumerate() {
                cum += n;
                let le = LATENCY_BUCKETS
                    .get(k)
                    .map_or("+Inf".to_string(), |b| format!("{b}"));
                let _ = writeln!(
                    t,
                    "litesim_call_duration_seconds_bucket{{method=\"{method}\",le=\"{le}\"}} {cum}"
                );
            }
            let _ = writeln!(
                t,
                "litesim_call_duration_seconds_sum{{method=\"{method}\"}} {}",
                l.sum
            );
            let _ = writeln!(
                t,
                "litesim_call_duration_seconds_count{{method=\"{method}\"}} {}",
                l.count
            );
        }
        t
    }
}

impl SspService {
    /// `path` resolved (symbolic links, `..`) if it lies under one of the
    /// map roots; otherwise PERMISSION_DENIED with one message whether or
    /// not the file exists (the server is no oracle for its disk).
    fn map_under_roots(&self, path: &str) -> SspResult<String> {
        let roots = &self.inner.roots;
        let refused = || {
            SspError::new(
                litesim_ssp::ErrorCode::PermissionDenied,
                format!(
                    "map_path is not under the server's map roots ({}); send the map inline (map_xodr), or start the server with --map-root",
                    roots
                        .iter()
                        .map(|r| r.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        };
        let p = std::path::Path::new(path);
        // Relative paths are taken from the first root.
        let p = if p.is_absolute() {
            p.to_path_buf()
        } else {
            roots.first().map_or(p.to_path_buf(), |r| r.join(p))
        };
        let under = |q: &std::path::Path| roots.iter().any(|r| q.starts_with(r));
        match std::fs::canonicalize(&p) {
            Ok(real) if under(&real) => Ok(real.display().to_string()),
            Ok(_) => Err(refused()),
            // A file that does not exist is "not found" only where its
            // folder resolves under a root; elsewhere the same refusal.
            Err(_) => match p.parent().map(std::fs::canonicalize) {
                Some(Ok(dir)) if under(&dir) => Err(SspError::not_found(format!(
                    "map_path {path}: no such file under the map root"
                ))),
                _ => Err(refused()),
            },
        }
    }
}

/// Why [`serve`] could not serve.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The service could not be set up (the RPC trace file could not be
    /// created, the current folder — the default map root — not read).
    #[error("cannot set up the service")]
    Setup(#[source] std::io::Error),
    /// The metrics listener could not bind.
    #[error("--metrics {addr}")]
    Metrics {
        /// The address asked for.
        addr: std::net::SocketAddr,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Reflection's descriptors could not be read.
    #[error("reflection")]
    Reflection(#[source] tonic_reflection::server::Error),
    /// The TLS identity cannot be used.
    #[error("TLS")]
    Tls(#[source] tonic::transport::Error),
    /// The transport failed while serving.
    #[error("serving")]
    Transport(#[source] tonic::transport::Error),
}

/// Why a [`LoopbackServer`] ended badly.
#[derive(Debug, thiserror::Error)]
pub enum LoopbackError {
    /// Its runtime could not be built.
    #[error("cannot build the server's runtime")]
    Runtime(#[source] std::io::Error),
    /// Serving failed.
    #[error(transparent)]
    Serve(#[from] ServeError),
    /// The server's thread panicked.
    #[error("the server thread panicked")]
    Panicked,
}

/// Serves the SSP API, gRPC health and reflection on `listener` until
/// `shutdown` completes. Idle sessions are reaped every second.
pub async fn serve(
    listener: tokio::net::TcpListener,
    cfg: ServerConfig,
    shutdown: impl std::future::Future<Output = ()> + Send,
) -> Result<(), ServeError> {
    let max = cfg.max_message_bytes;
    let keepalive = cfg.keepalive;
    let metrics_addr = cfg.metrics;
    let tls = cfg.tls.clone();
    let check = BearerCheck {
        expected: cfg.auth_token.as_deref().map(Arc::from),
    };
    let svc = SspService::new(cfg).map_err(ServeError::Setup)?;
    let conns = svc.clone();
    let reaper = svc.clone();
    let metrics_task = match metrics_addr {
        Some(a) => {
            let l = tokio::net::TcpListener::bind(a)
                .await
                .map_err(|source| ServeError::Metrics { addr: a, source })?;
            Some(tokio::spawn(serve_metrics(l, svc.clone())))
        }
        None => None,
    };
    let reap_task = tokio::spawn(async move {
        let mut every = tokio::time::interval(Duration::from_secs(1));
        loop {
            every.tick().await;
            reaper.reap();
        }
    });
    let (reporter, health) = tonic_health::server::health_reporter();
    reporter
        .set_serving::<SimulatorSupportServer<SspService>>()
        .await;
    // Reflection in both versions: grpcurl asks v1, older grpcurl,
    // Postman and grpcio's reflection client ask v1alpha.
    let reflection_builder = || {
        tonic_reflection::server::Builder::configure()
            .register_encoded_file_descriptor_set(FILE_DESCRIPTOR_SET)
            .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
    };
    // Health stays open (load balancers ask it); the API and reflection
    // need the token when the server has one.
    use tonic::service::interceptor::InterceptedService;
    let v1 = reflection_builder()
        .build_v1()
        .map_err(ServeError::Reflection)?;
    let v1alpha = reflection_builder()
        .build_v1alpha()
        .map_err(ServeError::Reflection)?;
    let reflection = InterceptedService::new(v1, check.clone());
    let reflection_alpha = InterceptedService::new(v1alpha, check.clone());
    let ssp = InterceptedService::new(
        SimulatorSupportServer::new(svc)
            .max_decoding_message_size(max)
            .max_encoding_message_size(usize::MAX),
        check,
    );
    let incoming = tracked_incoming(listener, conns);
    let mut builder = tonic::transport::Server::builder();
    if let Some(t) = &tls {
        let id = tonic::transport::Identity::from_pem(&t.cert, &t.key);
        builder = builder
            .tls_config(tonic::transport::ServerTlsConfig::new().identity(id))
            .map_err(ServeError::Tls)?;
    }
    let result = builder
        .tcp_nodelay(true)
        .http2_keepalive_interval(Some(keepalive))
        .http2_keepalive_timeout(Some(keepalive))
        .layer(tower::util::MapResponseLayer::new(remap_oversize))
        .add_service(health)
        .add_service(reflection)
        .add_service(reflection_alpha)
        .add_service(ssp)
        .serve_with_incoming_shutdown(incoming, shutdown)
        .await;
    reap_task.abort();
    if let Some(t) = metrics_task {
        t.abort();
    }
    result.map_err(ServeError::Transport)
}
