//! Elaboration: from a checked OSC program to a [`Test`] — the run
//! configuration, the actors, the variables with their constraints, and
//! the behaviour tree of `top.main` with every name resolved to an absolute
//! path (`s.r1`, `sut.car`, `s.car1.vehicle_category`).
//!
//! Scenario instances get a namespace: the label of the invocation (`s` in
//! `do s: sut.smoke()`), or a generated one. Fields of the instance live
//! under it; `keep`s of the instance, of its fields' `with:` blocks and of
//! the invocation's `with:` block become [`Constraint`]s over paths.

use crate::error::ScenarioError;
use litesim_core::ActorClass;
use litesim_osc::ast::{Arg, Decl, DeclKind, DoKind, DoMember, Expr, Member};
use litesim_osc::index::{DeclIndex, modifier_key};
use litesim_osc::{Program, Span};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};

/// A constant value (physical values in SI units).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Value {
    /// A number in SI units (m, s, m/s, m/s², rad, kg).
    Num(f64),
    /// Text.
    Str(String),
    /// Truth value.
    Bool(bool),
    /// An enum member (`best_effort`).
    Enum(String),
}

impl Value {
    /// The number, when it is one.
    pub fn num(&self) -> Option<f64> {
        match self {
            Value::Num(v) => Some(*v),
            _ => None,
        }
    }
    /// The truth value, when it is one.
    pub fn boolean(&self) -> Option<bool> {
        match self {
            Value::Bool(b) => Some(*b),
            _ => None,
        }
    }
    /// The text of a string or enum member.
    pub fn text(&self) -> Option<&str> {
        match self {
            Value::Str(s) | Value::Enum(s) => Some(s),
            _ => None,
        }
    }
}

/// A constraint or argument expression with names resolved to paths.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum CExpr {
    /// A constant.
    Const(Value),
    /// A variable by absolute path (`s.r1`, `s.car1.bbox.length`).
    Var(String),
    /// A range `[lo..hi]` in SI units; open bounds are `None`.
    Range(Option<f64>, Option<f64>),
    /// A list of values.
    List(Vec<CExpr>),
    /// Unary operator.
    Unary(String, Box<CExpr>),
    /// Binary operator.
    Binary(String, Box<CExpr>, Box<CExpr>),
    /// Something the engine does not evaluate (a method call, an event);
    /// the text says what.
    Opaque(String),
}

/// A `keep`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Constraint {
    /// `keep(default …)`: a preference that yields to hard constraints.
    pub soft: bool,
    /// The expression.
    pub expr: CExpr,
    /// Where it was written (`file:line:col`).
    pub at: String,
}

/// An actor of the test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ActorDef {
    /// Id used with the simulator and in logs (`sut.car`, `car1`).
    pub id: String,
    /// Path of the field that declared it (`s.car1`).
    pub path: String,
    /// Declared type (`vehicle`, `person`, `fire_truck`).
    pub type_name: String,
    /// Kind.
    pub kind: ActorClass,
    /// The system under test's car.
    pub ego: bool,
}

/// Map-element variable kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RoadKind {
    /// Any road.
    Road,
    /// A road whose drivable lanes all run one way.
    OneWay,
    /// A road with lanes in both directions.
    TwoWay,
}

/// A scalar or map-element variable.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VarDef {
    /// Declared type name.
    pub type_name: String,
    /// For map elements: which kind of road.
    pub road: Option<RoadKind>,
    /// Default value.
    pub default: Option<CExpr>,
}

/// A modifier application with its arguments bound to parameter names.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Modifier {
    /// What it is (decoded from the name here, once).
    pub kind: crate::intent::ModKind,
    /// Modifier name as written (`speed`, `along`, …), for messages.
    pub name: String,
    /// Arguments by parameter name.
    pub args: BTreeMap<String, CExpr>,
    /// Where.
    pub at: String,
}

/// A node of the behaviour tree.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "node", rename_all = "snake_case")]
pub enum Node {
    /// Children one after another.
    Serial {
        /// Stable id: the node's place in a pre-order walk of the tree
        /// (numbered once elaboration is done; [`Node::id`]).
        #[serde(skip)]
        id: u32,
        /// Label.
        label: Option<String>,
        /// Children.
        children: Vec<Node>,
        /// Modifiers of the composition (`duration`).
        mods: Vec<Modifier>,
    },
    /// Children at the same time.
    Parallel {
        /// Stable id: the node's place in a pre-order walk of the tree
        /// (numbered once elaboration is done; [`Node::id`]).
        #[serde(skip)]
        id: u32,
        /// Label.
        label: Option<String>,
        /// Children.
        children: Vec<Node>,
        /// Modifiers.
        mods: Vec<Modifier>,
        /// `overlap:` (`equal` by default).
        overlap: String,
    },
    /// One child, chosen under the seed.
    OneOf {
        /// Stable id: the node's place in a pre-order walk of the tree
        /// (numbered once elaboration is done; [`Node::id`]).
        #[serde(skip)]
        id: u32,
        /// Label.
        label: Option<String>,
        /// Children.
        children: Vec<Node>,
        /// Modifiers.
        mods: Vec<Modifier>,
    },
    /// An action of one actor.
    Action {
        /// Stable id: the node's place in a pre-order walk of the tree
        /// (numbered once elaboration is done; [`Node::id`]).
        #[serde(skip)]
        id: u32,
        /// Label.
        label: Option<String>,
        /// Actor id.
        actor: String,
        /// What the actor does.
        action: crate::intent::Action,
        /// Modifiers.
        mods: Vec<Modifier>,
        /// Where.
        at: String,
    },
    /// `wait elapsed(t)` or `wait @event` (the event's planned time);
    /// conditions over states end at once in a plan.
    Wait {
        /// Stable id: the node's place in a pre-order walk of the tree
        /// (numbered once elaboration is done; [`Node::id`]).
        #[serde(skip)]
        id: u32,
        /// Duration (s), when it is `elapsed(t)`.
        duration: Option<CExpr>,
        /// Event path (`go`, `first.end`), when it waits for one.
        event: Option<String>,
        /// A condition over the planned states (`sut.car.speed > 30kph`,
        /// `rise(…)`), when it waits for one.
        cond: Option<CExpr>,
    },
    /// `light.switch(color)`: a traffic light changes colour at this time.
    Switch {
        /// Stable id: the node's place in a pre-order walk of the tree
        /// (numbered once elaboration is done; [`Node::id`]).
        #[serde(skip)]
        id: u32,
        /// Path of the `traffic_light` variable.
        light: String,
        /// The colour (an enum member).
        color: CExpr,
        /// Where.
        at: String,
    },
    /// `emit e`.
    Emit {
        /// Stable id: the node's place in a pre-order walk of the tree
        /// (numbered once elaboration is done; [`Node::id`]).
        #[serde(skip)]
        id: u32,
        /// Event name.
        event: String,
    },
}

impl Node {
    /// The node's stable id (its place in a pre-order walk of the tree):
    /// what planning keys per-node state and conditions by.
    pub fn id(&self) -> u32 {
        match self {
            Node::Serial { id, .. }
            | Node::Parallel { id, .. }
            | Node::OneOf { id, .. }
            | Node::Action { id, .. }
            | Node::Wait { id, .. }
            | Node::Switch { id, .. }
            | Node::Emit { id, .. } => *id,
        }
    }

    /// Numbers the tree in pre-order from `next`.
    fn number(&mut self, next: &mut u32) {
        let (Node::Serial { id, .. }
        | Node::Parallel { id, .. }
        | Node::OneOf { id, .. }
        | Node::Action { id, .. }
        | Node::Wait { id, .. }
        | Node::Switch { id, .. }
        | Node::Emit { id, .. }) = self;
        *id = *next;
        *next += 1;
        if let Node::Serial { children, .. }
        | Node::Parallel { children, .. }
        | Node::OneOf { children, .. } = self
        {
            for c in children {
                c.number(next);
            }
        }
    }
}

/// Run configuration from `test_config` and `sim_info`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RunConfig {
    /// Map path as written (after `$ENV` expansion), relative to the test file.
    pub map: Option<String>,
    /// Seed from the test (`--seed` wins).
    pub seed: Option<u64>,
    /// Step (ms).
    pub step_ms: Option<u32>,
    /// `sim_info.simulator_name`.
    pub simulator_name: String,
    /// `sim_info.profile`.
    pub profile: String,
    /// `sim_info.dynamic`: drive with pedals and steering unless the run
    /// says otherwise.
    pub dynamic: bool,
    /// Pass/fail thresholds on the system under test.
    pub thresholds: Thresholds,
    /// Ambient traffic around sut.car (`traffic_density` > 0).
    pub traffic: Option<TrafficDecl>,
}

/// Ambient traffic as a test declares it (`extend test_config: set
/// traffic_density = 15`, …), checked when the test is elaborated.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrafficDecl {
    /// Vehicles per km per lane.
    pub density: f64,
    /// Desired speeds (m/s), drawn uniformly.
    pub speed: (f64, f64),
    /// Vehicles are kept within this distance of sut.car (m).
    pub radius: f64,
    /// The drivers' desired time gap (s).
    pub time_gap: f64,
    /// The drivers' MOBIL politeness.
    pub politeness: f64,
    /// Where the declaration is (file:line:col of `traffic_density`).
    pub at: String,
}

/// The most vehicles per km per lane a declaration may ask for: above
/// jam density (one 4.5 m car and its 2 m gap every 6.5 m ≈ 154/km).
pub const MAX_TRAFFIC_DENSITY: f64 = 150.0;
/// The largest radius of ambient traffic (m).
pub const MAX_TRAFFIC_RADIUS: f64 = 5000.0;

impl TrafficDecl {
    /// The declaration's values from `test_config`, checked; the error
    /// names the field, its value and the range it must be in.
    fn check(self) -> Result<Self, String> {
        let field = |name: &str, v: f64, lo: f64, hi: f64, unit: &str| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(format!(
                    "test_config.{name} = {v}{unit} is out of range (expected {lo}{unit} ..= {hi}{unit})"
                ))
            }
        };
        field(
            "traffic_density",
            self.density,
            0.0,
            MAX_TRAFFIC_DENSITY,
            " per km per lane",
        )?;
        if self.radius <= 0.0 || !self.radius.is_finite() {
            return Err(format!(
                "test_config.traffic_radius = {} m: ambient traffic needs a radius above 0 m",
                self.radius
            ));
        }
        field("traffic_radius", self.radius, 0.0, MAX_TRAFFIC_RADIUS, " m")?;
        field("traffic_min_speed", self.speed.0, 0.0, 70.0, " m/s")?;
        field("traffic_max_speed", self.speed.1, 0.0, 70.0, " m/s")?;
        if self.speed.0 > self.speed.1 {
            return Err(format!(
                "test_config.traffic_min_speed ({} m/s) is above traffic_max_speed ({} m/s)",
                self.speed.0, self.speed.1
            ));
        }
        let mut p = crate::runtime::driver::DriverParams::for_category("car", self.speed.1);
        p.time_gap = self.time_gap;
        p.politeness = self.politeness;
        p.validate()
            .map_err(|e| format!("{e} (test_config.traffic_time_gap / traffic_politeness)"))?;
        Ok(self)
    }
}

/// Thresholds a test sets on the system under test (`extend test_config:
/// set min_ttc = 1.5s`); `None` (or 0 in the test) leaves a check off.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Thresholds {
    /// Smallest allowed time to collision between sut.car and any actor (s).
    pub min_ttc: Option<f64>,
    /// Smallest allowed box-to-box gap between sut.car and any actor (m).
    pub min_gap: Option<f64>,
    /// Largest allowed deceleration of sut.car (m/s²).
    pub max_decel: Option<f64>,
    /// Largest allowed jerk of sut.car (m/s³), over 0.1 s.
    pub max_jerk: Option<f64>,
    /// Largest allowed jerk of sut.car over 1 s windows (m/s³).
    pub max_jerk_1s: Option<f64>,
    /// Smallest allowed time headway of sut.car to an actor it follows (s).
    pub min_thw: Option<f64>,
    /// Largest allowed deceleration sut.car would need to avoid a crash
    /// with an actor it closes on (DRAC, m/s²).
    pub max_drac: Option<f64>,
    /// Smallest allowed post-encroachment time of sut.car with an actor at
    /// a junction's conflict area (s).
    pub min_pet: Option<f64>,
    /// sut.car must end within this distance of its route's goal (m).
    pub goal_tolerance: Option<f64>,
    /// Seconds the system under test may take to answer a step.
    pub sut_timeout: Option<f64>,
}

/// An elaborated test.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Test {
    /// Configuration.
    pub config: RunConfig,
    /// Actors, ego first, then in declaration order.
    pub actors: Vec<ActorDef>,
    /// Variables by path.
    pub vars: BTreeMap<String, VarDef>,
    /// Constraints.
    pub constraints: Vec<Constraint>,
    /// `top.main`'s behaviour.
    pub root: Option<Node>,
    /// Things the engine saw but does not execute (reported, never silent).
    pub notes: Vec<String>,
    /// `cover`/`record` items, in the order met.
    pub covers: Vec<crate::coverage::CoverItem>,
}

/// The program and its declaration index (shared with the checker).
struct Lib<'a> {
    prog: &'a Program,
    ix: DeclIndex<'a>,
}

impl<'a> Lib<'a> {
    fn new(prog: &'a Program) -> Self {
        Lib {
            prog,
            ix: DeclIndex::build(prog),
        }
    }

    fn is_a(&self, t: &str, base: &str) -> bool {
        self.ix.is_a(t, base)
    }

    /// Parameter names of an action, modifier or scenario, in positional order.
    fn params(&self, key: &str) -> Vec<String> {
        self.ix
            .params(key)
            .into_iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// A range given for an `int`/`uint` parameter of `key` becomes the
    /// list of its integers, so that a run draws one of them with its seed
    /// (`change_lane(lane_changes: [1..2])`: 1 or 2, each as likely) rather
    /// than a real number truncated. Ranges of more than 4096 integers stay
    /// ranges.
    fn ints_drawn(&self, key: &str, bound: &mut BTreeMap<String, CExpr>) {
        for p in self.ix.params(key) {
            if !matches!(p.ty.base.name.text.as_str(), "int" | "uint") || p.ty.list {
                continue;
            }
            if let Some(CExpr::Range(Some(lo), Some(hi))) = bound.get(&p.name) {
                let (lo, hi) = (lo.ceil(), hi.floor());
                if lo <= hi && hi - lo < 4096.0 {
                    let items = (lo as i64..=hi as i64)
                        .map(|v| CExpr::Const(Value::Num(v as f64)))
                        .collect();
                    bound.insert(p.name.clone(), CExpr::List(items));
                }
            }
        }
    }

    /// The members of scenario `name` (declaration and `extend`s).
    fn scenario(&self, name: &str) -> Option<Vec<&'a Member>> {
        self.ix
            .compounds
            .get(name)
            .filter(|c| c.kind == DeclKind::Scenario)
            .map(|c| c.body.clone())
    }

    fn at(&self, span: Span) -> String {
        let f = self.prog.sources.file(span.file);
        let (l, c) = f.line_col(span.start as usize);
        format!("{}:{l}:{c}", f.path)
    }
}

/// Names visible in one scenario instance.
#[derive(Clone, Default)]
struct Scope {
    /// Namespace of the instance (`s`); fields are `ns.field`.
    ns: String,
    /// Field names of the instance.
    fields: BTreeSet<String>,
    /// Labels of the instance's `do` tree → namespace of a scenario instance.
    labels: BTreeMap<String, String>,
    /// The actor the scenario runs on (`actor`).
    actor: Option<String>,
    /// `it` inside a field's `with:`.
    it: Option<String>,
}

struct Elab<'a> {
    lib: Lib<'a>,
    test: Test,
    /// actor path → id
    actor_ids: BTreeMap<String, String>,
    counter: usize,
    depth: usize,
    /// Traffic settings met so far (in any `extend test_config`), with
    /// the span of the one that names the density (else the first).
    traffic: Option<(TrafficDecl, Span)>,
}

/// Elaborates `top.main` of a program that loaded without errors.
pub fn elaborate(prog: &Program) -> Result<Test, ScenarioError> {
    if prog.has_errors() {
        return Err(ScenarioError::Elaboration(
            "the program has errors; run `litesim check` for the diagnostics".into(),
        ));
    }
    let mut e = Elab {
        lib: Lib::new(prog),
        test: Test::default(),
        actor_ids: BTreeMap::new(),
        counter: 0,
        depth: 0,
        traffic: None,
    };
    // The ego: `sut.car`.
    e.test.actors.push(ActorDef {
        id: "sut.car".into(),
        path: "sut.car".into(),
        type_name: "vehicle".into(),
        kind: ActorClass::Vehicle,
        ego: true,
    });
    e.actor_ids.insert("sut.car".into(), "sut.car".into());
    let mut main: Vec<&Member> = Vec::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            if let Decl::Extend { target, members } = d {
                match (
                    target.actor.as_ref().map(|a| a.text.as_str()),
                    target.name.text.as_str(),
                ) {
                    (Some("top"), "main") => main.extend(members.iter()),
                    (None, "test_config") | (None, "sim_info") => e.config(members)?,
                    _ => {}
                }
            }
        }
    }
    e.traffic()?;
    let scope = Scope {
        ns: "top".into(),
        ..Scope::default()
    };
    let mut root = e.body(&main, scope)?;
    if let Some(r) = &mut root {
        r.number(&mut 0);
    }
    e.test.root = root;
    Ok(e.test)
}

impl Elab<'_> {
    fn config(&mut self, members: &[Member]) -> Result<(), ScenarioError> {
        for m in members {
            if let Member::Set { path, value, span } = m {
                let Expr::Ident { name, .. } = path else {
                    continue;
                };
                let v = self.constant(value)?;
                let bad = || {
                    ScenarioError::Elaboration(format!(
                        "{}: '{name}' has the wrong type",
                        self.lib.at(*span)
                    ))
                };
                match name.as_str() {
                    "map" => self.test.config.map = Some(v.text().ok_or_else(bad)?.to_string()),
                    "seed" => self.test.config.seed = Some(v.num().ok_or_else(bad)? as u64),
                    "step_ms" => self.test.config.step_ms = Some(v.num().ok_or_else(bad)? as u32),
                    "simulator_name" => {
                        self.test.config.simulator_name = v.text().ok_or_else(bad)?.to_string()
                    }
                    "profile" => self.test.config.profile = v.text().ok_or_else(bad)?.to_string(),
                    "dynamic" => self.test.config.dynamic = v.boolean().ok_or_else(bad)?,
                    "min_ttc" | "min_gap" | "max_decel" | "max_jerk" | "max_jerk_1s"
                    | "min_thw" | "max_drac" | "min_pet" | "goal_tolerance" | "sut_timeout" => {
                        let x = v.num().ok_or_else(bad)?;
                        if !(x.is_finite() && x >= 0.0) {
                            return Err(ScenarioError::Elaboration(format!(
                                "{}: '{name}' must be a finite value ≥ 0 (0 turns the check off), got {x}",
                                self.lib.at(*span)
                            )));
                        }
                        let th = &mut self.test.config.thresholds;
                        let slot = match name.as_str() {
                            "min_ttc" => &mut th.min_ttc,
                            "min_gap" => &mut th.min_gap,
                            "max_decel" => &mut th.max_decel,
                            "max_jerk" => &mut th.max_jerk,
                            "max_jerk_1s" => &mut th.max_jerk_1s,
                            "min_thw" => &mut th.min_thw,
                            "max_drac" => &mut th.max_drac,
                            "min_pet" => &mut th.min_pet,
                            "goal_tolerance" => &mut th.goal_tolerance,
                            _ => &mut th.sut_timeout,
                        };
                        *slot = (x > 0.0).then_some(x);
                    }
                    "traffic_density" | "traffic_min_speed" | "traffic_max_speed"
                    | "traffic_radius" | "traffic_time_gap" | "traffic_politeness" => {
                        let x = v.num().ok_or_else(bad)?;
                        let (t, at) = self.traffic.get_or_insert_with(|| {
                            (
                                TrafficDecl {
                                    density: 0.0,
                                    speed: (80.0 / 3.6, 120.0 / 3.6),
                                    radius: 300.0,
                                    time_gap: 1.5,
                                    politeness: 0.3,
                                    at: String::new(),
                                },
                                *span,
                            )
                        });
                        match name.as_str() {
                            "traffic_density" => {
                                t.density = x;
                                *at = *span;
                            }
                            "traffic_min_speed" => t.speed.0 = x,
                            "traffic_max_speed" => t.speed.1 = x,
                            "traffic_radius" => t.radius = x,
                            "traffic_time_gap" => t.time_gap = x,
                            _ => t.politeness = x,
                        }
                    }
                    _ => {}
                }
            }
        }
        Ok(())
    }

    /// Checks the traffic settings of every `extend test_config` together.
    fn traffic(&mut self) -> Result<(), ScenarioError> {
        if let Some((mut t, span)) = self.traffic.take() {
            t.at = self.lib.at(span);
            let at = t.at.clone();
            let t = t
                .check()
                .map_err(|e| ScenarioError::Elaboration(format!("{at}: {e}")))?;
            if t.density > 0.0 {
                self.test.config.traffic = Some(t);
            } else {
                self.test.notes.push(format!(
                    "{at}: traffic settings without a traffic_density above 0: no ambient traffic"
                ));
            }
        }
        Ok(())
    }

    fn constant(&self, e: &Expr) -> Result<Value, ScenarioError> {
        match self.cexpr(e, &Scope::default()) {
            CExpr::Const(v) => Ok(v),
            other => Err(ScenarioError::Elaboration(format!(
                "{}: expected a constant, found {other:?}",
                self.lib.at(e.span())
            ))),
        }
    }

    /// The SI factor of a unit.
    fn unit(&self, u: &str) -> f64 {
        self.lib.ix.units.get(u).map_or(1.0, |u| u.factor)
    }

    /// Resolves an expression in a scope.
    fn cexpr(&self, e: &Expr, sc: &Scope) -> CExpr {
        match e {
            Expr::Int { value, .. } => CExpr::Const(Value::Num(*value as f64)),
            Expr::Float { value, .. } => CExpr::Const(Value::Num(*value)),
            Expr::Physical { value, unit, .. } => CExpr::Const(Value::Num(value * self.unit(unit))),
            Expr::Str { value, .. } => CExpr::Const(Value::Str(value.clone())),
            Expr::Bool { value, .. } => CExpr::Const(Value::Bool(*value)),
            Expr::EnumRef { member, .. } => CExpr::Const(Value::Enum(member.clone())),
            Expr::Range { lo, hi, unit, .. } => {
                let f = unit.as_deref().map_or(1.0, |u| self.unit(u));
                let bound = |b: &Option<Box<Expr>>| {
                    b.as_deref().and_then(|x| match self.cexpr(x, sc) {
                        CExpr::Const(Value::Num(v)) => Some(v * f),
                        _ => None,
                    })
                };
                CExpr::Range(bound(lo), bound(hi))
            }
            Expr::List { items, .. } => {
                CExpr::List(items.iter().map(|x| self.cexpr(x, sc)).collect())
            }
            Expr::Unary { op, expr, .. } => {
                let inner = self.cexpr(expr, sc);
                match (op.as_str(), &inner) {
                    ("-", CExpr::Const(Value::Num(v))) => CExpr::Const(Value::Num(-v)),
                    ("-", CExpr::Range(a, b)) => CExpr::Range(b.map(|v| -v), a.map(|v| -v)),
                    _ => CExpr::Unary(op.clone(), Box::new(inner)),
                }
            }
            Expr::Binary { op, lhs, rhs, .. } => CExpr::Binary(
                op.clone(),
                Box::new(self.cexpr(lhs, sc)),
                Box::new(self.cexpr(rhs, sc)),
            ),
            Expr::Ident { .. } | Expr::Field { .. } => match self.path(e, sc) {
                Some(p) => p,
                None => CExpr::Opaque(format!("{e:?}")),
            },
            // The engine's own methods over two actors (osc/domain):
            // `a.gap_to(b)`, `a.ttc_to(b)`.
            Expr::Call { callee, args, .. }
                if args.len() == 1
                    && matches!(&**callee, Expr::Field { name, .. } if name.text == "gap_to" || name.text == "ttc_to")
                    && let Expr::Field { base, name, .. } = &**callee
                    && let (Some(a), Some(b)) =
                        (self.path(base, sc), self.path(&args[0].value, sc)) =>
            {
                CExpr::Binary(name.text.clone(), Box::new(a), Box::new(b))
            }
            Expr::Ternary { span, .. }
            | Expr::Cast { span, .. }
            | Expr::Index { span, .. }
            | Expr::Call { span, .. }
            | Expr::Error { span } => {
                let f = self.lib.prog.sources.file(span.file);
                CExpr::Opaque(f.text[span.start as usize..span.end as usize].to_string())
            }
        }
    }

    /// `a.b.c` → an absolute path or an enum constant.
    fn path(&self, e: &Expr, sc: &Scope) -> Option<CExpr> {
        match e {
            Expr::Ident { name, .. } => {
                if name == "it" {
                    return sc.it.clone().map(CExpr::Var);
                }
                if sc.fields.contains(name) {
                    return Some(CExpr::Var(format!("{}.{name}", sc.ns)));
                }
                if let Some(ns) = sc.labels.get(name) {
                    return Some(CExpr::Var(ns.clone()));
                }
                if name == "actor" {
                    return sc.actor.clone().map(CExpr::Var);
                }
                if name == "sut" || name == "top" {
                    return Some(CExpr::Var(name.clone()));
                }
                if self.lib.ix.is_enum_member(name) {
                    return Some(CExpr::Const(Value::Enum(name.clone())));
                }
                Some(CExpr::Var(format!("{}.{name}", sc.ns)))
            }
            Expr::Field { base, name, .. } => match self.path(base, sc)? {
                CExpr::Var(p) => Some(CExpr::Var(format!("{p}.{}", name.text))),
                _ => None,
            },
            _ => None,
        }
    }

    /// Resolves an actor reference to its id.
    fn actor_of(&self, e: &Expr, sc: &Scope) -> Option<String> {
        match self.path(e, sc)? {
            CExpr::Var(p) => self.actor_ids.get(&p).cloned(),
            _ => None,
        }
    }

    /// Declares a scenario's fields under `sc.ns`.
    fn fields(&mut self, members: &[&Member], sc: &mut Scope) -> Result<(), ScenarioError> {
        for m in members {
            let Member::Field(f) = m else { continue };
            for n in &f.names {
                sc.fields.insert(n.text.clone());
            }
        }
        for m in members {
            let Member::Field(f) = m else { continue };
            let t = f.ty.base.name.text.clone();
            for n in &f.names {
                let path = format!("{}.{}", sc.ns, n.text);
                let kind = [
                    ("vehicle", ActorClass::Vehicle),
                    ("person", ActorClass::Person),
                    ("cyclist", ActorClass::Cyclist),
                    ("animal", ActorClass::Animal),
                    ("stationary_object", ActorClass::Stationary),
                    ("physical_object", ActorClass::Stationary),
                ]
                .into_iter()
                .find(|(b, _)| self.lib.is_a(&t, b))
                .map(|(_, k)| k);
                if let Some(kind) = kind {
                    let mut id = n.text.clone();
                    if self.test.actors.iter().any(|a| a.id == id) {
                        id = path.clone();
                    }
                    self.actor_ids.insert(path.clone(), id.clone());
                    self.test.actors.push(ActorDef {
                        id,
                        path: path.clone(),
                        type_name: t.clone(),
                        kind,
                        ego: false,
                    });
                } else {
                    let road = if self.lib.is_a(&t, "one_way_road") {
                        Some(RoadKind::OneWay)
                    } else if self.lib.is_a(&t, "two_way_road") {
                        Some(RoadKind::TwoWay)
                    } else if self.lib.is_a(&t, "road_element") {
                        Some(RoadKind::Road)
                    } else {
                        None
                    };
                    let default = f.default.as_ref().map(|d| self.cexpr(d, sc));
                    self.test.vars.insert(
                        path.clone(),
                        VarDef {
                            type_name: t.clone(),
                            road,
                            default,
                        },
                    );
                }
                // `with:` constraints on the field, with `it` bound.
                let mut inner = sc.clone();
                inner.it = Some(path.clone());
                for w in &f.with {
                    if let Member::Keep {
                        strength,
                        expr,
                        span,
                    } = w
                    {
                        self.keep(strength.as_deref(), expr, *span, &inner);
                    }
                }
            }
        }
        Ok(())
    }

    /// A condition over states: `rise(c)` / `fall(c)` become unary
    /// operators the planner evaluates on the planned samples.
    fn condition(&self, e: &Expr, sc: &Scope) -> CExpr {
        if let Expr::Call { callee, args, .. } = e
            && let Expr::Ident { name, .. } = &**callee
            && (name == "rise" || name == "fall")
            && let Some(a) = args.first()
        {
            return CExpr::Unary(name.clone(), Box::new(self.cexpr(&a.value, sc)));
        }
        self.cexpr(e, sc)
    }

    fn keep(&mut self, strength: Option<&str>, expr: &Expr, span: Span, sc: &Scope) {
        let c = Constraint {
            soft: strength == Some("default"),
            expr: self.cexpr(expr, sc),
            at: self.lib.at(span),
        };
        self.test.constraints.push(c);
    }

    /// A scenario body (or `top.main`'s): fields, keeps, then its `do`.
    fn body(&mut self, members: &[&Member], mut sc: Scope) -> Result<Option<Node>, ScenarioError> {
        self.depth += 1;
        if self.depth > 32 {
            return Err(ScenarioError::Elaboration(
                "scenarios invoke each other more than 32 levels deep (recursion?)".into(),
            ));
        }
        self.fields(members, &mut sc)?;
        // Labels first: keeps may name them before the `do`.
        for m in members {
            if let Member::Do(d) = m {
                self.collect_labels(d, &mut sc);
            }
        }
        let mut root = None;
        for m in members {
            match m {
                Member::Keep {
                    strength,
                    expr,
                    span,
                } => self.keep(strength.as_deref(), expr, *span, &sc),
                Member::Do(d) => {
                    let n = self.node(d, &sc)?;
                    if root.is_some() {
                        self.test
                            .notes
                            .push("a second `do` in one scenario is ignored".into());
                    } else {
                        root = n;
                    }
                }
                Member::Method { name, .. } => self.test.notes.push(format!(
                    "method '{}' in {}: not executed by the engine",
                    name.text, sc.ns
                )),
                // A plain `event e` is what `emit e` raises and `@e` waits
                // for; only a definition (`event e is …`) goes unevaluated.
                Member::Event {
                    name, is: Some(_), ..
                } => self.test.notes.push(format!(
                    "event '{}' in {}: its `is` definition is not evaluated; only `emit {}` raises it",
                    name.text, sc.ns, name.text
                )),
                Member::On { .. } => self
                    .test
                    .notes
                    .push(format!("`on` in {}: not executed by the engine", sc.ns)),
                Member::Coverage { record, args, span } => self.cover(*record, args, *span, &sc),
                _ => {}
            }
        }
        self.depth -= 1;
        Ok(root)
    }

    /// A `cover`/`record` item (the checker has vetted its arguments).
    fn cover(&mut self, record: bool, args: &[Arg], span: Span, sc: &Scope) {
        use crate::coverage::{CoverItem, SampleAt};
        let named = |n: &str| {
            args.iter()
                .find(|a| a.name.as_ref().is_some_and(|x| x.text == n))
                .map(|a| &a.value)
        };
        let name = match (args.first(), named("name")) {
            (_, Some(Expr::Ident { name, .. })) => name.clone(),
            (
                Some(Arg {
                    name: None,
                    value: Expr::Ident { name, .. },
                }),
                _,
            ) => name.clone(),
            _ => return,
        };
        let at = self.lib.at(span);
        let expr = match named("expression") {
            Some(e) => self.cexpr(e, sc),
            None => self
                .path(
                    &Expr::Ident {
                        name: name.clone(),
                        span,
                    },
                    sc,
                )
                .unwrap_or(CExpr::Opaque(name.clone())),
        };
        let unit = match named("unit") {
            Some(Expr::Ident { name, .. }) => Some(name.clone()),
            _ => None,
        };
        let factor = unit.as_deref().map_or(1.0, |u| self.unit(u));
        // A bound or width: physical literals convert to the item's unit,
        // plain numbers are in it.
        let in_unit = |e: &Expr| -> Option<f64> {
            match e {
                Expr::Physical { value, unit, .. } => Some(value * self.unit(unit) / factor),
                Expr::Int { value, .. } => Some(*value as f64),
                Expr::Float { value, .. } => Some(*value),
                Expr::Unary { op, expr, .. } if op == "-" => match &**expr {
                    Expr::Physical { value, unit, .. } => Some(-value * self.unit(unit) / factor),
                    Expr::Int { value, .. } => Some(-(*value as f64)),
                    Expr::Float { value, .. } => Some(-value),
                    _ => None,
                },
                _ => None,
            }
        };
        let range = match named("range") {
            Some(Expr::Range { lo, hi, unit, .. }) => {
                let scale = unit.as_deref().map_or(1.0, |u| self.unit(u) / factor);
                match (
                    lo.as_deref().and_then(in_unit),
                    hi.as_deref().and_then(in_unit),
                ) {
                    (Some(a), Some(b)) => Some((a * scale, b * scale)),
                    _ => None,
                }
            }
            _ => None,
        };
        let every = named("every").and_then(in_unit);
        // Enum and bool items bucket by value.
        let values = match &expr {
            CExpr::Var(p) => match self.test.vars.get(p).map(|v| v.type_name.as_str()) {
                Some("bool") => vec!["false".into(), "true".into()],
                Some(t) => self
                    .lib
                    .ix
                    .enums
                    .get(t)
                    .map(|m| m.iter().cloned().collect())
                    .unwrap_or_default(),
                None => Vec::new(),
            },
            _ => Vec::new(),
        };
        let event = match named("event") {
            Some(Expr::Ident { name: e, .. }) if e == "start" => SampleAt::Start,
            Some(Expr::Ident { name: e, .. }) if e == "end" => SampleAt::End,
            Some(Expr::Ident { name: e, .. }) => match sc.labels.get(e) {
                Some(path) => SampleAt::PhaseEnd(path.clone()),
                None => {
                    self.test.notes.push(format!(
                        "{at}: {} '{name}' is sampled at event '{e}', which the engine does not raise: sampled at the end instead",
                        if record { "record" } else { "cover" }
                    ));
                    SampleAt::End
                }
            },
            // The default: the end of the enclosing scenario — its
            // invocation's end where the plan knows it (a labelled
            // invocation), else the end of the run.
            _ if sc.ns != "top" => SampleAt::PhaseEnd(sc.ns.clone()),
            _ => SampleAt::End,
        };
        let text = match named("text") {
            Some(Expr::Str { value, .. }) => Some(value.clone()),
            _ => None,
        };
        self.test.covers.push(CoverItem {
            name: format!("{}.{name}", sc.ns),
            record,
            expr,
            unit,
            factor,
            range,
            every,
            values,
            event,
            text,
            at,
        });
    }

    fn collect_labels(&mut self, d: &DoMember, sc: &mut Scope) {
        if let Some(l) = &d.label {
            let ns = if sc.ns == "top" {
                l.text.clone()
            } else {
                format!("{}.{}", sc.ns, l.text)
            };
            sc.labels.insert(l.text.clone(), ns);
        }
        if let DoKind::Composition { children, .. } = &d.kind {
            for c in children {
                self.collect_labels(c, sc);
            }
        }
    }

    fn mods(&mut self, with: &[Member], sc: &Scope, out: &mut Vec<Modifier>) {
        for m in with {
            match m {
                Member::Modifier { call, .. } => {
                    let Expr::Call { callee, args, span } = call else {
                        continue;
                    };
                    let name = match &**callee {
                        Expr::Ident { name, .. } => name.clone(),
                        Expr::Field { name, .. } => name.text.clone(),
                        _ => continue,
                    };
                    let key = modifier_key(&name);
                    let params = self.lib.params(&key);
                    let mut bound = self.bind(args, &params, sc);
                    self.lib.ints_drawn(&key, &mut bound);
                    out.push(Modifier {
                        kind: crate::intent::ModKind::of(&name),
                        args: bound,
                        name,
                        at: self.lib.at(*span),
                    });
                }
                Member::Keep {
                    strength,
                    expr,
                    span,
                } => self.keep(strength.as_deref(), expr, *span, sc),
                Member::Until(spec) => {
                    let at = self.lib.at(spec.span);
                    let arg = match (&spec.event, &spec.cond) {
                        (Some(e), _) => event_name(e)
                            .map(|n| ("event".to_string(), CExpr::Const(Value::Str(n)))),
                        (None, Some(c)) => Some(match elapsed_arg(c) {
                            Some(a) => ("elapsed".to_string(), self.cexpr(a, sc)),
                            None => ("cond".to_string(), self.condition(c, sc)),
                        }),
                        _ => None,
                    };
                    match arg {
                        Some((k, v)) => out.push(Modifier {
                            kind: crate::intent::ModKind::Until,
                            name: "until".into(),
                            args: BTreeMap::from([(k, v)]),
                            at,
                        }),
                        None => self
                            .test
                            .notes
                            .push(format!("{at}: `until` without an event or condition")),
                    }
                }
                _ => {}
            }
        }
    }

    fn bind(&self, args: &[Arg], params: &[String], sc: &Scope) -> BTreeMap<String, CExpr> {
        let mut out = BTreeMap::new();
        for (i, a) in args.iter().enumerate() {
            let name = match &a.name {
                Some(n) => n.text.clone(),
                None => params.get(i).cloned().unwrap_or_else(|| format!("#{i}")),
            };
            out.insert(name, self.cexpr(&a.value, sc));
        }
        out
    }

    /// An invocation in a `do` tree: a traffic light's `switch(color)`, an
    /// actor's action with its modifiers, or a scenario inlined under its
    /// label (its arguments bound as constraints on the instance's fields).
    fn invoke(
        &mut self,
        call: &Expr,
        with: &[Member],
        label: Option<String>,
        sc: &Scope,
    ) -> Result<Option<Node>, ScenarioError> {
        let Expr::Call { callee, args, span } = call else {
            return Ok(None);
        };
        let (base, name) = match &**callee {
            Expr::Field { base, name, .. } => (Some(&**base), name.text.clone()),
            Expr::Ident { name, .. } => (None, name.clone()),
            _ => return Ok(None),
        };
        let at = self.lib.at(*span);
        let mut mods = Vec::new();
        let light = base.and_then(|b| match self.path(b, sc) {
            Some(CExpr::Var(p))
                if self
                    .test
                    .vars
                    .get(&p)
                    .is_some_and(|v| self.lib.is_a(&v.type_name, "traffic_light")) =>
            {
                Some(p)
            }
            _ => None,
        });
        if let Some(light) = light {
            if name != "switch" {
                return Err(ScenarioError::Elaboration(format!(
                    "{at}: a traffic light can only `switch(color)`, not '{name}'"
                )));
            }
            let bound = self.bind(args, &["color".to_string()], sc);
            let color = bound
                .get("color")
                .cloned()
                .ok_or_else(|| ScenarioError::Elaboration(format!("{at}: switch needs a color")))?;
            return Ok(Some(Node::Switch {
                id: 0,
                light,
                color,
                at,
            }));
        }
        if let Some(action) = crate::intent::Action::parse(&name) {
            let actor = base.and_then(|b| self.actor_of(b, sc)).ok_or_else(|| {
                ScenarioError::Elaboration(format!(
                    "{at}: '{name}' needs an actor, e.g. `car1.{name}()`"
                ))
            })?;
            self.mods(with, sc, &mut mods);
            Ok(Some(Node::Action {
                id: 0,
                label,
                actor,
                action,
                mods,
                at,
            }))
        } else if let Some(members) = self.lib.scenario(&name) {
            self.counter += 1;
            let ns = match &label {
                Some(l) if sc.ns == "top" => l.clone(),
                Some(l) => format!("{}.{l}", sc.ns),
                None => format!("{}.{name}#{}", sc.ns, self.counter),
            };
            let actor = base.and_then(|b| match self.path(b, sc) {
                Some(CExpr::Var(p)) => Some(self.actor_ids.get(&p).cloned().unwrap_or(p)),
                _ => None,
            });
            let inner = Scope {
                ns: ns.clone(),
                actor,
                ..Scope::default()
            };
            let sub = self.body(&members, inner)?;
            // Arguments bind the instance's fields; the invocation's
            // `with:` keeps see the caller's names (`s.r1`).
            let params = self.lib.params(&name);
            for (p, v) in self.bind(args, &params, sc) {
                self.test.constraints.push(Constraint {
                    soft: false,
                    expr: CExpr::Binary(
                        "==".into(),
                        Box::new(CExpr::Var(format!("{ns}.{p}"))),
                        Box::new(v),
                    ),
                    at: at.clone(),
                });
            }
            self.mods(with, sc, &mut mods);
            Ok(Some(Node::Serial {
                id: 0,
                label,
                children: sub.into_iter().collect(),
                mods,
            }))
        } else {
            Err(ScenarioError::Elaboration(format!(
                "{at}: the engine cannot execute '{name}' (known actions: {})",
                crate::intent::Action::ALL
                    .map(crate::intent::Action::name)
                    .join(", ")
            )))
        }
    }

    fn node(&mut self, d: &DoMember, sc: &Scope) -> Result<Option<Node>, ScenarioError> {
        let label = d.label.as_ref().map(|l| l.text.clone());
        Ok(match &d.kind {
            DoKind::Composition {
                op,
                args,
                children,
                with,
            } => {
                let mut kids = Vec::new();
                for c in children {
                    if let Some(n) = self.node(c, sc)? {
                        kids.push(n);
                    }
                }
                let mut mods = Vec::new();
                let bound = self.bind(args, &["duration".into()], sc);
                let overlap = match bound.get("overlap") {
                    Some(CExpr::Const(v)) => v.text().unwrap_or("equal").to_string(),
                    _ => "equal".to_string(),
                };
                if let Some(dur) = bound.get("duration") {
                    mods.push(Modifier {
                        kind: crate::intent::ModKind::Duration,
                        name: "duration".into(),
                        args: BTreeMap::from([("duration".to_string(), dur.clone())]),
                        at: self.lib.at(d.span),
                    });
                }
                self.mods(with, sc, &mut mods);
                Some(match op.as_str() {
                    "parallel" => Node::Parallel {
                        id: 0,
                        label,
                        children: kids,
                        mods,
                        overlap,
                    },
                    "one_of" => Node::OneOf {
                        id: 0,
                        label,
                        children: kids,
                        mods,
                    },
                    _ => Node::Serial {
                        id: 0,
                        label,
                        children: kids,
                        mods,
                    },
                })
            }
            DoKind::Invoke { call, with } => self.invoke(call, with, label, sc)?,
            DoKind::Wait(spec) => {
                let event = spec.event.as_ref().and_then(event_name);
                let (duration, cond) = match &spec.cond {
                    Some(c) => match elapsed_arg(c) {
                        Some(a) => (Some(self.cexpr(a, sc)), None),
                        None => (None, Some(self.condition(c, sc))),
                    },
                    None => (None, None),
                };
                Some(Node::Wait {
                    id: 0,
                    duration,
                    event,
                    cond,
                })
            }
            DoKind::Emit { event } => {
                let e = match event {
                    Expr::Call { callee, .. } => &**callee,
                    other => other,
                };
                Some(Node::Emit {
                    id: 0,
                    event: event_name(e).unwrap_or_default(),
                })
            }
            DoKind::Call { .. } => {
                self.test
                    .notes
                    .push("`call` is not executed by the engine".into());
                None
            }
        })
    }
}

/// `go`, `first.end`: the dotted path of an event reference.
fn event_name(e: &Expr) -> Option<String> {
    match e {
        Expr::Ident { name, .. } => Some(name.clone()),
        Expr::Field { base, name, .. } => Some(format!("{}.{}", event_name(base)?, name.text)),
        Expr::Unary { op, expr, .. } if op == "@" => event_name(expr),
        _ => None,
    }
}

/// The argument of `elapsed(t)`.
fn elapsed_arg(e: &Expr) -> Option<&Expr> {
    match e {
        Expr::Call { callee, args, .. } if matches!(&**callee, Expr::Ident { name, .. } if name == "elapsed") => {
            args.first().map(|a| &a.value)
        }
        _ => None,
    }
}
