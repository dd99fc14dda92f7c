//! The actors of a run that drivers drive, stepped by the [`Traffic`]
//! engine each step beside the actors it does not drive (sut.car, planned
//! actors), which they follow and yield to as [`Obstacle`]s:
//!
//! - the scenario's own vehicles under `--npc driver`: each pursues the
//!   goals its plan gives at the time (the phase's speed, its lane, a gap
//!   to another actor until the phase ends) within its own limits, and
//!   takes the plan's lanes at forks;
//! - ambient traffic around sut.car: vehicles `traffic.N` placed at the
//!   test's seed within the declared radius and kept around sut.car as it
//!   moves — a vehicle that falls out of range or stops at the map's edge is taken
//!   off the road and placed again in a free spot at the far side of the
//!   range, ahead of or behind sut.car (same id: the simulator's actor
//!   list stays fixed during a run; the summary counts these re-entries).

use super::spawn::{Density, fill};
use super::{LaneGraph, Obstacle, StopLine, TRACK_TAU_S, Traffic};
use crate::elab::TrafficDecl;
use crate::error::ScenarioError;
use crate::plan::{
    ActorPlan, GAP_CLOSE_S, Plan, PlanSample, gap_closing_speed, headway_closing_speed,
    leading_speed,
};
use crate::reactive::gap;
use crate::state::BodyState;
use litesim_core::ActorClass;
use litesim_core::Vec2;
use litesim_core::geometry::Pose;
use litesim_core::rng::Rng;
use litesim_map::{LocateMemo, Located, RoadNetwork};
use litesim_ssp::api::{Coord6, XyTrajectory};
use std::sync::Arc;

/// Length and width of an ambient vehicle (m): a mid-size car.
pub const SIZE: (f64, f64) = (4.5, 1.8);
/// How often vehicles out of range are placed again (steps of 20 ms: 0.5 s).
const RECYCLE_EVERY_S: f64 = 0.5;
/// A vehicle farther than this many radii from sut.car is out of range.
const OUT_OF_RANGE: f64 = 1.2;

/// How far ahead on its plan a scenario vehicle looks for the lane it
/// should be in (s): half a lane change, so that its change is centred
/// where the plan's is.
const LANE_LOOKAHEAD_S: f64 = 1.5;

/// The acceleration that brings a driver (`me`) to its gap goal `g` to
/// `reference` (accelerating at `a_ref`) in `left` seconds, at the
/// reference's speed: the least-effort law for a double integrator that
/// must reach a position and a speed at a set time, `−6e/T² − 4ė/T` on the
/// gap's error `e` and its rate `ė`, with `T` at least a second (a goal
/// about to end is not chased with a jolt). It aims at the phase's end,
/// not at the plan's path there: a reference that brakes early moves the
/// aim, and a reference that keeps braking draws the driver only as much as
/// the time left asks.
fn gap_pursuit(
    g: &crate::plan::GapGoal,
    me: &BodyState,
    reference: &BodyState,
    a_ref: f64,
    left: f64,
) -> f64 {
    let e = gap(g, me, reference) - g.distance;
    let e_dot = g.sign * (me.speed - reference.speed);
    let t = left.max(1.0);
    a_ref.clamp(-6.0, 3.0) - g.sign * (6.0 * e / (t * t) + 4.0 * e_dot / t)
}

/// What a driver's pursuit of one gap goal asked.
#[derive(Clone, Debug)]
struct Asked {
    actor: String,
    /// The goal's modifier (`file:line:col`).
    at: String,
    asked: f64,
    limit: f64,
}

/// The driven actors of one run.
#[derive(Debug)]
pub struct Driven {
    /// The map's lanes.
    pub graph: Arc<LaneGraph>,
    /// The engine and its vehicles: the scenario's driven vehicles first,
    /// then ambient traffic (`traffic.K` for slot `npcs.len() + K`).
    pub traffic: Traffic,
    /// The ambient traffic's declaration (`None`: no ambient traffic).
    pub decl: Option<TrafficDecl>,
    /// The scenario's driven vehicles: (plan actor, slot).
    pub npcs: Vec<(usize, u32)>,
    /// Each plan actor's slot, when driven (ambient traffic included).
    pub driven: Vec<Option<u32>>,
    /// Each slot's plan actor.
    actor_of: Vec<usize>,
    /// Notes for the summary (vehicles that keep their plans, and why).
    pub notes: Vec<String>,
    /// Vehicles placed again after leaving the range or the map.
    pub recycled: u64,
    /// Where each traffic-light box's stop lines are: (lane, u).
    box_lines: Vec<Vec<(u32, f64)>>,
    /// Each plan actor's last map location (a hint for the next).
    hints: Vec<Option<Located>>,
    /// Each plan actor's map location as the run's read-back last found
    /// it, with its question (see [`Driven::see_located`]): the same
    /// question asked here is answered from it.
    kept: Vec<LocateMemo>,
    /// Each plan actor's speed at the last step, and when (s): the
    /// references' accelerations for gap goals.
    last_speeds: (f64, Vec<f64>),
    /// Per gap goal: the hardest deceleration its pursuit asked (m/s²,
    /// positive) and the limit the driver brakes within (see
    /// [`Driven::asked`]).
    asked: Vec<Asked>,
    /// The plan's lane at a lane goal's start, per (actor, goal start):
    /// asked every step while the goal lasts, the same answer each time.
    goal_start_lanes: std::cell::RefCell<Vec<(usize, u64, Option<u32>)>>,
    rng: Rng,
    poses: Vec<Pose>,
    /// One step's buffers, kept for the run: the actors the engine does
    /// not drive, where they stand in lanes, which vehicles were placed
    /// again, the trajectory being sent.
    scratch: Scratch,
}

/// [`Driven::step`]'s buffers (emptied and filled again each step).
#[derive(Debug, Default)]
struct Scratch {
    others: Vec<(Vec2, f64, f64, f64)>,
    obstacles: Vec<Obstacle>,
    jumped: Vec<bool>,
    traj: XyTrajectory,
}

impl Driven {
    /// The driven actors of a run of `plan`: its vehicles (with `npc`)
    /// that start on a driving lane and move, and the declared ambient
    /// traffic placed around sut.car's start, avoiding the scenario's
    /// actors. Returns them and one plan entry per ambient vehicle (its
    /// start), to be appended to the plan's actors.
    pub fn place(
        decl: Option<&TrafficDecl>,
        npc: bool,
        graph: Arc<LaneGraph>,
        net: &RoadNetwork,
        plan: &Plan,
        dt: f64,
        seed: u64,
    ) -> Result<(Self, Vec<ActorPlan>), ScenarioError> {
        let mut me = Driven {
            graph: graph.clone(),
            traffic: Traffic::new(dt),
            decl: decl.cloned(),
            npcs: Vec::new(),
            driven: vec![None; plan.actors.len()],
            actor_of: Vec::new(),
            notes: Vec::new(),
            recycled: 0,
            box_lines: Vec::new(),
            hints: vec![None; plan.actors.len()],
            kept: Vec::new(),
            last_speeds: (f64::NAN, Vec::new()),
            asked: Vec::new(),
            goal_start_lanes: Default::default(),
            rng: Rng::new(0),
            poses: Vec::new(),
            scratch: Scratch::default(),
        };
        if npc {
            me.place_npcs(net, plan);
        }
        let actors = match decl {
            Some(decl) => me.place_ambient(decl, net, plan, seed)?,
            None => Vec::new(),
        };
        Ok((me, actors))
    }

    /// Ambient traffic around sut.car's start, clear of the scenario's
    /// actors (and of its driven vehicles); one plan entry per vehicle.
    fn place_ambient(
        &mut self,
        decl: &TrafficDecl,
        net: &RoadNetwork,
        plan: &Plan,
        seed: u64,
    ) -> Result<Vec<ActorPlan>, ScenarioError> {
        let me = self;
        let graph = me.graph.clone();
        let at = &decl.at;
        if graph.is_empty() {
            return Err(ScenarioError::Elaboration(format!(
                "{at}: ambient traffic needs driving lanes, and the map has none"
            )));
        }
        let ego = plan.actors.iter().find(|a| a.ego).ok_or_else(|| {
            ScenarioError::Elaboration(format!(
                "{at}: ambient traffic surrounds sut.car, which takes part in no phase"
            ))
        })?;
        let centre = Vec2::new(ego.samples[0].x, ego.samples[0].y);
        // Its own stream: the scenario's draws stay as they were.
        let mut rng = Rng::new(seed ^ 0x7472_6166_6669_6300);
        let start: Vec<(Vec2, f64, f64, f64)> = plan
            .actors
            .iter()
            .map(|a| {
                let s = a.samples[0];
                (Vec2::new(s.x, s.y), s.yaw, s.v, a.length)
            })
            .collect();
        let mut obstacles = me.obstacles(net, &start);
        // The scenario's driven vehicles stand where they start, too.
        for &(_, k) in &me.npcs {
            let v = &me.traffic.vehicles[k as usize];
            obstacles.push(Obstacle {
                lane: v.lane,
                u: v.u,
                v: v.v,
                a: 0.0,
                length: v.length,
            });
        }
        let d = Density {
            per_km_per_lane: decl.density,
            speed: decl.speed,
            size: SIZE,
        };
        let r2 = decl.radius * decl.radius;
        let slots = fill(
            &mut me.traffic,
            &graph,
            &d,
            &mut rng,
            &obstacles,
            |lane, u| {
                graph.pose(net, lane, u, 0.0).is_some_and(|p| {
                    let d = p.position.xy() - centre;
                    d.dot(d) <= r2
                })
            },
        )
        .map_err(|source| ScenarioError::Traffic {
            at: at.to_string(),
            source,
        })?;
        let mut actors = Vec::with_capacity(slots.len());
        for (n, &k) in slots.iter().enumerate() {
            let v = &mut me.traffic.vehicles[k as usize];
            v.params.time_gap = decl.time_gap;
            v.params.politeness = decl.politeness;
            let p = graph
                .pose(net, v.lane, v.u, 0.0)
                .unwrap_or(Pose::planar(0.0, 0.0, 0.0));
            me.poses.push(p);
            me.driven.push(Some(k));
            me.actor_of.push(plan.actors.len() + n);
            actors.push(ActorPlan {
                id: format!("traffic.{n}"),
                kind: ActorClass::Vehicle,
                ego: false,
                category: "car".into(),
                model: None,
                length: SIZE.0,
                width: SIZE.1,
                samples: vec![PlanSample {
                    t: 0.0,
                    x: p.position.x,
                    y: p.position.y,
                    yaw: p.yaw,
                    v: v.v,
                    a: 0.0,
                }],
                jumps: Vec::new(),
                heading_trig: Default::default(),
            });
        }
        me.hints.resize(plan.actors.len() + actors.len(), None);
        me.rng = rng;
        Ok(actors)
    }

    /// The scenario's vehicles that drivers take over: every vehicle but
    /// sut.car whose plan moves and starts on a driving lane (the others
    /// keep their plans, with a note).
    fn place_npcs(&mut self, net: &RoadNetwork, plan: &Plan) {
        for (i, a) in plan.actors.iter().enumerate() {
            if a.ego || a.kind != ActorClass::Vehicle || a.samples.iter().all(|s| s.v <= 0.0) {
                continue;
            }
            if let Some(why) = plan.exact.get(&a.id) {
                self.notes.push(format!(
                    "{} keeps its plan: {why} asks for exactness over physics",
                    a.id
                ));
                continue;
            }
            let s0 = a.samples[0];
            let start = net
                .locate(Vec2::new(s0.x, s0.y))
                .and_then(|p| self.graph.locate(net, &p));
            let Some((lane, u, lat)) =
                start.filter(|&(l, _, lat)| lat.abs() < 0.5 * self.graph.lanes[l as usize].width)
            else {
                self.notes.push(format!(
                    "{} keeps its plan: it does not start on a driving lane",
                    a.id
                ));
                continue;
            };
            let _ = lat;
            // The lanes its plan passes through, in order (for forks).
            let mut route: Vec<u32> = Vec::new();
            let mut hint = None;
            for s in a.samples.iter().step_by(5) {
                let here = net.locate_near(Vec2::new(s.x, s.y), hint);
                hint = here;
                if let Some((l, _, _)) = here.and_then(|p| self.graph.locate(net, &p))
                    && route.last() != Some(&l)
                {
                    route.push(l);
                }
            }
            let top = a.samples.iter().map(|s| s.v).fold(0.0, f64::max);
            let slot = self.traffic.add(super::Vehicle {
                lane,
                u,
                v: s0.v,
                a: 0.0,
                lat: 0.0,
                from: None,
                length: a.length,
                width: a.width,
                params: crate::runtime::driver::DriverParams::for_category(&a.category, top),
                route: i as u64,
                at_dead_end: false,
                lane_changes: 0,
                active: true,
                goals: super::Goals {
                    speed: Some(s0.v),
                    lane: Some(lane),
                    route,
                    firm: false,
                    change_s: None,
                    time_gap: None,
                    reckless: false,
                },
            });
            self.npcs.push((i, slot));
            self.driven[i] = Some(slot);
            self.actor_of.push(i);
            self.poses.push(Pose::planar(s0.x, s0.y, s0.yaw));
        }
    }

    /// The goals of the scenario's driven vehicles at time `t`: the plan's
    /// speed (or the speed that closes a gap goal by the phase's end, while
    /// the phase lasts) and the lane the plan is in a little ahead.
    fn update_goals(
        &mut self,
        net: &RoadNetwork,
        plan: &Plan,
        states: &[(Vec2, f64, f64, f64)],
        t: f64,
    ) {
        self.goals_at(net, plan, states, t);
        self.last_speeds.0 = t;
        self.last_speeds.1.clear();
        self.last_speeds.1.extend(states.iter().map(|s| s.2));
    }

    /// Actor `j`'s acceleration from its speed now (`v`, at `t`) and at the
    /// last step (0 at the first).
    fn accel_of(&self, j: usize, v: f64, t: f64) -> f64 {
        let (t0, speeds) = &self.last_speeds;
        match speeds.get(j) {
            Some(v0) if t > *t0 + 1e-9 => (v - v0) / (t - t0),
            _ => 0.0,
        }
    }

    /// The goals proper (see [`Driven::update_goals`]).
    fn goals_at(
        &mut self,
        net: &RoadNetwork,
        plan: &Plan,
        states: &[(Vec2, f64, f64, f64)],
        t: f64,
    ) {
        for &(i, k) in &self.npcs {
            let a = &plan.actors[i];
            // The plan's speed one tracking time constant ahead: the
            // driver's first-order speed tracking then keeps the plan's
            // ramps without lagging them.
            let mut speed = a.speed_at(t + TRACK_TAU_S, plan.dt);
            let mut firm = false;
            for g in &plan.goals {
                if g.actor != a.id || t < g.t0 - 1e-9 || t >= g.t1 - 1e-9 {
                    continue;
                }
                let Some(r) = plan.actors.iter().position(|x| x.id == g.reference) else {
                    continue;
                };
                let body = |j: usize| {
                    let (xy, yaw, speed, length) = states[j];
                    BodyState {
                        x: xy.x,
                        y: xy.y,
                        yaw,
                        speed,
                        length,
                        ..BodyState::default()
                    }
                };
                let (me, reference) = (body(i), g.reference_at(&body(r), t));
                // A projected reference does not brake: it keeps its speed.
                let a_ref = if g.projected.is_some() {
                    0.0
                } else {
                    self.accel_of(r, reference.speed, t)
                };
                let a = gap_pursuit(g, &me, &reference, a_ref, g.t1 - t);
                let p = &self.traffic.vehicles[k as usize].params;
                let limit = p.safe_decel.max(p.comfort_decel);
                // Looked up by reference: a goal's record is made once, not
                // a key per step.
                match self
                    .asked
                    .iter_mut()
                    .find(|x| x.actor == g.actor && x.at == g.at)
                {
                    Some(x) => x.asked = x.asked.max(-a),
                    None => self.asked.push(Asked {
                        actor: g.actor.clone(),
                        at: g.at.clone(),
                        asked: (-a).max(0.0),
                        limit,
                    }),
                }
                // The speed that the tracking turns into that acceleration.
                speed = (me.speed + a * TRACK_TAU_S).max(0.0);
                firm = true;
            }
            // A kept gap or headway to the actor ahead: a constant time-gap
            // follower (an ACC's law) on where that actor really is — its
            // speed plus the gap's error closed over the headway — with the
            // headway as the car-following time gap.
            let mut time_gap = None;
            let reckless = plan
                .reckless
                .iter()
                .any(|(who, t0, t1)| *who == a.id && t >= *t0 - 1e-9 && t < *t1 - 1e-9);
            if let Some((v_keep, h)) = self.gap_keeping_speed(plan, states, i, t) {
                speed = v_keep;
                // Leading one behind, its own time gap: the car-following
                // model only bounds it by whoever is ahead.
                time_gap = h.or(Some(self.traffic.vehicles[k as usize].params.time_gap));
                // A kept gap brakes as firmly as a gap goal does.
                firm = true;
            }
            // A change the scenario asks for takes its phase (the plan's
            // convention: the whole phase, within 2–6 s) and is centred
            // where the plan's is: the lane half that time ahead.
            let change_s = plan
                .phases
                .iter()
                .find(|p| p.actor == a.id && p.t0 <= t + 1e-9 && t < p.t1 - 1e-9)
                .map(|p| (p.t1 - p.t0).clamp(2.0, 6.0));
            let ahead = a.at(t + change_s.map_or(LANE_LOOKAHEAD_S, |s| 0.5 * s), plan.dt);
            let hint = self.hints[i];
            let found = net.locate_near(Vec2::new(ahead.x, ahead.y), hint);
            self.hints[i] = found;
            let mut lane = found.and_then(|p| self.graph.locate(net, &p)).map(|x| x.0);
            if let Some(l) = self.relative_lane(net, plan, states, i, t) {
                lane = Some(l);
            }
            let v = &mut self.traffic.vehicles[k as usize];
            v.goals.speed = Some(speed);
            v.goals.firm = firm;
            v.goals.time_gap = time_gap;
            v.goals.reckless = reckless;
            // Only between changes: one under way keeps its pace.
            if v.from.is_none() {
                v.goals.change_s = change_s;
            }
            if let Some(l) = lane {
                v.goals.lane = Some(l);
            }
        }
    }

    /// The speed that keeps actor `i`'s gap or headway of a phase active at
    /// `t` to the actor ahead (`plan.keeps`, kept or changed to a target),
    /// from where both really are: the planner's laws
    /// ([`headway_closing_speed`], [`gap_closing_speed`] over
    /// [`GAP_CLOSE_S`]); and the car-following time gap under it.
    fn gap_keeping_speed(
        &self,
        plan: &Plan,
        states: &[(Vec2, f64, f64, f64)],
        i: usize,
        t: f64,
    ) -> Option<(f64, Option<f64>)> {
        let (k, r) = plan.keeps.iter().find_map(|k| match k.index {
            Some((a, r)) if a == i && t >= k.t0 - 1e-9 && t < k.t1 - 1e-9 => Some((k, r)),
            _ => None,
        })?;

        let ((me, yaw, v, len), (them, their_yaw, v_ahead, len_ahead)) = (states[i], states[r]);
        if k.behind {
            // It leads the reference (behind it), whatever is ahead of it
            // for its car-following.
            let gap = litesim_core::ahead_along(them, their_yaw, me) - (len + len_ahead) / 2.0;
            let want = k.headway.unwrap_or(k.gap);
            let a_behind = self.accel_of(r, v_ahead, t);
            return Some((
                leading_speed((v_ahead, a_behind), gap, want, k.headway.is_some()),
                None,
            ));
        }
        let gap = litesim_core::ahead_along(me, yaw, them) - (len + len_ahead) / 2.0;
        Some(match k.headway {
            // The car-following model's own time gap at half the headway:
            // its equilibrium gap (s₀ + v·T, widened by the free-road term)
            // would otherwise hold the follower back from the headway it
            // keeps; it stays the bound that avoids a collision.
            Some(h) => (headway_closing_speed(v_ahead, gap, h), Some(0.5 * h)),
            // A space gap: likewise, with the time gap that leaves half of
            // it at the speed it has.
            None => (
                gap_closing_speed(v_ahead, gap, k.gap, GAP_CLOSE_S),
                Some(0.5 * k.gap / v.max(1.0)),
            ),
        })
    }

    /// The lane a phase asks of actor `i` relative to another actor's real
    /// lane at time `t`: a lane goal (`lane(same_as | left_of | right_of:
    /// x, at: end)`) or a phase beside it (`lateral(d, side_of: x)`: the
    /// plan's sideways offset from x, applied where x really is).
    fn relative_lane(
        &self,
        net: &RoadNetwork,
        plan: &Plan,
        states: &[(Vec2, f64, f64, f64)],
        i: usize,
        t: f64,
    ) -> Option<u32> {
        let id = &plan.actors[i].id;
        let active = |t0: f64, t1: f64| t >= t0 - 1e-9 && t < t1 - 1e-9;
        let index = |r: &str| plan.actors.iter().position(|x| x.id == r);
        let lane_at = |xy: Vec2, r: usize| {
            net.locate_near_kept(xy, self.hints.get(r).copied().flatten(), self.kept.get(r))
                .0
                .and_then(|p| self.graph.locate(net, &p))
                .map(|x| x.0)
        };
        // Near the plan's point ahead this step (the hint): a projection
        // from there, not a search of the map's grid cell.
        let plan_lane = |at: f64| {
            let p = plan.actors[i].at(at, plan.dt);
            net.locate_near(Vec2::new(p.x, p.y), self.hints[i])
                .and_then(|p| self.graph.locate(net, &p))
                .map(|x| x.0)
        };
        if let Some(g) = plan
            .lane_goals
            .iter()
            .find(|g| &g.actor == id && active(g.t0, g.t1))
        {
            // Not before the plan's own change is due: the reference may
            // still move, and a change once begun is finished.
            let key = (i, g.t0.to_bits());
            let memo = self
                .goal_start_lanes
                .borrow()
                .iter()
                .find(|(a, t0, _)| (*a, *t0) == key)
                .map(|x| x.2);
            let at_start = memo.unwrap_or_else(|| {
                let l = plan_lane(g.t0);
                self.goal_start_lanes.borrow_mut().push((key.0, key.1, l));
                l
            });
            if plan_lane(t + LANE_LOOKAHEAD_S) == at_start {
                return None;
            }
            let r = index(&g.reference)?;
            let l = lane_at(states[r].0, r)?;
            let info = &self.graph.lanes[l as usize];
            return match g.relation {
                crate::intent::LaneRelation::SameAs => Some(l),
                crate::intent::LaneRelation::LeftOf => info.left,
                crate::intent::LaneRelation::RightOf => info.right,
            };
        }
        if let Some(f) = plan
            .side_follows
            .iter()
            .find(|f| &f.actor == id && active(f.t0, f.t1))
        {
            let r = index(&f.reference)?;
            let (pm, pr) = (plan.actors[i].at(t, plan.dt), plan.actors[r].at(t, plan.dt));
            let (s, c) = litesim_core::math::sin_cos(pr.yaw);
            let offset = -(pm.x - pr.x) * s + (pm.y - pr.y) * c;
            let (xy, yaw, _, _) = states[r];
            let (s, c) = litesim_core::math::sin_cos(yaw);
            return lane_at(Vec2::new(xy.x - offset * s, xy.y + offset * c), r);
        }
        None
    }

    /// The plan actor of slot `k`.
    pub fn actor_of(&self, k: usize) -> usize {
        self.actor_of[k]
    }

    /// For `actor`'s gap goal whose modifier stands at `at`: the hardest
    /// deceleration its pursuit asked (m/s², positive) and the limit the
    /// driver brakes within; `None` when it never pursued it.
    pub fn asked(&self, actor: &str, at: &str) -> Option<(f64, f64)> {
        self.asked
            .iter()
            .find(|x| x.actor == actor && x.at == at)
            .map(|x| (x.asked, x.limit))
    }

    /// The stop lines of the simulator's traffic-light boxes (`road` is
    /// each box's road index): one per lane the box controls, where it
    /// stands along the lane.
    pub fn set_lights(
        &mut self,
        net: &RoadNetwork,
        boxes: &[litesim_ssp::traffic::TrafficLightBox],
        roads: &[Option<usize>],
    ) {
        self.box_lines = boxes
            .iter()
            .zip(roads)
            .map(|(b, road)| {
                let Some(road) = *road else {
                    return Vec::new();
                };
                let r = &net.roads()[road];
                let sec = r.section_index(b.s);
                let ids: Vec<i32> = if b.valid_lanes.is_empty() {
                    let s = &r.sections[sec];
                    s.left.iter().chain(&s.right).map(|l| l.id).collect()
                } else {
                    b.valid_lanes.clone()
                };
                ids.into_iter()
                    .filter_map(|id| self.graph.at_road_s(net, road, id, b.s))
                    .collect()
            })
            .collect();
    }

    /// The map locations the run's read-back found last step (plan
    /// order): where this engine asks the same of an actor, it takes the
    /// answer instead of locating it again.
    pub fn see_located(&mut self, kept: &[LocateMemo]) {
        self.kept.clear();
        self.kept.extend_from_slice(kept);
    }

    /// Where the actors the engine does not drive stand, in lanes: each
    /// (position, heading, speed, length); one straddling two lanes counts
    /// in both.
    fn obstacles(&mut self, net: &RoadNetwork, actors: &[(Vec2, f64, f64, f64)]) -> Vec<Obstacle> {
        let mut out = Vec::with_capacity(actors.len());
        self.obstacles_into(net, actors, &mut out);
        out
    }

    /// [`Driven::obstacles`] into `out` (emptied first).
    fn obstacles_into(
        &mut self,
        net: &RoadNetwork,
        actors: &[(Vec2, f64, f64, f64)],
        out: &mut Vec<Obstacle>,
    ) {
        out.clear();
        for (i, &(xy, _yaw, speed, length)) in actors.iter().enumerate() {
            if xy.x.is_nan() {
                // A driven actor: the engine has it already.
                continue;
            }
            let hint = self.hints.get(i).copied().flatten();
            let found = net.locate_near_kept(xy, hint, self.kept.get(i)).0;
            if let Some(h) = self.hints.get_mut(i) {
                *h = found;
            }
            let Some((lane, u, lat)) = found.and_then(|p| self.graph.locate(net, &p)) else {
                continue;
            };
            let o = Obstacle {
                lane,
                u,
                v: speed.max(0.0),
                a: 0.0,
                length,
            };
            out.push(o);
            let info = &self.graph.lanes[lane as usize];
            let beside = if lat > 0.25 * info.width {
                info.left
            } else if lat < -0.25 * info.width {
                info.right
            } else {
                None
            };
            if let Some(b) = beside {
                out.push(Obstacle { lane: b, ..o });
            }
        }
    }

    /// One step: every plan actor as it stands (`states[i]`: position,
    /// heading, speed, length), the lights' red and yellow flags per box,
    /// then every
    /// driven actor's trajectory for the coming step from `now_ms` (in the
    /// map's frame; `send` gets the plan actor's index and the trajectory).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        net: &RoadNetwork,
        plan: &Plan,
        states: &[(Vec2, f64, f64, f64)],
        (red, yellow): (&[bool], &[bool]),
        now_ms: u64,
        step_ms: u64,
        ego: Option<Vec2>,
        mut send: impl FnMut(usize, &mut XyTrajectory) -> Result<(), ScenarioError>,
    ) -> Result<(), ScenarioError> {
        let mut scratch = std::mem::take(&mut self.scratch);
        let stepped = self.step_with(
            net,
            plan,
            states,
            (red, yellow),
            (now_ms, step_ms),
            ego,
            &mut scratch,
            &mut send,
        );
        self.scratch = scratch;
        stepped
    }

    /// [`Driven::step`] with its buffers.
    #[allow(clippy::too_many_arguments)]
    fn step_with(
        &mut self,
        net: &RoadNetwork,
        plan: &Plan,
        states: &[(Vec2, f64, f64, f64)],
        (red, yellow): (&[bool], &[bool]),
        (now_ms, step_ms): (u64, u64),
        ego: Option<Vec2>,
        scratch: &mut Scratch,
        send: &mut impl FnMut(usize, &mut XyTrajectory) -> Result<(), ScenarioError>,
    ) -> Result<(), ScenarioError> {
        let t = now_ms as f64 / 1000.0;
        self.update_goals(net, plan, states, t);
        let others = &mut scratch.others;
        others.clear();
        others.extend(states.iter().zip(&self.driven).map(|(s, d)| {
            if d.is_some() {
                (Vec2::new(f64::NAN, f64::NAN), 0.0, 0.0, 0.0)
            } else {
                *s
            }
        }));
        let obstacles = &mut scratch.obstacles;
        self.obstacles_into(net, others, obstacles);
        self.traffic.stop_lines.clear();
        for ((lines, &is_red), &is_yellow) in self.box_lines.iter().zip(red).zip(yellow) {
            for &(lane, u) in lines {
                self.traffic.stop_lines.push(StopLine {
                    lane,
                    u,
                    red: is_red,
                    yellow: is_yellow,
                });
            }
        }
        if self.traffic.tick() == 0 {
            // Ambient vehicles start able to stop comfortably for what is
            // ahead as the run starts (lights included).
            let ambient: Vec<u32> =
                (self.npcs.len() as u32..self.traffic.vehicles.len() as u32).collect();
            self.traffic.settle(&self.graph, obstacles, &ambient);
        }
        let every = ((RECYCLE_EVERY_S * 1000.0) as u64 / step_ms.max(1)).max(1);
        let jumped = &mut scratch.jumped;
        jumped.clear();
        jumped.resize(self.traffic.vehicles.len(), false);
        if let Some(c) = ego
            && self.decl.is_some()
            && self.traffic.tick().is_multiple_of(every)
        {
            self.recycle(net, c, obstacles, jumped);
            let placed: Vec<u32> = (0..jumped.len() as u32)
                .filter(|&k| jumped[k as usize])
                .collect();
            if !placed.is_empty() {
                self.traffic.settle(&self.graph, obstacles, &placed);
            }
        }
        self.traffic.step(&self.graph, obstacles);
        let traj = &mut scratch.traj;
        for (k, v) in self.traffic.vehicles.iter().enumerate() {
            let before = self.poses[k];
            let after = if v.active {
                self.graph.pose(net, v.lane, v.u, v.lat).unwrap_or(before)
            } else {
                before
            };
            self.poses[k] = after;
            let from = if jumped[k] { after } else { before };
            let pt = |p: Pose| Coord6::xy_yaw(p.position.x, p.position.y, p.yaw);
            traj.set_step((now_ms, step_ms), pt(from), pt(after), v.v);
            send(self.actor_of[k], traj)?;
        }
        Ok(())
    }

    /// Vehicles out of range of sut.car (or off the map) go back on the
    /// road at a free spot 0.6 … 1 radius ahead of or behind it.
    fn recycle(
        &mut self,
        net: &RoadNetwork,
        centre: Vec2,
        obstacles: &[Obstacle],
        jumped: &mut [bool],
    ) {
        let Some(decl) = self.decl.clone() else {
            return;
        };
        let r = decl.radius;
        let far2 = (OUT_OF_RANGE * r) * (OUT_OF_RANGE * r);
        let Some(here) = net.locate(centre).and_then(|p| self.graph.locate(net, &p)) else {
            return;
        };
        #[allow(clippy::needless_range_loop)] // k indexes poses, jumped and vehicles alike
        for k in self.npcs.len()..self.traffic.vehicles.len() {
            let out = {
                let v = &self.traffic.vehicles[k];
                let d = self.poses[k].position.xy() - centre;
                // Out of range, or stopped where its lane leaves the map.
                let at_edge = v.at_dead_end && self.graph.lanes[v.lane as usize].exit;
                !v.active || at_edge || d.dot(d) > far2
            };
            if !out {
                continue;
            }
            // A few tries at a random spot; none free: it waits a round.
            for _ in 0..4 {
                let ahead = self.rng.unit() < 0.5;
                let d = r * (0.6 + 0.4 * self.rng.unit());
                let Some((lane, u)) = self.walk(here.0, here.1, if ahead { d } else { -d }) else {
                    continue;
                };
                let lane = self.side_lane(lane);
                if !self.graph.lanes[lane as usize].junction && self.free(lane, u, obstacles) {
                    let v0 = decl.speed.0 + self.rng.unit() * (decl.speed.1 - decl.speed.0);
                    let v = &mut self.traffic.vehicles[k];
                    v.lane = lane;
                    v.u = u;
                    v.v = v0;
                    v.a = 0.0;
                    v.lat = 0.0;
                    v.from = None;
                    v.active = true;
                    v.at_dead_end = false;
                    v.params.desired_speed = v0;
                    self.poses[k] = self.graph.pose(net, lane, u, 0.0).unwrap_or(self.poses[k]);
                    jumped[k] = true;
                    self.recycled += 1;
                    break;
                }
            }
        }
    }

    /// The lane and `u` `d` metres along the lanes from (`lane`, `u`),
    /// forwards (d > 0, first successors) or backwards (first predecessors).
    fn walk(&self, mut lane: u32, mut u: f64, d: f64) -> Option<(u32, f64)> {
        let g = &self.graph;
        u += d;
        for _ in 0..64 {
            let len = g.lanes[lane as usize].length;
            if u > len {
                u -= len;
                lane = *g.lanes[lane as usize].next.first()?;
            } else if u < 0.0 {
                lane = *g.lanes[lane as usize].prev.first()?;
                u += g.lanes[lane as usize].length;
            } else {
                return Some((lane, u));
            }
        }
        None
    }

    /// A seeded pick among `lane` and its neighbours to both sides.
    fn side_lane(&mut self, lane: u32) -> u32 {
        let g = &self.graph;
        let mut all = vec![lane];
        let mut l = lane;
        while let Some(n) = g.lanes[l as usize].left {
            all.push(n);
            l = n;
        }
        l = lane;
        while let Some(n) = g.lanes[l as usize].right {
            all.push(n);
            l = n;
        }
        all[(self.rng.next_u64() % all.len() as u64) as usize]
    }

    /// Nobody (vehicle or obstacle) within a safe distance of `u` in `lane`.
    fn free(&self, lane: u32, u: f64, obstacles: &[Obstacle]) -> bool {
        let room = self
            .decl
            .as_ref()
            .map_or(50.0, |d| 2.0 * (SIZE.0 + 2.0) + d.speed.1 * d.time_gap);
        let vehicles = self
            .traffic
            .vehicles
            .iter()
            .filter(|v| v.active)
            .flat_map(|v| {
                [Some(v.lane), v.from]
                    .into_iter()
                    .flatten()
                    .map(move |l| (l, v.u))
            });
        let others = obstacles.iter().map(|o| (o.lane, o.u));
        vehicles
            .chain(others)
            .all(|(l, x)| l != lane || (x - u).abs() > room)
    }
}
