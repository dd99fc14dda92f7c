//! The broad phase: every pair's minimum distance, collisions and TTC
//! over a run without testing every pair at every step (a grid of cells,
//! sleeping pairs woken by a bound on how fast they can close).

use super::*;

/// Up to this many actors the pair index is a table (n² × 4 bytes: 16 MiB
/// at 2,048); beyond, a hash map.
pub const DENSE_PAIRS: usize = 2048;

/// How far below a pair's recorded minimum its distance may go unseen (m):
/// a pair whose relative pose barely changed is not measured again while
/// its distance provably stays within this of the minimum.
pub const DISTANCE_RESOLUTION: f64 = 1e-9;

/// A pair's relative pose at its last exact distance.
#[derive(Clone, Copy, Debug)]
pub(super) struct Last {
    pub(super) rel: (f64, f64),
    pub(super) yaw: (f64, f64),
    pub(super) d: f64,
}

/// A hasher for pair indices: a multiply-xorshift of the key (the std
/// SipHash led the profile; only lookups use it — outputs are sorted).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PairHasher(u64);

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
    pub(super) near: Vec<Tracked>,
    pub(super) index_of: std::collections::HashMap<(u32, u32), usize, PairHash>,
    /// The same index as a table `i · n + j` (u32::MAX: not met yet) for up
    /// to [`DENSE_PAIRS`] actors: a hash lookup per candidate pair and step
    /// led the profile of dense traffic.
    pub(super) dense: Vec<u32>,
    pub(super) ids: Vec<String>,
    pub(super) sq: Vec<f64>,
    pub(super) sq_v: Vec<f64>,
    pub(super) n: usize,
    pub(super) last: Vec<Option<(f64, f64)>>,
    pub(super) index: BTreeMap<String, usize>,
    pub(super) order: Vec<u32>,
    /// Per actor: its shape, valid where `shape_at` is this step's number
    /// (made only for actors in a pair measured this step).
    pub(super) shapes: Vec<Shape>,
    pub(super) shape_at: Vec<usize>,
    /// Per actor: the `sin_cos` of its heading, kept while it holds.
    pub(super) trig: Vec<math::SinCosMemo>,
    pub(super) swept: Vec<[f64; 4]>,
    pub(super) near_box: Vec<[f64; 4]>,
    pub(super) ttc_box: Vec<[f64; 4]>,
    /// Per actor: the step whose `near_box`, `ttc_box` and `swept` it
    /// holds (made for every actor only when the broad phase runs, else
    /// for the actors of the pairs measured).
    pub(super) bounds_at: Vec<usize>,
    /// The actors' mean velocity this step.
    pub(super) mean_v: (f64, f64),
    /// Per actor: its position relative to the actors' mean position (a
    /// pair's relative position is the difference of these, exactly).
    pub(super) drift_pos: Vec<(f64, f64)>,
    /// Per actor: the path length its box has drifted relative to the mean
    /// (translation plus radius × turn), summed step by step: a pair's
    /// distance falls by at most the sum of both actors' growth.
    pub(super) drift: Vec<f64>,
    /// Per actor at the last broad phase: drift position, yaw and
    /// velocity relative to the mean.
    pub(super) at_sweep: Vec<SweepRef>,
    /// The candidate pairs of the last broad phase (a Verlet list: boxes
    /// grown by [`SKIN`] / 2, valid until some actor wobbled further).
    pub(super) cands: Vec<Cand>,
    /// Per actor: yaw at the last step.
    pub(super) yaw_prev: Vec<f64>,
    /// Per actor: velocity at the last step.
    pub(super) v_prev: Vec<(f64, f64)>,
    /// Per actor: the length and width of its box and its half diagonal.
    pub(super) radii: Vec<(f64, f64, f64)>,
    /// How far any pair's skip margin can have shrunk since the start: per
    /// step, twice the largest growth of one actor's drift plus
    /// [`TTC_HORIZON`] times its change of velocity (summed).
    pub(super) shrink: f64,
    /// Indices into `cands` of the candidates to look at this step; the
    /// others sleep in `asleep` until `shrink` reaches their wake.
    pub(super) awake: Vec<u32>,
    /// Sleeping candidates by wake (the bits of a positive `f64` order as
    /// the number does), least first.
    pub(super) asleep: std::collections::BinaryHeap<std::cmp::Reverse<(u64, u32)>>,
    pub(super) swept_once: bool,
}

/// A pair met so far: its (i, j), its KPIs, its last exact distance and
/// when it may be skipped.
#[derive(Clone, Debug)]
pub(super) struct Tracked {
    pub(super) ij: (u32, u32),
    pub(super) kpi: PairKpi,
    pub(super) last: Option<Last>,
    pub(super) quiet: Quiet,
}

/// An actor as the last broad phase saw it: drift position, yaw and
/// velocity relative to the mean.
#[derive(Clone, Copy, Debug)]
pub(super) struct SweepRef {
    pub(super) pos: (f64, f64),
    pub(super) yaw: f64,
    pub(super) w: (f64, f64),
}

/// A broad-phase candidate pair and its tracked pair (`u32::MAX`: none yet).
#[derive(Clone, Copy, Debug)]
pub(super) struct Cand {
    pub(super) i: u32,
    pub(super) j: u32,
    pub(super) k: u32,
}

/// What a tracked pair needs to stay untouched: its distance is at least
/// `key − drift[i] − drift[j]`; while that stays above `floor` (its minimum
/// less [`DISTANCE_RESOLUTION`], and above 0) and above what the pair can
/// close within `limit` s, no output can change.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Quiet {
    pub(super) key: f64,
    pub(super) floor: f64,
    pub(super) limit: f64,
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
pub(super) fn wake(shrink: f64, pace: f64, lb: f64, q: Quiet, (wx, wy): (f64, f64)) -> Option<f64> {
    if 0.5 * (lb - q.floor) <= pace {
        return None;
    }
    let closes = math::hypot(wx, wy) * q.limit * WAKE_SLACK;
    let margin = (lb - q.floor).min(lb - 1e-6 - closes);
    (margin > 1e-12 * (1.0 + lb.abs()) && 0.5 * margin > pace).then_some(shrink + 0.5 * margin)
}

/// A pair is put to sleep only where its margin lasts at least this many
/// steps at the current step's pace of shrinking.
pub(super) const SLEEP_STEPS: f64 = 4.0;

/// The skip test's relative cushion on its squared comparison (`1 + 1e-9`)
/// as a factor on lengths: this exceeds its square root.
pub(super) const WAKE_SLACK: f64 = 1.0 + 1e-6;

/// How a change of velocity counts against a sleeping pair's margin: the
/// longest TTC limit times [`WAKE_SLACK`].
pub(super) const WAKE_REACH: f64 = TTC_HORIZON * WAKE_SLACK;

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
            self.fit(boxes);
            self.step_pairs(t, boxes);
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

    /// Sizes the per-box caches for `boxes` when the number of actors
    /// changed.
    fn fit(&mut self, boxes: &[BodyState]) {
        let n = boxes.len();
        if self.trig.len() != n {
            self.trig = boxes.iter().map(|b| math::SinCosMemo::new(b.yaw)).collect();
            self.near_box = vec![[0.0; 4]; n];
            self.ttc_box = vec![[0.0; 4]; n];
            self.swept = vec![[0.0; 4]; n];
            self.bounds_at = vec![0; n];
            self.shapes = boxes.iter().map(Shape::of).collect();
            self.shape_at = vec![0; n];
        }
    }

    /// One step of every pair's KPIs over `boxes` (two or more): the broad
    /// phase's drift bounds, candidate pairs, their exact tests.
    fn step_pairs(&mut self, t: f64, boxes: &[BodyState]) {
        let n = boxes.len();
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

    /// Actor `i`'s half diagonal (its box's corners' distance from its
    /// centre), made again only when its box's size changes.
    pub(super) fn radius(&mut self, i: usize, b: &BodyState) -> f64 {
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
    pub(super) fn bounds(&mut self, x: usize, b: &BodyState) {
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
    pub(super) fn sweep(&mut self, boxes: &[BodyState], (cx, cy): (f64, f64)) {
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
    pub(super) fn lookup(&self, i: usize, j: usize) -> Option<usize> {
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
    pub(super) fn pair(
        &mut self,
        t: f64,
        i: usize,
        j: usize,
        boxes: &[BodyState],
    ) -> Option<(usize, f64)> {
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
