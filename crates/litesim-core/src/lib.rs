//! # litesim-core
//!
//! The pure heart of litesim: geometry, actors, control commands and their
//! normalisation, vehicle models and the fixed-step [`World`].
//!
//! Promises:
//! * **No I/O, no clock, no threads, no ambient randomness.** Everything here
//!   is a function of its inputs.
//! * **Bit-identical results across machines.** Transcendental functions go
//!   through [`math`] (litesim's own `sin_cos`, the pure-Rust `libm` for the
//!   rest), never the platform libm,
//!   so a run gives the same bytes wherever it runs.
//! * **Fast by batching, with the same bits**: a [`World`] steps its dynamic
//!   actors together, column by column ([`vehicle::batch`]), and gives the
//!   bits its vehicle models give one vehicle at a time.
//! * **Time is a tick counter**: `t = tick as f64 * dt`, never a running sum.
//! * **No panics on user input**: commands are validated into typed errors
//!   ([`ControlError`]) before they touch a model.
#![warn(missing_docs)]

pub mod actor;
pub mod control;
pub mod files;
pub mod geometry;
pub mod math;
pub mod rng;
pub mod run;
pub mod trajectory;
pub mod vehicle;
pub mod world;

pub use actor::{
    ActorClass, ActorDescription, ActorId, ActorKind, ActorState, TrajectoryStatus, VehicleCategory,
};
pub use control::{
    ActuatorLimits, ControlError, DynamicCommand, NormalizedPedals, PedalInput, RangePolicy,
    SteeringInput, normalize_command,
};
pub use geometry::{
    OrientedBox, Polyline, Pose, Projection, Vec2, Vec3, ahead_along, segment_fraction, wrap_angle,
};
pub use rng::Rng;
pub use run::{StopCondition, run_loop, steps_for_horizon};
pub use trajectory::{TimedPoint, Trajectory, TrajectoryError};
pub use vehicle::{
    ActuatorLag, Derived, KinematicBicycle, ReferencePoint, SspDynamics, VehicleInput,
    VehicleModel, VehicleModelKind, VehicleState, seed_wheelbase,
};
pub use world::{Actor, ActorRef, ControlMode, SetTrajectoryError, World, WorldError};
