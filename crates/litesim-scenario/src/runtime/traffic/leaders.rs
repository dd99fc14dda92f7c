//! Who is ahead: the leader on a vehicle's lane and the lanes it will
//! take, vehicles at junctions, red lines and dead ends; the car-following
//! acceleration behind them.

use super::*;

impl Traffic {
    /// The nearest constraint ahead of a vehicle at `u` in `lane`
    /// (`half` its half length, `me` its slot): the vehicle in front, or
    /// a red stop line it can still stop at, or a dead end — whichever
    /// asks for the lowest acceleration — within [`LOOKAHEAD_M`].
    /// `at`: where the vehicle's own entry is in `lane`'s part of the
    /// index, when the caller knows it (no search then).
    pub(super) fn leader(
        &self,
        g: &LaneGraph,
        me: u32,
        (lane, at): (u32, Option<usize>),
        u: f64,
        half: f64,
    ) -> (Leader, f64) {
        self.leader_above(g, me, (lane, at), (u, half), None)
    }

    /// [`Traffic::leader`] for a caller that takes the minimum of its
    /// acceleration and `floor` and does not look at which leader it is
    /// when that acceleration is at least `floor`: each candidate's
    /// acceleration is [`driver::acceleration_above`] `floor` (0 for one
    /// surely not braking when `floor` ≤ 0), the same minimum with `floor`
    /// at less cost. `None`: each exactly.
    pub(super) fn leader_above(
        &self,
        g: &LaneGraph,
        me: u32,
        (lane, at): (u32, Option<usize>),
        (u, half): (f64, f64),
        floor: Option<f64>,
    ) -> (Leader, f64) {
        let veh = &self.vehicles[me as usize];
        let p = &veh.follow_params();
        // The constraint that asks for the lowest acceleration wins.
        let mut best = (
            Leader {
                gap: f64::INFINITY,
                speed: veh.v,
                accel: 0.0,
            },
            f64::INFINITY,
        );
        let mut consider = |l: Leader| {
            let a = match floor {
                Some(floor) => driver::acceleration_above(p, veh.v, l, floor),
                None => driver::acceleration(p, veh.v, Some(l)),
            };
            if a < best.1 {
                best = (l, a);
            }
        };
        let first = lane;
        let mut lane = lane;
        let mut from = u;
        let mut ahead = 0.0;
        loop {
            let info = &g.lanes[lane as usize];
            if info.junction {
                for l in self.at_junction(g, me, (lane, lane != first), from, ahead, half) {
                    consider(l);
                }
            }
            let entries = self.index.lane(lane);
            let start = match at {
                Some(k) if lane == first && ahead == 0.0 => k,
                _ => entries.partition_point(|e| e.u < from),
            };
            let found = entries[start..].iter().find(|e| e.who != me);
            if let Some(e) = found {
                consider(Leader {
                    gap: ahead + e.u - from - e.half - half,
                    speed: e.v,
                    accel: e.a,
                });
            }
            if let Some((line, red)) = self.red_line(lane, from - half) {
                // A front already over the line, the centre not: it stays.
                let gap = (ahead + line - from - half).max(0.01);
                // Past the point of stopping (at its emergency deceleration
                // on red, its safe one on yellow) it goes through.
                let can = if red { p.emergency_decel } else { p.safe_decel };
                if gap > 0.0 && (self.settling || veh.v * veh.v / (2.0 * gap) <= can) {
                    consider(Leader {
                        gap,
                        speed: 0.0,
                        accel: 0.0,
                    });
                }
            }
            if found.is_some() {
                break;
            }
            let info = &g.lanes[lane as usize];
            ahead += info.length - from;
            if ahead > LOOKAHEAD_M {
                break;
            }
            match Self::next_lane(g, lane, veh) {
                Some(n) => {
                    lane = n;
                    from = 0.0;
                }
                None => {
                    consider(Leader {
                        gap: ahead - half,
                        speed: 0.0,
                        accel: 0.0,
                    });
                    break;
                }
            }
        }
        if best.1.is_infinite() {
            // Nothing ahead within sight: the free road.
            best.1 = driver::acceleration(p, veh.v, None);
        }
        best
    }

    /// What junction lane `lane` (`entered`: not the vehicle's own) asks of
    /// vehicle `me`, `ahead` metres before it: waiting at its start while
    /// another has the crossing (unless it is too late to stop: then it
    /// goes), and the vehicles on lanes that cross or merge with it.
    pub(super) fn at_junction(
        &self,
        g: &LaneGraph,
        me: u32,
        (lane, entered): (u32, bool),
        from: f64,
        ahead: f64,
        half: f64,
    ) -> Vec<Leader> {
        let veh = &self.vehicles[me as usize];
        let p = veh.follow_params();
        let mut out = Vec::new();
        if entered && self.must_wait(g, me, lane, ahead) {
            let gap = ahead - half - 0.5;
            if gap > 0.0 && (self.settling || veh.v * veh.v / (2.0 * gap) <= p.emergency_decel) {
                out.push(Leader {
                    gap,
                    speed: 0.0,
                    accel: 0.0,
                });
            }
        }
        out.extend(self.junction_leaders(g, me, lane, from, ahead, half));
        out
    }

    /// Whether vehicle `me`, `ahead` metres before junction lane `lane`,
    /// must let another go first: a crossing or merging lane is occupied,
    /// or claimed by one that arrives sooner (then by slot).
    pub(super) fn must_wait(&self, g: &LaneGraph, me: u32, lane: u32, ahead: f64) -> bool {
        let v = self.vehicles[me as usize].v.max(0.1);
        let mine = (ahead / v, me);
        g.lanes[lane as usize]
            .conflicts
            .iter()
            .filter(|(_, k)| *k != Conflict::Diverge)
            .any(|&(c, _)| {
                self.index.lane(c).iter().any(|e| e.who != me)
                    || self.claims[c as usize]
                        .is_some_and(|(eta, who)| who != me && (eta, who) < mine)
            })
    }

    /// Vehicles on junction lanes that share `lane`'s start (ahead of
    /// `from` on theirs) or its end (nearer to it than this one), as
    /// leaders: paths that part or join are followed like one lane.
    pub(super) fn junction_leaders(
        &self,
        g: &LaneGraph,
        me: u32,
        lane: u32,
        from: f64,
        ahead: f64,
        half: f64,
    ) -> Vec<Leader> {
        let mut out = Vec::new();
        let len = g.lanes[lane as usize].length;
        for &(c, kind) in &g.lanes[lane as usize].conflicts {
            let entries = self.index.lane(c);
            let e = match kind {
                Conflict::Diverge => {
                    let k = entries.partition_point(|e| e.u < from);
                    entries[k..]
                        .iter()
                        .find(|e| e.who != me)
                        .map(|e| (ahead + e.u - from - e.half - half, e))
                }
                Conflict::Merge => {
                    let to_end = ahead + len - from;
                    let len_c = g.lanes[c as usize].length;
                    let k = entries.partition_point(|e| e.u <= len_c - to_end);
                    entries[k..]
                        .iter()
                        .find(|e| e.who != me)
                        .map(|e| (to_end - (len_c - e.u) - e.half - half, e))
                }
                Conflict::Cross => None,
            };
            if let Some((gap, e)) = e {
                out.push(Leader {
                    gap,
                    speed: e.v,
                    accel: e.a,
                });
            }
        }
        out
    }

    /// The first red or yellow stop line of `lane` at or after `u`: where
    /// it is, and whether it is red.
    pub(super) fn red_line(&self, lane: u32, u: f64) -> Option<(f64, bool)> {
        let s = self.stops_by_lane.partition_point(|&(l, _)| l < lane);
        self.stops_by_lane[s..]
            .iter()
            .take_while(|&&(l, _)| l == lane)
            .map(|&(_, k)| &self.stop_lines[k as usize])
            .filter(|x| x.u >= u)
            .min_by(|a, b| a.u.total_cmp(&b.u))
            .map(|x| (x.u, x.red))
    }

    /// Distance from `u` in `lane` to where the vehicle's route ends
    /// (infinite when farther than [`DEAD_END_NOTICE_M`]).
    pub(super) fn dead_end_in(g: &LaneGraph, mut lane: u32, u: f64, v: &Vehicle) -> f64 {
        let mut d = g.lanes[lane as usize].length - u;
        while d < DEAD_END_NOTICE_M {
            match Self::next_lane(g, lane, v) {
                Some(n) => {
                    lane = n;
                    d += g.lanes[n as usize].length;
                }
                None if g.lanes[lane as usize].exit => return f64::INFINITY,
                None => return d,
            }
        }
        f64::INFINITY
    }

    pub(super) fn accel_with(&self, who: u32, v: f64, l: Option<Leader>) -> f64 {
        // Obstacles (sut.car, planned actors) are judged as careful cars.
        let p = if who & OBSTACLE == 0 {
            self.vehicles[who as usize].params
        } else {
            DriverParams::for_category("car", v.max(1.0))
        };
        driver::acceleration(&p, v, l)
    }
}
