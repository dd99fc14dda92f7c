//! What elaboration makes: the `Test` — run configuration, actors,
//! variables and constraints, traffic, thresholds — and its behaviour tree
//! of `Node`s with typed modifiers.

use super::*;

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
    /// `environment.rain(…)` and the other environment actions: the
    /// weather, the sun or the time of day changes at this time.
    Environment {
        /// Stable id: the node's place in a pre-order walk of the tree
        /// (numbered once elaboration is done; [`Node::id`]).
        #[serde(skip)]
        id: u32,
        /// The action (`rain`, `fog`, …; elaboration vetted it).
        action: String,
        /// Its arguments by parameter name.
        args: BTreeMap<String, CExpr>,
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
            | Node::Environment { id, .. }
            | Node::Emit { id, .. } => *id,
        }
    }

    /// Numbers the tree in pre-order from `next`.
    pub(super) fn number(&mut self, next: &mut u32) {
        let (Node::Serial { id, .. }
        | Node::Parallel { id, .. }
        | Node::OneOf { id, .. }
        | Node::Action { id, .. }
        | Node::Wait { id, .. }
        | Node::Switch { id, .. }
        | Node::Environment { id, .. }
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
    pub(super) fn check(self) -> Result<Self, String> {
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
    /// Paths and trajectories the actions follow, by index.
    pub paths: Vec<super::paths::PathDef>,
}
