//! The closed loop of seed 001: plan (FMT*), smooth (corridor), track (MPC)
//! in the deterministic world, log everything.
//!
//! The world steps `N = ⌈T/dt⌉` times (early stop within the goal tolerance
//! below the stop speed); the MPC runs every `tracker.dt`, which must be a
//! whole number of simulation steps, and its command is held in between
//! (zero-order hold). Commands are saturated by the vehicle model before
//! integration. The MPC's model uses the tracker's dt and the vehicle's
//! wheelbase — both named in the configuration, never guessed.

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

/// Where the occupancy comes from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapConfig {
    /// Lower-left corner (m).
    #[serde(default)]
    pub origin: [f64; 2],
    /// Width and height (m) for obstacle maps.
    #[serde(default)]
    pub size: [f64; 2],
    /// Cell size (m).
    pub resolution: f64,
    /// Obstacles (rectangles, circles, polygons).
    #[serde(default)]
    pub obstacles: Vec<Obstacle>,
    /// A PNG (dark = obstacle), relative to the configuration file.
    #[serde(default)]
    pub png: Option<String>,
    /// An OpenDRIVE map (drivable lanes free), relative to the configuration file.
    #[serde(default)]
    pub opendrive: Option<String>,
}

/// A start pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartConfig {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad).
    #[serde(default)]
    pub yaw: f64,
    /// Speed (m/s).
    #[serde(default)]
    pub speed: f64,
}

/// The goal.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GoalConfig {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Arrival radius (m).
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Stop speed (m/s): the run ends inside the tolerance below it.
    #[serde(default = "default_stop")]
    pub stop_speed: f64,
}
fn default_tolerance() -> f64 {
    1.0
}
fn default_stop() -> f64 {
    0.3
}

/// Vehicle parameters (a preset, optionally overridden).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleConfig {
    /// Preset: passenger, compact, sport, suv, van, bus, truck.
    #[serde(default = "default_preset")]
    pub preset: String,
    /// Length (m).
    pub length: Option<f64>,
    /// Width (m).
    pub width: Option<f64>,
    /// Wheelbase (m).
    pub wheelbase: Option<f64>,
    /// Mass (kg).
    pub mass: Option<f64>,
    /// Steering limit (deg).
    pub max_steer_deg: Option<f64>,
    /// Steering-rate limit (deg/s).
    pub max_steer_rate_deg: Option<f64>,
    /// Acceleration limit (m/s²).
    pub max_accel: Option<f64>,
    /// Deceleration limit (m/s², positive).
    pub max_decel: Option<f64>,
    /// Top speed (m/s).
    pub max_speed: Option<f64>,
    /// Lateral acceleration limit (m/s²).
    pub max_lat_accel: Option<f64>,
}
fn default_preset() -> String {
    "passenger".into()
}

/// A resolved vehicle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Vehicle {
    /// Length (m).
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// Wheelbase (m).
    pub wheelbase: f64,
    /// Mass (kg).
    pub mass: f64,
    /// Steering limit (rad).
    pub max_steer: f64,
    /// Steering-rate limit (rad/s).
    pub max_steer_rate: f64,
    /// Acceleration (m/s²).
    pub max_accel: f64,
    /// Deceleration (m/s²).
    pub max_decel: f64,
    /// Top speed (m/s).
    pub max_speed: f64,
    /// Lateral acceleration (m/s²).
    pub max_lat_accel: f64,
}

/// Vehicle presets: (name, length, width, wheelbase, mass, steer deg, steer rate deg/s, accel, decel, v max, a_lat).
pub const PRESETS: &[(&str, [f64; 10])] = &[
    (
        "passenger",
        [4.6, 1.85, 2.7, 1500.0, 35.0, 40.0, 2.5, 6.0, 15.0, 3.0],
    ),
    (
        "compact",
        [3.9, 1.7, 2.45, 1100.0, 38.0, 45.0, 2.5, 6.0, 14.0, 3.0],
    ),
    (
        "sport",
        [4.4, 1.9, 2.6, 1400.0, 32.0, 50.0, 5.0, 9.0, 20.0, 5.0],
    ),
    (
        "suv",
        [4.9, 2.0, 2.95, 2100.0, 34.0, 35.0, 2.0, 6.0, 14.0, 2.5],
    ),
    (
        "van",
        [5.9, 2.0, 3.66, 2800.0, 33.0, 30.0, 1.5, 5.0, 12.0, 2.0],
    ),
    (
        "bus",
        [12.0, 2.55, 6.0, 12000.0, 40.0, 25.0, 1.0, 4.0, 10.0, 1.5],
    ),
    (
        "truck",
        [9.0, 2.5, 5.0, 14000.0, 38.0, 25.0, 1.0, 4.0, 10.0, 1.5],
    ),
];

impl VehicleConfig {
    /// Resolves the preset and overrides.
    pub fn resolve(&self) -> Result<Vehicle, PlanError> {
        let (_, p) = PRESETS
            .iter()
            .find(|(n, _)| *n == self.preset)
            .ok_or_else(|| {
                PlanError::Config(format!(
                    "unknown vehicle preset '{}'; available: {}",
                    self.preset,
                    PRESETS
                        .iter()
                        .map(|(n, _)| *n)
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })?;
        let v = Vehicle {
            length: self.length.unwrap_or(p[0]),
            width: self.width.unwrap_or(p[1]),
            wheelbase: self.wheelbase.unwrap_or(p[2]),
            mass: self.mass.unwrap_or(p[3]),
            max_steer: self.max_steer_deg.unwrap_or(p[4]).to_radians(),
            max_steer_rate: self.max_steer_rate_deg.unwrap_or(p[5]).to_radians(),
            max_accel: self.max_accel.unwrap_or(p[6]),
            max_decel: self.max_decel.unwrap_or(p[7]),
            max_speed: self.max_speed.unwrap_or(p[8]),
            max_lat_accel: self.max_lat_accel.unwrap_or(p[9]),
        };
        let all = [
            v.length,
            v.width,
            v.wheelbase,
            v.mass,
            v.max_steer,
            v.max_steer_rate,
            v.max_accel,
            v.max_decel,
            v.max_speed,
            v.max_lat_accel,
        ];
        if all.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return Err(PlanError::Config(
                "vehicle: every dimension and limit must be positive".into(),
            ));
        }
        if v.wheelbase >= v.length {
            return Err(PlanError::Config(format!(
                "vehicle: wheelbase {} m must be shorter than the length {} m",
                v.wheelbase, v.length
            )));
        }
        Ok(v)
    }
}

/// Planner settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlannerConfig {
    /// Samples.
    #[serde(default = "default_samples")]
    pub samples: usize,
    /// η of the FMT* radius (ignored when `radius` or `k_nearest` is set).
    #[serde(default = "default_eta")]
    pub eta: f64,
    /// Fixed connection radius (m).
    pub radius: Option<f64>,
    /// k nearest neighbours.
    pub k_nearest: Option<usize>,
    /// Seed.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Safety margin beyond the vehicle's half width (m).
    #[serde(default = "default_margin")]
    pub margin: f64,
    /// Corridor resampling step (m).
    #[serde(default = "default_ds")]
    pub corridor_ds: f64,
}
fn default_samples() -> usize {
    2000
}
fn default_eta() -> f64 {
    0.5
}
fn default_seed() -> u64 {
    1
}
fn default_margin() -> f64 {
    0.4
}
fn default_ds() -> f64 {
    0.5
}

/// Simulation settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationConfig {
    /// Step (s).
    pub dt: f64,
    /// Horizon T (s).
    pub horizon: f64,
}

/// A whole closed-loop configuration (the TOML file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClosedLoopConfig {
    /// Map.
    pub map: MapConfig,
    /// Start.
    pub start: StartConfig,
    /// Goal.
    pub goal: GoalConfig,
    /// Vehicle.
    #[serde(default = "default_vehicle")]
    pub vehicle: VehicleConfig,
    /// Planner.
    #[serde(default = "default_planner")]
    pub planner: PlannerConfig,
    /// Tracker (MPC); its `wheelbase` is taken from the vehicle.
    pub tracker: TrackerConfig,
    /// Simulation.
    pub simulation: SimulationConfig,
}
fn default_vehicle() -> VehicleConfig {
    VehicleConfig {
        preset: default_preset(),
        length: None,
        width: None,
        wheelbase: None,
        mass: None,
        max_steer_deg: None,
        max_steer_rate_deg: None,
        max_accel: None,
        max_decel: None,
        max_speed: None,
        max_lat_accel: None,
    }
}
fn default_planner() -> PlannerConfig {
    PlannerConfig {
        samples: default_samples(),
        eta: default_eta(),
        radius: None,
        k_nearest: None,
        seed: default_seed(),
        margin: default_margin(),
        corridor_ds: default_ds(),
    }
}

/// Tracker settings as written in the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerConfig {
    /// Horizon N.
    #[serde(default = "default_horizon")]
    pub horizon: usize,
    /// Control period and prediction step (s).
    pub dt: f64,
    /// State weights (x, y, ψ, v).
    #[serde(default = "default_q")]
    pub q: [f64; 4],
    /// Terminal weight multiplier.
    #[serde(default = "default_qt")]
    pub q_terminal: f64,
    /// Input weights (a, δ).
    #[serde(default = "default_r")]
    pub r: [f64; 2],
    /// Input-rate weights (a, δ).
    #[serde(default = "default_rr")]
    pub r_rate: [f64; 2],
}
fn default_horizon() -> usize {
    20
}
fn default_q() -> [f64; 4] {
    MpcConfig::default().q
}
fn default_qt() -> f64 {
    MpcConfig::default().q_terminal
}
fn default_r() -> [f64; 2] {
    MpcConfig::default().r
}
fn default_rr() -> [f64; 2] {
    MpcConfig::default().r_rate
}

/// Why a closed-loop run could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// Bad configuration.
    #[error("configuration: {0}")]
    Config(String),
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

/// A stretch of the path driven in one direction: its corridor, built and
/// tracked in the direction of travel (for a reversing leg the body is
/// mirrored, [`PlanningGrid::reversed`], and the controller drives the
/// vehicle turned around: heading + π, speed, acceleration and steering
/// negated — the kinematic bicycle's equations are the same).
#[derive(Clone, Debug, PartialEq)]
pub struct Leg {
    /// The reference along the leg, in the direction of travel.
    pub corridor: Corridor,
    /// Driven backwards.
    pub reverse: bool,
    /// What the corridor was built with (the leg is rebuilt from where
    /// the vehicle actually stopped before it).
    limits: SpeedLimits,
    end_heading: Option<f64>,
}

impl Leg {
    /// A forward leg (the whole path of a run that never reverses).
    fn forward(corridor: Corridor, limits: &SpeedLimits) -> Self {
        Self {
            corridor,
            reverse: false,
            limits: *limits,
            end_heading: None,
        }
    }

    /// The leg started again from where the vehicle stands (`at`) and the
    /// way it faces (`travel`: its direction of travel on this leg), if
    /// its body fits along the result: the vehicle stops a centimetre or
    /// two off the cusp and turned by a hundredth of a radian, which a leg
    /// that starts slowly would otherwise carry for metres.
    pub(crate) fn restarted_at(
        &self,
        at: Vec2,
        travel: f64,
        grid: &PlanningGrid,
        ds: f64,
    ) -> Option<Corridor> {
        // From where it stands on along the planned points it has not
        // passed: those after the nearest of the first few metres (a
        // vehicle that stalled short of the cusp stands past the next
        // leg's first points).
        let planned = &self.corridor.raw;
        let nearest = planned
            .iter()
            .take(60)
            .enumerate()
            .min_by(|a, b| a.1.distance(at).total_cmp(&b.1.distance(at)))?
            .0;
        let mut raw = vec![at];
        raw.extend_from_slice(planned.get(nearest + 1..)?);
        if raw.len() < 2 {
            return None;
        }
        let limits = SpeedLimits {
            start_heading: Some(travel),
            ..self.limits
        };
        let c = Corridor::along_to(&raw, grid, ds, &limits, self.end_heading);
        c.first_blocked(grid).is_none().then_some(c)
    }
}

/// How the vehicle turned around drives a leg: (sign of its speed,
/// acceleration and steering; what its heading gains) — (−1, π) on a
/// reversing leg, (1, 0) on a forward one.
pub(crate) fn turned_around(reverse: bool) -> (f64, f64) {
    if reverse {
        (-1.0, std::f64::consts::PI)
    } else {
        (1.0, 0.0)
    }
}

/// Top speed driving backwards (m/s): a walking pace and a half, as
/// drivers reverse (and what keeps a long body's swing small).
pub const REVERSE_SPEED_MAX: f64 = 2.0;

/// The legs of a path, one per direction (a path that never reverses is
/// one forward leg along it): each leg's corridor leaves in the direction
/// the vehicle is in at its start (the start heading, then the previous
/// leg's end turned around), a leg after a cusp from rest; `grid_for`
/// gives the grid of a direction (reversing: the body mirrored).
fn legs_along<'g>(
    segments: &[crate::hybrid::PathSegment],
    grid_for: &dyn Fn(bool) -> &'g PlanningGrid,
    ds: f64,
    limits: &SpeedLimits,
) -> Vec<Leg> {
    // The direction of travel at a cusp, from the search's arcs (points
    // 0.1 m apart): the leg arrives along it and the next one leaves
    // against it — the vehicle's heading is continuous.
    let leaving = |pts: &[Vec2]| match pts {
        [a, b, ..] => Some((*b - *a).heading()),
        _ => None,
    };
    let arriving = |pts: &[Vec2]| match pts {
        [.., a, b] => Some((*b - *a).heading()),
        _ => None,
    };
    let mut legs: Vec<Leg> = Vec::with_capacity(segments.len());
    for (k, seg) in segments.iter().enumerate() {
        let start_heading = match (k, seg.reverse) {
            (0, false) => limits.start_heading,
            (0, true) => limits
                .start_heading
                .map(|h| wrap_angle(h + turned_around(true).1)),
            _ => leaving(&seg.points),
        };
        let end_heading = if k + 1 < segments.len() {
            arriving(&seg.points)
        } else {
            None
        };
        let lim = SpeedLimits {
            start_heading,
            v_max: if seg.reverse {
                limits.v_max.min(REVERSE_SPEED_MAX)
            } else {
                limits.v_max
            },
            // After a cusp the vehicle starts from rest.
            v_start: if k == 0 { limits.v_start } else { 0.0 },
            ..*limits
        };
        legs.push(Leg {
            corridor: Corridor::along_to(&seg.points, grid_for(seg.reverse), ds, &lim, end_heading),
            reverse: seg.reverse,
            limits: lim,
            end_heading,
        });
    }
    legs
}

/// A goal the reference point can be at: a finite point on the map, not
/// inside an obstacle. One inside the margin is planned to (within the
/// goal's tolerance, where the body keeps the margin); one that is not a
/// place is refused with the place and why.
fn goal_on_the_map(pgrid: &PlanningGrid, goal: Vec2) -> Result<(), PlanError> {
    if !(goal.x.is_finite() && goal.y.is_finite()) {
        return Err(PlanError::Config(format!(
            "goal: ({}, {}) is not a finite point",
            goal.x, goal.y
        )));
    }
    let g = &pgrid.grid;
    if g.cell(goal).is_none() {
        let (x1, y1) = (
            g.origin.x + g.width as f64 * g.resolution,
            g.origin.y + g.height as f64 * g.resolution,
        );
        return Err(PlanError::Impossible(format!(
            "the goal ({:.2}, {:.2}) is off the map, which spans x {:.1}..{x1:.1} m, y {:.1}..{y1:.1} m",
            goal.x, goal.y, g.origin.x, g.origin.y
        )));
    }
    if g.is_occupied(goal) {
        return Err(PlanError::Impossible(format!(
            "the goal ({:.2}, {:.2}) lies inside an obstacle",
            goal.x, goal.y
        )));
    }
    Ok(())
}

/// Whether no path exists from `(from, yaw)` to within `end_within` of
/// `goal` on the curvature-bounded search's lattice: a search forwards and
/// backwards at the vehicle's full curvature `kappa_max` that expands every
/// pose reachable from the start without reaching the goal (within
/// [`EXHAUSTIVE_POSES`]). Run only where every other search failed; the
/// text says what was searched.
fn exhausted(
    pgrid: &PlanningGrid,
    from: Vec2,
    yaw: f64,
    goal: Vec2,
    kappa_max: f64,
    end_within: f64,
) -> Option<String> {
    let base = HybridConfig::new(kappa_max, pgrid.grid.resolution);
    let hcfg = HybridConfig {
        goal_tolerance: end_within,
        reverse: true,
        max_expansions: EXHAUSTIVE_POSES,
        steering_in_state: true,
        ..base
    };
    match hybrid_astar(pgrid, from, yaw, goal, &hcfg) {
        // Every reachable pose expanded (and at least the start: a search
        // pruned before it begins proves nothing).
        Err(HybridError::NoPath { expansions, .. })
            if expansions > 0 && expansions < EXHAUSTIVE_POSES =>
        {
            Some(format!(
                "no path exists on the search's lattice: forwards and backwards at the full steering ({:.2} m turns), {:.2} m cells, {} headings, {:.2} m arcs, the body's covering circles keeping the margin, every one of the {expansions} poses reachable from the start was expanded and none came within {end_within:.2} m of the goal",
                1.0 / kappa_max,
                hcfg.cell,
                hcfg.headings,
                hcfg.step
            ))
        }
        _ => None,
    }
}

/// The escape leg out of the margin ([`crate::escape`]) as the path's
/// first leg: it leaves along the start heading (turned around when it
/// reverses), arrives along the leg's end heading and ends at rest, where
/// the planned path starts.
fn escape_leg<'g>(
    e: &crate::escape::Escape,
    yaw: f64,
    grid_for: &dyn Fn(bool) -> &'g PlanningGrid,
    ds: f64,
    limits: &SpeedLimits,
    speed: f64,
) -> Leg {
    let (_, turn) = turned_around(e.reverse);
    let lim = SpeedLimits {
        start_heading: Some(wrap_angle(yaw + turn)),
        v_max: limits.v_max.min(REVERSE_SPEED_MAX),
        v_start: speed.max(0.0),
        ..*limits
    };
    let end_heading = Some(wrap_angle(e.end_yaw + turn));
    Leg {
        corridor: Corridor::along_to(&e.points, grid_for(e.reverse), ds, &lim, end_heading),
        reverse: e.reverse,
        limits: lim,
        end_heading,
    }
}

/// The legs as one corridor to look at: points, arc length and time run
/// on; headings are the vehicle's (the direction of travel + π on a
/// reversing leg) and speeds negative there. One forward leg is itself.
fn joined(legs: &[Leg]) -> Corridor {
    match legs {
        [one] if !one.reverse => one.corridor.clone(),
        _ => {
            let mut out = Corridor {
                smoothed: true,
                jerk_limited: true,
                ..Corridor::default()
            };
            for leg in legs {
                let c = &leg.corridor;
                let (s0, t0) = (out.length(), out.duration());
                let (sign, turn) = turned_around(leg.reverse);
                out.raw.extend(&c.raw);
                out.shortcut.extend(&c.shortcut);
                out.points.extend(&c.points);
                out.s.extend(c.s.iter().map(|s| s0 + s));
                out.time.extend(c.time.iter().map(|t| t0 + t));
                out.heading
                    .extend(c.heading.iter().map(|h| wrap_angle(h + turn)));
                out.curvature.extend(&c.curvature);
                out.speed.extend(c.speed.iter().map(|v| sign * v));
                out.left_bound.extend(&c.left_bound);
                out.right_bound.extend(&c.right_bound);
                out.smoothed &= c.smoothed;
                out.jerk_limited &= c.jerk_limited;
            }
            out
        }
    }
}

/// Footprint sample points of a rear-axle-referenced vehicle.
fn footprint(v: &Vehicle, x: f64, y: f64, yaw: f64) -> Vec<Vec2> {
    let rear = (v.length - v.wheelbase) / 2.0;
    let f = Vec2::from_heading(yaw);
    let n = Vec2::new(-f.y, f.x);
    let base = Vec2::new(x, y);
    let mut pts = Vec::new();
    for i in 0..=8 {
        let along = -rear + v.length * i as f64 / 8.0;
        for j in 0..=2 {
            let across = -v.width / 2.0 + v.width * j as f64 / 2.0;
            pts.push(base + f * along + n * across);
        }
    }
    pts
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

/// Plans, tracks and logs one run. `grid` is the occupancy (already loaded).
pub fn run_closed_loop(
    cfg: &ClosedLoopConfig,
    grid: OccupancyGrid,
) -> Result<ClosedLoopResult, PlanError> {
    run_closed_loop_timed(cfg, grid, &|| 0.0).map(|(r, _)| r)
}

/// Where FMT*'s path cannot be driven (or FMT* found none, or its goal is
/// inside the margin): the curvature-bounded search over forward and
/// reversing motion (a cusp and a metre backwards cost more than one
/// forwards), at 80 % then 95 % of the turning limit, ending within half
/// the goal tolerance, then within it less 10 cm; where none finds a
/// drivable path, the exhaustive search that may prove the run impossible. Returns the
/// search's path in FMT*'s shape (for the views), the legs, and the
/// planner used; `first` is FMT*'s failure, which a refusal quotes.
#[allow(clippy::too_many_arguments)]
fn search_fallback<'g>(
    pgrid: &'g PlanningGrid,
    grid_for: &dyn Fn(bool) -> &'g PlanningGrid,
    drivable: &dyn Fn(&Corridor, &PlanningGrid) -> Result<(), PlanError>,
    (from, from_yaw, goal): (Vec2, f64, Vec2),
    cfg: &ClosedLoopConfig,
    kappa_max: f64,
    limits: &SpeedLimits,
    first: PlanError,
) -> Result<(FmtResult, Vec<Leg>, PathPlanner), PlanError> {
    let pl = &cfg.planner;
    // Curves at 80 % of the limit, so that the controller keeps a
    // fifth of the steering to correct with; where that finds
    // nothing, at 95 %. When no shot reaches the goal itself, a
    // path may end short of it: first within half the goal
    // tolerance; where neither finds a drivable path, within the
    // tolerance less 10 cm for tracking and stopping (the matrix's
    // worst cross-track error is 21 mm) — a search that stops
    // earlier, so it finds paths the first did not (a long truck
    // ending 0.31 m from the goal of the S-bend).
    let half = 0.5 * cfg.goal.tolerance;
    let wide = cfg.goal.tolerance - 0.1;
    let attempt = |share: f64, end_within: f64| {
        let base = HybridConfig::new(share * kappa_max, pgrid.grid.resolution);
        let hcfg = HybridConfig {
            goal_tolerance: end_within,
            reverse: true,
            // Reversing doubles the states, and a manoeuvre with
            // several cusps lies deeper in them.
            max_expansions: 2 * base.max_expansions,
            ..base
        };
        // The error, whether it is the start (which no other
        // turning limit changes), and how close the search came.
        hybrid_astar(pgrid, from, from_yaw, goal, &hcfg)
            .map_err(|e| {
                // (A search pruned before it began — a goal
                // whose nearer end cells the body cannot reach —
                // says nothing of a wider end.)
                let closest = match &e {
                    HybridError::NoPath {
                        closest,
                        expansions,
                        ..
                    } if *expansions > 0 => Some(*closest),
                    _ => None,
                };
                (
                    matches!(e, HybridError::StartBlocked { .. }),
                    closest,
                    e.to_string(),
                )
            })
            .and_then(|h| {
                let legs = legs_along(&h.segments, &grid_for, pl.corridor_ds, limits);
                for leg in &legs {
                    drivable(&leg.corridor, grid_for(leg.reverse))
                        .map_err(|e| (false, None, e.to_string()))?;
                }
                Ok((h, legs, hcfg))
            })
    };
    let mut tries = vec![(0.8, half), (0.95, half)];
    if wide > half {
        tries.extend([(0.8, wide), (0.95, wide)]);
    }
    // How close each curvature's first search came. A search with a
    // wider end expands the same poses in the same order and stops
    // at the first within its end, so it can only succeed where one
    // came that close (or where the first found a path the vehicle
    // could not drive): otherwise it is not run.
    let closest_of = |r: &Result<_, (bool, Option<f64>, String)>| match r {
        Err((_, c, _)) => *c,
        Ok(_) => None,
    };
    let mut found = Err((false, None, String::new()));
    // One search over forward and reversing motion: a cusp and every
    // metre backwards cost more than driving on, so a forward path is
    // taken wherever one costs less, and a manoeuvre with cusps (into a
    // dead end and back out, a turn in three moves, backing into the
    // goal) is found without waiting for forward searches to fail.
    let mut came: Vec<(f64, Option<f64>)> = Vec::new();
    for &(share, end_within) in &tries {
        // A start the body does not fit ends the search: no other
        // turning limit or end changes it.
        let Err((false, _, _)) = found else { break };
        let hopeless = end_within > half
            && came
                .iter()
                .any(|&(s, c)| s == share && c.is_some_and(|c| c > end_within));
        if hopeless {
            continue;
        }
        found = attempt(share, end_within);
        if end_within <= half {
            came.push((share, closest_of(&found)));
        }
    }
    let found = found.map_err(|(_, _, e)| e);
    Ok(match found {
        Ok((h, legs, hcfg)) => {
            // The search's tree in the planner views: its expanded
            // positions after start and goal, its edges in
            // expansion order (the exploration GIF replays them).
            let n = h.explored.len();
            let mut samples = vec![from, goal];
            samples.extend(&h.explored);
            let mut cost = vec![0.0, h.length];
            cost.resize(n + 2, f64::INFINITY);
            let fmt = FmtResult {
                samples,
                parent: vec![None; n + 2],
                cost,
                edges: h.tree.iter().map(|&(a, b)| (a + 2, b + 2)).collect(),
                path: h.points,
                path_cost: h.length,
                radius: 0.0,
                collision_checks: 0,
            };
            let used = PathPlanner::Hybrid {
                radius: 1.0 / hcfg.kappa,
                expansions: h.expansions,
                cusps: h.segments.len().saturating_sub(1),
                fmt_failure: first.to_string(),
            };
            (fmt, legs, used)
        }
        Err(second) => {
            let first = match first {
                PlanError::Infeasible(m) => m,
                e => e.to_string(),
            };
            let why =
                format!("{first}; and a search within the turning limit found none: {second}");
            return Err(
                match exhausted(pgrid, from, from_yaw, goal, kappa_max, half) {
                    Some(proof) => PlanError::Impossible(format!("{why}; {proof}")),
                    None => PlanError::Infeasible(why),
                },
            );
        }
    })
}

/// What planning made, before anything is driven.
#[derive(Debug)]
pub struct Planned {
    /// The grids the planners used (the vehicle's footprint and margin;
    /// the body mirrored for reversing legs).
    pub grids: Grids,
    /// The leg out of the margin, when the start was inside it.
    pub escape: Option<crate::escape::Escape>,
    /// FMT*'s output (or the search's path and tree in its shape).
    pub fmt: FmtResult,
    /// The legs to drive, in order (the escape's first).
    pub legs: Vec<Leg>,
    /// Which planner made the path.
    pub planner: PathPlanner,
}

/// The planning chain of [`run_closed_loop`] alone, from the
/// configuration's start (pose and speed) to its goal on `grid`: the
/// escape from the margin, FMT*, the curvature-bounded search over
/// forward and reversing motion where FMT*'s path cannot be driven, the
/// exhaustive search that may prove the run impossible; then the legs to
/// drive ([`crate::follow::LegFollower`]). What a system under test that
/// plans for itself calls (the `fmt-mpc` SUT of scenarios).
pub fn plan(cfg: &ClosedLoopConfig, grid: OccupancyGrid) -> Result<Planned, PlanError> {
    let veh = cfg.vehicle.resolve()?;
    let kappa_max = veh.max_steer.tan() / veh.wheelbase;
    plan_path(cfg, &veh, grid, kappa_max)
}

/// The planning chain of a closed-loop run: the start's escape from the
/// margin, FMT*, and where its path cannot be driven the curvature-bounded
/// search (forwards, then reversing; where none finds a path, the
/// exhaustive search that may prove the run impossible); then the legs,
/// each a corridor to track. `kappa_max` is the vehicle's tightest
/// curvature (1/m).
fn plan_path(
    cfg: &ClosedLoopConfig,
    veh: &Vehicle,
    grid: OccupancyGrid,
    kappa_max: f64,
) -> Result<Planned, PlanError> {
    let pl = &cfg.planner;
    if !(pl.margin.is_finite() && pl.margin >= 0.0) {
        return Err(PlanError::Config(format!(
            "planner.margin must be ≥ 0, got {}",
            pl.margin
        )));
    }
    let pgrid = PlanningGrid::with_footprint(
        grid,
        veh.length,
        veh.width,
        (veh.length - veh.wheelbase) / 2.0,
        pl.margin,
    );
    let start = Vec2::new(cfg.start.x, cfg.start.y);
    let goal = Vec2::new(cfg.goal.x, cfg.goal.y);
    // A start inside the margin (the body free, but closer to an obstacle
    // or the map's edge than the planners keep it) is left along one short
    // leg, and the path planned from where that leg ends ([`crate::escape`]);
    // a body that overlaps an obstacle or leaves the map is refused here.
    let escape = crate::escape::from_start(
        &pgrid,
        start,
        cfg.start.yaw,
        0.8 * kappa_max,
        0.5 * pgrid.grid.resolution,
        crate::escape::max_escape(veh.length),
    )
    .map_err(|e| match e {
        // A body that cannot stand where the vehicle starts: no planner
        // can start there.
        crate::escape::StartError::Overlap { .. } => PlanError::Impossible(e.to_string()),
        _ => PlanError::Infeasible(e.to_string()),
    })?;
    let (from, from_yaw) = escape
        .as_ref()
        .map_or((start, cfg.start.yaw), |e| (e.end, e.end_yaw));
    goal_on_the_map(&pgrid, goal)?;
    let radius = match (pl.radius, pl.k_nearest) {
        (Some(r), _) => Radius::Fixed(r),
        (None, Some(k)) => Radius::KNearest(k),
        _ => Radius::Eta(pl.eta),
    };
    let limits = SpeedLimits {
        v_max: veh.max_speed,
        a_lat_max: veh.max_lat_accel,
        a_max: veh.max_accel * 0.8,
        d_max: veh.max_decel * 0.5,
        // After an escape leg the vehicle has stopped where the path starts.
        v_start: if escape.is_some() {
            0.0
        } else {
            cfg.start.speed.max(0.5)
        },
        // Half the steering rate: the other half is the controller's
        // to correct errors with.
        kappa_rate_max: 0.5 * veh.max_steer_rate / veh.wheelbase,
        kappa_max,
        jerk_max: JERK_MAX,
        start_heading: Some(from_yaw),
    };
    // A path the vehicle cannot drive is refused before it is driven: too
    // tight a turn, or a body that does not fit where the path goes.
    let drivable = |corridor: &Corridor, pgrid: &PlanningGrid| -> Result<(), PlanError> {
        let turn = corridor.turn_curvature(TURN_HALF_ARC);
        if let Some(i) = (0..turn.len())
            .filter(|&i| turn[i].abs() > kappa_max * TURN_SLACK)
            .max_by(|&a, &b| turn[a].abs().total_cmp(&turn[b].abs()))
        {
            let p = corridor.points[i];
            return Err(PlanError::Infeasible(format!(
                "the smoothed path turns with a {:.2} m radius at ({:.1}, {:.1}); the {} turns no tighter than {:.2} m (wheelbase {} m, steering {:.0}°)",
                1.0 / turn[i].abs(),
                p.x,
                p.y,
                cfg.vehicle.preset,
                1.0 / kappa_max,
                veh.wheelbase,
                veh.max_steer.to_degrees()
            )));
        }
        if let Some(p) = corridor.first_blocked(pgrid) {
            return Err(PlanError::Infeasible(format!(
                "the {} m × {} m body does not fit along the path at ({:.1}, {:.1}) with a {} m margin",
                veh.length, veh.width, p.x, p.y, pl.margin
            )));
        }
        Ok(())
    };
    // FMT* first (shortest, fast); when its path cannot be driven — its
    // straight edges leave no room for this body, or its corners are
    // tighter than the vehicle turns — the curvature-bounded search plans
    // arcs the vehicle can follow.
    let by_fmt = fmt_star(
        &pgrid,
        from,
        goal,
        &FmtConfig {
            samples: pl.samples,
            radius,
            seed: pl.seed,
        },
    )
    .map_err(PlanError::from)
    .and_then(|fmt| {
        let corridor = Corridor::build(&fmt.path, &pgrid, pl.corridor_ds, &limits);
        drivable(&corridor, &pgrid)?;
        Ok((fmt, corridor))
    });
    // The body mirrored, for stretches driven backwards (made only when a
    // path reverses).
    let grids = Grids::new(pgrid);
    let pgrid = &grids.forward;
    let grid_for = |reverse: bool| grids.for_direction(reverse);
    let (fmt, mut legs, planner) = match by_fmt {
        Ok((fmt, corridor)) => {
            let used = PathPlanner::Fmt {
                samples: fmt.samples.len() - 2,
                radius: fmt.radius,
            };
            let legs = vec![Leg::forward(corridor, &limits)];
            (fmt, legs, used)
        }
        // A goal inside the margin (on the map, not in an obstacle:
        // checked above) is FMT*'s refusal, not the search's: its path may
        // end within the goal's tolerance where the body keeps the margin.
        Err(
            first @ (PlanError::Infeasible(_)
            | PlanError::Plan(FmtError::NoPath { .. } | FmtError::GoalInCollision(..))),
        ) => search_fallback(
            pgrid,
            &grid_for,
            &drivable,
            (from, from_yaw, goal),
            cfg,
            kappa_max,
            &limits,
            first,
        )?,
        Err(e) => return Err(e),
    };
    if let Some(e) = &escape {
        legs.insert(
            0,
            escape_leg(
                e,
                cfg.start.yaw,
                &grid_for,
                pl.corridor_ds,
                &limits,
                cfg.start.speed,
            ),
        );
    }
    Ok(Planned {
        grids,
        escape,
        fmt,
        legs,
        planner,
    })
}

/// [`run_closed_loop`], also timing planning and each MPC solve with
/// `clock` (seconds from any origin). The clock never influences results.
pub fn run_closed_loop_timed(
    cfg: &ClosedLoopConfig,
    grid: OccupancyGrid,
    clock: &dyn Fn() -> f64,
) -> Result<(ClosedLoopResult, Timings), PlanError> {
    let mut timings = Timings::default();
    let veh = cfg.vehicle.resolve()?;
    let sim = cfg.simulation;
    if !(sim.dt.is_finite() && sim.dt > 0.0 && sim.horizon.is_finite() && sim.horizon > 0.0) {
        return Err(PlanError::Config(format!(
            "simulation: dt ({}) and horizon ({}) must be positive",
            sim.dt, sim.horizon
        )));
    }
    let ratio = cfg.tracker.dt / sim.dt;
    if !(ratio.is_finite() && ratio >= 1.0 - 1e-9 && (ratio - ratio.round()).abs() < 1e-6) {
        return Err(PlanError::Config(format!(
            "tracker.dt = {} s must be a whole multiple of simulation.dt = {} s",
            cfg.tracker.dt, sim.dt
        )));
    }
    let every = ratio.round() as u64;
    let mut mpc = Mpc::new(MpcConfig {
        horizon: cfg.tracker.horizon,
        dt: cfg.tracker.dt,
        wheelbase: veh.wheelbase,
        q: cfg.tracker.q,
        q_terminal: cfg.tracker.q_terminal,
        r: cfg.tracker.r,
        r_rate: cfg.tracker.r_rate,
        max_steer: veh.max_steer,
        max_steer_rate: veh.max_steer_rate,
        min_accel: -veh.max_decel,
        max_accel: veh.max_accel,
        // Predict with the world's own integration step.
        substeps: every as usize,
    })?;
    let pl = &cfg.planner;
    // The tightest turn the vehicle can drive (1/m): the corridor is
    // shaped towards it, and a path beyond it is refused below.
    let kappa_max = veh.max_steer.tan() / veh.wheelbase;
    let t_plan = clock();
    let Planned {
        grids,
        escape,
        fmt,
        legs,
        planner,
    } = plan_path(cfg, &veh, grid, kappa_max)?;
    let pgrid = &grids.forward;
    let start = Vec2::new(cfg.start.x, cfg.start.y);
    let goal = Vec2::new(cfg.goal.x, cfg.goal.y);
    timings.plan_s = clock() - t_plan;

    // The world: one vehicle on direct (acceleration, steering) control.
    let mut world = World::new(sim.dt)?;
    let mut bike = KinematicBicycle::new(veh.wheelbase);
    bike.max_steering_angle = veh.max_steer;
    bike.max_acceleration = veh.max_accel;
    bike.max_deceleration = veh.max_decel;
    bike.max_speed = veh.max_speed;
    bike.reverse = legs.first().is_some_and(|l| l.reverse);
    let desc = ActorDescription {
        kind: ActorKind::Vehicle(VehicleCategory::Car),
        actor_type: "Ego".into(),
        model: cfg.vehicle.preset.clone(),
        length: veh.length,
        width: veh.width,
        height: 1.5,
        mass: veh.mass,
        properties: Default::default(),
    };
    let mut st = ActorState::at_rest(Pose::planar(start.x, start.y, cfg.start.yaw));
    st.speed = cfg.start.speed.max(0.0);
    world.add_actor(Actor::new(
        "ego",
        desc,
        st,
        Some(VehicleModelKind::Bicycle(bike.clone())),
    ))?;

    let mut rec = LogRecorder::new(sim.dt);
    rec.meta("kind", "closed_loop");
    rec.meta(
        "planner",
        match &planner {
            PathPlanner::Fmt { .. } => format!("FMT* n={} seed={}", pl.samples, pl.seed),
            other => other.to_string(),
        },
    );
    rec.meta(
        "tracker",
        format!("MPC N={} dt={}", cfg.tracker.horizon, cfg.tracker.dt),
    );
    rec.meta("vehicle", &cfg.vehicle.preset);
    rec.record_world(&world);
    let mut tracking = TrackingColumns::default();
    let mut mpc_error: Option<MpcError> = None;
    let mut collided = false;
    let mut min_clear = f64::INFINITY;
    let stop = litesim_core::StopCondition {
        actor: "ego".into(),
        goal,
        radius: cfg.goal.tolerance,
        speed_threshold: cfg.goal.stop_speed,
    };
    let tdt = cfg.tracker.dt;
    let check = |w: &World, min_clear: &mut f64, collided: &mut bool| {
        if let Some(a) = w.actor("ego") {
            let p = a.state().pose;
            for q in footprint(&veh, p.position.x, p.position.y, p.yaw) {
                // On an obstacle or off the map, beyond touching (a body
                // parked on the map's edge is not a collision).
                if crate::escape::blocked(pgrid, q) {
                    *collided = true;
                }
                let d = pgrid.clearance(q);
                if d < *min_clear {
                    *min_clear = d;
                }
            }
        }
    };
    let mut follower = LegFollower::new(
        legs,
        FollowerVehicle {
            wheelbase: veh.wheelbase,
            max_steer: veh.max_steer,
            max_steer_rate: veh.max_steer_rate,
        },
        pl.corridor_ds,
    );
    let mut control = |w: &mut World| {
        if !w.tick().is_multiple_of(every) || mpc_error.is_some() {
            return;
        }
        let Some(a) = w.actor("ego") else { return };
        let st = a.state();
        let state = (st.pose.position.xy(), st.pose.yaw, st.speed);
        match follower.command(&grids, &mut mpc, state, tdt, clock) {
            Ok(steer) => {
                timings.mpc_s.push(steer.solve_s);
                // The gear changes with the leg.
                if steer.gear_changed {
                    let mut geared = bike.clone();
                    geared.reverse = steer.reverse;
                    let _ = w.set_model("ego", VehicleModelKind::Bicycle(geared));
                }
                if let Some(why) = &steer.fallback {
                    tracking.fallback.push((w.tick(), why.clone()));
                }
                tracking.tick.push(w.tick());
                tracking.lateral_error.push(steer.lateral_error);
                tracking.heading_error.push(steer.heading_error);
                tracking.progress.push(steer.progress);
                tracking.cmd_acceleration.push(steer.acceleration);
                tracking.cmd_steering.push(steer.steering);
                tracking.predictions.push(steer.predicted);
                let _ = w.set_mode(
                    "ego",
                    ControlMode::Dynamic {
                        input: VehicleInput::Direct {
                            acceleration: steer.acceleration,
                            steering_angle: steer.steering,
                        },
                        valid_until_tick: None,
                    },
                );
            }
            Err(e) => mpc_error = Some(e),
        }
    };
    // The loop of `run_loop`, plus the verdict: the run ends at the first
    // contact of the footprint with an obstacle (driving on through a wall
    // says nothing more about the controller).
    let mut steps = 0u64;
    let mut collision = None;
    // A start inside the margin: until when the body stayed inside it.
    let mut inside_until = None;
    for _ in 0..litesim_core::steps_for_horizon(sim.horizon, sim.dt) {
        control(&mut world);
        world.step();
        steps += 1;
        rec.record_world(&world);
        check(&world, &mut min_clear, &mut collided);
        if escape.is_some()
            && inside_until.is_none()
            && let Some(a) = world.actor("ego")
        {
            let p = a.state().pose;
            if pgrid.pose_free(p.position.xy(), p.yaw) {
                inside_until = Some(world.time());
            }
        }
        if collided {
            let p = world.actor("ego").map(|a| a.state().pose.position.xy());
            collision = Some((world.time(), p.map_or([f64::NAN; 2], |p| [p.x, p.y])));
            break;
        }
        if stop.reached(&world) {
            break;
        }
    }
    if let Some((t, [x, y])) = collision {
        rec.meta(
            "verdict",
            format!("collision at t = {t:.2} s, rear axle at ({x:.2}, {y:.2})"),
        );
    }
    if let Some(e) = mpc_error {
        return Err(PlanError::Mpc(e));
    }
    let legs = follower.into_legs();
    let reached = stop.reached(&world);
    let (goal_distance, final_speed) = world.actor("ego").map_or((f64::NAN, f64::NAN), |a| {
        let st = a.state();
        (st.pose.position.xy().distance(goal), st.speed.abs())
    });
    let abs: Vec<f64> = tracking.lateral_error.iter().map(|e| e.abs()).collect();
    let max_cte = abs.iter().copied().fold(0.0, f64::max);
    let mean_cte = if abs.is_empty() {
        0.0
    } else {
        abs.iter().sum::<f64>() / abs.len() as f64
    };
    let g = &pgrid.grid;
    let cells: Vec<u8> = pgrid
        .layers()
        .iter()
        .map(|l| match l {
            Layer::Free => 0,
            Layer::Inflated => 1,
            Layer::Hard => 2,
        })
        .collect();
    let mut log = rec.finish();
    let corridor = joined(&legs);
    log.plan = Some(PlanRecord {
        samples: fmt.samples.iter().map(|p| [p.x, p.y]).collect(),
        edges: fmt.edges.iter().map(|&(a, b)| [a, b]).collect(),
        radius: fmt.radius,
        raw_path: fmt.path.iter().map(|p| [p.x, p.y]).collect(),
        corridor: corridor.points.iter().map(|p| [p.x, p.y]).collect(),
        corridor_speed: corridor.speed.clone(),
        left_bound: corridor.left_bound.clone(),
        right_bound: corridor.right_bound.clone(),
        smoothed: corridor.smoothed,
        grid: GridRecord {
            width: g.width,
            height: g.height,
            resolution: g.resolution,
            origin: [g.origin.x, g.origin.y],
            cells,
        },
        reference_name: String::new(),
    });
    log.tracking = Some(tracking);
    let start_escape = escape.as_ref().map(|e| StartEscape {
        depth: e.depth,
        length: e.length,
        reverse: e.reverse,
        inside_s: inside_until,
    });
    if let Some(e) = &start_escape {
        log.meta.insert("start".into(), e.to_string());
    }
    let result = ClosedLoopResult {
        time: world.time(),
        steps,
        reached_goal: reached,
        goal_rule: (cfg.goal.tolerance, cfg.goal.stop_speed),
        goal_distance,
        final_speed,
        path_length: fmt.path_cost,
        max_cross_track: max_cte,
        mean_cross_track: mean_cte,
        min_clearance: min_clear,
        collided,
        collision,
        log,
        fmt,
        corridor,
        legs,
        grid: grids.into_forward(),
        planner,
        start_escape,
    };
    Ok((result, timings))
}

/// Builds the occupancy grid a configuration names; `png` and `opendrive`
/// paths are relative to `base` (the configuration's folder). The one
/// place this crate reads files.
pub fn load_grid(
    cfg: &ClosedLoopConfig,
    base: &std::path::Path,
) -> Result<OccupancyGrid, PlanError> {
    let m = &cfg.map;
    let origin = Vec2::new(m.origin[0], m.origin[1]);
    match (&m.png, &m.opendrive) {
        (Some(_), Some(_)) => Err(PlanError::Config(
            "map: give either png or opendrive, not both".into(),
        )),
        (Some(png), None) => {
            let p = base.join(png);
            let bytes = litesim_core::files::read_bytes(&p, litesim_core::files::MAX_INPUT_BYTES)?;
            OccupancyGrid::from_png(&bytes, m.resolution, origin)
                .map_err(|e| PlanError::Config(format!("{}: {e}", p.display())))
        }
        (None, Some(xodr)) => {
            let p = base.join(xodr);
            let net = litesim_map::RoadNetwork::load(&p)?;
            net.rasterise(m.resolution, 2.0)
                .map_err(|e| PlanError::Config(format!("{}: {e}", p.display())))
        }
        (None, None) => Ok(OccupancyGrid::from_obstacles(
            origin,
            (m.size[0], m.size[1]),
            m.resolution,
            &m.obstacles,
        )?),
    }
}

/// Parses a configuration (TOML), naming the offending key on error.
pub fn parse_config(text: &str) -> Result<ClosedLoopConfig, PlanError> {
    toml_parse(text)
}

fn toml_parse(text: &str) -> Result<ClosedLoopConfig, PlanError> {
    toml::from_str(text).map_err(|e| PlanError::Config(e.to_string()))
}
