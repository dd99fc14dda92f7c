//! A closed-loop run's configuration (TOML): map, start, goal, vehicle and
//! its presets, planner, tracker, simulation; its parsing and the map it
//! names as a grid.

use super::*;

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

pub(super) fn default_tolerance() -> f64 {
    1.0
}

pub(super) fn default_stop() -> f64 {
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

pub(super) fn default_preset() -> String {
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

pub(super) fn default_samples() -> usize {
    2000
}

pub(super) fn default_eta() -> f64 {
    0.5
}

pub(super) fn default_seed() -> u64 {
    1
}

pub(super) fn default_margin() -> f64 {
    0.4
}

pub(super) fn default_ds() -> f64 {
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

pub(super) fn default_vehicle() -> VehicleConfig {
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

pub(super) fn default_planner() -> PlannerConfig {
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

pub(super) fn default_horizon() -> usize {
    20
}

pub(super) fn default_q() -> [f64; 4] {
    MpcConfig::default().q
}

pub(super) fn default_qt() -> f64 {
    MpcConfig::default().q_terminal
}

pub(super) fn default_r() -> [f64; 2] {
    MpcConfig::default().r
}

pub(super) fn default_rr() -> [f64; 2] {
    MpcConfig::default().r_rate
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
                .map_err(|source| PlanError::GridFile { path: p, source })
        }
        (None, Some(xodr)) => {
            let p = base.join(xodr);
            let net = litesim_map::RoadNetwork::load(&p)?;
            net.rasterise(m.resolution, 2.0)
                .map_err(|source| PlanError::GridFile { path: p, source })
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

pub(super) fn toml_parse(text: &str) -> Result<ClosedLoopConfig, PlanError> {
    Ok(toml::from_str(text)?)
}
