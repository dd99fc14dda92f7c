//! Semantic checks over a loaded program: names resolve (types, units,
//! modifiers, behaviours, fields along a path such as `s.r1`, labels, enum
//! members), expressions are typed (a speed given in seconds is an error;
//! kph and mps mix freely, being the same physical type), arguments of
//! actions and modifiers match their parameters (name, count, type, and
//! subtype for actors and structs), and constraints are boolean.
//!
//! Declarations from every file are collected first (imports and the
//! importer see each other), `extend` merges fields into its target, and
//! `inherits` makes a compound see its bases' fields. Names an expression
//! may use, innermost first: locals (`it`, method parameters), labels of
//! the compound's `do` tree, the compound's fields (own, extended,
//! inherited), `actor` in a scenario declared on an actor, globals, actor
//! names used as their instance (`sut.car`), and enum members where the
//! expected type is that enum (or unambiguous).

mod model;
mod passes;
mod types;
use model::*;
use passes::*;

use crate::ast::*;
use crate::diag::Diagnostic;
use crate::index::{DeclIndex, Dimension, dimension, modifier_key};
use crate::loader::Program;
use crate::precedence;
use crate::source::Span;
use rustc_hash::{FxHashMap, FxHashSet};
use std::collections::{BTreeMap, BTreeSet};

/// Members every scenario and action has (standard §7: events and timing).
const BEHAVIOUR_MEMBERS: &[&str] = &[
    "start",
    "end",
    "fail",
    "actor",
    "start_time",
    "end_time",
    "duration",
];

/// Names visible while checking one declaration's body.
#[derive(Default)]
struct Scope {
    /// The compound whose fields are visible.
    this: Option<String>,
    /// The actor of a scenario declared on one (`actor`).
    actor: Option<String>,
    /// Labels and locals, innermost last.
    locals: Vec<(String, Ty)>,
}

struct Checker<'a> {
    m: &'a Model,
    diags: Vec<Diagnostic>,
    scope: Scope,
    /// CARLA dialect: behaviours and modifiers declared without parameters
    /// are native and take any arguments (scenario_runner's convention).
    carla: bool,
    /// The actor type of the behaviour whose `with:` block is being checked
    /// (what an unqualified modifier there applies to).
    invoking: Option<Ty>,
    /// Checking the expression of a `keep` (a path to a `var` is an error).
    in_keep: bool,
}

fn labels(d: &DoMember, m: &Model, out: &mut Vec<(String, Ty)>) {
    match &d.kind {
        DoKind::Composition { children, .. } => {
            if let Some(l) = &d.label {
                out.push((l.text.clone(), Ty::Unknown));
            }
            children.iter().for_each(|c| labels(c, m, out));
        }
        DoKind::Invoke { call, .. } => {
            if let Some(l) = &d.label {
                let ty = call_target(call)
                    .filter(|(n, _)| m.compounds.contains_key(&n.text))
                    .map_or(Ty::Unknown, |(n, _)| Ty::Compound(n.text.into()));
                out.push((l.text.clone(), ty));
            }
        }
        _ => {
            if let Some(l) = &d.label {
                out.push((l.text.clone(), Ty::Unknown));
            }
        }
    }
}

impl Checker<'_> {
    fn err(&mut self, code: &'static str, span: Span, msg: String, hint: Option<String>) {
        let mut d = Diagnostic::error(code, span, msg);
        if let Some(h) = hint.filter(|h| !h.is_empty()) {
            d = d.with_hint(h);
        }
        self.diags.push(d);
    }

    fn modifier(&mut self, call: &Expr) {
        let Some((name, args)) = call_target(call) else {
            self.expr(call, None);
            return;
        };
        let receiver = match call {
            Expr::Call { callee, .. } if let Expr::Field { base, .. } = &**callee => {
                Some(self.expr(base, None))
            }
            _ => self.invoking.clone(),
        };
        let key = modifier_key(&name.text);
        // `modifier car.m` applies to cars (and what inherits from car).
        if let (Some(Ty::Compound(t)), Some(owner)) = (&receiver, self.m.owners.get(&key))
            && self.m.compounds.contains_key(&**t)
            && !self.m.is_a(t, owner)
        {
            let (t, owner) = (t.clone(), owner.clone());
            self.err(
                "E0342",
                name.span,
                format!(
                    "modifier '{}' is declared on {owner}; it does not apply to a {t}, which does not inherit from {owner}",
                    name.text
                ),
                Some(format!("use it with a behaviour of a {owner}")),
            );
        }
        match self.m.compounds.get(&key) {
            Some(_) => self.call_args("modifier", &key, &name, args),
            None => {
                let mods: Vec<String> = self
                    .m
                    .compounds
                    .keys()
                    .filter_map(|k| k.strip_prefix("modifier ").map(String::from))
                    .collect();
                let hint = close_names(&name.text, mods.iter());
                self.err(
                    "E0304",
                    name.span,
                    format!("unknown modifier '{}'", name.text),
                    (!hint.is_empty()).then(|| format!("did you mean: {hint}?")),
                );
            }
        }
    }

    fn keep(&mut self, expr: &Expr) {
        let outer = std::mem::replace(&mut self.in_keep, true);
        let t = self.expr(expr, None);
        self.in_keep = outer;
        self.want_bool(&t, expr.span(), "a constraint");
    }

    fn members(&mut self, members: &[Member]) {
        // Variables of this body: set by sampling or assignment, never by
        // the constraint solver, so no `keep` may name them (§3.6).
        let vars: BTreeMap<&str, Span> = members
            .iter()
            .filter_map(|m| match m {
                Member::Field(f) if f.var => Some(&f.names),
                _ => None,
            })
            .flatten()
            .map(|n| (n.text.as_str(), n.span))
            .collect();
        for m in members {
            if let Member::Keep { expr, .. } = m
                && !vars.is_empty()
            {
                let mut roots = Vec::new();
                path_roots(expr, &mut roots);
                if let Some((name, at, decl)) = roots
                    .into_iter()
                    .find_map(|(n, at)| vars.get(n.as_str()).map(|d| (n, at, *d)))
                {
                    self.diags.push(
                        Diagnostic::error(
                            "E0341",
                            at,
                            format!("a `keep` constrains '{name}', which is a `var`"),
                        )
                        .with_hint("variables get values by sampling or assignment, not from constraints: make it a parameter (drop `var`) to constrain it")
                        .with_related(decl, "declared as a variable here"),
                    );
                }
            }
        }
        for m in members {
            match m {
                Member::Field(f) => {
                    self.type_ref(&f.ty);
                    let want = self.m.ty_of(&f.ty);
                    if let Some(d) = &f.default {
                        self.value_for(d, &want, || format!("'{}'", f.names[0].text));
                    }
                    self.scope.locals.push(("it".into(), want));
                    self.members(&f.with);
                    self.scope.locals.pop();
                }
                Member::Keep { expr, .. } => self.keep(expr),
                Member::RemoveDefault { path, .. } => {
                    self.expr(path, None);
                }
                Member::Modifier { call, .. } => self.modifier(call),
                Member::Do(d) => self.do_member(d),
                Member::On { event, body } => {
                    self.event_spec(event);
                    body.iter().for_each(|d| self.do_member(d))
                }
                Member::Until(spec) => self.event_spec(spec),
                Member::Event { name, params, is } => {
                    params.iter().for_each(|p| self.type_ref(&p.ty));
                    if !params.is_empty() && is.is_some() {
                        self.err(
                            "E0345",
                            name.span,
                            format!(
                                "event '{}' has parameters and an `is` specification; only an event without parameters may have one (§3.8)",
                                name.text
                            ),
                            Some("drop the parameters (its occurrences carry no values then), or the `is` part and `emit` it with its arguments".into()),
                        );
                    }
                    if let Some(s) = is {
                        self.event_spec(s);
                    }
                }
                Member::Method {
                    params,
                    ret,
                    expr,
                    body,
                    ..
                } => self.method(params, ret.as_ref(), expr.as_ref(), body),
                Member::Set { path, value, .. } => {
                    let want = self.expr(path, None);
                    self.value_for(value, &want, || "this field".into());
                }
                Member::Coverage { record, args, span } => {
                    let events: Vec<String> = members
                        .iter()
                        .filter_map(|m| match m {
                            Member::Event { name, .. } => Some(name.text.clone()),
                            _ => None,
                        })
                        .collect();
                    self.coverage(*record, args, *span, &events);
                }
            }
        }
    }

    /// A method: its types; an `is external` one's arguments, or an
    /// expression body typed against its return type with the parameters
    /// in scope.
    fn method(&mut self, params: &[Field], ret: Option<&TypeRef>, expr: Option<&Expr>, body: &str) {
        params.iter().for_each(|p| self.type_ref(&p.ty));
        if let Some(r) = ret {
            self.type_ref(r);
        }
        // `is external lib.fn(args)`: the callee names something
        // outside the program; only its arguments are checked.
        let external = body.trim_start().starts_with("external");
        if external && let Some(Expr::Call { args, .. }) = expr {
            let n = self.scope.locals.len();
            for p in params {
                let t = self.m.ty_of(&p.ty);
                for name in &p.names {
                    self.scope.locals.push((name.text.clone(), t.clone()));
                }
            }
            for a in args {
                self.expr(&a.value, None);
            }
            self.scope.locals.truncate(n);
        } else if let Some(e) = expr {
            let n = self.scope.locals.len();
            for p in params {
                let t = self.m.ty_of(&p.ty);
                for name in &p.names {
                    self.scope.locals.push((name.text.clone(), t.clone()));
                }
            }
            let got = self.expr(e, None);
            if let Some(r) = ret {
                let want = self.m.ty_of(r);
                if !self.m.fits(&got, &want) {
                    self.err(
                        "E0313",
                        e.span(),
                        format!(
                            "the method returns {}, but this is {}",
                            want.describe(),
                            got.describe()
                        ),
                        None,
                    );
                }
            }
            self.scope.locals.truncate(n);
        }
    }

    /// `cover(name, expression:, unit:, range:, every:, event:, …)` and
    /// `record(…)` (§3.11): the name, known arguments, a scalar expression,
    /// a unit of the expression's dimension (mandatory for physical items),
    /// range and bucket width in that dimension, a local event.
    fn coverage(&mut self, record: bool, args: &[Arg], span: Span, events: &[String]) {
        let what = if record { "record" } else { "cover" };
        const KNOWN: &[&str] = &[
            "name",
            "expression",
            "unit",
            "range",
            "every",
            "event",
            "text",
            "items",
            "ignore",
            "illegal",
            "buckets",
            "target",
            "disable",
            "override",
        ];
        let named = |n: &str| {
            args.iter()
                .find(|a| a.name.as_ref().is_some_and(|x| x.text == n))
        };
        let mut name: Option<(&String, Span)> = None;
        for (k, a) in args.iter().enumerate() {
            match &a.name {
                None if k == 0 => match &a.value {
                    Expr::Ident { name: n, span } => name = Some((n, *span)),
                    other => self.err(
                        "E0320",
                        other.span(),
                        format!("the first argument of {what} must be the item's name"),
                        Some(format!("write {what}(my_item, expression: …)")),
                    ),
                },
                None => self.err(
                    "E0320",
                    a.value.span(),
                    format!(
                        "{what} takes one positional argument (the name); this one has no name"
                    ),
                    Some("name the argument: expression:, unit:, range:, every:, event:".into()),
                ),
                Some(n) if !KNOWN.contains(&n.text.as_str()) => self.err(
                    "E0321",
                    n.span,
                    format!("{what} has no argument '{}'", n.text),
                    Some(format!("expected one of: {}", KNOWN.join(", "))),
                ),
                Some(n) if n.text == "name" => match &a.value {
                    Expr::Ident { name: x, span } => name = Some((x, *span)),
                    other => self.err(
                        "E0320",
                        other.span(),
                        format!("the name of a {what} item must be an identifier"),
                        None,
                    ),
                },
                Some(_) => {}
            }
        }
        if name.is_none() && named("override").is_none() {
            self.err(
                "E0320",
                span,
                format!("{what} needs a name"),
                Some(format!("write {what}(my_item, expression: …)")),
            );
        }
        // What is sampled: `expression:`, else the field the name names.
        let ty = match (named("expression"), name) {
            (Some(e), _) => self.expr(&e.value, None),
            (None, Some((n, sp))) => self.ident(n, sp, None),
            (None, None) => Ty::Unknown,
        };
        let at = named("expression").map_or(span, |e| e.value.span());
        if matches!(ty, Ty::Str | Ty::Compound(_) | Ty::List(_)) {
            self.err(
                "E0322",
                at,
                format!(
                    "{what} samples a number, a physical value, an enum or a bool; this is {}",
                    ty.describe()
                ),
                Some("sample a field of it, e.g. sut.car.speed".into()),
            );
        }
        // The unit: a known unit of the expression's physical type.
        self.cover_unit(named("unit"), &ty, at, what);
        // Range and bucket width: in the unit (plain numbers) or physical
        // values of the expression's dimension.
        for key in ["range", "every"] {
            if let Some(a) = named(key)
                && !(record && key == "every")
            {
                self.cover_bound(key, a, &ty, what);
            }
        }
        // The event: start, end, a declared event or a label of this scope.
        if let Some(a) = named("event") {
            self.cover_event(a, events);
        }
    }

    /// A cover item's `unit:` (`unit`): a known unit of the type `ty` of
    /// the item (written at `at`); a physical item needs one, a plain one
    /// takes none.
    fn cover_unit(&mut self, unit: Option<&Arg>, ty: &Ty, at: Span, what: &str) {
        let unit_ty = match unit.map(|a| &a.value) {
            Some(Expr::Ident { name: u, span }) => match self.m.units.get(u) {
                Some(p) => Some((p.clone(), *span)),
                None => {
                    self.unknown_unit(u, *span);
                    None
                }
            },
            Some(other) => {
                self.err(
                    "E0323",
                    other.span(),
                    "unit: takes a unit name (e.g. kph)".into(),
                    None,
                );
                None
            }
            None => None,
        };
        match (ty, &unit_ty) {
            (Ty::Physical(p), None) if unit.is_none() => self.err(
                "E0323",
                at,
                format!(
                    "{what} of {} needs unit: (the unit its samples and buckets are in)",
                    ty.describe()
                ),
                Some(format!("e.g. unit: {}", self.some_unit(p))),
            ),
            (Ty::Physical(p), Some((q, usp))) if p != q => self.err(
                "E0324",
                *usp,
                format!("unit of a {q} for {what} of {}", ty.describe()),
                Some(format!("a unit of {p}, e.g. {}", self.some_unit(p))),
            ),
            (Ty::Number | Ty::Enum(_) | Ty::Bool, Some((q, usp))) => self.err(
                "E0324",
                *usp,
                format!("unit of a {q} for {what} of {}", ty.describe()),
                Some("leave unit: out".into()),
            ),
            _ => {}
        }
    }

    /// A cover item's `range:` or `every:` (`key`): in the item's unit
    /// (plain numbers) or physical values of the item's type `ty`; `every`
    /// positive.
    fn cover_bound(&mut self, key: &str, a: &Arg, ty: &Ty, what: &str) {
        let t = self.expr(&a.value, None);
        let bad = match (&t, ty) {
            (Ty::Physical(q), Ty::Physical(p)) => q != p,
            (Ty::Physical(_), Ty::Number | Ty::Enum(_) | Ty::Bool) => true,
            (Ty::Bool | Ty::Str | Ty::Enum(_) | Ty::Compound(_) | Ty::List(_), _) => true,
            _ => false,
        };
        if key == "range" && !matches!(a.value, Expr::Range { .. }) {
            self.err(
                "E0325",
                a.value.span(),
                format!("range: of {what} takes a range [lo..hi]"),
                None,
            );
        } else if bad {
            self.err(
                "E0325",
                a.value.span(),
                format!("{key}: is {}, the item is {}", t.describe(), ty.describe()),
                None,
            );
        }
        if key == "every"
            && let Expr::Int { value, .. } = &a.value
            && *value <= 0
        {
            self.err(
                "E0325",
                a.value.span(),
                "every: must be positive".into(),
                None,
            );
        }
        if key == "every"
            && let Expr::Physical { value, .. } | Expr::Float { value, .. } = &a.value
            && *value <= 0.0
        {
            self.err(
                "E0325",
                a.value.span(),
                "every: must be positive".into(),
                None,
            );
        }
    }

    /// A cover item's `event:`: start, end, a declared event or a label of
    /// this scope.
    fn cover_event(&mut self, a: &Arg, events: &[String]) {
        match &a.value {
            Expr::Ident { name: e, span } => {
                let known = e == "start"
                    || e == "end"
                    || events.contains(e)
                    || self.scope.locals.iter().any(|(n, _)| n == e);
                if !known {
                    self.err(
                        "E0326",
                        *span,
                        format!("no event '{e}' here"),
                        Some(
                            "start, end, an event declared in this scenario or a label of its phases (sampled at the phase's end)"
                                .into(),
                        ),
                    );
                }
            }
            other => self.err(
                "E0326",
                other.span(),
                "event: takes a local event name".into(),
                None,
            ),
        }
    }

    fn event_spec(&mut self, s: &EventSpec) {
        if let Some(c) = &s.cond {
            let t = self.expr(c, None);
            self.want_bool(&t, c.span(), "an event condition");
        }
    }

    fn do_member(&mut self, d: &DoMember) {
        match &d.kind {
            DoKind::Composition {
                children,
                with,
                args,
                ..
            } => {
                for a in args {
                    self.expr(&a.value, None);
                }
                children.iter().for_each(|c| self.do_member(c));
                self.members(with);
            }
            DoKind::Invoke { call, with } => {
                if let Some((name, args)) = call_target(call) {
                    let mut receiver = None;
                    if let Expr::Call { callee, .. } = call
                        && let Expr::Field { base, .. } = &**callee
                    {
                        let r = self.expr(base, None);
                        self.receiver_has(&r, &name);
                        receiver = Some(r);
                    }
                    match self.m.compounds.get(&name.text) {
                        Some((DeclKind::Scenario | DeclKind::Action, ..)) => {
                            self.call_args("behaviour", &name.text, &name, args)
                        }
                        _ => {
                            let bs: Vec<&String> = self
                                .m
                                .compounds
                                .iter()
                                .filter(|(_, v)| {
                                    matches!(v.0, DeclKind::Scenario | DeclKind::Action)
                                })
                                .map(|(k, _)| k)
                                .collect();
                            let hint = close_names(&name.text, bs.into_iter());
                            self.err(
                                "E0309",
                                name.span,
                                format!("unknown scenario or action '{}'", name.text),
                                (!hint.is_empty()).then(|| format!("did you mean: {hint}?")),
                            );
                        }
                    }
                    // Unqualified modifiers in its `with:` apply to the
                    // receiver of the behaviour (`a.drive() with: m()`).
                    let outer = std::mem::replace(&mut self.invoking, receiver);
                    self.members(with);
                    self.invoking = outer;
                    return;
                } else {
                    self.expr(call, None);
                }
                self.members(with);
            }
            DoKind::Wait(spec) => self.event_spec(spec),
            DoKind::Emit { event } => self.emit(event),
            DoKind::Call { .. } => {}
        }
    }

    /// `x.m(…)` in an expression: `m` is a method (`def`) of x's type or one
    /// it inherits, or one every object has (`as`, `is`); E0349 otherwise.
    /// Fields and events are not callable either.
    fn method_exists(&mut self, compound: &str, name: &Name) {
        let m = self.m;
        if matches!(name.text.as_str(), "as" | "is") || !m.compounds.contains_key(compound) {
            return;
        }
        match m.method_returns(compound, &name.text) {
            Some(true) => return,
            Some(false) => {
                self.err(
                    "E0351",
                    name.span,
                    format!(
                        "method '{}' of {compound} returns no value, but it is used in an expression",
                        name.text
                    ),
                    Some("declare what it returns (`def m(…) -> type is …`), or call it as a directive (`call x.m()`)".into()),
                );
                return;
            }
            None => {}
        }
        let field = m.field(compound, &name.text);
        if field == Some(Ty::Unknown) {
            return; // an event, or a field of an unknown type
        }
        let is_field = field.is_some();
        let methods: Vec<String> = m
            .method_names(compound)
            .into_iter()
            .map(String::from)
            .collect();
        let hint = if is_field {
            format!("'{}' is a field: read it without parentheses", name.text)
        } else if methods.is_empty() {
            format!("a {compound} has no methods besides as() and is()")
        } else {
            format!("its methods: {}", methods.join(", "))
        };
        self.err(
            "E0349",
            name.span,
            format!("a {compound} has no method '{}'", name.text),
            Some(hint),
        );
    }

    /// `keep(x.v == …)` where `v` is a `var` of x's type or one it
    /// inherits (§3.6): variables get values by sampling or assignment,
    /// never from the constraint solver (E0341, as for the body's own).
    fn var_in_keep(&mut self, compound: &str, name: &Name) {
        let m = self.m;
        if m.vars.is_empty() || !m.vars.values().any(|v| v.contains_key(&name.text)) {
            return; // not a variable anywhere: the common case
        }
        let Some((c, decl)) = m
            .lineage(compound)
            .find_map(|c| m.vars.get(c)?.get(&name.text).map(|d| (c, *d)))
        else {
            return;
        };
        self.diags.push(
            Diagnostic::error(
                "E0341",
                name.span,
                format!(
                    "a `keep` constrains '{}', which is a `var` of {c}",
                    name.text
                ),
            )
            .with_hint("variables get values by sampling or assignment, not from constraints: make it a parameter (drop `var`) to constrain it")
            .with_related(decl, "declared as a variable here"),
        );
    }

    /// `emit e(args)` of an event of this body's compound (or one it
    /// inherits): every parameter without a default gets a value, and no
    /// more arguments than parameters are given (E0346). Events of other
    /// objects and unknown names are left to the engine.
    fn emit(&mut self, event: &Expr) {
        let (callee, args): (&Expr, &[Arg]) = match event {
            Expr::Call { callee, args, .. } => (callee, args),
            e => (e, &[]),
        };
        if let Expr::Ident { name, span } = callee {
            let n = Name {
                text: name.clone(),
                span: *span,
            };
            self.emit_checked(&n, args, event.span());
        }
    }

    fn emit_checked(&mut self, name: &Name, args: &[Arg], at: Span) {
        let m = self.m;
        let Some(this) = self.scope.this.as_deref() else {
            return;
        };
        // The nearest compound in the inheritance chain that declares it.
        let Some(params) = m
            .lineage(this)
            .find_map(|c| m.events.get(c)?.get(&name.text))
        else {
            return;
        };
        for a in args {
            self.expr(&a.value, None);
        }
        let positional = args.iter().filter(|a| a.name.is_none()).count();
        let names = || {
            params
                .iter()
                .map(|(p, _)| p.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if args.len() > params.len() {
            let list = names();
            self.err(
                "E0346",
                at,
                format!(
                    "event '{}' has {} parameter(s), {} argument(s) given",
                    name.text,
                    params.len(),
                    args.len()
                ),
                Some(if list.is_empty() {
                    "emit it without arguments".into()
                } else {
                    format!("its parameters: {list}")
                }),
            );
            return;
        }
        let missing: Vec<&str> = params
            .iter()
            .enumerate()
            .filter(|(i, (p, has_default))| {
                !has_default
                    && *i >= positional
                    && !args
                        .iter()
                        .any(|a| a.name.as_ref().is_some_and(|n| &n.text == p))
            })
            .map(|(_, (p, _))| p.as_str())
            .collect();
        if !missing.is_empty() {
            self.err(
                "E0346",
                at,
                format!(
                    "`emit {}` gives no value for {}",
                    name.text,
                    missing
                        .iter()
                        .map(|p| format!("'{p}'"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                Some(format!(
                    "an occurrence carries a value for every parameter without a default: emit {}({})",
                    name.text,
                    names()
                )),
            );
        }
    }

    /// `x.drive()`: the behaviour must be declared on x's actor type or one
    /// it inherits from (`action vehicle.drive` is not a person's).
    fn receiver_has(&mut self, receiver: &Ty, name: &Name) {
        let (Ty::Compound(t), Some(owner)) = (receiver, self.m.owners.get(&name.text)) else {
            return;
        };
        if !self.m.compounds.contains_key(&**t) || self.m.is_a(t, owner) {
            return;
        }
        let owner = owner.clone();
        // The behaviours this actor type does have, for the hint.
        let mut own: Vec<String> = self
            .m
            .owners
            .iter()
            .filter(|(k, o)| {
                self.m.is_a(t, o)
                    && matches!(
                        self.m.compounds.get(*k).map(|c| c.0),
                        Some(DeclKind::Action | DeclKind::Scenario)
                    )
            })
            .map(|(k, _)| k.clone())
            .collect();
        own.sort();
        self.err(
            "E0337",
            name.span,
            format!(
                "a {t} has no action '{}': it is declared on {owner}, which {t} does not inherit from",
                name.text
            ),
            Some(if own.is_empty() {
                format!("call it on a {owner}")
            } else {
                format!("a {t} has: {}", own.join(", "))
            }),
        );
    }

    /// Checks a compound or extend body with the right names in scope.
    fn body(&mut self, this: Option<String>, actor: Option<String>, members: &[Member]) {
        let mut locals = Vec::new();
        for m in members {
            if let Member::Do(d) = m {
                labels(d, self.m, &mut locals);
            }
        }
        let saved = std::mem::replace(
            &mut self.scope,
            Scope {
                this,
                actor,
                locals,
            },
        );
        self.members(members);
        self.scope = saved;
    }
}

/// The names an expression reads at the root of its paths (`x` in `x`,
/// `x.y`, `x.y(…)`), with their places.
fn path_roots(e: &Expr, out: &mut Vec<(String, Span)>) {
    match e {
        Expr::Ident { name, span } => out.push((name.clone(), *span)),
        Expr::Field { base, .. } | Expr::Cast { base, .. } => path_roots(base, out),
        Expr::Index { base, index, .. } => {
            path_roots(base, out);
            path_roots(index, out);
        }
        Expr::Unary { expr, .. } => path_roots(expr, out),
        Expr::Binary { lhs, rhs, .. } => {
            path_roots(lhs, out);
            path_roots(rhs, out);
        }
        Expr::Ternary {
            cond,
            then,
            otherwise,
            ..
        } => {
            path_roots(cond, out);
            path_roots(then, out);
            path_roots(otherwise, out);
        }
        Expr::Call { callee, args, .. } => {
            path_roots(callee, out);
            args.iter().for_each(|a| path_roots(&a.value, out));
        }
        Expr::List { items, .. } => items.iter().for_each(|x| path_roots(x, out)),
        Expr::Range { lo, hi, .. } => {
            lo.iter().chain(hi.iter()).for_each(|x| path_roots(x, out));
        }
        _ => {}
    }
}

fn call_target(e: &Expr) -> Option<(Name, &[Arg])> {
    match e {
        Expr::Call { callee, args, .. } => match &**callee {
            Expr::Field { name, .. } => Some((name.clone(), &args[..])),
            Expr::Ident { name, span } => Some((
                Name {
                    text: name.clone(),
                    span: *span,
                },
                &args[..],
            )),
            _ => None,
        },
        _ => None,
    }
}

/// Semantic diagnostics of a loaded program.
pub fn check(prog: &Program) -> Vec<Diagnostic> {
    let m = Model::collect(prog);
    let carla = prog.dialect == crate::Dialect::Carla;
    let mut c = Checker {
        m: &m,
        diags: Vec::new(),
        scope: Scope::default(),
        carla,
        invoking: None,
        in_keep: false,
    };
    redefinitions(prog, &mut c.diags);
    declared_once(prog, &m, &mut c.diags);
    for (_, f) in &prog.files {
        for d in &f.decls {
            match d {
                Decl::Compound {
                    name,
                    inherits,
                    members,
                    of,
                    kind,
                } => {
                    if let Some(a) = &name.actor
                        && !matches!(m.compounds.get(&a.text), Some((DeclKind::Actor, ..)))
                    {
                        let actors: Vec<&String> = m
                            .compounds
                            .iter()
                            .filter(|(_, v)| v.0 == DeclKind::Actor)
                            .map(|(k, _)| k)
                            .collect();
                        let hint = close_names(&a.text, actors.into_iter());
                        c.err(
                            "E0317",
                            a.span,
                            format!(
                                "'{}' is declared on '{}', which is not an actor",
                                name.name.text, a.text
                            ),
                            (!hint.is_empty()).then(|| format!("did you mean: {hint}?")),
                        );
                    }
                    if let Some((base, cond)) = inherits {
                        if !m.compounds.contains_key(&base.name.text) {
                            c.err(
                                "E0305",
                                base.name.span,
                                format!(
                                    "'{}' inherits from unknown '{}'",
                                    name.name.text, base.name.text
                                ),
                                None,
                            );
                        } else if let Some(msg) =
                            inheritance_problem(&m, *kind, &name.name.text, &base.name.text)
                        {
                            c.err(msg.0, base.name.span, msg.1, Some(msg.2));
                        } else if let Some(cond) = cond {
                            // Conditional inheritance: the condition reads the base's fields.
                            c.scope = Scope {
                                this: Some(base.name.text.clone()),
                                ..Scope::default()
                            };
                            let t = c.expr(cond, None);
                            c.want_bool(&t, cond.span(), "an inheritance condition");
                        }
                    }
                    if let Some(of) = of
                        && !m.compounds.contains_key(&of.name.text)
                    {
                        c.err(
                            "E0309",
                            of.name.span,
                            format!("unknown scenario or action '{}'", of.name.text),
                            None,
                        );
                    }
                    let key = if *kind == DeclKind::Modifier {
                        modifier_key(&name.name.text)
                    } else {
                        name.name.text.clone()
                    };
                    let this = m.compounds.contains_key(&key).then_some(key);
                    c.body(this, name.actor.as_ref().map(|a| a.text.clone()), members);
                }
                Decl::Extend { target, members } => {
                    let builtin = target.actor.as_ref().is_some_and(|a| a.text == "top")
                        && target.name.text == "main";
                    let known = m.compounds.contains_key(&target.name.text);
                    if !builtin && !known {
                        c.err(
                            "E0306",
                            target.name.span,
                            format!("cannot extend unknown '{}'", target.name.text),
                            None,
                        );
                    }
                    let actor = target.actor.as_ref().map(|a| a.text.clone());
                    c.body(known.then(|| target.name.text.clone()), actor, members);
                }
                Decl::Unit { of, .. } if !m.physical.contains(&of.text) => {
                    c.err(
                        "E0301",
                        of.span,
                        format!("unknown physical type '{}'", of.text),
                        None,
                    );
                }
                Decl::Global(f) => c.body(None, None, &[Member::Field(f.clone())]),
                _ => {}
            }
        }
    }
    c.diags.sort_by_key(|d| (d.span.file, d.span.start));
    c.diags
}
