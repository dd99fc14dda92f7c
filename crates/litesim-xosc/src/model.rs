//! The typed scenario a `.xosc` file reads into: parameters resolved,
//! catalog references replaced by their entries, every element checked.
//! Each storyboard element keeps the place it is written (`at`), which
//! the player's notes and the summary's trigger list name.

use serde::Serialize;
use std::path::PathBuf;

/// `file:line:col` of an element.
pub type At = String;

/// A whole scenario.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Scenario {
    /// The file read.
    pub file: PathBuf,
    /// `FileHeader revMajor.revMinor` (1.0 … 1.3).
    pub version: (u32, u32),
    /// `FileHeader description`.
    pub description: String,
    /// Global parameters with their values after overrides, in declaration
    /// order.
    pub parameters: Vec<(String, String)>,
    /// `VariableDeclarations` (1.2): name and initial value, in order.
    pub variables: Vec<(String, String)>,
    /// `RoadNetwork/LogicFile`, resolved against the file's directory.
    pub map: Option<PathBuf>,
    /// `RoadNetwork/TrafficSignals`.
    pub signal_controllers: Vec<SignalController>,
    /// `Entities`, in order.
    pub entities: Vec<Entity>,
    /// `EntitySelection`s: name and members.
    pub selections: Vec<(String, Vec<String>)>,
    /// `Storyboard/Init` actions.
    pub init: Vec<Action>,
    /// `Storyboard/Story` elements.
    pub stories: Vec<Story>,
    /// `Storyboard/StopTrigger` (none: the run ends at its duration).
    pub stop_trigger: Option<Trigger>,
}

/// A traffic signal controller's phases.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SignalController {
    /// Its `name`.
    pub name: String,
    /// Offset of its first phase (s).
    pub delay: f64,
    /// (phase name, duration s, [(signal id, state)]).
    pub phases: Vec<SignalPhase>,
}

/// A `Phase` of a signal controller.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SignalPhase {
    /// Its `name`.
    pub name: String,
    /// `duration` (s).
    pub duration: f64,
    /// Each `TrafficSignalState`: signal id and state.
    pub states: Vec<(String, String)>,
}

/// A `ScenarioObject`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Entity {
    /// Its `name`.
    pub name: String,
    /// What it is.
    pub kind: EntityKind,
    /// Box centre in the entity frame (from the rear axle's ground point)
    /// and its size: x, y, z, length, width, height (m).
    pub bbox: [f64; 6],
    /// `ObjectController`, when it has one.
    pub controller: Option<Controller>,
    /// Where it is written (`file:line:col`).
    pub at: At,
}

/// What an entity is.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum EntityKind {
    /// `Vehicle`.
    Vehicle {
        /// The category attribute, as written.
        category: String,
        /// maxSpeed, maxAcceleration, maxDeceleration.
        performance: [f64; 3],
        /// Front axle: max steering (rad), wheel diameter, track width,
        /// position x and z (m); absent from 1.3 on.
        front_axle: Option<[f64; 5]>,
        /// Rear axle, likewise.
        rear_axle: [f64; 5],
        /// Mass (kg), when given (1.2+).
        mass: Option<f64>,
    },
    /// `Pedestrian`.
    Pedestrian {
        /// The category attribute, as written.
        category: String,
        /// Mass (kg).
        mass: f64,
    },
    /// `MiscObject`.
    MiscObject {
        /// The category attribute, as written.
        category: String,
        /// Mass (kg).
        mass: f64,
    },
}

/// An `ObjectController`'s `Controller`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Controller {
    /// Its `name`.
    pub name: String,
    /// `ExternalController` (esmini's name, also a `controllerType`-free
    /// property `external=true`): the entity is driven from outside —
    /// litesim's sut.car.
    pub external: bool,
    /// `Properties` as written.
    pub properties: Vec<(String, String)>,
}

/// `Story`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Story {
    /// Its `name`.
    pub name: String,
    /// Its `Act`s.
    pub acts: Vec<Act>,
    /// Where it is written (`file:line:col`).
    pub at: At,
}

/// `Act`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Act {
    /// Its `name`.
    pub name: String,
    /// Its `ManeuverGroup`s.
    pub groups: Vec<ManeuverGroup>,
    /// None (1.3): starts with the storyboard.
    pub start: Option<Trigger>,
    /// `StopTrigger`.
    pub stop: Option<Trigger>,
    /// Where it is written (`file:line:col`).
    pub at: At,
}

/// `ManeuverGroup`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ManeuverGroup {
    /// Its `name`.
    pub name: String,
    /// `maximumExecutionCount`.
    pub max_count: u32,
    /// `Actors/EntityRef`s.
    pub actors: Vec<String>,
    /// `Actors selectTriggeringEntities`.
    pub select_triggering: bool,
    /// Its `Maneuver`s (inline or from a catalog).
    pub maneuvers: Vec<Maneuver>,
    /// Where it is written (`file:line:col`).
    pub at: At,
}

/// `Maneuver`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Maneuver {
    /// Its `name`.
    pub name: String,
    /// Its `Event`s.
    pub events: Vec<Event>,
    /// Where it is written (`file:line:col`).
    pub at: At,
}

/// `Event priority`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Priority {
    /// `overwrite` (1.0–1.1) or `override` (1.2+).
    Override,
    /// `Skip`.
    Skip,
    /// `Parallel`.
    Parallel,
}

/// `Event`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Event {
    /// Its `name`.
    pub name: String,
    /// `priority`.
    pub priority: Priority,
    /// `maximumExecutionCount`.
    pub max_count: u32,
    /// Its `Action`s.
    pub actions: Vec<Action>,
    /// None: starts when its maneuver does.
    pub start: Option<Trigger>,
    /// Where it is written (`file:line:col`).
    pub at: At,
}

/// An `Action` (or an `Init` action): for `actors` (the maneuver group's,
/// or the `Private entityRef`), or global.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Action {
    /// Its `name`.
    pub name: String,
    /// The entities a private action acts on (empty for a global one).
    pub actors: Vec<String>,
    /// What it is.
    pub kind: ActionKind,
    /// Where it is written (`file:line:col`).
    pub at: At,
}

/// Where a transition's `value` is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Dimension {
    /// `Time`.
    Time,
    /// `Distance`.
    Distance,
    /// `Rate`.
    Rate,
}

/// `dynamicsShape`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Shape {
    /// `Step`.
    Step,
    /// `Linear`.
    Linear,
    /// `Cubic`.
    Cubic,
    /// `Sinusoidal`.
    Sinusoidal,
}

impl Shape {
    /// The shape's progress f(τ) ∈ [0, 1] at τ ∈ [0, 1].
    pub fn at(self, tau: f64) -> f64 {
        let t = tau.clamp(0.0, 1.0);
        match self {
            Shape::Step => 1.0,
            Shape::Linear => t,
            Shape::Cubic => t * t * (3.0 - 2.0 * t),
            Shape::Sinusoidal => (1.0 - litesim_core::math::cos(std::f64::consts::PI * t)) / 2.0,
        }
    }

    /// Peak slope of f over τ (for a `rate` taken as the peak rate).
    pub fn peak_slope(self) -> f64 {
        match self {
            Shape::Step | Shape::Linear => 1.0,
            Shape::Cubic => 1.5,
            Shape::Sinusoidal => std::f64::consts::FRAC_PI_2,
        }
    }
}

/// `TransitionDynamics`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Transition {
    /// `dynamicsShape`.
    pub shape: Shape,
    /// `dynamicsDimension`.
    pub dimension: Dimension,
    /// The `value` compared or set.
    pub value: f64,
    /// `followingMode follow` (1.2): within the entity's limits; else the
    /// exact shape (`position`, the default).
    pub follow: bool,
}

/// A speed target.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum SpeedTarget {
    /// `Absolute`.
    Absolute(f64),
    /// v_ref + value (`delta`) or v_ref · value (`factor`); `continuous`
    /// tracks the reference for good.
    Relative {
        /// The reference entity (`entityRef`).
        entity: String,
        /// The `value` compared or set.
        value: f64,
        /// `speedTargetValueType factor` (else `delta`).
        factor: bool,
        /// `continuous`.
        continuous: bool,
    },
}

/// A lane change's target.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum LaneTarget {
    /// A lane id.
    Absolute(i32),
    /// Lanes to the reference entity's left (+) or right (−).
    Relative {
        /// The reference entity.
        entity: String,
        /// Lanes to its left (+) or right (−).
        lanes: i32,
    },
}

/// A lane offset's target.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum OffsetTarget {
    /// `Absolute`.
    Absolute(f64),
    /// `Relative`.
    Relative {
        /// The reference entity.
        entity: String,
        /// Offset from the reference's lane position (m).
        value: f64,
    },
}

/// A trajectory's shape, its points in the world frame once the positions
/// are resolved (the player resolves them; positions here as written).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum TrajShape {
    /// Vertices: (time, position).
    Polyline(Vec<(Option<f64>, Position)>),
    /// start, curvature, curvaturePrime, length, startTime, stopTime.
    Clothoid {
        /// `StartTrigger`.
        start: Position,
        /// `curvature` (1/m).
        curvature: f64,
        /// `curvaturePrime` (1/m²).
        curvature_prime: f64,
        /// `length` (m).
        length: f64,
        /// `startTime` (s).
        start_time: Option<f64>,
        /// `stopTime` (s).
        stop_time: Option<f64>,
    },
    /// order, control points (time, weight, position), knots.
    Nurbs {
        /// `order`.
        order: u32,
        /// `ControlPoint`s: time, weight, position.
        points: Vec<(Option<f64>, f64, Position)>,
        /// `Knot` values.
        knots: Vec<f64>,
    },
}

/// A `Trajectory`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Trajectory {
    /// Its `name`.
    pub name: String,
    /// `closed`.
    pub closed: bool,
    /// `dynamicsShape`.
    pub shape: TrajShape,
}

/// `TimeReference/Timing`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Timing {
    /// Times are simulation time (else since the action's start).
    pub absolute: bool,
    /// `scale`.
    pub scale: f64,
    /// `offset` (m; a time offset in `Timing`).
    pub offset: f64,
}

/// A `Route`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Route {
    /// Its `name`.
    pub name: String,
    /// `closed`.
    pub closed: bool,
    /// (strategy, position).
    pub waypoints: Vec<(String, Position)>,
}

/// What an action does.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum ActionKind {
    /// `Teleport`.
    Teleport(Position),
    /// `Speed`.
    Speed {
        /// The dynamics.
        transition: Transition,
        /// The target.
        target: SpeedTarget,
    },
    /// `LaneChange`.
    LaneChange {
        /// The dynamics.
        transition: Transition,
        /// The target.
        target: LaneTarget,
        /// `targetLaneOffset` (m).
        target_offset: f64,
    },
    /// `LaneOffset`.
    LaneOffset {
        /// `continuous`.
        continuous: bool,
        /// `dynamicsShape`.
        shape: Shape,
        /// `maxLateralAcc` (m/s²; None: unbounded).
        max_lateral_acc: Option<f64>,
        /// The target.
        target: OffsetTarget,
    },
    /// `LongitudinalDistance`.
    LongitudinalDistance {
        /// The reference entity (`entityRef`).
        entity: String,
        /// Distance (m) or time gap (s).
        distance: Option<f64>,
        /// `timeGap` (s).
        time_gap: Option<f64>,
        /// `freespace`: between bounding boxes (else reference points).
        freespace: bool,
        /// `continuous`.
        continuous: bool,
        /// The actor ends ahead of (leads) the reference.
        leading: bool,
        /// maxAcceleration, maxDeceleration, maxSpeed (None: rigid).
        limits: Option<[f64; 3]>,
    },
    /// `Synchronize`.
    Synchronize {
        /// `masterEntityRef`.
        master: String,
        /// `TargetPositionMaster`.
        master_target: Position,
        /// The target.
        target: Position,
        /// An absolute final speed, or relative to the master's (delta or
        /// factor).
        final_speed: Option<SpeedTarget>,
        /// `targetTolerance` (m).
        tolerance: f64,
        /// `targetToleranceMaster` (m).
        master_tolerance: f64,
    },
    /// `FollowTrajectory`.
    FollowTrajectory {
        /// The trajectory.
        trajectory: Trajectory,
        /// `TimeReference/Timing` (None: no timing).
        timing: Option<Timing>,
        /// `followingMode position` (exact) or `follow`.
        follow: bool,
        /// `initialDistanceOffset` (m).
        initial_offset: f64,
    },
    /// `AssignRoute`.
    AssignRoute(Route),
    /// `AcquirePosition`.
    AcquirePosition(Position),
    /// `ActivateControllerAction`: lateral, longitudinal (None: unchanged).
    ActivateController {
        /// `lateral` (None: unchanged).
        lateral: Option<bool>,
        /// `longitudinal` (None: unchanged).
        longitudinal: Option<bool>,
    },
    /// `AssignControllerAction`.
    AssignController(Controller),
    /// `TrafficSignalState`.
    TrafficSignalState {
        /// The signal (`name`).
        signal: String,
        /// The `state` string.
        state: String,
    },
    /// `TrafficSignalController`.
    TrafficSignalController {
        /// `trafficSignalControllerRef`.
        controller: String,
        /// `phase`.
        phase: String,
    },
    /// `AddEntity`.
    AddEntity {
        /// The reference entity (`entityRef`).
        entity: String,
        /// The position.
        position: Position,
    },
    /// `DeleteEntity`.
    DeleteEntity {
        /// The reference entity (`entityRef`).
        entity: String,
    },
    /// `ParameterSetAction` / `VariableSetAction` (and modify: add or
    /// multiply).
    SetValue {
        /// A `VariableAction` (else a `ParameterAction`).
        variable: bool,
        /// Its `name`.
        name: String,
        /// How the value changes.
        op: ValueOp,
    },
    /// Read and logged as a note, not executed: environment actions,
    /// `CustomCommandAction`, visibility. The text says what.
    Note(String),
}

/// How a parameter or variable action changes the value.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum ValueOp {
    /// `Set`.
    Set(String),
    /// `Add`.
    Add(f64),
    /// `Multiply`.
    Multiply(f64),
}

/// An `Orientation`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Orientation {
    /// Heading (rad).
    pub h: f64,
    /// Pitch (rad).
    pub p: f64,
    /// Roll (rad).
    pub r: f64,
    /// Relative to the road (road/lane positions) or the reference entity;
    /// false: absolute (the world's frame).
    pub relative: bool,
}

/// A position, as written.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum Position {
    /// `World`.
    World {
        /// x (m).
        x: f64,
        /// y (m).
        y: f64,
        /// z (m).
        z: f64,
        /// Heading (rad).
        h: Option<f64>,
    },
    /// `RelativeWorld`.
    RelativeWorld {
        /// The reference entity (`entityRef`).
        entity: String,
        /// `dx` (m).
        dx: f64,
        /// `dy` (m).
        dy: f64,
        /// `Orientation`.
        orientation: Option<Orientation>,
    },
    /// `RelativeObject`.
    RelativeObject {
        /// The reference entity (`entityRef`).
        entity: String,
        /// `dx` (m).
        dx: f64,
        /// `dy` (m).
        dy: f64,
        /// `Orientation`.
        orientation: Option<Orientation>,
    },
    /// `Road`.
    Road {
        /// `roadId`.
        road: String,
        /// `s` (m).
        s: f64,
        /// `t` (m).
        t: f64,
        /// `Orientation`.
        orientation: Option<Orientation>,
    },
    /// `RelativeRoad`.
    RelativeRoad {
        /// The reference entity (`entityRef`).
        entity: String,
        /// `ds` or `dsLane` (m).
        ds: f64,
        /// `dt` (m).
        dt: f64,
        /// `Orientation`.
        orientation: Option<Orientation>,
    },
    /// `Lane`.
    Lane {
        /// `roadId`.
        road: String,
        /// `laneId`.
        lane: i32,
        /// `s` (m).
        s: f64,
        /// `offset` (m; a time offset in `Timing`).
        offset: f64,
        /// `Orientation`.
        orientation: Option<Orientation>,
    },
    /// `RelativeLane`.
    RelativeLane {
        /// The reference entity (`entityRef`).
        entity: String,
        /// `dLane`.
        dlane: i32,
        /// Along the road's reference line (`ds`) or the entity's lane
        /// centre (`dsLane`, 1.1).
        ds: f64,
        /// `dsLane` (along the lane centre) rather than `ds`.
        along_lane: bool,
        /// `offset` (m; a time offset in `Timing`).
        offset: f64,
        /// `Orientation`.
        orientation: Option<Orientation>,
    },
    /// `Route`.
    Route {
        /// `RouteRef`.
        route: Box<Route>,
        /// `InRoutePosition`.
        in_route: InRoute,
        /// `Orientation`.
        orientation: Option<Orientation>,
    },
}

/// `InRoutePosition`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum InRoute {
    /// `FromCurrentEntity`.
    FromCurrentEntity(String),
    /// `FromRoadCoordinates`.
    FromRoadCoordinates {
        /// `pathS` (m along the route).
        s: f64,
        /// `t` (m, left positive).
        t: f64,
    },
    /// `FromLaneCoordinates`.
    FromLaneCoordinates {
        /// `pathS` (m along the route).
        s: f64,
        /// `laneId`.
        lane: i32,
        /// `laneOffset` (m).
        offset: f64,
    },
}

/// `conditionEdge`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Edge {
    /// `Rising`.
    Rising,
    /// `Falling`.
    Falling,
    /// `RisingOrFalling`.
    RisingOrFalling,
    /// `None`.
    None,
}

/// A comparison `rule`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Rule {
    /// `EqualTo`.
    EqualTo,
    /// `GreaterThan`.
    GreaterThan,
    /// `LessThan`.
    LessThan,
    /// `GreaterOrEqual`.
    GreaterOrEqual,
    /// `LessOrEqual`.
    LessOrEqual,
    /// `NotEqualTo`.
    NotEqualTo,
}

impl Rule {
    /// `measured <rule> value`. `equalTo` on doubles holds within 1e-9
    /// (the standard defines no tolerance).
    pub fn holds(self, measured: f64, value: f64) -> bool {
        match self {
            Rule::EqualTo => (measured - value).abs() <= 1e-9,
            Rule::NotEqualTo => (measured - value).abs() > 1e-9,
            Rule::GreaterThan => measured > value,
            Rule::LessThan => measured < value,
            Rule::GreaterOrEqual => measured >= value,
            Rule::LessOrEqual => measured <= value,
        }
    }
}

/// A `Trigger`: condition groups OR'ed, conditions AND'ed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Trigger {
    /// Its `ManeuverGroup`s.
    pub groups: Vec<Vec<Condition>>,
}

/// A `Condition`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Condition {
    /// Its `name`.
    pub name: String,
    /// `delay` (s).
    pub delay: f64,
    /// `conditionEdge`.
    pub edge: Edge,
    /// What it is.
    pub kind: ConditionKind,
    /// Where it is written (`file:line:col`).
    pub at: At,
}

/// Distance measure of distance-like conditions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Measure {
    /// `Longitudinal`.
    Longitudinal,
    /// `Lateral`.
    Lateral,
    /// `Euclidean`.
    Euclidean,
}

/// `coordinateSystem`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Frame {
    /// `Entity`.
    Entity,
    /// `Lane`.
    Lane,
    /// `Road`.
    Road,
    /// `Trajectory`.
    Trajectory,
    /// `World`.
    World,
}

/// A storyboard element type (`StoryboardElementStateCondition`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ElementType {
    /// `Story`.
    Story,
    /// `Act`.
    Act,
    /// `ManeuverGroup`.
    ManeuverGroup,
    /// `Maneuver`.
    Maneuver,
    /// `Event`.
    Event,
    /// `Action`.
    Action,
}

/// A storyboard element state or transition.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ElementState {
    /// `Standby`.
    Standby,
    /// `Running`.
    Running,
    /// `Complete`.
    Complete,
    /// `StartTransition`.
    StartTransition,
    /// `EndTransition`.
    EndTransition,
    /// `StopTransition`.
    StopTransition,
    /// `SkipTransition`.
    SkipTransition,
}

/// What a condition tests.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum ConditionKind {
    /// For the triggering entities (all or any).
    Entity {
        /// `TriggeringEntities`.
        entities: Vec<String>,
        /// `triggeringEntitiesRule all` (else any).
        all: bool,
        /// The entity condition.
        test: EntityTest,
    },
    /// `SimulationTime`.
    SimulationTime {
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: f64,
    },
    /// `StoryboardElementState`.
    StoryboardElementState {
        /// `storyboardElementType`.
        element: ElementType,
        /// Its `name`.
        name: String,
        /// The `state` string.
        state: ElementState,
    },
    /// `Parameter`.
    Parameter {
        /// Its `name`.
        name: String,
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: String,
    },
    /// `Variable`.
    Variable {
        /// Its `name`.
        name: String,
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: String,
    },
    /// `TrafficSignal`.
    TrafficSignal {
        /// The signal (`name`).
        signal: String,
        /// The `state` string.
        state: String,
    },
}

/// An entity condition.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum EntityTest {
    /// `EndOfRoad`.
    EndOfRoad {
        /// `duration` (s).
        duration: f64,
    },
    /// With this entity (None: any object, of `by_type` if given).
    Collision {
        /// The reference entity (`entityRef`).
        entity: Option<String>,
        /// `ByType type`.
        by_type: Option<String>,
    },
    /// `Offroad`.
    Offroad {
        /// `duration` (s).
        duration: f64,
    },
    /// `TimeHeadway`.
    TimeHeadway {
        /// The reference entity (`entityRef`).
        entity: String,
        /// `freespace`: between bounding boxes (else reference points).
        freespace: bool,
        /// `coordinateSystem`.
        frame: Frame,
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: f64,
    },
    /// `TimeToCollision`.
    TimeToCollision {
        /// The reference entity (`entityRef`).
        entity: Option<String>,
        /// The position.
        position: Option<Position>,
        /// `freespace`: between bounding boxes (else reference points).
        freespace: bool,
        /// `coordinateSystem`.
        frame: Frame,
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: f64,
    },
    /// `Acceleration`.
    Acceleration {
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: f64,
    },
    /// `StandStill`.
    StandStill {
        /// `duration` (s).
        duration: f64,
    },
    /// `Speed`.
    Speed {
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: f64,
    },
    /// `RelativeSpeed`.
    RelativeSpeed {
        /// The reference entity (`entityRef`).
        entity: String,
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: f64,
    },
    /// `TraveledDistance`.
    TraveledDistance {
        /// The `value` compared or set.
        value: f64,
    },
    /// `ReachPosition`.
    ReachPosition {
        /// The position.
        position: Position,
        /// `targetTolerance` (m).
        tolerance: f64,
    },
    /// `Distance`.
    Distance {
        /// The position.
        position: Position,
        /// `freespace`: between bounding boxes (else reference points).
        freespace: bool,
        /// `relativeDistanceType`.
        measure: Measure,
        /// `coordinateSystem`.
        frame: Frame,
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: f64,
    },
    /// `RelativeDistance`.
    RelativeDistance {
        /// The reference entity (`entityRef`).
        entity: String,
        /// `freespace`: between bounding boxes (else reference points).
        freespace: bool,
        /// `relativeDistanceType`.
        measure: Measure,
        /// `coordinateSystem`.
        frame: Frame,
        /// The comparison `rule`.
        rule: Rule,
        /// The `value` compared or set.
        value: f64,
    },
}
