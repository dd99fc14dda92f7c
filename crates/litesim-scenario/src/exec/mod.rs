//! Execution: drive a plan through any [`Ssp`] step by step.
//!
//! Kinematic mode sends each actor xy-trajectory moves ahead with point
//! times, headings and speeds: when no actor is driven in closed loop, a
//! chunk of up to 60 s at once, stepped with one `step_many` call; beside
//! dynamic actors, every 200 ms covering the coming 400 ms. Dynamic mode drives vehicles with pedals and steering: a PID on
//! the speed error (with the planned acceleration as feed-forward) for
//! throttle and brake, and a curvature feed-forward plus PD on lateral and
//! heading error for steering; the gains are the profile's calibration.
//! People and objects stay kinematic. After each step the states are read
//! back (`readback`): checked ([`crate::kpi`]) and, when asked, logged.

mod readback;

use crate::error::ScenarioError;
use crate::kpi::{BoxState, EgoKpi, Kpis};
use crate::plan::{ActorPlan, Plan};
use crate::reactive::{Body, GoalResult, LaneResult, Warp, shifted};
use crate::sut::{LightState, ObjectState, Observation, RoadPos, Route, Sut, SutCommand, SutInfo};
use litesim_core::geometry::wrap_angle;
use litesim_core::math;
use litesim_log::{ControlSample, LogRecorder, SimulationLog};
use litesim_map::RoadNetwork;
use litesim_ssp::api::*;
use litesim_ssp::profile::{Calibration, PidGains};
use litesim_ssp::traffic::{
    BulbColor, BulbMode, BulbState, LightTarget, TrafficLightBox, TrafficLights,
};
use readback::{ReadEnv, Readback};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};

/// How actors are moved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveMode {
    /// xy trajectories sent ahead.
    #[default]
    Kinematic,
    /// Pedals and steering from the drivers.
    Dynamic,
}

/// What the execution needs besides the plan.
#[derive(Clone, Debug)]
pub struct ExecConfig<'a> {
    /// SSP profile.
    pub profile: String,
    /// SSP model.
    pub model: String,
    /// Seed passed to the simulator.
    pub seed: u64,
    /// Step (ms).
    pub step_ms: u32,
    /// OpenDRIVE text sent to the simulator (traffic lights), if any.
    pub map_text: Option<&'a str>,
    /// Drive mode.
    pub mode: DriveMode,
    /// Driver gains (the profile's calibration when `None`).
    pub calibration: Option<Calibration>,
    /// Record a [`SimulationLog`].
    pub record: bool,
    /// With `record`: told of each completed tick.
    pub observer: Option<crate::TickObserver>,
    /// Test file name (told to the SUT).
    pub test_name: String,
    /// Map path (told to the SUT).
    pub map_path: String,
    /// The map (for in-process SUTs).
    pub map: Option<std::sync::Arc<RoadNetwork>>,
    /// How long the SUT may take per call (s).
    pub sut_timeout: f64,
    /// Pace steps to the wall clock with this policy (`None`: no pacing).
    pub realtime: Option<crate::realtime::Policy>,
    /// `cover`/`record` items to sample.
    pub covers: Vec<crate::coverage::CoverItem>,
    /// The solved scenario parameters (what items may read).
    pub values: BTreeMap<String, crate::elab::Value>,
    /// People, cyclists and animals hold their plans' clocks rather than
    /// walk into a vehicle that stands in their way (`--npc driver`).
    pub people_yield: bool,
}

/// What an execution produced.
#[derive(Clone, Debug)]
pub struct Executed {
    /// KPIs.
    pub kpis: Kpis,
    /// Steps run.
    pub steps: u64,
    /// The log, when recorded.
    pub log: Option<SimulationLog>,
    /// Profile and model the simulator used.
    pub profile: String,
    /// Model.
    pub model: String,
    /// The ego's KPIs (closed loop and planned alike).
    pub ego: Option<EgoKpi>,
    /// Gap goals re-solved during the run, judged at their phase ends.
    pub goals: Vec<GoalResult>,
    /// Lane goals, judged at their phase ends on the simulated state.
    pub lane_goals: Vec<LaneResult>,
    /// The SUT failed: the run stopped here (`sut error at t=…: …`).
    pub sut_error: Option<String>,
    /// `wait`/`until` conditions as they held on the simulated state.
    pub live_events: Vec<LiveEvent>,
    /// The plan in force at the end, when live conditions changed it.
    pub plan: Option<Plan>,
    /// Pacing figures of a real-time run.
    pub realtime: Option<crate::realtime::Stats>,
    /// The `cover`/`record` items' samples, in item order.
    pub coverage: Vec<crate::coverage::Sample>,
    /// A real-time run under the `fail` policy overran: the first overrun.
    pub realtime_failure: Option<String>,
    /// The actors drivers drove (their missed goals are the scenario's,
    /// not the SUT's).
    pub driven: std::collections::BTreeSet<String>,
}

/// Plans the test again with the given condition times fixed.
pub type Replan<'a> = dyn Fn(&BTreeMap<String, f64>) -> Result<Plan, ScenarioError> + 'a;

/// A `wait`/`until` condition held on the simulated state.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LiveEvent {
    /// The condition (`sut.car.speed > 8.333`, `rise(…)`).
    pub condition: String,
    /// When the first plan had it hold (s); `None`: never.
    pub planned: Option<f64>,
    /// When it held on the simulated state (s).
    pub live: f64,
}

/// How long a condition the plan expected by now, but the world does not
/// show yet, is postponed before it is looked at again in a new plan (s).
pub const POSTPONE_S: f64 = 1.0;

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

#[allow(clippy::too_many_arguments)]
/// Evaluates the plan's conditions on the object list at time `t`: one that
/// holds at another time than planned, or that the plan has holding by now
/// while the world does not, gets its time fixed (or postponed by
/// [`POSTPONE_S`]). Returns whether the plan must be made again.
fn live_conditions(
    plan: &Plan,
    obs: &Observation,
    t: f64,
    fixed: &mut BTreeMap<String, f64>,
    settled: &mut BTreeSet<String>,
    last_truth: &mut BTreeMap<String, bool>,
    events: &mut Vec<LiveEvent>,
    first_plan: &BTreeMap<String, Option<f64>>,
) -> bool {
    let sample = |id: &str, field: usize| {
        let i = plan.actors.iter().position(|a| a.id == id)?;
        let o = &obs.objects[i];
        Some([o.speed, o.acceleration, o.x, o.y][field])
    };
    let mut changed = false;
    for c in &plan.conditions {
        if settled.contains(&c.key) || t < c.t0 - 1e-9 {
            continue;
        }
        let Some(now) = c.holds(&plan.ids, &sample) else {
            // Not something the state shows: the plan's time stands.
            settled.insert(c.key.clone());
            continue;
        };
        let before = last_truth.insert(c.key.clone(), now);
        let hit = match c.edge().0 {
            "rise" => before == Some(false) && now,
            "fall" => before == Some(true) && !now,
            _ => now,
        };
        if hit {
            settled.insert(c.key.clone());
            events.push(LiveEvent {
                condition: describe(&c.cond),
                planned: first_plan.get(&c.key).copied().flatten(),
                live: t,
            });
            if c.at.is_none_or(|a| (a - t).abs() > 1e-6) {
                fixed.insert(c.key.clone(), t);
                changed = true;
            }
        } else if c.at.is_some_and(|a| a <= t + 1e-9) {
            fixed.insert(c.key.clone(), t + POSTPONE_S);
            changed = true;
        }
    }
    changed
}

/// A condition as text, for summaries.
fn describe(e: &crate::elab::CExpr) -> String {
    use crate::elab::{CExpr, Value};
    match e {
        CExpr::Const(Value::Num(v)) => format!("{v}"),
        CExpr::Const(v) => format!("{v:?}"),
        CExpr::Var(p) => p.clone(),
        CExpr::Unary(op, x) => format!("{op}({})", describe(x)),
        CExpr::Binary(op, a, b) => format!("{} {op} {}", describe(a), describe(b)),
        other => format!("{other:?}"),
    }
}

fn ssp_err(e: litesim_ssp::SspError) -> ScenarioError {
    ScenarioError::Ssp(e)
}

/// A vehicle's limits from the simulator's catalogue (defaults: the
/// seed's 0.6 · length wheelbase, 35°, 4 and 8 m/s²): what the drivers
/// scale their commands by and what the SUT is told.
#[derive(Clone, Copy, Debug, Default)]
struct Limits {
    wheelbase: f64,
    max_steer: f64,
    max_accel: f64,
    max_decel: f64,
}

impl Limits {
    fn of(e: Option<&CatalogEntry>, length: f64) -> Self {
        Limits {
            wheelbase: e.map_or(0.6 * length, |e| e.effective_wheelbase()),
            max_steer: e.map_or(35f64, |e| e.max_steer_angle_deg).to_radians(),
            max_accel: e.map_or(4.0, |e| e.max_accel),
            max_decel: e.map_or(8.0, |e| e.max_decel),
        }
    }
}

struct Driver {
    /// Integral of the speed error (m).
    integral: f64,
    /// Last speed error (m/s), for its rate.
    last_err: f64,
    /// Integral of the steering error (m·s).
    steer_integral: f64,
    /// Last steering error (m), for its rate.
    last_steer_err: f64,
    lim: Limits,
    mirror: bool,
    /// The profile's command resolution (a fraction of full travel).
    resolution: f64,
}

/// Lever (m) that turns a heading error into the steering error: the
/// steering loop acts on `e_lat + HEADING_LEVER · e_yaw`, the lateral offset
/// of a point this far ahead of the car (docs/drivers.md).
pub const HEADING_LEVER_M: f64 = 1.0;

impl Driver {
    /// The pedal command (in units of the maximum acceleration; negative =
    /// brake) that gives the planned acceleration `a` by itself.
    fn feed_forward(&self, a: f64) -> f64 {
        a / self.lim.max_accel
    }

    /// One step of the speed loop (docs/drivers.md): feed-forward plus PID
    /// on the speed error, with the throttle gains while the car is too
    /// slow and the brake gains while it is too fast. Returns `u` in units
    /// of the maximum acceleration (negative = brake).
    fn longitudinal(&mut self, g: &Calibration, a_ref: f64, v_ref: f64, v: f64, dt: f64) -> f64 {
        let err = v_ref - v;
        self.integral = (self.integral + err * dt).clamp(-5.0, 5.0);
        let derr = (err - self.last_err) / dt;
        self.last_err = err;
        let k = if err >= 0.0 { &g.throttle } else { &g.brake };
        self.feed_forward(a_ref) + k.kp * err + k.ki * self.integral + k.kd * derr
    }

    /// Throttle and brake fractions for `u` (units of the maximum
    /// acceleration, negative = brake), clamped and rounded to the
    /// profile's resolution. In the seed's model a car on no pedal coasts
    /// at 2 m/s²: while the plan holds or gains speed, a command that
    /// rounds to no pedal at all becomes the smallest throttle instead (a
    /// readable 0.0001, where an exact hold would need a denormal).
    fn pedals(&self, u: f64, a_ref: f64, v_ref: f64) -> (f64, f64) {
        let r = self.resolution;
        let (throttle, brake) = if u >= 0.0 {
            (quantise(u.clamp(0.0, 1.0), r), 0.0)
        } else {
            let b = -u * self.lim.max_accel / self.lim.max_decel;
            (0.0, quantise(b.clamp(0.0, 1.0), r))
        };
        if throttle == 0.0 && brake == 0.0 && v_ref > 0.01 && a_ref >= 0.0 {
            (r, 0.0)
        } else {
            (throttle, brake)
        }
    }

    /// One step of the steering loop: the reference curvature's wheel
    /// angle plus PID on `e = e_lat + HEADING_LEVER_M · e_yaw`. Returns the
    /// wheel angle (rad).
    fn lateral(&mut self, g: &PidGains, kappa: f64, e_lat: f64, e_yaw: f64, dt: f64) -> f64 {
        let e = e_lat + HEADING_LEVER_M * e_yaw;
        self.steer_integral = (self.steer_integral + e * dt).clamp(-2.0, 2.0);
        let de = (e - self.last_steer_err) / dt;
        self.last_steer_err = e;
        math::atan(self.lim.wheelbase * kappa) + g.kp * e + g.ki * self.steer_integral + g.kd * de
    }
}

/// The planned points of the trajectory last sent to one actor (see
/// `sent` in [`execute`]).
#[derive(Clone, Debug, Default)]
struct Sent {
    from_ms: u64,
    offset: f64,
    /// Sent on the plain plan clock (`points` is filled only then).
    plain: bool,
    points: Vec<(f64, f64, f64)>,
}

impl Sent {
    /// The planned (x, y, v) at `ms` if it was sent and the actor's clock
    /// and shift are still the ones it was sent with (`tau(t) = t`).
    fn planned(&self, ms: u64, step_ms: u64, w: &Warp) -> Option<(f64, f64, f64)> {
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
#[derive(Clone, Copy, PartialEq)]
struct Clock {
    now_ms: u64,
    step_ms: u64,
    ahead_ms: u64,
    dt: f64,
    mirror: bool,
}

/// The trajectory actor `a` follows on its clock `w` from `c.now_ms`: its
/// planned points (shifted sideways by the warp's offset), their times and
/// speeds. What was sent on the plain plan clock is kept in `keep` for the
/// read-back's path error.
fn plan_trajectory(a: &ActorPlan, w: &Warp, c: Clock, keep: &mut Sent) -> XyTrajectory {
    let Clock {
        now_ms,
        step_ms,
        ahead_ms,
        dt,
        mirror,
    } = c;
    let n = ahead_ms / step_ms + 1;
    let mut points = Vec::with_capacity(n as usize + 1);
    let mut times = Vec::with_capacity(n as usize + 1);
    let mut sp = Vec::with_capacity(n as usize + 1);
    let plain = w.lag == 0.0 && w.rate == 1.0;
    keep.points.clear();
    keep.from_ms = now_ms;
    keep.offset = w.offset;
    keep.plain = plain;
    for j in 0..=n {
        let tm = now_ms + j * step_ms;
        let tau = if plain {
            tm as f64 / 1000.0
        } else {
            w.tau(now_ms as f64 / 1000.0) + w.rate * (j * step_ms) as f64 / 1000.0
        };
        let p = shifted(a.at(tau, dt), w.offset);
        if plain {
            keep.points.push((p.x, p.y, p.v));
        }
        points.push(to_sim(Coord6::xy_yaw(p.x, p.y, p.yaw), mirror));
        times.push(tm);
        sp.push(p.v);
    }
    XyTrajectory {
        start_time_ms: now_ms,
        end_time_ms: now_ms + n * step_ms,
        points,
        point_times_ms: times,
        speeds: sp,
    }
}

/// Steps of the chunk from step `k`: `most`, or fewer so that it ends
/// where the next light switch (`switch`, its step) happens — at least one.
fn chunk_steps(k: u64, most: u64, switch: Option<u64>) -> u64 {
    match switch {
        Some(at) => most.min(at.saturating_sub(k).max(1)),
        None => most,
    }
}

/// `x` rounded to a multiple of `res` (commands travel at the resolution
/// the profile declares).
fn quantise(x: f64, res: f64) -> f64 {
    if res > 0.0 {
        (x / res).round() * res
    } else {
        x
    }
}

/// Runs `plan` on `ssp`; with a `sut`, `sut.car` is driven by it each step
/// and the other actors react to where it actually is.
pub fn execute(
    ssp: &mut dyn Ssp,
    plan: &Plan,
    net: Option<&RoadNetwork>,
    cfg: &ExecConfig,
    mut sut: Option<&mut (dyn Sut + '_)>,
    replan: Option<&Replan<'_>>,
    mut drivers_of: Option<&mut crate::runtime::traffic::driven::Driven>,
) -> Result<Executed, ScenarioError> {
    // The actors drivers drive (the scenario's vehicles under `--npc
    // driver`, ambient traffic) are moved by the traffic engine, not by
    // their plans.
    let driven: Vec<bool> = match drivers_of.as_ref() {
        Some(d) => d.driven.iter().map(Option::is_some).collect(),
        None => vec![false; plan.actors.len()],
    };
    // The plan in force: replaced when a condition holds live at another
    // time than planned (closed loop only).
    let mut plan: Cow<Plan> = Cow::Borrowed(plan);
    let ego_index = plan.actors.iter().position(|a| a.ego);
    // The ego's index when a SUT drives it.
    let ego_i = match sut {
        Some(_) => Some(ego_index.ok_or_else(|| {
            ScenarioError::Plan(
                "a system under test drives sut.car, but sut.car takes part in no phase".into(),
            )
        })?),
        None => None,
    };
    let init = ssp
        .init(InitRequest {
            client_name: "litesim scenario".into(),
            step_size_ms: cfg.step_ms,
            map: cfg.map_text.map(String::from),
            profile: cfg.profile.clone(),
            model: cfg.model.clone(),
            seed: cfg.seed,
            ..InitRequest::default()
        })
        .map_err(ssp_err)?;
    let caps = init.capabilities;
    let step_ms = u64::from(caps.step_size_ms.max(1));
    let dt = step_ms as f64 / 1000.0;
    // The profile the simulator reports (it may differ from the one asked for).
    let profile = litesim_ssp::profile::Profile::builtin(&caps.profile).ok();
    let calibration = cfg
        .calibration
        .unwrap_or_else(|| profile.as_ref().map(|p| p.calibration).unwrap_or_default());
    // Profiles with a left-handed frame (CARLA) see y and yaw mirrored; the
    // engine works in the map's frame and converts at the boundary, so the
    // simulator's world matches its map (traffic lights, its own roads).
    let mirror = profile.as_ref().is_some_and(|p| p.mirror_y);
    // The model the simulator reports: its brake decides the drivers'.
    let model = litesim_ssp::model::model_by_name(&caps.model).ok();
    let command_resolution = profile
        .as_ref()
        .map_or(litesim_ssp::profile::DEFAULT_COMMAND_RESOLUTION, |p| {
            p.command_resolution
        });
    ssp.start_simulation(0).map_err(ssp_err)?;
    ssp.wait_start_simulation(1000).map_err(ssp_err)?;
    let mut rec = cfg.record.then(|| LogRecorder::new(dt));
    if let Some(r) = rec.as_mut() {
        r.meta("profile", &caps.profile);
        r.meta("model", &caps.model);
        r.meta("mode", format!("{:?}", cfg.mode).to_lowercase());
        r.meta("seed", cfg.seed);
    }
    let mut dims = Vec::new();
    let mut drivers: Vec<Option<Driver>> = Vec::new();
    let mut ego_lim = Limits::default();
    for a in &plan.actors {
        let s0 = a.samples[0];
        let (category, actor_type) = match a.kind {
            crate::elab::ActorKind::Vehicle => (
                ActorCategory::Vehicle,
                if a.ego { "Ego" } else { "Vehicle" },
            ),
            crate::elab::ActorKind::Person => (ActorCategory::Pedestrian, "Pedestrian"),
            crate::elab::ActorKind::Cyclist => (ActorCategory::Cyclist, "Cyclist"),
            crate::elab::ActorKind::Animal => (ActorCategory::Animal, "Animal"),
            crate::elab::ActorKind::Stationary => (ActorCategory::StaticObject, "Object"),
        };
        // A catalogue entry of the asked category, else the default vehicle.
        // A model the test names is honoured or refused, never swapped
        // for another of the category.
        let named = match &a.model {
            Some(m) => Some(caps.catalog.iter().find(|e| &e.model_id == m).ok_or_else(|| {
                ScenarioError::Simulator(format!(
                    "actor '{}': model '{m}' is not in the {} profile's catalogue (it has: {})",
                    a.id,
                    caps.profile,
                    caps.catalog
                        .iter()
                        .map(|e| e.model_id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })?),
            None => None,
        };
        let entry = named.or_else(|| {
            caps.catalog
                .iter()
                .find(|e| e.category == a.category)
                .or_else(|| {
                    caps.catalog.iter().find(|e| match category {
                        ActorCategory::Pedestrian => e.category == "pedestrian",
                        ActorCategory::StaticObject => e.category == "static",
                        _ => false,
                    })
                })
        });
        let closed_ego = ego_i == Some(dims.len());
        let dynamic = !closed_ego
            && !driven[dims.len()]
            && cfg.mode == DriveMode::Dynamic
            && a.kind == crate::elab::ActorKind::Vehicle
            && a.samples.iter().any(|s| s.v > 0.0);
        let (sy, cy) = math::sin_cos(s0.yaw);
        let desc = ssp
            .create_actor(CreateActor {
                actor_id: a.id.clone(),
                spec: ActorSpec {
                    actor_type: actor_type.into(),
                    category,
                    model_id: entry.map(|e| e.model_id.clone()).unwrap_or_default(),
                    length: Some(a.length),
                    width: Some(a.width),
                    ..ActorSpec::default()
                },
                position: to_sim(Coord6::xy_yaw(s0.x, s0.y, s0.yaw), mirror),
                speed: to_sim(
                    Coord6 {
                        x: Some(s0.v * cy),
                        y: Some(s0.v * sy),
                        ..Coord6::default()
                    },
                    mirror,
                ),
                initial_mode: if dynamic || closed_ego {
                    MoveMode::Dynamic
                } else {
                    MoveMode::Kinematic
                },
                ..CreateActor::default()
            })
            .map_err(ssp_err)?;
        let e = caps.catalog.iter().find(|e| e.model_id == desc.model_id);
        if let Some(r) = rec.as_mut() {
            r.actor(
                &a.id,
                actor_type,
                &desc.model_id,
                desc.length,
                desc.width,
                e.map_or(1500.0, |e| e.mass),
            );
        }
        let lim = Limits::of(e, desc.length);
        if closed_ego {
            ego_lim = lim;
        }
        dims.push((desc.length, desc.width, e.map_or(1500.0, |e| e.mass)));
        // The drivers scale brake commands by the deceleration the model
        // really has (the seed's dummy brakes at 30 m/s² whatever the
        // catalogue says).
        let mut lim = lim;
        if let Some(d) = model.as_ref().and_then(|m| m.brake_deceleration(e)) {
            lim.max_decel = d;
        }
        drivers.push(dynamic.then_some(Driver {
            integral: 0.0,
            last_err: 0.0,
            steer_integral: 0.0,
            last_steer_err: 0.0,
            lim,
            mirror,
            resolution: command_resolution,
        }));
    }
    let ids: Vec<String> = plan.actors.iter().map(|a| a.id.clone()).collect();
    let mut rb = Readback::new(
        &ids,
        rec,
        ego_index.map(|e| EgoKpi::new(&plan.actors[e].id, dt)),
        cfg,
        &plan,
    );
    let mut steps = litesim_core::steps_for_horizon(plan.duration, dt);
    let send_every = (200 / step_ms).max(1);
    let horizon_ms = 400;
    let filter = ActorFilter::default();
    let mut controls = vec![ControlSample::default(); ids.len()];
    // Coverage: each item's sample time (phase ends from the plan; the
    // run's end is taken after the loop), the live state it reads.
    let sampling = !cfg.covers.is_empty();
    // Without closed-loop drivers nothing needs the states before the next
    // command: the plan is known, so trajectories go out a chunk (up to
    // 60 s) ahead and the chunk's steps run in one `step_many` call — a
    // handful of round trips per test over gRPC instead of one per step.
    // Replies stay bounded: ≤ 5,000 actor states per call (20,000 made the
    // 100-vehicle test 1.25× slower: a chunk's ~4.6 MB of states pushed
    // the checkers' tables out of the cache; 2,000 re-sends too much
    // overlap — BENCHMARKS.md, eleventh session).
    let yielding = cfg.people_yield && plan.actors.iter().any(yields);
    let open_loop =
        drivers.iter().all(Option::is_none) && ego_i.is_none() && drivers_of.is_none() && !yielding;
    // Paced to the wall clock: one step per call, each released on time.
    let mut pacer = cfg
        .realtime
        .map(|p| crate::realtime::Pacer::new(step_ms as u32, p));
    let mut realtime_failure: Option<String> = None;
    let chunk = if open_loop && pacer.is_none() {
        (60_000 / step_ms).clamp(1, (5_000 / ids.len().max(1)) as u64)
    } else {
        1
    };
    // Traffic lights: the simulator's boxes, and which show red (tracked
    // here from the listing and every switch the plan makes).
    let mut lights = if !plan.lights.is_empty() {
        Some(ssp.list_traffic_lights().map_err(ssp_err)?)
    } else if cfg.map_text.is_some() {
        // The map's signals, for the red-light check; a simulator without a
        // traffic-light API (Simian) has none to list, and nothing switches.
        match ssp.list_traffic_lights() {
            Ok(l) => Some(l),
            Err(e) if e.code == litesim_ssp::ErrorCode::Unimplemented => None,
            Err(e) => return Err(ssp_err(e)),
        }
    } else {
        None
    };
    let mut red: Vec<bool> = lights
        .as_ref()
        .map(|l| l.boxes.iter().map(shows_red).collect())
        .unwrap_or_default();
    // Each light box's road as an index into the map's roads (compared per
    // vehicle and step; a box on a road the map lacks never matches).
    let box_roads: Vec<Option<usize>> = match (lights.as_ref(), net) {
        (Some(l), Some(n)) => l
            .boxes
            .iter()
            .map(|b| n.od.roads.iter().position(|r| r.id == b.road_id))
            .collect(),
        _ => Vec::new(),
    };
    if let (Some(amb), Some(l), Some(n)) = (drivers_of.as_deref_mut(), lights.as_ref(), net) {
        amb.set_lights(n, &l.boxes, &box_roads);
    }
    let mut warps = vec![Warp::new(); ids.len()];
    // Per actor: the planned (x, y, v) of the trajectory last sent on the
    // plain plan clock (no lag, rate 1), from which time, and its offset —
    // the path error then reads the point sent instead of sampling the
    // plan again (the same numbers: the same times, the same function).
    let mut sent: Vec<Sent> = vec![Sent::default(); ids.len()];
    // Each goal's (actor, reference) indices; goals come sorted by end time.
    let mut goal_actors = goal_indices(&plan);
    // Conditions seen on the simulated state: times fixed for the planner,
    // the ones settled, each one's last truth (for rise/fall).
    let mut fixed: BTreeMap<String, f64> = BTreeMap::new();
    let mut settled: BTreeSet<String> = BTreeSet::new();
    let mut last_truth: BTreeMap<String, bool> = BTreeMap::new();
    let mut live_events: Vec<LiveEvent> = Vec::new();
    // What the first plan had for each condition (reported beside the live time).
    let first_plan: BTreeMap<String, Option<f64>> = plan
        .conditions
        .iter()
        .map(|c| (c.key.clone(), c.at))
        .collect();
    // The SUT's view of the lights is rebuilt only after a switch.
    let mut lights_seen = false;
    let mut sut_error: Option<String> = None;
    let mut route = Route::default();
    let mut route_hint = 0;
    if let (Some(e), Some(s)) = (ego_i, sut.as_deref_mut()) {
        let ego = &plan.actors[e];
        let pts: Vec<[f64; 2]> = ego.samples.iter().map(|p| [p.x, p.y]).collect();
        let sp: Vec<f64> = ego.samples.iter().map(|p| p.v).collect();
        route = Route::new(&pts, &sp);
        rb.obs.objects = plan
            .actors
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let p = a.samples[0];
                let (sy, cy) = math::sin_cos(p.yaw);
                ObjectState {
                    id: a.id.clone(),
                    kind: format!("{:?}", a.kind).to_lowercase(),
                    x: p.x,
                    y: p.y,
                    yaw: p.yaw,
                    speed: p.v,
                    vx: p.v * cy,
                    vy: p.v * sy,
                    acceleration: 0.0,
                    length: dims[i].0,
                    width: dims[i].1,
                }
            })
            .collect();
        let info = SutInfo {
            test: cfg.test_name.clone(),
            seed: cfg.seed,
            map_path: cfg.map_path.clone(),
            step_ms: step_ms as u32,
            ego_id: ego.id.clone(),
            length: dims[e].0,
            width: dims[e].1,
            wheelbase: ego_lim.wheelbase,
            max_steer: ego_lim.max_steer,
            max_accel: ego_lim.max_accel,
            max_decel: ego_lim.max_decel,
            route: route.clone(),
            timeout_s: cfg.sut_timeout,
            map: cfg.map.clone(),
        };
        if let Err(err) = s.reset(&info) {
            sut_error = Some(format!("sut error at t=0.00 s (reset): {err}"));
        }
    }
    let dynamic: Vec<bool> = drivers.iter().map(Option::is_some).collect();
    let switch_tick = |t: f64| (t * 1000.0 / step_ms as f64).round() as u64;
    let mut next_switch = 0;
    let mut k = 0;
    // Each chunk's states, the memory kept from chunk to chunk.
    let mut got = litesim_ssp::api::KinematicSteps::default();
    // A chunk's trajectories made ahead of sending (open loop, many actors).
    let mut made: Vec<Option<XyTrajectory>> = Vec::new();
    // Open loop, many actors: the next chunk's trajectories, made on
    // another core while this chunk is read back, with the clock they were
    // made for and what they send (`sent` for the next chunk).
    let overlap = open_loop && plan.actors.len() >= crate::PARALLEL_ACTORS;
    let mut next_made: Vec<Option<XyTrajectory>> = Vec::new();
    let mut next_clock: Option<Clock> = None;
    let mut next_sent: Vec<Sent> = if overlap { sent.clone() } else { Vec::new() };
    while k < steps && sut_error.is_none() {
        if let (Some(_), Some(replan)) = (ego_i, replan)
            && !plan.conditions.is_empty()
        {
            let t = (k * step_ms) as f64 / 1000.0;
            let changed = live_conditions(
                &plan,
                &rb.obs,
                t,
                &mut fixed,
                &mut settled,
                &mut last_truth,
                &mut live_events,
                &first_plan,
            );
            if changed {
                let new = replan(&fixed)?;
                if new.actors.len() != plan.actors.len() {
                    return Err(ScenarioError::Plan(
                        "planning again for a live condition changed the actors".into(),
                    ));
                }
                plan = Cow::Owned(new);
                rb.next_due = due_time(cfg, &plan, &rb.samples);
                steps = litesim_core::steps_for_horizon(plan.duration, dt);
                goal_actors = goal_indices(&plan);
                // Goals ended and switches due by now belong to the past.
                rb.next_goal = plan.goals.iter().filter(|g| g.t1 <= t + 1e-9).count();
                rb.next_lane_goal = plan.lane_goals.iter().filter(|g| g.t1 <= t + 1e-9).count();
                next_switch = plan
                    .lights
                    .iter()
                    .filter(|sw| switch_tick(sw.t) < k)
                    .count();
                rb.tracking.cum.clear();
                // Trajectories sent from the old plan go out again.
                for w in &mut warps {
                    w.sent_lag = f64::NAN;
                }
            }
        }
        while next_switch < plan.lights.len() && switch_tick(plan.lights[next_switch].t) <= k {
            let sw = &plan.lights[next_switch];
            let info = lights.as_mut().ok_or_else(|| {
                ScenarioError::Plan(format!(
                    "traffic light '{}': the map has no traffic lights",
                    sw.light
                ))
            })?;
            switch_light(ssp, info, &mut red, sw)?;
            next_switch += 1;
            lights_seen = false;
        }
        let n_steps = chunk_steps(
            k,
            chunk.min(steps - k),
            plan.lights.get(next_switch).map(|sw| switch_tick(sw.t)),
        );
        let now_ms = k * step_ms;
        let t_next = (now_ms + step_ms) as f64 / 1000.0;
        if let Some(e) = ego_i {
            let t = now_ms as f64 / 1000.0;
            // The others re-solve their gap goals against where the actors are.
            for (i, a) in plan.actors.iter().enumerate() {
                if i == e {
                    continue;
                }
                let goal = plan.goals.iter().zip(&goal_actors).find_map(|(g, ix)| {
                    let (m, r) = (*ix)?;
                    (m == i && g.t0 <= t + 1e-9 && t < g.t1 - 1e-9).then_some((g, r))
                });
                let bodies = goal.map(|(g, r)| {
                    // The gap the plan had one second ahead (at most at the
                    // phase's end, where it is the goal's).
                    let ta = (t + 1.0).min(g.t1);
                    let pb = |j: usize| {
                        let p = plan.actors[j].at(ta, plan.dt);
                        Body {
                            x: p.x,
                            y: p.y,
                            yaw: p.yaw,
                            speed: p.v,
                            length: dims[j].0,
                        }
                    };
                    let planned = crate::reactive::gap(g, &pb(i), &pb(r));
                    (
                        g,
                        body(&rb.obs.objects[i]),
                        body(&rb.obs.objects[r]),
                        planned,
                    )
                });
                warps[i].advance(
                    a,
                    plan.dt,
                    t,
                    dt,
                    bodies.as_ref().map(|(g, m, o, pg)| (*g, m, o, *pg)),
                );
            }
            let s = sut.as_deref_mut().expect("closed loop has a SUT");
            rb.obs.tick = k;
            rb.obs.time = t;
            rb.obs.ego = rb.obs.objects[e].clone();
            let rp = route.project(rb.obs.ego.x, rb.obs.ego.y, route_hint);
            if let Some(p) = rp {
                route_hint = p.segment;
            }
            // Lane goals and `lateral(side_of:)` phases follow their
            // reference's sideways move off its planned path: sut.car's
            // offset from its route, another actor's own shift (which may
            // follow sut.car in turn).
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
                    rp.map(|p| p.lateral)
                } else {
                    Some(warps[r].offset)
                };
                if let Some(target) = target
                    && m != e
                {
                    warps[m].shift_towards(target, dt);
                }
            }
            rb.obs.distance_to_goal = rp.map_or(0.0, |p| route.length() - p.s);
            rb.obs.requested_speed = plan.actors[e].at(t, plan.dt).v;
            rb.obs.road = rb.last_pos[e].as_ref().zip(net).map(|(p, n)| RoadPos {
                road: n.od.roads[p.road].id.clone(),
                lane: p.lane,
                s: p.s,
                offset: p.offset,
            });
            if !lights_seen {
                rb.obs.lights = lights
                    .as_ref()
                    .map(|l| l.boxes.iter().map(light_state).collect())
                    .unwrap_or_default();
                lights_seen = true;
            }
            // The SUT sees every actor but itself.
            let ego_obj = rb.obs.objects.remove(e);
            let answer = s.step(&rb.obs);
            rb.obs.objects.insert(e, ego_obj);
            let cmd = answer.map_err(|err| err.0).and_then(|c| {
                c.validate()
                    .map(|()| c)
                    .map_err(|m| format!("it returned a bad command: {m}"))
            });
            match cmd {
                Ok(c) => send_sut(
                    ssp,
                    &plan.actors[e].id,
                    c,
                    &ego_lim,
                    &caps.model,
                    mirror,
                    &mut controls[e],
                )?,
                Err(m) => {
                    sut_error = Some(format!("sut error at t={t:.2} s: {m}"));
                    break;
                }
            }
        }
        // Open loop, many actors: every actor's trajectory for the chunk is
        // made on all cores first (each reads only its own plan), then
        // sent in actor order as below.
        // Trajectories go out the chunk ahead (open loop) or 400 ms.
        let clock = Clock {
            now_ms,
            step_ms,
            ahead_ms: if open_loop {
                n_steps * step_ms
            } else {
                horizon_ms
            },
            dt: plan.dt,
            mirror,
        };
        made.clear();
        // The loop's head must have foreseen this chunk (the light
        // switches, the run's end) exactly; a miss would only cost time
        // (the trajectories are made again below), but tests catch it.
        let foreseen = next_clock.take();
        debug_assert!(
            foreseen.is_none_or(|c| c == clock),
            "chunk at {now_ms} ms foreseen wrong"
        );
        if overlap && foreseen == Some(clock) {
            // Made while the last chunk was read back, for this very clock
            // (an open loop's plan and warps do not change).
            std::mem::swap(&mut made, &mut next_made);
            std::mem::swap(&mut sent, &mut next_sent);
        } else if overlap {
            use rayon::prelude::*;
            plan.actors
                .par_iter()
                .zip(&warps)
                .zip(sent.par_iter_mut())
                .map(|((a, w), keep)| Some(plan_trajectory(a, w, clock, keep)))
                .collect_into_vec(&mut made);
        }
        if let (Some(amb), Some(n)) = (drivers_of.as_deref_mut(), net) {
            let now = DrivenStep {
                net: n,
                plan: &plan,
                boxes: &rb.boxes,
                speeds: &rb.speeds,
                dims: &dims,
                lights: lights.as_ref(),
                red: &red,
                now_ms,
                step_ms,
                ego_index,
                mirror,
            };
            step_driven(amb, &now, ssp)?;
        }
        if yielding && !rb.boxes.is_empty() {
            hold_people(
                &plan,
                &rb.boxes,
                &driven,
                now_ms as f64 / 1000.0,
                dt,
                &mut warps,
            );
        }
        for (i, a) in plan.actors.iter().enumerate() {
            if Some(i) == ego_i || driven[i] {
                continue;
            }
            match drivers[i].as_mut() {
                None => {
                    let w = warps[i];
                    if !open_loop
                        && k % send_every != 0
                        && w.lag == w.sent_lag
                        && w.rate == 1.0
                        && w.offset == w.sent_offset
                    {
                        continue;
                    }
                    warps[i].sent_lag = w.lag;
                    warps[i].sent_offset = w.offset;
                    let traj = match made.get_mut(i).and_then(Option::take) {
                        Some(t) => t,
                        None => plan_trajectory(a, &w, clock, &mut sent[i]),
                    };
                    ssp.set_xy_trajectory(&a.id, traj).map_err(ssp_err)?;
                }
                Some(d) => {
                    let Some(st) = &rb.states[i] else {
                        // First step: the actor starts at the plan's speed; hold it.
                        let p = a.at(warps[i].tau(t_next), plan.dt);
                        let u = d.pedals(d.feed_forward(p.a), p.a, p.v);
                        send_dynamic(ssp, &a.id, u, 0.0, d, &mut controls[i])?;
                        continue;
                    };
                    let t_now = now_ms as f64 / 1000.0;
                    // A re-timed actor's clock follows the car: its plan
                    // time is the one whose point is abreast of it (a
                    // reference ahead of or behind the car would turn its
                    // heading error into lateral error and diverge).
                    if warps[i].lag != 0.0 || warps[i].rate != 1.0 {
                        let there = a.at(warps[i].tau(t_now), plan.dt);
                        let (sh, ch) = math::sin_cos(there.yaw);
                        let along = (st.pose.position.x - there.x) * ch
                            + (st.pose.position.y - there.y) * sh;
                        warps[i].lag += along / there.v.max(0.5);
                    }
                    let t_next = warps[i].tau(t_next);
                    // A re-timed actor moves `rate` times its plan's speed.
                    let rate = warps[i].rate;
                    let off = warps[i].offset;
                    let here = shifted(a.at(warps[i].tau(t_now), plan.dt), off);
                    let mut p = shifted(a.at(t_next, plan.dt), off);
                    let v_plan = p.v;
                    // The feed-forward is the acceleration planned over the
                    // coming step, i.e. the one in force now (the next
                    // point's may already be the following segment's: a
                    // step early at every change, a·dt of speed error).
                    p.a = here.a;
                    if warps[i].lag != 0.0 || rate != 1.0 {
                        p.v *= rate;
                        p.a = warps[i].accel;
                    }
                    let g = &calibration;
                    let u = d.longitudinal(g, p.a, p.v, st.speed, dt);
                    let u = d.pedals(u, p.a, p.v);
                    // Lateral error: planned point relative to the car, left positive.
                    let (sy, cy) = math::sin_cos(st.pose.yaw);
                    let ex = here.x - st.pose.position.x;
                    let ey = here.y - st.pose.position.y;
                    let e_lat = -sy * ex + cy * ey;
                    let e_yaw = wrap_angle(here.yaw - st.pose.yaw);
                    let ahead = a.at(t_next + 0.2, plan.dt);
                    // 0.2 s of plan time ahead: the plan's speed sets the arc.
                    let ds = (v_plan.max(0.5)) * 0.2;
                    let kappa = wrap_angle(ahead.yaw - p.yaw) / ds;
                    let delta = d.lateral(&g.steering, kappa, e_lat, e_yaw, dt);
                    let steer = (delta / d.lim.max_steer).clamp(-1.0, 1.0);
                    send_dynamic(ssp, &a.id, u, steer, d, &mut controls[i])?;
                }
            }
        }
        if sut_error.is_some() {
            break;
        }
        if let Some(p) = pacer.as_mut()
            && let Err(msg) = p.release(k)
        {
            realtime_failure = Some(msg);
            break;
        }
        if n_steps == 1 {
            let (info, states) = ssp.step(None, &filter).map_err(ssp_err)?;
            got.clear();
            got.push_reported(info, &states).map_err(ssp_err)?;
        } else {
            ssp.step_many_kinematics(n_steps as u32, &mut got)
                .map_err(ssp_err)?;
        }
        k += n_steps;
        let env = ReadEnv {
            plan: &plan,
            net,
            cfg,
            lights: lights.as_ref(),
            red: &red,
            box_roads: &box_roads,
            dims: &dims,
            dynamic: &dynamic,
            controls: &controls,
            ego_i,
            ego_index,
            sampling,
            mirror,
            step_ms,
            goal_actors: &goal_actors,
            warps: &warps,
            sent: &sent,
            driven: &driven,
        };
        // The next chunk's clock as the loop's head will make it: from
        // here to the end or the next light switch.
        let upcoming = (overlap && k < steps).then(|| {
            // The head switches every light due by then first.
            let switch = plan.lights[next_switch..]
                .iter()
                .map(|sw| switch_tick(sw.t))
                .find(|&at| at > k);
            Clock {
                now_ms: k * step_ms,
                ahead_ms: chunk_steps(k, chunk.min(steps - k), switch) * step_ms,
                ..clock
            }
        });
        match upcoming {
            Some(c) => {
                // Reading back here, the next trajectories on another core
                // (or after, on this one, when none is free).
                let actors = &plan.actors;
                let (warps, next_made, next_sent) = (&warps, &mut next_made, &mut next_sent);
                rayon::in_place_scope(|s| {
                    s.spawn(move |_| {
                        next_made.clear();
                        next_made.extend(
                            actors
                                .iter()
                                .zip(warps)
                                .zip(next_sent.iter_mut())
                                .map(|((a, w), keep)| Some(plan_trajectory(a, w, c, keep))),
                        );
                    });
                    rb.chunk(&env, &mut got)
                })?;
                next_clock = Some(c);
            }
            None => rb.chunk(&env, &mut got)?,
        }
    }
    let Readback {
        boxes,
        speeds,
        accels,
        mut kpis,
        rec,
        tracking,
        mut ego_kpi,
        last_t,
        mut live,
        mut samples,
        goal_results,
        lane_results,
        ..
    } = rb;
    ssp.end_simulation(if sut_error.is_some() {
        "system under test failed"
    } else {
        "plan finished"
    })
    .map_err(ssp_err)?;
    kpis.finish();
    if sampling {
        live_state(&boxes, &speeds, &accels, &mut live);
        sample_items(cfg, &plan, net, &live, last_t, true, &mut samples);
    }
    if let (Some(ek), Some(e)) = (ego_kpi.as_mut(), ego_index) {
        let last = plan.actors[e].samples.last().copied().unwrap_or_default();
        ek.finish(last.x, last.y);
    }
    let log = rec.map(|r| {
        let mut log = r.finish();
        if !tracking.tick.is_empty() {
            log.tracking = Some(litesim_log::TrackingColumns {
                command_source: if ego_i.is_some() { "sut" } else { "planned" }.into(),
                ..tracking.columns
            });
        }
        // The ego's planned path, drawn as the reference in the
        // dashboard's map panel and the ego animation.
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
    });
    let driven_ids = plan
        .actors
        .iter()
        .zip(&driven)
        .filter(|(_, d)| **d)
        .map(|(a, _)| a.id.clone())
        .collect();
    let replanned = match plan {
        Cow::Owned(p) => Some(p),
        Cow::Borrowed(_) => None,
    };
    Ok(Executed {
        kpis,
        steps: k,
        live_events,
        ego: ego_kpi,
        goals: goal_results,
        lane_goals: lane_results,
        sut_error,
        plan: replanned,
        log,
        profile: caps.profile,
        model: caps.model,
        realtime: pacer.as_ref().map(crate::realtime::Pacer::stats),
        realtime_failure,
        coverage: samples.into_iter().flatten().collect(),
        driven: driven_ids,
    })
}

/// What the driven actors' step reads of the run.
struct DrivenStep<'a> {
    net: &'a RoadNetwork,
    plan: &'a Plan,
    /// The last step's boxes and speeds (empty before the first step).
    boxes: &'a [BoxState],
    speeds: &'a [f64],
    /// Per actor: length, width, mass.
    dims: &'a [(f64, f64, f64)],
    lights: Option<&'a TrafficLights>,
    red: &'a [bool],
    now_ms: u64,
    step_ms: u64,
    ego_index: Option<usize>,
    mirror: bool,
}

/// One step of the actors drivers drive: every actor as it stands after
/// the last step (at the start: as planned), seen from one snapshot; the
/// lights' colours; each driven actor's trajectory for the coming step
/// sent to the simulator.
fn step_driven(
    amb: &mut crate::runtime::traffic::driven::Driven,
    s: &DrivenStep<'_>,
    ssp: &mut dyn Ssp,
) -> Result<(), ScenarioError> {
    let states: Vec<(litesim_core::Vec2, f64, f64, f64)> = (0..s.plan.actors.len())
        .map(|i| match s.boxes.get(i) {
            Some(b) => (
                litesim_core::Vec2::new(b.x, b.y),
                b.yaw,
                s.speeds[i],
                b.length,
            ),
            None => {
                let p = s.plan.actors[i].samples[0];
                (litesim_core::Vec2::new(p.x, p.y), p.yaw, p.v, s.dims[i].0)
            }
        })
        .collect();
    let ego_xy = s.ego_index.map(|e| states[e].0);
    let yellow: Vec<bool> = s
        .lights
        .map(|l| {
            l.boxes
                .iter()
                .map(|b| shows(b, BulbColor::Yellow))
                .collect()
        })
        .unwrap_or_default();
    amb.step(
        s.net,
        s.plan,
        &states,
        (s.red, &yellow),
        s.now_ms,
        s.step_ms,
        ego_xy,
        |i, mut traj| {
            if s.mirror {
                traj.points = traj.points.into_iter().map(|c| to_sim(c, true)).collect();
            }
            ssp.set_xy_trajectory(&s.plan.actors[i].id, traj)
                .map_err(ssp_err)
        },
    )
}

/// Walks on its plan and may yield: a person, cyclist or animal that moves.
fn yields(a: &ActorPlan) -> bool {
    use crate::elab::ActorKind;
    matches!(
        a.kind,
        ActorKind::Person | ActorKind::Cyclist | ActorKind::Animal
    ) && a.samples.iter().any(|s| s.v > 0.0)
}

/// People, cyclists and animals keep their planned paths but stop rather
/// than walk into a vehicle: one whose position 0.6 s ahead on its plan
/// lies within 0.6 m of a vehicle's box holds its plan clock this step.
fn hold_people(
    plan: &Plan,
    boxes: &[BoxState],
    driven: &[bool],
    t: f64,
    dt: f64,
    warps: &mut [Warp],
) {
    const AHEAD_S: f64 = 0.6;
    const MARGIN_M: f64 = 0.6;
    for (i, a) in plan.actors.iter().enumerate() {
        if !yields(a) || driven[i] {
            continue;
        }
        let tau = warps[i].tau(t);
        let (here, next) = (a.at(tau, plan.dt), a.at(tau + AHEAD_S, plan.dt));
        let (dx, dy) = (next.x - here.x, next.y - here.y);
        if dx * dx + dy * dy < 1e-4 {
            continue;
        }
        let blocked = boxes.iter().enumerate().any(|(j, b)| {
            if j == i || plan.actors[j].kind != crate::elab::ActorKind::Vehicle {
                return false;
            }
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

/// The step's state as coverage items read it (lanes are looked up only
/// by items that read one).
fn live_state(
    boxes: &[BoxState],
    speeds: &[f64],
    accels: &[f64],
    live: &mut Vec<crate::coverage::LiveActor>,
) {
    live.clear();
    for (i, b) in boxes.iter().enumerate() {
        live.push(crate::coverage::LiveActor {
            speed: speeds[i],
            acceleration: accels.get(i).copied().unwrap_or(0.0),
            x: b.x,
            y: b.y,
            yaw: b.yaw,
            lane: None,
            length: b.length,
            width: b.width,
            vx: b.vx,
            vy: b.vy,
        });
    }
}

/// When the next item not sampled yet is due (s; infinite: at the end).
fn due_time(cfg: &ExecConfig<'_>, plan: &Plan, samples: &[Option<crate::coverage::Sample>]) -> f64 {
    cfg.covers
        .iter()
        .zip(samples)
        .filter(|(_, s)| s.is_none())
        .map(|(item, _)| item_due(item, plan))
        .fold(f64::INFINITY, f64::min)
}

/// When an item is due by the plan (s; infinite: at the end).
fn item_due(item: &crate::coverage::CoverItem, plan: &Plan) -> f64 {
    use crate::coverage::SampleAt;
    match &item.event {
        SampleAt::Start => 0.0,
        SampleAt::End => f64::INFINITY,
        // The plan keys label times by the label as written (`a.end`);
        // the item knows its path (`c.a`).
        SampleAt::PhaseEnd(label) => plan
            .events
            .get(&format!("{label}.end"))
            .or_else(|| {
                let own = label.rsplit('.').next().unwrap_or(label);
                plan.events.get(&format!("{own}.end"))
            })
            .copied()
            .unwrap_or(f64::INFINITY),
    }
}

/// Samples the items due at `t` (`end`: the run is over, every item not
/// sampled yet is due — a phase that never ended is sampled at the end).
fn sample_items(
    cfg: &ExecConfig<'_>,
    plan: &Plan,
    net: Option<&RoadNetwork>,
    live: &[crate::coverage::LiveActor],
    t: f64,
    end: bool,
    out: &mut [Option<crate::coverage::Sample>],
) {
    use crate::coverage::{Sample, evaluate};
    for (item, slot) in cfg.covers.iter().zip(out.iter_mut()) {
        if slot.is_some() || !(end || t >= item_due(item, plan) - 1e-9) {
            continue;
        }
        // The map lookup only for items that read a lane.
        let lane = item.reads_lane();
        let actor = |id: &str| {
            let i = plan.actors.iter().position(|a| a.id == id)?;
            let mut a = *live.get(i)?;
            if lane {
                a.lane = net
                    .and_then(|n| n.to_road(litesim_core::Vec2::new(a.x, a.y)))
                    .map(|p| p.lane);
            }
            Some(a)
        };
        *slot = Some(Sample {
            item: item.name.clone(),
            value: evaluate(item, &plan.ids, &cfg.values, &actor),
            t,
        });
    }
}

/// The ego against its plan, for the log's tracking columns (the
/// dashboard's error and progress panels, the animation's look-ahead).
#[derive(Default)]
struct Tracking {
    columns: litesim_log::TrackingColumns,
    tick: Vec<u64>,
    /// Planned distance at each plan sample (built on first use).
    cum: Vec<f64>,
}

impl Tracking {
    /// Planned path ahead shown as the "prediction": 2 s in 0.2 s steps.
    const AHEAD: usize = 10;

    fn push(
        &mut self,
        tick: u64,
        t: f64,
        st: &litesim_ssp::api::Kinematics,
        a: &crate::plan::ActorPlan,
        plan: &Plan,
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
        c_.cmd_acceleration.push(p.a);
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
        c_.cmd_steering.push(math::atan(0.6 * a.length * kappa));
        c_.predictions.push(ahead);
        self.tick.push(tick);
    }
}

/// Whether a box shows `color` (a bulb of that colour on or flashing).
fn shows(b: &TrafficLightBox, color: BulbColor) -> bool {
    b.bulbs
        .iter()
        .any(|x| x.color == color && matches!(x.mode, BulbMode::On | BulbMode::Flashing))
}

/// Whether a box shows red.
fn shows_red(b: &TrafficLightBox) -> bool {
    shows(b, BulbColor::Red)
}

/// Sets a light (logical by preference, else a box) to one colour: that
/// colour's bulbs on, the others off.
fn switch_light(
    ssp: &mut dyn Ssp,
    info: &mut TrafficLights,
    red: &mut [bool],
    sw: &crate::plan::LightSwitch,
) -> Result<(), ScenarioError> {
    let (target, boxes): (LightTarget, Vec<String>) = match info
        .logical
        .iter()
        .find(|l| l.id == sw.light || l.controller_id == sw.light)
    {
        Some(l) => (LightTarget::Logical(l.id.clone()), l.box_ids.clone()),
        None if info.boxes.iter().any(|b| b.id == sw.light) => {
            (LightTarget::Box(sw.light.clone()), vec![sw.light.clone()])
        }
        None => {
            let known: Vec<&str> = info
                .logical
                .iter()
                .map(|l| l.id.as_str())
                .chain(info.boxes.iter().map(|b| b.id.as_str()))
                .collect();
            return Err(ScenarioError::Plan(format!(
                "traffic light '{}' is not in the map (lights: {})",
                sw.light,
                known.join(", ")
            )));
        }
    };
    let want = match sw.color.as_str() {
        "red" => BulbColor::Red,
        "yellow" => BulbColor::Yellow,
        _ => BulbColor::Green,
    };
    let mut states: Vec<BulbState> = Vec::new();
    for b in info.boxes.iter().filter(|b| boxes.contains(&b.id)) {
        for bulb in &b.bulbs {
            let s = BulbState {
                icon: bulb.icon,
                color: bulb.color,
                mode: if bulb.color == want {
                    BulbMode::On
                } else {
                    BulbMode::Off
                },
            };
            if !states.contains(&s) {
                states.push(s);
            }
        }
    }
    let changed = ssp
        .set_traffic_light_state(target, states)
        .map_err(ssp_err)?;
    for c in changed {
        if let Some(k) = info.boxes.iter().position(|b| b.id == c.id) {
            red[k] = shows_red(&c);
            info.boxes[k] = c;
        }
    }
    Ok(())
}

/// Map frame → the simulator's frame.
fn to_sim(mut c: Coord6, mirror: bool) -> Coord6 {
    if mirror {
        c.y = c.y.map(|v| -v);
        c.yaw = c.yaw.map(|v| -v);
    }
    c
}

fn send_dynamic(
    ssp: &mut dyn Ssp,
    id: &str,
    (throttle, brake): (f64, f64),
    steer: f64,
    d: &Driver,
    control: &mut ControlSample,
) -> Result<(), ScenarioError> {
    let steer = quantise(steer.clamp(-1.0, 1.0), d.resolution);
    let mv = pedals(throttle, brake, steer, &d.lim, d.mirror, control);
    ssp.set_dynamic_move(id, mv, 0).map_err(ssp_err)
}

/// Normalised pedals and steering (+ = left in the map's frame) as a move,
/// recorded in `control`.
fn pedals(
    throttle: f64,
    brake: f64,
    steer: f64,
    lim: &Limits,
    mirror: bool,
    control: &mut ControlSample,
) -> DynamicMove {
    *control = ControlSample {
        throttle,
        brake,
        steering: steer,
        steering_angle: steer * lim.max_steer,
        ..ControlSample::default()
    };
    DynamicMove::Normalized {
        throttle,
        brake,
        // A mirrored (left-handed) profile turns the other way for the same sign.
        steering: if mirror { -steer } else { steer },
    }
}

fn body(o: &ObjectState) -> Body {
    Body {
        x: o.x,
        y: o.y,
        yaw: o.yaw,
        speed: o.speed,
        length: o.length,
    }
}

/// A traffic-light box's colour as the SUT sees it.
fn light_state(b: &TrafficLightBox) -> LightState {
    let on = |c: BulbColor| shows(b, c);
    let color = if on(BulbColor::Red) {
        "red"
    } else if on(BulbColor::Yellow) {
        "yellow"
    } else if on(BulbColor::Green) {
        "green"
    } else {
        "off"
    };
    LightState {
        id: b.id.clone(),
        road: b.road_id.clone(),
        s: b.s,
        color: color.into(),
    }
}

/// Sends the SUT's command to `sut.car` as a dynamic move.
fn send_sut(
    ssp: &mut dyn Ssp,
    id: &str,
    c: SutCommand,
    caps: &Limits,
    model: &str,
    mirror: bool,
    control: &mut ControlSample,
) -> Result<(), ScenarioError> {
    let m = if mirror { -1.0 } else { 1.0 };
    let mv = match c {
        SutCommand::Pedals {
            throttle,
            brake,
            steering,
        } => pedals(throttle, brake, steering, caps, mirror, control),
        SutCommand::Physical {
            drive_force_n,
            brake_force_n,
            steering_wheel_angle_rad,
        } => DynamicMove::Physical {
            drive_force_n,
            brake_force_n,
            steer: litesim_ssp::api::PhysicalSteer::SteeringWheelAngleRad(
                m * steering_wheel_angle_rad,
            ),
        },
        SutCommand::Accel {
            acceleration,
            curvature,
        } => {
            // The road-wheel angle giving that curvature in the model: the
            // seed's Model SSP turns at sin δ / L, the bicycle at tan δ / L.
            let lk = caps.wheelbase * curvature;
            let delta = if model == "dummy" || model.is_empty() {
                math::asin(lk.clamp(-1.0, 1.0))
            } else {
                math::atan(lk)
            };
            *control = ControlSample {
                acceleration,
                steering_angle: delta,
                ..ControlSample::default()
            };
            DynamicMove::Direct {
                acceleration,
                steering_angle_rad: m * delta,
            }
        }
    };
    ssp.set_dynamic_move(id, mv, 0).map_err(ssp_err)
}
