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
use crate::intent::{Action, At, Intent, LaneRelation, RefKind, Side};
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
#[derive(Clone, Debug, PartialEq, Serialize)]
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
    /// Gaps to other actors that phases ask for at their end
    /// (`position(d, ahead_of: x, at: end)`): the runtime re-solves them
    /// against where `x` actually is.
    pub goals: Vec<GapGoal>,
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

struct Leaf<'a> {
    actor: String,
    action: Action,
    label: Option<String>,
    mods: Vec<&'a Modifier>,
    at: String,
    t0: f64,
    t1: f64,
}

struct Timer<'a> {
    /// The first `duration(…)` out of range, as an error message.
    bad_duration: Option<String>,
    rng: &'a mut Rng,
    sol: &'a Solution,
    leaves: Vec<Leaf<'a>>,
    /// Event times known from the previous pass (labels' start/end, emits).
    events: BTreeMap<String, f64>,
    /// Event times of this pass.
    seen: BTreeMap<String, f64>,
    /// `one_of` choices and `until elapsed` values, drawn once and kept
    /// across passes so that the passes converge.
    choice: BTreeMap<*const Node, usize>,
    until_after: BTreeMap<*const Node, Option<f64>>,
    /// Traffic-light switches: time, light path, colour, place.
    switches: Vec<(f64, String, &'a CExpr, String)>,
    /// Times at which state conditions hold, from the previous plan.
    cond_events: &'a BTreeMap<String, f64>,
    /// State conditions met in this layout: key, start time, condition.
    conds: Vec<(String, f64, &'a CExpr)>,
}

/// Evaluates an argument to a value: variables from the solution, ranges sampled.
pub fn eval(e: &CExpr, sol: &Solution, rng: &mut Rng) -> Option<Value> {
    match e {
        CExpr::Const(v) => Some(v.clone()),
        CExpr::Var(p) => sol
            .values
            .get(p)
            .cloned()
            .or_else(|| sol.roads.get(p).map(|r| Value::Str(r.clone()))),
        CExpr::Range(a, b) => Some(Value::Num(sample(
            a.unwrap_or(f64::NEG_INFINITY),
            b.unwrap_or(f64::INFINITY),
            rng,
        ))),
        CExpr::List(items) if !items.is_empty() => {
            let i = (rng.next_u64() % items.len() as u64) as usize;
            eval(&items[i], sol, rng)
        }
        CExpr::Unary(op, x) if op == "-" => eval(x, sol, rng)?.num().map(|v| Value::Num(-v)),
        _ => None,
    }
}

fn mods_of(n: &Node) -> &[Modifier] {
    match n {
        Node::Serial { mods, .. }
        | Node::Parallel { mods, .. }
        | Node::OneOf { mods, .. }
        | Node::Action { mods, .. } => mods,
        _ => &[],
    }
}

impl<'a> Timer<'a> {
    fn explicit(&mut self, n: &Node) -> Option<f64> {
        let m = mods_of(n).iter().find(|m| m.name == "duration")?;
        let e = m.args.get("duration")?;
        let d = eval(e, self.sol, self.rng)?.num()?;
        // A phase lasts longer than nothing and at most the test's limit:
        // `duration(-5s)` or `duration(0s)` is a mistake to report, not a
        // phase to skip (the first one found is reported).
        if !(d > 0.0 && d <= MAX_DURATION_S) && self.bad_duration.is_none() {
            self.bad_duration = Some(format!(
                "{}: duration({d} s) is out of range: a phase lasts more than 0 s and at most {MAX_DURATION_S} s",
                m.at
            ));
        }
        Some(d).filter(|d| *d >= 0.0)
    }

    /// Natural duration: explicit, or from the children.
    fn natural(&mut self, n: &Node, memo: &mut BTreeMap<*const Node, Option<f64>>) -> Option<f64> {
        let key = n as *const Node;
        if let Some(v) = memo.get(&key) {
            return *v;
        }
        let v = if let Some(d) = self.explicit(n) {
            Some(d)
        } else {
            match n {
                Node::Serial { children, .. } => {
                    let mut sum = 0.0;
                    let mut any = false;
                    for c in children {
                        if let Some(d) = self.natural(c, memo) {
                            sum += d;
                            any = true;
                        }
                    }
                    any.then_some(sum)
                }
                Node::Parallel { children, .. } | Node::OneOf { children, .. } => children
                    .iter()
                    .filter_map(|c| self.natural(c, memo))
                    .reduce(f64::max),
                Node::Wait { duration, .. } => duration
                    .as_ref()
                    .and_then(|e| eval(e, self.sol, self.rng))
                    .and_then(|v| v.num()),
                Node::Emit { .. } | Node::Switch { .. } => Some(0.0),
                Node::Action { .. } => None,
            }
        };
        memo.insert(key, v);
        v
    }

    /// Lays `n` out from `t0`; `forced` is the duration a parent imposes.
    fn assign(
        &mut self,
        n: &'a Node,
        t0: f64,
        forced: Option<f64>,
        memo: &mut BTreeMap<*const Node, Option<f64>>,
    ) -> f64 {
        let own = memo.get(&(n as *const Node)).copied().flatten();
        let mut dur = forced.or(own);
        // `until`: an event's planned time or an elapsed time ends the node early.
        for m in mods_of(n).iter().filter(|m| m.name == "until") {
            let cut = if let Some(CExpr::Const(Value::Str(e))) = m.args.get("event") {
                self.events.get(e).map(|te| te - t0).filter(|d| *d >= 0.0)
            } else if let Some(e) = m.args.get("elapsed") {
                let key = n as *const Node;
                if !self.until_after.contains_key(&key) {
                    let v = eval(e, self.sol, self.rng).and_then(|v| v.num());
                    self.until_after.insert(key, v);
                }
                self.until_after[&key].filter(|d| *d >= 0.0)
            } else if let Some(c) = m.args.get("cond") {
                let key = format!("cond@{}", m as *const Modifier as usize);
                self.conds.push((key.clone(), t0, c));
                self.cond_events
                    .get(&key)
                    .map(|te| te - t0)
                    .filter(|d| *d >= 0.0)
            } else {
                None
            };
            if let Some(c) = cut {
                dur = Some(dur.map_or(c, |d| d.min(c)));
            }
        }
        let end = self.assign_inner(n, t0, dur, memo);
        let label = match n {
            Node::Serial { label, .. }
            | Node::Parallel { label, .. }
            | Node::OneOf { label, .. }
            | Node::Action { label, .. } => label.as_ref(),
            _ => None,
        };
        if let Some(l) = label {
            self.seen.entry(format!("{l}.start")).or_insert(t0);
            self.seen.entry(format!("{l}.end")).or_insert(end);
        }
        end
    }

    fn assign_inner(
        &mut self,
        n: &'a Node,
        t0: f64,
        dur: Option<f64>,
        memo: &mut BTreeMap<*const Node, Option<f64>>,
    ) -> f64 {
        match n {
            Node::Action {
                actor,
                action,
                label,
                mods,
                at,
            } => {
                let d = dur.unwrap_or(DEFAULT_PHASE_S);
                self.leaves.push(Leaf {
                    actor: actor.clone(),
                    action: *action,
                    label: label.clone(),
                    mods: mods.iter().collect(),
                    at: at.clone(),
                    t0,
                    t1: t0 + d,
                });
                t0 + d
            }
            Node::Serial { children, .. } => {
                // Children without their own duration share what is left.
                let known: f64 = children
                    .iter()
                    .filter_map(|c| memo.get(&(c as *const Node)).copied().flatten())
                    .sum();
                let open = children
                    .iter()
                    .filter(|c| memo.get(&(*c as *const Node)).copied().flatten().is_none())
                    .count();
                let share = match dur {
                    Some(d) if open > 0 => Some(((d - known) / open as f64).max(0.0)),
                    _ => None,
                };
                let mut t = t0;
                for c in children {
                    let cd = memo.get(&(c as *const Node)).copied().flatten();
                    t = self.assign(c, t, cd.or(share), memo);
                }
                t
            }
            Node::Parallel {
                children, overlap, ..
            } => {
                let d = dur.unwrap_or(DEFAULT_PHASE_S);
                for c in children {
                    let cd = memo.get(&(c as *const Node)).copied().flatten();
                    match overlap.as_str() {
                        "equal" | "full" => {
                            self.assign(c, t0, Some(d), memo);
                        }
                        "end" | "final" => {
                            let cd = cd.unwrap_or(d).min(d);
                            self.assign(c, t0 + d - cd, Some(cd), memo);
                        }
                        _ => {
                            self.assign(c, t0, Some(cd.unwrap_or(d).min(d)), memo);
                        }
                    }
                }
                t0 + d
            }
            Node::OneOf { children, .. } => {
                if children.is_empty() {
                    return t0;
                }
                let key = n as *const Node;
                let i = match self.choice.get(&key) {
                    Some(i) => *i,
                    None => {
                        let i = (self.rng.next_u64() % children.len() as u64) as usize;
                        self.choice.insert(key, i);
                        i
                    }
                };
                self.assign(&children[i], t0, dur, memo)
            }
            Node::Wait { event: Some(e), .. } => match self.events.get(e) {
                Some(te) if *te > t0 => *te,
                _ => t0 + dur.unwrap_or(0.0),
            },
            Node::Wait { cond: Some(c), .. } => {
                let key = format!("cond@{}", n as *const Node as usize);
                self.conds.push((key.clone(), t0, c));
                match self.cond_events.get(&key) {
                    Some(te) if *te > t0 => *te,
                    _ => t0,
                }
            }
            Node::Emit { event } => {
                self.seen.entry(event.clone()).or_insert(t0);
                t0
            }
            Node::Switch { light, color, at } => {
                self.switches.push((t0, light.clone(), color, at.clone()));
                t0
            }
            Node::Wait { .. } => t0 + dur.unwrap_or(0.0),
        }
    }
}

/// Per-actor motion state while sampling.
#[derive(Clone, Debug)]
struct Motion {
    pos: LanePos,
    v: f64,
    /// Lateral offset from the lane centre (persons beside the road).
    lateral: f64,
    /// Walking direction across the lane (+1 left, −1 right, 0 along).
    across: f64,
    /// Lane change in progress: (from lane, to lane, t start, t end).
    change: Option<(i32, i32, f64, f64)>,
}

fn at_kind(m: &Modifier) -> String {
    match m.args.get("at") {
        Some(CExpr::Const(v)) => v.text().unwrap_or("all").to_string(),
        _ => "all".into(),
    }
}

fn actor_ref(e: Option<&CExpr>, ids: &BTreeMap<String, String>) -> Option<String> {
    match e? {
        CExpr::Var(p) => ids.get(p).cloned().or_else(|| {
            // `sut.car` is its own id; ids are also paths' last segments.
            ids.values().find(|v| *v == p).cloned()
        }),
        _ => None,
    }
}

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
        let (mut p, conds) = plan_once(test, sol, net, step_s, &mut r, &events)?;
        // A time once found is kept: a phase cut at the moment its
        // condition becomes true may keep it from becoming true in the
        // next layout (the cut changes the motion from that sample on), so
        // re-evaluating would oscillate. Times are found in causal order:
        // each round evaluates the conditions not yet timed on a layout
        // that already honours the earlier ones.
        let mut next = events.clone();
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
        if next == events || round == 7 {
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
            if next != events {
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

/// Reads actor attributes from the plan at time `t` (the plan has no
/// yaw or lane to show).
struct PlanScope<'a> {
    plan: &'a Plan,
    t: f64,
}

impl Scope for PlanScope<'_> {
    fn field(&self, id: &str, field: Field) -> Option<f64> {
        let a = self.plan.actors.iter().find(|a| a.id == id)?;
        let s = a.at(self.t, self.plan.dt);
        match field {
            Field::Speed => Some(s.v),
            Field::Acceleration => Some(s.a),
            Field::X => Some(s.x),
            Field::Y => Some(s.y),
            Field::Yaw | Field::Lane => None,
        }
    }
}

/// The first plan sample time at or after `t0` at which a condition holds
/// (`rise`: becomes true; `fall`: becomes false). `Err` when it cannot be
/// evaluated on a plan.
fn cond_time(
    c: &CExpr,
    t0: f64,
    p: &Plan,
    ids: &BTreeMap<String, String>,
) -> Result<Option<f64>, ()> {
    let (edge, inner) = Edge::of(c);
    let n = (p.duration / p.dt).ceil() as usize + 1;
    let mut prev: Option<bool> = None;
    for k in 0..n {
        let t = k as f64 * p.dt;
        if t < t0 - 1e-9 {
            continue;
        }
        let v = crate::expr::truth(inner, ids, &PlanScope { plan: p, t }).ok_or(())?;
        if edge.fires(prev, v) {
            return Ok(Some(t));
        }
        prev = Some(v);
    }
    Ok(None)
}

/// One layout and sampling with state-condition times `cond_events`.
#[allow(clippy::type_complexity)]
fn plan_once(
    test: &Test,
    sol: &Solution,
    net: &RoadNetwork,
    step_s: f64,
    rng: &mut Rng,
    cond_events: &BTreeMap<String, f64>,
) -> Result<(Plan, Vec<(String, f64, CExpr)>), ScenarioError> {
    let Some(root) = &test.root else {
        return Err(ScenarioError::no_behaviour());
    };
    let mut timer = Timer {
        rng,
        sol,
        leaves: Vec::new(),
        events: BTreeMap::new(),
        seen: BTreeMap::new(),
        choice: BTreeMap::new(),
        until_after: BTreeMap::new(),
        switches: Vec::new(),
        bad_duration: None,
        cond_events,
        conds: Vec::new(),
    };
    let mut memo = BTreeMap::new();
    fn visit<'a>(t: &mut Timer<'a>, n: &'a Node, memo: &mut BTreeMap<*const Node, Option<f64>>) {
        t.natural(n, memo);
        if let Node::Serial { children, .. }
        | Node::Parallel { children, .. }
        | Node::OneOf { children, .. } = n
        {
            for c in children {
                visit(t, c, memo);
            }
        }
    }
    visit(&mut timer, root, &mut memo);
    // Waits and untils read event times that the layout itself produces:
    // lay out again with the last pass's times until they stop changing.
    let mut duration = 0.0;
    for _ in 0..16 {
        timer.leaves.clear();
        timer.seen.clear();
        timer.switches.clear();
        timer.conds.clear();
        duration = timer.assign(root, 0.0, None, &mut memo).max(step_s);
        if timer.seen == timer.events {
            break;
        }
        timer.events = std::mem::take(&mut timer.seen);
    }
    if let Some(msg) = timer.bad_duration.take() {
        return Err(ScenarioError::Plan(msg));
    }
    if duration.is_nan() || duration > MAX_DURATION_S {
        return Err(ScenarioError::Plan(format!(
            "the behaviour lasts {duration} s; litesim plans at most {MAX_DURATION_S} s per test (check the `duration` modifiers)"
        )));
    }
    let Timer {
        rng,
        leaves,
        switches,
        conds,
        events,
        ..
    } = timer;
    let conds: Vec<(String, f64, CExpr)> = conds
        .into_iter()
        .map(|(k, t, c)| (k, t, c.clone()))
        .collect();
    let mut lights = Vec::new();
    for (t, path, color, at) in switches {
        let light = sol
            .values
            .get(&format!("{path}.light_id"))
            .and_then(|v| v.text().map(String::from))
            .ok_or_else(|| {
                ScenarioError::Plan(format!(
                    "{at}: traffic light '{path}' names no light: add `keep(it.light_id == \"…\")` with a signal or controller id of the map"
                ))
            })?;
        let color = eval(color, sol, rng)
            .and_then(|v| v.text().map(String::from))
            .ok_or_else(|| {
                ScenarioError::Plan(format!("{at}: switch needs red, yellow or green"))
            })?;
        lights.push(LightSwitch { t, light, color });
    }
    lights.sort_by(|a, b| a.t.total_cmp(&b.t));
    let ids: BTreeMap<String, String> = test
        .actors
        .iter()
        .map(|a| (a.path.clone(), a.id.clone()))
        .collect();
    let mut notes = Vec::new();
    let mut violations = Vec::new();
    let mut goals: Vec<GapGoal> = Vec::new();
    let mut lane_goals: Vec<LaneGoal> = Vec::new();
    let mut side_follows: Vec<SideFollow> = Vec::new();

    // Resolve each leaf's modifier arguments once, in time order (seeded).
    let mut leaves = leaves;
    leaves.sort_by(|a, b| a.t0.total_cmp(&b.t0).then(a.actor.cmp(&b.actor)));
    struct RLeaf {
        actor: String,
        action: Action,
        label: Option<String>,
        t0: f64,
        t1: f64,
        at: String,
        mods: Vec<Intent>,
        /// Where each of `mods` is written (`file:line:col`).
        mod_at: Vec<String>,
    }
    let mut rleaves = Vec::new();
    for l in &leaves {
        let mut mods = Vec::new();
        let mut mod_at = Vec::new();
        for m in &l.mods {
            let mut vals = BTreeMap::new();
            let mut refs = BTreeMap::new();
            for (k, e) in &m.args {
                if let Some(a) = actor_ref(Some(e), &ids) {
                    refs.insert(k.clone(), a);
                } else if let Some(v) = eval(e, sol, rng) {
                    vals.insert(k.clone(), v);
                }
            }
            if let Some(i) = Intent::decode(&m.name, &at_kind(m), &vals, &refs) {
                mods.push(i);
                mod_at.push(m.at.clone());
            }
        }
        rleaves.push(RLeaf {
            actor: l.actor.clone(),
            action: l.action,
            label: l.label.clone(),
            t0: l.t0,
            t1: l.t1,
            at: l.at.clone(),
            mods,
            mod_at,
        });
    }

    // Actor attributes from the solution.
    let attr = |a: &ActorDef, k: &str| sol.values.get(&format!("{}.{k}", a.path)).cloned();
    let mut plans: Vec<ActorPlan> = test
        .actors
        .iter()
        .map(|a| {
            let category = attr(a, "vehicle_category")
                .and_then(|v| v.text().map(String::from))
                .unwrap_or_else(|| {
                    match a.kind {
                        ActorClass::Vehicle => "car",
                        ActorClass::Person => "pedestrian",
                        ActorClass::Cyclist => "bicycle",
                        ActorClass::Animal => "animal",
                        ActorClass::Stationary => "static",
                    }
                    .into()
                });
            let (dl, dw) = match a.kind {
                ActorClass::Vehicle => match category.as_str() {
                    "truck" | "semitrailer" => (10.0, 2.5),
                    "bus" => (12.0, 2.55),
                    "van" => (5.2, 2.0),
                    "motorbike" => (2.2, 0.8),
                    _ => (4.6, 1.9),
                },
                ActorClass::Person => (0.5, 0.5),
                ActorClass::Cyclist => (1.8, 0.6),
                ActorClass::Animal => (1.2, 0.5),
                ActorClass::Stationary => (1.0, 1.0),
            };
            let length = attr(a, "bbox.length").and_then(|v| v.num()).unwrap_or(dl);
            let width = attr(a, "bbox.width").and_then(|v| v.num()).unwrap_or(dw);
            let mut p = ActorPlan::new(a.id.clone(), a.kind, a.ego, category, (length, width));
            p.model = attr(a, "model")
                .and_then(|v| v.text().map(String::from))
                .filter(|m| !m.is_empty());
            p
        })
        .collect();
    // Actors that take part in no phase are not planned (nor created).
    let active: Vec<bool> = plans
        .iter()
        .map(|p| rleaves.iter().any(|l| l.actor == p.id))
        .collect();

    // Placement, in dependency order.
    let first_leaf = |id: &str| rleaves.iter().find(|l| l.actor == id);
    let mut placed: BTreeMap<String, Motion> = BTreeMap::new();
    let mut unplaced = Vec::new();
    let roads_ok: Vec<usize> = (0..net.roads().len())
        .filter(|i| {
            let r = &net.roads()[*i];
            r.junction.is_none()
                && r.sections
                    .iter()
                    .any(|s| s.left.iter().chain(s.right.iter()).any(|l| l.is_drivable()))
        })
        .collect();
    if roads_ok.is_empty() {
        return Err(ScenarioError::Plan(
            "the map has no drivable road outside junctions".into(),
        ));
    }
    let order: Vec<usize> = (0..plans.len()).filter(|i| active[*i]).collect();
    let mut pending = order.clone();
    let mut guard = 0;
    // Placing does not change the plans: one index for every placement.
    let index = plans_index(&plans);
    while !pending.is_empty() {
        guard += 1;
        if guard > plans.len() + 2 {
            let ids: Vec<&str> = pending.iter().map(|i| plans[*i].id.as_str()).collect();
            return Err(ScenarioError::Plan(format!(
                "placement depends on itself (position/lane relations form a cycle): {}",
                ids.join(", ")
            )));
        }
        let mut next = Vec::new();
        for &i in &pending {
            let id = plans[i].id.clone();
            let leaf = first_leaf(&id).expect("active actors have a leaf");
            let deps: Vec<&str> = leaf
                .mods
                .iter()
                .filter(|m| m.at() != At::End)
                .flat_map(Intent::references)
                .collect();
            if deps.iter().any(|d| *d != id && !placed.contains_key(*d)) {
                next.push(i);
                continue;
            }
            let m = place(
                net,
                &plans,
                i,
                leaf.mods.as_slice(),
                &placed,
                &index,
                rng,
                &roads_ok,
                (&leaf.at, &leaf.mod_at),
                &mut unplaced,
            )?;
            placed.insert(id, m);
        }
        pending = next;
    }

    // Motion, sampled every plan step, actors without dependencies on
    // others' futures first (position at: end reads the other's plan).
    let plan_dt = step_s * (0.1 / step_s).round().max(1.0);
    let n = (duration / plan_dt).ceil() as usize + 1;
    // An actor's motion reads other actors' plans only for `position(…,
    // at: end)`: the actors without it (sorted first) are independent of
    // one another and move on all cores, their outputs gathered in order;
    // the others follow one by one. The same results either way.
    let ties = |i: usize| {
        rleaves
            .iter()
            .filter(|l| l.actor == plans[i].id)
            .flat_map(|l| l.mods.iter())
            .any(|m| {
                matches!(
                    m,
                    Intent::Position {
                        reference: Some(_),
                        at: At::End,
                        ..
                    }
                )
            })
    };
    // Independent actors first, each side in its order (a stable sort on
    // `ties`, with `ties` looked at once per actor).
    let (mut order, tied): (Vec<usize>, Vec<usize>) = order.into_iter().partition(|&i| !ties(i));
    let free = order.len();
    order.extend(tied);
    let motion = |i: usize, plans: &[ActorPlan]| -> Result<Moved, ScenarioError> {
        let mut violations = Vec::new();
        let mut notes = Vec::new();
        let mut goals = Vec::new();
        let mut lane_goals = Vec::new();
        let mut side_follows = Vec::new();
        let id = plans[i].id.clone();
        let mut mo = placed[&id].clone();
        let my: Vec<&RLeaf> = rleaves.iter().filter(|l| l.actor == id).collect();
        let mut samples = Vec::with_capacity(n);
        let mut leaf_i = 0;
        // Target speed profile state.
        let mut target: Option<f64> = None;
        let mut accel_up = ACCEL_UP;
        let mut accel_down = ACCEL_DOWN;
        let mut end_speed: Option<(f64, f64, f64)> = None; // (v0, v1, t1) linear
        let mut strict_speed: Option<(f64, String)> = None;
        let mut stationary = false;
        // Reached a lane end with no continuation: stands there from then on.
        let mut dead_end = false;
        let mut started: Option<usize> = None;
        // `along(road, at: end)`: (phase end, road id, place) to verify.
        let mut along_end: Vec<(f64, String, String)> = Vec::new();
        // The lane-centre pose the last move computed at the place it
        // reached (reused where the next sample starts from that place).
        let mut reached: Option<(LanePos, litesim_core::Pose)> = None;
        for k in 0..n {
            let t = k as f64 * plan_dt;
            // A lane change that ends now is done before the phases that
            // start now are entered: a second `change_lane` right after a
            // first starts from the lane the first reached.
            if let Some((_, to, _, c1)) = mo.change
                && c1 <= t + 1e-9
            {
                mo.pos.lane = to;
                mo.change = None;
            }
            // Phases that end now and asked to end on a road.
            along_end.retain(|(t1, road, at)| {
                if *t1 > t + 1e-9 {
                    return true;
                }
                let here = &net.roads()[mo.pos.road].id;
                if here != road {
                    violations.push(format!(
                        "{at}: {id} should end its phase on road {road} (along …, at: end) but is on road {here} at t = {t:.1} s"
                    ));
                }
                false
            });
            // Enter phases that start now.
            while leaf_i < my.len() && my[leaf_i].t0 <= t + 1e-9 {
                let l = my[leaf_i];
                started = Some(leaf_i);
                stationary = l.action == Action::RemainStationary;
                end_speed = None;
                accel_up = ACCEL_UP;
                accel_down = ACCEL_DOWN;
                let first = leaf_i == 0;
                for m in &l.mods {
                    match m {
                        Intent::Along {
                            road: Some(road),
                            at: At::End,
                            ..
                        } => {
                            along_end.push((l.t1, road.clone(), l.at.clone()));
                        }
                        Intent::Lateral {
                            side_of: Some(o),
                            at,
                            ..
                        } if *at != At::End => side_follows.push(SideFollow {
                            actor: id.clone(),
                            reference: o.clone(),
                            t0: l.t0,
                            t1: l.t1,
                        }),
                        Intent::Acceleration { accel, .. } => {
                            accel_up = accel.abs().max(0.1);
                            accel_down = accel.abs().max(0.1);
                        }
                        &Intent::Speed {
                            speed: v,
                            at,
                            strict,
                            ..
                        } => match at {
                            At::End => end_speed = Some((mo.v, v, l.t1)),
                            _ => {
                                if first || (at == At::Start && k == 0) {
                                    mo.v = v;
                                }
                                target = Some(v);
                                if strict && !first {
                                    strict_speed = Some((v, l.at.clone()));
                                }
                            }
                        },
                        Intent::Position {
                            distance,
                            reference: Some((order, o)),
                            at: At::End,
                            strict,
                            ..
                        } => {
                            let sign = order.sign();
                            if let Some(op) = plans.iter().find(|p| p.id == *o)
                                && !op.samples.is_empty()
                            {
                                let distance = distance.unwrap_or(5.0);
                                goals.push(GapGoal {
                                    actor: id.clone(),
                                    reference: o.clone(),
                                    distance,
                                    sign,
                                    t0: l.t0,
                                    t1: l.t1,
                                    strict: *strict,
                                    at: l.at.clone(),
                                    label: l.label.clone(),
                                });
                                let gap = distance + (op.length + plans[i].length) / 2.0;
                                let me = net.lane_pos_pose(mo.pos, 0.0);
                                let here_other = op.at(t, plan_dt);
                                // Distance the other covers plus the change of gap.
                                let now_gap = litesim_core::ahead_along(
                                    litesim_core::Vec2::new(here_other.x, here_other.y),
                                    here_other.yaw,
                                    litesim_core::Vec2::new(me.position.x, me.position.y),
                                );
                                let other_travel = travel(op, t, l.t1, plan_dt);
                                let need = other_travel + sign * gap - now_gap;
                                let dur = (l.t1 - t).max(plan_dt);
                                let v1 = (2.0 * need / dur - mo.v).max(0.0);
                                end_speed = Some((mo.v, v1, l.t1));
                            }
                        }
                        &Intent::ChangeLane {
                            lanes: nl, side, ..
                        } => {
                            let d = if side == Side::Right { -nl } else { nl };
                            let to = net.lane_beside(mo.pos, d).ok_or_else(|| {
                                ScenarioError::Plan(format!(
                                    "{}: {id} cannot change {nl} lane(s) to the {} on road {} (lane {})",
                                    l.at,
                                    if side == Side::Right { "right" } else { "left" },
                                    net.roads()[mo.pos.road].id,
                                    mo.pos.lane
                                ))
                            })?;
                            if to != mo.pos.lane {
                                let len = (l.t1 - l.t0).clamp(2.0, 6.0);
                                mo.change = Some((mo.pos.lane, to, l.t0, l.t0 + len));
                            }
                        }
                        Intent::Lane {
                            lane,
                            reference,
                            at: At::End,
                            strict,
                        } => {
                            if let Some((rel, o)) = reference {
                                lane_goals.push(LaneGoal {
                                    actor: id.clone(),
                                    reference: o.clone(),
                                    relation: *rel,
                                    t0: l.t0,
                                    t1: l.t1,
                                    strict: *strict,
                                    at: l.at.clone(),
                                });
                            }
                            let to = match reference {
                                Some((rel, o)) => placed.get(o).map(|m| m.pos).and_then(|olp| {
                                    let base = LanePos {
                                        s: mo.pos.s,
                                        road: mo.pos.road,
                                        lane: olp.lane,
                                    };
                                    match rel {
                                        LaneRelation::SameAs => Some(olp.lane),
                                        r => net.lane_beside(base, r.offset()),
                                    }
                                }),
                                None => lane.and_then(|n| {
                                    let lanes = net.lanes_same_way(
                                        mo.pos.road,
                                        mo.pos.s,
                                        net.travels_forward(mo.pos),
                                    );
                                    lanes.get(lane_index(lanes.len(), n)).copied()
                                }),
                            };
                            if let Some(to) = to
                                && to != mo.pos.lane
                            {
                                let len = (l.t1 - l.t0).clamp(2.0, 6.0);
                                mo.change = Some((mo.pos.lane, to, l.t0, l.t0 + len));
                            }
                        }
                        _ => {}
                    }
                }
                leaf_i += 1;
            }
            // Speed this sample.
            let prev_v = mo.v;
            if stationary || dead_end {
                mo.v = 0.0;
            } else if let Some((v0, v1, t1)) = end_speed {
                let l = &my[started.unwrap_or(0)];
                let u = ((t - l.t0) / (t1 - l.t0).max(1e-9)).clamp(0.0, 1.0);
                mo.v = v0 + (v1 - v0) * u;
                if u >= 1.0 {
                    end_speed = None;
                    target = Some(v1);
                }
            } else if let Some(v) = target {
                let dv = v - mo.v;
                let step = if dv > 0.0 { accel_up } else { accel_down } * plan_dt;
                mo.v += dv.clamp(-step, step);
                if let Some((sv, _)) = &strict_speed
                    && (mo.v - sv).abs() < 1e-6
                {
                    strict_speed = None;
                }
            }
            // Lane change.
            let mut lat_rate = 0.0;
            // The lane-centre pose at mo.pos, when this sample computes it
            // (reused by the move below).
            let mut centre = None;
            let p = if let Some((from, to, c0, c1)) = mo.change {
                let u = ((t - c0) / (c1 - c0)).clamp(0.0, 1.0);
                let sm = u * u * (3.0 - 2.0 * u);
                let a = net.lane_pos_pose(
                    LanePos {
                        lane: from,
                        ..mo.pos
                    },
                    0.0,
                );
                let b = net.lane_pos_pose(LanePos { lane: to, ..mo.pos }, 0.0);
                let width = a.position.xy().distance(b.position.xy());
                lat_rate = width * 6.0 * u * (1.0 - u) / (c1 - c0);
                if b.yaw.is_finite() {
                    let (sa, ca) = math::sin_cos(a.yaw);
                    let side = ((b.position.x - a.position.x) * -sa
                        + (b.position.y - a.position.y) * ca)
                        .signum();
                    lat_rate *= side;
                }
                if u >= 1.0 {
                    mo.pos.lane = to;
                    mo.change = None;
                }
                let mut q = a;
                q.position.x = a.position.x + (b.position.x - a.position.x) * sm;
                q.position.y = a.position.y + (b.position.y - a.position.y) * sm;
                q
            } else {
                let c = match reached {
                    Some((at, c)) if at == mo.pos => c,
                    _ => net.lane_pos_pose(mo.pos, 0.0),
                };
                centre = Some(c);
                c
            };
            let (s_yaw, c_yaw) = math::sin_cos(p.yaw);
            let x = p.position.x - s_yaw * mo.lateral;
            let y = p.position.y + c_yaw * mo.lateral;
            let mut yaw = p.yaw;
            if mo.across != 0.0 {
                yaw = wrap_angle(p.yaw + mo.across * std::f64::consts::FRAC_PI_2);
            } else if mo.v > 0.1 && lat_rate != 0.0 {
                yaw = wrap_angle(p.yaw + math::atan(lat_rate / mo.v));
            }
            if plans[i].kind == ActorClass::Stationary {
                yaw = p.yaw;
            }
            samples.push(PlanSample {
                t,
                x,
                y,
                yaw,
                v: mo.v,
                a: (mo.v - prev_v) / plan_dt,
            });
            // Move.
            if mo.across != 0.0 {
                mo.lateral += mo.across * mo.v * plan_dt;
            } else {
                let before = mo.pos;
                let (to, pose) = net.advance_path_pose(mo.pos, mo.v * plan_dt, centre);
                mo.pos = to;
                reached = pose.map(|c| (to, c));
                if mo.v > 0.0 && mo.pos == before && !dead_end {
                    dead_end = true;
                    notes.push(format!(
                        "{id} reaches the end of road {} lane {} at t = {t:.1} s: no lane continues, it stops there",
                        net.roads()[mo.pos.road].id,
                        mo.pos.lane
                    ));
                }
            }
        }
        if let Some((v, at)) = strict_speed {
            violations.push(format!(
                "{at}: {id} does not reach the strict speed {:.2} m/s within its phase at {ACCEL_UP}/{ACCEL_DOWN} m/s² (use run_mode: best_effort or an acceleration modifier)",
                v
            ));
        }
        Ok(Moved {
            samples,
            violations,
            notes,
            goals,
            lane_goals,
            side_follows,
        })
    };
    let mut gather = |i: usize, plans: &mut [ActorPlan], m: Moved| {
        plans[i].samples = m.samples;
        violations.extend(m.violations);
        notes.extend(m.notes);
        goals.extend(m.goals);
        lane_goals.extend(m.lane_goals);
        side_follows.extend(m.side_follows);
    };
    let moved: Vec<Result<Moved, ScenarioError>> = if free >= crate::PARALLEL_ACTORS {
        use rayon::prelude::*;
        order[..free]
            .par_iter()
            .map(|&i| motion(i, &plans))
            .collect()
    } else {
        order[..free].iter().map(|&i| motion(i, &plans)).collect()
    };
    for (&i, m) in order[..free].iter().zip(moved) {
        gather(i, &mut plans, m?);
    }
    for &i in &order[free..] {
        let m = motion(i, &plans)?;
        gather(i, &mut plans, m);
    }
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
    let keep: Vec<ActorPlan> = plans
        .into_iter()
        .zip(active)
        .filter_map(|(p, a)| a.then_some(p))
        .collect();
    if keep.is_empty() {
        notes.push("no actor takes part in the behaviour".into());
    }
    goals.sort_by(|a, b| a.t1.total_cmp(&b.t1).then(a.actor.cmp(&b.actor)));
    Ok((
        Plan {
            dt: plan_dt,
            duration,
            actors: keep,
            phases,
            violations,
            unplaced,
            lights,
            goals,
            lane_goals,
            side_follows,
            conditions: Vec::new(),
            ids: BTreeMap::new(),
            events,
            notes,
        },
        conds,
    ))
}

/// One actor's planned motion and what planning it found.
struct Moved {
    samples: Vec<PlanSample>,
    violations: Vec<String>,
    notes: Vec<String>,
    goals: Vec<GapGoal>,
    lane_goals: Vec<LaneGoal>,
    side_follows: Vec<SideFollow>,
}

fn plans_index(plans: &[ActorPlan]) -> BTreeMap<String, usize> {
    plans
        .iter()
        .enumerate()
        .map(|(i, p)| (p.id.clone(), i))
        .collect()
}

/// Distance an actor's plan covers between two times.
fn travel(p: &ActorPlan, t0: f64, t1: f64, dt: f64) -> f64 {
    let mut d = 0.0;
    let mut t = t0;
    while t < t1 - 1e-9 {
        let h = dt.min(t1 - t);
        d += p.at(t, dt).v * h;
        t += h;
    }
    d
}

#[allow(clippy::too_many_arguments)]
fn place(
    net: &RoadNetwork,
    plans: &[ActorPlan],
    i: usize,
    mods: &[Intent],
    placed: &BTreeMap<String, Motion>,
    index: &BTreeMap<String, usize>,
    rng: &mut Rng,
    roads_ok: &[usize],
    (at, mod_at): (&str, &[String]),
    unplaced: &mut Vec<String>,
) -> Result<Motion, ScenarioError> {
    let me = &plans[i];
    check_start_combination(net, me, mods, mod_at, placed)?;
    // The modifiers that shape the start (`at: end` ones are goals).
    let starting = || mods.iter().filter(|m| m.at() != At::End);
    let mut mo = Motion {
        pos: LanePos {
            road: roads_ok[0],
            lane: 0,
            s: 0.0,
        },
        v: 0.0,
        lateral: 0.0,
        across: 0.0,
        change: None,
    };
    // Road: along(road) or the reference actor's, else a seeded choice.
    let along = starting().find_map(|m| match m {
        Intent::Along {
            road, start_offset, ..
        } => Some((road.clone(), *start_offset)),
        _ => None,
    });
    let along_road = along.as_ref().and_then(|a| a.0.clone());
    let reference: Option<String> = [
        RefKind::AheadOf,
        RefKind::Behind,
        RefKind::SameAs,
        RefKind::LeftOf,
        RefKind::RightOf,
        RefKind::SideOf,
    ]
    .into_iter()
    .find_map(|k| starting().find_map(|m| m.reference(k).map(String::from)));
    let lane_mod = starting().find_map(|m| match m {
        Intent::Lane {
            lane, reference, ..
        } => Some((*lane, reference.clone())),
        _ => None,
    });
    if let Some(o) = &reference
        && let Some(om) = placed.get(o)
    {
        mo.pos = om.pos;
        // `lane(n)` beside a position relative to `o`: lane n of o's road
        // in o's direction of travel (d along o's lane, below).
        if let Some((Some(n), None)) = &lane_mod {
            let fwd = net.travels_forward(om.pos);
            let lanes = net.lanes_same_way(om.pos.road, om.pos.s, fwd);
            mo.pos.lane = *lanes.get(lane_index(lanes.len(), *n)).ok_or_else(|| {
                ScenarioError::Plan(format!(
                    "{at}: lane {n} asked for {} beside {o}, but road {} has {} lane(s) that way",
                    me.id,
                    net.roads()[om.pos.road].id,
                    lanes.len()
                ))
            })?;
        }
    } else {
        let road = match &along_road {
            Some(id) => net.road_index(id).ok_or_else(|| {
                ScenarioError::Plan(format!("{at}: road '{id}' is not in the map"))
            })?,
            None => roads_ok[(rng.next_u64() % roads_ok.len() as u64) as usize],
        };
        mo.pos.road = road;
        let r = &net.roads()[road];
        // Lanes going either way; prefer forward lanes, then any.
        let mut lanes = net.lanes_same_way(road, 0.01, true);
        if lanes.is_empty() {
            lanes = net.lanes_same_way(road, 0.01, false);
        }
        if lanes.is_empty() {
            return Err(ScenarioError::Plan(format!(
                "{at}: road {} has no driving lane",
                r.id
            )));
        }
        let lane = match lane_mod.as_ref().and_then(|m| m.0) {
            Some(n) => *lanes.get(lane_index(lanes.len(), n)).ok_or_else(|| {
                ScenarioError::Plan(format!(
                    "{at}: lane {} asked for {} but road {} has {} lane(s) that way",
                    if n < 0.0 {
                        format!("{} from the left", -n)
                    } else {
                        n.to_string()
                    },
                    me.id,
                    r.id,
                    lanes.len()
                ))
            })?,
            None => lanes[(rng.next_u64() % lanes.len() as u64) as usize],
        };
        mo.pos.lane = lane;
        let offset = along.as_ref().and_then(|a| a.1);
        // A free s: clear of every placed actor on this road by their lengths + 5 m.
        let margin = me.length / 2.0 + 5.0;
        let lo = margin.min(r.length / 2.0);
        let hi = (r.length * 0.5).max(lo);
        if let Some(o) = offset
            && !(0.0..=r.length).contains(&o)
        {
            unplaced.push(format!(
                "{at}: {} could not be placed {o:.1} m along road {}: the road is {:.1} m long",
                me.id, r.id, r.length
            ));
        }
        let mut s = offset.unwrap_or_else(|| sample(lo, hi, rng));
        let clear = |s: f64| {
            placed.iter().all(|(oid, om)| {
                let ol = index.get(oid).map_or(4.0, |k| plans[*k].length);
                om.pos.road != road
                    || om.pos.lane != lane
                    || (om.pos.s - s).abs() > (ol + me.length) / 2.0 + 5.0
            })
        };
        for _ in 0..50 {
            if clear(s) {
                break;
            }
            s += (me.length + 10.0).min(r.length / 8.0).max(1.0);
            if s > r.length - margin.min(r.length / 4.0) {
                s = lo;
            }
        }
        // An explicit offset is where the author put the actor (another
        // actor there is the author's choice); a free place that every try
        // found taken is a scenario that could not be set up.
        if offset.is_none() && !clear(s) {
            unplaced.push(format!(
                "{at}: {} could not be placed: no free place in road {} lane {lane} \
                 ({:.0} m, {} actor(s) already there)",
                me.id,
                r.id,
                r.length,
                placed
                    .values()
                    .filter(|om| om.pos.road == road && om.pos.lane == lane)
                    .count()
            ));
        }
        mo.pos.s = s.clamp(0.0, r.length);
        // Point the lane's s at its direction of travel: s runs backwards on backward lanes.
        if !net.travels_forward(mo.pos) {
            mo.pos.s = (r.length - mo.pos.s).clamp(0.0, r.length);
        }
    }
    // Lane relative to another actor.
    if let Some((_, Some((rel, o)))) = &lane_mod
        && let Some(om) = placed.get(o)
    {
        let base = LanePos {
            lane: om.pos.lane,
            ..mo.pos
        };
        mo.pos.lane = match rel {
            LaneRelation::SameAs => om.pos.lane,
            r => net.lane_beside(base, r.offset()).ok_or_else(|| {
                ScenarioError::Plan(format!(
                    "{at}: no lane {} of {o} on road {} for {}",
                    if *r == LaneRelation::LeftOf {
                        "left"
                    } else {
                        "right"
                    },
                    net.roads()[base.road].id,
                    me.id
                ))
            })?,
        };
    }
    // Longitudinal relation.
    if let Some((k, distance, time, order, o)) = mods
        .iter()
        .enumerate()
        .filter(|(_, m)| m.at() != At::End)
        .find_map(|(k, m)| match m {
            Intent::Position {
                distance,
                time,
                reference,
                ..
            } => Some((k, *distance, *time, reference.clone())),
            _ => None,
        })
        .and_then(|(k, d, t, r)| r.map(|(order, o)| (k, d, t, order, o)))
        && let Some(om) = placed.get(&o)
    {
        let ol = index.get(&o).map_or(4.6, |j| plans[*j].length);
        let d = match (distance, time) {
            (Some(d), _) => d,
            (None, Some(t)) => t * om.v,
            _ => 10.0,
        };
        let gap = d + (ol + me.length) / 2.0;
        let lane = mo.pos.lane;
        let base = LanePos {
            lane: om.pos.lane,
            ..om.pos
        };
        let (end, rest) = net.advance_rest(base, order.sign() * gap);
        if rest > 0.01 {
            let road = &net.roads()[end.road];
            unplaced.push(format!(
                "{}: {} could not be placed {d:.1} m {} {o}: {o}'s lane (road {} lane {}) \
                 ends {:.1} m {} it, {rest:.1} m short",
                mod_at.get(k).map_or(at, String::as_str),
                me.id,
                order.word(),
                road.id,
                end.lane,
                (gap - rest - (ol + me.length) / 2.0).max(0.0),
                if order.sign() > 0.0 {
                    "ahead of"
                } else {
                    "behind"
                },
            ));
        }
        mo.pos = net.advance_path(base, order.sign() * gap, None);
        mo.pos.lane = lane;
    }
    // Beside another actor (people, cyclists at the kerb).
    if let Some((d, side)) = starting().find_map(|m| match m {
        Intent::Lateral { distance, side, .. } => Some((*distance, *side)),
        _ => None,
    }) {
        let sgn = if side == Side::Left { 1.0 } else { -1.0 };
        mo.lateral = sgn * d;
        if me.kind == ActorClass::Person || me.kind == ActorClass::Animal {
            mo.across = -sgn; // walk towards and across the lane
        }
    }
    // Initial speed: a speed modifier of the first phase (at start/all), else
    // the reference actor's speed, else a seeded 30–50 km/h for vehicles.
    let v0 = starting().find_map(|m| match m {
        Intent::Speed {
            speed,
            change: false,
            ..
        } => Some(*speed),
        _ => None,
    });
    mo.v = match (v0, me.kind) {
        (Some(v), _) => v,
        (None, ActorClass::Stationary) => 0.0,
        (None, ActorClass::Person | ActorClass::Animal) => WALK_SPEED,
        (None, _) => match &reference {
            Some(o) if placed.contains_key(o) => placed[o].v,
            _ => sample(30.0 / 3.6, 50.0 / 3.6, rng),
        },
    };
    Ok(mo)
}

/// Refuses start modifiers that cannot all hold, naming each: two that
/// both fix the lane, or `along(r)` with a position relative to an actor
/// on another road. (`lane(n)` with `position(…, ahead_of: x)` holds: the
/// actor stands in lane n, d along x's lane.)
fn check_start_combination(
    net: &RoadNetwork,
    me: &ActorPlan,
    mods: &[Intent],
    mod_at: &[String],
    placed: &BTreeMap<String, Motion>,
) -> Result<(), ScenarioError> {
    let starting: Vec<(usize, &Intent)> = mods
        .iter()
        .enumerate()
        .filter(|(_, m)| m.at() != At::End)
        .collect();
    let where_ = |k: usize| mod_at.get(k).map_or("?", String::as_str);
    let lanes: Vec<usize> = starting
        .iter()
        .filter(|(_, m)| matches!(m, Intent::Lane { .. }))
        .map(|(k, _)| *k)
        .collect();
    if lanes.len() > 1 {
        return Err(ScenarioError::Plan(format!(
            "{}: lane(…) and {}: lane(…) both set {}'s lane at the start; only one can hold",
            where_(lanes[0]),
            where_(lanes[1]),
            me.id
        )));
    }
    let along = starting.iter().find_map(|(k, m)| match m {
        Intent::Along { road: Some(r), .. } => Some((*k, r.clone())),
        _ => None,
    });
    let position = starting.iter().find_map(|(k, m)| match m {
        Intent::Position {
            reference: Some((_, o)),
            ..
        } => Some((*k, o.clone())),
        _ => None,
    });
    if let (Some((ka, road)), Some((kp, o))) = (along, position)
        && let Some(om) = placed.get(&o)
        && net.road_index(&road).is_some_and(|r| r != om.pos.road)
    {
        return Err(ScenarioError::Plan(format!(
            "{}: along({road}) and {}: position(…, {o}) cannot both hold for {}: {o} starts on road {}",
            where_(ka),
            where_(kp),
            me.id,
            net.roads()[om.pos.road].id
        )));
    }
    Ok(())
}

/// The index in a right-to-left list of `len` lanes of lane number `n`
/// (1 = rightmost; negative counts from the left, −1 = leftmost; 0 reads
/// as 1, as it always has); out of range gives `len` (no such lane).
fn lane_index(len: usize, n: f64) -> usize {
    let k = n.abs() as usize;
    if k == 0 {
        0
    } else if k > len {
        len
    } else if n < 0.0 {
        len - k
    } else {
        k - 1
    }
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
                        x: r * th.sin(),
                        y: r * (1.0 - th.cos()),
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
