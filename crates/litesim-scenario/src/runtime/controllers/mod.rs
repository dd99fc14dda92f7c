//! The controllers: everything that moves an actor does it behind
//! [`Controller`] — observe (the [`See`] every controller gets, the same
//! object list a SUT is sent), decide, command the SSP.
//!
//! - `planned::Planned`: each actor replays its plan exactly
//!   (trajectories, or pedals and steering in dynamic mode), on a clock that
//!   reacts to gap goals — today's scenario player, and `--npc planned`;
//! - `drivers::Drivers`: the traffic engine's drivers (`--npc driver`
//!   and ambient traffic);
//! - `seam::SutSeam`: the system under test (`acc`, `fmt-mpc`,
//!   `grpc://`, Python) driving sut.car.
//!
//! A controller drives a group of actors at once (SUMO, CARLA's Traffic
//! Manager and rapier step their vehicles in bulk, for the same reason: the
//! lane index is built once per step, not once per vehicle).

pub mod drivers;
pub mod pid;
pub mod planned;
pub mod seam;

use super::lights::Lights;
use super::observe::World;
use crate::error::ScenarioError;
use crate::plan::Plan;
use litesim_log::ControlSample;
use litesim_ssp::api::Ssp;

/// What every controller sees at a step.
pub struct See<'a> {
    /// The plan in force.
    pub plan: &'a Plan,
    /// Every actor as last reported (before the first step: as planned).
    pub world: &'a World,
    /// The lights and which show red.
    pub lights: &'a Lights,
    /// Per actor: length, width, mass.
    pub dims: &'a [(f64, f64, f64)],
    /// Each gap goal's (actor, reference) indices.
    pub goal_actors: &'a [Option<(usize, usize)>],
    /// The step index.
    pub k: u64,
    /// Steps this command covers (more than one only in open loop).
    pub n_steps: u64,
    /// The step (ms).
    pub step_ms: u64,
    /// The actor a SUT drives.
    pub ego_i: Option<usize>,
    /// sut.car's actor, driven or planned.
    pub ego_index: Option<usize>,
    /// sut.car's sideways offset from its route (closed loop).
    pub ego_lateral: Option<f64>,
    /// The simulator's frame is mirrored (CARLA).
    pub mirror: bool,
}

impl See<'_> {
    /// The step's start (ms).
    pub fn now_ms(&self) -> u64 {
        self.k * self.step_ms
    }

    /// The step's start (s).
    pub fn t(&self) -> f64 {
        self.now_ms() as f64 / 1000.0
    }

    /// The step (s).
    pub fn dt(&self) -> f64 {
        self.step_ms as f64 / 1000.0
    }

    /// Nothing reported yet: the world is the plan's start.
    pub fn first(&self) -> bool {
        self.k == 0
    }
}

/// Where a controller's commands go.
pub struct Act<'a> {
    /// The simulator.
    pub ssp: &'a mut dyn Ssp,
    /// Per actor: the command it got (what its log samples show).
    pub controls: &'a mut [ControlSample],
}

/// What a step's commands came to.
#[derive(Debug, PartialEq)]
pub enum Flow {
    /// Step on.
    Go,
    /// The system under test failed: the run stops here (the message says
    /// when and why).
    Stop(String),
    /// The scenario is over (an OpenSCENARIO storyboard's stop trigger
    /// fired): this step is made, then the run ends normally.
    End(String),
}

/// Something that drives actors: called once per step, in the runtime's
/// fixed order (the SUT, the drivers, the planned actors), it reads the
/// step's [`See`] and sends its actors' commands to the SSP.
pub trait Controller {
    /// Decides and sends this step's commands.
    fn command(&mut self, see: &See<'_>, act: &mut Act<'_>) -> Result<Flow, ScenarioError>;

    /// What the controller has to report when the run ends (triggers
    /// that fired, notes); most have nothing.
    fn report(&mut self) -> Option<super::ControllerReport> {
        None
    }
}

/// An SSP error as the runtime's.
pub(crate) fn ssp_err(e: litesim_ssp::SspError) -> ScenarioError {
    ScenarioError::Ssp(e)
}

/// Map frame → the simulator's frame.
pub(crate) fn to_sim(mut c: litesim_ssp::api::Coord6, mirror: bool) -> litesim_ssp::api::Coord6 {
    if mirror {
        c.y = c.y.map(|v| -v);
        c.yaw = c.yaw.map(|v| -v);
    }
    c
}
