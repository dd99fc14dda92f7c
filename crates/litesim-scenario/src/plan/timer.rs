//! The behaviour tree in time: each leaf's start and end (serial,
//! parallel with overlap, one_of, durations, waits and untils) and the
//! arguments evaluated from the solution.

use super::*;

pub(super) struct Leaf<'a> {
    /// The action node's id.
    pub(super) id: u32,
    pub(super) actor: String,
    pub(super) action: Action,
    pub(super) label: Option<String>,
    pub(super) mods: Vec<&'a Modifier>,
    pub(super) at: String,
    pub(super) t0: f64,
    pub(super) t1: f64,
}

/// How long a `change_speed` phase is laid out before its motion has found
/// when it reaches its target (s): long enough for any change at a rate a
/// vehicle has; the next layout uses the time found.
pub const PROVISIONAL_REACH_S: f64 = 60.0;

/// The key of the time a `change_speed` action (node `id`) took to reach
/// its target, kept between layouts with the condition times.
pub(super) fn reach_key(id: u32) -> String {
    format!("reach@{id}")
}

/// An environment action laid out: time, action, arguments, place.
pub(super) type EnvNode<'a> = (f64, &'a str, &'a BTreeMap<String, CExpr>, &'a str);

/// The time a `change_speed` (node id) will take, from the speed its
/// actor has before it as far as the tree says it (the constant speed of
/// its phase before, in tree order) and its rate: the layout's first guess,
/// in the motion's steps of `dt`; actions whose start speed the tree does
/// not tell are not guessed.
fn reach_estimates(root: &Node, dt: f64) -> BTreeMap<u32, f64> {
    fn constant(m: &Modifier, key: &str) -> Option<f64> {
        match m.args.get(key) {
            Some(CExpr::Const(Value::Num(v))) => Some(*v),
            _ => None,
        }
    }
    fn walk<'a>(
        n: &'a Node,
        dt: f64,
        last: &mut BTreeMap<&'a str, f64>,
        out: &mut BTreeMap<u32, f64>,
    ) {
        match n {
            Node::Serial { children, .. }
            | Node::Parallel { children, .. }
            | Node::OneOf { children, .. } => {
                for c in children {
                    walk(c, dt, last, out);
                }
            }
            Node::Action {
                id,
                actor,
                action,
                mods,
                ..
            } => {
                let absolute = mods.iter().find(|m| {
                    m.kind == ModKind::Speed
                        && !crate::intent::RELATIVE_SPEED
                            .iter()
                            .any(|(k, _)| m.args.contains_key(*k))
                });
                let speed = absolute.and_then(|m| constant(m, "speed"));
                let rate = mods
                    .iter()
                    .find(|m| m.kind == ModKind::Acceleration)
                    .and_then(|m| constant(m, "acceleration"));
                match (*action, speed, last.get(actor.as_str())) {
                    (Action::ChangeSpeed, Some(v1), Some(&v0)) => {
                        let up = v1 > v0;
                        let a = rate
                            .map_or(if up { ACCEL_UP } else { ACCEL_DOWN }, |a| a.abs().max(0.1));
                        // A smooth profile's mean rate is 2/π of its peak.
                        let smooth = absolute.is_some_and(|m| {
                            matches!(m.args.get("rate_profile"), Some(CExpr::Const(Value::Enum(p))) if p == "smooth")
                        });
                        let a = if smooth {
                            a / std::f64::consts::FRAC_PI_2
                        } else {
                            a
                        };
                        let steps = ((v1 - v0).abs() / (a * dt) - 1e-9).ceil().max(0.0);
                        out.insert(*id, steps * dt);
                    }
                    // A lane change at a sideways rate, over lanes of the
                    // usual 3.5 m.
                    (Action::ChangeLane, ..) => {
                        let of = |k: &str| {
                            mods.iter()
                                .find(|m| m.kind == ModKind::ChangeLane)
                                .and_then(|m| constant(m, k))
                        };
                        if let Some(r) = of("rate") {
                            let lanes = of("num_of_lanes").unwrap_or(1.0).max(1.0);
                            let len = super::lane_change_time(3.5 * lanes, r);
                            out.insert(*id, super::in_steps(len, dt));
                        }
                    }
                    (Action::RemainStationary, ..) => {
                        last.insert(actor, 0.0);
                        return;
                    }
                    (Action::KeepSpeed, ..) => return,
                    _ => {}
                }
                match speed {
                    Some(v) => {
                        last.insert(actor, v);
                    }
                    None if mods.iter().any(|m| m.kind == ModKind::KeepSpeed) => {}
                    None => {
                        last.remove(actor.as_str());
                    }
                }
            }
            _ => {}
        }
    }
    let mut out = BTreeMap::new();
    walk(root, dt, &mut BTreeMap::new(), &mut out);
    out
}

pub(super) struct Timer<'a> {
    /// The first `duration(…)` out of range, as an error message.
    pub(super) bad_duration: Option<String>,
    pub(super) rng: Rng,
    pub(super) sol: &'a Solution,
    pub(super) leaves: Vec<Leaf<'a>>,
    /// Event times known from the previous pass (labels' start/end, emits).
    pub(super) events: BTreeMap<String, f64>,
    /// Event times of this pass.
    pub(super) seen: BTreeMap<String, f64>,
    /// `one_of` choices and `until elapsed` values, drawn once and kept
    /// across passes so that the passes converge.
    pub(super) choice: BTreeMap<u32, usize>,
    pub(super) until_after: BTreeMap<u32, Option<f64>>,
    /// Traffic-light switches: time, light path, colour, place.
    pub(super) switches: Vec<(f64, String, &'a CExpr, String)>,
    /// Changes of the environment: time, action, arguments, place.
    pub(super) environment: Vec<EnvNode<'a>>,
    /// First guesses of `change_speed` durations, by node id.
    pub(super) estimates: BTreeMap<u32, f64>,
    /// Times at which state conditions hold, from the previous plan.
    pub(super) cond_events: &'a BTreeMap<String, f64>,
    /// State conditions met in this layout: key, start time, condition.
    pub(super) conds: Vec<(String, f64, &'a CExpr)>,
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

pub(super) fn mods_of(n: &Node) -> &[Modifier] {
    match n {
        Node::Serial { mods, .. }
        | Node::Parallel { mods, .. }
        | Node::OneOf { mods, .. }
        | Node::Action { mods, .. } => mods,
        _ => &[],
    }
}

impl<'a> Timer<'a> {
    pub(super) fn explicit(&mut self, n: &Node) -> Option<f64> {
        let m = mods_of(n).iter().find(|m| m.kind == ModKind::Duration)?;
        let e = m.args.get("duration")?;
        let d = eval(e, self.sol, &mut self.rng)?.num()?;
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

    /// The natural duration of an action that ends by itself: a lane
    /// change its usual time; a speed change the time its motion took to
    /// reach the target in the previous layout (`reach@N`), or, before
    /// one was made, [`PROVISIONAL_REACH_S`] for the motion to find it in.
    /// Other actions last their phase (none).
    fn action_natural(&self, action: Action, id: u32) -> Option<f64> {
        match action {
            // Its usual time, or one its sideways rate sets (the motion's
            // in the previous layout, else a guess).
            Action::ChangeLane => Some(
                self.cond_events
                    .get(&reach_key(id))
                    .or_else(|| self.estimates.get(&id))
                    .copied()
                    .unwrap_or(super::LANE_CHANGE_S),
            ),
            Action::AssignSpeed
            | Action::AssignPosition
            | Action::AssignOrientation
            | Action::AssignAcceleration => Some(0.0),
            Action::ChangeSpeed
            | Action::ChangeSpaceGap
            | Action::ChangeTimeHeadway
            | Action::FollowPath
            | Action::ReplayPath
            | Action::FollowTrajectory
            | Action::ReplayTrajectory
            | Action::ChangeAcceleration
            | Action::ChangePosition => Some(
                self.cond_events
                    .get(&reach_key(id))
                    .or_else(|| self.estimates.get(&id))
                    .copied()
                    .unwrap_or(PROVISIONAL_REACH_S),
            ),
            _ => None,
        }
    }

    /// Natural duration: explicit, or from the children.
    pub(super) fn natural(
        &mut self,
        n: &Node,
        memo: &mut BTreeMap<u32, Option<f64>>,
    ) -> Option<f64> {
        let key = n.id();
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
                    .and_then(|e| eval(e, self.sol, &mut self.rng))
                    .and_then(|v| v.num()),
                Node::Emit { .. } | Node::Switch { .. } | Node::Environment { .. } => Some(0.0),
                Node::Action { action, id, .. } => self.action_natural(*action, *id),
            }
        };
        memo.insert(key, v);
        v
    }

    /// Lays `n` out from `t0`; `forced` is the duration a parent imposes.
    pub(super) fn assign(
        &mut self,
        n: &'a Node,
        t0: f64,
        forced: Option<f64>,
        memo: &mut BTreeMap<u32, Option<f64>>,
    ) -> f64 {
        let own = memo.get(&n.id()).copied().flatten();
        let mut dur = forced.or(own);
        // `until`: an event's planned time or an elapsed time ends the node early.
        for (k, m) in mods_of(n)
            .iter()
            .filter(|m| m.kind == ModKind::Until)
            .enumerate()
        {
            let cut = if let Some(CExpr::Const(Value::Str(e))) = m.args.get("event") {
                self.events.get(e).map(|te| te - t0).filter(|d| *d >= 0.0)
            } else if let Some(e) = m.args.get("elapsed") {
                let key = n.id();
                if !self.until_after.contains_key(&key) {
                    let v = eval(e, self.sol, &mut self.rng).and_then(|v| v.num());
                    self.until_after.insert(key, v);
                }
                self.until_after[&key].filter(|d| *d >= 0.0)
            } else if let Some(c) = m.args.get("cond") {
                let key = format!("until@{}.{k}", n.id());
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

    pub(super) fn assign_inner(
        &mut self,
        n: &'a Node,
        t0: f64,
        dur: Option<f64>,
        memo: &mut BTreeMap<u32, Option<f64>>,
    ) -> f64 {
        match n {
            Node::Action {
                id,
                actor,
                action,
                label,
                mods,
                at,
            } => {
                let d = dur.unwrap_or(DEFAULT_PHASE_S);
                self.leaves.push(Leaf {
                    id: *id,
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
                    .filter_map(|c| memo.get(&c.id()).copied().flatten())
                    .sum();
                let open = children
                    .iter()
                    .filter(|c| memo.get(&c.id()).copied().flatten().is_none())
                    .count();
                let share = match dur {
                    Some(d) if open > 0 => Some(((d - known) / open as f64).max(0.0)),
                    _ => None,
                };
                let mut t = t0;
                for c in children {
                    let cd = memo.get(&c.id()).copied().flatten();
                    t = self.assign(c, t, cd.or(share), memo);
                }
                t
            }
            Node::Parallel {
                children, overlap, ..
            } => {
                let d = dur.unwrap_or(DEFAULT_PHASE_S);
                for c in children {
                    let cd = memo.get(&c.id()).copied().flatten();
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
                let key = n.id();
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
                let key = format!("wait@{}", n.id());
                self.conds.push((key.clone(), t0, c));
                match self.cond_events.get(&key) {
                    Some(te) if *te > t0 => *te,
                    _ => t0,
                }
            }
            Node::Emit { event, .. } => {
                self.seen.entry(event.clone()).or_insert(t0);
                t0
            }
            Node::Switch {
                light, color, at, ..
            } => {
                self.switches.push((t0, light.clone(), color, at.clone()));
                t0
            }
            Node::Environment {
                action, args, at, ..
            } => {
                self.environment.push((t0, action, args, at));
                t0
            }
            Node::Wait { .. } => t0 + dur.unwrap_or(0.0),
        }
    }
}

/// The behaviour tree laid out in time.
pub(super) struct Layout<'a> {
    /// How long the behaviour lasts (s).
    pub(super) duration: f64,
    /// The leaves with their times, in tree order.
    pub(super) leaves: Vec<Leaf<'a>>,
    /// Traffic-light switches: time, light path, colour, place.
    pub(super) switches: Vec<(f64, String, &'a CExpr, String)>,
    /// Changes of the environment: time, action, arguments, place.
    pub(super) environment: Vec<EnvNode<'a>>,
    /// The guesses of `change_speed` durations this layout used, by
    /// node id.
    pub(super) estimates: BTreeMap<u32, f64>,
    /// State conditions met: key, start time, condition.
    pub(super) conds: Vec<(String, f64, CExpr)>,
    /// Event times (labels' start/end, emits).
    pub(super) events: BTreeMap<String, f64>,
}

/// Lays the tree under `root` out in time with the state-condition times
/// `cond_events` (at least one step `step_s` long); `rng` draws the
/// `one_of` choices and ranges.
pub(super) fn lay_out<'a>(
    root: &'a Node,
    sol: &'a Solution,
    rng: &mut Rng,
    cond_events: &'a BTreeMap<String, f64>,
    step_s: f64,
) -> Result<Layout<'a>, ScenarioError> {
    let mut timer = Timer {
        rng: rng.clone(),
        sol,
        leaves: Vec::new(),
        events: BTreeMap::new(),
        seen: BTreeMap::new(),
        choice: BTreeMap::new(),
        until_after: BTreeMap::new(),
        switches: Vec::new(),
        environment: Vec::new(),
        estimates: reach_estimates(root, super::plan_step(step_s)),
        bad_duration: None,
        cond_events,
        conds: Vec::new(),
    };
    let mut memo = BTreeMap::new();
    fn visit<'a>(t: &mut Timer<'a>, n: &'a Node, memo: &mut BTreeMap<u32, Option<f64>>) {
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
        timer.environment.clear();
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
    *rng = timer.rng;
    let conds: Vec<(String, f64, CExpr)> = timer
        .conds
        .into_iter()
        .map(|(k, t, c)| (k, t, c.clone()))
        .collect();
    Ok(Layout {
        duration,
        leaves: timer.leaves,
        switches: timer.switches,
        environment: timer.environment,
        // The guesses this layout used (no time found for them yet).
        estimates: timer
            .estimates
            .into_iter()
            .filter(|(id, _)| !cond_events.contains_key(&reach_key(*id)))
            .collect(),
        conds,
        events: timer.events,
    })
}

/// The changes of the environment with their arguments evaluated (SI),
/// in time order.
pub(super) fn environment_changes(
    nodes: Vec<EnvNode<'_>>,
    sol: &Solution,
    rng: &mut Rng,
) -> Result<Vec<super::EnvChange>, ScenarioError> {
    let mut out = Vec::with_capacity(nodes.len());
    for (t, action, args, at) in nodes {
        let mut values = BTreeMap::new();
        for (k, e) in args {
            match eval(e, sol, rng) {
                Some(Value::Num(v)) => {
                    values.insert(k.clone(), v);
                }
                // Enums (the light source) were vetted by elaboration.
                Some(Value::Enum(_)) => {}
                _ => {
                    return Err(ScenarioError::Plan(format!(
                        "{at}: environment.{action}: {k} has no value the engine can evaluate"
                    )));
                }
            }
        }
        out.push(super::EnvChange {
            t,
            action: action.to_string(),
            values,
            at: at.to_string(),
        });
    }
    out.sort_by(|a, b| a.t.total_cmp(&b.t));
    Ok(out)
}

/// The traffic-light switches with their lights (from the solution) and
/// colours, in time order.
pub(super) fn light_switches(
    switches: Vec<(f64, String, &CExpr, String)>,
    sol: &Solution,
    rng: &mut Rng,
) -> Result<Vec<LightSwitch>, ScenarioError> {
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
    Ok(lights)
}
