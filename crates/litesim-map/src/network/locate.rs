//! Locating a point on the network: the segment index over every road's
//! reference line, road coordinates of a point, the lane it is in, and the
//! radius within which it surely stays on a road.

use super::*;

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

#[derive(Clone, Debug)]
pub(super) struct Segment {
    pub(super) road: usize,
    pub(super) s0: f64,
    pub(super) s1: f64,
    pub(super) a: Vec2,
    pub(super) b: Vec2,
}

/// Uniform grid over reference-line segments, padded by each road's width.
#[derive(Clone, Debug, Default)]
pub(super) struct SegmentIndex {
    pub(super) cell: f64,
    pub(super) origin: Vec2,
    pub(super) nx: usize,
    pub(super) ny: usize,
    pub(super) cells: Vec<Vec<u32>>,
    /// Per cell: the one road all its segments belong to, `u32::MAX` when
    /// none or several.
    pub(super) single: Vec<u32>,
    pub(super) segments: Vec<Segment>,
}

impl SegmentIndex {
    pub(super) fn cell_of(&self, p: Vec2) -> Option<usize> {
        let i = ((p.x - self.origin.x) / self.cell).floor();
        let j = ((p.y - self.origin.y) / self.cell).floor();
        if i < 0.0 || j < 0.0 || i >= self.nx as f64 || j >= self.ny as f64 {
            return None;
        }
        Some(j as usize * self.nx + i as usize)
    }
}

/// The question [`RoadNetwork::locate_near`] answers, reduced to what its
/// answer depends on (see [`RoadNetwork::near_query`]); compared bit for
/// bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NearQuery {
    x: u64,
    y: u64,
    /// The hint's road and s (bits), where the hint is used.
    from: Option<(usize, u64)>,
}

/// One [`RoadNetwork::locate_near`] answer kept with its question (see
/// [`RoadNetwork::locate_near_kept`]): a run keeps one per actor, so the
/// read-back and the drivers locate an actor once a step between them where
/// they ask the same question.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocateMemo {
    question: Option<NearQuery>,
    found: Option<Located>,
}

/// A disc every point of which is on a road (see
/// [`RoadNetwork::surely_on_road`]): a point inside needs no map lookup to
/// know it is not off road.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurelyOnRoad {
    pub(super) centre: Vec2,
    pub(super) radius: f64,
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
pub(super) struct EdgeBounds {
    /// Bound on |d(edge t)/ds| between breaks: the lane offset's slope plus
    /// the sum of one side's lane-width slopes.
    pub(super) slope: f64,
    /// Bound on the reference line's |curvature| (infinite for polynomial
    /// shapes, whose curvature is not bounded cheaply: no radius there).
    pub(super) curvature: f64,
    /// Road s of every section, width/border/offset record and geometry
    /// start, sorted: edges and headings are continuous between them.
    pub(super) breaks: Vec<f64>,
}

impl EdgeBounds {
    pub(super) fn of(r: &Road) -> Self {
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

/// Newton refinement of the foot point on the reference line:
/// g(s) = (P − C(s))·T(s) = 0, g'(s) = −1 + κ (P − C(s))·N(s).
/// How far past a road's end (m) a point may lie and still count as on it
/// (the Newton refinement leaves millimetres on curves).
pub(super) const BEYOND_END_M: f64 = 0.05;

/// Projects `p` onto the road's reference line by Newton steps from `s`:
/// (s, t, how far `p` lies beyond the road's ends along the line (0
/// inside), whether the last step was below 1 mm). A step below 1 nm is not
/// taken: the reference point already evaluated is the answer (one road
/// evaluation fewer per call; this runs for every vehicle at every step).
pub(super) fn refine(road: &Road, p: Vec2, mut s: f64) -> (f64, f64, f64, bool) {
    let mut settled = false;
    let mut r = road.reference(s);
    for _ in 0..3 {
        let (sn, cs) = r.sin_cos();
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
    let (sn, cs) = r.sin_cos();
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

impl RoadNetwork {
    pub(super) fn build_segments(&mut self) {
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
        self.answer(&self.near_query(p, hint))
    }

    /// What decides [`RoadNetwork::locate_near`]'s answer for `p` near
    /// `hint`: the point's bits and, where the hint is used at all (its
    /// road alone in the point's grid cell), its road and s — nothing else
    /// of the hint matters.
    pub fn near_query(&self, p: Vec2, hint: Option<Located>) -> NearQuery {
        let from = match (self.segments.cell_of(p), hint) {
            (Some(cell), Some(h)) if self.segments.single[cell] == h.road as u32 => {
                Some((h.road, h.s.to_bits()))
            }
            _ => None,
        };
        NearQuery {
            x: p.x.to_bits(),
            y: p.y.to_bits(),
            from,
        }
    }

    /// [`RoadNetwork::locate_near`], answered from `kept` when it holds the
    /// same question (another caller located the same actor at the same
    /// point this step); returns the answer and the memo to keep. Sharing
    /// it changes no result: the answer is a function of the question.
    pub fn locate_near_kept(
        &self,
        p: Vec2,
        hint: Option<Located>,
        kept: Option<&LocateMemo>,
    ) -> (Option<Located>, LocateMemo) {
        let q = self.near_query(p, hint);
        let found = match kept {
            Some(m) if m.question == Some(q) => m.found,
            _ => self.answer(&q),
        };
        let memo = LocateMemo {
            question: Some(q),
            found,
        };
        (found, memo)
    }

    /// The answer to a [`NearQuery`]: a projection from the hint's s where
    /// it is usable and settles, the full search otherwise.
    fn answer(&self, q: &NearQuery) -> Option<Located> {
        let p = Vec2::new(f64::from_bits(q.x), f64::from_bits(q.y));
        if let Some((road, s)) = q.from
            && let (found, true) = self.on_road(road, p, f64::from_bits(s))
        {
            return found;
        }
        self.locate(p)
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
    pub(super) fn on_road(&self, ri: usize, p: Vec2, s_guess: f64) -> (Option<Located>, bool) {
        let road = &self.od.roads[ri];
        let (s, t, beyond, settled) = refine(road, p, s_guess);
        // A point past either end of this road projects onto the end:
        // it is not on this road (a junction road starting there would
        // otherwise claim points of the road leading into it).
        if beyond > BEYOND_END_M {
            return (None, settled);
        }
        let found = road.lane_holding(s, t).map(|span| Located {
            road: ri,
            lane: span.id,
            s,
            t,
            offset: t - span.t_center(),
        });
        (found, settled)
    }
}
