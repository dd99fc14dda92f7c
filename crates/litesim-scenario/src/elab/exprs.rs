//! Expressions of the program as the test keeps them: constants in SI
//! units, constraint expressions over absolute paths, conditions, and
//! arguments bound to a scenario's or action's parameters.

use super::*;

impl Elab<'_> {
    pub(super) fn constant(&self, e: &Expr) -> Result<Value, ScenarioError> {
        match self.cexpr(e, &Scope::default()) {
            CExpr::Const(v) => Ok(v),
            other => Err(ScenarioError::Elaboration(format!(
                "{}: expected a constant, found {other:?}",
                self.lib.at(e.span())
            ))),
        }
    }

    /// The SI factor of a unit.
    pub(super) fn unit(&self, u: &str) -> f64 {
        self.lib.ix.units.get(u).map_or(1.0, |u| u.factor)
    }

    /// The SI offset of a unit (`celsius`: 273.15 K; most units: 0).
    pub(super) fn unit_offset(&self, u: &str) -> f64 {
        self.lib.ix.units.get(u).map_or(0.0, |u| u.offset)
    }

    /// Resolves an expression in a scope.
    pub(super) fn cexpr(&self, e: &Expr, sc: &Scope) -> CExpr {
        match e {
            Expr::Int { value, .. } => CExpr::Const(Value::Num(*value as f64)),
            Expr::Float { value, .. } => CExpr::Const(Value::Num(*value)),
            Expr::Physical { value, unit, .. } => {
                CExpr::Const(Value::Num(value * self.unit(unit) + self.unit_offset(unit)))
            }
            Expr::Str { value, .. } => CExpr::Const(Value::Str(value.clone())),
            Expr::Bool { value, .. } => CExpr::Const(Value::Bool(*value)),
            Expr::EnumRef { member, .. } => CExpr::Const(Value::Enum(member.clone())),
            Expr::Range { lo, hi, unit, .. } => {
                let f = unit.as_deref().map_or(1.0, |u| self.unit(u));
                let off = unit.as_deref().map_or(0.0, |u| self.unit_offset(u));
                let bound = |b: &Option<Box<Expr>>| {
                    b.as_deref().and_then(|x| match self.cexpr(x, sc) {
                        CExpr::Const(Value::Num(v)) => Some(v * f + off),
                        _ => None,
                    })
                };
                CExpr::Range(bound(lo), bound(hi))
            }
            Expr::List { items, .. } => {
                CExpr::List(items.iter().map(|x| self.cexpr(x, sc)).collect())
            }
            Expr::Unary { op, expr, .. } => {
                let inner = self.cexpr(expr, sc);
                match (op.as_str(), &inner) {
                    ("-", CExpr::Const(Value::Num(v))) => CExpr::Const(Value::Num(-v)),
                    ("-", CExpr::Range(a, b)) => CExpr::Range(b.map(|v| -v), a.map(|v| -v)),
                    _ => CExpr::Unary(op.clone(), Box::new(inner)),
                }
            }
            Expr::Binary { op, lhs, rhs, .. } => CExpr::Binary(
                op.clone(),
                Box::new(self.cexpr(lhs, sc)),
                Box::new(self.cexpr(rhs, sc)),
            ),
            Expr::Ident { .. } | Expr::Field { .. } => match self.path(e, sc) {
                Some(p) => p,
                None => CExpr::Opaque(self.source_text(e.span())),
            },
            // The engine's own methods over two actors (osc/domain):
            // `a.gap_to(b)`, `a.ttc_to(b)`.
            Expr::Call { callee, args, .. }
                if args.len() == 1
                    && matches!(&**callee, Expr::Field { name, .. } if name.text == "gap_to" || name.text == "ttc_to")
                    && let Expr::Field { base, name, .. } = &**callee
                    && let (Some(a), Some(b)) =
                        (self.path(base, sc), self.path(&args[0].value, sc)) =>
            {
                CExpr::Binary(name.text.clone(), Box::new(a), Box::new(b))
            }
            Expr::Ternary { span, .. }
            | Expr::Cast { span, .. }
            | Expr::Index { span, .. }
            | Expr::Call { span, .. }
            | Expr::Error { span } => CExpr::Opaque(self.source_text(*span)),
        }
    }

    /// The text an expression was written as (for what the engine cannot
    /// evaluate and says so).
    fn source_text(&self, span: Span) -> String {
        let f = self.lib.prog.sources.file(span.file);
        f.text
            .get(span.start as usize..span.end as usize)
            .unwrap_or("")
            .to_string()
    }

    /// `a.b.c` → an absolute path or an enum constant.
    pub(super) fn path(&self, e: &Expr, sc: &Scope) -> Option<CExpr> {
        match e {
            Expr::Ident { name, .. } => {
                if name == "it" {
                    return sc.it.clone().map(CExpr::Var);
                }
                if sc.fields.contains(name) {
                    return Some(CExpr::Var(format!("{}.{name}", sc.ns)));
                }
                if let Some(ns) = sc.labels.get(name) {
                    return Some(CExpr::Var(ns.clone()));
                }
                if name == "actor" {
                    return sc.actor.clone().map(CExpr::Var);
                }
                if name == "sut" || name == "top" {
                    return Some(CExpr::Var(name.clone()));
                }
                if self.lib.ix.is_enum_member(name) {
                    return Some(CExpr::Const(Value::Enum(name.clone())));
                }
                Some(CExpr::Var(format!("{}.{name}", sc.ns)))
            }
            Expr::Field { base, name, .. } => match self.path(base, sc)? {
                CExpr::Var(p) => Some(CExpr::Var(format!("{p}.{}", name.text))),
                _ => None,
            },
            _ => None,
        }
    }

    /// Resolves an actor reference to its id.
    pub(super) fn actor_of(&self, e: &Expr, sc: &Scope) -> Option<String> {
        match self.path(e, sc)? {
            CExpr::Var(p) => self.actor_ids.get(&p).cloned(),
            _ => None,
        }
    }

    /// A condition over states: `rise(c)` / `fall(c)` become unary
    /// operators the planner evaluates on the planned samples.
    pub(super) fn condition(&self, e: &Expr, sc: &Scope) -> CExpr {
        if let Expr::Call { callee, args, .. } = e
            && let Expr::Ident { name, .. } = &**callee
            && (name == "rise" || name == "fall")
            && let Some(a) = args.first()
        {
            return CExpr::Unary(name.clone(), Box::new(self.cexpr(&a.value, sc)));
        }
        self.cexpr(e, sc)
    }

    pub(super) fn bind(
        &self,
        args: &[Arg],
        params: &[String],
        sc: &Scope,
    ) -> BTreeMap<String, CExpr> {
        let mut out = BTreeMap::new();
        for (i, a) in args.iter().enumerate() {
            let name = match &a.name {
                Some(n) => n.text.clone(),
                None => params.get(i).cloned().unwrap_or_else(|| format!("#{i}")),
            };
            match self.literal(&a.value, sc) {
                Some((ty, fields)) => {
                    for (f, v) in fields {
                        out.insert(format!("{name}.{f}"), v);
                    }
                    out.insert(name, CExpr::Const(Value::Str(ty)));
                }
                None => {
                    out.insert(name, self.cexpr(&a.value, sc));
                }
            }
        }
        out
    }

    /// Every field a struct literal among `bound` names is one of its
    /// type's (`position_3d(q: 1m)` is an error naming the fields).
    pub(super) fn check_literals(
        &self,
        bound: &BTreeMap<String, CExpr>,
        at: &str,
    ) -> Result<(), ScenarioError> {
        for key in bound.keys() {
            let Some((owner, field)) = key.rsplit_once('.') else {
                continue;
            };
            let Some(CExpr::Const(Value::Str(ty))) = bound.get(owner) else {
                continue;
            };
            let fields = self.lib.params(ty);
            if !fields.iter().any(|f| f == field) {
                return Err(ScenarioError::Elaboration(format!(
                    "{at}: {ty} has no field '{field}' (its fields: {})",
                    fields.join(", ")
                )));
            }
        }
        Ok(())
    }

    /// `T(field: v, …)` where `T` is a declared struct: litesim's struct
    /// literal (`position_3d(x: 10m, y: 2m)`, `odr_point("1", "-1", s:
    /// 30m)`), as its type and its fields (positional ones in declaration
    /// order; nested literals as `field.sub`). A bound argument holds the
    /// type under its name and each field under `name.field`.
    pub(super) fn literal(&self, e: &Expr, sc: &Scope) -> Option<(String, Vec<(String, CExpr)>)> {
        let Expr::Call { callee, args, .. } = e else {
            return None;
        };
        let Expr::Ident { name, .. } = &**callee else {
            return None;
        };
        self.lib
            .ix
            .compounds
            .get(name)
            .filter(|c| c.kind == DeclKind::Struct)?;
        let fields = self.lib.params(name);
        let mut out = Vec::new();
        for (i, a) in args.iter().enumerate() {
            let f = match &a.name {
                Some(n) => n.text.clone(),
                None => fields.get(i).cloned().unwrap_or_else(|| format!("#{i}")),
            };
            match self.literal(&a.value, sc) {
                Some((t, sub)) => {
                    out.extend(sub.into_iter().map(|(g, v)| (format!("{f}.{g}"), v)));
                    out.push((f, CExpr::Const(Value::Str(t))));
                }
                None => out.push((f, self.cexpr(&a.value, sc))),
            }
        }
        Some((name.clone(), out))
    }
}
