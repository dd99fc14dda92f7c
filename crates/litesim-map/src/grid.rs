//! Occupancy grids: the raster type shared by maps and the planner.

use crate::network::RoadNetwork;
use litesim_core::Vec2;
use serde::{Deserialize, Serialize};

/// A row-major occupancy grid. Cell (i, j) covers
/// `[origin.x + i·res, origin.x + (i+1)·res) × [origin.y + j·res, …)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Cell size (m).
    pub resolution: f64,
    /// World position of the corner of cell (0, 0) (m).
    pub origin: Vec2,
    /// `true` = occupied (not drivable).
    pub occupied: Vec<bool>,
}

/// Why a grid could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GridError {
    /// Resolution not positive and finite.
    #[error("resolution must be positive and finite, got {0} m")]
    BadResolution(f64),
    /// More cells than allowed.
    #[error("a {width} × {height} grid has more than {max} cells; use a coarser resolution")]
    TooLarge {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
        /// Limit.
        max: usize,
    },
}

/// Largest grid built (cells): 100 M cells = 100 MB.
pub const MAX_CELLS: usize = 100_000_000;

impl OccupancyGrid {
    /// An all-free grid covering `[lo, hi]`.
    pub fn new(lo: Vec2, hi: Vec2, resolution: f64) -> Result<Self, GridError> {
        if !(resolution.is_finite() && resolution > 0.0) {
            return Err(GridError::BadResolution(resolution));
        }
        let width = ((hi.x - lo.x) / resolution).ceil().max(1.0);
        let height = ((hi.y - lo.y) / resolution).ceil().max(1.0);
        // Written so that a NaN extent is refused too.
        let cells = width * height;
        if cells.is_nan() || cells > MAX_CELLS as f64 {
            return Err(GridError::TooLarge {
                width: width.min(usize::MAX as f64) as usize,
                height: height.min(usize::MAX as f64) as usize,
                max: MAX_CELLS,
            });
        }
        let (width, height) = (width as usize, height as usize);
        Ok(Self {
            width,
            height,
            resolution,
            origin: lo,
            occupied: vec![false; width * height],
        })
    }
    /// The cell containing a world point.
    pub fn cell(&self, p: Vec2) -> Option<(usize, usize)> {
        let i = ((p.x - self.origin.x) / self.resolution).floor();
        let j = ((p.y - self.origin.y) / self.resolution).floor();
        (i >= 0.0 && j >= 0.0 && (i as usize) < self.width && (j as usize) < self.height)
            .then_some((i as usize, j as usize))
    }
    /// Centre of a cell.
    pub fn center(&self, i: usize, j: usize) -> Vec2 {
        Vec2::new(
            self.origin.x + (i as f64 + 0.5) * self.resolution,
            self.origin.y + (j as f64 + 0.5) * self.resolution,
        )
    }
    /// Whether a world point is occupied (outside the grid counts as occupied).
    pub fn is_occupied(&self, p: Vec2) -> bool {
        self.cell(p)
            .is_none_or(|(i, j)| self.occupied[j * self.width + i])
    }
    /// Number of free cells.
    pub fn free_cells(&self) -> usize {
        self.occupied.iter().filter(|o| !**o).count()
    }

    /// Marks every cell whose centre lies in the convex quadrilateral `q` as `value`.
    fn fill_quad(&mut self, q: [Vec2; 4], value: bool) {
        let (mut lo, mut hi) = (q[0], q[0]);
        for p in &q[1..] {
            lo = Vec2::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = Vec2::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        let r = self.resolution;
        let i0 = (((lo.x - self.origin.x) / r - 0.5).ceil().max(0.0)) as usize;
        let j0 = (((lo.y - self.origin.y) / r - 0.5).ceil().max(0.0)) as usize;
        let i1 = (((hi.x - self.origin.x) / r - 0.5).floor()).min(self.width as f64 - 1.0);
        let j1 = (((hi.y - self.origin.y) / r - 0.5).floor()).min(self.height as f64 - 1.0);
        if i1 < 0.0 || j1 < 0.0 {
            return;
        }
        // Orientation-independent inside test: all edge crosses have one sign.
        for j in j0..=j1 as usize {
            for i in i0..=i1 as usize {
                let c = self.center(i, j);
                let mut pos = false;
                let mut neg = false;
                for k in 0..4 {
                    let (a, b) = (q[k], q[(k + 1) % 4]);
                    let x = (b - a).cross(c - a);
                    pos |= x > 1e-12;
                    neg |= x < -1e-12;
                }
                if !(pos && neg) {
                    self.occupied[j * self.width + i] = value;
                }
            }
        }
    }
}

impl RoadNetwork {
    /// Rasterises the drivable lanes: free where a vehicle may drive,
    /// occupied elsewhere (and under road objects), with `margin` m of
    /// occupied border around the map.
    pub fn rasterise(&self, resolution: f64, margin: f64) -> Result<OccupancyGrid, GridError> {
        let lanes = self.lane_polylines((resolution / 4.0).max(0.01));
        let (mut lo, mut hi) = (Vec2::new(f64::MAX, f64::MAX), Vec2::new(f64::MIN, f64::MIN));
        for l in &lanes {
            for p in l.outer.iter().chain(l.inner.iter()) {
                lo = Vec2::new(lo.x.min(p.x), lo.y.min(p.y));
                hi = Vec2::new(hi.x.max(p.x), hi.y.max(p.y));
            }
        }
        if lo.x > hi.x {
            lo = Vec2::new(0.0, 0.0);
            hi = lo;
        }
        let m = margin.max(0.0);
        let mut g = OccupancyGrid::new(
            Vec2::new(lo.x - m, lo.y - m),
            Vec2::new(hi.x + m, hi.y + m),
            resolution,
        )?;
        g.occupied.iter_mut().for_each(|c| *c = true);
        for l in lanes.iter().filter(|l| {
            self.road(&l.road)
                .and_then(|r| r.sections.get(l.section))
                .and_then(|s| s.left.iter().chain(s.right.iter()).find(|x| x.id == l.lane))
                .is_some_and(|x| x.is_drivable())
        }) {
            for k in 1..l.inner.len().min(l.outer.len()) {
                g.fill_quad(
                    [l.inner[k - 1], l.inner[k], l.outer[k], l.outer[k - 1]],
                    false,
                );
            }
        }
        for r in self.roads() {
            for o in &r.objects {
                let (x, y, _) = r.st_to_xyz(o.s, o.t);
                let h = r.reference(o.s).hdg + o.hdg;
                let (hl, hw) = if o.radius > 0.0 {
                    (o.radius, o.radius)
                } else {
                    (o.length / 2.0, o.width / 2.0)
                };
                if hl <= 0.0 || hw <= 0.0 {
                    continue;
                }
                let f = Vec2::from_heading(h);
                let n = Vec2::new(-f.y, f.x);
                let c = Vec2::new(x, y);
                g.fill_quad(
                    [
                        c + f * hl + n * hw,
                        c - f * hl + n * hw,
                        c - f * hl - n * hw,
                        c + f * hl - n * hw,
                    ],
                    true,
                );
            }
        }
        Ok(g)
    }
}
