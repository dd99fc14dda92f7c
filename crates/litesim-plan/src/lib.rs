//! # litesim-plan
//!
//! Planning and control on occupancy grids (seed 001): [`PlanningGrid`]
//! (exact distance transform bounded by the map's edge; free / inflated /
//! hard layers; the vehicle's footprint as covering circles), [`fmt_star`]
//! (FMT*, Janson et al. 2015), [`hybrid_astar`] (forward arcs within the
//! turning limit, for vehicles FMT*'s straight edges do not fit),
//! [`Corridor`] (lead-in along the start heading, centripetal Catmull–Rom,
//! bending-energy relaxation with footprint checks, arc-length
//! resampling, a speed profile limited by lateral acceleration and steering
//! rate, lateral bounds), [`Mpc`] (linear
//! time-varying tracking MPC for the kinematic bicycle, condensed and
//! solved by the dual active-set method of [`qp`]; Clarabel solves the same
//! QP as the reference), the closed-loop runner ([`closed_loop`]) that ties
//! them to `litesim-core`'s world and writes a `SimulationLog`, and the
//! example × preset table ([`matrix`]).
//!
//! No clock: timings come from a clock the caller passes. The only I/O is
//! [`closed_loop::load_grid`] and [`matrix::load_examples`]. Sampling uses an explicit seeded generator,
//! so a plan is a function of its inputs and its seed.
#![warn(missing_docs)]

pub mod closed_loop;
pub mod corridor;
pub mod escape;
pub mod fmt;
pub mod follow;
pub mod grid;
pub mod hybrid;
pub mod matrix;
pub mod mpc;
pub mod qp;
pub mod reach;
/// The seeded generator lives in `litesim-core` (shared with the scenario engine).
pub use litesim_core::rng;

pub use closed_loop::{
    ClosedLoopConfig, ClosedLoopResult, PathPlanner, PlanError, run_closed_loop,
};
pub use corridor::Corridor;
pub use fmt::{FmtConfig, FmtError, FmtResult, Radius, fmt_star};
pub use grid::{Layer, PlanningGrid, distance_transform};
pub use hybrid::{HybridConfig, HybridError, HybridPath, hybrid_astar};
pub use mpc::{Mpc, MpcConfig, MpcSolution};
