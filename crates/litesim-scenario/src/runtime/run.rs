//! The step loop: one [`Runtime`] drives every actor through its
//! controller, step by step.
//!
//! Each step (a chunk of steps in open loop) goes the same way:
//! 1. the head: live conditions may re-plan the test, light switches that
//!    are due are made, the chunk is sized (up to the next switch);
//! 2. observe: sut.car's observation is completed (route, road, lights);
//! 3. the controllers command, in a fixed order — the SUT, the drivers,
//!    the planned actors — each reading the same world;
//! 4. pacing (real time), then the simulator steps;
//! 5. the read-back: checks, log, coverage, goals, and the world the next
//!    step observes.

use super::cast::{self, Cast, Sim};
use super::controllers::drivers::Drivers;
use super::controllers::pid::Pid;
use super::controllers::planned::{Clock, Planned, yields};
use super::controllers::seam::{SutSeam, SutSlot};
use super::controllers::{Act, Controller, Flow, See, ssp_err};
use super::lights::Lights;
use super::live::Live;
use super::observe::{Observer, World};
use super::readback::{ReadEnv, Readback};
use super::sample::{due_time, sample_items};
use super::traffic::driven::Driven;
use super::{DriveMode, ExecConfig, Executed, Replan};
use crate::error::ScenarioError;
use crate::kpi::EgoKpi;
use crate::plan::Plan;
use crate::sut::SutInfo;
use litesim_log::{ControlSample, LogRecorder, SimulationLog};
use litesim_ssp::api::{KinematicSteps, Ssp};
use std::collections::BTreeMap;

/// Runs `plan` on `ssp`; with a `sut`, `sut.car` is driven by it each step
/// and the other actors react to where it actually is; with `drivers_of`,
/// the actors it drives (the scenario's vehicles under `--npc driver`,
/// ambient traffic) are driven by the traffic engine. The map is
/// `cfg.map`. With `replan`, a live condition that holds at another time
/// than planned has the test planned again ([`Head::Replan`]); without,
/// the plan stands.
pub fn execute<'a>(
    ssp: &'a mut dyn Ssp,
    plan: Plan,
    cfg: ExecConfig,
    sut: Option<SutSlot<'a>>,
    replan: Option<&Replan<'_>>,
    drivers_of: Option<Driven>,
) -> Result<Finished, ScenarioError> {
    let mut rt = Runtime::new(SspSlot::Borrowed(ssp), plan, cfg, sut, drivers_of)?;
    rt.replans = replan.is_some();
    loop {
        match rt.head()? {
            Head::Over => break,
            Head::Replan(fixed) => {
                if let Some(replan) = replan {
                    rt.adopt(replan(&fixed)?)?;
                }
            }
            Head::Ready => {
                if !rt.tail()? {
                    break;
                }
            }
        }
    }
    rt.finish()
}

/// What the head of a step found.
pub enum Head {
    /// The step is ready: observe, command, then the runtime's `tail`.
    Ready,
    /// The run is over.
    Over,
    /// A live condition held at another time than planned: the caller
    /// plans the test again with these condition times fixed and gives
    /// the plan to the runtime's `adopt`, then asks for the head again.
    Replan(BTreeMap<String, f64>),
}

/// What a finished run gives back: the record, the plan in force at the
/// end and the traffic engine (what its drivers asked, their notes).
pub struct Finished {
    /// What happened.
    pub ex: Executed,
    /// The plan in force at the end (a live condition may have replaced
    /// the first one).
    pub plan: Plan,
    /// The drivers, when there were any.
    pub drivers: Option<Driven>,
}

/// The simulator a runtime steps: the caller's (a run) or its own (a run
/// stepped from outside, which outlives any caller's frame).
pub enum SspSlot<'a> {
    /// Borrowed for the run.
    Borrowed(&'a mut dyn Ssp),
    /// Owned by the run.
    Owned(Box<dyn Ssp>),
}

impl SspSlot<'_> {
    fn get(&mut self) -> &mut dyn Ssp {
        match self {
            SspSlot::Borrowed(s) => &mut **s,
            SspSlot::Owned(s) => &mut **s,
        }
    }
}

/// A run in progress: the simulator, the controllers and what the
/// read-back has gathered. It owns everything per run (the plan, the
/// configuration, the drivers) so that a caller can keep it between
/// steps ([`crate::Stepped`]); only the simulator and the re-planning
/// may be borrowed.
pub(crate) struct Runtime<'a> {
    ssp: SspSlot<'a>,
    cfg: ExecConfig,
    /// The plan in force: replaced when a condition holds live at another
    /// time than planned (closed loop only).
    plan: Plan,
    /// Live conditions are checked, and a re-plan asked for (closed loop
    /// with a caller that plans again).
    pub replans: bool,
    /// The step whose live conditions were checked last.
    relived: Option<u64>,
    sim: Sim,
    cast: Cast,
    /// Per actor: driven by a driver.
    driven: Vec<bool>,
    /// Per actor: driven by pedals and steering (planned, dynamic mode).
    dynamic: Vec<bool>,
    lights: Lights,
    environment: super::environment::Environment,
    live: Live,
    world: World,
    observer: Option<Observer>,
    sut: Option<SutSeam<'a>>,
    drivers: Option<Drivers>,
    /// A controller that runs a scenario of its own (an OpenSCENARIO
    /// storyboard), driving the actors it claimed ([`Runtime::set_story`]).
    story: Option<Box<dyn Controller + Send + 'a>>,
    /// The scenario controller said the scenario is over.
    ended: bool,
    planned: Planned,
    /// Per actor: the command it got last.
    controls: Vec<ControlSample>,
    rb: Readback,
    /// Each chunk's states, the memory kept from chunk to chunk.
    got: KinematicSteps,
    /// Each gap goal's (actor, reference) indices; goals come sorted by end
    /// time.
    goal_actors: Vec<Option<(usize, usize)>>,
    /// The actor a SUT drives.
    ego_i: Option<usize>,
    /// sut.car's actor, driven or planned.
    ego_index: Option<usize>,
    /// Steps done.
    k: u64,
    /// Steps the plan lasts.
    steps: u64,
    /// Most steps per simulator call (1 in closed loop).
    chunk: u64,
    /// The step's head is done (conditions, lights, observation): its
    /// (steps, sut.car's offset from its route) wait for the command.
    headed: Option<(u64, Option<f64>)>,
    pacer: Option<crate::realtime::Pacer>,
    realtime_failure: Option<String>,
    sut_error: Option<String>,
}

/// The earlier of two steps, either maybe none.
fn min_tick(a: Option<u64>, b: Option<u64>) -> Option<u64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// Each goal's (actor, reference) indices.
fn goal_indices(plan: &Plan) -> Vec<Option<(usize, usize)>> {
    plan.goals
        .iter()
        .map(|g| {
            let idx = |id: &str| plan.actors.iter().position(|a| a.id == id);
            Some((idx(&g.actor)?, idx(&g.reference)?))
        })
        .collect()
}

/// Steps of the chunk from step `k`: `most`, or fewer so that it ends
/// where the next light switch (`switch`, its step) happens — at least one.
fn chunk_steps(k: u64, most: u64, switch: Option<u64>) -> u64 {
    match switch {
        Some(at) => most.min(at.saturating_sub(k).max(1)),
        None => most,
    }
}

/// Per actor: driven by pedals and steering — a vehicle that moves, in
/// dynamic mode, that neither the SUT nor a driver drives.
fn pedal_driven(plan: &Plan, cfg: &ExecConfig, ego_i: Option<usize>, driven: &[bool]) -> Vec<bool> {
    (0..plan.actors.len())
        .map(|i| {
            let a = &plan.actors[i];
            // A plan that asks for exactness (a jump, a heading of its
            // own) is replayed as it is, never chased with pedals.
            Some(i) != ego_i
                && !driven[i]
                && !plan.exact.contains_key(&a.id)
                && cfg.mode == DriveMode::Dynamic
                && a.kind == litesim_core::ActorClass::Vehicle
                && a.samples.iter().any(|s| s.v > 0.0)
        })
        .collect()
}

/// The log recorder, told what the simulator is.
fn recorder(sim: &Sim, cfg: &ExecConfig) -> LogRecorder {
    let mut r = LogRecorder::new(sim.dt);
    r.meta("profile", &sim.caps.profile);
    r.meta("model", &sim.caps.model);
    r.meta("mode", format!("{:?}", cfg.mode).to_lowercase());
    r.meta("seed", cfg.seed);
    r
}

/// What the SUT is told before the first step.
fn sut_info(
    cfg: &ExecConfig,
    sim: &Sim,
    plan: &Plan,
    cast: &Cast,
    e: usize,
    obs: &Observer,
) -> SutInfo {
    let lim = cast.catalogue[e];
    SutInfo {
        test: cfg.test_name.clone(),
        seed: cfg.seed,
        map_path: cfg.map_path.clone(),
        step_ms: sim.step_ms as u32,
        ego_id: plan.actors[e].id.clone(),
        length: cast.dims[e].0,
        width: cast.dims[e].1,
        wheelbase: lim.wheelbase,
        max_steer: lim.max_steer,
        max_accel: lim.max_accel,
        max_decel: lim.max_decel,
        route: obs.route.clone(),
        timeout_s: cfg.sut_timeout,
        map: cfg.map.clone(),
    }
}

/// The planned controller for every actor neither the SUT (`ego_i`) nor
/// a driver drives; `dynamic[i]`: actor i gets a pedal driver.
fn planned_controller(
    sim: &Sim,
    cast: &Cast,
    dynamic: &[bool],
    ego_i: Option<usize>,
    driven: &[bool],
    (open_loop, yielding): (bool, bool),
) -> Planned {
    let n = dynamic.len();
    let pids: Vec<Option<Pid>> = (0..n)
        .map(|i| dynamic[i].then(|| Pid::new(cast.limits[i], sim.mirror, sim.resolution)))
        .collect();
    let other: Vec<bool> = (0..n).map(|i| Some(i) == ego_i || driven[i]).collect();
    // Open loop with many actors: trajectories are made on another core.
    let overlap = open_loop && n >= crate::PARALLEL_ACTORS;
    Planned::new(
        n,
        pids,
        other,
        sim.calibration,
        (open_loop, overlap, yielding),
    )
}

impl<'a> Runtime<'a> {
    /// Sets the stage: the simulator initialised, every actor created, the
    /// controllers made, the SUT reset.
    pub fn new(
        mut ssp: SspSlot<'a>,
        plan: Plan,
        cfg: ExecConfig,
        sut: Option<SutSlot<'a>>,
        drivers_of: Option<Driven>,
    ) -> Result<Self, ScenarioError> {
        let n = plan.actors.len();
        let driven: Vec<bool> = match drivers_of.as_ref() {
            Some(d) => d.driven.iter().map(Option::is_some).collect(),
            None => vec![false; n],
        };
        let ego_index = plan.actors.iter().position(|a| a.ego);
        let ego_i = match sut {
            Some(_) => Some(ego_index.ok_or_else(|| {
                ScenarioError::Plan(
                    "a system under test drives sut.car, but sut.car takes part in no phase".into(),
                )
            })?),
            None => None,
        };
        if let Some(why) = ego_i.and_then(|e| plan.exact.get(&plan.actors[e].id)) {
            return Err(ScenarioError::Plan(format!(
                "{why}: sut.car's plan asks for exactness over physics, but a system under test drives sut.car (the SUT's car goes where its commands take it; use --sut planned)"
            )));
        }
        let sim = cast::init(ssp.get(), &cfg)?;
        let mut rec = cfg.record.then(|| recorder(&sim, &cfg));
        let dynamic = pedal_driven(&plan, &cfg, ego_i, &driven);
        let modes: Vec<bool> = (0..n).map(|i| dynamic[i] || Some(i) == ego_i).collect();
        let cast = cast::create(ssp.get(), &sim, &plan, &modes, rec.as_mut())?;
        let ids: Vec<String> = plan.actors.iter().map(|a| a.id.clone()).collect();
        let ego_kpi = ego_index.map(|e| {
            EgoKpi::new(&plan.actors[e].id, sim.dt).with_areas(cfg.conflict_areas.clone())
        });
        let rb = Readback::new(&ids, rec, ego_kpi, &cfg, &plan);
        let yielding = cfg.people_yield && plan.actors.iter().any(yields);
        // Without closed-loop drivers nothing needs the states before the
        // next command: the plan is known, so trajectories go out a chunk
        // (up to 60 s) ahead and the chunk's steps run in one `step_many`
        // call — a handful of round trips per test over gRPC instead of one
        // per step. Replies stay bounded: ≤ 5,000 actor states per call
        // (20,000 made the 100-vehicle test 1.25× slower: a chunk's ~4.6 MB
        // of states pushed the checkers' tables out of the cache; 2,000
        // re-sends too much overlap — BENCHMARKS.md, eleventh session).
        let open_loop =
            !dynamic.iter().any(|d| *d) && ego_i.is_none() && drivers_of.is_none() && !yielding;
        // Paced to the wall clock: one step per call, each released on time.
        let pacer = cfg
            .realtime
            .map(|p| crate::realtime::Pacer::new(sim.step_ms as u32, p));
        let chunk = if open_loop && pacer.is_none() {
            (60_000 / sim.step_ms).clamp(1, (5_000 / n.max(1)) as u64)
        } else {
            1
        };
        let lights = Lights::list(ssp.get(), &plan, &cfg, cfg.map.as_deref())?;
        let drivers = match (drivers_of, cfg.map.clone()) {
            (Some(d), Some(net)) => Some(Drivers::new(d, net, &lights)),
            _ => None,
        };
        let planned =
            planned_controller(&sim, &cast, &dynamic, ego_i, &driven, (open_loop, yielding));
        let world = if open_loop {
            World::empty()
        } else {
            World::start(&plan, &cast.dims, ego_i)
        };
        let mut rt = Runtime {
            steps: litesim_core::steps_for_horizon(plan.duration, sim.dt),
            goal_actors: goal_indices(&plan),
            live: Live::new(&plan),
            controls: vec![ControlSample::default(); n],
            plan,
            ssp,
            cfg,
            replans: false,
            relived: None,
            sim,
            cast,
            driven,
            dynamic,
            lights,
            environment: Default::default(),
            world,
            observer: None,
            sut: None,
            drivers,
            story: None,
            ended: false,
            planned,
            rb,
            got: KinematicSteps::default(),
            ego_i,
            ego_index,
            k: 0,
            chunk,
            headed: None,
            pacer,
            realtime_failure: None,
            sut_error: None,
        };
        if let (Some(e), Some(s)) = (ego_i, sut) {
            rt.seat_sut(e, s);
        }
        Ok(rt)
    }

    /// The SUT takes sut.car (actor `e`): it is told its vehicle and route.
    fn seat_sut(&mut self, e: usize, s: SutSlot<'a>) {
        let observer = Observer::new(&self.plan.actors[e]);
        let lim = self.cast.catalogue[e];
        let model = (self.sim.caps.model.as_str(), self.cast.dims[e].2);
        let mut seam = SutSeam::new(s, e, lim, model, self.sim.mirror);
        let info = sut_info(&self.cfg, &self.sim, &self.plan, &self.cast, e, &observer);
        self.sut_error = seam.reset(&info);
        self.sut = Some(seam);
        self.observer = Some(observer);
    }

    /// Hands the actors marked in `claims` to `story`, a controller that
    /// runs a scenario of its own (an OpenSCENARIO storyboard): the
    /// planned controller leaves them, and the world is observed every
    /// step (the story's conditions read it).
    pub fn set_story(&mut self, story: Box<dyn Controller + Send + 'a>, claims: &[bool]) {
        for (d, c) in self.driven.iter_mut().zip(claims) {
            *d |= *c;
        }
        self.dynamic = pedal_driven(&self.plan, &self.cfg, self.ego_i, &self.driven);
        self.planned = planned_controller(
            &self.sim,
            &self.cast,
            &self.dynamic,
            self.ego_i,
            &self.driven,
            (false, false),
        );
        self.world = World::start(&self.plan, &self.cast.dims, self.ego_i);
        self.chunk = 1;
        self.story = Some(story);
    }

    /// Whether the run is over (its steps done, the SUT failed, real time
    /// overran, or the scenario controller ended the scenario).
    pub fn over(&self) -> bool {
        self.k >= self.steps
            || self.ended
            || self.sut_error.is_some()
            || self.realtime_failure.is_some()
    }

    /// The step's head, once per step: live conditions (a re-plan asked
    /// of the caller), light switches, the chunk's size, sut.car's
    /// observation.
    pub fn head(&mut self) -> Result<Head, ScenarioError> {
        if self.headed.is_some() {
            return Ok(Head::Ready);
        }
        if self.over() {
            return Ok(Head::Over);
        }
        let (k, step_ms) = (self.k, self.sim.step_ms);
        if self.relived != Some(k) {
            self.relived = Some(k);
            if let Some(fixed) = self.relive() {
                return Ok(Head::Replan(fixed));
            }
        }
        self.lights
            .switch_due(self.ssp.get(), &self.plan, k, step_ms)?;
        self.environment.apply_due(
            self.ssp.get(),
            &self.plan,
            (k, step_ms),
            self.rb.rec.as_mut(),
        )?;
        // A chunk ends where the next switch or change is made.
        let next_switch = min_tick(
            self.lights.next_tick(&self.plan, step_ms),
            self.environment.next_tick(&self.plan, step_ms),
        );
        let n_steps = chunk_steps(k, self.chunk.min(self.steps - k), next_switch);
        let ego_lateral = self.observe();
        self.headed = Some((n_steps, ego_lateral));
        Ok(Head::Ready)
    }

    /// What sut.car observes at this step (after [`Runtime::head`]),
    /// shared (see [`World::obs`]).
    pub fn observation(&self) -> Option<&std::sync::Arc<crate::sut::Observation>> {
        self.observer.as_ref().map(|_| &self.world.obs)
    }

    /// The command of a SUT driven from outside, for this step.
    pub fn give(&mut self, cmd: crate::sut::SutCommand) {
        if let Some(s) = self.sut.as_mut() {
            s.give(cmd);
        }
    }

    /// The rest of the step: the controllers command, the simulator steps,
    /// the read-back. Returns whether the run goes on.
    pub fn tail(&mut self) -> Result<bool, ScenarioError> {
        let Some((n_steps, ego_lateral)) = self.headed.take() else {
            return Ok(!self.over());
        };
        let k = self.k;
        match self.command(n_steps, ego_lateral)? {
            Flow::Stop(msg) => {
                self.sut_error = Some(msg);
                return Ok(false);
            }
            // The scenario is over: this step is made, then no more.
            Flow::End(_) => self.ended = true,
            Flow::Go => {}
        }
        if let Some(p) = self.pacer.as_mut()
            && let Err(msg) = p.release(k)
        {
            self.realtime_failure = Some(msg.to_string());
            return Ok(false);
        }
        self.simulate(n_steps)?;
        self.read(n_steps)?;
        Ok(self.k < self.steps)
    }

    /// The time of the step to come (s).
    pub fn time(&self) -> f64 {
        (self.k * self.sim.step_ms) as f64 / 1000.0
    }

    /// Closed loop: the plan's conditions on the world. The times to fix
    /// when one held at another time than planned (the plan must be made
    /// again).
    fn relive(&mut self) -> Option<BTreeMap<String, f64>> {
        if !self.replans || self.ego_i.is_none() || self.plan.conditions.is_empty() {
            return None;
        }
        let t = (self.k * self.sim.step_ms) as f64 / 1000.0;
        self.live
            .check(&self.plan, &self.world, t)
            .then(|| self.live.fixed.clone())
    }

    /// Takes the plan made again after [`Head::Replan`]: from the step to
    /// come on, the run follows it.
    pub fn adopt(&mut self, new: Plan) -> Result<(), ScenarioError> {
        if new.actors.len() != self.plan.actors.len() {
            return Err(ScenarioError::Plan(
                "planning again for a live condition changed the actors".into(),
            ));
        }
        let (k, step_ms) = (self.k, self.sim.step_ms);
        let t = (k * step_ms) as f64 / 1000.0;
        self.plan = new;
        let (plan, rb) = (&self.plan, &mut self.rb);
        rb.next_due = due_time(&self.cfg, plan, &rb.samples);
        self.steps = litesim_core::steps_for_horizon(plan.duration, self.sim.dt);
        self.goal_actors = goal_indices(plan);
        // Goals ended and switches due by now belong to the past.
        rb.next_goal = plan.goals.iter().filter(|g| g.t1 <= t + 1e-9).count();
        rb.next_lane_goal = plan.lane_goals.iter().filter(|g| g.t1 <= t + 1e-9).count();
        self.lights.replanned(plan, k, step_ms);
        self.environment.replanned(plan, k, step_ms);
        rb.tracking.cum.clear();
        rb.goal_braking = vec![None; plan.goals.len()];
        self.planned.replanned();
        Ok(())
    }

    /// Completes sut.car's observation; returns its offset from its route.
    fn observe(&mut self) -> Option<f64> {
        let (observer, seam) = (self.observer.as_mut()?, self.sut.as_ref()?);
        let e = seam.ego;
        let t = (self.k * self.sim.step_ms) as f64 / 1000.0;
        observer.observe(
            &mut self.world,
            &self.plan,
            (self.k, t),
            e,
            self.rb.last_pos[e].as_ref(),
            self.cfg.map.as_deref(),
            &mut self.lights,
        )
    }

    /// Every controller commands its actors, in the fixed order: the SUT,
    /// the drivers, the planned actors.
    fn command(&mut self, n_steps: u64, ego_lateral: Option<f64>) -> Result<Flow, ScenarioError> {
        let see = See {
            plan: &self.plan,
            world: &self.world,
            lights: &self.lights,
            dims: &self.cast.dims,
            goal_actors: &self.goal_actors,
            k: self.k,
            n_steps,
            step_ms: self.sim.step_ms,
            ego_i: self.ego_i,
            ego_index: self.ego_index,
            ego_lateral,
            mirror: self.sim.mirror,
        };
        let mut act = Act {
            ssp: self.ssp.get(),
            controls: &mut self.controls,
        };
        let mut controllers: [Option<&mut dyn Controller>; 4] = [
            self.sut.as_mut().map(|c| c as &mut dyn Controller),
            self.drivers.as_mut().map(|c| c as &mut dyn Controller),
            self.story.as_mut().map(|c| &mut **c as &mut dyn Controller),
            Some(&mut self.planned),
        ];
        let mut flow = Flow::Go;
        for c in controllers.iter_mut().flatten() {
            match c.command(&see, &mut act)? {
                Flow::Stop(msg) => return Ok(Flow::Stop(msg)),
                Flow::End(msg) => flow = Flow::End(msg),
                Flow::Go => {}
            }
        }
        Ok(flow)
    }

    /// The simulator runs `n_steps` steps.
    fn simulate(&mut self, n_steps: u64) -> Result<(), ScenarioError> {
        if n_steps == 1 {
            self.ssp
                .get()
                .step_kinematics(&mut self.got)
                .map_err(ssp_err)?;
        } else {
            self.ssp
                .get()
                .step_many_kinematics(n_steps as u32, &mut self.got)
                .map_err(ssp_err)?;
        }
        self.k += n_steps;
        Ok(())
    }

    /// Reads the steps just simulated back (open loop with many actors: the
    /// next chunk's trajectories are made meanwhile, on another core when
    /// one is free).
    fn read(&mut self, n_steps: u64) -> Result<(), ScenarioError> {
        let (k, step_ms) = (self.k, self.sim.step_ms);
        let planned = &mut self.planned;
        let env = ReadEnv {
            plan: &self.plan,
            net: self.cfg.map.as_deref(),
            cfg: &self.cfg,
            lights: &self.lights,
            dims: &self.cast.dims,
            dynamic: &self.dynamic,
            controls: &self.controls,
            ego_i: self.ego_i,
            ego_index: self.ego_index,
            sampling: !self.cfg.covers.is_empty(),
            observed: !planned.open_loop,
            mirror: self.sim.mirror,
            step_ms,
            goal_actors: &self.goal_actors,
            warps: &planned.warps,
            sent: &planned.sent,
            driven: &self.driven,
            sut_command: self.sut.as_ref().and_then(|s| s.last),
        };
        let (rb, world, got) = (&mut self.rb, &mut self.world, &mut self.got);
        if !(planned.overlap && k < self.steps) {
            return rb.chunk(&env, world, got);
        }
        // The next chunk's clock as the loop's head will make it: from here
        // to the end or the next light switch.
        let switch = min_tick(
            self.lights.next_after(&self.plan, k, step_ms),
            self.environment.next_after(&self.plan, k, step_ms),
        );
        let c = Clock {
            now_ms: k * step_ms,
            step_ms,
            ahead_ms: chunk_steps(k, self.chunk.min(self.steps - k), switch) * step_ms,
            dt: self.plan.dt,
            mirror: self.sim.mirror,
        };
        debug_assert!(n_steps >= 1);
        let (actors, warps, prefetch) = (&self.plan.actors, &planned.warps, &mut planned.prefetch);
        rayon::in_place_scope(|s| {
            s.spawn(move |_| prefetch.make(actors, warps, c));
            rb.chunk(&env, world, got)
        })
    }

    /// Ends the simulation and gathers what the run produced.
    pub fn finish(mut self) -> Result<Finished, ScenarioError> {
        let reason = if self.sut_error.is_some() {
            "system under test failed"
        } else if self.ended {
            "scenario ended"
        } else {
            "plan finished"
        };
        let story = self.story.as_mut().and_then(|s| s.report());
        self.ssp.get().end_simulation(reason).map_err(ssp_err)?;
        let Readback {
            states,
            mut kpis,
            rec,
            tracking,
            mut ego_kpi,
            last_t,
            mut samples,
            goal_results,
            lane_results,
            ..
        } = self.rb;
        let plan = self.plan;
        let sut_notes = self.sut.as_mut().map(SutSeam::notes).unwrap_or_default();
        let never_held = self.live.never_held(&plan);
        kpis.finish();
        if !self.cfg.covers.is_empty() {
            let net = self.cfg.map.as_deref();
            sample_items(&self.cfg, &plan, net, &states, last_t, true, &mut samples);
        }
        if let (Some(ek), Some(e)) = (ego_kpi.as_mut(), self.ego_index) {
            let last = plan.actors[e].samples.last().copied().unwrap_or_default();
            ek.finish(last.x, last.y);
            ek.finish_pets(e, |j| &plan.actors[j].id);
        }
        let log = rec.map(|r| finish_log(r, tracking, &plan, self.ego_i.is_some()));
        let driven = plan
            .actors
            .iter()
            .zip(&self.driven)
            .filter(|(_, d)| **d)
            .map(|(a, _)| a.id.clone())
            .collect();
        let ex = Executed {
            kpis,
            steps: self.k,
            live_events: self.live.events,
            ego: ego_kpi,
            goals: goal_results,
            lane_goals: lane_results,
            sut_error: self.sut_error,
            log,
            profile: self.sim.caps.profile,
            model: self.sim.caps.model,
            realtime: self.pacer.as_ref().map(crate::realtime::Pacer::stats),
            realtime_failure: self.realtime_failure,
            coverage: samples.into_iter().flatten().collect(),
            driven,
            sut_notes,
            environment_notes: std::mem::take(&mut self.environment.notes),
            never_held,
            story,
        };
        Ok(Finished {
            ex,
            plan,
            drivers: self.drivers.map(|d| d.driven),
        })
    }
}

/// The recorded log, with sut.car's tracking columns and planned path
/// (drawn as the reference in the dashboard's map panel and the ego
/// animation).
fn finish_log(
    r: LogRecorder,
    tracking: super::readback::Tracking,
    plan: &Plan,
    closed_loop: bool,
) -> SimulationLog {
    let mut log = r.finish();
    if !tracking.tick.is_empty() {
        log.tracking = Some(litesim_log::TrackingColumns {
            command_source: if closed_loop { "sut" } else { "planned" }.into(),
            ..tracking.columns
        });
    }
    if let Some(ego) = plan.actors.iter().find(|a| a.ego) {
        log.plan = Some(litesim_log::PlanRecord {
            corridor: ego.samples.iter().map(|s| [s.x, s.y]).collect(),
            corridor_speed: ego.samples.iter().map(|s| s.v).collect(),
            smoothed: true,
            reference_name: "planned path".into(),
            ..litesim_log::PlanRecord::default()
        });
    }
    log
}
