//! Starting where the vehicle stands: a start pose whose body is free but
//! inside the safety margin (a bus parked with its rear at the map's edge,
//! a van beside a wall) is driven out of the margin along one short leg,
//! and the path is planned from where that leg ends.
//!
//! The planners keep the body `margin` away from every obstacle and the
//! map's edge, so a pose inside the margin is not one they can start from.
//! Refusing it would refuse a vehicle that stands there, which is where
//! the vehicle is. The escape is deliberately simple and bounded:
//!
//! - one leg: straight, or an arc at the planning curvature to either
//!   side, driven forwards or backwards (six candidates);
//! - at most the vehicle's length long ([`max_escape`]);
//! - every pose along it (every `check` m) checked against the exact body
//!   with no margin: no point of the body on an obstacle or off the map
//!   ([`overlap`]);
//! - it ends at the first pose that keeps the margin again
//!   ([`PlanningGrid::pose_free`]); the shortest candidate wins, forwards
//!   before backwards, straight before arcs, on a tie.
//!
//! Only a start whose body overlaps an obstacle or leaves the map is
//! refused (with the place and by how much), or one with no such leg.

use crate::grid::PlanningGrid;
use crate::hybrid::arc;
use litesim_core::Vec2;

/// A point of the body this close outside the map or an obstacle cell
/// (m) still counts as touching, not overlapping: a bus parked with its
/// rear on the map's edge at a heading of 1.5708 rad has corners a few
/// micrometres past it.
pub const TOUCH: f64 = 1e-3;

/// The leg out of the margin.
#[derive(Clone, Debug, PartialEq)]
pub struct Escape {
    /// Positions of the reference point every ≤ `check` m, from the start
    /// (included) to the end.
    pub points: Vec<Vec2>,
    /// Driven backwards.
    pub reverse: bool,
    /// The leg's curvature (1/m; 0 straight).
    pub curvature: f64,
    /// Its length (m).
    pub length: f64,
    /// Where it ends (the reference point) …
    pub end: Vec2,
    /// … and the body's heading there (rad).
    pub end_yaw: f64,
    /// How far inside the margin the start is (m): the clearance the body
    /// needs there less what its tightest point has.
    pub depth: f64,
}

/// Why a start cannot be driven from.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StartError {
    /// Not a number, or infinite.
    #[error("the start ({x}, {y}) heading {yaw} is not a finite pose")]
    NotFinite {
        /// The start (m).
        x: f64,
        /// The start (m).
        y: f64,
        /// The heading (rad).
        yaw: f64,
    },
    /// The body overlaps an obstacle or leaves the map.
    #[error(
        "the vehicle cannot stand at its start ({x:.2}, {y:.2}) heading {heading_deg:.0}°: its body {what} at ({at_x:.2}, {at_y:.2}), by {depth:.2} m"
    )]
    Overlap {
        /// The start (m).
        x: f64,
        /// The start (m).
        y: f64,
        /// The heading (degrees).
        heading_deg: f64,
        /// "leaves the map" or "overlaps an obstacle".
        what: &'static str,
        /// The point of the body furthest inside (m).
        at_x: f64,
        /// The same point's y (m).
        at_y: f64,
        /// How far inside the obstacle or beyond the map's edge it is (m;
        /// to within a cell for obstacles).
        depth: f64,
    },
    /// Free but inside the margin, and no leg leaves it.
    #[error(
        "the vehicle at its start ({x:.2}, {y:.2}) heading {heading_deg:.0}° is {depth:.2} m inside the margin and no escape leg (straight or an arc at {radius:.2} m, forwards or backwards, up to {max:.1} m) leaves it without touching an obstacle or the map's edge"
    )]
    NoEscape {
        /// The start (m).
        x: f64,
        /// The start (m).
        y: f64,
        /// The heading (degrees).
        heading_deg: f64,
        /// How far inside the margin (m).
        depth: f64,
        /// The arcs' radius (m).
        radius: f64,
        /// The longest leg tried (m).
        max: f64,
    },
}

/// The longest escape leg tried for a vehicle `length` m long: its own
/// length (a body inside the margin at one end is out of it after moving
/// that far straight, unless it is hemmed in).
pub fn max_escape(length: f64) -> f64 {
    length.max(1.0)
}

/// Points of the whole body at `p` heading `yaw` (outline and interior,
/// at most a cell apart); a disc vehicle's disc. Empty for a grid without
/// a body or footprint radius.
fn body_points(grid: &PlanningGrid, p: Vec2, yaw: f64) -> Vec<Vec2> {
    let s = grid.grid.resolution.max(1e-3);
    let f = Vec2::from_heading(yaw);
    let n = Vec2::new(-f.y, f.x);
    match grid.body {
        Some([length, width, rear]) => {
            let along = (length / s).ceil().max(1.0) as usize;
            let across = (width / s).ceil().max(1.0) as usize;
            let mut out = Vec::with_capacity((along + 1) * (across + 1));
            for i in 0..=along {
                let a = -rear + length * i as f64 / along as f64;
                for j in 0..=across {
                    let l = -0.5 * width + width * j as f64 / across as f64;
                    out.push(p + f * a + n * l);
                }
            }
            out
        }
        None => {
            let r = grid.radius;
            let rings = (r / s).ceil() as usize;
            let mut out = vec![p];
            for k in 1..=rings {
                let rr = r * k as f64 / rings as f64;
                let m = ((std::f64::consts::TAU * rr / s).ceil() as usize).max(4);
                out.extend((0..m).map(|i| {
                    p + Vec2::from_heading(std::f64::consts::TAU * i as f64 / m as f64) * rr
                }));
            }
            out
        }
    }
}

/// Whether a point is off the map or on an obstacle cell, even moved by
/// [`TOUCH`] in any diagonal direction (a point on a cell's boundary
/// touches, it does not overlap): the closed loop's collision test too.
pub fn blocked(grid: &PlanningGrid, q: Vec2) -> bool {
    [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
        .iter()
        .all(|(dx, dy)| {
            let r = q + Vec2::new(dx * TOUCH, dy * TOUCH);
            grid.grid.cell(r).is_none() || grid.grid.is_occupied(r)
        })
}

/// The point of the body at `p` heading `yaw` that overlaps an obstacle
/// or leaves the map the most, what it overlaps and by how much (m; an
/// obstacle's depth to within a cell), or `None` when the body is free
/// (touching counts as free).
pub fn overlap(grid: &PlanningGrid, p: Vec2, yaw: f64) -> Option<(Vec2, &'static str, f64)> {
    let g = &grid.grid;
    let (x0, y0) = (g.origin.x, g.origin.y);
    let (x1, y1) = (
        x0 + g.width as f64 * g.resolution,
        y0 + g.height as f64 * g.resolution,
    );
    let mut worst: Option<(Vec2, &'static str, f64)> = None;
    for q in body_points(grid, p, yaw) {
        if !blocked(grid, q) {
            continue;
        }
        let outside = (x0 - q.x).max(q.x - x1).max(y0 - q.y).max(q.y - y1);
        let (what, depth) = if outside > 0.0 {
            ("leaves the map", outside)
        } else {
            // Inside an obstacle: its depth is at least the point's cell.
            ("overlaps an obstacle", 0.5 * g.resolution)
        };
        if worst.is_none_or(|w| depth > w.2) {
            worst = Some((q, what, depth));
        }
    }
    worst
}

/// How far the pose is inside the margin by the planner's rule (m): the
/// largest shortfall of a point of the body's outline (it needs the margin
/// plus a cell's diagonal) or of its axis (half the width less the margin,
/// plus the diagonal) against what [`PlanningGrid::body_free`] asks; a disc
/// vehicle's covering circles against radius + margin.
fn shortfall(grid: &PlanningGrid, p: Vec2, yaw: f64) -> f64 {
    let (_, clearance, need) = grid.tightest_part(p, yaw);
    let outline = need - clearance;
    let axis = grid
        .body
        .and_then(|body| grid.axis(body, p, Vec2::from_heading(yaw)))
        .map_or(f64::NEG_INFINITY, |(deep, points)| {
            points
                .map(|q| deep - grid.clearance(q))
                .fold(f64::NEG_INFINITY, f64::max)
        });
    outline.max(axis).max(0.0)
}

/// The leg out of the margin from `(p, yaw)`, `None` when the start keeps
/// the margin already; arcs at curvature `kappa` (1/m), poses checked
/// every `check` m, at most `max_len` m long. See the module's rules.
pub fn from_start(
    grid: &PlanningGrid,
    p: Vec2,
    yaw: f64,
    kappa: f64,
    check: f64,
    max_len: f64,
) -> Result<Option<Escape>, StartError> {
    if !(p.x.is_finite() && p.y.is_finite() && yaw.is_finite()) {
        return Err(StartError::NotFinite {
            x: p.x,
            y: p.y,
            yaw,
        });
    }
    let heading_deg = yaw.to_degrees();
    if let Some((q, what, depth)) = overlap(grid, p, yaw) {
        return Err(StartError::Overlap {
            x: p.x,
            y: p.y,
            heading_deg,
            what,
            at_x: q.x,
            at_y: q.y,
            depth,
        });
    }
    if grid.pose_free(p, yaw) {
        return Ok(None);
    }
    let depth = shortfall(grid, p, yaw);
    let check = if check.is_finite() && check > 0.0 {
        check
    } else {
        0.1
    };
    let steps = (max_len / check).ceil().max(1.0) as usize;
    let mut best: Option<Escape> = None;
    for dir in [1.0, -1.0] {
        for k in [0.0, kappa, -kappa] {
            let mut points = vec![p];
            for i in 1..=steps {
                let len = dir * check * i as f64;
                if best.as_ref().is_some_and(|b| b.length <= len.abs()) {
                    break;
                }
                let (q, h) = arc(p, yaw, k, len);
                if overlap(grid, q, h).is_some() {
                    break;
                }
                points.push(q);
                if grid.pose_free(q, h) {
                    best = Some(Escape {
                        points,
                        reverse: dir < 0.0,
                        curvature: k,
                        length: len.abs(),
                        end: q,
                        end_yaw: h,
                        depth,
                    });
                    break;
                }
            }
        }
    }
    best.map(Some).ok_or(StartError::NoEscape {
        x: p.x,
        y: p.y,
        heading_deg,
        depth,
        radius: 1.0 / kappa.max(1e-9),
        max: max_len,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::PlanningGrid;
    use litesim_map::OccupancyGrid;

    /// A 40 m × 20 m yard at 0.2 m, with a wall across x = 20..21.
    fn yard() -> PlanningGrid {
        let mut g = OccupancyGrid::new(Vec2::new(0.0, 0.0), Vec2::new(40.0, 20.0), 0.2).unwrap();
        for j in 0..100 {
            for i in 100..105 {
                g.occupied[j * 200 + i] = true;
            }
        }
        // A bus: 12 m × 2.55 m, the reference 3 m ahead of the rear.
        PlanningGrid::with_footprint(g, 12.0, 2.55, 3.0, 0.4)
    }

    #[test]
    fn a_bus_with_its_rear_on_the_maps_edge_drives_forwards_out_of_the_margin() {
        let g = yard();
        // Heading north (as the example configurations write it, 1.5708,
        // a few micrometres off π/2), rear bumper on y = 0.
        let north: f64 = "1.5708".parse().unwrap();
        let e = from_start(&g, Vec2::new(5.0, 3.0), north, 0.05, 0.1, 12.0)
            .unwrap()
            .expect("inside the margin: an escape");
        assert!(!e.reverse && e.curvature == 0.0, "{e:?}");
        assert!(e.depth > 0.3, "{}", e.depth);
        // Out of the margin (0.4 m + a cell's diagonal) after about that far.
        assert!((0.5..1.0).contains(&e.length), "{}", e.length);
        assert!(g.pose_free(e.end, e.end_yaw));
        assert!(
            e.points
                .iter()
                .all(|q| overlap(&g, *q, e.end_yaw).is_none())
        );
    }

    #[test]
    fn a_body_off_the_map_or_in_a_wall_is_refused_with_place_and_depth() {
        let g = yard();
        let e = from_start(&g, Vec2::new(2.5, 5.0), 0.0, 0.05, 0.1, 12.0).unwrap_err();
        let StartError::Overlap {
            what, depth, at_x, ..
        } = e.clone()
        else {
            panic!("{e}")
        };
        assert_eq!(what, "leaves the map");
        assert!((depth - 0.5).abs() < 1e-6 && at_x < 0.0, "{e}");
        assert!(e.to_string().contains("leaves the map at (-0.50"), "{e}");
        let e = from_start(&g, Vec2::new(15.0, 10.0), 0.0, 0.05, 0.1, 12.0).unwrap_err();
        assert!(e.to_string().contains("overlaps an obstacle"), "{e}");
        let e = from_start(&g, Vec2::new(f64::NAN, 10.0), 0.0, 0.05, 0.1, 12.0).unwrap_err();
        assert!(matches!(e, StartError::NotFinite { .. }), "{e}");
    }

    #[test]
    fn a_start_that_keeps_the_margin_needs_no_escape_and_a_hemmed_in_one_has_none() {
        let g = yard();
        assert_eq!(
            from_start(&g, Vec2::new(5.0, 10.0), 0.0, 0.05, 0.1, 12.0),
            Ok(None)
        );
        // A 12 m bus in a yard 12.2 m long, 0.1 m from either end: any
        // move along its length or turn touches an end first.
        let g2 = {
            let g = OccupancyGrid::new(Vec2::new(0.0, 0.0), Vec2::new(12.2, 20.0), 0.2).unwrap();
            PlanningGrid::with_footprint(g, 12.0, 2.55, 3.0, 0.4)
        };
        let e = from_start(&g2, Vec2::new(3.1, 10.0), 0.0, 0.05, 0.1, 12.0).unwrap_err();
        assert!(matches!(e, StartError::NoEscape { .. }), "{e}");
        assert!(e.to_string().contains("no escape leg"), "{e}");
    }
}
