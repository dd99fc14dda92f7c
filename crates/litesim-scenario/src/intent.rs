//! Typed actions and modifiers: what each phase asks of its actor, decoded
//! once from the elaborated (name, arguments) after the test's parameters
//! are sampled. The planner and the live executor match on these types;
//! names are read here and nowhere else, so a modifier the domain adds is
//! one variant and one decoding arm, and a misspelt name cannot silently do
//! nothing in one place and something in another.

use crate::elab::Value;
use serde::Serialize;
use std::collections::BTreeMap;

/// The action of a phase (`actor.drive()`, …).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Action {
    /// `drive()`: a vehicle follows its lane.
    Drive,
    /// `remain_stationary()`: stands still for the phase.
    RemainStationary,
    /// `walk()`: a person or animal moves.
    Walk,
    /// `move()`: any actor moves.
    Move,
    /// `keep_speed()`: holds the speed it starts with, for the phase.
    KeepSpeed,
    /// `change_speed(target, …)`: reaches the target speed at the rate
    /// asked; ends when it is reached.
    ChangeSpeed,
    /// `change_lane(num_of_lanes, side, …)`: changes lanes; ends in the
    /// target lane.
    ChangeLane,
    /// `follow_lane()`: keeps to its lane, for the phase.
    FollowLane,
    /// `assign_speed(speed)`: has that speed at once (exactness over
    /// physics); takes no time.
    AssignSpeed,
    /// `keep_space_gap(reference)`: keeps the gap to the actor ahead that
    /// it has at its start, for the phase.
    KeepSpaceGap,
    /// `keep_time_headway(reference)`: keeps the time headway to the actor
    /// ahead that it has at its start, for the phase (an ACC's following).
    KeepTimeHeadway,
    /// `change_space_gap(target, reference)`: brings the gap to the actor
    /// ahead to `target`; ends when it is reached.
    ChangeSpaceGap,
    /// `change_time_headway(target, reference)`: brings the time headway
    /// to the actor ahead to `target`; ends when it is reached.
    ChangeTimeHeadway,
    /// `assign_position(position | odr_point | route_point)`: is there at
    /// once (exactness over physics); takes no time.
    AssignPosition,
    /// `assign_orientation(orientation)`: has that heading at once, kept
    /// while it stands; takes no time.
    AssignOrientation,
    /// `follow_path(absolute | relative, …)`: along a path at its own
    /// speed; ends at the path's end.
    FollowPath,
    /// `replay_path(…)`: likewise (a path has no times to be exact to).
    ReplayPath,
    /// `follow_trajectory(…)`: the trajectory's speed at each time as its
    /// target, within its acceleration; ends at the last point.
    FollowTrajectory,
    /// `replay_trajectory(…)`: where the trajectory is at each time.
    ReplayTrajectory,
    /// `assign_acceleration(a)`: has it at once; takes no time.
    AssignAcceleration,
    /// `change_acceleration(target, …)`: reaches it at its jerk; ends when
    /// reached.
    ChangeAcceleration,
    /// `keep_acceleration()`: holds the acceleration it has, for the phase.
    KeepAcceleration,
    /// `change_position(target_xyz | target_odr | target_st)`: drives to
    /// the target; ends level with it.
    ChangePosition,
}

impl Action {
    /// Every action, in the order the domain declares them.
    pub const ALL: [Action; 23] = [
        Action::Drive,
        Action::RemainStationary,
        Action::Walk,
        Action::Move,
        Action::KeepSpeed,
        Action::ChangeSpeed,
        Action::ChangeLane,
        Action::FollowLane,
        Action::AssignSpeed,
        Action::KeepSpaceGap,
        Action::KeepTimeHeadway,
        Action::ChangeSpaceGap,
        Action::ChangeTimeHeadway,
        Action::AssignPosition,
        Action::AssignOrientation,
        Action::FollowPath,
        Action::ReplayPath,
        Action::FollowTrajectory,
        Action::ReplayTrajectory,
        Action::AssignAcceleration,
        Action::ChangeAcceleration,
        Action::KeepAcceleration,
        Action::ChangePosition,
    ];

    /// The action called `name`; `None` for names the domain does not have
    /// (the checker rejects those before planning).
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "drive" => Action::Drive,
            "remain_stationary" => Action::RemainStationary,
            "walk" => Action::Walk,
            "move" => Action::Move,
            "keep_speed" => Action::KeepSpeed,
            "change_speed" => Action::ChangeSpeed,
            "change_lane" => Action::ChangeLane,
            "follow_lane" => Action::FollowLane,
            "assign_speed" => Action::AssignSpeed,
            "keep_space_gap" => Action::KeepSpaceGap,
            "keep_time_headway" => Action::KeepTimeHeadway,
            "change_space_gap" => Action::ChangeSpaceGap,
            "change_time_headway" => Action::ChangeTimeHeadway,
            "assign_position" => Action::AssignPosition,
            "assign_orientation" => Action::AssignOrientation,
            "follow_path" => Action::FollowPath,
            "replay_path" => Action::ReplayPath,
            "follow_trajectory" => Action::FollowTrajectory,
            "replay_trajectory" => Action::ReplayTrajectory,
            "assign_acceleration" => Action::AssignAcceleration,
            "change_acceleration" => Action::ChangeAcceleration,
            "keep_acceleration" => Action::KeepAcceleration,
            "change_position" => Action::ChangePosition,
            _ => return None,
        })
    }

    /// The name as written in OSC.
    pub fn name(self) -> &'static str {
        match self {
            Action::Drive => "drive",
            Action::RemainStationary => "remain_stationary",
            Action::Walk => "walk",
            Action::Move => "move",
            Action::KeepSpeed => "keep_speed",
            Action::ChangeSpeed => "change_speed",
            Action::ChangeLane => "change_lane",
            Action::FollowLane => "follow_lane",
            Action::AssignSpeed => "assign_speed",
            Action::KeepSpaceGap => "keep_space_gap",
            Action::KeepTimeHeadway => "keep_time_headway",
            Action::ChangeSpaceGap => "change_space_gap",
            Action::ChangeTimeHeadway => "change_time_headway",
            Action::AssignPosition => "assign_position",
            Action::AssignOrientation => "assign_orientation",
            Action::FollowPath => "follow_path",
            Action::ReplayPath => "replay_path",
            Action::FollowTrajectory => "follow_trajectory",
            Action::ReplayTrajectory => "replay_trajectory",
            Action::AssignAcceleration => "assign_acceleration",
            Action::ChangeAcceleration => "change_acceleration",
            Action::KeepAcceleration => "keep_acceleration",
            Action::ChangePosition => "change_position",
        }
    }

    /// A path or trajectory action.
    pub fn follows_path(self) -> bool {
        matches!(
            self,
            Action::FollowPath
                | Action::ReplayPath
                | Action::FollowTrajectory
                | Action::ReplayTrajectory
        )
    }

    /// A trajectory action (its path has times).
    pub fn timed(self) -> bool {
        matches!(self, Action::FollowTrajectory | Action::ReplayTrajectory)
    }
}

impl std::fmt::Display for Action {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::fmt::Display for LaneRelation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What a modifier is, decoded from its name once, when the test is
/// elaborated: the one place that reads a modifier's name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModKind {
    /// `duration(t)` of a phase.
    Duration,
    /// `until …` of a phase (event, elapsed time or condition).
    Until,
    /// `speed(v)`.
    Speed,
    /// `change_speed(v)`.
    ChangeSpeed,
    /// `acceleration(a)`.
    Acceleration,
    /// `position(…)`.
    Position,
    /// `lane(…)`.
    Lane,
    /// `change_lane(…)`.
    ChangeLane,
    /// `lateral(…)`.
    Lateral,
    /// `along(…)`.
    Along,
    /// `keep_speed()`.
    KeepSpeed,
    /// `keep_position()`.
    KeepPosition,
    /// `distance(d)`: the distance travelled in the phase.
    Distance,
    /// `physical_movement(option)`.
    PhysicalMovement,
    /// `avoid_collisions(avoid)`.
    AvoidCollisions,
    /// The gap a `keep_space_gap` action keeps (made by elaboration from
    /// the action's `reference`; no modifier has this name).
    KeepSpaceGap,
    /// The time headway a `keep_time_headway` action keeps (likewise).
    KeepTimeHeadway,
    /// `yaw(angle, …)`, and the heading `assign_orientation` gives.
    Yaw,
    /// The place an `assign_position` action jumps to (made by
    /// elaboration from its argument).
    AssignPosition,
    /// The path a path or trajectory action follows (likewise).
    FollowPath,
    /// The acceleration an acceleration action sets or keeps (likewise).
    Accel,
    /// The offset from its lane's centre `follow_lane(offset)` keeps
    /// (likewise).
    LaneOffset,
    /// Any other modifier: planning has no use for it (a note names it).
    Other,
}

impl ModKind {
    /// The kind of the modifier called `name`.
    pub fn of(name: &str) -> Self {
        match name {
            "duration" => ModKind::Duration,
            "until" => ModKind::Until,
            "speed" => ModKind::Speed,
            "change_speed" => ModKind::ChangeSpeed,
            "acceleration" => ModKind::Acceleration,
            "position" => ModKind::Position,
            "lane" => ModKind::Lane,
            "change_lane" => ModKind::ChangeLane,
            "lateral" => ModKind::Lateral,
            "along" => ModKind::Along,
            "keep_speed" => ModKind::KeepSpeed,
            "keep_position" => ModKind::KeepPosition,
            "distance" => ModKind::Distance,
            "physical_movement" => ModKind::PhysicalMovement,
            "avoid_collisions" => ModKind::AvoidCollisions,
            "yaw" => ModKind::Yaw,
            _ => ModKind::Other,
        }
    }
}

/// When within its phase a modifier applies (`at:`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum At {
    /// From the phase's start on (`at: start`).
    Start,
    /// Reached by the phase's end (`at: end`).
    End,
    /// Throughout (`at: all`, the default).
    All,
}

impl At {
    /// Decodes `at:` (anything but `start`/`end` is `all`, the default).
    pub fn parse(text: &str) -> Self {
        match text {
            "start" => At::Start,
            "end" => At::End,
            _ => At::All,
        }
    }
}

/// A side of the road or of an actor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Left.
    Left,
    /// Right.
    Right,
}

impl Side {
    /// +1 for the left, −1 for the right: the sign of an offset to it
    /// (left positive).
    pub fn sign(self) -> f64 {
        match self {
            Side::Left => 1.0,
            Side::Right => -1.0,
        }
    }

    /// The side opposite.
    pub fn other(self) -> Side {
        match self {
            Side::Left => Side::Right,
            Side::Right => Side::Left,
        }
    }
}

/// A longitudinal relation to another actor (`position(…, ahead_of: X)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Order {
    /// In front of it.
    AheadOf,
    /// Behind it.
    Behind,
}

impl Order {
    /// +1 ahead, −1 behind.
    pub fn sign(self) -> f64 {
        match self {
            Order::AheadOf => 1.0,
            Order::Behind => -1.0,
        }
    }

    /// How a message says it (`ahead of`, `behind`).
    pub fn word(self) -> &'static str {
        match self {
            Order::AheadOf => "ahead of",
            Order::Behind => "behind",
        }
    }
}

/// A lane relation to another actor (`lane(same_as: X)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LaneRelation {
    /// The lane left of its lane.
    LeftOf,
    /// The lane right of its lane.
    RightOf,
    /// Its lane.
    SameAs,
}

impl LaneRelation {
    /// The parameter name in OSC (`left_of`, …).
    pub fn name(self) -> &'static str {
        match self {
            LaneRelation::LeftOf => "left_of",
            LaneRelation::RightOf => "right_of",
            LaneRelation::SameAs => "same_as",
        }
    }

    /// Lanes to the left of the reference's lane: +1, −1 or 0.
    pub fn offset(self) -> i32 {
        match self {
            LaneRelation::LeftOf => 1,
            LaneRelation::RightOf => -1,
            LaneRelation::SameAs => 0,
        }
    }
}

/// Which relation to another actor placement looks at first: the order in
/// which a phase's modifiers name the actor it is placed relative to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum RefKind {
    /// `ahead_of:`
    AheadOf,
    /// `behind:`
    Behind,
    /// `same_as:`
    SameAs,
    /// `left_of:`
    LeftOf,
    /// `right_of:`
    RightOf,
    /// `side_of:`
    SideOf,
}

/// One modifier of a phase, its arguments evaluated.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "modifier", rename_all = "snake_case")]
pub enum Intent {
    /// `speed(v)` (`strict` unless `run_mode: best_effort`) and
    /// `change_speed(v)` (never strict).
    Speed {
        /// Target speed (m/s).
        speed: f64,
        /// When.
        at: At,
        /// A strict `speed` that is not reached fails the run.
        strict: bool,
        /// Written as `change_speed` (it does not set the start speed).
        change: bool,
        /// The standard's `change_speed(v)`: `speed` is a signed change
        /// from the speed the phase starts with, not a target.
        delta: bool,
        /// `change_speed(…, rate_profile: smooth)`: reached along a
        /// half-cosine whose steepest slope is the phase's rate.
        smooth: bool,
        /// `faster_than: X` (+1), `slower_than: X` (−1) or `same_as: X` (0):
        /// the speed is X's speed plus the sign times `speed` (0 when not
        /// given), as X's plan has it at each sample of the phase.
        relative: Option<(f64, String)>,
    },
    /// `acceleration(a)`: the rate of the phase's speed changes.
    Acceleration {
        /// |a| (m/s²); relative to another actor, the signed offset's size.
        accel: f64,
        /// When.
        at: At,
        /// `faster_than: X` (+1), `slower_than: X` (−1) or `same_as: X`
        /// (0): the acceleration is X's planned one plus the sign times
        /// `accel`, at every sample of the phase.
        relative: Option<(f64, String)>,
    },
    /// `position(d | time: τ, ahead_of|behind: X)`.
    Position {
        /// Distance (m), if given.
        distance: Option<f64>,
        /// Headway (s), if given instead.
        time: Option<f64>,
        /// Relative to whom.
        reference: Option<(Order, String)>,
        /// When.
        at: At,
        /// A strict miss fails the run.
        strict: bool,
    },
    /// `lane(n)` or `lane(same_as|left_of|right_of: X)`.
    Lane {
        /// Lane number counted from the road's edge in the direction of
        /// travel (1 = first); negative counts from the left (−1 = the
        /// leftmost lane that way: `lane(1, from: left)`).
        lane: Option<f64>,
        /// Relative to whom.
        reference: Option<(LaneRelation, String)>,
        /// When.
        at: At,
        /// A strict miss fails the run.
        strict: bool,
    },
    /// `change_lane(num_of_lanes, side)`.
    ChangeLane {
        /// How many lanes.
        lanes: i32,
        /// Which way.
        side: Side,
        /// The side was written; not written, the standard draws one
        /// (seeded, when the leaves are resolved) and the planner takes the
        /// other when the drawn one has no lane.
        side_given: bool,
        /// `side: inside` (true: towards the road's centre, the left under
        /// right-hand traffic) or `outside` (false): the planner takes the
        /// side from the road's rule.
        inside: Option<bool>,
        /// `rate_peak` (m/s): the peak sideways speed, which sets how long
        /// the change takes (its sideways profile's peak is 1.5 · width /
        /// time); `None`: the phase's time within 2–6 s.
        rate: Option<f64>,
        /// When.
        at: At,
    },
    /// `lateral(distance, side, side_of: X)`: beside the lane (or beside another actor).
    Lateral {
        /// Offset from the lane centre (m), or the distance to the
        /// reference as `measure` measures it.
        distance: f64,
        /// Which side.
        side: Side,
        /// The actor it stays beside, if any.
        side_of: Option<String>,
        /// Between which edges `distance` is measured (beside a
        /// reference; from a lane's centre, centre to centre).
        measure: LatMeasure,
        /// When.
        at: At,
    },
    /// `along(road, start_offset)`.
    Along {
        /// Road id, if given.
        road: Option<String>,
        /// Start s (m), if given.
        start_offset: Option<f64>,
        /// `end_offset` (m), if given and not 0: the phase ends this far
        /// before the road's end.
        end_offset: Option<f64>,
        /// When.
        at: At,
    },
    /// `keep_speed()`: the speed at the phase's start, held.
    KeepSpeed {
        /// When.
        at: At,
    },
    /// `keep_position()`: stays where it is for the phase.
    KeepPosition {
        /// When.
        at: At,
    },
    /// `distance(d)`: travels `d` in the phase.
    Distance {
        /// Metres.
        distance: f64,
        /// When.
        at: At,
    },
    /// Keeps the gap (`headway` false) or the time headway (true) to
    /// `reference`, as they are at the phase's start, or changes it to
    /// `target` (`change_space_gap`, `change_time_headway`).
    KeepGap {
        /// The actor ahead.
        reference: String,
        /// Time headway rather than space gap.
        headway: bool,
        /// The gap (m) or headway (s) to reach; `None` keeps the one it
        /// has.
        target: Option<f64>,
        /// `direction: behind`: the reference is behind the actor (it
        /// leads); `ahead`: ahead of it (it follows); `None`
        /// (`keep_space_gap`'s `longitudinal`): whichever it is at the
        /// phase's start.
        behind: Option<bool>,
    },
    /// A gap sideways to `reference`: `keep_space_gap(…, direction:
    /// lateral)` keeps the one it has, `change_space_gap(…, direction:
    /// left | right | inside | outside)` brings it to `target`.
    LateralGap {
        /// The other actor.
        reference: String,
        /// The free space (m) to reach; `None` keeps the one it has.
        target: Option<f64>,
        /// Where the other actor is; `None`: where it is at the start.
        side: Option<GapSide>,
    },
    /// `avoid_collisions(avoid)`: drivers avoid others by default;
    /// `false` lets this one collide where the scenario asks it to.
    AvoidCollisions {
        /// Avoid (the default) or not.
        avoid: bool,
    },
    /// `physical_movement(option)`: litesim's motion is always physical;
    /// `prefer_non_physical` is a preference it notes.
    PhysicalMovement {
        /// The option's name.
        option: String,
    },
    /// `yaw(angle, relative_to, measure_by)`: the heading for the phase.
    Yaw {
        /// Radians.
        angle: f64,
        /// Relative to this actor's planned heading, if given.
        relative_to: Option<String>,
        /// A compass heading (clockwise from north, +y) rather than one
        /// relative to the road.
        north: bool,
        /// A heading in the map's frame (0 along +x, counter-clockwise):
        /// `orientation(…, measured_by: absolute)`.
        world: bool,
        /// Kept after the phase while the actor stands
        /// (`assign_orientation`).
        hold: bool,
        /// `at: start` (its first sample only), `end` (turned to by the
        /// phase's end) or `all`.
        when: At,
    },
    /// Where `assign_position` puts the actor.
    AssignPosition {
        /// The place.
        place: Place,
        /// `change_position(…, on_road_network: false)`: there in a
        /// straight line, off the roads.
        off_road: bool,
    },
    /// The acceleration an acceleration action sets (`target`, at `jerk`
    /// or at once) or keeps (no target).
    Accel {
        /// m/s².
        target: Option<f64>,
        /// m/s³; `None`: at once.
        jerk: Option<f64>,
        /// `rate_profile: smooth`: along a half-cosine whose steepest
        /// slope is `jerk`.
        smooth: bool,
    },
    /// `follow_lane(offset, rate_peak)`: this far from the lane's centre
    /// (m, left positive), reached at `rate` (m/s sideways).
    LaneOffset {
        /// Metres.
        offset: f64,
        /// m/s.
        rate: f64,
    },
    /// The path a path or trajectory action follows.
    FollowPath {
        /// Index into the test's paths.
        path: usize,
        /// A relative path's reference (the actor itself when `None`).
        reference: Option<String>,
        /// How a relative path's points are placed on its reference
        /// (`transform`).
        frame: PathFrame,
        /// Metres of the path skipped at its start, and left at its end.
        offsets: (f64, f64),
        /// Where the trajectory is at each time (`replay_trajectory`).
        exact: bool,
    },
    /// A modifier the planner has no use for (kept so a note can name it).
    Other {
        /// Its name.
        name: String,
        /// When.
        at: At,
    },
}

/// A place on the map an actor is put at.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Place {
    /// A point of the map's frame (m): the lane there, beside its centre
    /// as far as the point is.
    Xy {
        /// x.
        x: f64,
        /// y.
        y: f64,
    },
    /// OpenDRIVE road and lane ids, `s` along the road's reference line,
    /// `t` sideways from the lane's centre (left positive).
    Odr {
        /// Road id.
        road: String,
        /// Lane id ("-1").
        lane: String,
        /// s (m).
        s: f64,
        /// t (m).
        t: f64,
    },
    /// A road of the scenario: its lane `lane` (1 = the first from the
    /// right the way the actor drives), `s` along it, `t` sideways.
    Route {
        /// Road id.
        road: String,
        /// Lane number.
        lane: f64,
        /// s (m).
        s: f64,
        /// t (m).
        t: f64,
    },
}

impl Place {
    /// The place `assign_position`'s arguments give (`kind` names which;
    /// the fields are under `kind.field`).
    fn decode(vals: &BTreeMap<String, Value>) -> Option<Self> {
        let num = |k: &str| vals.get(k).and_then(Value::num);
        let text = |k: &str| vals.get(k).and_then(|v| v.text().map(String::from));
        // An id written as text ("-1") or as a number (-1).
        let id = |k: &str| text(k).or_else(|| num(k).map(|n| format!("{}", n as i64)));
        Some(match text("kind").as_deref()? {
            "position" => Place::Xy {
                x: num("position.x").unwrap_or(0.0),
                y: num("position.y").unwrap_or(0.0),
            },
            "odr_point" => Place::Odr {
                road: id("odr_point.road_id")?,
                lane: id("odr_point.lane_id")?,
                s: num("odr_point.s").unwrap_or(0.0),
                t: num("odr_point.t").unwrap_or(0.0),
            },
            _ => Place::Route {
                road: text("route_point.route")?,
                lane: num("route_point.lane").unwrap_or(1.0),
                s: num("route_point.s").unwrap_or(0.0),
                t: num("route_point.t").unwrap_or(0.0),
            },
        })
    }
}

/// The `side` argument (`left` or `right`), `default` when not given.
fn side_arg(vals: &BTreeMap<String, Value>, default: Side) -> Side {
    match vals.get("side").and_then(Value::text) {
        Some("left") => Side::Left,
        Some("right") => Side::Right,
        _ => default,
    }
}

/// `speed`, `change_speed` or `acceleration` decoded: absolute, or
/// relative to another actor ([`RELATIVE_SPEED`]); `None` without a value.
fn speed_intent(
    kind: ModKind,
    at: At,
    vals: &BTreeMap<String, Value>,
    refs: &BTreeMap<String, String>,
) -> Option<Intent> {
    let num = |k: &str| vals.get(k).and_then(Value::num);
    let strict = vals.get("run_mode").and_then(Value::text) != Some("best_effort");
    let relative = RELATIVE_SPEED
        .iter()
        .find_map(|&(k, sign)| refs.get(k).map(|o| (sign, o.clone())));
    if kind == ModKind::Acceleration {
        return Some(Intent::Acceleration {
            accel: num("acceleration").or(relative.as_ref().map(|_| 0.0))?,
            at,
            relative,
        });
    }
    let change = kind == ModKind::ChangeSpeed;
    // `change_speed(target: v)`: litesim's (and CARLA's) target.
    let target = num("target").filter(|_| change);
    Some(Intent::Speed {
        // Relative to another actor, the speed is an offset: none given
        // (`speed(same_as: x)`) is 0.
        speed: target.or(num("speed")).or(relative.as_ref().map(|_| 0.0))?,
        at,
        strict: strict && !change,
        change,
        delta: change && target.is_none(),
        smooth: vals.get("rate_profile").and_then(Value::text) == Some("smooth"),
        relative,
    })
}

/// A kept or changed gap or headway decoded: along the road
/// ([`Intent::KeepGap`]) or sideways ([`Intent::LateralGap`], a space gap
/// whose `direction` is `lateral`, `left`, `right`, `inside` or
/// `outside`); `None` without its reference.
fn gap_intent(
    kind: ModKind,
    vals: &BTreeMap<String, Value>,
    refs: &BTreeMap<String, String>,
) -> Option<Intent> {
    let direction = vals.get("direction").and_then(Value::text);
    let reference = refs.get("reference")?.clone();
    let target = vals.get("target").and_then(Value::num);
    let side = match direction {
        Some("left") => Some(GapSide::Left),
        Some("right") => Some(GapSide::Right),
        Some("inside") => Some(GapSide::Inside),
        Some("outside") => Some(GapSide::Outside),
        _ => None,
    };
    if kind == ModKind::KeepSpaceGap && (side.is_some() || direction == Some("lateral")) {
        return Some(Intent::LateralGap {
            reference,
            target,
            side,
        });
    }
    Some(Intent::KeepGap {
        reference,
        headway: kind == ModKind::KeepTimeHeadway,
        target,
        behind: match direction {
            Some("behind") => Some(true),
            Some("longitudinal") => None,
            _ => Some(false),
        },
    })
}

/// Where the other actor of a sideways gap is (`change_space_gap`'s
/// `direction`): on the actor's left or right, or towards the road's
/// centre (`inside`) or its edge (`outside`) by the road's traffic rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GapSide {
    /// On its left.
    Left,
    /// On its right.
    Right,
    /// Towards the road's centre.
    Inside,
    /// Towards the road's edge.
    Outside,
}

/// How a relative path's points (x, y) are placed on its reference (the
/// standard's `relative_transform`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PathFrame {
    /// x ahead of the reference, y to its left (`object_relative`).
    Object,
    /// x and y along the map's axes (`world_relative`).
    World,
    /// x along the road from the reference (its direction of travel), y
    /// sideways from where the reference is: the path bends with the road
    /// (`road_relative`).
    Road,
    /// x along the reference's lane, y from that lane's centre
    /// (`lane_relative`).
    Lane,
}

/// Between which sides of the two actors `lateral(…, measure_by: …)`
/// measures its distance (the standard's `lat_measure_by`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LatMeasure {
    /// The facing edges (the standard's default).
    Closest,
    /// This actor's edge or centre to the reference's (`left_to_right`:
    /// its left edge to the reference's right edge).
    Between(Edge, Edge),
}

/// A side of an actor's outline, or its centre line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Edge {
    /// Its left edge.
    Left,
    /// Its centre line.
    Center,
    /// Its right edge.
    Right,
}

impl Edge {
    /// Its offset (m, left positive) from the centre, at width `w`.
    fn offset(self, w: f64) -> f64 {
        match self {
            Edge::Left => w / 2.0,
            Edge::Center => 0.0,
            Edge::Right => -w / 2.0,
        }
    }
}

impl LatMeasure {
    /// The measure named `text` (`None` for another name).
    pub fn parse(text: &str) -> Option<Self> {
        if text == "closest" {
            return Some(Self::Closest);
        }
        let edge = |e: &str| match e {
            "left" => Some(Edge::Left),
            "center" => Some(Edge::Center),
            "right" => Some(Edge::Right),
            _ => None,
        };
        let (mine, theirs) = text.split_once("_to_")?;
        Some(Self::Between(edge(mine)?, edge(theirs)?))
    }

    /// The offset (m, left positive) of this actor's centre from the
    /// reference's that puts `distance` between the measured edges on
    /// `side`: the edges' offset (this actor's less the reference's) is
    /// the distance towards that side, so centre = side · distance − own
    /// edge + reference's edge, with widths `w_me`, `w_ref`.
    pub fn centre_offset(self, distance: f64, side: Side, (w_me, w_ref): (f64, f64)) -> f64 {
        let s = side.sign();
        let (me, them) = match self {
            // Facing edges: its edge towards the reference, the
            // reference's towards it.
            Self::Closest => (-s * w_me / 2.0, s * w_ref / 2.0),
            Self::Between(mine, theirs) => (mine.offset(w_me), theirs.offset(w_ref)),
        };
        s * distance - me + them
    }
}

/// `lateral(…)` decoded: beside the lane centre or beside another actor.
fn lateral_intent(
    vals: &BTreeMap<String, Value>,
    refs: &BTreeMap<String, String>,
    at: At,
) -> Intent {
    let num = |k: &str| vals.get(k).and_then(Value::num);
    let side = |default| side_arg(vals, default);

    // `left_of: x` is `side_of: x, side: left`; `same_as: x`
    // beside it by `distance` (0 when not given).
    let (side_of, side, default) = match (
        refs.get("left_of"),
        refs.get("right_of"),
        refs.get("same_as"),
    ) {
        (Some(o), ..) => (Some(o.clone()), Side::Left, 2.0),
        (_, Some(o), _) => (Some(o.clone()), Side::Right, 2.0),
        (.., Some(o)) => (Some(o.clone()), side(Side::Left), 0.0),
        _ => (refs.get("side_of").cloned(), side(Side::Right), 2.0),
    };
    // Beside a reference, the standard measures between the facing edges
    // unless told otherwise; from a lane's centre, the centre's offset.
    let measure = vals
        .get("measure_by")
        .and_then(Value::text)
        .and_then(LatMeasure::parse)
        .unwrap_or(if side_of.is_some() && !refs.contains_key("same_as") {
            LatMeasure::Closest
        } else {
            LatMeasure::Between(Edge::Center, Edge::Center)
        });
    Intent::Lateral {
        distance: num("distance").unwrap_or(default),
        side,
        side_of,
        measure,
        at,
    }
}

/// `lane(…)` decoded: a number (from the left as a negative one) or a
/// relation to another actor.
fn lane_intent(
    vals: &BTreeMap<String, Value>,
    refs: &BTreeMap<String, String>,
    at: At,
    strict: bool,
) -> Intent {
    let num = |k: &str| vals.get(k).and_then(Value::num);
    let text = |k: &str| vals.get(k).and_then(|v| v.text().map(String::from));
    let side = |default| side_arg(vals, default);
    Intent::Lane {
        // `from: left` (CARLA's numbering) as a negative number.
        lane: num("lane").map(|n| {
            if text("from").as_deref() == Some("left") {
                -n
            } else {
                n
            }
        }),
        // The first in parameter-name order, as written in the
        // domain (left_of, right_of, same_as).
        reference: [
            LaneRelation::LeftOf,
            LaneRelation::RightOf,
            LaneRelation::SameAs,
        ]
        .into_iter()
        .find_map(|r| refs.get(r.name()).map(|o| (r, o.clone())))
        // The standard's form: `side_of: x, side: left|right`.
        .or_else(|| {
            refs.get("side_of").map(|o| {
                let r = match side(Side::Left) {
                    Side::Left => LaneRelation::LeftOf,
                    Side::Right => LaneRelation::RightOf,
                };
                (r, o.clone())
            })
        }),
        at,
        strict,
    }
}

/// The `speed` modifier's references to another actor and the sign of the
/// offset each means; at most one of them may be given.
pub const RELATIVE_SPEED: [(&str, f64); 3] = [
    ("faster_than", 1.0),
    ("slower_than", -1.0),
    ("same_as", 0.0),
];

impl Intent {
    /// Decodes one modifier: its kind (and name, kept for notes), `at:`
    /// text, evaluated values and the actors its parameters name. `None`
    /// for a `speed`/`change_speed` or `acceleration` without a value (they
    /// ask for nothing).
    pub fn decode(
        (kind, name): (ModKind, &str),
        at: &str,
        vals: &BTreeMap<String, Value>,
        refs: &BTreeMap<String, String>,
    ) -> Option<Self> {
        let at = At::parse(at);
        let num = |k: &str| vals.get(k).and_then(Value::num);
        let text = |k: &str| vals.get(k).and_then(|v| v.text().map(String::from));
        let strict = vals.get("run_mode").and_then(Value::text) != Some("best_effort");
        let side = |default| side_arg(vals, default);
        Some(match kind {
            ModKind::Speed | ModKind::ChangeSpeed | ModKind::Acceleration => {
                speed_intent(kind, at, vals, refs)?
            }
            ModKind::Position => Intent::Position {
                distance: num("distance"),
                time: num("time"),
                reference: refs
                    .get("ahead_of")
                    .map(|o| (Order::AheadOf, o.clone()))
                    .or_else(|| refs.get("behind").map(|o| (Order::Behind, o.clone()))),
                at,
                strict,
            },
            ModKind::Lane => lane_intent(vals, refs, at, strict),
            ModKind::ChangeLane => Intent::ChangeLane {
                lanes: num("lane_changes")
                    .or_else(|| num("lane"))
                    .or_else(|| num("num_of_lanes"))
                    .unwrap_or(1.0) as i32,
                side: side(Side::Left),
                side_given: vals.contains_key("side"),
                inside: match text("side").as_deref() {
                    Some("inside") => Some(true),
                    Some("outside") => Some(false),
                    _ => None,
                },
                rate: num("rate").map(|r| r.abs().max(0.01)),
                at,
            },
            ModKind::Lateral => lateral_intent(vals, refs, at),
            ModKind::Along => Intent::Along {
                road: text("road").or_else(|| text("route")),
                end_offset: num("end_offset").filter(|&e| e != 0.0),
                start_offset: num("start_offset"),
                at,
            },
            ModKind::KeepSpeed => Intent::KeepSpeed { at },
            ModKind::KeepPosition => Intent::KeepPosition { at },
            ModKind::Distance => Intent::Distance {
                distance: num("distance")?,
                at,
            },
            ModKind::KeepSpaceGap | ModKind::KeepTimeHeadway => gap_intent(kind, vals, refs)?,
            ModKind::AvoidCollisions => Intent::AvoidCollisions {
                avoid: !matches!(vals.get("avoid"), Some(Value::Bool(false))),
            },
            ModKind::PhysicalMovement => Intent::PhysicalMovement {
                option: text("option").unwrap_or_default(),
            },
            ModKind::Yaw => Intent::Yaw {
                // Between axes of the two actors: its length to the
                // other's width is the other's heading plus a right angle.
                angle: num("angle")?
                    + match text("measure_by").as_deref() {
                        Some("length_to_width") => std::f64::consts::FRAC_PI_2,
                        Some("width_to_length") => -std::f64::consts::FRAC_PI_2,
                        _ => 0.0,
                    },
                relative_to: refs.get("relative_to").cloned(),
                north: text("measure_by").as_deref() == Some("relative_to_north"),
                world: text("measure_by").as_deref() == Some("absolute"),
                hold: vals.get("hold").and_then(Value::boolean).unwrap_or(false),
                when: at,
            },
            ModKind::AssignPosition => Intent::AssignPosition {
                place: Place::decode(vals)?,
                off_road: vals
                    .get("off_road")
                    .and_then(Value::boolean)
                    .unwrap_or(false),
            },
            ModKind::LaneOffset => Intent::LaneOffset {
                offset: num("offset")?,
                rate: num("rate").map_or(0.5, |r| r.abs().max(0.01)),
            },
            ModKind::Accel => Intent::Accel {
                target: num("target"),
                jerk: num("jerk"),
                smooth: text("rate_profile").as_deref() == Some("smooth"),
            },
            ModKind::FollowPath => Intent::FollowPath {
                path: num("path")? as usize,
                reference: refs.get("reference").cloned(),
                frame: match text("transform").as_deref() {
                    Some("world_relative") => PathFrame::World,
                    Some("road_relative") => PathFrame::Road,
                    Some("lane_relative") => PathFrame::Lane,
                    _ => PathFrame::Object,
                },
                offsets: (
                    num("start_offset").unwrap_or(0.0),
                    num("end_offset").unwrap_or(0.0),
                ),
                exact: vals.get("exact").and_then(Value::boolean).unwrap_or(false),
            },
            ModKind::Duration | ModKind::Until | ModKind::Other => Intent::Other {
                name: name.to_string(),
                at,
            },
        })
    }

    /// When the modifier applies.
    pub fn at(&self) -> At {
        match self {
            Intent::Speed { at, .. }
            | Intent::Acceleration { at, .. }
            | Intent::Position { at, .. }
            | Intent::Lane { at, .. }
            | Intent::ChangeLane { at, .. }
            | Intent::Lateral { at, .. }
            | Intent::Along { at, .. }
            | Intent::KeepSpeed { at }
            | Intent::KeepPosition { at }
            | Intent::Distance { at, .. }
            | Intent::Other { at, .. } => *at,
            Intent::PhysicalMovement { .. }
            | Intent::KeepGap { .. }
            | Intent::LateralGap { .. }
            | Intent::AvoidCollisions { .. }
            | Intent::Yaw { .. }
            | Intent::AssignPosition { .. }
            | Intent::FollowPath { .. }
            | Intent::Accel { .. }
            | Intent::LaneOffset { .. } => At::All,
        }
    }

    /// The other actor this modifier names under `kind`, if any.
    pub fn reference(&self, kind: RefKind) -> Option<&str> {
        match (self, kind) {
            (
                Intent::Position {
                    reference: Some((o, id)),
                    ..
                },
                RefKind::AheadOf | RefKind::Behind,
            ) if (*o == Order::AheadOf) == (kind == RefKind::AheadOf) => Some(id),
            (
                Intent::Lane {
                    reference: Some((r, id)),
                    ..
                },
                RefKind::SameAs | RefKind::LeftOf | RefKind::RightOf,
            ) if matches!(
                (r, kind),
                (LaneRelation::SameAs, RefKind::SameAs)
                    | (LaneRelation::LeftOf, RefKind::LeftOf)
                    | (LaneRelation::RightOf, RefKind::RightOf)
            ) =>
            {
                Some(id)
            }
            (
                Intent::Lateral {
                    side_of: Some(id), ..
                },
                RefKind::SideOf,
            ) => Some(id),
            _ => None,
        }
    }

    /// Every actor this modifier names.
    pub fn references(&self) -> impl Iterator<Item = &str> {
        let one = match self {
            Intent::Position {
                reference: Some((_, id)),
                ..
            }
            | Intent::Lane {
                reference: Some((_, id)),
                ..
            }
            | Intent::Lateral {
                side_of: Some(id), ..
            } => Some(id.as_str()),
            _ => None,
        };
        one.into_iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A modifier as elaboration hands it over.
    fn d(name: &str) -> (ModKind, &str) {
        (ModKind::of(name), name)
    }

    fn vals(kv: &[(&str, Value)]) -> BTreeMap<String, Value> {
        kv.iter().map(|(k, v)| (k.to_string(), v.clone())).collect()
    }

    fn refs(kv: &[(&str, &str)]) -> BTreeMap<String, String> {
        kv.iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn modifiers_decode_to_their_types() {
        let s = Intent::decode(
            d("speed"),
            "end",
            &vals(&[("speed", Value::Num(5.0))]),
            &refs(&[]),
        );
        assert_eq!(
            s,
            Some(Intent::Speed {
                speed: 5.0,
                at: At::End,
                strict: true,
                change: false,
                delta: false,
                smooth: false,
                relative: None,
            })
        );
        let best = vals(&[
            ("speed", Value::Num(5.0)),
            ("run_mode", Value::Enum("best_effort".into())),
        ]);
        assert!(matches!(
            Intent::decode(d("speed"), "all", &best, &refs(&[])),
            Some(Intent::Speed { strict: false, .. })
        ));
        assert!(matches!(
            Intent::decode(
                d("change_speed"),
                "all",
                &vals(&[("speed", Value::Num(1.0))]),
                &refs(&[])
            ),
            Some(Intent::Speed { strict: false, .. })
        ));
        assert_eq!(
            Intent::decode(d("speed"), "all", &vals(&[]), &refs(&[])),
            None
        );
        let p = Intent::decode(
            d("position"),
            "end",
            &vals(&[("distance", Value::Num(5.0))]),
            &refs(&[("behind", "sut.car")]),
        )
        .unwrap();
        assert_eq!(p.reference(RefKind::Behind), Some("sut.car"));
        assert_eq!(p.reference(RefKind::AheadOf), None);
        let l = Intent::decode(d("lane"), "start", &vals(&[]), &refs(&[("left_of", "a")])).unwrap();
        assert_eq!(l.reference(RefKind::LeftOf), Some("a"));
        assert_eq!(l.references().collect::<Vec<_>>(), ["a"]);
        let c = Intent::decode(d("change_lane"), "all", &vals(&[]), &refs(&[])).unwrap();
        assert_eq!(
            c,
            Intent::ChangeLane {
                lanes: 1,
                side: Side::Left,
                side_given: false,
                inside: None,
                rate: None,
                at: At::All
            }
        );
        assert_eq!(At::parse("bogus"), At::All);
        assert_eq!(Action::parse("walk").map(Action::name), Some("walk"));
        assert_eq!(Action::parse("fly"), None);
    }
}
