//! Expressions: precedence climbing from implication down to primaries,
//! arguments, ranges and lists, event specifications, names and types.

use super::*;

impl<'a> P<'a> {
    pub(super) fn qual_name(&mut self, what: &str) -> Option<QualName> {
        let first = self.ident(what)?;
        if self.is_p(".") && is_name(self.nth(1)) {
            self.bump();
            let name = self.ident(what)?;
            Some(QualName {
                actor: Some(first),
                name,
            })
        } else {
            Some(QualName {
                actor: None,
                name: first,
            })
        }
    }

    pub(super) fn type_ref(&mut self) -> Option<TypeRef> {
        let list = if self.is_kw("list") && matches!(self.nth(1), Tok::Ident(s) if *s == "of") {
            self.bump();
            self.bump();
            true
        } else {
            false
        };
        // `list of list of T`: the grammar's element type is not a list
        // (§3.3). Said precisely here rather than as an unexpected `of`.
        if list && self.is_kw("list") && matches!(self.nth(1), Tok::Ident(s) if *s == "of") {
            let at = self.span();
            self.diags.push(
                Diagnostic::error("E0125", at, "a list of lists is not allowed: the element type of `list of` is a scalar, struct or actor type")
                    .with_hint("wrap the inner list in a struct (`struct row: items: list of T`) and make a list of that"),
            );
            self.bump();
            self.bump();
        }
        let base = self.qual_name("a type")?;
        Some(TypeRef { list, base })
    }

    // ---------- expressions ----------

    pub(super) fn expr(&mut self) -> Expr {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            self.depth -= 1;
            let span = self.span();
            self.diags.push(Diagnostic::error(
                "E0190",
                span,
                "expression nested too deeply",
            ));
            self.recover();
            return Expr::Error { span };
        }
        let cond = self.implication();
        let e = if self.eat_p("?") {
            let then = self.expr();
            self.expect_p(":");
            let otherwise = self.expr();
            let span = join(cond.span(), otherwise.span());
            Expr::Ternary {
                cond: Box::new(cond),
                then: Box::new(then),
                otherwise: Box::new(otherwise),
                span,
            }
        } else {
            cond
        };
        self.depth -= 1;
        e
    }

    /// A left-associative level: `next (op next)*`, where an op is a
    /// punctuation token or a word (`and`, `or`, `in`) listed in `ops`.
    pub(super) fn binary(&mut self, ops: &[&str], next: fn(&mut Self) -> Expr) -> Expr {
        let mut lhs = next(self);
        loop {
            let op = match self.tok() {
                Tok::Punct(p) if ops.contains(p) => p.to_string(),
                Tok::Ident(w) if ops.contains(w) => w.to_string(),
                _ => break,
            };
            self.bump();
            let rhs = next(self);
            let span = join(lhs.span(), rhs.span());
            lhs = Expr::Binary {
                op,
                lhs: Box::new(lhs),
                rhs: Box::new(rhs),
                span,
            };
        }
        lhs
    }

    pub(super) fn implication(&mut self) -> Expr {
        self.binary(&["=>"], Self::disjunction)
    }

    pub(super) fn disjunction(&mut self) -> Expr {
        self.binary(&["or"], Self::conjunction)
    }

    pub(super) fn conjunction(&mut self) -> Expr {
        self.binary(&["and"], Self::inversion)
    }

    pub(super) fn inversion(&mut self) -> Expr {
        if self.is_kw("not") {
            let s = self.bump();
            let e = self.inversion();
            let span = join(s, e.span());
            return Expr::Unary {
                op: "not".into(),
                expr: Box::new(e),
                span,
            };
        }
        self.relation()
    }

    pub(super) fn relation(&mut self) -> Expr {
        // One level for all comparisons and `in`.
        self.binary(&["==", "!=", "<", "<=", ">", ">=", "in"], Self::sum)
    }

    pub(super) fn sum(&mut self) -> Expr {
        self.binary(&["+", "-"], Self::term)
    }

    pub(super) fn term(&mut self) -> Expr {
        self.binary(&["*", "/", "%"], Self::factor)
    }

    pub(super) fn factor(&mut self) -> Expr {
        if self.is_p("-") {
            let s = self.bump();
            let e = self.factor();
            let span = join(s, e.span());
            // Fold into numeric literals: `-2mpsps` is a literal, `a - 1` is not.
            return match e {
                Expr::Int { value, .. } => Expr::Int {
                    value: -value,
                    span,
                },
                Expr::Float { value, .. } => Expr::Float {
                    value: -value,
                    span,
                },
                Expr::Physical { value, unit, .. } => Expr::Physical {
                    value: -value,
                    unit,
                    span,
                },
                e => Expr::Unary {
                    op: "-".into(),
                    expr: Box::new(e),
                    span,
                },
            };
        }
        self.postfix()
    }

    pub(super) fn postfix(&mut self) -> Expr {
        let mut e = self.primary();
        loop {
            if self.is_p(".") {
                self.bump();
                if (self.is_kw("as") || self.is_kw("is")) && matches!(self.nth(1), Tok::Punct("("))
                {
                    let test = self.is_kw("is");
                    self.bump();
                    self.bump();
                    let ty = self.type_ref();
                    self.expect_p(")");
                    let span = join(e.span(), self.prev_span());
                    match ty {
                        Some(ty) => {
                            e = Expr::Cast {
                                base: Box::new(e),
                                test,
                                ty,
                                span,
                            }
                        }
                        None => return Expr::Error { span },
                    }
                    continue;
                }
                match self.ident("a field name after '.'") {
                    Some(name) => {
                        let span = join(e.span(), name.span);
                        e = Expr::Field {
                            base: Box::new(e),
                            name,
                            span,
                        };
                    }
                    None => return Expr::Error { span: e.span() },
                }
            } else if self.is_p("(") {
                self.bump();
                let args = self.args(")");
                let span = join(e.span(), self.prev_span());
                e = Expr::Call {
                    callee: Box::new(e),
                    args,
                    span,
                };
            } else if self.is_p("[") {
                self.bump();
                let index = self.expr();
                self.expect_p("]");
                let span = join(e.span(), self.prev_span());
                e = Expr::Index {
                    base: Box::new(e),
                    index: Box::new(index),
                    span,
                };
            } else {
                return e;
            }
        }
    }

    /// Arguments up to `close` (consumed): positional first, then named.
    pub(super) fn args(&mut self, close: &str) -> Vec<Arg> {
        let mut out: Vec<Arg> = Vec::new();
        if self.eat_p(close) {
            return out;
        }
        loop {
            let named = is_name(self.tok()) && matches!(self.nth(1), Tok::Punct(":"));
            let arg = if named {
                let name = self.ident("an argument name");
                self.bump();
                Arg {
                    name,
                    value: self.expr(),
                }
            } else {
                let value = self.expr();
                if out.iter().any(|a| a.name.is_some()) {
                    self.diags.push(
                        Diagnostic::error(
                            "E0105",
                            value.span(),
                            "positional argument after a named one",
                        )
                        .with_hint("give positional arguments first, then name: value pairs"),
                    );
                }
                Arg { name: None, value }
            };
            out.push(arg);
            if self.eat_p(",") {
                continue;
            }
            if !self.expect_p(close) {
                // Skip to the closing bracket on this logical line.
                while !matches!(self.tok(), Tok::Newline | Tok::Eof | Tok::Dedent)
                    && !self.is_p(close)
                {
                    self.bump();
                }
                self.eat_p(close);
            }
            return out;
        }
    }

    pub(super) fn primary(&mut self) -> Expr {
        let span = self.span();
        match self.tok() {
            &Tok::Int(v) => {
                self.bump();
                Expr::Int {
                    value: v as i128,
                    span,
                }
            }
            &Tok::Float(v) => {
                self.bump();
                Expr::Float { value: v, span }
            }
            &Tok::Physical(v, _, _) => {
                let (unit, _) = self.take_text();
                Expr::Physical {
                    value: v,
                    unit,
                    span,
                }
            }
            Tok::Str(_) => {
                let (value, _) = self.take_text();
                Expr::Str { value, span }
            }
            Tok::Ident(w) if *w == "true" || *w == "false" => {
                let value = *w == "true";
                self.bump();
                Expr::Bool { value, span }
            }
            Tok::Ident(w) if *w == "range" && matches!(self.nth(1), Tok::Punct("(")) => {
                self.bump();
                self.bump();
                let lo = self.expr();
                self.expect_p(",");
                let hi = self.expr();
                self.expect_p(")");
                Expr::Range {
                    lo: Some(Box::new(lo)),
                    hi: Some(Box::new(hi)),
                    unit: None,
                    span: join(span, self.prev_span()),
                }
            }
            Tok::Ident(_) | Tok::Quoted(_) => {
                let (w, _) = self.take_text();
                if self.is_p("!") && is_name(self.nth(1)) {
                    self.bump();
                    let m = self
                        .ident("an enum member")
                        .map(|n| n.text)
                        .unwrap_or_default();
                    return Expr::EnumRef {
                        enum_name: w,
                        member: m,
                        span: join(span, self.prev_span()),
                    };
                }
                Expr::Ident { name: w, span }
            }
            Tok::Punct("(") => {
                self.bump();
                let e = self.expr();
                self.expect_p(")");
                e
            }
            Tok::Punct("@") => {
                // An event reference as a value: `sample(x, @e)`.
                self.bump();
                let e = self.postfix();
                let span = join(span, e.span());
                Expr::Unary {
                    op: "@".into(),
                    expr: Box::new(e),
                    span,
                }
            }
            Tok::Punct("[") => self.range_or_list(span),
            _ => {
                self.error("E0107", "an expression");
                // Keep closers for the enclosing rule, so one error is reported once.
                let closer = matches!(
                    self.tok(),
                    Tok::Punct(")" | "]" | "," | ":") | Tok::CloseUnit(_)
                );
                if !closer
                    && !matches!(
                        self.tok(),
                        Tok::Newline | Tok::Eof | Tok::Dedent | Tok::Indent
                    )
                {
                    self.bump();
                }
                Expr::Error { span }
            }
        }
    }

    /// `[..hi]`, `[lo..]`, `[lo..hi]` (with a unit), or a list `[a, b]`,
    /// from the `[` at `span`.
    pub(super) fn range_or_list(&mut self, span: Span) -> Expr {
        self.bump();
        // `[..hi]`, `[lo..]`, `[lo..hi]`, or a list.
        let lo = if self.is_p("..") {
            None
        } else {
            Some(Box::new(self.expr()))
        };
        if self.eat_p("..") {
            let hi = if self.is_p("]") || matches!(self.tok(), Tok::CloseUnit(_)) {
                None
            } else {
                Some(Box::new(self.expr()))
            };
            let unit = match self.tok() {
                Tok::CloseUnit(_) => Some(self.take_text().0),
                _ => {
                    self.expect_p("]");
                    None
                }
            };
            return Expr::Range {
                lo,
                hi,
                unit,
                span: join(span, self.prev_span()),
            };
        }
        let mut items: Vec<Expr> = lo.map(|b| vec![*b]).unwrap_or_default();
        while self.eat_p(",") {
            items.push(self.expr());
        }
        if !self.eat_p("]") {
            if let Tok::CloseUnit(_) = self.tok() {
                self.bump();
                self.diags.push(Diagnostic::error(
                    "E0106",
                    self.prev_span(),
                    "a unit after ']' applies to ranges only",
                ));
            } else {
                self.error("E0101", "']' or ','");
            }
        }
        Expr::List {
            items,
            span: join(span, self.prev_span()),
        }
    }

    pub(super) fn event_spec(&mut self) -> EventSpec {
        let start = self.span();
        if self.eat_p("@") {
            let ev = self.postfix();
            let bind = if self.eat_kw("as") {
                self.ident("a name after 'as'")
            } else {
                None
            };
            let cond = if self.eat_kw("if") {
                Some(self.expr())
            } else {
                None
            };
            return EventSpec {
                event: Some(ev),
                bind,
                cond,
                span: join(start, self.prev_span()),
            };
        }
        let cond = self.expr();
        EventSpec {
            event: None,
            bind: None,
            cond: Some(cond),
            span: join(start, self.prev_span()),
        }
    }

    // ---------- members ----------
}
