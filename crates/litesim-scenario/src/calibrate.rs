//! Driver calibration: tunes every gain of the dynamic drivers (throttle,
//! brake and steering P/I/D, see docs/drivers.md) for a profile's default
//! vehicle and step size.
//!
//! Five reference manoeuvres are driven in-process: a launch from rest, a
//! stop, speed steps, a lane change and a curve. The gains are tuned on the
//! first, third and fourth ([`TUNED_ON`]) by coordinate descent (each gain
//! scaled up and down in turn, kept where the score falls, up to six rounds);
//! the stop and the curve ([`HELD_OUT`]) are never used for tuning and
//! report how the gains do on manoeuvres they were not tuned on. The result
//! is the `[calibration]` table a profile uses, written as TOML.

use crate::ScenarioError;
use crate::plan::{ActorPlan, Plan, PlanSample};
use crate::runtime::{DriveMode, ExecConfig, execute};
use litesim_core::ActorClass;
use litesim_core::math;
use litesim_ssp::profile::{Calibration, Profile};
use serde::Serialize;

/// A reference manoeuvre.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Manoeuvre {
    /// From rest to 15 m/s at 2.5 m/s², then hold.
    Launch,
    /// From 15 m/s to a stop at 4 m/s², then stand.
    Stop,
    /// 5 → 15 → 8 m/s.
    SpeedSteps,
    /// A 3.5 m lane change over 4 s at 12 m/s.
    LaneChange,
    /// A quarter circle of 40 m radius at 10 m/s between straights.
    Curve,
}

/// The manoeuvres the gains are tuned on.
pub const TUNED_ON: [Manoeuvre; 3] = [
    Manoeuvre::Launch,
    Manoeuvre::SpeedSteps,
    Manoeuvre::LaneChange,
];

/// The manoeuvres kept out of tuning (evaluation only).
pub const HELD_OUT: [Manoeuvre; 2] = [Manoeuvre::Stop, Manoeuvre::Curve];

/// Tracking errors over a set of manoeuvres: RMS values are the root of
/// the mean square over all of them, maxima the largest.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Errors {
    /// RMS path error (m).
    pub rms_path_error: f64,
    /// Largest path error (m).
    pub max_path_error: f64,
    /// RMS speed error (m/s).
    pub rms_speed_error: f64,
    /// Largest speed error (m/s).
    pub max_speed_error: f64,
}

impl Errors {
    /// What the search minimises (m).
    pub fn score(&self) -> f64 {
        let s = self.rms_path_error
            + 0.1 * self.max_path_error
            + 0.5 * self.rms_speed_error
            + 0.1 * self.max_speed_error;
        if s.is_finite() { s } else { f64::INFINITY }
    }
}

/// Gains and how they track.
#[derive(Clone, Debug, Serialize)]
pub struct Trial {
    /// Gains tried.
    pub calibration: Calibration,
    /// On the manoeuvres tuned on.
    pub tuned: Errors,
    /// On the held-out manoeuvres.
    pub held_out: Errors,
    /// Score on the tuned manoeuvres (lower is better).
    pub score: f64,
}

/// The outcome.
#[derive(Clone, Debug, Serialize)]
pub struct Calibrated {
    /// Profile.
    pub profile: String,
    /// Best gains.
    pub best: Trial,
    /// The starting gains on the same manoeuvres.
    pub before: Trial,
    /// Candidates tried.
    pub trials: usize,
}

/// A reference manoeuvre's plan at the given step.
pub fn reference_plan(m: Manoeuvre, step_s: f64) -> Plan {
    let dt = crate::plan::plan_step(step_s);
    let (v0, duration): (f64, f64) = match m {
        Manoeuvre::Launch => (0.0, 12.0),
        Manoeuvre::Stop => (15.0, 10.0),
        Manoeuvre::SpeedSteps => (5.0, 14.0),
        Manoeuvre::LaneChange => (12.0, 9.0),
        Manoeuvre::Curve => (10.0, 14.0),
    };
    let target = |t: f64| match m {
        Manoeuvre::Launch => {
            if t < 1.0 {
                0.0
            } else {
                15.0
            }
        }
        Manoeuvre::Stop => {
            if t < 2.0 {
                15.0
            } else {
                0.0
            }
        }
        Manoeuvre::SpeedSteps => {
            if t < 7.0 {
                15.0
            } else {
                8.0
            }
        }
        Manoeuvre::LaneChange | Manoeuvre::Curve => v0,
    };
    let radius = 40.0;
    let kappa = |s: f64| {
        let arc = std::f64::consts::FRAC_PI_2 * radius;
        if m == Manoeuvre::Curve && (30.0..30.0 + arc).contains(&s) {
            1.0 / radius
        } else {
            0.0
        }
    };
    // Lateral offset and its rate: a smoothstep over 3.5 m from 2 to 6 s.
    let lateral = |t: f64| {
        if m != Manoeuvre::LaneChange {
            return (0.0, 0.0);
        }
        let u = ((t - 2.0) / 4.0).clamp(0.0, 1.0);
        (
            3.5 * u * u * (3.0 - 2.0 * u),
            3.5 * 6.0 * u * (1.0 - u) / 4.0,
        )
    };
    let n = (duration / dt).ceil() as usize + 1;
    let mut samples = Vec::with_capacity(n);
    let (mut s, mut v, mut bx, mut by, mut bh) = (0.0f64, v0, 0.0f64, 0.0f64, 0.0f64);
    for k in 0..n {
        let t = k as f64 * dt;
        let goal = target(t);
        let a = if (goal - v).abs() < 1e-9 {
            0.0
        } else if goal > v {
            2.5f64.min((goal - v) / dt)
        } else {
            -(4.0f64.min((v - goal) / dt))
        };
        let (l, dl) = lateral(t);
        let (sh, ch) = math::sin_cos(bh);
        samples.push(PlanSample {
            t,
            x: bx - sh * l,
            y: by + ch * l,
            yaw: bh + math::atan(dl / v.max(0.1)),
            v,
            a,
        });
        let ds = v * dt + 0.5 * a * dt * dt;
        let k = kappa(s);
        let (sm, cm) = math::sin_cos(bh + 0.5 * k * ds);
        bx += ds * cm;
        by += ds * sm;
        bh += k * ds;
        s += ds;
        v = (v + a * dt).max(0.0);
    }
    Plan {
        dt,
        duration,
        actors: vec![ActorPlan {
            samples,
            ..ActorPlan::new(
                "calibration".into(),
                ActorClass::Vehicle,
                true,
                "car".into(),
                (4.6, 1.9),
            )
        }],
        phases: Vec::new(),
        violations: Vec::new(),
        unplaced: Vec::new(),
        lights: Vec::new(),
        environment: Vec::new(),
        exact: std::collections::BTreeMap::new(),
        goals: Vec::new(),
        keeps: Vec::new(),
        reckless: Vec::new(),
        lane_goals: Vec::new(),
        side_follows: Vec::new(),
        conditions: Vec::new(),
        ids: Default::default(),
        events: Default::default(),
        notes: Vec::new(),
    }
}

/// Tracking errors of `c` on each of `set`, combined.
pub fn errors(
    profile: &Profile,
    set: &[Manoeuvre],
    c: &Calibration,
) -> Result<Errors, ScenarioError> {
    let mut e = Errors::default();
    let (mut sq_p, mut sq_v) = (0.0, 0.0);
    for &m in set {
        let plan = reference_plan(m, f64::from(profile.step_ms) / 1000.0);
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
            observer: None,
            test_name: String::new(),
            map_path: String::new(),
            map: None,
            sut_timeout: 1.0,
            realtime: None,
            covers: Vec::new(),
            values: Default::default(),
            people_yield: false,
            conflict_areas: Default::default(),
        };
        let ex = execute(&mut ssp, plan, cfg, None, None, None)?.ex;
        let a = &ex.kpis.actors[0];
        sq_p += a.rms_path_error.powi(2);
        sq_v += a.rms_speed_error.powi(2);
        e.max_path_error = e.max_path_error.max(a.max_path_error);
        e.max_speed_error = e.max_speed_error.max(a.max_speed_error);
    }
    let n = set.len().max(1) as f64;
    e.rms_path_error = (sq_p / n).sqrt();
    e.rms_speed_error = (sq_v / n).sqrt();
    Ok(e)
}

fn trial(profile: &Profile, c: &Calibration) -> Result<Trial, ScenarioError> {
    let tuned = errors(profile, &TUNED_ON, c)?;
    let held_out = errors(profile, &HELD_OUT, c)?;
    Ok(Trial {
        calibration: *c,
        tuned,
        held_out,
        score: tuned.score(),
    })
}

/// Calibrates a built-in profile's drivers, starting from its gains.
pub fn calibrate(profile_name: &str) -> Result<Calibrated, ScenarioError> {
    let profile = Profile::builtin(profile_name).map_err(ScenarioError::Ssp)?;
    let start = profile.calibration;
    calibrate_from(&profile, start)
}

/// `x` to three significant digits: gains a person can read and write.
fn three_digits(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(2 - litesim_core::math::log10(x.abs()).floor() as i32);
    (x * scale).round() / scale
}

/// The nine gains of a calibration, in search order.
fn gain_mut(c: &mut Calibration, k: usize) -> &mut f64 {
    let pid = match k / 3 {
        0 => &mut c.throttle,
        1 => &mut c.brake,
        _ => &mut c.steering,
    };
    match k % 3 {
        0 => &mut pid.kp,
        1 => &mut pid.ki,
        _ => &mut pid.kd,
    }
}

/// Calibrates `profile`'s drivers starting from `start` (coordinate
/// descent over all nine gains on [`TUNED_ON`]).
pub fn calibrate_from(profile: &Profile, start: Calibration) -> Result<Calibrated, ScenarioError> {
    let before = trial(profile, &start)?;
    let mut best_c = start;
    let mut best = before.score;
    let mut trials = 1;
    for _round in 0..6 {
        let mut moved = false;
        for k in 0..9 {
            let now = *gain_mut(&mut best_c, k);
            let candidates: Vec<f64> = if now == 0.0 {
                // A gain at zero is tried at small values of its kind.
                match k % 3 {
                    0 => vec![0.05, 0.2],
                    1 => vec![0.01, 0.05],
                    _ => vec![0.005, 0.02],
                }
            } else {
                let mut v = vec![now * 0.5, now * 0.75, now * 1.33, now * 2.0];
                // Proportional gains stay: without one a loop leaves a
                // steady error uncorrected (the manoeuvres may not show it).
                if k % 3 != 0 {
                    v.push(0.0);
                }
                v
            };
            for v in candidates {
                let mut c = best_c;
                *gain_mut(&mut c, k) = three_digits(v);
                let sc = errors(profile, &TUNED_ON, &c)?.score();
                trials += 1;
                if sc < best - 1e-9 {
                    best = sc;
                    best_c = c;
                    moved = true;
                }
            }
        }
        if !moved {
            break;
        }
    }
    best_c.calibrated_step_ms = profile.step_ms;
    Ok(Calibrated {
        profile: profile.name.clone(),
        best: trial(profile, &best_c)?,
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
        "# litesim calibration for profile '{}' (written by `litesim calibrate`, {} candidates)\n# tuned on launch, speed steps, lane change; held out: stop, curve\n{}{body}",
        c.profile,
        c.trials,
        report(c)
            .lines()
            .map(|l| format!("# {l}\n"))
            .collect::<String>()
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
        .map_err(|e| ScenarioError::format("calibration", e))
}

/// A table of the errors before and after, on the tuned and the held-out
/// manoeuvres.
pub fn report(c: &Calibrated) -> String {
    let row = |name: &str, b: &Errors, a: &Errors| {
        format!(
            "{name:<9} rms path {:.4} → {:.4} m, max path {:.4} → {:.4} m, rms speed {:.4} → {:.4} m/s, max speed {:.4} → {:.4} m/s\n",
            b.rms_path_error,
            a.rms_path_error,
            b.max_path_error,
            a.max_path_error,
            b.rms_speed_error,
            a.rms_speed_error,
            b.max_speed_error,
            a.max_speed_error
        )
    };
    row("tuned", &c.before.tuned, &c.best.tuned)
        + &row("held out", &c.before.held_out, &c.best.held_out)
}
