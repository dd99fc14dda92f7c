//! Following a path or a trajectory (`follow_path`, `replay_path`,
//! `follow_trajectory`, `replay_trajectory`): the actor leaves its lane
//! and goes along the points, by arc length at its own speed, or where the
//! trajectory is at each time; at the end it takes the lane it is on (or
//! stands there, off the roads).

use super::*;
use crate::elab::PathDef;
use crate::intent::PathFrame;

/// A path being followed.
#[derive(Clone, Debug)]
pub(super) struct OnPath {
    /// Points in the map's frame: x, y, heading.
    pts: Vec<(f64, f64, f64)>,
    /// Arc length at each point (m).
    cum: Vec<f64>,
    /// A trajectory's times from the phase's start (s).
    times: Option<Vec<f64>>,
    /// Arc length now, and where it ends (m).
    s: f64,
    end: f64,
    /// The phase's start (s).
    t0: f64,
    /// Where the trajectory is at each time (`replay_trajectory`).
    exact: bool,
}

/// The pose `u` of the way along segment `i` of `pts`, the heading turned
/// by the shorter way.
fn lerp(pts: &[(f64, f64, f64)], i: usize, u: f64) -> (f64, f64, f64) {
    let (a, b) = (pts[i], pts[(i + 1).min(pts.len() - 1)]);
    (
        a.0 + (b.0 - a.0) * u,
        a.1 + (b.1 - a.1) * u,
        a.2 + wrap_angle(b.2 - a.2) * u,
    )
}

impl OnPath {
    /// The pose at arc length `s`.
    fn at_s(&self, s: f64) -> (f64, f64, f64) {
        let i = self.cum.partition_point(|&c| c <= s).saturating_sub(1);
        let i = i.min(self.pts.len() - 2);
        let len = (self.cum[i + 1] - self.cum[i]).max(1e-9);
        lerp(&self.pts, i, ((s - self.cum[i]) / len).clamp(0.0, 1.0))
    }

    /// A trajectory's pose and speed `tau` seconds after its start.
    fn at_time(&self, tau: f64) -> ((f64, f64, f64), f64) {
        let times = self.times.as_deref().unwrap_or(&[]);
        let i = times.partition_point(|&c| c <= tau).saturating_sub(1);
        let i = i.min(times.len().saturating_sub(2));
        let span = (times[i + 1] - times[i]).max(1e-9);
        let v = (self.cum[i + 1] - self.cum[i]) / span;
        (
            lerp(&self.pts, i, ((tau - times[i]) / span).clamp(0.0, 1.0)),
            v,
        )
    }

    /// The time the trajectory ends (s from its start), or none.
    fn last_time(&self) -> Option<f64> {
        self.times.as_ref().and_then(|t| t.last().copied())
    }
}

impl Mover<'_> {
    /// Enters a path or trajectory phase at sample `k` (time `t`): the
    /// path in the map's frame (a relative one placed on its reference's
    /// pose now), and where the actor starts on it.
    pub(super) fn start_path(
        &mut self,
        l: &RLeaf,
        (k, t): (usize, f64),
        intent: &Intent,
        plans: &[ActorPlan],
    ) -> Result<(), ScenarioError> {
        let &Intent::FollowPath {
            path,
            ref reference,
            frame,
            offsets: (start, end_off),
            exact,
        } = intent
        else {
            return Ok(());
        };
        let def: &PathDef = &self.cx.paths[path];
        let err = |what: String| self.action_err(l, what);
        let mut pts = match frame {
            PathFrame::Road | PathFrame::Lane if def.relative => {
                self.on_the_road(l, t, (def, reference, frame), plans)?
            }
            _ => self.on_the_reference(l, t, (def, reference, frame), plans)?,
        };
        let mut cum = Vec::with_capacity(pts.len());
        let mut total = 0.0;
        for i in 0..pts.len() {
            if i > 0 {
                total += math::hypot(pts[i].0 - pts[i - 1].0, pts[i].1 - pts[i - 1].1);
            }
            cum.push(total);
        }
        if total <= 1e-6 {
            return Err(err(format!("its path ({}) has no length", def.source)));
        }
        // Headings: given ones (turned with the reference, or the road
        // there: the third value holds that base), else along it.
        for i in 0..pts.len() {
            let (a, b) = (
                pts[i.saturating_sub(1).min(pts.len() - 2)],
                pts[(i + 1).min(pts.len() - 1)],
            );
            let along = math::atan2(b.1 - a.1, b.0 - a.0);
            pts[i].2 = match def.points[i].h {
                Some(h) => wrap_angle(pts[i].2 + h),
                None => along,
            };
        }
        let end = total - end_off;
        if start < 0.0 || end_off < 0.0 || end <= start {
            return Err(err(format!(
                "start_offset {start} m and end_offset {end_off} m leave nothing of its {total:.1} m path"
            )));
        }
        let times = def.timed.then(|| {
            let t_first = def.points[0].t.unwrap_or(0.0);
            def.points
                .iter()
                .map(|p| p.t.unwrap_or(0.0) - t_first)
                .collect()
        });
        // physical_movement chooses between exactness and physics: a
        // trajectory is where it is at each time only when neither
        // physical option is asked (replay_*, or follow_* that prefers
        // the non-physical); a path has no times to be exact to.
        let exact = def.timed
            && match physical_option(l) {
                Some("must_be_physical" | "prefer_physical") => false,
                Some("prefer_non_physical") => true,
                _ => exact,
            };
        let on = OnPath {
            pts,
            cum,
            times,
            s: start,
            end,
            t0: t,
            exact,
        };
        if !def.timed && self.target.is_none() && self.end_speed.is_none() && self.mo.v < 0.1 {
            return Err(err(
                "it stands and has no speed to follow its path at: give it one (`with: speed(…)`)"
                    .into(),
            ));
        }
        // A path that starts away from the actor puts it there.
        let (x0, y0, _) = on.at_s(start);
        let here = self.cx.net.lane_pos_pose(self.mo.pos, self.mo.lateral);
        let away = math::hypot(x0 - here.position.x, y0 - here.position.y);
        if k > 0 && away > 1.0 && self.parked.is_none() {
            self.out.jumps.push(k);
            self.out.notes.push(format!(
                "{}: {}'s path ({}) starts {away:.1} m from where it is: it is put there",
                l.at, self.id, def.source
            ));
        }
        self.parked = None;
        self.on_path = Some(on);
        self.reaching = Some((l.id, Reach::Path, t));
        self.exact(l, l.action.name());
        Ok(())
    }

    /// A `follow_trajectory`'s target: the trajectory's speed now.
    pub(super) fn path_target(&mut self, t: f64) {
        if let Some(p) = &self.on_path
            && p.times.is_some()
            && !p.exact
        {
            self.target = Some(p.at_time(t - p.t0).1);
        }
    }

    /// The sample at `t` on the path (or where a path left the actor off
    /// the roads); `None` on its lane.
    pub(super) fn path_sample(&mut self, t: f64, prev_v: f64) -> Option<PlanSample> {
        let dt = self.cx.dt;
        if let Some(p) = &self.on_path {
            let ((x, y, yaw), v) = if p.exact {
                p.at_time(t - p.t0)
            } else {
                (p.at_s(p.s), self.mo.v)
            };
            self.mo.v = v;
            return Some(PlanSample {
                t,
                x,
                y,
                yaw,
                v,
                a: (v - prev_v) / dt,
            });
        }
        self.parked.map(|p| {
            self.mo.v = 0.0;
            PlanSample {
                t,
                v: 0.0,
                a: -prev_v / dt,
                ..p
            }
        })
    }

    /// Moves one plan step along the path at the sample's speed.
    pub(super) fn path_advance(&mut self) {
        let v = self.mo.v;
        if let Some(p) = &mut self.on_path
            && !p.exact
        {
            p.s = (p.s + v * self.cx.dt).min(p.end);
        }
    }

    /// A path passed to its end (a trajectory's last time) by `t`: the
    /// phase ends at `t`, and the actor takes the lane it is on there, or
    /// stands there off the roads. Checked before the phases that start
    /// at `t` are entered, like a changed gap.
    pub(super) fn path_reached(&mut self, t: f64) {
        let Some(p) = &self.on_path else {
            return;
        };
        let done = match (p.exact, p.last_time()) {
            (true, Some(last)) => t - p.t0 >= last - 1e-9,
            _ => p.s >= p.end - 1e-9,
        };
        if !done || t <= p.t0 + 1e-9 {
            return;
        }
        if let Some((id, Reach::Path, t0)) = self.reaching {
            self.out
                .reached
                .push((super::super::timer::reach_key(id), t - t0));
            self.reaching = None;
        }
        self.leave_path(t);
    }

    /// Leaves the path where the actor is on it at `t` (its end, or where
    /// a parent's duration cut it short).
    pub(super) fn leave_path(&mut self, t: f64) {
        let Some(p) = self.on_path.take() else {
            return;
        };
        let (x, y, yaw) = if p.exact {
            p.at_time(t - p.t0).0
        } else {
            p.at_s(p.s)
        };
        match self.cx.net.locate(litesim_core::Vec2::new(x, y)) {
            Some(at) => {
                self.mo.pos = LanePos {
                    road: at.road,
                    lane: at.lane,
                    s: at.s,
                };
                self.mo.lateral = at.offset;
                self.reached = None;
            }
            None => {
                self.out.notes.push(format!(
                    "{}'s path ends off the map's roads at ({x:.1}, {y:.1}), t = {t:.1} s: it stands there from then on",
                    self.id
                ));
                self.parked = Some(PlanSample {
                    t,
                    x,
                    y,
                    yaw,
                    v: 0.0,
                    a: 0.0,
                });
            }
        }
    }
}

impl Mover<'_> {
    /// A path's points in the map's frame, placed on its reference's pose
    /// now (`object_relative`, `world_relative`) or absolute; each with the
    /// heading its own given heading is relative to (the third value).
    fn on_the_reference(
        &self,
        l: &RLeaf,
        t: f64,
        (def, reference, frame): (&PathDef, &Option<String>, PathFrame),
        plans: &[ActorPlan],
    ) -> Result<Vec<(f64, f64, f64)>, ScenarioError> {
        // The reference's pose now: another actor's plan, or this one.
        let (rx, ry, ryaw) = match (def.relative, reference) {
            (false, _) => (0.0, 0.0, 0.0),
            (true, Some(o)) => {
                let j = self.planned_before(l, o, "path", plans)?;
                let p = plans[j].at(t, self.cx.dt);
                (p.x, p.y, p.yaw)
            }
            (true, None) => {
                let p = self.cx.net.lane_pos_pose(self.mo.pos, self.mo.lateral);
                (p.position.x, p.position.y, p.yaw)
            }
        };
        let world = frame == PathFrame::World || !def.relative;
        let (s, c) = if world {
            (0.0, 1.0)
        } else {
            math::sin_cos(ryaw)
        };
        let base = if world { 0.0 } else { ryaw };
        Ok(def
            .points
            .iter()
            .map(|p| (rx + c * p.x - s * p.y, ry + s * p.x + c * p.y, base))
            .collect())
    }

    /// A relative path's points along the road its reference is on
    /// (`road_relative`: x along the road in its direction of travel, y
    /// sideways from the reference; `lane_relative`: y from its lane's
    /// centre), so that the path bends with the road; each with the lane's
    /// heading there (its given heading is relative to it). A point off
    /// that road's ends is an error.
    fn on_the_road(
        &self,
        l: &RLeaf,
        t: f64,
        (def, reference, frame): (&PathDef, &Option<String>, PathFrame),
        plans: &[ActorPlan],
    ) -> Result<Vec<(f64, f64, f64)>, ScenarioError> {
        let net = self.cx.net;
        let err = |what: String| self.action_err(l, what);
        // Where the reference is: road, lane, s and its offset from the
        // lane's centre (left of its travel).
        let (pos, offset) = match reference {
            Some(o) => {
                let j = self.planned_before(l, o, "path", plans)?;
                let p = plans[j].at(t, self.cx.dt);
                let at = net.locate(litesim_core::Vec2::new(p.x, p.y)).ok_or_else(|| {
                    err(format!("its reference {o} is off the roads, where a {frame:?}-relative path has no road"))
                })?;
                let pos = LanePos {
                    road: at.road,
                    lane: at.lane,
                    s: at.s,
                };
                let dir = if net.travels_forward(pos) { 1.0 } else { -1.0 };
                (pos, dir * at.offset)
            }
            None => (self.mo.pos, self.mo.lateral),
        };
        let road = &net.roads()[pos.road];
        let dir = if net.travels_forward(pos) { 1.0 } else { -1.0 };
        let from = if frame == PathFrame::Road {
            offset
        } else {
            0.0
        };
        def.points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let s = pos.s + dir * p.x;
                let centre = net.lane_pose_at(pos.road, pos.lane, s, 0.0).filter(|_| (0.0..=road.length).contains(&s)).ok_or_else(|| {
                    err(format!(
                        "point {} of its path ({}) is {:.1} m along road {} from s = {:.1} m, beyond the road's ends (0–{:.1} m)",
                        i + 1,
                        def.source,
                        p.x,
                        road.id,
                        pos.s,
                        road.length
                    ))
                })?;
                let (sn, cs) = math::sin_cos(centre.yaw);
                let y = from + p.y;
                Ok((centre.position.x - sn * y, centre.position.y + cs * y, centre.yaw))
            })
            .collect()
    }
}

impl Mover<'_> {
    /// `change_position(…, on_road_network: false)` entered at `t`: a
    /// straight line from where it is to the target, driven
    /// like a path at its own speed (its modifiers, else the speed it
    /// has), ending there; a `position_3d` target may be off the roads.
    pub(super) fn start_straight(
        &mut self,
        l: &RLeaf,
        t: f64,
        place: &crate::intent::Place,
    ) -> Result<(), ScenarioError> {
        let net = self.cx.net;
        let (x1, y1) = match place {
            crate::intent::Place::Xy { x, y } => (*x, *y),
            other => {
                let (pos, lateral) = self.resolve_place(l, other)?;
                let p = net.lane_pos_pose(pos, lateral);
                (p.position.x, p.position.y)
            }
        };
        let here = net.lane_pos_pose(self.mo.pos, self.mo.lateral);
        let (x0, y0) = (here.position.x, here.position.y);
        let len = math::hypot(x1 - x0, y1 - y0);
        if len < 0.1 {
            return Err(self.action_err(l, "it is at its target already".into()));
        }
        self.needs_speed(l, "change its position")?;
        let yaw = math::atan2(y1 - y0, x1 - x0);
        self.parked = None;
        self.on_path = Some(OnPath {
            pts: vec![(x0, y0, yaw), (x1, y1, yaw)],
            cum: vec![0.0, len],
            times: None,
            s: 0.0,
            end: len,
            t0: t,
            exact: false,
        });
        self.reaching = Some((l.id, Reach::Path, t));
        self.exact(l, "change_position(on_road_network: false)");
        Ok(())
    }
}

/// The `physical_movement(option)` of phase `l`, if it has one.
fn physical_option(l: &RLeaf) -> Option<&str> {
    l.mods.iter().find_map(|m| match m {
        Intent::PhysicalMovement { option } => Some(option.as_str()),
        _ => None,
    })
}
