//! The SSP API as a Rust trait, [`Ssp`], and its message types.
//!
//! The call set mirrors the simulator-support API a scenario engine uses
//! (init, launch/terminate, start/wait-start/end simulation, start-step /
//! wait-step, actor create/destroy/params/states, the three move kinds,
//! weather, time of day, sim commands, traffic lights). One trait, two
//! transports: [`crate::Session`] implements it in-process, and
//! `litesim-grpc`'s client implements it over the network, with identical
//! results.
//!
//! Units: SI everywhere (m, s, rad, m/s, N); simulation time in integer ms.

use crate::error::SspResult;
use crate::traffic::{BulbState, LightTarget, TrafficLightBox, TrafficLights};
use litesim_core::{ActorState, Pose, TrajectoryStatus, Vec3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Six optional coordinates, as on the wire: x, y, z (m, m/s, m/s²) and
/// roll, pitch, yaw (rad, rad/s, rad/s²). Absent is not zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Coord6 {
    /// x.
    pub x: Option<f64>,
    /// y.
    pub y: Option<f64>,
    /// z.
    pub z: Option<f64>,
    /// Roll.
    pub roll: Option<f64>,
    /// Pitch.
    pub pitch: Option<f64>,
    /// Yaw.
    pub yaw: Option<f64>,
}

impl Coord6 {
    /// A planar position with heading.
    pub fn xy_yaw(x: f64, y: f64, yaw: f64) -> Self {
        Self {
            x: Some(x),
            y: Some(y),
            yaw: Some(yaw),
            ..Self::default()
        }
    }
}

/// Actor categories on the wire.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum ActorCategory {
    /// Not given: the catalog entry decides (vehicle when there is none).
    #[default]
    Unspecified,
    /// Car, van, bus, truck…
    Vehicle,
    /// Pedestrian.
    Pedestrian,
    /// Cyclist.
    Cyclist,
    /// Motorcycle.
    Motorcycle,
    /// Animal.
    Animal,
    /// Static object.
    StaticObject,
}

/// How an actor is moved.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum MoveMode {
    /// Not given (stored).
    #[default]
    Unspecified,
    /// Stored or xy trajectory.
    Kinematic,
    /// Pedals and steering, or direct acceleration and steering angle.
    Dynamic,
    /// A simulator-side controller.
    External,
}

/// How a profile's actuators are natively commanded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PedalEncoding {
    /// Pedals 0..1, steering −1..1 (CARLA style).
    #[default]
    Normalized,
    /// Forces in N and steering torque in N·m or wheel angle in rad.
    Physical,
}

/// The session's start-up parameters.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct InitRequest {
    /// Who is calling (for traces).
    pub client_name: String,
    /// Step size (ms); 0 = the profile's default.
    pub step_size_ms: u32,
    /// Path or inline text of an OpenDRIVE map; stored, not interpreted here.
    pub map: Option<String>,
    /// Simulator profile ("" = the server's default).
    pub profile: String,
    /// Model ("" = the server's default).
    pub model: String,
    /// Seed for anything random in the session.
    pub seed: u64,
    /// Free-form options.
    pub options: BTreeMap<String, String>,
    /// Traffic-light boxes to add to those of the map.
    pub traffic_lights: Vec<TrafficLightBox>,
    /// Logical traffic lights grouping the boxes.
    pub logical_lights: Vec<crate::traffic::LogicalTrafficLight>,
}

/// A catalog entry of a profile (a blueprint with its real dimensions).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CatalogEntry {
    /// Blueprint / model id, e.g. `vehicle.tesla.model3`.
    pub model_id: String,
    /// Category name (`car`, `van`, `bus`, `truck`, `semitrailer`,
    /// `motorbike`, `emergency`, `bicycle`, `pedestrian`, `animal`, `static`).
    pub category: String,
    /// Length (m).
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// Height (m).
    pub height: f64,
    /// Wheelbase (m); 0 = `0.6 · length` (the seed's rule).
    #[serde(default)]
    pub wheelbase: f64,
    /// Mass (kg).
    #[serde(default = "default_mass")]
    pub mass: f64,
    /// Road-wheel angle at full lock (degrees).
    #[serde(default = "default_steer")]
    pub max_steer_angle_deg: f64,
    /// Steering ratio (steering-wheel angle / road-wheel angle).
    #[serde(default = "default_ratio")]
    pub steering_ratio: f64,
    /// Top speed (m/s).
    #[serde(default = "default_speed")]
    pub max_speed: f64,
    /// Acceleration at full throttle (m/s²).
    #[serde(default = "default_accel")]
    pub max_accel: f64,
    /// Deceleration at full brake (m/s²).
    #[serde(default = "default_decel")]
    pub max_decel: f64,
}

fn default_mass() -> f64 {
    1500.0
}
fn default_steer() -> f64 {
    35.0
}
fn default_ratio() -> f64 {
    litesim_core::vehicle::MAX_STEERING_WHEEL_ANGLE / 35f64.to_radians()
}
fn default_speed() -> f64 {
    40.0
}
fn default_accel() -> f64 {
    4.0
}
fn default_decel() -> f64 {
    30.0
}

impl CatalogEntry {
    /// The wheelbase, applying the seed's `0.6 · length` when none is given.
    pub fn effective_wheelbase(&self) -> f64 {
        if self.wheelbase > 0.0 {
            self.wheelbase
        } else {
            litesim_core::seed_wheelbase(self.length)
        }
    }
}

/// What a session can do.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Capabilities {
    /// Profile name.
    pub profile: String,
    /// Model name.
    pub model: String,
    /// Step size in use (ms).
    pub step_size_ms: u32,
    /// Supported move modes.
    pub move_modes: Vec<MoveMode>,
    /// Native actuator encoding.
    pub pedal_encoding: PedalEncoding,
    /// Smallest step (ms).
    pub min_step_ms: u32,
    /// Largest step (ms).
    pub max_step_ms: u32,
    /// Traffic lights can be read and set.
    pub traffic_lights: bool,
    /// Weather can be set.
    pub weather: bool,
    /// Time of day can be set.
    pub time_of_day: bool,
    /// Blueprints.
    pub catalog: Vec<CatalogEntry>,
    /// Verbs accepted by `sim_command`.
    pub sim_commands: Vec<String>,
}

/// The answer to `init`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct InitResponse {
    /// Session id ("local" in-process; the server's id over gRPC).
    pub session_id: String,
    /// What the session can do.
    pub capabilities: Capabilities,
    /// Non-fatal remarks.
    pub diagnostics: Vec<String>,
}

/// How to describe an actor at creation.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActorSpec {
    /// Free text ("Ego", "Vehicle", "Pedestrian").
    pub actor_type: String,
    /// Category; `Unspecified` = from the catalog entry.
    pub category: ActorCategory,
    /// Blueprint id; "" = the profile's default vehicle.
    pub model_id: String,
    /// Length override (m).
    pub length: Option<f64>,
    /// Width override (m).
    pub width: Option<f64>,
    /// Height override (m).
    pub height: Option<f64>,
    /// Free-form properties.
    pub properties: BTreeMap<String, String>,
}

/// `create_actor`'s request.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CreateActor {
    /// Unique id.
    pub actor_id: String,
    /// Description.
    pub spec: ActorSpec,
    /// Initial position; x and y are mandatory.
    pub position: Coord6,
    /// Initial velocity (world frame, m/s; yaw = yaw rate).
    pub speed: Coord6,
    /// Initial acceleration (world frame, m/s²).
    pub acceleration: Coord6,
    /// Initial mode.
    pub initial_mode: MoveMode,
}

/// The description the simulator actually used.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActualDescription {
    /// Free text type.
    pub actor_type: String,
    /// Category.
    pub category: ActorCategory,
    /// Blueprint.
    pub model_id: String,
    /// Length (m).
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// Height (m).
    pub height: f64,
    /// Properties.
    pub properties: BTreeMap<String, String>,
}

/// Turn indicators.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IndicatorState {
    /// Not reported.
    #[default]
    Unspecified,
    /// Off.
    Off,
    /// Left.
    Left,
    /// Right.
    Right,
    /// Hazard.
    Hazard,
}

/// Controls state of an actor (reported; partly settable via `set_actor_params`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActorControls {
    /// Gear "P", "R", "N", "D" or a number.
    pub gear: String,
    /// Hand brake.
    pub hand_brake: Option<bool>,
    /// Hazard lights.
    pub hazard_lights: Option<bool>,
    /// Indicators.
    pub indicators: IndicatorState,
    /// Brake pedal position [0, 1].
    pub brake_pedal_pos: Option<f64>,
    /// Throttle pedal position [0, 1].
    pub throttle_pedal_pos: Option<f64>,
    /// Steering-wheel angle (rad, + = left).
    pub steering_wheel_angle: Option<f64>,
    /// Siren.
    pub siren: Option<bool>,
    /// Emergency lights.
    pub emergency_lights: Option<bool>,
}

/// One actor's reported state.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReportedState {
    /// Actor id. A small string: ids up to 23 bytes are stored inline and
    /// copied, longer ones shared — a state report per actor and step
    /// neither allocates a copy nor touches a shared counter (an `Arc`'s
    /// atomic increment and decrement were ~4 % of a 100-actor run).
    pub actor_id: smol_str::SmolStr,
    /// Pose (m, rad).
    pub pose: Pose,
    /// World-frame velocity (m/s).
    pub velocity: Vec3,
    /// World-frame acceleration (m/s²).
    pub acceleration: Vec3,
    /// Yaw rate (rad/s).
    pub yaw_rate: f64,
    /// Longitudinal speed (m/s).
    pub speed: f64,
    /// Controls state.
    pub controls: ActorControls,
    /// Active move mode.
    pub mode: MoveMode,
    /// Trajectory status.
    pub trajectory: TrajectoryStatus,
}

impl ReportedState {
    /// Mirrors the state across the x axis — between a left-handed frame
    /// (CARLA's) and litesim's right-handed one: y, yaw, roll, the lateral
    /// velocity and acceleration, the yaw rate and the steering-wheel angle
    /// change sign. Its own inverse.
    pub fn mirror_y(&mut self) {
        mirror_motion(
            &mut self.pose,
            &mut self.velocity,
            &mut self.acceleration,
            &mut self.yaw_rate,
        );
        self.controls.steering_wheel_angle = self.controls.steering_wheel_angle.map(|v| -v);
    }
}

/// The motion part of a mirror across the x axis: y, yaw, roll, the
/// lateral velocity and acceleration and the yaw rate change sign.
fn mirror_motion(
    pose: &mut Pose,
    velocity: &mut Vec3,
    acceleration: &mut Vec3,
    yaw_rate: &mut f64,
) {
    pose.position.y = -pose.position.y;
    pose.yaw = -pose.yaw;
    pose.roll = -pose.roll;
    velocity.y = -velocity.y;
    acceleration.y = -acceleration.y;
    *yaw_rate = -*yaw_rate;
}

/// An actor's kinematic state: a [`ReportedState`] without its id,
/// controls and modes — what a checker reads of every actor each step.
///
/// Half the bytes of a report (112 against ~230) and no string: a run that
/// reads every actor at every step gets them from
/// [`Ssp::step_many_kinematics`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Kinematics {
    /// Pose (m, rad).
    pub pose: Pose,
    /// World-frame velocity (m/s).
    pub velocity: Vec3,
    /// World-frame acceleration (m/s²).
    pub acceleration: Vec3,
    /// Yaw rate (rad/s).
    pub yaw_rate: f64,
    /// Longitudinal speed (m/s).
    pub speed: f64,
}

impl Kinematics {
    /// As [`ReportedState::mirror_y`]: y, yaw, roll, the lateral velocity
    /// and acceleration and the yaw rate change sign. Its own inverse.
    pub fn mirror_y(&mut self) {
        mirror_motion(
            &mut self.pose,
            &mut self.velocity,
            &mut self.acceleration,
            &mut self.yaw_rate,
        );
    }
}

impl From<&ActorState> for Kinematics {
    fn from(s: &ActorState) -> Self {
        Kinematics {
            pose: s.pose,
            velocity: s.velocity,
            acceleration: s.acceleration,
            yaw_rate: s.yaw_rate,
            speed: s.speed,
        }
    }
}

impl From<&ReportedState> for Kinematics {
    fn from(s: &ReportedState) -> Self {
        Kinematics {
            pose: s.pose,
            velocity: s.velocity,
            acceleration: s.acceleration,
            yaw_rate: s.yaw_rate,
            speed: s.speed,
        }
    }
}

/// Steps and every actor's [`Kinematics`] after each (what
/// [`Ssp::step_many_kinematics`] fills): the ids once, the states step by
/// step in that order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KinematicSteps {
    /// Each step's info, in order.
    pub infos: Vec<StepInfo>,
    /// The actors, in the order of each step's states.
    pub ids: Vec<smol_str::SmolStr>,
    /// `infos.len() × ids.len()` states, step-major.
    pub states: Vec<Kinematics>,
}

impl KinematicSteps {
    /// Empties it, keeping its memory.
    pub fn clear(&mut self) {
        self.infos.clear();
        self.ids.clear();
        self.states.clear();
    }

    /// Step `k`'s states (one per id).
    pub fn step(&self, k: usize) -> &[Kinematics] {
        let n = self.ids.len();
        &self.states[k * n..(k + 1) * n]
    }

    /// Appends one step's reported states (the first step sets the ids;
    /// a later one must report the same actors in the same order).
    pub fn push_reported(&mut self, info: StepInfo, states: &[ReportedState]) -> SspResult<()> {
        if self.infos.is_empty() {
            self.ids.clear();
            self.ids.extend(states.iter().map(|s| s.actor_id.clone()));
        } else if states.len() != self.ids.len()
            || states
                .iter()
                .zip(&self.ids)
                .any(|(s, id)| s.actor_id != *id)
        {
            return Err(crate::SspError::new(
                crate::ErrorCode::Internal,
                format!(
                    "step {} reported other actors than the steps before it in the same call",
                    info.step_index
                ),
            ));
        }
        self.infos.push(info);
        self.states.extend(states.iter().map(Kinematics::from));
        Ok(())
    }
}

/// Which actors a state query returns.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActorFilter {
    /// Ids; empty = all.
    pub actor_ids: Vec<String>,
    /// Categories; empty = all.
    pub categories: Vec<ActorCategory>,
}

/// An xy trajectory move.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct XyTrajectory {
    /// Time of the first point (ms).
    pub start_time_ms: u64,
    /// Time of the last point (ms).
    pub end_time_ms: u64,
    /// Points; x and y mandatory, yaw optional.
    pub points: Vec<Coord6>,
    /// Explicit point times (ms, strictly increasing); empty = evenly spaced
    /// over `[start_time_ms, end_time_ms]`.
    pub point_times_ms: Vec<u64>,
    /// Optional speeds per point (m/s); empty = derived.
    pub speeds: Vec<f64>,
}

impl XyTrajectory {
    /// Makes this (its memory reused) the move of one step from `now_ms`
    /// to `now_ms + step_ms`: from `from` to `to` at `speed` — what a
    /// controller that decides each step sends.
    pub fn set_step(
        &mut self,
        (now_ms, step_ms): (u64, u64),
        from: Coord6,
        to: Coord6,
        speed: f64,
    ) {
        // The same two slots are overwritten step after step.
        fn put<T: Copy>(v: &mut Vec<T>, pair: [T; 2]) {
            if let [a, b] = v.as_mut_slice() {
                (*a, *b) = (pair[0], pair[1]);
            } else {
                v.clear();
                v.extend(pair);
            }
        }
        self.start_time_ms = now_ms;
        self.end_time_ms = now_ms + step_ms;
        put(&mut self.points, [from, to]);
        put(&mut self.point_times_ms, [now_ms, now_ms + step_ms]);
        put(&mut self.speeds, [speed, speed]);
    }
}

/// Steering in physical units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PhysicalSteer {
    /// Steering torque (N·m).
    TorqueNm(f64),
    /// Steering-wheel angle (rad).
    SteeringWheelAngleRad(f64),
}

/// A dynamic move.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "encoding")]
pub enum DynamicMove {
    /// Pedals 0..1 and steering −1..1 (+ = left).
    Normalized {
        /// Throttle.
        throttle: f64,
        /// Brake.
        brake: f64,
        /// Steering.
        steering: f64,
    },
    /// Forces and steering in physical units.
    Physical {
        /// Drive force (N).
        drive_force_n: f64,
        /// Brake force (N).
        brake_force_n: f64,
        /// Steering.
        steer: PhysicalSteer,
    },
    /// Longitudinal acceleration and road-wheel angle (for planners and MPC).
    Direct {
        /// Acceleration (m/s²).
        acceleration: f64,
        /// Road-wheel angle (rad, + = left).
        steering_angle_rad: f64,
    },
}

/// An external-controller move.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ExternalMove {
    /// Controller: "cruise", "idm", "stop" or "release".
    pub controller: String,
    /// Named parameters (see `Session` docs for each controller's keys).
    pub params: BTreeMap<String, f64>,
    /// Desired speed (m/s).
    pub desired_speed: Option<f64>,
}

/// Weather; scalars without unit suffix are in `[0, 1]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Weather {
    /// Preset name ("clear_noon", …), free text.
    pub preset: String,
    /// Cloudiness.
    pub cloudiness: f64,
    /// Precipitation.
    pub precipitation: f64,
    /// Road wetness.
    pub wetness: f64,
    /// Fog density.
    pub fog_density: f64,
    /// Fog visibility distance (m).
    pub fog_distance_m: f64,
    /// Wind intensity.
    pub wind_intensity: f64,
    /// Sun azimuth (degrees, [0, 360)).
    pub sun_azimuth_deg: f64,
    /// Sun altitude (degrees, [−90, 90]).
    pub sun_altitude_deg: f64,
}

/// Time of day.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TimeOfDay {
    /// Seconds since midnight, `< 86400`.
    pub seconds_since_midnight: u32,
    /// Day of the year, 1..=366.
    pub day_of_year: Option<u32>,
    /// Advance the clock with simulation time.
    pub advance_with_sim: bool,
}

/// The answer to `wait_step`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StepInfo {
    /// Simulation time after the step (ms).
    pub sim_time_ms: u64,
    /// Steps executed so far.
    pub step_index: u64,
}

/// Most steps one [`Ssp::step_many`] call may run (bounds the reply's size).
pub const MAX_STEPS_PER_CALL: u32 = 10_000;

/// Most actor states one `step_many` reply holds (steps × actors): the
/// reply is built whole, so this bounds the memory a single call can make
/// a server take (about 300 bytes a state on the wire, 60 MB at the limit).
pub const MAX_STATES_PER_CALL: u64 = 200_000;

/// Refuses a step count outside `1..=MAX_STEPS_PER_CALL`, naming the range.
pub fn check_step_count(steps: u32) -> SspResult<()> {
    if steps == 0 || steps > MAX_STEPS_PER_CALL {
        return Err(crate::SspError::invalid(format!(
            "steps = {steps}: step_many runs 1 to {MAX_STEPS_PER_CALL} steps per call"
        )));
    }
    Ok(())
}

/// Checks that `steps` steps of `per_step` states each fit in one reply
/// ([`MAX_STATES_PER_CALL`]); the refusal says how many steps would.
/// `filterable`: the call takes an [`ActorFilter`], and the message says
/// that filtering is the other way out.
pub fn check_reply_size(steps: u32, per_step: u64, filterable: bool) -> SspResult<()> {
    let states = u64::from(steps) * per_step;
    if states > MAX_STATES_PER_CALL {
        return Err(crate::SspError::exhausted(format!(
            "steps = {steps} with {per_step} actor states each is {states} states in one reply; the limit is {MAX_STATES_PER_CALL}: ask for at most {} steps per call{}",
            (MAX_STATES_PER_CALL / per_step.max(1)).max(1),
            if filterable {
                " (or filter the states)"
            } else {
                ""
            }
        )));
    }
    Ok(())
}

/// The simulator-support API.
///
/// Calls are refused with `FAILED_PRECONDITION` when the session's life-cycle
/// state does not allow them; the message says the state and what is allowed.
pub trait Ssp: Send {
    /// Initialises the session; must be the first call.
    fn init(&mut self, req: InitRequest) -> SspResult<InitResponse>;
    /// Launches the simulator process (a no-op for the in-process model);
    /// returns the connection string to use.
    fn launch_simulator(&mut self, connection_string: &str) -> SspResult<String>;
    /// Terminates the launched simulator process.
    fn terminate_simulator(&mut self) -> SspResult<()>;
    /// Starts the simulation (asynchronous in real simulators).
    fn start_simulation(&mut self, start_time_ms: u64) -> SspResult<()>;
    /// Waits until the start has completed; returns the simulation time (ms).
    fn wait_start_simulation(&mut self, max_wait_ms: u32) -> SspResult<u64>;
    /// Ends the simulation; returns the number of steps executed.
    fn end_simulation(&mut self, reason: &str) -> SspResult<u64>;
    /// Starts a step to `requested_sim_time_ms` (absolute; `None` = one step).
    fn start_step(&mut self, requested_sim_time_ms: Option<u64>) -> SspResult<u64>;
    /// Waits for the step to finish.
    fn wait_step(&mut self, max_wait_ms: u32) -> SspResult<StepInfo>;
    /// States of the actors selected by `filter`, in creation order.
    fn get_actors_states(&mut self, filter: &ActorFilter) -> SspResult<Vec<ReportedState>>;
    /// Creates an actor; returns the description actually used.
    fn create_actor(&mut self, req: CreateActor) -> SspResult<ActualDescription>;
    /// Destroys an actor.
    fn destroy_actor(&mut self, actor_id: &str) -> SspResult<()>;
    /// Sets parameters (string map) and controls (gear, lights, indicators).
    fn set_actor_params(
        &mut self,
        actor_id: &str,
        params: BTreeMap<String, String>,
        controls: Option<ActorControls>,
    ) -> SspResult<()>;
    /// Sets the weather; returns what was applied.
    fn set_weather(&mut self, weather: Weather) -> SspResult<Weather>;
    /// Sets the time of day.
    fn set_time_of_day(&mut self, tod: TimeOfDay) -> SspResult<()>;
    /// A free-form simulator command; returns its output.
    fn sim_command(&mut self, command: &str, args: &[String]) -> SspResult<String>;
    /// Kinematic move along timed xy points.
    fn set_xy_trajectory(&mut self, actor_id: &str, traj: XyTrajectory) -> SspResult<()>;
    /// Dynamic move; `valid_until_ms` 0 = until replaced.
    fn set_dynamic_move(
        &mut self,
        actor_id: &str,
        cmd: DynamicMove,
        valid_until_ms: u64,
    ) -> SspResult<()>;
    /// Hands the actor to a simulator-side controller.
    fn set_external_controller(&mut self, actor_id: &str, ext: ExternalMove) -> SspResult<()>;
    /// Traffic-light boxes and logical groups.
    fn list_traffic_lights(&mut self) -> SspResult<TrafficLights>;
    /// Sets bulb states of a box or a logical light; returns the affected boxes.
    fn set_traffic_light_state(
        &mut self,
        target: LightTarget,
        states: Vec<BulbState>,
    ) -> SspResult<Vec<TrafficLightBox>>;

    /// [`Ssp::set_xy_trajectory`] from a borrowed trajectory: a caller that
    /// sends every step keeps one buffer. The default clones it; an
    /// in-process simulator reads it in place.
    fn set_xy_trajectory_ref(&mut self, actor_id: &str, traj: &XyTrajectory) -> SspResult<()> {
        self.set_xy_trajectory(actor_id, traj.clone())
    }

    /// One step of [`Ssp::step`] for every actor, the states kept as
    /// [`Kinematics`] in `out` (emptied first; its memory is reused). The
    /// default steps with `step` and converts; an in-process simulator
    /// writes the states straight from its world, with no report made.
    fn step_kinematics(&mut self, out: &mut KinematicSteps) -> SspResult<()> {
        let (info, states) = self.step(None, &ActorFilter::default())?;
        out.clear();
        out.push_reported(info, &states)
    }

    /// Runs `steps` steps back to back, with no commands in between, and
    /// returns what [`Ssp::step`] returns for each. A client whose commands
    /// are already sent (xy trajectories ahead, external controllers) moves
    /// many steps per round trip; `1..=MAX_STEPS_PER_CALL` steps.
    fn step_many(
        &mut self,
        steps: u32,
        filter: &ActorFilter,
    ) -> SspResult<Vec<(StepInfo, Vec<ReportedState>)>> {
        check_step_count(steps)?;
        if steps > 1 {
            check_reply_size(steps, self.count_states(filter)?, true)?;
        }
        (0..steps).map(|_| self.step(None, filter)).collect()
    }

    /// [`Ssp::step_many`] for every actor, their states kept as
    /// [`Kinematics`] in `out` (emptied first; its memory is reused).
    ///
    /// The default steps with `step_many` and converts; an in-process
    /// simulator writes the states straight from its world (a run of 100
    /// vehicles reads half a million states).
    fn step_many_kinematics(&mut self, steps: u32, out: &mut KinematicSteps) -> SspResult<()> {
        let got = self.step_many(steps, &ActorFilter::default())?;
        out.clear();
        for (info, states) in &got {
            out.push_reported(*info, states)?;
        }
        Ok(())
    }

    /// How many states [`Ssp::get_actors_states`] would return for
    /// `filter` now (what [`Ssp::step_many`] checks its reply size with).
    /// The default asks for the states; a simulator that can count them
    /// without making them says so.
    fn count_states(&mut self, filter: &ActorFilter) -> SspResult<u64> {
        Ok(self.get_actors_states(filter)?.len() as u64)
    }

    /// Start-step, wait-step and get-states in one call.
    fn step(
        &mut self,
        requested_sim_time_ms: Option<u64>,
        filter: &ActorFilter,
    ) -> SspResult<(StepInfo, Vec<ReportedState>)> {
        self.start_step(requested_sim_time_ms)?;
        let info = self.wait_step(0)?;
        Ok((info, self.get_actors_states(filter)?))
    }
}
