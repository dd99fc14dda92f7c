//! # litesim-log
//!
//! [`SimulationLog`]: everything a run produced, columnar — a time axis and,
//! per actor, columns of state, control and derived quantities — so that
//! dashboards, metrics and replays never need to re-run a simulation.
//!
//! * [`LogRecorder`] builds a log step by step, from a `litesim-core`
//!   [`World`](litesim_core::World) or from states read back over the SSP API.
//! * [`SimulationLog::write_json`] / [`SimulationLog::write_csv`] write
//!   atomically (temporary file in the target folder, then rename), so a
//!   crash never leaves half a log behind; [`SimulationLog::read_json`]
//!   reads and validates the JSON form.
//!
//! Invariant: every column of a track has exactly one entry per tick in the
//! track's `tick` column; readers reject logs that break it.
#![warn(missing_docs)]

mod io;
mod log;

pub use io::{AtomicFile, LogError, write_atomic, write_atomic_seekable};
pub use log::{
    ActorSample, ActorTrack, ControlColumns, ControlSample, DerivedColumns, EnvironmentChange,
    GridRecord, LogRecorder, PlanRecord, SimulationLog, StateColumns, TrackingColumns,
};
