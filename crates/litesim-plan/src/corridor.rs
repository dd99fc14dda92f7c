//! Path → smoothed, time-parametrised reference corridor.
//!
//! 1. Greedy line-of-sight shortcutting of the planner's path (every kept
//!    segment is checked against the grid).
//! 2. Centripetal Catmull–Rom (α = ½: no cusps or self-intersections,
//!    Yuksel et al. 2011) through the remaining vertices.
//! 3. Resampling by arc length at `ds`.
//! 4. Validation against the grid; when smoothing cuts into the inflated
//!    margin, the unsmoothed polyline is used instead (`smoothed = false`).
//! 5. Speed profile: v ≤ v_max, v ≤ √(a_lat,max / |κ|), forward pass with
//!    a_max, backward pass with d_max to stop at the goal.
//! 6. Lateral bounds: free distance to the left and right of each point.

use crate::grid::PlanningGrid;
use litesim_core::{Vec2, wrap_angle};
use serde::{Deserialize, Serialize};

/// Limits of the speed profile.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeedLimits {
    /// Top speed (m/s).
    pub v_max: f64,
    /// Lateral acceleration limit (m/s²).
    pub a_lat_max: f64,
    /// Acceleration (m/s²).
    pub a_max: f64,
    /// Deceleration (m/s², positive).
    pub d_max: f64,
    /// Speed at the start (m/s).
    pub v_start: f64,
}

/// A reference corridor.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Corridor {
    /// The planner's path.
    pub raw: Vec<Vec2>,
    /// The path after shortcutting.
    pub shortcut: Vec<Vec2>,
    /// Resampled reference points.
    pub points: Vec<Vec2>,
    /// Arc length (m).
    pub s: Vec<f64>,
    /// Heading (rad).
    pub heading: Vec<f64>,
    /// Curvature (1/m).
    pub curvature: Vec<f64>,
    /// Speed profile (m/s).
    pub speed: Vec<f64>,
    /// Time at each point along the profile (s).
    pub time: Vec<f64>,
    /// Free distance to the left (m).
    pub left_bound: Vec<f64>,
    /// Free distance to the right (m).
    pub right_bound: Vec<f64>,
    /// False when smoothing was rejected and the raw polyline is used.
    pub smoothed: bool,
}

/// A reference point at some time or arc length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefState {
    /// Position.
    pub p: Vec2,
    /// Heading (rad).
    pub heading: f64,
    /// Speed (m/s).
    pub speed: f64,
    /// Curvature (1/m).
    pub curvature: f64,
    /// Arc length (m).
    pub s: f64,
}

fn shortcut(path: &[Vec2], grid: &PlanningGrid) -> Vec<Vec2> {
    if path.len() <= 2 {
        return path.to_vec();
    }
    let mut out = vec![path[0]];
    let mut i = 0;
    while i < path.len() - 1 {
        let mut j = path.len() - 1;
        while j > i + 1 && !grid.segment_free(path[i], path[j]) {
            j -= 1;
        }
        out.push(path[j]);
        i = j;
    }
    out
}

fn catmull_rom(pts: &[Vec2], per_segment: usize) -> Vec<Vec2> {
    if pts.len() < 3 {
        return pts.to_vec();
    }
    // Mirror the ends so the curve passes through the first and last points.
    let first = pts[0] + (pts[0] - pts[1]);
    let last = pts[pts.len() - 1] + (pts[pts.len() - 1] - pts[pts.len() - 2]);
    let mut ext = vec![first];
    ext.extend_from_slice(pts);
    ext.push(last);
    let knot = |a: Vec2, b: Vec2| a.distance(b).sqrt().max(1e-9);
    let mut out = Vec::new();
    for k in 1..ext.len() - 2 {
        let (p0, p1, p2, p3) = (ext[k - 1], ext[k], ext[k + 1], ext[k + 2]);
        let t0 = 0.0;
        let t1 = t0 + knot(p0, p1);
        let t2 = t1 + knot(p1, p2);
        let t3 = t2 + knot(p2, p3);
        for m in 0..per_segment {
            let t = t1 + (t2 - t1) * m as f64 / per_segment as f64;
            let a1 = p0 * ((t1 - t) / (t1 - t0)) + p1 * ((t - t0) / (t1 - t0));
            let a2 = p1 * ((t2 - t) / (t2 - t1)) + p2 * ((t - t1) / (t2 - t1));
            let a3 = p2 * ((t3 - t) / (t3 - t2)) + p3 * ((t - t2) / (t3 - t2));
            let b1 = a1 * ((t2 - t) / (t2 - t0)) + a2 * ((t - t0) / (t2 - t0));
            let b2 = a2 * ((t3 - t) / (t3 - t1)) + a3 * ((t - t1) / (t3 - t1));
            out.push(b1 * ((t2 - t) / (t2 - t1)) + b2 * ((t - t1) / (t2 - t1)));
        }
    }
    out.push(*pts.last().unwrap_or(&Vec2::default()));
    out
}

fn resample(dense: &[Vec2], ds: f64) -> Vec<Vec2> {
    let mut cum = vec![0.0];
    for w in dense.windows(2) {
        cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
    }
    let total = *cum.last().unwrap_or(&0.0);
    if total <= 0.0 {
        return dense.to_vec();
    }
    let n = (total / ds).ceil().max(1.0) as usize;
    let mut out = Vec::with_capacity(n + 1);
    let mut j = 0;
    for k in 0..=n {
        let s = total * k as f64 / n as f64;
        while j + 1 < cum.len() - 1 && cum[j + 1] < s {
            j += 1;
        }
        let seg = cum[j + 1] - cum[j];
        let u = if seg > 0.0 {
            ((s - cum[j]) / seg).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(dense[j].lerp(dense[j + 1], u));
    }
    out
}

fn free_distance(grid: &PlanningGrid, p: Vec2, dir: Vec2) -> f64 {
    let step = 0.5 * grid.grid.resolution;
    let mut d = 0.0;
    while d < 20.0 && grid.is_free(p + dir * (d + step)) {
        d += step;
    }
    d
}

impl Corridor {
    /// Builds a corridor from a planner path (at least 2 points).
    pub fn build(raw: &[Vec2], grid: &PlanningGrid, ds: f64, limits: &SpeedLimits) -> Self {
        let ds = if ds.is_finite() && ds > 0.0 { ds } else { 0.5 };
        let short = shortcut(raw, grid);
        let smooth = resample(&catmull_rom(&short, 20), ds);
        let (points, smoothed) = if smooth.iter().all(|p| grid.is_free(*p)) {
            (smooth, true)
        } else {
            // Smoothing cut a corner: densify the checked polyline instead.
            let mut dense = Vec::new();
            for w in short.windows(2) {
                let n = (w[0].distance(w[1]) / (ds / 4.0)).ceil().max(1.0) as usize;
                dense.extend((0..n).map(|k| w[0].lerp(w[1], k as f64 / n as f64)));
            }
            dense.extend(short.last().copied());
            (resample(&dense, ds), false)
        };
        let n = points.len();
        let mut s = vec![0.0; n];
        for i in 1..n {
            s[i] = s[i - 1] + points[i - 1].distance(points[i]);
        }
        let heading: Vec<f64> = (0..n)
            .map(|i| {
                let (a, b) = (points[i.saturating_sub(1)], points[(i + 1).min(n - 1)]);
                (b - a).heading()
            })
            .collect();
        let curvature: Vec<f64> = (0..n)
            .map(|i| {
                if i == 0 || i + 1 >= n {
                    return 0.0;
                }
                let (a, b) = (points[i] - points[i - 1], points[i + 1] - points[i]);
                let c = (points[i + 1] - points[i - 1]).norm();
                let den = a.norm() * b.norm() * c;
                if den > 1e-12 {
                    2.0 * a.cross(b) / den
                } else {
                    0.0
                }
            })
            .collect();
        let mut speed: Vec<f64> = curvature
            .iter()
            .map(|k| {
                let lat = if k.abs() > 1e-9 {
                    (limits.a_lat_max / k.abs()).sqrt()
                } else {
                    f64::INFINITY
                };
                lat.min(limits.v_max)
            })
            .collect();
        if n > 0 {
            speed[0] = speed[0].min(limits.v_start.max(0.0));
            speed[n - 1] = 0.0;
        }
        for i in 1..n {
            let d = s[i] - s[i - 1];
            speed[i] = speed[i].min((speed[i - 1].powi(2) + 2.0 * limits.a_max * d).sqrt());
        }
        for i in (0..n.saturating_sub(1)).rev() {
            let d = s[i + 1] - s[i];
            speed[i] = speed[i].min((speed[i + 1].powi(2) + 2.0 * limits.d_max * d).sqrt());
        }
        let mut time = vec![0.0; n];
        for i in 1..n {
            let v = 0.5 * (speed[i] + speed[i - 1]);
            time[i] = time[i - 1] + if v > 1e-6 { (s[i] - s[i - 1]) / v } else { 0.0 };
        }
        let (left_bound, right_bound) = (0..n)
            .map(|i| {
                let nrm = Vec2::from_heading(heading[i] + std::f64::consts::FRAC_PI_2);
                (
                    free_distance(grid, points[i], nrm),
                    free_distance(grid, points[i], -nrm),
                )
            })
            .unzip();
        Self {
            raw: raw.to_vec(),
            shortcut: short,
            points,
            s,
            heading,
            curvature,
            speed,
            time,
            left_bound,
            right_bound,
            smoothed,
        }
    }

    /// Total length (m).
    pub fn length(&self) -> f64 {
        self.s.last().copied().unwrap_or(0.0)
    }

    /// Duration of the speed profile (s).
    pub fn duration(&self) -> f64 {
        self.time.last().copied().unwrap_or(0.0)
    }

    fn interp(&self, i: usize, u: f64) -> RefState {
        let j = (i + 1).min(self.points.len() - 1);
        RefState {
            p: self.points[i].lerp(self.points[j], u),
            heading: self.heading[i] + wrap_angle(self.heading[j] - self.heading[i]) * u,
            speed: self.speed[i] + (self.speed[j] - self.speed[i]) * u,
            curvature: self.curvature[i] + (self.curvature[j] - self.curvature[i]) * u,
            s: self.s[i] + (self.s[j] - self.s[i]) * u,
        }
    }

    /// The reference at time `t` along the speed profile (clamped).
    pub fn at_time(&self, t: f64) -> RefState {
        let i = self
            .time
            .partition_point(|x| *x <= t)
            .clamp(1, self.time.len().max(2) - 1)
            - 1;
        let j = (i + 1).min(self.time.len() - 1);
        let dt = self.time[j] - self.time[i];
        let u = if dt > 0.0 {
            ((t - self.time[i]) / dt).clamp(0.0, 1.0)
        } else {
            1.0
        };
        self.interp(i, u)
    }

    /// Projects a point: (arc length, signed lateral error, index of the segment).
    pub fn project(&self, p: Vec2, hint: usize) -> (f64, f64, usize) {
        let n = self.points.len();
        if n < 2 {
            return (0.0, 0.0, 0);
        }
        // Search a window around the previous projection; the vehicle moves
        // little per step, and a global search could jump between branches.
        let lo = hint.saturating_sub(20);
        let hi = (hint + 200).min(n - 1);
        let mut best = (f64::INFINITY, 0.0, 0.0, lo);
        for i in lo..hi {
            let (a, b) = (self.points[i], self.points[i + 1]);
            let d = b - a;
            let l2 = d.dot(d);
            let u = if l2 > 0.0 {
                ((p - a).dot(d) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let e = p - (a + d * u);
            let dist = e.dot(e);
            if dist < best.0 {
                let lat = if l2 > 0.0 {
                    d.cross(p - a) / l2.sqrt()
                } else {
                    0.0
                };
                best = (dist, self.s[i] + u * (self.s[i + 1] - self.s[i]), lat, i);
            }
        }
        (best.1, best.2, best.3)
    }

    /// The segment `[i, j]` around arc length `s` and the fraction `u` along it.
    fn locate_s(&self, s: f64) -> (usize, usize, f64) {
        let i = self
            .s
            .partition_point(|x| *x <= s)
            .clamp(1, self.s.len().max(2) - 1)
            - 1;
        let j = (i + 1).min(self.s.len() - 1);
        let ds = self.s[j] - self.s[i];
        let u = if ds > 0.0 {
            ((s - self.s[i]) / ds).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (i, j, u)
    }

    /// Time along the profile at arc length `s`.
    pub fn time_at_s(&self, s: f64) -> f64 {
        let (i, j, u) = self.locate_s(s);
        self.time[i] + (self.time[j] - self.time[i]) * u
    }

    /// Heading at arc length `s`.
    pub fn heading_at_s(&self, s: f64) -> f64 {
        let (i, j, u) = self.locate_s(s);
        self.heading[i] + wrap_angle(self.heading[j] - self.heading[i]) * u
    }

    /// Smallest clearance along the corridor (m), from the grid.
    pub fn min_clearance(&self, grid: &PlanningGrid) -> f64 {
        self.points
            .iter()
            .map(|p| grid.clearance(*p))
            .fold(f64::INFINITY, f64::min)
    }
}
