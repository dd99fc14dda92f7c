//! What each action does when it starts: instantaneous ones (teleport,
//! routes, controllers, signals, entities, parameters) take effect and
//! end at once; the others hand their entities a control strategy
//! (`motion`) that ends when its goal is reached. A new action on the
//! same domain of an entity overrides the one running there.

use super::motion::{self, GapKind, Lat, Long, Path};
use super::place::{self, Place};
use super::{Body, Storyboard, kind_name};
use crate::error::ScenarioError;
use crate::runtime::controllers::{Act, ssp_err};
use litesim_ssp::traffic::{BulbColor, BulbMode, BulbState, LightTarget};
use litesim_xosc::{
    Action, ActionKind, Dimension, LaneTarget, OffsetTarget, Shape, SpeedTarget, TrajShape, ValueOp,
};

fn err(at: &str, msg: impl std::fmt::Display) -> ScenarioError {
    ScenarioError::Plan(format!("{at}: {msg}"))
}

impl Storyboard {
    /// Starts `a` (`ai`: its index among the stories' actions; none for an
    /// Init action). True when it is over at once.
    pub(super) fn apply(&mut self, a: &Action, ai: Option<usize>) -> Result<bool, ScenarioError> {
        let ix = ai.unwrap_or(usize::MAX);
        match &a.kind {
            ActionKind::Note(text) => {
                self.notes.push(format!("{}: {text}", a.at));
                Ok(true)
            }
            ActionKind::SetValue { variable, name, op } => {
                let map = if *variable {
                    &mut self.vars
                } else {
                    &mut self.params
                };
                let old = map.get(name).cloned().unwrap_or_default();
                let num = |s: &str| {
                    s.trim().parse::<f64>().map_err(|_| {
                        err(
                            &a.at,
                            format!("'{name}' = \"{s}\" is not a number to change"),
                        )
                    })
                };
                let new = match op {
                    ValueOp::Set(v) => v.clone(),
                    ValueOp::Add(d) => fmt(num(&old)? + d),
                    ValueOp::Multiply(f) => fmt(num(&old)? * f),
                };
                map.insert(name.clone(), new);
                Ok(true)
            }
            ActionKind::TrafficSignalState { signal, state } => {
                self.pending.push((signal.clone(), state.clone()));
                Ok(true)
            }
            ActionKind::TrafficSignalController { controller, phase } => {
                let sc = self.scenario.clone();
                let k = sc
                    .signal_controllers
                    .iter()
                    .position(|c| c.name == *controller)
                    .ok_or_else(|| err(&a.at, format!("no signal controller '{controller}'")))?;
                let p = sc.signal_controllers[k]
                    .phases
                    .iter()
                    .position(|p| p.name == *phase)
                    .ok_or_else(|| {
                        err(
                            &a.at,
                            format!("signal controller '{controller}' has no phase '{phase}'"),
                        )
                    })?;
                self.phases[k] = (p, self.t);
                for (signal, state) in &sc.signal_controllers[k].phases[p].states {
                    self.pending.push((signal.clone(), state.clone()));
                }
                Ok(true)
            }
            ActionKind::AddEntity { entity, position } => {
                let pl = place::resolve(&self.net, position, &self.bodies, &a.at)?;
                let i = self.body_ix(entity, &a.at)?;
                put(&mut self.bodies[i], pl);
                self.bodies[i].active = true;
                Ok(true)
            }
            ActionKind::DeleteEntity { entity } => {
                let i = self.body_ix(entity, &a.at)?;
                let b = &mut self.bodies[i];
                b.active = false;
                b.long = None;
                b.lat = None;
                b.path = None;
                b.v = 0.0;
                let (x, y) = super::parked(i);
                b.x = x;
                b.y = y;
                b.lane = None;
                Ok(true)
            }
            ActionKind::ActivateController {
                lateral,
                longitudinal,
            } => {
                for who in &a.actors {
                    let i = self.body_ix(who, &a.at)?;
                    let by = if self.driven[i] {
                        "the storyboard (no system under test drives it)"
                    } else {
                        "the system under test"
                    };
                    self.notes.push(format!(
                        "{}: ActivateControllerAction on {who} (lateral {}, longitudinal {}): {who} is driven by {by} for the whole run",
                        a.at,
                        opt(*lateral),
                        opt(*longitudinal)
                    ));
                }
                Ok(true)
            }
            ActionKind::AssignController(c) => {
                self.notes.push(format!(
                    "{}: AssignControllerAction {} on {}: played by litesim's storyboard player (the standard's default controller)",
                    a.at,
                    c.name,
                    a.actors.join(", ")
                ));
                Ok(true)
            }
            _ => self.apply_private(a, ix),
        }
    }

    fn body_ix(&self, name: &str, at: &str) -> Result<usize, ScenarioError> {
        self.bodies
            .iter()
            .position(|b| b.id == name)
            .ok_or_else(|| err(at, format!("entity '{name}' does not exist")))
    }

    /// A private action on each of its actors.
    fn apply_private(&mut self, a: &Action, ix: usize) -> Result<bool, ScenarioError> {
        let mut instant = true;
        let actors: Vec<usize> = a.actors.iter().flat_map(|n| self.members(n)).collect();
        for i in actors {
            // The Init's places and speeds set the SUT's car up too; after
            // the start the SUT drives it.
            let setup = !self.started && matches!(a.kind, ActionKind::Speed { .. });
            if !self.driven[i] && !setup && !matches!(a.kind, ActionKind::Teleport(_)) {
                self.notes.push(format!(
                    "{}: {} on {} is not applied: the system under test drives it",
                    a.at,
                    kind_name(&a.kind),
                    self.bodies[i].id
                ));
                continue;
            }
            instant &= self.private_on(a, ix, i)?;
        }
        Ok(instant)
    }

    /// A private action on body `i`; true when it is over at once.
    fn private_on(&mut self, a: &Action, ix: usize, i: usize) -> Result<bool, ScenarioError> {
        let net = self.net.clone();

        match &a.kind {
            ActionKind::Teleport(p) => {
                let pl = place::resolve(&net, p, &self.bodies, &a.at)?;
                if !self.driven[i] && self.started {
                    self.notes.push(format!(
                        "{}: TeleportAction on {} is not applied: the system under test drives it",
                        a.at, self.bodies[i].id
                    ));
                    return Ok(true);
                }
                put(&mut self.bodies[i], pl);
                self.bodies[i].active = true;
                Ok(true)
            }
            ActionKind::Speed { .. } => self.speed_action(a, ix, i),
            ActionKind::LaneChange { .. } => self.lane_change(a, ix, i),
            ActionKind::LaneOffset { .. } => self.lane_offset(a, ix, i),
            ActionKind::LongitudinalDistance {
                entity,
                distance,
                time_gap,
                freespace,
                continuous,
                leading,
                limits,
            } => {
                self.body_ix(entity, &a.at)?;
                let gap = match (distance, time_gap) {
                    (Some(d), _) => GapKind::Distance(*d),
                    (_, Some(h)) => GapKind::Time(*h),
                    _ => GapKind::Distance(0.0),
                };
                let long = Long::Distance {
                    ix,
                    reference: entity.clone(),
                    gap,
                    freespace: *freespace,
                    continuous: *continuous,
                    leading: *leading,
                    limits: *limits,
                };
                self.override_long(i, Some(long));
                Ok(false)
            }
            ActionKind::Synchronize {
                master,
                master_target,
                target,
                final_speed,
                tolerance,
                ..
            } => {
                self.body_ix(master, &a.at)?;
                let mt = place::resolve(&net, master_target, &self.bodies, &a.at)?;
                let tg = place::resolve(&net, target, &self.bodies, &a.at)?;
                let long = Long::Sync {
                    ix,
                    master: master.clone(),
                    master_target: mt,
                    target: tg,
                    final_speed: final_speed.clone(),
                    tolerance: *tolerance,
                };
                self.override_long(i, Some(long));
                Ok(false)
            }
            ActionKind::FollowTrajectory {
                trajectory,
                timing,
                follow,
                initial_offset,
            } => {
                let path =
                    self.path_of(trajectory, *timing, *follow, *initial_offset, ix, &a.at)?;
                let b = &mut self.bodies[i];
                b.path = Some(path);
                b.lat = None;
                if b.path.as_ref().is_some_and(|p| p.times.is_some()) {
                    b.long = None;
                }
                Ok(false)
            }
            ActionKind::AssignRoute(route) => {
                let lanes = place::route_lanes(&net, route, &self.bodies, &a.at)?;
                self.bodies[i].route = self.route_through(&lanes, &a.at)?;
                Ok(true)
            }
            ActionKind::AcquirePosition(p) => {
                let pl = place::resolve(&net, p, &self.bodies, &a.at)?;
                let b = &self.bodies[i];
                let (from, _) = b
                    .lane
                    .ok_or_else(|| err(&a.at, format!("{} is not in a lane", b.id)))?;
                let (to, _) = pl
                    .lane
                    .ok_or_else(|| err(&a.at, "the position to acquire is not on a lane"))?;
                let route = self.route_through(&[from, to], &a.at)?;
                let b = &mut self.bodies[i];
                b.route = route;
                b.acquire = Some((ix, pl));
                Ok(false)
            }
            _ => unreachable!("global actions are applied before"),
        }
    }

    /// `LaneChange Action` on body `i`.
    fn lane_change(&mut self, a: &Action, ix: usize, i: usize) -> Result<bool, ScenarioError> {
        let net = self.net.clone();
        let t = self.t;
        let ActionKind::LaneChange {
            transition,
            target,
            target_offset,
        } = &a.kind
        else {
            unreachable!("called for its kind")
        };
        let b = &self.bodies[i];
        let Some((p, off)) = b.lane else {
            return Err(err(
                &a.at,
                format!("{} is not in a lane: it cannot change lanes", b.id),
            ));
        };
        let lane = match target {
            LaneTarget::Absolute(l) => *l,
            LaneTarget::Relative { entity, lanes } => {
                let r = &self.bodies[self.body_ix(entity, &a.at)?];
                let (rp, _) = r
                    .lane
                    .ok_or_else(|| err(&a.at, format!("{entity} is not in a lane")))?;
                if *lanes == 0 {
                    rp.lane
                } else {
                    net.lane_beside(rp, *lanes).ok_or_else(|| {
                        err(
                            &a.at,
                            format!(
                                "there is no lane {lanes} to the {} of {entity}",
                                if *lanes > 0 { "left" } else { "right" }
                            ),
                        )
                    })?
                }
            }
        };
        let to = litesim_map::LanePos { lane, ..p };
        let (tc_now, tc_to) = (motion::t_center(&net, p), motion::t_center(&net, to));
        let (Some(a0), Some(a1)) = (tc_now, tc_to) else {
            return Err(err(
                &a.at,
                format!(
                    "road {} has no lane {lane} at s = {:.1} m",
                    net.roads()[p.road].id,
                    p.s
                ),
            ));
        };
        let d0 = a0 + off - a1;
        let (dur, dist) = match transition.dimension {
            Dimension::Distance => (None, Some((b.traveled, transition.value))),
            _ => (
                Some(if transition.shape == Shape::Step {
                    0.0
                } else {
                    transition.value
                }),
                None,
            ),
        };
        let lat = Lat {
            ix,
            d0,
            d1: *target_offset,
            shape: transition.shape,
            t0: t,
            dur,
            dist,
            track: None,
        };
        let b = &mut self.bodies[i];
        b.lane = Some((to, d0));
        self.override_lat(i, Some(lat));
        Ok(false)
    }

    /// `LaneOffset Action` on body `i`.
    fn lane_offset(&mut self, a: &Action, ix: usize, i: usize) -> Result<bool, ScenarioError> {
        let t = self.t;
        let ActionKind::LaneOffset {
            continuous,
            shape,
            max_lateral_acc,
            target,
        } = &a.kind
        else {
            unreachable!("called for its kind")
        };
        let b = &self.bodies[i];
        let now = b.lane.map_or(0.0, |l| l.1);
        let (goal, track) = match target {
            OffsetTarget::Absolute(v) => (*v, None),
            OffsetTarget::Relative { entity, value } => {
                let r = &self.bodies[self.body_ix(entity, &a.at)?];
                (
                    r.lane.map_or(0.0, |l| l.1) + value,
                    continuous.then(|| (entity.clone(), *value)),
                )
            }
        };
        let d = (goal - now).abs();
        // The standard's shapes at their greatest sideways
        // acceleration (none given: at once).
        let dur = match max_lateral_acc {
            None => 0.0,
            Some(acc) => match shape {
                Shape::Step => 0.0,
                Shape::Cubic => (6.0 * d / acc).sqrt(),
                Shape::Sinusoidal => std::f64::consts::PI * (d / (2.0 * acc)).sqrt(),
                Shape::Linear => (2.0 * d / acc).sqrt(),
            },
        };
        let lat = Lat {
            ix,
            d0: now,
            d1: goal,
            shape: *shape,
            t0: t,
            dur: Some(dur),
            dist: None,
            track,
        };
        self.override_lat(i, Some(lat));
        Ok(false)
    }

    /// `Speed Action` on body `i`.
    fn speed_action(&mut self, a: &Action, ix: usize, i: usize) -> Result<bool, ScenarioError> {
        let t = self.t;
        let ActionKind::Speed { transition, target } = &a.kind else {
            unreachable!("called for its kind")
        };
        let b = &self.bodies[i];
        let vt = motion::target_speed(target, &self.bodies);
        let v0 = b.v;
        let continuous = matches!(
            target,
            SpeedTarget::Relative {
                continuous: true,
                ..
            }
        );
        let rate =
            (continuous && transition.dimension == Dimension::Rate).then_some(transition.value);
        let dur =
            motion::check_duration(motion::duration(transition, v0, vt, Some((v0, vt))), &a.at)?;
        // A relative target that is not continuous is the reference's
        // speed when the action starts.
        let target = if continuous {
            target.clone()
        } else {
            SpeedTarget::Absolute(vt)
        };
        let long = Long::Speed {
            ix,
            v0,
            target,
            shape: transition.shape,
            t0: t,
            dur,
            rate,
            follow: transition.follow,
        };
        if !self.started {
            // Init: a step takes effect before the first step.
            if dur <= 0.0 && !continuous {
                self.bodies[i].v = vt;
                return Ok(true);
            }
        }
        self.override_long(i, Some(long));
        Ok(false)
    }

    /// The lanes from waypoint to waypoint along the map's routes.
    fn route_through(
        &self,
        lanes: &[litesim_map::LanePos],
        at: &str,
    ) -> Result<Vec<litesim_map::LanePos>, ScenarioError> {
        let net = &self.net;
        let node = |p: &litesim_map::LanePos| litesim_map::LaneRef {
            road: p.road,
            section: net.roads()[p.road].section_index(p.s),
            lane: p.lane,
        };
        let mut out = Vec::new();
        for w in lanes.windows(2) {
            let legs = net.route(node(&w[0]), node(&w[1])).ok_or_else(|| {
                err(
                    at,
                    format!(
                        "no route from road {} lane {} to road {} lane {}",
                        net.roads()[w[0].road].id,
                        w[0].lane,
                        net.roads()[w[1].road].id,
                        w[1].lane
                    ),
                )
            })?;
            out.extend(legs.into_iter().map(|r| litesim_map::LanePos {
                road: r.road,
                lane: r.lane,
                s: 0.0,
            }));
        }
        Ok(out)
    }

    fn override_long(&mut self, i: usize, long: Option<Long>) {
        if let Some(old) = self.bodies[i].long.take() {
            let ai = match &old {
                Long::Speed { ix, .. } | Long::Distance { ix, .. } | Long::Sync { ix, .. } => *ix,
            };
            self.action_over(ai, true);
        }
        if let Some(old) = self.bodies[i].path.take()
            && old.times.is_some()
        {
            self.action_over(old.ix, true);
        }
        self.bodies[i].long = long;
    }

    fn override_lat(&mut self, i: usize, lat: Option<Lat>) {
        if let Some(old) = self.bodies[i].lat.take() {
            self.action_over(old.ix, true);
        }
        if let Some(old) = self.bodies[i].path.take() {
            self.action_over(old.ix, true);
        }
        self.bodies[i].lat = lat;
    }

    /// A trajectory as world points with arc lengths (and times).
    fn path_of(
        &self,
        tr: &litesim_xosc::Trajectory,
        timing: Option<litesim_xosc::Timing>,
        follow: bool,
        initial: f64,
        ix: usize,
        at: &str,
    ) -> Result<Path, ScenarioError> {
        let net = &self.net;
        let mut pts: Vec<(f64, f64, Option<f64>)> = Vec::new();
        match &tr.shape {
            TrajShape::Polyline(v) => {
                for (time, p) in v {
                    let pl = place::resolve(net, p, &self.bodies, at)?;
                    pts.push((pl.x, pl.y, *time));
                }
            }
            TrajShape::Clothoid {
                start,
                curvature,
                curvature_prime,
                length,
                start_time,
                stop_time,
            } => {
                let pl = place::resolve(net, start, &self.bodies, at)?;
                let n = ((length / 0.25).ceil() as usize).clamp(2, 100_000);
                let (mut x, mut y, mut h) = (pl.x, pl.y, pl.yaw);
                let ds = length / n as f64;
                for k in 0..=n {
                    let s = k as f64 * ds;
                    let time = match (start_time, stop_time) {
                        (Some(a), Some(b)) => Some(a + (b - a) * s / length.max(1e-9)),
                        _ => None,
                    };
                    pts.push((x, y, time));
                    // Midpoint rule on the heading over the step.
                    let hm = h + (curvature + curvature_prime * (s + 0.5 * ds)) * 0.5 * ds;
                    let (hs, hc) = litesim_core::math::sin_cos(hm);
                    x += ds * hc;
                    y += ds * hs;
                    h += (curvature + curvature_prime * (s + 0.5 * ds)) * ds;
                }
            }
            TrajShape::Nurbs {
                order,
                points,
                knots,
            } => {
                let mut cps = Vec::new();
                for (time, w, p) in points {
                    let pl = place::resolve(net, p, &self.bodies, at)?;
                    cps.push((pl.x, pl.y, time.unwrap_or(f64::NAN), *w));
                }
                let timed = points.iter().all(|(t, _, _)| t.is_some());
                let (u0, u1) = (knots[*order as usize - 1], knots[points.len()]);
                let n = (points.len() * 16).max(32);
                for k in 0..=n {
                    let u = u0 + (u1 - u0) * k as f64 / n as f64;
                    let (x, y, tt) = nurbs_point(
                        *order as usize,
                        &cps,
                        knots,
                        u.min(u1 - 1e-12 * (u1 - u0).abs().max(1.0)),
                    );
                    pts.push((x, y, timed.then_some(tt)));
                }
            }
        }
        if pts.len() < 2 {
            return Err(err(
                at,
                format!("trajectory '{}' has fewer than two points", tr.name),
            ));
        }
        let mut out = Vec::with_capacity(pts.len());
        let mut s = 0.0;
        for (k, p) in pts.iter().enumerate() {
            if k > 0 {
                s += litesim_core::math::hypot(p.0 - pts[k - 1].0, p.1 - pts[k - 1].1);
            }
            out.push((p.0, p.1, s));
        }
        let times = match timing {
            Some(tm) if pts.iter().all(|p| p.2.is_some()) => {
                let base = if tm.absolute { 0.0 } else { self.t };
                Some(
                    pts.iter()
                        .map(|p| base + tm.offset + tm.scale * p.2.unwrap_or(0.0))
                        .collect(),
                )
            }
            Some(_) => {
                return Err(err(
                    at,
                    format!(
                        "trajectory '{}' has timing but not every point has a time",
                        tr.name
                    ),
                ));
            }
            None => None,
        };
        Ok(Path {
            ix,
            pts: out,
            times,
            at: initial.max(0.0),
            closed: tr.closed,
            follow,
        })
    }

    /// Sets a signal's state in the simulator (`off;off;on`: red, yellow,
    /// green lamps top to bottom; or a colour's name).
    pub(super) fn set_signal(
        &mut self,
        act: &mut Act<'_>,
        signal: &str,
        state: &str,
    ) -> Result<(), ScenarioError> {
        let lights = act.ssp.list_traffic_lights().map_err(ssp_err)?;
        let Some(b) = lights.boxes.iter().find(|b| b.id == signal) else {
            return Err(ScenarioError::Plan(format!(
                "traffic signal '{signal}' is not in the map (its signals: {})",
                lights
                    .boxes
                    .iter()
                    .map(|b| b.id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        let lower = state.to_ascii_lowercase();
        let on: Vec<BulbColor> = if lower.contains(';') {
            lower
                .split(';')
                .zip([BulbColor::Red, BulbColor::Yellow, BulbColor::Green])
                .filter(|(s, _)| s.trim() == "on")
                .map(|(_, c)| c)
                .collect()
        } else {
            [
                ("red", BulbColor::Red),
                ("yellow", BulbColor::Yellow),
                ("amber", BulbColor::Yellow),
                ("green", BulbColor::Green),
            ]
            .iter()
            .filter(|(w, _)| lower.contains(w))
            .map(|(_, c)| *c)
            .collect()
        };
        let states: Vec<BulbState> = b
            .bulbs
            .iter()
            .map(|bulb| BulbState {
                icon: bulb.icon,
                color: bulb.color,
                mode: if on.contains(&bulb.color) {
                    BulbMode::On
                } else {
                    BulbMode::Off
                },
            })
            .collect();
        act.ssp
            .set_traffic_light_state(LightTarget::Box(signal.to_string()), states)
            .map_err(ssp_err)?;
        self.signals.insert(signal.to_string(), state.to_string());
        Ok(())
    }
}

/// Puts a body at a place.
fn put(b: &mut Body, pl: Place) {
    b.x = pl.x;
    b.y = pl.y;
    b.yaw = pl.yaw;
    b.lane = pl.lane;
    b.path = None;
}

fn fmt(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 9e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

fn opt(b: Option<bool>) -> &'static str {
    match b {
        Some(true) => "on",
        Some(false) => "off",
        None => "unchanged",
    }
}

/// A NURBS curve's point (x, y, and the control points' times blended the
/// same way) at parameter `u`, by the Cox–de Boor recursion.
fn nurbs_point(
    order: usize,
    cps: &[(f64, f64, f64, f64)],
    knots: &[f64],
    u: f64,
) -> (f64, f64, f64) {
    let n = cps.len();
    let mut basis = vec![0.0; n + order];
    for i in 0..n + order - 1 {
        basis[i] = if knots[i] <= u && u < knots[i + 1] {
            1.0
        } else {
            0.0
        };
    }
    for k in 2..=order {
        for i in 0..n + order - k {
            let a = knots[i + k - 1] - knots[i];
            let b = knots[i + k] - knots[i + 1];
            let left = if a > 0.0 {
                (u - knots[i]) / a * basis[i]
            } else {
                0.0
            };
            let right = if b > 0.0 {
                (knots[i + k] - u) / b * basis[i + 1]
            } else {
                0.0
            };
            basis[i] = left + right;
        }
    }
    let (mut x, mut y, mut t, mut w) = (0.0, 0.0, 0.0, 0.0);
    for (i, c) in cps.iter().enumerate() {
        let bw = basis[i] * c.3;
        x += bw * c.0;
        y += bw * c.1;
        t += bw * c.2;
        w += bw;
    }
    if w > 0.0 {
        (x / w, y / w, t / w)
    } else {
        (cps[0].0, cps[0].1, cps[0].2)
    }
}
