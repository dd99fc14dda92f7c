//! Checkers and KPIs over the executed states: collisions between actors
//! (oriented boxes, separating axes), off-road vehicles, minimum distance
//! (box to box) and time to collision per pair (constant velocities, swept
//! boxes), and speed and path errors against the plan.

use litesim_core::geometry::wrap_angle;
use litesim_core::math;
use serde::Serialize;
use std::collections::BTreeMap;

/// One actor's box at one step.
#[derive(Clone, Copy, Debug)]
pub struct BoxState {
    /// Centre x (m).
    pub x: f64,
    /// Centre y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
    /// Length (m).
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// World velocity x (m/s).
    pub vx: f64,
    /// World velocity y (m/s).
    pub vy: f64,
}

/// A box's corners and the trig of its heading, computed once per box and
/// step and shared by every pair test it takes part in.
#[derive(Clone, Copy, Debug)]
struct Shape {
    corners: [(f64, f64); 4],
    /// Centre.
    centre: (f64, f64),
    /// Half length and half width.
    half: (f64, f64),
    /// Centre to corner (m).
    radius: f64,
    /// `sin_cos(yaw)`.
    sc: (f64, f64),
    /// `sin_cos(yaw + π/2)`.
    sc90: (f64, f64),
}

impl Shape {
    fn of(b: &BoxState) -> Self {
        let sc = math::sin_cos(b.yaw);
        let (s, c) = sc;
        let (hl, hw) = (b.length / 2.0, b.width / 2.0);
        let p = |u: f64, v: f64| (b.x + u * c - v * s, b.y + u * s + v * c);
        Shape {
            corners: [p(hl, hw), p(-hl, hw), p(-hl, -hw), p(hl, -hw)],
            centre: (b.x, b.y),
            half: (hl, hw),
            radius: math::hypot(hl, hw),
            sc,
            sc90: math::sin_cos(b.yaw + std::f64::consts::FRAC_PI_2),
        }
    }
}

/// The interval a box's corners cover along the axis (ux, uy).
fn interval(c: &[(f64, f64); 4], ux: f64, uy: f64) -> (f64, f64) {
    c.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let d = p.0 * ux + p.1 * uy;
            (lo.min(d), hi.max(d))
        })
}

/// Whether two oriented boxes overlap (separating axis theorem).
pub fn overlap(a: &BoxState, b: &BoxState) -> bool {
    overlap_shapes(&Shape::of(a), &Shape::of(b))
}

/// The separating-axis test (the axes are the two boxes' edge directions).
fn overlap_shapes(a: &Shape, b: &Shape) -> bool {
    separation(a, b).is_none()
}

/// The widest gap between the boxes' intervals over the separating axes:
/// `None` when they overlap on every axis (the boxes overlap), else a lower
/// bound of their distance (a projection onto a unit axis never lengthens).
fn separation(a: &Shape, b: &Shape) -> Option<f64> {
    let mut widest: Option<f64> = None;
    for sh in [a, b] {
        for (ax, ay) in [sh.sc, sh.sc90] {
            // (sin, cos) → axis (cos, sin)
            let (ux, uy) = (ay, ax);
            let (a0, a1) = interval(&a.corners, ux, uy);
            let (b0, b1) = interval(&b.corners, ux, uy);
            let gap = if a1 < b0 {
                b0 - a1
            } else if b1 < a0 {
                a0 - b1
            } else {
                continue;
            };
            widest = Some(widest.map_or(gap, |w| w.max(gap)));
        }
    }
    widest
}

/// Squared distance from a point to a filled box (0 inside): the point in
/// the box's frame, clamped to its half extents.
fn point_box_sq(p: (f64, f64), b: &Shape) -> f64 {
    let (s, c) = b.sc;
    let (dx, dy) = (p.0 - b.centre.0, p.1 - b.centre.1);
    let ex = ((dx * c + dy * s).abs() - b.half.0).max(0.0);
    let ey = ((-dx * s + dy * c).abs() - b.half.1).max(0.0);
    ex * ex + ey * ey
}

/// Distance between two boxes (0 when they overlap).
pub fn distance(a: &BoxState, b: &BoxState) -> f64 {
    distance_shapes(&Shape::of(a), &Shape::of(b))
}

fn distance_shapes(a: &Shape, b: &Shape) -> f64 {
    if overlap_shapes(a, b) {
        return 0.0;
    }
    corner_distance(a, b)
}

/// The distance of two boxes that do not overlap: for two separate convex
/// polygons it is reached at a corner of one, so it is the smallest
/// distance of a corner of either to the other (filled) box.
fn corner_distance(a: &Shape, b: &Shape) -> f64 {
    let mut d2 = f64::INFINITY;
    for c in &a.corners {
        d2 = d2.min(point_box_sq(*c, b));
    }
    for c in &b.corners {
        d2 = d2.min(point_box_sq(*c, a));
    }
    d2.sqrt()
}

/// KPIs of one actor pair.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PairKpi {
    /// First actor id.
    pub a: String,
    /// Second actor id.
    pub b: String,
    /// Smallest box-to-box distance (m), to [`DISTANCE_RESOLUTION`].
    pub min_distance: f64,
    /// When it was smallest (s).
    pub min_distance_at: f64,
    /// Smallest time to collision (s): when the boxes would touch if both
    /// kept their velocities (within [`TTC_HORIZON`]); `null` when never.
    pub min_ttc: Option<f64>,
    /// When it was smallest (s).
    pub min_ttc_at: Option<f64>,
    /// First collision time (s).
    pub collision_at: Option<f64>,
}

/// KPIs of one actor.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ActorKpi {
    /// Id.
    pub id: String,
    /// Largest |speed − planned speed| (m/s).
    pub max_speed_error: f64,
    /// Largest distance from the planned position (m).
    pub max_path_error: f64,
    /// RMS distance from the planned position (m).
    pub rms_path_error: f64,
    /// First time off every road (s), vehicles only.
    pub off_road_at: Option<f64>,
    /// Distance travelled (m).
    pub distance: f64,
    /// Top speed (m/s).
    pub max_speed: f64,
    /// The first red light run: (box id, time s).
    pub ran_red_light: Option<(String, f64)>,
}

/// Pairs closer than this (box bound to box bound, m) are tracked: their
/// distance, TTC and collisions are computed exactly.
pub const NEAR: f64 = 30.0;
/// Pairs whose boxes, swept along their velocities over this time, could
/// meet are tracked too (s); it bounds the TTCs reported.
pub const TTC_HORIZON: f64 = 5.0;

/// Time until two boxes touch if both keep their velocities: the swept
/// separating-axis test (for translating convex polygons the edge normals
/// of both are the only candidate axes). `None` when they never touch,
/// `Some(0)` when they overlap now.
pub fn time_to_collision(a: &BoxState, b: &BoxState) -> Option<f64> {
    ttc_shapes(&Shape::of(a), &Shape::of(b), b.vx - a.vx, b.vy - a.vy)
}

/// [`time_to_collision`] of b moving at (wx, wy) relative to a.
fn ttc_shapes(a: &Shape, b: &Shape, wx: f64, wy: f64) -> Option<f64> {
    let (mut enter, mut exit) = (0.0f64, f64::INFINITY);
    for sh in [a, b] {
        let (s, c) = sh.sc;
        for (ux, uy) in [(c, s), (-s, c)] {
            let (a0, a1) = interval(&a.corners, ux, uy);
            let (b0, b1) = interval(&b.corners, ux, uy);
            let w = wx * ux + wy * uy;
            if w.abs() < 1e-12 {
                if b1 < a0 || a1 < b0 {
                    return None;
                }
                continue;
            }
            // b's interval [b0 + wτ, b1 + wτ] meets [a0, a1] for τ in [t0, t1].
            let (t0, t1) = ((a0 - b1) / w, (a1 - b0) / w);
            let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
            enter = enter.max(t0);
            exit = exit.min(t1);
            if enter > exit {
                return None;
            }
        }
    }
    (exit >= 0.0 && enter.is_finite()).then_some(enter.max(0.0))
}

/// Up to this many actors the pair index is a table (n² × 4 bytes: 16 MiB
/// at 2,048); beyond, a hash map.
pub const DENSE_PAIRS: usize = 2048;

/// How far below a pair's recorded minimum its distance may go unseen (m):
/// a pair whose relative pose barely changed is not measured again while
/// its distance provably stays within this of the minimum.
pub const DISTANCE_RESOLUTION: f64 = 1e-9;

/// A pair's relative pose at its last exact distance.
#[derive(Clone, Copy, Debug)]
struct Last {
    rel: (f64, f64),
    yaw: (f64, f64),
    d: f64,
}

/// A hasher for pair indices: a multiply-xorshift of the key (the std
/// SipHash led the profile; only lookups use it — outputs are sorted).
#[derive(Clone, Copy, Debug, Default)]
struct PairHasher(u64);

impl std::hash::Hasher for PairHasher {
    fn finish(&self) -> u64 {
        let x = self.0.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        x ^ (x >> 29)
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(*b);
        }
    }
    fn write_u32(&mut self, n: u32) {
        self.0 = (self.0 << 32) ^ u64::from(n);
    }
}

type PairHash = std::hash::BuildHasherDefault<PairHasher>;

/// Accumulates KPIs step by step.
///
/// Pairs go through a broad phase first: each box swept along its
/// velocity over [`TTC_HORIZON`] and grown by [`NEAR`]/2 gives an
/// axis-aligned interval in x and y; the intervals are sorted by x and
/// swept (sort-and-sweep), and only pairs whose intervals overlap in x and
/// y get the narrow phase: the exact box distance where it could set a new
/// minimum, and the swept-box TTC. Pairs that never come within `NEAR`
/// and cannot meet within the horizon are not reported. The cost grows as
/// n log n (plus the pairs that really are close), not n².
#[derive(Clone, Debug, Default)]
pub struct Kpis {
    /// Pairs that came near, in (i, j) order of the actor list (filled by
    /// [`Kpis::finish`]).
    pub pairs: Vec<PairKpi>,
    /// Per actor.
    pub actors: Vec<ActorKpi>,
    /// Pairs met so far, in the order first met, with their index by (i, j)
    /// (a lookup table only: the output is sorted by (i, j)).
    near: Vec<((u32, u32), PairKpi, Option<Last>)>,
    index_of: std::collections::HashMap<(u32, u32), usize, PairHash>,
    /// The same index as a table `i · n + j` (u32::MAX: not met yet) for up
    /// to [`DENSE_PAIRS`] actors: a hash lookup per candidate pair and step
    /// led the profile of dense traffic.
    dense: Vec<u32>,
    ids: Vec<String>,
    sq: Vec<f64>,
    n: usize,
    last: Vec<Option<(f64, f64)>>,
    index: BTreeMap<String, usize>,
    order: Vec<u32>,
    shapes: Vec<Shape>,
    swept: Vec<[f64; 4]>,
    near_box: Vec<[f64; 4]>,
    ttc_box: Vec<[f64; 4]>,
}

impl Kpis {
    /// For these actors.
    pub fn new(ids: &[String]) -> Self {
        Kpis {
            actors: ids
                .iter()
                .map(|id| ActorKpi {
                    id: id.clone(),
                    ..ActorKpi::default()
                })
                .collect(),
            ids: ids.to_vec(),
            sq: vec![0.0; ids.len()],
            n: 0,
            last: vec![None; ids.len()],
            index: ids
                .iter()
                .enumerate()
                .map(|(i, s)| (s.clone(), i))
                .collect(),
            order: (0..ids.len() as u32).collect(),
            dense: if ids.len() <= DENSE_PAIRS {
                vec![u32::MAX; ids.len() * ids.len()]
            } else {
                Vec::new()
            },
            ..Kpis::default()
        }
    }

    /// Records that actor `i` passed the red light `box_id` at `t` (the first one counts).
    pub fn red_light(&mut self, i: usize, box_id: &str, t: f64) {
        let a = &mut self.actors[i];
        if a.ran_red_light.is_none() {
            a.ran_red_light = Some((box_id.to_string(), t));
        }
    }

    /// Index of an actor id.
    pub fn index(&self, id: &str) -> Option<usize> {
        self.index.get(id).copied()
    }

    /// Moves the pairs that came near into [`Kpis::pairs`], in (i, j) order.
    pub fn finish(&mut self) {
        let mut near = std::mem::take(&mut self.near);
        near.sort_by_key(|(k, _, _)| *k);
        self.index_of.clear();
        self.dense = Vec::new();
        self.pairs = near.into_iter().map(|(_, p, _)| p).collect();
    }

    /// Adds one step: boxes, speeds, planned positions and speeds, on-road flags.
    pub fn step(
        &mut self,
        t: f64,
        boxes: &[BoxState],
        speeds: &[f64],
        planned: &[(f64, f64, f64)],
        off_road: &[bool],
    ) {
        self.n += 1;
        let n = boxes.len();
        if n > 1 {
            // Per box: corners, and its box swept over the TTC horizon as
            // an axis-aligned interval in x and y (grown by NEAR / 2).
            self.shapes.clear();
            self.swept.clear();
            self.near_box.clear();
            self.ttc_box.clear();
            // Boxes are swept relative to the actors' mean velocity: moving
            // both boxes of a pair by the same c·τ changes no overlap, so a
            // pair can meet within the horizon only where the boxes swept
            // along v − c meet — and traffic that moves together sweeps
            // (almost) nothing.
            let inv = 1.0 / n as f64;
            let cx = boxes.iter().map(|b| b.vx).sum::<f64>() * inv;
            let cy = boxes.iter().map(|b| b.vy).sum::<f64>() * inv;
            for b in boxes {
                let sh = Shape::of(b);
                let c = sh.corners;
                let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
                for p in &c {
                    x0 = x0.min(p.0);
                    x1 = x1.max(p.0);
                    y0 = y0.min(p.1);
                    y1 = y1.max(p.1);
                }
                let h = 0.5 * NEAR;
                let grown = [x0 - h, x1 + h, y0 - h, y1 + h];
                let (dx, dy) = ((b.vx - cx) * TTC_HORIZON, (b.vy - cy) * TTC_HORIZON);
                let swept = [
                    x0 + dx.min(0.0),
                    x1 + dx.max(0.0),
                    y0 + dy.min(0.0),
                    y1 + dy.max(0.0),
                ];
                self.shapes.push(sh);
                self.near_box.push(grown);
                // The sweep runs on the union of both intervals.
                self.swept.push([
                    grown[0].min(swept[0]),
                    grown[1].max(swept[1]),
                    grown[2].min(swept[2]),
                    grown[3].max(swept[3]),
                ]);
                self.ttc_box.push(swept);
            }
            // Insertion sort by the intervals' low x: the order barely
            // changes from step to step.
            let sw = &self.swept;
            for k in 1..self.order.len() {
                let mut j = k;
                while j > 0 && sw[self.order[j - 1] as usize][0] > sw[self.order[j] as usize][0] {
                    self.order.swap(j - 1, j);
                    j -= 1;
                }
            }
            let order = std::mem::take(&mut self.order);
            for k in 0..n {
                let i = order[k] as usize;
                let [_, hi, ylo, yhi] = self.swept[i];
                for &j in &order[k + 1..] {
                    let j = j as usize;
                    let sj = self.swept[j];
                    if sj[0] > hi {
                        break;
                    }
                    if sj[2] > yhi || sj[3] < ylo {
                        continue;
                    }
                    self.pair(t, i.min(j), i.max(j), boxes);
                }
            }
            self.order = order;
        }
        for (i, a) in self.actors.iter_mut().enumerate() {
            let (px, py, pv) = planned[i];
            let b = &boxes[i];
            let e = ((b.x - px).powi(2) + (b.y - py).powi(2)).sqrt();
            a.max_path_error = a.max_path_error.max(e);
            self.sq[i] += e * e;
            a.rms_path_error = (self.sq[i] / self.n as f64).sqrt();
            a.max_speed_error = a.max_speed_error.max((speeds[i] - pv).abs());
            a.max_speed = a.max_speed.max(speeds[i]);
            if off_road[i] && a.off_road_at.is_none() {
                a.off_road_at = Some(t);
            }
            if let Some((lx, ly)) = self.last[i] {
                a.distance += ((b.x - lx).powi(2) + (b.y - ly).powi(2)).sqrt();
            }
            self.last[i] = Some((b.x, b.y));
        }
    }

    /// The narrow phase of one candidate pair (i < j).
    fn pair(&mut self, t: f64, i: usize, j: usize, boxes: &[BoxState]) {
        let meets = |u: &[f64; 4], v: &[f64; 4]| {
            !(u[0] > v[1] || v[0] > u[1] || u[2] > v[3] || v[2] > u[3])
        };
        let near = meets(&self.near_box[i], &self.near_box[j]);
        let can_meet = meets(&self.ttc_box[i], &self.ttc_box[j]);
        if !near && !can_meet {
            return;
        }
        let (a, b) = (&boxes[i], &boxes[j]);
        let (sa, sb) = (&self.shapes[i], &self.shapes[j]);
        let slot = (!self.dense.is_empty()).then(|| i * self.ids.len() + j);
        let known = match slot {
            Some(x) => (self.dense[x] != u32::MAX).then(|| self.dense[x] as usize),
            None => self.index_of.get(&(i as u32, j as u32)).copied(),
        };
        let k = match known {
            Some(k) => k,
            None => {
                self.near.push((
                    (i as u32, j as u32),
                    PairKpi {
                        a: self.ids[i].clone(),
                        b: self.ids[j].clone(),
                        min_distance: f64::INFINITY,
                        ..PairKpi::default()
                    },
                    None,
                ));
                let k = self.near.len() - 1;
                match slot {
                    Some(x) => self.dense[x] = k as u32,
                    None => {
                        self.index_of.insert((i as u32, j as u32), k);
                    }
                }
                k
            }
        };
        let (pair, p) = {
            let e = &mut self.near[k];
            (&mut e.2, &mut e.1)
        };
        let rel = (b.x - a.x, b.y - a.y);
        // Since the last exact distance the boxes moved relative to each
        // other by at most `moved` (common motion changes no distance;
        // turning by Δψ moves a corner by at most its radius · |Δψ|).
        let bound = pair.map(|l| {
            let moved = math::hypot(rel.0 - l.rel.0, rel.1 - l.rel.1)
                + sa.radius * wrap_angle(a.yaw - l.yaw.0).abs()
                + sb.radius * wrap_angle(b.yaw - l.yaw.1).abs();
            l.d - moved
        });
        let d = match bound {
            // Cannot come below the minimum (within DISTANCE_RESOLUTION)
            // and cannot touch: nothing to compute.
            Some(lb) if lb > 0.0 && lb + DISTANCE_RESOLUTION >= p.min_distance => lb,
            _ => {
                // The separating axes' widest gap is a lower bound too.
                let d = match separation(sa, sb) {
                    None => 0.0,
                    Some(gap) if gap >= p.min_distance => gap,
                    Some(_) => corner_distance(sa, sb),
                };
                *pair = Some(Last {
                    rel,
                    yaw: (a.yaw, b.yaw),
                    d,
                });
                d
            }
        };
        if d < p.min_distance {
            p.min_distance = d;
            p.min_distance_at = t;
        }
        if d == 0.0 && p.collision_at.is_none() {
            p.collision_at = Some(t);
        }
        let (wx, wy) = (b.vx - a.vx, b.vy - a.vy);
        let closing = math::hypot(wx, wy);
        // Separate boxes without relative motion never touch (what
        // ttc_shapes answers too, at a cost). And boxes d apart closing at
        // |w| cannot touch before d / |w|: where that is beyond the horizon
        // or the pair's minimum (with a margin far above rounding), the
        // swept test cannot set a new one.
        let limit = p.min_ttc.map_or(TTC_HORIZON, |m| m.min(TTC_HORIZON));
        if d > 0.0
            && can_meet
            && closing >= 1e-12
            && d <= closing * limit + 1e-6
            && let Some(ttc) = ttc_shapes(sa, sb, wx, wy)
            && ttc <= TTC_HORIZON
            && p.min_ttc.is_none_or(|m| ttc < m)
        {
            p.min_ttc = Some(ttc);
            p.min_ttc_at = Some(t);
        }
    }
}

/// The ego's own KPIs: braking, jerk, where it ended.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct EgoKpi {
    /// Ego id.
    pub id: String,
    /// Largest deceleration (m/s², positive), from the speed step to step.
    pub max_decel: f64,
    /// When (s).
    pub max_decel_at: f64,
    /// Largest |jerk| (m/s³), the change of acceleration over 0.1 s.
    pub max_jerk: f64,
    /// When (s).
    pub max_jerk_at: f64,
    /// Distance from the final position to the route's goal (m).
    pub distance_to_goal: f64,
    /// Final speed (m/s).
    pub final_speed: f64,
    #[serde(skip)]
    dt: f64,
    #[serde(skip)]
    accels: std::collections::VecDeque<f64>,
    #[serde(skip)]
    last_v: Option<f64>,
    #[serde(skip)]
    pos: (f64, f64),
}

impl EgoKpi {
    /// For the ego `id`, stepped every `dt` s.
    pub fn new(id: &str, dt: f64) -> Self {
        EgoKpi {
            id: id.to_string(),
            dt,
            ..EgoKpi::default()
        }
    }

    /// Adds one step's speed and position.
    pub fn step(&mut self, t: f64, v: f64, x: f64, y: f64) {
        self.pos = (x, y);
        self.final_speed = v;
        let Some(last) = self.last_v.replace(v) else {
            return;
        };
        let a = (v - last) / self.dt;
        if -a > self.max_decel {
            self.max_decel = -a;
            self.max_decel_at = t;
        }
        // Jerk over 0.1 s (whole steps): a per-step difference of a
        // pedal-driven car is dominated by the pedal switching.
        let m = ((0.1 / self.dt).round() as usize).max(1);
        self.accels.push_back(a);
        if self.accels.len() > m {
            let old = self.accels.pop_front().unwrap_or(a);
            let j = (a - old) / (m as f64 * self.dt);
            if j.abs() > self.max_jerk {
                self.max_jerk = j.abs();
                self.max_jerk_at = t;
            }
        }
    }

    /// Closes the record against the goal `(gx, gy)`.
    pub fn finish(&mut self, gx: f64, gy: f64) {
        self.distance_to_goal = math::hypot(self.pos.0 - gx, self.pos.1 - gy);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn bx(x: f64, y: f64, yaw: f64, vx: f64, vy: f64) -> BoxState {
        BoxState {
            x,
            y,
            yaw,
            length: 4.0,
            width: 2.0,
            vx,
            vy,
        }
    }

    /// Distance by brute force: every corner of each box to every edge of
    /// the other (0 when they overlap).
    fn brute(a: &BoxState, b: &BoxState) -> f64 {
        if overlap(a, b) {
            return 0.0;
        }
        let seg = |p: (f64, f64), s: (f64, f64), e: (f64, f64)| {
            let (dx, dy) = (e.0 - s.0, e.1 - s.1);
            let u = (((p.0 - s.0) * dx + (p.1 - s.1) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            ((s.0 + dx * u - p.0).powi(2) + (s.1 + dy * u - p.1).powi(2)).sqrt()
        };
        let (ca, cb) = (Shape::of(a).corners, Shape::of(b).corners);
        let mut d = f64::INFINITY;
        for (p, q) in [(&ca, &cb), (&cb, &ca)] {
            for c in p {
                for k in 0..4 {
                    d = d.min(seg(*c, q[k], q[(k + 1) % 4]));
                }
            }
        }
        d
    }

    proptest! {
        #[test]
        fn distance_matches_brute_force(
            x in -20.0f64..20.0, y in -20.0f64..20.0, ya in -3.2f64..3.2, yb in -3.2f64..3.2,
        ) {
            let (a, b) = (bx(0.0, 0.0, ya, 0.0, 0.0), bx(x, y, yb, 0.0, 0.0));
            let (d, r) = (distance(&a, &b), brute(&a, &b));
            prop_assert!((d - r).abs() < 1e-9, "{} vs {}", d, r);
            // The separating axes' gap never exceeds the distance.
            if let Some(g) = separation(&Shape::of(&a), &Shape::of(&b)) {
                prop_assert!(g <= r + 1e-9);
            }
        }
    }

    #[test]
    fn ttc_is_when_the_swept_boxes_touch() {
        // Head-on in one lane: 20 m between bumpers, closing at 10 m/s.
        let a = bx(0.0, 0.0, 0.0, 5.0, 0.0);
        let b = bx(24.0, 0.0, std::f64::consts::PI, -5.0, 0.0);
        let t = time_to_collision(&a, &b).unwrap();
        assert!((t - 2.0).abs() < 1e-9, "{t}");
        // Passing in the next lane: never.
        let c = bx(24.0, 3.5, std::f64::consts::PI, -5.0, 0.0);
        assert_eq!(time_to_collision(&a, &c), None);
        // Moving apart: never; overlapping: now.
        assert_eq!(time_to_collision(&a, &bx(24.0, 0.0, 0.0, 9.0, 0.0)), None);
        assert_eq!(
            time_to_collision(&a, &bx(1.0, 0.5, 0.3, 0.0, 0.0)),
            Some(0.0)
        );
    }

    #[test]
    fn far_pairs_are_not_tracked_and_close_ones_are() {
        let ids: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let mut k = Kpis::new(&ids);
        let boxes = [
            bx(0.0, 0.0, 0.0, 10.0, 0.0),
            bx(15.0, 0.0, 0.0, 10.0, 0.0),
            bx(500.0, 0.0, 0.0, 10.0, 0.0),
        ];
        k.step(0.0, &boxes, &[10.0; 3], &[(0.0, 0.0, 10.0); 3], &[false; 3]);
        k.finish();
        assert_eq!(k.pairs.len(), 1);
        assert_eq!((k.pairs[0].a.as_str(), k.pairs[0].b.as_str()), ("a", "b"));
        assert!((k.pairs[0].min_distance - 11.0).abs() < 1e-9);
    }
}
