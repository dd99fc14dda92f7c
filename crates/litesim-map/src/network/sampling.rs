//! Sampling lanes into polylines within a tolerance (refined where curved),
//! with their road-mark runs.

use super::*;

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

/// Step (m) that keeps a chord within `tol` of an arc of curvature `k`.
/// How often the lane sampler may halve a first step (the first step is
/// already sized by the curvature; halving serves width changes).
pub const MAX_REFINE_DEPTH: u32 = 6;

/// Pieces the lane sampler may test per lane section (about 0.1 s of
/// work): enough for 0.1 mm on kilometres of ordinary road.
pub const MAX_REFINED_PIECES: usize = 50_000;

/// Distance from `p` to the segment `a`–`b`.
pub(super) fn seg_distance(p: Vec2, a: Vec2, b: Vec2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let u = litesim_core::segment_fraction(p, a, b - a);
    let (fx, fy) = (a.x + dx * u, a.y + dy * u);
    ((p.x - fx).powi(2) + (p.y - fy).powi(2)).sqrt()
}

/// The piece of `r` from `s` to its next breakpoint (geometry, offset and
/// width records included) is straight: a line of the plan view, a lane
/// offset and every lane width of `sec` constant there (their records'
/// b = c = d = 0; border records are not looked into).
pub(super) fn straight_between(r: &Road, sec: &crate::model::LaneSection, s: f64) -> bool {
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

pub(super) fn step_for(k: f64, tol: f64, max: f64) -> f64 {
    if k.abs() < 1e-9 {
        max
    } else {
        (8.0 * tol / k.abs()).sqrt().clamp(0.05, max)
    }
}

/// Cuts a border (points at road positions `at`) into one run per road-mark
/// record; records apply from `section_s + sOffset` to the next record.
/// Neighbouring runs share their boundary point so that the drawing has no
/// gap.
pub(super) fn mark_runs(
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

impl RoadNetwork {
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
                let ss = breakpoints(r, sec, s_end);
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
    pub(super) fn refine_piece(
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
}

/// The section's breakpoints (from `sec.s` to `s_end`, sorted): where
/// geometry pieces meet and lane offsets and lane widths/borders change
/// record — the lines may bend sharply (or jump) there, so a sample sits
/// on each; a record that may jump gets a sample just before it too (on
/// the old record), so that the jump is one short step.
fn breakpoints(r: &Road, sec: &crate::model::LaneSection, s_end: f64) -> Vec<f64> {
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
    ss
}
