//! sut.car's own KPIs: time headway and DRAC to each actor it follows,
//! post-encroachment time at the map's conflict areas, jerk.

use super::*;

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
pub(super) const PET_RANGE_M: f64 = 100.0;

/// Whether `b`'s box comes within `r` of `c`.
pub(super) fn box_within(b: &BodyState, c: litesim_core::Vec2, r: f64) -> bool {
    let (along, across) = b.rect().outside(c);
    along * along + across * across <= r * r
}

/// Beyond this distance (m) along or across sut.car nothing is a lead.
pub(super) const LEAD_RANGE_M: f64 = 150.0;

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
    pub(super) areas: std::sync::Arc<[crate::runtime::traffic::ConflictArea]>,
    /// Per actor and area: its first passage (entered, left; NaN until).
    #[serde(skip)]
    pub(super) passes: Vec<Vec<[f64; 2]>>,
    #[serde(skip)]
    pub(super) dt: f64,
    /// The jerk windows in whole steps of `dt`: 0.1 s and 1 s (made with
    /// `dt`, not each step).
    #[serde(skip)]
    pub(super) windows: (usize, usize),
    #[serde(skip)]
    pub(super) accels: std::collections::VecDeque<f64>,
    #[serde(skip)]
    pub(super) accels_1s: std::collections::VecDeque<f64>,
    #[serde(skip)]
    pub(super) lead_of: std::collections::BTreeMap<usize, usize>,
    /// sut.car's last heading and its (sin, cos): a car driving straight
    /// needs no trigonometry per step.
    #[serde(skip)]
    pub(super) trig: (f64, (f64, f64)),
    #[serde(skip)]
    pub(super) last_v: Option<f64>,
    #[serde(skip)]
    pub(super) pos: (f64, f64),
}

impl EgoKpi {
    /// For the ego `id`, stepped every `dt` s.
    pub fn new(id: &str, dt: f64) -> Self {
        EgoKpi {
            id: id.to_string(),
            dt,
            windows: (
                ((0.1 / dt).round() as usize).max(1),
                ((1.0 / dt).round() as usize).max(1),
            ),
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
        let (m, m1) = self.windows;
        self.accels.push_back(a);
        if self.accels.len() > m {
            let old = self.accels.pop_front().unwrap_or(a);
            let j = (a - old) / (m as f64 * self.dt);
            if j.abs() > self.max_jerk {
                self.max_jerk = j.abs();
                self.max_jerk_at = t;
            }
        }
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
    pub(super) fn pass(&mut self, t: f64, e: usize, boxes: &[BodyState]) {
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
