//! The closed loop of seed 001: plan (FMT*), smooth (corridor), track (MPC)
//! in the deterministic world, log everything.
//!
//! The world steps `N = ⌈T/dt⌉` times (early stop within the goal tolerance
//! below the stop speed); the MPC runs every `tracker.dt`, which must be a
//! whole number of simulation steps, and its command is held in between
//! (zero-order hold). Commands are saturated by the vehicle model before
//! integration. The MPC's model uses the tracker's dt and the vehicle's
//! wheelbase — both named in the configuration, never guessed.

mod config;
mod legs;
mod run;
pub use config::*;
pub use legs::*;
pub use run::*;

use crate::corridor::{Corridor, SpeedLimits, TURN_HALF_ARC, TURN_SLACK};
use crate::fmt::{FmtConfig, FmtError, FmtResult, Radius, fmt_star};
use crate::follow::{FollowerVehicle, Grids, LegFollower};
use crate::grid::{Layer, PlanningGrid};
use crate::hybrid::{HybridConfig, HybridError, hybrid_astar};
use crate::mpc::{Mpc, MpcConfig, MpcError};
use litesim_core::{
    Actor, ActorDescription, ActorKind, ActorState, ControlMode, KinematicBicycle, Pose, Vec2,
    VehicleCategory, VehicleInput, VehicleModelKind, World, wrap_angle,
};
use litesim_log::{GridRecord, LogRecorder, PlanRecord, SimulationLog, TrackingColumns};
use litesim_map::{Obstacle, OccupancyGrid};
use serde::{Deserialize, Serialize};

/// Why a closed-loop run could not be made. Each message includes its
/// cause's (the CLI and the SUT print one line), and the cause is also
/// the error's typed `source()`.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// Bad configuration.
    #[error("configuration: {0}")]
    Config(String),
    /// Not valid TOML for a configuration (the parser names the key).
    #[error("configuration: {0}")]
    Toml(#[from] toml::de::Error),
    /// A configuration's folder could not be listed.
    #[error("configuration: cannot read {}: {source}", path.display())]
    Dir {
        /// The folder.
        path: std::path::PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A configuration file is wrong (what is wrong is the source).
    #[error("configuration: {}: {source}", path.display())]
    InFile {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong in it.
        #[source]
        source: Box<PlanError>,
    },
    /// The map file a configuration names makes no grid (not a PNG, a road
    /// network with no lanes).
    #[error("configuration: {}: {source}", path.display())]
    GridFile {
        /// The PNG or OpenDRIVE file.
        path: std::path::PathBuf,
        /// Why.
        #[source]
        source: litesim_map::GridError,
    },
    /// A file the configuration names could not be read.
    #[error(transparent)]
    Read(#[from] litesim_core::files::ReadError),
    /// The map the configuration names could not be loaded.
    #[error(transparent)]
    Map(#[from] litesim_map::MapError),
    /// The simulated world refused the run's setup.
    #[error("simulation: {0}")]
    World(#[from] litesim_core::world::WorldError),
    /// Grid construction failed.
    #[error("map: {0}")]
    Grid(#[from] litesim_map::GridError),
    /// Planning failed.
    #[error("planner: {0}")]
    Plan(#[from] FmtError),
    /// Tracking failed.
    #[error("tracker: {0}")]
    Mpc(#[from] MpcError),
    /// The planned path cannot be driven by this vehicle.
    #[error("no feasible path for this vehicle: {0}")]
    Infeasible(String),
    /// No run can exist: the body at the start overlaps an obstacle or
    /// leaves the map, or a search that expanded every pose reachable from
    /// the start (forwards and backwards, up to the vehicle's full
    /// curvature) never reached the goal.
    #[error("impossible for this vehicle: {0}")]
    Impossible(String),
}

/// The exhaustive search that proves a cell impossible on the search's
/// lattice: at most this many poses (a hard case exhausts its reachable
/// poses in 50,000–70,000; a cap reached proves nothing and says so).
pub const EXHAUSTIVE_POSES: usize = 2_000_000;

/// Which planner made the path a run drove.
#[derive(Clone, Debug, PartialEq)]
pub enum PathPlanner {
    /// FMT*, smoothed into the corridor.
    Fmt {
        /// Samples drawn.
        samples: usize,
        /// Connection radius (m).
        radius: f64,
    },
    /// The curvature-bounded search ([`crate::hybrid_astar`]), because
    /// FMT*'s path could not be driven.
    Hybrid {
        /// Its tightest turn radius (m).
        radius: f64,
        /// Poses it expanded.
        expansions: usize,
        /// Changes of direction on its path (0: forwards all the way).
        cusps: usize,
        /// Why FMT*'s path was not used.
        fmt_failure: String,
    },
}

impl std::fmt::Display for PathPlanner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Fmt { samples, radius } => {
                write!(f, "FMT*, {samples} samples, r = {radius:.2} m")
            }
            Self::Hybrid {
                radius,
                expansions,
                cusps,
                fmt_failure,
            } => {
                write!(f, "hybrid A*, turns ≥ {radius:.2} m, {expansions} poses")?;
                match cusps {
                    0 => {}
                    1 => write!(f, ", reversing once")?,
                    n => write!(f, ", {n} changes of direction")?,
                }
                write!(f, "; FMT*'s path was not drivable: {fmt_failure}")
            }
        }
    }
}

/// How a run left a start inside the margin ([`crate::escape`]).
#[derive(Clone, Debug, PartialEq)]
pub struct StartEscape {
    /// How far inside the margin the start was (m).
    pub depth: f64,
    /// The escape leg's length (m) …
    pub length: f64,
    /// … driven backwards.
    pub reverse: bool,
    /// Simulated time until the body kept the margin (s); `None` when it
    /// never did.
    pub inside_s: Option<f64>,
}

impl std::fmt::Display for StartEscape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "inside the margin by {:.2} m: left along a {:.2} m leg {}",
            self.depth,
            self.length,
            if self.reverse {
                "backwards"
            } else {
                "forwards"
            }
        )?;
        match self.inside_s {
            Some(t) => write!(f, ", inside it for {t:.2} s"),
            None => write!(f, ", and never out of it"),
        }
    }
}

/// What a run produced.
#[derive(Clone, Debug)]
pub struct ClosedLoopResult {
    /// The complete log (with plan and tracking).
    pub log: SimulationLog,
    /// Goal reached (within tolerance, below the stop speed).
    pub reached_goal: bool,
    /// The goal rule: (tolerance m, stop speed m/s).
    pub goal_rule: (f64, f64),
    /// Where the run ended: distance to the goal (m) and speed (m/s).
    pub goal_distance: f64,
    /// Speed at the end (m/s).
    pub final_speed: f64,
    /// Simulated time (s).
    pub time: f64,
    /// Steps executed.
    pub steps: u64,
    /// Length of the planner's path (m).
    pub path_length: f64,
    /// Largest |cross-track error| (m).
    pub max_cross_track: f64,
    /// Mean |cross-track error| (m).
    pub mean_cross_track: f64,
    /// Smallest clearance of the vehicle's footprint to a hard obstacle (m).
    pub min_clearance: f64,
    /// Whether the footprint ever touched a hard obstacle.
    pub collided: bool,
    /// Where the run ended by a collision: time (s) and the rear axle's
    /// position.
    pub collision: Option<(f64, [f64; 2])>,
    /// FMT* output; when the curvature-bounded search planned instead
    /// (see `planner`), no tree (start and goal only) and that search's
    /// path.
    pub fmt: FmtResult,
    /// Which planner made the path (the log's `planner` meta says the
    /// same).
    pub planner: PathPlanner,
    /// The start was inside the margin: how the vehicle left it (the log's
    /// `start` meta says the same).
    pub start_escape: Option<StartEscape>,
    /// The corridor: the legs joined, for display (the one leg itself
    /// when the path never reverses).
    pub corridor: Corridor,
    /// The path's legs, each driven in one direction, in order.
    pub legs: Vec<Leg>,
    /// The planning grid.
    pub grid: PlanningGrid,
}

/// The speed profile's jerk limit (m/s³): comfortable driving stays within
/// about 2 m/s³.
pub const JERK_MAX: f64 = 2.0;

/// Wall time spent in a run's parts (seconds), from the caller's clock.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Timings {
    /// Distance field, FMT* and corridor.
    pub plan_s: f64,
    /// Each MPC solve.
    pub mpc_s: Vec<f64>,
}
