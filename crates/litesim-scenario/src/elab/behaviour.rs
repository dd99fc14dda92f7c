//! Behaviour: a scenario's body and its fields, the `do` tree with its
//! invocations inlined under their labels, modifiers, `keep`s and
//! coverage items.

use super::*;

/// The path argument of a call: under which key, and its index among the
/// test's paths.
type PathArg = Option<(String, usize)>;

impl Elab<'_> {
    /// Declares a scenario's fields under `sc.ns`.
    pub(super) fn fields(
        &mut self,
        members: &[&Member],
        sc: &mut Scope,
    ) -> Result<(), ScenarioError> {
        for m in members {
            let Member::Field(f) = m else { continue };
            for n in &f.names {
                sc.fields.insert(n.text.clone());
            }
        }
        for m in members {
            let Member::Field(f) = m else { continue };
            let t = f.ty.base.name.text.clone();
            for n in &f.names {
                let path = format!("{}.{}", sc.ns, n.text);
                let kind = [
                    ("vehicle", ActorClass::Vehicle),
                    ("person", ActorClass::Person),
                    ("cyclist", ActorClass::Cyclist),
                    ("animal", ActorClass::Animal),
                    ("stationary_object", ActorClass::Stationary),
                    ("physical_object", ActorClass::Stationary),
                ]
                .into_iter()
                .find(|(b, _)| self.lib.is_a(&t, b))
                .map(|(_, k)| k);
                if let Some(kind) = kind {
                    let mut id = n.text.clone();
                    if self.test.actors.iter().any(|a| a.id == id) {
                        id = path.clone();
                    }
                    self.actor_ids.insert(path.clone(), id.clone());
                    self.test.actors.push(ActorDef {
                        id,
                        path: path.clone(),
                        type_name: t.clone(),
                        kind,
                        ego: false,
                    });
                } else {
                    let road = if self.lib.is_a(&t, "one_way_road") {
                        Some(RoadKind::OneWay)
                    } else if self.lib.is_a(&t, "two_way_road") {
                        Some(RoadKind::TwoWay)
                    } else if self.lib.is_a(&t, "road_element") {
                        Some(RoadKind::Road)
                    } else {
                        None
                    };
                    let default = f.default.as_ref().map(|d| self.cexpr(d, sc));
                    self.test.vars.insert(
                        path.clone(),
                        VarDef {
                            type_name: t.clone(),
                            road,
                            default,
                        },
                    );
                }
                // `with:` constraints on the field, with `it` bound.
                let mut inner = sc.clone();
                inner.it = Some(path.clone());
                for w in &f.with {
                    if let Member::Keep {
                        strength,
                        expr,
                        span,
                    } = w
                    {
                        self.keep(strength.as_deref(), expr, *span, &inner);
                    }
                }
            }
        }
        Ok(())
    }

    pub(super) fn keep(&mut self, strength: Option<&str>, expr: &Expr, span: Span, sc: &Scope) {
        let c = Constraint {
            soft: strength == Some("default"),
            expr: self.cexpr(expr, sc),
            at: self.lib.at(span),
        };
        self.test.constraints.push(c);
    }

    /// A scenario body (or `top.main`'s): fields, keeps, then its `do`.
    pub(super) fn body(
        &mut self,
        members: &[&Member],
        mut sc: Scope,
    ) -> Result<Option<Node>, ScenarioError> {
        self.depth += 1;
        if self.depth > 32 {
            return Err(ScenarioError::Elaboration(
                "scenarios invoke each other more than 32 levels deep (recursion?)".into(),
            ));
        }
        self.fields(members, &mut sc)?;
        // Labels first: keeps may name them before the `do`.
        for m in members {
            if let Member::Do(d) = m {
                self.collect_labels(d, &mut sc);
            }
        }
        let mut root = None;
        for m in members {
            match m {
                Member::Keep {
                    strength,
                    expr,
                    span,
                } => self.keep(strength.as_deref(), expr, *span, &sc),
                Member::Do(d) => {
                    let n = self.node(d, &sc)?;
                    if root.is_some() {
                        self.test
                            .notes
                            .push("a second `do` in one scenario is ignored".into());
                    } else {
                        root = n;
                    }
                }
                Member::Method { name, .. } => self.test.notes.push(format!(
                    "method '{}' in {}: not executed by the engine",
                    name.text, sc.ns
                )),
                // A plain `event e` is what `emit e` raises and `@e` waits
                // for; only a definition (`event e is …`) goes unevaluated.
                Member::Event {
                    name, is: Some(_), ..
                } => self.test.notes.push(format!(
                    "event '{}' in {}: its `is` definition is not evaluated; only `emit {}` raises it",
                    name.text, sc.ns, name.text
                )),
                Member::On { .. } => self
                    .test
                    .notes
                    .push(format!("`on` in {}: not executed by the engine", sc.ns)),
                Member::Coverage { record, args, span } => self.cover(*record, args, *span, &sc),
                _ => {}
            }
        }
        self.depth -= 1;
        Ok(root)
    }

    /// A `cover`/`record` item (the checker has vetted its arguments).
    pub(super) fn cover(&mut self, record: bool, args: &[Arg], span: Span, sc: &Scope) {
        use crate::coverage::{CoverItem, SampleAt};
        let named = |n: &str| {
            args.iter()
                .find(|a| a.name.as_ref().is_some_and(|x| x.text == n))
                .map(|a| &a.value)
        };
        let name = match (args.first(), named("name")) {
            (_, Some(Expr::Ident { name, .. })) => name.clone(),
            (
                Some(Arg {
                    name: None,
                    value: Expr::Ident { name, .. },
                }),
                _,
            ) => name.clone(),
            _ => return,
        };
        let at = self.lib.at(span);
        let expr = match named("expression") {
            Some(e) => self.cexpr(e, sc),
            None => self
                .path(
                    &Expr::Ident {
                        name: name.clone(),
                        span,
                    },
                    sc,
                )
                .unwrap_or(CExpr::Opaque(name.clone())),
        };
        let unit = match named("unit") {
            Some(Expr::Ident { name, .. }) => Some(name.clone()),
            _ => None,
        };
        let factor = unit.as_deref().map_or(1.0, |u| self.unit(u));
        // A bound or width: physical literals convert to the item's unit,
        // plain numbers are in it.
        let in_unit = |e: &Expr| -> Option<f64> {
            match e {
                Expr::Physical { value, unit, .. } => Some(value * self.unit(unit) / factor),
                Expr::Int { value, .. } => Some(*value as f64),
                Expr::Float { value, .. } => Some(*value),
                Expr::Unary { op, expr, .. } if op == "-" => match &**expr {
                    Expr::Physical { value, unit, .. } => Some(-value * self.unit(unit) / factor),
                    Expr::Int { value, .. } => Some(-(*value as f64)),
                    Expr::Float { value, .. } => Some(-value),
                    _ => None,
                },
                _ => None,
            }
        };
        let range = match named("range") {
            Some(Expr::Range { lo, hi, unit, .. }) => {
                let scale = unit.as_deref().map_or(1.0, |u| self.unit(u) / factor);
                match (
                    lo.as_deref().and_then(in_unit),
                    hi.as_deref().and_then(in_unit),
                ) {
                    (Some(a), Some(b)) => Some((a * scale, b * scale)),
                    _ => None,
                }
            }
            _ => None,
        };
        let every = named("every").and_then(in_unit);
        // Enum and bool items bucket by value.
        let values = match &expr {
            CExpr::Var(p) => match self.test.vars.get(p).map(|v| v.type_name.as_str()) {
                Some("bool") => vec!["false".into(), "true".into()],
                Some(t) => self
                    .lib
                    .ix
                    .enums
                    .get(t)
                    .map(|m| m.iter().cloned().collect())
                    .unwrap_or_default(),
                None => Vec::new(),
            },
            _ => Vec::new(),
        };
        let event = match named("event") {
            Some(Expr::Ident { name: e, .. }) if e == "start" => SampleAt::Start,
            Some(Expr::Ident { name: e, .. }) if e == "end" => SampleAt::End,
            Some(Expr::Ident { name: e, .. }) => match sc.labels.get(e) {
                Some(path) => SampleAt::PhaseEnd(path.clone()),
                None => {
                    self.test.notes.push(format!(
                        "{at}: {} '{name}' is sampled at event '{e}', which the engine does not raise: sampled at the end instead",
                        if record { "record" } else { "cover" }
                    ));
                    SampleAt::End
                }
            },
            // The default: the end of the enclosing scenario — its
            // invocation's end where the plan knows it (a labelled
            // invocation), else the end of the run.
            _ if sc.ns != "top" => SampleAt::PhaseEnd(sc.ns.clone()),
            _ => SampleAt::End,
        };
        let text = match named("text") {
            Some(Expr::Str { value, .. }) => Some(value.clone()),
            _ => None,
        };
        self.test.covers.push(CoverItem {
            name: format!("{}.{name}", sc.ns),
            record,
            expr,
            unit,
            factor,
            range,
            every,
            values,
            event,
            text,
            at,
        });
    }

    pub(super) fn collect_labels(&mut self, d: &DoMember, sc: &mut Scope) {
        if let Some(l) = &d.label {
            let ns = if sc.ns == "top" {
                l.text.clone()
            } else {
                format!("{}.{}", sc.ns, l.text)
            };
            sc.labels.insert(l.text.clone(), ns);
        }
        if let DoKind::Composition { children, .. } = &d.kind {
            for c in children {
                self.collect_labels(c, sc);
            }
        }
    }

    /// `along_trajectory(trajectory, start_offset, end_offset)`: the
    /// trajectory read like the trajectory actions', as the modifier that
    /// follows it.
    fn along_trajectory(
        &mut self,
        args: &[Arg],
        params: &[String],
        sc: &Scope,
        span: Span,
    ) -> Result<Modifier, ScenarioError> {
        let at = self.lib.at(span);
        let (path, rest) = self.split_path(
            ("along_trajectory", args),
            params,
            &["trajectory"],
            true,
            &at,
        )?;
        let Some((_, idx)) = path else {
            return Err(ScenarioError::Elaboration(format!(
                "{at}: along_trajectory needs its trajectory, e.g. `along_trajectory(trajectory(file: \"drive.csv\"))`"
            )));
        };
        if self.test.paths[idx].relative {
            return Err(ScenarioError::Elaboration(format!(
                "{at}: along_trajectory takes a trajectory, not a relative_trajectory"
            )));
        }
        let mut bound = self.bind(&rest, params, sc);
        bound.insert("path".into(), CExpr::Const(Value::Num(idx as f64)));
        Ok(Modifier {
            kind: crate::intent::ModKind::FollowPath,
            name: "along_trajectory".into(),
            args: bound,
            at,
        })
    }

    /// Splits a call's arguments: the one under one of `keys` (a path or
    /// trajectory, `timed` for a trajectory: read here, a literal of
    /// points or a CSV file, and named by its index in the test), and the
    /// others, each named (positional ones by `params`). Two of `keys`
    /// given is an error naming the call (`what`).
    fn split_path(
        &mut self,
        (what, args): (&str, &[Arg]),
        params: &[String],
        keys: &[&str],
        timed: bool,
        at: &str,
    ) -> Result<(PathArg, Vec<Arg>), ScenarioError> {
        let mut path = None;
        let mut rest = Vec::with_capacity(args.len());
        for (i, a) in args.iter().enumerate() {
            let key = a.name.as_ref().map_or_else(
                || params.get(i).cloned().unwrap_or_default(),
                |n| n.text.clone(),
            );
            if keys.contains(&key.as_str()) {
                let idx = self.path_def(&a.value, timed, at)?;
                if let Some((first, _)) = path.replace((key.clone(), idx)) {
                    return Err(ScenarioError::Elaboration(format!(
                        "{at}: {what} takes one of {first} and {key}, not both"
                    )));
                }
                continue;
            }
            rest.push(Arg {
                name: Some(litesim_osc::ast::Name {
                    text: key,
                    span: a.value.span(),
                }),
                value: a.value.clone(),
            });
        }
        Ok((path, rest))
    }

    pub(super) fn mods(
        &mut self,
        with: &[Member],
        sc: &Scope,
        out: &mut Vec<Modifier>,
    ) -> Result<(), ScenarioError> {
        for m in with {
            match m {
                Member::Modifier { call, .. } => {
                    let Expr::Call { callee, args, span } = call else {
                        continue;
                    };
                    let name = match &**callee {
                        Expr::Ident { name, .. } => name.clone(),
                        Expr::Field { name, .. } => name.text.clone(),
                        _ => continue,
                    };
                    let key = modifier_key(&name);
                    let params = self.lib.params(&key);
                    if name == "along_trajectory" {
                        out.push(self.along_trajectory(args, &params, sc, *span)?);
                        continue;
                    }
                    let mut bound = self.bind(args, &params, sc);
                    self.lib.ints_drawn(&key, &mut bound);
                    let kind = crate::intent::ModKind::of(&name);
                    if matches!(
                        kind,
                        crate::intent::ModKind::Speed
                            | crate::intent::ModKind::ChangeSpeed
                            | crate::intent::ModKind::Acceleration
                    ) {
                        let refs = crate::intent::RELATIVE_SPEED.map(|(k, _)| k);
                        at_most_one(
                            &bound,
                            &refs,
                            (&self.lib.at(*span), &name),
                            "exclude each other (give one reference actor)",
                        )?;
                    }
                    let at = self.lib.at(*span);
                    // `track: projected` reads a reference's motion as it
                    // would have gone on from the phase's start: the
                    // planner and the runtime do that for a speed, an
                    // acceleration or a position relative to another
                    // actor; the sideways references follow it as it moves.
                    if let Some(CExpr::Const(Value::Enum(t))) = bound.get("track")
                        && t == "projected"
                        && matches!(name.as_str(), "lane" | "lateral" | "yaw" | "orientation")
                    {
                        return Err(ScenarioError::Elaboration(format!(
                            "{at}: {name}(track: {t}) is not supported by litesim: its reference is followed as it actually moves (speed, acceleration and position support track: projected)"
                        )));
                    }
                    let (kind, bound) = supported(&name, kind, bound, &at)?;
                    out.push(Modifier {
                        kind,
                        args: bound,
                        name,
                        at: self.lib.at(*span),
                    });
                }
                Member::Keep {
                    strength,
                    expr,
                    span,
                } => self.keep(strength.as_deref(), expr, *span, sc),
                Member::Until(spec) => {
                    let at = self.lib.at(spec.span);
                    let arg = match (&spec.event, &spec.cond) {
                        (Some(e), _) => event_name(e)
                            .map(|n| ("event".to_string(), CExpr::Const(Value::Str(n)))),
                        (None, Some(c)) => Some(match elapsed_arg(c) {
                            Some(a) => ("elapsed".to_string(), self.cexpr(a, sc)),
                            None => ("cond".to_string(), self.condition(c, sc)),
                        }),
                        _ => None,
                    };
                    match arg {
                        Some((k, v)) => out.push(Modifier {
                            kind: crate::intent::ModKind::Until,
                            name: "until".into(),
                            args: BTreeMap::from([(k, v)]),
                            at,
                        }),
                        None => self
                            .test
                            .notes
                            .push(format!("{at}: `until` without an event or condition")),
                    }
                }
                _ => {}
            }
        }
        contradictions(out)
    }

    /// An invocation in a `do` tree: a traffic light's `switch(color)`, an
    /// actor's action with its modifiers, or a scenario inlined under its
    /// label (its arguments bound as constraints on the instance's fields).
    pub(super) fn invoke(
        &mut self,
        call: &Expr,
        with: &[Member],
        label: Option<String>,
        sc: &Scope,
    ) -> Result<Option<Node>, ScenarioError> {
        let Expr::Call { callee, args, span } = call else {
            return Ok(None);
        };
        let (base, name) = match &**callee {
            Expr::Field { base, name, .. } => (Some(&**base), name.text.clone()),
            Expr::Ident { name, .. } => (None, name.clone()),
            _ => return Ok(None),
        };
        let at = self.lib.at(*span);
        let mut mods = Vec::new();
        let light = base.and_then(|b| match self.path(b, sc) {
            Some(CExpr::Var(p))
                if self
                    .test
                    .vars
                    .get(&p)
                    .is_some_and(|v| self.lib.is_a(&v.type_name, "traffic_light")) =>
            {
                Some(p)
            }
            _ => None,
        });
        if let Some(light) = light {
            if name != "switch" {
                return Err(ScenarioError::Elaboration(format!(
                    "{at}: a traffic light can only `switch(color)`, not '{name}'"
                )));
            }
            let bound = self.bind(args, &["color".to_string()], sc);
            let color = bound
                .get("color")
                .cloned()
                .ok_or_else(|| ScenarioError::Elaboration(format!("{at}: switch needs a color")))?;
            return Ok(Some(Node::Switch {
                id: 0,
                light,
                color,
                at,
            }));
        }
        if base.is_some_and(|b| self.is_environment(b, sc)) {
            if !with.is_empty() {
                return Err(ScenarioError::Elaboration(format!(
                    "{at}: environment.{name} takes no `with:` block (it changes the environment at its time)"
                )));
            }
            return self.environment_action(&name, args, sc, at).map(Some);
        }
        if let Some(action) = crate::intent::Action::parse(&name) {
            let actor = base.and_then(|b| self.actor_of(b, sc)).ok_or_else(|| {
                ScenarioError::Elaboration(format!(
                    "{at}: '{name}' needs an actor, e.g. `car1.{name}()`"
                ))
            })?;
            self.mods(with, sc, &mut mods)?;
            self.std_action(action, args, sc, &at, &mut mods)?;
            contradictions(&mods)?;
            Ok(Some(Node::Action {
                id: 0,
                label,
                actor,
                action,
                mods,
                at,
            }))
        } else if let Some(members) = self.lib.scenario(&name) {
            self.counter += 1;
            let ns = match &label {
                Some(l) if sc.ns == "top" => l.clone(),
                Some(l) => format!("{}.{l}", sc.ns),
                None => format!("{}.{name}#{}", sc.ns, self.counter),
            };
            let actor = base.and_then(|b| match self.path(b, sc) {
                Some(CExpr::Var(p)) => Some(self.actor_ids.get(&p).cloned().unwrap_or(p)),
                _ => None,
            });
            let inner = Scope {
                ns: ns.clone(),
                actor,
                ..Scope::default()
            };
            let sub = self.body(&members, inner)?;
            // Arguments bind the instance's fields; the invocation's
            // `with:` keeps see the caller's names (`s.r1`).
            let params = self.lib.params(&name);
            for (p, v) in self.bind(args, &params, sc) {
                self.test.constraints.push(Constraint {
                    soft: false,
                    expr: CExpr::Binary(
                        "==".into(),
                        Box::new(CExpr::Var(format!("{ns}.{p}"))),
                        Box::new(v),
                    ),
                    at: at.clone(),
                });
            }
            self.mods(with, sc, &mut mods)?;
            Ok(Some(Node::Serial {
                id: 0,
                label,
                children: sub.into_iter().collect(),
                mods,
            }))
        } else {
            Err(ScenarioError::Elaboration(format!(
                "{at}: the engine cannot execute '{name}' (known actions: {})",
                crate::intent::Action::ALL
                    .map(crate::intent::Action::name)
                    .join(", ")
            )))
        }
    }

    /// A standard-library action's parameters as the modifiers that plan
    /// it ([`stdlib::StdCall`](super::stdlib::StdCall)).
    fn std_action(
        &mut self,
        action: crate::intent::Action,
        args: &[Arg],
        sc: &Scope,
        at: &str,
        mods: &mut Vec<Modifier>,
    ) -> Result<(), ScenarioError> {
        let name = action.name();
        let params = self.lib.params(name);
        let keys: &[&str] = if action.follows_path() {
            &["absolute", "relative"]
        } else {
            &[]
        };
        let (path, rest) = self.split_path((name, args), &params, keys, action.timed(), at)?;
        let mut bound = self.bind(&rest, &params, sc);
        if let Some((key, idx)) = path {
            if (key == "relative") != self.test.paths[idx].relative {
                return Err(ScenarioError::Elaboration(format!(
                    "{at}: {name}({key}: …) takes a {}",
                    if key == "relative" {
                        "relative_path or relative_trajectory"
                    } else {
                        "path or trajectory"
                    }
                )));
            }
            // An absolute path is where it is: a reference or a transform
            // would mean nothing.
            if key == "absolute"
                && let Some(k) = ["reference", "transform"]
                    .into_iter()
                    .find(|k| bound.contains_key(*k))
            {
                return Err(ScenarioError::Elaboration(format!(
                    "{at}: {name}(absolute: …, {k}: …): `{k}` places a relative path; an absolute one is where its points are"
                )));
            }
            bound.insert("path".into(), CExpr::Const(Value::Num(idx as f64)));
        }
        self.check_literals(&bound, at)?;
        let call = super::stdlib::StdCall { name, at, bound };
        call.lower(action, mods)
    }

    pub(super) fn node(&mut self, d: &DoMember, sc: &Scope) -> Result<Option<Node>, ScenarioError> {
        let label = d.label.as_ref().map(|l| l.text.clone());
        Ok(match &d.kind {
            DoKind::Composition {
                op,
                args,
                children,
                with,
            } => {
                let mut kids = Vec::new();
                for c in children {
                    if let Some(n) = self.node(c, sc)? {
                        kids.push(n);
                    }
                }
                let mut mods = Vec::new();
                let bound = self.bind(args, &["duration".into()], sc);
                let overlap = match bound.get("overlap") {
                    Some(CExpr::Const(v)) => v.text().unwrap_or("equal").to_string(),
                    _ => "equal".to_string(),
                };
                if let Some(dur) = bound.get("duration") {
                    mods.push(Modifier {
                        kind: crate::intent::ModKind::Duration,
                        name: "duration".into(),
                        args: BTreeMap::from([("duration".to_string(), dur.clone())]),
                        at: self.lib.at(d.span),
                    });
                }
                self.mods(with, sc, &mut mods)?;
                Some(match op.as_str() {
                    "parallel" => Node::Parallel {
                        id: 0,
                        label,
                        children: kids,
                        mods,
                        overlap,
                    },
                    "one_of" => Node::OneOf {
                        id: 0,
                        label,
                        children: kids,
                        mods,
                    },
                    _ => Node::Serial {
                        id: 0,
                        label,
                        children: kids,
                        mods,
                    },
                })
            }
            DoKind::Invoke { call, with } => self.invoke(call, with, label, sc)?,
            DoKind::Wait(spec) => {
                let event = spec.event.as_ref().and_then(event_name);
                let (duration, cond) = match &spec.cond {
                    Some(c) => match elapsed_arg(c) {
                        Some(a) => (Some(self.cexpr(a, sc)), None),
                        None => (None, Some(self.condition(c, sc))),
                    },
                    None => (None, None),
                };
                Some(Node::Wait {
                    id: 0,
                    duration,
                    event,
                    cond,
                })
            }
            DoKind::Emit { event } => {
                let e = match event {
                    Expr::Call { callee, .. } => &**callee,
                    other => other,
                };
                Some(Node::Emit {
                    id: 0,
                    event: event_name(e).unwrap_or_default(),
                })
            }
            DoKind::Call { .. } => {
                self.test
                    .notes
                    .push("`call` is not executed by the engine".into());
                None
            }
        })
    }
}

/// Modifiers of one block (with what a standard action asks, once
/// lowered) that cannot all hold: an error naming both and their places.
fn contradictions(out: &[Modifier]) -> Result<(), ScenarioError> {
    // What holds a speed contradicts what sets one in the same block,
    // and so do a speed and a change of it.
    use crate::intent::ModKind as K;
    let of = |k: &[K]| out.iter().find(|m| k.contains(&m.kind));
    // `speed(v, at: start)` is where a change starts from, not a rival.
    let starts = |m: &Modifier| matches!(m.args.get("at"), Some(CExpr::Const(Value::Enum(a))) if a == "start");
    let speed = out.iter().find(|m| m.kind == K::Speed && !starts(m));
    if let (Some(a), Some(b)) = (speed, of(&[K::ChangeSpeed])) {
        return Err(ScenarioError::Elaboration(format!(
            "{}: speed contradicts change_speed at {}: give one of them",
            a.at, b.at
        )));
    }
    // A position is ahead of or behind one actor, by a distance or a time.
    for m in out.iter().filter(|m| m.kind == K::Position) {
        for pair in [["ahead_of", "behind"], ["distance", "time"]] {
            if pair.iter().all(|k| m.args.contains_key(*k)) {
                return Err(ScenarioError::Elaboration(format!(
                    "{}: position: {} and {} exclude each other (give one)",
                    m.at, pair[0], pair[1]
                )));
            }
        }
    }
    // An acceleration relative to another actor sets the speed at every
    // sample, as a speed does.
    // What sets the phase's speed (a start speed does not).
    let speed_setter = out.iter().find(|m| {
        matches!(
            m.kind,
            K::ChangeSpeed | K::Distance | K::KeepSpeed | K::KeepPosition
        ) || (m.kind == K::Speed && !starts(m))
    });
    let relative_accel = out.iter().find(|m| {
        m.kind == K::Acceleration
            && crate::intent::RELATIVE_SPEED
                .iter()
                .any(|(k, _)| m.args.contains_key(*k))
    });
    if let (Some(a), Some(s)) = (relative_accel, speed_setter) {
        return Err(ScenarioError::Elaboration(format!(
            "{}: an acceleration relative to another actor sets the speed at every step; it contradicts {} at {}",
            a.at, s.name, s.at
        )));
    }
    // `along(…, end_offset: e)` sets how far the phase goes, as
    // `distance` does.
    let ends = out.iter().find(|m| {
        m.kind == K::Along
            && !matches!(
                m.args.get("end_offset"),
                None | Some(CExpr::Const(Value::Num(0.0)))
            )
    });
    if let (Some(a), Some(s)) = (ends, speed_setter) {
        return Err(ScenarioError::Elaboration(format!(
            "{}: along(…, end_offset: …) sets how far the phase goes; it contradicts {} at {}",
            a.at, s.name, s.at
        )));
    }
    for (holds, sets) in [
        (K::KeepSpeed, &[K::Speed, K::ChangeSpeed, K::Distance][..]),
        (K::Distance, &[K::Speed, K::ChangeSpeed][..]),
        (
            K::KeepPosition,
            &[K::Speed, K::ChangeSpeed, K::Distance, K::KeepSpeed][..],
        ),
    ] {
        if let (Some(h), Some(s)) = (of(&[holds]), of(sets)) {
            return Err(ScenarioError::Elaboration(format!(
                "{}: {}() contradicts {} at {}",
                h.at, h.name, s.name, s.at
            )));
        }
    }
    Ok(())
}

/// What litesim plans of `yaw(…)`: the whole phase (`at: all`), measured
/// from the road, from north or from another actor's heading.
fn yaw_supported(bound: &BTreeMap<String, CExpr>, at: &str) -> Result<(), ScenarioError> {
    let refuse = |what: String| {
        Err(ScenarioError::Elaboration(format!(
            "{at}: yaw({what}) is not supported by litesim (docs/osc-stdlib.md)"
        )))
    };
    let between_axes = [
        "length_to_length",
        "length_to_width",
        "width_to_length",
        "width_to_width",
    ];
    if let Some(CExpr::Const(Value::Enum(m))) = bound.get("measure_by") {
        if between_axes.contains(&m.as_str()) && !bound.contains_key("relative_to") {
            return Err(ScenarioError::Elaboration(format!(
                "{at}: yaw(measure_by: {m}) measures between its axes and another actor's: give that actor as `relative_to`"
            )));
        }
        if !between_axes.contains(&m.as_str())
            && !["relative_to_road", "relative_to_north", "absolute"].contains(&m.as_str())
        {
            return refuse(format!("measure_by: {m}"));
        }
    }
    Ok(())
}

/// `orientation(yaw, pitch, roll, relative_to, measured_by)` as the `yaw`
/// modifier it is for litesim (a heading only: a non-zero pitch or roll
/// is refused).
fn orientation_as_yaw(
    mut bound: BTreeMap<String, CExpr>,
    at: &str,
) -> Result<BTreeMap<String, CExpr>, ScenarioError> {
    for k in ["pitch", "roll"] {
        if matches!(bound.get(k), Some(CExpr::Const(Value::Num(v))) if *v != 0.0)
            || matches!(bound.get(k), Some(e) if !matches!(e, CExpr::Const(_)))
        {
            return Err(ScenarioError::Elaboration(format!(
                "{at}: orientation({k}: …) is not supported by litesim (a heading only)"
            )));
        }
    }
    let yaw = bound.remove("yaw").ok_or_else(|| {
        ScenarioError::Elaboration(format!(
            "{at}: orientation needs its yaw, e.g. `orientation(yaw: 90deg)`"
        ))
    })?;
    let measure = match bound.remove("measured_by") {
        Some(CExpr::Const(Value::Enum(m))) if m == "absolute" => "absolute",
        _ => "relative_to_road",
    };
    bound.insert("angle".into(), yaw);
    bound.insert(
        "measure_by".into(),
        CExpr::Const(Value::Enum(measure.into())),
    );
    bound.remove("pitch");
    bound.remove("roll");
    Ok(bound)
}

/// What litesim plans of `lateral(…)`: one reference at most, measured
/// centre to centre.
fn lateral_supported(bound: &BTreeMap<String, CExpr>, at: &str) -> Result<(), ScenarioError> {
    at_most_one(
        bound,
        &["side_of", "left_of", "right_of", "same_as"],
        (at, "lateral"),
        "exclude each other (give one reference actor)",
    )
}

/// At most one of `keys` given to the modifier `what` (at `at`); two or
/// more are an error naming them and `why`.
fn at_most_one(
    bound: &BTreeMap<String, CExpr>,
    keys: &[&str],
    (at, what): (&str, &str),
    why: &str,
) -> Result<(), ScenarioError> {
    let given: Vec<&str> = keys
        .iter()
        .copied()
        .filter(|k| bound.contains_key(*k))
        .collect();
    if given.len() > 1 {
        return Err(ScenarioError::Elaboration(format!(
            "{at}: {what}: {} {why}",
            given.join(" and ")
        )));
    }
    Ok(())
}

/// `change_speed` takes its change (`speed`, the standard's) or litesim's
/// `target`: exactly one of them.
fn change_speed_supported(bound: &BTreeMap<String, CExpr>, at: &str) -> Result<(), ScenarioError> {
    match (bound.contains_key("speed"), bound.contains_key("target")) {
        (true, false) | (false, true) => Ok(()),
        (true, true) => Err(ScenarioError::Elaboration(format!(
            "{at}: change_speed: `speed` (a change from the phase's start speed) and `target` (the speed to reach) exclude each other: give one"
        ))),
        (false, false) => Err(ScenarioError::Elaboration(format!(
            "{at}: change_speed needs its change, e.g. `change_speed(-20kph)`, or litesim's `target: 50kph`"
        ))),
    }
}

/// `along`: its road as `road` (litesim's) or `route` (the standard's),
/// not both; an `end_offset` is where the phase ends, so not `at: start`.
fn along_supported(bound: &BTreeMap<String, CExpr>, at: &str) -> Result<(), ScenarioError> {
    if bound.contains_key("road") && bound.contains_key("route") {
        return Err(ScenarioError::Elaboration(format!(
            "{at}: along: `road` and `route` name the same thing (litesim's name and the standard's): give one"
        )));
    }
    let nonzero = !matches!(
        bound.get("end_offset"),
        None | Some(CExpr::Const(Value::Num(0.0)))
    );
    if nonzero && matches!(bound.get("at"), Some(CExpr::Const(Value::Enum(a))) if a == "start") {
        return Err(ScenarioError::Elaboration(format!(
            "{at}: along(…, at: start, end_offset: …): the end offset is where the phase ends; give it with `at: all` or `at: end`"
        )));
    }
    Ok(())
}

/// What litesim takes of one written modifier, checked by its name (an
/// error naming what it cannot honour); `orientation` becomes a `yaw`.
fn supported(
    name: &str,
    kind: crate::intent::ModKind,
    bound: BTreeMap<String, CExpr>,
    at: &str,
) -> Result<(crate::intent::ModKind, BTreeMap<String, CExpr>), ScenarioError> {
    use crate::intent::ModKind as K;
    let (kind, bound) = match name {
        "orientation" => (K::Yaw, orientation_as_yaw(bound, at)?),
        "lateral" => {
            lateral_supported(&bound, at)?;
            (kind, bound)
        }
        "change_speed" => {
            change_speed_supported(&bound, at)?;
            (kind, bound)
        }
        "along" => {
            along_supported(&bound, at)?;
            (kind, bound)
        }
        "change_lane" => {
            at_most_one(
                &bound,
                &["num_of_lanes", "lane_changes", "lane"],
                (at, "change_lane"),
                "name the same number of lanes (litesim's, CARLA's and the standard's names): give one",
            )?;
            (kind, bound)
        }
        _ => (kind, bound),
    };
    if kind == K::Yaw {
        yaw_supported(&bound, at)?;
    }
    Ok((kind, bound))
}
