//! A lane-keeping adaptive cruise: the built-in SUT `acc`.
//!
//! Longitudinal: the Intelligent Driver Model (Treiber, Hennecke, Helbing
//! 2000) towards the speed the scenario asks, keeping a time gap to the
//! lead — the nearest object ahead whose box overlaps the ego's lane
//! corridor along the route — and stopping before a red (or yellow, when it
//! still can) light on its road. Lateral: pure pursuit of the route.

use super::{ObjectState, Observation, Route, Sut, SutCommand, SutError, SutInfo};
use litesim_core::math;

/// Hardest braking the cruise asks for (m/s²): an emergency stop on dry
/// asphalt, whatever the model could do.
pub const EMERGENCY_DECEL: f64 = 9.0;

/// IDM parameters and pursuit gains.
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

/// The adaptive cruise.
#[derive(Clone, Debug, Default)]
pub struct Acc {
    /// Parameters.
    pub params: AccParams,
    info: SutInfo,
    hint: usize,
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
    let (sy, cy) = math::sin_cos(ego.yaw);
    let mut best: Option<(f64, f64)> = None;
    for o in objects {
        let (dx, dy) = (o.x - ego.x, o.y - ego.y);
        // Cheap filter: ahead, within 200 m.
        if dx * cy + dy * sy < -ego.length || dx * dx + dy * dy > 200.0 * 200.0 {
            continue;
        }
        // Start the search where the object's distance ahead puts it on
        // the route (a far object would otherwise cost a full search).
        let guess = ego_s + dx * cy + dy * sy;
        let seg = route.s.partition_point(|s| *s <= guess).saturating_sub(1);
        let Some(p) = route.project(o.x, o.y, if guess > ego_s { seg } else { hint }) else {
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
        if best.is_none_or(|b| gap < b.0) {
            best = Some((gap, v_along));
        }
    }
    best
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

impl Sut for Acc {
    fn name(&self) -> String {
        "acc".into()
    }

    fn reset(&mut self, info: &SutInfo) -> Result<(), SutError> {
        if info.route.points.len() < 2 {
            return Err(SutError("acc needs a route of at least two points".into()));
        }
        self.info = info.clone();
        self.hint = 0;
        Ok(())
    }

    fn step(&mut self, obs: &Observation) -> Result<SutCommand, SutError> {
        let route = &self.info.route;
        let ego = &obs.ego;
        let Some(p) = route.project(ego.x, ego.y, self.hint) else {
            return Err(SutError("acc: the route is empty".into()));
        };
        self.hint = p.segment;
        let v = ego.speed;
        let mut lead = lead(route, ego, p.s, self.hint, &obs.objects, self.params.margin);
        // A red light ahead on the ego's road is a standing lead at its stop line.
        if let Some(rp) = &obs.road {
            let dir = if rp.lane < 0 { 1.0 } else { -1.0 };
            for l in &obs.lights {
                if l.road != rp.road || !(l.color == "red" || l.color == "yellow") {
                    continue;
                }
                let ahead = (l.s - rp.s) * dir - 0.5 * ego.length;
                // Yellow: stop only when that is comfortable.
                let can_stop = v * v / (2.0 * self.params.b_comf) < ahead;
                if ahead > 0.0 && (l.color == "red" || can_stop) && lead.is_none_or(|b| ahead < b.0)
                {
                    lead = Some((ahead, 0.0));
                }
            }
        }
        let v0 = obs.requested_speed;
        let a = idm(&self.params, v, v0, lead).clamp(
            -self.info.max_decel.clamp(0.1, EMERGENCY_DECEL),
            self.info.max_accel.max(0.1),
        );
        let look = (0.6 * v + 4.0).clamp(5.0, 30.0);
        let kappa = pursuit(route, ego, p.s, look);
        Ok(SutCommand::Accel {
            acceleration: a,
            curvature: kappa.clamp(-1.0, 1.0),
        })
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
}
