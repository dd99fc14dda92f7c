//! The step's index: every vehicle and obstacle on its lane, sorted by
//! position, junction claims and stop lines, rebuilt once per step.

use super::*;

impl Traffic {
    pub(super) fn build_index(&mut self, g: &LaneGraph, obstacles: &[Obstacle]) {
        self.count_lanes(g, obstacles);
        self.fill_vehicles();
        self.fill_obstacles_and_sort(g, obstacles);
        self.claim_junctions(g);
        self.index_stop_lines();
    }

    /// Each lane's share of the index (vehicles, their ghosts, obstacles),
    /// and the entries sized for it.
    pub(super) fn count_lanes(&mut self, g: &LaneGraph, obstacles: &[Obstacle]) {
        let n_lanes = g.lanes.len();
        let ix = &mut self.index;
        ix.starts.clear();
        ix.starts.resize(n_lanes + 1, 0);
        for v in self.vehicles.iter().filter(|v| v.active) {
            ix.starts[v.lane as usize + 1] += 1;
            if let Some(f) = v.from {
                ix.starts[f as usize + 1] += 1;
            }
        }
        for o in obstacles {
            ix.starts[o.lane as usize + 1] += 1;
        }
        for i in 0..n_lanes {
            ix.starts[i + 1] += ix.starts[i];
        }
        self.cursor.clear();
        self.cursor.extend_from_slice(&ix.starts[..n_lanes]);
        let total = ix.starts[n_lanes] as usize;
        ix.entries.clear();
        ix.entries.resize(
            total,
            Entry {
                u: 0.0,
                v: 0.0,
                a: 0.0,
                half: 0.0,
                who: NONE,
                ghost: false,
            },
        );
    }

    /// The vehicles' entries, in last step's order.
    pub(super) fn fill_vehicles(&mut self) {
        let ix = &mut self.index;
        // Filled in last step's order (each vehicle's entry and its ghost in
        // the lane it is leaving where they were): every lane comes out
        // almost sorted, and the insertion sort below is linear. A ghost
        // not in that order (a change begun last step) comes last.
        self.ghost_done.clear();
        self.ghost_done.resize(self.vehicles.len(), false);
        for &item in &self.order {
            let slot = item & !GHOST_ITEM;
            let v = &self.vehicles[slot as usize];
            if !v.active {
                continue;
            }
            let e = Entry {
                u: v.u,
                v: v.v,
                a: v.a,
                half: 0.5 * v.length,
                who: slot,
                ghost: false,
            };
            let lane = if item & GHOST_ITEM == 0 {
                v.lane
            } else if let Some(f) = v.from {
                self.ghost_done[slot as usize] = true;
                f
            } else {
                continue;
            };
            let c = &mut self.cursor[lane as usize];
            ix.entries[*c as usize] = Entry {
                ghost: item & GHOST_ITEM != 0,
                ..e
            };
            *c += 1;
        }
        for (slot, v) in self.vehicles.iter().enumerate() {
            if let (true, Some(f), false) = (v.active, v.from, self.ghost_done[slot]) {
                let c = &mut self.cursor[f as usize];
                ix.entries[*c as usize] = Entry {
                    u: v.u,
                    v: v.v,
                    a: v.a,
                    half: 0.5 * v.length,
                    who: slot as u32,
                    ghost: true,
                };
                *c += 1;
            }
        }
    }

    /// The obstacles' entries, every lane sorted by `u`, and the next
    /// step's fill order.
    pub(super) fn fill_obstacles_and_sort(&mut self, g: &LaneGraph, obstacles: &[Obstacle]) {
        let n_lanes = g.lanes.len();
        let ix = &mut self.index;
        for (k, o) in obstacles.iter().enumerate() {
            let c = &mut self.cursor[o.lane as usize];
            ix.entries[*c as usize] = Entry {
                u: o.u,
                v: o.v,
                a: o.a,
                half: 0.5 * o.length,
                who: OBSTACLE | k as u32,
                ghost: false,
            };
            *c += 1;
        }
        for lane in 0..n_lanes {
            let (a, b) = (ix.starts[lane] as usize, ix.starts[lane + 1] as usize);
            insertion_sort(&mut ix.entries[a..b]);
        }
        // The next step's fill order: every vehicle once, in lane order.
        self.order.clear();
        self.order.extend(
            ix.entries
                .iter()
                .filter(|e| e.who & OBSTACLE == 0)
                .map(|e| if e.ghost { e.who | GHOST_ITEM } else { e.who }),
        );
    }

    /// Claims on junction lanes, and the vehicles off the road appended
    /// to the fill order.
    pub(super) fn claim_junctions(&mut self, g: &LaneGraph) {
        let n_lanes = g.lanes.len();
        // Claims on junction lanes by vehicles about to enter them (and
        // the vehicles off the road, last in the next fill order).
        self.claims.clear();
        self.claims.resize(n_lanes, None);
        for (slot, v) in self.vehicles.iter().enumerate() {
            if !v.active {
                self.order.push(slot as u32);
                continue;
            }
            let info = &g.lanes[v.lane as usize];
            if info.junction {
                continue;
            }
            let to_end = info.length - v.u;
            if to_end > CLAIM_M.max(3.0 * v.v) {
                continue;
            }
            if let Some(n) = Self::next_lane(g, v.lane, v)
                && g.lanes[n as usize].junction
            {
                let claim = (to_end / v.v.max(0.1), slot as u32);
                let c = &mut self.claims[n as usize];
                if c.is_none_or(|old| claim < old) {
                    *c = Some(claim);
                }
            }
        }
    }

    /// Red and yellow stop lines by lane, for the look-ahead.
    pub(super) fn index_stop_lines(&mut self) {
        // Stop lines by lane, for the look-ahead.
        self.stops_by_lane.clear();
        for (k, s) in self.stop_lines.iter().enumerate() {
            if s.red || s.yellow {
                self.stops_by_lane.push((s.lane, k as u32));
            }
        }
        self.stops_by_lane.sort_unstable();
    }
}
