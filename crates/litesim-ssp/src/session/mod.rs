//! The in-process Model SSP: one simulation session implementing [`Ssp`].
//!
//! Life cycle: `Uninitialized → Initialized → Starting → Running ⇄ Stepping
//! → Ended`. Calls that the current state does not allow are refused with
//! `FAILED_PRECONDITION` and a message naming the state and the allowed calls.
//!
//! Kinematic actors keep what they were given (the seed: "Model SSP does not
//! update actor data"); trajectories, dynamic moves and external controllers
//! move them through `litesim-core`'s [`World`]. Commands take effect at the
//! next step boundary in arrival order; because a step only happens inside
//! `start_step`, applying them at once is the same thing.
//!
//! External controllers and their parameters (all SI):
//! * `cruise` — `desired_speed` (required), `max_acceleration` (2.0);
//! * `idm` — `desired_speed` (required), `max_acceleration` (1.5),
//!   `comfortable_deceleration` (2.0), `time_headway` (1.5), `min_gap` (2.0),
//!   `lane_half_width` (1.75);
//! * `stop` — `deceleration` (3.0);
//! * `release` — back to stored kinematic control at the current state.

use crate::api::*;
use crate::error::{ErrorCode, SspError, SspResult, finite};
use crate::model::{Model, model_by_name};
use crate::profile::{Profile, TrafficLightApi};
use crate::traffic::{BulbState, LightTarget, TrafficLightBox, TrafficLights};
use litesim_core::world::ExternalController;
use litesim_core::{
    Actor, ActorDescription, ActorKind, ActorRef, ActorState, ActuatorLimits, ControlMode,
    DynamicCommand, PedalInput, Pose, SetTrajectoryError, SteeringInput, TimedPoint, Vec3,
    VehicleCategory, VehicleInput, World, WorldError, normalize_command,
};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

mod checks;
mod phase;
use checks::*;
pub use phase::*;

/// Limits that protect a session (and a server) from runaway clients.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SessionLimits {
    /// Actors alive at once.
    pub max_actors: usize,
    /// Points per trajectory call.
    pub max_trajectory_points: usize,
    /// Steps one `start_step` may execute.
    pub max_steps_per_call: u64,
}

impl Default for SessionLimits {
    fn default() -> Self {
        Self {
            max_actors: 10_000,
            max_trajectory_points: 100_000,
            max_steps_per_call: 100_000,
        }
    }
}

#[derive(Clone, Debug)]
struct ActorMeta {
    /// The id as reports carry it.
    id: smol_str::SmolStr,
    category: ActorCategory,
    actual: ActualDescription,
    limits: ActuatorLimits,
    controls: ActorControls,
}

/// One Model SSP session, in-process.
pub struct Session {
    phase: Phase,
    limits: SessionLimits,
    default_profile: String,
    default_model: String,
    profile: Option<Profile>,
    model: Option<Box<dyn Model>>,
    world: Option<World>,
    step_ms: u64,
    // In world order (`World::actors`): a step's report reads it by
    // position, not by id.
    meta: Vec<ActorMeta>,
    weather: Weather,
    time_of_day: TimeOfDay,
    lights: TrafficLights,
    map: Option<String>,
    network: Option<std::sync::Arc<litesim_map::RoadNetwork>>,
    seed: u64,
    launched: bool,
    steps_executed: u64,
    pending_steps: u64,
    /// The points of the trajectory being set (reused from call to call).
    scratch_points: Vec<TimedPoint>,
}

impl Default for Session {
    fn default() -> Self {
        Self::new("dummy", "dummy", SessionLimits::default())
    }
}

impl fmt::Debug for Session {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Session")
            .field("phase", &self.phase)
            .field("profile", &self.profile.as_ref().map(|p| p.name.clone()))
            .field("actors", &self.meta.len())
            .finish()
    }
}

impl Session {
    /// A session whose `init` uses `default_profile` / `default_model` when the request names none.
    pub fn new(default_profile: &str, default_model: &str, limits: SessionLimits) -> Self {
        Self {
            phase: Phase::Uninitialized,
            limits,
            default_profile: default_profile.to_string(),
            default_model: default_model.to_string(),
            profile: None,
            model: None,
            world: None,
            step_ms: 0,
            meta: Vec::new(),
            weather: Weather::default(),
            time_of_day: TimeOfDay::default(),
            lights: TrafficLights::default(),
            map: None,
            network: None,
            seed: 0,
            launched: false,
            steps_executed: 0,
            pending_steps: 0,
            scratch_points: Vec::new(),
        }
    }

    /// The life-cycle state.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The world (after `init`).
    pub fn world(&self) -> Option<&World> {
        self.world.as_ref()
    }

    /// The active profile (after `init`).
    pub fn profile(&self) -> Option<&Profile> {
        self.profile.as_ref()
    }

    /// The road network loaded at `init`, if any.
    pub fn network(&self) -> Option<&litesim_map::RoadNetwork> {
        self.network.as_deref()
    }

    /// Step size (ms) set at `init`.
    pub fn step_ms(&self) -> u64 {
        self.step_ms
    }

    /// Steps run since `init`.
    pub fn steps_executed(&self) -> u64 {
        self.steps_executed
    }

    /// Simulated time (ms).
    pub fn sim_time_ms(&self) -> u64 {
        self.world.as_ref().map_or(0, |w| w.tick() * self.step_ms)
    }

    // Inlined: a bit test where every call of a step asks; the refusal,
    // formatted, is out of line.
    #[inline]
    fn require(&self, call: Call) -> SspResult<()> {
        if self.phase.allows(call) {
            Ok(())
        } else {
            Err(self.refusal(call))
        }
    }

    #[cold]
    fn refusal(&self, call: Call) -> SspError {
        SspError::precondition(format!(
            "cannot call {} while the session is {}; allowed now: {}",
            call.name(),
            self.phase,
            self.phase.allowed_calls().join(", ")
        ))
    }

    fn parts(&mut self) -> (&mut World, &Profile) {
        // `require` has been called: init has run, so both exist.
        match (self.world.as_mut(), self.profile.as_ref()) {
            (Some(w), Some(p)) => (w, p),
            _ => unreachable!("session parts are set by init before any call that needs them"),
        }
    }

    fn mirror(&self) -> bool {
        self.profile.as_ref().is_some_and(|p| p.mirror_y)
    }

    /// Converts between the profile's frame and litesim's (CARLA is left-handed).
    fn frame(&self, mut c: Coord6) -> Coord6 {
        if self.mirror() {
            c.y = c.y.map(|v| -v);
            c.yaw = c.yaw.map(|v| -v);
            c.roll = c.roll.map(|v| -v);
        }
        c
    }

    fn slot(&self, id: &str) -> SspResult<usize> {
        self.world
            .as_ref()
            .and_then(|w| w.position(id))
            .filter(|&i| i < self.meta.len())
            .ok_or_else(|| SspError::not_found(format!("no actor with id '{id}'")))
    }

    fn meta(&self, id: &str) -> SspResult<&ActorMeta> {
        self.slot(id).map(|i| &self.meta[i])
    }

    /// Whether `filter` selects actor `a` (by id, then by category).
    fn selects(&self, filter: &ActorFilter, a: ActorRef<'_>) -> bool {
        (filter.actor_ids.is_empty() || filter.actor_ids.iter().any(|id| id == a.id()))
            && (filter.categories.is_empty()
                || filter.categories.contains(&self.meta[a.index()].category))
    }

    fn report(&self, a: ActorRef<'_>) -> ReportedState {
        let m = &self.meta[a.index()];
        let s = a.state();
        let mut controls = m.controls.clone();
        if let VehicleInput::Pedals(p) = a.last_input()
            && matches!(a.mode(), ControlMode::Dynamic { .. })
        {
            controls.throttle_pedal_pos = Some(p.throttle);
            controls.brake_pedal_pos = Some(p.brake);
            controls.steering_wheel_angle =
                Some(p.steering * m.limits.max_steering_wheel_angle_rad);
        }
        let mode = match a.mode() {
            ControlMode::Stored | ControlMode::Trajectory(_) => MoveMode::Kinematic,
            ControlMode::Dynamic { .. } => MoveMode::Dynamic,
            ControlMode::External(_) => MoveMode::External,
        };
        let mut r = ReportedState {
            actor_id: m.id.clone(),
            pose: s.pose,
            velocity: s.velocity,
            acceleration: s.acceleration,
            yaw_rate: s.yaw_rate,
            speed: s.speed,
            controls,
            mode,
            trajectory: s.trajectory,
        };
        if self.mirror() {
            r.mirror_y();
        }
        r
    }

    fn advance(&mut self, steps: u64) {
        let w = self.world.as_mut().expect("world exists after init");
        for _ in 0..steps {
            w.step();
        }
        self.steps_executed += steps;
    }

    fn status_json(&self) -> String {
        #[derive(Serialize)]
        struct Status<'a> {
            phase: String,
            profile: &'a str,
            model: &'a str,
            sim_time_ms: u64,
            steps_executed: u64,
            actors: usize,
            seed: u64,
            map: Option<&'a str>,
        }
        serde_json::to_string(&Status {
            phase: self.phase.to_string(),
            profile: self.profile.as_ref().map_or("", |p| p.name.as_str()),
            model: self.model.as_ref().map_or("", |m| m.name()),
            sim_time_ms: self.sim_time_ms(),
            steps_executed: self.steps_executed,
            actors: self.meta.len(),
            seed: self.seed,
            map: self.map.as_deref(),
        })
        .unwrap_or_default()
    }

    fn time_of_day_now(&self) -> TimeOfDay {
        let mut t = self.time_of_day;
        if t.advance_with_sim {
            let secs = u64::from(t.seconds_since_midnight) + self.sim_time_ms() / 1000;
            t.seconds_since_midnight = (secs % 86_400) as u32;
        }
        t
    }
}

/// Verbs `sim_command` accepts.
pub const SIM_COMMANDS: &[&str] = &[
    "status",
    "get_weather",
    "get_time_of_day",
    "list_models",
    "list_profiles",
    "catalog",
    "set_friction",
    "echo",
];

impl Ssp for Session {
    fn init(&mut self, req: InitRequest) -> SspResult<InitResponse> {
        self.require(Call::Init)?;
        let profile_name = if req.profile.is_empty() {
            self.default_profile.clone()
        } else {
            req.profile.clone()
        };
        let profile = Profile::builtin(&profile_name)?;
        let model = model_by_name(if req.model.is_empty() {
            &self.default_model
        } else {
            &req.model
        })?;
        let step = if req.step_size_ms == 0 {
            profile.step_ms
        } else {
            req.step_size_ms
        };
        if !(profile.min_step_ms..=profile.max_step_ms).contains(&step) {
            return Err(SspError::invalid(format!(
                "step_size_ms = {step} is outside profile {}'s range [{}, {}] ms",
                profile.name, profile.min_step_ms, profile.max_step_ms
            )));
        }
        let declared = !req.traffic_lights.is_empty() || !req.logical_lights.is_empty();
        let mut boxes = req.traffic_lights;
        let mut logical = req.logical_lights;
        let no_light_api = profile.traffic_light_api == TrafficLightApi::None;
        let mut map_lights_dropped = 0;
        let network = match req.map.as_deref() {
            None | Some("") => None,
            Some(m) => {
                let loaded = if m.trim_start().starts_with('<') {
                    litesim_map::RoadNetwork::from_xodr(m, "map_xodr")
                } else {
                    litesim_map::RoadNetwork::load(std::path::Path::new(m))
                };
                Some(loaded.map_err(|e| SspError::invalid(format!("map: {e}")))?)
            }
        };
        if let Some(net) = &network {
            let (b, l) = crate::traffic::from_map(net);
            // A simulator without a traffic-light API still drives on a map
            // with signals: they are simply not simulated (said below).
            if no_light_api {
                map_lights_dropped = b.len();
            } else {
                boxes.extend(b);
                logical.extend(l);
            }
        }
        let lights = TrafficLights::new(boxes, logical)?;
        if no_light_api && declared {
            return Err(SspError::unimplemented(format!(
                "profile {} has no traffic-light API; remove traffic_lights from init",
                profile.name
            )));
        }
        let mut diagnostics = Vec::new();
        if map_lights_dropped > 0 {
            diagnostics.push(format!(
                "profile {} has no traffic-light API: the map's {map_lights_dropped} signal(s) are not simulated",
                profile.name
            ));
        }
        if step != profile.calibration.calibrated_step_ms {
            diagnostics.push(format!(
                "profile {} is calibrated for {} ms steps; running at {step} ms",
                profile.name, profile.calibration.calibrated_step_ms
            ));
        }
        let capabilities = Capabilities {
            profile: profile.name.clone(),
            model: model.name().to_string(),
            step_size_ms: step,
            move_modes: vec![MoveMode::Kinematic, MoveMode::Dynamic, MoveMode::External],
            pedal_encoding: profile.pedal_encoding,
            min_step_ms: profile.min_step_ms,
            max_step_ms: profile.max_step_ms,
            traffic_lights: profile.traffic_light_api != TrafficLightApi::None,
            weather: profile.weather,
            time_of_day: profile.time_of_day,
            catalog: profile.catalog.clone(),
            sim_commands: SIM_COMMANDS.iter().map(|s| s.to_string()).collect(),
        };
        self.world = Some(World::with_step_ms(u64::from(step)).map_err(world_err)?);
        self.step_ms = u64::from(step);
        self.profile = Some(profile);
        self.model = Some(model);
        self.lights = lights;
        if let Some(net) = &network {
            diagnostics.extend(
                net.warnings
                    .iter()
                    .map(|w| format!("map: line {}: {}: {}", w.line, w.path, w.message)),
            );
        }
        self.network = network.map(std::sync::Arc::new);
        self.map = req.map.map(|m| {
            if m.trim_start().starts_with('<') {
                "<inline OpenDRIVE>".into()
            } else {
                m
            }
        });
        self.seed = req.seed;
        self.phase = Phase::Initialized;
        Ok(InitResponse {
            session_id: "local".into(),
            capabilities,
            diagnostics,
        })
    }

    fn launch_simulator(&mut self, connection_string: &str) -> SspResult<String> {
        self.require(Call::LaunchSimulator)?;
        if self.launched {
            return Err(SspError::precondition(
                "launch_simulator was already called: the simulator is launched",
            ));
        }
        self.launched = true;
        Ok(if connection_string.is_empty() {
            "inproc://litesim".into()
        } else {
            connection_string.into()
        })
    }

    fn terminate_simulator(&mut self) -> SspResult<()> {
        self.require(Call::TerminateSimulator)?;
        if !self.launched {
            return Err(SspError::precondition(
                "terminate_simulator: no simulator was launched",
            ));
        }
        self.launched = false;
        Ok(())
    }

    fn start_simulation(&mut self, start_time_ms: u64) -> SspResult<()> {
        // Called again (starting, running, stepping): `require` answers
        // FAILED_PRECONDITION with the state and the allowed calls.
        self.require(Call::StartSimulation)?;
        if !start_time_ms.is_multiple_of(self.step_ms) {
            return Err(SspError::invalid(format!(
                "start_time_ms = {start_time_ms} is not a multiple of the step size {} ms",
                self.step_ms
            )));
        }
        let tick = start_time_ms / self.step_ms;
        self.parts().0.set_tick(tick);
        self.phase = Phase::Starting;
        Ok(())
    }

    fn wait_start_simulation(&mut self, _max_wait_ms: u32) -> SspResult<u64> {
        self.require(Call::WaitStartSimulation)?;
        // The in-process model starts instantly, so no wait can time out.
        self.phase = Phase::Running;
        Ok(self.sim_time_ms())
    }

    fn end_simulation(&mut self, _reason: &str) -> SspResult<u64> {
        self.require(Call::EndSimulation)?;
        self.phase = Phase::Ended;
        Ok(self.steps_executed)
    }

    fn start_step(&mut self, requested_sim_time_ms: Option<u64>) -> SspResult<u64> {
        self.require(Call::StartStep)?;
        let now = self.sim_time_ms();
        let steps = match requested_sim_time_ms {
            None => 1,
            Some(t) if t <= now => {
                return Err(SspError::invalid(format!(
                    "requested_sim_time_ms = {t} must be after the current time {now} ms"
                )));
            }
            Some(t) => (t - now).div_ceil(self.step_ms),
        };
        if steps > self.limits.max_steps_per_call {
            return Err(SspError::exhausted(format!(
                "requested_sim_time_ms asks for {steps} steps in one call; the limit is {}",
                self.limits.max_steps_per_call
            )));
        }
        self.advance(steps);
        self.pending_steps = steps;
        self.phase = Phase::Stepping;
        Ok(self.steps_executed)
    }

    fn wait_step(&mut self, _max_wait_ms: u32) -> SspResult<StepInfo> {
        self.require(Call::WaitStep)?;
        self.phase = Phase::Running;
        self.pending_steps = 0;
        Ok(StepInfo {
            sim_time_ms: self.sim_time_ms(),
            step_index: self.steps_executed,
        })
    }

    fn step_kinematics(&mut self, out: &mut KinematicSteps) -> SspResult<()> {
        self.step_many_kinematics(1, out)
    }

    fn step_many_kinematics(&mut self, steps: u32, out: &mut KinematicSteps) -> SspResult<()> {
        check_step_count(steps)?;
        self.require(Call::GetActorsStates)?;
        let n = self.world.as_ref().map_or(0, World::len);
        check_reply_size(steps, n as u64, false)?;
        out.clear();
        // Sized once (grown by doubling, a chunk of 5,000 states was
        // copied a dozen times on its way up).
        out.infos.reserve(steps as usize);
        out.states.reserve(steps as usize * n);
        let mirror = self.mirror();
        for _ in 0..steps {
            self.start_step(None)?;
            let info = self.wait_step(0)?;
            let w = self.world.as_ref().expect("world exists after init");
            if out.infos.is_empty() {
                out.ids
                    .extend(w.actors().map(|a| self.meta[a.index()].id.clone()));
            }
            out.infos.push(info);
            out.states.extend(w.actors().map(|a| {
                let mut k = Kinematics::from(&a.state());
                if mirror {
                    k.mirror_y();
                }
                k
            }));
        }
        Ok(())
    }

    fn count_states(&mut self, filter: &ActorFilter) -> SspResult<u64> {
        self.require(Call::GetActorsStates)?;
        for id in &filter.actor_ids {
            self.meta(id)?;
        }
        let w = self.world.as_ref().expect("world exists after init");
        Ok(w.actors().filter(|a| self.selects(filter, *a)).count() as u64)
    }

    fn get_actors_states(&mut self, filter: &ActorFilter) -> SspResult<Vec<ReportedState>> {
        self.require(Call::GetActorsStates)?;
        for id in &filter.actor_ids {
            self.meta(id)?;
        }
        let w = self.world.as_ref().expect("world exists after init");
        // Sized for every actor up front: collecting through the filters
        // grew the reply by doubling (six copies of it per step at 100
        // actors).
        let mut out = Vec::with_capacity(if filter.actor_ids.is_empty() {
            w.len()
        } else {
            filter.actor_ids.len().min(w.len())
        });
        out.extend(
            w.actors()
                .filter(|a| self.selects(filter, *a))
                .map(|a| self.report(a)),
        );
        Ok(out)
    }

    fn create_actor(&mut self, req: CreateActor) -> SspResult<ActualDescription> {
        self.require(Call::CreateActor)?;
        if req.actor_id.is_empty() {
            return Err(SspError::invalid("actor_id must not be empty"));
        }
        if req.actor_id.len() > crate::error::ID_MAX {
            return Err(SspError::invalid(format!(
                "actor_id is {} bytes; ids are at most {} bytes",
                req.actor_id.len(),
                crate::error::ID_MAX
            )));
        }
        if self.slot(&req.actor_id).is_ok() {
            return Err(SspError::new(
                ErrorCode::AlreadyExists,
                format!("an actor with id '{}' already exists", req.actor_id),
            ));
        }
        if self.meta.len() >= self.limits.max_actors {
            return Err(SspError::exhausted(format!(
                "the session already has {} actors (the limit)",
                self.limits.max_actors
            )));
        }
        let (Some(_), Some(_)) = (req.position.x, req.position.y) else {
            return Err(SspError::invalid("position.x and position.y are mandatory"));
        };
        check_coord(&|| "position".into(), &req.position)?;
        check_coord(&|| "speed".into(), &req.speed)?;
        check_coord(&|| "acceleration".into(), &req.acceleration)?;
        let length = positive_dim("description.length", req.spec.length)?;
        let width = positive_dim("description.width", req.spec.width)?;
        let height = positive_dim("description.height", req.spec.height)?;
        let pos = self.frame(req.position);
        let spd = self.frame(req.speed);
        let acc = self.frame(req.acceleration);
        let dt = self.parts().0.dt();
        let profile = self.profile.as_ref().expect("profile exists after init");
        let entry = catalog_entry(profile, &req.spec)?;
        let kind = kind_of(&entry.category).ok_or_else(|| {
            SspError::invalid(format!(
                "catalog entry {} has unknown category {}",
                entry.model_id, entry.category
            ))
        })?;
        let mut entry = entry;
        entry.length = length.unwrap_or(entry.length);
        entry.width = width.unwrap_or(entry.width);
        entry.height = height.unwrap_or(entry.height);
        let description = ActorDescription {
            kind,
            actor_type: if req.spec.actor_type.is_empty() {
                "Vehicle".into()
            } else {
                req.spec.actor_type.clone()
            },
            model: entry.model_id.clone(),
            length: entry.length,
            width: entry.width,
            height: entry.height,
            mass: entry.mass,
            properties: req.spec.properties.clone(),
        };
        let drivable = matches!(kind, ActorKind::Vehicle(_) | ActorKind::Cyclist);
        let model = drivable.then(|| {
            self.model
                .as_ref()
                .expect("model exists after init")
                .vehicle_model(&entry, dt)
        });
        let state = initial_state(&pos, &spd, &acc);
        let max_wheel = entry.max_steer_angle_deg.to_radians();
        let limits = ActuatorLimits {
            max_drive_force_n: entry.mass * entry.max_accel,
            max_brake_force_n: entry.mass * entry.max_decel,
            max_steering_wheel_angle_rad: entry.steering_ratio * max_wheel,
            max_wheel_angle_rad: max_wheel,
            max_steering_torque_nm: profile.max_steering_torque_nm,
            policy: profile.range_policy,
        };
        let actual = ActualDescription {
            actor_type: description.actor_type.clone(),
            category: wire_category(kind),
            model_id: entry.model_id.clone(),
            length: entry.length,
            width: entry.width,
            height: entry.height,
            properties: description.properties.clone(),
        };
        let actor = Actor::new(req.actor_id.clone(), description, state, model);
        self.parts().0.add_actor(actor).map_err(world_err)?;
        self.meta.push(ActorMeta {
            id: req.actor_id.into(),
            category: actual.category,
            actual: actual.clone(),
            limits,
            controls: ActorControls::default(),
        });
        Ok(actual)
    }

    fn destroy_actor(&mut self, actor_id: &str) -> SspResult<()> {
        self.require(Call::DestroyActor)?;
        let i = self.slot(actor_id)?;
        self.parts().0.remove_actor(actor_id).map_err(world_err)?;
        self.meta.remove(i);
        Ok(())
    }

    fn set_actor_params(
        &mut self,
        actor_id: &str,
        params: BTreeMap<String, String>,
        controls: Option<ActorControls>,
    ) -> SspResult<()> {
        self.require(Call::SetActorParams)?;
        self.meta(actor_id)?;
        if let Some(c) = &controls {
            for (name, v) in [
                ("controls.brake_pedal_pos", c.brake_pedal_pos),
                ("controls.throttle_pedal_pos", c.throttle_pedal_pos),
            ] {
                if let Some(v) = v
                    && !(0.0..=1.0).contains(&v)
                {
                    return Err(SspError::invalid(format!("{name} = {v} is outside [0, 1]")));
                }
            }
            opt_finite("controls.steering_wheel_angle", c.steering_wheel_angle)?;
            if !c.gear.is_empty()
                && !matches!(c.gear.as_str(), "P" | "R" | "N" | "D")
                && c.gear.parse::<i32>().is_err()
            {
                return Err(SspError::invalid(format!(
                    "controls.gear = '{}' is not P, R, N, D or a gear number",
                    c.gear
                )));
            }
        }
        let mut friction = None;
        if let Some(mu) = params.get("friction") {
            let v: f64 = mu
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite() && *v > 0.0)
                .ok_or_else(|| {
                    SspError::invalid(format!("params.friction = '{mu}' is not a positive number"))
                })?;
            friction = Some(v);
        }
        // The gear drives the vehicle model: R backwards, D or a forward
        // gear number forwards (P and N are reported, the model keeps its
        // direction). A model with no reverse gear refuses R.
        let reverse = match controls.as_ref().map(|c| c.gear.as_str()) {
            Some("R") => Some(true),
            Some("D") => Some(false),
            Some(g) => g.parse::<i32>().ok().filter(|n| *n > 0).map(|_| false),
            None => None,
        };
        if let (Some(reverse), Some(w)) = (reverse, self.world.as_mut()) {
            let current = w
                .actor(actor_id)
                .and_then(|a| a.model().cloned())
                .ok_or_else(|| {
                    SspError::invalid(format!(
                        "controls.gear: actor '{actor_id}' has no vehicle model to put in gear"
                    ))
                })?;
            // (A model with no reverse gear is always in drive.)
            if current.reverse().unwrap_or(false) != reverse {
                let geared = current.with_reverse(reverse).ok_or_else(|| {
                    SspError::invalid(format!(
                        "controls.gear = 'R': actor '{actor_id}''s model ({}) has no reverse gear",
                        litesim_core::VehicleModel::name(&current)
                    ))
                })?;
                w.set_model(actor_id, geared)
                    .map_err(|e| SspError::invalid(e.to_string()))?;
            }
        }
        let i = self.slot(actor_id)?;
        let m = &mut self.meta[i];
        m.actual.properties.extend(params.clone());
        if let Some(c) = controls {
            m.controls = c;
        }
        if let (Some(mu), Some(w)) = (friction, self.world.as_mut()) {
            w.set_friction(actor_id, mu);
        }
        Ok(())
    }

    fn set_weather(&mut self, weather: Weather) -> SspResult<Weather> {
        self.require(Call::SetWeather)?;
        if !self.profile.as_ref().is_some_and(|p| p.weather) {
            return Err(SspError::unimplemented("this profile has no weather"));
        }
        for (name, v) in [
            ("weather.cloudiness", weather.cloudiness),
            ("weather.precipitation", weather.precipitation),
            ("weather.wetness", weather.wetness),
            ("weather.fog_density", weather.fog_density),
            ("weather.wind_intensity", weather.wind_intensity),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(SspError::invalid(format!("{name} = {v} is outside [0, 1]")));
            }
        }
        if !(weather.fog_distance_m.is_finite() && weather.fog_distance_m >= 0.0) {
            return Err(SspError::invalid(format!(
                "weather.fog_distance_m = {} must be ≥ 0",
                weather.fog_distance_m
            )));
        }
        if !(0.0..360.0).contains(&weather.sun_azimuth_deg) {
            return Err(SspError::invalid(format!(
                "weather.sun_azimuth_deg = {} is outside [0, 360)",
                weather.sun_azimuth_deg
            )));
        }
        if !(-90.0..=90.0).contains(&weather.sun_altitude_deg) {
            return Err(SspError::invalid(format!(
                "weather.sun_altitude_deg = {} is outside [-90, 90]",
                weather.sun_altitude_deg
            )));
        }
        self.weather = weather.clone();
        Ok(weather)
    }

    fn set_time_of_day(&mut self, tod: TimeOfDay) -> SspResult<()> {
        self.require(Call::SetTimeOfDay)?;
        if !self.profile.as_ref().is_some_and(|p| p.time_of_day) {
            return Err(SspError::unimplemented("this profile has no time of day"));
        }
        if tod.seconds_since_midnight >= 86_400 {
            return Err(SspError::invalid(format!(
                "seconds_since_midnight = {} must be < 86400",
                tod.seconds_since_midnight
            )));
        }
        if let Some(d) = tod.day_of_year.filter(|d| !(1..=366).contains(d)) {
            return Err(SspError::invalid(format!(
                "day_of_year = {d} is outside 1..=366"
            )));
        }
        // Store relative to the current simulation time so that reports advance from now.
        let mut t = tod;
        if t.advance_with_sim {
            let elapsed = (self.sim_time_ms() / 1000) % 86_400;
            t.seconds_since_midnight =
                ((u64::from(t.seconds_since_midnight) + 86_400 - elapsed) % 86_400) as u32;
        }
        self.time_of_day = t;
        Ok(())
    }

    fn sim_command(&mut self, command: &str, args: &[String]) -> SspResult<String> {
        self.require(Call::SimCommand)?;
        let json = |v: &dyn erased::Json| v.json();
        match command {
            "status" => Ok(self.status_json()),
            "get_weather" => Ok(json(&self.weather)),
            "get_time_of_day" => Ok(json(&self.time_of_day_now())),
            "list_models" => Ok(crate::model::models()
                .iter()
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join("\n")),
            "list_profiles" => Ok(crate::profile::builtin_names().join("\n")),
            "catalog" => Ok(json(
                &self
                    .profile
                    .as_ref()
                    .map(|p| p.catalog.clone())
                    .unwrap_or_default(),
            )),
            "echo" => Ok(args.join(" ")),
            "set_friction" => {
                let [id, mu] = args else {
                    return Err(SspError::invalid(
                        "set_friction expects 2 arguments: ACTOR_ID MU",
                    ));
                };
                self.set_actor_params(
                    id,
                    BTreeMap::from([("friction".to_string(), mu.clone())]),
                    None,
                )?;
                Ok(String::new())
            }
            other => Err(SspError::unimplemented(format!(
                "unknown sim_command '{other}'; available: {}",
                SIM_COMMANDS.join(", ")
            ))),
        }
    }

    fn set_xy_trajectory(&mut self, actor_id: &str, traj: XyTrajectory) -> SspResult<()> {
        self.set_xy_trajectory_ref(actor_id, &traj)
    }

    fn set_xy_trajectory_ref(&mut self, actor_id: &str, traj: &XyTrajectory) -> SspResult<()> {
        self.require(Call::SetXyTrajectory)?;
        let slot = self.slot(actor_id)?;
        let n = traj.points.len();
        if n == 0 {
            return Err(SspError::invalid("polyline must have at least 1 point"));
        }
        if n > self.limits.max_trajectory_points {
            return Err(SspError::exhausted(format!(
                "polyline has {n} points; the limit is {}",
                self.limits.max_trajectory_points
            )));
        }
        if !traj.speeds.is_empty() && traj.speeds.len() != n {
            return Err(SspError::invalid(format!(
                "speeds has {} entries for {n} points (give one per point or none)",
                traj.speeds.len()
            )));
        }
        // Each point's time (ms): given, the start alone, or evenly spaced.
        let explicit = !traj.point_times_ms.is_empty();
        if explicit && traj.point_times_ms.len() != n {
            return Err(SspError::invalid(format!(
                "point_times_ms has {} entries for {n} points",
                traj.point_times_ms.len()
            )));
        }
        if !explicit && n > 1 && traj.end_time_ms <= traj.start_time_ms {
            return Err(SspError::invalid(format!(
                "end_time_ms = {} must be after start_time_ms = {} for {n} points",
                traj.end_time_ms, traj.start_time_ms
            )));
        }
        let span = traj.end_time_ms.saturating_sub(traj.start_time_ms);
        let time_of = |i: usize| -> u64 {
            if explicit {
                traj.point_times_ms[i]
            } else if n == 1 {
                traj.start_time_ms
            } else {
                traj.start_time_ms + span * i as u64 / (n as u64 - 1)
            }
        };
        // The actor's height, for points without z (only then: it is a
        // state report of the actor).
        let z0 = if traj.points.iter().any(|c| c.z.is_none()) {
            self.world
                .as_ref()
                .and_then(|w| w.z_at(slot))
                .unwrap_or(0.0)
        } else {
            0.0
        };
        let mirror = self.mirror();
        // One buffer for the session: a closed loop sends every actor a
        // trajectory each step (a refused call drops it; the next makes
        // another).
        let mut points = std::mem::take(&mut self.scratch_points);
        points.clear();
        for (i, c) in traj.points.iter().enumerate() {
            let (Some(x), Some(y)) = (c.x, c.y) else {
                return Err(SspError::invalid(format!(
                    "polyline[{i}]: x and y are mandatory"
                )));
            };
            check_coord(&|| format!("polyline[{i}]"), c)?;
            // Into litesim's frame (as `frame`: y and yaw mirrored for CARLA).
            let (y, yaw) = if mirror {
                (-y, c.yaw.map(|v| -v))
            } else {
                (y, c.yaw)
            };
            let speed = traj.speeds.get(i).copied();
            if let Some(s) = speed
                && !(s.is_finite() && s >= 0.0)
            {
                return Err(SspError::invalid(format!(
                    "speeds[{i}] = {s} must be finite and ≥ 0"
                )));
            }
            points.push(TimedPoint {
                t: time_of(i) as f64 / 1000.0,
                position: Vec3::new(x, y, c.z.unwrap_or(z0)),
                yaw,
                speed,
            });
        }
        let set = self.parts().0.set_trajectory_at(slot, &points);
        self.scratch_points = points;
        set.map_err(|e| match e {
            SetTrajectoryError::Points(e) => SspError::invalid(format!("polyline: {e}")),
            SetTrajectoryError::World(e) => world_err(e),
        })
    }

    fn set_dynamic_move(
        &mut self,
        actor_id: &str,
        cmd: DynamicMove,
        valid_until_ms: u64,
    ) -> SspResult<()> {
        self.require(Call::SetDynamicMove)?;
        let limits = self.meta(actor_id)?.limits;
        let sign = if self.mirror() { -1.0 } else { 1.0 };
        let input = match cmd {
            DynamicMove::Normalized {
                throttle,
                brake,
                steering,
            } => VehicleInput::Pedals(
                normalize_command(
                    &DynamicCommand::fractions(throttle, brake, steering * sign),
                    &limits,
                )
                .map_err(|e| SspError::invalid(e.to_string()))?,
            ),
            DynamicMove::Physical {
                drive_force_n,
                brake_force_n,
                steer,
            } => {
                let steering = match steer {
                    PhysicalSteer::TorqueNm(v) => SteeringInput::TorqueNm(v * sign),
                    PhysicalSteer::SteeringWheelAngleRad(v) => {
                        SteeringInput::SteeringWheelAngleRad(v * sign)
                    }
                };
                let cmd = DynamicCommand {
                    throttle: PedalInput::ForceN(drive_force_n),
                    brake: PedalInput::ForceN(brake_force_n),
                    steering,
                };
                VehicleInput::Pedals(
                    normalize_command(&cmd, &limits)
                        .map_err(|e| SspError::invalid(e.to_string()))?,
                )
            }
            DynamicMove::Direct {
                acceleration,
                steering_angle_rad,
            } => VehicleInput::Direct {
                acceleration: finite("acceleration", acceleration)?,
                steering_angle: finite("steering_angle_rad", steering_angle_rad)? * sign,
            },
        };
        let now = self.sim_time_ms();
        let valid_until_tick = match valid_until_ms {
            0 => None,
            t if t <= now => {
                return Err(SspError::invalid(format!(
                    "valid_until_ms = {t} is not after the current time {now} ms"
                )));
            }
            t => Some(t / self.step_ms),
        };
        self.parts()
            .0
            .set_mode(
                actor_id,
                ControlMode::Dynamic {
                    input,
                    valid_until_tick,
                },
            )
            .map_err(world_err)
    }

    fn set_external_controller(&mut self, actor_id: &str, ext: ExternalMove) -> SspResult<()> {
        self.require(Call::SetExternalController)?;
        self.meta(actor_id)?;
        let keys: &[(&str, f64)] = match ext.controller.as_str() {
            "cruise" => &[("max_acceleration", 2.0)],
            "idm" => &[
                ("max_acceleration", 1.5),
                ("comfortable_deceleration", 2.0),
                ("time_headway", 1.5),
                ("min_gap", 2.0),
                ("lane_half_width", 1.75),
            ],
            "stop" => &[("deceleration", 3.0)],
            "release" => &[],
            other => {
                return Err(SspError::unimplemented(format!(
                    "unknown controller '{other}'; available: cruise, idm, stop, release"
                )));
            }
        };
        if let Some(bad) = ext
            .params
            .keys()
            .find(|k| !keys.iter().any(|(n, _)| n == k))
        {
            return Err(SspError::invalid(format!(
                "params.{bad} is not a parameter of controller '{}'; known: {}",
                ext.controller,
                keys.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
            )));
        }
        let mut p = BTreeMap::new();
        for (k, default) in keys {
            let v = ext.params.get(*k).copied().unwrap_or(*default);
            if !(v.is_finite() && v > 0.0) {
                return Err(SspError::invalid(format!(
                    "params.{k} = {v} must be positive"
                )));
            }
            p.insert(*k, v);
        }
        let desired = || -> SspResult<f64> {
            match ext.desired_speed {
                Some(v) if v.is_finite() && v >= 0.0 => Ok(v),
                Some(v) => Err(SspError::invalid(format!(
                    "desired_speed = {v} must be finite and ≥ 0"
                ))),
                None => Err(SspError::invalid(format!(
                    "desired_speed is required by controller '{}'",
                    ext.controller
                ))),
            }
        };
        let mode = match ext.controller.as_str() {
            "cruise" => ControlMode::External(ExternalController::Cruise {
                desired_speed: desired()?,
                max_acceleration: p["max_acceleration"],
            }),
            "idm" => ControlMode::External(ExternalController::Idm {
                desired_speed: desired()?,
                max_acceleration: p["max_acceleration"],
                comfortable_deceleration: p["comfortable_deceleration"],
                time_headway: p["time_headway"],
                min_gap: p["min_gap"],
                lane_half_width: p["lane_half_width"],
            }),
            "stop" => ControlMode::External(ExternalController::Stop {
                deceleration: p["deceleration"],
            }),
            _ => ControlMode::Stored,
        };
        self.parts().0.set_mode(actor_id, mode).map_err(world_err)
    }

    fn list_traffic_lights(&mut self) -> SspResult<TrafficLights> {
        self.require(Call::ListTrafficLights)?;
        if self
            .profile
            .as_ref()
            .is_some_and(|p| p.traffic_light_api == TrafficLightApi::None)
        {
            return Err(SspError::unimplemented(
                "this profile has no traffic-light API",
            ));
        }
        Ok(self.lights.clone())
    }

    fn set_traffic_light_state(
        &mut self,
        target: LightTarget,
        states: Vec<BulbState>,
    ) -> SspResult<Vec<TrafficLightBox>> {
        self.require(Call::SetTrafficLightState)?;
        match self.profile.as_ref().map(|p| p.traffic_light_api) {
            Some(TrafficLightApi::None) => {
                return Err(SspError::unimplemented(
                    "this profile has no traffic-light API",
                ));
            }
            Some(TrafficLightApi::Logical) if matches!(target, LightTarget::Box(_)) => {
                return Err(SspError::unimplemented(
                    "this profile sets traffic lights at logical level only; target a logical light",
                ));
            }
            _ => {}
        }
        self.lights.set(&target, &states)
    }
}

mod erased {
    /// Object-safe JSON rendering for `sim_command` outputs.
    pub trait Json {
        fn json(&self) -> String;
    }
    impl<T: serde::Serialize> Json for T {
        fn json(&self) -> String {
            serde_json::to_string(self).unwrap_or_default()
        }
    }
}
