//! OpenSCENARIO positions on the map: each kind resolved against the
//! entities' current places to a world pose and, where there is one, the
//! lane it lies in.

use super::Body;
use crate::error::ScenarioError;
use litesim_map::{LanePos, RoadNetwork};
use litesim_xosc::{InRoute, Orientation, Position, Route};

/// A resolved position: the entity's reference point (the rear axle's
/// ground point, as OpenSCENARIO has it), its heading, and the lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Place {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
    /// The lane and the offset from its centre (m, towards +t), when the
    /// place is on one.
    pub lane: Option<(LanePos, f64)>,
}

fn err(at: &str, msg: String) -> ScenarioError {
    ScenarioError::Plan(format!("{at}: {msg}"))
}

/// The body of entity `name`.
fn body<'b>(bodies: &'b [Body], name: &str, at: &str) -> Result<&'b Body, ScenarioError> {
    bodies
        .iter()
        .find(|b| b.id == name)
        .ok_or_else(|| err(at, format!("entity '{name}' does not exist")))
}

/// Applies an `Orientation` to the heading `base` (the lane's, or the
/// reference entity's): relative adds, absolute replaces.
fn orient(base: f64, o: Option<&Orientation>) -> f64 {
    match o {
        Some(o) if o.relative => litesim_core::wrap_angle(base + o.h),
        Some(o) => litesim_core::wrap_angle(o.h),
        None => base,
    }
}

/// The lane (and offset) at a world point, when it is on one.
pub fn lane_at(net: &RoadNetwork, x: f64, y: f64) -> Option<(LanePos, f64)> {
    let l = net.locate(litesim_core::Vec2::new(x, y))?;
    (l.lane != 0).then_some((
        LanePos {
            road: l.road,
            lane: l.lane,
            s: l.s,
        },
        l.offset,
    ))
}

/// The pose of a lane position with an offset (m, towards +t).
pub fn on_lane(net: &RoadNetwork, p: LanePos, offset: f64) -> Option<Place> {
    let pose = net.lane_pose_at(p.road, p.lane, p.s, offset)?;
    Some(Place {
        x: pose.position.x,
        y: pose.position.y,
        yaw: pose.yaw,
        lane: Some((p, offset)),
    })
}

/// Lane id `lane` moved `d` lanes by id arithmetic, skipping the centre
/// lane 0 (OpenSCENARIO's `dLane`).
pub fn lane_plus(lane: i32, d: i32) -> i32 {
    let mut l = lane + d;
    if (lane > 0) != (l > 0) || l == 0 {
        // Crossing the centre: one more, over lane 0.
        l += d.signum();
    }
    l
}

/// Resolves `p` given the entities' bodies (`find` by name); `at` names
/// the element for errors.
pub fn resolve(
    net: &RoadNetwork,
    p: &Position,
    bodies: &[Body],
    at: &str,
) -> Result<Place, ScenarioError> {
    let find = |name: &str| body(bodies, name, at);
    let road_ix = |id: &str| {
        net.road_index(id)
            .ok_or_else(|| err(at, format!("the map has no road '{id}'")))
    };
    Ok(match p {
        Position::World { x, y, h, .. } => {
            let lane = lane_at(net, *x, *y);
            let yaw = h.unwrap_or_else(|| {
                lane.and_then(|(l, o)| on_lane(net, l, o))
                    .map_or(0.0, |p| p.yaw)
            });
            Place {
                x: *x,
                y: *y,
                yaw,
                lane,
            }
        }
        Position::RelativeWorld {
            entity,
            dx,
            dy,
            orientation,
        } => {
            let b = find(entity)?;
            let (x, y) = (b.x + dx, b.y + dy);
            Place {
                x,
                y,
                yaw: orient(b.yaw, orientation.as_ref()),
                lane: lane_at(net, x, y),
            }
        }
        Position::RelativeObject {
            entity,
            dx,
            dy,
            orientation,
        } => {
            let b = find(entity)?;
            let (s, c) = litesim_core::math::sin_cos(b.yaw);
            let (x, y) = (b.x + dx * c - dy * s, b.y + dx * s + dy * c);
            Place {
                x,
                y,
                yaw: orient(b.yaw, orientation.as_ref()),
                lane: lane_at(net, x, y),
            }
        }
        Position::Road {
            road,
            s,
            t,
            orientation,
        } => {
            let r = road_ix(road)?;
            on_road(net, r, *s, *t, orientation.as_ref(), at)?
        }
        Position::RelativeRoad {
            entity,
            ds,
            dt,
            orientation,
        } => {
            let b = find(entity)?;
            let l = net
                .locate(litesim_core::Vec2::new(b.x, b.y))
                .ok_or_else(|| {
                    err(
                        at,
                        format!(
                            "{entity} is not on a road: a RelativeRoadPosition needs it on one"
                        ),
                    )
                })?;
            on_road(net, l.road, l.s + ds, l.t + dt, orientation.as_ref(), at)?
        }
        Position::Lane {
            road,
            lane,
            s,
            offset,
            orientation,
        } => {
            let r = road_ix(road)?;
            let p = LanePos {
                road: r,
                lane: *lane,
                s: *s,
            };
            let mut pl = on_lane(net, p, *offset).ok_or_else(|| {
                err(
                    at,
                    format!(
                        "road {road} has no lane {lane} at s = {s} m (its length is {:.1} m)",
                        net.roads()[r].length
                    ),
                )
            })?;
            pl.yaw = orient(pl.yaw, orientation.as_ref());
            pl
        }
        _ => lane_relative(net, p, bodies, at)?,
    })
}

/// A `RelativeLanePosition` or a `RoutePosition`.
fn lane_relative(
    net: &RoadNetwork,
    p: &Position,
    bodies: &[Body],
    at: &str,
) -> Result<Place, ScenarioError> {
    let find = |name: &str| body(bodies, name, at);
    Ok(match p {
        Position::RelativeLane {
            entity,
            dlane,
            ds,
            along_lane,
            offset,
            orientation,
        } => {
            let b = find(entity)?;
            let (bl, _) = b.lane.ok_or_else(|| {
                err(
                    at,
                    format!("{entity} is not in a lane: a RelativeLanePosition needs it in one"),
                )
            })?;
            let moved = if *along_lane {
                net.advance(bl, *ds)
            } else {
                LanePos { s: bl.s + ds, ..bl }
            };
            let target = LanePos {
                lane: lane_plus(bl.lane, *dlane),
                ..moved
            };
            let mut pl = on_lane(net, target, *offset).ok_or_else(|| {
                err(at, format!("there is no lane {} at s = {:.1} m on road {} ({dlane} from {entity}'s lane {})", target.lane, target.s, net.roads()[target.road].id, bl.lane))
            })?;
            pl.yaw = orient(pl.yaw, orientation.as_ref());
            pl
        }
        Position::Route {
            route,
            in_route,
            orientation,
        } => {
            let mut pl = on_route(net, route, in_route, bodies, at)?;
            pl.yaw = orient(pl.yaw, orientation.as_ref());
            pl
        }
        _ => unreachable!("the other kinds are resolved by resolve"),
    })
}

fn on_road(
    net: &RoadNetwork,
    r: usize,
    s: f64,
    t: f64,
    o: Option<&Orientation>,
    at: &str,
) -> Result<Place, ScenarioError> {
    let road = &net.roads()[r];
    if !(0.0..=road.length).contains(&s) {
        return Err(err(
            at,
            format!(
                "s = {s:.2} m is beyond road {} (0 to {:.1} m)",
                road.id, road.length
            ),
        ));
    }
    let (x, y, _, h) = road.st_to_xyz_hdg(s, t);
    let lane = lane_at(net, x, y);
    // Along the road's direction of travel at that t: the lane's heading
    // when there is one (a lane of the other direction faces back).
    let base = lane
        .and_then(|(l, off)| on_lane(net, l, off))
        .map_or(h, |p| p.yaw);
    Ok(Place {
        x,
        y,
        yaw: orient(base, o),
        lane,
    })
}

/// The lanes a route runs through, waypoint to waypoint (each leg the
/// map's route between them).
pub fn route_lanes(
    net: &RoadNetwork,
    route: &Route,
    bodies: &[Body],
    at: &str,
) -> Result<Vec<LanePos>, ScenarioError> {
    let mut places = Vec::new();
    for (_, p) in &route.waypoints {
        let pl = resolve(net, p, bodies, at)?;
        let (l, _) = pl.lane.ok_or_else(|| {
            err(
                at,
                format!("a waypoint of route '{}' is not on a lane", route.name),
            )
        })?;
        places.push(l);
    }
    Ok(places)
}

/// A `RoutePosition`: `pathS` along the route from its first waypoint
/// (the lanes the route passes, road after road).
fn on_route(
    net: &RoadNetwork,
    route: &Route,
    in_route: &InRoute,
    bodies: &[Body],
    at: &str,
) -> Result<Place, ScenarioError> {
    let lanes = route_lanes(net, route, bodies, at)?;
    let start = lanes[0];
    let (s, lane, offset) = match in_route {
        InRoute::FromCurrentEntity(e) => {
            let b = body(bodies, e, at)?;
            return Ok(Place {
                x: b.x,
                y: b.y,
                yaw: b.yaw,
                lane: b.lane,
            });
        }
        InRoute::FromRoadCoordinates { s, t } => (*s, None, *t),
        InRoute::FromLaneCoordinates { s, lane, offset } => (*s, Some(*lane), *offset),
    };
    let p = net.advance(start, s);
    let p = LanePos {
        lane: lane.unwrap_or(p.lane),
        ..p
    };
    match lane {
        Some(_) => on_lane(net, p, offset).ok_or_else(|| {
            err(
                at,
                format!(
                    "route '{}' has no lane {} at pathS = {s} m",
                    route.name, p.lane
                ),
            )
        }),
        None => on_road(net, p.road, p.s, offset, None, at),
    }
}
