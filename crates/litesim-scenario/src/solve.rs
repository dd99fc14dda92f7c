//! Constraint solving under a seed: equalities between variables unify
//! them (`keep(s.r1 == s.r2)` gives both one road), comparisons and
//! ranges narrow a variable's interval, soft (`default`) constraints apply
//! only where they fit, and each variable then takes its default when
//! allowed or a seeded sample. Map-element variables (`one_way_road`,
//! `two_way_road`, `road`) are chosen among the map's roads that satisfy
//! the kind and the `length`, `min_lanes` and `max_lanes` constraints; when
//! none does, the error names what was asked and what the map has.

use crate::elab::{CExpr, RoadKind, Test, Value};
use crate::error::ScenarioError;
use crate::expr::show;
use litesim_core::rng::Rng;
use litesim_map::RoadNetwork;
use serde::Serialize;
use std::collections::BTreeMap;

/// The solved values.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Solution {
    /// Scalars by path.
    pub values: BTreeMap<String, Value>,
    /// Road variables by path → road id.
    pub roads: BTreeMap<String, String>,
    /// Constraints the solver could not use (reported, not silent).
    pub notes: Vec<String>,
}

#[derive(Clone, Debug)]
struct Dom {
    lo: f64,
    hi: f64,
    eq: Option<Value>,
    one_of: Option<Vec<Value>>,
    why: Vec<String>,
}

impl Default for Dom {
    fn default() -> Self {
        Dom {
            lo: f64::NEG_INFINITY,
            hi: f64::INFINITY,
            eq: None,
            one_of: None,
            why: Vec::new(),
        }
    }
}

impl Dom {
    fn empty(&self) -> bool {
        if self.lo > self.hi {
            return true;
        }
        if let Some(v) = &self.eq {
            if let Some(x) = v.num()
                && (x < self.lo - 1e-12 || x > self.hi + 1e-12)
            {
                return true;
            }
            if let Some(list) = &self.one_of
                && !list.contains(v)
            {
                return true;
            }
        }
        false
    }
    fn describe(&self) -> String {
        if let Some(v) = &self.eq {
            return format!("== {v:?}");
        }
        format!("in [{}, {}]", self.lo, self.hi)
    }
}

struct Solver<'a> {
    parent: BTreeMap<String, String>,
    dom: BTreeMap<String, Dom>,
    test: &'a Test,
    notes: Vec<String>,
}

impl Solver<'_> {
    fn find(&self, p: &str) -> String {
        let mut cur = p.to_string();
        while let Some(n) = self.parent.get(&cur) {
            if *n == cur {
                break;
            }
            cur = n.clone();
        }
        cur
    }
    fn union(&mut self, a: &str, b: &str, at: &str) -> Result<(), String> {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return Ok(());
        }
        let (keep, drop) = if ra < rb { (ra, rb) } else { (rb, ra) };
        let d2 = self.dom.remove(&drop).unwrap_or_default();
        let d1 = self.dom.entry(keep.clone()).or_default();
        d1.lo = d1.lo.max(d2.lo);
        d1.hi = d1.hi.min(d2.hi);
        if d1.eq.is_none() {
            d1.eq = d2.eq;
        } else if d2.eq.is_some() && d1.eq != d2.eq {
            return Err(format!(
                "{at}: {a} and {b} are kept equal but fixed to different values"
            ));
        }
        d1.why.extend(d2.why);
        d1.why.push(at.to_string());
        self.parent.insert(drop, keep);
        Ok(())
    }

    /// Narrows `var` by `op rhs`; returns false if that empties the domain.
    fn narrow(&mut self, var: &str, op: &str, rhs: &CExpr, at: &str, soft: bool) -> bool {
        let root = self.find(var);
        let old = self.dom.get(&root).cloned().unwrap_or_default();
        let mut d = old.clone();
        match (op, rhs) {
            ("==", CExpr::Const(v)) => {
                if let Some(x) = v.num() {
                    d.lo = d.lo.max(x);
                    d.hi = d.hi.min(x);
                }
                if d.eq.as_ref().is_some_and(|e| e != v) {
                    d.lo = f64::INFINITY;
                }
                d.eq = Some(v.clone());
            }
            ("==" | "in", CExpr::Range(lo, hi)) => {
                d.lo = d.lo.max(lo.unwrap_or(f64::NEG_INFINITY));
                d.hi = d.hi.min(hi.unwrap_or(f64::INFINITY));
            }
            ("in" | "==", CExpr::List(items)) => {
                let vals: Vec<Value> = items
                    .iter()
                    .filter_map(|i| match i {
                        CExpr::Const(v) => Some(v.clone()),
                        _ => None,
                    })
                    .collect();
                d.one_of = Some(match &d.one_of {
                    Some(prev) => prev.iter().filter(|v| vals.contains(v)).cloned().collect(),
                    None => vals,
                });
                if d.one_of.as_ref().is_some_and(Vec::is_empty) {
                    d.lo = f64::INFINITY;
                }
            }
            ("<" | "<=", CExpr::Const(Value::Num(x))) => d.hi = d.hi.min(*x),
            (">" | ">=", CExpr::Const(Value::Num(x))) => d.lo = d.lo.max(*x),
            ("!=", _) => {
                self.notes
                    .push(format!("{at}: '!=' is checked, not solved; ignored"));
                return true;
            }
            _ => {
                self.notes.push(format!(
                    "{at}: constraint form '{var} {op} {rhs:?}' is not solved; ignored"
                ));
                return true;
            }
        }
        d.why.push(at.to_string());
        if d.empty() {
            if soft {
                return true; // a default yields
            }
            self.dom.insert(root, d);
            return false;
        }
        self.dom.insert(root, d);
        true
    }

    fn apply(&mut self, e: &CExpr, at: &str, soft: bool) -> Result<(), ScenarioError> {
        match e {
            CExpr::Binary(op, a, b) if op == "and" => {
                self.apply(a, at, soft)?;
                self.apply(b, at, soft)
            }
            CExpr::Binary(op, a, b) => match (&**a, &**b) {
                (CExpr::Var(x), CExpr::Var(y)) if op == "==" => {
                    if soft {
                        return Ok(());
                    }
                    self.union(x, y, at).map_err(ScenarioError::Unsatisfiable)
                }
                (CExpr::Var(x), rhs) if !matches!(rhs, CExpr::Var(_) | CExpr::Opaque(_)) => {
                    self.narrow_or_fail(x, op, rhs, at, soft)
                }
                (lhs, CExpr::Var(y)) if !matches!(lhs, CExpr::Var(_) | CExpr::Opaque(_)) => {
                    let flipped = match op.as_str() {
                        "<" => ">",
                        "<=" => ">=",
                        ">" => "<",
                        ">=" => "<=",
                        o => o,
                    };
                    self.narrow_or_fail(y, flipped, lhs, at, soft)
                }
                _ => {
                    self.notes
                        .push(format!("{at}: constraint {e:?} is not solved; ignored"));
                    Ok(())
                }
            },
            CExpr::Var(x) => {
                self.narrow_or_fail(x, "==", &CExpr::Const(Value::Bool(true)), at, soft)
            }
            CExpr::Unary(op, inner) if op == "not" => match &**inner {
                CExpr::Var(x) => {
                    self.narrow_or_fail(x, "==", &CExpr::Const(Value::Bool(false)), at, soft)
                }
                _ => {
                    self.notes
                        .push(format!("{at}: constraint not solved; ignored"));
                    Ok(())
                }
            },
            _ => {
                self.notes
                    .push(format!("{at}: constraint {e:?} is not solved; ignored"));
                Ok(())
            }
        }
    }

    fn narrow_or_fail(
        &mut self,
        var: &str,
        op: &str,
        rhs: &CExpr,
        at: &str,
        soft: bool,
    ) -> Result<(), ScenarioError> {
        if self.narrow(var, op, rhs, at, soft) {
            return Ok(());
        }
        let root = self.find(var);
        let d = &self.dom[&root];
        Err(ScenarioError::Unsatisfiable(format!(
            "{at}: '{var} {op} {}' contradicts earlier constraints ({}); the domain is empty: {}",
            show(rhs),
            d.why[..d.why.len() - 1].join(", "),
            d.describe()
        )))
    }
}

/// Lanes a road offers in its busiest allowed direction (one-way) or in
/// each direction (two-way).
fn lanes(s: &litesim_map::network::RoadSummary, kind: RoadKind) -> usize {
    match kind {
        RoadKind::OneWay => s.min_forward_lanes.max(s.min_backward_lanes),
        RoadKind::TwoWay => s.min_forward_lanes.min(s.min_backward_lanes),
        RoadKind::Road => s.min_forward_lanes.max(s.min_backward_lanes),
    }
}

/// Solves the test's constraints on `net` under `seed`.
pub fn solve(
    test: &Test,
    net: Option<&RoadNetwork>,
    map_name: &str,
    rng: &mut Rng,
) -> Result<Solution, ScenarioError> {
    let mut s = Solver {
        parent: BTreeMap::new(),
        dom: BTreeMap::new(),
        test,
        notes: Vec::new(),
    };
    for soft in [false, true] {
        for c in test.constraints.iter().filter(|c| c.soft == soft) {
            s.apply(&c.expr, &c.at, soft)?;
        }
    }
    let mut sol = Solution::default();
    // Roads: one choice per class of unified variables, in path order.
    let summaries = net.map(|n| n.road_summaries()).unwrap_or_default();
    let mut chosen: BTreeMap<String, String> = BTreeMap::new();
    for (path, var) in &s.test.vars {
        if var.road.is_none() {
            continue;
        }
        let root = s.find(path);
        if let Some(id) = chosen.get(&root) {
            sol.roads.insert(path.clone(), id.clone());
            continue;
        }
        let pick = s.road_for(path, &root, net.is_some(), (&summaries, map_name), rng)?;
        chosen.insert(root, pick.clone());
        sol.roads.insert(path.clone(), pick);
    }
    s.scalars(rng, &mut sol);
    sol.notes = s.notes;
    Ok(sol)
}

impl Solver<'_> {
    /// The road of the map-element variable `path` (its class of unified
    /// variables rooted at `root`): a seeded choice among the map's roads
    /// (`summaries` of `map_name`) that fit every member's kind, lanes,
    /// length and junction; none is an error naming what was asked and
    /// what the map has.
    fn road_for(
        &self,
        path: &str,
        root: &str,
        has_map: bool,
        (summaries, map_name): (&[litesim_map::network::RoadSummary], &str),
        rng: &mut Rng,
    ) -> Result<String, ScenarioError> {
        let members: Vec<String> = self
            .test
            .vars
            .iter()
            .filter(|(p, v)| v.road.is_some() && self.find(p) == root)
            .map(|(p, _)| p.clone())
            .collect();
        let attr = |name: &str| -> Dom {
            let mut d = Dom::default();
            for m in &members {
                let r = self.find(&format!("{m}.{name}"));
                if let Some(x) = self.dom.get(&r) {
                    d.lo = d.lo.max(x.lo);
                    d.hi = d.hi.min(x.hi);
                    if let Some(v) = &x.eq {
                        d.eq = Some(v.clone());
                    }
                }
            }
            d
        };
        let length = attr("length");
        // CARLA's `path_over_junction`: a road with an end at a junction.
        let into_junction = attr("into_junction").eq == Some(Value::Bool(true));
        let min_lanes = attr("min_lanes");
        let max_lanes = attr("max_lanes");
        let kinds: Vec<RoadKind> = members
            .iter()
            .filter_map(|m| self.test.vars[m].road)
            .collect();
        let need_min = min_lanes.lo.max(1.0);
        let need_max = max_lanes.hi;
        if !has_map {
            return Err(ScenarioError::Unsatisfiable(format!(
                "'{path}' is a map element but the test has no map (set test_config.map or pass --map)"
            )));
        }
        let fits = |r: &&litesim_map::network::RoadSummary| {
            r.junction.is_none()
                && kinds.iter().all(|k| match k {
                    RoadKind::OneWay => r.one_way,
                    RoadKind::TwoWay => {
                        !r.one_way && r.min_forward_lanes > 0 && r.min_backward_lanes > 0
                    }
                    RoadKind::Road => r.max_driving_lanes > 0,
                })
                && kinds.iter().all(|k| {
                    let n = lanes(r, *k) as f64;
                    n >= need_min && n <= need_max
                })
                && r.length >= length.lo
                && r.length <= length.hi
                && (!into_junction || r.into_junction)
        };
        let cands: Vec<&litesim_map::network::RoadSummary> =
            summaries.iter().filter(fits).collect();
        if cands.is_empty() {
            let kind_name = match kinds.first().copied().unwrap_or(RoadKind::Road) {
                RoadKind::OneWay => "one_way_road",
                RoadKind::TwoWay => "two_way_road",
                RoadKind::Road => "road",
            };
            let mut asked = vec![format!("≥ {need_min} lanes")];
            if need_max.is_finite() {
                asked.push(format!("≤ {need_max} lanes"));
            }
            if into_junction {
                asked.push("an end at a junction".into());
            }
            if length.lo.is_finite() || length.hi.is_finite() {
                asked.push(format!(
                    "length in [{:.1}, {:.1}] m",
                    length.lo.max(0.0),
                    length.hi
                ));
            }
            let have: Vec<String> = summaries
                .iter()
                .filter(|r| r.junction.is_none())
                .map(|r| {
                    format!(
                        "road {} ({}, {} lanes, {:.1} m)",
                        r.id,
                        if r.one_way { "one-way" } else { "two-way" },
                        lanes(r, kinds.first().copied().unwrap_or(RoadKind::Road)),
                        r.length
                    )
                })
                .collect();
            return Err(ScenarioError::Unsatisfiable(format!(
                "no {kind_name} in {map_name} has {} (asked for '{}'; the map has: {})",
                asked.join(" and "),
                members.join("', '"),
                have.join("; ")
            )));
        }
        Ok(cands[(rng.next_u64() % cands.len() as u64) as usize]
            .id
            .clone())
    }

    /// Every constrained, unified or declared scalar, in path order: its
    /// equality, else a seeded member of its list, else its default (a
    /// range sampled) within its domain, else a seeded sample of a bounded
    /// domain.
    fn scalars(&self, rng: &mut Rng, sol: &mut Solution) {
        // Scalars: every constrained, unified or declared variable, in path order.
        let paths: std::collections::BTreeSet<String> = self
            .dom
            .keys()
            .chain(self.parent.keys())
            .chain(
                self.test
                    .vars
                    .iter()
                    .filter(|(_, v)| v.road.is_none())
                    .map(|(p, _)| p),
            )
            .cloned()
            .collect();
        let mut done: BTreeMap<String, Value> = BTreeMap::new();
        for p in paths {
            let root = self.find(&p);
            if let Some(v) = done.get(&root) {
                sol.values.insert(p, v.clone());
                continue;
            }
            let d = self.dom.get(&root).cloned().unwrap_or_default();
            let default = self
                .test
                .vars
                .get(&p)
                .and_then(|v| v.default.clone())
                .or_else(|| self.test.vars.get(&root).and_then(|v| v.default.clone()));
            let v = if let Some(v) = d.eq.clone() {
                Some(v)
            } else if let Some(list) = &d.one_of {
                Some(list[(rng.next_u64() % list.len() as u64) as usize].clone())
            } else {
                let def = match default {
                    Some(CExpr::Const(v)) => Some(v),
                    Some(CExpr::Range(a, b)) => {
                        let (a, b) = (a.unwrap_or(d.lo).max(d.lo), b.unwrap_or(d.hi).min(d.hi));
                        Some(Value::Num(sample(a, b, rng)))
                    }
                    _ => None,
                };
                match def {
                    Some(Value::Num(x)) if x >= d.lo && x <= d.hi => Some(Value::Num(x)),
                    Some(v) if v.num().is_none() => Some(v),
                    _ if d.lo.is_finite() || d.hi.is_finite() => {
                        Some(Value::Num(sample(d.lo, d.hi, rng)))
                    }
                    _ => None,
                }
            };
            if let Some(v) = v {
                done.insert(root, v.clone());
                sol.values.insert(p, v);
            }
        }
    }
}

/// A seeded sample of `[lo, hi]`; a half-open interval samples a span of
/// its bound's size beyond it.
pub fn sample(lo: f64, hi: f64, rng: &mut Rng) -> f64 {
    let u = rng.unit();
    match (lo.is_finite(), hi.is_finite()) {
        (true, true) => lo + (hi - lo) * u,
        (true, false) => lo + lo.abs().max(1.0) * u,
        (false, true) => hi - hi.abs().max(1.0) * u,
        (false, false) => 0.0,
    }
}
