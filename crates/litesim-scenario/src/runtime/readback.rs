//! Reading steps back: each step's reported states become the checks'
//! inputs (actor states, planned points, on-road flags), the log's samples,
//! the world the controllers observe, coverage samples and the gap and lane
//! goals judged at their phase ends.
//!
//! Everything the read-back changes lives in [`Readback`] (and the
//! [`World`]); everything it only reads comes in a [`ReadEnv`], rebuilt for
//! each chunk (in closed loop the plan, the lights and the actors' clocks
//! change between chunks). A chunk's read-back depends only on its own
//! states and on the read-backs before it, never on the simulator. (Reading
//! one chunk back on a second core while the next was stepped was tried on
//! this split and dropped: BENCHMARKS.md, twelfth session.)

use super::ExecConfig;
use super::controllers::planned::Sent;
use super::lights::Lights;
use super::observe::World;
use super::sample::{due_time, sample_items};
use crate::error::ScenarioError;
use crate::intent::{LaneRelation, Order};
use crate::kpi::{EgoKpi, Kpis};
use crate::plan::Plan;
use crate::reactive::{GoalResult, LaneResult, Warp, shifted};
use crate::state::BodyState;
use litesim_core::geometry::wrap_angle;
use litesim_core::math;
use litesim_log::{ActorSample, ControlSample, LogRecorder};
use litesim_map::RoadNetwork;
use litesim_ssp::api::{KinematicSteps, Kinematics, StepInfo};

/// A state's acceleration along its heading (m/s²).
fn along_heading(st: &Kinematics) -> f64 {
    let (sy, cy) = math::sin_cos(st.pose.yaw);
    st.acceleration.x * cy + st.acceleration.y * sy
}

/// What reading steps back only reads (fixed for a chunk; in open loop for
/// the whole run).
#[derive(Clone, Copy)]
pub(crate) struct ReadEnv<'e> {
    pub plan: &'e Plan,
    pub net: Option<&'e RoadNetwork>,
    pub cfg: &'e ExecConfig,
    /// The lights, which show red and each box's road.
    pub lights: &'e Lights,
    /// Per actor: length, width, mass.
    pub dims: &'e [(f64, f64, f64)],
    /// Per actor: driven by pedals and steering.
    pub dynamic: &'e [bool],
    /// Commands each actor got (what its log samples show).
    pub controls: &'e [ControlSample],
    /// The actor a SUT drives.
    pub ego_i: Option<usize>,
    /// sut.car's actor, driven or planned.
    pub ego_index: Option<usize>,
    pub sampling: bool,
    /// Someone observes the world between steps (closed loop): keep it.
    pub observed: bool,
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
    /// The SUT's command of the steps being read, as (acceleration,
    /// road-wheel angle).
    pub sut_command: Option<(f64, f64)>,
}

/// What reading steps back changes: the checks, the log, the last states.
pub(crate) struct Readback {
    /// Every actor's state at the step being read (plan order).
    pub states: Vec<BodyState>,
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
    /// Per plan actor: its place in the simulator's list of the last
    /// chunk (found again only when the list changes).
    pub slots: Vec<usize>,
    slot_ids: Vec<litesim_ssp::SmolStr>,
    pub ego_kpi: Option<EgoKpi>,
    pub last_t: f64,
    pub samples: Vec<Option<crate::coverage::Sample>>,
    pub next_due: f64,
    pub next_goal: usize,
    pub next_lane_goal: usize,
    pub goal_results: Vec<GoalResult>,
    pub lane_results: Vec<LaneResult>,
    /// Per gap goal: its reference's hardest braking in the phase so far
    /// and when it first braked (m/s², s).
    pub goal_braking: Vec<Option<(f64, f64)>>,
}

impl Readback {
    /// Nothing read back yet, for the actors `ids`: the log goes to `rec`
    /// (when recorded), sut.car's KPIs to `ego_kpi`, and `cfg`'s coverage
    /// items are sampled when `plan` has them due.
    pub(crate) fn new(
        ids: &[String],
        rec: Option<LogRecorder>,
        ego_kpi: Option<EgoKpi>,
        cfg: &ExecConfig,
        plan: &Plan,
    ) -> Self {
        let n = ids.len();
        let samples = vec![None; cfg.covers.len()];
        Readback {
            states: Vec::with_capacity(n),
            planned: Vec::with_capacity(n),
            off: Vec::with_capacity(n),
            kpis: Kpis::new(ids),
            last_pos: vec![None; n],
            on_road_until: vec![None; n],
            rec,
            tracking: Tracking::default(),
            slots: Vec::new(),
            slot_ids: Vec::new(),
            ego_kpi,
            last_t: 0.0,
            next_due: due_time(cfg, plan, &samples),
            samples,
            next_goal: 0,
            next_lane_goal: 0,
            goal_results: Vec::new(),
            lane_results: Vec::new(),
            goal_braking: vec![None; plan.goals.len()],
        }
    }

    /// Each plan actor's place in the chunk's list of states. States
    /// usually come back in creation order: look there first (a search per
    /// actor would make a chunk quadratic in actors).
    fn find_slots(&mut self, plan: &Plan, got: &KinematicSteps) -> Result<(), ScenarioError> {
        if self.slot_ids == got.ids {
            return Ok(());
        }
        self.slots.clear();
        for (i, a) in plan.actors.iter().enumerate() {
            let at = match got.ids.get(i) {
                Some(id) if **id == *a.id => i,
                _ => got.ids.iter().position(|id| **id == *a.id).ok_or_else(|| {
                    ScenarioError::Simulator(format!("the simulator lost actor '{}'", a.id))
                })?,
            };
            self.slots.push(at);
        }
        self.slot_ids.clone_from(&got.ids);
        Ok(())
    }

    /// Reads a chunk of steps back, in step order (`got`'s states are in
    /// the simulator's frame).
    pub(crate) fn chunk(
        &mut self,
        env: &ReadEnv<'_>,
        world: &mut World,
        got: &mut KinematicSteps,
    ) -> Result<(), ScenarioError> {
        self.find_slots(env.plan, got)?;
        if env.mirror {
            got.states.iter_mut().for_each(Kinematics::mirror_y);
        }
        for (k, info) in got.infos.iter().enumerate() {
            let step = got.step(k);
            let t = info.sim_time_ms as f64 / 1000.0;
            self.states.clear();
            self.planned.clear();
            self.off.clear();
            for i in 0..env.plan.actors.len() {
                self.read_actor(env, world, i, &step[self.slots[i]], info);
            }
            self.kpis.step(t, &self.states, &self.planned, &self.off);
            self.note_braking(env, step, t);
            if let (Some(e), Some(ek)) = (env.ego_index, self.ego_kpi.as_mut()) {
                let actors = &env.plan.actors;
                ek.follow(t, e, &self.states, |j| &actors[j].id);
            }
            self.last_t = t;
            if env.sampling && t >= self.next_due - 1e-9 {
                let cfg = env.cfg;
                sample_items(
                    cfg,
                    env.plan,
                    env.net,
                    &self.states,
                    t,
                    false,
                    &mut self.samples,
                );
                self.next_due = due_time(cfg, env.plan, &self.samples);
            }
            self.judge_lane_goals(env, t);
            self.judge_gap_goals(env, t);
        }
        Ok(())
    }

    /// Each open gap goal's reference: its hardest braking in the phase
    /// and when it first braked harder than 0.5 m/s² (what an invalid
    /// verdict names as the reason a goal was missed).
    fn note_braking(&mut self, env: &ReadEnv<'_>, step: &[Kinematics], t: f64) {
        // One slot per goal of the plan in force (made with the plan, again
        // when it is replanned).
        for (k, g) in env.plan.goals.iter().enumerate() {
            let Some((_, r)) = env.goal_actors.get(k).copied().flatten() else {
                continue;
            };
            if t < g.t0 - 1e-9 || t > g.t1 + 1e-9 {
                continue;
            }
            let st = &step[self.slots[r]];
            let (ax, ay) = (st.acceleration.x, st.acceleration.y);
            // Braking harder than 0.5 m/s² needs an acceleration that
            // large: most steps are decided without trigonometry.
            if ax * ax + ay * ay <= 0.25 {
                continue;
            }
            let decel = -along_heading(st);
            if decel > 0.5 {
                let b = self.goal_braking[k].get_or_insert((decel, t));
                b.0 = b.0.max(decel);
            }
        }
    }

    /// One actor's state at one step: the checks' inputs, the log, the
    /// world, sut.car's KPIs.
    fn read_actor(
        &mut self,
        env: &ReadEnv<'_>,
        world: &mut World,
        i: usize,
        st: &Kinematics,
        info: &StepInfo,
    ) {
        let t = info.sim_time_ms as f64 / 1000.0;
        let (plan, dims) = (env.plan, env.dims);
        let a = &plan.actors[i];
        let w = &env.warps[i];
        let p = match env.sent[i].planned(info.sim_time_ms, env.step_ms, w) {
            _ if env.driven[i] => (st.pose.position.x, st.pose.position.y, st.speed),
            Some(p) => p,
            None => {
                let p = shifted(a.at(w.tau(t), plan.dt), w.offset);
                (p.x, p.y, p.v)
            }
        };
        // The acceleration along the heading, for coverage and the world.
        let accel = (env.sampling || env.observed).then(|| along_heading(st));
        self.states.push(BodyState {
            x: st.pose.position.x,
            y: st.pose.position.y,
            yaw: st.pose.yaw,
            length: dims[i].0,
            width: dims[i].1,
            vx: st.velocity.x,
            vy: st.velocity.y,
            speed: st.speed,
            acceleration: accel.unwrap_or_default(),
        });
        self.planned.push(p);
        self.check_road(env, world, i, st, t);
        if self.rec.is_some() {
            self.log_sample(env, i, st, info);
        }
        if env.observed {
            let o = world.get_mut(i);
            o.x = st.pose.position.x;
            o.y = st.pose.position.y;
            o.yaw = st.pose.yaw;
            o.speed = st.speed;
            o.vx = st.velocity.x;
            o.vy = st.velocity.y;
            o.acceleration = accel.unwrap_or_default();
        }
        if Some(i) == env.ego_index
            && let Some(ek) = self.ego_kpi.as_mut()
        {
            ek.step(t, st.speed, st.pose.position.x, st.pose.position.y);
        }
    }

    /// Off-road and red-light checks of actor `i` (a vehicle is located
    /// again only when it may have left the part of the road it was surely
    /// on).
    fn check_road(
        &mut self,
        env: &ReadEnv<'_>,
        world: &mut World,
        i: usize,
        st: &Kinematics,
        t: f64,
    ) {
        let net = env.net;
        let vehicle = env.plan.actors[i].kind == litesim_core::ActorClass::Vehicle;
        let here = st.pose.position.xy();
        if self.on_road_until[i].is_some_and(|z| z.contains(here)) {
            self.off.push(false);
            return;
        }
        // Not in the scenario (an OpenSCENARIO entity before its
        // AddEntityAction or after its DeleteEntityAction): not off a road.
        if here.x.abs().max(here.y.abs()) > super::ABSENT_BEYOND_M {
            self.off.push(false);
            return;
        }
        let pos = match net {
            Some(n) if vehicle => {
                let (pos, kept) =
                    n.locate_near_kept(here, self.last_pos[i], world.located().get(i));
                world.keep_located(i, kept);
                pos
            }
            _ => None,
        };
        self.off.push(vehicle && net.is_some() && pos.is_none());
        let lights = env.lights.info.as_ref();
        // Red light: the car's s passes a red box's s on a lane it controls.
        if let (Some(info), Some(p), Some(q)) = (lights, &pos, &self.last_pos[i]) {
            let boxes = info.boxes.iter().zip(&env.lights.red);
            for ((b, is_red), road) in boxes.zip(&env.lights.box_roads) {
                let lane_ok = b.valid_lanes.is_empty() || b.valid_lanes.contains(&p.lane);
                let crossed = *road == Some(p.road)
                    && *road == Some(q.road)
                    && ((q.s < b.s && p.s >= b.s) || (q.s > b.s && p.s <= b.s));
                if *is_red && lane_ok && crossed {
                    self.kpis.red_light(i, &b.id, t);
                }
            }
        }
        self.on_road_until[i] = match (net, &pos) {
            (Some(n), Some(p)) if lights.is_none() && Some(i) != env.ego_i => {
                Some(n.surely_on_road(here, p))
            }
            _ => None,
        };
        self.last_pos[i] = pos;
    }

    /// Actor `i`'s log sample (the first actor's opens the tick, after the
    /// observer has taken the ticks so far).
    fn log_sample(&mut self, env: &ReadEnv<'_>, i: usize, st: &Kinematics, info: &StepInfo) {
        let t = info.sim_time_ms as f64 / 1000.0;
        let a = &env.plan.actors[i];
        let Some(r) = self.rec.as_mut() else {
            return;
        };
        if i == 0 {
            // The ticks so far are complete: the observer may take them
            // before the next one starts.
            if let Some(o) = &env.cfg.observer
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
            env.dims[i].2,
        );
        s.control = env.controls[i];
        let mode = if env.dynamic[i] || Some(i) == env.ego_i {
            "dynamic"
        } else {
            "trajectory"
        };
        r.sample(&a.id, mode, &s);
        if a.ego {
            self.tracking
                .push(info.step_index, t, st, a, env.plan, env.sut_command);
        }
    }

    /// Lane goals whose phase ends now: judged on the simulated state.
    fn judge_lane_goals(&mut self, env: &ReadEnv<'_>, t: f64) {
        let plan = env.plan;
        while self.next_lane_goal < plan.lane_goals.len()
            && t >= plan.lane_goals[self.next_lane_goal].t1 - 1e-9
        {
            let g = &plan.lane_goals[self.next_lane_goal];
            self.next_lane_goal += 1;
            let idx = |id: &str| plan.actors.iter().position(|a| a.id == id);
            let (Some(m), Some(r), Some(net)) = (idx(&g.actor), idx(&g.reference), env.net) else {
                continue;
            };
            let states = &self.states;
            let on = |j: usize| net.to_road(litesim_core::Vec2::new(states[j].x, states[j].y));
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
            self.lane_results.push(LaneResult {
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
    }

    /// Gap goals whose phase ends now: judged on the simulated state.
    fn judge_gap_goals(&mut self, env: &ReadEnv<'_>, t: f64) {
        let plan = env.plan;
        while self.next_goal < plan.goals.len() && t >= plan.goals[self.next_goal].t1 - 1e-9 {
            let g = &plan.goals[self.next_goal];
            let ix = env.goal_actors[self.next_goal];
            self.next_goal += 1;
            let Some((m, r)) = ix else {
                continue;
            };
            let got = crate::reactive::gap(g, &self.states[m], &g.reference_at(&self.states[r], t));
            self.goal_results.push(GoalResult {
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
                reference_braking: self.goal_braking.get(self.next_goal - 1).copied().flatten(),
                needed: None,
            });
        }
    }
}

/// The ego against its plan, for the log's tracking columns (the
/// dashboard's error and progress panels, the animation's look-ahead).
#[derive(Default)]
pub(crate) struct Tracking {
    pub columns: litesim_log::TrackingColumns,
    pub tick: Vec<u64>,
    /// Planned distance at each plan sample (built on first use).
    pub cum: Vec<f64>,
}

impl Tracking {
    /// Planned path ahead shown as the "prediction": 2 s in 0.2 s steps.
    const AHEAD: usize = 10;

    /// One tick of the ego's columns; `sut`: the SUT's command this tick
    /// as (acceleration, road-wheel angle) — what the columns show in
    /// closed loop instead of the plan's.
    fn push(
        &mut self,
        tick: u64,
        t: f64,
        st: &litesim_ssp::api::Kinematics,
        a: &crate::plan::ActorPlan,
        plan: &Plan,
        sut: Option<(f64, f64)>,
    ) {
        let p = a.at(t, plan.dt);
        let (s, c) = math::sin_cos(p.yaw);
        let (dx, dy) = (st.pose.position.x - p.x, st.pose.position.y - p.y);
        let c_ = &mut self.columns;
        c_.tick.push(tick);
        c_.lateral_error.push(-s * dx + c * dy);
        c_.heading_error.push(wrap_angle(st.pose.yaw - p.yaw));
        // Progress: the planned distance covered by time t.
        if self.cum.len() != a.samples.len() {
            let mut acc = 0.0;
            self.cum = std::iter::once(0.0)
                .chain(a.samples.windows(2).map(|w| {
                    acc += math::hypot(w[1].x - w[0].x, w[1].y - w[0].y);
                    acc
                }))
                .collect();
        }
        let k = ((t / plan.dt) as usize).min(a.samples.len().saturating_sub(1));
        let d = self.cum[k] + math::hypot(p.x - a.samples[k].x, p.y - a.samples[k].y);
        c_.progress.push(d);
        c_.cmd_acceleration.push(sut.map_or(p.a, |c| c.0));
        // The planned path ahead, 0.2 s apart (the animation's look-ahead).
        let ahead: Vec<[f64; 4]> = (1..=Self::AHEAD)
            .map(|j| {
                let q = a.at(t + 0.2 * j as f64, plan.dt);
                [q.x, q.y, q.yaw, q.v]
            })
            .collect();
        // The steering the plan's curvature over the next 0.2 s implies
        // (bicycle, wheelbase 0.6 · length as in the seed) — what the applied
        // angle is compared with.
        let [x, y, yaw, _] = ahead[0];
        let ds = math::hypot(x - p.x, y - p.y);
        let kappa = if ds > 1e-6 {
            wrap_angle(yaw - p.yaw) / ds
        } else {
            0.0
        };
        c_.cmd_steering.push(sut.map_or(
            math::atan(litesim_core::seed_wheelbase(a.length) * kappa),
            |c| c.1,
        ));
        c_.predictions.push(ahead);
        self.tick.push(tick);
    }
}
