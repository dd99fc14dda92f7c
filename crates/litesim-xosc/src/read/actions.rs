//! Actions: private (speed, lane change and offset, distances, synchronize,
//! teleport, routing, controllers), global (signals, entities, parameters
//! and variables; environment as a note) and user-defined (a note).

use super::entities::{object_controller, scoped, with_entry};
use super::positions::{position, trajectory};
use super::{Cx, R};
use crate::model::*;
use litesim_map::xml::Node;

/// What a refused element is told.
fn refused(cx: &Cx<'_>, n: Node<'_, '_>, what: &str) -> crate::error::XoscError {
    cx.err(
        n,
        format!("{} is not supported by litesim's player{what}", n.name()),
    )
}

/// A `PrivateAction` for `actors`.
pub(super) fn private(cx: &mut Cx<'_>, n: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(n, &[])?;
    let a = cx.choice(
        n,
        &[
            "LongitudinalAction",
            "LateralAction",
            "VisibilityAction",
            "SynchronizeAction",
            "ActivateControllerAction",
            "ControllerAction",
            "TeleportAction",
            "RoutingAction",
            "AppearanceAction",
            "TrailerAction",
        ],
    )?;
    cx.within(a, |cx| match a.name() {
        "LongitudinalAction" => {
            let c = cx.choice(a, &["SpeedAction", "LongitudinalDistanceAction", "SpeedProfileAction"])?;
            cx.within(c, |cx| match c.name() {
                "SpeedAction" => speed(cx, c),
                "LongitudinalDistanceAction" => longitudinal_distance(cx, c),
                _ => Err(refused(cx, c, " (SpeedAction is)")),
            })
        }
        "LateralAction" => {
            let c = cx.choice(a, &["LaneChangeAction", "LaneOffsetAction", "LateralDistanceAction"])?;
            cx.within(c, |cx| match c.name() {
                "LaneChangeAction" => lane_change(cx, c),
                "LaneOffsetAction" => lane_offset(cx, c),
                _ => Err(refused(cx, c, " (LaneChangeAction and LaneOffsetAction are)")),
            })
        }
        "VisibilityAction" => {
            cx.attrs(a, &["graphics", "sensors", "traffic"])?;
            Ok(ActionKind::Note(format!(
                "VisibilityAction (graphics {}, sensors {}, traffic {}) is recorded, not applied: litesim's objects are always seen",
                cx.req(a, "graphics")?,
                cx.req(a, "sensors")?,
                cx.req(a, "traffic")?
            )))
        }
        "SynchronizeAction" => synchronize(cx, a),
        "ActivateControllerAction" => activate(cx, a),
        "ControllerAction" => {
            cx.attrs(a, &[])?;
            cx.children(a, &["AssignControllerAction", "OverrideControllerValueAction", "ActivateControllerAction"])?;
            let mut out = None;
            for c in a.elements() {
                let k = match c.name() {
                    "AssignControllerAction" => cx.within(c, |cx| {
                        cx.attrs(c, &["activateLateral", "activateLongitudinal", "activateLighting", "activateAnimation"])?;
                        let inner = cx.choice(c, &["Controller", "CatalogReference", "ObjectController"])?;
                        let ctl = match inner.name() {
                            "Controller" => cx.within(inner, |cx| scoped(cx, inner, |cx| super::entities::controller(cx, inner)))?,
                            "CatalogReference" => with_entry(cx, inner, "ControllerCatalog", &["Controller"], |cx, e| {
                                cx.within(e, |cx| super::entities::controller(cx, e))
                            })?,
                            _ => object_controller(cx, inner)?,
                        };
                        Ok(ActionKind::AssignController(ctl))
                    })?,
                    "ActivateControllerAction" => cx.within(c, |cx| activate(cx, c))?,
                    _ => return Err(refused(cx, c, " (pedal and steering overrides are not modelled; AssignControllerAction and ActivateControllerAction are)")),
                };
                if out.is_some() {
                    return Err(cx.err(c, "one ControllerAction holds one controller action in litesim's player (write two Actions)"));
                }
                out = Some(k);
            }
            out.ok_or_else(|| cx.err(a, "<ControllerAction> needs one of AssignControllerAction or ActivateControllerAction"))
        }
        "TeleportAction" => {
            cx.attrs(a, &[])?;
            cx.children(a, &["Position"])?;
            let p = cx.child(a, "Position")?;
            Ok(ActionKind::Teleport(position(cx, p)?))
        }
        "RoutingAction" => {
            let c = cx.choice(a, &["AssignRouteAction", "FollowTrajectoryAction", "AcquirePositionAction", "RandomRouteAction"])?;
            cx.within(c, |cx| match c.name() {
                "AssignRouteAction" => {
                    cx.attrs(c, &[])?;
                    let r = cx.choice(c, &["Route", "CatalogReference"])?;
                    let route = if r.name() == "Route" {
                        cx.within(r, |cx| scoped(cx, r, |cx| super::positions::route(cx, r)))?
                    } else {
                        with_entry(cx, r, "RouteCatalog", &["Route"], |cx, e| cx.within(e, |cx| super::positions::route(cx, e)))?
                    };
                    Ok(ActionKind::AssignRoute(route))
                }
                "AcquirePositionAction" => {
                    cx.attrs(c, &[])?;
                    cx.children(c, &["Position"])?;
                    let p = cx.child(c, "Position")?;
                    Ok(ActionKind::AcquirePosition(position(cx, p)?))
                }
                "FollowTrajectoryAction" => follow_trajectory(cx, c),
                _ => Err(refused(cx, c, " (AssignRouteAction, FollowTrajectoryAction and AcquirePositionAction are)")),
            })
        }
        _ => Err(refused(cx, a, "")),
    })
}

fn activate(cx: &Cx<'_>, a: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(
        a,
        &[
            "lateral",
            "longitudinal",
            "lighting",
            "animation",
            "controllerRef",
            "objectControllerRef",
        ],
    )?;
    cx.children(a, &[])?;
    Ok(ActionKind::ActivateController {
        lateral: cx.opt_bool(a, "lateral")?,
        longitudinal: cx.opt_bool(a, "longitudinal")?,
    })
}

/// `TransitionDynamics` (or a speed/lane-change dynamics element).
fn transition(cx: &Cx<'_>, d: Node<'_, '_>) -> R<Transition> {
    cx.attrs(
        d,
        &[
            "dynamicsShape",
            "dynamicsDimension",
            "value",
            "followingMode",
        ],
    )?;
    cx.children(d, &[])?;
    let shape = shape(cx, d)?;
    let dimension = match cx
        .req_enum(d, "dynamicsDimension", &["time", "distance", "rate"])?
        .as_str()
    {
        "time" => Dimension::Time,
        "distance" => Dimension::Distance,
        _ => Dimension::Rate,
    };
    let value = cx.non_neg(d, "value")?;
    if shape != Shape::Step && value == 0.0 {
        return Err(cx.err(
            d,
            format!("a {shape:?} transition needs a value above 0 (a step takes no time)"),
        ));
    }
    let follow = match cx.enumer(d, "followingMode", &["position", "follow"])? {
        Some(m) => {
            cx.since(d, "followingMode", 2)?;
            m == "follow"
        }
        None => false,
    };
    Ok(Transition {
        shape,
        dimension,
        value,
        follow,
    })
}

fn shape(cx: &Cx<'_>, d: Node<'_, '_>) -> R<Shape> {
    Ok(
        match cx
            .req_enum(
                d,
                "dynamicsShape",
                &["step", "linear", "cubic", "sinusoidal"],
            )?
            .as_str()
        {
            "step" => Shape::Step,
            "linear" => Shape::Linear,
            "cubic" => Shape::Cubic,
            _ => Shape::Sinusoidal,
        },
    )
}

fn speed(cx: &mut Cx<'_>, s: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(s, &[])?;
    cx.children(s, &["SpeedActionDynamics", "SpeedActionTarget"])?;
    let transition = transition(cx, cx.child(s, "SpeedActionDynamics")?)?;
    let t = cx.child(s, "SpeedActionTarget")?;
    let c = cx.choice(t, &["AbsoluteTargetSpeed", "RelativeTargetSpeed"])?;
    let target = if c.name() == "AbsoluteTargetSpeed" {
        cx.attrs(c, &["value"])?;
        SpeedTarget::Absolute(cx.num(c, "value")?)
    } else {
        cx.attrs(
            c,
            &["entityRef", "value", "speedTargetValueType", "continuous"],
        )?;
        let continuous = cx
            .opt_bool(c, "continuous")?
            .ok_or_else(|| cx.err(c, "<RelativeTargetSpeed> needs the attribute 'continuous'"))?;
        if continuous && transition.dimension != Dimension::Rate && transition.shape != Shape::Step
        {
            return Err(cx.err(c, "a continuous relative speed tracks its reference for good: its dynamics are a rate or a step, not a time or a distance"));
        }
        SpeedTarget::Relative {
            entity: cx.req(c, "entityRef")?,
            value: cx.num(c, "value")?,
            factor: cx.req_enum(c, "speedTargetValueType", &["delta", "factor"])? == "factor",
            continuous,
        }
    };
    Ok(ActionKind::Speed { transition, target })
}

fn lane_change(cx: &mut Cx<'_>, l: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(l, &["targetLaneOffset"])?;
    cx.children(l, &["LaneChangeActionDynamics", "LaneChangeTarget"])?;
    let transition = transition(cx, cx.child(l, "LaneChangeActionDynamics")?)?;
    if transition.dimension == Dimension::Rate {
        return Err(cx.err(
            l,
            "a lane change's dynamics are a time or a distance, not a rate",
        ));
    }
    let t = cx.child(l, "LaneChangeTarget")?;
    let c = cx.choice(t, &["RelativeTargetLane", "AbsoluteTargetLane"])?;
    let int = |n: Node<'_, '_>| -> R<i32> {
        cx.opt_int(n, "value")?
            .map(|v| v as i32)
            .ok_or_else(|| cx.err(n, format!("<{}> needs the attribute 'value'", n.name())))
    };
    let target = if c.name() == "AbsoluteTargetLane" {
        cx.attrs(c, &["value"])?;
        LaneTarget::Absolute(int(c)?)
    } else {
        cx.attrs(c, &["entityRef", "value"])?;
        LaneTarget::Relative {
            entity: cx.req(c, "entityRef")?,
            lanes: int(c)?,
        }
    };
    Ok(ActionKind::LaneChange {
        transition,
        target,
        target_offset: cx.opt_num(l, "targetLaneOffset")?.unwrap_or(0.0),
    })
}

fn lane_offset(cx: &mut Cx<'_>, l: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(l, &["continuous"])?;
    cx.children(l, &["LaneOffsetActionDynamics", "LaneOffsetTarget"])?;
    let d = cx.child(l, "LaneOffsetActionDynamics")?;
    cx.attrs(d, &["dynamicsShape", "maxLateralAcc"])?;
    let max_lateral_acc = cx.opt_num(d, "maxLateralAcc")?;
    if max_lateral_acc.is_some_and(|a| a <= 0.0) {
        return Err(cx.err(d, "maxLateralAcc must be above 0"));
    }
    let t = cx.child(l, "LaneOffsetTarget")?;
    let c = cx.choice(t, &["RelativeTargetLaneOffset", "AbsoluteTargetLaneOffset"])?;
    let target = if c.name() == "AbsoluteTargetLaneOffset" {
        cx.attrs(c, &["value"])?;
        OffsetTarget::Absolute(cx.num(c, "value")?)
    } else {
        cx.attrs(c, &["entityRef", "value"])?;
        OffsetTarget::Relative {
            entity: cx.req(c, "entityRef")?,
            value: cx.num(c, "value")?,
        }
    };
    Ok(ActionKind::LaneOffset {
        continuous: cx
            .opt_bool(l, "continuous")?
            .ok_or_else(|| cx.err(l, "<LaneOffsetAction> needs the attribute 'continuous'"))?,
        shape: shape(cx, d)?,
        max_lateral_acc,
        target,
    })
}

fn longitudinal_distance(cx: &mut Cx<'_>, l: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(
        l,
        &[
            "entityRef",
            "distance",
            "timeGap",
            "freespace",
            "continuous",
            "displacement",
            "coordinateSystem",
        ],
    )?;
    cx.children(l, &["DynamicConstraints"])?;
    let distance = cx.opt_num(l, "distance")?;
    let time_gap = cx.opt_num(l, "timeGap")?;
    if distance.is_some() == time_gap.is_some() {
        return Err(cx.err(
            l,
            "<LongitudinalDistanceAction> takes exactly one of distance and timeGap",
        ));
    }
    if distance.or(time_gap).is_some_and(|v| v < 0.0) {
        return Err(cx.err(l, "a distance or time gap is at least 0"));
    }
    let displacement = cx.enumer(
        l,
        "displacement",
        &["trailingReferencedEntity", "leadingReferencedEntity", "any"],
    )?;
    if let Some(cs) = cx.enumer(
        l,
        "coordinateSystem",
        &["entity", "lane", "road", "trajectory", "world"],
    )? && cs != "entity"
        && cs != "lane"
        && cs != "road"
    {
        return Err(cx.err(l, format!("coordinateSystem {cs} is not supported for a distance action (entity, lane and road are: litesim measures along the road)")));
    }
    let limits = match cx.opt_child(l, "DynamicConstraints")? {
        Some(d) => {
            cx.attrs(
                d,
                &[
                    "maxAcceleration",
                    "maxDeceleration",
                    "maxSpeed",
                    "maxAccelerationRate",
                    "maxDecelerationRate",
                ],
            )?;
            let inf = |k| -> R<f64> { Ok(cx.opt_num(d, k)?.unwrap_or(f64::INFINITY)) };
            Some([
                inf("maxAcceleration")?,
                inf("maxDeceleration")?,
                inf("maxSpeed")?,
            ])
        }
        None => None,
    };
    Ok(ActionKind::LongitudinalDistance {
        entity: cx.req(l, "entityRef")?,
        distance,
        time_gap,
        freespace: cx.opt_bool(l, "freespace")?.ok_or_else(|| {
            cx.err(
                l,
                "<LongitudinalDistanceAction> needs the attribute 'freespace'",
            )
        })?,
        continuous: cx.opt_bool(l, "continuous")?.ok_or_else(|| {
            cx.err(
                l,
                "<LongitudinalDistanceAction> needs the attribute 'continuous'",
            )
        })?,
        leading: displacement.as_deref() == Some("leadingReferencedEntity"),
        limits,
    })
}

fn synchronize(cx: &mut Cx<'_>, s: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(
        s,
        &[
            "masterEntityRef",
            "targetToleranceMaster",
            "targetTolerance",
        ],
    )?;
    cx.children(s, &["TargetPositionMaster", "TargetPosition", "FinalSpeed"])?;
    let pm = cx.child(s, "TargetPositionMaster")?;
    let master_target = cx.within(pm, |cx| position(cx, pm))?;
    let pt = cx.child(s, "TargetPosition")?;
    let target = cx.within(pt, |cx| position(cx, pt))?;
    let final_speed = match cx.opt_child(s, "FinalSpeed")? {
        Some(f) => {
            let c = cx.choice(f, &["AbsoluteSpeed", "RelativeSpeedToMaster"])?;
            cx.children(c, &["SteadyState"])?;
            if cx.opt_child(c, "SteadyState")?.is_some() {
                return Err(cx.err(c, "a SteadyState (a final constant-speed phase) is not supported by litesim's player"));
            }
            Some(if c.name() == "AbsoluteSpeed" {
                cx.attrs(c, &["value"])?;
                SpeedTarget::Absolute(cx.num(c, "value")?)
            } else {
                cx.attrs(c, &["value", "speedTargetValueType"])?;
                SpeedTarget::Relative {
                    entity: cx.req(s, "masterEntityRef")?,
                    value: cx.num(c, "value")?,
                    factor: cx.req_enum(c, "speedTargetValueType", &["delta", "factor"])?
                        == "factor",
                    continuous: false,
                }
            })
        }
        None => None,
    };
    Ok(ActionKind::Synchronize {
        master: cx.req(s, "masterEntityRef")?,
        master_target,
        target,
        final_speed,
        tolerance: cx.opt_num(s, "targetTolerance")?.unwrap_or(1.0),
        master_tolerance: cx.opt_num(s, "targetToleranceMaster")?.unwrap_or(1.0),
    })
}

fn follow_trajectory(cx: &mut Cx<'_>, f: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(f, &["initialDistanceOffset"])?;
    cx.children(
        f,
        &[
            "Trajectory",
            "CatalogReference",
            "TrajectoryRef",
            "TimeReference",
            "TrajectoryFollowingMode",
        ],
    )?;
    let direct = f
        .elements()
        .find(|c| c.name() == "Trajectory" || c.name() == "CatalogReference");
    let tref = cx.opt_child(f, "TrajectoryRef")?;
    let holder = match (direct, tref) {
        (Some(d), None) => d,
        (None, Some(t)) => {
            cx.attrs(t, &[])?;
            cx.choice(t, &["Trajectory", "CatalogReference"])?
        }
        (Some(_), Some(t)) => return Err(cx.err(t, "a FollowTrajectoryAction holds its trajectory once (TrajectoryRef, or directly before 1.1)")),
        (None, None) => return Err(cx.err(f, "<FollowTrajectoryAction> needs a TrajectoryRef")),
    };
    let traj = if holder.name() == "Trajectory" {
        cx.within(holder, |cx| scoped(cx, holder, |cx| trajectory(cx, holder)))?
    } else {
        with_entry(cx, holder, "TrajectoryCatalog", &["Trajectory"], |cx, e| {
            cx.within(e, |cx| trajectory(cx, e))
        })?
    };
    let tr = cx.child(f, "TimeReference")?;
    let c = cx.choice(tr, &["None", "Timing"])?;
    let timing = if c.name() == "Timing" {
        cx.attrs(c, &["domainAbsoluteRelative", "scale", "offset"])?;
        Some(Timing {
            absolute: cx.req_enum(c, "domainAbsoluteRelative", &["absolute", "relative"])?
                == "absolute",
            scale: cx.num(c, "scale")?,
            offset: cx.num(c, "offset")?,
        })
    } else {
        None
    };
    if timing.is_some_and(|t| t.absolute) && traj.closed {
        return Err(cx.err(c, "a closed trajectory cannot have absolute times"));
    }
    let m = cx.child(f, "TrajectoryFollowingMode")?;
    cx.attrs(m, &["followingMode"])?;
    let follow = cx.req_enum(m, "followingMode", &["position", "follow"])? == "follow";
    Ok(ActionKind::FollowTrajectory {
        trajectory: traj,
        timing,
        follow,
        initial_offset: cx.opt_num(f, "initialDistanceOffset")?.unwrap_or(0.0),
    })
}

/// A `GlobalAction`.
pub(super) fn global(cx: &mut Cx<'_>, n: Node<'_, '_>) -> R<ActionKind> {
    cx.attrs(n, &[])?;
    let a = cx.choice(
        n,
        &[
            "EnvironmentAction",
            "EntityAction",
            "ParameterAction",
            "InfrastructureAction",
            "TrafficAction",
            "VariableAction",
            "SetMonitorAction",
        ],
    )?;
    cx.within(a, |cx| match a.name() {
        "EnvironmentAction" => Ok(ActionKind::Note(format!(
            "EnvironmentAction (at {}) is recorded, not applied: set the weather with the DSL's environment actions",
            super::at(cx, a)
        ))),
        "EntityAction" => {
            cx.attrs(a, &["entityRef"])?;
            let entity = cx.req(a, "entityRef")?;
            let c = cx.choice(a, &["AddEntityAction", "DeleteEntityAction"])?;
            if c.name() == "AddEntityAction" {
                cx.children(c, &["Position"])?;
                let p = cx.child(c, "Position")?;
                Ok(ActionKind::AddEntity {
                    entity,
                    position: position(cx, p)?,
                })
            } else {
                cx.children(c, &[])?;
                Ok(ActionKind::DeleteEntity { entity })
            }
        }
        "ParameterAction" | "VariableAction" => {
            let variable = a.name() == "VariableAction";
            if variable {
                cx.since(a, "VariableAction", 2)?;
            }
            let key = if variable { "variableRef" } else { "parameterRef" };
            cx.attrs(a, &[key])?;
            let name = cx.req(a, key)?;
            let c = cx.choice(a, &["SetAction", "ModifyAction"])?;
            let op = if c.name() == "SetAction" {
                cx.attrs(c, &["value"])?;
                ValueOp::Set(cx.req(c, "value")?)
            } else {
                let r = cx.child(c, "Rule")?;
                let x = cx.choice(r, &["AddValue", "MultiplyByValue"])?;
                cx.attrs(x, &["value"])?;
                let v = cx.num(x, "value")?;
                if x.name() == "AddValue" { ValueOp::Add(v) } else { ValueOp::Multiply(v) }
            };
            Ok(ActionKind::SetValue { variable, name, op })
        }
        "InfrastructureAction" => {
            let t = cx.child(a, "TrafficSignalAction")?;
            cx.children(a, &["TrafficSignalAction"])?;
            let c = cx.choice(t, &["TrafficSignalControllerAction", "TrafficSignalStateAction"])?;
            if c.name() == "TrafficSignalStateAction" {
                cx.attrs(c, &["name", "state"])?;
                Ok(ActionKind::TrafficSignalState {
                    signal: cx.req(c, "name")?,
                    state: cx.req(c, "state")?,
                })
            } else {
                cx.attrs(c, &["trafficSignalControllerRef", "phase"])?;
                Ok(ActionKind::TrafficSignalController {
                    controller: cx.req(c, "trafficSignalControllerRef")?,
                    phase: cx.req(c, "phase")?,
                })
            }
        }
        other => Err(cx.err(
            a,
            format!("{other} is not supported by litesim's player (environment, entity, parameter, variable and traffic-signal actions are)"),
        )),
    })
}

/// A `UserDefinedAction`: recorded as a note.
pub(super) fn user_defined(cx: &Cx<'_>, n: Node<'_, '_>) -> R<ActionKind> {
    let c = cx.choice(n, &["CustomCommandAction"])?;
    cx.attrs(c, &["type"])?;
    Ok(ActionKind::Note(format!(
        "CustomCommandAction type {} ({}) is recorded, not executed",
        cx.req(c, "type")?,
        c.text().unwrap_or("").trim()
    )))
}

/// An `Action` element (storyboard) or an Init action.
pub(super) fn action(cx: &mut Cx<'_>, n: Node<'_, '_>, actors: &[String]) -> R<Action> {
    cx.attrs(n, &["name"])?;
    let c = cx.choice(n, &["GlobalAction", "UserDefinedAction", "PrivateAction"])?;
    let kind = match c.name() {
        "GlobalAction" => global(cx, c)?,
        "UserDefinedAction" => user_defined(cx, c)?,
        _ => {
            if actors.is_empty() {
                return Err(cx.err(
                    c,
                    "a PrivateAction needs actors: its ManeuverGroup lists none",
                ));
            }
            private(cx, c)?
        }
    };
    Ok(Action {
        name: cx.req(n, "name")?,
        actors: if c.name() == "PrivateAction" {
            actors.to_vec()
        } else {
            Vec::new()
        },
        kind,
        at: super::at(cx, n),
    })
}
