//! The road network: a parsed map plus the indices queries need.

use crate::geometry::Shape;
use crate::model::{Cubic, Lane, LinkTarget, OpenDrive, Road};
use crate::parse::{MapError, Warning, parse};
use crate::road::{Direction, LaneSpan};
use litesim_core::{Pose, Vec2, math, wrap_angle};
use serde::Serialize;
use std::collections::{BTreeMap, BinaryHeap};

/// A point in road coordinates.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RoadPosition {
    /// Road id.
    pub road: String,
    /// Lane id (0 when on the centre line exactly between sides).
    pub lane: i32,
    /// s along the reference line (m).
    pub s: f64,
    /// t from the reference line (m, left positive).
    pub t: f64,
    /// Offset from the lane centre (m, left positive).
    pub offset: f64,
}

/// [`RoadPosition`] with the road as its index in `od.roads`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Located {
    /// Road index.
    pub road: usize,
    /// Lane id.
    pub lane: i32,
    /// s along the reference line (m).
    pub s: f64,
    /// t from the reference line (m, left positive).
    pub t: f64,
    /// Offset from the lane centre (m, left positive).
    pub offset: f64,
}

/// A lane in the routing graph: a lane of one lane section.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub struct LaneRef {
    /// Road index.
    pub road: usize,
    /// Section index.
    pub section: usize,
    /// Lane id.
    pub lane: i32,
}

/// What a scenario engine wants to know about a road.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RoadSummary {
    /// Road id.
    pub id: String,
    /// Length (m).
    pub length: f64,
    /// Junction it belongs to.
    pub junction: Option<String>,
    /// Fewest drivable lanes along +s over the road's sections.
    pub min_forward_lanes: usize,
    /// Fewest drivable lanes along −s.
    pub min_backward_lanes: usize,
    /// Most drivable lanes (both directions) in any section.
    pub max_driving_lanes: usize,
    /// All drivable lanes run the same way (and there is at least one).
    pub one_way: bool,
    /// One of its ends touches a junction (a path along it leads into or
    /// out of the junction).
    pub into_junction: bool,
}

/// A sampled lane: centre and both borders, for export, drawing and rasterising.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LanePolyline {
    /// Road id.
    pub road: String,
    /// Section index.
    pub section: usize,
    /// Lane id.
    pub lane: i32,
    /// Lane type.
    pub kind: String,
    /// Centre line.
    pub center: Vec<Vec2>,
    /// Inner border.
    pub inner: Vec<Vec2>,
    /// Outer border.
    pub outer: Vec<Vec2>,
    /// The lane's road marks along its outer border, one run per
    /// `<roadMark>` record (from its `sOffset` to the next record); for the
    /// centre lane (id 0, which has no width) along the reference line.
    pub marks: Vec<MarkRun>,
}

/// A stretch of one road mark, as a polyline to draw.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MarkRun {
    /// OpenDRIVE type: `solid`, `broken`, `solid solid`, `none`, …
    pub kind: String,
    /// OpenDRIVE colour: `standard` (white), `yellow`, …
    pub color: String,
    /// Line width (m).
    pub width: f64,
    /// The border points the mark covers.
    pub points: Vec<Vec2>,
}

#[derive(Clone, Debug)]
struct Segment {
    road: usize,
    s0: f64,
    s1: f64,
    a: Vec2,
    b: Vec2,
}

/// Uniform grid over reference-line segments, padded by each road's width.
#[derive(Clone, Debug, Default)]
struct SegmentIndex {
    cell: f64,
    origin: Vec2,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<u32>>,
    /// Per cell: the one road all its segments belong to, `u32::MAX` when
    /// none or several.
    single: Vec<u32>,
    segments: Vec<Segment>,
}

impl SegmentIndex {
    fn cell_of(&self, p: Vec2) -> Option<usize> {
        let i = ((p.x - self.origin.x) / self.cell).floor();
        let j = ((p.y - self.origin.y) / self.cell).floor();
        if i < 0.0 || j < 0.0 || i >= self.nx as f64 || j >= self.ny as f64 {
            return None;
        }
        Some(j as usize * self.nx + i as usize)
    }
}

/// Largest map file [`RoadNetwork::load`] reads (bytes): 256 MiB.
pub const MAX_MAP_BYTES: u64 = 256 * 1024 * 1024;

/// A loaded OpenDRIVE road network.
#[derive(Clone, Debug)]
pub struct RoadNetwork {
    /// The parsed file.
    pub od: OpenDrive,
    /// Warnings found while loading.
    pub warnings: Vec<Warning>,
    index: BTreeMap<String, usize>,
    segments: SegmentIndex,
    graph: BTreeMap<LaneRef, Vec<(LaneRef, f64)>>,
    edges: Vec<EdgeBounds>,
    /// Per road: every lane centre keeps its distance from the reference
    /// line along the whole road (one section, constant widths and lane
    /// offset), so a lane's heading is the reference line's.
    parallel: Vec<bool>,
}

/// A disc every point of which is on a road (see
/// [`RoadNetwork::surely_on_road`]): a point inside needs no map lookup to
/// know it is not off road.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurelyOnRoad {
    centre: Vec2,
    radius: f64,
}

impl SurelyOnRoad {
    /// True when `p` lies strictly inside the disc.
    pub fn contains(&self, p: Vec2) -> bool {
        let d = p - self.centre;
        d.dot(d) < self.radius * self.radius
    }
}

/// What [`RoadNetwork::on_road_radius`] needs to know about a road: how
/// fast its outer edges can move sideways and its reference line can turn,
/// and where either may jump.
#[derive(Clone, Debug, Default)]
struct EdgeBounds {
    /// Bound on |d(edge t)/ds| between breaks: the lane offset's slope plus
    /// the sum of one side's lane-width slopes.
    slope: f64,
    /// Bound on the reference line's |curvature| (infinite for polynomial
    /// shapes, whose curvature is not bounded cheaply: no radius there).
    curvature: f64,
    /// Road s of every section, width/border/offset record and geometry
    /// start, sorted: edges and headings are continuous between them.
    breaks: Vec<f64>,
}

impl EdgeBounds {
    fn of(r: &Road) -> Self {
        // |b + 2c·x + 3d·x²| on [0, len].
        let slope = |c: &Cubic, len: f64| {
            let len = len.max(0.0);
            c.b.abs() + 2.0 * c.c.abs() * len + 3.0 * c.d.abs() * len * len
        };
        let max_slope = |recs: &[Cubic], base: f64, end: f64| {
            recs.iter()
                .enumerate()
                .map(|(i, c)| {
                    let next = recs.get(i + 1).map_or(end, |n| base + n.s);
                    slope(c, next - (base + c.s))
                })
                .fold(0.0, f64::max)
        };
        let mut breaks = vec![0.0, r.length];
        breaks.extend(r.lane_offsets.iter().map(|c| c.s));
        breaks.extend(r.plan_view.iter().map(|g| g.s));
        let offset = max_slope(&r.lane_offsets, 0.0, r.length);
        let mut lanes: f64 = 0.0;
        for (k, sec) in r.sections.iter().enumerate() {
            let end = r.sections.get(k + 1).map_or(r.length, |n| n.s);
            breaks.push(sec.s);
            let mut side = |ls: &[Lane]| {
                let mut sum = 0.0;
                for l in ls {
                    for recs in [&l.widths, &l.borders] {
                        breaks.extend(recs.iter().map(|c| sec.s + c.s));
                        sum += max_slope(recs, sec.s, end);
                    }
                }
                sum
            };
            let (left, right) = (side(&sec.left), side(&sec.right));
            lanes = lanes.max(left).max(right);
        }
        let curvature = r
            .plan_view
            .iter()
            .map(|g| match g.shape {
                Shape::Line => 0.0,
                Shape::Arc { curvature } => curvature.abs(),
                Shape::Spiral {
                    curv_start,
                    curv_end,
                } => curv_start.abs().max(curv_end.abs()),
                Shape::Poly3 { .. } | Shape::ParamPoly3 { .. } => f64::INFINITY,
            })
            .fold(0.0, f64::max);
        breaks.retain(|b| b.is_finite());
        breaks.sort_by(f64::total_cmp);
        breaks.dedup();
        Self {
            slope: offset + lanes,
            curvature,
            breaks,
        }
    }
}

/// Step (m) that keeps a chord within `tol` of an arc of curvature `k`.
/// How often the lane sampler may halve a first step (the first step is
/// already sized by the curvature; halving serves width changes).
pub const MAX_REFINE_DEPTH: u32 = 6;

/// Pieces the lane sampler may test per lane section (about 0.1 s of
/// work): enough for 0.1 mm on kilometres of ordinary road.
pub const MAX_REFINED_PIECES: usize = 50_000;

/// Distance from `p` to the segment `a`–`b`.
fn seg_distance(p: Vec2, a: Vec2, b: Vec2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let u = litesim_core::segment_fraction(p, a, b - a);
    let (fx, fy) = (a.x + dx * u, a.y + dy * u);
    ((p.x - fx).powi(2) + (p.y - fy).powi(2)).sqrt()
}

/// The piece of `r` from `s` to its next breakpoint (geometry, offset and
/// width records included) is straight: a line of the plan view, a lane
/// offset and every lane width of `sec` constant there (their records'
/// b = c = d = 0; border records are not looked into).
fn straight_between(r: &Road, sec: &crate::model::LaneSection, s: f64) -> bool {
    let at = |v: &[crate::model::Cubic], x: f64| v.partition_point(|c| c.s <= x).max(1) - 1;
    let flat = |c: &crate::model::Cubic| c.b == 0.0 && c.c == 0.0 && c.d == 0.0;
    let line = !r.plan_view.is_empty()
        && matches!(
            r.plan_view[r.geometry_index(s)].shape,
            crate::geometry::Shape::Line
        );
    let offset = r.lane_offsets.is_empty() || flat(&r.lane_offsets[at(&r.lane_offsets, s)]);
    let widths = sec.left.iter().chain(&sec.right).all(|l| {
        l.borders.is_empty() && (l.widths.is_empty() || flat(&l.widths[at(&l.widths, s - sec.s)]))
    });
    line && offset && widths
}

fn step_for(k: f64, tol: f64, max: f64) -> f64 {
    if k.abs() < 1e-9 {
        max
    } else {
        (8.0 * tol / k.abs()).sqrt().clamp(0.05, max)
    }
}

impl RoadNetwork {
    /// Loads an `.xodr` file ([`RoadNetwork::read_text`], then
    /// [`RoadNetwork::from_xodr`]).
    pub fn load(path: &std::path::Path) -> Result<Self, MapError> {
        Self::from_xodr(&Self::read_text(path)?, &path.display().to_string())
    }

    /// Reads a map file's text, the one guarded read of a map: only a
    /// regular file of at most [`MAX_MAP_BYTES`] is read: a FIFO, a device
    /// (`/dev/zero`) or a directory is refused at once, before it is opened
    /// (opening a FIFO would wait for a writer).
    pub fn read_text(path: &std::path::Path) -> Result<String, MapError> {
        let fail = |message: String| MapError {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            path: String::new(),
            message,
        };
        litesim_core::files::read_text(path, MAX_MAP_BYTES).map_err(|e| match e {
            litesim_core::files::ReadError::Io { source, .. } => {
                fail(format!("cannot read: {source}"))
            }
            litesim_core::files::ReadError::NotAFile { kind, .. } => fail(format!(
                "not a regular file (a {kind}): a map is an OpenDRIVE file"
            )),
            litesim_core::files::ReadError::TooLarge { len, .. } => fail(format!(
                "{len} bytes; maps are at most {MAX_MAP_BYTES} bytes"
            )),
            other => fail(other.reason()),
        })
    }

    /// Builds a network from OpenDRIVE text; `file` names it in messages.
    pub fn from_xodr(text: &str, file: &str) -> Result<Self, MapError> {
        let (od, mut warnings) = parse(text, file)?;
        let index: BTreeMap<String, usize> = od
            .roads
            .iter()
            .enumerate()
            .map(|(i, r)| (r.id.clone(), i))
            .collect();
        let mut net = Self {
            od,
            warnings: Vec::new(),
            index,
            segments: SegmentIndex::default(),
            graph: BTreeMap::new(),
            edges: Vec::new(),
            parallel: Vec::new(),
        };
        net.edges = net.od.roads.iter().map(EdgeBounds::of).collect();
        net.parallel = net.od.roads.iter().map(lanes_parallel).collect();
        net.build_segments();
        net.build_graph(&mut warnings);
        net.warnings = warnings;
        Ok(net)
    }

    /// Roads in file order.
    pub fn roads(&self) -> &[Road] {
        &self.od.roads
    }

    /// A road by id.
    pub fn road(&self, id: &str) -> Option<&Road> {
        self.index.get(id).map(|&i| &self.od.roads[i])
    }

    /// A road's index by id.
    pub fn road_index(&self, id: &str) -> Option<usize> {
        self.index.get(id).copied()
    }

    /// Total reference-line length (m).
    pub fn total_length(&self) -> f64 {
        self.od.roads.iter().map(|r| r.length).sum()
    }

    fn build_segments(&mut self) {
        let mut segs = Vec::new();
        let mut pad = Vec::new();
        for (ri, r) in self.od.roads.iter().enumerate() {
            let width = r
                .sections
                .iter()
                .map(|sec| {
                    let mid = (sec.s + 0.01).min(r.length);
                    r.lane_spans(mid)
                        .iter()
                        .map(|l| l.t_outer.abs())
                        .fold(0.0, f64::max)
                })
                .fold(0.0, f64::max)
                + r.lane_offsets.iter().map(|o| o.a.abs()).fold(0.0, f64::max);
            let mut s = 0.0;
            let mut p = r.reference(0.0);
            while s < r.length {
                let step = step_for(p.curvature, 0.02, 2.0);
                let s1 = (s + step).min(r.length);
                let q = r.reference(s1);
                segs.push(Segment {
                    road: ri,
                    s0: s,
                    s1,
                    a: Vec2::new(p.x, p.y),
                    b: Vec2::new(q.x, q.y),
                });
                // A lane wider than a kilometre is a bogus map: its index
                // padding is capped so that every segment covers a bounded
                // number of cells.
                pad.push(width.min(1000.0) + 0.5);
                s = s1;
                p = q;
            }
        }
        let (mut lo, mut hi) = (Vec2::new(f64::MAX, f64::MAX), Vec2::new(f64::MIN, f64::MIN));
        for (sg, w) in segs.iter().zip(&pad) {
            for p in [sg.a, sg.b] {
                lo = Vec2::new(lo.x.min(p.x - w), lo.y.min(p.y - w));
                hi = Vec2::new(hi.x.max(p.x + w), hi.y.max(p.y + w));
            }
        }
        // 8 m cells, coarser where that would make more than MAX_CELLS of
        // them (a map spread over a huge area, or a bogus lane width):
        // the index stays a bounded size whatever the input.
        const MAX_CELLS: f64 = 4_000_000.0;
        let area = (hi.x - lo.x).max(1e-3) * (hi.y - lo.y).max(1e-3);
        let cell = 8.0f64.max((area / MAX_CELLS).sqrt());
        let nx = (((hi.x - lo.x) / cell).ceil() as usize).clamp(1, 20_000);
        let ny = (((hi.y - lo.y) / cell).ceil() as usize).clamp(1, 20_000);
        let cell = ((hi.x - lo.x) / nx as f64)
            .max((hi.y - lo.y) / ny as f64)
            .max(1e-3);
        let mut idx = SegmentIndex {
            cell,
            origin: lo,
            nx,
            ny,
            cells: vec![Vec::new(); nx * ny],
            single: Vec::new(),
            segments: Vec::new(),
        };
        for (k, (sg, w)) in segs.iter().zip(&pad).enumerate() {
            let i0 = ((sg.a.x.min(sg.b.x) - w - lo.x) / cell).floor().max(0.0) as usize;
            let i1 = (((sg.a.x.max(sg.b.x) + w - lo.x) / cell).floor() as usize).min(nx - 1);
            let j0 = ((sg.a.y.min(sg.b.y) - w - lo.y) / cell).floor().max(0.0) as usize;
            let j1 = (((sg.a.y.max(sg.b.y) + w - lo.y) / cell).floor() as usize).min(ny - 1);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    idx.cells[j * nx + i].push(k as u32);
                }
            }
        }
        idx.single = idx
            .cells
            .iter()
            .map(|c| {
                let mut roads = c.iter().map(|&k| segs[k as usize].road as u32);
                match roads.next() {
                    Some(r) if roads.all(|x| x == r) => r,
                    _ => u32::MAX,
                }
            })
            .collect();
        idx.segments = segs;
        self.segments = idx;
    }

    /// The road position of a world point: the lane it lies in (drivable or
    /// not), or `None` when it is on no road. Overlapping roads (junctions)
    /// are resolved in favour of the nearest lane centre.
    pub fn to_road(&self, p: Vec2) -> Option<RoadPosition> {
        self.locate(p).map(|l| RoadPosition {
            road: self.od.roads[l.road].id.clone(),
            lane: l.lane,
            s: l.s,
            t: l.t,
            offset: l.offset,
        })
    }

    /// [`RoadNetwork::to_road`] with the road as an index into `od.roads`:
    /// no allocation, for callers that ask for every vehicle at every step.
    pub fn locate(&self, p: Vec2) -> Option<Located> {
        let cell = self.segments.cell_of(p)?;
        // Nearest segment per road first, then refine once per road. A cell
        // holds a few roads: they live on the stack (the list of a crowded
        // junction cell spills to the heap).
        let mut inline = [(usize::MAX, 0.0f64, 0.0f64); 8];
        let mut used = 0usize;
        let mut spill: Vec<(usize, f64, f64)> = Vec::new();
        for &k in &self.segments.cells[cell] {
            let sg = &self.segments.segments[k as usize];
            let d = sg.b - sg.a;
            let u = litesim_core::segment_fraction(p, sg.a, d);
            let foot = sg.a + d * u;
            let e = p - foot;
            let dist2 = e.dot(e);
            let s = sg.s0 + (sg.s1 - sg.s0) * u;
            let entry = inline[..used]
                .iter_mut()
                .chain(spill.iter_mut())
                .find(|(r, _, _)| *r == sg.road);
            match entry {
                Some(entry) if dist2 < entry.2 => *entry = (sg.road, s, dist2),
                Some(_) => {}
                None if used < 8 => {
                    inline[used] = (sg.road, s, dist2);
                    used += 1;
                }
                None => spill.push((sg.road, s, dist2)),
            }
        }
        let mut best: Option<Located> = None;
        for &(ri, s_guess, _) in inline[..used].iter().chain(spill.iter()) {
            let Some(here) = self.on_road(ri, p, s_guess).0 else {
                continue;
            };
            if best.is_none_or(|b| here.offset.abs() < b.offset.abs()) {
                best = Some(here);
            }
        }
        best
    }

    /// [`RoadNetwork::locate`] for a point that moved a little since it was
    /// at `hint`: where the point's grid cell holds that road alone, the
    /// projection starts from the hint's s instead of searching the cell's
    /// segments (what makes a per-step off-road check of every vehicle
    /// cheap). Falls back to the full search when the cell holds other roads
    /// too or the projection does not settle.
    pub fn locate_near(&self, p: Vec2, hint: Option<Located>) -> Option<Located> {
        let cell = self.segments.cell_of(p)?;
        match hint {
            Some(h) if self.segments.single[cell] == h.road as u32 => {
                match self.on_road(h.road, p, h.s) {
                    (found, true) => found,
                    (_, false) => self.locate(p),
                }
            }
            _ => self.locate(p),
        }
    }

    /// A distance within which every point is on a road, given that `at`
    /// is where [`RoadNetwork::locate`] put a point: a caller that checks
    /// each vehicle each step for leaving the road checks again only once
    /// the vehicle has moved that far (0 where the map gives no bound:
    /// polynomial reference lines, a point at a section or record border).
    ///
    /// Why it holds: moving a distance d changes the point's t by at most d
    /// and its s by at most d·c, c = 1/(1 − κ·|t|) on a reference line of
    /// curvature ≤ κ; between breaks the road's edges move by at most
    /// slope·Δs. The radius keeps t inside the edges and s between breaks,
    /// with a 10 % and 1 cm reserve for rounding.
    pub fn on_road_radius(&self, at: &Located) -> f64 {
        let (Some(r), Some(b)) = (self.od.roads.get(at.road), self.edges.get(at.road)) else {
            return 0.0;
        };
        if !(b.curvature.is_finite() && b.slope.is_finite()) {
            return 0.0;
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        r.find_span(at.s, |l| {
            if l.width() > 1e-3 {
                lo = lo.min(l.t_inner.min(l.t_outer));
                hi = hi.max(l.t_inner.max(l.t_outer));
            }
            false
        });
        let m_t = (at.t - lo).min(hi - at.t) - 0.01;
        let i = b.breaks.partition_point(|&x| x <= at.s);
        let prev = if i > 0 { b.breaks[i - 1] } else { 0.0 };
        let next = b.breaks.get(i).copied().unwrap_or(r.length);
        let m_s = (at.s - prev).min(next - at.s);
        let k = b.curvature * (at.t.abs() + m_t.max(0.0));
        if !(m_t > 0.0 && m_s > 0.0 && k < 0.5) {
            return 0.0;
        }
        let c = 1.0 / (1.0 - k);
        0.9 * (m_t / (1.0 + b.slope * c)).min(m_s / c)
    }

    /// The disc of [`RoadNetwork::on_road_radius`] around `p`, which
    /// [`RoadNetwork::locate`] put at `at`.
    pub fn surely_on_road(&self, p: Vec2, at: &Located) -> SurelyOnRoad {
        SurelyOnRoad {
            centre: p,
            radius: self.on_road_radius(at),
        }
    }

    /// The point on road `ri` (projection refined from `s_guess`), if it
    /// lies in one of its lanes; and whether the projection settled.
    fn on_road(&self, ri: usize, p: Vec2, s_guess: f64) -> (Option<Located>, bool) {
        let road = &self.od.roads[ri];
        let (s, t, beyond, settled) = refine(road, p, s_guess);
        // A point past either end of this road projects onto the end:
        // it is not on this road (a junction road starting there would
        // otherwise claim points of the road leading into it).
        if beyond > BEYOND_END_M {
            return (None, settled);
        }
        let found = road
            .find_span(s, |l| l.width() > 1e-3 && l.contains(t))
            .map(|span| Located {
                road: ri,
                lane: span.id,
                s,
                t,
                offset: t - span.t_center(),
            });
        (found, settled)
    }

    /// World pose at (road, lane, s) plus a lateral offset from the lane
    /// centre; heading along the lane's direction of travel.
    pub fn lane_pose(&self, road: &str, lane: i32, s: f64, offset: f64) -> Option<Pose> {
        self.lane_pose_at(self.road_index(road)?, lane, s, offset)
    }

    /// Whether road `road`'s lane centres all keep their distance from its
    /// reference line (one lane section, constant widths and lane offset);
    /// there a lane's heading is the reference line's. Panics on an index
    /// out of range.
    pub fn lanes_parallel(&self, road: usize) -> bool {
        self.parallel[road]
    }

    /// [`RoadNetwork::lane_pose`] on road index `road` (the planner walks
    /// lanes by index: no lookup by name per sample). Panics on an index
    /// out of range.
    pub fn lane_pose_at(&self, road: usize, lane: i32, s: f64, offset: f64) -> Option<Pose> {
        let r = &self.od.roads[road];
        let span = r.lane_span(s, lane)?;
        let t = span.t_center() + offset;
        let (x, y, z, h) = r.st_to_xyz_hdg(s, t);
        // Lane centre heading: road heading + atan(dt/ds), by a central
        // difference — exactly 0 where the lanes run parallel to the
        // reference line (the two spans are the same sums of constants).
        let ds = 0.05;
        let (a, b) = ((s - ds).max(0.0), (s + ds).min(r.length));
        let dt = if self.parallel[road] {
            0.0
        } else {
            r.lane_span(b, lane).map_or(0.0, |l| l.t_center())
                - r.lane_span(a, lane).map_or(0.0, |l| l.t_center())
        };
        let mut yaw = h + if b > a { math::atan(dt / (b - a)) } else { 0.0 };
        if r.lane_direction(s, lane) == Direction::Backward {
            yaw += std::f64::consts::PI;
        }
        let mut pose = Pose::planar(x, y, wrap_angle(yaw));
        pose.position.z = z;
        Some(pose)
    }

    /// Summaries of all roads (for scenario elaboration).
    pub fn road_summaries(&self) -> Vec<RoadSummary> {
        self.od
            .roads
            .iter()
            .map(|r| {
                let mut min_f = usize::MAX;
                let mut min_b = usize::MAX;
                let mut max_all = 0;
                for sec in &r.sections {
                    let mid = (sec.s + 0.01).min(r.length);
                    let (mut f, mut b) = (0, 0);
                    for l in sec
                        .left
                        .iter()
                        .chain(sec.right.iter())
                        .filter(|l| l.is_drivable())
                    {
                        match r.lane_direction(mid, l.id) {
                            Direction::Forward => f += 1,
                            Direction::Backward => b += 1,
                            Direction::Both => {
                                f += 1;
                                b += 1;
                            }
                        }
                    }
                    min_f = min_f.min(f);
                    min_b = min_b.min(b);
                    max_all = max_all.max(
                        sec.left
                            .iter()
                            .chain(sec.right.iter())
                            .filter(|l| l.is_drivable())
                            .count(),
                    );
                }
                let (min_f, min_b) = (min_f.min(max_all), min_b.min(max_all));
                RoadSummary {
                    id: r.id.clone(),
                    length: r.length,
                    junction: r.junction.clone(),
                    min_forward_lanes: min_f,
                    min_backward_lanes: min_b,
                    max_driving_lanes: max_all,
                    into_junction: [&r.predecessor, &r.successor]
                        .iter()
                        .any(|l| matches!(l, Some(crate::model::LinkTarget::Junction(_)))),
                    one_way: max_all > 0
                        && (min_f == 0 || min_b == 0)
                        && r.sections.iter().all(|sec| {
                            let mid = (sec.s + 0.01).min(r.length);
                            let dirs: std::collections::BTreeSet<_> = sec
                                .left
                                .iter()
                                .chain(sec.right.iter())
                                .filter(|l| l.is_drivable())
                                .map(|l| r.lane_direction(mid, l.id) as u8)
                                .collect();
                            dirs.len() <= 1 && !dirs.contains(&(Direction::Both as u8))
                        }),
                }
            })
            .collect()
    }

    /// Free spawn poses along a lane every `spacing` m, at least `clearance` m
    /// from every point in `occupied`, in the lane's direction of travel.
    pub fn spawn_positions(
        &self,
        road: &str,
        lane: i32,
        spacing: f64,
        clearance: f64,
        occupied: &[Vec2],
    ) -> Vec<Pose> {
        let Some(r) = self.road(road) else {
            return Vec::new();
        };
        if !(spacing.is_finite() && spacing > 0.0) {
            return Vec::new();
        }
        let mut out = Vec::new();
        let mut s = spacing / 2.0;
        while s < r.length {
            if let Some(p) = self.lane_pose(road, lane, s, 0.0) {
                let xy = p.position.xy();
                if occupied.iter().all(|o| o.distance(xy) >= clearance) {
                    out.push(p);
                }
            }
            s += spacing;
        }
        out
    }

    /// Centre and border polylines of every lane (not the zero-width centre
    /// lanes), within `tolerance` m of the true curves: a sample where
    /// geometry pieces meet, lane offsets and lane width/border records
    /// change and road marks start; between them, pieces are halved until
    /// every lane line's exact points at a quarter, half and three quarters
    /// of each piece lie within `tolerance` of its chord
    /// (`tests/export_tolerance.rs` checks every 2 cm of every example map).
    pub fn lane_polylines(&self, tolerance: f64) -> Vec<LanePolyline> {
        let mut all = self.all_lane_polylines(tolerance);
        all.retain(|l| l.lane != 0);
        all
    }

    /// Every road mark of the map (lane borders and centre lines), as runs
    /// within `tolerance` m of the true curves, in road, section and lane
    /// order.
    pub fn road_marks(&self, tolerance: f64) -> Vec<MarkRun> {
        self.all_lane_polylines(tolerance)
            .into_iter()
            .flat_map(|l| l.marks)
            .collect()
    }

    /// [`Self::lane_polylines`] plus the centre lanes (id 0: all three lines
    /// along the reference line, carrying the centre marks) — what a
    /// drawing of the road needs, in one pass.
    pub fn all_lane_polylines(&self, tolerance: f64) -> Vec<LanePolyline> {
        let tol = tolerance.max(1e-4);
        let mut out = Vec::new();
        for r in &self.od.roads {
            for (si, sec) in r.sections.iter().enumerate() {
                let s_end = r.sections.get(si + 1).map_or(r.length, |n| n.s);
                if s_end - sec.s < 1e-6 {
                    continue;
                }
                // Breakpoints: where geometry pieces meet, lane offsets and
                // lane widths/borders change record — the lines may bend
                // sharply (or jump) there, so a sample sits on each.
                let mut ss = vec![sec.s, s_end];
                let inside = |x: f64| x > sec.s + 1e-9 && x < s_end - 1e-9;
                ss.extend(r.plan_view.iter().map(|g| g.s).filter(|x| inside(*x)));
                // A record may jump: a sample just before it too (on the
                // old record), so that the jump is one short step.
                let mut records: Vec<f64> = r.lane_offsets.iter().map(|c| c.s).collect();
                for l in sec.left.iter().chain(&sec.right) {
                    records.extend(l.widths.iter().chain(&l.borders).map(|c| sec.s + c.s));
                }
                for x in records {
                    if inside(x) {
                        ss.push(x);
                        if inside(x - 1e-6) {
                            ss.push(x - 1e-6);
                        }
                    }
                }
                ss.sort_by(f64::total_cmp);
                ss.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
                // Between breakpoints: a first step from the curvature, then
                // halving every piece until each lane border's exact points
                // at a quarter, half and three quarters of it are within
                // `tol` of the chord (checked against the exact evaluation).
                let mut fine = Vec::with_capacity(ss.len() * 4);
                let mut budget = MAX_REFINED_PIECES;
                for w in ss.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    let mut s = a;
                    fine.push(a);
                    // A straight reference with constant widths and offset:
                    // every border is a straight line, its two ends exact.
                    if straight_between(r, sec, a) {
                        continue;
                    }
                    while s < b - 1e-9 {
                        let k = r.reference(s).curvature.abs();
                        let next = (s + step_for(k, tol, 5.0)).min(b);
                        self.refine_piece(r, sec, (s, next), s_end, tol, 0, &mut budget, &mut fine);
                        s = next;
                    }
                }
                fine.push(s_end);
                let mut ss = fine;
                // A sample where each road mark starts, so that runs meet.
                let starts = sec
                    .center
                    .iter()
                    .chain(&sec.left)
                    .chain(&sec.right)
                    .flat_map(|l| &l.road_marks)
                    .map(|m| sec.s + m.s_offset)
                    .filter(|s| *s > sec.s && *s < s_end);
                ss.extend(starts);
                ss.sort_by(f64::total_cmp);
                ss.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
                // The centre lane's marks run along the reference line
                // (the inner border of lanes ±1).
                let first = sec.left.first().or(sec.right.first()).map(|l| l.id);
                let lanes = sec
                    .center
                    .iter()
                    .chain(sec.left.iter())
                    .chain(sec.right.iter());
                for lane in lanes {
                    let span_id = if lane.id == 0 { first } else { Some(lane.id) };
                    let Some(span_id) = span_id else { continue };
                    let mut pl = LanePolyline {
                        road: r.id.clone(),
                        section: si,
                        lane: lane.id,
                        kind: lane.kind.clone(),
                        center: Vec::with_capacity(ss.len()),
                        inner: Vec::with_capacity(ss.len()),
                        outer: Vec::with_capacity(ss.len()),
                        marks: Vec::new(),
                    };
                    // s of each border point, to cut the mark runs.
                    let mut at = Vec::with_capacity(ss.len());
                    for &s in &ss {
                        // Evaluate just inside the section at its end.
                        let se = if s >= s_end {
                            (s_end - 1e-6).max(sec.s)
                        } else {
                            s
                        };
                        if let Some(span) = r.lane_span(se, span_id) {
                            let pt = |t: f64| {
                                let (x, y, _) = r.st_to_xyz(se, t);
                                Vec2::new(x, y)
                            };
                            if lane.id == 0 {
                                let c = pt(span.t_inner);
                                pl.center.push(c);
                                pl.inner.push(c);
                                pl.outer.push(c);
                            } else {
                                pl.center.push(pt(span.t_center()));
                                pl.inner.push(pt(span.t_inner));
                                pl.outer.push(pt(span.t_outer));
                            }
                            at.push(s);
                        }
                    }
                    pl.marks = mark_runs(&lane.road_marks, sec.s, &at, &pl.outer);
                    out.push(pl);
                }
            }
        }
        out
    }

    /// Adds the samples in (a, b] that keep every lane border of the
    /// section within `tol` of its chords (bisecting up to
    /// [`MAX_REFINE_DEPTH`] times: at most 64 pieces per first step, and at most `budget` pieces per
    /// section — absurd but finite maps, a lane width growing as s³, must
    /// not take minutes: past the budget pieces are taken as they are).
    #[allow(clippy::too_many_arguments)]
    fn refine_piece(
        &self,
        r: &Road,
        sec: &crate::model::LaneSection,
        (a, b): (f64, f64),
        s_end: f64,
        tol: f64,
        depth: u32,
        budget: &mut usize,
        out: &mut Vec<f64>,
    ) {
        *budget = budget.saturating_sub(1);
        let inside = |s: f64| {
            if s >= s_end {
                (s_end - 1e-6).max(sec.s)
            } else {
                s
            }
        };
        let borders = |s: f64| -> Vec<Vec2> {
            let s = inside(s);
            let mut v = Vec::new();
            for span in r.lane_spans(s) {
                for t in [span.t_inner, span.t_outer, span.t_center()] {
                    let (x, y, _) = r.st_to_xyz(s, t);
                    v.push(Vec2::new(x, y));
                }
            }
            v
        };
        let ok = depth >= MAX_REFINE_DEPTH || *budget == 0 || {
            let (pa, pb) = (borders(a), borders(b));
            [0.25, 0.5, 0.75].iter().all(|u| {
                let pm = borders(a + (b - a) * u);
                pm.len() == pa.len()
                    && pa.len() == pb.len()
                    && pm
                        .iter()
                        .zip(pa.iter().zip(&pb))
                        .all(|(m, (p, q))| seg_distance(*m, *p, *q) <= tol)
            })
        };
        if ok {
            out.push(b);
        } else {
            let m = 0.5 * (a + b);
            self.refine_piece(r, sec, (a, m), s_end, tol, depth + 1, budget, out);
            self.refine_piece(r, sec, (m, b), s_end, tol, depth + 1, budget, out);
        }
    }

    /// Lane spans of a road at `s` (convenience).
    pub fn lane_spans(&self, road: &str, s: f64) -> Vec<LaneSpan> {
        self.road(road).map(|r| r.lane_spans(s)).unwrap_or_default()
    }

    fn lane_ref(&self, road: usize, at_start: bool, lane: i32) -> Option<LaneRef> {
        let r = &self.od.roads[road];
        let section = if at_start { 0 } else { r.sections.len() - 1 };
        let sec = &r.sections[section];
        sec.left
            .iter()
            .chain(sec.right.iter())
            .any(|l| l.id == lane && l.is_drivable())
            .then_some(LaneRef {
                road,
                section,
                lane,
            })
    }

    fn lane_length(&self, n: LaneRef) -> f64 {
        let r = &self.od.roads[n.road];
        let s0 = r.sections[n.section].s;
        let s1 = r.sections.get(n.section + 1).map_or(r.length, |x| x.s);
        (s1 - s0).max(0.0)
    }

    fn build_graph(&mut self, warnings: &mut Vec<Warning>) {
        let mut graph: BTreeMap<LaneRef, Vec<(LaneRef, f64)>> = BTreeMap::new();
        let mut dropped = 0usize;
        for (ri, r) in self.od.roads.iter().enumerate() {
            for (si, sec) in r.sections.iter().enumerate() {
                let mid = (sec.s + 0.01).min(r.length);
                for lane in sec
                    .left
                    .iter()
                    .chain(sec.right.iter())
                    .filter(|l| l.is_drivable())
                {
                    let node = LaneRef {
                        road: ri,
                        section: si,
                        lane: lane.id,
                    };
                    let dirs: &[bool] = match r.lane_direction(mid, lane.id) {
                        Direction::Forward => &[true],
                        Direction::Backward => &[false],
                        Direction::Both => &[true, false],
                    };
                    for &forward in dirs {
                        let mut next = Vec::new();
                        let link = if forward {
                            lane.successor
                        } else {
                            lane.predecessor
                        };
                        let neighbour_section = if forward { si + 1 } else { si.wrapping_sub(1) };
                        if neighbour_section < r.sections.len() {
                            let id = link.unwrap_or(lane.id);
                            let ns = &r.sections[neighbour_section];
                            if ns
                                .left
                                .iter()
                                .chain(ns.right.iter())
                                .any(|l| l.id == id && l.is_drivable())
                            {
                                next.push(LaneRef {
                                    road: ri,
                                    section: neighbour_section,
                                    lane: id,
                                });
                            }
                        } else {
                            let target = if forward {
                                &r.successor
                            } else {
                                &r.predecessor
                            };
                            match target {
                                Some(LinkTarget::Road { id, at_start }) => {
                                    let to = link.unwrap_or(lane.id);
                                    match self
                                        .index
                                        .get(id)
                                        .and_then(|&t| self.lane_ref(t, *at_start, to))
                                    {
                                        Some(n) => next.push(n),
                                        None => dropped += 1,
                                    }
                                }
                                Some(LinkTarget::Junction(jid)) => {
                                    for j in self.od.junctions.iter().filter(|j| &j.id == jid) {
                                        for c in j.connections.iter().filter(|c| c.incoming == r.id)
                                        {
                                            for &(from, to) in &c.lane_links {
                                                if from != lane.id {
                                                    continue;
                                                }
                                                match self
                                                    .index
                                                    .get(&c.connecting)
                                                    .and_then(|&t| self.lane_ref(t, c.at_start, to))
                                                {
                                                    Some(n) => next.push(n),
                                                    None => dropped += 1,
                                                }
                                            }
                                        }
                                    }
                                }
                                None => {}
                            }
                        }
                        let cost = self.lane_length(node);
                        graph
                            .entry(node)
                            .or_default()
                            .extend(next.into_iter().map(|n| (n, cost)));
                    }
                }
            }
        }
        if dropped > 0 {
            warnings.push(Warning {
                line: 0,
                path: "OpenDRIVE".into(),
                message: format!("{dropped} lane link(s) point at lanes that do not exist or are not drivable; dropped"),
            });
        }
        for v in graph.values_mut() {
            v.sort_by_key(|a| a.0);
            v.dedup_by(|a, b| a.0 == b.0);
        }
        self.graph = graph;
    }

    /// All lanes of a type (`driving`, `sidewalk`, …), in file order.
    pub fn lanes_of_type(&self, kind: &str) -> Vec<LaneRef> {
        let mut out = Vec::new();
        for (ri, r) in self.od.roads.iter().enumerate() {
            for (si, sec) in r.sections.iter().enumerate() {
                for l in sec
                    .left
                    .iter()
                    .chain(sec.right.iter())
                    .filter(|l| l.kind == kind)
                {
                    out.push(LaneRef {
                        road: ri,
                        section: si,
                        lane: l.id,
                    });
                }
            }
        }
        out
    }

    /// Footprints of road objects as world polygons (boxes, or 16-gons for round objects).
    pub fn object_footprints(&self) -> Vec<(String, Vec<Vec2>)> {
        let mut out = Vec::new();
        for r in &self.od.roads {
            for o in &r.objects {
                let (x, y, _) = r.st_to_xyz(o.s, o.t);
                let c = Vec2::new(x, y);
                let h = r.reference(o.s).hdg + o.hdg;
                let poly: Vec<Vec2> = if o.radius > 0.0 {
                    (0..16)
                        .map(|k| {
                            c + Vec2::from_heading(k as f64 * std::f64::consts::PI / 8.0) * o.radius
                        })
                        .collect()
                } else if o.length > 0.0 && o.width > 0.0 {
                    let f = Vec2::from_heading(h) * (o.length / 2.0);
                    let n = Vec2::from_heading(h + std::f64::consts::FRAC_PI_2) * (o.width / 2.0);
                    vec![c + f + n, c - f + n, c - f - n, c + f - n]
                } else {
                    continue;
                };
                out.push((o.id.clone(), poly));
            }
        }
        out
    }

    /// Lanes reachable from `from` in one move along the direction of travel.
    pub fn successors(&self, from: LaneRef) -> Vec<LaneRef> {
        self.graph
            .get(&from)
            .map(|v| v.iter().map(|(n, _)| *n).collect())
            .unwrap_or_default()
    }

    /// The drivable lane node of (road, lane) at s.
    pub fn lane_at(&self, road: &str, lane: i32, s: f64) -> Option<LaneRef> {
        let ri = self.road_index(road)?;
        let section = self.od.roads[ri].section_index(s);
        let node = LaneRef {
            road: ri,
            section,
            lane,
        };
        self.graph.contains_key(&node).then_some(node)
    }

    /// Shortest route (by lane length, Dijkstra) from one lane node to another.
    pub fn route(&self, from: LaneRef, to: LaneRef) -> Option<Vec<LaneRef>> {
        #[derive(PartialEq)]
        struct Item(f64, LaneRef);
        impl Eq for Item {}
        impl PartialOrd for Item {
            fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
                Some(self.cmp(o))
            }
        }
        impl Ord for Item {
            fn cmp(&self, o: &Self) -> std::cmp::Ordering {
                o.0.total_cmp(&self.0).then_with(|| o.1.cmp(&self.1))
            }
        }
        let mut dist: BTreeMap<LaneRef, f64> = BTreeMap::new();
        let mut prev: BTreeMap<LaneRef, LaneRef> = BTreeMap::new();
        let mut heap = BinaryHeap::new();
        dist.insert(from, 0.0);
        heap.push(Item(0.0, from));
        while let Some(Item(d, n)) = heap.pop() {
            if n == to {
                let mut path = vec![to];
                let mut cur = to;
                while let Some(&p) = prev.get(&cur) {
                    path.push(p);
                    cur = p;
                }
                path.reverse();
                return Some(path);
            }
            if d > dist.get(&n).copied().unwrap_or(f64::INFINITY) {
                continue;
            }
            for &(m, w) in self.graph.get(&n).into_iter().flatten() {
                let nd = d + w;
                if nd < dist.get(&m).copied().unwrap_or(f64::INFINITY) {
                    dist.insert(m, nd);
                    prev.insert(m, n);
                    heap.push(Item(nd, m));
                }
            }
        }
        None
    }
}

/// Newton refinement of the foot point on the reference line:
/// g(s) = (P − C(s))·T(s) = 0, g'(s) = −1 + κ (P − C(s))·N(s).
/// How far past a road's end (m) a point may lie and still count as on it
/// (the Newton refinement leaves millimetres on curves).
const BEYOND_END_M: f64 = 0.05;

/// Projects `p` onto the road's reference line by Newton steps from `s`:
/// (s, t, how far `p` lies beyond the road's ends along the line (0
/// inside), whether the last step was below 1 mm). A step below 1 nm is not
/// taken: the reference point already evaluated is the answer (one road
/// evaluation fewer per call; this runs for every vehicle at every step).
fn refine(road: &Road, p: Vec2, mut s: f64) -> (f64, f64, f64, bool) {
    let mut settled = false;
    let mut r = road.reference(s);
    for _ in 0..3 {
        let (sn, cs) = math::sin_cos(r.hdg);
        let (dx, dy) = (p.x - r.x, p.y - r.y);
        let along = dx * cs + dy * sn;
        let across = -dx * sn + dy * cs;
        let d = 1.0 - r.curvature * across;
        let step = if d.abs() > 1e-6 { along / d } else { along };
        let ns = (s + step).clamp(0.0, road.length);
        settled = (ns - s).abs() < 1e-3;
        if (ns - s).abs() < 1e-9 {
            break;
        }
        s = ns;
        r = road.reference(s);
    }
    let (sn, cs) = math::sin_cos(r.hdg);
    let t = -(p.x - r.x) * sn + (p.y - r.y) * cs;
    let along = (p.x - r.x) * cs + (p.y - r.y) * sn;
    let beyond = if s <= 0.0 {
        (-along).max(0.0)
    } else if s >= road.length {
        along.max(0.0)
    } else {
        0.0
    };
    (s, t, beyond, settled)
}

/// Cuts a border (points at road positions `at`) into one run per road-mark
/// record; records apply from `section_s + sOffset` to the next record.
/// Neighbouring runs share their boundary point so that the drawing has no
/// gap.
fn mark_runs(
    marks: &[crate::model::RoadMark],
    section_s: f64,
    at: &[f64],
    border: &[Vec2],
) -> Vec<MarkRun> {
    let mut sorted: Vec<&crate::model::RoadMark> = marks.iter().collect();
    sorted.sort_by(|a, b| a.s_offset.total_cmp(&b.s_offset));
    let mut runs = Vec::new();
    for (k, m) in sorted.iter().enumerate() {
        let from = section_s + m.s_offset;
        let to = sorted
            .get(k + 1)
            .map_or(f64::INFINITY, |n| section_s + n.s_offset);
        let points: Vec<Vec2> = at
            .iter()
            .zip(border)
            .filter(|(s, _)| **s >= from - 1e-9 && **s <= to + 1e-9)
            .map(|(_, p)| *p)
            .collect();
        if points.len() >= 2 {
            runs.push(MarkRun {
                kind: m.kind.clone(),
                color: m.color.clone(),
                width: m.width,
                points,
            });
        }
    }
    runs
}

/// Whether every lane centre of `r` keeps its distance from the reference
/// line: one lane section, a lane offset that is one constant record from
/// s = 0 (or none), and each lane's width one constant record.
fn lanes_parallel(r: &Road) -> bool {
    let constant = |c: &Cubic| c.b == 0.0 && c.c == 0.0 && c.d == 0.0 && c.a.is_finite();
    let offset_ok = match r.lane_offsets.as_slice() {
        [] => true,
        [o] => o.s <= 0.0 && constant(o),
        _ => false,
    };
    offset_ok
        && r.sections.len() == 1
        && r.sections[0]
            .left
            .iter()
            .chain(&r.sections[0].right)
            .all(|l| matches!(l.widths.as_slice(), [w] if constant(w)))
}
