//! Checkers and KPIs over the executed states: collisions between actors
//! (oriented boxes, separating axes), off-road vehicles, minimum distance
//! (box to box) and time to collision per pair (constant velocities, swept
//! boxes), and speed and path errors against the plan.

use crate::state::BodyState;
use litesim_core::geometry::wrap_angle;
use litesim_core::math;
use serde::Serialize;
use std::collections::BTreeMap;

/// A box's corners and the trig of its heading, computed once per box and
/// step and shared by every pair test it takes part in.
#[derive(Clone, Copy, Debug)]
struct Shape {
    corners: [(f64, f64); 4],
    /// Centre.
    centre: (f64, f64),
    /// Half length and half width.
    half: (f64, f64),
    /// Centre to corner (m).
    radius: f64,
    /// `sin_cos(yaw)`.
    sc: (f64, f64),
    /// `sin_cos(yaw + π/2)`.
    sc90: (f64, f64),
}

impl Shape {
    fn of(b: &BodyState) -> Self {
        Self::with(b, math::sin_cos(b.yaw))
    }

    /// The shape of `b` whose heading's `sin_cos` is `sc`.
    fn with(b: &BodyState, sc: (f64, f64)) -> Self {
        let (hl, hw) = (b.length / 2.0, b.width / 2.0);
        Shape {
            corners: corners(b, sc),
            centre: (b.x, b.y),
            half: (hl, hw),
            radius: math::hypot(hl, hw),
            sc,
            sc90: math::sin_cos(b.yaw + std::f64::consts::FRAC_PI_2),
        }
    }
}

impl BodyState {
    /// The rectangle of the box ([`litesim_core::OrientedBox`]).
    fn rect(&self) -> litesim_core::OrientedBox {
        litesim_core::OrientedBox {
            x: self.x,
            y: self.y,
            yaw: self.yaw,
            length: self.length,
            width: self.width,
        }
    }
}

/// A box's corners, given `sin_cos` of its heading.
fn corners(b: &BodyState, sc: (f64, f64)) -> [(f64, f64); 4] {
    b.rect().corners_with(sc).map(|p| (p.x, p.y))
}

/// The interval a box's corners cover along the axis (ux, uy).
fn interval(c: &[(f64, f64); 4], ux: f64, uy: f64) -> (f64, f64) {
    c.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let d = p.0 * ux + p.1 * uy;
            (lo.min(d), hi.max(d))
        })
}

/// Whether two oriented boxes overlap (separating axis theorem).
pub fn overlap(a: &BodyState, b: &BodyState) -> bool {
    overlap_shapes(&Shape::of(a), &Shape::of(b))
}

/// The separating-axis test (the axes are the two boxes' edge directions).
fn overlap_shapes(a: &Shape, b: &Shape) -> bool {
    separation(a, b).is_none()
}

/// The widest gap between the boxes' intervals over the separating axes:
/// `None` when they overlap on every axis (the boxes overlap), else a lower
/// bound of their distance (a projection onto a unit axis never lengthens).
fn separation(a: &Shape, b: &Shape) -> Option<f64> {
    let mut widest: Option<f64> = None;
    for sh in [a, b] {
        for (ax, ay) in [sh.sc, sh.sc90] {
            // (sin, cos) → axis (cos, sin)
            let (ux, uy) = (ay, ax);
            let (a0, a1) = interval(&a.corners, ux, uy);
            let (b0, b1) = interval(&b.corners, ux, uy);
            let gap = if a1 < b0 {
                b0 - a1
            } else if b1 < a0 {
                a0 - b1
            } else {
                continue;
            };
            widest = Some(widest.map_or(gap, |w| w.max(gap)));
        }
    }
    widest
}

/// Squared distance from a point to a filled box (0 inside): the point in
/// the box's frame, clamped to its half extents.
fn point_box_sq(p: (f64, f64), b: &Shape) -> f64 {
    let (s, c) = b.sc;
    let (dx, dy) = (p.0 - b.centre.0, p.1 - b.centre.1);
    let ex = ((dx * c + dy * s).abs() - b.half.0).max(0.0);
    let ey = ((-dx * s + dy * c).abs() - b.half.1).max(0.0);
    ex * ex + ey * ey
}

/// Distance between two boxes (0 when they overlap).
pub fn distance(a: &BodyState, b: &BodyState) -> f64 {
    distance_shapes(&Shape::of(a), &Shape::of(b))
}

fn distance_shapes(a: &Shape, b: &Shape) -> f64 {
    if overlap_shapes(a, b) {
        return 0.0;
    }
    corner_distance(a, b)
}

/// The distance of two boxes that do not overlap: for two separate convex
/// polygons it is reached at a corner of one, so it is the smallest
/// distance of a corner of either to the other (filled) box.
fn corner_distance(a: &Shape, b: &Shape) -> f64 {
    let mut d2 = f64::INFINITY;
    for c in &a.corners {
        d2 = d2.min(point_box_sq(*c, b));
    }
    for c in &b.corners {
        d2 = d2.min(point_box_sq(*c, a));
    }
    d2.sqrt()
}

/// KPIs of one actor pair.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PairKpi {
    /// First actor id.
    pub a: String,
    /// Second actor id.
    pub b: String,
    /// Smallest box-to-box distance (m), to [`DISTANCE_RESOLUTION`].
    pub min_distance: f64,
    /// When it was smallest (s).
    pub min_distance_at: f64,
    /// Smallest time to collision (s): when the boxes would touch if both
    /// kept their velocities (within [`TTC_HORIZON`]); `null` when never.
    pub min_ttc: Option<f64>,
    /// When it was smallest (s).
    pub min_ttc_at: Option<f64>,
    /// First collision time (s).
    pub collision_at: Option<f64>,
    /// How the first collision happened, and who caused it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact: Option<Contact>,
}

/// Which part of a body was hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    /// The front.
    Front,
    /// The rear.
    Rear,
    /// The left side.
    Left,
    /// The right side.
    Right,
}

/// The kind of a collision, from the two headings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactKind {
    /// Same direction, a front into a rear (headings within 30°).
    RearEnd,
    /// Same direction, side to side.
    Sideswipe,
    /// Opposite directions (headings 150° or more apart).
    HeadOn,
    /// Crossing paths (between).
    Angle,
}

/// A collision's geometry at first contact and its attribution: who struck
/// whom, where, and who was not keeping its lane and speed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Contact {
    /// The kind.
    pub kind: ContactKind,
    /// Where the pair's first actor (`a`) was hit.
    pub part_a: Part,
    /// Where the second (`b`) was hit.
    pub part_b: Part,
    /// The actor that struck the other (its front, or the one that moved
    /// sideways into the other).
    pub striker: String,
    /// The actor responsible: the striker, unless the other cut into its
    /// path (it was moving sideways across the striker's heading faster
    /// than [`CUT_IN_SPEED`]); `None`: both (a head-on where neither
    /// swerved).
    pub responsible: Option<String>,
}

/// Sideways speed (m/s) across the other's heading above which an actor
/// counts as changing lanes at a contact (not keeping its lane).
pub const CUT_IN_SPEED: f64 = 0.3;

/// Where `other`'s centre lies seen from `me`: the part of `me` facing it
/// (its half extents set the diagonals that part the four sides).
fn part_facing(me: &BodyState, other: &BodyState) -> Part {
    let (s, c) = math::sin_cos(me.yaw);
    let (dx, dy) = (other.x - me.x, other.y - me.y);
    let along = (dx * c + dy * s) / (0.5 * me.length).max(1e-6);
    let across = (-dx * s + dy * c) / (0.5 * me.width).max(1e-6);
    if along.abs() >= across.abs() {
        if along >= 0.0 {
            Part::Front
        } else {
            Part::Rear
        }
    } else if across >= 0.0 {
        Part::Left
    } else {
        Part::Right
    }
}

/// `me`'s speed across `other`'s heading, towards `other` (m/s).
fn sideways_towards(me: &BodyState, other: &BodyState) -> f64 {
    let (s, c) = math::sin_cos(other.yaw);
    let lateral_v = -me.vx * s + me.vy * c;
    let lateral_p = -(other.x - me.x) * s + (other.y - me.y) * c;
    lateral_v * lateral_p.signum()
}

/// The geometry and attribution of a contact between `a` and `b` (ids
/// `ida`, `idb`).
pub fn contact(a: &BodyState, b: &BodyState, ida: &str, idb: &str) -> Contact {
    let (part_a, part_b) = (part_facing(a, b), part_facing(b, a));
    let alpha = wrap_angle(b.yaw - a.yaw).abs();
    let kind = if alpha >= 150f64.to_radians() {
        ContactKind::HeadOn
    } else if alpha > 30f64.to_radians() {
        ContactKind::Angle
    } else if matches!(part_a, Part::Front | Part::Rear)
        && matches!(part_b, Part::Front | Part::Rear)
    {
        ContactKind::RearEnd
    } else {
        ContactKind::Sideswipe
    };
    let (sa, sb) = (sideways_towards(a, b), sideways_towards(b, a));
    let name = |first: bool| if first { ida } else { idb }.to_string();
    let (striker, responsible) = match kind {
        ContactKind::RearEnd | ContactKind::Angle => {
            // The front that hit: a's front into b, or b's into a.
            let a_strikes = part_a == Part::Front && part_b != Part::Front;
            let struck_swerved = if a_strikes { sb } else { sa } > CUT_IN_SPEED;
            let striker = name(a_strikes);
            let responsible = if kind == ContactKind::RearEnd && struck_swerved {
                // It cut into the striker's path: the cut-in's fault.
                name(!a_strikes)
            } else {
                striker.clone()
            };
            (striker, Some(responsible))
        }
        ContactKind::Sideswipe | ContactKind::HeadOn => {
            // The one moving sideways into the other.
            let a_moves = sa >= sb;
            let striker = name(a_moves);
            let responsible = (sa.max(sb) > CUT_IN_SPEED).then(|| striker.clone());
            (striker, responsible)
        }
    };
    Contact {
        kind,
        part_a,
        part_b,
        striker,
        responsible,
    }
}

/// KPIs of one actor.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ActorKpi {
    /// Id.
    pub id: String,
    /// Largest |speed − planned speed| (m/s).
    pub max_speed_error: f64,
    /// Largest distance from the planned position (m).
    pub max_path_error: f64,
    /// RMS distance from the planned position (m), set by [`Kpis::finish`].
    pub rms_path_error: f64,
    /// RMS |speed − planned speed| (m/s); for calibration reports, not in
    /// run summaries.
    #[serde(skip)]
    pub rms_speed_error: f64,
    /// First time off every road (s), vehicles only.
    pub off_road_at: Option<f64>,
    /// Distance travelled (m).
    pub distance: f64,
    /// Top speed (m/s).
    pub max_speed: f64,
    /// The first red light run: (box id, time s).
    pub ran_red_light: Option<(String, f64)>,
}

/// Pairs closer than this (box bound to box bound, m) are tracked: their
/// distance, TTC and collisions are computed exactly.
pub const NEAR: f64 = 30.0;
/// Pairs whose boxes, swept along their velocities over this time, could
/// meet are tracked too (s); it bounds the TTCs reported.
pub const TTC_HORIZON: f64 = 5.0;

/// Time until two boxes touch if both keep their velocities: the swept
/// separating-axis test (for translating convex polygons the edge normals
/// of both are the only candidate axes). `None` when they never touch,
/// `Some(0)` when they overlap now.
pub fn time_to_collision(a: &BodyState, b: &BodyState) -> Option<f64> {
    ttc_shapes(&Shape::of(a), &Shape::of(b), b.vx - a.vx, b.vy - a.vy)
}

/// [`time_to_collision`] of b moving at (wx, wy) relative to a.
fn ttc_shapes(a: &Shape, b: &Shape, wx: f64, wy: f64) -> Option<f64> {
    let (mut enter, mut exit) = (0.0f64, f64::INFINITY);
    for sh in [a, b] {
        let (s, c) = sh.sc;
        for (ux, uy) in [(c, s), (-s, c)] {
            let (a0, a1) = interval(&a.corners, ux, uy);
            let (b0, b1) = interval(&b.corners, ux, uy);
            let w = wx * ux + wy * uy;
            if w.abs() < 1e-12 {
                if b1 < a0 || a1 < b0 {
                    return None;
                }
                continue;
            }
            // b's interval [b0 + wτ, b1 + wτ] meets [a0, a1] for τ in [t0, t1].
            let (t0, t1) = ((a0 - b1) / w, (a1 - b0) / w);
            let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
            enter = enter.max(t0);
            exit = exit.min(t1);
            if enter > exit {
                return None;
            }
        }
    }
    (exit >= 0.0 && enter.is_finite()).then_some(enter.max(0.0))
}

/// Up to this many actors the pair index is a table (n² × 4 bytes: 16 MiB
/// at 2,048); beyond, a hash map.
pub const DENSE_PAIRS: usize = 2048;

/// How far below a pair's recorded minimum its distance may go unseen (m):
/// a pair whose relative pose barely changed is not measured again while
/// its distance provably stays within this of the minimum.
pub const DISTANCE_RESOLUTION: f64 = 1e-9;

/// A pair's relative pose at its last exact distance.
#[derive(Clone, Copy, Debug)]
struct Last {
    rel: (f64, f64),
    yaw: (f64, f64),
    d: f64,
}

/// A hasher for pair indices: a multiply-xorshift of the key (the std
/// SipHash led the profile; only lookups use it — outputs are sorted).
#[derive(Clone, Copy, Debug, Default)]
struct PairHasher(u64);

impl std::hash::Hasher for PairHasher {
    fn finish(&self) -> u64 {
        let x = self.0.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        x ^ (x >> 29)
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(*b);
        }
    }
    fn write_u32(&mut self, n: u32) {
        self.0 = (self.0 << 32) ^ u64::from(n);
    }
}

type PairHash = std::hash::BuildHasherDefault<PairHasher>;

/// Accumulates KPIs step by step.
///
/// Pairs go through a broad phase first: each box swept along its
/// velocity over [`TTC_HORIZON`] and grown by [`NEAR`]/2 gives an
/// axis-aligned interval in x and y; the intervals are sorted by x and
/// swept (sort-and-sweep), and only pairs whose intervals overlap in x and
/// y get the narrow phase: the exact box distance where it could set a new
/// minimum, and the swept-box TTC. Pairs that never come within `NEAR`
/// and cannot meet within the horizon are not reported. The cost grows as
/// n log n (plus the pairs that really are close), not n².
///
/// Two things keep steps cheap where traffic moves together. The broad
/// phase runs on boxes grown by [`SKIN`]/2 and its candidate list is kept
/// until some actor has moved (relative to the actors' mean position), turned
/// or changed its relative velocity enough to leave that margin (a Verlet
/// list). And each actor's drift relative to the mean is summed step by
/// step: a tracked pair's distance is at least its last bound less both
/// actors' drift since, so while that stays above its recorded minimum and
/// beyond what the pair can close within the TTC horizon, the pair is
/// skipped without touching its boxes (a property test checks against
/// every pair measured exactly at every step).
#[derive(Clone, Debug, Default)]
pub struct Kpis {
    /// Pairs that came near, in (i, j) order of the actor list (filled by
    /// [`Kpis::finish`]).
    pub pairs: Vec<PairKpi>,
    /// Per actor.
    pub actors: Vec<ActorKpi>,
    /// Pairs met so far, in the order first met, with their index by (i, j)
    /// (a lookup table only: the output is sorted by (i, j)).
    near: Vec<Tracked>,
    index_of: std::collections::HashMap<(u32, u32), usize, PairHash>,
    /// The same index as a table `i · n + j` (u32::MAX: not met yet) for up
    /// to [`DENSE_PAIRS`] actors: a hash lookup per candidate pair and step
    /// led the profile of dense traffic.
    dense: Vec<u32>,
    ids: Vec<String>,
    sq: Vec<f64>,
    sq_v: Vec<f64>,
    n: usize,
    last: Vec<Option<(f64, f64)>>,
    index: BTreeMap<String, usize>,
    order: Vec<u32>,
    /// Per actor: its shape, valid where `shape_at` is this step's number
    /// (made only for actors in a pair measured this step).
    shapes: Vec<Shape>,
    shape_at: Vec<usize>,
    /// Per actor: the `sin_cos` of its heading, kept while it holds.
    trig: Vec<math::SinCosMemo>,
    swept: Vec<[f64; 4]>,
    near_box: Vec<[f64; 4]>,
    ttc_box: Vec<[f64; 4]>,
    /// Per actor: the step whose `near_box`, `ttc_box` and `swept` it
    /// holds (made for every actor only when the broad phase runs, else
    /// for the actors of the pairs measured).
    bounds_at: Vec<usize>,
    /// The actors' mean velocity this step.
    mean_v: (f64, f64),
    /// Per actor: its position relative to the actors' mean position (a
    /// pair's relative position is the difference of these, exactly).
    drift_pos: Vec<(f64, f64)>,
    /// Per actor: the path length its box has drifted relative to the mean
    /// (translation plus radius × turn), summed step by step: a pair's
    /// distance falls by at most the sum of both actors' growth.
    drift: Vec<f64>,
    /// Per actor at the last broad phase: drift position, yaw and
    /// velocity relative to the mean.
    at_sweep: Vec<SweepRef>,
    /// The candidate pairs of the last broad phase (a Verlet list: boxes
    /// grown by [`SKIN`] / 2, valid until some actor wobbled further).
    cands: Vec<Cand>,
    /// Per actor: yaw at the last step.
    yaw_prev: Vec<f64>,
    /// Per actor: velocity at the last step.
    v_prev: Vec<(f64, f64)>,
    /// Per actor: the length and width of its box and its half diagonal.
    radii: Vec<(f64, f64, f64)>,
    /// How far any pair's skip margin can have shrunk since the start: per
    /// step, twice the largest growth of one actor's drift plus
    /// [`TTC_HORIZON`] times its change of velocity (summed).
    shrink: f64,
    /// Indices into `cands` of the candidates to look at this step; the
    /// others sleep in `asleep` until `shrink` reaches their wake.
    awake: Vec<u32>,
    /// Sleeping candidates by wake (the bits of a positive `f64` order as
    /// the number does), least first.
    asleep: std::collections::BinaryHeap<std::cmp::Reverse<(u64, u32)>>,
    swept_once: bool,
}

/// A pair met so far: its (i, j), its KPIs, its last exact distance and
/// when it may be skipped.
#[derive(Clone, Debug)]
struct Tracked {
    ij: (u32, u32),
    kpi: PairKpi,
    last: Option<Last>,
    quiet: Quiet,
}

/// An actor as the last broad phase saw it: drift position, yaw and
/// velocity relative to the mean.
#[derive(Clone, Copy, Debug)]
struct SweepRef {
    pos: (f64, f64),
    yaw: f64,
    w: (f64, f64),
}

/// A broad-phase candidate pair and its tracked pair (`u32::MAX`: none yet).
#[derive(Clone, Copy, Debug)]
struct Cand {
    i: u32,
    j: u32,
    k: u32,
}

/// What a tracked pair needs to stay untouched: its distance is at least
/// `key − drift[i] − drift[j]`; while that stays above `floor` (its minimum
/// less [`DISTANCE_RESOLUTION`], and above 0) and above what the pair can
/// close within `limit` s, no output can change.
#[derive(Clone, Copy, Debug, Default)]
struct Quiet {
    key: f64,
    floor: f64,
    limit: f64,
}

/// A pair's skip test at `t0` holds while its bound `lb` stays above the
/// floor and above what the pair closes within `limit` (≤ [`TTC_HORIZON`]).
/// Until then the bound falls by at most both actors' drift growth and the
/// closing speed |w| grows by at most both actors' change of velocity, so
/// the test surely passes again while the summed shrink of the margin
/// stays below its margin at `t0` — half of it here, a cushion far above
/// the rounding of the sums. Returns the `shrink` it may sleep until
/// — or `None` where that is within `pace` of `shrink`: a pair sleeps
/// only where its margin lasts several steps at the current pace (in
/// traffic that changes a lot a heap entry per pair and step would cost
/// more than the test it saves). Half the floor margin bounds the wake, so
/// below the pace nothing more is computed.
fn wake(shrink: f64, pace: f64, lb: f64, q: Quiet, (wx, wy): (f64, f64)) -> Option<f64> {
    if 0.5 * (lb - q.floor) <= pace {
        return None;
    }
    let closes = math::hypot(wx, wy) * q.limit * WAKE_SLACK;
    let margin = (lb - q.floor).min(lb - 1e-6 - closes);
    (margin > 1e-12 * (1.0 + lb.abs()) && 0.5 * margin > pace).then_some(shrink + 0.5 * margin)
}

/// A pair is put to sleep only where its margin lasts at least this many
/// steps at the current step's pace of shrinking.
const SLEEP_STEPS: f64 = 4.0;

/// The skip test's relative cushion on its squared comparison (`1 + 1e-9`)
/// as a factor on lengths: this exceeds its square root.
const WAKE_SLACK: f64 = 1.0 + 1e-6;

/// How a change of velocity counts against a sleeping pair's margin: the
/// longest TTC limit times [`WAKE_SLACK`].
const WAKE_REACH: f64 = TTC_HORIZON * WAKE_SLACK;

/// The broad phase's margin (m): candidate boxes are grown by half of it
/// each, and the candidate list is rebuilt once an actor's box (or its
/// sweep) has moved by half of it relative to the others.
pub const SKIN: f64 = 4.0;

impl Kpis {
    /// For these actors.
    pub fn new(ids: &[String]) -> Self {
        Kpis {
            actors: ids
                .iter()
                .map(|id| ActorKpi {
                    id: id.clone(),
                    ..ActorKpi::default()
                })
                .collect(),
            ids: ids.to_vec(),
            sq: vec![0.0; ids.len()],
            sq_v: vec![0.0; ids.len()],
            n: 0,
            last: vec![None; ids.len()],
            index: ids
                .iter()
                .enumerate()
                .map(|(i, s)| (s.clone(), i))
                .collect(),
            order: (0..ids.len() as u32).collect(),
            drift_pos: vec![(0.0, 0.0); ids.len()],
            drift: vec![0.0; ids.len()],
            yaw_prev: vec![0.0; ids.len()],
            v_prev: vec![(0.0, 0.0); ids.len()],
            // No size yet (NaN equals nothing): made at the first step.
            radii: vec![(f64::NAN, f64::NAN, 0.0); ids.len()],
            dense: if ids.len() <= DENSE_PAIRS {
                vec![u32::MAX; ids.len() * ids.len()]
            } else {
                Vec::new()
            },
            ..Kpis::default()
        }
    }

    /// Records that actor `i` passed the red light `box_id` at `t` (the first one counts).
    pub fn red_light(&mut self, i: usize, box_id: &str, t: f64) {
        let a = &mut self.actors[i];
        if a.ran_red_light.is_none() {
            a.ran_red_light = Some((box_id.to_string(), t));
        }
    }

    /// Index of an actor id.
    pub fn index(&self, id: &str) -> Option<usize> {
        self.index.get(id).copied()
    }

    /// Moves the pairs that came near into [`Kpis::pairs`], in (i, j) order,
    /// and sets each actor's RMS errors from the sums of squares.
    pub fn finish(&mut self) {
        if self.n > 0 {
            let n = self.n as f64;
            for ((a, sq), sq_v) in self.actors.iter_mut().zip(&self.sq).zip(&self.sq_v) {
                a.rms_path_error = (sq / n).sqrt();
                a.rms_speed_error = (sq_v / n).sqrt();
            }
        }
        let mut near = std::mem::take(&mut self.near);
        near.sort_by_key(|e| e.ij);
        self.index_of.clear();
        self.dense = Vec::new();
        self.pairs = near.into_iter().map(|e| e.kpi).collect();
    }

    /// Adds one step: states, planned positions and speeds, on-road flags.
    pub fn step(
        &mut self,
        t: f64,
        boxes: &[BodyState],
        planned: &[(f64, f64, f64)],
        off_road: &[bool],
    ) {
        self.n += 1;
        let n = boxes.len();
        if n > 1 {
            if self.trig.len() != n {
                self.trig = boxes.iter().map(|b| math::SinCosMemo::new(b.yaw)).collect();
                self.near_box = vec![[0.0; 4]; n];
                self.ttc_box = vec![[0.0; 4]; n];
                self.swept = vec![[0.0; 4]; n];
                self.bounds_at = vec![0; n];
                self.shapes = boxes.iter().map(Shape::of).collect();
                self.shape_at = vec![0; n];
            }
            let inv = 1.0 / n as f64;
            let (mut cx, mut cy, mut px, mut py) = (0.0, 0.0, 0.0, 0.0);
            for b in boxes {
                cx += b.vx;
                cy += b.vy;
                px += b.x;
                py += b.y;
            }
            let (cx, cy, px, py) = (cx * inv, cy * inv, px * inv, py * inv);
            // Drift relative to the mean: common motion moves no pair.
            let first = !self.swept_once;
            let mut rebuild = first;
            let mut grow = 0.0f64;
            for (i, b) in boxes.iter().enumerate() {
                let d = (b.x - px, b.y - py);
                let (ox, oy) = self.drift_pos[i];
                let r = self.radius(i, b);
                // Rounding of the differences (a few ulps of the
                // coordinates) is added so the bound stays a bound.
                let slack = 1e-15 * (b.x.abs() + b.y.abs() + px.abs() + py.abs() + 1.0);
                if !first {
                    let turn = wrap_angle(b.yaw - self.yaw_prev[i]).abs();
                    let step = math::hypot(d.0 - ox, d.1 - oy) + r * turn + slack;
                    self.drift[i] += step;
                    let (ux, uy) = self.v_prev[i];
                    // |Δv| bounded by its 1-norm (a bound is all it needs).
                    grow = grow.max(step + WAKE_REACH * ((b.vx - ux).abs() + (b.vy - uy).abs()));
                }
                self.v_prev[i] = (b.vx, b.vy);
                self.drift_pos[i] = d;
                let w = (b.vx - cx, b.vy - cy);
                if !rebuild {
                    let o = self.at_sweep[i];
                    let wobble = math::hypot(d.0 - o.pos.0, d.1 - o.pos.1)
                        + r * wrap_angle(b.yaw - o.yaw).abs()
                        + TTC_HORIZON * math::hypot(w.0 - o.w.0, w.1 - o.w.1)
                        + slack;
                    rebuild = wobble > 0.5 * SKIN - 1e-6;
                }
            }
            self.mean_v = (cx, cy);
            self.shrink += 2.0 * grow;
            // How far the margins shrink in a few steps at this step's pace.
            let pace = SLEEP_STEPS * 2.0 * grow;
            if rebuild {
                for (x, b) in boxes.iter().enumerate() {
                    self.bounds(x, b);
                }
                self.sweep(boxes, (cx, cy));
            }
            let shrink = self.shrink;
            let mut cands = std::mem::take(&mut self.cands);
            let mut awake = std::mem::take(&mut self.awake);
            while let Some(&std::cmp::Reverse((w, x))) = self.asleep.peek() {
                if f64::from_bits(w) > shrink {
                    break;
                }
                self.asleep.pop();
                awake.push(x);
            }
            let mut still = 0;
            for a in 0..awake.len() {
                let x = awake[a];
                let c = &mut cands[x as usize];
                let (i, j) = (c.i as usize, c.j as usize);
                if c.k != u32::MAX {
                    let q = self.near[c.k as usize].quiet;
                    let lb = q.key - self.drift[i] - self.drift[j];
                    // The TTC cannot beat the limit when the pair cannot
                    // close the bound within it: lb > |w| · limit, squared.
                    let (a, b) = (&boxes[i], &boxes[j]);
                    let (wx, wy) = (b.vx - a.vx, b.vy - a.vy);
                    let reach = lb - 1e-6;
                    if lb > q.floor
                        && reach > 0.0
                        && reach * reach > (wx * wx + wy * wy) * q.limit * q.limit * (1.0 + 1e-9)
                    {
                        if let Some(w) = wake(shrink, pace, lb, q, (wx, wy)) {
                            self.asleep.push(std::cmp::Reverse((w.to_bits(), x)));
                            continue;
                        }
                        awake[still] = x;
                        still += 1;
                        continue;
                    }
                }
                if let Some((k, d)) = self.pair(t, i, j, boxes) {
                    c.k = k as u32;
                    let e = &mut self.near[k];
                    let p = &e.kpi;
                    e.quiet = Quiet {
                        key: d + self.drift[i] + self.drift[j],
                        floor: (p.min_distance - DISTANCE_RESOLUTION).max(0.0),
                        limit: p.min_ttc.map_or(TTC_HORIZON, |m| m.min(TTC_HORIZON)),
                    };
                    // Asleep from the next step on while the test surely passes.
                    let q = e.quiet;
                    let lb = q.key - self.drift[i] - self.drift[j];
                    let (a, b) = (&boxes[i], &boxes[j]);
                    if let Some(w) = wake(shrink, pace, lb, q, (b.vx - a.vx, b.vy - a.vy)) {
                        self.asleep.push(std::cmp::Reverse((w.to_bits(), x)));
                        continue;
                    }
                }
                awake[still] = x;
                still += 1;
            }
            awake.truncate(still);
            self.awake = awake;
            self.cands = cands;
        }
        for (y, b) in self.yaw_prev.iter_mut().zip(boxes) {
            *y = b.yaw;
        }
        for (i, a) in self.actors.iter_mut().enumerate() {
            let (px, py, pv) = planned[i];
            let b = &boxes[i];
            let e = ((b.x - px).powi(2) + (b.y - py).powi(2)).sqrt();
            a.max_path_error = a.max_path_error.max(e);
            self.sq[i] += e * e;
            let ev = b.speed - pv;
            a.max_speed_error = a.max_speed_error.max(ev.abs());
            self.sq_v[i] += ev * ev;
            a.max_speed = a.max_speed.max(b.speed);
            if off_road[i] && a.off_road_at.is_none() {
                a.off_road_at = Some(t);
            }
            if let Some((lx, ly)) = self.last[i] {
                a.distance += ((b.x - lx).powi(2) + (b.y - ly).powi(2)).sqrt();
            }
            self.last[i] = Some((b.x, b.y));
        }
    }

    /// Actor `i`'s half diagonal (its box's corners' distance from its
    /// centre), made again only when its box's size changes.
    fn radius(&mut self, i: usize, b: &BodyState) -> f64 {
        let (l, w, r) = self.radii[i];
        if l == b.length && w == b.width {
            return r;
        }
        let r = math::hypot(b.length / 2.0, b.width / 2.0);
        self.radii[i] = (b.length, b.width, r);
        r
    }

    /// Per box: its axis-aligned bounds grown by [`NEAR`]/2 (`near_box`),
    /// swept along its velocity relative to the mean `c` over the TTC
    /// horizon (`ttc_box`), and the union of both (`swept`). Moving both
    /// boxes of a pair by the same c·τ changes no overlap, so a pair can
    /// meet within the horizon only where the boxes swept along v − c
    /// meet — and traffic that moves together sweeps (almost) nothing.
    /// (Made for actor `x`, box `b`, once per step: see `bounds_at`.)
    fn bounds(&mut self, x: usize, b: &BodyState) {
        if self.bounds_at[x] == self.n {
            return;
        }
        self.bounds_at[x] = self.n;
        let (cx, cy) = self.mean_v;
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for p in &corners(b, self.trig[x].get(b.yaw)) {
            x0 = x0.min(p.0);
            x1 = x1.max(p.0);
            y0 = y0.min(p.1);
            y1 = y1.max(p.1);
        }
        let h = 0.5 * NEAR;
        let grown = [x0 - h, x1 + h, y0 - h, y1 + h];
        let (dx, dy) = ((b.vx - cx) * TTC_HORIZON, (b.vy - cy) * TTC_HORIZON);
        let swept = [
            x0 + dx.min(0.0),
            x1 + dx.max(0.0),
            y0 + dy.min(0.0),
            y1 + dy.max(0.0),
        ];
        self.near_box[x] = grown;
        self.swept[x] = [
            grown[0].min(swept[0]),
            grown[1].max(swept[1]),
            grown[2].min(swept[2]),
            grown[3].max(swept[3]),
        ];
        self.ttc_box[x] = swept;
    }

    /// The broad phase (sort-and-sweep on the `swept` bounds grown by
    /// [`SKIN`]/2): rebuilds the candidate list and notes each actor's
    /// drift, yaw and relative velocity it was built for.
    fn sweep(&mut self, boxes: &[BodyState], (cx, cy): (f64, f64)) {
        self.swept_once = true;
        self.at_sweep.clear();
        for (b, d) in boxes.iter().zip(&self.drift_pos) {
            self.at_sweep.push(SweepRef {
                pos: *d,
                yaw: b.yaw,
                w: (b.vx - cx, b.vy - cy),
            });
        }
        let m = 0.5 * SKIN;
        // Insertion sort by the intervals' low x: the order barely changes
        // from sweep to sweep.
        let sw = &self.swept;
        for k in 1..self.order.len() {
            let mut j = k;
            while j > 0 && sw[self.order[j - 1] as usize][0] > sw[self.order[j] as usize][0] {
                self.order.swap(j - 1, j);
                j -= 1;
            }
        }
        self.cands.clear();
        let order = &self.order;
        for (k, &i) in order.iter().enumerate() {
            let i = i as usize;
            let [_, hi, ylo, yhi] = self.swept[i];
            for &j in &order[k + 1..] {
                let j = j as usize;
                let sj = self.swept[j];
                if sj[0] - m > hi + m {
                    break;
                }
                if sj[2] - m > yhi + m || sj[3] + m < ylo - m {
                    continue;
                }
                let (a, b) = (i.min(j), i.max(j));
                let k = self.lookup(a, b).map_or(u32::MAX, |k| k as u32);
                self.cands.push(Cand {
                    i: a as u32,
                    j: b as u32,
                    k,
                });
            }
        }
        // A new list starts awake: each pair goes back to sleep at its
        // first passed test (the list is rebuilt rarely where pairs sleep
        // long, and often where they hardly sleep at all).
        self.awake.clear();
        self.awake.extend(0..self.cands.len() as u32);
        self.asleep.clear();
    }

    /// The tracked pair (i < j), if met.
    fn lookup(&self, i: usize, j: usize) -> Option<usize> {
        if self.dense.is_empty() {
            self.index_of.get(&(i as u32, j as u32)).copied()
        } else {
            let x = self.dense[i * self.ids.len() + j];
            (x != u32::MAX).then_some(x as usize)
        }
    }

    /// The narrow phase of one candidate pair (i < j).
    /// Returns the tracked pair and the distance it measured, or a lower
    /// bound of it (None: not near and cannot meet; nothing done).
    fn pair(&mut self, t: f64, i: usize, j: usize, boxes: &[BodyState]) -> Option<(usize, f64)> {
        let meets = |u: &[f64; 4], v: &[f64; 4]| {
            !(u[0] > v[1] || v[0] > u[1] || u[2] > v[3] || v[2] > u[3])
        };
        self.bounds(i, &boxes[i]);
        self.bounds(j, &boxes[j]);
        let near = meets(&self.near_box[i], &self.near_box[j]);
        let can_meet = meets(&self.ttc_box[i], &self.ttc_box[j]);
        if !near && !can_meet {
            return None;
        }
        let (a, b) = (&boxes[i], &boxes[j]);
        for x in [i, j] {
            if self.shape_at[x] != self.n {
                self.shape_at[x] = self.n;
                self.shapes[x] = Shape::with(&boxes[x], self.trig[x].get(boxes[x].yaw));
            }
        }
        let (sa, sb) = (&self.shapes[i], &self.shapes[j]);
        let slot = (!self.dense.is_empty()).then(|| i * self.ids.len() + j);
        let known = match slot {
            Some(x) => (self.dense[x] != u32::MAX).then(|| self.dense[x] as usize),
            None => self.index_of.get(&(i as u32, j as u32)).copied(),
        };
        let k = match known {
            Some(k) => k,
            None => {
                self.near.push(Tracked {
                    ij: (i as u32, j as u32),
                    kpi: PairKpi {
                        a: self.ids[i].clone(),
                        b: self.ids[j].clone(),
                        min_distance: f64::INFINITY,
                        ..PairKpi::default()
                    },
                    last: None,
                    quiet: Quiet::default(),
                });
                let k = self.near.len() - 1;
                match slot {
                    Some(x) => self.dense[x] = k as u32,
                    None => {
                        self.index_of.insert((i as u32, j as u32), k);
                    }
                }
                k
            }
        };
        let (pair, p) = {
            let e = &mut self.near[k];
            (&mut e.last, &mut e.kpi)
        };
        let rel = (b.x - a.x, b.y - a.y);
        // Since the last exact distance the boxes moved relative to each
        // other by at most `moved` (common motion changes no distance;
        // turning by Δψ moves a corner by at most its radius · |Δψ|).
        let bound = pair.map(|l| {
            let moved = math::hypot(rel.0 - l.rel.0, rel.1 - l.rel.1)
                + sa.radius * wrap_angle(a.yaw - l.yaw.0).abs()
                + sb.radius * wrap_angle(b.yaw - l.yaw.1).abs();
            l.d - moved
        });
        let (d, measured) = match bound {
            // Cannot come below the minimum (within DISTANCE_RESOLUTION)
            // and cannot touch: nothing to compute (the minimum keeps an
            // exact distance; the bound is not recorded).
            Some(lb) if lb > 0.0 && lb + DISTANCE_RESOLUTION >= p.min_distance => (lb, false),
            _ => {
                // The separating axes' widest gap is a lower bound too.
                let d = match separation(sa, sb) {
                    None => 0.0,
                    Some(gap) if gap >= p.min_distance => gap,
                    Some(_) => corner_distance(sa, sb),
                };
                *pair = Some(Last {
                    rel,
                    yaw: (a.yaw, b.yaw),
                    d,
                });
                (d, true)
            }
        };
        if measured && d < p.min_distance {
            p.min_distance = d;
            p.min_distance_at = t;
        }
        if d == 0.0 && p.collision_at.is_none() {
            p.collision_at = Some(t);
            p.contact = Some(contact(a, b, &p.a, &p.b));
        }
        let (wx, wy) = (b.vx - a.vx, b.vy - a.vy);
        let closing = math::hypot(wx, wy);
        // Separate boxes without relative motion never touch (what
        // ttc_shapes answers too, at a cost). And boxes d apart closing at
        // |w| cannot touch before d / |w|: where that is beyond the horizon
        // or the pair's minimum (with a margin far above rounding), the
        // swept test cannot set a new one.
        let limit = p.min_ttc.map_or(TTC_HORIZON, |m| m.min(TTC_HORIZON));
        if d > 0.0
            && can_meet
            && closing >= 1e-12
            && d <= closing * limit + 1e-6
            && let Some(ttc) = ttc_shapes(sa, sb, wx, wy)
            && ttc <= TTC_HORIZON
            && p.min_ttc.is_none_or(|m| ttc < m)
        {
            p.min_ttc = Some(ttc);
            p.min_ttc_at = Some(t);
        }
        Some((k, d))
    }
}

/// sut.car behind one actor: how close in time, how hard it would have had
/// to brake.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LeadKpi {
    /// The actor ahead.
    pub id: String,
    /// Smallest time headway (s): the bumper gap over sut.car's speed
    /// (the time gap; SUMO's and most ADAS programs' reading of THW).
    pub min_thw: f64,
    /// When (s).
    pub min_thw_at: f64,
    /// Largest deceleration needed to avoid a crash (m/s²): `Δv² / (2 s)`
    /// while closing on it (the lead at constant speed); 0 when it never
    /// closed.
    pub max_drac: f64,
    /// When (s); 0 when it never closed.
    pub max_drac_at: f64,
}

/// sut.car and one actor at a junction's conflict area.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PetKpi {
    /// The other actor.
    pub id: String,
    /// The junction.
    pub junction: String,
    /// Post-encroachment time (s): from the first one leaving the area to
    /// the second entering it; 0 when both were in it at once.
    pub pet: f64,
    /// When the second entered (s).
    pub at: f64,
}

/// Beyond this distance (m) of sut.car no actor's passage through a
/// conflict area is tracked.
const PET_RANGE_M: f64 = 100.0;

/// Whether `b`'s box comes within `r` of `c`.
fn box_within(b: &BodyState, c: litesim_core::Vec2, r: f64) -> bool {
    let (along, across) = b.rect().outside(c);
    along * along + across * across <= r * r
}

/// Beyond this distance (m) along or across sut.car nothing is a lead.
const LEAD_RANGE_M: f64 = 150.0;

/// The ego's own KPIs: braking, jerk, where it ended.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct EgoKpi {
    /// Ego id.
    pub id: String,
    /// Largest deceleration (m/s², positive), from the speed step to step.
    pub max_decel: f64,
    /// When (s).
    pub max_decel_at: f64,
    /// Largest |jerk| (m/s³), the change of acceleration over 0.1 s.
    pub max_jerk: f64,
    /// When (s).
    pub max_jerk_at: f64,
    /// Largest |jerk| over 1 s windows (m/s³): the change of acceleration
    /// over a second, the averaging ISO 15622's limits are read with.
    pub max_jerk_1s: f64,
    /// When (s).
    pub max_jerk_1s_at: f64,
    /// Distance from the final position to the route's goal (m).
    pub distance_to_goal: f64,
    /// Final speed (m/s).
    pub final_speed: f64,
    /// Per actor sut.car followed (ahead of it in its path, the same
    /// way): the smallest time headway and the largest DRAC, in plan order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub leads: Vec<LeadKpi>,
    /// Per actor whose path crossed sut.car's at a junction's conflict
    /// area: the post-encroachment time, in plan order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub pets: Vec<PetKpi>,
    #[serde(skip)]
    areas: std::sync::Arc<[crate::runtime::traffic::ConflictArea]>,
    /// Per actor and area: its first passage (entered, left; NaN until).
    #[serde(skip)]
    passes: Vec<Vec<[f64; 2]>>,
    #[serde(skip)]
    dt: f64,
    #[serde(skip)]
    accels: std::collections::VecDeque<f64>,
    #[serde(skip)]
    accels_1s: std::collections::VecDeque<f64>,
    #[serde(skip)]
    lead_of: std::collections::BTreeMap<usize, usize>,
    /// sut.car's last heading and its (sin, cos): a car driving straight
    /// needs no trigonometry per step.
    #[serde(skip)]
    trig: (f64, (f64, f64)),
    #[serde(skip)]
    last_v: Option<f64>,
    #[serde(skip)]
    pos: (f64, f64),
}

impl EgoKpi {
    /// For the ego `id`, stepped every `dt` s.
    pub fn new(id: &str, dt: f64) -> Self {
        EgoKpi {
            id: id.to_string(),
            dt,
            // No heading yet: the first step computes its trigonometry.
            trig: (f64::NAN, (0.0, 1.0)),
            ..EgoKpi::default()
        }
    }

    /// Adds one step's speed and position.
    pub fn step(&mut self, t: f64, v: f64, x: f64, y: f64) {
        self.pos = (x, y);
        self.final_speed = v;
        let Some(last) = self.last_v.replace(v) else {
            return;
        };
        let a = (v - last) / self.dt;
        if -a > self.max_decel {
            self.max_decel = -a;
            self.max_decel_at = t;
        }
        // Jerk over 0.1 s (whole steps): a per-step difference of a
        // pedal-driven car is dominated by the pedal switching.
        let m = ((0.1 / self.dt).round() as usize).max(1);
        self.accels.push_back(a);
        if self.accels.len() > m {
            let old = self.accels.pop_front().unwrap_or(a);
            let j = (a - old) / (m as f64 * self.dt);
            if j.abs() > self.max_jerk {
                self.max_jerk = j.abs();
                self.max_jerk_at = t;
            }
        }
        let m1 = ((1.0 / self.dt).round() as usize).max(1);
        self.accels_1s.push_back(a);
        if self.accels_1s.len() > m1 {
            let old = self.accels_1s.pop_front().unwrap_or(a);
            let j = (a - old) / (m1 as f64 * self.dt);
            if j.abs() > self.max_jerk_1s {
                self.max_jerk_1s = j.abs();
                self.max_jerk_1s_at = t;
            }
        }
    }

    /// The junctions' conflict areas where post-encroachment time is
    /// measured.
    pub fn with_areas(
        mut self,
        areas: std::sync::Arc<[crate::runtime::traffic::ConflictArea]>,
    ) -> Self {
        self.areas = areas;
        self
    }

    /// Each actor near sut.car (`boxes[e]`) entering or leaving a conflict
    /// area: its first passage through each.
    fn pass(&mut self, t: f64, e: usize, boxes: &[BodyState]) {
        if self.areas.is_empty() {
            return;
        }
        if self.passes.len() < boxes.len() {
            self.passes
                .resize(boxes.len(), vec![[f64::NAN; 2]; self.areas.len()]);
        }
        let me = &boxes[e];
        for (j, b) in boxes.iter().enumerate() {
            if (b.x - me.x).abs() > PET_RANGE_M || (b.y - me.y).abs() > PET_RANGE_M {
                continue;
            }
            for (k, a) in self.areas.iter().enumerate() {
                let p = &mut self.passes[j][k];
                if !p[1].is_nan() && p[1] < t - 1e-9 {
                    // Its first passage is over.
                    continue;
                }
                if (a.centre.x - b.x).abs() > a.radius + b.length
                    || (a.centre.y - b.y).abs() > a.radius + b.length
                {
                    continue;
                }
                if box_within(b, a.centre, a.radius) {
                    if p[0].is_nan() {
                        p[0] = t;
                    }
                    p[1] = t;
                }
            }
        }
    }

    /// sut.car (`boxes[e]`) against every actor ahead of it
    /// in its path and heading the same way (within 45°): time headway and
    /// DRAC; `id(j)` names actor `j`.
    pub fn follow<'a>(
        &mut self,
        t: f64,
        e: usize,
        boxes: &[BodyState],
        id: impl Fn(usize) -> &'a str,
    ) {
        self.pass(t, e, boxes);
        let me = &boxes[e];
        let v = me.speed;
        if me.yaw.to_bits() != self.trig.0.to_bits() {
            self.trig = (me.yaw, math::sin_cos(me.yaw));
        }
        let (s, c) = self.trig.1;
        for (j, b) in boxes.iter().enumerate() {
            let (dx, dy) = (b.x - me.x, b.y - me.y);
            if j == e || dx.abs() > LEAD_RANGE_M || dy.abs() > LEAD_RANGE_M {
                continue;
            }
            let along = dx * c + dy * s;
            let across = -dx * s + dy * c;
            if along <= 0.0 || across.abs() > 0.5 * (me.width + b.width) {
                continue;
            }
            let (sb, cb) = if b.yaw == me.yaw {
                (0.0, 1.0)
            } else {
                math::sin_cos(b.yaw - me.yaw)
            };
            if cb < 0.707 {
                continue;
            }
            // The lead's extent along sut.car's heading.
            let half = 0.5 * (b.length * cb.abs() + b.width * sb.abs());
            let gap = (along - 0.5 * me.length - half).max(0.0);
            let v_lead = b.vx * c + b.vy * s;
            let k = *self.lead_of.entry(j).or_insert_with(|| {
                self.leads.push(LeadKpi {
                    id: id(j).to_string(),
                    min_thw: f64::INFINITY,
                    ..LeadKpi::default()
                });
                self.leads.len() - 1
            });
            let l = &mut self.leads[k];
            if v > 0.5 {
                let thw = gap / v;
                if thw < l.min_thw {
                    l.min_thw = thw;
                    l.min_thw_at = t;
                }
            }
            let closing = v - v_lead;
            if closing > 0.0 {
                let drac = closing * closing / (2.0 * gap.max(0.01));
                if drac > l.max_drac {
                    l.max_drac = drac;
                    l.max_drac_at = t;
                }
            }
        }
    }

    /// The post-encroachment times of sut.car (actor `e`) with every actor
    /// whose first passage through a conflict area it shared: the smallest
    /// per actor; `id(j)` names actor `j`.
    pub fn finish_pets<'a>(&mut self, e: usize, id: impl Fn(usize) -> &'a str) {
        let Some(mine) = self.passes.get(e).cloned() else {
            return;
        };
        for (j, theirs) in self.passes.iter().enumerate() {
            if j == e {
                continue;
            }
            let mut best: Option<PetKpi> = None;
            for (k, (m, o)) in mine.iter().zip(theirs).enumerate() {
                if m[0].is_nan() || o[0].is_nan() {
                    continue;
                }
                let (pet, at) = if m[1] < o[0] {
                    (o[0] - m[1], o[0])
                } else if o[1] < m[0] {
                    (m[0] - o[1], m[0])
                } else {
                    (0.0, m[0].max(o[0]))
                };
                if best.as_ref().is_none_or(|b| pet < b.pet) {
                    best = Some(PetKpi {
                        id: id(j).to_string(),
                        junction: self.areas[k].junction.clone(),
                        pet,
                        at,
                    });
                }
            }
            self.pets.extend(best);
        }
    }

    /// Closes the record against the goal `(gx, gy)`.
    pub fn finish(&mut self, gx: f64, gy: f64) {
        // Leads in plan order; a lead never followed at speed has no THW.
        let order: Vec<usize> = self.lead_of.values().copied().collect();
        let mut leads = std::mem::take(&mut self.leads);
        self.leads = order
            .into_iter()
            .map(|k| std::mem::take(&mut leads[k]))
            .filter(|l| l.min_thw.is_finite() || l.max_drac > 0.0)
            .map(|mut l| {
                if !l.min_thw.is_finite() {
                    l.min_thw = -1.0;
                }
                l
            })
            .collect();
        self.distance_to_goal = math::hypot(self.pos.0 - gx, self.pos.1 - gy);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn bx(x: f64, y: f64, yaw: f64, vx: f64, vy: f64) -> BodyState {
        BodyState {
            x,
            y,
            yaw,
            length: 4.0,
            width: 2.0,
            vx,
            vy,
            speed: vx.hypot(vy),
            acceleration: 0.0,
        }
    }

    #[test]
    fn time_headway_drac_and_jerk_over_a_second() {
        let mut k = EgoKpi::new("sut.car", 0.02);
        // sut.car at 20 m/s, a car 20 m ahead (16 m bumper gap) at 10 m/s,
        // one in the next lane, one behind.
        let boxes = [
            bx(0.0, 0.0, 0.0, 20.0, 0.0),
            bx(20.0, 0.0, 0.0, 10.0, 0.0),
            bx(10.0, 3.5, 0.0, 10.0, 0.0),
            bx(-20.0, 0.0, 0.0, 30.0, 0.0),
        ];
        let ids = ["sut.car", "lead", "beside", "behind"];
        k.follow(1.0, 0, &boxes, |j| ids[j]);
        k.finish(0.0, 0.0);
        assert_eq!(k.leads.len(), 1);
        let l = &k.leads[0];
        assert_eq!(l.id, "lead");
        assert!((l.min_thw - 0.8).abs() < 1e-12, "{l:?}");
        assert!((l.max_drac - 100.0 / 32.0).abs() < 1e-12, "{l:?}");
        // Braking ramped at 2 m/s³ for 2 s: 2 m/s³ over a second.
        let mut k = EgoKpi::new("sut.car", 0.02);
        let mut v = 20.0;
        for i in 0..200 {
            let a = -2.0 * (i as f64 * 0.02);
            v += a * 0.02;
            k.step(i as f64 * 0.02, v, 0.0, 0.0);
        }
        assert!((k.max_jerk_1s - 2.0).abs() < 1e-6, "{}", k.max_jerk_1s);
    }

    #[test]
    fn contacts_are_attributed_from_their_geometry() {
        // The ego keeps its lane at 10 m/s; a faster car runs into its rear.
        let ego = bx(0.0, 0.0, 0.0, 10.0, 0.0);
        let rear = bx(-3.9, 0.1, 0.0, 15.0, 0.0);
        let c = contact(&ego, &rear, "sut.car", "other");
        assert_eq!(
            (c.kind, c.part_a, c.part_b),
            (ContactKind::RearEnd, Part::Rear, Part::Front)
        );
        assert_eq!(c.striker, "other");
        assert_eq!(c.responsible.as_deref(), Some("other"));
        // A car cuts in just ahead, moving sideways: the ego's front hits
        // its rear, and the cut-in is responsible.
        let cut = bx(3.9, 0.3, 0.1, 10.0, -1.5);
        let c = contact(&ego, &cut, "sut.car", "other");
        assert_eq!(c.kind, ContactKind::RearEnd);
        assert_eq!(c.striker, "sut.car");
        assert_eq!(c.responsible.as_deref(), Some("other"));
        // The same car ahead keeping its lane: the ego is responsible.
        let slow = bx(3.9, 0.3, 0.0, 5.0, 0.0);
        let c = contact(&ego, &slow, "sut.car", "other");
        assert_eq!(c.responsible.as_deref(), Some("sut.car"));
        // Side by side, the other drifting into the ego's side.
        let beside = bx(0.5, 1.9, 0.0, 10.0, -1.0);
        let c = contact(&ego, &beside, "sut.car", "other");
        assert_eq!(
            (c.kind, c.part_a, c.part_b),
            (ContactKind::Sideswipe, Part::Left, Part::Right)
        );
        assert_eq!(c.responsible.as_deref(), Some("other"));
        // A crossing car's front into the ego's right side.
        let crossing = bx(0.0, -2.9, std::f64::consts::FRAC_PI_2, 0.0, 8.0);
        let c = contact(&ego, &crossing, "sut.car", "other");
        assert_eq!(
            (c.kind, c.part_a, c.part_b),
            (ContactKind::Angle, Part::Right, Part::Front)
        );
        assert_eq!(c.responsible.as_deref(), Some("other"));
    }

    /// Distance by brute force: every corner of each box to every edge of
    /// the other (0 when they overlap).
    fn brute(a: &BodyState, b: &BodyState) -> f64 {
        if overlap(a, b) {
            return 0.0;
        }
        let seg = |p: (f64, f64), s: (f64, f64), e: (f64, f64)| {
            let (dx, dy) = (e.0 - s.0, e.1 - s.1);
            let u = (((p.0 - s.0) * dx + (p.1 - s.1) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            ((s.0 + dx * u - p.0).powi(2) + (s.1 + dy * u - p.1).powi(2)).sqrt()
        };
        let (ca, cb) = (Shape::of(a).corners, Shape::of(b).corners);
        let mut d = f64::INFINITY;
        for (p, q) in [(&ca, &cb), (&cb, &ca)] {
            for c in p {
                for k in 0..4 {
                    d = d.min(seg(*c, q[k], q[(k + 1) % 4]));
                }
            }
        }
        d
    }

    proptest! {
        #[test]
        fn distance_matches_brute_force(
            x in -20.0f64..20.0, y in -20.0f64..20.0, ya in -3.2f64..3.2, yb in -3.2f64..3.2,
        ) {
            let (a, b) = (bx(0.0, 0.0, ya, 0.0, 0.0), bx(x, y, yb, 0.0, 0.0));
            let (d, r) = (distance(&a, &b), brute(&a, &b));
            prop_assert!((d - r).abs() < 1e-9, "{} vs {}", d, r);
            // The separating axes' gap never exceeds the distance.
            if let Some(g) = separation(&Shape::of(&a), &Shape::of(&b)) {
                prop_assert!(g <= r + 1e-9);
            }
        }
    }

    /// n vehicles in random traffic for `steps` steps: positions, headings
    /// and speeds from a seeded generator, each step a random acceleration
    /// and yaw rate (some vehicles keep a constant velocity, like traffic
    /// that moves together).
    fn random_traffic(seed: u64, n: usize, steps: usize) -> Vec<Vec<BodyState>> {
        let mut x = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut rnd = move || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let dt = 0.05;
        // Some runs are mostly a platoon (one velocity), some mostly free;
        // in some the free ones now and then change velocity at once (a
        // pair's TTC can then drop long before its distance does).
        let rigid = if rnd() < 0.5 { 0.8 } else { 0.2 };
        let jumps = if rnd() < 0.5 { 0.02 } else { 0.0 };
        let mut st: Vec<(f64, f64, f64, f64, bool)> = (0..n)
            .map(|_| {
                // Platoon runs: the others drift slowly around the
                // platoon's velocity (small closing speeds, long TTCs).
                let (yaw, v) = if rigid > 0.5 {
                    ((rnd() - 0.5) * 0.2, 9.0 + rnd() * 2.0)
                } else {
                    ((rnd() - 0.5) * 6.3, rnd() * 15.0)
                };
                (rnd() * 240.0, rnd() * 24.0, yaw, v, rnd() < rigid)
            })
            .collect();
        let mut frames = Vec::new();
        for _ in 0..steps {
            frames.push(
                st.iter()
                    .map(|&(x, y, yaw, v, _)| BodyState {
                        x,
                        y,
                        yaw,
                        length: 4.5,
                        width: 1.9,
                        vx: v * yaw.cos(),
                        vy: v * yaw.sin(),
                        speed: v,
                        acceleration: 0.0,
                    })
                    .collect(),
            );
            for s in &mut st {
                if s.4 {
                    (s.2, s.3) = (0.0, 10.0);
                } else if rnd() < jumps {
                    (s.2, s.3) = ((rnd() - 0.5) * 6.3, rnd() * 20.0);
                } else {
                    s.3 = (s.3 + (rnd() - 0.5) * 8.0 * dt).max(0.0);
                    s.2 += (rnd() - 0.5) * 0.8 * dt;
                }
                s.0 += s.3 * s.2.cos() * dt;
                s.1 += s.3 * s.2.sin() * dt;
            }
        }
        frames
    }

    /// Every pair of `k` (stepped over `frames`, `dt` apart) against the
    /// exact distance, collision and TTC of every frame: the minimum of a
    /// pair that comes within 10 m (to DISTANCE_RESOLUTION), the first
    /// collision and the minimum TTC of every pair that has one. (A pair
    /// tracked only for its TTC keeps the distances it met.)
    fn agrees_with_exact(
        k: &Kpis,
        ids: &[String],
        frames: &[Vec<BodyState>],
        dt: f64,
    ) -> Result<(), TestCaseError> {
        let n = ids.len();
        for i in 0..n {
            for j in i + 1..n {
                let (mut dmin, mut hit, mut ttc) = (f64::INFINITY, None, None::<f64>);
                for (s, f) in frames.iter().enumerate() {
                    let d = distance(&f[i], &f[j]);
                    dmin = dmin.min(d);
                    if d == 0.0 && hit.is_none() {
                        hit = Some(s as f64 * dt);
                    }
                    if d > 0.0
                        && let Some(x) = time_to_collision(&f[i], &f[j])
                        && x <= TTC_HORIZON
                    {
                        ttc = Some(ttc.map_or(x, |m: f64| m.min(x)));
                    }
                }
                let got = k.pairs.iter().find(|p| p.a == ids[i] && p.b == ids[j]);
                if dmin < 10.0 || ttc.is_some() {
                    let p = got.expect("a close pair is reported");
                    if dmin < 10.0 {
                        prop_assert!(
                            p.min_distance >= dmin - 1e-12
                                && p.min_distance <= dmin + DISTANCE_RESOLUTION,
                            "{}-{}: {} vs {}",
                            i,
                            j,
                            p.min_distance,
                            dmin
                        );
                    }
                    prop_assert_eq!(p.collision_at, hit);
                    prop_assert_eq!(p.min_ttc, ttc, "{}-{}", i, j);
                }
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// The broad phase, the candidate list and every skipped pair lose
        /// nothing: each pair's minimum distance (to DISTANCE_RESOLUTION),
        /// first collision and minimum TTC equal what checking every pair
        /// exactly at every step gives.
        #[test]
        fn skipping_pairs_loses_nothing(seed in any::<u64>(), n in 2usize..24) {
            let frames = random_traffic(seed, n, 160);
            let ids: Vec<String> = (0..n).map(|i| format!("v{i:02}")).collect();
            let mut k = Kpis::new(&ids);
            for (s, f) in frames.iter().enumerate() {
                k.step(s as f64 * 0.05, f, &vec![(0.0, 0.0, 0.0); n], &vec![false; n]);
            }
            k.finish();
            agrees_with_exact(&k, &ids, &frames, 0.05)?;
        }
    }

    proptest! {
        /// Pairs asleep in a platoon that moves together wake in time: after
        /// `calm` steps one vehicle brakes (or swerves) into the others, and
        /// every pair's minimum distance, first collision and minimum TTC
        /// equal the exact ones.
        #[test]
        fn sleeping_pairs_wake_in_time(
            n in 3usize..16,
            calm in 20usize..200,
            who in 0usize..16,
            brake in 0.5f64..9.0,
            swerve in -0.3f64..0.3,
            gap in 5.0f64..30.0,
        ) {
            let who = who % n;
            // Two lanes, 3.5 m apart, everyone at 20 m/s along x.
            let mut cars: Vec<(f64, f64, f64, f64)> = (0..n)
                .map(|k| ((k / 2) as f64 * gap, (k % 2) as f64 * 3.5, 20.0, 0.0))
                .collect();
            let dt = 0.02;
            let mut frames = Vec::new();
            for s in 0..calm + 150 {
                frames.push(cars.iter().map(|&(x, y, v, yaw)| bx(x, y, yaw, v * yaw.cos(), v * yaw.sin())).collect::<Vec<_>>());
                for (k, c) in cars.iter_mut().enumerate() {
                    if k == who && s >= calm {
                        c.2 = (c.2 - brake * dt).max(0.0);
                        c.3 += swerve * dt;
                    }
                    c.0 += c.2 * c.3.cos() * dt;
                    c.1 += c.2 * c.3.sin() * dt;
                }
            }
            let ids: Vec<String> = (0..n).map(|i| format!("v{i:02}")).collect();
            let mut k = Kpis::new(&ids);
            for (s, f) in frames.iter().enumerate() {
                k.step(s as f64 * dt, f, &vec![(0.0, 0.0, 0.0); n], &vec![false; n]);
            }
            k.finish();
            agrees_with_exact(&k, &ids, &frames, dt)?;
        }
    }

    #[test]
    fn ttc_is_when_the_swept_boxes_touch() {
        // Head-on in one lane: 20 m between bumpers, closing at 10 m/s.
        let a = bx(0.0, 0.0, 0.0, 5.0, 0.0);
        let b = bx(24.0, 0.0, std::f64::consts::PI, -5.0, 0.0);
        let t = time_to_collision(&a, &b).unwrap();
        assert!((t - 2.0).abs() < 1e-9, "{t}");
        // Passing in the next lane: never.
        let c = bx(24.0, 3.5, std::f64::consts::PI, -5.0, 0.0);
        assert_eq!(time_to_collision(&a, &c), None);
        // Moving apart: never; overlapping: now.
        assert_eq!(time_to_collision(&a, &bx(24.0, 0.0, 0.0, 9.0, 0.0)), None);
        assert_eq!(
            time_to_collision(&a, &bx(1.0, 0.5, 0.3, 0.0, 0.0)),
            Some(0.0)
        );
    }

    #[test]
    fn far_pairs_are_not_tracked_and_close_ones_are() {
        let ids: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let mut k = Kpis::new(&ids);
        let boxes = [
            bx(0.0, 0.0, 0.0, 10.0, 0.0),
            bx(15.0, 0.0, 0.0, 10.0, 0.0),
            bx(500.0, 0.0, 0.0, 10.0, 0.0),
        ];
        k.step(0.0, &boxes, &[(0.0, 0.0, 10.0); 3], &[false; 3]);
        k.finish();
        assert_eq!(k.pairs.len(), 1);
        assert_eq!((k.pairs[0].a.as_str(), k.pairs[0].b.as_str()), ("a", "b"));
        assert!((k.pairs[0].min_distance - 11.0).abs() < 1e-9);
    }
}
