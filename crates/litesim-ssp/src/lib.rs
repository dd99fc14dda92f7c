//! # litesim-ssp
//!
//! The simulator-support (SSP) API as a Rust trait, [`Ssp`], and the
//! in-process Model SSP that implements it, [`Session`].
//!
//! * [`api`] — the call set and its message types (SI units, times in ms).
//! * [`Session`] — life-cycle state machine, actors, moves, environment.
//! * [`model`] — pluggable vehicle models (`dummy` by default, `bicycle`, `lag`).
//! * [`profile`] — the ten simulator profiles shipped in `profiles/`.
//! * [`traffic`] — bulb-level traffic lights with logical grouping.
//!
//! This crate knows nothing about networks or protobuf: `litesim-grpc` puts
//! it on the wire, and its client implements the same trait remotely.
#![warn(missing_docs)]

pub mod api;
pub mod error;
pub mod model;
pub mod profile;
pub mod session;
pub mod testkit;
pub mod trace;
pub mod traffic;

pub use api::*;
pub use error::{ErrorCode, SspError, SspResult};
pub use model::{Model, model_by_name, models};
pub use profile::Profile;
pub use session::{Phase, Session, SessionLimits};
/// The small string of actor ids in reports (re-exported for callers that keep them).
pub use smol_str::SmolStr;
pub use traffic::{
    Bulb, BulbColor, BulbIcon, BulbMode, BulbState, LightTarget, LogicalTrafficLight,
    TrafficLightBox, TrafficLights,
};
