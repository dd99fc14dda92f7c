//! FMT* — Fast Marching Tree (Janson, Schmerling, Clark, Pavone, IJRR 2015).
//!
//! Batch-samples `n` points of free space under a seed, then grows a tree
//! outward in cost order: each step takes the cheapest open node `z`, and
//! every unvisited neighbour `x` of `z` connects to the open neighbour `y`
//! that minimises `cost(y) + |y − x|` — with one lazy collision check of
//! that single edge. Connection radius
//! `r_n = (1+η)·2·(1/d)^(1/d)·(μ(X_free)/ζ_d)^(1/d)·(log n / n)^(1/d)`,
//! d = 2, ζ₂ = π; or a fixed radius; or the k nearest neighbours.

use crate::grid::PlanningGrid;
use crate::rng::Rng;
use litesim_core::Vec2;
use litesim_core::math;
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// How neighbours are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "value")]
pub enum Radius {
    /// The paper's r_n with tuning parameter η (> 0).
    Eta(f64),
    /// A fixed radius (m).
    Fixed(f64),
    /// The k nearest samples.
    KNearest(usize),
}

/// FMT* settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FmtConfig {
    /// Number of samples.
    pub samples: usize,
    /// Neighbourhood rule.
    pub radius: Radius,
    /// Seed of the sampler.
    pub seed: u64,
}

impl Default for FmtConfig {
    fn default() -> Self {
        Self {
            samples: 2000,
            radius: Radius::Eta(0.5),
            seed: 1,
        }
    }
}

/// Why planning failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FmtError {
    /// Start in (or too close to) an obstacle.
    #[error(
        "start ({0:.2}, {1:.2}) is in collision: closer than radius + margin to an obstacle, or off the map"
    )]
    StartInCollision(f64, f64),
    /// Goal in (or too close to) an obstacle.
    #[error(
        "goal ({0:.2}, {1:.2}) is in collision: closer than radius + margin to an obstacle, or off the map"
    )]
    GoalInCollision(f64, f64),
    /// No free space to sample.
    #[error("the map has no free space for a vehicle of this size")]
    NoFreeSpace,
    /// The tree stopped growing before reaching the goal.
    #[error(
        "no path found with {samples} samples (the tree reached {reached} of them); try more samples or a larger radius"
    )]
    NoPath {
        /// Samples drawn.
        samples: usize,
        /// Nodes connected.
        reached: usize,
    },
    /// Bad settings.
    #[error("invalid planner settings: {0}")]
    BadConfig(String),
}

/// Everything FMT* produced.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FmtResult {
    /// Start, goal, then the samples.
    pub samples: Vec<Vec2>,
    /// Parent of each sample in the tree (`None`: not connected, or the start).
    pub parent: Vec<Option<usize>>,
    /// Cost-to-come of each sample (m); +∞ when not connected.
    pub cost: Vec<f64>,
    /// Edges (parent, child) in the order they were accepted.
    pub edges: Vec<(usize, usize)>,
    /// The path from start to goal.
    pub path: Vec<Vec2>,
    /// Its length (m).
    pub path_cost: f64,
    /// The connection radius used (m; for k-nearest, the largest distance seen).
    pub radius: f64,
    /// Edge collision checks performed.
    pub collision_checks: usize,
}

/// Uniform buckets for radius queries, stored sorted by (cell, index):
/// the cells of one row of a query's window are one contiguous run of
/// coordinates, scanned without chasing per-cell lists. The order of the
/// answer (row by row, cell by cell, index within a cell) is the order of
/// per-cell lists, so the planner's tree does not depend on the layout.
struct Buckets {
    cell: f64,
    origin: Vec2,
    nx: usize,
    ny: usize,
    /// Offset of each cell's run; `nx·ny + 1` entries.
    start: Vec<u32>,
    ids: Vec<u32>,
    xs: Vec<f64>,
    ys: Vec<f64>,
}

impl Buckets {
    fn new(points: &[Vec2], lo: Vec2, hi: Vec2, cell: f64) -> Self {
        let nx = (((hi.x - lo.x) / cell).ceil() as usize).clamp(1, 4096);
        let ny = (((hi.y - lo.y) / cell).ceil() as usize).clamp(1, 4096);
        let cell = ((hi.x - lo.x) / nx as f64)
            .max((hi.y - lo.y) / ny as f64)
            .max(1e-9);
        let mut b = Self {
            cell,
            origin: lo,
            nx,
            ny,
            start: Vec::new(),
            ids: Vec::new(),
            xs: Vec::new(),
            ys: Vec::new(),
        };
        // Counting sort by cell (stable: indices stay ascending per cell).
        let cells: Vec<usize> = points
            .iter()
            .map(|p| {
                let (cx, cy) = b.cell_of(*p);
                cy * nx + cx
            })
            .collect();
        let mut start = vec![0u32; nx * ny + 1];
        for &c in &cells {
            start[c + 1] += 1;
        }
        for c in 0..nx * ny {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut ids = vec![0u32; points.len()];
        for (i, &c) in cells.iter().enumerate() {
            ids[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        b.xs = ids.iter().map(|&i| points[i as usize].x).collect();
        b.ys = ids.iter().map(|&i| points[i as usize].y).collect();
        b.ids = ids;
        b.start = start;
        b
    }
    fn cell_of(&self, p: Vec2) -> (usize, usize) {
        // `as usize` truncates (= floor for values ≥ 0) and saturates
        // negatives and NaN to 0: ⌊·⌋ clamped to the grid, without libm.
        let cy = (((p.y - self.origin.y) / self.cell) as usize).min(self.ny - 1);
        (self.column(p.x), cy)
    }
    /// Calls `hit(id, d²)` for every point within `r` of `p`, in the
    /// buckets' order (row by row, cell by cell, index within a cell);
    /// d² is formed as `q.distance(p)` forms it, so its root is that
    /// distance bit for bit.
    #[inline]
    fn scan(&self, p: Vec2, r: f64, mut hit: impl FnMut(u32, f64)) {
        let reach = (r / self.cell).ceil() as isize;
        let (cx, cy) = self.cell_of(p);
        let r2 = r * r;
        let x0 = (cx as isize - reach).max(0) as usize;
        let x1 = ((cx as isize + reach) as usize).min(self.nx - 1);
        for dy in -reach..=reach {
            let y = cy as isize + dy;
            if y < 0 || y >= self.ny as isize {
                continue;
            }
            let row = y as usize * self.nx;
            let (a, b) = (
                self.start[row + x0] as usize,
                self.start[row + x1 + 1] as usize,
            );
            for ((&x, &y), &id) in self.xs[a..b]
                .iter()
                .zip(&self.ys[a..b])
                .zip(&self.ids[a..b])
            {
                let (dx, dy) = (x - p.x, y - p.y);
                let d2 = dx * dx + dy * dy;
                if d2 <= r2 {
                    hit(id, d2);
                }
            }
        }
    }
    /// The column of `x` (see [`Self::cell_of`]).
    fn column(&self, x: f64) -> usize {
        (((x - self.origin.x) / self.cell) as usize).min(self.nx - 1)
    }

    /// Every point's neighbours within `r` at once, as an arena: point
    /// `id`'s list is `ids[span[id].0..][..span[id].1]` with the distances
    /// beside it in `dist`. Each list is what [`Self::scan`] answers for
    /// that point (without the point itself), in the same order (ascending
    /// bucket position), distances bit for bit.
    ///
    /// Each pair is found once, from its lower bucket position looking
    /// forward (the rest of its row, then the rows above), so half the
    /// candidates and half the square roots of one query per point; no
    /// branch per candidate (about half of a window is in range, at
    /// random, and a conditional push mispredicts often).
    fn all_within(&self, r: f64, expect: usize) -> (Vec<(u32, u32)>, Vec<u32>, Vec<f64>) {
        let n = self.ids.len();
        let r2 = r * r;
        let reach = (r / self.cell).ceil() as usize;
        // The columns of [x − r, x + r], a hair wider for rounding (the
        // exact test decides).
        let wide = r * (1.0 + 1e-9);
        let mut deg = vec![0u32; n];
        let (mut pi, mut pj, mut pd) = (
            Vec::with_capacity(expect / 2),
            Vec::with_capacity(expect / 2),
            Vec::with_capacity(expect / 2),
        );
        let mut window: (Vec<u32>, Vec<f64>) = (Vec::new(), Vec::new());
        for i in 0..n {
            let (px, py) = (self.xs[i], self.ys[i]);
            let (_, cy) = self.cell_of(Vec2::new(px, py));
            let (x0, x1) = (self.column(px - wide), self.column(px + wide));
            for y in cy..=(cy + reach).min(self.ny - 1) {
                let row = y * self.nx;
                let (mut a, b) = (
                    self.start[row + x0] as usize,
                    self.start[row + x1 + 1] as usize,
                );
                if y == cy {
                    a = a.max(i + 1);
                }
                if a >= b {
                    continue;
                }
                if window.0.len() < b - a {
                    window.0.resize(b - a, 0);
                    window.1.resize(b - a, 0.0);
                }
                let mut k = 0;
                for (j, (&x, &y)) in (a..b).zip(self.xs[a..b].iter().zip(&self.ys[a..b])) {
                    // As `Vec2::distance` forms it: (q − p), squared, summed.
                    let (dx, dy) = (x - px, y - py);
                    let d2 = dx * dx + dy * dy;
                    window.0[k] = j as u32;
                    window.1[k] = d2;
                    k += usize::from(d2 <= r2);
                }
                deg[i] += k as u32;
                for (&j, &d2) in window.0[..k].iter().zip(&window.1[..k]) {
                    deg[j as usize] += 1;
                    pi.push(i as u32);
                    pj.push(j);
                    pd.push(d2.sqrt());
                }
            }
        }
        let mut next = Vec::with_capacity(n);
        let mut total = 0u32;
        for &d in &deg {
            next.push(total);
            total += d;
        }
        let mut span = vec![(0u32, 0u32); n];
        for (pos, (&o, &d)) in next.iter().zip(&deg).enumerate() {
            span[self.ids[pos] as usize] = (o, d);
        }
        let mut ids = vec![0u32; total as usize];
        let mut dist = vec![0.0f64; total as usize];
        for ((&i, &j), &d) in pi.iter().zip(&pj).zip(&pd) {
            let (i, j) = (i as usize, j as usize);
            let (a, b) = (next[i] as usize, next[j] as usize);
            ids[a] = self.ids[j];
            dist[a] = d;
            ids[b] = self.ids[i];
            dist[b] = d;
            next[i] += 1;
            next[j] += 1;
        }
        (span, ids, dist)
    }
    /// The points within `r` of `p` (replacing `out`'s contents).
    fn near(&self, p: Vec2, r: f64, out: &mut Vec<u32>) {
        out.clear();
        self.scan(p, r, |id, _| out.push(id));
    }
}

/// A heap entry ordered so that `BinaryHeap` (a max-heap) pops the lowest
/// cost first, ties by the lowest id: the search order of FMT*, hybrid A*
/// and its Dijkstra heuristic, deterministic.
#[derive(PartialEq)]
pub(crate) struct Cheapest<I>(pub(crate) f64, pub(crate) I);
impl<I: Ord> Eq for Cheapest<I> {}
impl<I: Ord> PartialOrd for Cheapest<I> {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl<I: Ord> Ord for Cheapest<I> {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then_with(|| o.1.cmp(&self.1))
    }
}

#[derive(Clone, Copy, PartialEq)]
enum State {
    Unvisited,
    Open,
    Closed,
}

/// Plans from `start` to `goal` on `grid`.
pub fn fmt_star(
    grid: &PlanningGrid,
    start: Vec2,
    goal: Vec2,
    cfg: &FmtConfig,
) -> Result<FmtResult, FmtError> {
    let area = check_fmt(grid, start, goal, cfg)?;
    let (lo, size) = extent(grid);
    let (samples, r) = sample(grid, (start, goal), cfg, area);
    let n = samples.len();
    // Cells of half the radius: a query scans 5 × 5 cells of (r/2)², 6.25 r²
    // of candidates, instead of 3 × 3 cells of r², 9 r².
    let buckets = Buckets::new(&samples, lo, lo + size, (0.5 * r).max(grid.grid.resolution));
    let mut state = vec![State::Unvisited; n];
    let mut cost = vec![f64::INFINITY; n];
    let mut parent: Vec<Option<usize>> = vec![None; n];
    let mut edges = Vec::new();
    let mut heap = BinaryHeap::new();
    let mut checks = 0usize;
    state[0] = State::Open;
    cost[0] = 0.0;
    let mut open_cost = vec![f64::INFINITY; n];
    open_cost[0] = 0.0;
    heap.push(Cheapest(0.0, 0));
    // Neighbour lists, each computed once (see `neighbour_arena`).
    let (mut span, mut arena_idx, mut arena_dist) = neighbour_arena(cfg, &buckets, n, (r, area));
    let mut scratch = Vec::new();
    let mut load = |i: usize,
                    span: &mut Vec<(u32, u32)>,
                    arena_idx: &mut Vec<u32>,
                    arena_dist: &mut Vec<f64>|
     -> (usize, usize) {
        // Radius lists were all built above; only k-nearest ones are missing.
        if let (u32::MAX, Radius::KNearest(k)) = (span[i].0, cfg.radius) {
            let start = arena_idx.len();
            buckets.near(samples[i], r, &mut scratch);
            nearest_k(&samples, samples[i], &mut scratch, k);
            arena_idx.extend_from_slice(&scratch);
            arena_dist.extend(
                scratch
                    .iter()
                    .map(|&y| samples[y as usize].distance(samples[i])),
            );
            span[i] = (start as u32, (arena_idx.len() - start) as u32);
        }
        let (a, l) = span[i];
        (a as usize, a as usize + l as usize)
    };
    let mut reached_goal = false;
    let mut new_open: Vec<usize> = Vec::new();
    let mut near_z: Vec<u32> = Vec::new();
    while let Some(Cheapest(_, z)) = heap.pop() {
        if state[z] != State::Open {
            continue;
        }
        if z == 1 {
            reached_goal = true;
            break;
        }
        let (a, b) = load(z, &mut span, &mut arena_idx, &mut arena_dist);
        near_z.clear();
        near_z.extend_from_slice(&arena_idx[a..b]);
        new_open.clear();
        for &xi in &near_z {
            let x = xi as usize;
            if state[x] != State::Unvisited {
                continue;
            }
            let (a, b) = load(x, &mut span, &mut arena_idx, &mut arena_dist);
            // The open node y minimising cost(y) + d(y, x) (ties: lower
            // index); `open_cost` is +∞ off the open set, so one load
            // per neighbour decides.
            let (mut bc, mut by) = (f64::INFINITY, usize::MAX);
            for (&y, &d) in arena_idx[a..b].iter().zip(&arena_dist[a..b]) {
                let c = open_cost[y as usize] + d;
                if c < bc || (c == bc && (y as usize) < by) {
                    (bc, by) = (c, y as usize);
                }
            }
            let best = (bc.is_finite()).then_some((bc, by));
            if let Some((c, y)) = best {
                checks += 1;
                if grid.segment_free(samples[y], samples[x]) {
                    cost[x] = c;
                    parent[x] = Some(y);
                    edges.push((y, x));
                    new_open.push(x);
                }
            }
        }
        for &x in &new_open {
            state[x] = State::Open;
            open_cost[x] = cost[x];
            heap.push(Cheapest(cost[x], x));
        }
        state[z] = State::Closed;
        open_cost[z] = f64::INFINITY;
    }
    if !reached_goal {
        return Err(FmtError::NoPath {
            samples: n - 2,
            reached: parent.iter().filter(|p| p.is_some()).count(),
        });
    }
    let path = path_to_goal(&samples, &parent);
    Ok(FmtResult {
        path_cost: cost[1],
        samples,
        parent,
        cost,
        edges,
        path,
        radius: r,
        collision_checks: checks,
    })
}

/// The neighbour lists' arena. Neighbour lists are asked for again and
/// again (each node both as `z` and as a candidate `x`): each is computed
/// once, into one arena of indices and distances (no per-node allocation,
/// no repeated square roots; d(y, x) = d(x, y) bit for bit). Radius
/// neighbourhoods are symmetric and nearly every node's is needed, so they
/// are built at once (about n · (n π r² / area) entries, sized once);
/// k-nearest ones are not symmetric and are built on demand.
#[allow(clippy::type_complexity)]
fn neighbour_arena(
    cfg: &FmtConfig,
    buckets: &Buckets,
    n: usize,
    (r, area): (f64, f64),
) -> (Vec<(u32, u32)>, Vec<u32>, Vec<f64>) {
    if let Radius::KNearest(_) = cfg.radius {
        (vec![(u32::MAX, 0); n], Vec::new(), Vec::new())
    } else {
        let expect = (n as f64 * n as f64 * std::f64::consts::PI * r * r / area)
            .clamp(n as f64, (1u64 << 24) as f64) as usize;
        buckets.all_within(r, expect)
    }
}

/// Keeps the nearest `k` of `out` to `p` (and `p`'s own index when it is
/// among them), ties by index.
fn nearest_k(samples: &[Vec2], p: Vec2, out: &mut Vec<u32>, k: usize) {
    out.sort_by(|a, b| {
        let (da, db) = (
            samples[*a as usize].distance(p),
            samples[*b as usize].distance(p),
        );
        da.total_cmp(&db).then(a.cmp(b))
    });
    out.truncate(k + 1);
}

/// The path from the start (sample 0) to the goal (sample 1) along the
/// tree's parents.
fn path_to_goal(samples: &[Vec2], parent: &[Option<usize>]) -> Vec<Vec2> {
    let mut path = vec![samples[1]];
    let mut cur = 1;
    while let Some(p) = parent[cur] {
        path.push(samples[p]);
        cur = p;
    }
    path.reverse();
    path
}

/// Refuses a configuration FMT* cannot run (no samples, a radius, eta or k
/// that is not positive) and a start or goal in collision; gives the free
/// area.
fn check_fmt(
    grid: &PlanningGrid,
    start: Vec2,
    goal: Vec2,
    cfg: &FmtConfig,
) -> Result<f64, FmtError> {
    if cfg.samples == 0 {
        return Err(FmtError::BadConfig("samples must be at least 1".into()));
    }
    match cfg.radius {
        Radius::Eta(e) if !(e.is_finite() && e > 0.0) => {
            return Err(FmtError::BadConfig(format!(
                "eta must be positive, got {e}"
            )));
        }
        Radius::Fixed(r) if !(r.is_finite() && r > 0.0) => {
            return Err(FmtError::BadConfig(format!(
                "radius must be positive, got {r}"
            )));
        }
        Radius::KNearest(0) => return Err(FmtError::BadConfig("k must be at least 1".into())),
        _ => {}
    }
    if !(start.is_finite() && grid.is_free(start)) {
        return Err(FmtError::StartInCollision(start.x, start.y));
    }
    if !(goal.is_finite() && grid.is_free(goal)) {
        return Err(FmtError::GoalInCollision(goal.x, goal.y));
    }
    let area = grid.free_area();
    if area <= 0.0 {
        return Err(FmtError::NoFreeSpace);
    }
    Ok(area)
}

/// The grid's lower corner and size (m).
fn extent(grid: &PlanningGrid) -> (Vec2, Vec2) {
    let g = &grid.grid;
    let size = Vec2::new(
        g.width as f64 * g.resolution,
        g.height as f64 * g.resolution,
    );
    (g.origin, size)
}

/// The seeded samples (start and goal first, then free points drawn over
/// the grid) and the connection radius for them.
fn sample(
    grid: &PlanningGrid,
    (start, goal): (Vec2, Vec2),
    cfg: &FmtConfig,
    area: f64,
) -> (Vec<Vec2>, f64) {
    let (lo, size) = extent(grid);
    let mut rng = Rng::new(cfg.seed);
    let mut samples = vec![start, goal];
    let max_tries = cfg.samples.saturating_mul(1000).max(10_000);
    let mut tries = 0;
    while samples.len() < cfg.samples + 2 && tries < max_tries {
        tries += 1;
        let p = Vec2::new(lo.x + rng.unit() * size.x, lo.y + rng.unit() * size.y);
        if grid.is_free(p) {
            samples.push(p);
        }
    }
    let n = samples.len();
    let r = match cfg.radius {
        Radius::Eta(eta) => {
            let nn = n as f64;
            (1.0 + eta)
                * 2.0
                * (0.5f64).sqrt()
                * (area / std::f64::consts::PI).sqrt()
                * (math::ln(nn) / nn).sqrt()
        }
        Radius::Fixed(r) => r,
        // k-nearest: grow a radius until it holds k neighbours on average (then exact per node below).
        Radius::KNearest(k) => {
            ((k as f64 + 1.0) * area / (std::f64::consts::PI * n as f64)).sqrt() * 1.5
        }
    };
    (samples, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The neighbour lists built at once are the scan's, in its order
    /// (less the point itself), with its distances bit for bit.
    #[test]
    fn neighbour_lists_match_the_scan() {
        let mut rng = Rng::new(3);
        for (cell, r) in [(1.1, 2.2), (0.7, 3.1), (2.0, 0.9), (25.0, 30.0)] {
            let pts: Vec<Vec2> = (0..3000)
                .map(|_| Vec2::new(rng.unit() * 50.0, rng.unit() * 20.0))
                .collect();
            let b = Buckets::new(&pts, Vec2::new(0.0, 0.0), Vec2::new(50.0, 20.0), cell);
            let (span, ids, dist) = b.all_within(r, 0);
            for (k, &p) in pts.iter().enumerate() {
                let (a, l) = (span[k].0 as usize, span[k].1 as usize);
                let mut want = (vec![], vec![]);
                b.scan(p, r, |id, d2| {
                    if id as usize != k {
                        want.0.push(id);
                        want.1.push(d2.sqrt().to_bits());
                    }
                });
                assert_eq!(&ids[a..a + l], &want.0[..], "point {k}");
                let got: Vec<u64> = dist[a..a + l].iter().map(|d| d.to_bits()).collect();
                assert_eq!(got, want.1, "point {k}");
            }
        }
    }
}
