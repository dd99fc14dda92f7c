//! Post-plan checks (the seed's dSPACE and CarMaker configurations): before
//! anything runs, every vehicle's planned trajectory is checked against the
//! profile's limits (speed, acceleration, deceleration, curvature) and the
//! map (every planned position of a vehicle lies in a lane), and `strict`
//! modifiers the plan could not honour are reported. Each violation names
//! the actor, the time and the numbers.

use crate::plan::{ActorPlan, Plan};
use litesim_core::ActorClass;
use litesim_core::geometry::wrap_angle;
use litesim_map::RoadNetwork;
use litesim_ssp::Profile;

/// Violations of `plan` (empty when it may run).
pub fn check(plan: &Plan, profile: Option<&Profile>, net: Option<&RoadNetwork>) -> Vec<String> {
    let mut out = plan.violations.clone();
    let limits = profile.map(|p| p.post_plan).filter(|l| l.enabled);
    let vehicles: Vec<&ActorPlan> = plan
        .actors
        .iter()
        .filter(|a| a.kind == ActorClass::Vehicle)
        .collect();
    // Each vehicle's checks read only its own plan: many are checked on
    // all cores, the reports gathered in actor order (the same list).
    let each = |a: &&ActorPlan| vehicle(a, limits, net);
    let found: Vec<Vec<String>> = if vehicles.len() >= crate::PARALLEL_ACTORS {
        use rayon::prelude::*;
        vehicles.par_iter().map(each).collect()
    } else {
        vehicles.iter().map(each).collect()
    };
    out.extend(found.into_iter().flatten());
    out
}

/// The violations of one vehicle's plan, in the order found.
fn vehicle(
    a: &ActorPlan,
    limits: Option<litesim_ssp::profile::PostPlanChecks>,
    net: Option<&RoadNetwork>,
) -> Vec<String> {
    let mut out = Vec::new();
    {
        // One report per actor and kind: the first time it happens.
        let mut seen = [false; 5];
        let mut report = |k: usize, msg: String| {
            if !seen[k] {
                seen[k] = true;
                out.push(msg);
            }
        };
        // The map check skips samples within `on_road_radius` of the last
        // located one (they are surely on the road) and starts each
        // projection from the last one.
        let mut hint: Option<litesim_map::Located> = None;
        let mut surely_on: Option<litesim_map::SurelyOnRoad> = None;
        let mut off_map = false;
        for w in a.samples.windows(2) {
            let (p, q) = (&w[0], &w[1]);
            if let Some(l) = limits {
                if q.v > l.max_speed + 1e-9 {
                    report(
                        0,
                        format!(
                            "{}: speed {:.2} m/s at t = {:.2} s exceeds the profile's {:.2} m/s",
                            a.id, q.v, q.t, l.max_speed
                        ),
                    );
                }
                if q.a > l.max_acceleration + 1e-6 {
                    report(
                        1,
                        format!(
                            "{}: acceleration {:.2} m/s² at t = {:.2} s exceeds the profile's {:.2} m/s²",
                            a.id, q.a, q.t, l.max_acceleration
                        ),
                    );
                }
                if -q.a > l.max_deceleration + 1e-6 {
                    report(
                        2,
                        format!(
                            "{}: deceleration {:.2} m/s² at t = {:.2} s exceeds the profile's {:.2} m/s²",
                            a.id, -q.a, q.t, l.max_deceleration
                        ),
                    );
                }
                let ds = ((q.x - p.x).powi(2) + (q.y - p.y).powi(2)).sqrt();
                if l.level == litesim_ssp::profile::PostPlanLevel::Full && ds > 0.05 {
                    let k = wrap_angle(q.yaw - p.yaw).abs() / ds;
                    if k > l.max_curvature + 1e-9 {
                        report(
                            3,
                            format!(
                                "{}: curvature {:.3} 1/m at t = {:.2} s exceeds the profile's {:.3} 1/m",
                                a.id, k, q.t, l.max_curvature
                            ),
                        );
                    }
                }
            }
            let Some(n) = net.filter(|_| !off_map) else {
                continue;
            };
            let here = litesim_core::geometry::Vec2::new(q.x, q.y);
            if surely_on.is_some_and(|z| z.contains(here)) {
                continue;
            }
            hint = n.locate_near(here, hint);
            surely_on = hint.map(|h| n.surely_on_road(here, &h));
            if hint.is_none() {
                off_map = true;
                report(
                    4,
                    format!(
                        "{}: planned position ({:.1}, {:.1}) at t = {:.2} s is in no lane of the map",
                        a.id, q.x, q.y, q.t
                    ),
                );
            }
        }
    }
    out
}
