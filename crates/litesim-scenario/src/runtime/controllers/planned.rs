//! The planned controller: each actor it drives replays its plan exactly —
//! today's scenario player, and every vehicle under `--npc planned`.
//!
//! Kinematic actors get xy trajectories sent ahead with point times,
//! headings and speeds: when nothing is driven in closed loop, a chunk of
//! up to 60 s at once; beside closed-loop actors, every 200 ms covering the
//! coming 400 ms. Dynamic actors (dynamic mode, vehicles that move) are
//! driven with pedals and steering by [`Pid`]. In closed loop each actor
//! runs on its own clock ([`Warp`]): gap goals are re-solved against where
//! the actors are, lane goals follow their reference's sideways move, and
//! people stop rather than walk into a vehicle.

use super::pid::{Pid, send_dynamic};
use super::{Act, Controller, Flow, See, ssp_err, to_sim};
use crate::error::ScenarioError;
use crate::plan::{ActorPlan, Plan};
use crate::reactive::{Warp, shifted};
use crate::state::BodyState;
use litesim_core::geometry::wrap_angle;
use litesim_core::math;
use litesim_ssp::api::{Coord6, XyTrajectory};
use litesim_ssp::profile::Calibration;

/// The planned points of the trajectory last sent to one actor: the
/// read-back's path error reads the point sent instead of sampling the plan
/// again (the same numbers: the same times, the same function).
#[derive(Clone, Debug, Default)]
pub(crate) struct Sent {
    from_ms: u64,
    offset: f64,
    /// Sent on the plain plan clock (`points` is filled only then).
    plain: bool,
    points: Vec<(f64, f64, f64)>,
}

impl Sent {
    /// The planned (x, y, v) at `ms` if it was sent and the actor's clock
    /// and shift are still the ones it was sent with (`tau(t) = t`).
    pub fn planned(&self, ms: u64, step_ms: u64, w: &Warp) -> Option<(f64, f64, f64)> {
        if !self.plain || w.lag != 0.0 || w.rate != 1.0 || w.offset != self.offset {
            return None;
        }
        let d = ms.checked_sub(self.from_ms)?;
        if d % step_ms != 0 {
            return None;
        }
        self.points.get((d / step_ms) as usize).copied()
    }
}

/// When and how a trajectory is sampled: from `now_ms`, a point every
/// `step_ms` up to `ahead_ms` past it (and one more), of a plan sampled
/// every `dt` s, in the simulator's frame (`mirror`: CARLA's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Clock {
    pub now_ms: u64,
    pub step_ms: u64,
    pub ahead_ms: u64,
    pub dt: f64,
    pub mirror: bool,
}

/// The trajectory actor `a` follows on its clock `w` from `c.now_ms`: its
/// planned points (shifted sideways by the warp's offset), their times and
/// speeds. What was sent on the plain plan clock is kept in `keep` for the
/// read-back's path error.
pub(crate) fn plan_trajectory(a: &ActorPlan, w: &Warp, c: Clock, keep: &mut Sent) -> XyTrajectory {
    let n = c.ahead_ms / c.step_ms + 1;
    let mut points = Vec::with_capacity(n as usize + 1);
    let mut times = Vec::with_capacity(n as usize + 1);
    let mut sp = Vec::with_capacity(n as usize + 1);
    let plain = w.lag == 0.0 && w.rate == 1.0;
    keep.points.clear();
    keep.from_ms = c.now_ms;
    keep.offset = w.offset;
    keep.plain = plain;
    for j in 0..=n {
        let tm = c.now_ms + j * c.step_ms;
        let tau = if plain {
            tm as f64 / 1000.0
        } else {
            w.tau(c.now_ms as f64 / 1000.0) + w.rate * (j * c.step_ms) as f64 / 1000.0
        };
        let p = shifted(a.at(tau, c.dt), w.offset);
        if plain {
            keep.points.push((p.x, p.y, p.v));
        }
        points.push(to_sim(Coord6::xy_yaw(p.x, p.y, p.yaw), c.mirror));
        times.push(tm);
        sp.push(p.v);
    }
    XyTrajectory {
        start_time_ms: c.now_ms,
        end_time_ms: c.now_ms + n * c.step_ms,
        points,
        point_times_ms: times,
        speeds: sp,
    }
}

/// Open loop with many actors: the next chunk's trajectories, made on
/// another core while this chunk is read back, with the clock they were
/// made for and what they send (`sent` for the next chunk).
#[derive(Default)]
pub(crate) struct Prefetch {
    made: Vec<Option<XyTrajectory>>,
    clock: Option<Clock>,
    sent: Vec<Sent>,
}

impl Prefetch {
    /// Makes every actor's trajectory for clock `c` (on this thread: the
    /// caller runs it beside the read-back).
    pub fn make(&mut self, actors: &[ActorPlan], warps: &[Warp], c: Clock) {
        self.made.clear();
        self.made.extend(
            actors
                .iter()
                .zip(warps)
                .zip(self.sent.iter_mut())
                .map(|((a, w), keep)| Some(plan_trajectory(a, w, c, keep))),
        );
        self.clock = Some(c);
    }
}

/// The planned controller's actors and their state.
pub(crate) struct Planned {
    /// Per actor: its clock.
    pub warps: Vec<Warp>,
    /// Per actor: the trajectory last sent on the plain plan clock.
    pub sent: Vec<Sent>,
    /// Per actor: its pedal driver, when it is driven dynamically.
    pids: Vec<Option<Pid>>,
    /// Per actor: driven by someone else (the SUT, a driver).
    other: Vec<bool>,
    /// Every actor is driven by someone else: nothing to send. The warps
    /// it would move are then read by no one (the read-back takes the
    /// SUT's own, which [`Planned::react`] never moves, and a driven
    /// actor's real state), so a step does nothing.
    idle: bool,
    /// The gains of the pedal drivers.
    calibration: Calibration,
    /// Nothing is driven in closed loop: trajectories go out a chunk ahead.
    pub open_loop: bool,
    /// Open loop with many actors: trajectories are made ahead on another
    /// core.
    pub overlap: bool,
    /// People may hold their clocks for vehicles (`--npc driver`).
    yielding: bool,
    /// This chunk's trajectories, made ahead.
    made: Vec<Option<XyTrajectory>>,
    /// The next chunk's, being made ahead.
    pub prefetch: Prefetch,
}

/// Beside closed-loop actors, trajectories go out every this many ms …
const SEND_EVERY_MS: u64 = 200;
/// … covering the coming this many ms.
const HORIZON_MS: u64 = 400;

impl Planned {
    /// The controller for every actor not in `other` (driven by the SUT or
    /// a driver); `pids[i]`: actor i's pedal driver in dynamic mode.
    pub fn new(
        n: usize,
        pids: Vec<Option<Pid>>,
        other: Vec<bool>,
        calibration: Calibration,
        (open_loop, overlap, yielding): (bool, bool, bool),
    ) -> Self {
        Planned {
            warps: vec![Warp::new(); n],
            sent: vec![Sent::default(); n],
            pids,
            idle: !overlap && other.iter().all(|&o| o),
            other,
            calibration,
            open_loop,
            overlap,
            yielding,
            made: Vec::new(),
            prefetch: Prefetch {
                sent: if overlap {
                    vec![Sent::default(); n]
                } else {
                    Vec::new()
                },
                ..Prefetch::default()
            },
        }
    }

    /// The plan changed: trajectories sent from the old plan go out again.
    pub fn replanned(&mut self) {
        for w in &mut self.warps {
            w.sent_lag = f64::NAN;
        }
    }

    /// The clock of this step's trajectories: the chunk ahead (open loop)
    /// or 400 ms.
    pub fn clock(&self, see: &See<'_>) -> Clock {
        Clock {
            now_ms: see.now_ms(),
            step_ms: see.step_ms,
            ahead_ms: if self.open_loop {
                see.n_steps * see.step_ms
            } else {
                HORIZON_MS
            },
            dt: see.plan.dt,
            mirror: see.mirror,
        }
    }

    /// Closed loop: every actor's clock reacts to what the others did.
    fn react(&mut self, see: &See<'_>) {
        let Some(e) = see.ego_i else {
            return;
        };
        let (plan, t, dt) = (see.plan, see.t(), see.dt());
        // The others re-solve their gap goals against where the actors are.
        for (i, a) in plan.actors.iter().enumerate() {
            if i == e {
                continue;
            }
            let goal = plan.goals.iter().zip(see.goal_actors).find_map(|(g, ix)| {
                let (m, r) = (*ix)?;
                (m == i && g.t0 <= t + 1e-9 && t < g.t1 - 1e-9).then_some((g, r))
            });
            let bodies = goal.map(|(g, r)| {
                // The gap the plan had one second ahead (at most at the
                // phase's end, where it is the goal's).
                let ta = (t + 1.0).min(g.t1);
                let pb = |j: usize| {
                    let p = plan.actors[j].at(ta, plan.dt);
                    BodyState {
                        x: p.x,
                        y: p.y,
                        yaw: p.yaw,
                        speed: p.v,
                        length: see.dims[j].0,
                        ..BodyState::default()
                    }
                };
                let planned = crate::reactive::gap(g, &pb(i), &g.reference_at(&pb(r), ta));
                let reference = g.reference_at(&see.world.state(r), t);
                (g, see.world.state(i), reference, planned)
            });
            self.warps[i].advance(
                a,
                plan.dt,
                t,
                dt,
                bodies.as_ref().map(|(g, m, o, pg)| (*g, m, o, *pg)),
            );
        }
        self.follow_sideways(see, e);
    }

    /// Lane goals and `lateral(side_of:)` phases follow their reference's
    /// sideways move off its planned path: sut.car's offset from its
    /// route, another actor's own shift (which may follow sut.car in turn).
    fn follow_sideways(&mut self, see: &See<'_>, e: usize) {
        let (plan, t, dt) = (see.plan, see.t(), see.dt());
        let follows = plan
            .lane_goals
            .iter()
            .map(|g| (&g.actor, &g.reference, g.t0, g.t1))
            .chain(
                plan.side_follows
                    .iter()
                    .map(|f| (&f.actor, &f.reference, f.t0, f.t1)),
            );
        for (actor, reference, t0, t1) in follows {
            if t < t0 - 1e-9 || t >= t1 - 1e-9 {
                continue;
            }
            let idx = |id: &str| plan.actors.iter().position(|a| a.id == id);
            let (Some(m), Some(r)) = (idx(actor), idx(reference)) else {
                continue;
            };
            let target = if r == e {
                see.ego_lateral
            } else {
                Some(self.warps[r].offset)
            };
            if let Some(target) = target
                && m != e
            {
                self.warps[m].shift_towards(target, dt);
            }
        }
    }

    /// Open loop, many actors: every actor's trajectory for the chunk is
    /// made on all cores first (each reads only its own plan), or taken
    /// from what was made while the last chunk was read back.
    fn make_ahead(&mut self, plan: &Plan, clock: Clock) {
        self.made.clear();
        // The loop's head must have foreseen this chunk (the light
        // switches, the run's end) exactly; a miss would only cost time
        // (the trajectories are made again below), but tests catch it.
        let foreseen = self.prefetch.clock.take();
        debug_assert!(
            foreseen.is_none_or(|c| c == clock),
            "chunk at {} ms foreseen wrong",
            clock.now_ms
        );
        if !self.overlap {
            return;
        }
        if foreseen == Some(clock) {
            // Made for this very clock (an open loop's plan and warps do
            // not change).
            std::mem::swap(&mut self.made, &mut self.prefetch.made);
            std::mem::swap(&mut self.sent, &mut self.prefetch.sent);
        } else {
            use rayon::prelude::*;
            plan.actors
                .par_iter()
                .zip(&self.warps)
                .zip(self.sent.par_iter_mut())
                .map(|((a, w), keep)| Some(plan_trajectory(a, w, clock, keep)))
                .collect_into_vec(&mut self.made);
        }
    }

    /// Sends kinematic actor `i`'s trajectory when it is due: every chunk in
    /// open loop, else every 200 ms or when its clock changed.
    fn send_trajectory(
        &mut self,
        see: &See<'_>,
        i: usize,
        clock: Clock,
        act: &mut Act<'_>,
    ) -> Result<(), ScenarioError> {
        let a = &see.plan.actors[i];
        let w = self.warps[i];
        let send_every = (SEND_EVERY_MS / see.step_ms).max(1);
        if !self.open_loop
            && !see.k.is_multiple_of(send_every)
            && w.lag == w.sent_lag
            && w.rate == 1.0
            && w.offset == w.sent_offset
        {
            return Ok(());
        }
        self.warps[i].sent_lag = w.lag;
        self.warps[i].sent_offset = w.offset;
        let traj = match self.made.get_mut(i).and_then(Option::take) {
            Some(t) => t,
            None => plan_trajectory(a, &w, clock, &mut self.sent[i]),
        };
        act.ssp.set_xy_trajectory(&a.id, traj).map_err(ssp_err)
    }

    /// Drives dynamic actor `i` one step: pedals from the speed loop,
    /// steering from the path loop, both against its plan on its clock.
    fn send_pedals(
        &mut self,
        see: &See<'_>,
        i: usize,
        act: &mut Act<'_>,
    ) -> Result<(), ScenarioError> {
        let (plan, dt) = (see.plan, see.dt());
        let a = &plan.actors[i];
        let t_now = see.t();
        let t_next = (see.now_ms() + see.step_ms) as f64 / 1000.0;
        let w = &mut self.warps[i];
        let d = self.pids[i].as_mut().expect("a dynamic actor has a driver");
        if see.first() {
            // First step: the actor starts at the plan's speed; hold it.
            let p = a.at(w.tau(t_next), plan.dt);
            let u = d.pedals(d.feed_forward(p.a), p.a, p.v);
            return send_dynamic(act.ssp, &a.id, u, 0.0, d, &mut act.controls[i]);
        }
        let st = see.world.get(i);
        // A re-timed actor's clock follows the car: its plan time is the
        // one whose point is abreast of it (a reference ahead of or behind
        // the car would turn its heading error into lateral error and
        // diverge).
        if w.lag != 0.0 || w.rate != 1.0 {
            let there = a.at(w.tau(t_now), plan.dt);
            let (sh, ch) = math::sin_cos(there.yaw);
            let along = (st.x - there.x) * ch + (st.y - there.y) * sh;
            w.lag += along / there.v.max(0.5);
        }
        let t_next = w.tau(t_next);
        let here = shifted(a.at(w.tau(t_now), plan.dt), w.offset);
        let mut p = shifted(a.at(t_next, plan.dt), w.offset);
        let v_plan = p.v;
        // The feed-forward is the acceleration planned over the coming
        // step, i.e. the one in force now (the next point's may already be
        // the following segment's: a step early at every change, a·dt of
        // speed error).
        p.a = here.a;
        if w.lag != 0.0 || w.rate != 1.0 {
            // A re-timed actor moves `rate` times its plan's speed.
            p.v *= w.rate;
            p.a = w.accel;
        }
        let g = &self.calibration;
        let u = d.longitudinal(g, p.a, p.v, st.speed, dt);
        let u = d.pedals(u, p.a, p.v);
        // Lateral error: planned point relative to the car, left positive.
        let (sy, cy) = math::sin_cos(st.yaw);
        let (ex, ey) = (here.x - st.x, here.y - st.y);
        let e_lat = -sy * ex + cy * ey;
        let e_yaw = wrap_angle(here.yaw - st.yaw);
        let ahead = a.at(t_next + 0.2, plan.dt);
        // 0.2 s of plan time ahead: the plan's speed sets the arc.
        let ds = (v_plan.max(0.5)) * 0.2;
        let kappa = wrap_angle(ahead.yaw - p.yaw) / ds;
        let delta = d.lateral(&g.steering, kappa, e_lat, e_yaw, dt);
        let steer = (delta / d.lim.max_steer).clamp(-1.0, 1.0);
        send_dynamic(act.ssp, &a.id, u, steer, d, &mut act.controls[i])
    }
}

impl Controller for Planned {
    fn command(&mut self, see: &See<'_>, act: &mut Act<'_>) -> Result<Flow, ScenarioError> {
        if self.idle {
            return Ok(Flow::Go);
        }
        self.react(see);
        let clock = self.clock(see);
        self.make_ahead(see.plan, clock);
        if self.yielding && !see.first() {
            hold_people(see, &self.other, &mut self.warps);
        }
        for i in 0..see.plan.actors.len() {
            if self.other[i] {
                continue;
            }
            if self.pids[i].is_some() {
                self.send_pedals(see, i, act)?;
            } else {
                self.send_trajectory(see, i, clock, act)?;
            }
        }
        Ok(Flow::Go)
    }
}

/// Walks on its plan and may yield: a person, cyclist or animal that moves.
pub(crate) fn yields(a: &ActorPlan) -> bool {
    use litesim_core::ActorClass;
    matches!(
        a.kind,
        ActorClass::Person | ActorClass::Cyclist | ActorClass::Animal
    ) && a.samples.iter().any(|s| s.v > 0.0)
}

/// People, cyclists and animals keep their planned paths but stop rather
/// than walk into a vehicle: one whose position 0.6 s ahead on its plan
/// lies within 0.6 m of a vehicle's box holds its plan clock this step.
fn hold_people(see: &See<'_>, other: &[bool], warps: &mut [Warp]) {
    const AHEAD_S: f64 = 0.6;
    const MARGIN_M: f64 = 0.6;
    let (plan, t, dt) = (see.plan, see.t(), see.dt());
    for (i, a) in plan.actors.iter().enumerate() {
        if !yields(a) || other[i] {
            continue;
        }
        let tau = warps[i].tau(t);
        let (here, next) = (a.at(tau, plan.dt), a.at(tau + AHEAD_S, plan.dt));
        let (dx, dy) = (next.x - here.x, next.y - here.y);
        if dx * dx + dy * dy < 1e-4 {
            continue;
        }
        let blocked = (0..plan.actors.len()).any(|j| {
            if j == i || plan.actors[j].kind != litesim_core::ActorClass::Vehicle {
                return false;
            }
            let b = see.world.get(j);
            let (s, c) = math::sin_cos(b.yaw);
            let (px, py) = (next.x - b.x, next.y - b.y);
            let along = px * c + py * s;
            let across = -px * s + py * c;
            along.abs() <= 0.5 * b.length + MARGIN_M && across.abs() <= 0.5 * b.width + MARGIN_M
        });
        if blocked {
            warps[i].lag -= dt;
        }
    }
}
