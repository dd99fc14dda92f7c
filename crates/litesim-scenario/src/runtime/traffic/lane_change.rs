//! Lane changes: MOBIL's incentive and safety over both sides, forced
//! changes towards a route, courtesy and the clearances a change needs.

use super::*;

impl Traffic {
    /// The nearest occupant behind `u` in `lane` (other than `me`), or at
    /// the end of a lane leading into it, with the distance between their
    /// centres along the lanes.
    pub(super) fn follower(
        &self,
        g: &LaneGraph,
        me: u32,
        lane: u32,
        u: f64,
    ) -> Option<(Entry, f64)> {
        let entries = self.index.lane(lane);
        let j = entries.partition_point(|e| e.u < u);
        if let Some(e) = entries[..j].iter().rev().find(|e| e.who != me) {
            return Some((*e, u - e.u));
        }
        g.lanes[lane as usize]
            .prev
            .iter()
            .filter_map(|&p| {
                let len = g.lanes[p as usize].length;
                let e = self.index.lane(p).iter().rev().find(|e| e.who != me)?;
                Some((*e, u + len - e.u))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// Courtesy at a lane drop (zip merging): a driver whose lane goes on
    /// makes room for the first vehicle ahead in a neighbouring lane that
    /// ends, when it can do so braking at most comfortably. Returns that
    /// acceleration, or +∞ when there is no one to let in.
    pub(super) fn courtesy(&self, g: &LaneGraph, me: u32) -> f64 {
        let v = &self.vehicles[me as usize];
        let info = &g.lanes[v.lane as usize];
        let mut a = f64::INFINITY;
        for side in [info.left, info.right].into_iter().flatten() {
            if Self::dead_end_in(g, side, v.u, v).is_infinite()
                || Self::dead_end_in(g, v.lane, v.u, v).is_finite()
            {
                continue;
            }
            let entries = self.index.lane(side);
            let j = entries.partition_point(|e| e.u < v.u);
            let Some(e) = entries[j..].iter().find(|e| e.who != me) else {
                continue;
            };
            let gap = e.u - e.half - v.u - 0.5 * v.length;
            if gap <= 0.0 {
                continue;
            }
            let l = Leader {
                gap,
                speed: e.v,
                accel: e.a,
            };
            let yield_a = driver::acceleration(&v.params, v.v, Some(l));
            if yield_a >= -v.params.comfort_decel {
                a = a.min(yield_a);
            }
        }
        a
    }

    pub(super) fn note_contact(&mut self, me: u32, lane: u32, u: f64) {
        let entries = self.index.lane(lane);
        let i = entries.partition_point(|e| e.u < u);
        let v = &self.vehicles[me as usize];
        let other = entries
            .iter()
            .skip(i.saturating_sub(2))
            .find(|e| e.who != me && e.u >= u && e.u - e.half <= u + 0.5 * v.length);
        if let Some(o) = other {
            let key = (me, o.who);
            if self.touching.insert(key) {
                self.contacts.push(Contact {
                    tick: self.tick,
                    vehicle: me,
                    other: if o.who & OBSTACLE == 0 {
                        Ok(o.who)
                    } else {
                        Err(o.who & !OBSTACLE)
                    },
                });
            }
        }
    }

    /// A change the scenario asks for: one lane towards `target` (a lane
    /// of the same section to the left or right) as soon as the gap there
    /// is physically free — no one within a metre ahead or behind, and the
    /// new follower able to stay behind at its emergency deceleration —
    /// whether or not MOBIL would change; −1, +1, or 0 (not yet).
    pub(super) fn forced_change(&self, g: &LaneGraph, me: u32, target: u32) -> i8 {
        let v = &self.vehicles[me as usize];
        let chain = |mut l: u32, left: bool| {
            while let Some(n) = if left {
                g.lanes[l as usize].left
            } else {
                g.lanes[l as usize].right
            } {
                if n == target {
                    return true;
                }
                l = n;
            }
            false
        };
        let (side, next) = if chain(v.lane, true) {
            (1, g.lanes[v.lane as usize].left)
        } else if chain(v.lane, false) {
            (-1, g.lanes[v.lane as usize].right)
        } else {
            return 0;
        };
        let Some(t) = next else { return 0 };
        let half = 0.5 * v.length;
        let (lead, _) = self.leader(g, me, (t, None), v.u, half);
        if lead.gap < 1.0 {
            return 0;
        }
        if let Some((f, d)) = self.follower(g, me, t, v.u) {
            let gap = d - half - f.half;
            let after = self.accel_with(
                f.who,
                f.v,
                Some(Leader {
                    gap,
                    speed: v.v,
                    accel: v.a,
                }),
            );
            if gap < 1.0 || after <= -9.0 || !self.clear_of_obstacle(&f, gap, v) {
                return 0;
            }
        }
        if !self.clear_of_obstacles_behind(me, t, v.u, half) {
            return 0;
        }
        side
    }

    /// Whether a lane change may go in front of `f`, `gap` behind: an
    /// actor the engine does not drive (sut.car, a planned actor) may not
    /// brake for it at all, so it must not close the gap within the change.
    pub(super) fn clear_of_obstacle(&self, f: &Entry, gap: f64, me: &Vehicle) -> bool {
        f.who & OBSTACLE == 0 || gap >= 2.0 + (f.v - me.v).max(0.0) * me.change_s()
    }

    /// Every such actor behind `u` in `lane` within 150 m (not only the
    /// nearest occupant: one may come up behind a car that is leaving).
    pub(super) fn clear_of_obstacles_behind(&self, me: u32, lane: u32, u: f64, half: f64) -> bool {
        let v = &self.vehicles[me as usize];
        let entries = self.index.lane(lane);
        let j = entries.partition_point(|e| e.u < u);
        entries[..j]
            .iter()
            .rev()
            .take_while(|e| u - e.u < 150.0)
            .filter(|e| e.who != me && e.who & OBSTACLE != 0)
            .all(|e| self.clear_of_obstacle(e, u - half - e.u - e.half, v))
    }

    /// MOBIL over both neighbours: −1 (right), +1 (left) or 0.
    pub(super) fn mobil(&self, g: &LaneGraph, me: u32, a_now: f64, lead_now: Leader) -> i8 {
        let v = &self.vehicles[me as usize];
        let info = &g.lanes[v.lane as usize];
        let half = 0.5 * v.length;
        let here_ends = Self::dead_end_in(g, v.lane, v.u, v);
        // The old follower: behind me now, behind my leader after.
        let old_follower = self.follower(g, me, v.lane, v.u).map(|(o, d)| {
            let gap_me = d - half - o.half;
            let me_as_leader = Leader {
                gap: gap_me,
                speed: v.v,
                accel: v.a,
            };
            let after = Leader {
                gap: gap_me + lead_now.gap + v.length,
                ..lead_now
            };
            self.before_and_after(&o, me_as_leader, after)
        });
        let mut best = (0i8, f64::NEG_INFINITY);
        for (side, target) in [(1i8, info.left), (-1i8, info.right)] {
            let Some(t) = target else { continue };
            let side_case = SideCase {
                me,
                target: t,
                a_now,
                here_ends,
                old_follower,
                towards_slow_side: (side < 0) == info.right_hand,
            };
            if let Some(gain) = self.weigh_side(g, &side_case)
                && gain > best.1
            {
                best = (side, gain);
            }
        }
        best.0
    }

    /// What `f` does now behind `now` and would do behind `after`.
    pub(super) fn before_and_after(&self, f: &Entry, now: Leader, after: Leader) -> (f64, f64) {
        (
            self.accel_with(f.who, f.v, Some(now)),
            self.accel_with(f.who, f.v, Some(after)),
        )
    }

    /// MOBIL for one neighbouring lane: `None` when the change is unsafe,
    /// not physically free or not worth it; else its gain.
    pub(super) fn weigh_side(&self, g: &LaneGraph, c: &SideCase) -> Option<f64> {
        let (me, t) = (c.me, c.target);
        let v = &self.vehicles[me as usize];
        let half = 0.5 * v.length;
        let there_ends = Self::dead_end_in(g, t, v.u, v);
        if there_ends < c.here_ends {
            return None;
        }
        // Out of a lane that ends, half the jam gap suffices (a zip merge
        // behind a driver who made room, see `courtesy`).
        let need = if c.here_ends.is_finite() {
            0.5 * v.params.min_gap
        } else {
            v.params.min_gap
        };
        let entries = self.index.lane(t);
        let j = entries.partition_point(|e| e.u < v.u);
        let lead_gap_in_lane = entries[j..]
            .iter()
            .find(|e| e.who != me)
            .map(|e| e.u - e.half - v.u - half);
        if lead_gap_in_lane.is_some_and(|gap| gap < need) {
            return None;
        }
        let (lead_there, a_there) = self.leader(g, me, (t, None), v.u, half);
        if lead_there.gap < need || !self.clear_of_obstacles_behind(me, t, v.u, half) {
            return None;
        }
        // The new follower: behind my new leader now, behind me after.
        let new_follower = match self.follower(g, me, t, v.u) {
            Some((f, d)) => {
                let gap = d - half - f.half;
                if gap < need || !self.clear_of_obstacle(&f, gap, v) {
                    return None;
                }
                let now = Leader {
                    gap: gap + v.length + lead_there.gap,
                    ..lead_there
                };
                let me_as_leader = Leader {
                    gap,
                    speed: v.v,
                    accel: c.a_now,
                };
                Some(self.before_and_after(&f, now, me_as_leader))
            }
            None => None,
        };
        let strategic = if c.here_ends.is_finite() && there_ends.is_infinite() {
            // A lane that ends ahead: leaving it outweighs any gain (more
            // so the closer the end), within safety.
            2.0 * v.params.max_accel * (1.0 - c.here_ends / DEAD_END_NOTICE_M).max(0.25)
        } else {
            0.0
        };
        let case = LaneChangeCase {
            me: (c.a_now, a_there),
            new_follower,
            old_follower: c.old_follower,
            towards_slow_side: c.towards_slow_side,
            strategic,
        };
        driver::mobil(&v.params, &case).then_some(a_there - c.a_now + strategic)
    }
}
