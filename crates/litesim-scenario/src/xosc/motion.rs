//! The storyboard's default controller: each entity's motion under the
//! actions that run on it — a longitudinal one (speed, distance,
//! synchronize), a lateral one (lane change, lane offset), or a
//! trajectory — moved one step at a time along its lane (or its path).
//!
//! Shapes follow the standard exactly (`followingMode position`, the
//! default): a linear speed change over 2 s reaches its speed at t0 + 2 s,
//! a sinusoidal lane change lands on the lane centre at its duration.
//! `followingMode follow` keeps to the entity's performance limits.

use super::Body;
use super::place::{self, Place};
use crate::error::ScenarioError;
use litesim_core::math;
use litesim_map::{LanePos, RoadNetwork};
use litesim_xosc::{Dimension, Shape, SpeedTarget, Transition};

/// A running action's index in the storyboard's flat action list.
pub type ActionIx = usize;

/// A longitudinal action under way.
#[derive(Clone, Debug)]
pub enum Long {
    /// `SpeedAction`.
    Speed {
        /// The action.
        ix: ActionIx,
        /// Speed when it started (m/s).
        v0: f64,
        /// What it aims at.
        target: SpeedTarget,
        /// Shape.
        shape: Shape,
        /// Start time (s).
        t0: f64,
        /// Duration (s; 0 for a step; for a rate, from the first target).
        dur: f64,
        /// A rate dynamics (m/s²) for a continuous target.
        rate: Option<f64>,
        /// Within the entity's limits.
        follow: bool,
    },
    /// `LongitudinalDistanceAction`.
    Distance {
        /// The action.
        ix: ActionIx,
        /// Reference entity.
        reference: String,
        /// Gap (m) or time gap (s).
        gap: GapKind,
        /// Between bounding boxes.
        freespace: bool,
        /// Never ends.
        continuous: bool,
        /// Ahead of the reference.
        leading: bool,
        /// maxAcceleration, maxDeceleration, maxSpeed (None: rigid).
        limits: Option<[f64; 3]>,
    },
    /// `SynchronizeAction`.
    Sync {
        /// The action.
        ix: ActionIx,
        /// The master entity.
        master: String,
        /// Where the master is going.
        master_target: Place,
        /// Where this entity must be when the master is there.
        target: Place,
        /// The speed to have there (m/s), if given.
        final_speed: Option<SpeedTarget>,
        /// Radius within which the target counts as reached (m).
        tolerance: f64,
    },
}

/// A gap to keep or reach.
#[derive(Clone, Copy, Debug)]
pub enum GapKind {
    /// Metres.
    Distance(f64),
    /// Seconds at the entity's speed.
    Time(f64),
}

/// A lateral action under way: the offset from the (target) lane's centre
/// goes from `d0` to `d1` along its shape.
#[derive(Clone, Debug)]
pub struct Lat {
    /// The action.
    pub ix: ActionIx,
    /// Offset at the start, in the target lane's frame (m, towards +t).
    pub d0: f64,
    /// Offset at the end (m).
    pub d1: f64,
    /// Shape.
    pub shape: Shape,
    /// Start time (s).
    pub t0: f64,
    /// Over a time (s) …
    pub dur: Option<f64>,
    /// … or a travelled distance: (distance travelled at the start, m).
    pub dist: Option<(f64, f64)>,
    /// A relative offset that keeps tracking its reference (entity, value).
    pub track: Option<(String, f64)>,
}

/// A trajectory being followed.
#[derive(Clone, Debug)]
pub struct Path {
    /// The action.
    pub ix: ActionIx,
    /// Points (x, y) and their arc length (m).
    pub pts: Vec<(f64, f64, f64)>,
    /// Each point's time (s, simulation time), when timed.
    pub times: Option<Vec<f64>>,
    /// Arc length covered (m).
    pub at: f64,
    /// Closed: goes round for good.
    pub closed: bool,
    /// Within the entity's limits (`followingMode follow`).
    pub follow: bool,
}

/// What one step of motion finished: actions that reached their goal.
pub type Done = Vec<ActionIx>;

/// The standard's duration of a transition from `from` to `to` (the
/// shapes' progress over time: a distance is turned into the time the
/// shape's mean speed takes; a rate is the shape's peak rate).
pub fn duration(
    t: &Transition,
    from: f64,
    to: f64,
    speeds: Option<(f64, f64)>,
) -> Result<f64, String> {
    if t.shape == Shape::Step {
        return Ok(0.0);
    }
    let delta = (to - from).abs();
    Ok(match t.dimension {
        Dimension::Time => t.value,
        Dimension::Rate => t.shape.peak_slope() * delta / t.value,
        Dimension::Distance => match speeds {
            Some((v0, v1)) if v0 + v1 > 1e-9 => 2.0 * t.value / (v0 + v1),
            Some(_) => {
                return Err(format!(
                    "a speed change over a distance ({} m) from and to standstill never covers it",
                    t.value
                ));
            }
            None => t.value,
        },
    })
}

/// The shape's progress from `t0` over `dur` at time `t`.
fn progress(shape: Shape, t: f64, t0: f64, dur: f64) -> f64 {
    if dur <= 0.0 {
        1.0
    } else {
        shape.at((t - t0) / dur)
    }
}

/// A speed target's value now.
pub fn target_speed(target: &SpeedTarget, bodies: &[Body]) -> f64 {
    match target {
        SpeedTarget::Absolute(v) => *v,
        SpeedTarget::Relative {
            entity,
            value,
            factor,
            ..
        } => {
            let r = bodies.iter().find(|b| b.id == *entity).map_or(0.0, |b| b.v);
            if *factor { r * value } else { r + value }
        }
    }
}

/// The lane-centre t of `p`'s lane (m).
pub fn t_center(net: &RoadNetwork, p: LanePos) -> Option<f64> {
    net.roads()[p.road]
        .lane_span(p.s, p.lane)
        .map(|l| l.t_center())
}

/// Gap from `me` to `r` along the direction of travel (m, + when `r` is
/// ahead): by s on the same road, else along `r`'s heading.
pub fn along_gap(net: &RoadNetwork, me: &Body, r: &Body) -> f64 {
    if let (Some((a, _)), Some((b, _))) = (me.lane, r.lane)
        && a.road == b.road
    {
        let dir = if net.travels_forward(a) { 1.0 } else { -1.0 };
        return (b.s - a.s) * dir;
    }
    -litesim_core::ahead_along(
        litesim_core::Vec2::new(r.x, r.y),
        r.yaw,
        litesim_core::Vec2::new(me.x, me.y),
    )
}

impl Body {
    /// Moves the body by one step `dt` from time `t`: its speed from its
    /// longitudinal action, its lane offset from its lateral one, or its
    /// trajectory. `others` are the other bodies as they were at `t`.
    pub fn step(&mut self, net: &RoadNetwork, t: f64, dt: f64, others: &[Body], done: &mut Done) {
        // A step change holds for the whole step (the speed is new from
        // the step's start); any other change is integrated as a trapezoid.
        let stepped = matches!(&self.long, Some(Long::Speed { dur, .. }) if *dur <= 0.0);
        let v_before = self.v;
        self.step_speed(net, t, dt, others, done);
        let v_prev = if stepped { self.v } else { v_before };
        if self.path.is_some() {
            self.step_path(net, t, dt, v_prev, done);
            return;
        }
        let ds = 0.5 * (v_prev + self.v) * dt;
        self.traveled += ds.abs();
        let before = self.lane.map(|l| l.1);
        let offset = self.step_lateral(t + dt, others, done);
        // Standing with nothing moving it sideways, it keeps its pose
        // (a heading of its own, the end of a road).
        if ds == 0.0 && before == Some(offset) {
            return;
        }
        match self.lane {
            // Vehicles go along their lanes; people, animals and objects
            // straight on where they face.
            Some((p, _)) if self.on_lanes => {
                let route = &self.route;
                let choose = |next: &[litesim_map::LaneRef]| -> Option<litesim_map::LaneRef> {
                    next.iter()
                        .find(|n| route.iter().any(|r| r.road == n.road))
                        .or(next.first())
                        .copied()
                };
                let (np, rest) = net.advance_choosing(p, ds, &choose);
                self.end_of_road = rest > 1e-9 || (np == p && self.end_of_road);
                if self.end_of_road {
                    self.v = 0.0;
                }
                let before = (self.x, self.y);
                match net.lane_pose_travel_at(np.road, np.lane, np.s, offset) {
                    Some((pl, forward)) => {
                        // Heading: the lane's, turned by the sideways speed.
                        let lateral = (offset - self.lane.map_or(offset, |l| l.1))
                            * if forward { 1.0 } else { -1.0 };
                        let along = (self.v * dt).max(1e-6);
                        self.yaw = litesim_core::wrap_angle(pl.yaw + math::atan(lateral / along));
                        self.x = pl.position.x;
                        self.y = pl.position.y;
                        self.lane = Some((np, offset));
                    }
                    None => {
                        // The lane ended under it: straight on.
                        self.lane = None;
                        let (ys, yc) = self.trig_of(self.yaw);
                        self.x = before.0 + ds * yc;
                        self.y = before.1 + ds * ys;
                    }
                }
            }
            _ => {
                let (ys, yc) = self.trig_of(self.yaw);
                self.x += ds * yc;
                self.y += ds * ys;
                self.lane = place::lane_at(net, self.x, self.y);
            }
        }
    }

    /// The speed after this step, from the longitudinal action.
    fn step_speed(&mut self, net: &RoadNetwork, t: f64, dt: f64, others: &[Body], done: &mut Done) {
        let Some(long) = self.long.clone() else {
            return;
        };
        let t1 = t + dt;
        let (max_acc, max_dec) = (self.perf[1].max(1e-3), self.perf[2].max(1e-3));
        let clamp = |v0: f64, v: f64, on: bool| {
            if on {
                v.clamp(v0 - max_dec * dt, v0 + max_acc * dt)
            } else {
                v
            }
        };
        match long {
            Long::Speed {
                ix,
                v0,
                target,
                shape,
                t0,
                dur,
                rate,
                follow,
            } => {
                let vt = target_speed(&target, others);
                let continuous = matches!(
                    target,
                    SpeedTarget::Relative {
                        continuous: true,
                        ..
                    }
                );
                let v = match rate {
                    Some(r) if continuous => self.v + (vt - self.v).clamp(-r * dt, r * dt),
                    _ if continuous && dur <= 0.0 => vt,
                    _ => v0 + (vt - v0) * progress(shape, t1, t0, dur),
                };
                self.v = clamp(self.v, v, follow).min(self.perf[0]).max(0.0);
                if !continuous && (t1 >= t0 + dur - 1e-9) && (!follow || (self.v - vt).abs() < 1e-6)
                {
                    self.v = vt.max(0.0);
                    self.long = None;
                    done.push(ix);
                }
            }
            Long::Distance { .. } => self.step_distance(net, &long, dt, others, done),
            Long::Sync {
                ix,
                ref master,
                master_target,
                target,
                ref final_speed,
                tolerance,
            } => {
                let Some(m) = others.iter().find(|b| b.id == *master) else {
                    return;
                };
                let dm = ((master_target.x - m.x).powi(2) + (master_target.y - m.y).powi(2)).sqrt();
                let da = ((target.x - self.x).powi(2) + (target.y - self.y).powi(2)).sqrt();
                let vf = final_speed.as_ref().map(|f| target_speed(f, others));
                if da <= tolerance.max(self.v * dt) {
                    if let Some(vf) = vf {
                        self.v = vf.max(0.0);
                    }
                    self.long = None;
                    done.push(ix);
                    return;
                }
                // The master's time to its target; this entity covers its
                // own distance in the same time, ending at the final speed
                // (a linear change: the mean of now and then covers it).
                let tm = if m.v > 1e-6 { dm / m.v } else { f64::INFINITY };
                let want = match vf {
                    Some(vf) if tm.is_finite() => 2.0 * da / tm - vf,
                    _ if tm.is_finite() => da / tm,
                    _ => self.v,
                };
                self.v = clamp(self.v, want, true).clamp(0.0, self.perf[0]);
            }
        }
    }

    fn step_distance(
        &mut self,
        net: &RoadNetwork,
        long: &Long,
        dt: f64,
        others: &[Body],
        done: &mut Done,
    ) {
        let Long::Distance {
            ix,
            reference,
            gap,
            freespace,
            continuous,
            leading,
            limits,
        } = long
        else {
            return;
        };
        let Some(r) = others.iter().find(|b| b.id == *reference) else {
            return;
        };
        let want = match gap {
            GapKind::Distance(d) => *d,
            GapKind::Time(h) => h * self.v,
        } + if *freespace {
            0.5 * (self.length + r.length)
        } else {
            0.0
        };
        // Where it should be: behind the reference (trailing) or ahead.
        let sign = if *leading { -1.0 } else { 1.0 };
        let err = sign * along_gap(net, self, r) - want;
        match limits {
            None => {
                // Rigid: at the distance at once, at the reference's speed.
                if let Some((p, off)) = self.lane {
                    let np = net.advance(p, sign * err);
                    if let Some(pl) = place::on_lane(net, np, off) {
                        self.x = pl.x;
                        self.y = pl.y;
                        self.lane = Some((np, off));
                    }
                }
                self.v = r.v;
            }
            Some([acc, dec, vmax]) => {
                // Closes the error in about two seconds, within the limits.
                let v = r.v + sign * err / 2.0;
                self.v = v
                    .clamp(self.v - dec * dt, self.v + acc * dt)
                    .clamp(0.0, vmax.min(self.perf[0]));
            }
        }
        let reached = err.abs() < 0.1 && (self.v - r.v).abs() < 0.1;
        if !continuous && (limits.is_none() || reached) {
            self.long = None;
            done.push(*ix);
        }
    }

    /// The lane offset at the end of this step (time `t1`).
    fn step_lateral(&mut self, t1: f64, others: &[Body], done: &mut Done) -> f64 {
        let now = self.lane.map_or(0.0, |l| l.1);
        let Some(lat) = self.lat.as_mut() else {
            return now;
        };
        if let Some((e, value)) = &lat.track
            && let Some(r) = others.iter().find(|b| b.id == *e)
        {
            lat.d1 = r.lane.map_or(0.0, |l| l.1) + value;
        }
        let f = match (lat.dur, lat.dist) {
            (Some(d), _) => progress(lat.shape, t1, lat.t0, d),
            (None, Some((tr0, d))) if d > 0.0 => lat.shape.at((self.traveled - tr0) / d),
            _ => 1.0,
        };
        let off = lat.d0 + (lat.d1 - lat.d0) * f;
        if f >= 1.0 - 1e-12 && lat.track.is_none() {
            let ix = lat.ix;
            let d1 = lat.d1;
            self.lat = None;
            done.push(ix);
            return d1;
        }
        off
    }

    /// Along its trajectory for one step.
    fn step_path(&mut self, net: &RoadNetwork, t: f64, dt: f64, v_prev: f64, done: &mut Done) {
        let Some(path) = self.path.as_mut() else {
            return;
        };
        let total = path.pts.last().map_or(0.0, |p| p.2);
        let t1 = t + dt;
        let target_s = match &path.times {
            Some(times) => {
                // Where the timing puts it at t1: linear in time between
                // vertices.
                let k = times.partition_point(|&x| x <= t1);
                if k == 0 {
                    0.0
                } else if k >= times.len() {
                    total
                } else {
                    let (ta, tb) = (times[k - 1], times[k]);
                    let (sa, sb) = (path.pts[k - 1].2, path.pts[k].2);
                    if tb > ta {
                        sa + (sb - sa) * (t1 - ta) / (tb - ta)
                    } else {
                        sb
                    }
                }
            }
            None => path.at + 0.5 * (v_prev + self.v) * dt,
        };
        let mut s1 = target_s;
        if path.follow {
            // Within the limits: the speed it may have this step.
            let v_want = (target_s - path.at) / dt;
            let v = v_want
                .clamp(v_prev - self.perf[2] * dt, v_prev + self.perf[1] * dt)
                .min(self.perf[0]);
            s1 = path.at + v.max(0.0) * dt;
        }
        let moved = s1 - path.at;
        if path.times.is_some() || path.follow {
            self.v = (moved / dt).max(0.0);
        }
        self.traveled += moved.abs();
        path.at = if path.closed && total > 0.0 {
            s1.rem_euclid(total)
        } else {
            s1.min(total)
        };
        let (x, y, yaw) = point_at(&path.pts, path.at);
        self.x = x;
        self.y = y;
        self.yaw = yaw;
        self.lane = place::lane_at(net, x, y);
        if !path.closed && path.at >= total - 1e-9 {
            let ix = path.ix;
            self.path = None;
            done.push(ix);
        }
    }
}

/// The point and heading at arc length `s` along `pts`.
pub fn point_at(pts: &[(f64, f64, f64)], s: f64) -> (f64, f64, f64) {
    let k = pts.partition_point(|p| p.2 <= s).clamp(1, pts.len() - 1);
    let (a, b) = (pts[k - 1], pts[k]);
    let yaw = math::atan2(b.1 - a.1, b.0 - a.0);
    let u = if b.2 > a.2 {
        ((s - a.2) / (b.2 - a.2)).clamp(0.0, 1.0)
    } else {
        1.0
    };
    (a.0 + (b.0 - a.0) * u, a.1 + (b.1 - a.1) * u, yaw)
}

/// Checks a resolved transition: errors name the action.
pub fn check_duration(r: Result<f64, String>, at: &str) -> Result<f64, ScenarioError> {
    r.map_err(|m| ScenarioError::Plan(format!("{at}: {m}")))
}
