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
    /// to nothing there): a driver leaves the map here. A lane without
    /// successors whose road goes on is a dead end (a lane drop) instead.
    pub exit: bool,
}

/// Every drivable lane, indexed by `u32` (what drivers hold).
#[derive(Clone, Debug, Default)]
pub struct LaneGraph {
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
                        exit: if forward {
                            si + 1 == road.sections.len() && road.successor.is_none()
                        } else {
                            si == 0 && road.predecessor.is_none()
                        },
                    });
                }
            }
        }
        let mut g = LaneGraph { lanes, index };
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
        g
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
