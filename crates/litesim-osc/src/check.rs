//! First semantic checks over a loaded program: names of types, units,
//! modifiers and behaviours resolve; physical values have the dimension the
//! parameter asks for (a speed given in seconds is an error; kph and mps mix
//! freely, being the same physical type); named arguments exist.
//!
//! Declarations from every file are collected first (imports and the
//! importer see each other), `extend` merges fields into its target, and
//! `inherits` makes a compound see its bases' fields.

use crate::ast::*;
use crate::diag::Diagnostic;
use crate::loader::Program;
use std::collections::{BTreeMap, BTreeSet};

const BUILTIN_TYPES: &[&str] = &["int", "uint", "float", "bool", "string"];

/// A compound's kind, own parameters and base.
type Compound = (DeclKind, Vec<(String, TypeRef)>, Option<String>);

#[derive(Default)]
struct Model {
    physical: BTreeSet<String>,
    units: BTreeMap<String, String>,
    enums: BTreeMap<String, BTreeSet<String>>,
    /// compound name (behaviours by their own name) → what it is
    compounds: BTreeMap<String, Compound>,
}

fn close_names<'a>(name: &str, all: impl Iterator<Item = &'a String>) -> String {
    // Names sharing a prefix or differing by little: the usual typos.
    let mut v: Vec<&String> = all
        .filter(|n| n.starts_with(&name[..name.len().min(2)]) || levenshtein(n, name) <= 2)
        .take(5)
        .collect();
    v.sort();
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
        let mut m = Model::default();
        for (_, f) in &prog.files {
            for d in &f.decls {
                match d {
                    Decl::PhysicalType { name, .. } => {
                        m.physical.insert(name.text.clone());
                    }
                    Decl::Unit { name, of, .. } => {
                        m.units.insert(name.text.clone(), of.text.clone());
                    }
                    Decl::Enum { name, members } | Decl::ExtendEnum { name, members } => {
                        m.enums
                            .entry(name.text.clone())
                            .or_default()
                            .extend(members.iter().map(|(n, _)| n.text.clone()));
                    }
                    Decl::Compound {
                        kind,
                        name,
                        inherits,
                        members,
                        ..
                    } => {
                        let params = fields(members);
                        let entry = m.compounds.entry(name.name.text.clone()).or_insert((
                            *kind,
                            Vec::new(),
                            None,
                        ));
                        entry.1.extend(params);
                        entry.2 = inherits.as_ref().map(|(b, _)| b.name.text.clone());
                    }
                    _ => {}
                }
            }
        }
        for (_, f) in &prog.files {
            for d in &f.decls {
                if let Decl::Extend { target, members } = d
                    && let Some(e) = m.compounds.get_mut(&target.name.text)
                {
                    e.1.extend(fields(members));
                }
            }
        }
        m
    }
    fn is_type(&self, t: &str) -> bool {
        BUILTIN_TYPES.contains(&t)
            || self.physical.contains(t)
            || self.enums.contains_key(t)
            || self.compounds.contains_key(t)
    }
    /// Parameters of a compound including inherited ones.
    fn params(&self, name: &str) -> Vec<(String, TypeRef)> {
        let mut out = Vec::new();
        let mut cur = Some(name.to_string());
        let mut guard = 0;
        while let Some(n) = cur {
            guard += 1;
            if guard > 64 {
                break; // inheritance cycle: reported elsewhere
            }
            match self.compounds.get(&n) {
                Some((_, p, base)) => {
                    out.extend(p.iter().cloned());
                    cur = base.clone();
                }
                None => break,
            }
        }
        out
    }
    /// The physical type of an expression's value, when it has one.
    fn physical_of(&self, e: &Expr) -> Option<String> {
        match e {
            Expr::Physical { unit, .. } => self.units.get(unit).cloned(),
            Expr::Range { unit: Some(u), .. } => self.units.get(u).cloned(),
            Expr::Range { lo, hi, .. } => lo
                .as_deref()
                .or(hi.as_deref())
                .and_then(|x| self.physical_of(x)),
            Expr::Unary { op, expr, .. } if op == "-" => self.physical_of(expr),
            _ => None,
        }
    }
}

fn fields(members: &[Member]) -> Vec<(String, TypeRef)> {
    let mut out = Vec::new();
    for m in members {
        if let Member::Field(f) = m {
            out.extend(f.names.iter().map(|n| (n.text.clone(), f.ty.clone())));
        }
    }
    out
}

struct Checker<'a> {
    m: &'a Model,
    diags: Vec<Diagnostic>,
}

impl Checker<'_> {
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
            let mut d = Diagnostic::error("E0301", n.span, format!("unknown type '{}'", n.text));
            if !hint.is_empty() {
                d = d.with_hint(format!("did you mean one of: {hint}?"));
            }
            self.diags.push(d);
        }
    }

    fn expr(&mut self, e: &Expr) {
        match e {
            Expr::Physical { unit, span, .. } if !self.m.units.contains_key(unit) => {
                let hint = close_names(unit, self.m.units.keys());
                let mut d = Diagnostic::error("E0302", *span, format!("unknown unit '{unit}'"));
                if !hint.is_empty() {
                    d = d.with_hint(format!("known units like it: {hint}"));
                }
                self.diags.push(d);
            }
            Expr::Range { lo, hi, unit, span } => {
                if let Some(u) = unit
                    && !self.m.units.contains_key(u)
                {
                    self.diags.push(Diagnostic::error(
                        "E0302",
                        *span,
                        format!("unknown unit '{u}'"),
                    ));
                }
                for x in lo.iter().chain(hi.iter()) {
                    self.expr(x);
                }
            }
            Expr::Unary { expr, .. } => self.expr(expr),
            Expr::Binary { lhs, rhs, op, span } => {
                self.expr(lhs);
                self.expr(rhs);
                if ["+", "-", "<", "<=", ">", ">=", "=="].contains(&op.as_str())
                    && let (Some(a), Some(b)) = (self.m.physical_of(lhs), self.m.physical_of(rhs))
                    && a != b
                {
                    self.diags.push(Diagnostic::error(
                        "E0303",
                        *span,
                        format!("'{op}' mixes a {a} and a {b}"),
                    ));
                }
            }
            Expr::Ternary {
                cond,
                then,
                otherwise,
                ..
            } => {
                self.expr(cond);
                self.expr(then);
                self.expr(otherwise);
            }
            Expr::Field { base, .. } | Expr::Cast { base, .. } => self.expr(base),
            Expr::Index { base, index, .. } => {
                self.expr(base);
                self.expr(index);
            }
            Expr::Call { callee, args, .. } => {
                self.expr(callee);
                for a in args {
                    self.expr(&a.value);
                }
            }
            Expr::List { items, .. } => items.iter().for_each(|x| self.expr(x)),
            _ => {}
        }
    }

    /// `name(args)` against a modifier's or behaviour's parameters.
    fn call_args(&mut self, what: &str, name: &Name, args: &[Arg]) {
        let params = self.m.params(&name.text);
        for (i, a) in args.iter().enumerate() {
            let param = match &a.name {
                Some(n) => match params.iter().find(|(p, _)| *p == n.text) {
                    Some(p) => Some(p),
                    None => {
                        let names: Vec<&str> = params.iter().map(|(p, _)| p.as_str()).collect();
                        self.diags.push(
                            Diagnostic::error(
                                "E0308",
                                n.span,
                                format!("{what} '{}' has no parameter '{}'", name.text, n.text),
                            )
                            .with_hint(format!("its parameters: {}", names.join(", "))),
                        );
                        None
                    }
                },
                None => params.get(i),
            };
            if let (Some((pname, ty)), Some(got)) = (param, self.m.physical_of(&a.value)) {
                let want = &ty.base.name.text;
                if self.m.physical.contains(want) && *want != got && !ty.list {
                    self.diags.push(
                        Diagnostic::error(
                            "E0303",
                            a.value.span(),
                            format!(
                                "'{pname}' of {what} '{}' is a {want}, but this value is a {got}",
                                name.text
                            ),
                        )
                        .with_hint(format!("give a {want}: a number with a unit of {want}")),
                    );
                }
            }
        }
    }

    fn modifier(&mut self, call: &Expr) {
        self.expr(call);
        let Some((name, args)) = call_target(call) else {
            return;
        };
        match self.m.compounds.get(&name.text) {
            Some((DeclKind::Modifier, ..)) => self.call_args("modifier", &name, args),
            Some(_) => {}
            None => {
                let mods: Vec<&String> = self
                    .m
                    .compounds
                    .iter()
                    .filter(|(_, v)| v.0 == DeclKind::Modifier)
                    .map(|(k, _)| k)
                    .collect();
                let hint = close_names(&name.text, mods.into_iter());
                let mut d = Diagnostic::error(
                    "E0304",
                    name.span,
                    format!("unknown modifier '{}'", name.text),
                );
                if !hint.is_empty() {
                    d = d.with_hint(format!("did you mean: {hint}?"));
                }
                self.diags.push(d);
            }
        }
    }

    fn members(&mut self, members: &[Member]) {
        for m in members {
            match m {
                Member::Field(f) => {
                    self.type_ref(&f.ty);
                    if let Some(d) = &f.default {
                        self.expr(d);
                        if let Some(got) = self.m.physical_of(d) {
                            let want = &f.ty.base.name.text;
                            if self.m.physical.contains(want) && *want != got {
                                self.diags.push(Diagnostic::error(
                                    "E0303",
                                    d.span(),
                                    format!(
                                        "'{}' is a {want}, but its default is a {got}",
                                        f.names[0].text
                                    ),
                                ));
                            }
                        }
                    }
                    self.members(&f.with);
                }
                Member::Keep { expr, .. } => self.expr(expr),
                Member::Modifier { call, .. } => self.modifier(call),
                Member::Do(d) => self.do_member(d),
                Member::On { body, .. } => body.iter().for_each(|d| self.do_member(d)),
                Member::Event { params, .. } | Member::Method { params, .. } => {
                    params.iter().for_each(|p| self.type_ref(&p.ty))
                }
                Member::Set { value, .. } => self.expr(value),
                _ => {}
            }
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
                args.iter().for_each(|a| self.expr(&a.value));
                children.iter().for_each(|c| self.do_member(c));
                self.members(with);
            }
            DoKind::Invoke { call, with } => {
                self.expr(call);
                if let Some((name, args)) = call_target(call) {
                    match self.m.compounds.get(&name.text) {
                        Some((DeclKind::Scenario | DeclKind::Action, ..)) => {
                            self.call_args("behaviour", &name, args)
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
                            let mut e = Diagnostic::error(
                                "E0309",
                                name.span,
                                format!("unknown scenario or action '{}'", name.text),
                            );
                            if !hint.is_empty() {
                                e = e.with_hint(format!("did you mean: {hint}?"));
                            }
                            self.diags.push(e);
                        }
                    }
                }
                self.members(with);
            }
            _ => {}
        }
    }
}

/// The name and arguments of `name(args)` or `x.name(args)`.
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
    let mut c = Checker {
        m: &m,
        diags: Vec::new(),
    };
    let mut seen: BTreeMap<String, ()> = BTreeMap::new();
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
                    let key = format!(
                        "{}{}",
                        name.actor
                            .as_ref()
                            .map_or(String::new(), |a| format!("{}.", a.text)),
                        name.name.text
                    );
                    if seen.insert(key.clone(), ()).is_some() && *kind != DeclKind::Modifier {
                        c.diags.push(
                            Diagnostic::error(
                                "E0307",
                                name.name.span,
                                format!("'{key}' is declared twice"),
                            )
                            .with_hint("use `extend` to add to an existing declaration"),
                        );
                    }
                    if let Some((base, _)) = inherits
                        && !m.compounds.contains_key(&base.name.text)
                    {
                        c.diags.push(Diagnostic::error(
                            "E0305",
                            base.name.span,
                            format!(
                                "'{}' inherits from unknown '{}'",
                                name.name.text, base.name.text
                            ),
                        ));
                    }
                    if let Some(of) = of
                        && !m.compounds.contains_key(&of.name.text)
                    {
                        c.diags.push(Diagnostic::error(
                            "E0309",
                            of.name.span,
                            format!("unknown scenario or action '{}'", of.name.text),
                        ));
                    }
                    c.members(members);
                }
                Decl::Extend { target, members } => {
                    let builtin = target.actor.as_ref().is_some_and(|a| a.text == "top")
                        && target.name.text == "main";
                    if !builtin && !m.compounds.contains_key(&target.name.text) {
                        c.diags.push(Diagnostic::error(
                            "E0306",
                            target.name.span,
                            format!("cannot extend unknown '{}'", target.name.text),
                        ));
                    }
                    c.members(members);
                }
                Decl::Unit { of, .. } if !m.physical.contains(&of.text) => {
                    c.diags.push(Diagnostic::error(
                        "E0301",
                        of.span,
                        format!("unknown physical type '{}'", of.text),
                    ));
                }
                Decl::Global(f) => c.members(&[Member::Field(f.clone())]),
                _ => {}
            }
        }
    }
    c.diags.sort_by_key(|d| (d.span.file, d.span.start));
    c.diags
}
