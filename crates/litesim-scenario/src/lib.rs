//! # litesim-scenario
//!
//! The scenario engine: a test file (OpenSCENARIO DSL 2.0) brings a
//! configuration, a map and a scenario; [`elab`] resolves `top.main` into
//! actors, variables, constraints and a behaviour tree; [`solve`] fixes
//! every variable under a seed (roads from the OpenDRIVE map included);
//! [`plan`] gives every actor a trajectory before anything runs;
//! [`postplan`] checks it against the profile's limits; [`runtime`] drives
//! every actor through its controller (the SUT, a driver or its plan)
//! over any SSP (in-process or remote), step by step, and
//! [`kpi`] checks the result; [`batch`] runs tests × seeds in parallel and
//! in shards; [`calibrate`] tunes the drivers.
//!
//! Invariant: a run is a pure function of (test, map, seed, profile, model,
//! mode): summaries and logs are byte-identical across runs, threads,
//! shards and transports (golden tests in `tests/`).
#![warn(missing_docs)]

pub mod batch;
pub mod calibrate;
pub mod coverage;
pub mod elab;
pub mod error;
pub mod expr;
pub mod intent;
pub mod judge;
pub mod kpi;
pub mod load;
pub mod plan;
pub mod postplan;
pub mod reactive;
pub mod realtime;
pub mod runtime;
pub mod solve;
pub mod state;
pub mod stepped;
pub mod sut;
pub mod xosc;

pub use error::ScenarioError;
use load::calibration_file;
pub use load::{
    CalibrationKey, CalibrationRead, LoadOptions, MapFileError, Prepared, calibration_near,
    carla_map_file, prepare, sha256_hex,
};
pub use runtime::DriveMode;
pub use stepped::Stepped;
use stepped::run_here;

use litesim_core::rng::Rng;
use litesim_ssp::Ssp;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

/// The callback of a [`TickObserver`].
pub type TickCallback = dyn FnMut(&litesim_log::SimulationLog) + Send;

/// Called while a recorded run goes on, with the log so far, after each
/// completed tick but the last (the run's result has the whole log): for
/// writers that stream the log, such as the MCAP file of `litesim run`.
#[derive(Clone)]
pub struct TickObserver(
    /// The callback, shared so that the caller can reach its state after the run.
    pub Arc<std::sync::Mutex<TickCallback>>,
);

impl std::fmt::Debug for TickObserver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("TickObserver")
    }
}

/// How to run a prepared test.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Seed (`None`: the test's, else 1).
    pub seed: Option<u64>,
    /// Drive mode (`None`: the test's configuration — `sim_info.dynamic`,
    /// set by the seed's dummy configuration — else kinematic).
    pub mode: Option<DriveMode>,
    /// Profile override (`None`: the test's `sim_info`).
    pub profile: Option<String>,
    /// Driver gains override (from `litesim calibrate`).
    pub calibration: Option<litesim_ssp::profile::Calibration>,
    /// Folder of calibration files (`PROFILE.toml`, written by `litesim
    /// calibrate`); used when `calibration` is `None` and the file exists.
    pub calibration_dir: Option<PathBuf>,
    /// Without `calibration` and `calibration_dir`: look for
    /// `calibration/PROFILE.toml` in the test's folder and its ancestors
    /// (the nearest wins) — never in the current directory, so the same
    /// command gives the same results from anywhere.
    pub calibration_near_test: bool,
    /// Record the log.
    pub record: bool,
    /// With `record`: told of each tick as it is recorded.
    pub observer: Option<TickObserver>,
    /// Stop after planning.
    pub plan_only: bool,
    /// What drives sut.car (`planned`: its plan).
    pub sut: sut::SutChoice,
    /// What drives the other vehicles (`driver` by default; `planned`
    /// replays their plans exactly, as litesim did before drivers).
    pub npc: Npc,
    /// Time the SUT may take per call (s); `None`: the test's
    /// `sut_timeout`, else 1 s.
    pub sut_timeout: Option<f64>,
    /// Pace the steps to the wall clock (hardware in the loop), with this
    /// policy for late steps; `None`: as fast as possible.
    pub realtime: Option<realtime::Policy>,
    /// The simulation step (ms), overriding the test's `sim_info.step_ms`
    /// and the profile's (an OpenSCENARIO XML file has no step of its own:
    /// the profile's, else this).
    pub step_ms: Option<u32>,
}

/// What drives the scenario's vehicles other than sut.car (`--npc`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Npc {
    /// A driver each (ACC car-following, the plan's lanes and speeds as
    /// goals, gap goals pursued within its limits until the phase ends).
    #[default]
    Driver,
    /// Each replays its plan exactly (re-timed for gap goals in a closed
    /// loop): the player litesim was before drivers.
    Planned,
}

impl Npc {
    /// Planned replay (what a summary leaves unsaid).
    pub fn is_planned(&self) -> bool {
        *self == Npc::Planned
    }

    /// `driver` or `planned`.
    pub fn name(self) -> &'static str {
        match self {
            Npc::Driver => "driver",
            Npc::Planned => "planned",
        }
    }

    /// From its name.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "driver" => Some(Npc::Driver),
            "planned" => Some(Npc::Planned),
            _ => None,
        }
    }
}

/// What a run came to, from the least to the most severe (a batch takes
/// the most severe of its runs).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Every check on the SUT held and the scenario happened.
    #[default]
    Pass,
    /// The scenario was not realised: a non-SUT actor missed its goal (its
    /// gap or lane), or a condition it waited for never held. Nothing is
    /// said of the SUT; the run counts in no coverage and no KPI.
    Invalid,
    /// A check on the SUT failed: a collision, off-road, a red light, a
    /// test threshold, a goal of sut.car's own, or (for the scenario
    /// player) an actor off its plan.
    Fail,
    /// The run could not be carried out: the SUT failed to answer, a paced
    /// run overran under the `fail` policy, or the test could not run.
    Error,
}

impl Verdict {
    /// Its name (`pass`, `invalid`, `fail`, `error`).
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Invalid => "invalid",
            Verdict::Fail => "fail",
            Verdict::Error => "error",
        }
    }

    /// The exit code of `litesim run` for it: 0 pass, 2 fail, 3 invalid,
    /// 1 error (64 is a usage error, before any run).
    pub fn exit_code(self) -> u8 {
        match self {
            Verdict::Pass => 0,
            Verdict::Fail => 2,
            Verdict::Invalid => 3,
            Verdict::Error => 1,
        }
    }
}

/// The run summary: deterministic (no wall-clock fields).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Test file name.
    pub test: String,
    /// Seed.
    pub seed: u64,
    /// Passed every check (`verdict` is `pass`).
    pub pass: bool,
    /// What the run came to.
    pub verdict: Verdict,
    /// Why not: the SUT's failures (or the error that stopped the run).
    pub failures: Vec<String>,
    /// Why the scenario was not realised (verdict `invalid` when nothing
    /// failed): each intent that did not happen, and why.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub invalid: Vec<String>,
    /// Map file.
    pub map: String,
    /// Profile and model used.
    pub profile: String,
    /// Model.
    pub model: String,
    /// Drive mode.
    pub mode: DriveMode,
    /// What drove sut.car (`planned`, `acc`, `fmt-mpc`, `grpc://…`).
    pub sut: String,
    /// What drove the other vehicles (absent: `planned`, their plans
    /// replayed, as summaries before drivers had it).
    #[serde(skip_serializing_if = "Npc::is_planned")]
    pub npc: Npc,
    /// Planned duration (s).
    pub duration: f64,
    /// Steps executed.
    pub steps: u64,
    /// Roads chosen for map variables.
    pub roads: BTreeMap<String, String>,
    /// Per-actor KPIs.
    pub actors: Vec<kpi::ActorKpi>,
    /// Per-pair KPIs.
    pub pairs: Vec<kpi::PairKpi>,
    /// The ego's KPIs (deceleration, jerk, distance to its goal).
    pub ego: Option<kpi::EgoKpi>,
    /// Gap goals re-solved live, as they ended.
    pub goals: Vec<reactive::GoalResult>,
    /// Lane goals (`lane(same_as: x, at: end)`), as they ended.
    pub lane_goals: Vec<reactive::LaneResult>,
    /// `wait`/`until` conditions as they held on the simulated state
    /// (closed loop), with the time the plan had for them.
    pub conditions: Vec<runtime::LiveEvent>,
    /// Where the drivers' gains came from (`built-in` or a file).
    pub calibration: String,
    /// How well a paced run kept to the wall clock (`--realtime`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub realtime: Option<realtime::Stats>,
    /// `cover`/`record` samples of this run, in item order (absent when
    /// the test has none).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub coverage: Vec<coverage::Sample>,
    /// An OpenSCENARIO XML storyboard's triggers as they fired, with the
    /// time (absent for other tests).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub triggers: Vec<xosc::Fired>,
    /// What the engine saw but did not execute, and solver remarks.
    pub notes: Vec<String>,
}

/// Tolerances a run must hold to pass (path error m, speed error m/s).
pub fn tolerances(mode: DriveMode) -> (f64, f64) {
    match mode {
        DriveMode::Kinematic => (0.05, 0.05),
        DriveMode::Dynamic => (1.5, 2.0),
    }
}

/// Everything one run produced.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// Summary.
    pub summary: Summary,
    /// The plan.
    pub plan: plan::Plan,
    /// The log, when recorded.
    pub log: Option<litesim_log::SimulationLog>,
}

/// Profile and model named by a test's `sim_info`.
pub fn simulator_of(test: &elab::Test) -> (String, String) {
    let name = &test.config.simulator_name;
    let model = name
        .strip_prefix("model_ssp_")
        .unwrap_or(if name.is_empty() { "dummy" } else { name })
        .to_string();
    let profile = if test.config.profile.is_empty() {
        "dummy".to_string()
    } else {
        test.config.profile.clone()
    };
    (profile, model)
}

/// Solves and plans under a seed (no simulator).
pub fn plan_test(
    prep: &Prepared,
    seed: u64,
    step_ms: u32,
) -> Result<(solve::Solution, plan::Plan), ScenarioError> {
    plan_test_with(prep, seed, step_ms, &BTreeMap::new())
}

/// [`plan_test`] with the times of some `wait`/`until` conditions fixed
/// (what the closed loop saw on the simulated state).
pub fn plan_test_with(
    prep: &Prepared,
    seed: u64,
    step_ms: u32,
    fixed: &BTreeMap<String, f64>,
) -> Result<(solve::Solution, plan::Plan), ScenarioError> {
    // Nothing to run says so before anything else (an empty file would
    // otherwise be told it lacks a map).
    if prep.test.root.is_none() {
        return Err(ScenarioError::no_behaviour());
    }
    let mut rng = Rng::new(seed);
    let sol = solve::solve(&prep.test, prep.net.as_deref(), &prep.map_name, &mut rng)?;
    let net = prep.net.as_deref().ok_or_else(|| {
        ScenarioError::Map(
            "the test has no map: set `test_config.map` or pass --map FILE.xodr".into(),
        )
    })?;
    let plan = plan::plan_with(
        &prep.test,
        &sol,
        net,
        f64::from(step_ms) / 1000.0,
        &mut rng,
        fixed,
    )?;
    Ok((sol, plan))
}

/// The profile a run of `prep` under `opts` uses.
pub fn profile_of(prep: &Prepared, opts: &RunOptions) -> String {
    opts.profile
        .clone()
        .unwrap_or_else(|| simulator_of(&prep.test).0)
}

/// Which driver gains a run of `prep` under `opts` uses: `given`,
/// `built-in`, or the file's path and content hash (what summaries and
/// batch manifests record).
pub fn calibration_used(prep: &Prepared, opts: &RunOptions) -> String {
    if opts.calibration.is_some() {
        return "given".into();
    }
    match calibration_file(prep, opts, &profile_of(prep, opts)).and_then(|f| {
        litesim_core::files::read_bytes(&f, litesim_core::files::MAX_INPUT_BYTES)
            .ok()
            .map(|b| (f, b))
    }) {
        Some((f, bytes)) => format!("{} sha256:{}", f.display(), sha256_hex(&bytes)),
        None => "built-in".into(),
    }
}

/// Runs a prepared test on `ssp` under a seed.
///
/// A test of many actors (from [`PARALLEL_ACTORS`]) with sut.car on its plan,
/// called from outside rayon's pool, runs on one of the pool's threads
/// (the caller waits): its parallel parts (motion planning, post-plan
/// checks, trajectories made while a chunk is read back) then share their
/// work with the thread that runs it instead of handing it over and
/// sleeping until it is done — on two cores the 100-vehicle test's median
/// went from ~10 to ~8.5 ms (BENCHMARKS.md). Runs with a system under test
/// stay on the caller's thread (an external SUT may need it). Same results
/// on any thread.
pub fn run(
    prep: &Prepared,
    ssp: &mut dyn Ssp,
    opts: &RunOptions,
) -> Result<RunResult, ScenarioError> {
    if prep.test.actors.len() >= PARALLEL_ACTORS
        && matches!(opts.sut, sut::SutChoice::Planned)
        && rayon::current_thread_index().is_none()
    {
        return rayon::scope(|_| run_here(prep, ssp, opts));
    }
    run_here(prep, ssp, opts)
}

/// From how many actors a run's parts run on all cores — independent
/// motions planned, vehicles' plans checked, an open loop's trajectories
/// made while a chunk is read back — and so from how many [`run`] goes
/// into rayon's pool. Below it, spreading the work costs more than it
/// saves.
pub const PARALLEL_ACTORS: usize = 16;

/// A fresh in-process Model SSP session.
pub fn in_process() -> litesim_ssp::Session {
    litesim_ssp::Session::new("dummy", "dummy", litesim_ssp::SessionLimits::default())
}
