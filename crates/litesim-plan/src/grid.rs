//! The planning grid: an occupancy grid with an exact Euclidean distance
//! transform and the seed's three layers — free space, inflated safety
//! margin, hard obstacle.

use litesim_core::Vec2;
use litesim_map::OccupancyGrid;
use serde::{Deserialize, Serialize};

/// What a cell is for planning.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Layer {
    /// Farther than `radius + margin` from every obstacle.
    Free,
    /// Within the safety margin (`radius + margin`) of an obstacle.
    Inflated,
    /// An obstacle cell.
    Hard,
}

/// "No site" in the squared-distance transform: large but finite, so the
/// parabola intersections stay well-defined.
const FAR: f64 = 1e20;

/// Exact squared Euclidean distance transform of one line (Felzenszwalb &
/// Huttenlocher 2012, lower envelope of parabolas): `f` holds 0 at sites and
/// [`FAR`] elsewhere.
fn edt_1d(f: &[f64], out: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    if n == 0 {
        return;
    }
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let fq = f[q] + (q * q) as f64;
        let mut s;
        loop {
            let p = v[k];
            s = (fq - (f[p] + (p * p) as f64)) / (2.0 * (q - p) as f64);
            if s <= z[k] && k > 0 {
                k -= 1;
            } else {
                break;
            }
        }
        if s <= z[k] {
            // k == 0 and the new parabola dominates from −∞.
            v[0] = q;
            z[1] = f64::INFINITY;
            continue;
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    let mut k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let p = v[k];
        *o = (q as f64 - p as f64).powi(2) + f[p];
    }
}

/// Distance (m) from each cell centre to the nearest obstacle cell centre;
/// +∞ when there is no obstacle at all.
pub fn distance_transform(g: &OccupancyGrid) -> Vec<f64> {
    let (w, h) = (g.width, g.height);
    let mut d: Vec<f64> = g
        .occupied
        .iter()
        .map(|&o| if o { 0.0 } else { FAR })
        .collect();
    let n = w.max(h);
    let (mut f, mut out, mut v, mut z) = (
        vec![0.0; n],
        vec![0.0; n],
        vec![0usize; n],
        vec![0.0; n + 1],
    );
    for x in 0..w {
        for y in 0..h {
            f[y] = d[y * w + x];
        }
        edt_1d(&f[..h], &mut out[..h], &mut v, &mut z);
        for y in 0..h {
            d[y * w + x] = out[y];
        }
    }
    for y in 0..h {
        f[..w].copy_from_slice(&d[y * w..(y + 1) * w]);
        edt_1d(&f[..w], &mut out[..w], &mut v, &mut z);
        d[y * w..(y + 1) * w].copy_from_slice(&out[..w]);
    }
    d.iter()
        .map(|&s| {
            if s >= FAR / 2.0 {
                f64::INFINITY
            } else {
                s.sqrt() * g.resolution
            }
        })
        .collect()
}

/// A grid ready for planning.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanningGrid {
    /// The occupancy.
    pub grid: OccupancyGrid,
    /// Distance to the nearest obstacle (m), per cell.
    pub distance: Vec<f64>,
    /// Vehicle radius (m): centres closer than this to an obstacle collide.
    pub radius: f64,
    /// Extra safety margin (m).
    pub margin: f64,
    /// Per cell: free for planning (the hot query of sampling and edge checks).
    free: Vec<bool>,
    /// The vehicle's footprint as circles of `radius` along its axis: the
    /// centres' offsets ahead of the reference point (m). Empty = a disc
    /// of `radius` at the reference point.
    #[serde(default)]
    pub footprint: Vec<f64>,
    /// The body the circles cover — length, width, and how far the
    /// reference point is ahead of the rear bumper (m) — checked exactly
    /// where the circles, which reach beyond it, do not fit
    /// ([`Self::pose_free`]). `None` for a disc vehicle.
    #[serde(default)]
    pub body: Option<[f64; 3]>,
    /// Summed-area table of the cells that are not free, (w+1)·(h+1)
    /// entries: a rectangle of cells is known free in four lookups, so an
    /// edge whose bounding box is clear skips its per-point walk. Rebuilt
    /// by the constructors; empty after deserialising (then every edge
    /// walks its points).
    #[serde(skip)]
    blocked_sum: Vec<u32>,
}

/// The summed-area table of `!free` over a `w × h` grid: entry
/// `(j, i)` of the `(w+1) × (h+1)` table counts the blocked cells in
/// rows `< j` and columns `< i`.
fn blocked_sum(free: &[bool], w: usize, h: usize) -> Vec<u32> {
    let mut s = vec![0u32; (w + 1) * (h + 1)];
    for j in 0..h {
        let mut row = 0u32;
        for i in 0..w {
            row += u32::from(!free[j * w + i]);
            s[(j + 1) * (w + 1) + i + 1] = s[j * (w + 1) + i + 1] + row;
        }
    }
    s
}

impl PlanningGrid {
    /// Computes the distance field and layers for a vehicle of `radius` m with `margin` m to spare.
    pub fn new(grid: OccupancyGrid, radius: f64, margin: f64) -> Self {
        // Beyond the map's edge is not drivable (the simulation counts a
        // body outside the map as a collision): the edge bounds every
        // distance like an obstacle one cell outside it.
        let mut distance = distance_transform(&grid);
        let (w, h, res) = (grid.width, grid.height, grid.resolution);
        for j in 0..h {
            for i in 0..w {
                let edge = (i + 1).min(j + 1).min(w - i).min(h - j) as f64 * res;
                let d = &mut distance[j * w + i];
                *d = d.min(edge);
            }
        }
        let (radius, margin) = (radius.max(0.0), margin.max(0.0));
        let need = radius + margin + 0.5 * grid.resolution;
        let free = grid
            .occupied
            .iter()
            .zip(&distance)
            .map(|(o, d)| !o && *d >= need)
            .collect::<Vec<bool>>();
        let blocked_sum = blocked_sum(&free, w, h);
        Self {
            grid,
            distance,
            radius,
            margin,
            free,
            footprint: Vec::new(),
            body: None,
            blocked_sum,
        }
    }

    /// A grid for a rectangular vehicle `length × width` whose reference
    /// point (the rear axle) is `rear` m ahead of its rear bumper: the body
    /// is covered by k circles along its axis, k = ⌈2·length / width⌉, each
    /// of radius √((w/2)² + (length/2k)²), so that every point of the
    /// rectangle is inside one. Collision checks then cover the whole body
    /// from bumper to bumper — a long vehicle's front swings wide of its
    /// rear axle in a turn.
    pub fn with_footprint(
        grid: OccupancyGrid,
        length: f64,
        width: f64,
        rear: f64,
        margin: f64,
    ) -> Self {
        let (length, width) = (length.max(1e-3), width.max(1e-3));
        let k = (2.0 * length / width).ceil().clamp(1.0, 64.0) as usize;
        let seg = length / k as f64;
        let radius = ((0.5 * width).powi(2) + (0.5 * seg).powi(2)).sqrt();
        let mut g = Self::new(grid, radius, margin);
        g.footprint = (0..k).map(|j| -rear + seg * (j as f64 + 0.5)).collect();
        g.body = Some([length, width, rear]);
        g
    }

    /// The same grid for the vehicle driven backwards: its body mirrored
    /// about the reference point, so that a pose's heading is the
    /// direction of travel (the body's heading + π). A path driven in
    /// reverse is then checked, smoothed and profiled like a forward one.
    pub fn reversed(&self) -> Self {
        let mut g = self.clone();
        g.footprint = self.footprint.iter().rev().map(|o| -o).collect();
        g.body = self
            .body
            .map(|[length, width, rear]| [length, width, length - rear]);
        g
    }

    /// The covering circles' offsets ahead of the reference point (a
    /// single 0 for a disc vehicle).
    fn offsets(&self) -> &[f64] {
        if self.footprint.is_empty() {
            &[0.0]
        } else {
            &self.footprint
        }
    }

    /// True when the vehicle at `p` heading `yaw` keeps the margin from
    /// every obstacle and the map's edge with its whole body: its covering
    /// circles fit (radius + margin), or else its rectangle does, checked
    /// exactly ([`Self::body_free`]).
    pub fn pose_free(&self, p: Vec2, yaw: f64) -> bool {
        self.pose_free_along(p, Vec2::from_heading(yaw))
    }

    /// [`Self::pose_free`] with the heading as a unit vector `f` (no
    /// trigonometry: searches that step along arcs rotate `f` instead).
    pub fn pose_free_along(&self, p: Vec2, f: Vec2) -> bool {
        self.circles_free_along(p, f) || self.body_free(p, f, 0.0)
    }

    /// The covering circles alone fit (radius + margin): more room than
    /// the body needs, which keeps a search from spending its poses along
    /// walls ([`crate::hybrid_astar`] checks the body exactly only while
    /// it leaves its start).
    pub fn circles_free_along(&self, p: Vec2, f: Vec2) -> bool {
        self.offsets().iter().all(|o| self.is_free(p + f * *o))
    }

    /// The body's rectangle at `p` heading along the unit vector `f` keeps
    /// `margin + extra` from every obstacle and the map's edge; false for
    /// a disc vehicle (no body). Circles that cover a rectangle reach
    /// beyond its sides and ends (a bus's by 0.13 m and 0.2 m), so a long
    /// vehicle 3 m from a wall, or starting near the map's edge, does not
    /// fit its circles where its body fits.
    ///
    /// Clearance is measured per cell (between cell centres, less half a
    /// cell), so it may drop by up to a cell's diagonal `r√2` between a
    /// point and one within half a cell of it. Points every cell along the
    /// outline keep `margin + extra + r√2`: every point of the outline is
    /// within half a cell of one, so every point of it keeps `margin +
    /// extra` as the planner (and the closed loop's check) measures it.
    /// Points every cell along the axis (less the margin at each end) keep
    /// more than `w/2 − margin + r√2`: an obstacle cell under the body lies
    /// at least `margin` inside the outline (or the outline's points would
    /// not keep theirs), so within `w/2 − margin` of that stretch of the
    /// axis, and such a point would be nearer.
    /// The outline's rule is stricter than the circles' along the sides and
    /// looser at the bumpers, where the circles reach far beyond the body.
    pub fn body_free(&self, p: Vec2, f: Vec2, extra: f64) -> bool {
        let Some(body) = self.body else {
            return false;
        };
        let s = self.grid.resolution.max(1e-3);
        let edge = self.margin + extra + s * std::f64::consts::SQRT_2;
        self.outline(body, p, f).all(|q| self.clearance(q) >= edge)
            && self
                .axis(body, p, f)
                .is_none_or(|(deep, mut points)| points.all(|q| self.clearance(q) > deep))
    }

    /// The axis rule of [`Self::body_free`]: the clearance an axis point
    /// must exceed (half the width less the margin, plus a cell's
    /// diagonal) and the points of the axis where an obstacle `margin`
    /// inside the outline can be, at most a cell apart; `None` where the
    /// rule asks nothing (a body narrower than twice its margin, or
    /// shorter).
    pub fn axis(
        &self,
        [length, width, rear]: [f64; 3],
        p: Vec2,
        f: Vec2,
    ) -> Option<(f64, impl Iterator<Item = Vec2>)> {
        let s = self.grid.resolution.max(1e-3);
        let deep = 0.5 * width - self.margin + s * std::f64::consts::SQRT_2;
        let (c0, c1) = (self.margin - rear, length - rear - self.margin);
        if deep <= 0.0 || c1 < c0 {
            return None;
        }
        let inner = ((c1 - c0) / s).ceil().max(1.0) as usize;
        Some((
            deep,
            (0..=inner).map(move |k| p + f * (c0 + (c1 - c0) * k as f64 / inner as f64)),
        ))
    }

    /// Points of the outline of `body` ([`Self::body`]) at `p` heading
    /// along the unit vector `f`, at most a cell apart along each side
    /// (corners included).
    fn outline(
        &self,
        [length, width, rear]: [f64; 3],
        p: Vec2,
        f: Vec2,
    ) -> impl Iterator<Item = Vec2> {
        let s = self.grid.resolution.max(1e-3);
        let n = Vec2::new(-f.y, f.x);
        let (a0, hw) = (-rear, 0.5 * width);
        let along = (length / s).ceil().max(1.0) as usize;
        let across = (width / s).ceil().max(1.0) as usize;
        let sides = (0..=along).flat_map(move |k| {
            let a = a0 + length * k as f64 / along as f64;
            [(a, -hw), (a, hw)]
        });
        let ends = (0..=across).flat_map(move |k| {
            let l = -hw + width * k as f64 / across as f64;
            [(a0, l), (a0 + length, l)]
        });
        sides.chain(ends).map(move |(a, l)| p + f * a + n * l)
    }

    /// The covering circle of the pose's footprint with the least
    /// clearance, and that clearance (m): where a pose that does not fit
    /// collides first (a circle fits with clearance ≥ radius + margin).
    pub fn tightest_circle(&self, p: Vec2, yaw: f64) -> (Vec2, f64) {
        let f = Vec2::from_heading(yaw);
        self.offsets()
            .iter()
            .map(|o| {
                let c = p + f * *o;
                (c, self.clearance(c))
            })
            .fold((p, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a })
    }

    /// The point of the body's outline (every cell along it) with the
    /// least clearance, that clearance, and the clearance the outline needs
    /// (the margin plus a cell's diagonal, [`Self::body_free`]); for a disc vehicle the tightest covering
    /// circle ([`Self::tightest_circle`]) and radius + margin.
    pub fn tightest_part(&self, p: Vec2, yaw: f64) -> (Vec2, f64, f64) {
        let Some(body) = self.body else {
            let (c, d) = self.tightest_circle(p, yaw);
            return (c, d, self.radius + self.margin);
        };
        let (q, d) = self
            .outline(body, p, Vec2::from_heading(yaw))
            .map(|q| (q, self.clearance(q)))
            .fold((p, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        let s = self.grid.resolution.max(1e-3);
        (q, d, self.margin + s * std::f64::consts::SQRT_2)
    }

    /// [`Self::pose_free`] with `extra` m more room than the margin.
    pub fn pose_free_with(&self, p: Vec2, yaw: f64, extra: f64) -> bool {
        let f = Vec2::from_heading(yaw);
        let need = self.radius + self.margin + extra;
        self.offsets()
            .iter()
            .all(|o| self.clearance(p + f * *o) >= need)
            || self.body_free(p, f, extra)
    }

    /// Clearance at a point (m); 0 outside the grid.
    pub fn clearance(&self, p: Vec2) -> f64 {
        match self.grid.cell(p) {
            Some((i, j)) => {
                let d = self.distance[j * self.grid.width + i];
                // Distances are between cell centres; half a cell of slack.
                (d - 0.5 * self.grid.resolution).max(0.0)
            }
            None => 0.0,
        }
    }
    /// The layer of a point.
    pub fn layer(&self, p: Vec2) -> Layer {
        if self.grid.is_occupied(p) {
            Layer::Hard
        } else if self.clearance(p) < self.radius + self.margin {
            Layer::Inflated
        } else {
            Layer::Free
        }
    }
    /// True when a vehicle centred at `p` keeps radius + margin from every obstacle.
    pub fn is_free(&self, p: Vec2) -> bool {
        // The cell lookup of `OccupancyGrid::cell` inlined: for a
        // coordinate ≥ 0 truncation is `floor`, and the sign test first
        // refuses what `floor` would put at −1 (and NaN) — the same cells,
        // without a libm call (this is the hot query of sampling and edge
        // walks).
        let g = &self.grid;
        let i = (p.x - g.origin.x) / g.resolution;
        let j = (p.y - g.origin.y) / g.resolution;
        if !(i >= 0.0 && j >= 0.0) {
            return false;
        }
        let (i, j) = (i as usize, j as usize);
        i < g.width && j < g.height && self.free[j * g.width + i]
    }
    /// Layer of each cell, row-major.
    pub fn layers(&self) -> Vec<Layer> {
        (0..self.grid.height)
            .flat_map(|j| (0..self.grid.width).map(move |i| (i, j)))
            .map(|(i, j)| self.layer(self.grid.center(i, j)))
            .collect()
    }
    /// Free area (m²), μ(X_free) of the FMT* radius.
    pub fn free_area(&self) -> f64 {
        let r2 = self.grid.resolution * self.grid.resolution;
        let need = self.radius + self.margin + 0.5 * self.grid.resolution;
        self.distance.iter().filter(|d| **d >= need).count() as f64 * r2
    }
    /// True when the vehicle driving straight from a to b stays free,
    /// checked every half cell. Along a straight line every covering
    /// circle's centre stays on the line, so the swept footprint is the
    /// segment from the rearmost centre at `a` to the foremost at `b`.
    pub fn segment_free(&self, a: Vec2, b: Vec2) -> bool {
        let (lo, hi) = self
            .offsets()
            .iter()
            .fold((0.0f64, 0.0f64), |(lo, hi), o| (lo.min(*o), hi.max(*o)));
        if lo == 0.0 && hi == 0.0 {
            return self.point_segment_free(a, b);
        }
        let d = b - a;
        let len = d.norm();
        if len <= 1e-12 {
            // No direction to place the body along: the centre only.
            return self.is_free(a);
        }
        let f = d * (1.0 / len);
        self.point_segment_free(a + f * lo, b + f * hi)
    }

    /// True when every cell of the box spanned by `a` and `b`, grown by
    /// one cell on each side, is inside the grid and free. The points of
    /// the walk between `a` and `b` lie in that box up to rounding far
    /// below a cell, so then the walk would find them all free: this
    /// answers yes only where the walk would, and the walk decides the
    /// rest (results are the same with or without it).
    fn box_free(&self, a: Vec2, b: Vec2) -> bool {
        let g = &self.grid;
        let (w, h) = (g.width, g.height);
        // `min`/`max` would drop a NaN coordinate: refuse those first.
        if self.blocked_sum.len() != (w + 1) * (h + 1) || !(a.is_finite() && b.is_finite()) {
            return false;
        }
        let inv = 1.0 / g.resolution;
        let (u0, v0) = (
            (a.x.min(b.x) - g.origin.x) * inv,
            (a.y.min(b.y) - g.origin.y) * inv,
        );
        let (u1, v1) = (
            (a.x.max(b.x) - g.origin.x) * inv,
            (a.y.max(b.y) - g.origin.y) * inv,
        );
        // Cells ⌊u0⌋−1 ..= ⌊u1⌋+1 (and the same in y) must exist: u0 ≥ 1
        // (then truncation is ⌊·⌋, without a libm call) and ⌊u1⌋+1 < w.
        if !(u0 >= 1.0 && v0 >= 1.0 && u1 + 1.0 < w as f64 && v1 + 1.0 < h as f64) {
            return false;
        }
        let (i0, j0) = (u0 as usize - 1, v0 as usize - 1);
        // ⌊u1⌋ ≤ w − 2 by the test above, so i1 ≤ w (and j1 ≤ h).
        let (i1, j1) = (u1 as usize + 2, v1 as usize + 2);
        let s = &self.blocked_sum;
        let row = w + 1;
        s[j1 * row + i1] + s[j0 * row + i0] == s[j0 * row + i1] + s[j1 * row + i0]
    }

    fn point_segment_free(&self, a: Vec2, b: Vec2) -> bool {
        self.box_free(a, b) || self.walk_free(a, b)
    }

    /// The points from `a` to `b` every half cell, each free.
    fn walk_free(&self, a: Vec2, b: Vec2) -> bool {
        let len = a.distance(b);
        let n = (len / (0.5 * self.grid.resolution)).ceil().max(1.0) as usize;
        (0..=n).all(|k| self.is_free(a.lerp(b, k as f64 / n as f64)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box shortcut answers yes only where the walk does, and often:
    /// random segments (some leaving the map, some NaN) on a grid with
    /// random obstacles.
    #[test]
    fn box_shortcut_agrees_with_the_walk() {
        let mut g = OccupancyGrid::new(Vec2::new(-3.0, 2.0), Vec2::new(20.0, 12.0), 0.2).unwrap();
        let mut rng = crate::rng::Rng::new(7);
        for _ in 0..40 {
            let i = (rng.unit() * g.width as f64) as usize;
            let j = (rng.unit() * g.height as f64) as usize;
            g.occupied[j * g.width + i] = true;
        }
        let pg = PlanningGrid::new(g, 0.3, 0.1);
        let (mut shortcuts, mut free) = (0, 0);
        for k in 0..20_000 {
            let pt = |rng: &mut crate::rng::Rng| {
                Vec2::new(-4.0 + rng.unit() * 22.0, 1.0 + rng.unit() * 14.0)
            };
            let a = pt(&mut rng);
            let mut b = a + (pt(&mut rng) - a) * (0.05 + 0.3 * rng.unit());
            if k % 997 == 0 {
                b.x = f64::NAN;
            }
            let walk = pg.walk_free(a, b);
            if pg.box_free(a, b) {
                assert!(walk, "box says free, walk does not: {a:?} → {b:?}");
                shortcuts += 1;
            }
            free += usize::from(walk);
            assert_eq!(pg.segment_free(a, b), walk);
        }
        assert!(shortcuts > free / 4, "{shortcuts} shortcuts of {free} free");
        let copy: PlanningGrid =
            serde_json::from_str(&serde_json::to_string(&pg).unwrap()).unwrap();
        assert!(!copy.box_free(Vec2::new(1.0, 5.0), Vec2::new(1.1, 5.0)));
    }

    /// The body check is sound: random grids (small obstacles, some deep
    /// inside where a body may stand) and random poses of a bus and a car;
    /// wherever it admits a pose, every point of the body's outline on a
    /// fine lattice (5 cm) keeps the margin as the planner measures
    /// clearance, and no obstacle cell lies under the body (inside, 5 cm
    /// lattice). It admits many poses the circles refuse.
    #[test]
    fn the_body_check_keeps_the_margin_everywhere_it_admits_a_pose() {
        let mut rng = crate::rng::Rng::new(11);
        let (mut body_only, mut both) = (0, 0);
        for (length, width, rear) in [(12.0, 2.55, 2.4), (4.6, 1.9, 1.0)] {
            for round in 0..6 {
                let mut g =
                    OccupancyGrid::new(Vec2::new(0.0, 0.0), Vec2::new(40.0, 24.0), 0.2).unwrap();
                for _ in 0..(10 + 15 * round) {
                    let i = (rng.unit() * g.width as f64) as usize;
                    let j = (rng.unit() * g.height as f64) as usize;
                    g.occupied[j * g.width + i] = true;
                }
                let pg = PlanningGrid::with_footprint(g, length, width, rear, 0.4);
                for _ in 0..4_000 {
                    let p = Vec2::new(rng.unit() * 40.0, rng.unit() * 24.0);
                    let yaw = (rng.unit() - 0.5) * 7.0;
                    let f = Vec2::from_heading(yaw);
                    if !pg.body_free(p, f, 0.0) {
                        continue;
                    }
                    if pg.circles_free_along(p, f) {
                        both += 1;
                    } else {
                        body_only += 1;
                    }
                    let n = Vec2::new(-f.y, f.x);
                    let (na, nl) = ((length / 0.05) as usize, (width / 0.05) as usize);
                    for a in 0..=na {
                        for l in 0..=nl {
                            let q = p
                                + f * (-rear + length * a as f64 / na as f64)
                                + n * (-0.5 * width + width * l as f64 / nl as f64);
                            assert!(
                                !pg.grid.is_occupied(q) && pg.grid.cell(q).is_some(),
                                "obstacle or the map's edge under the body at {q:?}"
                            );
                            let outline = a == 0 || a == na || l == 0 || l == nl;
                            if outline {
                                assert!(
                                    pg.clearance(q) >= 0.4 - 1e-9,
                                    "{q:?} of the body at {p:?} {yaw}: {}",
                                    pg.clearance(q)
                                );
                            }
                        }
                    }
                }
            }
        }
        assert!(body_only > 100 && both > 1_000, "{body_only} {both}");
    }

    /// A truck starting 1.6 m from the map's edge, heading away from it:
    /// its rear circle (1.37 m, plus 0.4 m of margin) does not fit, its
    /// body (1.05 m from the edge at the rear bumper) does; the tightest
    /// part named is on the rear bumper.
    #[test]
    fn a_long_body_fits_near_the_edge_where_its_circles_do_not() {
        let g = OccupancyGrid::new(Vec2::new(0.0, 0.0), Vec2::new(30.0, 30.0), 0.2).unwrap();
        let pg = PlanningGrid::with_footprint(g, 8.5, 2.5, 0.6 + 1.3, 0.4);
        let (p, yaw) = (Vec2::new(15.0, 3.0), std::f64::consts::FRAC_PI_2);
        assert!(!pg.circles_free_along(p, Vec2::from_heading(yaw)));
        assert!(pg.pose_free(p, yaw));
        let (at, clearance, need) = pg.tightest_part(p, yaw);
        assert!((at.y - 1.1).abs() < 1e-9, "{at:?}");
        assert!(
            clearance >= need && need == 0.4 + 0.2 * std::f64::consts::SQRT_2,
            "{clearance} {need}"
        );
        // Backed up to 0.6 m from the edge the body no longer keeps its margin.
        assert!(!pg.pose_free(Vec2::new(15.0, 2.5), yaw));
        // A disc vehicle has no body to fall back on.
        let disc = PlanningGrid::new(pg.grid.clone(), 1.4, 0.4);
        assert!(!disc.body_free(p, Vec2::from_heading(yaw), 0.0));
    }

    #[test]
    fn edt_is_exact_against_brute_force() {
        let mut g = OccupancyGrid::new(Vec2::new(0.0, 0.0), Vec2::new(13.0, 7.0), 1.0).unwrap();
        for &(i, j) in &[(2usize, 3usize), (9, 1), (12, 6), (5, 5)] {
            g.occupied[j * g.width + i] = true;
        }
        let d = distance_transform(&g);
        for j in 0..g.height {
            for i in 0..g.width {
                let brute = [(2, 3), (9, 1), (12, 6), (5, 5)]
                    .iter()
                    .map(|&(a, b): &(i32, i32)| {
                        (((i as i32 - a).pow(2) + (j as i32 - b).pow(2)) as f64).sqrt()
                    })
                    .fold(f64::INFINITY, f64::min);
                assert!((d[j * g.width + i] - brute).abs() < 1e-12, "({i},{j})");
            }
        }
        let empty = OccupancyGrid::new(Vec2::new(0.0, 0.0), Vec2::new(3.0, 3.0), 1.0).unwrap();
        assert!(distance_transform(&empty).iter().all(|d| d.is_infinite()));
    }
}
