//! Driver calibration: tunes the dynamic drivers' gains for a profile's
//! default vehicle and step size. A reference manoeuvre (speed steps up and
//! down, then a 3.5 m lane change) is driven in-process with each candidate
//! of a grid; throttle gains are chosen first (speed tracking), then
//! steering gains (path tracking). The result is the `[calibration]` table
//! a profile uses, written as TOML.

use crate::ScenarioError;
use crate::elab::ActorKind;
use crate::exec::{DriveMode, ExecConfig, execute};
use crate::plan::{ActorPlan, Plan, PlanSample};
use litesim_core::math;
use litesim_ssp::profile::{Calibration, PidGains, Profile};
use serde::Serialize;

/// One evaluated candidate.
#[derive(Clone, Debug, Serialize)]
pub struct Trial {
    /// Gains tried.
    pub calibration: Calibration,
    /// Largest speed error (m/s).
    pub max_speed_error: f64,
    /// RMS path error (m).
    pub rms_path_error: f64,
    /// Score (lower is better).
    pub score: f64,
}

/// The outcome.
#[derive(Clone, Debug, Serialize)]
pub struct Calibrated {
    /// Profile.
    pub profile: String,
    /// Best gains.
    pub best: Trial,
    /// The profile's current gains on the same manoeuvre.
    pub before: Trial,
    /// Candidates tried.
    pub trials: usize,
}

/// The reference manoeuvre at the given step.
pub fn reference_plan(step_s: f64) -> Plan {
    let dt = step_s * (0.1 / step_s).round().max(1.0);
    let duration = 16.0;
    let n = (duration / dt).ceil() as usize + 1;
    let mut samples = Vec::with_capacity(n);
    let (mut x, mut v): (f64, f64) = (0.0, 5.0);
    for k in 0..n {
        let t = k as f64 * dt;
        let target = if t < 7.0 { 15.0 } else { 8.0 };
        let a = if (target - v).abs() < 1e-9 {
            0.0
        } else if target > v {
            2.5f64.min((target - v) / dt)
        } else {
            -(4.0f64.min((v - target) / dt))
        };
        // Lane change between 10 s and 14 s: smoothstep over 3.5 m.
        let u = ((t - 10.0) / 4.0).clamp(0.0, 1.0);
        let y = 3.5 * u * u * (3.0 - 2.0 * u);
        let dy = 3.5 * 6.0 * u * (1.0 - u) / 4.0;
        samples.push(PlanSample {
            t,
            x,
            y,
            yaw: math::atan(dy / v.max(0.1)),
            v,
            a,
        });
        x += v * dt;
        v += a * dt;
    }
    Plan {
        dt,
        duration,
        actors: vec![ActorPlan {
            samples,
            ..ActorPlan::new(
                "calibration".into(),
                ActorKind::Vehicle,
                true,
                "car".into(),
                (4.6, 1.9),
            )
        }],
        phases: Vec::new(),
        violations: Vec::new(),
        lights: Vec::new(),
        goals: Vec::new(),
        lane_goals: Vec::new(),
        side_follows: Vec::new(),
        conditions: Vec::new(),
        ids: Default::default(),
        events: Default::default(),
        notes: Vec::new(),
    }
}

fn trial(profile: &Profile, plan: &Plan, c: &Calibration) -> Result<Trial, ScenarioError> {
    let mut ssp = crate::in_process();
    let cfg = ExecConfig {
        profile: profile.name.clone(),
        model: String::new(),
        seed: 1,
        step_ms: profile.step_ms,
        map_text: None,
        mode: DriveMode::Dynamic,
        calibration: Some(*c),
        record: false,
        test_name: String::new(),
        map_path: String::new(),
        map: None,
        sut_timeout: 1.0,
        realtime: None,
        covers: Vec::new(),
        values: Default::default(),
    };
    let ex = execute(&mut ssp, plan, None, &cfg, None, None)?;
    let a = &ex.kpis.actors[0];
    let score = a.rms_path_error + 0.3 * a.max_speed_error;
    Ok(Trial {
        calibration: *c,
        max_speed_error: a.max_speed_error,
        rms_path_error: a.rms_path_error,
        score: if score.is_finite() {
            score
        } else {
            f64::INFINITY
        },
    })
}

/// Calibrates a built-in profile's drivers.
pub fn calibrate(profile_name: &str) -> Result<Calibrated, ScenarioError> {
    let profile = Profile::builtin(profile_name).map_err(ScenarioError::Ssp)?;
    let plan = reference_plan(f64::from(profile.step_ms) / 1000.0);
    let before = trial(&profile, &plan, &profile.calibration)?;
    let mut best = before.clone();
    let mut trials = 1;
    let g = |kp: f64, ki: f64, kd: f64| PidGains { kp, ki, kd };
    for kp in [0.05, 0.1, 0.2, 0.4, 0.8, 1.6] {
        for ki in [0.0, 0.02, 0.05, 0.1, 0.2] {
            let mut c = best.calibration;
            c.throttle = g(kp, ki, 0.0);
            c.brake = g(kp, 0.0, 0.0);
            let t = trial(&profile, &plan, &c)?;
            trials += 1;
            if t.score < best.score {
                best = t;
            }
        }
    }
    for kp in [0.02, 0.05, 0.1, 0.2, 0.4, 0.8] {
        for kd in [0.0, 0.05, 0.1, 0.2] {
            let mut c = best.calibration;
            c.steering = g(kp, 0.0, kd);
            let t = trial(&profile, &plan, &c)?;
            trials += 1;
            if t.score < best.score {
                best = t;
            }
        }
    }
    best.calibration.calibrated_step_ms = profile.step_ms;
    Ok(Calibrated {
        profile: profile.name,
        best,
        before,
        trials,
    })
}

/// The TOML a profile's calibration file holds.
pub fn to_toml(c: &Calibrated) -> String {
    #[derive(Serialize)]
    struct File<'a> {
        calibration: &'a Calibration,
    }
    let body = toml::to_string(&File {
        calibration: &c.best.calibration,
    })
    .unwrap_or_default();
    format!(
        "# litesim calibration for profile '{}' (written by `litesim calibrate`)\n# reference manoeuvre: speed steps 5→15→8 m/s and a 3.5 m lane change\n# before: rms path error {:.4} m, max speed error {:.4} m/s\n# after:  rms path error {:.4} m, max speed error {:.4} m/s ({} candidates)\n{body}",
        c.profile,
        c.before.rms_path_error,
        c.before.max_speed_error,
        c.best.rms_path_error,
        c.best.max_speed_error,
        c.trials
    )
}

/// Reads a calibration file written by [`to_toml`].
pub fn from_toml(text: &str) -> Result<Calibration, ScenarioError> {
    #[derive(serde::Deserialize)]
    struct File {
        calibration: Calibration,
    }
    toml::from_str::<File>(text)
        .map(|f| f.calibration)
        .map_err(|e| ScenarioError::Io(format!("calibration: {e}")))
}
