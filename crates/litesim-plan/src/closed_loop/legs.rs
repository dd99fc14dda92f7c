//! A path as legs driven one way each (forward or reversing), the escape
//! from a start inside an obstacle's margin, and the proofs that no path
//! exists.

use super::*;

/// A stretch of the path driven in one direction: its corridor, built and
/// tracked in the direction of travel (for a reversing leg the body is
/// mirrored, [`PlanningGrid::reversed`], and the controller drives the
/// vehicle turned around: heading + π, speed, acceleration and steering
/// negated — the kinematic bicycle's equations are the same).
#[derive(Clone, Debug, PartialEq)]
pub struct Leg {
    /// The reference along the leg, in the direction of travel.
    pub corridor: Corridor,
    /// Driven backwards.
    pub reverse: bool,
    /// What the corridor was built with (the leg is rebuilt from where
    /// the vehicle actually stopped before it).
    pub(super) limits: SpeedLimits,
    pub(super) end_heading: Option<f64>,
}

impl Leg {
    /// A forward leg (the whole path of a run that never reverses).
    pub(super) fn forward(corridor: Corridor, limits: &SpeedLimits) -> Self {
        Self {
            corridor,
            reverse: false,
            limits: *limits,
            end_heading: None,
        }
    }

    /// The leg started again from where the vehicle stands (`at`) and the
    /// way it faces (`travel`: its direction of travel on this leg), if
    /// its body fits along the result: the vehicle stops a centimetre or
    /// two off the cusp and turned by a hundredth of a radian, which a leg
    /// that starts slowly would otherwise carry for metres.
    pub(crate) fn restarted_at(
        &self,
        at: Vec2,
        travel: f64,
        grid: &PlanningGrid,
        ds: f64,
    ) -> Option<Corridor> {
        // From where it stands on along the planned points it has not
        // passed: those after the nearest of the first few metres (a
        // vehicle that stalled short of the cusp stands past the next
        // leg's first points).
        let planned = &self.corridor.raw;
        let nearest = planned
            .iter()
            .take(60)
            .enumerate()
            .min_by(|a, b| a.1.distance(at).total_cmp(&b.1.distance(at)))?
            .0;
        let mut raw = vec![at];
        raw.extend_from_slice(planned.get(nearest + 1..)?);
        if raw.len() < 2 {
            return None;
        }
        let limits = SpeedLimits {
            start_heading: Some(travel),
            ..self.limits
        };
        let c = Corridor::along_to(&raw, grid, ds, &limits, self.end_heading);
        c.first_blocked(grid).is_none().then_some(c)
    }
}

/// How the vehicle turned around drives a leg: (sign of its speed,
/// acceleration and steering; what its heading gains) — (−1, π) on a
/// reversing leg, (1, 0) on a forward one.
pub(crate) fn turned_around(reverse: bool) -> (f64, f64) {
    if reverse {
        (-1.0, std::f64::consts::PI)
    } else {
        (1.0, 0.0)
    }
}

/// Top speed driving backwards (m/s): a walking pace and a half, as
/// drivers reverse (and what keeps a long body's swing small).
pub const REVERSE_SPEED_MAX: f64 = 2.0;

/// The legs of a path, one per direction (a path that never reverses is
/// one forward leg along it): each leg's corridor leaves in the direction
/// the vehicle is in at its start (the start heading, then the previous
/// leg's end turned around), a leg after a cusp from rest; `grid_for`
/// gives the grid of a direction (reversing: the body mirrored).
pub(super) fn legs_along<'g>(
    segments: &[crate::hybrid::PathSegment],
    grid_for: &dyn Fn(bool) -> &'g PlanningGrid,
    ds: f64,
    limits: &SpeedLimits,
) -> Vec<Leg> {
    // The direction of travel at a cusp, from the search's arcs (points
    // 0.1 m apart): the leg arrives along it and the next one leaves
    // against it — the vehicle's heading is continuous.
    let leaving = |pts: &[Vec2]| match pts {
        [a, b, ..] => Some((*b - *a).heading()),
        _ => None,
    };
    let arriving = |pts: &[Vec2]| match pts {
        [.., a, b] => Some((*b - *a).heading()),
        _ => None,
    };
    let mut legs: Vec<Leg> = Vec::with_capacity(segments.len());
    for (k, seg) in segments.iter().enumerate() {
        let start_heading = match (k, seg.reverse) {
            (0, false) => limits.start_heading,
            (0, true) => limits
                .start_heading
                .map(|h| wrap_angle(h + turned_around(true).1)),
            _ => leaving(&seg.points),
        };
        let end_heading = if k + 1 < segments.len() {
            arriving(&seg.points)
        } else {
            None
        };
        let lim = SpeedLimits {
            start_heading,
            v_max: if seg.reverse {
                limits.v_max.min(REVERSE_SPEED_MAX)
            } else {
                limits.v_max
            },
            // After a cusp the vehicle starts from rest.
            v_start: if k == 0 { limits.v_start } else { 0.0 },
            ..*limits
        };
        legs.push(Leg {
            corridor: Corridor::along_to(&seg.points, grid_for(seg.reverse), ds, &lim, end_heading),
            reverse: seg.reverse,
            limits: lim,
            end_heading,
        });
    }
    legs
}

/// A goal the reference point can be at: a finite point on the map, not
/// inside an obstacle. One inside the margin is planned to (within the
/// goal's tolerance, where the body keeps the margin); one that is not a
/// place is refused with the place and why.
pub(super) fn goal_on_the_map(pgrid: &PlanningGrid, goal: Vec2) -> Result<(), PlanError> {
    if !(goal.x.is_finite() && goal.y.is_finite()) {
        return Err(PlanError::Config(format!(
            "goal: ({}, {}) is not a finite point",
            goal.x, goal.y
        )));
    }
    let g = &pgrid.grid;
    if g.cell(goal).is_none() {
        let (x1, y1) = (
            g.origin.x + g.width as f64 * g.resolution,
            g.origin.y + g.height as f64 * g.resolution,
        );
        return Err(PlanError::Impossible(format!(
            "the goal ({:.2}, {:.2}) is off the map, which spans x {:.1}..{x1:.1} m, y {:.1}..{y1:.1} m",
            goal.x, goal.y, g.origin.x, g.origin.y
        )));
    }
    if g.is_occupied(goal) {
        return Err(PlanError::Impossible(format!(
            "the goal ({:.2}, {:.2}) lies inside an obstacle",
            goal.x, goal.y
        )));
    }
    Ok(())
}

/// Whether no path exists from `(from, yaw)` to within `end_within` of
/// `goal` on the curvature-bounded search's lattice: a search forwards and
/// backwards at the vehicle's full curvature `kappa_max` that expands every
/// pose reachable from the start without reaching the goal (within
/// [`EXHAUSTIVE_POSES`]). Run only where every other search failed; the
/// text says what was searched.
pub(super) fn exhausted(
    pgrid: &PlanningGrid,
    from: Vec2,
    yaw: f64,
    goal: Vec2,
    kappa_max: f64,
    end_within: f64,
) -> Option<String> {
    let base = HybridConfig::new(kappa_max, pgrid.grid.resolution);
    let hcfg = HybridConfig {
        goal_tolerance: end_within,
        reverse: true,
        max_expansions: EXHAUSTIVE_POSES,
        steering_in_state: true,
        ..base
    };
    match hybrid_astar(pgrid, from, yaw, goal, &hcfg) {
        // Every reachable pose expanded (and at least the start: a search
        // pruned before it begins proves nothing).
        Err(HybridError::NoPath { expansions, .. })
            if expansions > 0 && expansions < EXHAUSTIVE_POSES =>
        {
            Some(format!(
                "no path exists on the search's lattice: forwards and backwards at the full steering ({:.2} m turns), {:.2} m cells, {} headings, {:.2} m arcs, the body's covering circles keeping the margin, every one of the {expansions} poses reachable from the start was expanded and none came within {end_within:.2} m of the goal",
                1.0 / kappa_max,
                hcfg.cell,
                hcfg.headings,
                hcfg.step
            ))
        }
        _ => None,
    }
}

/// The escape leg out of the margin ([`crate::escape`]) as the path's
/// first leg: it leaves along the start heading (turned around when it
/// reverses), arrives along the leg's end heading and ends at rest, where
/// the planned path starts.
pub(super) fn escape_leg<'g>(
    e: &crate::escape::Escape,
    yaw: f64,
    grid_for: &dyn Fn(bool) -> &'g PlanningGrid,
    ds: f64,
    limits: &SpeedLimits,
    speed: f64,
) -> Leg {
    let (_, turn) = turned_around(e.reverse);
    let lim = SpeedLimits {
        start_heading: Some(wrap_angle(yaw + turn)),
        v_max: limits.v_max.min(REVERSE_SPEED_MAX),
        v_start: speed.max(0.0),
        ..*limits
    };
    let end_heading = Some(wrap_angle(e.end_yaw + turn));
    Leg {
        corridor: Corridor::along_to(&e.points, grid_for(e.reverse), ds, &lim, end_heading),
        reverse: e.reverse,
        limits: lim,
        end_heading,
    }
}

/// The legs as one corridor to look at: points, arc length and time run
/// on; headings are the vehicle's (the direction of travel + π on a
/// reversing leg) and speeds negative there. One forward leg is itself.
pub(super) fn joined(legs: &[Leg]) -> Corridor {
    match legs {
        [one] if !one.reverse => one.corridor.clone(),
        _ => {
            let mut out = Corridor {
                smoothed: true,
                jerk_limited: true,
                ..Corridor::default()
            };
            for leg in legs {
                let c = &leg.corridor;
                let (s0, t0) = (out.length(), out.duration());
                let (sign, turn) = turned_around(leg.reverse);
                out.raw.extend(&c.raw);
                out.shortcut.extend(&c.shortcut);
                out.points.extend(&c.points);
                out.s.extend(c.s.iter().map(|s| s0 + s));
                out.time.extend(c.time.iter().map(|t| t0 + t));
                out.heading
                    .extend(c.heading.iter().map(|h| wrap_angle(h + turn)));
                out.curvature.extend(&c.curvature);
                out.speed.extend(c.speed.iter().map(|v| sign * v));
                out.left_bound.extend(&c.left_bound);
                out.right_bound.extend(&c.right_bound);
                out.smoothed &= c.smoothed;
                out.jerk_limited &= c.jerk_limited;
            }
            out
        }
    }
}

/// Footprint sample points of a rear-axle-referenced vehicle.
pub(super) fn footprint(v: &Vehicle, x: f64, y: f64, yaw: f64) -> Vec<Vec2> {
    let rear = (v.length - v.wheelbase) / 2.0;
    let f = Vec2::from_heading(yaw);
    let n = Vec2::new(-f.y, f.x);
    let base = Vec2::new(x, y);
    let mut pts = Vec::new();
    for i in 0..=8 {
        let along = -rear + v.length * i as f64 / 8.0;
        for j in 0..=2 {
            let across = -v.width / 2.0 + v.width * j as f64 / 2.0;
            pts.push(base + f * along + n * across);
        }
    }
    pts
}
