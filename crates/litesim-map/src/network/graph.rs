//! The lane graph: lane references, successors across sections, roads and
//! junctions, and routes over it.

use super::*;

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

impl RoadNetwork {
    pub(super) fn lane_ref(&self, road: usize, at_start: bool, lane: i32) -> Option<LaneRef> {
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

    pub(super) fn lane_length(&self, n: LaneRef) -> f64 {
        let r = &self.od.roads[n.road];
        let s0 = r.sections[n.section].s;
        let s1 = r.sections.get(n.section + 1).map_or(r.length, |x| x.s);
        (s1 - s0).max(0.0)
    }

    pub(super) fn build_graph(&mut self, warnings: &mut Vec<Warning>) {
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
