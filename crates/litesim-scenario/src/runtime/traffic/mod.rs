//! Driver-controlled vehicles on the map's lane graph: car-following,
//! MOBIL lane changes, stop lines and dead ends, in lane coordinates.
//!
//! A step has the two phases SUMO and highway-env use, in the shape of
//! rapier's pipeline: [`Traffic::step`] first builds the lane index (every
//! lane's occupants sorted by `u`, built once per step from the last
//! step's order, so the sort is linear), then every driver decides from
//! that frozen snapshot (its acceleration and maybe a lane change, written
//! into its own slot of the scratch columns), then one pass commits every
//! decision and integrates (ballistic update, Treiber & Kanagaraj 2015).
//! The order in which drivers decide cannot change a result; lane changes
//! that two drivers chose into the same gap are resolved in slot order.
//! A lane change's effect on the followers in the target lane shows from
//! the next step on, as in SUMO.
//!
//! Actors the engine does not drive (sut.car, the scenario's planned
//! actors) enter each step as [`Obstacle`]s: drivers follow and yield to
//! them like to anyone else.

pub mod driven;
pub mod lanes;
pub mod spawn;

use super::driver::{self, DriverParams, LaneChangeCase, Leader};
pub use lanes::{Conflict, ConflictArea, LaneGraph, LaneInfo};

/// How long a lane change takes from lane to lane (s).
pub const LANE_CHANGE_S: f64 = 3.0;
/// How often a driver weighs a lane change (s), staggered over drivers
/// (highway-env's `LANE_CHANGE_DELAY`).
pub const DECISION_PERIOD_S: f64 = 1.0;
/// How far ahead a driver looks for a leader, a stop line or a dead end (m).
pub const LOOKAHEAD_M: f64 = 250.0;
/// From how far before a junction a driver claims its way through it (m;
/// or three seconds at its speed, whichever is more).
pub const CLAIM_M: f64 = 30.0;
/// From how far ahead a lane's dead end pushes its drivers out of it (m).
pub const DEAD_END_NOTICE_M: f64 = 400.0;
const NONE: u32 = u32::MAX;
/// Marks an index entry as an [`Obstacle`].
const OBSTACLE: u32 = 1 << 31;
/// Marks an item of the fill order as a vehicle's ghost.
const GHOST_ITEM: u32 = 1 << 30;

/// A vehicle the engine drives.
#[derive(Clone, Debug, PartialEq)]
pub struct Vehicle {
    /// Lane index in the [`LaneGraph`].
    pub lane: u32,
    /// Position of the vehicle's centre along the lane (m).
    pub u: f64,
    /// Speed (m/s), never negative.
    pub v: f64,
    /// Acceleration of the last step (m/s²).
    pub a: f64,
    /// Offset of the centre to the left of the lane centre (m): nonzero
    /// during a lane change, shrinking to 0.
    pub lat: f64,
    /// The lane being left during a change (it still occupies it).
    pub from: Option<u32>,
    /// Length and width (m).
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// The driver's parameters.
    pub params: DriverParams,
    /// Picks the successor at each fork (a seeded value per vehicle).
    pub route: u64,
    /// Stopped at a lane's dead end (reported once).
    pub at_dead_end: bool,
    /// Lane changes made.
    pub lane_changes: u32,
    /// On the road: a vehicle the caller sets `false` takes no part in
    /// steps until it is set `true` again (the engine itself never takes a
    /// vehicle off: at a dead end or the map's edge it stops there).
    pub active: bool,
    /// Goals the scenario gives this step (a scenario's own vehicle);
    /// `Goals::default()` for ambient traffic.
    pub goals: Goals,
}

/// The time constant of a driver's speed tracking (s): a speed goal is
/// approached at (goal − v) / τ, within the driver's limits.
pub const TRACK_TAU_S: f64 = 0.5;

impl Vehicle {
    /// The parameters its car-following runs with: with a speed goal the
    /// desired speed does not limit (the goal's tracking does, see
    /// [`Vehicle::track`]).
    fn follow_params(&self) -> DriverParams {
        match self.goals.speed {
            Some(goal) => DriverParams {
                desired_speed: 1.0 + 1.2 * goal.max(self.v),
                ..self.params
            },
            None => self.params,
        }
    }

    /// The acceleration that tracks the speed goal (a proportional law
    /// with a 0.5 s time constant) within the driver's comfort limits (its
    /// safe deceleration for a gap goal).
    fn track(&self) -> f64 {
        let brake = if self.goals.firm {
            self.params.safe_decel.max(self.params.comfort_decel)
        } else {
            self.params.comfort_decel
        };
        match self.goals.speed {
            Some(goal) => ((goal - self.v) / TRACK_TAU_S).clamp(-brake, self.params.max_accel),
            None => f64::INFINITY,
        }
    }
}

/// What the scenario asks of a driver now: the runtime updates them each
/// step from the plan (a phase's speed, its lane, a gap to another actor)
/// and releases them when the phase ends. A driver pursues them within
/// its own limits and never by driving into anyone.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Goals {
    /// Track this speed (m/s) instead of cruising at the desired speed.
    pub speed: Option<f64>,
    /// Move to this lane (one lane at a time, as soon as the gap there is
    /// physically free, whether or not MOBIL would); MOBIL is off while set.
    pub lane: Option<u32>,
    /// The lanes of the planned route, in order: at a fork, the successor
    /// among them is taken.
    pub route: Vec<u32>,
    /// The speed goal keeps a gap to another actor: it is tracked braking
    /// up to the driver's safe deceleration (`b_safe`, what it may also
    /// impose on others), not only its comfortable one.
    pub firm: bool,
    /// How long its lane changes take (s): the phase's, for a change the
    /// scenario asks; `None`: [`LANE_CHANGE_S`].
    pub change_s: Option<f64>,
}

impl Vehicle {
    /// How long this vehicle's lane change takes (s).
    fn change_s(&self) -> f64 {
        self.goals.change_s.unwrap_or(LANE_CHANGE_S)
    }
}

/// An actor the engine does not drive, as it stands this step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obstacle {
    /// Lane index.
    pub lane: u32,
    /// Centre along the lane (m).
    pub u: f64,
    /// Speed along the lane (m/s).
    pub v: f64,
    /// Acceleration (m/s²).
    pub a: f64,
    /// Length (m).
    pub length: f64,
}

/// A stop line: where a lane's traffic light stands, and whether it shows
/// red (or yellow) now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopLine {
    /// Lane index.
    pub lane: u32,
    /// Along the lane (m).
    pub u: f64,
    /// Drivers stop here while it is set, unless they cannot stop at
    /// their emergency deceleration any more.
    pub red: bool,
    /// Yellow: drivers stop here when they can at their safe deceleration
    /// (`b_safe`), and go on otherwise.
    pub yellow: bool,
}

/// Contact between a driven vehicle and what is ahead of it in its lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Contact {
    /// The step it was first seen at.
    pub tick: u64,
    /// The driven vehicle behind.
    pub vehicle: u32,
    /// What it touched: a vehicle's slot, or `Err(obstacle index)`.
    pub other: Result<u32, u32>,
}

#[derive(Clone, Copy, Debug)]
struct Entry {
    u: f64,
    v: f64,
    a: f64,
    half: f64,
    who: u32,
    /// A vehicle's entry in the lane it is leaving (mid-change).
    ghost: bool,
}

/// The index of lane occupants (CSR: `starts[lane] .. starts[lane + 1]`
/// of `entries`, each lane sorted by `u`).
#[derive(Clone, Debug, Default)]
struct LaneIndex {
    starts: Vec<u32>,
    entries: Vec<Entry>,
}

impl LaneIndex {
    fn lane(&self, lane: u32) -> &[Entry] {
        let (a, b) = (self.starts[lane as usize], self.starts[lane as usize + 1]);
        &self.entries[a as usize..b as usize]
    }
}

/// The engine: vehicles, their lanes, and the scratch a step reuses.
#[derive(Clone, Debug)]
pub struct Traffic {
    /// The vehicles, by slot.
    pub vehicles: Vec<Vehicle>,
    /// Stop lines (set by the caller from the lights' states).
    pub stop_lines: Vec<StopLine>,
    /// Contacts seen so far (each pair once per contact episode).
    pub contacts: Vec<Contact>,
    tick: u64,
    dt: f64,
    index: LaneIndex,
    order: Vec<u32>,
    ghost_done: Vec<bool>,
    cursor: Vec<u32>,
    /// Decided this step: acceleration and lane change (−1 right, +1 left).
    decided: Vec<(f64, i8)>,
    touching: std::collections::BTreeSet<(u32, u32)>,
    stops_by_lane: Vec<(u32, u32)>,
    /// Per junction lane: the earliest arrival (s) and slot of a vehicle
    /// about to enter it, from this step's snapshot.
    claims: Vec<Option<(f64, u32)>>,
    /// [`Traffic::settle`] is looking: every stop counts, reachable or not.
    settling: bool,
}

/// splitmix64: the successor a vehicle takes at a fork, from its route
/// value and the lane (no state: the same choice however often asked).
fn mix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Traffic {
    /// An engine stepping every `dt` seconds.
    pub fn new(dt: f64) -> Self {
        Traffic {
            vehicles: Vec::new(),
            stop_lines: Vec::new(),
            contacts: Vec::new(),
            tick: 0,
            dt,
            index: LaneIndex::default(),
            order: Vec::new(),
            ghost_done: Vec::new(),
            cursor: Vec::new(),
            decided: Vec::new(),
            touching: Default::default(),
            stops_by_lane: Vec::new(),
            claims: Vec::new(),
            settling: false,
        }
    }

    /// Steps taken.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Adds a vehicle; returns its slot.
    pub fn add(&mut self, v: Vehicle) -> u32 {
        self.vehicles.push(v);
        let slot = self.vehicles.len() as u32 - 1;
        self.order.push(slot);
        slot
    }

    /// Slows the vehicles `slots` (just placed) to what lets
    /// them stop comfortably behind what is ahead of them — a slower
    /// vehicle or obstacle, a red light, a crossing they must yield at —
    /// so that nothing starts on a course it could not brake out of.
    pub fn settle(&mut self, g: &LaneGraph, obstacles: &[Obstacle], slots: &[u32]) {
        self.build_index(g, obstacles);
        self.settling = true;
        for &slot in slots {
            let slot = slot as usize;
            let v = &self.vehicles[slot];
            if !v.active {
                continue;
            }
            let (l, _) = self.leader(g, slot as u32, (v.lane, None), v.u, 0.5 * v.length);
            if l.gap.is_finite() && l.speed < v.v {
                let b = v.params.comfort_decel;
                let room = (l.gap - v.params.min_gap).max(0.0);
                let most = (l.speed * l.speed + 2.0 * b * room).sqrt();
                self.vehicles[slot].v = v.v.min(most);
            }
        }
        self.settling = false;
    }

    /// The successor of `lane` that vehicle `route` takes (`None`: dead end).
    fn next_lane(g: &LaneGraph, lane: u32, v: &Vehicle) -> Option<u32> {
        let next = &g.lanes[lane as usize].next;
        match next.len() {
            0 => None,
            1 => Some(next[0]),
            n => next
                .iter()
                .copied()
                .find(|l| v.goals.route.contains(l))
                .or(Some(
                    next[(mix(v.route ^ u64::from(lane)) % n as u64) as usize],
                )),
        }
    }

    /// One step: index, decide, commit. `obstacles` are this step's actors
    /// the engine does not drive.
    pub fn step(&mut self, g: &LaneGraph, obstacles: &[Obstacle]) {
        self.build_index(g, obstacles);
        self.decide(g);
        self.commit(g);
        self.tick += 1;
    }

    fn build_index(&mut self, g: &LaneGraph, obstacles: &[Obstacle]) {
        self.count_lanes(g, obstacles);
        self.fill_vehicles();
        self.fill_obstacles_and_sort(g, obstacles);
        self.claim_junctions(g);
        self.index_stop_lines();
    }

    /// Each lane's share of the index (vehicles, their ghosts, obstacles),
    /// and the entries sized for it.
    fn count_lanes(&mut self, g: &LaneGraph, obstacles: &[Obstacle]) {
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
    fn fill_vehicles(&mut self) {
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
    fn fill_obstacles_and_sort(&mut self, g: &LaneGraph, obstacles: &[Obstacle]) {
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
    fn claim_junctions(&mut self, g: &LaneGraph) {
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
    fn index_stop_lines(&mut self) {
        // Stop lines by lane, for the look-ahead.
        self.stops_by_lane.clear();
        for (k, s) in self.stop_lines.iter().enumerate() {
            if s.red || s.yellow {
                self.stops_by_lane.push((s.lane, k as u32));
            }
        }
        self.stops_by_lane.sort_unstable();
    }

    /// The nearest constraint ahead of a vehicle at `u` in `lane`
    /// (`half` its half length, `me` its slot): the vehicle in front, or
    /// a red stop line it can still stop at, or a dead end — whichever
    /// asks for the lowest acceleration — within [`LOOKAHEAD_M`].
    /// `at`: where the vehicle's own entry is in `lane`'s part of the
    /// index, when the caller knows it (no search then).
    fn leader(
        &self,
        g: &LaneGraph,
        me: u32,
        (lane, at): (u32, Option<usize>),
        u: f64,
        half: f64,
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
            let a = driver::acceleration(p, veh.v, Some(l));
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
    fn at_junction(
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
    fn must_wait(&self, g: &LaneGraph, me: u32, lane: u32, ahead: f64) -> bool {
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
    fn junction_leaders(
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
    fn red_line(&self, lane: u32, u: f64) -> Option<(f64, bool)> {
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
    fn dead_end_in(g: &LaneGraph, mut lane: u32, u: f64, v: &Vehicle) -> f64 {
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

    fn accel_with(&self, who: u32, v: f64, l: Option<Leader>) -> f64 {
        // Obstacles (sut.car, planned actors) are judged as careful cars.
        let p = if who & OBSTACLE == 0 {
            self.vehicles[who as usize].params
        } else {
            DriverParams::for_category("car", v.max(1.0))
        };
        driver::acceleration(&p, v, l)
    }

    fn decide(&mut self, g: &LaneGraph) {
        let n = self.vehicles.len();
        let mut decided = std::mem::take(&mut self.decided);
        decided.clear();
        decided.resize(n, (0.0, 0));
        let period = ((DECISION_PERIOD_S / self.dt).round() as u64).max(1);
        let mut touching = Vec::new();
        // Lane by lane through the index: neighbours' entries are next to
        // each other in memory, and each vehicle's own entry is known (the
        // result is per slot, the same in any order).
        let own = (0..self.index.entries.len()).filter(|&k| {
            let e = &self.index.entries[k];
            e.who & OBSTACLE == 0 && !e.ghost
        });
        for k in own {
            let me = self.index.entries[k].who;
            let lane_start = self.index.starts[self.vehicles[me as usize].lane as usize] as usize;
            let at = k - lane_start;
            let slot = me as usize;
            let v = &self.vehicles[slot];
            if !v.active {
                continue;
            }
            let half = 0.5 * v.length;
            let (l, mut a) = self.leader(g, me, (v.lane, Some(at)), v.u, half);
            if l.gap <= 0.0 {
                touching.push((me, v.lane, v.u));
            }
            if let Some(f) = v.from {
                // Mid-change: the slower of both lanes (highway-env).
                a = a.min(self.leader(g, me, (f, None), v.u, half).1);
            }
            a = a.min(self.courtesy(g, me)).min(v.track());
            let mut change = 0;
            if let Some(target) = v.goals.lane
                && v.from.is_none()
                && target != v.lane
            {
                change = self.forced_change(g, me, target);
            }
            // In a lane that ends, drivers look for a gap five times as
            // often, standing or not; elsewhere standing drivers stay.
            let ending = Self::dead_end_in(g, v.lane, v.u, v).is_finite();
            let every = if ending { (period / 5).max(1) } else { period };
            if v.from.is_none()
                && v.goals.lane.is_none()
                && !v.at_dead_end
                && (v.v > 1.0 || ending)
                && (self.tick + slot as u64).is_multiple_of(every)
            {
                change = self.mobil(g, me, a, l);
            }
            decided[slot] = (a, change);
        }
        self.decided = decided;
        for (me, lane, u) in touching {
            self.note_contact(me, lane, u);
        }
    }

    /// The nearest occupant behind `u` in `lane` (other than `me`), or at
    /// the end of a lane leading into it, with the distance between their
    /// centres along the lanes.
    fn follower(&self, g: &LaneGraph, me: u32, lane: u32, u: f64) -> Option<(Entry, f64)> {
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
    fn courtesy(&self, g: &LaneGraph, me: u32) -> f64 {
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

    fn note_contact(&mut self, me: u32, lane: u32, u: f64) {
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
    fn forced_change(&self, g: &LaneGraph, me: u32, target: u32) -> i8 {
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
    fn clear_of_obstacle(&self, f: &Entry, gap: f64, me: &Vehicle) -> bool {
        f.who & OBSTACLE == 0 || gap >= 2.0 + (f.v - me.v).max(0.0) * me.change_s()
    }

    /// Every such actor behind `u` in `lane` within 150 m (not only the
    /// nearest occupant: one may come up behind a car that is leaving).
    fn clear_of_obstacles_behind(&self, me: u32, lane: u32, u: f64, half: f64) -> bool {
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
    fn mobil(&self, g: &LaneGraph, me: u32, a_now: f64, lead_now: Leader) -> i8 {
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
    fn before_and_after(&self, f: &Entry, now: Leader, after: Leader) -> (f64, f64) {
        (
            self.accel_with(f.who, f.v, Some(now)),
            self.accel_with(f.who, f.v, Some(after)),
        )
    }

    /// MOBIL for one neighbouring lane: `None` when the change is unsafe,
    /// not physically free or not worth it; else its gain.
    fn weigh_side(&self, g: &LaneGraph, c: &SideCase) -> Option<f64> {
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

    fn commit(&mut self, g: &LaneGraph) {
        let dt = self.dt;
        // Changes accepted this step, by target lane and u: a second driver
        // aiming at the same gap from the other side waits (slot order).
        let mut claimed: Vec<(u32, f64, f64)> = Vec::new();
        for (slot, &(a, change)) in self.decided.iter().enumerate() {
            let v = &mut self.vehicles[slot];
            if !v.active {
                continue;
            }
            if change != 0 {
                let info = &g.lanes[v.lane as usize];
                let target = if change > 0 { info.left } else { info.right };
                if let Some(t) = target {
                    let reach = v.length + v.params.min_gap;
                    let free = claimed
                        .iter()
                        .all(|&(l, u, r)| l != t || (u - v.u).abs() > 0.5 * (reach + r));
                    if free {
                        claimed.push((t, v.u, reach));
                        let w = 0.5 * (info.width + g.lanes[t as usize].width);
                        v.lat += if change > 0 { -w } else { w };
                        v.from = Some(v.lane);
                        v.lane = t;
                        v.lane_changes += 1;
                    }
                }
            }
            // Ballistic update; a stop inside the step stops there.
            let (du, v_new) = if v.v + a * dt < 0.0 {
                (-v.v * v.v / (2.0 * a), 0.0)
            } else {
                (v.v * dt + 0.5 * a * dt * dt, v.v + a * dt)
            };
            v.a = a;
            v.u += du;
            v.v = v_new;
            if v.lat != 0.0 {
                let w = g.lanes[v.lane as usize].width;
                let step = w / v.change_s() * dt;
                v.lat = if v.lat.abs() <= step {
                    0.0
                } else {
                    v.lat - step * v.lat.signum()
                };
                if v.lat == 0.0 {
                    v.from = None;
                }
            }
            while v.u > g.lanes[v.lane as usize].length {
                match Self::next_lane(g, v.lane, v) {
                    Some(n) => {
                        v.u -= g.lanes[v.lane as usize].length;
                        v.lane = n;
                        v.from = None;
                    }
                    None => {
                        // A dead end: it stops at the lane's end, on the road.
                        v.u = g.lanes[v.lane as usize].length;
                        v.v = 0.0;
                        v.a = 0.0;
                        v.at_dead_end = true;
                    }
                }
            }
        }
        // Contacts end when the pair is apart again.
        let touching = std::mem::take(&mut self.touching);
        self.touching = touching
            .into_iter()
            .filter(|&(me, other)| {
                other & OBSTACLE != 0 || {
                    let (a, b) = (&self.vehicles[me as usize], &self.vehicles[other as usize]);
                    a.active
                        && b.active
                        && a.lane == b.lane
                        && (a.u - b.u).abs() < 0.5 * (a.length + b.length)
                }
            })
            .collect();
    }
}

/// One neighbouring lane MOBIL weighs for vehicle `me`.
struct SideCase {
    me: u32,
    target: u32,
    /// My acceleration now.
    a_now: f64,
    /// How far my own lane goes on (infinite: far enough).
    here_ends: f64,
    /// The old follower's acceleration now and after I leave.
    old_follower: Option<(f64, f64)>,
    towards_slow_side: bool,
}

fn insertion_sort(e: &mut [Entry]) {
    for i in 1..e.len() {
        let mut j = i;
        while j > 0 && e[j - 1].u > e[j].u {
            e.swap(j - 1, j);
            j -= 1;
        }
    }
}
