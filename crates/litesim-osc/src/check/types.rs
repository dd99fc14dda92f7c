//! Expression typing: names along field paths, literals, units and
//! dimensions, operators, calls and their arguments.

use super::*;

/// Enums and numbers do not mix without a conversion (§3.3): say which.
pub(super) fn enum_number_hint(a: &Ty, b: &Ty) -> Option<String> {
    match (a, b) {
        (Ty::Enum(e), Ty::Number) | (Ty::Number, Ty::Enum(e)) => Some(format!(
            "convert explicitly: `x.as(int)` gives an enum value's number, `n.as({e})` the {e} member numbered n"
        )),
        _ => None,
    }
}

impl Checker<'_> {
    pub(super) fn type_ref(&mut self, t: &TypeRef) {
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
    pub(super) fn bare_literal(&self, e: &Expr) -> bool {
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
    pub(super) fn ident(&mut self, name: &str, span: Span, want: Option<&Ty>) -> Ty {
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
    pub(super) fn expr(&mut self, e: &Expr, want: Option<&Ty>) -> Ty {
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
                self.range(lo.as_deref(), hi.as_deref(), unit.as_deref(), *span)
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
            } => self.enum_ref(enum_name, member, *span),
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
            Expr::Field { base, name, .. } => self.field(base, name),
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

    /// `enum!member`: a member of a known enum.
    fn enum_ref(&mut self, enum_name: &str, member: &str, span: Span) -> Ty {
        match self.m.enums.get(enum_name) {
            Some(ms) if ms.contains(member) => Ty::Enum(enum_name.into()),
            Some(ms) => {
                let list: Vec<&str> = ms.iter().map(String::as_str).collect();
                self.err(
                    "E0311",
                    span,
                    format!("'{member}' is not a member of enum {enum_name}"),
                    Some(format!("its members: {}", list.join(", "))),
                );
                Ty::Unknown
            }
            None => {
                self.err("E0301", span, format!("unknown enum '{enum_name}'"), None);
                Ty::Unknown
            }
        }
    }

    /// A range `[lo..hi]` (with its unit): bounds of one physical type.
    fn range(
        &mut self,
        lo: Option<&Expr>,
        hi: Option<&Expr>,
        unit: Option<&str>,
        span: Span,
    ) -> Ty {
        let mut ty = Ty::Unknown;
        if let Some(u) = unit {
            match self.m.units.get(u) {
                Some(p) => ty = Ty::Physical(p.clone()),
                None => self.err("E0302", span, format!("unknown unit '{u}'"), None),
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

    /// `base.name`: a field of the base's compound (behaviours' builtin
    /// members allowed), with a hint naming the fields there are.
    fn field(&mut self, base: &Expr, name: &Name) -> Ty {
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

    pub(super) fn want_bool(&mut self, t: &Ty, span: Span, what: &str) {
        if !matches!(t, Ty::Bool | Ty::Unknown) {
            self.err(
                "E0312",
                span,
                format!("{what} needs a bool, this is {}", t.describe()),
                None,
            );
        }
    }

    pub(super) fn binary(&mut self, op: &str, lhs: &Expr, rhs: &Expr, span: Span) -> Ty {
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

    pub(super) fn mismatch(&mut self, op: &str, a: &Ty, b: &Ty, span: Span) {
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
    pub(super) fn value_for(&mut self, v: &Expr, want: &Ty, what: impl FnOnce() -> String) {
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
    pub(super) fn call_args(&mut self, what: &str, key: &str, name: &Name, args: &[Arg]) {
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

    /// E0302 with the known units that look like it.
    pub(super) fn unknown_unit(&mut self, unit: &str, span: Span) {
        let hint = close_names(unit, self.m.units.keys());
        self.err(
            "E0302",
            span,
            format!("unknown unit '{unit}'"),
            (!hint.is_empty()).then(|| format!("known units like it: {hint}")),
        );
    }

    /// A unit of a physical type, for hints.
    pub(super) fn some_unit(&self, p: &str) -> String {
        self.m
            .units
            .iter()
            .filter(|(_, q)| ***q == *p)
            .min_by_key(|(u, _)| (u.len(), u.as_str()))
            .map_or_else(|| "?".into(), |(u, _)| u.clone())
    }
}
