//! Real time for hardware in the loop: each simulation step is released at
//! its wall-clock time (start + k·step), so a test of 1 ms steps takes as
//! long as it simulates. Pacing never changes results — the same steps run
//! in the same order — it only decides *when*; what happens when a step is
//! late is the [`Policy`]. The wall clock is read here and nowhere else in
//! the engine.

use serde::Serialize;
use std::time::{Duration, Instant};

/// What a late step does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Policy {
    /// Run late steps back to back until the schedule is met again.
    #[default]
    CatchUp,
    /// Give up the missed slots: the schedule restarts from the late step.
    Skip,
    /// Stop the run with a verdict naming the first overrun.
    Fail,
}

impl std::str::FromStr for Policy {
    type Err = UnknownPolicy;
    fn from_str(s: &str) -> Result<Self, UnknownPolicy> {
        match s {
            "catch-up" => Ok(Policy::CatchUp),
            "skip" => Ok(Policy::Skip),
            "fail" => Ok(Policy::Fail),
            other => Err(UnknownPolicy(other.to_string())),
        }
    }
}

/// A realtime policy's name that is none of litesim's.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("realtime policy '{0}': expected skip, catch-up or fail")]
pub struct UnknownPolicy(pub String);

/// A step released later than one step after it was due, under
/// [`Policy::Fail`].
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "realtime overrun at t={t:.3} s: the step was released {late_ms:.2} ms late (the step is {step_ms} ms)"
)]
pub struct Overrun {
    /// The step's simulated time (s).
    pub t: f64,
    /// How late it was released (ms).
    pub late_ms: f64,
    /// The step (ms).
    pub step_ms: u32,
}

/// How well a run kept pace (in the summary).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    /// The policy.
    pub policy: Policy,
    /// Step (ms).
    pub step_ms: u32,
    /// Steps released.
    pub steps: u64,
    /// Median lateness of a step's release (ms).
    pub lateness_p50_ms: f64,
    /// 99th percentile (ms).
    pub lateness_p99_ms: f64,
    /// Largest (ms).
    pub lateness_max_ms: f64,
    /// Steps released more than one step late.
    pub overruns: u64,
    /// The first overrun: (simulation time s, lateness ms).
    pub first_overrun: Option<(f64, f64)>,
    /// Wall-clock time of the run's steps (s).
    pub wall_s: f64,
}

/// Releases steps at their wall-clock times.
#[derive(Debug)]
pub struct Pacer {
    policy: Policy,
    step: Duration,
    step_ms: u32,
    start: Option<Instant>,
    /// Slot of the schedule's origin (moves under `Skip`).
    origin_k: u64,
    late: Vec<f64>,
    overruns: u64,
    first_overrun: Option<(f64, f64)>,
}

impl Pacer {
    /// For steps of `step_ms`.
    pub fn new(step_ms: u32, policy: Policy) -> Self {
        Pacer {
            policy,
            step: Duration::from_millis(u64::from(step_ms)),
            step_ms,
            start: None,
            origin_k: 0,
            late: Vec::new(),
            overruns: 0,
            first_overrun: None,
        }
    }

    /// Waits until step `k` is due; `Err` (policy `Fail`) names the overrun.
    pub fn release(&mut self, k: u64) -> Result<(), Overrun> {
        let start = *self.start.get_or_insert_with(Instant::now);
        let due = start + self.step * (k - self.origin_k) as u32;
        let mut now = Instant::now();
        if now < due {
            // Sleep most of the wait, then spin the last stretch: a sleep
            // overshoots by tens of µs on a busy VM.
            let left = due - now;
            if left > Duration::from_micros(300) {
                std::thread::sleep(left - Duration::from_micros(200));
            }
            while Instant::now() < due {
                std::hint::spin_loop();
            }
            now = Instant::now();
        }
        let late = now.saturating_duration_since(due);
        let late_ms = late.as_secs_f64() * 1000.0;
        self.late.push(late_ms);
        if late > self.step {
            self.overruns += 1;
            let t = k as f64 * f64::from(self.step_ms) / 1000.0;
            self.first_overrun.get_or_insert((t, late_ms));
            match self.policy {
                Policy::Fail => {
                    return Err(Overrun {
                        t,
                        late_ms,
                        step_ms: self.step_ms,
                    });
                }
                Policy::Skip => {
                    // Restart the schedule here: the missed slots are gone.
                    self.start = Some(now);
                    self.origin_k = k;
                }
                Policy::CatchUp => {}
            }
        }
        Ok(())
    }

    /// The figures so far.
    pub fn stats(&self) -> Stats {
        let mut d = self.late.clone();
        d.sort_by(f64::total_cmp);
        let q = |p: f64| {
            if d.is_empty() {
                0.0
            } else {
                d[((d.len() - 1) as f64 * p).round() as usize]
            }
        };
        Stats {
            policy: self.policy,
            step_ms: self.step_ms,
            steps: d.len() as u64,
            lateness_p50_ms: q(0.5),
            lateness_p99_ms: q(0.99),
            lateness_max_ms: d.last().copied().unwrap_or(0.0),
            overruns: self.overruns,
            first_overrun: self.first_overrun,
            wall_s: self.start.map_or(0.0, |s| s.elapsed().as_secs_f64()),
        }
    }
}
