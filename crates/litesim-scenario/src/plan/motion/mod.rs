//! Each actor's motion, sampled every plan step: speed, lane changes,
//! walking across, the goals its phases set.

use super::*;

mod exact;
mod path;
mod sideways;

/// Per-actor motion state while sampling.
#[derive(Clone, Debug)]
pub(super) struct Motion {
    pub(super) pos: LanePos,
    pub(super) v: f64,
    /// Lateral offset from the lane centre (persons beside the road).
    pub(super) lateral: f64,
    /// Walking direction across the lane (+1 left, −1 right, 0 along).
    pub(super) across: f64,
    /// Lane change in progress: (from lane, to lane, t start, t end).
    pub(super) change: Option<(i32, i32, f64, f64)>,
}

pub(super) fn at_kind(m: &Modifier) -> String {
    match m.args.get("at") {
        Some(CExpr::Const(v)) => v.text().unwrap_or("all").to_string(),
        _ => "all".into(),
    }
}

pub(super) fn actor_ref(e: Option<&CExpr>, ids: &BTreeMap<String, String>) -> Option<String> {
    match e? {
        CExpr::Var(p) => ids.get(p).cloned().or_else(|| {
            // `sut.car` is its own id; ids are also paths' last segments.
            ids.values().find(|v| *v == p).cloned()
        }),
        _ => None,
    }
}

/// A leaf with its modifiers decoded and their arguments evaluated.
pub(super) struct RLeaf {
    /// The action node's id.
    pub(super) id: u32,
    pub(super) actor: String,
    pub(super) action: Action,
    pub(super) label: Option<String>,
    pub(super) t0: f64,
    pub(super) t1: f64,
    pub(super) at: String,
    pub(super) mods: Vec<Intent>,
    /// Where each of `mods` is written (`file:line:col`).
    pub(super) mod_at: Vec<String>,
    /// Each of `mods` written with `track: projected`: the reference
    /// actor's motion it reads is the one it would have kept from the
    /// phase's start (its speed then, straight on along its heading), not
    /// its actual one.
    pub(super) projected: Vec<bool>,
}

/// Resolves each leaf's modifier arguments once, in time order (seeded):
/// actor references to ids, the rest evaluated on the solution. An
/// argument the engine cannot evaluate (a method call, arithmetic) is an
/// error naming it, not a modifier quietly without it.
pub(super) fn resolve_leaves(
    mut leaves: Vec<Leaf<'_>>,
    ids: &BTreeMap<String, String>,
    sol: &Solution,
    rng: &mut Rng,
) -> Result<Vec<RLeaf>, ScenarioError> {
    leaves.sort_by(|a, b| a.t0.total_cmp(&b.t0).then(a.actor.cmp(&b.actor)));
    let mut rleaves = Vec::with_capacity(leaves.len());
    for l in &leaves {
        let mut mods = Vec::new();
        let mut mod_at = Vec::new();
        let mut projected = Vec::new();
        for m in &l.mods {
            let mut vals = BTreeMap::new();
            let mut refs = BTreeMap::new();
            for (k, e) in &m.args {
                if let Some(a) = actor_ref(Some(e), ids) {
                    refs.insert(k.clone(), a);
                } else if let Some(v) = eval(e, sol, rng) {
                    vals.insert(k.clone(), v);
                } else if m.kind != ModKind::Until
                    && matches!(e, CExpr::Opaque(_) | CExpr::Binary(..) | CExpr::Unary(..))
                {
                    return Err(ScenarioError::Plan(format!(
                        "{}: {}({k}: {}) cannot be evaluated by litesim (a constant, a parameter, a range or a list is)",
                        m.at,
                        m.name,
                        match e {
                            CExpr::Opaque(text) => text.clone(),
                            other => crate::expr::show(other),
                        }
                    )));
                }
            }
            if let Some(mut i) = Intent::decode((m.kind, &m.name), &at_kind(m), &vals, &refs) {
                // change_lane without a side: the standard's random side,
                // drawn with the run's seed.
                if let Intent::ChangeLane {
                    side,
                    side_given: false,
                    ..
                } = &mut i
                {
                    *side = if rng.next_u64().is_multiple_of(2) {
                        Side::Left
                    } else {
                        Side::Right
                    };
                }
                projected.push(vals.get("track").and_then(Value::text) == Some("projected"));
                mods.push(i);
                mod_at.push(m.at.clone());
            }
        }
        rleaves.push(RLeaf {
            id: l.id,
            actor: l.actor.clone(),
            action: l.action,
            label: l.label.clone(),
            t0: l.t0,
            t1: l.t1,
            at: l.at.clone(),
            mods,
            mod_at,
            projected,
        });
    }
    Ok(rleaves)
}

/// One actor's planned motion and what planning it found.
#[derive(Default)]
pub(super) struct Moved {
    pub(super) samples: Vec<PlanSample>,
    pub(super) violations: Vec<String>,
    pub(super) notes: Vec<String>,
    pub(super) goals: Vec<GapGoal>,
    pub(super) lane_goals: Vec<LaneGoal>,
    pub(super) side_follows: Vec<SideFollow>,
    /// How long each `change_speed` action took to reach its target
    /// (`reach@N`, s): its natural duration in the next layout.
    pub(super) reached: Vec<(String, f64)>,
    /// Gaps and headways kept to an actor ahead.
    pub(super) keeps: Vec<super::KeepGoal>,
    /// Phases that do not avoid collisions: (actor, t0, t1).
    pub(super) reckless: Vec<(String, f64, f64)>,
    /// Samples the actor jumps to (`assign_position`).
    pub(super) jumps: Vec<usize>,
    /// Actors whose plan asks for exactness, with the first place that
    /// asks.
    pub(super) exact: BTreeMap<String, String>,
}

/// What every actor's motion reads: the map, the leaves, where each actor
/// starts, the plan's step and length.
pub(super) struct MoveCx<'a> {
    pub(super) net: &'a RoadNetwork,
    pub(super) rleaves: &'a [RLeaf],
    pub(super) placed: &'a BTreeMap<String, Motion>,
    /// The times known from the layouts before (conditions, `reach@N`).
    pub(super) known: &'a BTreeMap<String, f64>,
    /// The test's paths and trajectories.
    pub(super) paths: &'a [crate::elab::PathDef],
    /// Plan step (s).
    pub(super) dt: f64,
    /// Samples per actor.
    pub(super) n: usize,
}

/// Samples every active actor's motion in `order` into `plans` and gathers
/// what planning found. The first `free` actors read no other actor's plan
/// (no `position(…, at: end)`): they move on all cores when there are many,
/// their outputs gathered in order; the others follow one by one. The same
/// results either way.
pub(super) fn move_all(
    cx: &MoveCx<'_>,
    plans: &mut [ActorPlan],
    order: &[usize],
    free: usize,
) -> Result<Moved, ScenarioError> {
    let mut all = Moved::default();
    let mut gather = |i: usize, plans: &mut [ActorPlan], m: Moved| {
        plans[i].samples = m.samples;
        plans[i].jumps = m.jumps;
        all.exact.extend(m.exact);
        all.violations.extend(m.violations);
        all.notes.extend(m.notes);
        all.goals.extend(m.goals);
        all.lane_goals.extend(m.lane_goals);
        all.side_follows.extend(m.side_follows);
        all.reached.extend(m.reached);
        all.keeps.extend(m.keeps);
        all.reckless.extend(m.reckless);
    };
    let moved: Vec<Result<Moved, ScenarioError>> = if free >= crate::PARALLEL_ACTORS {
        use rayon::prelude::*;
        order[..free]
            .par_iter()
            .map(|&i| Mover::new(cx, i, plans).run(plans))
            .collect()
    } else {
        order[..free]
            .iter()
            .map(|&i| Mover::new(cx, i, plans).run(plans))
            .collect()
    };
    for (&i, m) in order[..free].iter().zip(moved) {
        gather(i, plans, m?);
    }
    for &i in &order[free..] {
        let m = Mover::new(cx, i, plans).run(plans)?;
        gather(i, plans, m);
    }
    Ok(all)
}

/// Where modifier `m` of leaf `l` is written (the action's place when it
/// was made for the action).
fn mod_at<'l>(l: &'l RLeaf, m: &Intent) -> &'l str {
    l.mods
        .iter()
        .position(|x| std::ptr::eq(x, m))
        .map_or(l.at.as_str(), |j| l.mod_at[j].as_str())
}

/// Whether `m` (one of `l`'s modifiers) is written with `track: projected`.
fn projected(l: &RLeaf, m: &Intent) -> bool {
    l.mods
        .iter()
        .position(|x| std::ptr::eq(x, m))
        .is_some_and(|j| l.projected[j])
}

/// Whether actor `i`'s motion reads another actor's plan (a `position(…,
/// at: end)` goal): it must move after the others.
pub(super) fn ties(rleaves: &[RLeaf], id: &str) -> bool {
    rleaves
        .iter()
        .filter(|l| l.actor == id)
        .flat_map(|l| l.mods.iter())
        .any(|m| {
            matches!(
                m,
                Intent::Position {
                    reference: Some(_),
                    at: At::End,
                    ..
                } | Intent::Speed {
                    relative: Some(_),
                    ..
                } | Intent::Acceleration {
                    relative: Some(_),
                    ..
                } | Intent::KeepGap { .. }
                    | Intent::LateralGap { .. }
                    | Intent::Yaw {
                        relative_to: Some(_),
                        ..
                    }
                    | Intent::FollowPath {
                        reference: Some(_),
                        ..
                    }
            )
        })
}

/// Whether a modifier sets the actor's speed (and so ends an acceleration
/// an acceleration action set).
fn sets_speed(m: &Intent) -> bool {
    matches!(
        m,
        Intent::Speed { .. }
            | Intent::KeepSpeed { .. }
            | Intent::Distance { .. }
            | Intent::KeepPosition { .. }
            | Intent::KeepGap { .. }
    )
}

/// A heading the plan sets (`yaw`, `assign_orientation`).
#[derive(Clone, Copy, Debug)]
struct Heading {
    /// Radians from the reference.
    angle: f64,
    /// The reference: another actor's plan (index), else the road or north.
    relative_to: Option<usize>,
    /// Compass heading: clockwise from north (+y).
    north: bool,
    /// In the map's frame (0 along +x).
    world: bool,
    /// Kept after its phase while the actor stands.
    hold: bool,
    /// `at: start`: its phase's first sample only (from `t0`); `at: end`:
    /// turned to from the natural heading over the phase `t0`..`t1`.
    when: At,
    t0: f64,
    t1: f64,
}

/// How a target speed follows another actor's planned speed.
#[derive(Clone, Copy, Debug)]
enum Follow {
    /// Its speed plus this offset (m/s): `speed(…, faster_than | slower_than
    /// | same_as: X)`, and a kept space gap (offset 0).
    Offset(f64),
    /// Keeps this time headway (s) to it: `keep_time_headway(X)`.
    Headway(f64),
    /// Brings the gap to it to a target: `change_space_gap` (the gap,
    /// m) or `change_time_headway` (`headway`: gap = target · speed). The
    /// gap now (m) is carried from sample to sample by both speeds.
    Change {
        gap: f64,
        target: f64,
        headway: bool,
        /// It is ahead of the other, which trails it
        /// ([`super::leading_speed`]).
        behind: bool,
    },
    /// Its acceleration plus `offset` (m/s²): `acceleration(…,
    /// faster_than | slower_than | same_as: X)`. The speed is `v0` plus
    /// X's change of speed since `t0` (from `ahead0`) plus `offset` · (t −
    /// t0).
    Accel {
        offset: f64,
        v0: f64,
        ahead0: f64,
        t0: f64,
        /// `track: projected`: X keeps the speed it had at `t0` (its
        /// change since is 0).
        projected: bool,
    },
}

/// The bound (m/s²) on an acceleration that follows another actor's: the
/// planner's hardest braking.
const RELATIVE_ACCEL_BOUND: f64 = 8.0;

/// A `change_*` action under way and what ends it.
#[derive(Clone, Copy, Debug)]
enum Reach {
    /// `change_speed`: this speed (m/s).
    Speed(f64),
    /// `change_space_gap` / `change_time_headway`: its [`Follow::Change`]
    /// target.
    Gap,
    /// A path or trajectory action: the end of its path.
    Path,
    /// `change_acceleration`: this acceleration (m/s²).
    Accel(f64),
    /// `change_position`: level with this point (m).
    Place(f64, f64),
    /// `change_space_gap` sideways: this free space (m) beside the other.
    Side(f64),
}

/// Most acceleration and deceleration a change or keep of the
/// acceleration asks (m/s²): the domain's default vehicle limits.
const ACCEL_LIMITS: (f64, f64) = (-8.0, 4.0);

/// The acceleration an acceleration action set: speed follows it.
#[derive(Clone, Copy, Debug)]
struct Accel {
    /// Now (m/s²).
    a: f64,
    /// Where it goes (m/s²).
    target: f64,
    /// How fast it gets there (m/s³); infinite: at once.
    jerk: f64,
    /// `rate_profile: smooth`: along this half-cosine instead of at a
    /// constant jerk.
    smooth: Option<Ramp>,
}

/// A change along a half-cosine, `from` + (`to` − `from`) · (1 − cos πu)/2
/// with u = (t − `t0`)/`dur`: `rate_profile: smooth`. Its steepest slope,
/// halfway, is π/2 · |to − from| / dur: the `rate_peak` it is made with.
#[derive(Clone, Copy, Debug)]
struct Ramp {
    from: f64,
    to: f64,
    t0: f64,
    dur: f64,
}

impl Ramp {
    /// The ramp from `from` to `to` starting at `t0` whose steepest slope
    /// is `peak`.
    fn new(from: f64, to: f64, t0: f64, peak: f64) -> Self {
        let dur = std::f64::consts::FRAC_PI_2 * (to - from).abs() / peak.abs().max(1e-3);
        Ramp { from, to, t0, dur }
    }

    /// Its value at `t`, and whether it has arrived.
    fn at(&self, t: f64) -> (f64, bool) {
        let u = ((t - self.t0) / self.dur.max(1e-9)).clamp(0.0, 1.0);
        let w = 0.5 * (1.0 - litesim_core::math::cos(std::f64::consts::PI * u));
        (self.from + (self.to - self.from) * w, u >= 1.0)
    }
}

/// A changed space gap is reached within this (m).
pub(super) const GAP_REACHED_M: f64 = 0.25;
/// A changed time headway is reached within this (s).
pub(super) const HEADWAY_REACHED_S: f64 = 0.05;

/// One actor's motion being sampled.
struct Mover<'a> {
    cx: &'a MoveCx<'a>,
    i: usize,
    id: String,
    mo: Motion,
    my: Vec<&'a RLeaf>,
    leaf_i: usize,
    /// Target speed.
    target: Option<f64>,
    /// A `change_*` action under way: its node id, what ends it and its
    /// start.
    reaching: Option<(u32, Reach, f64)>,
    /// A lateral gap kept or changed this phase.
    side_gap: Option<sideways::SideGap>,
    /// The phase's target speed follows another actor's plan at every
    /// sample (a relative speed, a kept gap or headway): that actor's plan
    /// index, how, and the phase's end.
    follow: Option<(usize, Follow, f64)>,
    accel_up: f64,
    accel_down: f64,
    /// A linear speed change to reach by a time: (v0, v1, t1).
    end_speed: Option<(f64, f64, f64)>,
    /// A heading of its own (`yaw`, `assign_orientation`).
    heading: Option<Heading>,
    /// A path or trajectory being followed.
    on_path: Option<path::OnPath>,
    /// Where a path left it, off the roads: it stands there.
    parked: Option<PlanSample>,
    /// An acceleration set by an acceleration action, kept until a phase
    /// sets a speed.
    accel: Option<Accel>,
    /// A `change_speed(…, rate_profile: smooth)` under way.
    smooth: Option<Ramp>,
    /// A sideways offset from the lane's centre to go to (m) at a rate
    /// (m/s): `follow_lane(offset)`, and back to 0 after its phase.
    lane_offset: Option<(f64, f64)>,
    /// A strict speed not reached yet, with its place.
    strict_speed: Option<(f64, String)>,
    stationary: bool,
    /// Reached a lane end with no continuation: stands there from then on.
    dead_end: bool,
    /// The phase entered last.
    started: Option<usize>,
    /// `along(road, at: end)`: (phase end, road id, place) to verify.
    along_end: Vec<(f64, String, String)>,
    /// The lane-centre pose the last move computed at the place it reached
    /// (reused where the next sample starts from that place).
    reached: Option<(LanePos, litesim_core::Pose)>,
    out: Moved,
}

impl<'a> Mover<'a> {
    fn new(cx: &'a MoveCx<'a>, i: usize, plans: &[ActorPlan]) -> Self {
        let id = plans[i].id.clone();
        Mover {
            cx,
            i,
            mo: cx.placed[&id].clone(),
            my: cx.rleaves.iter().filter(|l| l.actor == id).collect(),
            id,
            leaf_i: 0,
            target: None,
            reaching: None,
            side_gap: None,
            follow: None,
            accel_up: ACCEL_UP,
            accel_down: ACCEL_DOWN,
            end_speed: None,
            heading: None,
            on_path: None,
            parked: None,
            accel: None,
            smooth: None,
            lane_offset: None,
            strict_speed: None,
            stationary: false,
            dead_end: false,
            started: None,
            along_end: Vec::new(),
            reached: None,
            out: Moved {
                samples: Vec::with_capacity(cx.n),
                ..Moved::default()
            },
        }
    }

    /// Samples the actor over the whole plan (`plans`: the others' plans so
    /// far, read by `position(…, at: end)`).
    fn run(mut self, plans: &[ActorPlan]) -> Result<Moved, ScenarioError> {
        for k in 0..self.cx.n {
            let t = k as f64 * self.cx.dt;
            // A lane change that ends now is done before the phases that
            // start now are entered: a second `change_lane` right after a
            // first starts from the lane the first reached.
            if let Some((_, to, _, c1)) = self.mo.change
                && c1 <= t + 1e-9
            {
                self.mo.pos.lane = to;
                self.mo.change = None;
            }
            self.check_along_end(t);
            self.gap_reached(t, plans);
            self.side_gap_reached(t, plans);
            self.path_reached(t);
            self.place_reached(t);
            // Enter phases that start now.
            while self.leaf_i < self.my.len() && self.my[self.leaf_i].t0 <= t + 1e-9 {
                match self.enter(k, t, plans) {
                    Ok(()) => {}
                    // Laid out after a change whose time this layout found
                    // (it took the provisional time): the next layout
                    // moves it, and judges it there.
                    Err(_) if self.found_new_reach() => {}
                    Err(e) => return Err(e),
                }
                self.leaf_i += 1;
            }
            self.follow(t, plans);
            self.path_target(t);
            let prev_v = self.mo.v;
            self.speed(t);
            self.note_reached(t, prev_v);
            self.carry_gap(t, plans);
            if let Some(sample) = self.path_sample(t, prev_v) {
                self.out.samples.push(sample);
                self.path_advance();
                continue;
            }
            self.shift_sideways();
            self.shift_to_side_gap(t, plans);
            let (sample, centre) = self.pose(t, prev_v, plans);
            self.out.samples.push(sample);
            self.advance(t, centre);
        }
        self.unreached();
        if let Some((v, at)) = self.strict_speed {
            self.out.violations.push(format!(
                "{at}: {} does not reach the strict speed {:.2} m/s within its phase at {ACCEL_UP}/{ACCEL_DOWN} m/s² (use run_mode: best_effort or an acceleration modifier)",
                self.id, v
            ));
        }
        Ok(self.out)
    }

    /// This layout found how long a `change_*` action takes that the
    /// layout itself did not know (it laid the phases after it out with
    /// [`super::timer::PROVISIONAL_REACH_S`]).
    fn found_new_reach(&self) -> bool {
        self.out
            .reached
            .iter()
            .any(|(key, _)| !self.cx.known.contains_key(key))
    }

    /// Phases that end now and asked to end on a road.
    fn check_along_end(&mut self, t: f64) {
        let net = self.cx.net;
        let (id, pos, violations) = (&self.id, self.mo.pos, &mut self.out.violations);
        self.along_end.retain(|(t1, road, at)| {
            if *t1 > t + 1e-9 {
                return true;
            }
            let here = &net.roads()[pos.road].id;
            if here != road {
                violations.push(format!(
                    "{at}: {id} should end its phase on road {road} (along …, at: end) but is on road {here} at t = {t:.1} s"
                ));
            }
            false
        });
    }

    /// Enters the phase `my[leaf_i]` at sample `k` (time `t`): its
    /// modifiers set the speed profile, lane changes and goals.
    fn enter(&mut self, k: usize, t: f64, plans: &[ActorPlan]) -> Result<(), ScenarioError> {
        let l = self.my[self.leaf_i];
        self.started = Some(self.leaf_i);
        self.stationary = l.action == Action::RemainStationary;
        self.end_speed = None;
        self.smooth = None;
        self.unreached();
        self.leave_path(t);
        self.follow = None;
        self.accel_up = ACCEL_UP;
        self.accel_down = ACCEL_DOWN;
        // A held heading outlives its phase (while the actor stands).
        self.heading = self.heading.filter(|h| h.hold);
        // A lateral gap lasts its phase: it stays where it is across its
        // lane, and goes back to the centre as a lane offset does.
        if self.side_gap.take().is_some() && self.mo.lateral != 0.0 {
            self.lane_offset = Some((0.0, sideways::SIDE_GAP_RATE));
        }
        // A lane offset lasts its phase: back to the centre after it.
        if let Some((off, rate)) = self.lane_offset
            && off != 0.0
        {
            self.lane_offset = Some((0.0, rate));
        }
        // An acceleration lasts until a phase sets a speed.
        if l.mods.iter().any(sets_speed) || self.stationary || l.action == Action::AssignSpeed {
            self.accel = None;
        }
        let mut keep_speed = false;
        // A change of speed last: it starts from the speed the block's
        // `speed(…, at: start)` gives, and its target is the phase's.
        let is_change = |m: &&Intent| matches!(m, Intent::Speed { change: true, .. });
        let (changes, others): (Vec<&Intent>, Vec<&Intent>) = l.mods.iter().partition(is_change);
        for m in others.into_iter().chain(changes) {
            if self.modifier(l, m, (k, t), plans)? {
                keep_speed = true;
            }
        }
        match l.action {
            // It holds the speed it has now (not a target still ahead).
            _ if keep_speed => {
                self.target = Some(self.mo.v);
                self.end_speed = None;
            }
            Action::ChangeSpeed => {
                if let Some(v) = self.target {
                    self.reaching = Some((l.id, Reach::Speed(v), t));
                    let smooth = l
                        .mods
                        .iter()
                        .any(|m| matches!(m, Intent::Speed { smooth: true, .. }));
                    if smooth && v != self.mo.v {
                        let peak = if v > self.mo.v {
                            self.accel_up
                        } else {
                            self.accel_down
                        };
                        // The next sample is one step in.
                        self.smooth = Some(Ramp::new(self.mo.v, v, t - self.cx.dt, peak));
                    }
                }
            }
            Action::ChangeSpaceGap | Action::ChangeTimeHeadway if self.side_gap.is_none() => {
                self.reaching = Some((l.id, Reach::Gap, t));
            }
            // At once: exactness over physics.
            Action::AssignSpeed => {
                if let Some(v) = self.target {
                    self.mo.v = v;
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// One modifier of the phase `l` entered at sample `k` (time `t`):
    /// what it sets. True for `keep_speed()` (the action's speed is then
    /// the one the actor has).
    fn modifier(
        &mut self,
        l: &RLeaf,
        m: &Intent,
        (k, t): (usize, f64),
        plans: &[ActorPlan],
    ) -> Result<bool, ScenarioError> {
        match m {
            Intent::Along {
                road: Some(road),
                at,
                end_offset,
                ..
            } => {
                if *at == At::End {
                    self.along_end.push((l.t1, road.clone(), l.at.clone()));
                }
                if let Some(e) = end_offset {
                    self.end_offset((mod_at(l, m), l.t1), t, road, *e)?;
                }
            }
            Intent::Lateral {
                side_of: Some(o),
                at,
                ..
            } if *at != At::End => self.out.side_follows.push(SideFollow {
                actor: self.id.clone(),
                reference: o.clone(),
                t0: l.t0,
                t1: l.t1,
            }),
            Intent::Acceleration { .. } => self.acceleration_modifier(l, m, t, plans)?,
            Intent::Speed { .. } => self.speed_modifier(l, m, (k, t), plans)?,
            Intent::Position {
                distance,
                reference: Some((order, o)),
                at: At::End,
                strict,
                ..
            } => self.gap_goal(
                l,
                t,
                plans,
                (*distance, order.sign(), o, *strict, projected(l, m)),
            ),
            &Intent::ChangeLane {
                lanes: nl,
                side,
                side_given,
                inside,
                rate,
                ..
            } => self.change_lane(l, nl, (side, side_given, inside), rate)?,
            Intent::Lane {
                lane,
                reference,
                at: At::End,
                strict,
            } => self.lane_goal(l, *lane, reference.as_ref(), *strict),
            Intent::KeepSpeed { .. } => return Ok(true),
            Intent::KeepGap {
                reference,
                headway,
                target,
                behind,
            } => {
                self.start_gap(l, t, reference, (*headway, *target, *behind), plans)?;
            }
            Intent::LateralGap {
                reference,
                target,
                side,
            } => self.start_side_gap(l, t, (reference, *target, *side), plans)?,
            Intent::KeepPosition { .. } => self.stationary = true,
            Intent::Yaw { .. } => self.set_heading(l, m, plans)?,
            Intent::AssignPosition {
                place,
                off_road: true,
            } if l.action == Action::ChangePosition => self.start_straight(l, t, place)?,
            Intent::AssignPosition { place, .. } if l.action == Action::ChangePosition => {
                self.start_change_position(l, t, place)?
            }
            Intent::AssignPosition { place, .. } => self.teleport(l, k, place)?,
            Intent::FollowPath { .. } => self.start_path(l, (k, t), m, plans)?,
            &Intent::Accel {
                target,
                jerk,
                smooth,
            } => self.set_accel(l, t, target, (jerk, smooth)),
            &Intent::LaneOffset { offset, rate } => {
                self.lane_offset = Some((offset, rate));
                self.exact(l, "follow_lane(offset: …)");
            }
            Intent::AvoidCollisions { avoid: false } => {
                self.out.reckless.push((self.id.clone(), l.t0, l.t1));
            }
            // Travels `d` by the phase's end.
            &Intent::Distance { distance, .. } => self.travel_by(distance, t, l.t1),
            // A trajectory takes it exactly (`motion/path`).
            Intent::PhysicalMovement { option }
                if option == "prefer_non_physical"
                    && !l.mods.iter().any(|m| {
                        matches!(m, Intent::FollowPath { path, .. } if self.cx.paths[*path].timed)
                    }) =>
            {
                self.out.notes.push(format!(
                    "{}: physical_movement(prefer_non_physical): {} moves physically (within its acceleration), as the preference allows",
                    l.at, self.id
                ));
            }
            _ => {}
        }
        Ok(false)
    }

    /// `acceleration(a)`: the rate of the phase's speed changes; relative
    /// to another actor, its speed changes plus the offset's from the
    /// speeds both have now (within the planner's hardest bounds).
    fn acceleration_modifier(
        &mut self,
        l: &RLeaf,
        m: &Intent,
        t: f64,
        plans: &[ActorPlan],
    ) -> Result<(), ScenarioError> {
        let Intent::Acceleration {
            accel, relative, ..
        } = m
        else {
            return Ok(());
        };
        match relative {
            None => {
                self.accel_up = accel.abs().max(0.1);
                self.accel_down = accel.abs().max(0.1);
            }
            Some((sign, o)) => {
                let j = self.planned_before(l, o, "acceleration", plans)?;
                let how = Follow::Accel {
                    offset: sign * accel,
                    v0: self.mo.v,
                    ahead0: plans[j].speed_at(t, self.cx.dt),
                    t0: t,
                    projected: projected(l, m),
                };
                self.follow = Some((j, how, l.t1));
                self.accel_up = RELATIVE_ACCEL_BOUND;
                self.accel_down = RELATIVE_ACCEL_BOUND;
            }
        }
        Ok(())
    }

    /// `along(road, end_offset: e)`: the phase ends `e` before the road's
    /// end, the distance to there travelled like `distance(d)`'s (a linear
    /// speed change from the speed it has). The actor must be on that road
    /// at the phase's start, short of that place.
    fn end_offset(
        &mut self,
        (at, t1): (&str, f64),
        t: f64,
        road: &str,
        e: f64,
    ) -> Result<(), ScenarioError> {
        let net = self.cx.net;
        let pos = self.mo.pos;
        let r = &net.roads()[pos.road];
        if r.id != road {
            return Err(ScenarioError::Plan(format!(
                "{at}: along(…, end_offset: {e} m): {} is on road {} at the phase's start (t = {t:.1} s), not on road {road}; end_offset is measured on the road it drives",
                self.id, r.id
            )));
        }
        let left = if net.travels_forward(pos) {
            r.length - pos.s
        } else {
            pos.s
        };
        let d = left - e;
        if d < 0.0 {
            return Err(ScenarioError::Plan(format!(
                "{at}: along(…, end_offset: {e} m): {} is {left:.1} m from the end of road {road} at the phase's start (t = {t:.1} s), already within the offset",
                self.id
            )));
        }
        self.travel_by(d, t, t1);
        Ok(())
    }

    /// Travels `d` from `t` to `t1`: a linear speed change from the speed
    /// it has, (v0 + v1) / 2 · T = d.
    fn travel_by(&mut self, d: f64, t: f64, t1: f64) {
        let dur = (t1 - t).max(self.cx.dt);
        let v1 = (2.0 * d / dur - self.mo.v).max(0.0);
        self.end_speed = Some((self.mo.v, v1, t1));
    }

    /// A `speed` or `change_speed` modifier of the phase `l` entered at
    /// sample `k` (time `t`): the speed it starts with, its target, or the
    /// speed at its end.
    fn speed_modifier(
        &mut self,
        l: &RLeaf,
        m: &Intent,
        (k, t): (usize, f64),
        plans: &[ActorPlan],
    ) -> Result<(), ScenarioError> {
        let &Intent::Speed {
            speed,
            at,
            strict,
            ref relative,
            change,
            delta,
            ..
        } = m
        else {
            return Ok(());
        };
        let first = self.leaf_i == 0;
        // The standard's change_speed: a change from the speed the phase
        // starts with.
        let speed = if delta {
            (self.mo.v + speed).max(0.0)
        } else {
            speed
        };
        let v = self.relative_speed(l, t, (speed, at, projected(l, m)), relative, plans)?;
        match at {
            At::End => self.end_speed = Some((self.mo.v, v, l.t1)),
            _ => {
                // A change ramps from the speed it has, even in the actor's
                // first phase.
                if !change && (first || (at == At::Start && k == 0)) {
                    self.mo.v = v;
                }
                self.target = Some(v);
                if strict && !first {
                    self.strict_speed = Some((v, l.at.clone()));
                }
            }
        }
        Ok(())
    }

    /// `yaw(…)` or `assign_orientation`: the heading the phase sets.
    fn set_heading(
        &mut self,
        l: &RLeaf,
        m: &Intent,
        plans: &[ActorPlan],
    ) -> Result<(), ScenarioError> {
        let &Intent::Yaw {
            angle,
            ref relative_to,
            north,
            world,
            hold,
            when,
        } = m
        else {
            return Ok(());
        };
        let relative_to = match relative_to {
            Some(o) => Some(self.planned_before(l, o, "yaw", plans)?),
            None => None,
        };
        self.heading = Some(Heading {
            angle,
            relative_to,
            north,
            world,
            hold,
            when,
            t0: l.t0,
            t1: l.t1,
        });
        self.exact(l, "yaw");
        Ok(())
    }

    /// An error about the phase `l`'s action: at its place, naming the
    /// actor and the action.
    pub(super) fn action_err(&self, l: &RLeaf, what: String) -> ScenarioError {
        ScenarioError::Plan(format!("{}: {}'s {}: {what}", l.at, self.id, l.action))
    }

    /// An error unless the actor has a speed to move by for the phase
    /// `l`: it stands and no modifier gives it one.
    pub(super) fn needs_speed(&self, l: &RLeaf, to: &str) -> Result<(), ScenarioError> {
        if self.target.is_none() && self.end_speed.is_none() && self.mo.v < 0.1 {
            return Err(ScenarioError::Plan(format!(
                "{}: {} stands and has no speed to {to} at: give it one (`with: speed(…)`)",
                l.at, self.id
            )));
        }
        Ok(())
    }

    /// The side towards the road's centre (`inside`) or its edge, by the
    /// traffic rule of the road it is on: the left under right-hand
    /// traffic.
    pub(super) fn inner_side(&self, inside: bool) -> Side {
        let rht = self.cx.net.roads()[self.mo.pos.road].rule == litesim_map::model::Rule::Rht;
        if inside == rht {
            Side::Left
        } else {
            Side::Right
        }
    }

    /// Moves one plan step towards the lane offset asked for.
    fn shift_sideways(&mut self) {
        if let Some((off, rate)) = self.lane_offset {
            let step = rate * self.cx.dt;
            self.mo.lateral += (off - self.mo.lateral).clamp(-step, step);
            if off == 0.0 && self.mo.lateral == 0.0 {
                self.lane_offset = None;
            }
        }
    }

    /// An acceleration action entered at `t`: `assign_acceleration` (a
    /// target at once), `change_acceleration` (a target at a jerk, ended
    /// when reached) or `keep_acceleration` (the acceleration it has). A
    /// change or keep stays within [`ACCEL_LIMITS`] (noted when asked
    /// beyond); an assignment is exact.
    fn set_accel(
        &mut self,
        l: &RLeaf,
        t: f64,
        target: Option<f64>,
        (jerk, smooth): (Option<f64>, bool),
    ) {
        let now = self
            .accel
            .map(|a| a.a)
            .or_else(|| self.out.samples.last().map(|s| s.a))
            .unwrap_or(0.0);
        let mut want = target.unwrap_or(now);
        if l.action != Action::AssignAcceleration {
            let bounded = want.clamp(ACCEL_LIMITS.0, ACCEL_LIMITS.1);
            if bounded != want {
                self.out.notes.push(format!(
                    "{}: {}'s {} of {want:.2} m/s² is beyond its limits: {bounded:.2} m/s²",
                    l.at, self.id, l.action
                ));
                want = bounded;
            }
        }
        let jerk = jerk.map_or(f64::INFINITY, |j| j.abs().max(1e-3));
        let a = if jerk.is_infinite() { want } else { now };
        // The next sample is one step in.
        let smooth =
            (smooth && jerk.is_finite()).then(|| Ramp::new(now, want, t - self.cx.dt, jerk));
        self.accel = Some(Accel {
            a,
            target: want,
            jerk,
            smooth,
        });
        self.target = None;
        self.end_speed = None;
        if l.action == Action::ChangeAcceleration {
            self.reaching = Some((l.id, Reach::Accel(want), t));
        }
    }

    /// A `change_speed` whose phase ends (or the plan does) before it
    /// reaches its target (a parent's duration cut it short): a note says
    /// so.
    fn unreached(&mut self) {
        if let Some((id, reach, t0)) = self.reaching.take() {
            let Some(l) = self.my.iter().find(|l| l.id == id) else {
                return;
            };
            let what = match (reach, self.follow) {
                (Reach::Speed(v), _) => format!("{v:.2} m/s"),
                (Reach::Path, _) => "the end of its path".into(),
                (Reach::Accel(a), _) => format!("{a:.2} m/s²"),
                (Reach::Place(x, y), _) => format!("its target ({x:.1}, {y:.1})"),
                (Reach::Side(g), _) => format!("a lateral gap of {g:.2} m"),
                (
                    Reach::Gap,
                    Some((
                        _,
                        Follow::Change {
                            target, headway, ..
                        },
                        _,
                    )),
                ) => {
                    if headway {
                        format!("a time headway of {target:.2} s")
                    } else {
                        format!("a gap of {target:.2} m")
                    }
                }
                (Reach::Gap, _) => "its target".into(),
            };
            self.out.notes.push(format!(
                "{}: {}'s {} from t = {t0:.1} s does not reach {what} within its phase (the phase is shorter than the change takes)",
                l.at, self.id, l.action
            ));
        }
    }

    /// A `change_speed` action that reached its target with the step at
    /// `t` (speed `prev_v` before it): how long it took, for the next
    /// layout. A sample's speed is the one its step reached, so the phase
    /// takes that sample too and the next phase starts at the target; one
    /// already at its target takes no time.
    fn note_reached(&mut self, t: f64, prev_v: f64) {
        if let Some((id, Reach::Accel(target), t0)) = self.reaching
            && let Some(acc) = self.accel
            && (acc.a - target).abs() < 1e-9
        {
            self.out
                .reached
                .push((super::timer::reach_key(id), t - t0 + self.cx.dt));
            self.reaching = None;
        }
        if let Some((id, Reach::Speed(v), t0)) = self.reaching
            && (self.mo.v - v).abs() < 1e-9
        {
            let took = if (prev_v - v).abs() < 1e-9 {
                t - t0
            } else {
                t - t0 + self.cx.dt
            };
            self.out.reached.push((super::timer::reach_key(id), took));
            self.reaching = None;
        }
    }

    /// A `change_space_gap` or `change_time_headway` whose gap at `t` (a
    /// place, known before the sample's speed) is within
    /// [`GAP_REACHED_M`] or [`HEADWAY_REACHED_S`] of its target (a
    /// headway at the speed it comes with): it ends at `t`. Checked before
    /// the phases that start at `t` are entered, so that in the next
    /// layout, where it ends at `t`, it is found reached again.
    fn gap_reached(&mut self, t: f64, plans: &[ActorPlan]) {
        let Some((id, Reach::Gap, t0)) = self.reaching else {
            return;
        };
        let Some((
            j,
            Follow::Change {
                gap,
                target,
                headway,
                behind,
            },
            _,
        )) = self.follow
        else {
            return;
        };
        // A headway at the trailing actor's speed.
        let v = if behind {
            plans[j].speed_at(t, self.cx.dt)
        } else {
            self.mo.v
        };
        let done = if headway {
            v > 0.1 && (gap / v - target).abs() <= HEADWAY_REACHED_S
        } else {
            (gap - target).abs() <= GAP_REACHED_M
        };
        if done && t > t0 + 1e-9 {
            self.out.reached.push((super::timer::reach_key(id), t - t0));
            self.reaching = None;
        }
    }

    /// A changed gap moves on by the step from `t`: the one ahead's speed
    /// less this one's, over the plan's step.
    fn carry_gap(&mut self, t: f64, plans: &[ActorPlan]) {
        if let Some((j, Follow::Change { gap, behind, .. }, _)) = &mut self.follow {
            let closing = plans[*j].speed_at(t, self.cx.dt) - self.mo.v;
            *gap += if *behind { -closing } else { closing } * self.cx.dt;
        }
    }

    /// `position(d, ahead_of/behind: o, at: end)`: a gap goal, and the
    /// speed change that reaches it by the phase's end on `o`'s plan.
    fn gap_goal(
        &mut self,
        l: &RLeaf,
        t: f64,
        plans: &[ActorPlan],
        (distance, sign, o, strict, projected): (Option<f64>, f64, &String, bool, bool),
    ) {
        let Some(op) = plans.iter().find(|p| p.id == *o) else {
            return;
        };
        if op.samples.is_empty() {
            return;
        }
        let (net, dt) = (self.cx.net, self.cx.dt);
        let distance = distance.unwrap_or(5.0);
        let here_other = op.at(t, dt);
        let projected = projected.then_some(Projection {
            x: here_other.x,
            y: here_other.y,
            yaw: here_other.yaw,
            speed: here_other.v,
            t0: t,
        });
        self.out.goals.push(GapGoal {
            actor: self.id.clone(),
            reference: o.clone(),
            distance,
            sign,
            t0: l.t0,
            t1: l.t1,
            strict,
            at: l.at.clone(),
            label: l.label.clone(),
            projected,
        });
        let gap = distance + (op.length + plans[self.i].length) / 2.0;
        let me = net.lane_pos_pose(self.mo.pos, 0.0);
        // Distance the other covers plus the change of gap.
        let now_gap = litesim_core::ahead_along(
            litesim_core::Vec2::new(here_other.x, here_other.y),
            here_other.yaw,
            litesim_core::Vec2::new(me.position.x, me.position.y),
        );
        // Projected, the other goes on at the speed it has now.
        let other_travel = match projected {
            Some(p) => p.speed * (l.t1 - t),
            None => travel(op, t, l.t1, dt),
        };
        let need = other_travel + sign * gap - now_gap;
        let dur = (l.t1 - t).max(dt);
        let v1 = (2.0 * need / dur - self.mo.v).max(0.0);
        self.end_speed = Some((self.mo.v, v1, l.t1));
    }

    /// `change_lane(n, side)`: a change to the lane `n` over, taking the
    /// phase clipped to [2 s, 6 s].
    fn change_lane(
        &mut self,
        l: &RLeaf,
        nl: i32,
        (side, given, inside): (Side, bool, Option<bool>),
        rate: Option<f64>,
    ) -> Result<(), ScenarioError> {
        let side = inside.map_or(side, |inside| self.inner_side(inside));
        let net = self.cx.net;
        let mo = &mut self.mo;
        if nl < 1 {
            return Err(ScenarioError::Plan(format!(
                "{}: change_lane({nl}): the number of lanes to change is at least 1 (the side is `side`)",
                l.at
            )));
        }
        let signed = |s: Side| if s == Side::Right { -nl } else { nl };
        let mut side = side;
        // A drawn side without the lanes: the other one.
        if !given && net.lane_beside(mo.pos, signed(side)).is_none() {
            side = side.other();
        }
        let d = signed(side);
        let to = net.lane_beside(mo.pos, d).ok_or_else(|| {
            ScenarioError::Plan(format!(
                "{}: {} cannot change {nl} lane(s) to the {} on road {} (lane {})",
                l.at,
                self.id,
                if side == Side::Right { "right" } else { "left" },
                net.roads()[mo.pos.road].id,
                mo.pos.lane
            ))
        })?;
        if to != mo.pos.lane {
            let len = match rate {
                Some(r) => {
                    let from = net.lane_pos_pose(mo.pos, 0.0).position;
                    let there = net
                        .lane_pos_pose(LanePos { lane: to, ..mo.pos }, 0.0)
                        .position;
                    let len = lane_change_time(
                        litesim_core::math::hypot(there.x - from.x, there.y - from.y),
                        r,
                    );
                    // The action lasts that long (to the plan's step): its
                    // natural duration in the next layout.
                    self.out
                        .reached
                        .push((super::timer::reach_key(l.id), in_steps(len, self.cx.dt)));
                    len
                }
                None => (l.t1 - l.t0).clamp(2.0, 6.0),
            };
            let mo = &mut self.mo;
            mo.change = Some((mo.pos.lane, to, l.t0, l.t0 + len));
        }
        Ok(())
    }

    /// `lane(…, at: end)`: a lane goal against a reference (judged on the
    /// simulated state), and the change to that lane or to lane `lane`.
    fn lane_goal(
        &mut self,
        l: &RLeaf,
        lane: Option<f64>,
        reference: Option<&(LaneRelation, String)>,
        strict: bool,
    ) {
        let (net, placed) = (self.cx.net, self.cx.placed);
        if let Some((rel, o)) = reference {
            self.out.lane_goals.push(LaneGoal {
                actor: self.id.clone(),
                reference: o.clone(),
                relation: *rel,
                t0: l.t0,
                t1: l.t1,
                strict,
                at: l.at.clone(),
            });
        }
        let mo = &mut self.mo;
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
                let lanes = net.lanes_same_way(mo.pos.road, mo.pos.s, net.travels_forward(mo.pos));
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

    /// The speed a `speed` modifier asks for: `speed` itself, or relative
    /// to another actor its speed in that actor's plan (at the phase's end
    /// for `at: end`, else now) plus the offset; from now to the phase's end
    /// the target follows that actor (`Mover::follow`).
    fn relative_speed(
        &mut self,
        l: &RLeaf,
        t: f64,
        (speed, at, projected): (f64, At, bool),
        relative: &Option<(f64, String)>,
        plans: &[ActorPlan],
    ) -> Result<f64, ScenarioError> {
        let Some((sign, o)) = relative else {
            return Ok(speed);
        };
        let j = self.planned_before(l, o, "speed", plans)?;
        let off = sign * speed;
        let end = l.t1;
        let at_end = at == At::End;
        // Projected, the other keeps the speed it has now: a constant
        // target, nothing to follow.
        if projected {
            return Ok((plans[j].speed_at(t, self.cx.dt) + off).max(0.0));
        }
        if !at_end {
            self.follow = Some((j, Follow::Offset(off), end));
        }
        let when = if at_end { end } else { t };
        Ok((plans[j].speed_at(when, self.cx.dt) + off).max(0.0))
    }

    /// The plan index of `o`, an actor planned before this one (not this
    /// one itself); the error says what asked for it.
    fn planned_before(
        &self,
        l: &RLeaf,
        o: &str,
        what: &str,
        plans: &[ActorPlan],
    ) -> Result<usize, ScenarioError> {
        plans
            .iter()
            .position(|p| p.id == o && !p.samples.is_empty())
            .filter(|&j| j != self.i)
            .ok_or_else(|| {
                ScenarioError::Plan(format!(
                    "{}: {}'s {what} is relative to {o}, whose own motion is not planned before it (a reference to itself, or to an actor whose speed or gap is relative to another in turn)",
                    l.at, self.id
                ))
            })
    }

    /// `keep_space_gap(o)` / `keep_time_headway(o)` entered at `t`: the
    /// gap (bumper to bumper, along `o`'s heading) or the headway (that gap
    /// over the trailing actor's speed) it has now is what it keeps; with a
    /// `target` (`change_space_gap`, `change_time_headway`) the gap or
    /// headway it brings it to. `behind`: `o` is behind this actor, which
    /// leads.
    fn start_gap(
        &mut self,
        l: &RLeaf,
        t: f64,
        o: &str,
        (headway, target, behind): (bool, Option<f64>, Option<bool>),
        plans: &[ActorPlan],
    ) -> Result<(), ScenarioError> {
        let what = if headway { "time headway" } else { "space gap" };
        let j = self.planned_before(l, o, what, plans)?;
        let (net, dt) = (self.cx.net, self.cx.dt);
        let me = net.lane_pos_pose(self.mo.pos, 0.0);
        let r = plans[j].at(t, dt);
        let ahead_of_it = litesim_core::ahead_along(
            litesim_core::Vec2::new(r.x, r.y),
            r.yaw,
            litesim_core::Vec2::new(me.position.x, me.position.y),
        );
        // Longitudinal either way: the side it is on now.
        let behind = behind.unwrap_or(ahead_of_it > 0.0);
        let apart = if behind { ahead_of_it } else { -ahead_of_it };
        let gap = apart - (plans[j].length + plans[self.i].length) / 2.0;
        if gap <= 0.0 {
            let (side, dir) = if behind {
                ("behind", ", direction: behind")
            } else {
                ("ahead of", "")
            };
            return Err(ScenarioError::Plan(format!(
                "{}: {} keeps a {what} to {o}{dir}, which is not {side} it when the phase starts (gap {gap:.1} m)",
                l.at, self.id
            )));
        }
        // The headway is measured at the trailing actor's speed.
        let trailing_v = if behind { r.v } else { self.mo.v };
        let target = match target {
            Some(target) if target <= 0.0 => {
                return Err(ScenarioError::Plan(format!(
                    "{}: {} changes its {what} to {o} to {target}, which is not positive",
                    l.at, self.id
                )));
            }
            Some(target) => Some(target),
            None if headway && trailing_v < 0.1 => {
                return Err(ScenarioError::Plan(format!(
                    "{}: {} keeps a time headway to {o} from standstill, where it has none (give {} a speed first)",
                    l.at,
                    self.id,
                    if behind { o } else { "it" }
                )));
            }
            None => None,
        };
        let keep = if headway { gap / trailing_v } else { gap };
        let how = match target {
            Some(target) => Follow::Change {
                gap,
                target,
                headway,
                behind,
            },
            // Kept ahead of one behind: brought to what it has, by the same law.
            None if behind => Follow::Change {
                gap,
                target: keep,
                headway,
                behind,
            },
            None if headway => Follow::Headway(keep),
            // A space gap stays as it is when both go as fast.
            None => Follow::Offset(0.0),
        };
        self.follow = Some((j, how, l.t1));
        let want = target.unwrap_or(keep);
        self.push_keep(
            l,
            o,
            (headway.then_some(want), behind),
            target.unwrap_or(gap),
        );
        self.end_speed = None;
        Ok(())
    }

    /// The gap or headway the phase `l` keeps to `o` (or changes to), for
    /// the driver that carries it.
    fn push_keep(&mut self, l: &RLeaf, o: &str, (headway, behind): (Option<f64>, bool), gap: f64) {
        self.out.keeps.push(super::KeepGoal {
            actor: self.id.clone(),
            reference: o.to_string(),
            headway,
            gap,
            behind,
            t0: l.t0,
            t1: l.t1,
            index: None,
        });
    }

    /// The target speed now under [`Mover::follow`]: the other's planned
    /// speed plus an offset, or under a kept headway `h` the speed whose
    /// change keeps gap = h · v, v' = (v_ahead − v)/h (the gap changes by
    /// v_ahead − v, the headway's gap by h · v'). A strict speed still to
    /// reach is that target too.
    fn follow(&mut self, t: f64, plans: &[ActorPlan]) {
        let Some((j, how, end)) = self.follow else {
            return;
        };
        if t > end + 1e-9 {
            self.follow = None;
            return;
        }
        let dt = self.cx.dt;
        let ahead = plans[j].speed_at(t, dt);
        let v = match how {
            Follow::Offset(off) => ahead + off,
            Follow::Accel {
                offset,
                v0,
                ahead0,
                t0,
                projected,
            } => v0 + if projected { 0.0 } else { ahead - ahead0 } + offset * (t - t0),
            Follow::Headway(h) => self.mo.v + dt * (ahead - self.mo.v) / h,
            Follow::Change {
                gap,
                target,
                headway,
                behind: true,
            } => super::leading_speed((ahead, plans[j].at(t, dt).a), gap, target, headway),
            Follow::Change {
                gap,
                target,
                headway: true,
                ..
            } => super::headway_closing_speed(ahead, gap, target),
            Follow::Change { gap, target, .. } => {
                super::gap_closing_speed(ahead, gap, target, super::GAP_CLOSE_S)
            }
        }
        .max(0.0);
        self.target = Some(v);
        if let Some((sv, _)) = &mut self.strict_speed {
            *sv = v;
        }
    }

    /// The speed of the sample at `t`.
    fn speed(&mut self, t: f64) {
        let mo = &mut self.mo;
        if self.stationary || self.dead_end {
            mo.v = 0.0;
        } else if let Some(acc) = &mut self.accel {
            let dt = self.cx.dt;
            match acc.smooth {
                Some(r) => {
                    let (a, done) = r.at(t);
                    acc.a = a;
                    if done {
                        acc.smooth = None;
                    }
                }
                None => {
                    let step = acc.jerk * dt;
                    acc.a += (acc.target - acc.a).clamp(-step, step);
                }
            }
            mo.v += acc.a * dt;
            if mo.v <= 0.0 {
                // Braked to a stop: it stands (speed is not negative).
                mo.v = 0.0;
                acc.a = acc.a.max(0.0);
                acc.target = acc.target.max(0.0);
            }
        } else if let Some(r) = self.smooth {
            let (v, done) = r.at(t);
            mo.v = v;
            if done {
                self.smooth = None;
            }
        } else if let Some((v0, v1, t1)) = self.end_speed {
            let l = &self.my[self.started.unwrap_or(0)];
            let u = ((t - l.t0) / (t1 - l.t0).max(1e-9)).clamp(0.0, 1.0);
            mo.v = v0 + (v1 - v0) * u;
            if u >= 1.0 {
                self.end_speed = None;
                self.target = Some(v1);
            }
        } else if let Some(v) = self.target {
            let dv = v - mo.v;
            let step = if dv > 0.0 {
                self.accel_up
            } else {
                self.accel_down
            } * self.cx.dt;
            mo.v += dv.clamp(-step, step);
            if let Some((sv, _)) = &self.strict_speed
                && (mo.v - sv).abs() < 1e-6
            {
                self.strict_speed = None;
            }
        }
    }

    /// The sample at `t` (speed `prev_v` at the last one): the lane-centre
    /// pose, through a lane change in progress, shifted sideways for a
    /// person beside the road; and the lane-centre pose at the actor's place
    /// when this sample computed it (the move reuses it).
    fn pose(
        &mut self,
        t: f64,
        prev_v: f64,
        plans: &[ActorPlan],
    ) -> (PlanSample, Option<litesim_core::Pose>) {
        let kind = plans[self.i].kind;
        let net = self.cx.net;
        let mo = &mut self.mo;
        let mut lat_rate = 0.0;
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
            let c = match self.reached {
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
        if kind == ActorClass::Stationary {
            yaw = p.yaw;
        }
        if let Some(h) = self.heading {
            if (h.hold && mo.v > 0.1) || (h.when == At::Start && t > h.t0 + 1e-9) {
                // Moving again (or past its start): its lane's heading again.
                self.heading = None;
            } else {
                let base = match (h.relative_to, h.north, h.world) {
                    (Some(j), ..) => plans[j].at(t, self.cx.dt).yaw,
                    (None, true, _) => std::f64::consts::FRAC_PI_2,
                    (None, _, true) => 0.0,
                    (None, false, false) => p.yaw,
                };
                let sign = if h.north && h.relative_to.is_none() {
                    -1.0
                } else {
                    1.0
                };
                let want = wrap_angle(base + sign * h.angle);
                yaw = match h.when {
                    // Turned to by the phase's last sample (a sample's
                    // heading is its step's).
                    At::End => {
                        let u = ((t - h.t0 + self.cx.dt) / (h.t1 - h.t0).max(1e-9)).clamp(0.0, 1.0);
                        wrap_angle(yaw + wrap_angle(want - yaw) * u)
                    }
                    _ => want,
                };
            }
        }
        let sample = PlanSample {
            t,
            x,
            y,
            yaw,
            v: mo.v,
            a: (mo.v - prev_v) / self.cx.dt,
        };
        (sample, centre)
    }

    /// Moves one plan step at the sample's speed: along the lane, or
    /// across it for a person walking across.
    fn advance(&mut self, t: f64, centre: Option<litesim_core::Pose>) {
        let net = self.cx.net;
        let mo = &mut self.mo;
        if mo.across != 0.0 {
            mo.lateral += mo.across * mo.v * self.cx.dt;
            return;
        }
        let before = mo.pos;
        let (to, pose) = net.advance_path_pose(mo.pos, mo.v * self.cx.dt, centre);
        mo.pos = to;
        self.reached = pose.map(|c| (to, c));
        if mo.v > 0.0 && mo.pos == before && !self.dead_end {
            self.dead_end = true;
            self.out.notes.push(format!(
                "{} reaches the end of road {} lane {} at t = {t:.1} s: no lane continues, it stops there",
                self.id,
                net.roads()[mo.pos.road].id,
                mo.pos.lane
            ));
        }
    }
}

pub(super) fn plans_index(plans: &[ActorPlan]) -> BTreeMap<String, usize> {
    plans
        .iter()
        .enumerate()
        .map(|(i, p)| (p.id.clone(), i))
        .collect()
}

/// Distance an actor's plan covers between two times.
pub(super) fn travel(p: &ActorPlan, t0: f64, t1: f64, dt: f64) -> f64 {
    let mut d = 0.0;
    let mut t = t0;
    while t < t1 - 1e-9 {
        let h = dt.min(t1 - t);
        d += p.speed_at(t, dt) * h;
        t += h;
    }
    d
}
