//! # litesim-plan
//!
//! Planning and control on occupancy grids (seed 001): [`PlanningGrid`]
//! (exact distance transform; free / inflated / hard layers), [`fmt_star`]
//! (FMT*, Janson et al. 2015), [`Corridor`] (centripetal Catmull–Rom
//! smoothing, arc-length resampling, curvature-limited speed profile,
//! lateral bounds), [`Mpc`] (linear time-varying tracking MPC for the
//! kinematic bicycle, solved by Clarabel), and the closed-loop runner
//! ([`closed_loop`]) that ties them to `litesim-core`'s world and writes a
//! `SimulationLog`.
//!
//! Pure: no I/O, no clock. Sampling uses an explicit seeded generator, so a
//! plan is a function of its inputs and its seed.
#![warn(missing_docs)]

pub mod closed_loop;
pub mod corridor;
pub mod fmt;
pub mod grid;
pub mod mpc;
/// The seeded generator lives in `litesim-core` (shared with the scenario engine).
pub use litesim_core::rng;

pub use closed_loop::{ClosedLoopConfig, ClosedLoopResult, PlanError, run_closed_loop};
pub use corridor::Corridor;
pub use fmt::{FmtConfig, FmtError, FmtResult, Radius, fmt_star};
pub use grid::{Layer, PlanningGrid, distance_transform};
pub use mpc::{Mpc, MpcConfig, MpcSolution};
