//! The map as drivers see it: every drivable lane of every lane section,
//! with its length, its successors along the direction of travel and its
//! neighbours to the left and right. Built once per map and shared by
//! every run of a batch.

use litesim_core::geometry::Pose;
use litesim_map::network::LaneRef;
use litesim_map::road::Direction;
use litesim_map::{Located, RoadNetwork};
use std::collections::BTreeMap;

/// One drivable lane of one lane section.
#[derive(Clone, Debug, PartialEq)]
pub struct LaneInfo {
    /// The lane in the map's routing graph.
    pub node: LaneRef,
    /// Section start and end along the road (m).
    pub s0: f64,
    /// Section end (m).
    pub s1: f64,
    /// Travel is along +s.
    pub forward: bool,
    /// Length along the reference line (m): a driver's `u` runs 0 ..= length.
    pub length: f64,
    /// Width at the section's middle (m).
    pub width: f64,
    /// Lanes reachable at this lane's end, in the map's order.
    pub next: Vec<u32>,
    /// Lanes that lead into this one.
    pub prev: Vec<u32>,
    /// The neighbour on the left of the direction of travel.
    pub left: Option<u32>,
    /// The neighbour on the right of the direction of travel.
    pub right: Option<u32>,
    /// Right-hand traffic: the right is the slow (keep-right) side.
    pub right_hand: bool,
    /// The lane ends at the map's edge (no successor, and its road links
    /// to nothing there): a driver stops here (ambient traffic is then
    /// placed again around sut.car). A lane without
    /// successors whose road goes on is a dead end (a lane drop) instead.
    pub exit: bool,
    /// A lane of a junction's connecting road.
    pub junction: bool,
    /// Lanes of the same junction whose paths meet this one's, and how.
    pub conflicts: Vec<(u32, Conflict)>,
}

/// How the paths of two lanes of one junction meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Conflict {
    /// They leave the same lane: a vehicle ahead on the other is followed
    /// until the paths part.
    Diverge,
    /// They enter the same lane: who enters first goes (as at a
    /// crossing), and inside the one nearer the end leads.
    Merge,
    /// They cross: who enters first (by arrival, then by slot) goes; the
    /// other waits at its lane's start.
    Cross,
}

/// Where the paths of two crossing lanes of a junction meet: a disc around
/// the closest pair of their centre-line points, as wide as the wider lane
/// (what post-encroachment time is measured at).
#[derive(Clone, Debug, PartialEq)]
pub struct ConflictArea {
    /// The junction's id.
    pub junction: String,
    /// The centre (map frame).
    pub centre: litesim_core::Vec2,
    /// The radius (m).
    pub radius: f64,
}

/// Every drivable lane, indexed by `u32` (what drivers hold).
#[derive(Clone, Debug, Default)]
pub struct LaneGraph {
    /// Where crossing lanes of junctions meet, in junction and lane order.
    pub areas: std::sync::Arc<[ConflictArea]>,
    /// The lanes, in road, section, lane-id order.
    pub lanes: Vec<LaneInfo>,
    index: BTreeMap<LaneRef, u32>,
}

impl LaneGraph {
    /// The drivable one-way lanes of `net` (bidirectional lanes are left to
    /// the scenario's own actors).
    pub fn new(net: &RoadNetwork) -> Self {
        let mut lanes = Vec::new();
        let mut index = BTreeMap::new();
        for (ri, road) in net.roads().iter().enumerate() {
            for (si, sec) in road.sections.iter().enumerate() {
                let s0 = sec.s;
                let s1 = road.sections.get(si + 1).map_or(road.length, |n| n.s);
                if s1 - s0 < 1e-6 {
                    continue;
                }
                let mid = 0.5 * (s0 + s1);
                for l in sec.left.iter().chain(&sec.right) {
                    if !l.is_drivable() {
                        continue;
                    }
                    let forward = match road.lane_direction(mid, l.id) {
                        Direction::Forward => true,
                        Direction::Backward => false,
                        Direction::Both => continue,
                    };
                    let node = LaneRef {
                        road: ri,
                        section: si,
                        lane: l.id,
                    };
                    index.insert(node, lanes.len() as u32);
                    lanes.push(LaneInfo {
                        node,
                        s0,
                        s1,
                        forward,
                        length: s1 - s0,
                        width: road.lane_span(mid, l.id).map_or(3.5, |s| s.width()),
                        next: Vec::new(),
                        prev: Vec::new(),
                        left: None,
                        right: None,
                        right_hand: road.rule == litesim_map::model::Rule::Rht,
                        junction: road.junction.is_some(),
                        conflicts: Vec::new(),
                        exit: if forward {
                            si + 1 == road.sections.len() && road.successor.is_none()
                        } else {
                            si == 0 && road.predecessor.is_none()
                        },
                    });
                }
            }
        }
        let mut g = LaneGraph {
            lanes,
            index,
            areas: Default::default(),
        };
        for i in 0..g.lanes.len() {
            let node = g.lanes[i].node;
            let next: Vec<u32> = net
                .successors(node)
                .into_iter()
                .filter_map(|n| g.index.get(&n).copied())
                .collect();
            // Left of travel is +t on a forward lane (higher id), −t on a
            // backward one; a neighbour must run the same way.
            let step = if g.lanes[i].forward { 1 } else { -1 };
            let side = |d: i32| {
                let id = node.lane + d;
                if id == 0 || (id > 0) != (node.lane > 0) {
                    return None;
                }
                let n = LaneRef { lane: id, ..node };
                let j = *g.index.get(&n)?;
                (g.lanes[j as usize].forward == g.lanes[i].forward).then_some(j)
            };
            let (left, right) = (side(step), side(-step));
            let l = &mut g.lanes[i];
            l.exit &= next.is_empty();
            l.next = next;
            l.left = left;
            l.right = right;
        }
        for i in 0..g.lanes.len() {
            for k in 0..g.lanes[i].next.len() {
                let n = g.lanes[i].next[k] as usize;
                g.lanes[n].prev.push(i as u32);
            }
        }
        g.find_conflicts(net);
        g
    }

    /// Pairs of lanes of one junction whose centre lines come closer than
    /// 90 % of half their widths summed: diverging (a common predecessor),
    /// merging (a common successor) or crossing.
    fn find_conflicts(&mut self, net: &RoadNetwork) {
        let mut by_junction: BTreeMap<&str, Vec<u32>> = BTreeMap::new();
        for (i, l) in self.lanes.iter().enumerate() {
            if let Some(j) = &net.roads()[l.node.road].junction {
                by_junction.entry(j.as_str()).or_default().push(i as u32);
            }
        }
        let points: BTreeMap<u32, Vec<litesim_core::Vec2>> = by_junction
            .values()
            .flatten()
            .map(|&i| {
                let len = self.lanes[i as usize].length;
                let n = (len / 1.0).ceil().max(1.0) as usize;
                let pts = (0..=n)
                    .filter_map(|k| self.pose(net, i, len * k as f64 / n as f64, 0.0))
                    .map(|p| p.position.xy())
                    .collect();
                (i, pts)
            })
            .collect();
        let mut found: Vec<(u32, u32, Conflict)> = Vec::new();
        let mut areas = Vec::new();
        for lanes in by_junction.values() {
            for (k, &a) in lanes.iter().enumerate() {
                for &b in &lanes[k + 1..] {
                    let (la, lb) = (&self.lanes[a as usize], &self.lanes[b as usize]);
                    let kind = if la.prev.iter().any(|p| lb.prev.contains(p)) {
                        Conflict::Diverge
                    } else if la.next.iter().any(|n| lb.next.contains(n)) {
                        Conflict::Merge
                    } else {
                        let reach = 0.45 * (la.width + lb.width);
                        let mut closest: Option<(f64, litesim_core::Vec2)> = None;
                        for p in &points[&a] {
                            for q in &points[&b] {
                                let d = *p - *q;
                                let d2 = d.dot(d);
                                if closest.is_none_or(|c| d2 < c.0) {
                                    closest = Some((d2, (*p + *q) * 0.5));
                                }
                            }
                        }
                        let Some((_, centre)) = closest.filter(|c| c.0 < reach * reach) else {
                            continue;
                        };
                        let junction = net.roads()[la.node.road]
                            .junction
                            .clone()
                            .unwrap_or_default();
                        areas.push(ConflictArea {
                            junction,
                            centre,
                            radius: 0.5 * la.width.max(lb.width),
                        });
                        Conflict::Cross
                    };
                    found.push((a, b, kind));
                }
            }
        }
        for (a, b, kind) in found {
            self.lanes[a as usize].conflicts.push((b, kind));
            self.lanes[b as usize].conflicts.push((a, kind));
        }
        self.areas = areas.into();
    }

    /// The lane index of a routing-graph node.
    pub fn index_of(&self, node: LaneRef) -> Option<u32> {
        self.index.get(&node).copied()
    }

    /// True when the map has no lane a driver can use.
    pub fn is_empty(&self) -> bool {
        self.lanes.is_empty()
    }

    /// Road s of `u` along lane `lane`.
    pub fn road_s(&self, lane: u32, u: f64) -> f64 {
        let l = &self.lanes[lane as usize];
        if l.forward { l.s0 + u } else { l.s1 - u }
    }

    /// World pose at `u` along `lane`, `lat` to the left of its centre
    /// (heading along the direction of travel).
    pub fn pose(&self, net: &RoadNetwork, lane: u32, u: f64, lat: f64) -> Option<Pose> {
        let l = &self.lanes[lane as usize];
        let s = self.road_s(lane, u.clamp(0.0, l.length));
        let offset = if l.forward { lat } else { -lat };
        net.lane_pose_at(l.node.road, l.node.lane, s, offset)
    }

    /// Lane, `u` and offset to the left of the lane centre of a map point.
    pub fn locate(&self, net: &RoadNetwork, at: &Located) -> Option<(u32, f64, f64)> {
        let road = &net.roads()[at.road];
        let section = road.section_index(at.s);
        let lane = self.index_of(LaneRef {
            road: at.road,
            section,
            lane: at.lane,
        })?;
        let l = &self.lanes[lane as usize];
        let (u, lat) = if l.forward {
            (at.s - l.s0, at.offset)
        } else {
            (l.s1 - at.s, -at.offset)
        };
        Some((lane, u.clamp(0.0, l.length), lat))
    }

    /// The lane with `u` along it of road `road_id`'s lane `lane_id` at
    /// road s `s` (what a traffic-light box names).
    pub fn at_road_s(
        &self,
        net: &RoadNetwork,
        road: usize,
        lane_id: i32,
        s: f64,
    ) -> Option<(u32, f64)> {
        let section = net.roads()[road].section_index(s);
        let lane = self.index_of(LaneRef {
            road,
            section,
            lane: lane_id,
        })?;
        let l = &self.lanes[lane as usize];
        let u = if l.forward { s - l.s0 } else { l.s1 - s };
        Some((lane, u.clamp(0.0, l.length)))
    }
}
