//! `Position` and its kinds, `Orientation`, `Route` and `Trajectory`.

use super::entities::{scoped, with_entry};
use super::{Cx, R};
use crate::model::*;
use litesim_map::xml::Node;

const POSITIONS: [&str; 11] = [
    "WorldPosition",
    "RelativeWorldPosition",
    "RelativeObjectPosition",
    "RoadPosition",
    "RelativeRoadPosition",
    "LanePosition",
    "RelativeLanePosition",
    "RoutePosition",
    "GeoPosition",
    "TrajectoryPosition",
    "ExternalObjectReferencePosition",
];

/// A `Position` element (the wrapper holding one kind).
pub(super) fn position(cx: &mut Cx<'_>, n: Node<'_, '_>) -> R<Position> {
    cx.attrs(n, &[])?;
    let p = cx.choice(n, &POSITIONS)?;
    cx.within(p, |cx| kind(cx, p))
}

fn orientation(cx: &Cx<'_>, n: Node<'_, '_>) -> R<Option<Orientation>> {
    let Some(o) = cx.opt_child(n, "Orientation")? else {
        return Ok(None);
    };
    cx.attrs(o, &["type", "h", "p", "r"])?;
    cx.children(o, &[])?;
    let relative = cx.enumer(o, "type", &["relative", "absolute"])?.as_deref() != Some("absolute");
    Ok(Some(Orientation {
        h: cx.opt_num(o, "h")?.unwrap_or(0.0),
        p: cx.opt_num(o, "p")?.unwrap_or(0.0),
        r: cx.opt_num(o, "r")?.unwrap_or(0.0),
        relative,
    }))
}

fn lane_id(cx: &Cx<'_>, n: Node<'_, '_>, name: &str) -> R<i32> {
    let v = cx.req(n, name)?;
    v.trim()
        .parse::<i32>()
        .ok()
        .or_else(|| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.fract() == 0.0 && x.abs() < 1e6)
                .map(|x| x as i32)
        })
        .ok_or_else(|| cx.err(n, format!("{name}=\"{v}\" is not a lane id (an integer)")))
}

fn kind(cx: &mut Cx<'_>, p: Node<'_, '_>) -> R<Position> {
    Ok(match p.name() {
        "WorldPosition" => {
            cx.attrs(p, &["x", "y", "z", "h", "p", "r"])?;
            cx.children(p, &[])?;
            Position::World {
                x: cx.num(p, "x")?,
                y: cx.num(p, "y")?,
                z: cx.opt_num(p, "z")?.unwrap_or(0.0),
                h: cx.opt_num(p, "h")?,
            }
        }
        "RelativeWorldPosition" | "RelativeObjectPosition" => {
            cx.attrs(p, &["entityRef", "dx", "dy", "dz"])?;
            cx.children(p, &["Orientation"])?;
            let (entity, dx, dy, orientation) = (
                cx.req(p, "entityRef")?,
                cx.num(p, "dx")?,
                cx.num(p, "dy")?,
                orientation(cx, p)?,
            );
            if p.name() == "RelativeWorldPosition" {
                Position::RelativeWorld {
                    entity,
                    dx,
                    dy,
                    orientation,
                }
            } else {
                Position::RelativeObject {
                    entity,
                    dx,
                    dy,
                    orientation,
                }
            }
        }
        "RoadPosition" => {
            cx.attrs(p, &["roadId", "s", "t"])?;
            cx.children(p, &["Orientation"])?;
            Position::Road {
                road: cx.req(p, "roadId")?,
                s: cx.num(p, "s")?,
                t: cx.num(p, "t")?,
                orientation: orientation(cx, p)?,
            }
        }
        "RelativeRoadPosition" => {
            cx.attrs(p, &["entityRef", "ds", "dt"])?;
            cx.children(p, &["Orientation"])?;
            Position::RelativeRoad {
                entity: cx.req(p, "entityRef")?,
                ds: cx.num(p, "ds")?,
                dt: cx.num(p, "dt")?,
                orientation: orientation(cx, p)?,
            }
        }
        "LanePosition" => {
            cx.attrs(p, &["roadId", "laneId", "s", "offset"])?;
            cx.children(p, &["Orientation"])?;
            Position::Lane {
                road: cx.req(p, "roadId")?,
                lane: lane_id(cx, p, "laneId")?,
                s: cx.num(p, "s")?,
                offset: cx.opt_num(p, "offset")?.unwrap_or(0.0),
                orientation: orientation(cx, p)?,
            }
        }
        "RelativeLanePosition" => {
            cx.attrs(p, &["entityRef", "dLane", "ds", "dsLane", "offset"])?;
            cx.children(p, &["Orientation"])?;
            let (ds, along_lane) = match (cx.opt_num(p, "ds")?, cx.opt_num(p, "dsLane")?) {
                (Some(d), None) => (d, false),
                (None, Some(d)) => {
                    cx.since(p, "RelativeLanePosition dsLane", 1)?;
                    (d, true)
                }
                (Some(_), Some(_)) => {
                    return Err(cx.err(p, "<RelativeLanePosition> takes ds or dsLane, not both"));
                }
                (None, None) => return Err(cx.err(p, "<RelativeLanePosition> needs ds or dsLane")),
            };
            Position::RelativeLane {
                entity: cx.req(p, "entityRef")?,
                dlane: lane_id(cx, p, "dLane")?,
                ds,
                along_lane,
                offset: cx.opt_num(p, "offset")?.unwrap_or(0.0),
                orientation: orientation(cx, p)?,
            }
        }
        "RoutePosition" => route_position(cx, p)?,
        other => {
            return Err(cx.err(
                p,
                format!("{other} is not supported by litesim's player (World, RelativeWorld, RelativeObject, Road, RelativeRoad, Lane, RelativeLane and Route positions are)"),
            ));
        }
    })
}

/// `RouteRef`: an inline `Route` or a catalog reference.
pub(super) fn route_ref(cx: &mut Cx<'_>, rr: Node<'_, '_>) -> R<Route> {
    cx.attrs(rr, &[])?;
    let c = cx.choice(rr, &["Route", "CatalogReference"])?;
    if c.name() == "Route" {
        cx.within(c, |cx| scoped(cx, c, |cx| route(cx, c)))
    } else {
        with_entry(cx, c, "RouteCatalog", &["Route"], |cx, e| {
            cx.within(e, |cx| route(cx, e))
        })
    }
}

/// A `Route` (its parameters in scope).
pub(super) fn route(cx: &mut Cx<'_>, r: Node<'_, '_>) -> R<Route> {
    cx.attrs(r, &["name", "closed"])?;
    cx.children(r, &["ParameterDeclarations", "Waypoint"])?;
    let mut waypoints = Vec::new();
    for w in r.elements().filter(|w| w.name() == "Waypoint") {
        cx.attrs(w, &["routeStrategy"])?;
        cx.children(w, &["Position"])?;
        let strategy = cx.req_enum(
            w,
            "routeStrategy",
            &["fastest", "shortest", "leastIntersections", "random"],
        )?;
        let pos = cx.child(w, "Position")?;
        waypoints.push((strategy, position(cx, pos)?));
    }
    if waypoints.len() < 2 {
        return Err(cx.err(
            r,
            format!(
                "a Route needs at least 2 waypoints ({} given)",
                waypoints.len()
            ),
        ));
    }
    Ok(Route {
        name: cx.req(r, "name")?,
        closed: cx.opt_bool(r, "closed")?.unwrap_or(false),
        waypoints,
    })
}

/// A `Trajectory` (its parameters in scope).
pub(super) fn trajectory(cx: &mut Cx<'_>, t: Node<'_, '_>) -> R<Trajectory> {
    cx.attrs(t, &["name", "closed"])?;
    cx.children(t, &["ParameterDeclarations", "Shape"])?;
    let shape = cx.child(t, "Shape")?;
    cx.attrs(shape, &[])?;
    let s = cx.choice(shape, &["Polyline", "Clothoid", "ClothoidSpline", "Nurbs"])?;
    let shape = match s.name() {
        "Polyline" => {
            cx.attrs(s, &[])?;
            cx.children(s, &["Vertex"])?;
            let mut v = Vec::new();
            for x in s.elements() {
                cx.attrs(x, &["time", "reference"])?;
                cx.children(x, &["Position"])?;
                let time = cx.opt_num(x, "time")?.or(cx.opt_num(x, "reference")?);
                let p = cx.child(x, "Position")?;
                v.push((time, position(cx, p)?));
            }
            if v.len() < 2 {
                return Err(cx.err(
                    s,
                    format!("a Polyline needs at least 2 vertices ({} given)", v.len()),
                ));
            }
            let times: Vec<f64> = v.iter().filter_map(|(t, _)| *t).collect();
            if !times.is_empty() && times.len() != v.len() {
                return Err(cx.err(
                    s,
                    "either every Vertex of a Polyline has a time or none has",
                ));
            }
            if times.windows(2).any(|w| w[1] < w[0]) {
                return Err(cx.err(s, "the Polyline's vertex times decrease (they must not)"));
            }
            TrajShape::Polyline(v)
        }
        "Clothoid" => {
            cx.attrs(
                s,
                &[
                    "curvature",
                    "curvatureDot",
                    "curvaturePrime",
                    "length",
                    "startTime",
                    "stopTime",
                ],
            )?;
            cx.children(s, &["Position"])?;
            let p = cx.child(s, "Position")?;
            let length = cx.non_neg(s, "length")?;
            TrajShape::Clothoid {
                start: position(cx, p)?,
                curvature: cx.num(s, "curvature")?,
                curvature_prime: cx
                    .opt_num(s, "curvaturePrime")?
                    .or(cx.opt_num(s, "curvatureDot")?)
                    .unwrap_or(0.0),
                length,
                start_time: cx.opt_num(s, "startTime")?,
                stop_time: cx.opt_num(s, "stopTime")?,
            }
        }
        "Nurbs" => {
            cx.attrs(s, &["order"])?;
            cx.children(s, &["ControlPoint", "Knot"])?;
            let order = cx
                .opt_int(s, "order")?
                .ok_or_else(|| cx.err(s, "<Nurbs> needs the attribute 'order'"))?;
            let mut points = Vec::new();
            let mut knots = Vec::new();
            for c in s.elements() {
                if c.name() == "Knot" {
                    cx.attrs(c, &["value"])?;
                    knots.push(cx.num(c, "value")?);
                    continue;
                }
                cx.attrs(c, &["time", "weight"])?;
                cx.children(c, &["Position"])?;
                let p = cx.child(c, "Position")?;
                points.push((
                    cx.opt_num(c, "time")?,
                    cx.opt_num(c, "weight")?.unwrap_or(1.0),
                    position(cx, p)?,
                ));
            }
            if order < 2 || points.len() < order as usize {
                return Err(cx.err(s, format!("a Nurbs of order {order} needs order ≥ 2 and at least that many control points ({} given)", points.len())));
            }
            if knots.len() != points.len() + order as usize {
                return Err(cx.err(
                    s,
                    format!(
                        "a Nurbs with {} control points of order {order} needs {} knots ({} given)",
                        points.len(),
                        points.len() + order as usize,
                        knots.len()
                    ),
                ));
            }
            if knots.windows(2).any(|w| w[1] < w[0]) {
                return Err(cx.err(s, "the Nurbs knots decrease (they must not)"));
            }
            TrajShape::Nurbs {
                order: order as u32,
                points,
                knots,
            }
        }
        _ => {
            return Err(cx.err(s, "ClothoidSpline (1.3) is not supported by litesim's player (Polyline, Clothoid and Nurbs are)"));
        }
    };
    Ok(Trajectory {
        name: cx.req(t, "name")?,
        closed: cx.opt_bool(t, "closed")?.unwrap_or(false),
        shape,
    })
}

/// A `RoutePosition`.
fn route_position(cx: &mut Cx<'_>, p: Node<'_, '_>) -> R<Position> {
    cx.attrs(p, &[])?;
    cx.children(p, &["RouteRef", "Orientation", "InRoutePosition"])?;
    let rr = cx.child(p, "RouteRef")?;
    let route = route_ref(cx, rr)?;
    let ir = cx.child(p, "InRoutePosition")?;
    let c = cx.choice(
        ir,
        &[
            "FromCurrentEntity",
            "FromRoadCoordinates",
            "FromLaneCoordinates",
        ],
    )?;
    let in_route = match c.name() {
        "FromCurrentEntity" => {
            cx.attrs(c, &["entityRef"])?;
            InRoute::FromCurrentEntity(cx.req(c, "entityRef")?)
        }
        "FromRoadCoordinates" => {
            cx.attrs(c, &["pathS", "t"])?;
            InRoute::FromRoadCoordinates {
                s: cx.num(c, "pathS")?,
                t: cx.num(c, "t")?,
            }
        }
        _ => {
            cx.attrs(c, &["pathS", "laneId", "laneOffset"])?;
            InRoute::FromLaneCoordinates {
                s: cx.num(c, "pathS")?,
                lane: lane_id(cx, c, "laneId")?,
                offset: cx.opt_num(c, "laneOffset")?.unwrap_or(0.0),
            }
        }
    };
    Ok(Position::Route {
        route: Box::new(route),
        in_route,
        orientation: orientation(cx, p)?,
    })
}
