//! The system under test (SUT) seam: whatever drives `sut.car`.
//!
//! Each step the runtime hands the SUT an [`Observation`] (the object list,
//! traffic lights, the ego's road position and its route) and sends the
//! [`SutCommand`] it returns to the simulator as a dynamic move of
//! `sut.car`. SUTs are stepped in lock step with the simulation, so a run
//! with a deterministic SUT is reproducible bit for bit.
//!
//! Built in: [`SutChoice::Planned`] (sut.car follows its plan: the
//! scenario player of the first wave), [`acc::Acc`] (lane-keeping adaptive
//! cruise) and [`fmt_mpc::FmtMpc`] (FMT* on the map's drivable area plus
//! MPC tracking). External SUTs (a gRPC process, a Python object) come in
//! through a [`SutFactory`].

pub mod acc;
pub mod fmt_mpc;
mod route;

pub use route::Route;

use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// One object of the object list (map frame: x east, y north, yaw
/// counter-clockwise from x; SI units).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectState {
    /// Actor id (`sut.car` for the ego).
    pub id: String,
    /// `vehicle`, `person`, `cyclist`, `animal` or `stationary`.
    pub kind: String,
    /// Centre x (m).
    pub x: f64,
    /// Centre y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
    /// Speed (m/s).
    pub speed: f64,
    /// World velocity x (m/s).
    pub vx: f64,
    /// World velocity y (m/s).
    pub vy: f64,
    /// Longitudinal acceleration (m/s²).
    pub acceleration: f64,
    /// Box length (m).
    pub length: f64,
    /// Box width (m).
    pub width: f64,
}

/// A traffic light box as the SUT sees it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LightState {
    /// Box (signal) id.
    pub id: String,
    /// Road the signal stands on.
    pub road: String,
    /// Its s on that road (m).
    pub s: f64,
    /// `red`, `yellow`, `green` or `off`.
    pub color: String,
}

/// Where the ego is on the road network.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RoadPos {
    /// Road id.
    pub road: String,
    /// Lane id (OpenDRIVE: negative right of the reference line).
    pub lane: i32,
    /// s along the road (m).
    pub s: f64,
    /// Offset from the lane centre (m, left positive).
    pub offset: f64,
}

/// What the SUT is told before the first step.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct SutInfo {
    /// Test file name.
    pub test: String,
    /// Seed of the run.
    pub seed: u64,
    /// OpenDRIVE map path (empty when the test has none).
    pub map_path: String,
    /// Simulation step (ms).
    pub step_ms: u32,
    /// The ego's id (`sut.car`).
    pub ego_id: String,
    /// Ego box length (m).
    pub length: f64,
    /// Ego box width (m).
    pub width: f64,
    /// Wheelbase (m).
    pub wheelbase: f64,
    /// Largest road-wheel angle (rad).
    pub max_steer: f64,
    /// Largest acceleration (m/s²).
    pub max_accel: f64,
    /// Largest deceleration (m/s², positive).
    pub max_decel: f64,
    /// The route to the goal: the ego's planned path.
    pub route: Route,
    /// How long the SUT may take to answer one call (s); external SUTs
    /// that take longer end the run with a sut error.
    pub timeout_s: f64,
    /// The map, for in-process SUTs (external ones read `map_path`).
    #[serde(skip)]
    pub map: Option<Arc<litesim_map::RoadNetwork>>,
}

/// What the SUT sees at one step.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Observation {
    /// Step index (the command applies from this tick to the next).
    pub tick: u64,
    /// Simulation time (s) = tick · step.
    pub time: f64,
    /// The ego.
    pub ego: ObjectState,
    /// Every other actor.
    pub objects: Vec<ObjectState>,
    /// Traffic light boxes.
    pub lights: Vec<LightState>,
    /// The ego's road position, when on a road.
    pub road: Option<RoadPos>,
    /// Speed the scenario asks of the ego now (m/s).
    pub requested_speed: f64,
    /// Distance from the ego to the route's goal along the route (m).
    pub distance_to_goal: f64,
}

/// The SUT's command for `sut.car`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum SutCommand {
    /// Normalised pedals 0..1 and steering −1..1 (+ = left).
    Pedals {
        /// Throttle.
        throttle: f64,
        /// Brake.
        brake: f64,
        /// Steering.
        steering: f64,
    },
    /// Physical forces and steering-wheel angle (the profile's actuator units).
    Physical {
        /// Drive force (N).
        drive_force_n: f64,
        /// Brake force (N).
        brake_force_n: f64,
        /// Steering-wheel angle (rad, + = left).
        steering_wheel_angle_rad: f64,
    },
    /// Target acceleration and path curvature, in a gear.
    Accel {
        /// Acceleration (m/s²) along the direction of travel: reversing, a
        /// positive one speeds the vehicle up backwards.
        acceleration: f64,
        /// Curvature of the wheels (1/m, tan δ / L, + = left): reversing
        /// with it positive, the heading turns right.
        curvature: f64,
        /// Reverse gear: the vehicle drives backwards (its speed ≤ 0). The
        /// gear changes when the command's does; a vehicle moving the other
        /// way is braked to rest first.
        #[serde(default)]
        reverse: bool,
    },
}

/// A command the vehicle cannot take ([`SutCommand::validate`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CommandError {
    /// NaN or infinite.
    #[error("{name} is {value}, expected a finite number")]
    NotFinite {
        /// The command's field.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// Outside the field's range.
    #[error("{name} is {value}, expected {lo}..{hi}")]
    OutOfRange {
        /// The command's field.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The range's ends.
        lo: f64,
        /// (inclusive)
        hi: f64,
    },
}

impl SutCommand {
    /// Every number is finite and pedals/steering are in range.
    pub fn validate(&self) -> Result<(), CommandError> {
        let check = |name: &'static str, value: f64, lo: f64, hi: f64| {
            if !value.is_finite() {
                Err(CommandError::NotFinite { name, value })
            } else if value < lo || value > hi {
                Err(CommandError::OutOfRange {
                    name,
                    value,
                    lo,
                    hi,
                })
            } else {
                Ok(())
            }
        };
        match *self {
            SutCommand::Pedals {
                throttle,
                brake,
                steering,
            } => {
                check("throttle", throttle, 0.0, 1.0)?;
                check("brake", brake, 0.0, 1.0)?;
                check("steering", steering, -1.0, 1.0)
            }
            SutCommand::Physical {
                drive_force_n,
                brake_force_n,
                steering_wheel_angle_rad,
            } => {
                check("drive_force_n", drive_force_n, 0.0, 1e7)?;
                check("brake_force_n", brake_force_n, 0.0, 1e7)?;
                check(
                    "steering_wheel_angle_rad",
                    steering_wheel_angle_rad,
                    -12.6,
                    12.6,
                )
            }
            SutCommand::Accel {
                acceleration,
                curvature,
                ..
            } => {
                check("acceleration", acceleration, -100.0, 100.0)?;
                check("curvature", curvature, -10.0, 10.0)
            }
        }
    }
}

/// Why a SUT could not answer.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct SutError(pub String);

/// A system under test, stepped in lock step with the simulation.
pub trait Sut: Send {
    /// A short name for summaries (`acc`, `grpc://127.0.0.1:5000`).
    fn name(&self) -> String;
    /// Called once before the first step of a run.
    fn reset(&mut self, info: &SutInfo) -> Result<(), SutError>;
    /// One step: the object list in, a command for `sut.car` out.
    fn step(&mut self, obs: &Observation) -> Result<SutCommand, SutError>;
    /// [`Sut::step`] given the run's own observation, shared: what the run
    /// calls. A SUT that keeps the observation past the call (a Python
    /// object gets one it may store) takes a reference instead of a copy;
    /// the run changes its observation copy-on-write, so what the SUT holds
    /// never changes under it. The default is [`Sut::step`].
    fn step_shared(&mut self, obs: &Arc<Observation>) -> Result<SutCommand, SutError> {
        self.step(obs)
    }
    /// What the SUT has to report since it was last asked (an emergency
    /// stage that fired, and why): the run's summary lists it as notes.
    fn notes(&mut self) -> Vec<String> {
        Vec::new()
    }
}

/// Makes a fresh SUT for each run (external SUTs: a connection each).
pub trait SutFactory: Send + Sync {
    /// The name runs report.
    fn name(&self) -> String;
    /// A SUT ready for `reset`.
    fn create(&self) -> Result<Box<dyn Sut>, SutError>;
}

/// Which SUT drives `sut.car` (`--sut NAME`).
#[derive(Clone, Default)]
pub enum SutChoice {
    /// sut.car follows its plan (the default; results as the scenario player).
    #[default]
    Planned,
    /// The built-in reference adaptive cruise (ISO 15622 envelope).
    Acc,
    /// The reference cruise with its emergency-braking stage.
    AccAeb,
    /// The built-in FMT* + MPC stack.
    FmtMpc,
    /// An external SUT.
    External(Arc<dyn SutFactory>),
}

impl std::fmt::Debug for SutChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// The names `--sut` accepts besides `grpc://HOST:PORT`.
pub const BUILTIN: [&str; 4] = ["planned", "acc", "acc-aeb", "fmt-mpc"];

impl SutChoice {
    /// Parses a built-in name; `None` for anything else (the caller handles
    /// `grpc://…` and reports the valid names).
    pub fn builtin(name: &str) -> Option<Self> {
        match name {
            "planned" => Some(SutChoice::Planned),
            "acc" => Some(SutChoice::Acc),
            "acc-aeb" | "acc_aeb" => Some(SutChoice::AccAeb),
            "fmt-mpc" | "fmt_mpc" => Some(SutChoice::FmtMpc),
            _ => None,
        }
    }

    /// The name summaries report.
    pub fn name(&self) -> String {
        match self {
            SutChoice::Planned => "planned".into(),
            SutChoice::Acc => "acc".into(),
            SutChoice::AccAeb => "acc-aeb".into(),
            SutChoice::FmtMpc => "fmt-mpc".into(),
            SutChoice::External(f) => f.name(),
        }
    }

    /// A SUT instance for one run; `None` for `planned`.
    pub fn instantiate(&self) -> Result<Option<Box<dyn Sut>>, SutError> {
        Ok(match self {
            SutChoice::Planned => None,
            SutChoice::Acc => Some(Box::new(acc::Acc::default())),
            SutChoice::AccAeb => Some(Box::new(acc::Acc::with_aeb())),
            SutChoice::FmtMpc => Some(Box::new(fmt_mpc::FmtMpc::default())),
            SutChoice::External(f) => Some(f.create()?),
        })
    }
}
