//! Box geometry: an actor's box as corners and axes (`Shape`), overlap
//! (separating axes), box-to-box distance and time to collision under
//! constant velocities (swept boxes).

use super::*;

/// A box's corners and the trig of its heading, computed once per box and
/// step and shared by every pair test it takes part in.
#[derive(Clone, Copy, Debug)]
pub(super) struct Shape {
    pub(super) corners: [(f64, f64); 4],
    /// Centre.
    pub(super) centre: (f64, f64),
    /// Half length and half width.
    pub(super) half: (f64, f64),
    /// Centre to corner (m).
    pub(super) radius: f64,
    /// `sin_cos(yaw)`.
    pub(super) sc: (f64, f64),
    /// `sin_cos(yaw + π/2)`.
    pub(super) sc90: (f64, f64),
}

impl Shape {
    pub(super) fn of(b: &BodyState) -> Self {
        Self::with(b, math::sin_cos(b.yaw))
    }

    /// The shape of `b` whose heading's `sin_cos` is `sc`.
    pub(super) fn with(b: &BodyState, sc: (f64, f64)) -> Self {
        let (hl, hw) = (b.length / 2.0, b.width / 2.0);
        Shape {
            corners: corners(b, sc),
            centre: (b.x, b.y),
            half: (hl, hw),
            radius: math::hypot(hl, hw),
            sc,
            sc90: math::sin_cos(b.yaw + std::f64::consts::FRAC_PI_2),
        }
    }
}

impl BodyState {
    /// The rectangle of the box ([`litesim_core::OrientedBox`]).
    pub(super) fn rect(&self) -> litesim_core::OrientedBox {
        litesim_core::OrientedBox {
            x: self.x,
            y: self.y,
            yaw: self.yaw,
            length: self.length,
            width: self.width,
        }
    }
}

/// A box's corners, given `sin_cos` of its heading.
pub(super) fn corners(b: &BodyState, sc: (f64, f64)) -> [(f64, f64); 4] {
    b.rect().corners_with(sc).map(|p| (p.x, p.y))
}

/// The interval a box's corners cover along the axis (ux, uy).
pub(super) fn interval(c: &[(f64, f64); 4], ux: f64, uy: f64) -> (f64, f64) {
    c.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let d = p.0 * ux + p.1 * uy;
            (lo.min(d), hi.max(d))
        })
}

/// Whether two oriented boxes overlap (separating axis theorem).
pub fn overlap(a: &BodyState, b: &BodyState) -> bool {
    overlap_shapes(&Shape::of(a), &Shape::of(b))
}

/// The separating-axis test (the axes are the two boxes' edge directions).
pub(super) fn overlap_shapes(a: &Shape, b: &Shape) -> bool {
    separation(a, b).is_none()
}

/// The widest gap between the boxes' intervals over the separating axes:
/// `None` when they overlap on every axis (the boxes overlap), else a lower
/// bound of their distance (a projection onto a unit axis never lengthens).
pub(super) fn separation(a: &Shape, b: &Shape) -> Option<f64> {
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
pub(super) fn point_box_sq(p: (f64, f64), b: &Shape) -> f64 {
    let (s, c) = b.sc;
    let (dx, dy) = (p.0 - b.centre.0, p.1 - b.centre.1);
    let ex = ((dx * c + dy * s).abs() - b.half.0).max(0.0);
    let ey = ((-dx * s + dy * c).abs() - b.half.1).max(0.0);
    ex * ex + ey * ey
}

/// Distance between two boxes (0 when they overlap).
pub fn distance(a: &BodyState, b: &BodyState) -> f64 {
    distance_shapes(&Shape::of(a), &Shape::of(b))
}

pub(super) fn distance_shapes(a: &Shape, b: &Shape) -> f64 {
    if overlap_shapes(a, b) {
        return 0.0;
    }
    corner_distance(a, b)
}

/// The distance of two boxes that do not overlap: for two separate convex
/// polygons it is reached at a corner of one, so it is the smallest
/// distance of a corner of either to the other (filled) box.
pub(super) fn corner_distance(a: &Shape, b: &Shape) -> f64 {
    let mut d2 = f64::INFINITY;
    for c in &a.corners {
        d2 = d2.min(point_box_sq(*c, b));
    }
    for c in &b.corners {
        d2 = d2.min(point_box_sq(*c, a));
    }
    d2.sqrt()
}

/// Time until two boxes touch if both keep their velocities: the swept
/// separating-axis test (for translating convex polygons the edge normals
/// of both are the only candidate axes). `None` when they never touch,
/// `Some(0)` when they overlap now.
pub fn time_to_collision(a: &BodyState, b: &BodyState) -> Option<f64> {
    ttc_shapes(&Shape::of(a), &Shape::of(b), b.vx - a.vx, b.vy - a.vy)
}

/// [`time_to_collision`] of b moving at (wx, wy) relative to a.
pub(super) fn ttc_shapes(a: &Shape, b: &Shape, wx: f64, wy: f64) -> Option<f64> {
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
