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

use crate::ast::*;
use crate::diag::Diagnostic;
use crate::index::{DeclIndex, Dimension, dimension, modifier_key};
use crate::loader::Program;
use crate::precedence;
use crate::source::Span;
use rustc_hash::{FxHashMap, FxHashSet};
use std::collections::{BTreeMap, BTreeSet};

const BUILTIN_TYPES: &[&str] = &["int", "uint", "float", "bool", "string"];

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

/// A compound's kind, own parameters and base.
type Compound = (DeclKind, Vec<(String, TypeRef)>, Option<String>);

/// A type's name inside [`Ty`]: shared, because types are copied at every
/// field lookup and literal (a copy is a count, not an allocation).
type Sym = std::rc::Rc<str>;

/// The type of an expression, as far as the checker can tell.
#[derive(Clone, Debug, PartialEq)]
enum Ty {
    /// Not known (builtin function results, method calls): never an error.
    Unknown,
    Bool,
    /// `int`, `uint` and `float` mix freely.
    Number,
    Str,
    Physical(Sym),
    Enum(Sym),
    Compound(Sym),
    List(Box<Ty>),
}

impl Ty {
    fn describe(&self) -> String {
        match self {
            Ty::Unknown => "a value".into(),
            Ty::Bool => "a bool".into(),
            Ty::Number => "a plain number".into(),
            Ty::Str => "a string".into(),
            Ty::Physical(p) => format!("a {p}"),
            Ty::Enum(e) => format!("a value of enum {e}"),
            Ty::Compound(c) => format!("a {c}"),
            Ty::List(t) => format!("a list of {}", t.describe().trim_start_matches("a ")),
        }
    }
}

/// The declarations as the checker looks them up. Hash maps: name lookups
/// are the checker's hot path, and nothing is ever emitted in these maps'
/// order (suggestions are sorted, see `close_names`).
#[derive(Default)]
struct Model {
    physical: FxHashSet<String>,
    /// CARLA's dialect: a physical type → the type of its dimension that
    /// was declared first (`velocity` → `speed`); see `DeclIndex`.
    physical_alias: FxHashMap<String, Sym>,
    units: FxHashMap<String, Sym>,
    enums: FxHashMap<String, BTreeSet<String>>,
    /// compound name (behaviours by their own name) → what it is
    compounds: FxHashMap<String, Compound>,
    globals: FxHashMap<String, TypeRef>,
    /// Every compound's visible fields (own, extended, inherited) and their
    /// types, built once: field lookups are the checker's hot path.
    field_types: FxHashMap<String, FxHashMap<String, Ty>>,
    /// Every compound's parameters in declaration order (for positional
    /// arguments), with their types.
    param_types: FxHashMap<String, Vec<(String, Ty)>>,
    /// The actor each actor-qualified action, scenario or modifier is
    /// declared on (`action vehicle.drive` → vehicle).
    owners: FxHashMap<String, String>,
    /// Each compound's own methods (declaration and extensions), with
    /// whether they return a value.
    methods: FxHashMap<String, Vec<(String, bool)>>,
    /// Each compound's own variables (declaration and extensions): name →
    /// where it is declared.
    vars: FxHashMap<String, BTreeMap<String, Span>>,
    /// Each compound's own events (declaration and extensions): name →
    /// parameters in order, each with whether it has a default.
    events: FxHashMap<String, BTreeMap<String, Vec<(String, bool)>>>,
}

fn close_names<'a>(name: &str, all: impl Iterator<Item = &'a String>) -> String {
    // Names sharing a prefix (two characters, not bytes: names may be
    // non-ASCII) or differing by little: the usual typos.
    let prefix: String = name.chars().take(2).collect();
    // All candidates sorted before the first five are taken: the names may
    // come from hash maps, whose order must not reach a message.
    let mut v: Vec<&String> = all
        .filter(|n| n.starts_with(&prefix) || levenshtein(n, name) <= 2)
        .collect();
    v.sort();
    v.dedup();
    v.truncate(5);
    v.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
}

fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            cur.push(
                (prev[j] + usize::from(ca != *cb))
                    .min(prev[j + 1] + 1)
                    .min(cur[j] + 1),
            );
        }
        prev = cur;
    }
    prev[b.len()]
}

impl Model {
    fn collect(prog: &Program) -> Self {
        Self::from_index(&DeclIndex::build(prog))
    }
    /// The checker's view of the shared declaration index, with each
    /// compound's field and parameter types resolved once.
    fn from_index(ix: &DeclIndex<'_>) -> Self {
        let mut m = Model {
            physical: ix.physical.iter().cloned().collect(),
            physical_alias: ix
                .physical_alias
                .iter()
                .map(|(k, v)| (k.clone(), Sym::from(v.as_str())))
                .collect(),
            units: ix
                .units
                .iter()
                .map(|(k, u)| {
                    let of = ix.physical_alias.get(&u.of).unwrap_or(&u.of);
                    (k.clone(), Sym::from(of.as_str()))
                })
                .collect(),
            enums: ix
                .enums
                .iter()
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect(),
            compounds: ix
                .compounds
                .iter()
                .map(|(k, c)| {
                    let own = c
                        .members
                        .iter()
                        .map(|d| (d.name.clone(), d.ty.clone()))
                        .collect();
                    (k.clone(), (c.kind, own, c.base.clone()))
                })
                .collect(),
            globals: ix
                .globals
                .iter()
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect(),
            owners: ix
                .compounds
                .iter()
                .filter_map(|(k, c)| c.owner.clone().map(|o| (k.clone(), o)))
                .collect(),
            ..Model::default()
        };
        // Each compound's own methods, variables and events (declaration and
        // extensions), in one pass over the bodies.
        for (k, c) in &ix.compounds {
            let (mut methods, mut vars, mut events) =
                (Vec::new(), BTreeMap::new(), BTreeMap::new());
            for member in &c.body {
                match member {
                    Member::Method { name, ret, .. } => {
                        methods.push((name.text.clone(), ret.is_some()))
                    }
                    Member::Field(f) if f.var => {
                        vars.extend(f.names.iter().map(|n| (n.text.clone(), n.span)))
                    }
                    Member::Event { name, params, .. } => {
                        let ps = params
                            .iter()
                            .flat_map(|f| {
                                f.names
                                    .iter()
                                    .map(|n| (n.text.clone(), f.default.is_some()))
                            })
                            .collect();
                        events.insert(name.text.clone(), ps);
                    }
                    _ => {}
                }
            }
            m.methods.insert(k.clone(), methods);
            // Only compounds with variables: a `keep`'s every path step
            // looks here.
            if !vars.is_empty() {
                m.vars.insert(k.clone(), vars);
            }
            m.events.insert(k.clone(), events);
        }
        let names: Vec<String> = m.compounds.keys().cloned().collect();
        for n in names {
            let mut map = FxHashMap::default();
            // Typed straight from the lineage's declarations (no copies of
            // the declared types): this runs for every compound per load.
            let params: Vec<(String, Ty)> = m
                .lineage(&n)
                .filter_map(|c| m.compounds.get(c))
                .flat_map(|(_, p, _)| p.iter().map(|(f, t)| (f.clone(), m.ty_of(t))))
                .collect();
            map.reserve(params.len());
            // Own fields first win over a base's field of the same name.
            for (f, t) in &params {
                map.entry(f.clone()).or_insert_with(|| t.clone());
            }
            m.field_types.insert(n.clone(), map);
            m.param_types.insert(n, params);
        }
        m
    }
    fn is_type(&self, t: &str) -> bool {
        BUILTIN_TYPES.contains(&t)
            || self.physical.contains(t)
            || self.enums.contains_key(t)
            || self.compounds.contains_key(t)
    }
    /// The names a compound's fields and its bases' go by (own first), for
    /// "did you mean" hints.
    fn member_names(&self, name: &str) -> Vec<String> {
        self.lineage(name)
            .filter_map(|n| self.compounds.get(n))
            .flat_map(|(_, p, _)| p.iter().map(|(n, _)| n.clone()))
            .collect()
    }
    /// A compound and the ones it inherits from, nearest first (an
    /// inheritance cycle, which E0339 reports, cannot loop).
    fn lineage<'m>(&'m self, start: &'m str) -> impl Iterator<Item = &'m str> + 'm {
        crate::index::lineage(start, |c| {
            self.compounds.get(c).and_then(|c| c.2.as_deref())
        })
    }
    /// `sub` is `sup` or inherits from it (directly or not).
    fn is_a(&self, sub: &str, sup: &str) -> bool {
        self.lineage(sub).any(|n| n == sup)
    }
    fn ty_of(&self, t: &TypeRef) -> Ty {
        let n = t.base.name.text.as_str();
        let base = match n {
            "int" | "uint" | "float" => Ty::Number,
            "bool" => Ty::Bool,
            "string" => Ty::Str,
            _ if self.physical.contains(n) => Ty::Physical(
                self.physical_alias
                    .get(n)
                    .cloned()
                    .unwrap_or_else(|| n.into()),
            ),
            _ if self.enums.contains_key(n) => Ty::Enum(n.into()),
            _ if self.compounds.contains_key(n) => Ty::Compound(n.into()),
            _ => Ty::Unknown,
        };
        if t.list {
            Ty::List(Box::new(base))
        } else {
            base
        }
    }
    /// The methods (`def`) a compound has, its own and inherited.
    fn method_names(&self, compound: &str) -> Vec<&str> {
        self.lineage(compound)
            .filter_map(|c| self.methods.get(c))
            .flatten()
            .map(|(n, _)| n.as_str())
            .collect()
    }
    /// Whether the nearest method `name` of a compound (own or inherited)
    /// returns a value; `None` when it has no such method.
    fn method_returns(&self, compound: &str, name: &str) -> Option<bool> {
        self.lineage(compound)
            .find_map(|c| self.methods.get(c)?.iter().find(|(n, _)| n == name))
            .map(|(_, r)| *r)
    }
    fn field(&self, compound: &str, name: &str) -> Option<Ty> {
        self.field_types.get(compound)?.get(name).cloned()
    }
    /// Whether a value of type `got` may be given where `want` is expected.
    fn fits(&self, got: &Ty, want: &Ty) -> bool {
        match (got, want) {
            (Ty::Unknown, _) | (_, Ty::Unknown) => true,
            (Ty::Compound(a), Ty::Compound(b)) => self.is_a(a, b),
            (Ty::List(a), Ty::List(b)) => self.fits(a, b),
            // A list value constrains a scalar parameter to one of its items.
            (Ty::List(a), b) => self.fits(a, b),
            (a, b) => a == b,
        }
    }
}

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

/// Enums and numbers do not mix without a conversion (§3.3): say which.
fn enum_number_hint(a: &Ty, b: &Ty) -> Option<String> {
    match (a, b) {
        (Ty::Enum(e), Ty::Number) | (Ty::Number, Ty::Enum(e)) => Some(format!(
            "convert explicitly: `x.as(int)` gives an enum value's number, `n.as({e})` the {e} member numbered n"
        )),
        _ => None,
    }
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

    fn type_ref(&mut self, t: &TypeRef) {
        let n = &t.base.name;
        if t.base.actor.is_none() && !self.m.is_type(&n.text) {
            let hint = close_names(
                &n.text,
                self.m
                    .compounds
                    .keys()
                    .chain(self.m.physical.iter())
                    .chain(self.m.enums.keys()),
            );
            self.err(
                "E0301",
                n.span,
                format!("unknown type '{}'", n.text),
                (!hint.is_empty()).then(|| format!("did you mean one of: {hint}?")),
            );
        }
    }

    /// A bare name that is no local, field, global or actor but a member
    /// of several enums: its type must come from the other operand.
    fn bare_literal(&self, e: &Expr) -> bool {
        let Expr::Ident { name, .. } = e else {
            return false;
        };
        let name = name.as_str();
        !self.scope.locals.iter().any(|(n, _)| n == name)
            && self
                .scope
                .this
                .as_deref()
                .is_none_or(|t| self.m.field(t, name).is_none())
            && !self.m.globals.contains_key(name)
            && !self.m.compounds.contains_key(name)
            && self.m.enums.values().filter(|ms| ms.contains(name)).count() > 1
    }

    /// Resolves a bare name; `want` lets an enum member be written unqualified.
    fn ident(&mut self, name: &str, span: Span, want: Option<&Ty>) -> Ty {
        if let Some(Ty::Enum(e)) = want
            && self.m.enums.get(&**e).is_some_and(|s| s.contains(name))
        {
            return Ty::Enum(e.clone());
        }
        if let Some((_, t)) = self.scope.locals.iter().rev().find(|(n, _)| n == name) {
            return t.clone();
        }
        if let Some(this) = &self.scope.this
            && let Some(t) = self.m.field(this, name)
        {
            return t;
        }
        if name == "actor"
            && let Some(a) = &self.scope.actor
        {
            return Ty::Compound(a.as_str().into());
        }
        if let Some(t) = self.m.globals.get(name) {
            return self.m.ty_of(t);
        }
        if matches!(self.m.compounds.get(name), Some((DeclKind::Actor, ..))) {
            return Ty::Compound(name.into());
        }
        let mut owners: Vec<&String> = self
            .m
            .enums
            .iter()
            .filter(|(_, ms)| ms.contains(name))
            .map(|(e, _)| e)
            .collect();
        owners.sort();
        if let Some(Ty::Enum(e)) = want {
            let members: Vec<&str> = self
                .m
                .enums
                .get(&**e)
                .map(|s| s.iter().map(String::as_str).collect())
                .unwrap_or_default();
            self.err(
                "E0311",
                span,
                format!("'{name}' is not a member of enum {e}"),
                Some(format!("its members: {}", members.join(", "))),
            );
            return Ty::Unknown;
        }
        if owners.len() == 1 {
            return Ty::Enum(owners[0].as_str().into());
        }
        if !owners.is_empty() {
            // A member of several enums and nothing here says which (§3.3).
            let list = owners
                .iter()
                .map(|e| format!("{e}!{name}"))
                .collect::<Vec<_>>()
                .join(", ");
            self.err(
                "E0347",
                span,
                format!(
                    "'{name}' is ambiguous: it is a member of {} and {}",
                    owners[..owners.len() - 1]
                        .iter()
                        .map(|e| e.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                    owners[owners.len() - 1]
                ),
                Some(format!("write the enum's name before it: {list}")),
            );
            return Ty::Unknown;
        }
        let mut visible: Vec<String> = self.scope.locals.iter().map(|(n, _)| n.clone()).collect();
        if let Some(this) = &self.scope.this {
            visible.extend(self.m.member_names(this));
        }
        let hint = close_names(name, visible.iter());
        let place = self
            .scope
            .this
            .as_ref()
            .map_or(String::new(), |t| format!(" in '{t}'"));
        // In a struct (a configuration such as test_config), the fields it
        // has are the answer: all of them, after the close ones.
        let fields = self.scope.this.as_ref().and_then(|t| {
            matches!(self.m.compounds.get(&**t), Some((DeclKind::Struct, ..)))
                .then(|| self.m.member_names(t))
        });
        let hint = match (hint.is_empty(), fields) {
            (true, Some(f)) => Some(format!("its fields: {}", f.join(", "))),
            (false, Some(f)) => Some(format!(
                "did you mean: {hint}? its fields: {}",
                f.join(", ")
            )),
            (false, None) => Some(format!("did you mean: {hint}?")),
            (true, None) => None,
        };
        self.err("E0310", span, format!("unknown name '{name}'{place}"), hint);
        Ty::Unknown
    }

    /// Checks an expression and returns its type.
    fn expr(&mut self, e: &Expr, want: Option<&Ty>) -> Ty {
        match e {
            Expr::Int { .. } | Expr::Float { .. } => Ty::Number,
            Expr::Str { .. } => Ty::Str,
            Expr::Bool { .. } => Ty::Bool,
            Expr::Physical { unit, span, .. } => match self.m.units.get(unit) {
                Some(p) => Ty::Physical(p.clone()),
                // A quoted unit (`80|foot/s|`) is a name like any other:
                // unknown unless declared (`unit |foot/s| of speed …`).
                None => {
                    self.unknown_unit(unit, *span);
                    Ty::Unknown
                }
            },
            Expr::Range { lo, hi, unit, span } => {
                let mut ty = Ty::Unknown;
                if let Some(u) = unit {
                    match self.m.units.get(u) {
                        Some(p) => ty = Ty::Physical(p.clone()),
                        None => self.err("E0302", *span, format!("unknown unit '{u}'"), None),
                    }
                }
                for x in lo.iter().chain(hi.iter()) {
                    let t = self.expr(x, None);
                    if ty == Ty::Unknown {
                        ty = t;
                    } else if matches!((&ty, &t), (Ty::Physical(_), Ty::Physical(_))) && ty != t {
                        self.err(
                            "E0303",
                            x.span(),
                            format!(
                                "range bound is {}, the range is {}",
                                t.describe(),
                                ty.describe()
                            ),
                            None,
                        );
                    }
                }
                ty
            }
            Expr::Ident { name, span } => {
                if name == "it" || name == "null" {
                    return self
                        .scope
                        .locals
                        .iter()
                        .rev()
                        .find(|(n, _)| n == name)
                        .map_or(Ty::Unknown, |(_, t)| t.clone());
                }
                self.ident(name, *span, want)
            }
            Expr::EnumRef {
                enum_name,
                member,
                span,
            } => match self.m.enums.get(enum_name) {
                Some(ms) if ms.contains(member) => Ty::Enum(enum_name.as_str().into()),
                Some(ms) => {
                    let list: Vec<&str> = ms.iter().map(String::as_str).collect();
                    self.err(
                        "E0311",
                        *span,
                        format!("'{member}' is not a member of enum {enum_name}"),
                        Some(format!("its members: {}", list.join(", "))),
                    );
                    Ty::Unknown
                }
                None => {
                    self.err("E0301", *span, format!("unknown enum '{enum_name}'"), None);
                    Ty::Unknown
                }
            },
            Expr::Unary { op, expr, span } => {
                let t = self.expr(expr, if op == "-" { want } else { None });
                match op.as_str() {
                    "not" => {
                        self.want_bool(&t, expr.span(), "'not'");
                        let _ = span;
                        Ty::Bool
                    }
                    "-" => t,
                    _ => Ty::Unknown,
                }
            }
            Expr::Binary { lhs, rhs, op, span } => self.binary(op, lhs, rhs, *span),
            Expr::Ternary {
                cond,
                then,
                otherwise,
                ..
            } => {
                let c = self.expr(cond, None);
                self.want_bool(&c, cond.span(), "a condition");
                let a = self.expr(then, want);
                let b = self.expr(otherwise, want);
                if a == Ty::Unknown { b } else { a }
            }
            Expr::Field { base, name, .. } => {
                let bt = self.expr(base, None);
                match bt {
                    Ty::Compound(c) => match self.m.field(&c, &name.text) {
                        Some(t) => {
                            if self.in_keep {
                                self.var_in_keep(&c, name);
                            }
                            t
                        }
                        // Behaviours have builtin members (events, their actor, timing).
                        None if BEHAVIOUR_MEMBERS.contains(&name.text.as_str())
                            && matches!(
                                self.m.compounds.get(&*c),
                                Some((DeclKind::Scenario | DeclKind::Action, ..))
                            ) =>
                        {
                            Ty::Unknown
                        }
                        None => {
                            let names: Vec<String> = self.m.member_names(&c);
                            let hint = close_names(&name.text, names.iter());
                            self.err(
                                "E0310",
                                name.span,
                                format!("'{c}' has no field '{}'", name.text),
                                Some(if hint.is_empty() {
                                    format!("its fields: {}", names.join(", "))
                                } else {
                                    format!("did you mean: {hint}?")
                                }),
                            );
                            Ty::Unknown
                        }
                    },
                    _ => Ty::Unknown,
                }
            }
            Expr::Cast { base, test, ty, .. } => {
                self.expr(base, None);
                self.type_ref(ty);
                if *test { Ty::Bool } else { self.m.ty_of(ty) }
            }
            Expr::Index { base, index, .. } => {
                let b = self.expr(base, None);
                self.expr(index, None);
                match b {
                    Ty::List(t) => *t,
                    _ => Ty::Unknown,
                }
            }
            Expr::Call { callee, args, .. } => {
                // Functions and methods are not typed; their receivers and
                // arguments are still checked, and a method must be one the
                // receiver's type has (§3.10).
                if let Expr::Field { base, name, .. } = &**callee {
                    let bt = self.expr(base, None);
                    if let Ty::Compound(c) = &bt {
                        self.method_exists(c, name);
                    }
                }
                for a in args {
                    self.expr(&a.value, None);
                }
                Ty::Unknown
            }
            Expr::List { items, .. } => {
                let inner = match want {
                    Some(Ty::List(t)) => Some((**t).clone()),
                    w => w.cloned(),
                };
                let mut ty = Ty::Unknown;
                for x in items {
                    let t = self.expr(x, inner.as_ref());
                    if ty == Ty::Unknown {
                        ty = t;
                    }
                }
                Ty::List(Box::new(ty))
            }
            Expr::Error { .. } => Ty::Unknown,
        }
    }

    fn want_bool(&mut self, t: &Ty, span: Span, what: &str) {
        if !matches!(t, Ty::Bool | Ty::Unknown) {
            self.err(
                "E0312",
                span,
                format!("{what} needs a bool, this is {}", t.describe()),
                None,
            );
        }
    }

    fn binary(&mut self, op: &str, lhs: &Expr, rhs: &Expr, span: Span) -> Ty {
        match op {
            "and" | "or" | "=>" => {
                for x in [lhs, rhs] {
                    let t = self.expr(x, None);
                    self.want_bool(&t, x.span(), &format!("'{op}'"));
                }
                Ty::Bool
            }
            "in" => {
                let a = self.expr(lhs, None);
                let b = self.expr(rhs, Some(&a));
                let inner = match &b {
                    Ty::List(t) => (**t).clone(),
                    t => t.clone(),
                };
                if !self.m.fits(&inner, &a) && !self.m.fits(&a, &inner) {
                    self.mismatch(op, &a, &inner, span);
                }
                Ty::Bool
            }
            _ => {
                // `red == c`: a bare enum literal on the left takes its
                // enum from the right operand, as it would on the right.
                let (a, b) = if self.bare_literal(lhs) && !self.bare_literal(rhs) {
                    let b = self.expr(rhs, None);
                    (self.expr(lhs, Some(&b)), b)
                } else {
                    let a = self.expr(lhs, None);
                    let b = self.expr(rhs, Some(&a));
                    (a, b)
                };
                let comparable = self.m.fits(&a, &b) || self.m.fits(&b, &a);
                match op {
                    "==" | "!=" | "<" | "<=" | ">" | ">=" => {
                        if !comparable {
                            self.mismatch(op, &a, &b, span);
                        }
                        Ty::Bool
                    }
                    "+" | "-" => {
                        if !comparable {
                            self.mismatch(op, &a, &b, span);
                        }
                        if a == Ty::Unknown { b } else { a }
                    }
                    // Products and quotients change the dimension; the
                    // algebra of dimensions is not tracked.
                    _ => match (&a, &b) {
                        (Ty::Number, Ty::Number) => Ty::Number,
                        (Ty::Physical(_), Ty::Number) if op == "*" || op == "/" => a,
                        (Ty::Number, Ty::Physical(_)) if op == "*" => b,
                        _ => Ty::Unknown,
                    },
                }
            }
        }
    }

    fn mismatch(&mut self, op: &str, a: &Ty, b: &Ty, span: Span) {
        let code = if matches!((a, b), (Ty::Physical(_), Ty::Physical(_))) {
            "E0303"
        } else {
            "E0313"
        };
        let what = match (a, b) {
            (Ty::Physical(x), Ty::Physical(y)) => format!("a {x} and a {y}"),
            _ => format!("{} and {}", a.describe(), b.describe()),
        };
        let hint = enum_number_hint(a, b);
        self.err(code, span, format!("'{op}' mixes {what}"), hint);
    }

    /// Checks one value against a parameter's declared type.
    fn value_for(&mut self, v: &Expr, want: &Ty, what: impl FnOnce() -> String) {
        let got = self.expr(v, Some(want));
        if self.m.fits(&got, want) {
            return;
        }
        let (code, hint) = match (&got, want) {
            (Ty::Physical(_), Ty::Physical(w)) => (
                "E0303",
                Some(format!("give a {w}: a number with a unit of {w}")),
            ),
            (Ty::Number, Ty::Physical(w)) => (
                "E0314",
                Some(format!("a {w} needs a unit, e.g. 20kph, 3s or 1.5m")),
            ),
            _ => ("E0313", enum_number_hint(&got, want)),
        };
        self.err(
            code,
            v.span(),
            format!(
                "{} is {}, but this value is {}",
                what(),
                want.describe(),
                got.describe()
            ),
            hint,
        );
    }

    /// `name(args)` against a modifier's or behaviour's parameters.
    fn call_args(&mut self, what: &str, key: &str, name: &Name, args: &[Arg]) {
        // The model outlives the checker's borrow of itself: parameters and
        // their types are read from it without copies.
        let m = self.m;
        let params: &[(String, Ty)] = m.param_types.get(key).map_or(&[], |p| p.as_slice());
        if self.carla && params.is_empty() {
            // Native in the CARLA dialect: the lowering checks what it uses.
            for a in args {
                self.expr(&a.value, None);
            }
            return;
        }
        let positional = args.iter().filter(|a| a.name.is_none()).count();
        if positional > params.len() {
            self.err(
                "E0315",
                args[params.len().min(args.len() - 1)].value.span(),
                format!(
                    "{what} '{}' takes at most {} positional argument(s), {} given",
                    name.text,
                    params.len(),
                    positional
                ),
                Some(format!(
                    "its parameters: {}",
                    params
                        .iter()
                        .map(|(p, _)| p.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )),
            );
        }
        let mut given: Vec<&str> = Vec::new();
        for (i, a) in args.iter().enumerate() {
            let param = match &a.name {
                Some(n) => match params.iter().find(|(p, _)| *p == n.text) {
                    Some(p) => Some(p),
                    None => {
                        let names: Vec<&str> = params.iter().map(|(p, _)| p.as_str()).collect();
                        self.err(
                            "E0308",
                            n.span,
                            format!("{what} '{}' has no parameter '{}'", name.text, n.text),
                            Some(format!("its parameters: {}", names.join(", "))),
                        );
                        None
                    }
                },
                None => params.get(i),
            };
            match param {
                Some((pname, ty)) => {
                    if given.contains(&pname.as_str()) {
                        self.err(
                            "E0316",
                            a.value.span(),
                            format!("'{pname}' of {what} '{}' is given twice", name.text),
                            None,
                        );
                    }
                    given.push(pname);
                    self.value_for(&a.value, ty, || {
                        format!("'{pname}' of {what} '{}'", name.text)
                    });
                }
                None => {
                    self.expr(&a.value, None);
                }
            }
        }
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
                } => {
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
        let unit_ty = match named("unit").map(|a| &a.value) {
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
        match (&ty, &unit_ty) {
            (Ty::Physical(p), None) if named("unit").is_none() => self.err(
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
        // Range and bucket width: in the unit (plain numbers) or physical
        // values of the expression's dimension.
        for key in ["range", "every"] {
            let Some(a) = named(key) else { continue };
            if record && key == "every" {
                continue;
            }
            let t = self.expr(&a.value, None);
            let bad = match (&t, &ty) {
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
        // The event: start, end, a declared event or a label of this scope.
        if let Some(a) = named("event") {
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
    }

    /// E0302 with the known units that look like it.
    fn unknown_unit(&mut self, unit: &str, span: Span) {
        let hint = close_names(unit, self.m.units.keys());
        self.err(
            "E0302",
            span,
            format!("unknown unit '{unit}'"),
            (!hint.is_empty()).then(|| format!("known units like it: {hint}")),
        );
    }

    /// A unit of a physical type, for hints.
    fn some_unit(&self, p: &str) -> String {
        self.m
            .units
            .iter()
            .filter(|(_, q)| ***q == *p)
            .min_by_key(|(u, _)| (u.len(), u.as_str()))
            .map_or_else(|| "?".into(), |(u, _)| u.clone())
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

/// Modifiers live in their own namespace (`lane` is both a struct and a
/// modifier in the domain model).
/// The name and arguments of `name(args)` or `x.name(args)`.
/// What is wrong with `name` (of `kind`) inheriting from the known `base`:
/// another kind of declaration (E0338), or a cycle back to `name` (E0339,
/// reported at the cycle's alphabetically first member only).
fn inheritance_problem(
    m: &Model,
    kind: DeclKind,
    name: &str,
    base: &str,
) -> Option<(&'static str, String, String)> {
    let kind_of = |k: DeclKind| format!("{k:?}").to_lowercase();
    if kind != DeclKind::Modifier
        && let Some(b) = m.compounds.get(base)
        && b.0 != kind
    {
        return Some((
            "E0338",
            format!(
                "{} '{name}' cannot inherit from {} '{base}'",
                kind_of(kind),
                kind_of(b.0)
            ),
            {
                let k = kind_of(kind);
                let a = if k.starts_with(['a', 'e', 'i', 'o', 'u']) {
                    "an"
                } else {
                    "a"
                };
                format!("{a} {k} inherits from another {k}")
            },
        ));
    }
    let mut path = vec![name.to_string()];
    let mut cur = Some(base.to_string());
    while let Some(n) = cur {
        if n == name {
            if path.iter().any(|p| p.as_str() < name) {
                return None;
            }
            path.push(n);
            return Some((
                "E0339",
                format!("inheritance cycle: {}", path.join(" → ")),
                "a type cannot inherit from itself, directly or not".into(),
            ));
        }
        if path.contains(&n) || path.len() > 64 {
            // A cycle that does not pass through `name`: its own members report it.
            return None;
        }
        cur = m.compounds.get(&n).and_then(|c| c.2.clone());
        path.push(n);
    }
    None
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

/// Names defined twice (E0330–E0336), each with where it was first
/// defined: enum types, enum members (an `extend` included), enum values
/// that do not increase, physical types, units, SI base exponents, and the
/// members of one compound (its own and its `extend`s').
fn redefinitions(prog: &Program, out: &mut Vec<Diagnostic>) {
    let twice = |code, span: Span, what: String, first: Span, hint: &str| {
        Diagnostic::error(code, span, what)
            .with_hint(hint)
            .with_related(first, "first defined here")
    };
    let mut enums: BTreeMap<String, Span> = BTreeMap::new();
    let mut enum_members: BTreeMap<String, BTreeMap<String, Span>> = BTreeMap::new();
    let mut enum_last: BTreeMap<String, i128> = BTreeMap::new();
    let mut physical: BTreeMap<String, (Span, Dimension)> = BTreeMap::new();
    let mut units: BTreeMap<String, (Span, precedence::UnitDef)> = BTreeMap::new();
    let mut globals: BTreeMap<String, Span> = BTreeMap::new();
    // (compound key) → member name → first span
    let mut members: BTreeMap<String, BTreeMap<String, Span>> = BTreeMap::new();
    let mut member_names = |key: String, ms: &[Member], out: &mut Vec<Diagnostic>| {
        let seen = members.entry(key.clone()).or_default();
        for m in ms {
            let names: Vec<&Name> = match m {
                Member::Field(f) => f.names.iter().collect(),
                Member::Event { name, .. } => vec![name],
                Member::Method { name, .. } => vec![name],
                _ => continue,
            };
            for n in names {
                if let Some(first) = first_place(seen, n) {
                    if precedence::overrides(prog, first, n.span) {
                        seen.insert(n.text.clone(), n.span);
                        continue;
                    }
                    out.push(twice(
                        "E0336",
                        n.span,
                        format!("'{}' is defined twice in '{key}'", n.text),
                        first,
                        "rename one of them; an `extend` adds members, it cannot redefine one",
                    ));
                }
            }
        }
    };
    for (_, f) in &prog.files {
        for d in &f.decls {
            match d {
                Decl::Enum { name, members: ms } | Decl::ExtendEnum { name, members: ms } => {
                    let builtin_enum = enums
                        .get(&name.text)
                        .is_some_and(|first| precedence::overrides(prog, *first, name.span));
                    if builtin_enum {
                        // CARLA's dialect: the file's enum adds to litesim's.
                        enums.insert(name.text.clone(), name.span);
                    } else if matches!(d, Decl::Enum { .. })
                        && let Some(first) = first_place(&mut enums, name)
                    {
                        out.push(twice(
                            "E0330",
                            name.span,
                            format!("enum '{}' is defined twice", name.text),
                            first,
                            "use `extend` to add members to an enum",
                        ));
                    }
                    let seen = enum_members.entry(name.text.clone()).or_default();
                    for (m, value) in ms {
                        if let Some(first) = first_place(seen, m) {
                            if precedence::overrides(prog, first, m.span) {
                                continue; // the same member, as litesim's library has it
                            }
                            out.push(twice(
                                "E0331",
                                m.span,
                                format!("'{}' is a member of enum '{}' twice", m.text, name.text),
                                first,
                                "each member once",
                            ));
                            continue;
                        }
                        // Values strictly increase: explicit ones as
                        // written, implicit ones one above the last.
                        let last = enum_last.get(&name.text).copied();
                        let v = match value {
                            Some(Expr::Int { value, .. }) => *value,
                            _ => last.map_or(0, |l| l + 1),
                        };
                        if let (Some(l), Some(e)) = (last, value)
                            && v <= l
                        {
                            out.push(
                                Diagnostic::error(
                                    "E0332",
                                    e.span(),
                                    format!(
                                        "'{}' = {v} in enum '{}' does not increase (the member before is {l})",
                                        m.text, name.text
                                    ),
                                )
                                .with_hint("enum values must be strictly increasing"),
                            );
                        }
                        enum_last.insert(name.text.clone(), v.max(last.unwrap_or(i128::MIN)));
                    }
                }
                Decl::PhysicalType { name, si } => {
                    let dim = dimension(si);
                    match physical.get(&name.text) {
                        Some((first, first_dim))
                            if precedence::overrides(prog, *first, name.span) =>
                        {
                            out.extend(precedence::physical_type(name, &dim, *first, first_dim));
                            physical.insert(name.text.clone(), (name.span, dim));
                        }
                        Some((first, _)) => out.push(twice(
                            "E0333",
                            name.span,
                            format!("physical type '{}' is defined twice", name.text),
                            *first,
                            "one `type … is SI(…)` per physical type",
                        )),
                        None => {
                            physical.insert(name.text.clone(), (name.span, dim));
                        }
                    }
                    si_twice(si, out);
                }
                Decl::Unit { name, args, .. } => {
                    let def = (dimension(args), crate::index::factor(args));
                    match units.get(&name.text) {
                        Some((first, first_def))
                            if precedence::overrides(prog, *first, name.span) =>
                        {
                            out.extend(precedence::unit(name, &def, *first, first_def));
                            units.insert(name.text.clone(), (name.span, def));
                        }
                        Some((first, _)) => out.push(twice(
                            "E0334",
                            name.span,
                            format!("unit '{}' is defined twice", name.text),
                            *first,
                            "unit names are global: pick another name",
                        )),
                        None => {
                            units.insert(name.text.clone(), (name.span, def));
                        }
                    }
                    si_twice(args, out);
                }
                Decl::Compound {
                    name,
                    members: ms,
                    kind,
                    ..
                } if *kind != DeclKind::Modifier => member_names(qual_key(name), ms, out),
                Decl::Extend {
                    target,
                    members: ms,
                } => member_names(qual_key(target), ms, out),
                Decl::Global(f) => {
                    for n in &f.names {
                        if let Some(first) = first_place(&mut globals, n) {
                            out.push(twice(
                                "E0352",
                                n.span,
                                format!("global '{}' is defined twice", n.text),
                                first,
                                "a global parameter is defined once: set its value with `keep` where it is used",
                            ));
                        }
                    }
                }
                _ => {}
            }
        }
    }
    behaviour_dos(prog, out);
    conditional_bases(prog, out);
    // A member may not redefine one its type inherits (§3.5): the first
    // ancestor that defines the name is the other place.
    let mut bases: BTreeMap<String, String> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            if let Decl::Compound {
                name,
                inherits: Some((base, _)),
                ..
            } = d
            {
                bases
                    .entry(qual_key(name))
                    .or_insert_with(|| qual_key(base));
            }
        }
    }
    // Methods' signatures and `only`, for overrides (§3.10).
    let mut methods: BTreeMap<(String, String), (String, bool)> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            let (key, ms) = match d {
                Decl::Compound {
                    name,
                    members: ms,
                    kind,
                    ..
                } if *kind != DeclKind::Modifier => (qual_key(name), ms),
                Decl::Extend {
                    target,
                    members: ms,
                } => (qual_key(target), ms),
                _ => continue,
            };
            for m in ms {
                if let Member::Method {
                    name,
                    params,
                    ret,
                    only,
                    ..
                } = m
                {
                    methods
                        .entry((key.clone(), name.text.clone()))
                        .or_insert((signature(params, ret.as_ref()), *only));
                }
            }
        }
    }
    for (key, own) in &members {
        for (name, span) in own {
            let mut cur = bases.get(key);
            let mut guard = 0;
            while let Some(b) = cur {
                guard += 1;
                if guard > 64 || b == key {
                    break; // an inheritance cycle: E0339 reports it
                }
                if let Some(first) = members.get(b).and_then(|m| m.get(name)) {
                    let mine = methods.get(&(key.clone(), name.clone()));
                    let theirs = methods.get(&(b.clone(), name.clone()));
                    if let (Some((sig, only)), Some((base_sig, _))) = (mine, theirs) {
                        // A method may be overridden: with `only` and the
                        // same signature.
                        let problem = if !only {
                            Some(format!(
                                "'{name}' in '{key}' overrides the method it inherits from '{b}' without `only`"
                            ))
                        } else if sig != base_sig {
                            Some(format!(
                                "'{name}' in '{key}' overrides '{b}.{name}' with another signature: {sig} instead of {base_sig}"
                            ))
                        } else {
                            None
                        };
                        if let Some(msg) = problem {
                            out.push(
                                Diagnostic::error("E0350", *span, msg)
                                    .with_hint(format!("an override is written `def {name}(…) is only …`, with the inherited parameter and return types {base_sig}"))
                                    .with_related(*first, "the inherited method is here"),
                            );
                        }
                        break;
                    }
                    out.push(
                        Diagnostic::error(
                            "E0340",
                            *span,
                            format!("'{name}' in '{key}' redefines the member it inherits from '{b}'"),
                        )
                        .with_hint("an inherited member cannot be redefined: rename it, or constrain the inherited one with `keep`")
                        .with_related(*first, "inherited from here"),
                    );
                    break;
                }
                cur = bases.get(b);
            }
        }
    }
}

/// A conditional type (`actor truck inherits vehicle (vehicle_category ==
/// truck)`) may be inherited only conditionally (§3.5): an unconditional
/// subtype would be a truck without the condition that makes one (E0348).
fn conditional_bases(prog: &Program, out: &mut Vec<Diagnostic>) {
    let mut conditional: BTreeMap<String, Span> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            if let Decl::Compound {
                name,
                inherits: Some((_, Some(_))),
                ..
            } = d
            {
                conditional.entry(qual_key(name)).or_insert(name.name.span);
            }
        }
    }
    for (_, f) in &prog.files {
        for d in &f.decls {
            if let Decl::Compound {
                name,
                inherits: Some((base, None)),
                ..
            } = d
                && let b = qual_key(base)
                && let Some(&decl) = conditional.get(&b)
            {
                out.push(
                    Diagnostic::error(
                        "E0348",
                        base.name.span,
                        format!(
                            "'{}' inherits '{b}' unconditionally, but '{b}' is a conditional type; it can only be inherited with a condition",
                            qual_key(name)
                        ),
                    )
                    .with_hint(format!("inherit what '{b}' inherits, with a condition of its own, or give this inheritance a condition: `inherits {b} (field == value)`"))
                    .with_related(decl, "declared conditional here"),
                );
            }
        }
    }
}

/// `do` (§3.5, §3.13): only scenarios and actions have one (E0344), and
/// at most one effective `do` each, across the declaration, its
/// `extend`s and what it inherits (E0343; the engine would run one and
/// drop the others).
fn behaviour_dos(prog: &Program, out: &mut Vec<Diagnostic>) {
    let dos_of = |ms: &[Member]| -> Vec<Span> {
        ms.iter()
            .filter_map(|m| match m {
                Member::Do(d) => Some(d.span),
                _ => None,
            })
            .collect()
    };
    // Compound key → kind, base and its `do`s in file order (declaration
    // and extensions).
    let mut kinds: BTreeMap<String, (DeclKind, Option<String>)> = BTreeMap::new();
    let mut dos: BTreeMap<String, Vec<Span>> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            match d {
                Decl::Compound {
                    name,
                    kind,
                    inherits,
                    members,
                    ..
                } => {
                    let key = qual_key(name);
                    // A name declared twice (E0336/E0337 report it) counts as
                    // a behaviour if one declaration is one: CARLA's
                    // `scenario top` beside the domain's `actor top`.
                    let entry = (*kind, inherits.as_ref().map(|(b, _)| qual_key(b)));
                    match kinds.get(&key) {
                        Some((DeclKind::Scenario | DeclKind::Action, _)) => {}
                        Some(_) if !matches!(kind, DeclKind::Scenario | DeclKind::Action) => {}
                        _ => {
                            kinds.insert(key.clone(), entry);
                        }
                    }
                    dos.entry(key).or_default().extend(dos_of(members));
                }
                Decl::Extend { target, members } => {
                    dos.entry(qual_key(target))
                        .or_default()
                        .extend(dos_of(members));
                }
                _ => {}
            }
        }
    }
    for (key, spans) in &dos {
        let Some((kind, base)) = kinds.get(key) else {
            continue; // an extend of an unknown type: reported elsewhere
        };
        if !matches!(kind, DeclKind::Scenario | DeclKind::Action) {
            let what = kind.noun();
            for &at in spans {
                out.push(
                    Diagnostic::error(
                        "E0344",
                        at,
                        format!("'{key}' is {what}: only scenarios and actions have a `do`"),
                    )
                    .with_hint("declare the behaviour as a scenario (on the actor: `scenario A.name:`) and give it the `do`"),
                );
            }
            continue;
        }
        if let [first, second, ..] = spans[..] {
            out.push(
                Diagnostic::error(
                    "E0343",
                    second,
                    format!("'{key}' has a second `do`; a scenario or action has at most one"),
                )
                .with_hint("put both in one `do` (e.g. `do serial:` with the two as its members), or remove one; with several `extend`s of one scenario, only one may add the `do`")
                .with_related(first, "its first `do` is here"),
            );
            continue;
        }
        // One of its own, and one it inherits: the nearest ancestor with one.
        let Some(&own) = spans.first() else { continue };
        let mut cur = base.clone();
        let mut guard = 0;
        while let Some(b) = cur {
            guard += 1;
            if guard > 64 || &b == key {
                break; // an inheritance cycle: E0339 reports it
            }
            if let Some(&inherited) = dos.get(&b).and_then(|v| v.first()) {
                out.push(
                    Diagnostic::error(
                        "E0343",
                        own,
                        format!("'{key}' has a `do` and inherits one from '{b}'; a scenario or action has at most one effective `do`"),
                    )
                    .with_hint("inherit from a scenario without a `do`, or invoke the base scenario from this one's `do` instead of inheriting it")
                    .with_related(inherited, "the inherited `do` is here"),
                );
                break;
            }
            cur = kinds.get(&b).and_then(|(_, bb)| bb.clone());
        }
    }
}

/// A declaration's key in the redefinition passes: `actor.name` for a
/// behaviour declared on an actor, the name otherwise.
fn qual_key(q: &QualName) -> String {
    q.actor.as_ref().map_or(q.name.text.clone(), |a| {
        format!("{}.{}", a.text, q.name.text)
    })
}

/// A method's signature as written: `(int, list of length) -> speed`.
fn signature(params: &[Field], ret: Option<&TypeRef>) -> String {
    let ty = |t: &TypeRef| {
        let base = t.base.actor.as_ref().map_or(t.base.name.text.clone(), |a| {
            format!("{}.{}", a.text, t.base.name.text)
        });
        if t.list {
            format!("list of {base}")
        } else {
            base
        }
    };
    let ps: Vec<String> = params
        .iter()
        .flat_map(|f| f.names.iter().map(move |_| ty(&f.ty)))
        .collect();
    match ret {
        Some(r) => format!("({}) -> {}", ps.join(", "), ty(r)),
        None => format!("({})", ps.join(", ")),
    }
}

/// Where `name` was first defined, if it was; else it is noted as first.
fn first_place(seen: &mut BTreeMap<String, Span>, name: &Name) -> Option<Span> {
    match seen.get(&name.text) {
        Some(first) => Some(*first),
        None => {
            seen.insert(name.text.clone(), name.span);
            None
        }
    }
}

/// An SI base exponent given twice in `SI(m: 1, m: 2)` (E0335).
fn si_twice(args: &[Arg], out: &mut Vec<Diagnostic>) {
    let mut seen: BTreeMap<&str, Span> = BTreeMap::new();
    for a in args {
        if let Some(n) = &a.name {
            if let Some(first) = seen.get(n.text.as_str()) {
                out.push(
                    Diagnostic::error(
                        "E0335",
                        n.span,
                        format!("'{}' is given twice in SI(…)", n.text),
                    )
                    .with_hint("each base unit once, with its exponent")
                    .with_related(*first, "first given here"),
                );
            } else {
                seen.insert(n.text.as_str(), n.span);
            }
        }
    }
}

/// Every name of the type namespace (physical types, enums, structs,
/// actors, scenarios, actions; a behaviour declared on an actor by
/// `actor.name`) and every modifier is declared once (E0307, with where it
/// was first declared). Two declarations of one kind are E0330/E0333's
/// (enums, physical types); two of different kinds are E0307's here.
/// CARLA's entry point `scenario top` may sit beside the domain's `actor top`.
fn declared_once(prog: &Program, m: &Model, out: &mut Vec<Diagnostic>) {
    let carla = prog.dialect == crate::Dialect::Carla;
    let mut seen: BTreeMap<String, (Span, &'static str, Option<&str>)> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            let (key, span, what, base) = match d {
                Decl::PhysicalType { name, .. } => {
                    (name.text.clone(), name.span, "a physical type", None)
                }
                Decl::Enum { name, .. } => (name.text.clone(), name.span, "an enum", None),
                Decl::Compound {
                    name,
                    kind,
                    inherits,
                    ..
                } => {
                    let key = qual_key(name);
                    let key = if *kind == DeclKind::Modifier {
                        modifier_key(&key)
                    } else {
                        key
                    };
                    let base = inherits.as_ref().map(|(b, _)| b.name.text.as_str());
                    (key, name.name.span, kind.noun(), base)
                }
                _ => continue,
            };
            let Some(&(first, first_what, first_base)) = seen.get(&key) else {
                seen.insert(key, (span, what, base));
                continue;
            };
            let carla_top = carla && key == "top" && what == "a scenario";
            if carla_top {
                continue;
            }
            if precedence::overrides(prog, first, span) {
                // CARLA's dialect: the file's own declaration is used.
                if let Decl::Compound { name, .. } = d {
                    let is_a = |a: &str, b: &str| m.is_a(a, b);
                    out.extend(precedence::compound(
                        name, what, base, first, first_what, first_base, &is_a,
                    ));
                }
                seen.insert(key, (span, what, base.or(first_base)));
                continue;
            }
            let same_kind_elsewhere =
                first_what == what && matches!(d, Decl::PhysicalType { .. } | Decl::Enum { .. });
            if same_kind_elsewhere {
                continue;
            }
            let shown = key.strip_prefix("modifier ").unwrap_or(&key);
            let msg = if first_what == what {
                format!("'{shown}' is declared twice")
            } else {
                format!("'{shown}' is declared twice: as {what} here, first as {first_what}")
            };
            out.push(
                Diagnostic::error("E0307", span, msg)
                    .with_hint(if first_what == what {
                        "use `extend` to add to an existing declaration"
                    } else {
                        "types, behaviours and modifiers share one namespace: rename one of them"
                    })
                    .with_related(first, "first declared here"),
            );
        }
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
