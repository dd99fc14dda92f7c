//! Checkers and KPIs over the executed states: collisions between actors
//! (oriented boxes, separating axes), off-road vehicles, minimum distance
//! (box to box) and time-to-collision per pair, and speed and path errors
//! against the plan.

use litesim_core::math;
use serde::Serialize;
use std::collections::BTreeMap;

/// One actor's box at one step.
#[derive(Clone, Copy, Debug)]
pub struct BoxState {
    /// Centre x (m).
    pub x: f64,
    /// Centre y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
    /// Length (m).
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// World velocity x (m/s).
    pub vx: f64,
    /// World velocity y (m/s).
    pub vy: f64,
}

impl BoxState {
    fn corners(&self) -> [(f64, f64); 4] {
        let (s, c) = math::sin_cos(self.yaw);
        let (hl, hw) = (self.length / 2.0, self.width / 2.0);
        let p = |a: f64, b: f64| (self.x + a * c - b * s, self.y + a * s + b * c);
        [p(hl, hw), p(-hl, hw), p(-hl, -hw), p(hl, -hw)]
    }
}

/// Whether two oriented boxes overlap (separating axis theorem).
pub fn overlap(a: &BoxState, b: &BoxState) -> bool {
    overlap_corners(a.yaw, b.yaw, &a.corners(), &b.corners())
}

/// The separating-axis test on corners already computed (the axes are the
/// two boxes' edge directions).
fn overlap_corners(ya: f64, yb: f64, ca: &[(f64, f64); 4], cb: &[(f64, f64); 4]) -> bool {
    for yaw in [ya, yb] {
        for (ax, ay) in [
            math::sin_cos(yaw),
            math::sin_cos(yaw + std::f64::consts::FRAC_PI_2),
        ] {
            // (sin, cos) → axis (cos, sin)
            let (ux, uy) = (ay, ax);
            let proj = |c: &[(f64, f64); 4]| {
                c.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                        let d = p.0 * ux + p.1 * uy;
                        (lo.min(d), hi.max(d))
                    })
            };
            let (a0, a1) = proj(ca);
            let (b0, b1) = proj(cb);
            if a1 < b0 || b1 < a0 {
                return false;
            }
        }
    }
    true
}

fn seg_dist(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l2 = dx * dx + dy * dy;
    let u = if l2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (fx, fy) = (a.0 + dx * u - p.0, a.1 + dy * u - p.1);
    (fx * fx + fy * fy).sqrt()
}

/// Distance between two boxes (0 when they overlap).
pub fn distance(a: &BoxState, b: &BoxState) -> f64 {
    let (ca, cb) = (a.corners(), b.corners());
    if overlap_corners(a.yaw, b.yaw, &ca, &cb) {
        return 0.0;
    }
    let mut d = f64::INFINITY;
    for (p, q) in [(&ca, &cb), (&cb, &ca)] {
        for c in p.iter() {
            for k in 0..4 {
                d = d.min(seg_dist(*c, q[k], q[(k + 1) % 4]));
            }
        }
    }
    d
}

/// KPIs of one actor pair.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PairKpi {
    /// First actor id.
    pub a: String,
    /// Second actor id.
    pub b: String,
    /// Smallest box-to-box distance (m).
    pub min_distance: f64,
    /// Smallest time to collision (s) while closing; `null` when never closing.
    pub min_ttc: Option<f64>,
    /// First collision time (s).
    pub collision_at: Option<f64>,
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
    /// RMS distance from the planned position (m).
    pub rms_path_error: f64,
    /// First time off every road (s), vehicles only.
    pub off_road_at: Option<f64>,
    /// Distance travelled (m).
    pub distance: f64,
    /// Top speed (m/s).
    pub max_speed: f64,
    /// The first red light run: (box id, time s).
    pub ran_red_light: Option<(String, f64)>,
}

/// Accumulates KPIs step by step.
#[derive(Clone, Debug, Default)]
pub struct Kpis {
    /// Pairs in (i, j) order of the actor list.
    pub pairs: Vec<PairKpi>,
    /// Per actor.
    pub actors: Vec<ActorKpi>,
    sq: Vec<f64>,
    n: usize,
    last: Vec<Option<(f64, f64)>>,
    index: BTreeMap<String, usize>,
}

impl Kpis {
    /// For these actors.
    pub fn new(ids: &[String]) -> Self {
        let mut pairs = Vec::new();
        for i in 0..ids.len() {
            for j in i + 1..ids.len() {
                pairs.push(PairKpi {
                    a: ids[i].clone(),
                    b: ids[j].clone(),
                    min_distance: f64::INFINITY,
                    ..PairKpi::default()
                });
            }
        }
        Kpis {
            pairs,
            actors: ids
                .iter()
                .map(|id| ActorKpi {
                    id: id.clone(),
                    ..ActorKpi::default()
                })
                .collect(),
            sq: vec![0.0; ids.len()],
            n: 0,
            last: vec![None; ids.len()],
            index: ids
                .iter()
                .enumerate()
                .map(|(i, s)| (s.clone(), i))
                .collect(),
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

    /// Adds one step: boxes, speeds, planned positions and speeds, on-road flags.
    pub fn step(
        &mut self,
        t: f64,
        boxes: &[BoxState],
        speeds: &[f64],
        planned: &[(f64, f64, f64)],
        off_road: &[bool],
    ) {
        self.n += 1;
        let mut k = 0;
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (&boxes[i], &boxes[j]);
                let p = &mut self.pairs[k];
                k += 1;
                let d = distance(a, b);
                p.min_distance = p.min_distance.min(d);
                if d == 0.0 && p.collision_at.is_none() {
                    p.collision_at = Some(t);
                }
                // Closing speed along the line of centres.
                let (dx, dy) = (b.x - a.x, b.y - a.y);
                let r = (dx * dx + dy * dy).sqrt();
                if r > 1e-9 && d > 0.0 {
                    let closing = -((b.vx - a.vx) * dx + (b.vy - a.vy) * dy) / r;
                    if closing > 1e-3 {
                        let ttc = d / closing;
                        p.min_ttc = Some(p.min_ttc.map_or(ttc, |m: f64| m.min(ttc)));
                    }
                }
            }
        }
        for (i, a) in self.actors.iter_mut().enumerate() {
            let (px, py, pv) = planned[i];
            let b = &boxes[i];
            let e = ((b.x - px).powi(2) + (b.y - py).powi(2)).sqrt();
            a.max_path_error = a.max_path_error.max(e);
            self.sq[i] += e * e;
            a.rms_path_error = (self.sq[i] / self.n as f64).sqrt();
            a.max_speed_error = a.max_speed_error.max((speeds[i] - pv).abs());
            a.max_speed = a.max_speed.max(speeds[i]);
            if off_road[i] && a.off_road_at.is_none() {
                a.off_road_at = Some(t);
            }
            if let Some((lx, ly)) = self.last[i] {
                a.distance += ((b.x - lx).powi(2) + (b.y - ly).powi(2)).sqrt();
            }
            self.last[i] = Some((b.x, b.y));
        }
    }
}
