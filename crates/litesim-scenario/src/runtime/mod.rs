//! The runtime: one step loop (`run`) drives every actor through a
//! controller (`controllers`) — observe, decide, command to the SSP — and
//! reads each step back (`readback`) into the checks, the log and the
//! world the controllers observe next.
//!
//! - `cast`: the simulator initialised, the actors created;
//! - `observe`: the one picture of the world every controller reads;
//! - `lights`: light control (the plan's switches, who shows red);
//! - `live`: `wait`/`until` conditions on the simulated state;
//! - `sample`: `cover`/`record` items sampled at their events;
//! - [`driver`] and [`traffic`]: the driver model (ACC car-following, MOBIL
//!   lane changes) and the traffic engine that runs it on the map's lanes.

pub(crate) mod cast;
pub mod config;
pub(crate) mod controllers;
pub mod driver;
pub(crate) mod environment;
pub(crate) mod lights;
pub(crate) mod live;
pub(crate) mod observe;
pub(crate) mod readback;
pub(crate) mod run;
pub(crate) mod sample;
pub(crate) mod schedule;
pub mod traffic;

pub use config::{DriveMode, ExecConfig, Executed, LiveEvent, POSTPONE_S, Replan};

/// An actor this far from the map's origin (m, in x or y) is not in the
/// scenario — an OpenSCENARIO entity before its `AddEntityAction` or after
/// its `DeleteEntityAction` waits there — and is not checked against the
/// roads.
pub const ABSENT_BEYOND_M: f64 = 1.0e5;

/// What a controller that runs a scenario of its own (an OpenSCENARIO
/// storyboard) reports at the end of a run.
#[derive(Clone, Debug, Default)]
pub struct ControllerReport {
    /// Triggers that fired, in order.
    pub triggers: Vec<crate::xosc::Fired>,
    /// What was read but not applied, and why.
    pub notes: Vec<String>,
    /// Why the scenario ended, when it ended before the run's time.
    pub ended: Option<String>,
}
pub use controllers::pid::HEADING_LEVER_M;
pub use controllers::seam::SutSlot;
pub use run::{Finished, Head, SspSlot, execute};
