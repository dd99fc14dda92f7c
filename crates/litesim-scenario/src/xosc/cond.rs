//! Conditions on the simulated state: each entity condition measured on
//! the bodies as they are at the step (a SUT-driven car as the simulator
//! reported it), the value conditions on time, storyboard states,
//! parameters, variables and signals.

use super::motion::along_gap;
use super::place;
use super::story::in_state;
use super::{Body, Storyboard};
use crate::state::BodyState;
use litesim_core::math;
use litesim_xosc::{ConditionKind, EntityTest, Frame, Measure, Rule};

/// The box of a body (centred, litesim's frame).
pub fn boxed(b: &Body) -> BodyState {
    let (cx, cy) = b.centre();
    BodyState {
        x: cx,
        y: cy,
        yaw: b.yaw,
        length: b.length,
        width: b.width,
        speed: b.v,
        ..BodyState::default()
    }
}

/// `a` relative to `b`'s … no: `p` in `me`'s frame: (ahead, left) of its
/// reference point.
fn in_frame(me: &Body, px: f64, py: f64) -> (f64, f64) {
    let (s, c) = math::sin_cos(me.yaw);
    let (dx, dy) = (px - me.x, py - me.y);
    (dx * c + dy * s, -dx * s + dy * c)
}

fn measure(m: Measure, along: f64, across: f64) -> f64 {
    match m {
        Measure::Longitudinal => along.abs(),
        Measure::Lateral => across.abs(),
        Measure::Euclidean => math::hypot(along, across),
    }
}

/// Distance from `me` to `r` by `m` in `frame`; `freespace`: between the
/// boxes.
fn entity_distance(
    sb: &Storyboard,
    me: &Body,
    r: &Body,
    m: Measure,
    frame: Frame,
    freespace: bool,
) -> f64 {
    if freespace && m == Measure::Euclidean {
        return crate::kpi::distance(&boxed(me), &boxed(r));
    }
    let (mut along, mut across) = match (frame, me.lane, r.lane) {
        (Frame::Lane | Frame::Road, Some((a, ao)), Some((b, bo))) if a.road == b.road => {
            let ta = super::motion::t_center(&sb.net, a).unwrap_or(0.0) + ao;
            let tb = super::motion::t_center(&sb.net, b).unwrap_or(0.0) + bo;
            (along_gap(&sb.net, me, r), tb - ta)
        }
        _ => in_frame(me, r.x, r.y),
    };
    if freespace {
        along = (along.abs() - 0.5 * (me.length + r.length)).max(0.0);
        across = (across.abs() - 0.5 * (me.width + r.width)).max(0.0);
    }
    measure(m, along, across)
}

impl Storyboard {
    /// The logical value of a condition now (before its edge and delay).
    pub(super) fn holds(&self, kind: &ConditionKind, t: f64) -> bool {
        match kind {
            ConditionKind::SimulationTime { rule, value } => rule.holds(t, *value),
            ConditionKind::StoryboardElementState {
                element,
                name,
                state,
            } => self
                .elems
                .iter()
                .enumerate()
                .find(|(_, e)| e.kind == *element && e.name == *name)
                .is_some_and(|(i, e)| in_state(e, &self.took, i, *state)),
            ConditionKind::Parameter { name, rule, value } => {
                compare(self.params.get(name).map(String::as_str), *rule, value)
            }
            ConditionKind::Variable { name, rule, value } => {
                compare(self.vars.get(name).map(String::as_str), *rule, value)
            }
            ConditionKind::TrafficSignal { signal, state } => {
                self.signals.get(signal).is_some_and(|s| s == state)
            }
            ConditionKind::Entity {
                entities,
                all,
                test,
            } => {
                let mut each = entities
                    .iter()
                    .flat_map(|e| self.members(e))
                    .map(|i| self.entity_holds(i, test));
                if *all {
                    each.all(|x| x)
                } else {
                    each.any(|x| x)
                }
            }
        }
    }

    /// An entity condition for body `i`.
    fn entity_holds(&self, i: usize, test: &EntityTest) -> bool {
        let me = &self.bodies[i];
        if !me.active {
            return false;
        }
        let find = |name: &str| self.bodies.iter().find(|b| b.id == name && b.active);
        let t = self.t;
        match test {
            EntityTest::EndOfRoad { duration } => {
                me.end_since.is_some_and(|s| t - s >= duration - 1e-9)
            }
            EntityTest::Offroad { duration } => {
                me.off_since.is_some_and(|s| t - s >= duration - 1e-9)
            }
            EntityTest::StandStill { duration } => {
                me.still_since.is_some_and(|s| t - s >= duration - 1e-9)
            }
            EntityTest::Collision { entity, by_type } => {
                let mine = boxed(me);
                self.bodies
                    .iter()
                    .filter(|o| o.id != me.id && o.active)
                    .any(|o| {
                        let wanted = match (entity, by_type) {
                            (Some(e), _) => o.id == *e,
                            (None, Some(ty)) => o.object_type == *ty,
                            _ => true,
                        };
                        wanted && crate::kpi::overlap(&mine, &boxed(o))
                    })
            }
            EntityTest::Acceleration { rule, value } => rule.holds(me.a, *value),
            EntityTest::Speed { rule, value } => rule.holds(me.v, *value),
            EntityTest::RelativeSpeed {
                entity,
                rule,
                value,
            } => find(entity).is_some_and(|r| rule.holds(me.v - r.v, *value)),
            EntityTest::TraveledDistance { value } => me.traveled >= *value - 1e-9,
            EntityTest::ReachPosition {
                position,
                tolerance,
            } => place::resolve(&self.net, position, &self.bodies, "ReachPositionCondition")
                .is_ok_and(|p| math::hypot(p.x - me.x, p.y - me.y) <= *tolerance),
            _ => self.gap_holds(me, test),
        }
    }
}

impl Storyboard {
    /// The headway, time-to-collision and distance conditions for `me`.
    fn gap_holds(&self, me: &Body, test: &EntityTest) -> bool {
        let find = |name: &str| self.bodies.iter().find(|b| b.id == name && b.active);
        match test {
            EntityTest::TimeHeadway {
                entity,
                freespace,
                frame,
                rule,
                value,
            } => find(entity).is_some_and(|r| {
                let mut d = match frame {
                    Frame::Lane | Frame::Road => along_gap(&self.net, me, r),
                    _ => in_frame(me, r.x, r.y).0,
                };
                if *freespace {
                    d -= 0.5 * (me.length + r.length);
                }
                // The reference must be ahead and the entity moving.
                d > 0.0 && me.v > 1e-6 && rule.holds(d / me.v, *value)
            }),
            EntityTest::TimeToCollision {
                entity,
                position,
                freespace,
                rule,
                value,
                ..
            } => {
                let (d, closing) = match (entity, position) {
                    (Some(e), _) => match find(e) {
                        Some(r) => {
                            let (along, _) = in_frame(me, r.x, r.y);
                            let rv = r.v * math::cos(r.yaw - me.yaw);
                            let gap = if *freespace {
                                along - 0.5 * (me.length + r.length)
                            } else {
                                along
                            };
                            (gap, me.v - rv)
                        }
                        None => return false,
                    },
                    (None, Some(p)) => {
                        match place::resolve(&self.net, p, &self.bodies, "TimeToCollisionCondition")
                        {
                            Ok(pl) => {
                                let (along, _) = in_frame(me, pl.x, pl.y);
                                (
                                    if *freespace {
                                        along - 0.5 * me.length
                                    } else {
                                        along
                                    },
                                    me.v,
                                )
                            }
                            Err(_) => return false,
                        }
                    }
                    _ => return false,
                };
                // Moving apart (or not closing): no time to collision.
                d >= 0.0 && closing > 1e-9 && rule.holds(d / closing, *value)
            }
            EntityTest::Distance {
                position,
                freespace,
                measure: m,
                rule,
                value,
                ..
            } => place::resolve(&self.net, position, &self.bodies, "DistanceCondition").is_ok_and(
                |p| {
                    let (mut along, mut across) = in_frame(me, p.x, p.y);
                    if *freespace {
                        let (cx, cy) = me.centre();
                        let ob = litesim_core::OrientedBox {
                            x: cx,
                            y: cy,
                            yaw: me.yaw,
                            length: me.length,
                            width: me.width,
                        };
                        let (a, c) = ob.outside(litesim_core::Vec2::new(p.x, p.y));
                        along = a;
                        across = c;
                    }
                    rule.holds(measure(*m, along, across), *value)
                },
            ),
            EntityTest::RelativeDistance {
                entity,
                freespace,
                measure: m,
                frame,
                rule,
                value,
            } => find(entity).is_some_and(|r| {
                rule.holds(entity_distance(self, me, r, *m, *frame, *freespace), *value)
            }),
            _ => false,
        }
    }
}

/// A parameter's or variable's value against a rule: numbers compared as
/// numbers, anything else only for (in)equality.
fn compare(have: Option<&str>, rule: Rule, want: &str) -> bool {
    let Some(have) = have else {
        return false;
    };
    match (have.trim().parse::<f64>(), want.trim().parse::<f64>()) {
        (Ok(a), Ok(b)) => rule.holds(a, b),
        _ => match rule {
            Rule::EqualTo => have == want,
            Rule::NotEqualTo => have != want,
            _ => false,
        },
    }
}
