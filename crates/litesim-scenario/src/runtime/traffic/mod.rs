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
mod index;
mod lane_change;
pub mod lanes;
mod leaders;
pub mod spawn;

use super::driver::{self, DriverParams, LaneChangeCase, Leader};
pub use lanes::{Conflict, ConflictArea, LaneGraph, LaneInfo};

/// How long a lane change takes from lane to lane (s): the plan's
/// (a `change_lane()` action lasts as long).
pub const LANE_CHANGE_S: f64 = crate::plan::LANE_CHANGE_S;
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
    /// [`Vehicle::track`]); keeping a headway, the goal's time gap.
    fn follow_params(&self) -> DriverParams {
        let p = match self.goals.speed {
            Some(goal) => DriverParams {
                desired_speed: 1.0 + 1.2 * goal.max(self.v),
                ..self.params
            },
            None => self.params,
        };
        match self.goals.time_gap {
            // Keeping a gap, the speed goal sets the pace and the
            // car-following model only bounds it: its free-road term (with
            // a desired speed well above) must not hold it back while the
            // one ahead speeds up.
            Some(time_gap) => DriverParams {
                time_gap,
                desired_speed: 1.0 + 2.0 * p.desired_speed.max(self.v),
                ..p
            },
            None => p,
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
    /// The car-following time gap (s) instead of its own, while it keeps a
    /// headway by its speed goal (`keep_time_headway`).
    pub time_gap: Option<f64>,
    /// It does not avoid collisions (`avoid_collisions(false)`): it
    /// tracks its speed goal whatever is ahead.
    pub reckless: bool,
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
    /// This step's vehicles with no gap to their leader (a buffer kept for
    /// the run).
    touched: Vec<(u32, u32, f64)>,
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
            touched: Vec::new(),
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

    fn decide(&mut self, g: &LaneGraph) {
        let n = self.vehicles.len();
        let mut decided = std::mem::take(&mut self.decided);
        decided.clear();
        decided.resize(n, (0.0, 0));
        let period = ((DECISION_PERIOD_S / self.dt).round() as u64).max(1);
        let mut touching = std::mem::take(&mut self.touched);
        touching.clear();
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
            let track = v.track();
            // In a lane that ends, drivers look for a gap five times as
            // often, standing or not; elsewhere standing drivers stay.
            let ending = Self::dead_end_in(g, v.lane, v.u, v).is_finite();
            let every = if ending { (period / 5).max(1) } else { period };
            let weighs_change = v.from.is_none()
                && v.goals.lane.is_none()
                && !v.at_dead_end
                && (v.v > 1.0 || ending)
                && (self.tick + slot as u64).is_multiple_of(every);
            // Unless MOBIL weighs a change (it reads the leader), only the
            // minimum with the speed goal's tracking matters: a leader
            // surely asking no braking need not be weighed exactly.
            let floor = (!weighs_change && !v.goals.reckless).then_some(track);
            let (l, mut a) = self.leader_above(g, me, (v.lane, Some(at)), (v.u, half), floor);
            if l.gap <= 0.0 {
                touching.push((me, v.lane, v.u));
            }
            if let Some(f) = v.from {
                // Mid-change: the slower of both lanes (highway-env).
                a = a.min(self.leader_above(g, me, (f, None), (v.u, half), floor).1);
            }
            a = a.min(self.courtesy(g, me)).min(track);
            if v.goals.reckless && track.is_finite() {
                a = track;
            }
            let mut change = 0;
            if let Some(target) = v.goals.lane
                && v.from.is_none()
                && target != v.lane
            {
                change = self.forced_change(g, me, target);
            }
            if weighs_change {
                change = self.mobil(g, me, a, l);
            }
            decided[slot] = (a, change);
        }
        self.decided = decided;
        for &(me, lane, u) in &touching {
            self.note_contact(me, lane, u);
        }
        self.touched = touching;
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
        // Contacts end when the pair is apart again (kept in place: no new
        // set each step while a pair touches).
        let vehicles = &self.vehicles;
        self.touching.retain(|&(me, other)| {
            other & OBSTACLE != 0 || {
                let (a, b) = (&vehicles[me as usize], &vehicles[other as usize]);
                a.active
                    && b.active
                    && a.lane == b.lane
                    && (a.u - b.u).abs() < 0.5 * (a.length + b.length)
            }
        });
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
