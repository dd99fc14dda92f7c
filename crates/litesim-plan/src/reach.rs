//! The shortest path to a point for a vehicle that turns no tighter than a
//! radius (Dubins's car with a free final heading), and the lower bounds
//! the curvature-bounded search draws from it.
//!
//! The search's obstacle-aware heuristic (Dijkstra over the grid for the
//! reference point) knows walls but not headings: a pose a metre from the
//! goal and facing away looks as close as one facing it, and a long vehicle
//! floods every heading near a goal it cannot turn into. These bounds know
//! headings but not walls; the search takes the larger of the two.
//!
//! Facts used (Bui, Souères, Boissonnat and Laumond, "Shortest path
//! synthesis for Dubins non-holonomic robot", ICRA 1994): with a free final
//! heading, the shortest forward path to a point is an arc then a straight
//! line (the point outside the turning circle on its side), or two arcs
//! turning opposite ways (the point inside it). Driving backwards to a point
//! is driving forwards to its mirror image through the rear axle's normal.

use litesim_core::math;
use std::f64::consts::TAU;

/// Length of the shortest forward path with turns of radius at least `r`
/// from the origin heading +x to `(x, y)` (any final heading).
pub fn forward_to_point(x: f64, y: f64, r: f64) -> f64 {
    // Mirror so that the point is on the left (the problem is symmetric).
    let y = y.abs();
    // Centre of the left turning circle: (0, r).
    let dl = (x * x + (y - r) * (y - r)).sqrt();
    if dl >= r {
        return arc_then_straight(x, y, r);
    }
    // Inside the left circle: right then left, or right then straight
    // (round the other way).
    arc_then_straight(x, -y, r).min(right_then_left(x, y, r))
}

/// Length of the shortest backward path: forwards to the mirrored point.
pub fn backward_to_point(x: f64, y: f64, r: f64) -> f64 {
    forward_to_point(-x, y, r)
}

/// A left arc from the origin heading +x, then straight to `(x, y)`; the
/// point must not be inside the left circle (for y < 0 this is the long
/// way round, which the caller wants when comparing).
fn arc_then_straight(x: f64, y: f64, r: f64) -> f64 {
    // Centre (0, r); the arc starts at angle −π/2 around it.
    let (vx, vy) = (x, y - r);
    let d2 = vx * vx + vy * vy;
    let straight = (d2 - r * r).max(0.0).sqrt();
    // Radial angle of the tangent point (counter-clockwise travel).
    let beta = math::atan2(vy, vx) - math::atan2(straight, r);
    let mut phi = (beta + std::f64::consts::FRAC_PI_2).rem_euclid(TAU);
    if phi > TAU - 1e-9 {
        phi = 0.0;
    }
    r * phi + straight
}

/// A right arc from the origin heading +x, then a left arc ending on
/// `(x, y)`, for a point inside the left circle; +∞ where no such pair
/// reaches it.
fn right_then_left(x: f64, y: f64, r: f64) -> f64 {
    // After turning right by α around (0, −r), the left circle's centre is
    // (0, −r) + 2r (sin α, cos α); the point lies on that circle when
    // u · (sin α, cos α) = (|u|² + 3r²) / 4r, u = point − (0, −r).
    let (ux, uy) = (x, y + r);
    let d = (ux * ux + uy * uy).sqrt();
    let c = (d * d + 3.0 * r * r) / (4.0 * r * d);
    if !(c.is_finite() && c <= 1.0) {
        return f64::INFINITY;
    }
    // u = d (sin ψ, cos ψ).
    let psi = math::atan2(ux, uy);
    let spread = math::acos(c);
    let mut best = f64::INFINITY;
    for alpha in [psi - spread, psi + spread] {
        let alpha = alpha.rem_euclid(TAU);
        let (s, co) = math::sin_cos(alpha);
        let centre = (2.0 * r * s, -r + 2.0 * r * co);
        // Where the left arc starts (angle of the junction seen from the
        // centre) and where it ends (the point), counter-clockwise.
        let from = math::atan2(-co, -s);
        let to = math::atan2(y - centre.1, x - centre.0);
        let beta = (to - from).rem_euclid(TAU);
        best = best.min(r * (alpha + beta));
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hybrid::arc;
    use litesim_core::Vec2;
    use proptest::prelude::*;

    #[test]
    fn closed_forms() {
        let r = 5.0;
        // Straight ahead.
        assert!((forward_to_point(10.0, 0.0, r) - 10.0).abs() < 1e-9);
        // A quarter circle to (r, r), either side.
        let q = std::f64::consts::FRAC_PI_2 * r;
        assert!((forward_to_point(r, r, r) - q).abs() < 1e-9);
        assert!((forward_to_point(r, -r, r) - q).abs() < 1e-9);
        // Straight behind, backwards.
        assert!((backward_to_point(-3.0, 0.0, r) - 3.0).abs() < 1e-9);
        // A point just beside the vehicle, inside the turning circle, is
        // far along any forward path (more than half a turn).
        assert!(forward_to_point(0.0, 1.0, r) > std::f64::consts::PI * r);
    }

    /// Each bound is reached: the path it measures ends on the point.
    #[test]
    fn the_bound_is_attained_where_it_is_an_arc_and_a_line() {
        let r = 4.0;
        for &(x, y) in &[(10.0, 3.0), (-6.0, 2.0), (1.0, 9.0), (-2.0, -9.0)] {
            let len = forward_to_point(x, y, r);
            // Search the left (or right) arc length whose tangent hits it.
            let side: f64 = if y >= 0.0 { 1.0 } else { -1.0 };
            let mut hit = false;
            for i in 0..=20_000 {
                let a = i as f64 * TAU * r / 20_000.0;
                let (p, h) = arc(Vec2::new(0.0, 0.0), 0.0, side / r, a);
                let rest = len - a;
                if rest < 0.0 {
                    break;
                }
                let end = p + Vec2::from_heading(h) * rest;
                if end.distance(Vec2::new(x, y)) < 2e-3 {
                    hit = true;
                    break;
                }
            }
            assert!(hit, "({x}, {y}): {len}");
        }
    }

    proptest! {
        /// A lower bound: no forward path of two arcs and a line (any
        /// turns at the limit, any lengths) reaches a point shorter.
        #[test]
        fn no_forward_path_is_shorter(
            r in 1.0f64..10.0,
            k1 in prop::sample::select(vec![-1.0, 0.0, 1.0]),
            k2 in prop::sample::select(vec![-1.0, 0.0, 1.0]),
            a in 0.0f64..30.0,
            b in 0.0f64..30.0,
            c in 0.0f64..30.0,
        ) {
            let (p, h) = arc(Vec2::new(0.0, 0.0), 0.0, k1 / r, a);
            let (p, h) = arc(p, h, k2 / r, b);
            let (p, _) = arc(p, h, 0.0, c);
            let bound = forward_to_point(p.x, p.y, r);
            prop_assert!(bound <= a + b + c + 1e-6, "{bound} > {}", a + b + c);
            // Backwards: the same path driven in reverse gear.
            let (q, h) = arc(Vec2::new(0.0, 0.0), 0.0, k1 / r, -a);
            let (q, h) = arc(q, h, k2 / r, -b);
            let (q, _) = arc(q, h, 0.0, -c);
            let back = backward_to_point(q.x, q.y, r);
            prop_assert!(back <= a + b + c + 1e-6, "{back} > {}", a + b + c);
        }
    }
}
