//! `wait`/`until` conditions over states, evaluated on the planned
//! samples.

use super::*;

/// Reads actor attributes from the plan at time `t` (the plan has no
/// yaw or lane to show).
pub(super) struct PlanScope<'a> {
    pub(super) plan: &'a Plan,
    pub(super) t: f64,
}

impl Scope for PlanScope<'_> {
    fn field(&self, id: &str, field: Field) -> Option<f64> {
        let a = self.plan.actors.iter().find(|a| a.id == id)?;
        let s = a.at(self.t, self.plan.dt);
        match field {
            Field::Speed => Some(s.v),
            Field::Acceleration => Some(s.a),
            Field::X => Some(s.x),
            Field::Y => Some(s.y),
            Field::Yaw | Field::Lane => None,
        }
    }
}

/// The first plan sample time at or after `t0` at which a condition holds
/// (`rise`: becomes true; `fall`: becomes false). `Err` when it cannot be
/// evaluated on a plan.
pub(super) fn cond_time(
    c: &CExpr,
    t0: f64,
    p: &Plan,
    ids: &BTreeMap<String, String>,
) -> Result<Option<f64>, ()> {
    let (edge, inner) = Edge::of(c);
    let n = (p.duration / p.dt).ceil() as usize + 1;
    let mut prev: Option<bool> = None;
    for k in 0..n {
        let t = k as f64 * p.dt;
        if t < t0 - 1e-9 {
            continue;
        }
        let v = crate::expr::truth(inner, ids, &PlanScope { plan: p, t }).ok_or(())?;
        if edge.fires(prev, v) {
            return Ok(Some(t));
        }
        prev = Some(v);
    }
    Ok(None)
}
