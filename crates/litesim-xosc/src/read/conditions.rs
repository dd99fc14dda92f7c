//! `Trigger`s, `ConditionGroup`s and `Condition`s.

use super::positions::position;
use super::{Cx, R};
use crate::model::*;
use litesim_map::xml::Node;

/// A `StartTrigger` or `StopTrigger`.
pub(super) fn trigger(cx: &mut Cx<'_>, t: Node<'_, '_>) -> R<Trigger> {
    cx.attrs(t, &[])?;
    cx.children(t, &["ConditionGroup"])?;
    let mut groups = Vec::new();
    for g in t.elements() {
        cx.attrs(g, &[])?;
        cx.children(g, &["Condition"])?;
        let mut conds = Vec::new();
        for c in g.elements() {
            conds.push(cx.within(c, |cx| condition(cx, c))?);
        }
        if conds.is_empty() {
            return Err(cx.err(g, "a ConditionGroup needs at least one Condition"));
        }
        groups.push(conds);
    }
    if groups.is_empty() && cx.version.1 > 0 {
        return Err(cx.err(
            t,
            format!("<{}> has no ConditionGroup (legal only in OpenSCENARIO 1.0 files): it could never fire", t.name()),
        ));
    }
    Ok(Trigger { groups })
}

/// The attributes of the conditions that measure a distance or a time to
/// a target (TimeToCollision, Distance; TimeHeadway adds `entityRef`).
const MEASURED: [&str; 7] = [
    "value",
    "freespace",
    "alongRoute",
    "rule",
    "coordinateSystem",
    "relativeDistanceType",
    "routingAlgorithm",
];

fn rule(cx: &Cx<'_>, n: Node<'_, '_>) -> R<Rule> {
    let r = cx.req_enum(
        n,
        "rule",
        &[
            "equalTo",
            "greaterThan",
            "lessThan",
            "greaterOrEqual",
            "lessOrEqual",
            "notEqualTo",
        ],
    )?;
    if matches!(r.as_str(), "greaterOrEqual" | "lessOrEqual" | "notEqualTo") {
        cx.since(n, &format!("rule {r}"), 1)?;
    }
    Ok(match r.as_str() {
        "equalTo" => Rule::EqualTo,
        "greaterThan" => Rule::GreaterThan,
        "lessThan" => Rule::LessThan,
        "greaterOrEqual" => Rule::GreaterOrEqual,
        "lessOrEqual" => Rule::LessOrEqual,
        _ => Rule::NotEqualTo,
    })
}

fn frame(cx: &Cx<'_>, n: Node<'_, '_>) -> R<Frame> {
    Ok(
        match cx
            .enumer(
                n,
                "coordinateSystem",
                &["entity", "lane", "road", "trajectory", "world"],
            )?
            .as_deref()
        {
            Some("lane") => Frame::Lane,
            Some("road") => Frame::Road,
            Some("trajectory") => Frame::Trajectory,
            Some("world") => Frame::World,
            _ => Frame::Entity,
        },
    )
}

fn measure(cx: &Cx<'_>, n: Node<'_, '_>, default: Measure) -> R<Measure> {
    Ok(
        match cx
            .enumer(
                n,
                "relativeDistanceType",
                &[
                    "longitudinal",
                    "lateral",
                    "euclidianDistance",
                    "cartesianDistance",
                ],
            )?
            .as_deref()
        {
            Some("longitudinal") => Measure::Longitudinal,
            Some("lateral") => Measure::Lateral,
            Some(_) => Measure::Euclidean,
            None => default,
        },
    )
}

fn freespace(cx: &Cx<'_>, n: Node<'_, '_>) -> R<bool> {
    cx.opt_bool(n, "freespace")?
        .ok_or_else(|| cx.err(n, format!("<{}> needs the attribute 'freespace'", n.name())))
}

fn condition(cx: &mut Cx<'_>, c: Node<'_, '_>) -> R<Condition> {
    cx.attrs(c, &["name", "delay", "conditionEdge"])?;
    let edge = match cx
        .req_enum(
            c,
            "conditionEdge",
            &["rising", "falling", "risingOrFalling", "none"],
        )?
        .as_str()
    {
        "rising" => Edge::Rising,
        "falling" => Edge::Falling,
        "risingOrFalling" => Edge::RisingOrFalling,
        _ => Edge::None,
    };
    let delay = cx.non_neg(c, "delay")?;
    let b = cx.choice(c, &["ByEntityCondition", "ByValueCondition"])?;
    let kind = cx.within(b, |cx| {
        if b.name() == "ByValueCondition" {
            by_value(cx, b)
        } else {
            by_entity(cx, b)
        }
    })?;
    Ok(Condition {
        name: cx.req(c, "name")?,
        delay,
        edge,
        kind,
        at: super::at(cx, c),
    })
}

fn by_value(cx: &mut Cx<'_>, b: Node<'_, '_>) -> R<ConditionKind> {
    cx.attrs(b, &[])?;
    let v = cx.choice(
        b,
        &[
            "ParameterCondition",
            "TimeOfDayCondition",
            "SimulationTimeCondition",
            "StoryboardElementStateCondition",
            "UserDefinedValueCondition",
            "TrafficSignalCondition",
            "TrafficSignalControllerCondition",
            "VariableCondition",
        ],
    )?;
    cx.children(v, &[])?;
    Ok(match v.name() {
        "SimulationTimeCondition" => {
            cx.attrs(v, &["value", "rule"])?;
            ConditionKind::SimulationTime {
                rule: rule(cx, v)?,
                value: cx.num(v, "value")?,
            }
        }
        "StoryboardElementStateCondition" => {
            cx.attrs(
                v,
                &["storyboardElementType", "storyboardElementRef", "state"],
            )?;
            let element = match cx
                .req_enum(
                    v,
                    "storyboardElementType",
                    &[
                        "story",
                        "act",
                        "maneuverGroup",
                        "maneuver",
                        "event",
                        "action",
                    ],
                )?
                .as_str()
            {
                "story" => ElementType::Story,
                "act" => ElementType::Act,
                "maneuverGroup" => ElementType::ManeuverGroup,
                "maneuver" => ElementType::Maneuver,
                "event" => ElementType::Event,
                _ => ElementType::Action,
            };
            let state = match cx
                .req_enum(
                    v,
                    "state",
                    &[
                        "startTransition",
                        "endTransition",
                        "stopTransition",
                        "skipTransition",
                        "completeState",
                        "runningState",
                        "standbyState",
                    ],
                )?
                .as_str()
            {
                "startTransition" => ElementState::StartTransition,
                "endTransition" => ElementState::EndTransition,
                "stopTransition" => ElementState::StopTransition,
                "skipTransition" => ElementState::SkipTransition,
                "completeState" => ElementState::Complete,
                "runningState" => ElementState::Running,
                _ => ElementState::Standby,
            };
            ConditionKind::StoryboardElementState {
                element,
                name: cx.req(v, "storyboardElementRef")?,
                state,
            }
        }
        "ParameterCondition" => {
            cx.attrs(v, &["parameterRef", "value", "rule"])?;
            ConditionKind::Parameter {
                name: cx.req(v, "parameterRef")?,
                rule: rule(cx, v)?,
                value: cx.req(v, "value")?,
            }
        }
        "VariableCondition" => {
            cx.since(v, "VariableCondition", 2)?;
            cx.attrs(v, &["variableRef", "value", "rule"])?;
            ConditionKind::Variable {
                name: cx.req(v, "variableRef")?,
                rule: rule(cx, v)?,
                value: cx.req(v, "value")?,
            }
        }
        "TrafficSignalCondition" => {
            cx.attrs(v, &["name", "state"])?;
            ConditionKind::TrafficSignal {
                signal: cx.req(v, "name")?,
                state: cx.req(v, "state")?,
            }
        }
        other => {
            return Err(cx.err(
                v,
                format!("{other} is not supported by litesim's player (SimulationTime, StoryboardElementState, Parameter, Variable and TrafficSignal conditions are)"),
            ));
        }
    })
}

fn by_entity(cx: &mut Cx<'_>, b: Node<'_, '_>) -> R<ConditionKind> {
    cx.attrs(b, &[])?;
    cx.children(b, &["TriggeringEntities", "EntityCondition"])?;
    let te = cx.child(b, "TriggeringEntities")?;
    cx.attrs(te, &["triggeringEntitiesRule"])?;
    cx.children(te, &["EntityRef"])?;
    let all = cx.req_enum(te, "triggeringEntitiesRule", &["any", "all"])? == "all";
    let mut entities = Vec::new();
    for e in te.elements() {
        cx.attrs(e, &["entityRef"])?;
        entities.push(cx.req(e, "entityRef")?);
    }
    if entities.is_empty() {
        return Err(cx.err(te, "<TriggeringEntities> needs at least one EntityRef"));
    }
    let ec = cx.child(b, "EntityCondition")?;
    cx.attrs(ec, &[])?;
    let e = cx.choice(
        ec,
        &[
            "EndOfRoadCondition",
            "CollisionCondition",
            "OffroadCondition",
            "TimeHeadwayCondition",
            "TimeToCollisionCondition",
            "AccelerationCondition",
            "StandStillCondition",
            "SpeedCondition",
            "RelativeSpeedCondition",
            "TraveledDistanceCondition",
            "ReachPositionCondition",
            "DistanceCondition",
            "RelativeDistanceCondition",
            "RelativeClearanceCondition",
            "AngleCondition",
            "RelativeAngleCondition",
        ],
    )?;
    let test = cx.within(e, |cx| entity_test(cx, e))?;
    Ok(ConditionKind::Entity {
        entities,
        all,
        test,
    })
}

fn entity_test(cx: &mut Cx<'_>, e: Node<'_, '_>) -> R<EntityTest> {
    let name = e.name();
    let no_children = |cx: &Cx<'_>| cx.children(e, &[]);
    Ok(match name {
        "EndOfRoadCondition" | "OffroadCondition" | "StandStillCondition" => {
            cx.attrs(e, &["duration"])?;
            no_children(cx)?;
            let duration = cx.non_neg(e, "duration")?;
            match name {
                "EndOfRoadCondition" => EntityTest::EndOfRoad { duration },
                "OffroadCondition" => EntityTest::Offroad { duration },
                _ => EntityTest::StandStill { duration },
            }
        }
        "CollisionCondition" => {
            cx.attrs(e, &[])?;
            let c = cx.choice(e, &["EntityRef", "ByType"])?;
            if c.name() == "EntityRef" {
                cx.attrs(c, &["entityRef"])?;
                EntityTest::Collision {
                    entity: Some(cx.req(c, "entityRef")?),
                    by_type: None,
                }
            } else {
                cx.attrs(c, &["type"])?;
                EntityTest::Collision {
                    entity: None,
                    by_type: Some(cx.req_enum(
                        c,
                        "type",
                        &["pedestrian", "vehicle", "miscellaneous", "external"],
                    )?),
                }
            }
        }
        "TimeHeadwayCondition" | "TimeToCollisionCondition" => gap_test(cx, e)?,
        "AccelerationCondition" | "SpeedCondition" => {
            cx.attrs(e, &["value", "rule", "direction"])?;
            no_children(cx)?;
            if let Some(d) = cx.enumer(e, "direction", &["longitudinal", "lateral", "vertical"])?
                && d != "longitudinal"
            {
                return Err(cx.err(e, format!("direction {d} is not supported (litesim's vehicles move along their heading: longitudinal is)")));
            }
            let (rule, value) = (rule(cx, e)?, cx.num(e, "value")?);
            if name == "SpeedCondition" {
                EntityTest::Speed { rule, value }
            } else {
                EntityTest::Acceleration { rule, value }
            }
        }
        "RelativeSpeedCondition" => {
            cx.attrs(e, &["entityRef", "value", "rule", "direction"])?;
            no_children(cx)?;
            EntityTest::RelativeSpeed {
                entity: cx.req(e, "entityRef")?,
                rule: rule(cx, e)?,
                value: cx.num(e, "value")?,
            }
        }
        "TraveledDistanceCondition" => {
            cx.attrs(e, &["value"])?;
            no_children(cx)?;
            EntityTest::TraveledDistance {
                value: cx.non_neg(e, "value")?,
            }
        }
        "ReachPositionCondition" => {
            cx.attrs(e, &["tolerance"])?;
            cx.children(e, &["Position"])?;
            let p = cx.child(e, "Position")?;
            EntityTest::ReachPosition {
                position: position(cx, p)?,
                tolerance: cx.non_neg(e, "tolerance")?,
            }
        }
        "DistanceCondition" | "RelativeDistanceCondition" => gap_test(cx, e)?,
        other => {
            return Err(cx.err(e, format!("{other} is not supported by litesim's player")));
        }
    })
}

/// The headway, time-to-collision and distance conditions.
fn gap_test(cx: &mut Cx<'_>, e: Node<'_, '_>) -> R<EntityTest> {
    let no_children = |cx: &Cx<'_>| cx.children(e, &[]);
    Ok(match e.name() {
        "TimeHeadwayCondition" => {
            cx.attrs(e, &[&MEASURED[..], &["entityRef"]].concat())?;
            no_children(cx)?;
            EntityTest::TimeHeadway {
                entity: cx.req(e, "entityRef")?,
                freespace: freespace(cx, e)?,
                frame: frame(cx, e)?,
                rule: rule(cx, e)?,
                value: cx.non_neg(e, "value")?,
            }
        }
        "TimeToCollisionCondition" => {
            cx.attrs(e, &MEASURED)?;
            cx.children(e, &["TimeToCollisionConditionTarget"])?;
            let t = cx.child(e, "TimeToCollisionConditionTarget")?;
            let c = cx.choice(t, &["Position", "EntityRef"])?;
            let (entity, position) = if c.name() == "EntityRef" {
                cx.attrs(c, &["entityRef"])?;
                (Some(cx.req(c, "entityRef")?), None)
            } else {
                (None, Some(position(cx, c)?))
            };
            EntityTest::TimeToCollision {
                entity,
                position,
                freespace: freespace(cx, e)?,
                frame: frame(cx, e)?,
                rule: rule(cx, e)?,
                value: cx.non_neg(e, "value")?,
            }
        }
        "DistanceCondition" => {
            cx.attrs(e, &MEASURED)?;
            cx.children(e, &["Position"])?;
            let p = cx.child(e, "Position")?;
            EntityTest::Distance {
                position: position(cx, p)?,
                freespace: freespace(cx, e)?,
                measure: measure(cx, e, Measure::Euclidean)?,
                frame: frame(cx, e)?,
                rule: rule(cx, e)?,
                value: cx.non_neg(e, "value")?,
            }
        }
        "RelativeDistanceCondition" => {
            cx.attrs(
                e,
                &[
                    "entityRef",
                    "value",
                    "freespace",
                    "relativeDistanceType",
                    "rule",
                    "coordinateSystem",
                    "routingAlgorithm",
                ],
            )?;
            no_children(cx)?;
            if e.attribute("relativeDistanceType").is_none() {
                return Err(cx.err(
                    e,
                    "<RelativeDistanceCondition> needs the attribute 'relativeDistanceType'",
                ));
            }
            EntityTest::RelativeDistance {
                entity: cx.req(e, "entityRef")?,
                freespace: freespace(cx, e)?,
                measure: measure(cx, e, Measure::Euclidean)?,
                frame: frame(cx, e)?,
                rule: rule(cx, e)?,
                value: cx.non_neg(e, "value")?,
            }
        }
        other => unreachable!("gap_test is called for gap conditions, not {other}"),
    })
}
