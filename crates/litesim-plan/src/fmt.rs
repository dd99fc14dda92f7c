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

/// Uniform buckets for radius queries.
struct Buckets {
    cell: f64,
    origin: Vec2,
    nx: usize,
    ny: usize,
    heads: Vec<Vec<u32>>,
}

impl Buckets {
    fn new(points: &[Vec2], lo: Vec2, hi: Vec2, cell: f64) -> Self {
        let nx = (((hi.x - lo.x) / cell).ceil() as usize).clamp(1, 4096);
        let ny = (((hi.y - lo.y) / cell).ceil() as usize).clamp(1, 4096);
        let cell = ((hi.x - lo.x) / nx as f64)
            .max((hi.y - lo.y) / ny as f64)
            .max(1e-9);
        let mut heads = vec![Vec::new(); nx * ny];
        let mut b = Self {
            cell,
            origin: lo,
            nx,
            ny,
            heads: Vec::new(),
        };
        for (i, p) in points.iter().enumerate() {
            let (cx, cy) = b.cell_of(*p);
            heads[cy * nx + cx].push(i as u32);
        }
        b.heads = heads;
        b
    }
    fn cell_of(&self, p: Vec2) -> (usize, usize) {
        let cx = (((p.x - self.origin.x) / self.cell).floor().max(0.0) as usize).min(self.nx - 1);
        let cy = (((p.y - self.origin.y) / self.cell).floor().max(0.0) as usize).min(self.ny - 1);
        (cx, cy)
    }
    fn near(&self, points: &[Vec2], p: Vec2, r: f64, out: &mut Vec<u32>) {
        out.clear();
        let reach = (r / self.cell).ceil() as isize;
        let (cx, cy) = self.cell_of(p);
        let r2 = r * r;
        for dy in -reach..=reach {
            let y = cy as isize + dy;
            if y < 0 || y >= self.ny as isize {
                continue;
            }
            for dx in -reach..=reach {
                let x = cx as isize + dx;
                if x < 0 || x >= self.nx as isize {
                    continue;
                }
                for &k in &self.heads[y as usize * self.nx + x as usize] {
                    let d = points[k as usize] - p;
                    if d.dot(d) <= r2 {
                        out.push(k);
                    }
                }
            }
        }
    }
}

#[derive(PartialEq)]
struct Open(f64, usize);
impl Eq for Open {}
impl PartialOrd for Open {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Open {
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
    let g = &grid.grid;
    let lo = g.origin;
    let size = Vec2::new(
        g.width as f64 * g.resolution,
        g.height as f64 * g.resolution,
    );
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
                * (nn.ln() / nn).sqrt()
        }
        Radius::Fixed(r) => r,
        // k-nearest: grow a radius until it holds k neighbours on average (then exact per node below).
        Radius::KNearest(k) => {
            ((k as f64 + 1.0) * area / (std::f64::consts::PI * n as f64)).sqrt() * 1.5
        }
    };
    let buckets = Buckets::new(&samples, lo, lo + size, r.max(g.resolution));
    let mut state = vec![State::Unvisited; n];
    let mut cost = vec![f64::INFINITY; n];
    let mut parent: Vec<Option<usize>> = vec![None; n];
    let mut edges = Vec::new();
    let mut heap = BinaryHeap::new();
    let mut checks = 0usize;
    state[0] = State::Open;
    cost[0] = 0.0;
    heap.push(Open(0.0, 0));
    // Neighbour lists are asked for again and again (each node both as `z`
    // and as a candidate `x`): compute each once.
    let mut cache: Vec<Option<Vec<u32>>> = vec![None; n];
    let mut scratch = Vec::new();
    let knn = |p: Vec2, out: &mut Vec<u32>, k: usize| {
        // Nearest k within the search radius (ties by index).
        out.sort_by(|a, b| {
            let (da, db) = (
                samples[*a as usize].distance(p),
                samples[*b as usize].distance(p),
            );
            da.total_cmp(&db).then(a.cmp(b))
        });
        out.truncate(k + 1);
    };
    let mut reached_goal = false;
    let mut new_open: Vec<usize> = Vec::new();
    while let Some(Open(_, z)) = heap.pop() {
        if state[z] != State::Open {
            continue;
        }
        if z == 1 {
            reached_goal = true;
            break;
        }
        let mut neighbours = |i: usize, cache: &mut Vec<Option<Vec<u32>>>| -> Vec<u32> {
            if let Some(v) = &cache[i] {
                return v.clone();
            }
            buckets.near(&samples, samples[i], r, &mut scratch);
            if let Radius::KNearest(k) = cfg.radius {
                knn(samples[i], &mut scratch, k);
            }
            cache[i] = Some(scratch.clone());
            scratch.clone()
        };
        let near_z = neighbours(z, &mut cache);
        new_open.clear();
        for &xi in &near_z {
            let x = xi as usize;
            if state[x] != State::Unvisited {
                continue;
            }
            let near_x = neighbours(x, &mut cache);
            let best = near_x
                .iter()
                .map(|&y| y as usize)
                .filter(|&y| state[y] == State::Open)
                .map(|y| (cost[y] + samples[y].distance(samples[x]), y))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
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
            heap.push(Open(cost[x], x));
        }
        state[z] = State::Closed;
    }
    if !reached_goal {
        return Err(FmtError::NoPath {
            samples: n - 2,
            reached: parent.iter().filter(|p| p.is_some()).count(),
        });
    }
    let mut path = vec![samples[1]];
    let mut cur = 1;
    while let Some(p) = parent[cur] {
        path.push(samples[p]);
        cur = p;
    }
    path.reverse();
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
