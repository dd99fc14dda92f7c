//! Live conditions: the plan's `wait`/`until` conditions evaluated on the
//! simulated state, step by step. One that holds at another time than
//! planned (or that the plan has holding by now while the world does not)
//! gets its time fixed, and the test is planned again around it.

use super::observe::World;
use super::{LiveEvent, POSTPONE_S};
use crate::expr::{Field, Scope, show};
use crate::plan::Plan;
use std::collections::{BTreeMap, BTreeSet};

/// What the runtime knows of the plan's conditions so far.
pub(crate) struct Live {
    /// Times fixed for the planner (condition key → s).
    pub fixed: BTreeMap<String, f64>,
    /// Conditions decided (held, or not something the state shows).
    settled: BTreeSet<String>,
    /// Each condition's last truth (for rise/fall).
    last_truth: BTreeMap<String, bool>,
    /// Conditions that held on the simulated state.
    pub events: Vec<LiveEvent>,
    /// What the first plan had for each condition (reported beside the
    /// live time).
    first_plan: BTreeMap<String, Option<f64>>,
}

impl Live {
    /// Nothing seen yet of `plan`'s conditions.
    pub fn new(plan: &Plan) -> Self {
        Live {
            fixed: BTreeMap::new(),
            settled: BTreeSet::new(),
            last_truth: BTreeMap::new(),
            events: Vec::new(),
            first_plan: plan
                .conditions
                .iter()
                .map(|c| (c.key.clone(), c.at))
                .collect(),
        }
    }

    /// Evaluates the plan's conditions on the world at time `t`: one that
    /// holds at another time than planned, or that the plan has holding by
    /// now while the world does not, gets its time fixed (or postponed by
    /// [`POSTPONE_S`]). Returns whether the plan must be made again.
    pub fn check(&mut self, plan: &Plan, world: &World, t: f64) -> bool {
        let scope = WorldScope { plan, world };
        let mut changed = false;
        for c in &plan.conditions {
            if self.settled.contains(&c.key) || t < c.t0 - 1e-9 {
                continue;
            }
            let Some(now) = c.holds(&plan.ids, &scope) else {
                // Not something the state shows: the plan's time stands.
                self.settled.insert(c.key.clone());
                continue;
            };
            let before = self.last_truth.insert(c.key.clone(), now);
            if c.edge().0.fires(before, now) {
                self.settled.insert(c.key.clone());
                self.events.push(LiveEvent {
                    condition: show(&c.cond),
                    planned: self.first_plan.get(&c.key).copied().flatten(),
                    live: t,
                });
                if c.at.is_none_or(|a| (a - t).abs() > 1e-6) {
                    self.fixed.insert(c.key.clone(), t);
                    changed = true;
                }
            } else if c.at.is_some_and(|a| a <= t + 1e-9) {
                self.fixed.insert(c.key.clone(), t + POSTPONE_S);
                changed = true;
            }
        }
        changed
    }
}

impl Live {
    /// The conditions the run looked at on the simulated state that never
    /// held, with the time the first plan had for them: the scenario did
    /// not happen as written.
    pub fn never_held(&self, plan: &Plan) -> Vec<String> {
        plan.conditions
            .iter()
            .filter(|c| self.last_truth.contains_key(&c.key) && !self.settled.contains(&c.key))
            .map(|c| {
                let when = match self.first_plan.get(&c.key).copied().flatten() {
                    Some(t) => format!("the plan had it at {t:.2} s"),
                    None => "the plan did not have it hold".to_string(),
                };
                format!("the condition {} never held ({when})", show(&c.cond))
            })
            .collect()
    }
}

/// The simulated state as conditions read it: the fields the plan's
/// conditions read (speed, acceleration, position).
struct WorldScope<'a> {
    plan: &'a Plan,
    world: &'a World,
}

impl Scope for WorldScope<'_> {
    fn field(&self, id: &str, field: Field) -> Option<f64> {
        let i = self.plan.actors.iter().position(|a| a.id == id)?;
        let o = self.world.get(i);
        match field {
            Field::Speed => Some(o.speed),
            Field::Acceleration => Some(o.acceleration),
            Field::X => Some(o.x),
            Field::Y => Some(o.y),
            // What planning cannot show either: the same conditions are
            // evaluable in both places.
            Field::Yaw | Field::Lane => None,
        }
    }
}
