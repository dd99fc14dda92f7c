//! Elaboration: from a checked OSC program to a [`Test`] — the run
//! configuration, the actors, the variables with their constraints, and
//! the behaviour tree of `top.main` with every name resolved to an absolute
//! path (`s.r1`, `sut.car`, `s.car1.vehicle_category`).
//!
//! Scenario instances get a namespace: the label of the invocation (`s` in
//! `do s: sut.smoke()`), or a generated one. Fields of the instance live
//! under it; `keep`s of the instance, of its fields' `with:` blocks and of
//! the invocation's `with:` block become [`Constraint`]s over paths.

use crate::error::ScenarioError;
use litesim_core::ActorClass;
use litesim_osc::ast::{Arg, Decl, DeclKind, DoKind, DoMember, Expr, Member};
use litesim_osc::index::{DeclIndex, modifier_key};
use litesim_osc::{Program, Span};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};

mod behaviour;
mod environment;
mod exprs;
mod paths;
pub use paths::{MAX_PATH_POINTS, PathDef, PathPoint, read_csv};
mod stdlib;
mod tree;
pub use tree::*;

/// The program and its declaration index (shared with the checker).
struct Lib<'a> {
    prog: &'a Program,
    ix: DeclIndex<'a>,
}

impl<'a> Lib<'a> {
    fn new(prog: &'a Program) -> Self {
        Lib {
            prog,
            ix: DeclIndex::build(prog),
        }
    }

    fn is_a(&self, t: &str, base: &str) -> bool {
        self.ix.is_a(t, base)
    }

    /// Parameter names of an action, modifier or scenario, in positional order.
    fn params(&self, key: &str) -> Vec<String> {
        self.ix
            .params(key)
            .into_iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// A range given for an `int`/`uint` parameter of `key` becomes the
    /// list of its integers, so that a run draws one of them with its seed
    /// (`change_lane(lane_changes: [1..2])`: 1 or 2, each as likely) rather
    /// than a real number truncated. Ranges of more than 4096 integers stay
    /// ranges.
    fn ints_drawn(&self, key: &str, bound: &mut BTreeMap<String, CExpr>) {
        for p in self.ix.params(key) {
            if !matches!(p.ty.base.name.text.as_str(), "int" | "uint") || p.ty.list {
                continue;
            }
            if let Some(CExpr::Range(Some(lo), Some(hi))) = bound.get(&p.name) {
                let (lo, hi) = (lo.ceil(), hi.floor());
                if lo <= hi && hi - lo < 4096.0 {
                    let items = (lo as i64..=hi as i64)
                        .map(|v| CExpr::Const(Value::Num(v as f64)))
                        .collect();
                    bound.insert(p.name.clone(), CExpr::List(items));
                }
            }
        }
    }

    /// The members of scenario `name` (declaration and `extend`s).
    fn scenario(&self, name: &str) -> Option<Vec<&'a Member>> {
        self.ix
            .compounds
            .get(name)
            .filter(|c| c.kind == DeclKind::Scenario)
            .map(|c| c.body.clone())
    }

    fn at(&self, span: Span) -> String {
        let f = self.prog.sources.file(span.file);
        let (l, c) = f.line_col(span.start as usize);
        format!("{}:{l}:{c}", f.path)
    }
}

/// Names visible in one scenario instance.
#[derive(Clone, Default)]
struct Scope {
    /// Namespace of the instance (`s`); fields are `ns.field`.
    ns: String,
    /// Field names of the instance.
    fields: BTreeSet<String>,
    /// Labels of the instance's `do` tree → namespace of a scenario instance.
    labels: BTreeMap<String, String>,
    /// The actor the scenario runs on (`actor`).
    actor: Option<String>,
    /// `it` inside a field's `with:`.
    it: Option<String>,
}

struct Elab<'a> {
    lib: Lib<'a>,
    test: Test,
    /// actor path → id
    actor_ids: BTreeMap<String, String>,
    counter: usize,
    depth: usize,
    /// Traffic settings met so far (in any `extend test_config`), with
    /// the span of the one that names the density (else the first).
    traffic: Option<(TrafficDecl, Span)>,
}

/// Elaborates `top.main` of a program that loaded without errors.
pub fn elaborate(prog: &Program) -> Result<Test, ScenarioError> {
    if prog.has_errors() {
        return Err(ScenarioError::Elaboration(
            "the program has errors; run `litesim check` for the diagnostics".into(),
        ));
    }
    let mut e = Elab {
        lib: Lib::new(prog),
        test: Test::default(),
        actor_ids: BTreeMap::new(),
        counter: 0,
        depth: 0,
        traffic: None,
    };
    // The ego: `sut.car`.
    e.test.actors.push(ActorDef {
        id: "sut.car".into(),
        path: "sut.car".into(),
        type_name: "vehicle".into(),
        kind: ActorClass::Vehicle,
        ego: true,
    });
    e.actor_ids.insert("sut.car".into(), "sut.car".into());
    let mut main: Vec<&Member> = Vec::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            if let Decl::Extend { target, members } = d {
                match (
                    target.actor.as_ref().map(|a| a.text.as_str()),
                    target.name.text.as_str(),
                ) {
                    (Some("top"), "main") => main.extend(members.iter()),
                    (None, "test_config") | (None, "sim_info") => e.config(members)?,
                    _ => {}
                }
            }
        }
    }
    e.traffic()?;
    let scope = Scope {
        ns: "top".into(),
        ..Scope::default()
    };
    let mut root = e.body(&main, scope)?;
    if let Some(r) = &mut root {
        r.number(&mut 0);
    }
    e.test.root = root;
    Ok(e.test)
}

impl Elab<'_> {
    fn config(&mut self, members: &[Member]) -> Result<(), ScenarioError> {
        for m in members {
            if let Member::Set { path, value, span } = m {
                let Expr::Ident { name, .. } = path else {
                    continue;
                };
                let v = self.constant(value)?;
                let bad = || {
                    ScenarioError::Elaboration(format!(
                        "{}: '{name}' has the wrong type",
                        self.lib.at(*span)
                    ))
                };
                match name.as_str() {
                    "map" => self.test.config.map = Some(v.text().ok_or_else(bad)?.to_string()),
                    "seed" => self.test.config.seed = Some(v.num().ok_or_else(bad)? as u64),
                    "step_ms" => self.test.config.step_ms = Some(v.num().ok_or_else(bad)? as u32),
                    "simulator_name" => {
                        self.test.config.simulator_name = v.text().ok_or_else(bad)?.to_string()
                    }
                    "profile" => self.test.config.profile = v.text().ok_or_else(bad)?.to_string(),
                    "dynamic" => self.test.config.dynamic = v.boolean().ok_or_else(bad)?,
                    "min_ttc" | "min_gap" | "max_decel" | "max_jerk" | "max_jerk_1s"
                    | "min_thw" | "max_drac" | "min_pet" | "goal_tolerance" | "sut_timeout" => {
                        let x = v.num().ok_or_else(bad)?;
                        if !(x.is_finite() && x >= 0.0) {
                            return Err(ScenarioError::Elaboration(format!(
                                "{}: '{name}' must be a finite value ≥ 0 (0 turns the check off), got {x}",
                                self.lib.at(*span)
                            )));
                        }
                        let th = &mut self.test.config.thresholds;
                        let slot = match name.as_str() {
                            "min_ttc" => &mut th.min_ttc,
                            "min_gap" => &mut th.min_gap,
                            "max_decel" => &mut th.max_decel,
                            "max_jerk" => &mut th.max_jerk,
                            "max_jerk_1s" => &mut th.max_jerk_1s,
                            "min_thw" => &mut th.min_thw,
                            "max_drac" => &mut th.max_drac,
                            "min_pet" => &mut th.min_pet,
                            "goal_tolerance" => &mut th.goal_tolerance,
                            _ => &mut th.sut_timeout,
                        };
                        *slot = (x > 0.0).then_some(x);
                    }
                    "traffic_density" | "traffic_min_speed" | "traffic_max_speed"
                    | "traffic_radius" | "traffic_time_gap" | "traffic_politeness" => {
                        let x = v.num().ok_or_else(bad)?;
                        let (t, at) = self.traffic.get_or_insert_with(|| {
                            (
                                TrafficDecl {
                                    density: 0.0,
                                    speed: (80.0 / 3.6, 120.0 / 3.6),
                                    radius: 300.0,
                                    time_gap: 1.5,
                                    politeness: 0.3,
                                    at: String::new(),
                                },
                                *span,
                            )
                        });
                        match name.as_str() {
                            "traffic_density" => {
                                t.density = x;
                                *at = *span;
                            }
                            "traffic_min_speed" => t.speed.0 = x,
                            "traffic_max_speed" => t.speed.1 = x,
                            "traffic_radius" => t.radius = x,
                            "traffic_time_gap" => t.time_gap = x,
                            _ => t.politeness = x,
                        }
                    }
                    _ => {}
                }
            }
        }
        Ok(())
    }

    /// Checks the traffic settings of every `extend test_config` together.
    fn traffic(&mut self) -> Result<(), ScenarioError> {
        if let Some((mut t, span)) = self.traffic.take() {
            t.at = self.lib.at(span);
            let at = t.at.clone();
            let t = t
                .check()
                .map_err(|e| ScenarioError::Elaboration(format!("{at}: {e}")))?;
            if t.density > 0.0 {
                self.test.config.traffic = Some(t);
            } else {
                self.test.notes.push(format!(
                    "{at}: traffic settings without a traffic_density above 0: no ambient traffic"
                ));
            }
        }
        Ok(())
    }
}

/// `go`, `first.end`: the dotted path of an event reference.
fn event_name(e: &Expr) -> Option<String> {
    match e {
        Expr::Ident { name, .. } => Some(name.clone()),
        Expr::Field { base, name, .. } => Some(format!("{}.{}", event_name(base)?, name.text)),
        Expr::Unary { op, expr, .. } if op == "@" => event_name(expr),
        _ => None,
    }
}

/// The argument of `elapsed(t)`.
fn elapsed_arg(e: &Expr) -> Option<&Expr> {
    match e {
        Expr::Call { callee, args, .. } if matches!(&**callee, Expr::Ident { name, .. } if name == "elapsed") => {
            args.first().map(|a| &a.value)
        }
        _ => None,
    }
}
