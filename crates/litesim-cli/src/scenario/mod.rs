//! `litesim run`, `litesim batch`, `litesim merge`, `litesim calibrate`.

pub use batches::*;

use anyhow::{Context, Result, anyhow, bail};
use litesim_log::{ActorSample, LogRecorder, SimulationLog};
use litesim_scenario::sut::SutChoice;
use litesim_scenario::{DriveMode, LoadOptions, RunOptions, Verdict, batch, calibrate, plan::Plan};
use std::path::{Path, PathBuf};

/// A value on the command line that cannot be used (`--seeds abc`, an
/// unknown `--sut`): `litesim` exits with 64, as for the errors its
/// argument parser finds, so that scripts can tell a mistyped command from
/// a run that could not run (1) or failed (2).
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// A [`UsageError`] from a format string.
macro_rules! usage {
    ($($arg:tt)*) => {
        anyhow::Error::new(UsageError(format!($($arg)*)))
    };
}

// After `usage!`: the submodules use it.
mod batches;
mod run;
mod stream;
pub use run::*;
use stream::*;

/// Options shared by `run` and `batch`.
#[derive(clap::Args, Clone, Debug)]
pub struct Common {
    /// Import search paths.
    #[arg(short = 'I', value_name = "DIR")]
    pub include: Vec<PathBuf>,
    /// Map file overriding the test's `test_config.map`.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// OSC dialect: auto (default: CARLA's when the test imports its
    /// `basic.osc` or declares `actor Path`), litesim or carla.
    #[arg(long, default_value = "auto", value_parser = ["auto", "litesim", "carla"])]
    pub dialect: String,
    /// Folder of OpenDRIVE maps for a CARLA scenario's
    /// `path.set_map("Town04")` (Town04.xodr). Default: the test's folder,
    /// then maps/ in it and in each folder above it.
    #[arg(long, value_name = "DIR")]
    pub map_dir: Option<PathBuf>,
    /// Drive actors dynamically (pedals and steering) instead of
    /// kinematically. Default: the test's configuration (the seed's dummy
    /// configuration is dynamic), else kinematic.
    #[arg(long, conflicts_with = "kinematic")]
    pub dynamic: bool,
    /// Drive actors kinematically (trajectories) even where the test's
    /// configuration is dynamic.
    #[arg(long)]
    pub kinematic: bool,
    /// What drives sut.car: planned (its plan; default), acc (the
    /// reference adaptive cruise, ISO 15622 envelope), acc-aeb (with an
    /// emergency-braking stage), fmt-mpc (FMT* + MPC) or grpc://HOST:PORT
    /// (an external process serving litesim.sut.v1).
    #[arg(long, default_value = "planned", value_name = "NAME")]
    pub sut: String,
    /// What drives the other vehicles: driver (default: a driver each —
    /// car-following, the plan's lanes and speeds as goals, gap goals
    /// pursued until their phase ends) or planned (each replays its plan
    /// exactly, as before drivers).
    #[arg(long, default_value = "driver", value_name = "NAME", value_parser = ["driver", "planned"])]
    pub npc: String,
    /// Seconds an external SUT may take per call (default: the test's
    /// `sut_timeout`, else 1).
    #[arg(long, value_name = "S")]
    pub sut_timeout: Option<f64>,
    /// Folder of driver calibrations (`PROFILE.toml` from `litesim
    /// calibrate`). Default: `calibration/` in the test's folder or the
    /// nearest ancestor that has one — never the current directory.
    #[arg(long, value_name = "DIR")]
    pub calibration_dir: Option<PathBuf>,
    /// The simulation step in ms (1 to 1000), overriding the test's and
    /// the profile's (an OpenSCENARIO XML file has no step of its own).
    #[arg(long, value_name = "MS", value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub step_ms: Option<u32>,
    /// OpenSCENARIO XML: the entity a system under test drives (default:
    /// the one whose ObjectController is an ExternalController).
    #[arg(long, value_name = "NAME")]
    pub ego: Option<String>,
    /// OpenSCENARIO XML: sets a global parameter (repeatable), as a
    /// distribution's variation does.
    #[arg(long = "param", value_name = "NAME=VALUE", value_parser = param_arg)]
    pub params: Vec<(String, String)>,
}

/// `NAME=VALUE` of `--param`.
fn param_arg(s: &str) -> std::result::Result<(String, String), String> {
    match s.split_once('=') {
        Some((n, v)) if !n.trim().is_empty() => Ok((n.trim().to_string(), v.to_string())),
        _ => Err(format!("'{s}': expected NAME=VALUE")),
    }
}

impl Common {
    fn load(&self) -> LoadOptions {
        LoadOptions {
            include: self.include.clone(),
            map: self.map.clone(),
            env: None,
            dialect: dialect_choice(&self.dialect),
            map_dir: self.map_dir.clone(),
            params: self.params.clone(),
            ego: self.ego.clone(),
        }
    }
    /// The `--npc` choice.
    pub fn npc(&self) -> litesim_scenario::Npc {
        litesim_scenario::Npc::parse(&self.npc).unwrap_or_default()
    }
    /// The `--sut` choice; an unknown name lists the valid ones.
    pub fn sut(&self) -> Result<SutChoice> {
        sut_choice(&self.sut)
    }
    fn sut_timeout(&self) -> Result<Option<f64>> {
        match self.sut_timeout {
            Some(t) if !(t.is_finite() && t > 0.0 && t <= 3600.0) => {
                Err(usage!("--sut-timeout {t}: expected seconds in (0, 3600]"))
            }
            t => Ok(t),
        }
    }
    fn mode(&self) -> Option<DriveMode> {
        if self.dynamic {
            Some(DriveMode::Dynamic)
        } else if self.kinematic {
            Some(DriveMode::Kinematic)
        } else {
            None
        }
    }
}

/// A `--dialect` value (`auto`: detect).
pub fn dialect_choice(name: &str) -> Option<litesim_osc::Dialect> {
    name.parse().ok()
}

/// Parses a `--sut` value.
pub fn sut_choice(name: &str) -> Result<SutChoice> {
    if let Some(c) = litesim_grpc::sut::choice_by_name(name).map_err(|e| usage!("--sut {e}"))? {
        return Ok(c);
    }
    Err(usage!(
        "--sut {name}: unknown system under test; valid: {}, grpc://HOST:PORT",
        litesim_scenario::sut::BUILTIN.join(", ")
    ))
}

/// The plan as a log (one sample per plan step), for pictures.
pub fn plan_log(plan: &Plan) -> SimulationLog {
    let mut rec = LogRecorder::new(plan.dt);
    rec.meta("source", "plan");
    for a in &plan.actors {
        rec.actor(
            &a.id,
            &format!("{:?}", a.kind).to_lowercase(),
            &a.category,
            a.length,
            a.width,
            1500.0,
        );
    }
    let n = plan
        .actors
        .iter()
        .map(|a| a.samples.len())
        .max()
        .unwrap_or(0);
    for k in 0..n {
        rec.begin(k as u64, k as f64 * plan.dt);
        for a in &plan.actors {
            let s = a.samples[k.min(a.samples.len() - 1)];
            let (sy, cy) = litesim_core::math::sin_cos(s.yaw);
            let sample = ActorSample::from_kinematics(
                litesim_core::geometry::Pose::planar(s.x, s.y, s.yaw),
                litesim_core::geometry::Vec3::new(s.v * cy, s.v * sy, 0.0),
                litesim_core::geometry::Vec3::new(s.a * cy, s.a * sy, 0.0),
                0.0,
                s.v,
                1500.0,
            );
            rec.sample(&a.id, "plan", &sample);
        }
    }
    rec.finish()
}

/// `litesim calibrate`.
pub fn calibrate_cmd(profile: &str, out: Option<PathBuf>) -> Result<()> {
    let c = calibrate::calibrate(profile)?;
    let path =
        out.unwrap_or_else(|| PathBuf::from("calibration").join(format!("{}.toml", c.profile)));
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d)?;
    }
    std::fs::write(&path, calibrate::to_toml(&c))?;
    print!(
        "profile {}: {} candidates (tuned on launch, speed steps, lane change; held out: stop, curve)\n{}",
        c.profile,
        c.trials,
        calibrate::report(&c)
    );
    println!("wrote {}", path.display());
    Ok(())
}
