//! Planar and spatial geometry: vectors, 6-DoF poses, angle wrapping and
//! polylines with arc-length projection.
//!
//! Frame: right-handed, x east, y north, z up, yaw counter-clockwise from +x
//! (the OpenDRIVE inertial frame). Units: metres and radians.

use crate::math;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A 2-D vector or point (m).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vec2 {
    /// East (m).
    pub x: f64,
    /// North (m).
    pub y: f64,
}

impl Vec2 {
    /// A new vector.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }
    /// Unit vector at heading `yaw` (rad).
    pub fn from_heading(yaw: f64) -> Self {
        let (s, c) = math::sin_cos(yaw);
        Self { x: c, y: s }
    }
    /// Dot product.
    pub fn dot(self, o: Self) -> f64 {
        self.x * o.x + self.y * o.y
    }
    /// z component of the cross product (positive when `o` is left of `self`).
    pub fn cross(self, o: Self) -> f64 {
        self.x * o.y - self.y * o.x
    }
    /// Euclidean length.
    pub fn norm(self) -> f64 {
        math::hypot(self.x, self.y)
    }
    /// Distance to another point.
    pub fn distance(self, o: Self) -> f64 {
        (self - o).norm()
    }
    /// Heading of this vector (rad, `atan2(y, x)`).
    pub fn heading(self) -> f64 {
        math::atan2(self.y, self.x)
    }
    /// Linear interpolation `self + (o − self)·u`.
    pub fn lerp(self, o: Self, u: f64) -> Self {
        self + (o - self) * u
    }
    /// Rotates counter-clockwise by `angle` (rad).
    pub fn rotate(self, angle: f64) -> Self {
        let (s, c) = math::sin_cos(angle);
        Self::new(c * self.x - s * self.y, s * self.x + c * self.y)
    }
    /// True when both components are finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

impl std::ops::Add for Vec2 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y)
    }
}
impl std::ops::Sub for Vec2 {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y)
    }
}
impl std::ops::Mul<f64> for Vec2 {
    type Output = Self;
    fn mul(self, k: f64) -> Self {
        Self::new(self.x * k, self.y * k)
    }
}
impl std::ops::Neg for Vec2 {
    type Output = Self;
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y)
    }
}

/// A 3-D vector (m, m/s or m/s² depending on use).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vec3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

impl Vec3 {
    /// A new vector.
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }
    /// The planar part.
    pub fn xy(self) -> Vec2 {
        Vec2::new(self.x, self.y)
    }
    /// Euclidean length.
    pub fn norm(self) -> f64 {
        (self.x * self.x + self.y * self.y + self.z * self.z).sqrt()
    }
    /// True when all components are finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
}

/// A 6-DoF pose: position (m) and roll, pitch, yaw (rad, right-hand rule).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Vec3,
    /// Rotation about x (rad).
    pub roll: f64,
    /// Rotation about y (rad); uphill is negative (OpenDRIVE convention).
    pub pitch: f64,
    /// Rotation about z (rad), counter-clockwise from +x.
    pub yaw: f64,
}

impl Pose {
    /// A planar pose at `(x, y)` with heading `yaw`.
    pub fn planar(x: f64, y: f64, yaw: f64) -> Self {
        Self {
            position: Vec3::new(x, y, 0.0),
            roll: 0.0,
            pitch: 0.0,
            yaw,
        }
    }
    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.position.is_finite()
            && self.roll.is_finite()
            && self.pitch.is_finite()
            && self.yaw.is_finite()
    }
}

/// How far `p` lies ahead of `from` along heading `yaw` (negative behind):
/// the one "gap along a heading", which the planner's gap goals and their
/// re-solving against the actual actors both measure with.
#[inline]
pub fn ahead_along(from: Vec2, yaw: f64, p: Vec2) -> f64 {
    (p - from).dot(Vec2::from_heading(yaw))
}

/// Where on the segment from `a` along `d` (to `a + d`) the point nearest
/// `p` lies, as the fraction u ∈ [0, 1] of `d` (0 for a segment of no
/// length). The one place the projection onto a segment is written: the
/// polylines, the corridors, the road network's locate and the SUT's route
/// all use it.
#[inline]
pub fn segment_fraction(p: Vec2, a: Vec2, d: Vec2) -> f64 {
    let len2 = d.dot(d);
    if len2 > 0.0 {
        ((p - a).dot(d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// A rectangle in the plane: its centre, heading, length along the
/// heading and width across it. The one place a box's corners and a
/// point's distance to a box are computed (the KPIs, the SUTs' obstacle
/// checks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientedBox {
    /// Centre x (m).
    pub x: f64,
    /// Centre y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
    /// Length along the heading (m).
    pub length: f64,
    /// Width across it (m).
    pub width: f64,
}

impl OrientedBox {
    /// The corners, front-left, rear-left, rear-right, front-right, given
    /// `sin_cos` of the heading (callers that keep it computed pass it).
    pub fn corners_with(&self, (s, c): (f64, f64)) -> [Vec2; 4] {
        let (hl, hw) = (self.length / 2.0, self.width / 2.0);
        let p = |u: f64, v: f64| Vec2::new(self.x + u * c - v * s, self.y + u * s + v * c);
        [p(hl, hw), p(-hl, hw), p(-hl, -hw), p(hl, -hw)]
    }

    /// The corners ([`OrientedBox::corners_with`]).
    pub fn corners(&self) -> [Vec2; 4] {
        self.corners_with(crate::math::sin_cos(self.yaw))
    }

    /// How far `p` lies beyond the box along its heading and across it (0
    /// within the box's extent that way).
    pub fn outside(&self, p: Vec2) -> (f64, f64) {
        let (s, c) = crate::math::sin_cos(self.yaw);
        let (dx, dy) = (p.x - self.x, p.y - self.y);
        let along = ((dx * c + dy * s).abs() - 0.5 * self.length).max(0.0);
        let across = ((-dx * s + dy * c).abs() - 0.5 * self.width).max(0.0);
        (along, across)
    }

    /// Distance from `p` to the box (0 inside).
    pub fn distance(&self, p: Vec2) -> f64 {
        let (along, across) = self.outside(p);
        crate::math::hypot(along, across)
    }
}

/// Wraps an angle into `(−π, π]`.
///
/// Headings change by a little per step, so the common cases (already in
/// range, or one turn off) are handled with one comparison and one addition;
/// only far-off values pay for a remainder. Non-finite input is returned
/// unchanged (callers validate).
#[inline]
pub fn wrap_angle(a: f64) -> f64 {
    const TWO_PI: f64 = 2.0 * PI;
    if a > -PI && a <= PI {
        return a;
    }
    if !a.is_finite() {
        return a;
    }
    let mut r = if a > -3.0 * PI && a <= 3.0 * PI {
        a
    } else {
        a % TWO_PI
    };
    if r > PI {
        r -= TWO_PI;
    } else if r <= -PI {
        r += TWO_PI;
    }
    r
}

/// The projection of a point onto a [`Polyline`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// Arc length of the foot point from the polyline's start (m).
    pub s: f64,
    /// Signed lateral offset, positive to the left of the direction of travel (m).
    pub t: f64,
    /// The foot point.
    pub point: Vec2,
    /// Index of the segment the foot point lies on.
    pub segment: usize,
    /// Heading of that segment (rad).
    pub heading: f64,
}

/// A polyline with cumulative arc lengths, for `s ↔ (x, y)` conversions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Polyline {
    points: Vec<Vec2>,
    cumulative: Vec<f64>,
}

/// Why a [`Polyline`] could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PolylineError {
    /// Fewer than two points.
    #[error("a polyline needs at least 2 points, got {0}")]
    TooFewPoints(usize),
    /// A point with NaN or infinite coordinates.
    #[error("point {0} is not finite")]
    NotFinite(usize),
}

impl Polyline {
    /// Builds a polyline; consecutive duplicate points are dropped so every
    /// segment has a positive length (a zero-length segment has no heading).
    pub fn new(points: impl IntoIterator<Item = Vec2>) -> Result<Self, PolylineError> {
        let mut pts: Vec<Vec2> = Vec::new();
        for (i, p) in points.into_iter().enumerate() {
            if !p.is_finite() {
                return Err(PolylineError::NotFinite(i));
            }
            if pts.last().is_none_or(|q| q.distance(p) > 0.0) {
                pts.push(p);
            }
        }
        if pts.len() < 2 {
            return Err(PolylineError::TooFewPoints(pts.len()));
        }
        let mut cumulative = Vec::with_capacity(pts.len());
        let mut s = 0.0;
        cumulative.push(0.0);
        for w in pts.windows(2) {
            s += w[0].distance(w[1]);
            cumulative.push(s);
        }
        Ok(Self {
            points: pts,
            cumulative,
        })
    }
    /// The vertices.
    pub fn points(&self) -> &[Vec2] {
        &self.points
    }
    /// Total arc length (m).
    pub fn length(&self) -> f64 {
        *self.cumulative.last().unwrap_or(&0.0)
    }
    /// The point and heading at arc length `s`, clamped to `[0, length]`.
    pub fn at(&self, s: f64) -> (Vec2, f64) {
        let s = s.clamp(0.0, self.length());
        let i = match self.cumulative.partition_point(|&c| c <= s) {
            0 => 0,
            k => (k - 1).min(self.points.len() - 2),
        };
        let (a, b) = (self.points[i], self.points[i + 1]);
        let seg = self.cumulative[i + 1] - self.cumulative[i];
        let u = ((s - self.cumulative[i]) / seg).clamp(0.0, 1.0);
        (a.lerp(b, u), (b - a).heading())
    }
    /// Projects `p` onto the polyline (nearest point; ties go to the earlier segment).
    pub fn project(&self, p: Vec2) -> Projection {
        let mut best: Option<(f64, Projection)> = None;
        for (i, w) in self.points.windows(2).enumerate() {
            let (a, b) = (w[0], w[1]);
            let d = b - a;
            let len2 = d.dot(d);
            let u = segment_fraction(p, a, d);
            let foot = a + d * u;
            let dist2 = {
                let e = p - foot;
                e.dot(e)
            };
            if best.as_ref().is_none_or(|(bd, _)| dist2 < *bd) {
                let len = len2.sqrt();
                let t = d.cross(p - a) / len;
                best = Some((
                    dist2,
                    Projection {
                        s: self.cumulative[i] + u * len,
                        t,
                        point: foot,
                        segment: i,
                        heading: d.heading(),
                    },
                ));
            }
        }
        // `new` guarantees at least one segment.
        best.map(|(_, pr)| pr).unwrap_or(Projection {
            s: 0.0,
            t: 0.0,
            point: self.points[0],
            segment: 0,
            heading: 0.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_oriented_box_has_its_corners_and_distances() {
        let b = OrientedBox {
            x: 1.0,
            y: 2.0,
            yaw: std::f64::consts::FRAC_PI_2,
            length: 4.0,
            width: 2.0,
        };
        // Heading +y: front-left is ahead (+y) and to the left (−x).
        let c = b.corners();
        let want = [(0.0, 4.0), (0.0, 0.0), (2.0, 0.0), (2.0, 4.0)];
        for (p, w) in c.iter().zip(want) {
            assert!(
                (p.x - w.0).abs() < 1e-12 && (p.y - w.1).abs() < 1e-12,
                "{p:?}"
            );
        }
        assert_eq!(b.distance(Vec2::new(1.5, 3.0)), 0.0);
        assert!((b.distance(Vec2::new(1.0, 7.0)) - 3.0).abs() < 1e-12);
        assert!((b.distance(Vec2::new(5.0, 2.0)) - 3.0).abs() < 1e-12);
        assert!((b.distance(Vec2::new(5.0, 7.0)) - 18f64.sqrt()).abs() < 1e-12);
        assert_eq!(b.outside(Vec2::new(1.0, 7.0)).1, 0.0);
    }

    #[test]
    fn wrap_angle_range() {
        for k in -20..=20 {
            let a = k as f64 * 0.7;
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "{a} -> {w}");
            assert!((math::sin(w) - math::sin(a)).abs() < 1e-9);
        }
        assert_eq!(wrap_angle(PI), PI);
        assert_eq!(wrap_angle(-PI), PI);
        assert!(wrap_angle(1e300).abs() <= PI);
    }

    #[test]
    fn polyline_projection_and_at() {
        let pl = Polyline::new([
            Vec2::new(0.0, 0.0),
            Vec2::new(10.0, 0.0),
            Vec2::new(10.0, 10.0),
        ])
        .unwrap();
        assert_eq!(pl.length(), 20.0);
        let pr = pl.project(Vec2::new(5.0, 2.0));
        assert_eq!((pr.s, pr.t, pr.segment), (5.0, 2.0, 0));
        let pr = pl.project(Vec2::new(12.0, 5.0));
        assert_eq!((pr.s, pr.t), (15.0, -2.0));
        let (p, h) = pl.at(15.0);
        assert_eq!(p, Vec2::new(10.0, 5.0));
        assert!((h - PI / 2.0).abs() < 1e-15);
        assert_eq!(pl.at(-3.0).0, Vec2::new(0.0, 0.0));
        assert_eq!(pl.at(99.0).0, Vec2::new(10.0, 10.0));
    }

    #[test]
    fn polyline_rejects_bad_input() {
        assert_eq!(
            Polyline::new([Vec2::new(1.0, 1.0)]),
            Err(PolylineError::TooFewPoints(1))
        );
        assert_eq!(
            Polyline::new([Vec2::new(1.0, 1.0), Vec2::new(1.0, 1.0)]),
            Err(PolylineError::TooFewPoints(1))
        );
        assert_eq!(
            Polyline::new([Vec2::new(0.0, 0.0), Vec2::new(f64::NAN, 1.0)]),
            Err(PolylineError::NotFinite(1))
        );
    }
}
