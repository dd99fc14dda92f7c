//! Curvature-bounded search: hybrid A* (Dolgov, Thrun, Montemerlo and
//! Diebel, "Path planning for autonomous vehicles in unknown semi-structured
//! environments", IJRR 2010), forward and — when asked — reversing
//! (Reeds–Shepp's car: arcs driven either way, a cusp where the direction
//! changes).
//!
//! FMT* connects samples with straight edges; a long vehicle cannot follow
//! their corners, and the smoother can only round a corner as far as the
//! free space around it allows. This search moves a pose (x, y, heading)
//! along arcs no tighter than the vehicle can drive, checks the whole
//! footprint along each arc, and keeps the cheapest pose per cell of
//! (x, y, heading[, direction]). It is guided by the larger of two lower
//! bounds: the obstacle-aware distance to the goal (Dijkstra over the grid
//! for the reference point) and the turning limit's shortest way to the
//! goal without obstacles ([`crate::reach`]). It finishes with an analytic
//! shot — one arc at the planning curvature, then a straight line, forwards
//! or backwards — whenever that reaches the goal free. Reversing, a way in
//! is kept, not taken at once, until no pose left could beat it by more
//! than [`HybridConfig::accept_within`]: a cusp and each metre backwards
//! cost more, so a forward way is taken wherever it costs less.
//! Deterministic: no randomness, ties broken by insertion order.

use crate::fmt::Cheapest;
use crate::grid::PlanningGrid;
use litesim_core::Vec2;
use litesim_core::math;
use std::collections::BinaryHeap;

/// Settings of the search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HybridConfig {
    /// The largest curvature a path may have (1/m), below the vehicle's
    /// limit so that the controller keeps some steering to correct with.
    pub kappa: f64,
    /// Arc length of one motion primitive (m).
    pub step: f64,
    /// Side of a position cell of the closed set (m).
    pub cell: f64,
    /// Heading bins of the closed set.
    pub headings: usize,
    /// Spacing of footprint checks along an arc (m).
    pub check: f64,
    /// Poses expanded before giving up.
    pub max_expansions: usize,
    /// A pose this close to the goal (m) ends the path there when no shot
    /// reaches the goal itself (0: only shots end it).
    pub goal_tolerance: f64,
    /// Reversing allowed: arcs are also driven backwards (and shots
    /// finish backwards). Off, the search is the forward-only one.
    pub reverse: bool,
    /// A reversing arc's cost per metre, against 1 forward: drivers (and
    /// trackers) prefer to see where they go.
    pub reverse_factor: f64,
    /// The cost of a change of direction (m of forward driving; into
    /// reverse, times `reverse_factor` like the arc it starts): the vehicle
    /// stops, steers at standstill and starts again.
    pub switch_cost: f64,
    /// Reversing, a way into the goal is taken once no pose left to
    /// expand could be cheaper by more than this factor (1: the cheapest
    /// on the lattice; more: sooner, at most that much dearer).
    pub accept_within: f64,
    /// The steering level is part of the closed set's state (5× the
    /// states): a pose reached with the wheels turned one way does not
    /// close the cell for a later arrival with them turned the other. The
    /// exhaustive search that proves a run impossible needs it; the
    /// planning search keys poses on position, heading and direction
    /// (each pose still keeps its level, and its arcs change it by one).
    pub steering_in_state: bool,
}

impl HybridConfig {
    /// Settings for a vehicle whose tightest planned curvature is `kappa`
    /// (1/m) on a grid of `resolution` m: cells of 0.5 m (at least two grid
    /// cells), 72 heading bins (5°), primitives of 1.5 cells, checks every
    /// half grid cell.
    pub fn new(kappa: f64, resolution: f64) -> Self {
        let cell = (2.0 * resolution).max(0.5);
        Self {
            kappa,
            step: 1.5 * cell,
            cell,
            headings: 72,
            check: 0.5 * resolution,
            max_expansions: 200_000,
            goal_tolerance: 0.0,
            reverse: false,
            reverse_factor: 2.0,
            switch_cost: 10.0,
            accept_within: 1.25,
            steering_in_state: false,
        }
    }
}

/// Why the search failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum HybridError {
    /// Bad settings.
    #[error("invalid search settings: {0}")]
    BadConfig(String),
    /// The vehicle does not fit at the start.
    #[error(
        "the vehicle does not fit at its start ({x:.2}, {y:.2}) heading {heading_deg:.0}°: the part of its body around ({at_x:.1}, {at_y:.1}) is {clearance:.2} m from an obstacle or the map's edge, it needs {need:.2} m ({rule})"
    )]
    StartBlocked {
        /// The start (m).
        x: f64,
        /// The start (m).
        y: f64,
        /// The start heading (degrees).
        heading_deg: f64,
        /// The point of the body's outline (a disc vehicle: the centre of
        /// its circle) with the least clearance (m).
        at_x: f64,
        /// The same point's y (m).
        at_y: f64,
        /// Its clearance (m).
        clearance: f64,
        /// The clearance it needs (m).
        need: f64,
        /// What that clearance is made of.
        rule: &'static str,
    },
    /// No path within the turning limit.
    #[error(
        "no {} path with turns no tighter than {radius:.2} m: {expansions} poses searched, the closest came within {closest:.2} m of the goal at ({at_x:.1}, {at_y:.1})",
        if *reverse { "forward-or-reversing" } else { "forward" }
    )]
    NoPath {
        /// Whether reversing was allowed.
        reverse: bool,
        /// Tightest turn radius planned (m).
        radius: f64,
        /// Poses expanded.
        expansions: usize,
        /// Closest distance to the goal reached (m).
        closest: f64,
        /// Where (m).
        at_x: f64,
        /// Where (m).
        at_y: f64,
    },
}

/// A stretch of a path driven in one direction.
#[derive(Clone, Debug, PartialEq)]
pub struct PathSegment {
    /// Points every ≤ `check` m in the order driven; a segment's last
    /// point is the next one's first (the cusp).
    pub points: Vec<Vec2>,
    /// Driven backwards: the vehicle's heading is opposite to the
    /// direction from one point to the next.
    pub reverse: bool,
}

/// A path found by the search.
#[derive(Clone, Debug, PartialEq)]
pub struct HybridPath {
    /// Points along the path every ≤ `check` m, start to goal.
    pub points: Vec<Vec2>,
    /// The same path cut at its changes of direction (one forward segment
    /// when it has none).
    pub segments: Vec<PathSegment>,
    /// Its length (m).
    pub length: f64,
    /// Poses expanded.
    pub expansions: usize,
    /// The search as a tree to look at: the positions of the first
    /// [`TREE_CAP`] poses expanded, in expansion order, and the edges
    /// (parent, child) between them, indices into `explored`.
    pub explored: Vec<Vec2>,
    /// See `explored`.
    pub tree: Vec<(usize, usize)>,
}

/// Expanded poses kept for [`HybridPath::explored`]: enough to show where a
/// search went (a typical arrival expands 1,000–30,000), bounded so that a
/// hard search does not bloat the log.
pub const TREE_CAP: usize = 20_000;

/// The pose after driving `len` m (negative: backwards) along curvature
/// `k` from `(p, yaw)`.
pub(crate) fn arc(p: Vec2, yaw: f64, k: f64, len: f64) -> (Vec2, f64) {
    if k.abs() < 1e-12 {
        return (p + Vec2::from_heading(yaw) * len, yaw);
    }
    let y1 = yaw + k * len;
    (
        p + Vec2::new(
            math::sin(y1) - math::sin(yaw),
            math::cos(yaw) - math::cos(y1),
        ) * (1.0 / k),
        y1,
    )
}

/// Poses every ≤ `check` m along an arc (excluding the start, including the
/// end); false as soon as one does not fit — by its covering circles, or
/// with `exact` by its body ([`PlanningGrid::pose_free_along`]).
///
/// Each sub-step is the same rigid motion in the vehicle's frame, so the
/// poses follow by rotating the heading vector (no trigonometry per
/// pose; the drift over an arc is far below a grid cell).
fn arc_free(
    grid: &PlanningGrid,
    p: Vec2,
    yaw: f64,
    k: f64,
    len: f64,
    check: f64,
    exact: bool,
) -> bool {
    // `len` < 0: driven backwards (the heading still the body's).
    let m = (len.abs() / check).ceil().max(1.0) as usize;
    let ds = len / m as f64;
    let turn = k * ds;
    // One sub-step in the frame of its start: ahead, to the left.
    let (ahead, left) = if k.abs() < 1e-12 {
        (ds, 0.0)
    } else {
        (math::sin(turn) / k, (1.0 - math::cos(turn)) / k)
    };
    let (s, c) = math::sin_cos(turn);
    let mut f = Vec2::from_heading(yaw);
    let mut q = p;
    for _ in 0..m {
        q = q + f * ahead + Vec2::new(-f.y, f.x) * left;
        f = Vec2::new(f.x * c - f.y * s, f.x * s + f.y * c);
        let free = if exact {
            grid.pose_free_along(q, f)
        } else {
            grid.circles_free_along(q, f)
        };
        if !free {
            return false;
        }
    }
    true
}

/// Appends points every ≤ `check` m along an arc (excluding its start;
/// `len` < 0 backwards).
fn arc_points(out: &mut Vec<Vec2>, p: Vec2, yaw: f64, k: f64, len: f64, check: f64) {
    let m = (len.abs() / check).ceil().max(1.0) as usize;
    out.extend((1..=m).map(|j| arc(p, yaw, k, len * j as f64 / m as f64).0));
}

/// The analytic finish from `(p, yaw)`: an arc of curvature ±`kappa` until
/// the direction of travel points at `goal`, then straight to it — driven
/// forwards (`dir` = 1) or backwards (`dir` = −1). Returns (curvature,
/// arc length, straight length) of the shorter free one, lengths signed
/// as driven (negative backwards).
fn shot(
    grid: &PlanningGrid,
    p: Vec2,
    yaw: f64,
    goal: Vec2,
    kappa: f64,
    check: f64,
    dir: f64,
) -> Option<(f64, f64, f64)> {
    let r = 1.0 / kappa;
    // Backwards is forwards for a vehicle turned around (heading + π)
    // steering the other way: the geometry below is the forward one on
    // the direction of travel, the checks on the body's own heading.
    let travel = if dir < 0.0 {
        yaw + std::f64::consts::PI
    } else {
        yaw
    };
    let mut best: Option<(f64, f64, f64)> = None;
    for side in [1.0, -1.0] {
        // Centre of the turning circle on this side.
        let (ts, tc) = math::sin_cos(travel);
        let c = p + Vec2::new(-ts, tc) * (side * r);
        let v = goal - c;
        let dist = v.norm();
        if dist < r * (1.0 + 1e-9) {
            continue;
        }
        let straight = (dist * dist - r * r).sqrt();
        // Radial angle of the tangent point, then the angle turned to it
        // (in the direction of travel, 0 ≤ φ < 2π).
        let beta = v.heading() - side * math::atan2(straight, r);
        let beta0 = (p - c).heading();
        let mut phi = (side * (beta - beta0)).rem_euclid(std::f64::consts::TAU);
        if phi > std::f64::consts::TAU - 1e-9 {
            // Already facing the goal, up to rounding: not a full circle.
            phi = 0.0;
        }
        let turn = phi * r;
        let total = turn + straight;
        if best.is_some_and(|b| (b.1 + b.2).abs() <= total) {
            continue;
        }
        let k = dir * side * kappa;
        let (turn, straight) = (dir * turn, dir * straight);
        if !arc_free(grid, p, yaw, k, turn, check, false) {
            continue;
        }
        let (q, h) = arc(p, yaw, k, turn);
        if straight != 0.0 && !arc_free(grid, q, h, 0.0, straight, check, false) {
            continue;
        }
        best = Some((k, turn, straight));
    }
    best
}

/// Obstacle-aware distance (m) from every cell to the goal's cell for the
/// reference point, 8-connected, through cells where the reference point
/// can be at all (clearance of at least the covering circles' radius plus
/// margin, less half their spacing: the point lies on the body's axis
/// within half a spacing of a circle's centre). +∞ where the goal cannot
/// be reached: a pose there is pruned.
///
/// A goal whose own cell the reference point cannot be in (a goal inside
/// the margin) is reached within `end_within` of it: the sources are then
/// the passable cells within that distance, each at its distance to the
/// goal (for a goal the point can be at, the goal's cell alone, as ever).
fn distance_to_goal(grid: &PlanningGrid, goal: Vec2, end_within: f64) -> Vec<f64> {
    let g = &grid.grid;
    let (w, h, res) = (g.width, g.height, g.resolution);
    let spacing = match grid.footprint.as_slice() {
        [a, b, ..] => (b - a).abs(),
        _ => 0.0,
    };
    let need = grid.radius + grid.margin - 0.5 * spacing;
    let pass: Vec<bool> = (0..w * h)
        .map(|c| !g.occupied[c] && grid.distance[c] - 0.5 * res >= need)
        .collect();
    let mut dist = vec![f64::INFINITY; w * h];
    let Some((gi, gj)) = g.cell(goal) else {
        return dist;
    };
    // The goal's own cell is the source even when it is tight.
    let start = gj * w + gi;
    dist[start] = 0.0;
    let mut heap = BinaryHeap::new();
    heap.push(Cheapest(0.0, start));
    if !pass[start] && end_within > 0.0 {
        let k = (end_within / res).ceil() as isize;
        for dj in -k..=k {
            for di in -k..=k {
                let (ni, nj) = (gi as isize + di, gj as isize + dj);
                if ni < 0 || nj < 0 || ni >= w as isize || nj >= h as isize {
                    continue;
                }
                let nc = nj as usize * w + ni as usize;
                let d = res * ((di * di + dj * dj) as f64).sqrt();
                if pass[nc] && d <= end_within && d < dist[nc] {
                    dist[nc] = d;
                    heap.push(Cheapest(d, nc));
                }
            }
        }
    }
    let diag = res * std::f64::consts::SQRT_2;
    while let Some(Cheapest(d, c)) = heap.pop() {
        if d > dist[c] {
            continue;
        }
        let (i, j) = ((c % w) as isize, (c / w) as isize);
        for (di, dj, step) in [
            (1, 0, res),
            (-1, 0, res),
            (0, 1, res),
            (0, -1, res),
            (1, 1, diag),
            (1, -1, diag),
            (-1, 1, diag),
            (-1, -1, diag),
        ] {
            let (ni, nj) = (i + di, j + dj);
            if ni < 0 || nj < 0 || ni >= w as isize || nj >= h as isize {
                continue;
            }
            let nc = nj as usize * w + ni as usize;
            if !pass[nc] {
                continue;
            }
            let nd = d + step;
            if nd < dist[nc] {
                dist[nc] = nd;
                heap.push(Cheapest(nd, nc));
            }
        }
    }
    dist
}

/// A way into the goal: (cost, the node it leaves from, the shot from
/// there as (curvature, arc length, straight length), none when the node
/// itself is within the goal tolerance).
type WayIn = (f64, u32, Option<(f64, f64, f64)>);

struct Node {
    p: Vec2,
    yaw: f64,
    g: f64,
    parent: u32,
    /// Curvature level of the arc that led here.
    level: u8,
    /// Direction of the arc that led here: 1 forwards, −1 backwards.
    dir: i8,
    /// Index in the tree kept for display (u32::MAX: not in it).
    shown: u32,
    /// The arc from the parent is not checked yet (a change of direction:
    /// most are never expanded, so each is checked when it is).
    unchecked: bool,
}

/// Plans a path from `(start, yaw)` to `goal` (any final heading) whose
/// curvature never exceeds `cfg.kappa`, with the grid's footprint free all
/// along: forwards only, or with `cfg.reverse` forwards and backwards.
pub fn hybrid_astar(
    grid: &PlanningGrid,
    start: Vec2,
    yaw: f64,
    goal: Vec2,
    cfg: &HybridConfig,
) -> Result<HybridPath, HybridError> {
    validate(cfg)?;
    if !(start.is_finite() && yaw.is_finite() && grid.pose_free(start, yaw)) {
        return Err(start_blocked(grid, start, yaw));
    }
    let mut s = Search::new(grid, start, goal, cfg)?;
    // The vehicle starts with its wheels straight.
    s.nodes.push(Node {
        p: start,
        yaw,
        g: 0.0,
        parent: u32::MAX,
        level: 2,
        dir: 1,
        shown: u32::MAX,
        unchecked: false,
    });
    let h0 = s.h(start, yaw, 1.0);
    if !h0.is_finite() {
        return Err(s.exhausted(0));
    }
    s.heap.push(Cheapest(h0, 0));
    while let Some(Cheapest(f, id)) = s.heap.pop() {
        if s.way_in.is_some_and(|w| f * cfg.accept_within >= w.0) {
            break;
        }
        let Some(kk) = s.open(id) else {
            continue;
        };
        s.best[kk] = f64::NEG_INFINITY;
        s.expansions += 1;
        s.show(id);
        if s.expansions > cfg.max_expansions {
            let expansions = s.expansions - 1;
            return s.finish(expansions);
        }
        let (p, gc) = (s.nodes[id as usize].p, s.nodes[id as usize].g);
        let d = p.distance(goal);
        if d < s.closest.0 {
            s.closest = (d, p);
        }
        let shot_here = s.shoot(id, d);
        // Ending short of the goal where no shot reaches it from here.
        if !shot_here && d <= cfg.goal_tolerance && s.way_in.is_none_or(|w| gc < w.0) {
            s.way_in = Some((gc, id, None));
        }
        // Forwards only, the first way in is the path (the search as it
        // always was).
        if !cfg.reverse && s.way_in.is_some() {
            break;
        }
        s.expand(id);
    }
    let expansions = s.expansions;
    s.finish(expansions)
}

/// The settings' numbers that no search can use, as an error naming them.
fn validate(cfg: &HybridConfig) -> Result<(), HybridError> {
    let HybridConfig {
        kappa,
        step,
        cell,
        check,
        accept_within,
        reverse,
        reverse_factor,
        switch_cost,
        headings,
        ..
    } = *cfg;
    if !(kappa.is_finite() && kappa > 0.0) {
        return Err(HybridError::BadConfig(format!(
            "curvature must be positive, got {kappa}"
        )));
    }
    for (name, v) in [("step", step), ("cell", cell), ("check", check)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(HybridError::BadConfig(format!(
                "{name} must be positive, got {v}"
            )));
        }
    }
    if !(accept_within.is_finite() && accept_within >= 1.0) {
        return Err(HybridError::BadConfig(format!(
            "accept_within must be a number ≥ 1, got {accept_within}"
        )));
    }
    for (name, v) in [
        ("reverse_factor", reverse_factor),
        ("switch_cost", switch_cost),
    ] {
        if reverse && !(v.is_finite() && v >= 0.0) {
            return Err(HybridError::BadConfig(format!(
                "{name} must be a number ≥ 0, got {v}"
            )));
        }
    }
    if headings == 0 {
        return Err(HybridError::BadConfig("headings must be at least 1".into()));
    }
    Ok(())
}

/// A start pose the body does not fit: where it is tightest, and the rule.
fn start_blocked(grid: &PlanningGrid, start: Vec2, yaw: f64) -> HybridError {
    let (at, clearance, need) = grid.tightest_part(start, yaw);
    HybridError::StartBlocked {
        x: start.x,
        y: start.y,
        heading_deg: yaw.to_degrees(),
        at_x: at.x,
        at_y: at.y,
        clearance,
        need,
        rule: if grid.body.is_some() {
            "the margin, plus a cell's diagonal"
        } else {
            "the vehicle's radius plus the margin"
        },
    }
}

/// One search: its fixed parts (grid, goal, settings, curvature levels,
/// distance to the goal, the state lattice's size) and what it has found
/// (the poses, the open heap, the cheapest cost per state, the tree kept
/// for display, the best way into the goal).
struct Search<'g> {
    grid: &'g PlanningGrid,
    goal: Vec2,
    cfg: HybridConfig,
    /// The turning radius at the planning curvature (m).
    radius: f64,
    /// Curvature levels −κ, −κ/2, 0, κ/2, κ; an arc changes the level by at
    /// most one (steering moves at a finite rate, and a path whose
    /// curvature jumps is one no vehicle follows exactly). The level is
    /// part of the state only where asked (`steering_in_state`).
    ks: [f64; 5],
    to_goal: Vec<f64>,
    /// The lattice: cells across and up, curvature levels and directions
    /// in a state's key.
    nx: usize,
    ny: usize,
    keyed_levels: usize,
    dirs: usize,
    /// The cheapest cost seen per state; −∞ once the state is expanded
    /// (closed): one array, not two, since a search's memory is mostly the
    /// pages it touches.
    best: Vec<f64>,
    nodes: Vec<Node>,
    heap: BinaryHeap<Cheapest<u32>>,
    explored: Vec<Vec2>,
    tree: Vec<(usize, usize)>,
    expansions: usize,
    /// The closest any expanded pose came to the goal, and where.
    closest: (f64, Vec2),
    /// Shots are tried on every 4th expansion within this distance of the
    /// goal, on every 16th away (a shot is long to check, and from afar
    /// rarely free; near the goal consecutive expansions are neighbours,
    /// whose shots differ little).
    near: f64,
    /// How far from its start the body is checked exactly: a body length.
    leave: f64,
    /// Reversing, the first way in is not taken at once: a shot backwards
    /// from a pose reached cheaply may cost more (reversing, a cusp) than a
    /// forward way found a little later. The cheapest way in so far is
    /// kept, (cost, node, shot), and returned once no pose left to expand
    /// could beat it by more than `accept_within`.
    way_in: Option<WayIn>,
}

impl<'g> Search<'g> {
    fn new(
        grid: &'g PlanningGrid,
        start: Vec2,
        goal: Vec2,
        cfg: &HybridConfig,
    ) -> Result<Self, HybridError> {
        let g = &grid.grid;
        let cell = cfg.cell;
        let extent = Vec2::new(g.width as f64, g.height as f64) * g.resolution;
        let (nx, ny) = (
            (extent.x / cell).ceil().max(1.0) as usize,
            (extent.y / cell).ceil().max(1.0) as usize,
        );
        let kappa = cfg.kappa;
        let ks = [-kappa, -0.5 * kappa, 0.0, 0.5 * kappa, kappa];
        let keyed_levels = if cfg.steering_in_state { ks.len() } else { 1 };
        // Reversing doubles the states: a pose reached backwards is not one
        // reached forwards (a change of direction costs).
        let dirs = if cfg.reverse { 2 } else { 1 };
        if nx
            .saturating_mul(ny)
            .saturating_mul(cfg.headings)
            .saturating_mul(keyed_levels * dirs)
            > 64 << 20
        {
            return Err(HybridError::BadConfig(format!(
                "{nx} × {ny} cells × {} headings is too fine for this map: use larger cells",
                cfg.headings
            )));
        }
        let states = nx * ny * cfg.headings * keyed_levels * dirs;
        // Each expansion adds up to eight poses: room for those of the first
        // 64k expansions up front, so that a long search does not copy its
        // poses and its heap on every doubling (untouched room costs nothing).
        let room = 8 * cfg.max_expansions.clamp(1, 1 << 16);
        let radius = 1.0 / kappa;
        Ok(Search {
            grid,
            goal,
            cfg: *cfg,
            radius,
            ks,
            to_goal: distance_to_goal(grid, goal, cfg.goal_tolerance),
            nx,
            ny,
            keyed_levels,
            dirs,
            best: vec![f64::INFINITY; states],
            nodes: Vec::with_capacity(room),
            heap: BinaryHeap::with_capacity(room),
            explored: Vec::new(),
            tree: Vec::new(),
            expansions: 0,
            closest: (start.distance(goal), start),
            near: 2.0 * radius + 5.0,
            leave: grid.body.map_or(0.0, |[length, ..]| length),
            way_in: None,
        })
    }

    /// The larger of two lower bounds of the cost to the goal: around the
    /// walls for the reference point, and the turning limit's for a
    /// heading without walls ([`crate::reach`]). Reversing, a path goes on
    /// in the direction it came or has a cusp (at least `switch_cost`
    /// more).
    fn h(&self, p: Vec2, yaw: f64, dir: f64) -> f64 {
        let g = &self.grid.grid;
        let Some((i, j)) = g.cell(p) else {
            return f64::INFINITY;
        };
        let (radius, c) = (self.radius, &self.cfg);
        let v = self.goal - p;
        let f = Vec2::from_heading(yaw);
        let (x, y) = (v.dot(f), f.cross(v));
        let turning = if !c.reverse {
            crate::reach::forward_to_point(x, y, radius)
        } else {
            let on = if dir > 0.0 {
                crate::reach::forward_to_point(x, y, radius)
            } else {
                c.reverse_factor * crate::reach::backward_to_point(x, y, radius)
            };
            on.min(v.norm() + c.switch_cost)
        };
        let turning = (turning - c.goal_tolerance).max(0.0);
        self.to_goal[j * g.width + i].max(v.norm()).max(turning)
    }

    /// The state of a pose: its lattice cell, heading bin, curvature
    /// level (where keyed) and direction; none off the lattice.
    fn key(&self, p: Vec2, yaw: f64, level: usize, dir: f64) -> Option<usize> {
        let g = &self.grid.grid;
        let (cell, headings) = (self.cfg.cell, self.cfg.headings);
        let u = (p.x - g.origin.x) / cell;
        let v = (p.y - g.origin.y) / cell;
        if !(u >= 0.0 && v >= 0.0) {
            return None;
        }
        let (i, j) = (u as usize, v as usize);
        if i >= self.nx || j >= self.ny {
            return None;
        }
        let t = yaw.rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU;
        let b = ((t * headings as f64) as usize).min(headings - 1);
        let d = usize::from(dir < 0.0);
        let level = if self.cfg.steering_in_state { level } else { 0 };
        Some((((j * self.nx + i) * headings + b) * self.keyed_levels + level) * self.dirs + d)
    }

    /// What a motion of cost `cost` costs driven forwards or (`back`)
    /// backwards after one driven the other way or not (`was_back`): a
    /// change of direction adds `switch_cost`, and backwards all of it
    /// costs `reverse_factor` times. One rule for the arcs and the shots.
    fn directed(&self, cost: f64, back: bool, was_back: bool) -> f64 {
        let cost = if back != was_back {
            cost + self.cfg.switch_cost
        } else {
            cost
        };
        if back {
            cost * self.cfg.reverse_factor
        } else {
            cost
        }
    }

    /// The state of node `id` when it is to be expanded: none when it is
    /// off the lattice, already reached more cheaply or closed, or its arc
    /// (a change of direction, checked only now) is blocked.
    fn open(&self, id: u32) -> Option<usize> {
        let n = &self.nodes[id as usize];
        let (lc, dc) = (usize::from(n.level), f64::from(n.dir));
        let kk = self.key(n.p, n.yaw, lc, dc)?;
        if n.g > self.best[kk] {
            return None;
        }
        if n.unchecked {
            let a = &self.nodes[n.parent as usize];
            let c = &self.cfg;
            if !arc_free(
                self.grid,
                a.p,
                a.yaw,
                self.ks[lc],
                dc * c.step,
                c.check,
                a.g < self.leave,
            ) {
                return None;
            }
        }
        Some(kk)
    }

    /// Keeps an expanded node in the tree shown in the views (up to
    /// [`TREE_CAP`] of them), with the edge from its parent.
    fn show(&mut self, id: u32) {
        if self.explored.len() >= TREE_CAP {
            return;
        }
        let at = self.explored.len();
        let n = &mut self.nodes[id as usize];
        n.shown = at as u32;
        let (p, parent) = (n.p, n.parent);
        self.explored.push(p);
        if let Some(pn) = self.nodes.get(parent as usize)
            && pn.shown != u32::MAX
        {
            self.tree.push((pn.shown as usize, at));
        }
    }

    /// Tries the shots into the goal from node `id` (at `d` from it) when
    /// one is due, keeping the cheapest way in; whether any was free.
    fn shoot(&mut self, id: u32, d: f64) -> bool {
        let (p, yaw, gc, dc) = {
            let n = &self.nodes[id as usize];
            (n.p, n.yaw, n.g, f64::from(n.dir))
        };
        let c = self.cfg;
        let expansions = self.expansions;
        // A reversing search also shoots from its start: a goal straight
        // behind is reached backwards, not after a few metres forwards.
        let first = c.reverse && expansions == 1;
        // (A shot is at least as long as the straight line: none from
        // here can beat a way in that costs less than that.)
        let worth = self.way_in.is_none_or(|w| gc + d < w.0);
        if !(worth
            && ((d < self.near && expansions.is_multiple_of(4))
                || expansions.is_multiple_of(16)
                || first))
        {
            return false;
        }
        // Forwards, and reversing also backwards (a shot against the
        // direction the pose was reached in adds a cusp there); the
        // cheaper by the search's costs.
        let (grid, goal) = (self.grid, self.goal);
        let shots = [
            shot(grid, p, yaw, goal, c.kappa, c.check, 1.0),
            c.reverse
                .then(|| shot(grid, p, yaw, goal, c.kappa, c.check, -1.0))
                .flatten(),
        ];
        let mut shot_here = false;
        for (k, turn, straight) in shots.into_iter().flatten() {
            shot_here = true;
            let back = turn < 0.0 || straight < 0.0;
            // The arc at the full planning curvature, as an arc of
            // the search costs it (1 + 0.05 per metre).
            let total = gc + self.directed(turn.abs() * 1.05 + straight.abs(), back, dc < 0.0);
            if self.way_in.is_none_or(|w| total < w.0) {
                self.way_in = Some((total, id, Some((k, turn, straight))));
            }
        }
        shot_here
    }

    /// Pushes node `id`'s successors: an arc of one step at its own
    /// curvature level or a neighbouring one, and reversing, at any level
    /// the other way.
    fn expand(&mut self, id: u32) {
        let (p, yaw, gc, lc, dc) = {
            let n = &self.nodes[id as usize];
            (n.p, n.yaw, n.g, usize::from(n.level), f64::from(n.dir))
        };
        let c = self.cfg;
        let levels = self.ks.len();
        let lo = lc.saturating_sub(1);
        let same = (lo..(lc + 2).min(levels)).map(|l| (l, dc));
        // A change of direction happens at standstill, where the wheels
        // may be turned to any angle: every level.
        let flip = (0..levels).filter(|_| c.reverse).map(|l| (l, -dc));
        for (level, dir) in same.chain(flip) {
            let k = self.ks[level];
            let len = dir * c.step;
            // A start the circles do not fit (a long body near a wall or
            // the map's edge) is left with the body checked exactly; the
            // rest of the search keeps the circles' room.
            let lazy = dir != dc;
            if !lazy && !arc_free(self.grid, p, yaw, k, len, c.check, gc < self.leave) {
                continue;
            }
            let (q, qy) = arc(p, yaw, k, len);
            let Some(qk) = self.key(q, qy, level, dir) else {
                continue;
            };
            if self.best[qk] == f64::NEG_INFINITY {
                continue;
            }
            // Length, a little more for turning and, going on in the same
            // direction, for changing the turn (smoother paths are cheaper
            // to track); then the direction's rule (`directed`).
            let mut cost = c.step * (1.0 + 0.05 * k.abs() / c.kappa);
            if dir == dc {
                cost += 0.1 * c.step * (level.abs_diff(lc) as f64);
            }
            let ng = gc + self.directed(cost, dir < 0.0, dc < 0.0);
            if ng >= self.best[qk] {
                continue;
            }
            let h = self.h(q, qy, dir);
            if !h.is_finite() {
                continue;
            }
            // (An arc not yet checked claims no cell: were it blocked, it
            // would have turned away a dearer arrival that is free.)
            if !lazy {
                self.best[qk] = ng;
            }
            self.nodes.push(Node {
                p: q,
                yaw: qy,
                g: ng,
                parent: id,
                level: level as u8,
                dir: dir as i8,
                shown: u32::MAX,
                unchecked: lazy,
            });
            self.heap
                .push(Cheapest(ng + h, (self.nodes.len() - 1) as u32));
        }
    }

    /// The search gave up or ran out of poses after `expansions`.
    fn exhausted(&self, expansions: usize) -> HybridError {
        HybridError::NoPath {
            reverse: self.cfg.reverse,
            radius: self.radius,
            expansions,
            closest: self.closest.0,
            at_x: self.closest.1.x,
            at_y: self.closest.1.y,
        }
    }

    /// The path through the best way in, or the search's failure.
    fn finish(self, expansions: usize) -> Result<HybridPath, HybridError> {
        let Some((_, id, shot)) = self.way_in else {
            return Err(self.exhausted(expansions));
        };
        let goal = self.goal;
        Ok(HybridPath {
            explored: self.explored,
            tree: self.tree,
            ..reconstruct(
                &self.nodes,
                &self.ks,
                id,
                self.cfg.step,
                self.cfg.check,
                shot.map(|(k, turn, straight)| (k, turn, straight, goal)),
                expansions,
            )
        })
    }
}

/// The points from the start to node `id`, then the shot (curvature, arc
/// length, straight length, goal) when there is one.
fn reconstruct(
    nodes: &[Node],
    ks: &[f64],
    id: u32,
    step: f64,
    check: f64,
    shot: Option<(f64, f64, f64, Vec2)>,
    expansions: usize,
) -> HybridPath {
    let mut chain = vec![id];
    while let Some(&last) = chain.last() {
        let parent = nodes[last as usize].parent;
        if parent == u32::MAX {
            break;
        }
        chain.push(parent);
    }
    chain.reverse();
    let first = &nodes[chain[0] as usize];
    let mut points = vec![first.p];
    // The direction each point after the first was reached in.
    let mut backwards = vec![false];
    let mut follow = |points: &mut Vec<Vec2>, p: Vec2, yaw: f64, k: f64, len: f64| {
        arc_points(points, p, yaw, k, len, check);
        backwards.resize(points.len(), len < 0.0);
    };
    for w in chain.windows(2) {
        let (a, b) = (&nodes[w[0] as usize], &nodes[w[1] as usize]);
        follow(
            &mut points,
            a.p,
            a.yaw,
            ks[usize::from(b.level)],
            f64::from(b.dir) * step,
        );
    }
    if let Some((k, turn, straight, goal)) = shot {
        let end = &nodes[id as usize];
        if turn != 0.0 {
            follow(&mut points, end.p, end.yaw, k, turn);
        }
        let (q, h) = arc(end.p, end.yaw, k, turn);
        if straight != 0.0 {
            follow(&mut points, q, h, 0.0, straight);
        }
        // The last point is the goal up to rounding: make it the goal.
        if let Some(last) = points.last_mut() {
            *last = goal;
        }
    }
    if backwards.len() > 1 {
        backwards[0] = backwards[1];
    }
    // Cut at each change of direction; the cusp ends one segment and
    // starts the next.
    let mut segments: Vec<PathSegment> = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        let reverse = backwards[i];
        match segments.last_mut() {
            Some(s) if s.reverse == reverse => s.points.push(p),
            Some(s) => {
                let cusp = *s.points.last().unwrap_or(&p);
                segments.push(PathSegment {
                    points: vec![cusp, p],
                    reverse,
                });
            }
            None => segments.push(PathSegment {
                points: vec![p],
                reverse,
            }),
        }
    }
    let length = points.windows(2).map(|w| w[0].distance(w[1])).sum();
    HybridPath {
        points,
        segments,
        length,
        expansions,
        explored: Vec::new(),
        tree: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use litesim_map::{Obstacle, OccupancyGrid};

    fn yard(obstacles: &[Obstacle]) -> PlanningGrid {
        let g = OccupancyGrid::from_obstacles(Vec2::new(0.0, 0.0), (60.0, 30.0), 0.2, obstacles)
            .unwrap();
        PlanningGrid::with_footprint(g, 4.6, 1.9, 1.0, 0.3)
    }

    #[test]
    fn arcs_are_exact() {
        // A quarter circle of radius 5 to the left from the origin heading +x.
        let (q, h) = arc(
            Vec2::new(0.0, 0.0),
            0.0,
            0.2,
            5.0 * std::f64::consts::FRAC_PI_2,
        );
        assert!(
            (q.x - 5.0).abs() < 1e-12 && (q.y - 5.0).abs() < 1e-12,
            "{q:?}"
        );
        assert!((h - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn turns_around_a_wall_within_the_limit_and_is_deterministic() {
        let grid = yard(&[Obstacle::Rect {
            min: [25.0, 0.0],
            max: [28.0, 20.0],
        }]);
        let cfg = HybridConfig::new(0.8 / 4.0, 0.2);
        let (start, goal) = (Vec2::new(5.0, 5.0), Vec2::new(50.0, 5.0));
        let a = hybrid_astar(&grid, start, 0.0, goal, &cfg).unwrap();
        let b = hybrid_astar(&grid, start, 0.0, goal, &cfg).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.points[0], start);
        assert_eq!(*a.points.last().unwrap(), goal);
        // Over the wall's top and back down: longer than the straight line.
        assert!(a.length > 55.0, "{}", a.length);
        assert!(crate::corridor::max_curvature(&a.points) <= cfg.kappa * 1.01);
        for w in a.points.windows(2) {
            assert!(w[0].distance(w[1]) <= cfg.check + 1e-9);
            assert!(grid.pose_free(w[1], (w[1] - w[0]).heading()));
        }
        // The tree kept for display: the expanded poses from the start, in
        // expansion order, each after its parent, one edge per pose but
        // the start, every edge one primitive long.
        assert_eq!(a.explored.len(), a.expansions.min(TREE_CAP));
        assert_eq!(a.explored[0], start);
        assert_eq!(a.tree.len(), a.explored.len() - 1);
        for &(p, c) in &a.tree {
            assert!(p < c && c < a.explored.len(), "({p}, {c})");
            let d = a.explored[p].distance(a.explored[c]);
            assert!(d <= cfg.step + 1e-9 && d > 0.5 * cfg.step, "{d}");
        }
    }

    /// Allowed to reverse, the search still drives forwards where a
    /// forward way costs less: round the wall as the forward-only search
    /// does, no cusp, within `accept_within` of the forward path's cost;
    /// and `accept_within` = 1 gives a way no dearer than the default's.
    #[test]
    fn reversing_allowed_a_forward_way_is_still_taken() {
        let grid = yard(&[Obstacle::Rect {
            min: [25.0, 0.0],
            max: [28.0, 20.0],
        }]);
        let (start, goal) = (Vec2::new(5.0, 5.0), Vec2::new(50.0, 5.0));
        let fwd = HybridConfig::new(0.8 / 4.0, 0.2);
        let only = hybrid_astar(&grid, start, 0.0, goal, &fwd).unwrap();
        let both = HybridConfig {
            reverse: true,
            ..fwd
        };
        let p = hybrid_astar(&grid, start, 0.0, goal, &both).unwrap();
        assert_eq!(p.segments.len(), 1, "{:?}", p.segments.len());
        assert!(!p.segments[0].reverse);
        assert!(
            p.length <= 1.25 * only.length + 1e-9,
            "{} vs {}",
            p.length,
            only.length
        );
        let exact = HybridConfig {
            accept_within: 1.0,
            ..both
        };
        let q = hybrid_astar(&grid, start, 0.0, goal, &exact).unwrap();
        assert!(q.segments.iter().all(|s| !s.reverse));
        assert!(q.length <= p.length + 1e-9, "{} vs {}", q.length, p.length);
        for bad in [0.5, f64::NAN, f64::INFINITY] {
            let cfg = HybridConfig {
                accept_within: bad,
                ..both
            };
            let e = hybrid_astar(&grid, start, 0.0, goal, &cfg).unwrap_err();
            assert!(e.to_string().contains("accept_within"), "{e}");
        }
    }

    #[test]
    fn failures_are_clear() {
        let grid = yard(&[Obstacle::Rect {
            min: [25.0, 0.0],
            max: [28.0, 30.0],
        }]);
        let cfg = HybridConfig {
            max_expansions: 20_000,
            ..HybridConfig::new(0.2, 0.2)
        };
        let e =
            hybrid_astar(&grid, Vec2::new(5.0, 5.0), 0.0, Vec2::new(50.0, 5.0), &cfg).unwrap_err();
        assert!(matches!(e, HybridError::NoPath { .. }), "{e}");
        let e =
            hybrid_astar(&grid, Vec2::new(26.0, 5.0), 0.0, Vec2::new(50.0, 5.0), &cfg).unwrap_err();
        assert!(
            matches!(e, HybridError::StartBlocked { x: 26.0, y: 5.0, clearance, .. } if clearance == 0.0),
            "{e}"
        );
        // The reason names the place and both clearances.
        let e =
            hybrid_astar(&grid, Vec2::new(1.5, 5.0), 0.0, Vec2::new(50.0, 5.0), &cfg).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with("the vehicle does not fit at its start (1.50, 5.00) heading 0°: the part of its body around (")
                && text.contains("m from an obstacle or the map's edge, it needs 0.58 m (the margin, plus a cell's diagonal)"),
            "{text}"
        );
        let bad = HybridConfig {
            kappa: f64::NAN,
            ..cfg
        };
        assert!(matches!(
            hybrid_astar(&grid, Vec2::new(5.0, 5.0), 0.0, Vec2::new(50.0, 5.0), &bad),
            Err(HybridError::BadConfig(_))
        ));
    }

    /// Bad input never panics: starts, yaws and goals anywhere (off the
    /// map, inside walls, NaN, infinite) end in a path or a clear error.
    #[test]
    fn any_input_ends_in_a_path_or_an_error() {
        let grid = yard(&[Obstacle::Rect {
            min: [25.0, 0.0],
            max: [28.0, 20.0],
        }]);
        let cfg = HybridConfig {
            max_expansions: 3_000,
            goal_tolerance: 0.5,
            ..HybridConfig::new(0.2, 0.2)
        };
        let mut rng = crate::rng::Rng::new(5);
        let odd = [f64::NAN, f64::INFINITY, -1e300, 1e300, -3.0, 70.0];
        for k in 0..200 {
            let mut v = [0.0; 5];
            for (i, x) in v.iter_mut().enumerate() {
                *x = if (k + i) % 17 == 0 {
                    odd[(k + i) % odd.len()]
                } else {
                    -5.0 + rng.unit() * 70.0
                };
            }
            let (start, goal) = (Vec2::new(v[0], v[1] * 0.5), Vec2::new(v[2], v[3] * 0.5));
            // Forwards only, and reversing (every other case).
            let cfg = HybridConfig {
                reverse: k % 2 == 1,
                ..cfg
            };
            match hybrid_astar(&grid, start, v[4], goal, &cfg) {
                Ok(p) => {
                    assert!(p.points.iter().all(|q| q.is_finite()));
                    assert!(p.length.is_finite());
                    // The segments are the path, cut at its cusps.
                    let n: usize = p.segments.iter().map(|s| s.points.len() - 1).sum();
                    assert_eq!(n + 1, p.points.len());
                    assert!(cfg.reverse || p.segments.iter().all(|s| !s.reverse));
                }
                Err(e) => assert!(!e.to_string().is_empty()),
            }
        }
    }

    /// A dead-end street 6 m wide (closed at x = 44), open to the left:
    /// a car facing the dead end cannot turn round.
    fn dead_end() -> PlanningGrid {
        yard(&[
            Obstacle::Rect {
                min: [0.0, 0.0],
                max: [60.0, 12.0],
            },
            Obstacle::Rect {
                min: [0.0, 18.0],
                max: [60.0, 30.0],
            },
            Obstacle::Rect {
                min: [44.0, 12.0],
                max: [60.0, 18.0],
            },
        ])
    }

    /// Every point of every segment is a free pose of the body: heading
    /// along the segment, turned around on a reversing one.
    fn body_fits_along(grid: &PlanningGrid, path: &HybridPath) {
        for seg in &path.segments {
            for w in seg.points.windows(2) {
                let travel = (w[1] - w[0]).heading();
                let heading = if seg.reverse {
                    travel + std::f64::consts::PI
                } else {
                    travel
                };
                assert!(
                    grid.pose_free(w[1], heading),
                    "{:?} reverse {}",
                    w[1],
                    seg.reverse
                );
            }
        }
    }

    #[test]
    fn a_bus_through_a_gap_backs_into_its_goal() {
        // The narrow-passage example: a wall across the yard with a 5 m
        // gap; a 12 m bus (wheelbase 6 m, 40°) at 80 % of its curvature.
        let g = OccupancyGrid::from_obstacles(
            Vec2::new(0.0, 0.0),
            (60.0, 30.0),
            0.2,
            &[
                Obstacle::Rect {
                    min: [29.0, 0.0],
                    max: [31.0, 12.5],
                },
                Obstacle::Rect {
                    min: [29.0, 17.5],
                    max: [31.0, 30.0],
                },
            ],
        )
        .unwrap();
        let grid = PlanningGrid::with_footprint(g, 12.0, 2.55, 3.0, 0.3);
        let kappa = 0.8 * math::tan(40f64.to_radians()) / 6.0;
        let (start, goal) = (Vec2::new(5.0, 5.0), Vec2::new(55.0, 25.0));
        let forward = HybridConfig {
            goal_tolerance: 0.25,
            max_expansions: 50_000,
            ..HybridConfig::new(kappa, 0.2)
        };
        let e = hybrid_astar(&grid, start, 0.0, goal, &forward).unwrap_err();
        assert!(e.to_string().starts_with("no forward path"), "{e}");
        let cfg = HybridConfig {
            reverse: true,
            ..forward
        };
        let a = hybrid_astar(&grid, start, 0.0, goal, &cfg).unwrap();
        assert_eq!(a, hybrid_astar(&grid, start, 0.0, goal, &cfg).unwrap());
        assert_eq!(a.points[0], start);
        assert!(a.points.last().unwrap().distance(goal) <= 0.25);
        // Forwards through the gap, then backwards into the goal corner:
        // segments alternate, share their cusps, and make up the path.
        assert!(a.segments.len() >= 2, "{}", a.segments.len());
        assert!(!a.segments[0].reverse && a.segments.iter().any(|s| s.reverse));
        for w in a.segments.windows(2) {
            assert_ne!(w[0].reverse, w[1].reverse);
            assert_eq!(w[0].points.last(), w[1].points.first());
        }
        let joined: usize = a.segments.iter().map(|s| s.points.len() - 1).sum();
        assert_eq!(joined + 1, a.points.len());
        for s in &a.segments {
            assert!(crate::corridor::max_curvature(&s.points) <= cfg.kappa * 1.01);
            for w in s.points.windows(2) {
                assert!(w[0].distance(w[1]) <= cfg.check + 1e-9);
            }
        }
        body_fits_along(&grid, &a);
        // Bad reversing settings are refused, not searched.
        let bad = HybridConfig {
            switch_cost: f64::NAN,
            ..cfg
        };
        let e = hybrid_astar(&grid, start, 0.0, goal, &bad).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid search settings: switch_cost must be a number ≥ 0, got NaN"
        );
    }

    #[test]
    fn a_goal_straight_behind_is_reached_backwards() {
        let grid = dead_end();
        let cfg = HybridConfig {
            reverse: true,
            max_expansions: 100_000,
            ..HybridConfig::new(0.2, 0.2)
        };
        let (start, goal) = (Vec2::new(35.0, 15.0), Vec2::new(8.0, 15.0));
        let a = hybrid_astar(&grid, start, 0.0, goal, &cfg).unwrap();
        assert_eq!(a.segments.len(), 1, "{:?}", a.segments);
        assert!(a.segments[0].reverse);
        assert!((a.length - 27.0).abs() < 0.5, "{}", a.length);
        body_fits_along(&grid, &a);
    }

    #[test]
    fn a_u_turn_needs_room() {
        // Goal behind the start: a forward U-turn of radius 1/κ needs
        // about 2/κ of width plus the body.
        let grid = yard(&[]);
        let start = Vec2::new(20.0, 15.0);
        let ok = hybrid_astar(
            &grid,
            start,
            0.0,
            Vec2::new(10.0, 15.0),
            &HybridConfig::new(0.2, 0.2),
        )
        .unwrap();
        assert!(crate::corridor::max_curvature(&ok.points) <= 0.2 * 1.01);
        // In a 6 m wide corridor a radius-10 U-turn cannot be made.
        let corridor = yard(&[
            Obstacle::Rect {
                min: [0.0, 0.0],
                max: [60.0, 12.0],
            },
            Obstacle::Rect {
                min: [0.0, 18.0],
                max: [60.0, 30.0],
            },
        ]);
        let e = hybrid_astar(
            &corridor,
            start,
            0.0,
            Vec2::new(10.0, 15.0),
            &HybridConfig {
                max_expansions: 50_000,
                ..HybridConfig::new(0.1, 0.2)
            },
        )
        .unwrap_err();
        assert!(matches!(e, HybridError::NoPath { .. }), "{e}");
    }
}
