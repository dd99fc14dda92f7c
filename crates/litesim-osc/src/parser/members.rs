//! Members of a declaration's body: fields and parameters, `keep`,
//! events, methods, `with` blocks and the `do` tree.

use super::*;

impl<'a> P<'a> {
    pub(super) fn params(&mut self) -> Vec<Field> {
        let mut out = Vec::new();
        if self.eat_p(")") {
            return out;
        }
        while let Some(name) = self.ident("a parameter name") {
            self.expect_p(":");
            let Some(ty) = self.type_ref() else { break };
            let default = if self.eat_p("=") {
                Some(self.expr())
            } else {
                None
            };
            out.push(Field {
                var: false,
                names: vec![name],
                ty,
                default,
                with: Vec::new(),
            });
            if !self.eat_p(",") {
                break;
            }
        }
        self.expect_p(")");
        out
    }

    pub(super) fn field(&mut self, var: bool) -> Option<Member> {
        let mut names = vec![self.ident("a field name")?];
        while self.eat_p(",") {
            names.push(self.ident("a field name")?);
        }
        if !self.expect_p(":") {
            self.recover();
            return None;
        }
        let Some(ty) = self.type_ref() else {
            self.recover();
            return None;
        };
        let default = if self.eat_p("=") {
            Some(self.expr())
        } else {
            None
        };
        let with = if self.is_kw("with") && !var {
            self.bump();
            self.block(|p| p.member())
        } else {
            self.end_line();
            Vec::new()
        };
        Some(Member::Field(Field {
            var,
            names,
            ty,
            default,
            with,
        }))
    }

    pub(super) fn member(&mut self) -> Option<Member> {
        let start = self.span();
        let kw = match self.tok() {
            Tok::Ident(_) | Tok::Quoted(_) => self.keyword(),
            _ => {
                self.error(
                    "E0110",
                    "a member (field, keep, event, def, do, modifier, …)",
                );
                self.recover();
                return None;
            }
        };
        let next_colon = matches!(self.nth(1), Tok::Punct(":"));
        match kw {
            "var" if !next_colon => {
                self.bump();
                self.field(true)
            }
            "keep" if matches!(self.nth(1), Tok::Punct("(")) => self.keep_member(start),
            "remove_default" if matches!(self.nth(1), Tok::Punct("(")) => {
                self.bump();
                self.bump();
                let path = self.expr();
                self.expect_p(")");
                let span = join(start, self.prev_span());
                self.end_line();
                Some(Member::RemoveDefault { path, span })
            }
            "event" if !next_colon => self.event_member(),
            "def" if !next_colon => self.method(),
            "cover" | "record" if matches!(self.nth(1), Tok::Punct("(")) => {
                self.bump();
                self.bump();
                let args = self.args(")");
                let span = join(start, self.prev_span());
                self.end_line();
                Some(Member::Coverage {
                    record: kw == "record",
                    args,
                    span,
                })
            }
            "do" if !next_colon || matches!(self.nth(2), Tok::Newline) => {
                self.bump();
                self.do_member().map(Member::Do)
            }
            "on" if !next_colon => {
                self.bump();
                let event = self.event_spec();
                let body = self.block(|p| p.do_member());
                Some(Member::On { event, body })
            }
            "until" if !next_colon => {
                self.bump();
                let e = self.event_spec();
                self.end_line();
                Some(Member::Until(e))
            }
            "set" if !next_colon && is_name(self.nth(1)) => {
                self.bump();
                let path = self.postfix();
                self.expect_p("=");
                let value = self.expr();
                let span = join(start, self.prev_span());
                self.end_line();
                Some(Member::Set { path, value, span })
            }
            _ if next_colon => {
                // `label: modifier(...)` or a field `name: type`.
                let labelled = is_name(self.nth(2))
                    && (matches!(self.nth(3), Tok::Punct("("))
                        || (matches!(self.nth(3), Tok::Punct("."))
                            && matches!(self.nth(5), Tok::Punct("("))));
                if labelled {
                    let label = self.ident("a label");
                    self.bump();
                    let call = self.postfix();
                    self.check_call(&call);
                    self.end_line();
                    return Some(Member::Modifier { label, call });
                }
                self.field(false)
            }
            _ if matches!(self.nth(1), Tok::Punct(",")) => self.field(false),
            _ => {
                let call = self.postfix();
                if !matches!(call, Expr::Call { .. }) {
                    self.diags.push(
                        Diagnostic::error("E0112", call.span(), "expected a member: a field (name: type), keep(…), event, def, do, or a modifier call")
                            .with_hint("a field needs a type: `name: type`"),
                    );
                    self.recover();
                    return None;
                }
                self.end_line();
                Some(Member::Modifier { label: None, call })
            }
        }
    }

    /// `keep([default|hard] expr)` from `start`.
    pub(super) fn keep_member(&mut self, start: Span) -> Option<Member> {
        self.bump();
        self.bump();
        let strength = if self.is_kw("default") || self.is_kw("hard") {
            let word = match self.tok() {
                Tok::Ident(s) => Some(s.to_string()),
                _ => None,
            };
            self.bump();
            word
        } else {
            None
        };
        let expr = self.expr();
        self.expect_p(")");
        let span = join(start, self.prev_span());
        self.end_line();
        Some(Member::Keep {
            strength,
            expr,
            span,
        })
    }

    /// `event name[(params)] [is spec]`.
    pub(super) fn event_member(&mut self) -> Option<Member> {
        self.bump();
        let name = self.ident("an event name")?;
        let params = if self.eat_p("(") {
            self.params()
        } else {
            Vec::new()
        };
        let is = if self.eat_kw("is") {
            Some(self.event_spec())
        } else {
            None
        };
        self.end_line();
        Some(Member::Event { name, params, is })
    }

    /// `def name(params) -> ret is [only] expression …|undefined|external …`.
    pub(super) fn method(&mut self) -> Option<Member> {
        self.bump();
        let name = self.ident("a method name")?;
        self.expect_p("(");
        let params = self.params();
        let ret = if self.eat_p("->") {
            self.type_ref()
        } else {
            None
        };
        if !self.eat_kw("is") {
            self.error(
                "E0111",
                "'is' and a method body (expression …, undefined, external …)",
            );
            self.recover();
            return None;
        }
        let only = self.eat_kw("only");
        let (body, expr) = match self.tok().clone() {
            Tok::Ident("expression") => {
                self.bump();
                ("expression".to_string(), Some(self.expr()))
            }
            Tok::Ident("undefined") => {
                self.bump();
                ("undefined".to_string(), None)
            }
            Tok::Ident("external") => {
                self.bump();
                ("external".to_string(), Some(self.postfix()))
            }
            _ => {
                self.error("E0111", "'expression', 'undefined' or 'external'");
                self.recover();
                return None;
            }
        };
        self.end_line();
        Some(Member::Method {
            name,
            params,
            ret,
            body,
            expr,
            only,
        })
    }

    pub(super) fn check_call(&mut self, e: &Expr) {
        if !matches!(e, Expr::Call { .. }) {
            self.diags.push(Diagnostic::error(
                "E0113",
                e.span(),
                "expected a call such as `drive()` or `speed(20kph)`",
            ));
        }
    }

    pub(super) fn with_block(&mut self) -> Vec<Member> {
        if self.eat_kw("with") {
            self.block(|p| p.member())
        } else {
            Vec::new()
        }
    }

    pub(super) fn do_member(&mut self) -> Option<DoMember> {
        let start = self.span();
        let label = if (matches!(self.tok(), Tok::Ident(w) if *w != "with")
            || matches!(self.tok(), Tok::Quoted(_)))
            && matches!(self.nth(1), Tok::Punct(":"))
            && !matches!(self.nth(2), Tok::Newline)
        {
            let l = self.ident("a label");
            self.bump();
            l
        } else {
            None
        };
        let kw = self.keyword();
        let kind = match kw {
            "serial" | "parallel" | "one_of" => {
                self.bump();
                let args = if self.eat_p("(") {
                    self.args(")")
                } else {
                    Vec::new()
                };
                let children = self.block(|p| p.do_member());
                let with = self.with_block();
                DoKind::Composition {
                    op: kw.to_string(),
                    args,
                    children,
                    with,
                }
            }
            "wait" => {
                self.bump();
                let e = self.event_spec();
                self.end_line();
                DoKind::Wait(e)
            }
            "emit" => {
                self.bump();
                let event = self.postfix();
                self.end_line();
                DoKind::Emit { event }
            }
            "call" => {
                self.bump();
                let call = self.postfix();
                self.check_call(&call);
                self.end_line();
                DoKind::Call { call }
            }
            _ if self.is_p(":") => {
                // `do:` with a block: an implicit serial (lenient, as in the standard's examples).
                let children = self.block(|p| p.do_member());
                DoKind::Composition {
                    op: "serial".into(),
                    args: Vec::new(),
                    children,
                    with: Vec::new(),
                }
            }
            _ => {
                let call = self.postfix();
                if !matches!(call, Expr::Call { .. }) {
                    self.diags.push(
                        Diagnostic::error("E0114", call.span(), "expected a scenario or action invocation, serial/parallel/one_of, wait, emit or call")
                            .with_hint("invocations need parentheses: `car.drive()`"),
                    );
                    self.recover();
                    return None;
                }
                let with = if self.is_kw("with") {
                    self.with_block()
                } else {
                    self.end_line();
                    Vec::new()
                };
                DoKind::Invoke { call, with }
            }
        };
        Some(DoMember {
            label,
            kind,
            span: start,
        })
    }

    // ---------- declarations ----------
}
