//! What a run is given and what it gives back: the configuration the
//! runtime reads, and the record of what happened ([`Executed`]).

use crate::error::ScenarioError;
use crate::kpi::{EgoKpi, Kpis};
use crate::plan::Plan;
use crate::reactive::{GoalResult, LaneResult};
use litesim_log::SimulationLog;
use litesim_map::RoadNetwork;
use litesim_ssp::profile::Calibration;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How actors are moved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveMode {
    /// xy trajectories sent ahead.
    #[default]
    Kinematic,
    /// Pedals and steering from the drivers.
    Dynamic,
}

/// What the execution needs besides the plan.
#[derive(Clone, Debug)]
pub struct ExecConfig {
    /// SSP profile.
    pub profile: String,
    /// SSP model.
    pub model: String,
    /// Seed passed to the simulator.
    pub seed: u64,
    /// Step (ms).
    pub step_ms: u32,
    /// OpenDRIVE text sent to the simulator (traffic lights), if any.
    pub map_text: Option<std::sync::Arc<String>>,
    /// Drive mode.
    pub mode: DriveMode,
    /// Driver gains (the profile's calibration when `None`).
    pub calibration: Option<Calibration>,
    /// Record a [`SimulationLog`].
    pub record: bool,
    /// With `record`: told of each completed tick.
    pub observer: Option<crate::TickObserver>,
    /// Test file name (told to the SUT).
    pub test_name: String,
    /// Map path (told to the SUT).
    pub map_path: String,
    /// The map (for in-process SUTs).
    pub map: Option<std::sync::Arc<RoadNetwork>>,
    /// How long the SUT may take per call (s).
    pub sut_timeout: f64,
    /// Pace steps to the wall clock with this policy (`None`: no pacing).
    pub realtime: Option<crate::realtime::Policy>,
    /// `cover`/`record` items to sample.
    pub covers: Vec<crate::coverage::CoverItem>,
    /// The solved scenario parameters (what items may read).
    pub values: BTreeMap<String, crate::elab::Value>,
    /// People, cyclists and animals hold their plans' clocks rather than
    /// walk into a vehicle that stands in their way (`--npc driver`).
    pub people_yield: bool,
    /// The map's junction conflict areas (post-encroachment time).
    pub conflict_areas: std::sync::Arc<[crate::runtime::traffic::ConflictArea]>,
}

/// What an execution produced.
#[derive(Clone, Debug)]
pub struct Executed {
    /// KPIs.
    pub kpis: Kpis,
    /// Steps run.
    pub steps: u64,
    /// The log, when recorded.
    pub log: Option<SimulationLog>,
    /// Profile and model the simulator used.
    pub profile: String,
    /// Model.
    pub model: String,
    /// The ego's KPIs (closed loop and planned alike).
    pub ego: Option<EgoKpi>,
    /// Gap goals re-solved during the run, judged at their phase ends.
    pub goals: Vec<GoalResult>,
    /// Lane goals, judged at their phase ends on the simulated state.
    pub lane_goals: Vec<LaneResult>,
    /// The SUT failed: the run stopped here (`sut error at t=…: …`).
    pub sut_error: Option<String>,
    /// `wait`/`until` conditions as they held on the simulated state.
    pub live_events: Vec<LiveEvent>,
    /// Pacing figures of a real-time run.
    pub realtime: Option<crate::realtime::Stats>,
    /// The `cover`/`record` items' samples, in item order.
    pub coverage: Vec<crate::coverage::Sample>,
    /// A real-time run under the `fail` policy overran: the first overrun.
    pub realtime_failure: Option<String>,
    /// The actors drivers drove (their missed goals are the scenario's,
    /// not the SUT's).
    pub driven: std::collections::BTreeSet<String>,
    /// What the SUT reported (an emergency stage that fired, and why).
    pub sut_notes: Vec<String>,
    /// What the simulator could not take of the environment's changes.
    pub environment_notes: Vec<String>,
    /// `wait`/`until` conditions looked at on the simulated state that
    /// never held.
    pub never_held: Vec<String>,
    /// What a scenario controller (an OpenSCENARIO storyboard) reported.
    pub story: Option<super::ControllerReport>,
}

/// Plans the test again with the given condition times fixed.
pub type Replan<'a> = dyn Fn(&BTreeMap<String, f64>) -> Result<Plan, ScenarioError> + Send + 'a;

/// A `wait`/`until` condition held on the simulated state.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LiveEvent {
    /// The condition (`sut.car.speed > 8.333`, `rise(…)`).
    pub condition: String,
    /// When the first plan had it hold (s); `None`: never.
    pub planned: Option<f64>,
    /// When it held on the simulated state (s).
    pub live: f64,
}

/// How long a condition the plan expected by now, but the world does not
/// show yet, is postponed before it is looked at again in a new plan (s).
pub const POSTPONE_S: f64 = 1.0;
