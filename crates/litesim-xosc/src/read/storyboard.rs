//! `Storyboard`: Init, Story → Act → ManeuverGroup → Maneuver → Event →
//! Action, the triggers; then every reference checked against what is
//! declared (entities, storyboard elements, signal controllers).

use super::actions::{action, global, private, user_defined};
use super::conditions::trigger;
use super::entities::{scoped, with_entry};
use super::{Cx, R, at};
use crate::error::XoscError;
use crate::model::*;
use litesim_map::xml::Node;
use std::collections::BTreeSet;

pub(super) fn storyboard(cx: &mut Cx<'_>, n: Node<'_, '_>, sc: &mut Scenario) -> R<()> {
    cx.attrs(n, &[])?;
    cx.children(n, &["Init", "Story", "StopTrigger"])?;
    let init = cx.child(n, "Init")?;
    cx.within(init, |cx| {
        cx.attrs(init, &[])?;
        cx.children(init, &["Actions"])?;
        let acts = cx.child(init, "Actions")?;
        cx.children(acts, &["GlobalAction", "UserDefinedAction", "Private"])?;
        for a in acts.elements() {
            let place = at(cx, a);
            match a.name() {
                "GlobalAction" => sc.init.push(Action {
                    name: "init".into(),
                    actors: Vec::new(),
                    kind: global(cx, a)?,
                    at: place,
                }),
                "UserDefinedAction" => sc.init.push(Action {
                    name: "init".into(),
                    actors: Vec::new(),
                    kind: user_defined(cx, a)?,
                    at: place,
                }),
                _ => {
                    cx.attrs(a, &["entityRef"])?;
                    cx.children(a, &["PrivateAction"])?;
                    let who = cx.req(a, "entityRef")?;
                    if a.elements().next().is_none() {
                        return Err(cx.err(a, "<Private> needs at least one PrivateAction"));
                    }
                    for p in a.elements() {
                        let place = at(cx, p);
                        let kind = cx.within(p, |cx| private(cx, p))?;
                        sc.init.push(Action {
                            name: format!("init {who}"),
                            actors: vec![who.clone()],
                            kind,
                            at: place,
                        });
                    }
                }
            }
        }
        Ok(())
    })?;
    for s in n.elements().filter(|s| s.name() == "Story") {
        let story = cx.within(s, |cx| scoped(cx, s, |cx| story(cx, s)))?;
        sc.stories.push(story);
    }
    if n.elements().all(|s| s.name() != "Story") && cx.version.1 < 2 {
        return Err(cx.err(n, "<Storyboard> needs a Story before OpenSCENARIO 1.2"));
    }
    match cx.opt_child(n, "StopTrigger")? {
        Some(t) => sc.stop_trigger = Some(cx.within(t, |cx| trigger(cx, t))?),
        None if cx.version.1 < 3 => {
            return Err(cx.err(
                n,
                "<Storyboard> needs a StopTrigger before OpenSCENARIO 1.3",
            ));
        }
        None => {}
    }
    Ok(())
}

fn story(cx: &mut Cx<'_>, s: Node<'_, '_>) -> R<Story> {
    cx.attrs(s, &["name"])?;
    cx.children(s, &["ParameterDeclarations", "Act"])?;
    let mut acts = Vec::new();
    for a in s.elements().filter(|a| a.name() == "Act") {
        acts.push(cx.within(a, |cx| act(cx, a))?);
    }
    if acts.is_empty() {
        return Err(cx.err(s, "a Story needs at least one Act"));
    }
    Ok(Story {
        name: cx.req(s, "name")?,
        acts,
        at: at(cx, s),
    })
}

fn act(cx: &mut Cx<'_>, a: Node<'_, '_>) -> R<Act> {
    cx.attrs(a, &["name"])?;
    cx.children(a, &["ManeuverGroup", "StartTrigger", "StopTrigger"])?;
    let mut groups = Vec::new();
    for g in a.elements().filter(|g| g.name() == "ManeuverGroup") {
        groups.push(cx.within(g, |cx| group(cx, g))?);
    }
    if groups.is_empty() {
        return Err(cx.err(a, "an Act needs at least one ManeuverGroup"));
    }
    let start = match cx.opt_child(a, "StartTrigger")? {
        Some(t) => Some(cx.within(t, |cx| trigger(cx, t))?),
        None if cx.version.1 < 3 => {
            return Err(cx.err(a, "an Act needs a StartTrigger before OpenSCENARIO 1.3"));
        }
        None => None,
    };
    let stop = match cx.opt_child(a, "StopTrigger")? {
        Some(t) => Some(cx.within(t, |cx| trigger(cx, t))?),
        None => None,
    };
    Ok(Act {
        name: cx.req(a, "name")?,
        groups,
        start,
        stop,
        at: at(cx, a),
    })
}

fn count(cx: &Cx<'_>, n: Node<'_, '_>, name: &str, default: Option<u32>) -> R<u32> {
    match cx.opt_int(n, name)? {
        Some(v) if (1..=u32::MAX as i64).contains(&v) => Ok(v as u32),
        Some(v) => Err(cx.err(n, format!("{name}=\"{v}\" must be at least 1"))),
        None => {
            default.ok_or_else(|| cx.err(n, format!("<{}> needs the attribute '{name}'", n.name())))
        }
    }
}

fn group(cx: &mut Cx<'_>, g: Node<'_, '_>) -> R<ManeuverGroup> {
    cx.attrs(g, &["name", "maximumExecutionCount"])?;
    cx.children(g, &["Actors", "CatalogReference", "Maneuver"])?;
    let actors_n = cx.child(g, "Actors")?;
    cx.attrs(actors_n, &["selectTriggeringEntities"])?;
    cx.children(actors_n, &["EntityRef"])?;
    let mut actors = Vec::new();
    for e in actors_n.elements() {
        cx.attrs(e, &["entityRef"])?;
        actors.push(cx.req(e, "entityRef")?);
    }
    let select_triggering = cx
        .opt_bool(actors_n, "selectTriggeringEntities")?
        .ok_or_else(|| {
            cx.err(
                actors_n,
                "<Actors> needs the attribute 'selectTriggeringEntities'",
            )
        })?;
    let mut maneuvers = Vec::new();
    for m in g.elements() {
        match m.name() {
            "Maneuver" => {
                maneuvers.push(cx.within(m, |cx| scoped(cx, m, |cx| maneuver(cx, m, &actors)))?)
            }
            "CatalogReference" => {
                let actors = actors.clone();
                maneuvers.push(with_entry(
                    cx,
                    m,
                    "ManeuverCatalog",
                    &["Maneuver"],
                    move |cx, e| cx.within(e, |cx| maneuver(cx, e, &actors)),
                )?)
            }
            _ => {}
        }
    }
    Ok(ManeuverGroup {
        name: cx.req(g, "name")?,
        max_count: count(cx, g, "maximumExecutionCount", None)?,
        actors,
        select_triggering,
        maneuvers,
        at: at(cx, g),
    })
}

fn maneuver(cx: &mut Cx<'_>, m: Node<'_, '_>, actors: &[String]) -> R<Maneuver> {
    cx.attrs(m, &["name"])?;
    cx.children(m, &["ParameterDeclarations", "Event"])?;
    let mut events = Vec::new();
    for e in m.elements().filter(|e| e.name() == "Event") {
        events.push(cx.within(e, |cx| event(cx, e, actors))?);
    }
    if events.is_empty() {
        return Err(cx.err(m, "a Maneuver needs at least one Event"));
    }
    Ok(Maneuver {
        name: cx.req(m, "name")?,
        events,
        at: at(cx, m),
    })
}

fn event(cx: &mut Cx<'_>, e: Node<'_, '_>, actors: &[String]) -> R<Event> {
    cx.attrs(e, &["name", "priority", "maximumExecutionCount"])?;
    cx.children(e, &["Action", "StartTrigger"])?;
    let p = cx.req_enum(
        e,
        "priority",
        &["overwrite", "override", "skip", "parallel"],
    )?;
    let priority = match p.as_str() {
        "override" => {
            cx.since(e, "priority override", 2)?;
            Priority::Override
        }
        "overwrite" => Priority::Override,
        "skip" => Priority::Skip,
        _ => Priority::Parallel,
    };
    let mut actions = Vec::new();
    for a in e.elements().filter(|a| a.name() == "Action") {
        actions.push(cx.within(a, |cx| action(cx, a, actors))?);
    }
    if actions.is_empty() {
        return Err(cx.err(e, "an Event needs at least one Action"));
    }
    let start = match cx.opt_child(e, "StartTrigger")? {
        Some(t) => Some(cx.within(t, |cx| trigger(cx, t))?),
        None if cx.version.1 == 0 => {
            return Err(cx.err(e, "an Event needs a StartTrigger in OpenSCENARIO 1.0"));
        }
        None => None,
    };
    Ok(Event {
        name: cx.req(e, "name")?,
        priority,
        max_count: count(cx, e, "maximumExecutionCount", Some(1))?,
        actions,
        start,
        at: at(cx, e),
    })
}

/// An error at a model element's `file:line:col`.
fn err_at(place: &str, message: String) -> XoscError {
    let mut it = place.rsplitn(3, ':');
    let col = it.next().and_then(|c| c.parse().ok()).unwrap_or(0);
    let line = it.next().and_then(|l| l.parse().ok()).unwrap_or(0);
    XoscError {
        file: it.next().unwrap_or(place).to_string(),
        line,
        col,
        path: String::new(),
        message,
    }
}

/// Every entity, storyboard element and signal controller a scenario names
/// exists.
pub(super) fn check_references(_cx: &Cx<'_>, _root: Node<'_, '_>, sc: &Scenario) -> R<()> {
    let mut known: Vec<String> = sc.entities.iter().map(|e| e.name.clone()).collect();
    known.extend(sc.selections.iter().map(|(n, _)| n.clone()));
    let entity = |name: &str, place: &str| -> R<()> {
        if known.iter().any(|k| k == name) {
            Ok(())
        } else {
            Err(err_at(
                place,
                format!(
                    "entity '{name}' does not exist (declared: {})",
                    known.join(", ")
                ),
            ))
        }
    };
    for (s, members) in &sc.selections {
        for m in members {
            if !sc.entities.iter().any(|e| e.name == *m) {
                return Err(err_at(
                    &sc.entities.first().map_or(String::new(), |e| e.at.clone()),
                    format!("selection '{s}' lists entity '{m}', which does not exist"),
                ));
            }
        }
    }
    let elements = element_names(sc);
    let check_trigger = |t: &Trigger| -> R<()> {
        for c in t.groups.iter().flatten() {
            match &c.kind {
                ConditionKind::Entity { entities, test, .. } => {
                    for e in entities {
                        entity(e, &c.at)?;
                    }
                    for r in test_refs(test) {
                        entity(r, &c.at)?;
                    }
                }
                ConditionKind::StoryboardElementState { element, name, .. } => {
                    let k = *element as u8;
                    if !elements.contains(&(k, name.clone())) {
                        return Err(err_at(
                            &c.at,
                            format!("storyboard element {element:?} '{name}' does not exist"),
                        ));
                    }
                }
                ConditionKind::Parameter { name, .. }
                    if !sc.parameters.iter().any(|(p, _)| p == name) =>
                {
                    return Err(err_at(
                        &c.at,
                        format!("parameter '{name}' is not declared globally"),
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    };
    let check_action = |a: &Action| -> R<()> {
        for who in &a.actors {
            entity(who, &a.at)?;
        }
        for r in action_refs(&a.kind) {
            entity(r, &a.at)?;
        }
        match &a.kind {
            ActionKind::TrafficSignalController { controller, .. }
                if !sc.signal_controllers.iter().any(|c| c.name == *controller) =>
            {
                Err(err_at(
                    &a.at,
                    format!(
                        "traffic signal controller '{controller}' does not exist in RoadNetwork/TrafficSignals"
                    ),
                ))
            }
            _ => Ok(()),
        }
    };
    for a in &sc.init {
        check_action(a)?;
    }
    for s in &sc.stories {
        for a in &s.acts {
            for t in a.start.iter().chain(a.stop.iter()) {
                check_trigger(t)?;
            }
            for g in &a.groups {
                for m in &g.maneuvers {
                    for e in &m.events {
                        if let Some(t) = &e.start {
                            check_trigger(t)?;
                        }
                        for x in &e.actions {
                            check_action(x)?;
                        }
                    }
                }
            }
        }
    }
    if let Some(t) = &sc.stop_trigger {
        check_trigger(t)?;
    }
    Ok(())
}

fn position_refs(p: &Position) -> Vec<&String> {
    match p {
        Position::RelativeWorld { entity, .. }
        | Position::RelativeObject { entity, .. }
        | Position::RelativeRoad { entity, .. }
        | Position::RelativeLane { entity, .. } => vec![entity],
        Position::Route {
            in_route: InRoute::FromCurrentEntity(e),
            ..
        } => vec![e],
        _ => Vec::new(),
    }
}

fn test_refs(t: &EntityTest) -> Vec<&String> {
    match t {
        EntityTest::Collision {
            entity: Some(e), ..
        }
        | EntityTest::TimeHeadway { entity: e, .. }
        | EntityTest::RelativeSpeed { entity: e, .. }
        | EntityTest::RelativeDistance { entity: e, .. }
        | EntityTest::TimeToCollision {
            entity: Some(e), ..
        } => vec![e],
        EntityTest::ReachPosition { position, .. } | EntityTest::Distance { position, .. } => {
            position_refs(position)
        }
        _ => Vec::new(),
    }
}

fn action_refs(k: &ActionKind) -> Vec<&String> {
    match k {
        ActionKind::Teleport(p) | ActionKind::AcquirePosition(p) => position_refs(p),
        ActionKind::Speed {
            target: SpeedTarget::Relative { entity, .. },
            ..
        }
        | ActionKind::LaneChange {
            target: LaneTarget::Relative { entity, .. },
            ..
        }
        | ActionKind::LaneOffset {
            target: OffsetTarget::Relative { entity, .. },
            ..
        }
        | ActionKind::LongitudinalDistance { entity, .. }
        | ActionKind::DeleteEntity { entity } => vec![entity],
        ActionKind::AddEntity { entity, position } => {
            let mut v = vec![entity];
            v.extend(position_refs(position));
            v
        }
        ActionKind::Synchronize {
            master,
            master_target,
            target,
            ..
        } => {
            let mut v = vec![master];
            v.extend(position_refs(master_target));
            v.extend(position_refs(target));
            v
        }
        _ => Vec::new(),
    }
}

/// Every storyboard element's (type as u8, name).
fn element_names(sc: &Scenario) -> BTreeSet<(u8, String)> {
    let mut elements: BTreeSet<(u8, String)> = BTreeSet::new();
    for s in &sc.stories {
        elements.insert((0, s.name.clone()));
        for a in &s.acts {
            elements.insert((1, a.name.clone()));
            for g in &a.groups {
                elements.insert((2, g.name.clone()));
                for m in &g.maneuvers {
                    elements.insert((3, m.name.clone()));
                    for e in &m.events {
                        elements.insert((4, e.name.clone()));
                        for x in &e.actions {
                            elements.insert((5, x.name.clone()));
                        }
                    }
                }
            }
        }
    }
    elements
}
