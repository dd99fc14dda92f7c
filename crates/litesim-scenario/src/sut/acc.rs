//! The reference adaptive cruise: the built-in SUTs `acc` and `acc-aeb`.
//!
//! It drives as an ISO 15622 ACC is allowed to (the envelope in
//! docs/closed-loop.md and the project's traffic-model reference):
//! - car-following at a constant time gap (1.5 s by default, settable
//!   1.0–2.2 s) by the ACC model — the improved IDM blended with the
//!   constant-acceleration heuristic (`runtime::driver`, the drivers' own
//!   law), so a car that cuts in is met with a comfortable brake;
//! - no braking at all for a car that cuts in but pulls away (faster than
//!   the ego: its gap grows);
//! - acceleration within the standard's speed-dependent envelope: braking
//!   at most 5 m/s² below 5 m/s down to 3.5 m/s² above 20 m/s, driving at
//!   most 4 m/s² down to 2 m/s², and the command's rate (jerk) at most
//!   5 m/s³ below 5 m/s down to 2.5 m/s³ above 20 m/s;
//! - the speed the scenario asks of sut.car as its set speed; it stops
//!   before a red (or yellow, when it still can) light on its road.
//!
//! `acc-aeb` adds an emergency-braking stage: when the time to collision
//! with the lead falls below [`AEB_TTC_S`] and the cruise's own envelope
//! cannot avoid contact, it brakes at the vehicle's limit after
//! [`AEB_DELAY_S`]; each firing is reported (when, the lead, TTC, gap).
//! Lateral: pure pursuit of the route.
//!
//! The IDM of the first closed-loop wave (`idm`) stays: `fmt-mpc` keeps
//! its speed with it.

use super::route::RoutePoint;
use super::{ObjectState, Observation, Route, Sut, SutCommand, SutError, SutInfo};
use crate::runtime::driver::{self, DriverParams, Leader};
use litesim_core::math;

/// Hardest braking the IDM of `fmt-mpc` asks for (m/s²): an emergency
/// stop on dry asphalt, whatever the model could do.
pub const EMERGENCY_DECEL: f64 = 9.0;

/// The share of the envelope the cruise commands.
const MARGIN: f64 = 0.98;

/// The AEB stage fires when the time to collision with the lead falls
/// below this (s) and the cruise cannot avoid contact within its envelope
/// (full braking at ≈ 1.1 s and a 1–1.6 s band are the typical figures of
/// the traffic-model reference, §7).
pub const AEB_TTC_S: f64 = 1.6;
/// The AEB's reaction delay (s): from the decision to braking (sensor
/// confirmation and brake build-up).
pub const AEB_DELAY_S: f64 = 0.2;

/// IDM parameters and pursuit gains of `fmt-mpc`'s speed keeping, and the
/// lane corridor margin the cruise's lead search uses.
#[derive(Clone, Debug)]
pub struct AccParams {
    /// Largest acceleration it asks (m/s²).
    pub a_max: f64,
    /// Comfortable deceleration (m/s², positive).
    pub b_comf: f64,
    /// Time gap (s).
    pub time_gap: f64,
    /// Standstill gap (m).
    pub s0: f64,
    /// Extra lateral margin of the lane corridor (m).
    pub margin: f64,
}

impl Default for AccParams {
    fn default() -> Self {
        AccParams {
            a_max: 2.0,
            b_comf: 3.0,
            time_gap: 1.5,
            s0: 2.0,
            margin: 0.3,
        }
    }
}

/// The reference cruise's envelope at speed `v` (m/s): (largest braking,
/// largest acceleration, largest jerk). ISO 15622 bounds them by speed —
/// braking 5 m/s² below 5 m/s down to 3.5 above 20 m/s, acceleration 4
/// down to 2 m/s², jerk 5 down to 2.5 m/s³, linear between. The reference
/// drives by the acceleration bound and keeps braking and jerk to the
/// highway figures at every speed (3.5 m/s², 2.5 m/s³; −3.5 m/s² is the
/// figure the standard's users treat as valid at all speeds): it is a
/// comfort reference, not the most a system may do.
pub fn envelope(v: f64) -> (f64, f64, f64) {
    let f = ((v - 5.0) / 15.0).clamp(0.0, 1.0);
    (3.5, 4.0 - 2.0 * f, 2.5)
}

/// The reference cruise.
#[derive(Clone, Debug)]
pub struct Acc {
    /// Desired time gap (s), 1.0–2.2.
    pub time_gap: f64,
    /// Standstill gap (m).
    pub s0: f64,
    /// Extra lateral margin of the lane corridor (m).
    pub margin: f64,
    /// With the emergency-braking stage (`acc-aeb`).
    pub aeb: bool,
    info: SutInfo,
    hint: usize,
    /// The last command's acceleration (m/s²): the jerk limit's start.
    last: f64,
    /// When the AEB decided to brake (s), and why; it brakes from
    /// decision + delay while the danger lasts.
    aeb_since: Option<f64>,
    /// Each AEB firing, for the summary.
    fired: Vec<String>,
}

impl Default for Acc {
    fn default() -> Self {
        Acc {
            time_gap: 1.5,
            s0: 2.0,
            margin: 0.3,
            aeb: false,
            info: SutInfo::default(),
            hint: 0,
            last: 0.0,
            aeb_since: None,
            fired: Vec::new(),
        }
    }
}

impl Acc {
    /// The cruise with its AEB stage (`acc-aeb`).
    pub fn with_aeb() -> Self {
        Acc {
            aeb: true,
            ..Acc::default()
        }
    }

    /// The cruise at time gap `t` (s); outside 1.0–2.2 s (the standard's
    /// settable range) an error naming it.
    pub fn with_time_gap(mut self, t: f64) -> Result<Self, SutError> {
        if !(1.0..=2.2).contains(&t) {
            return Err(SutError(format!(
                "acc: time gap {t} s is outside 1.0–2.2 s (ISO 15622's settable range)"
            )));
        }
        self.time_gap = t;
        Ok(self)
    }

    /// The car-following parameters at speed `v` towards `v0`.
    fn params(&self, v: f64, v0: f64) -> DriverParams {
        let (brake, accel, _) = envelope(v);
        DriverParams {
            desired_speed: v0.max(0.0),
            time_gap: self.time_gap,
            min_gap: self.s0,
            max_accel: accel,
            comfort_decel: 2.0,
            emergency_decel: brake,
            ..DriverParams::for_category("car", v0.max(0.1))
        }
    }
}

/// The lead the cruise keeps its gap to: (bumper gap m, speed along the route m/s).
pub(crate) fn lead(
    route: &Route,
    ego: &ObjectState,
    ego_s: f64,
    hint: usize,
    objects: &[ObjectState],
    margin: f64,
) -> Option<(f64, f64)> {
    nearest(route, ego, ego_s, hint, objects, margin, Route::project).map(|(l, _)| (l.gap, l.speed))
}

/// How a point is placed on the route.
type Project = fn(&Route, f64, f64, usize) -> Option<RoutePoint>;

/// The nearest object ahead whose box overlaps the ego's lane corridor
/// along the route, as a leader (gap, speed along the route, its own
/// acceleration), with its index in `objects`; `project` places a point
/// on the route.
fn nearest(
    route: &Route,
    ego: &ObjectState,
    ego_s: f64,
    hint: usize,
    objects: &[ObjectState],
    margin: f64,
    project: Project,
) -> Option<(Leader, usize)> {
    let (sy, cy) = math::sin_cos(ego.yaw);
    let mut best: Option<(Leader, usize)> = None;
    for (k, o) in objects.iter().enumerate() {
        let (dx, dy) = (o.x - ego.x, o.y - ego.y);
        // Cheap filter: ahead, within 200 m.
        if dx * cy + dy * sy < -ego.length || dx * dx + dy * dy > 200.0 * 200.0 {
            continue;
        }
        // Start the search where the object's distance ahead puts it on
        // the route (a far object would otherwise cost a full search).
        let guess = ego_s + dx * cy + dy * sy;
        let seg = route.s.partition_point(|s| *s <= guess).saturating_sub(1);
        let Some(p) = project(route, o.x, o.y, if guess > ego_s { seg } else { hint }) else {
            continue;
        };
        // The object's half extent across the route, from its heading.
        let (so, co) = math::sin_cos(o.yaw - p.heading);
        let half_across = 0.5 * (o.length * so.abs() + o.width * co.abs());
        let half_along = 0.5 * (o.length * co.abs() + o.width * so.abs());
        if p.lateral.abs() > 0.5 * ego.width + half_across + margin {
            continue;
        }
        let gap = p.s - ego_s - 0.5 * ego.length - half_along;
        if p.s <= ego_s {
            continue;
        }
        let (sh, ch) = math::sin_cos(p.heading);
        let v_along = o.vx * ch + o.vy * sh;
        if best.is_none_or(|b| gap < b.0.gap) {
            let l = Leader {
                gap,
                speed: v_along,
                accel: o.acceleration,
            };
            best = Some((l, k));
        }
    }
    best
}

/// [`Route::project`], with the route's last segment carried on straight
/// past its end: an object beyond sut.car's goal is still that far ahead
/// (not at the goal, which would read as a lead at no gap).
fn beyond(route: &Route, x: f64, y: f64, hint: usize) -> Option<RoutePoint> {
    let mut p = route.project(x, y, hint)?;
    let n = route.points.len();
    if p.segment + 2 == n {
        let end = route.points[n - 1];
        let (sh, ch) = math::sin_cos(p.heading);
        let (dx, dy) = (x - end[0], y - end[1]);
        let past = dx * ch + dy * sh;
        if past > 0.0 {
            p.s = route.length() + past;
            p.lateral = -dx * sh + dy * ch;
        }
    }
    Some(p)
}

/// IDM acceleration at speed `v` towards `v0`, with an optional lead (gap, speed).
pub(crate) fn idm(p: &AccParams, v: f64, v0: f64, lead: Option<(f64, f64)>) -> f64 {
    let free = if v0 > 0.1 {
        p.a_max * (1.0 - (v / v0).powi(4))
    } else {
        // Asked to stand: brake comfortably to a stop.
        -p.b_comf * v.clamp(0.0, 1.0)
    };
    match lead {
        Some((gap, vl)) => {
            let dv = v - vl;
            let s_star =
                p.s0 + (v * p.time_gap + v * dv / (2.0 * (p.a_max * p.b_comf).sqrt())).max(0.0);
            let gap = gap.max(0.1);
            free.min(p.a_max) - p.a_max * (s_star / gap) * (s_star / gap)
        }
        None => free,
    }
}

/// Pure pursuit: the curvature that reaches the route point `look` m ahead.
pub(crate) fn pursuit(route: &Route, ego: &ObjectState, s: f64, look: f64) -> f64 {
    let remaining = route.length() - s;
    if remaining < 0.5 {
        return 0.0;
    }
    let ([tx, ty], _) = route.at(s + look.min(remaining.max(0.5)));
    let (sy, cy) = math::sin_cos(ego.yaw);
    let (dx, dy) = (tx - ego.x, ty - ego.y);
    let ly = -sy * dx + cy * dy;
    let d2 = dx * dx + dy * dy;
    if d2 < 1e-6 { 0.0 } else { 2.0 * ly / d2 }
}

impl Acc {
    /// The lead: the nearest object in the lane corridor, or a red (or
    /// yellow, when it can still stop comfortably) light's stop line on the
    /// ego's road as a standing one; with the lead's id.
    fn lead(&self, obs: &Observation, s: f64) -> (Option<Leader>, String) {
        let ego = &obs.ego;
        let route = &self.info.route;
        let found = nearest(route, ego, s, self.hint, &obs.objects, self.margin, beyond);
        let mut id = found.map_or(String::new(), |(_, k)| obs.objects[k].id.clone());
        let mut lead = found.map(|(l, _)| l);
        let Some(rp) = &obs.road else {
            return (lead, id);
        };
        let dir = if rp.lane < 0 { 1.0 } else { -1.0 };
        let (brake, _, _) = envelope(ego.speed);
        for l in &obs.lights {
            if l.road != rp.road || !(l.color == "red" || l.color == "yellow") {
                continue;
            }
            let ahead = (l.s - rp.s) * dir - 0.5 * ego.length;
            // Yellow: stop only when that is within the envelope.
            let can_stop = ego.speed * ego.speed / (2.0 * brake) < ahead;
            if ahead > 0.0 && (l.color == "red" || can_stop) && lead.is_none_or(|b| ahead < b.gap) {
                lead = Some(Leader {
                    gap: ahead,
                    speed: 0.0,
                    accel: 0.0,
                });
                id = format!("the stop line of light {}", l.id);
            }
        }
        (lead, id)
    }

    /// The cruise's acceleration: the ACC model within the
    /// envelope, no braking for a lead that pulls away, the jerk limited.
    fn cruise(&mut self, v: f64, v0: f64, lead: Option<Leader>, dt: f64) -> f64 {
        let p = self.params(v, v0);
        let mut a = driver::acceleration(&p, v, lead);
        if let Some(l) = lead {
            // Pulling away: faster than the ego, the gap grows. Whatever
            // the lead does next is met when it is no longer faster.
            let pulling_away = l.gap > 0.0 && l.speed > v;
            if pulling_away && a < 0.0 {
                // The lead asks for nothing: slow only for the set speed,
                // and do not speed up into its gap.
                a = driver::acceleration(&p, v, None).min(0.0);
            }
        }
        // 2 % inside the envelope: what the vehicle does stays within it
        // whatever its rounding.
        let (brake, accel, jerk) = envelope(v);
        let a = a.clamp(-MARGIN * brake, MARGIN * accel);
        let step = MARGIN * jerk * dt;
        let a = a.clamp(self.last - step, self.last + step);
        // Standing still with nothing to do: no creeping backwards.
        if v <= 0.0 && a < 0.0 { 0.0 } else { a }
    }

    /// The AEB stage: whether it brakes now, at time `t`, for `lead`. It
    /// decides when the time to collision is below [`AEB_TTC_S`] and the
    /// envelope's braking cannot avoid contact; it brakes from the
    /// decision plus [`AEB_DELAY_S`] while that holds.
    fn emergency(&mut self, t: f64, v: f64, lead: Option<Leader>, id: &str) -> bool {
        let danger = lead.and_then(|l| {
            let closing = v - l.speed;
            if closing <= 0.0 {
                return None;
            }
            let ttc = l.gap.max(0.0) / closing;
            let (brake, _, _) = envelope(v);
            // Contact within the envelope: the leader's braking included.
            let needed = closing * closing / (2.0 * l.gap.max(0.01)) - l.accel.min(0.0);
            (ttc < AEB_TTC_S && needed > brake).then_some((ttc, l.gap, closing, needed))
        });
        match (danger, self.aeb_since) {
            (Some((ttc, gap, closing, needed)), None) => {
                self.aeb_since = Some(t);
                self.fired.push(format!(
                    "acc-aeb: emergency braking decided at t={t:.2} s (brakes from {:.2} s): \
                     TTC {ttc:.2} s to {id} ({gap:.1} m ahead, closing at {closing:.1} m/s), \
                     it needed {needed:.1} m/s² where the cruise may brake {:.1}",
                    t + AEB_DELAY_S,
                    envelope(v).0
                ));
                false
            }
            (Some(_), Some(since)) => t + 1e-9 >= since + AEB_DELAY_S,
            (None, _) => {
                self.aeb_since = None;
                false
            }
        }
    }
}

impl Sut for Acc {
    fn name(&self) -> String {
        if self.aeb { "acc-aeb" } else { "acc" }.into()
    }

    fn reset(&mut self, info: &SutInfo) -> Result<(), SutError> {
        if info.route.points.len() < 2 {
            return Err(SutError("acc needs a route of at least two points".into()));
        }
        self.info = info.clone();
        self.hint = 0;
        self.last = 0.0;
        self.aeb_since = None;
        self.fired.clear();
        Ok(())
    }

    fn step(&mut self, obs: &Observation) -> Result<SutCommand, SutError> {
        let ego = &obs.ego;
        let Some(p) = beyond(&self.info.route, ego.x, ego.y, self.hint) else {
            return Err(SutError("acc: the route is empty".into()));
        };
        self.hint = p.segment;
        let v = ego.speed;
        let dt = f64::from(self.info.step_ms.max(1)) / 1000.0;
        let (lead, id) = self.lead(obs, p.s);
        let mut a = self.cruise(v, obs.requested_speed, lead, dt);
        if self.aeb && self.emergency(obs.time, v, lead, &id) {
            a = -self.info.max_decel.max(0.1);
        }
        let a = a.clamp(-self.info.max_decel.max(0.1), self.info.max_accel.max(0.1));
        self.last = a;
        let look = (0.6 * v + 4.0).clamp(5.0, 30.0);
        let kappa = pursuit(&self.info.route, ego, p.s, look);
        Ok(SutCommand::Accel {
            acceleration: a,
            curvature: kappa.clamp(-1.0, 1.0),
            reverse: false,
        })
    }

    fn notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.fired)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn idm_brakes_for_a_close_slow_lead_and_cruises_when_free() {
        let p = AccParams::default();
        assert!(idm(&p, 15.0, 15.0, None).abs() < 1e-12);
        assert!(idm(&p, 10.0, 15.0, None) > 0.0);
        assert!(idm(&p, 15.0, 15.0, Some((5.0, 10.0))) < -5.0);
        // A far lead barely matters.
        assert!(idm(&p, 15.0, 15.0, Some((500.0, 15.0))).abs() < 0.1);
    }

    #[test]
    fn lead_is_the_nearest_object_in_the_lane() {
        let route = Route::new(&[[0.0, 0.0], [100.0, 0.0]], &[10.0, 10.0]);
        let ego = ObjectState {
            x: 10.0,
            length: 4.0,
            width: 2.0,
            ..ObjectState::default()
        };
        let obj = |x: f64, y: f64| ObjectState {
            x,
            y,
            length: 4.0,
            width: 2.0,
            vx: 5.0,
            ..ObjectState::default()
        };
        let objects = [
            obj(50.0, 0.0),
            obj(30.0, 3.5),
            obj(40.0, 0.5),
            obj(5.0, 0.0),
        ];
        let (gap, v) = lead(&route, &ego, 10.0, 0, &objects, 0.3).unwrap();
        assert!((gap - 26.0).abs() < 1e-9, "{gap}");
        assert_eq!(v, 5.0);
    }

    fn cruise_at(acc: &mut Acc, v: f64, lead: Option<Leader>, steps: usize) -> Vec<f64> {
        (0..steps)
            .map(|_| {
                let a = acc.cruise(v, 16.0, lead, 0.02);
                acc.last = a;
                a
            })
            .collect()
    }

    #[test]
    fn a_car_that_cuts_in_and_pulls_away_draws_no_braking() {
        let mut acc = Acc::default();
        let faster = Leader {
            gap: 4.0,
            speed: 18.0,
            accel: 0.0,
        };
        assert!(
            cruise_at(&mut acc, 16.0, Some(faster), 100)
                .iter()
                .all(|a| *a >= 0.0)
        );
        // The same car at the ego's speed is braked for, within the envelope.
        let mut acc = Acc::default();
        let same = Leader {
            gap: 4.0,
            speed: 16.0,
            accel: 0.0,
        };
        let a = cruise_at(&mut acc, 16.0, Some(same), 200);
        assert!(a.iter().any(|a| *a < -1.0));
        assert!(a.iter().all(|a| *a >= -3.5));
        // Jerk: 2.5 m/s³ at most, step to step.
        assert!(
            a.windows(2)
                .all(|w| (w[1] - w[0]).abs() <= 2.5 * 0.02 + 1e-12)
        );
    }

    #[test]
    fn the_time_gap_is_settable_within_the_standards_range() {
        assert!(Acc::default().with_time_gap(1.8).is_ok());
        let e = Acc::default().with_time_gap(0.5).unwrap_err();
        assert!(e.0.contains("1.0–2.2 s"), "{e}");
        assert!(Acc::default().with_time_gap(2.5).is_err());
    }

    #[test]
    fn the_aeb_decides_only_when_the_envelope_cannot_avoid_contact() {
        let mut acc = Acc::with_aeb();
        // 20 m/s onto a standing car 30 m ahead: 6.7 m/s² needed, TTC 1.5 s.
        let stand = Leader {
            gap: 30.0,
            speed: 0.0,
            accel: 0.0,
        };
        assert!(!acc.emergency(1.0, 20.0, Some(stand), "other"));
        assert!(!acc.emergency(1.1, 20.0, Some(stand), "other"));
        assert!(acc.emergency(1.2, 20.0, Some(stand), "other"));
        let notes = acc.notes();
        assert_eq!(notes.len(), 1);
        assert!(
            notes[0].starts_with("acc-aeb: emergency braking decided at t=1.00 s"),
            "{notes:?}"
        );
        // A far or slow approach is the cruise's.
        let mut acc = Acc::with_aeb();
        let far = Leader {
            gap: 80.0,
            speed: 10.0,
            accel: 0.0,
        };
        assert!(!acc.emergency(0.0, 20.0, Some(far), "other") && acc.notes().is_empty());
    }
}
