//! RPC tracing for any [`Ssp`]: every call the client makes — method,
//! arguments, result or error, and how long it took — as one JSON line, like
//! the seed's `--dlog_frpc trace`. Wraps an in-process session and a remote
//! one alike, so a scenario run can be traced wherever its simulator lives.
//! [`summarize`] turns such a file into counts and latencies per method.

use crate::api::*;
use crate::error::SspResult;
use crate::traffic::{BulbState, LightTarget, TrafficLightBox, TrafficLights};
use serde::Serialize;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::io::Write;
use std::time::Instant;

/// An [`Ssp`] that writes every call to `out` before returning its result.
pub struct TracingSsp<'a, W: Write> {
    inner: &'a mut dyn Ssp,
    out: W,
    seq: u64,
    /// The first write error (tracing never changes a call's result).
    pub write_error: Option<std::io::Error>,
}

impl<'a, W: Write> TracingSsp<'a, W> {
    /// Traces the calls made to `inner` into `out`.
    pub fn new(inner: &'a mut dyn Ssp, out: W) -> Self {
        Self {
            inner,
            out,
            seq: 0,
            write_error: None,
        }
    }

    /// The writer back (flushed).
    pub fn finish(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        match self.write_error.take() {
            Some(e) => Err(e),
            None => Ok(self.out),
        }
    }

    fn call<R: Serialize>(
        &mut self,
        method: &str,
        args: Value,
        f: impl FnOnce(&mut dyn Ssp) -> SspResult<R>,
    ) -> SspResult<R> {
        let started = Instant::now();
        let result = f(self.inner);
        let micros = started.elapsed().as_secs_f64() * 1e6;
        self.seq += 1;
        let outcome = match &result {
            Ok(r) => json!({ "result": serde_json::to_value(r).unwrap_or(Value::Null) }),
            Err(e) => json!({ "error": { "code": format!("{:?}", e.code), "message": e.message } }),
        };
        let mut line = json!({
            "seq": self.seq,
            "method": method,
            "args": args,
            "duration_us": (micros * 1000.0).round() / 1000.0,
        });
        if let (Some(l), Some(o)) = (line.as_object_mut(), outcome.as_object()) {
            l.extend(o.clone());
        }
        if self.write_error.is_none()
            && let Err(e) = writeln!(self.out, "{line}")
        {
            self.write_error = Some(e);
        }
        result
    }
}

impl<W: Write + Send> Ssp for TracingSsp<'_, W> {
    fn init(&mut self, req: InitRequest) -> SspResult<InitResponse> {
        let args = serde_json::to_value(&req).unwrap_or(Value::Null);
        self.call("init", args, |s| s.init(req))
    }
    fn launch_simulator(&mut self, connection_string: &str) -> SspResult<String> {
        self.call(
            "launch_simulator",
            json!({ "connection_string": connection_string }),
            |s| s.launch_simulator(connection_string),
        )
    }
    fn terminate_simulator(&mut self) -> SspResult<()> {
        self.call("terminate_simulator", Value::Null, |s| {
            s.terminate_simulator()
        })
    }
    fn start_simulation(&mut self, start_time_ms: u64) -> SspResult<()> {
        self.call(
            "start_simulation",
            json!({ "start_time_ms": start_time_ms }),
            |s| s.start_simulation(start_time_ms),
        )
    }
    fn wait_start_simulation(&mut self, max_wait_ms: u32) -> SspResult<u64> {
        self.call(
            "wait_start_simulation",
            json!({ "max_wait_ms": max_wait_ms }),
            |s| s.wait_start_simulation(max_wait_ms),
        )
    }
    fn end_simulation(&mut self, reason: &str) -> SspResult<u64> {
        self.call("end_simulation", json!({ "reason": reason }), |s| {
            s.end_simulation(reason)
        })
    }
    fn start_step(&mut self, requested_sim_time_ms: Option<u64>) -> SspResult<u64> {
        self.call(
            "start_step",
            json!({ "requested_sim_time_ms": requested_sim_time_ms }),
            |s| s.start_step(requested_sim_time_ms),
        )
    }
    fn wait_step(&mut self, max_wait_ms: u32) -> SspResult<StepInfo> {
        self.call("wait_step", json!({ "max_wait_ms": max_wait_ms }), |s| {
            s.wait_step(max_wait_ms)
        })
    }
    fn get_actors_states(&mut self, filter: &ActorFilter) -> SspResult<Vec<ReportedState>> {
        let args = serde_json::to_value(filter).unwrap_or(Value::Null);
        self.call("get_actors_states", args, |s| s.get_actors_states(filter))
    }
    fn create_actor(&mut self, req: CreateActor) -> SspResult<ActualDescription> {
        let args = serde_json::to_value(&req).unwrap_or(Value::Null);
        self.call("create_actor", args, |s| s.create_actor(req))
    }
    fn destroy_actor(&mut self, actor_id: &str) -> SspResult<()> {
        self.call("destroy_actor", json!({ "actor_id": actor_id }), |s| {
            s.destroy_actor(actor_id)
        })
    }
    fn set_actor_params(
        &mut self,
        actor_id: &str,
        params: BTreeMap<String, String>,
        controls: Option<ActorControls>,
    ) -> SspResult<()> {
        let args = json!({ "actor_id": actor_id, "params": params, "controls": controls });
        self.call("set_actor_params", args, |s| {
            s.set_actor_params(actor_id, params, controls)
        })
    }
    fn set_weather(&mut self, weather: Weather) -> SspResult<Weather> {
        let args = serde_json::to_value(&weather).unwrap_or(Value::Null);
        self.call("set_weather", args, |s| s.set_weather(weather))
    }
    fn set_time_of_day(&mut self, tod: TimeOfDay) -> SspResult<()> {
        let args = serde_json::to_value(tod).unwrap_or(Value::Null);
        self.call("set_time_of_day", args, |s| s.set_time_of_day(tod))
    }
    fn sim_command(&mut self, command: &str, args: &[String]) -> SspResult<String> {
        self.call(
            "sim_command",
            json!({ "command": command, "args": args }),
            |s| s.sim_command(command, args),
        )
    }
    fn set_xy_trajectory(&mut self, actor_id: &str, traj: XyTrajectory) -> SspResult<()> {
        let args = json!({ "actor_id": actor_id, "trajectory": traj });
        self.call("set_xy_trajectory", args, |s| {
            s.set_xy_trajectory(actor_id, traj)
        })
    }
    fn set_dynamic_move(
        &mut self,
        actor_id: &str,
        cmd: DynamicMove,
        valid_until_ms: u64,
    ) -> SspResult<()> {
        let args =
            json!({ "actor_id": actor_id, "command": cmd, "valid_until_ms": valid_until_ms });
        self.call("set_dynamic_move", args, |s| {
            s.set_dynamic_move(actor_id, cmd, valid_until_ms)
        })
    }
    fn set_external_controller(&mut self, actor_id: &str, ext: ExternalMove) -> SspResult<()> {
        let args = json!({ "actor_id": actor_id, "controller": ext });
        self.call("set_external_controller", args, |s| {
            s.set_external_controller(actor_id, ext)
        })
    }
    fn list_traffic_lights(&mut self) -> SspResult<TrafficLights> {
        self.call("list_traffic_lights", Value::Null, |s| {
            s.list_traffic_lights()
        })
    }
    fn set_traffic_light_state(
        &mut self,
        target: LightTarget,
        states: Vec<BulbState>,
    ) -> SspResult<Vec<TrafficLightBox>> {
        let args = json!({ "target": target, "states": states });
        self.call("set_traffic_light_state", args, |s| {
            s.set_traffic_light_state(target, states)
        })
    }
    fn step_many(
        &mut self,
        steps: u32,
        filter: &ActorFilter,
    ) -> SspResult<Vec<(StepInfo, Vec<ReportedState>)>> {
        let args = json!({ "steps": steps, "filter": filter });
        self.call("step_many", args, |s| s.step_many(steps, filter))
    }
    fn step(
        &mut self,
        requested_sim_time_ms: Option<u64>,
        filter: &ActorFilter,
    ) -> SspResult<(StepInfo, Vec<ReportedState>)> {
        let args = json!({ "requested_sim_time_ms": requested_sim_time_ms, "filter": filter });
        self.call("step", args, |s| s.step(requested_sim_time_ms, filter))
    }
}

/// Calls of one method in a trace.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MethodStats {
    /// Method.
    pub method: String,
    /// Calls.
    pub calls: u64,
    /// Calls that returned an error.
    pub errors: u64,
    /// Median duration (µs).
    pub p50_us: f64,
    /// 99th percentile (µs).
    pub p99_us: f64,
    /// Longest (µs).
    pub max_us: f64,
    /// Sum (µs).
    pub total_us: f64,
}

/// Counts and latencies per method of a trace (JSON lines as written by
/// [`TracingSsp`] or `litesim serve --trace-rpc`), by method name; lines
/// that are not JSON objects with a `method` are counted in the second
/// value.
pub fn summarize(text: &str) -> (Vec<MethodStats>, usize) {
    let mut by: BTreeMap<String, (Vec<f64>, u64)> = BTreeMap::new();
    let mut skipped = 0;
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let Ok(v) = serde_json::from_str::<Value>(line) else {
            skipped += 1;
            continue;
        };
        let Some(m) = v.get("method").and_then(Value::as_str) else {
            skipped += 1;
            continue;
        };
        let e = by.entry(m.to_string()).or_default();
        e.0.push(v.get("duration_us").and_then(Value::as_f64).unwrap_or(0.0));
        let failed = v.get("error").is_some_and(|e| !e.is_null())
            || v.pointer("/result/error").is_some_and(|e| !e.is_null());
        e.1 += u64::from(failed);
    }
    let stats = by
        .into_iter()
        .map(|(method, (mut d, errors))| {
            d.sort_by(f64::total_cmp);
            let q = |p: f64| d[((d.len() - 1) as f64 * p).round() as usize];
            MethodStats {
                calls: d.len() as u64,
                errors,
                p50_us: q(0.5),
                p99_us: q(0.99),
                max_us: d[d.len() - 1],
                total_us: d.iter().sum(),
                method,
            }
        })
        .collect();
    (stats, skipped)
}
