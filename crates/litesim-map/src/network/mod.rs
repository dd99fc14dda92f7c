//! The road network: a parsed map plus the indices queries need.

mod graph;
mod locate;
mod sampling;
pub use graph::*;
pub use locate::*;
pub use sampling::*;

use crate::geometry::Shape;
use crate::model::{Cubic, Lane, LinkTarget, OpenDrive, Road};
use crate::parse::{MapError, Warning, parse};
use crate::road::{Direction, LaneSpan};
use litesim_core::{Pose, Vec2, math, wrap_angle};
use serde::Serialize;
use std::collections::{BTreeMap, BinaryHeap};

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
        self.lane_pose_travel_at(road, lane, s, offset)
            .map(|(pose, _)| pose)
    }

    /// [`RoadNetwork::lane_pose_at`] and whether the lane is travelled
    /// towards increasing s there (what [`RoadNetwork::travels_forward`]
    /// answers): the pose finds the lane's direction anyway, and a body
    /// moved along its lane each step needs both.
    pub fn lane_pose_travel_at(
        &self,
        road: usize,
        lane: i32,
        s: f64,
        offset: f64,
    ) -> Option<(Pose, bool)> {
        let r = &self.od.roads[road];
        let (span, found) = r.lane_span_of(s, lane)?;
        let t = span.t_center() + offset;
        let (x, y, z, h) = r.st_to_xyz_hdg(s, t);
        // Lane centre heading: road heading + atan(dt/ds), by a central
        // difference — exactly 0 where the lanes run parallel to the
        // reference line (the two spans are the same sums of constants).
        let ds = 0.05;
        let (a, b) = ((s - ds).max(0.0), (s + ds).min(r.length));
        let mut yaw = if self.parallel[road] {
            // dt = 0 exactly: atan(0 / (b − a)) is +0 either way, added
            // as the general case adds it (the same bits, a -0 heading
            // included), without calling atan on every body-step.
            h + 0.0
        } else {
            let dt = r.lane_span(b, lane).map_or(0.0, |l| l.t_center())
                - r.lane_span(a, lane).map_or(0.0, |l| l.t_center());
            h + if b > a { math::atan(dt / (b - a)) } else { 0.0 }
        };
        // The lane the span was measured on: the one `lane_direction` finds.
        let forward = r.direction_of(found, lane) != Direction::Backward;
        if !forward {
            yaw += std::f64::consts::PI;
        }
        let mut pose = Pose::planar(x, y, wrap_angle(yaw));
        pose.position.z = z;
        Some((pose, forward))
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

    /// Lane spans of a road at `s` (convenience).
    pub fn lane_spans(&self, road: &str, s: f64) -> Vec<LaneSpan> {
        self.road(road).map(|r| r.lane_spans(s)).unwrap_or_default()
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
