//! Planning: the behaviour tree in time (serial, parallel with overlap,
//! one_of, durations, waits), each actor's placement (along a road, in a
//! lane, ahead of or behind another actor, beside it) and motion (speed,
//! change_speed, acceleration, position at the end of a phase, lane
//! changes, standing still, walking across), sampled into a trajectory for
//! every actor *before* anything runs.
//!
//! Conventions (documented because the standard leaves them open):
//! - a leaf without a duration takes its parent's; with none at all, 5 s;
//! - `position(d, ahead_of: x)` is a bumper-to-bumper gap along x's lane;
//!   `position(time: t, …)` means d = t · x's speed;
//! - lane numbers count from 1 at the rightmost lane of the direction of
//!   travel; `left_of`/`right_of` are one lane over;
//! - speed changes use the `acceleration` modifier, else 2.5 m/s² up and
//!   4 m/s² down; `best_effort` accepts what those rates reach, `strict`
//!   turns a miss into a post-plan violation;
//! - a lane change takes the whole phase, clipped to [2 s, 6 s], with a
//!   smoothstep lateral profile;
//! - a person with `lateral(d, side_of: x, side: …)` starts d beside x's
//!   lane centre and walks across, perpendicular to the lane.

use crate::elab::{ActorDef, CExpr, Modifier, Node, Test, Value};
use crate::error::ScenarioError;
use crate::expr::{Edge, Field, Scope};
use crate::intent::{Action, At, Intent, LaneRelation, ModKind, RefKind, Side};
use crate::solve::{Solution, sample};
use litesim_core::ActorClass;
use litesim_core::geometry::wrap_angle;
use litesim_core::math;
use litesim_core::rng::Rng;
use litesim_map::{LanePos, RoadNetwork};
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::OnceLock;

/// Longest test the planner accepts (s): a typo such as `duration(9999999s)`
/// is an error, not hours of sampling.
pub const MAX_DURATION_S: f64 = 3600.0;

/// Default leaf duration when nothing gives one (s).
pub const DEFAULT_PHASE_S: f64 = 5.0;

/// How long a lane change takes from lane to lane (s): a `change_lane()`
/// action without a duration lasts this long, and so do the drivers'.
pub const LANE_CHANGE_S: f64 = 3.0;

/// How long a lane change `width` metres across takes at the peak
/// sideways speed `rate` (`change_lane(…, rate_peak)`): the smoothstep's
/// peak is 1.5 · width / time; at least 0.5 s.
pub(crate) fn lane_change_time(width: f64, rate: f64) -> f64 {
    (1.5 * width / rate.abs().max(0.01)).max(0.5)
}

/// `s` seconds to the end of the plan step it falls in (steps of `dt`).
pub(crate) fn in_steps(s: f64, dt: f64) -> f64 {
    (s / dt - 1e-9).ceil() * dt
}

/// Seconds over which a kept or changed space gap's error is closed (the
/// planner's and the drivers' law alike).
pub const GAP_CLOSE_S: f64 = 2.0;

/// The speed that closes a space gap's error: the speed of the one ahead
/// plus the error (the gap less the one wanted) over `tau` seconds.
pub fn gap_closing_speed(v_ahead: f64, gap: f64, want: f64, tau: f64) -> f64 {
    (v_ahead + (gap - want) / tau).max(0.0)
}

/// The speed that closes a time headway's error (an ACC's constant
/// time-gap law): the speed v at which v = v_ahead + (gap − h · v)/h, the
/// error of the gap h · v closed over h, i.e. (v_ahead + gap/h)/2. Taking
/// the speed the follower has for v instead swings from step to step in
/// the plan and lags a driver; the error decays over 2h either way.
pub fn headway_closing_speed(v_ahead: f64, gap: f64, h: f64) -> f64 {
    (0.5 * (v_ahead + gap / h)).max(0.0)
}

/// The speed of an actor that keeps (or brings) its gap or time headway
/// to one **behind** it (`direction: behind`): the one behind's speed
/// plus the gap's shortfall closed over [`GAP_CLOSE_S`] for a space gap,
/// or over the headway for a time headway measured at the speed of the one
/// behind (the trailing actor's, as `position(time: …)` measures it):
/// v = v_behind + h · a_behind + (h · v_behind − gap)/h — the headway's gap
/// grows by h · a_behind, fed forward so that it is not lagged by h² ·
/// a_behind.
pub fn leading_speed((v_behind, a_behind): (f64, f64), gap: f64, want: f64, headway: bool) -> f64 {
    if headway {
        (v_behind + want * a_behind + (want * v_behind - gap) / want).max(0.0)
    } else {
        (v_behind + (want - gap) / GAP_CLOSE_S).max(0.0)
    }
}

const ACCEL_UP: f64 = 2.5;
const ACCEL_DOWN: f64 = 4.0;
const WALK_SPEED: f64 = 1.4;

/// One planned sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PlanSample {
    /// Time (s).
    pub t: f64,
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
    /// Speed (m/s).
    pub v: f64,
    /// Longitudinal acceleration (m/s²).
    pub a: f64,
}

/// One actor's plan.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ActorPlan {
    /// Id.
    pub id: String,
    /// Kind.
    pub kind: ActorClass,
    /// The ego.
    pub ego: bool,
    /// Vehicle category asked for (`car`, `truck`, …).
    pub category: String,
    /// Catalogue model asked for (`keep(it.model == "vehicle.audi.tt")`):
    /// the simulator must create exactly this one, or the run is an error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// Length (m) and width (m) assumed by the plan.
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// Samples every [`Plan::dt`].
    pub samples: Vec<PlanSample>,
    /// Samples the actor jumps to (`assign_position`), in order: the plan
    /// goes straight on from the sample before until the jump's time,
    /// never moving between the two places.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub jumps: Vec<usize>,
    #[serde(skip)]
    pub(crate) heading_trig: HeadingTrig,
}

/// `(yaw bits, sin, cos)` of every sample's heading, computed on the first
/// [`ActorPlan::at`]: a run asks for the plan several times per step and
/// each answer needs the trig of two samples. An entry is used only while
/// its sample still has that heading (`samples` is public), so the cache
/// never changes a result; it takes no part in equality.
#[derive(Clone, Default)]
pub(crate) struct HeadingTrig(OnceLock<Vec<(u64, f64, f64)>>);

impl PartialEq for HeadingTrig {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for HeadingTrig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("HeadingTrig")
    }
}

impl ActorPlan {
    /// A plan without samples yet.
    pub fn new(
        id: String,
        kind: ActorClass,
        ego: bool,
        category: String,
        size: (f64, f64),
    ) -> Self {
        ActorPlan {
            id,
            kind,
            ego,
            category,
            model: None,
            length: size.0,
            width: size.1,
            samples: Vec::new(),
            jumps: Vec::new(),
            heading_trig: HeadingTrig::default(),
        }
    }

    /// `(sin, cos)` of sample `j`'s heading.
    fn trig(&self, j: usize) -> (f64, f64) {
        let yaw = self.samples[j].yaw;
        let table = self.heading_trig.0.get_or_init(|| {
            self.samples
                .iter()
                .map(|p| {
                    let (s, c) = math::sin_cos(p.yaw);
                    (p.yaw.to_bits(), s, c)
                })
                .collect()
        });
        match table.get(j) {
            Some(&(bits, s, c)) if bits == yaw.to_bits() => (s, c),
            _ => math::sin_cos(yaw),
        }
    }

    /// The speed of [`ActorPlan::at`]`(t, dt)`, the same bits, without
    /// the position (the planner's followers read the others' speeds
    /// every sample).
    pub fn speed_at(&self, t: f64, dt: f64) -> f64 {
        let n = self.samples.len();
        if n == 0 {
            return 0.0;
        }
        let k = (t / dt).floor();
        if k < 0.0 {
            return self.samples[0].v;
        }
        let i = k as usize;
        if i + 1 >= n {
            return self.samples[n - 1].v;
        }
        let (a, b) = (&self.samples[i], &self.samples[i + 1]);
        if !self.jumps.is_empty() && self.jumps.binary_search(&(i + 1)).is_ok() {
            return a.v;
        }
        let u = t / dt - k;
        a.v + (b.v - a.v) * u
    }

    /// The planned state at time `t` (held at the ends). Positions follow
    /// the samples' headings between them (a cubic Hermite curve along the
    /// headings where a vehicle follows its path, else linear); heading and
    /// speed are interpolated linearly.
    pub fn at(&self, t: f64, dt: f64) -> PlanSample {
        let n = self.samples.len();
        if n == 0 {
            return PlanSample::default();
        }
        let k = (t / dt).floor();
        if k < 0.0 {
            return self.samples[0];
        }
        let i = k as usize;
        if i + 1 >= n {
            return self.samples[n - 1];
        }
        let u = t / dt - k;
        let (a, b) = (&self.samples[i], &self.samples[i + 1]);
        // No motion into a jump: from the sample before, straight on at
        // its speed and heading until the jump's time.
        if !self.jumps.is_empty() && self.jumps.binary_search(&(i + 1)).is_ok() {
            let (s, c) = self.trig(i);
            let d = a.v * (t - a.t);
            return PlanSample {
                t,
                x: a.x + c * d,
                y: a.y + s * d,
                ..*a
            };
        }
        let (x, y) = between(a, b, u, self.trig(i), self.trig(i + 1));
        PlanSample {
            t,
            x,
            y,
            yaw: a.yaw + wrap_angle(b.yaw - a.yaw) * u,
            v: a.v + (b.v - a.v) * u,
            a: a.a,
        }
    }
}

/// The position a fraction `u` of the way from sample `a` to `b`.
///
/// Where both headings run along the chord (within 0.35 rad, a vehicle
/// following its path), a cubic Hermite curve whose end tangents are the
/// headings scaled to the chord length: on a bend it follows the arc
/// instead of cutting it (a chord of 0.1 s at 17 m/s on a 55 m radius sags
/// 6 mm, enough to make a closed-loop driver chase a saw-tooth), and on a
/// straight it is the straight line. Elsewhere (standing, walking sideways)
/// plainly linear.
/// `(sa, ca)`, `(sb, cb)`: sine and cosine of the two samples' headings.
fn between(
    a: &PlanSample,
    b: &PlanSample,
    u: f64,
    (sa, ca): (f64, f64),
    (sb, cb): (f64, f64),
) -> (f64, f64) {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let linear = (a.x + dx * u, a.y + dy * u);
    let d = (dx * dx + dy * dy).sqrt();
    if d.is_nan() || d <= 1e-6 {
        return linear;
    }
    // cos of the angle between each heading and the chord, against cos 0.35.
    const ALONG: f64 = 0.939_372_712_847_379;
    if (dx * ca + dy * sa) < ALONG * d || (dx * cb + dy * sb) < ALONG * d {
        return linear;
    }
    let (u2, u3) = (u * u, u * u * u);
    let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
    let h10 = u3 - 2.0 * u2 + u;
    let h01 = -2.0 * u3 + 3.0 * u2;
    let h11 = u3 - u2;
    (
        h00 * a.x + h10 * d * ca + h01 * b.x + h11 * d * cb,
        h00 * a.y + h10 * d * sa + h01 * b.y + h11 * d * sb,
    )
}

/// A timed phase of the behaviour tree.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Phase {
    /// Label path, when labelled.
    pub label: Option<String>,
    /// Actor.
    pub actor: String,
    /// Action.
    pub action: Action,
    /// Start (s).
    pub t0: f64,
    /// End (s).
    pub t1: f64,
}

/// The whole plan.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Plan {
    /// Sample spacing (s).
    pub dt: f64,
    /// Duration (s).
    pub duration: f64,
    /// Actors.
    pub actors: Vec<ActorPlan>,
    /// Phases in time order.
    pub phases: Vec<Phase>,
    /// Violations of `strict` modifiers (reported with the post-plan checks).
    pub violations: Vec<String>,
    /// Actors that could not be placed where their start modifiers put
    /// them (beyond the end of a lane, no free place): the scenario cannot
    /// be set up with this seed, the run is `invalid` and not executed.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub unplaced: Vec<String>,
    /// Traffic-light switches in time order.
    pub lights: Vec<LightSwitch>,
    /// Actors whose plan asks for exactness over physics (a jump, a
    /// heading of their own), with the first place that asks: no driver
    /// takes them over (`--npc driver`), and a SUT may not drive one.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub exact: BTreeMap<String, String>,
    /// Changes of the environment (weather, sun, time of day) in time
    /// order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub environment: Vec<EnvChange>,
    /// Gaps to other actors that phases ask for at their end
    /// (`position(d, ahead_of: x, at: end)`): the runtime re-solves them
    /// against where `x` actually is.
    pub goals: Vec<GapGoal>,
    /// Gaps or time headways phases keep to an actor ahead
    /// (`keep_space_gap`, `keep_time_headway`): a driver follows that actor
    /// with them. (Not written when there are none: plans without them stay
    /// the same bytes.)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub keeps: Vec<KeepGoal>,
    /// Phases in which an actor does not avoid collisions
    /// (`avoid_collisions(false)`): (actor, t0, t1). A driver then follows
    /// its plan's speed whatever is ahead. (Not written when empty.)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub reckless: Vec<(String, f64, f64)>,
    /// Lanes phases ask for at their end relative to another actor
    /// (`lane(same_as: sut.car, at: end)`): re-solved against the lane that
    /// actor is really in.
    pub lane_goals: Vec<LaneGoal>,
    /// Phases that keep an actor beside another (`lateral(d, side_of: x)`):
    /// in a closed loop the actor's path follows x's sideways moves.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub side_follows: Vec<SideFollow>,
    /// State conditions of `wait` and `until` (`sut.car.speed > 30kph`,
    /// `rise(…)`) and when this plan has them hold: the closed-loop runtime
    /// evaluates them on the simulated state and plans again when they
    /// hold at another time.
    pub conditions: Vec<Condition>,
    /// Actor paths (`s.other`) to ids, for evaluating conditions.
    #[serde(skip)]
    pub ids: BTreeMap<String, String>,
    /// When labelled phases start and end (`c.a.start`, `c.a.end`, s).
    #[serde(skip)]
    pub events: BTreeMap<String, f64>,
    /// Remarks.
    pub notes: Vec<String>,
}

/// A phase keeps `actor` beside `reference` (`lateral(d, side_of:
/// reference)`): while it runs, `actor`'s path is shifted sideways as
/// `reference` moves off its own planned path.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SideFollow {
    /// The actor that follows.
    pub actor: String,
    /// The actor it stays beside.
    pub reference: String,
    /// Phase start (s).
    pub t0: f64,
    /// Phase end (s).
    pub t1: f64,
}

/// A phase asks `actor` to end in the lane `relation` (`same_as`,
/// `left_of`, `right_of`) `reference`'s.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LaneGoal {
    /// The actor that moves.
    pub actor: String,
    /// The actor whose lane counts.
    pub reference: String,
    /// Which lane of the reference's.
    pub relation: LaneRelation,
    /// Phase start (s).
    pub t0: f64,
    /// Phase end (s): when the lane is judged.
    pub t1: f64,
    /// A miss fails the run.
    pub strict: bool,
    /// The modifier's place in the test.
    pub at: String,
}

/// A `wait`/`until` condition over actors' states.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Condition {
    /// Identity of the condition within the test (stable across layouts).
    pub key: String,
    /// When its phase starts (s): it is looked for from then on.
    pub t0: f64,
    /// When this plan has it hold (s); `None`: never within the plan.
    pub at: Option<f64>,
    /// The condition.
    #[serde(skip)]
    pub cond: CExpr,
}

impl Condition {
    /// The edge (`rise`/`fall`/hold) and the condition under it.
    pub fn edge(&self) -> (Edge, &CExpr) {
        Edge::of(&self.cond)
    }

    /// Whether the condition under the edge holds in `scope`; `None` when
    /// it reads something the scope cannot show.
    pub fn holds(&self, ids: &BTreeMap<String, String>, scope: &dyn Scope) -> Option<bool> {
        crate::expr::truth(self.edge().1, ids, scope)
    }
}

/// A phase asks `actor` to end `distance` m (bumper to bumper) ahead of
/// (`sign` = 1) or behind (−1) `reference`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GapGoal {
    /// The actor that moves to meet the goal.
    pub actor: String,
    /// The actor the gap is measured to.
    pub reference: String,
    /// Wanted bumper-to-bumper gap (m).
    pub distance: f64,
    /// 1 ahead of, −1 behind.
    pub sign: f64,
    /// Phase start (s).
    pub t0: f64,
    /// Phase end (s): when the gap is judged.
    pub t1: f64,
    /// `run_mode: strict` (the default): a miss fails the run.
    pub strict: bool,
    /// The modifier's place in the test (`file:line:col`).
    pub at: String,
    /// The phase's label, when labelled.
    pub label: Option<String>,
    /// `track: projected`: the gap is to where the reference would be had
    /// it gone on from the phase's start at the speed it had then, straight
    /// along its heading, not to where it is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub projected: Option<Projection>,
}

/// Where an actor was at a phase's start and how fast it went: the motion
/// `track: projected` measures against (it keeps that speed and heading).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Projection {
    /// Position at `t0` (m).
    pub x: f64,
    /// Position at `t0` (m).
    pub y: f64,
    /// Heading at `t0` (rad).
    pub yaw: f64,
    /// Speed at `t0` (m/s), kept.
    pub speed: f64,
    /// The phase's start (s).
    pub t0: f64,
}

impl GapGoal {
    /// The reference's body the gap is measured to at time `t`: `actual`
    /// itself, or under `track: projected` the projection's place then
    /// (with `actual`'s size).
    pub fn reference_at(
        &self,
        actual: &crate::state::BodyState,
        t: f64,
    ) -> crate::state::BodyState {
        match self.projected {
            None => *actual,
            Some(p) => {
                let d = p.speed * (t - p.t0).max(0.0);
                let (s, c) = litesim_core::math::sin_cos(p.yaw);
                crate::state::BodyState {
                    x: p.x + d * c,
                    y: p.y + d * s,
                    yaw: p.yaw,
                    vx: p.speed * c,
                    vy: p.speed * s,
                    speed: p.speed,
                    acceleration: 0.0,
                    ..*actual
                }
            }
        }
    }
}

/// A phase asks `actor` to keep the gap or time headway it has to the
/// actor ahead when the phase starts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KeepGoal {
    /// The following actor.
    pub actor: String,
    /// The actor ahead.
    pub reference: String,
    /// The time headway kept (s), or `None` for a space gap.
    pub headway: Option<f64>,
    /// The bumper-to-bumper gap at the phase's start (m), or the one to
    /// reach.
    pub gap: f64,
    /// The reference is behind the actor (`direction: behind`): the actor
    /// leads and keeps the gap or headway ahead of it.
    pub behind: bool,
    /// Phase start (s).
    pub t0: f64,
    /// Phase end (s).
    pub t1: f64,
    /// The two actors' places in [`Plan::actors`] (set when the plan is
    /// made: the runtime looks a kept gap up every step).
    #[serde(skip)]
    pub(crate) index: Option<(usize, usize)>,
}

/// A traffic light changes colour.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LightSwitch {
    /// When (s).
    pub t: f64,
    /// Box (signal) or logical light (controller) id in the map.
    pub light: String,
    /// `red`, `yellow` or `green`.
    pub color: String,
}

/// The environment changes (`environment.rain(…)`, …).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EnvChange {
    /// When (s).
    pub t: f64,
    /// The action (`rain`, `fog`, `air`, `wind`, `clouds`, `snow`,
    /// `assign_celestial_position`, `time_of_day`).
    pub action: String,
    /// Its numeric arguments in SI units, by parameter name.
    pub values: BTreeMap<String, f64>,
    /// Where it is written (`file:line:col`).
    pub at: String,
}

mod conditions;
mod motion;
mod placement;
mod timer;

use conditions::*;
use motion::*;
use placement::*;
pub use timer::eval;
use timer::*;

/// Plans a solved test on a map.
/// Plans a solved test on a map. `wait` and `until` conditions over states
/// (`sut.car.speed > 30kph`, `rise(…)`) are evaluated on the planned
/// samples; the plan is laid out again with the times they give until the
/// times stop changing (each layout starts from the same generator state,
/// so the result is a function of the seed).
pub fn plan(
    test: &Test,
    sol: &Solution,
    net: &RoadNetwork,
    step_s: f64,
    rng: &mut Rng,
) -> Result<Plan, ScenarioError> {
    plan_with(test, sol, net, step_s, rng, &BTreeMap::new())
}

/// [`plan`] with the times of some conditions fixed (by key): what the
/// closed-loop runtime saw on the simulated state.
pub fn plan_with(
    test: &Test,
    sol: &Solution,
    net: &RoadNetwork,
    step_s: f64,
    rng: &mut Rng,
    fixed: &BTreeMap<String, f64>,
) -> Result<Plan, ScenarioError> {
    let ids: BTreeMap<String, String> = test
        .actors
        .iter()
        .map(|a| (a.path.clone(), a.id.clone()))
        .collect();
    let start = rng.clone();
    let mut events = fixed.clone();
    for round in 0..8 {
        let mut r = start.clone();
        let Once {
            plan: mut p,
            conds,
            reached,
            guessed,
        } = plan_once(test, sol, net, step_s, &mut r, &events)?;
        // A time once found is kept: a phase cut at the moment its
        // condition becomes true may keep it from becoming true in the
        // next layout (the cut changes the motion from that sample on), so
        // re-evaluating would oscillate. Times are found in causal order:
        // each round evaluates the conditions not yet timed on a layout
        // that already honours the earlier ones.
        let mut next = events.clone();
        // How long each `change_speed` took to reach its target: kept
        // once found, like the condition times (its start speed comes
        // from the phases before it, which do not depend on it).
        for (key, d) in reached {
            next.entry(key).or_insert(d);
        }
        let mut never = 0;
        let mut unsupported = 0;
        for (key, t0, c) in &conds {
            if next.contains_key(key) {
                continue;
            }
            match cond_time(c, *t0, &p, &ids) {
                Ok(Some(t)) => {
                    next.insert(key.clone(), t);
                }
                Ok(None) => never += 1,
                Err(()) => unsupported += 1,
            }
        }
        // A reach time found equal to the guess this layout was made with
        // needs no other layout.
        let settled = next.iter().all(|(k, v)| {
            events.get(k) == Some(v) || guessed.get(k).is_some_and(|g| (g - v).abs() < 1e-6)
        }) && events.keys().all(|k| next.contains_key(k));
        if settled || round == 7 {
            if never > 0 {
                p.notes.push(format!(
                    "{never} wait/until condition(s) never hold in the plan: the wait ends at once, the phase runs its full time"
                ));
            }
            if unsupported > 0 {
                p.notes.push(format!(
                    "{unsupported} wait/until condition(s) cannot be evaluated on a plan (supported: speed, acceleration, position.x/y of actors, numbers, comparisons, and/or/not, rise/fall)"
                ));
            }
            if !settled {
                p.notes
                    .push("wait/until conditions did not settle in 8 layouts".into());
            }
            p.conditions = conds
                .into_iter()
                .map(|(key, t0, cond)| Condition {
                    at: events.get(&key).copied(),
                    key,
                    t0,
                    cond,
                })
                .collect();
            p.ids = ids;
            *rng = r;
            return Ok(p);
        }
        events = next;
    }
    unreachable!("the loop returns on its last round")
}

/// What one layout gives: the plan, the state conditions it met (key,
/// start, condition), how long each `change_*` action took to reach its
/// target (`reach@N`), and the durations it guessed for the ones without a
/// time yet.
struct Once {
    plan: Plan,
    conds: Vec<(String, f64, CExpr)>,
    reached: Vec<(String, f64)>,
    guessed: BTreeMap<String, f64>,
}

/// The plan's step for a simulation step of `step_s`: the multiple of it
/// nearest 0.1 s (at least one step).
pub(crate) fn plan_step(step_s: f64) -> f64 {
    step_s * (0.1 / step_s).round().max(1.0)
}

/// The phases of the leaves, in time order (then by actor).
fn phases_of(rleaves: &[RLeaf]) -> Vec<Phase> {
    let mut phases: Vec<Phase> = rleaves
        .iter()
        .map(|l| Phase {
            label: l.label.clone(),
            actor: l.actor.clone(),
            action: l.action,
            t0: l.t0,
            t1: l.t1,
        })
        .collect();
    phases.sort_by(|a, b| a.t0.total_cmp(&b.t0).then(a.actor.cmp(&b.actor)));
    phases
}

/// The kept gaps with their actors' places among the plan's `actors`.
fn index_keeps(mut keeps: Vec<KeepGoal>, actors: &[ActorPlan]) -> Vec<KeepGoal> {
    for k in &mut keeps {
        let at = |id: &str| actors.iter().position(|a| a.id == id);
        k.index = at(&k.actor).zip(at(&k.reference));
    }
    keeps
}

/// One layout and sampling with state-condition times `cond_events`.
fn plan_once(
    test: &Test,
    sol: &Solution,
    net: &RoadNetwork,
    step_s: f64,
    rng: &mut Rng,
    cond_events: &BTreeMap<String, f64>,
) -> Result<Once, ScenarioError> {
    let Some(root) = &test.root else {
        return Err(ScenarioError::no_behaviour());
    };
    let Layout {
        duration,
        leaves,
        switches,
        environment,
        estimates,
        conds,
        events,
    } = lay_out(root, sol, rng, cond_events, step_s)?;
    let guessed = estimates
        .into_iter()
        .map(|(id, d)| (timer::reach_key(id), d))
        .collect();
    let lights = light_switches(switches, sol, rng)?;
    let environment = timer::environment_changes(environment, sol, rng)?;
    let ids: BTreeMap<String, String> = test
        .actors
        .iter()
        .map(|a| (a.path.clone(), a.id.clone()))
        .collect();
    let rleaves = resolve_leaves(leaves, &ids, sol, rng)?;

    let mut plans = actor_plans(test, sol);
    // Actors that take part in no phase are not planned (nor created).
    let active: Vec<bool> = plans
        .iter()
        .map(|p| rleaves.iter().any(|l| l.actor == p.id))
        .collect();

    let order: Vec<usize> = (0..plans.len()).filter(|i| active[*i]).collect();
    let (placed, unplaced) = place_all(net, &plans, &order, &rleaves, rng)?;

    // Motion, sampled every plan step, actors without dependencies on
    // others' futures first (position at: end reads the other's plan).
    let plan_dt = plan_step(step_s);
    let cx = MoveCx {
        net,
        rleaves: &rleaves,
        placed: &placed,
        known: cond_events,
        paths: &test.paths,
        dt: plan_dt,
        n: (duration / plan_dt).ceil() as usize + 1,
    };
    // Independent actors first, each side in its order (a stable sort on
    // `ties`, with `ties` looked at once per actor).
    let (mut order, tied): (Vec<usize>, Vec<usize>) = order
        .into_iter()
        .partition(|&i| !ties(&rleaves, &plans[i].id));
    let free = order.len();
    order.extend(tied);
    let Moved {
        violations,
        mut notes,
        mut goals,
        lane_goals,
        side_follows,
        reached,
        keeps,
        reckless,
        exact,
        ..
    } = move_all(&cx, &mut plans, &order, free)?;
    let phases = phases_of(&rleaves);
    let keep: Vec<ActorPlan> = plans
        .into_iter()
        .zip(active)
        .filter_map(|(p, a)| a.then_some(p))
        .collect();
    if keep.is_empty() {
        notes.push("no actor takes part in the behaviour".into());
    }
    goals.sort_by(|a, b| a.t1.total_cmp(&b.t1).then(a.actor.cmp(&b.actor)));
    let keeps = index_keeps(keeps, &keep);
    Ok(Once {
        plan: Plan {
            dt: plan_dt,
            duration,
            actors: keep,
            phases,
            violations,
            unplaced,
            lights,
            exact,
            environment,
            goals,
            keeps,
            reckless,
            lane_goals,
            side_follows,
            conditions: Vec::new(),
            ids: BTreeMap::new(),
            events,
            notes,
        },
        conds,
        reached,
        guessed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lane_numbers_count_from_the_right_or_from_the_left() {
        // Three lanes, listed right to left.
        assert_eq!(lane_index(3, 1.0), 0);
        assert_eq!(lane_index(3, 3.0), 2);
        assert_eq!(lane_index(3, -1.0), 2, "1 from the left is the leftmost");
        assert_eq!(lane_index(3, -3.0), 0);
        assert_eq!(lane_index(3, 4.0), 3, "no such lane");
        assert_eq!(lane_index(3, -4.0), 3, "no such lane");
        assert_eq!(lane_index(3, 0.0), 0, "0 reads as 1, as it always has");
    }

    /// A plan with these samples and a fresh (empty) heading cache.
    fn with_samples(samples: Vec<PlanSample>) -> ActorPlan {
        ActorPlan {
            samples,
            ..ActorPlan::new(
                "a".into(),
                ActorClass::Vehicle,
                true,
                "car".into(),
                (4.6, 1.9),
            )
        }
    }

    fn plan_on_a_bend() -> ActorPlan {
        // 17 m/s on a 55 m radius, sampled every 0.1 s.
        let (r, w) = (55.0, 17.0 / 55.0);
        with_samples(
            (0..40)
                .map(|k| {
                    let t = k as f64 * 0.1;
                    let th = w * t;
                    PlanSample {
                        t,
                        x: r * litesim_core::math::sin(th),
                        y: r * (1.0 - litesim_core::math::cos(th)),
                        yaw: th,
                        v: 17.0,
                        a: 0.0,
                    }
                })
                .collect(),
        )
    }

    /// The heading cache never changes an answer, also when a sample's
    /// heading is edited after the cache was filled.
    #[test]
    fn heading_cache_never_changes_results() {
        let mut cached = plan_on_a_bend();
        let bits = |s: PlanSample| [s.x, s.y, s.yaw, s.v].map(f64::to_bits);
        let fresh = |p: &ActorPlan| with_samples(p.samples.clone());
        for k in 0..390 {
            let t = k as f64 * 0.01 + 0.003;
            assert_eq!(bits(cached.at(t, 0.1)), bits(fresh(&cached).at(t, 0.1)));
        }
        // Edit headings under the filled cache: answers follow the edit.
        for s in cached.samples.iter_mut().skip(10).take(5) {
            s.yaw += 0.01;
        }
        for k in 0..390 {
            let t = k as f64 * 0.01 + 0.003;
            let f = fresh(&cached);
            assert_eq!(bits(cached.at(t, 0.1)), bits(f.at(t, 0.1)), "t = {t}");
        }
        // And the edit is visible (the cache did not answer with old values).
        assert_ne!(
            bits(cached.at(1.05, 0.1)),
            bits(plan_on_a_bend().at(1.05, 0.1))
        );
    }
}
