//! The fixed-step world: actors in a deterministic order and an integer clock.

use crate::actor::{ActorDescription, ActorId, ActorState, TrajectoryStatus};
use crate::geometry::{Pose, Vec2, Vec3, wrap_angle};
use crate::math;
use crate::trajectory::{TimedPoint, Trajectory};
use crate::vehicle::batch::{self, CommandColumns, Kernel, VehicleColumns};
use crate::vehicle::{Derived, VehicleInput, VehicleModel, VehicleModelKind, VehicleState};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::ops::Range;

/// A simulator-side behaviour model driving an actor (SSP "external controller").
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "controller")]
pub enum ExternalController {
    /// Hold the heading, approach `desired_speed` (m/s) at up to `max_acceleration`.
    Cruise {
        /// Target speed (m/s).
        desired_speed: f64,
        /// Acceleration limit (m/s²).
        max_acceleration: f64,
    },
    /// Intelligent Driver Model (Treiber, Hennecke, Helbing 2000) following
    /// the nearest actor ahead within ±`lane_half_width` of the heading line.
    Idm {
        /// Desired speed v0 (m/s).
        desired_speed: f64,
        /// Maximum acceleration a (m/s²).
        max_acceleration: f64,
        /// Comfortable deceleration b (m/s²).
        comfortable_deceleration: f64,
        /// Time headway T (s).
        time_headway: f64,
        /// Minimum gap s0 (m).
        min_gap: f64,
        /// Half width of the corridor in which leaders are looked for (m).
        lane_half_width: f64,
    },
    /// Brake at `deceleration` (m/s²) to a standstill and stay there.
    Stop {
        /// Deceleration (m/s², positive).
        deceleration: f64,
    },
}

/// How an actor is moved each step.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "mode")]
pub enum ControlMode {
    /// Kinematic, stored: the state given at creation or by a set call is
    /// returned unchanged (the seed's "Model SSP does not update actor data").
    #[default]
    Stored,
    /// Kinematic, xy trajectory: placed on the trajectory at the current time.
    Trajectory(Trajectory),
    /// Dynamic: pedals and steering into the actor's vehicle model.
    /// After tick `valid_until_tick` (if any) the pedals are released.
    Dynamic {
        /// The normalised command.
        input: VehicleInput,
        /// Last tick the command applies to.
        valid_until_tick: Option<u64>,
    },
    /// A simulator-side behaviour model.
    External(ExternalController),
}

impl ControlMode {
    /// A short name ("stored", "trajectory", "dynamic", "direct", "external").
    pub fn name(&self) -> &'static str {
        match self {
            ControlMode::Stored => "stored",
            ControlMode::Trajectory(_) => "trajectory",
            ControlMode::Dynamic {
                input: VehicleInput::Direct { .. },
                ..
            } => "direct",
            ControlMode::Dynamic { .. } => "dynamic",
            ControlMode::External(_) => "external",
        }
    }
}

/// One actor, as given to [`World::add_actor`] and returned by
/// [`World::remove_actor`]. Inside a world it is read through [`ActorRef`]:
/// the world keeps its live vehicle state in columns of its own.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Actor {
    /// Unique id.
    pub id: ActorId,
    /// What it is.
    pub description: ActorDescription,
    /// Its vehicle model, if it can be driven dynamically.
    pub model: Option<VehicleModelKind>,
    /// Road friction coefficient μ for the friction-use proxy.
    pub friction: f64,
    /// The input applied in the last step (for logs).
    pub last_input: VehicleInput,
    mode: ControlMode,
    // The state as given or stored; while `live`, the world's columns hold
    // the actor's state instead.
    state: ActorState,
    // The reported state is computed from the vehicle columns: set at the
    // first integrated step, cleared when the state is given or stored.
    live: bool,
    // The trig of the last heading a trajectory gave (a cache: not saved,
    // and no part of the actor's equality).
    #[serde(skip)]
    heading_trig: math::SinCosMemo,
}

impl Actor {
    /// A stored (kinematic) actor at `state`.
    pub fn new(
        id: impl Into<ActorId>,
        description: ActorDescription,
        state: ActorState,
        model: Option<VehicleModelKind>,
    ) -> Self {
        Self {
            id: id.into(),
            description,
            state,
            model,
            friction: 1.0,
            last_input: VehicleInput::default(),
            mode: ControlMode::Stored,
            live: false,
            heading_trig: math::SinCosMemo::new(state.pose.yaw),
        }
    }
    /// The control mode.
    pub fn mode(&self) -> &ControlMode {
        &self.mode
    }
    /// The state as given, or as it was when the actor left a world.
    pub fn state(&self) -> ActorState {
        self.state
    }
}

/// The model's state for an actor that starts integrating at `s`.
fn vehicle_from(s: &ActorState) -> VehicleState {
    VehicleState {
        x: s.pose.position.x,
        y: s.pose.position.y,
        z: s.pose.position.z,
        yaw: s.pose.yaw,
        v: s.speed.max(0.0),
        ..VehicleState::default()
    }
}

/// The state an integrating actor reports: pose, velocity along the
/// heading, tangential plus centripetal acceleration.
fn report(v: &VehicleState) -> ActorState {
    let (s, c) = math::sin_cos(v.yaw);
    // World-frame acceleration: tangential plus centripetal (a_y = v²κ = v·ω).
    let a_lat = v.v * v.yaw_rate;
    ActorState {
        pose: Pose {
            position: Vec3::new(v.x, v.y, v.z),
            roll: 0.0,
            pitch: 0.0,
            yaw: v.yaw,
        },
        velocity: Vec3::new(v.v * c, v.v * s, 0.0),
        acceleration: Vec3::new(
            v.acceleration * c - a_lat * s,
            v.acceleration * s + a_lat * c,
            0.0,
        ),
        yaw_rate: v.yaw_rate,
        speed: v.v,
        long_acceleration: v.acceleration,
        trajectory: TrajectoryStatus::None,
    }
}

/// An actor of a [`World`], read in place.
#[derive(Clone, Copy, Debug)]
pub struct ActorRef<'w> {
    world: &'w World,
    index: usize,
}

impl<'w> ActorRef<'w> {
    fn actor(&self) -> &'w Actor {
        &self.world.actors[self.index]
    }
    /// Position in [`World::actors`] (see [`World::position`]).
    pub fn index(&self) -> usize {
        self.index
    }
    /// Unique id.
    pub fn id(&self) -> &'w str {
        &self.actor().id
    }
    /// What it is.
    pub fn description(&self) -> &'w ActorDescription {
        &self.actor().description
    }
    /// Its vehicle model, if any.
    pub fn model(&self) -> Option<&'w VehicleModelKind> {
        self.actor().model.as_ref()
    }
    /// Road friction coefficient μ.
    pub fn friction(&self) -> f64 {
        self.actor().friction
    }
    /// The input applied in the last step.
    pub fn last_input(&self) -> VehicleInput {
        self.actor().last_input
    }
    /// The control mode.
    pub fn mode(&self) -> &'w ControlMode {
        &self.actor().mode
    }
    /// Its reported state.
    pub fn state(&self) -> ActorState {
        self.world.state_at(self.index)
    }
    /// The vehicle model's state (what the last step integrated or implied).
    pub fn vehicle_state(&self) -> VehicleState {
        self.world.vehicles.get(self.index)
    }
    /// The quantities derived from the last step (seed 001 §1.3).
    ///
    /// A pure function of the vehicle state, mass and friction, computed
    /// when asked: the sqrt and division it needs would otherwise cost a
    /// third of a world step for values most runs never read.
    pub fn derived(&self) -> Derived {
        let a = self.actor();
        Derived::from_state(&self.vehicle_state(), a.description.mass, a.friction)
    }
}

/// Why a world operation failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum WorldError {
    /// `dt` not positive and finite.
    #[error("time step must be positive and finite, got {0} s")]
    BadTimeStep(f64),
    /// Id already used.
    #[error("an actor with id '{0}' already exists")]
    DuplicateActor(ActorId),
    /// No actor with that id.
    #[error("no actor with id '{0}'")]
    UnknownActor(ActorId),
    /// Dynamic control of an actor without a vehicle model.
    #[error("actor '{0}' has no vehicle model and cannot be driven dynamically")]
    NoVehicleModel(ActorId),
    /// A NaN or infinite number.
    #[error("{0} is not finite")]
    NotFinite(&'static str),
}

/// Why [`World::set_trajectory_at`] failed: the points, or the world.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SetTrajectoryError {
    /// The points do not make a trajectory.
    #[error("{0}")]
    Points(crate::trajectory::TrajectoryError),
    /// The world refused the mode.
    #[error("{0}")]
    World(WorldError),
}

/// The simulated world.
///
/// Every actor's vehicle state lives in [`VehicleColumns`], index-aligned
/// with the actors; the reported state of an integrating actor is computed
/// from them when read ([`ActorRef::state`]). Dynamic actors whose model and
/// command allow it are stepped together by the batch loops of
/// [`crate::vehicle::batch`] (bit-identical to their models, see there); the
/// rest one by one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct World {
    dt: f64,
    step_ms: Option<u64>,
    tick: u64,
    actors: Vec<Actor>,
    vehicles: VehicleColumns,
    index: BTreeMap<ActorId, usize>,
    // Actors under an external controller; kept so that a step can skip the
    // snapshot of all actors when nobody needs it.
    external: usize,
    // Compiled commands, brought up to date at the start of a step (see
    // `Batch`); a cache, so not serialised.
    #[serde(skip)]
    batch: Batch,
    // Where the last `position` answer was: a cache, so not serialised.
    #[serde(skip)]
    last_found: LastFound,
}

/// The position [`World::position`] last answered. Callers ask for the
/// actors in their order, step after step (a controller sends every actor
/// its move), so the actor after it is tried first: a compare of two
/// short ids instead of a walk down the id index. Atomic only so that the
/// world stays `Sync`; relaxed order, since any value is merely a guess.
#[derive(Debug, Default)]
struct LastFound(std::sync::atomic::AtomicUsize);

impl Clone for LastFound {
    fn clone(&self) -> Self {
        LastFound(std::sync::atomic::AtomicUsize::new(self.get()))
    }
}

impl PartialEq for LastFound {
    /// A cache: never part of a world's value.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl LastFound {
    fn get(&self) -> usize {
        self.0.load(std::sync::atomic::Ordering::Relaxed)
    }
    fn set(&self, i: usize) {
        self.0.store(i, std::sync::atomic::Ordering::Relaxed);
    }
}

/// The compiled commands of the dynamic actors, and when they go stale.
#[derive(Clone, Debug, Default)]
struct Batch {
    // None: actors were added or removed (or the clock set) since it was built.
    // Boxed: taken out and put back every step, a pointer moves instead of
    // ten column headers.
    built: Option<Box<Built>>,
    // Actors whose command or mode changed since: recompiled one by one at
    // the next step, so that a client commanding one actor per step does
    // not pay for recompiling all of them.
    changed: Vec<usize>,
    // Off: every actor is stepped one by one (same bits; for tests and
    // benchmarks).
    off: bool,
}

impl Batch {
    fn changed(&mut self, i: usize) {
        if self.built.is_some() {
            self.changed.push(i);
        }
    }
}

#[derive(Clone, Debug)]
struct Built {
    commands: CommandColumns,
    runs: Vec<(Kernel, Range<usize>)>,
    // The earliest last tick of a dynamic command with a validity limit.
    next_expiry: u64,
}

impl PartialEq for Batch {
    /// A cache: never part of a world's value.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl World {
    /// An empty world stepping `dt` seconds per tick.
    pub fn new(dt: f64) -> Result<Self, WorldError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(WorldError::BadTimeStep(dt));
        }
        Ok(Self {
            dt,
            step_ms: None,
            tick: 0,
            actors: Vec::new(),
            vehicles: VehicleColumns::default(),
            index: BTreeMap::new(),
            external: 0,
            batch: Batch::default(),
            last_found: LastFound::default(),
        })
    }
    /// An empty world on an integer millisecond clock: `time() =
    /// (tick · step_ms) / 1000`, so times given in ms elsewhere (trajectory
    /// points, requested step times) convert to exactly the same `f64`.
    pub fn with_step_ms(step_ms: u64) -> Result<Self, WorldError> {
        if step_ms == 0 {
            return Err(WorldError::BadTimeStep(0.0));
        }
        let mut w = Self::new(step_ms as f64 / 1000.0)?;
        w.step_ms = Some(step_ms);
        Ok(w)
    }
    /// Step size (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// Steps taken.
    pub fn tick(&self) -> u64 {
        self.tick
    }
    /// Simulation time (s) = tick · dt (see [`World::with_step_ms`]).
    pub fn time(&self) -> f64 {
        self.time_at(self.tick)
    }
    fn time_at(&self, tick: u64) -> f64 {
        match self.step_ms {
            Some(ms) => (tick * ms) as f64 / 1000.0,
            None => tick as f64 * self.dt,
        }
    }
    /// Steps batchable dynamic actors together (the default) or every actor
    /// one by one. The results are bit-identical either way; this exists so
    /// that tests and benchmarks can compare the two.
    pub fn set_batching(&mut self, on: bool) {
        self.batch = Batch {
            off: !on,
            ..Batch::default()
        };
    }
    /// Sets the clock (e.g. a simulation that starts at a given time).
    pub fn set_tick(&mut self, tick: u64) {
        self.tick = tick;
        self.batch.built = None;
    }
    /// Actors in creation order.
    pub fn actors(&self) -> impl ExactSizeIterator<Item = ActorRef<'_>> + DoubleEndedIterator {
        (0..self.actors.len()).map(|index| ActorRef { world: self, index })
    }
    /// Number of actors.
    pub fn len(&self) -> usize {
        self.actors.len()
    }
    /// True when there are no actors.
    pub fn is_empty(&self) -> bool {
        self.actors.is_empty()
    }
    /// The actor at position `i` of [`World::actors`], if any.
    pub fn actor_at(&self, i: usize) -> Option<ActorRef<'_>> {
        (i < self.actors.len()).then_some(ActorRef {
            world: self,
            index: i,
        })
    }
    /// An actor by id.
    pub fn actor(&self, id: &str) -> Option<ActorRef<'_>> {
        self.index
            .get(id)
            .map(|&index| ActorRef { world: self, index })
    }
    /// An actor's position in [`World::actors`] (creation order, closed up
    /// when an actor is removed): lets a caller keep per-actor data in a
    /// `Vec` beside the world instead of looking ids up every step.
    pub fn position(&self, id: &str) -> Option<usize> {
        let next = self.last_found.get() + 1;
        let guess = if next < self.actors.len() { next } else { 0 };
        if self.actors.get(guess).is_some_and(|a| a.id == id) {
            self.last_found.set(guess);
            return Some(guess);
        }
        let i = self.index.get(id).copied()?;
        self.last_found.set(i);
        Some(i)
    }
    fn index_of(&self, id: &str) -> Result<usize, WorldError> {
        self.index
            .get(id)
            .copied()
            .ok_or_else(|| WorldError::UnknownActor(id.to_string()))
    }
    /// Actor `i`'s height: [`ActorRef::state`]'s z without the rest of
    /// the report (a trajectory without heights takes the actor's).
    pub fn z_at(&self, i: usize) -> Option<f64> {
        let a = self.actors.get(i)?;
        Some(if a.live {
            self.vehicles.z[i]
        } else {
            a.state.pose.position.z
        })
    }

    fn state_at(&self, i: usize) -> ActorState {
        let a = &self.actors[i];
        if a.live {
            report(&self.vehicles.get(i))
        } else {
            a.state
        }
    }

    /// Adds an actor at the end of the order.
    pub fn add_actor(&mut self, actor: Actor) -> Result<(), WorldError> {
        if !actor.state.is_finite() {
            return Err(WorldError::NotFinite("state"));
        }
        if self.index.contains_key(&actor.id) {
            return Err(WorldError::DuplicateActor(actor.id));
        }
        if matches!(actor.mode, ControlMode::External(_)) {
            self.external += 1;
        }
        self.index.insert(actor.id.clone(), self.actors.len());
        self.vehicles.push(&vehicle_from(&actor.state));
        self.actors.push(Actor {
            live: false,
            ..actor
        });
        self.batch.built = None;
        Ok(())
    }

    /// Removes an actor; the others keep their relative order. The actor
    /// comes back with its state as reported now.
    pub fn remove_actor(&mut self, id: &str) -> Result<Actor, WorldError> {
        let i = self.index_of(id)?;
        let state = self.state_at(i);
        let mut a = self.actors.remove(i);
        self.vehicles.remove(i);
        a.state = state;
        a.live = false;
        self.index.remove(id);
        if matches!(a.mode, ControlMode::External(_)) {
            self.external -= 1;
        }
        for j in self.index.values_mut() {
            if *j > i {
                *j -= 1;
            }
        }
        self.batch.built = None;
        Ok(a)
    }

    /// Overwrites an actor's state (a kinematic "set"); the actor returns to stored mode.
    pub fn set_state(&mut self, id: &str, state: ActorState) -> Result<(), WorldError> {
        if !state.is_finite() {
            return Err(WorldError::NotFinite("state"));
        }
        let i = self.index_of(id)?;
        let a = &mut self.actors[i];
        if matches!(a.mode, ControlMode::External(_)) {
            self.external -= 1;
        }
        a.state = state;
        a.live = false;
        a.mode = ControlMode::Stored;
        self.vehicles.set(i, &vehicle_from(&state));
        self.batch.changed(i);
        Ok(())
    }

    /// Replaces an actor's vehicle model (its parameters: a gear change, a
    /// new limit); the state carries on from where it is.
    pub fn set_model(&mut self, id: &str, model: VehicleModelKind) -> Result<(), WorldError> {
        let i = self.index_of(id)?;
        self.actors[i].model = Some(model);
        // Its compiled command was made with the old model's parameters.
        self.batch.changed(i);
        Ok(())
    }

    /// Changes how an actor is moved. A trajectory replaces the remainder of
    /// a trajectory already held from its own start time on.
    pub fn set_mode(&mut self, id: &str, mode: ControlMode) -> Result<(), WorldError> {
        let i = self.index_of(id)?;
        self.set_mode_at(i, mode)
    }

    /// [`World::set_mode`] for the actor at position `i` of
    /// [`World::actors`] (see [`World::position`]): a caller that keeps
    /// per-actor data by position sets a trajectory per actor and chunk
    /// without looking its id up again.
    ///
    /// # Panics
    /// If `i` is not below [`World::len`].
    pub fn set_mode_at(&mut self, i: usize, mode: ControlMode) -> Result<(), WorldError> {
        // What it reports now, kept where it leaves the model (only then:
        // made for every new trajectory it was a tenth of a 100-actor run).
        let needs_model = matches!(mode, ControlMode::Dynamic { .. } | ControlMode::External(_));
        // Needed only where the actor leaves the model (a closed loop
        // sets a dynamic command every step: no report made for it).
        let reported = (!needs_model && self.actors[i].live).then(|| self.state_at(i));
        let a = &mut self.actors[i];
        if needs_model && a.model.is_none() {
            return Err(WorldError::NoVehicleModel(a.id.clone()));
        }
        if let ControlMode::Dynamic {
            input:
                VehicleInput::Direct {
                    acceleration,
                    steering_angle,
                },
            ..
        } = mode
        {
            if !acceleration.is_finite() {
                return Err(WorldError::NotFinite("acceleration"));
            }
            if !steering_angle.is_finite() {
                return Err(WorldError::NotFinite("steering_angle"));
            }
        }
        let was_integrating = matches!(
            a.mode,
            ControlMode::Dynamic { .. } | ControlMode::External(_)
        );
        if needs_model && !was_integrating {
            self.vehicles.set(i, &vehicle_from(&a.state));
        }
        if !needs_model && let Some(reported) = reported {
            // Leaving the model: from now on the state is stored again.
            a.state = reported;
            a.live = false;
        }
        let was_external = matches!(a.mode, ControlMode::External(_));
        let is_external = matches!(mode, ControlMode::External(_));
        match (&mut a.mode, mode) {
            (ControlMode::Trajectory(old), ControlMode::Trajectory(new)) => old.replace_from(new),
            (slot, mode) => *slot = mode,
        }
        self.external = self.external + usize::from(is_external) - usize::from(was_external);
        self.batch.changed(i);
        Ok(())
    }

    /// [`World::set_mode_at`] with a trajectory of `points` (checked by
    /// [`Trajectory::check`] first): an actor already following one has it
    /// replaced in place, from the first point's time on, with no new
    /// memory; otherwise the trajectory is made and the mode set.
    pub fn set_trajectory_at(
        &mut self,
        i: usize,
        points: &[TimedPoint],
    ) -> Result<(), SetTrajectoryError> {
        Trajectory::check(points).map_err(SetTrajectoryError::Points)?;
        if let ControlMode::Trajectory(old) = &mut self.actors[i].mode {
            // What `set_mode_at` does for a trajectory over a trajectory:
            // the actor is not integrated (so nothing to report back), it
            // stays outside the model and outside the external count, and
            // its compiled command stays none (the batch is not touched).
            old.replace_from_slice(points);
            return Ok(());
        }
        // Checked above: made without checking again.
        let mut new = Trajectory::default();
        new.replace_from_slice(points);
        self.set_mode_at(i, ControlMode::Trajectory(new))
            .map_err(SetTrajectoryError::World)
    }

    /// Compiles the standing commands of dynamic actors whose model allows
    /// it, writes what those commands report every step (input, steering,
    /// curvature, slip), and finds the runs the batch loops step.
    fn build_batch(&mut self, tick: u64) -> Built {
        let mut built = Built {
            commands: CommandColumns::with_len(self.actors.len()),
            runs: Vec::new(),
            next_expiry: u64::MAX,
        };
        for i in 0..self.actors.len() {
            self.compile_actor(i, tick, &mut built);
        }
        built.runs = built.commands.runs();
        built
    }

    /// Actor `i`'s part of [`World::build_batch`]: releases its command if
    /// it ran out before `tick`, then compiles it (or clears it).
    fn compile_actor(&mut self, i: usize, tick: u64, built: &mut Built) {
        let a = &mut self.actors[i];
        let ControlMode::Dynamic {
            input,
            valid_until_tick,
        } = &mut a.mode
        else {
            built.commands.set(i, None);
            return;
        };
        if valid_until_tick.is_some_and(|last| tick > last) {
            *input = VehicleInput::default();
            *valid_until_tick = None;
        }
        if let Some(last) = *valid_until_tick {
            built.next_expiry = built.next_expiry.min(last);
        }
        let compiled = match a.model.as_mut() {
            Some(m) if !self.batch.off => m.compile(input, &self.vehicles.get(i), self.dt),
            _ => None,
        };
        if let Some(c) = &compiled {
            self.vehicles.set_command_outputs(i, c);
            a.last_input = *input;
            a.live = true;
        }
        built.commands.set(i, compiled);
    }

    /// Advances every actor by one tick.
    ///
    /// Every actor's step depends only on its own state, except that
    /// external controllers look at all actors as they were at the start of
    /// the step; so the result does not depend on the order actors were
    /// created in, nor on which of them the batch loops step.
    pub fn step(&mut self) {
        let dt = self.dt;
        let tick = self.tick + 1;
        let t = self.time_at(tick);
        // A command that runs out this tick changes the compiled set.
        let mut changed = std::mem::take(&mut self.batch.changed);
        let built = match self.batch.built.take() {
            Some(mut b) if tick <= b.next_expiry => {
                if !changed.is_empty() {
                    for &i in &changed {
                        self.compile_actor(i, tick, &mut b);
                    }
                    let mut runs = std::mem::take(&mut b.runs);
                    b.commands.runs_into(&mut runs);
                    b.runs = runs;
                }
                b
            }
            _ => Box::new(self.build_batch(tick)),
        };
        // The list's buffer is kept for the next step's changes (a closed
        // loop changes a command every step).
        changed.clear();
        if self.batch.changed.is_empty() {
            self.batch.changed = changed;
        }
        // Only external controllers look at other actors; skip the snapshot otherwise.
        let snapshot = if self.external > 0 {
            self.snapshot()
        } else {
            Vec::new()
        };
        for (kernel, range) in &built.runs {
            batch::step_run(
                &mut self.vehicles,
                &built.commands,
                *kernel,
                range.clone(),
                dt,
            );
        }
        for idx in 0..self.actors.len() {
            if built.commands.kernel(idx).is_some() {
                continue;
            }
            let a = &mut self.actors[idx];
            match &mut a.mode {
                ControlMode::Stored => {}
                ControlMode::Trajectory(tr) => {
                    tr.prune_before(t);
                    if let Some(s) = tr.sample(t) {
                        let prev = a.state;
                        let yaw = s.yaw.unwrap_or(prev.pose.yaw);
                        let (sn, cs) = a.heading_trig.get(yaw);
                        let yaw_rate = wrap_angle(yaw - prev.pose.yaw) / dt;
                        let long_acc = (s.speed - prev.speed) / dt;
                        let velocity = Vec3::new(s.speed * cs, s.speed * sn, 0.0);
                        a.state = ActorState {
                            pose: Pose {
                                position: s.position,
                                yaw,
                                ..prev.pose
                            },
                            velocity,
                            acceleration: Vec3::new(
                                (velocity.x - prev.velocity.x) / dt,
                                (velocity.y - prev.velocity.y) / dt,
                                0.0,
                            ),
                            yaw_rate,
                            speed: s.speed,
                            long_acceleration: long_acc,
                            trajectory: s.status,
                        };
                        // What the motion implies, for `ActorRef::derived`.
                        let mut vs = vehicle_from(&a.state);
                        vs.yaw_rate = yaw_rate;
                        vs.acceleration = long_acc;
                        vs.curvature = if s.speed > 1e-9 {
                            yaw_rate / s.speed
                        } else {
                            0.0
                        };
                        self.vehicles.set(idx, &vs);
                    }
                }
                ControlMode::Dynamic { input, .. } => {
                    // Expired commands were reset when the batch was built.
                    let input = *input;
                    if let Some(m) = a.model.as_mut() {
                        let mut vs = self.vehicles.get(idx);
                        m.step(&mut vs, &input, dt);
                        self.vehicles.set(idx, &vs);
                        a.last_input = input;
                        a.live = true;
                    }
                }
                ControlMode::External(ctrl) => {
                    let input = external_input(ctrl, idx, &snapshot);
                    if let Some(m) = a.model.as_mut() {
                        let mut vs = self.vehicles.get(idx);
                        m.step(&mut vs, &input, dt);
                        self.vehicles.set(idx, &vs);
                        a.last_input = input;
                        a.live = true;
                    }
                }
            }
        }
        self.batch.built = Some(built);
        self.tick = tick;
    }

    /// Every actor as it is at the start of a step, for external
    /// controllers.
    fn snapshot(&self) -> Vec<Snapshot> {
        (0..self.actors.len())
            .map(|i| {
                let a = &self.actors[i];
                // What `state_at` reports, without the trig it does not need.
                let (position, yaw, speed) = if a.live {
                    let v = &self.vehicles;
                    (Vec2::new(v.x[i], v.y[i]), v.yaw[i], v.v[i])
                } else {
                    (a.state.pose.position.xy(), a.state.pose.yaw, a.state.speed)
                };
                Snapshot {
                    position,
                    yaw,
                    speed,
                    length: a.description.length,
                }
            })
            .collect()
    }
}

/// What external controllers see of each actor at the start of a step.
struct Snapshot {
    position: Vec2,
    yaw: f64,
    speed: f64,
    length: f64,
}

fn external_input(ctrl: &ExternalController, me: usize, snapshot: &[Snapshot]) -> VehicleInput {
    let direct = |acceleration: f64| VehicleInput::Direct {
        acceleration,
        steering_angle: 0.0,
    };
    let v = snapshot[me].speed;
    match *ctrl {
        ExternalController::Stop { deceleration } => {
            direct(if v > 0.0 { -deceleration } else { 0.0 })
        }
        ExternalController::Cruise {
            desired_speed,
            max_acceleration,
        } => direct(math::clamp(
            desired_speed - v,
            -max_acceleration,
            max_acceleration,
        )),
        ExternalController::Idm {
            desired_speed,
            max_acceleration: a_max,
            comfortable_deceleration: b,
            time_headway,
            min_gap,
            lane_half_width,
        } => {
            let free = 1.0 - (v / desired_speed.max(0.1)).powi(4);
            let interaction = leader(me, snapshot, lane_half_width).map_or(0.0, |(gap, v_lead)| {
                let s_star = min_gap
                    + (v * time_headway + v * (v - v_lead) / (2.0 * (a_max * b).sqrt())).max(0.0);
                (s_star / gap.max(0.1)).powi(2)
            });
            direct(a_max * (free - interaction))
        }
    }
}

/// The nearest actor ahead of `me` within ±`half_width` of its heading line:
/// (bumper-to-bumper gap in m, its speed in m/s). Ties go to the earlier actor.
fn leader(me: usize, snapshot: &[Snapshot], half_width: f64) -> Option<(f64, f64)> {
    let ego = &snapshot[me];
    let dir = Vec2::from_heading(ego.yaw);
    let mut best: Option<(f64, f64)> = None;
    for (j, other) in snapshot.iter().enumerate() {
        if j == me {
            continue;
        }
        let d = other.position - ego.position;
        let along = d.dot(dir);
        if along <= 0.0 || dir.cross(d).abs() > half_width {
            continue;
        }
        let gap = along - (ego.length + other.length) / 2.0;
        if best.is_none_or(|(g, _)| gap < g) {
            best = Some((gap, other.speed));
        }
    }
    best
}

impl World {
    /// Sets the road friction μ an actor's friction-use proxy is computed with.
    /// Unknown ids and non-positive values are ignored (callers validate).
    pub fn set_friction(&mut self, id: &str, mu: f64) {
        if let (Ok(i), true) = (self.index_of(id), mu.is_finite() && mu > 0.0) {
            self.actors[i].friction = mu;
        }
    }
}
