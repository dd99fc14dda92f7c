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
#[derive(Debug, thiserror::Error)]
pub enum GridError {
    /// Resolution not positive and finite.
    #[error("resolution must be positive and finite, got {0} m")]
    BadResolution(f64),
    /// Width or height not positive and finite.
    #[error("grid size must be positive and finite, got {0} × {1} m")]
    BadSize(f64, f64),
    /// An obstacle with NaN/inf coordinates, negative radius or < 3 polygon points.
    #[error(
        "obstacle {0} is malformed (non-finite coordinates, negative radius, inverted rectangle or < 3 polygon points)"
    )]
    BadObstacle(usize),
    /// The image could not be decoded.
    #[error("not a readable PNG: {0}")]
    Image(#[source] png::DecodingError),
    /// The decoded image would not fit in memory.
    #[error("not a readable PNG: image too large")]
    ImageTooLarge,
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

/// An obstacle for [`OccupancyGrid::from_obstacles`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "shape")]
pub enum Obstacle {
    /// Axis-aligned rectangle `[min, max]`.
    Rect {
        /// Lower-left corner (m).
        min: [f64; 2],
        /// Upper-right corner (m).
        max: [f64; 2],
    },
    /// Disc.
    Circle {
        /// Centre (m).
        center: [f64; 2],
        /// Radius (m).
        radius: f64,
    },
    /// Simple polygon (any orientation; even–odd rule).
    Polygon {
        /// Vertices (m).
        points: Vec<[f64; 2]>,
    },
}

impl Obstacle {
    fn contains(&self, p: Vec2) -> bool {
        match self {
            Obstacle::Rect { min, max } => {
                p.x >= min[0] && p.x <= max[0] && p.y >= min[1] && p.y <= max[1]
            }
            Obstacle::Circle { center, radius } => {
                p.distance(Vec2::new(center[0], center[1])) <= *radius
            }
            Obstacle::Polygon { points } => {
                let mut inside = false;
                let n = points.len();
                for i in 0..n {
                    let (a, b) = (points[i], points[(i + n - 1) % n]);
                    if (a[1] > p.y) != (b[1] > p.y)
                        && p.x < (b[0] - a[0]) * (p.y - a[1]) / (b[1] - a[1]) + a[0]
                    {
                        inside = !inside;
                    }
                }
                inside
            }
        }
    }
    fn bounds(&self) -> (Vec2, Vec2) {
        match self {
            Obstacle::Rect { min, max } => (Vec2::new(min[0], min[1]), Vec2::new(max[0], max[1])),
            Obstacle::Circle { center, radius } => (
                Vec2::new(center[0] - radius, center[1] - radius),
                Vec2::new(center[0] + radius, center[1] + radius),
            ),
            Obstacle::Polygon { points } => points.iter().fold(
                (Vec2::new(f64::MAX, f64::MAX), Vec2::new(f64::MIN, f64::MIN)),
                |(lo, hi), p| {
                    (
                        Vec2::new(lo.x.min(p[0]), lo.y.min(p[1])),
                        Vec2::new(hi.x.max(p[0]), hi.y.max(p[1])),
                    )
                },
            ),
        }
    }
    fn is_valid(&self) -> bool {
        match self {
            Obstacle::Rect { min, max } => {
                min.iter().chain(max).all(|v| v.is_finite()) && min[0] <= max[0] && min[1] <= max[1]
            }
            Obstacle::Circle { center, radius } => {
                center.iter().all(|v| v.is_finite()) && radius.is_finite() && *radius >= 0.0
            }
            Obstacle::Polygon { points } => {
                points.len() >= 3 && points.iter().flatten().all(|v| v.is_finite())
            }
        }
    }
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
    /// A grid of `size` metres (width, height) at `origin`, free except
    /// under the obstacles; cells whose centre lies in an obstacle are occupied.
    pub fn from_obstacles(
        origin: Vec2,
        size: (f64, f64),
        resolution: f64,
        obstacles: &[Obstacle],
    ) -> Result<Self, GridError> {
        if !(size.0.is_finite() && size.1.is_finite() && size.0 > 0.0 && size.1 > 0.0) {
            return Err(GridError::BadSize(size.0, size.1));
        }
        if let Some(i) = obstacles.iter().position(|o| !o.is_valid()) {
            return Err(GridError::BadObstacle(i));
        }
        let mut g = Self::new(
            origin,
            Vec2::new(origin.x + size.0, origin.y + size.1),
            resolution,
        )?;
        for o in obstacles {
            let (lo, hi) = o.bounds();
            let r = g.resolution;
            let i0 = ((lo.x - g.origin.x) / r - 0.5).ceil().max(0.0) as usize;
            let j0 = ((lo.y - g.origin.y) / r - 0.5).ceil().max(0.0) as usize;
            let i1 = ((hi.x - g.origin.x) / r - 0.5)
                .floor()
                .min(g.width as f64 - 1.0);
            let j1 = ((hi.y - g.origin.y) / r - 0.5)
                .floor()
                .min(g.height as f64 - 1.0);
            if i1 < 0.0 || j1 < 0.0 {
                continue;
            }
            for j in j0..=j1 as usize {
                for i in i0..=i1 as usize {
                    if o.contains(g.center(i, j)) {
                        g.occupied[j * g.width + i] = true;
                    }
                }
            }
        }
        Ok(g)
    }

    /// Reads a PNG: dark pixels (luma < 128) are obstacles, light ones free;
    /// image row 0 is the top (largest y). `origin` is the lower-left corner.
    pub fn from_png(bytes: &[u8], resolution: f64, origin: Vec2) -> Result<Self, GridError> {
        let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
        dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let mut reader = dec.read_info().map_err(GridError::Image)?;
        let (w, h) = (reader.info().width as usize, reader.info().height as usize);
        if w.saturating_mul(h) > MAX_CELLS {
            return Err(GridError::TooLarge {
                width: w,
                height: h,
                max: MAX_CELLS,
            });
        }
        let mut buf = vec![
            0;
            reader
                .output_buffer_size()
                .ok_or(GridError::ImageTooLarge)?
        ];
        let info = reader.next_frame(&mut buf).map_err(GridError::Image)?;
        let channels = info.color_type.samples();
        let mut g = Self::new(
            origin,
            Vec2::new(
                origin.x + w as f64 * resolution,
                origin.y + h as f64 * resolution,
            ),
            resolution,
        )?;
        g.width = w;
        g.height = h;
        g.occupied = vec![false; w * h];
        for row in 0..h {
            for col in 0..w {
                let px = &buf[row * info.line_size + col * channels..][..channels];
                let luma = match channels {
                    1 | 2 => px[0] as f64,
                    _ => 0.299 * px[0] as f64 + 0.587 * px[1] as f64 + 0.114 * px[2] as f64,
                };
                g.occupied[(h - 1 - row) * w + col] = luma < 128.0;
            }
        }
        Ok(g)
    }

    /// Number of free cells.
    pub fn free_cells(&self) -> usize {
        self.occupied.iter().filter(|o| !**o).count()
    }

    /// Marks every cell whose centre lies in the convex quadrilateral `q` as `value`.
    pub fn fill_quad(&mut self, q: [Vec2; 4], value: bool) {
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
