//! The ego's route: its planned path with the speed the scenario asks for.

use litesim_core::{Vec2, math};
use serde::{Deserialize, Serialize};

/// A route: points with arc length and requested speed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Route {
    /// Points (x, y) in the map frame (m).
    pub points: Vec<[f64; 2]>,
    /// Arc length at each point (m).
    pub s: Vec<f64>,
    /// Requested speed at each point (m/s).
    pub speed: Vec<f64>,
}

/// A point projected onto a route.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoutePoint {
    /// Arc length (m).
    pub s: f64,
    /// Signed lateral offset of the point from the route (m, left positive).
    pub lateral: f64,
    /// Heading of the route there (rad).
    pub heading: f64,
    /// Segment index (a hint for the next projection).
    pub segment: usize,
}

impl Route {
    /// A route through `points` (consecutive duplicates dropped) with their speeds.
    pub fn new(points: &[[f64; 2]], speed: &[f64]) -> Self {
        let mut r = Route::default();
        for (k, p) in points.iter().enumerate() {
            let v = speed.get(k).copied().unwrap_or(0.0);
            match r.points.last() {
                Some(q) => {
                    let d = math::hypot(p[0] - q[0], p[1] - q[1]);
                    if d < 1e-3 {
                        // Same place: keep the larger requested speed (a stop
                        // followed by a start stays a stop only if both ask it).
                        let last = r.speed.len() - 1;
                        r.speed[last] = r.speed[last].max(v);
                        continue;
                    }
                    let s = r.s[r.s.len() - 1] + d;
                    r.s.push(s);
                }
                None => r.s.push(0.0),
            }
            r.points.push(*p);
            r.speed.push(v);
        }
        r
    }

    /// Total length (m).
    pub fn length(&self) -> f64 {
        self.s.last().copied().unwrap_or(0.0)
    }

    /// The goal: the route's last point.
    pub fn goal(&self) -> Option<[f64; 2]> {
        self.points.last().copied()
    }

    /// Projects `(x, y)`, searching segments near `hint` first (a vehicle
    /// moves a few segments per step at most), else the whole route.
    pub fn project(&self, x: f64, y: f64, hint: usize) -> Option<RoutePoint> {
        let n = self.points.len();
        if n < 2 {
            return None;
        }
        // (distance², u) of the foot on segment i; its arc length, lateral
        // offset (a square root) and heading (an atan2) are computed for
        // the winner only.
        let seg = |i: usize| -> (f64, f64) {
            let (a, b) = (self.points[i], self.points[i + 1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let u = litesim_core::segment_fraction(
                Vec2::new(x, y),
                Vec2::new(a[0], a[1]),
                Vec2::new(dx, dy),
            );
            let (fx, fy) = (a[0] + dx * u, a[1] + dy * u);
            ((x - fx) * (x - fx) + (y - fy) * (y - fy), u)
        };
        let best_in = |lo: usize, hi: usize| {
            let mut best: Option<(usize, (f64, f64))> = None;
            for i in lo..hi {
                let c = seg(i);
                if best.is_none_or(|b| c.0 < b.1.0) {
                    best = Some((i, c));
                }
            }
            best
        };
        let point = |(i, (_, u)): (usize, (f64, f64))| {
            let (a, b) = (self.points[i], self.points[i + 1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len = (dx * dx + dy * dy).sqrt();
            let lateral = if len > 0.0 {
                (dx * (y - a[1]) - dy * (x - a[0])) / len
            } else {
                0.0
            };
            RoutePoint {
                s: self.s[i] + u * (self.s[i + 1] - self.s[i]),
                lateral,
                heading: math::atan2(dy, dx),
                segment: i,
            }
        };
        let lo = hint.saturating_sub(3).min(n - 2);
        let hi = (hint + 12).min(n - 1);
        let near = best_in(lo, hi)?;
        // Accept the local answer when it lies inside the window (not at its
        // edge): a minimum of the distance there is the foot near the hint.
        // Otherwise (the hint is stale) search everywhere.
        if (near.0 > lo || lo == 0) && (near.0 + 1 < hi || hi == n - 1) {
            return Some(point(near));
        }
        best_in(0, n - 1).map(point)
    }

    /// Position and heading at arc length `s` (clamped to the route).
    pub fn at(&self, s: f64) -> ([f64; 2], f64) {
        let n = self.points.len();
        if n == 0 {
            return ([0.0, 0.0], 0.0);
        }
        if n == 1 {
            return (self.points[0], 0.0);
        }
        let i = match self.s.binary_search_by(|v| v.total_cmp(&s)) {
            Ok(i) => i.min(n - 2),
            Err(i) => i.saturating_sub(1).min(n - 2),
        };
        let (a, b) = (self.points[i], self.points[i + 1]);
        let len = self.s[i + 1] - self.s[i];
        let u = if len > 0.0 {
            ((s - self.s[i]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (
            [a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u],
            math::atan2(b[1] - a[1], b[0] - a[0]),
        )
    }

    /// Requested speed at arc length `s`.
    pub fn speed_at(&self, s: f64) -> f64 {
        let n = self.points.len();
        if n == 0 {
            return 0.0;
        }
        let i = match self.s.binary_search_by(|v| v.total_cmp(&s)) {
            Ok(i) => i,
            Err(i) => i.saturating_sub(1),
        };
        self.speed[i.min(n - 1)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_finds_side_and_arc_length() {
        let r = Route::new(&[[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]], &[5.0, 5.0, 0.0]);
        let p = r.project(12.0, 1.5, 0).unwrap();
        assert!((p.s - 12.0).abs() < 1e-12);
        assert!((p.lateral - 1.5).abs() < 1e-12);
        let q = r.project(3.0, -2.0, 1).unwrap();
        assert!((q.s - 3.0).abs() < 1e-12 && (q.lateral + 2.0).abs() < 1e-12);
        assert_eq!(r.length(), 20.0);
        let (p, h) = r.at(15.0);
        assert_eq!((p, h), ([15.0, 0.0], 0.0));
    }
}
