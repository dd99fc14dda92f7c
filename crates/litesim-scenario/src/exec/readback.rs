//! Reading steps back: each step's reported states become the checks'
//! inputs (boxes, speeds, planned points, on-road flags), the log's samples,
//! the SUT's object list, coverage samples and the gap and lane goals judged
//! at their phase ends.
//!
//! Everything the read-back changes lives in [`Readback`]; everything it
//! only reads comes in a [`ReadEnv`], rebuilt for each chunk (in closed
//! loop the plan, the lights and the actors' clocks change between chunks).
//! A chunk's read-back depends only on its own states and on the read-backs
//! before it, never on the simulator. (Reading one chunk back on a second
//! core while the next was stepped was tried on this split and dropped:
//! BENCHMARKS.md, twelfth session.)

use super::{ExecConfig, Sent, Tracking, due_time, live_state, sample_items};
use crate::error::ScenarioError;
use crate::intent::{LaneRelation, Order};
use crate::kpi::{BoxState, EgoKpi, Kpis};
use crate::plan::Plan;
use crate::reactive::{Body, GoalResult, LaneResult, Warp, shifted};
use crate::sut::Observation;
use litesim_core::math;
use litesim_log::{ActorSample, ControlSample, LogRecorder};
use litesim_map::RoadNetwork;
use litesim_ssp::api::{KinematicSteps, Kinematics};
use litesim_ssp::traffic::TrafficLights;

/// What reading steps back only reads (fixed for a chunk; in open loop for
/// the whole run).
#[derive(Clone, Copy)]
pub(super) struct ReadEnv<'e, 'c> {
    pub plan: &'e Plan,
    pub net: Option<&'e RoadNetwork>,
    pub cfg: &'e ExecConfig<'c>,
    pub lights: Option<&'e TrafficLights>,
    /// Which light boxes show red.
    pub red: &'e [bool],
    /// Each light box's road index.
    pub box_roads: &'e [Option<usize>],
    /// Per actor: length, width, mass.
    pub dims: &'e [(f64, f64, f64)],
    /// Per actor: driven by pedals and steering (its state is kept).
    pub dynamic: &'e [bool],
    /// Commands each actor got (what its log samples show).
    pub controls: &'e [ControlSample],
    /// The actor a SUT drives.
    pub ego_i: Option<usize>,
    /// sut.car's actor, driven or planned.
    pub ego_index: Option<usize>,
    pub sampling: bool,
    /// The simulator's frame is mirrored (CARLA).
    pub mirror: bool,
    pub step_ms: u64,
    pub goal_actors: &'e [Option<(usize, usize)>],
    pub warps: &'e [Warp],
    /// The trajectories sent for the steps being read.
    pub sent: &'e [Sent],
    /// Per actor: driven by a driver (no plan to track: its planned point
    /// is where it is).
    pub driven: &'e [bool],
}

/// What reading steps back changes: the checks, the log, the last states.
pub(super) struct Readback {
    pub boxes: Vec<BoxState>,
    pub speeds: Vec<f64>,
    pub accels: Vec<f64>,
    pub planned: Vec<(f64, f64, f64)>,
    pub off: Vec<bool>,
    pub kpis: Kpis,
    pub last_pos: Vec<Option<litesim_map::Located>>,
    /// Where each vehicle was last located and how far it may move from
    /// there and surely still be on a road (`on_road_radius`): the off-road
    /// check locates it again only beyond that. Not for the SUT's car (it
    /// sees its road position each step) nor with traffic lights (red-light
    /// crossings need every step's s).
    pub on_road_until: Vec<Option<litesim_map::SurelyOnRoad>>,
    pub rec: Option<LogRecorder>,
    pub tracking: Tracking,
    /// The last state of each dynamic actor (what its driver reads).
    pub states: Vec<Option<Kinematics>>,
    /// Per plan actor: its place in the simulator's list of the last
    /// chunk (found again only when the list changes).
    pub slots: Vec<usize>,
    slot_ids: Vec<litesim_ssp::SmolStr>,
    /// The object list as the SUT sees it, kept between steps (ids once).
    pub obs: Observation,
    pub ego_kpi: Option<EgoKpi>,
    pub last_t: f64,
    pub live: Vec<crate::coverage::LiveActor>,
    pub samples: Vec<Option<crate::coverage::Sample>>,
    pub next_due: f64,
    pub next_goal: usize,
    pub next_lane_goal: usize,
    pub goal_results: Vec<GoalResult>,
    pub lane_results: Vec<LaneResult>,
}

impl Readback {
    /// Nothing read back yet, for the actors `ids`: the log goes to `rec`
    /// (when recorded), sut.car's KPIs to `ego_kpi`, and `cfg`'s coverage
    /// items are sampled when `plan` has them due.
    pub(super) fn new(
        ids: &[String],
        rec: Option<LogRecorder>,
        ego_kpi: Option<EgoKpi>,
        cfg: &ExecConfig<'_>,
        plan: &Plan,
    ) -> Self {
        let n = ids.len();
        let samples = vec![None; cfg.covers.len()];
        Readback {
            boxes: Vec::with_capacity(n),
            speeds: Vec::with_capacity(n),
            accels: Vec::new(),
            planned: Vec::with_capacity(n),
            off: Vec::with_capacity(n),
            kpis: Kpis::new(ids),
            last_pos: vec![None; n],
            on_road_until: vec![None; n],
            rec,
            tracking: Tracking::default(),
            states: vec![None; n],
            slots: Vec::new(),
            slot_ids: Vec::new(),
            obs: Observation::default(),
            ego_kpi,
            last_t: 0.0,
            live: Vec::new(),
            next_due: due_time(cfg, plan, &samples),
            samples,
            next_goal: 0,
            next_lane_goal: 0,
            goal_results: Vec::new(),
            lane_results: Vec::new(),
        }
    }

    /// Reads a chunk of steps back, in step order (`got`'s states are in
    /// the simulator's frame).
    pub(super) fn chunk(
        &mut self,
        env: &ReadEnv<'_, '_>,
        got: &mut KinematicSteps,
    ) -> Result<(), ScenarioError> {
        let ReadEnv {
            plan,
            net,
            cfg,
            lights,
            red,
            box_roads,
            dims,
            dynamic,
            controls,
            ego_i,
            ego_index,
            sampling,
            mirror,
            step_ms,
            goal_actors,
            warps,
            sent,
            driven,
        } = *env;
        let Readback {
            boxes,
            speeds,
            accels,
            planned,
            off,
            kpis,
            last_pos,
            on_road_until,
            rec,
            tracking,
            states,
            slots,
            slot_ids,
            obs,
            ego_kpi,
            last_t,
            live,
            samples,
            next_due,
            next_goal,
            next_lane_goal,
            goal_results,
            lane_results,
        } = self;
        if *slot_ids != got.ids {
            // States usually come back in creation order: look there first
            // (a search per actor would make a chunk quadratic in actors).
            slots.clear();
            for (i, a) in plan.actors.iter().enumerate() {
                let at = match got.ids.get(i) {
                    Some(id) if **id == *a.id => i,
                    _ => got.ids.iter().position(|id| **id == *a.id).ok_or_else(|| {
                        ScenarioError::Simulator(format!("the simulator lost actor '{}'", a.id))
                    })?,
                };
                slots.push(at);
            }
            slot_ids.clone_from(&got.ids);
        }
        if mirror {
            got.states.iter_mut().for_each(Kinematics::mirror_y);
        }
        for (k, info) in got.infos.iter().enumerate() {
            let step = got.step(k);
            let t = info.sim_time_ms as f64 / 1000.0;
            boxes.clear();
            speeds.clear();
            accels.clear();
            planned.clear();
            off.clear();
            for (i, a) in plan.actors.iter().enumerate() {
                let st = &step[slots[i]];
                let w = &warps[i];
                let p = match sent[i].planned(info.sim_time_ms, step_ms, w) {
                    _ if driven[i] => (st.pose.position.x, st.pose.position.y, st.speed),
                    Some(p) => p,
                    None => {
                        let p = shifted(a.at(w.tau(t), plan.dt), w.offset);
                        (p.x, p.y, p.v)
                    }
                };
                boxes.push(BoxState {
                    x: st.pose.position.x,
                    y: st.pose.position.y,
                    yaw: st.pose.yaw,
                    length: dims[i].0,
                    width: dims[i].1,
                    vx: st.velocity.x,
                    vy: st.velocity.y,
                });
                speeds.push(st.speed);
                if sampling {
                    let (sy, cy) = math::sin_cos(st.pose.yaw);
                    accels.push(st.acceleration.x * cy + st.acceleration.y * sy);
                }
                planned.push(p);
                let vehicle = a.kind == crate::elab::ActorKind::Vehicle;
                let here = st.pose.position.xy();
                let surely_on = on_road_until[i].is_some_and(|z| z.contains(here));
                if surely_on {
                    off.push(false);
                } else {
                    let pos = if vehicle {
                        net.and_then(|n| n.locate_near(here, last_pos[i]))
                    } else {
                        None
                    };
                    off.push(vehicle && net.is_some() && pos.is_none());
                    // Red light: the car's s passes a red box's s on a lane it controls.
                    if let (Some(info), Some(p), Some(q)) = (lights, &pos, &last_pos[i]) {
                        for ((b, is_red), road) in info.boxes.iter().zip(red).zip(box_roads) {
                            let lane_ok =
                                b.valid_lanes.is_empty() || b.valid_lanes.contains(&p.lane);
                            let crossed = *road == Some(p.road)
                                && *road == Some(q.road)
                                && ((q.s < b.s && p.s >= b.s) || (q.s > b.s && p.s <= b.s));
                            if *is_red && lane_ok && crossed {
                                kpis.red_light(i, &b.id, t);
                            }
                        }
                    }
                    on_road_until[i] = match (net, &pos) {
                        (Some(n), Some(p)) if lights.is_none() && Some(i) != ego_i => {
                            Some(n.surely_on_road(here, p))
                        }
                        _ => None,
                    };
                    last_pos[i] = pos;
                }
                if let Some(r) = rec.as_mut() {
                    if i == 0 {
                        // The ticks so far are complete: the observer may
                        // take them before the next one starts.
                        if let Some(o) = &cfg.observer
                            && !r.log().tick.is_empty()
                        {
                            (o.0.lock().unwrap_or_else(|e| e.into_inner()))(r.log());
                        }
                        r.begin(info.step_index, t);
                    }
                    let mut s = ActorSample::from_kinematics(
                        st.pose,
                        st.velocity,
                        st.acceleration,
                        st.yaw_rate,
                        st.speed,
                        dims[i].2,
                    );
                    s.control = controls[i];
                    let mode = if dynamic[i] || Some(i) == ego_i {
                        "dynamic"
                    } else {
                        "trajectory"
                    };
                    r.sample(&a.id, mode, &s);
                    if a.ego {
                        tracking.push(info.step_index, t, st, a, plan);
                    }
                }
                if dynamic[i] {
                    states[i] = Some(*st);
                }
                if ego_i.is_some() {
                    let o = &mut obs.objects[i];
                    let (sy, cy) = math::sin_cos(st.pose.yaw);
                    o.x = st.pose.position.x;
                    o.y = st.pose.position.y;
                    o.yaw = st.pose.yaw;
                    o.speed = st.speed;
                    o.vx = st.velocity.x;
                    o.vy = st.velocity.y;
                    o.acceleration = st.acceleration.x * cy + st.acceleration.y * sy;
                }
                if Some(i) == ego_index
                    && let Some(ek) = ego_kpi.as_mut()
                {
                    ek.step(t, st.speed, st.pose.position.x, st.pose.position.y);
                }
            }
            kpis.step(t, boxes, speeds, planned, off);
            *last_t = t;
            if sampling && t >= *next_due - 1e-9 {
                live_state(boxes, speeds, accels, live);
                sample_items(cfg, plan, net, live, t, false, samples);
                *next_due = due_time(cfg, plan, samples);
            }
            // Gap goals whose phase ends now: judged on the simulated state.
            while *next_lane_goal < plan.lane_goals.len()
                && t >= plan.lane_goals[*next_lane_goal].t1 - 1e-9
            {
                let g = &plan.lane_goals[*next_lane_goal];
                *next_lane_goal += 1;
                let idx = |id: &str| plan.actors.iter().position(|a| a.id == id);
                let (Some(m), Some(r), Some(net)) = (idx(&g.actor), idx(&g.reference), net) else {
                    continue;
                };
                let on = |j: usize| net.to_road(litesim_core::Vec2::new(boxes[j].x, boxes[j].y));
                let got = on(m).map(|p| p.lane);
                let wanted = on(r).and_then(|p| {
                    let road = net.roads().iter().position(|x| x.id == p.road)?;
                    let here = litesim_map::LanePos {
                        road,
                        lane: p.lane,
                        s: p.s,
                    };
                    match g.relation {
                        LaneRelation::SameAs => Some(p.lane),
                        r => net.lane_beside(here, r.offset()),
                    }
                });
                lane_results.push(LaneResult {
                    actor: g.actor.clone(),
                    reference: g.reference.clone(),
                    relation: g.relation,
                    wanted,
                    got,
                    t,
                    met: wanted.is_some() && wanted == got,
                    strict: g.strict,
                    at: g.at.clone(),
                });
            }
            while *next_goal < plan.goals.len() && t >= plan.goals[*next_goal].t1 - 1e-9 {
                let g = &plan.goals[*next_goal];
                let ix = goal_actors[*next_goal];
                *next_goal += 1;
                if let Some((m, r)) = ix {
                    let bx = |j: usize| Body {
                        x: boxes[j].x,
                        y: boxes[j].y,
                        yaw: boxes[j].yaw,
                        speed: speeds[j],
                        length: boxes[j].length,
                    };
                    let got = crate::reactive::gap(g, &bx(m), &bx(r));
                    goal_results.push(GoalResult {
                        actor: g.actor.clone(),
                        reference: g.reference.clone(),
                        relation: if g.sign > 0.0 {
                            Order::AheadOf
                        } else {
                            Order::Behind
                        },
                        wanted: g.distance,
                        got,
                        t,
                        met: (got - g.distance).abs() <= crate::reactive::GAP_TOLERANCE,
                        strict: g.strict,
                        at: g.at.clone(),
                    });
                }
            }
        }
        Ok(())
    }
}
