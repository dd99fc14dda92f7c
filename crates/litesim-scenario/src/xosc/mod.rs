//! OpenSCENARIO XML on litesim's runtime: a `.xosc` scenario (read by
//! `litesim-xosc`) becomes the runtime's inputs — its entities are the
//! plan's actors (placed by the Init actions), and its storyboard is one
//! controller, [`Storyboard`], that runs live: each step it evaluates the
//! triggers on the simulated state, moves the storyboard's elements
//! through their states, and drives its entities under the actions that
//! run (the standard's default controller). The entity with an
//! `ExternalController` is sut.car: a SUT (`--sut`) drives it, and every
//! other actor reacts to where it really is.
//!
//! - `place`: positions resolved on the map;
//! - `motion`: the entities' motion under their actions;
//! - `story`: element states, transitions, triggers (edges, delays);
//! - `cond`: the conditions on the state;
//! - `apply`: what each action does when it starts.

mod apply;
mod cond;
pub mod motion;
pub mod place;
pub mod story;

use crate::error::ScenarioError;
use crate::plan::{ActorPlan, Plan, PlanSample};
use crate::runtime::controllers::{Act, Controller, Flow, See, ssp_err, to_sim};
use litesim_core::ActorClass;
use litesim_core::math;
use litesim_map::{LanePos, RoadNetwork};
use litesim_ssp::api::{Coord6, XyTrajectory};
use litesim_xosc::{ActionKind, ElementType, EntityKind, Priority, Scenario};
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;
use story::{Elem, State, Transition, TriggerRt};

/// How long a run may last when its stop trigger does not say (s).
pub const DEFAULT_DURATION_S: f64 = 120.0;

/// One entity as the storyboard moves it: its reference point (the rear
/// axle's ground point, as OpenSCENARIO places entities), heading, speed
/// and lane.
#[derive(Clone, Debug)]
pub struct Body {
    /// The entity's name (the actor's id).
    pub id: String,
    /// Reference point x (m).
    pub x: f64,
    /// Reference point y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
    /// Speed (m/s).
    pub v: f64,
    /// Acceleration (m/s²), from the last step.
    pub a: f64,
    /// Its lane and offset from the lane centre (m, towards +t).
    pub lane: Option<(LanePos, f64)>,
    /// Bounding box centre in the entity frame (m): ahead, left.
    pub centre_offset: (f64, f64),
    /// Box length (m).
    pub length: f64,
    /// Box width (m).
    pub width: f64,
    /// maxSpeed, maxAcceleration, maxDeceleration.
    pub perf: [f64; 3],
    /// Distance travelled since the start (m).
    pub traveled: f64,
    /// `vehicle`, `pedestrian` or `miscellaneous` (collision by type).
    pub object_type: String,
    /// In the scenario (not deleted, or added).
    pub active: bool,
    /// Moves along its lane (a vehicle); else straight on where it faces.
    pub on_lanes: bool,
    /// Since when it has stood still (s).
    pub still_since: Option<f64>,
    /// Since when it has been off the road (s).
    pub off_since: Option<f64>,
    /// Since when it has been at the end of the road network (s).
    pub end_since: Option<f64>,
    /// Its lane ended under it this step.
    pub end_of_road: bool,
    /// The longitudinal action running.
    pub long: Option<motion::Long>,
    /// The lateral action running.
    pub lat: Option<motion::Lat>,
    /// The trajectory it follows.
    pub path: Option<motion::Path>,
    /// The roads of its assigned route, in order.
    pub route: Vec<LanePos>,
    /// An `AcquirePositionAction` under way: (action, target).
    pub acquire: Option<(usize, place::Place)>,
    /// The heading's sine and cosine, kept while it holds (a cache of
    /// `trig_of`, not part of the body's state).
    pub(crate) trig: std::cell::Cell<math::SinCosMemo>,
}

impl Body {
    /// `math::sin_cos(yaw)`, kept for the next ask: the body's heading is
    /// asked several times a step (before and after moving, observing,
    /// sending) and holds along a straight lane.
    pub fn trig_of(&self, yaw: f64) -> (f64, f64) {
        let mut memo = self.trig.get();
        let sc = memo.get(yaw);
        self.trig.set(memo);
        sc
    }

    /// The box centre (m).
    pub fn centre(&self) -> (f64, f64) {
        let (s, c) = self.trig_of(self.yaw);
        let (dx, dy) = self.centre_offset;
        (self.x + dx * c - dy * s, self.y + dx * s + dy * c)
    }
}

/// A trigger that fired: what, when (the summary lists them).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fired {
    /// `start` or `stop`, and the element it belongs to (`act`, `event`,
    /// `storyboard`).
    pub trigger: String,
    /// The element's name.
    pub element: String,
    /// Simulation time (s).
    pub t: f64,
    /// Where the element is written.
    pub at: String,
}

/// The storyboard, run live: the runtime's controller for the scenario's
/// entities.
pub struct Storyboard {
    pub(crate) net: Arc<RoadNetwork>,
    pub(crate) scenario: Arc<Scenario>,
    /// Every entity, in plan order.
    pub bodies: Vec<Body>,
    /// Per body: moved by the storyboard (not by a SUT).
    pub driven: Vec<bool>,
    pub(crate) elems: Vec<Elem>,
    /// Every action of the stories: (its element, the action).
    pub(crate) actions: Vec<(usize, litesim_xosc::Action)>,
    pub(crate) triggers: Vec<TriggerRt>,
    /// The storyboard's stop trigger.
    stop: Option<usize>,
    /// Transitions of the last step (what conditions see now).
    pub(crate) took: Vec<(usize, Transition)>,
    /// Transitions of this step.
    took_now: Vec<(usize, Transition)>,
    /// Whether an element moved (by [`Storyboard::set`]) since the last
    /// [`Storyboard::settle`] found nothing to end: only such a move can
    /// give a running element its last complete child.
    unsettled: bool,
    pub(crate) params: BTreeMap<String, String>,
    pub(crate) vars: BTreeMap<String, String>,
    pub(crate) signals: BTreeMap<String, String>,
    /// Signal states to send to the simulator (set by actions, which have
    /// no simulator at hand).
    pub(crate) pending: Vec<(String, String)>,
    /// Signal controllers: (current phase index, since when).
    phases: Vec<(usize, f64)>,
    /// Triggers that fired, in order.
    pub fired: Vec<Fired>,
    /// Notes: what was read but not applied, and why.
    pub notes: Vec<String>,
    /// The time of the step being made (s).
    pub(crate) t: f64,
    dt: f64,
    /// Why the storyboard ended, when it did.
    pub ended: Option<String>,
    started: bool,
    /// The bodies as they were at the step's start (reused).
    snapshot: Vec<Body>,
    /// Each body's box centre before the step (reused).
    before: Vec<(f64, f64, f64)>,
    /// The trajectory being sent (reused).
    traj: XyTrajectory,
}

fn class_of(k: &EntityKind) -> (ActorClass, String, &'static str) {
    match k {
        EntityKind::Vehicle { category, .. } => match category.as_str() {
            "bicycle" => (ActorClass::Cyclist, "bicycle".into(), "vehicle"),
            "truck" | "semitrailer" | "trailer" => (ActorClass::Vehicle, "truck".into(), "vehicle"),
            "bus" | "tram" | "train" => (ActorClass::Vehicle, "bus".into(), "vehicle"),
            "motorbike" => (ActorClass::Vehicle, "motorcycle".into(), "vehicle"),
            _ => (ActorClass::Vehicle, "car".into(), "vehicle"),
        },
        EntityKind::Pedestrian { category, .. } if category == "animal" => {
            (ActorClass::Animal, "animal".into(), "pedestrian")
        }
        EntityKind::Pedestrian { .. } => (ActorClass::Person, "pedestrian".into(), "pedestrian"),
        EntityKind::MiscObject { .. } => {
            (ActorClass::Stationary, "obstacle".into(), "miscellaneous")
        }
    }
}

/// A prepared OpenSCENARIO XML test: the scenario and the entity a SUT
/// drives.
#[derive(Clone, Debug)]
pub struct XoscTest {
    /// The scenario as read.
    pub scenario: Arc<Scenario>,
    /// The entity that is sut.car (`--ego NAME`, else the one with an
    /// `ExternalController`).
    pub ego: Option<usize>,
}

impl XoscTest {
    /// The scenario with its ego chosen (`ego`: a name from the command
    /// line, checked).
    pub fn new(sc: Scenario, ego: Option<&str>) -> Result<Self, ScenarioError> {
        let ego = ego_of(&sc, ego)?;
        Ok(XoscTest {
            scenario: Arc::new(sc),
            ego,
        })
    }
}

/// The entity a SUT drives: `--ego NAME`, else the one with an
/// `ExternalController`, else none.
pub fn ego_of(sc: &Scenario, ego: Option<&str>) -> Result<Option<usize>, ScenarioError> {
    if let Some(name) = ego {
        return sc
            .entities
            .iter()
            .position(|e| e.name == name)
            .map(Some)
            .ok_or_else(|| {
                ScenarioError::Plan(format!(
                    "--ego {name}: the scenario has no entity of that name (it has {})",
                    sc.entities
                        .iter()
                        .map(|e| e.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            });
    }
    Ok(sc
        .entities
        .iter()
        .position(|e| e.controller.as_ref().is_some_and(|c| c.external)))
}

/// The run's length: the storyboard's stop trigger when it is one
/// simulation-time condition, else [`DEFAULT_DURATION_S`] (a note says so).
fn run_length(sc: &Scenario, notes: &mut Vec<String>) -> f64 {
    use litesim_xosc::{ConditionKind, Rule};
    if let Some(t) = &sc.stop_trigger {
        let times: Vec<f64> = t
            .groups
            .iter()
            .filter_map(|g| match g.as_slice() {
                [c] => match &c.kind {
                    ConditionKind::SimulationTime {
                        rule: Rule::GreaterThan | Rule::GreaterOrEqual | Rule::EqualTo,
                        value,
                    } => Some(value + c.delay),
                    _ => None,
                },
                _ => None,
            })
            .collect();
        if let Some(m) = times.iter().copied().reduce(f64::min) {
            // One step beyond: a `greaterThan` fires the step after.
            return m + 1.0;
        }
    }
    notes.push(format!(
        "the storyboard's stop trigger sets no time: the run lasts at most {DEFAULT_DURATION_S} s"
    ));
    DEFAULT_DURATION_S
}

/// Sets a run up: the plan's actors placed by the Init actions, and the
/// storyboard controller. `sut`: a SUT drives the entity `ego_of` names.
pub fn setup(
    sc: Arc<Scenario>,
    net: Arc<RoadNetwork>,
    step_ms: u32,
    ego: Option<usize>,
    sut: bool,
) -> Result<(Plan, Storyboard, Vec<String>), ScenarioError> {
    let dt = f64::from(step_ms) / 1000.0;
    let mut notes = Vec::new();
    let duration = run_length(&sc, &mut notes);
    let mut sb = Storyboard::new(sc.clone(), net.clone(), dt);
    if let Some(e) = ego {
        sb.driven[e] = !sut;
        if !sut
            && sc.entities[e]
                .controller
                .as_ref()
                .is_some_and(|c| c.external)
        {
            notes.push(format!(
                "{} has an ExternalController but no system under test was given (--sut): the storyboard drives it",
                sc.entities[e].name
            ));
        }
    }
    sb.init()?;
    let mut plan = Plan {
        dt: 0.1,
        duration,
        ..Plan::default()
    };
    for (i, (e, b)) in sc.entities.iter().zip(&sb.bodies).enumerate() {
        let (kind, category, _) = class_of(&e.kind);
        let (cx, cy) = b.centre();
        let mut samples = vec![PlanSample {
            t: 0.0,
            x: cx,
            y: cy,
            yaw: b.yaw,
            v: b.v,
            a: 0.0,
        }];
        if Some(i) == ego && sut {
            // The SUT's route: on along its lane at its start speed (what
            // the observation's route and the log's reference show).
            samples = ego_route(&net, b, duration);
        }
        plan.actors.push(ActorPlan {
            id: e.name.clone(),
            kind,
            ego: Some(i) == ego,
            category,
            model: None,
            length: b.length,
            width: b.width,
            samples,
            jumps: Vec::new(),
            heading_trig: Default::default(),
        });
    }
    for (i, b) in sb.bodies.iter().enumerate() {
        if !b.active {
            notes.push(format!(
                "{} is not in the scenario at the start (no Init position): it waits off the map until an AddEntityAction",
                sb.bodies[i].id
            ));
        }
    }
    Ok((plan, sb, notes))
}

/// sut.car's nominal path: along its lane at its Init speed, 0.1 s apart.
fn ego_route(net: &RoadNetwork, b: &Body, duration: f64) -> Vec<PlanSample> {
    let n = (duration / 0.1).ceil() as usize + 1;
    let v = b.v.max(1.0);
    (0..n)
        .map(|k| {
            let t = k as f64 * 0.1;
            let (x, y, yaw) = match b.lane {
                Some((p, off)) => {
                    let q = net.advance(p, v * t);
                    place::on_lane(net, q, off).map_or((b.x, b.y, b.yaw), |pl| (pl.x, pl.y, pl.yaw))
                }
                None => {
                    let (bs, bc) = math::sin_cos(b.yaw);
                    (b.x + v * t * bc, b.y + v * t * bs, b.yaw)
                }
            };
            let (s, c) = math::sin_cos(yaw);
            let (dx, dy) = b.centre_offset;
            PlanSample {
                t,
                x: x + dx * c - dy * s,
                y: y + dx * s + dy * c,
                yaw,
                v: b.v,
                a: 0.0,
            }
        })
        .collect()
}

/// Where an entity waits while it is not in the scenario: beyond
/// [`crate::runtime::ABSENT_BEYOND_M`], apart from the others.
fn parked(i: usize) -> (f64, f64) {
    (-10.0 * crate::runtime::ABSENT_BEYOND_M, 1.0e3 * i as f64)
}

impl Storyboard {
    fn new(sc: Arc<Scenario>, net: Arc<RoadNetwork>, dt: f64) -> Self {
        let bodies = sc
            .entities
            .iter()
            .enumerate()
            .map(|(i, e)| {
                let (_, _, object_type) = class_of(&e.kind);
                let perf = match &e.kind {
                    EntityKind::Vehicle { performance, .. } => *performance,
                    EntityKind::Pedestrian { .. } => [10.0, 3.0, 5.0],
                    EntityKind::MiscObject { .. } => [0.0, 0.0, 0.0],
                };
                let (x, y) = parked(i);
                Body {
                    id: e.name.clone(),
                    x,
                    y,
                    yaw: 0.0,
                    v: 0.0,
                    a: 0.0,
                    lane: None,
                    centre_offset: (e.bbox[0], e.bbox[1]),
                    length: e.bbox[3].max(0.1),
                    width: e.bbox[4].max(0.1),
                    perf,
                    traveled: 0.0,
                    object_type: object_type.into(),
                    active: false,
                    on_lanes: matches!(e.kind, EntityKind::Vehicle { .. }),
                    still_since: None,
                    off_since: None,
                    end_since: None,
                    end_of_road: false,
                    long: None,
                    lat: None,
                    path: None,
                    route: Vec::new(),
                    acquire: None,
                    trig: Default::default(),
                }
            })
            .collect::<Vec<_>>();
        let n = bodies.len();
        let mut sb = Storyboard {
            driven: vec![true; n],
            bodies,
            elems: Vec::new(),
            actions: Vec::new(),
            triggers: Vec::new(),
            stop: None,
            took: Vec::new(),
            took_now: Vec::new(),
            unsettled: true,
            params: sc.parameters.iter().cloned().collect(),
            vars: sc.variables.iter().cloned().collect(),
            signals: BTreeMap::new(),
            pending: Vec::new(),
            phases: sc.signal_controllers.iter().map(|c| (0, c.delay)).collect(),
            fired: Vec::new(),
            notes: Vec::new(),
            t: 0.0,
            dt,
            ended: None,
            started: false,
            snapshot: Vec::new(),
            before: Vec::new(),
            traj: XyTrajectory::default(),
            net,
            scenario: sc.clone(),
        };
        sb.flatten(&sc);
        sb
    }

    /// The storyboard's tree as a flat list of elements.
    fn flatten(&mut self, sc: &Scenario) {
        let add = |elems: &mut Vec<Elem>, kind, name: &str, parent: Option<usize>, at: &str| {
            let ix = elems.len();
            elems.push(Elem {
                kind,
                name: name.to_string(),
                parent,
                children: Vec::new(),
                state: State::Standby,
                count: 0,
                max: 1,
                start: None,
                stop: None,
                priority: Priority::Parallel,
                action: None,
                at: at.to_string(),
            });
            if let Some(p) = parent {
                elems[p].children.push(ix);
            }
            ix
        };
        for s in &sc.stories {
            let si = add(&mut self.elems, ElementType::Story, &s.name, None, &s.at);
            for a in &s.acts {
                let ai = add(&mut self.elems, ElementType::Act, &a.name, Some(si), &a.at);
                self.elems[ai].start = a.start.clone().map(|t| push(&mut self.triggers, t));
                self.elems[ai].stop = a.stop.clone().map(|t| push(&mut self.triggers, t));
                for g in &a.groups {
                    let gi = add(
                        &mut self.elems,
                        ElementType::ManeuverGroup,
                        &g.name,
                        Some(ai),
                        &g.at,
                    );
                    self.elems[gi].max = g.max_count;
                    for m in &g.maneuvers {
                        let mi = add(
                            &mut self.elems,
                            ElementType::Maneuver,
                            &m.name,
                            Some(gi),
                            &m.at,
                        );
                        for e in &m.events {
                            let ei = add(
                                &mut self.elems,
                                ElementType::Event,
                                &e.name,
                                Some(mi),
                                &e.at,
                            );
                            self.elems[ei].max = e.max_count;
                            self.elems[ei].priority = e.priority;
                            self.elems[ei].start =
                                e.start.clone().map(|t| push(&mut self.triggers, t));
                            for x in &e.actions {
                                let xi = add(
                                    &mut self.elems,
                                    ElementType::Action,
                                    &x.name,
                                    Some(ei),
                                    &x.at,
                                );
                                self.elems[xi].action = Some(self.actions.len());
                                self.actions.push((xi, x.clone()));
                            }
                        }
                    }
                }
            }
        }
        self.stop = sc.stop_trigger.clone().map(|t| push(&mut self.triggers, t));
    }

    /// The bodies an entity name stands for (a selection's members).
    pub(crate) fn members(&self, name: &str) -> Vec<usize> {
        if let Some((_, m)) = self.scenario.selections.iter().find(|(s, _)| s == name) {
            return m
                .iter()
                .filter_map(|n| self.bodies.iter().position(|b| b.id == *n))
                .collect();
        }
        self.bodies
            .iter()
            .position(|b| b.id == name)
            .into_iter()
            .collect()
    }

    /// Runs the Init actions: places, speeds, and the actions that go on
    /// after the start.
    fn init(&mut self) -> Result<(), ScenarioError> {
        let sc = self.scenario.clone();
        // Positions first (a relative position may name an entity placed
        // by another Init action: in document order, as written).
        for a in &sc.init {
            self.apply(a, None)?;
        }
        Ok(())
    }

    fn record(&mut self, ix: usize, tr: Transition) {
        self.took_now.push((ix, tr));
    }

    /// Moves element `ix` to `state`, recording the transition.
    fn set(&mut self, ix: usize, state: State, tr: Transition) {
        self.elems[ix].state = state;
        self.unsettled = true;
        self.record(ix, tr);
    }

    /// Whether trigger `k` fires now (arming it on first use).
    fn fires(&mut self, k: usize) -> bool {
        if !self.triggers[k].armed {
            self.triggers[k].rearm();
        }
        let (t, dt) = (self.t, self.dt);
        let mut any = false;
        for g in 0..self.triggers[k].trigger.groups.len() {
            let mut all = true;
            for c in 0..self.triggers[k].trigger.groups[g].len() {
                let cond = &self.triggers[k].trigger.groups[g][c];
                let (edge, delay) = (cond.edge, cond.delay);
                let l = self.holds(&cond.kind, t);
                let st = &mut self.triggers[k].conds[g][c];
                // Every condition is evaluated each step (their edges need
                // their history), not only until one group holds.
                all &= story::condition_value(st, edge, delay, l, t, dt);
            }
            any |= all;
        }
        any
    }

    fn note_fired(&mut self, trigger: &str, ix: Option<usize>) {
        let (element, at) = match ix {
            Some(i) => (self.elems[i].name.clone(), self.elems[i].at.clone()),
            None => ("storyboard".into(), String::new()),
        };
        self.fired.push(Fired {
            trigger: trigger.into(),
            element,
            t: self.t,
            at,
        });
    }

    /// Starts element `ix` and what starts with it.
    fn start(&mut self, ix: usize) -> Result<(), ScenarioError> {
        self.set(ix, State::Running, Transition::Start);
        match self.elems[ix].kind {
            ElementType::Event => {
                self.elems[ix].count += 1;
                for c in self.elems[ix].children.clone() {
                    self.set(c, State::Running, Transition::Start);
                    let Some(ai) = self.elems[c].action else {
                        continue;
                    };
                    let action = self.actions[ai].1.clone();
                    if self.apply(&action, Some(ai))? {
                        self.set(c, State::Complete, Transition::End);
                    }
                }
            }
            ElementType::ManeuverGroup => {
                self.elems[ix].count += 1;
                for c in self.elems[ix].children.clone() {
                    self.start(c)?;
                }
            }
            _ => {
                for c in self.elems[ix].children.clone() {
                    if let Some(k) = self.elems[c].start {
                        // Waits for its own trigger (standby: no
                        // transition to record).
                        self.elems[c].state = State::Standby;
                        self.triggers[k].armed = false;
                    } else {
                        self.start_event_or(c)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// An event starts under its priority; anything else starts.
    fn start_event_or(&mut self, ix: usize) -> Result<(), ScenarioError> {
        if self.elems[ix].kind != ElementType::Event {
            return self.start(ix);
        }
        let parent = self.elems[ix].parent.expect("an event is in a maneuver");
        let running: Vec<usize> = self.elems[parent]
            .children
            .iter()
            .copied()
            .filter(|&c| c != ix && self.elems[c].state == State::Running)
            .collect();
        match self.elems[ix].priority {
            Priority::Override => {
                for r in running {
                    self.stop_tree(r);
                }
                self.start(ix)
            }
            Priority::Skip if !running.is_empty() => {
                self.elems[ix].count += 1;
                let next = if self.elems[ix].count >= self.elems[ix].max {
                    State::Complete
                } else {
                    State::Standby
                };
                self.set(ix, next, Transition::Skip);
                Ok(())
            }
            _ => self.start(ix),
        }
    }

    /// Stops element `ix` and every descendant that runs or waits.
    fn stop_tree(&mut self, ix: usize) {
        for c in self.elems[ix].children.clone() {
            if self.elems[c].state != State::Complete {
                self.stop_tree(c);
            }
        }
        if let Some(ai) = self.elems[ix].action {
            self.release(ai);
        }
        self.set(ix, State::Complete, Transition::Stop);
    }

    /// Drops the control strategy of action `ai` from its entities.
    fn release(&mut self, ai: usize) {
        for b in &mut self.bodies {
            if b.long.as_ref().is_some_and(|l| long_ix(l) == ai) {
                b.long = None;
            }
            if b.lat.as_ref().is_some_and(|l| l.ix == ai) {
                b.lat = None;
            }
            if b.path.as_ref().is_some_and(|p| p.ix == ai) {
                b.path = None;
            }
            if b.acquire.is_some_and(|(x, _)| x == ai) {
                b.acquire = None;
            }
        }
    }

    /// An action reached its goal (or was overridden: `stopped`).
    pub(crate) fn action_over(&mut self, ai: usize, stopped: bool) {
        // An Init action (no storyboard element) just ends.
        let Some(&(ix, _)) = self.actions.get(ai) else {
            return;
        };
        if self.elems[ix].state != State::Running {
            return;
        }
        // An action on several actors ends when every one is done.
        if !stopped && self.bodies.iter().any(|b| holds_action(b, ai)) {
            return;
        }
        let tr = if stopped {
            Transition::Stop
        } else {
            Transition::End
        };
        self.set(ix, State::Complete, tr);
    }

    /// Ends whatever has all its children complete, bottom up.
    fn settle(&mut self) -> Result<(), ScenarioError> {
        // (Elements put back to standby directly, as `rearm` does, end
        // nothing: no need to look again for them.)
        if !self.unsettled {
            return Ok(());
        }
        let mut changed = true;
        while changed {
            changed = false;
            for ix in 0..self.elems.len() {
                let e = &self.elems[ix];
                if e.state != State::Running || e.kind == ElementType::Action {
                    continue;
                }
                if !e
                    .children
                    .iter()
                    .all(|&c| self.elems[c].state == State::Complete)
                {
                    continue;
                }
                changed = true;
                let (count, max, kind) = (e.count, e.max, e.kind);
                let again =
                    matches!(kind, ElementType::Event | ElementType::ManeuverGroup) && count < max;
                if again {
                    self.set(ix, State::Standby, Transition::End);
                    if kind == ElementType::ManeuverGroup {
                        // Loops at once: its maneuvers and events again.
                        self.rearm(ix);
                        self.start(ix)?;
                    } else if let Some(k) = self.elems[ix].start {
                        self.triggers[k].armed = false;
                    }
                } else {
                    self.set(ix, State::Complete, Transition::End);
                }
            }
        }
        self.unsettled = false;
        Ok(())
    }

    /// Sets a subtree back to standby (a maneuver group's next execution).
    fn rearm(&mut self, ix: usize) {
        for c in self.elems[ix].children.clone() {
            self.elems[c].state = State::Standby;
            if self.elems[c].kind == ElementType::Event {
                self.elems[c].count = 0;
                if let Some(k) = self.elems[c].start {
                    self.triggers[k].armed = false;
                }
            }
            self.rearm(c);
        }
    }

    /// One step of the storyboard at time `t`: triggers, states, actions.
    fn advance(&mut self, t: f64) -> Result<(), ScenarioError> {
        self.t = t;
        self.took = std::mem::take(&mut self.took_now);
        if !self.started {
            self.started = true;
            for ix in 0..self.elems.len() {
                if self.elems[ix].kind == ElementType::Story {
                    self.set(ix, State::Running, Transition::Start);
                    for a in self.elems[ix].children.clone() {
                        if self.elems[a].start.is_none() {
                            self.start(a)?;
                        }
                    }
                }
            }
        }
        if let Some(k) = self.stop
            && self.fires(k)
        {
            self.note_fired("stop", None);
            for ix in 0..self.elems.len() {
                if self.elems[ix].parent.is_none() && self.elems[ix].state != State::Complete {
                    self.stop_tree(ix);
                }
            }
            self.ended = Some(format!("the storyboard's stop trigger fired at {t:.2} s"));
            return Ok(());
        }
        self.acts()?;
        self.events()?;
        self.settle()
    }

    /// Acts: stop triggers of running ones, start triggers of waiting ones.
    fn acts(&mut self) -> Result<(), ScenarioError> {
        for ix in 0..self.elems.len() {
            if self.elems[ix].kind != ElementType::Act {
                continue;
            }
            let parent_runs = self.elems[ix]
                .parent
                .is_some_and(|p| self.elems[p].state == State::Running);
            match self.elems[ix].state {
                State::Running => {
                    if let Some(k) = self.elems[ix].stop
                        && self.fires(k)
                    {
                        self.note_fired("stop", Some(ix));
                        self.stop_tree(ix);
                    }
                }
                State::Standby if parent_runs => {
                    if let Some(k) = self.elems[ix].start
                        && self.fires(k)
                    {
                        self.note_fired("start", Some(ix));
                        self.start(ix)?;
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Waiting events of running maneuvers whose trigger fires start.
    fn events(&mut self) -> Result<(), ScenarioError> {
        for ix in 0..self.elems.len() {
            let e = &self.elems[ix];
            if e.kind != ElementType::Event || e.state != State::Standby {
                continue;
            }
            let Some(m) = e.parent else { continue };
            if self.elems[m].state != State::Running {
                continue;
            }
            let Some(k) = e.start else { continue };
            if self.fires(k) {
                self.note_fired("start", Some(ix));
                self.start_event_or(ix)?;
            }
        }
        Ok(())
    }

    /// Moves every body the storyboard drives by one step.
    fn move_bodies(&mut self, t: f64) {
        // Every body moves against the others as they were at `t`: a
        // snapshot kept for the run, its kinematics refreshed each step
        // (names and actions never change in it).
        let mut others = std::mem::take(&mut self.snapshot);
        if others.len() == self.bodies.len() {
            for (o, b) in others.iter_mut().zip(&self.bodies) {
                o.x = b.x;
                o.y = b.y;
                o.yaw = b.yaw;
                o.v = b.v;
                o.a = b.a;
                o.lane = b.lane;
                o.active = b.active;
                o.traveled = b.traveled;
            }
        } else {
            others = self.bodies.clone();
        }
        let mut done = Vec::new();
        let dt = self.dt;
        for (i, b) in self.bodies.iter_mut().enumerate() {
            if !self.driven[i] || !b.active {
                continue;
            }
            let v0 = b.v;
            b.step(&self.net, t, dt, &others, &mut done);
            b.a = (b.v - v0) / dt;
            if let Some((ai, target)) = b.acquire
                && math::hypot(target.x - b.x, target.y - b.y) <= (b.v * dt).max(1.0)
            {
                b.acquire = None;
                done.push(ai);
            }
        }
        self.snapshot = others;
        for ai in done {
            self.action_over(ai, false);
        }
    }

    /// Refreshes the bodies a SUT drives from the simulator's report, and
    /// every body's durations (standing, off road, at the road's end).
    fn observe(&mut self, see: &See<'_>) {
        let t = see.t();
        for i in 0..self.bodies.len() {
            if !self.driven[i] && !see.first() {
                let o = see.world.get(i);
                let b = &mut self.bodies[i];
                let (s, c) = b.trig_of(o.yaw);
                let (dx, dy) = b.centre_offset;
                let (x, y) = (o.x - dx * c + dy * s, o.y - dx * s - dy * c);
                b.traveled += math::hypot(x - b.x, y - b.y);
                b.x = x;
                b.y = y;
                b.yaw = o.yaw;
                b.a = o.acceleration;
                b.v = o.speed;
                b.lane = place::lane_at(&self.net, x, y);
            }
            let b = &mut self.bodies[i];
            if !b.active {
                continue;
            }
            let still = b.v.abs() < 1e-3;
            b.still_since = if still {
                b.still_since.or(Some(t))
            } else {
                None
            };
            // A body within its lane is on the road; only one beyond it
            // (or off the lanes) is located again.
            let in_lane = b.lane.is_some_and(|(p, off)| {
                // Within a metre of a lane's centre is in any lane.
                off.abs() < 1.0
                    || self.net.roads()[p.road]
                        .lane_span(p.s, p.lane)
                        .is_some_and(|sp| (off.abs() * 2.0) <= (sp.t_outer - sp.t_inner).abs())
            });
            let (cx, cy) = b.centre();
            let off = !in_lane && self.net.locate(litesim_core::Vec2::new(cx, cy)).is_none();
            b.off_since = if off { b.off_since.or(Some(t)) } else { None };
            b.end_since = if b.end_of_road {
                b.end_since.or(Some(t))
            } else {
                None
            };
        }
    }

    /// Traffic signal controllers move to their next phase when due.
    fn cycle_signals(&mut self, act: &mut Act<'_>) -> Result<(), ScenarioError> {
        // Most scenarios have none: no reference taken each step.
        if self.scenario.signal_controllers.is_empty() {
            return Ok(());
        }
        let sc = self.scenario.clone();
        for (k, c) in sc.signal_controllers.iter().enumerate() {
            if c.phases.is_empty() {
                continue;
            }
            let (mut p, mut since) = self.phases[k];
            if self.t + 1e-9 < since {
                continue;
            }
            let mut changed = self.t < since + 0.5 * self.dt;
            while self.t + 1e-9 >= since + c.phases[p].duration && c.phases[p].duration > 0.0 {
                since += c.phases[p].duration;
                p = (p + 1) % c.phases.len();
                changed = true;
            }
            self.phases[k] = (p, since);
            if changed {
                let states = c.phases[p].states.clone();
                for (signal, state) in states {
                    self.set_signal(act, &signal, &state)?;
                }
            }
        }
        Ok(())
    }

    /// Sends every driven body's move over the step.
    fn send(
        &mut self,
        act: &mut Act<'_>,
        before: &[(f64, f64, f64)],
        see: &See<'_>,
    ) -> Result<(), ScenarioError> {
        let (now, step) = (see.now_ms(), see.step_ms);
        for (i, b) in self.bodies.iter().enumerate() {
            if !self.driven[i] {
                continue;
            }
            let (cx, cy) = b.centre();
            let from = before[i];
            let pt = |x: f64, y: f64, yaw: f64| to_sim(Coord6::xy_yaw(x, y, yaw), see.mirror);
            let traj = &mut self.traj;
            traj.set_step(
                (now, step),
                pt(from.0, from.1, from.2),
                pt(cx, cy, b.yaw),
                b.v,
            );
            act.ssp
                .set_xy_trajectory_ref(&b.id, traj)
                .map_err(ssp_err)?;
        }
        Ok(())
    }
}

fn push(triggers: &mut Vec<TriggerRt>, t: litesim_xosc::Trigger) -> usize {
    triggers.push(TriggerRt::new(t));
    triggers.len() - 1
}

fn long_ix(l: &motion::Long) -> usize {
    match l {
        motion::Long::Speed { ix, .. }
        | motion::Long::Distance { ix, .. }
        | motion::Long::Sync { ix, .. } => *ix,
    }
}

/// Whether a body still carries action `ai`.
fn holds_action(b: &Body, ai: usize) -> bool {
    b.long.as_ref().is_some_and(|l| long_ix(l) == ai)
        || b.lat.as_ref().is_some_and(|l| l.ix == ai)
        || b.path.as_ref().is_some_and(|p| p.ix == ai)
        || b.acquire.is_some_and(|(x, _)| x == ai)
}

impl Controller for Storyboard {
    fn command(&mut self, see: &See<'_>, act: &mut Act<'_>) -> Result<Flow, ScenarioError> {
        if self.ended.is_some() {
            return Ok(Flow::End(self.ended.clone().unwrap_or_default()));
        }
        let t = see.t();
        self.observe(see);
        self.t = t;
        self.cycle_signals(act)?;
        self.pending_ssp(act)?;
        self.advance(t)?;
        self.pending_ssp(act)?;
        let mut before = std::mem::take(&mut self.before);
        before.clear();
        before.extend(self.bodies.iter().map(|b| {
            let (x, y) = b.centre();
            (x, y, b.yaw)
        }));
        self.move_bodies(t);
        self.settle()?;
        self.send(act, &before, see)?;
        self.before = before;
        if let Some(why) = &self.ended {
            return Ok(Flow::End(why.clone()));
        }
        // Without a stop trigger the storyboard ends when its stories have.
        if self.stop.is_none()
            && !self.elems.is_empty()
            && self
                .elems
                .iter()
                .filter(|e| e.parent.is_none())
                .all(|e| e.state == State::Complete)
        {
            self.ended = Some(format!("every story ended at {:.2} s", t + self.dt));
        }
        Ok(Flow::Go)
    }

    fn report(&mut self) -> Option<crate::runtime::ControllerReport> {
        Some(crate::runtime::ControllerReport {
            triggers: std::mem::take(&mut self.fired),
            notes: std::mem::take(&mut self.notes),
            ended: self.ended.take(),
        })
    }
}

/// Actions that act through the simulator are queued by `apply` (it has
/// no simulator at hand) and sent here.
impl Storyboard {
    fn pending_ssp(&mut self, act: &mut Act<'_>) -> Result<(), ScenarioError> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let pending = std::mem::take(&mut self.pending);
        for (signal, state) in pending {
            self.set_signal(act, &signal, &state)?;
        }
        Ok(())
    }
}

/// An action kind's one-word name, for notes.
pub(crate) fn kind_name(k: &ActionKind) -> &'static str {
    match k {
        ActionKind::Teleport(_) => "TeleportAction",
        ActionKind::Speed { .. } => "SpeedAction",
        ActionKind::LaneChange { .. } => "LaneChangeAction",
        ActionKind::LaneOffset { .. } => "LaneOffsetAction",
        ActionKind::LongitudinalDistance { .. } => "LongitudinalDistanceAction",
        ActionKind::Synchronize { .. } => "SynchronizeAction",
        ActionKind::FollowTrajectory { .. } => "FollowTrajectoryAction",
        ActionKind::AssignRoute(_) => "AssignRouteAction",
        ActionKind::AcquirePosition(_) => "AcquirePositionAction",
        ActionKind::ActivateController { .. } => "ActivateControllerAction",
        ActionKind::AssignController(_) => "AssignControllerAction",
        ActionKind::TrafficSignalState { .. } => "TrafficSignalStateAction",
        ActionKind::TrafficSignalController { .. } => "TrafficSignalControllerAction",
        ActionKind::AddEntity { .. } => "AddEntityAction",
        ActionKind::DeleteEntity { .. } => "DeleteEntityAction",
        ActionKind::SetValue { .. } => "ParameterAction",
        ActionKind::Note(_) => "note",
    }
}
