//! Top-level declarations: enums, structs, actors, scenarios, actions,
//! modifiers and their extensions.

use super::*;

impl<'a> P<'a> {
    pub(super) fn enum_members(&mut self) -> Vec<(Name, Option<Expr>)> {
        let mut out = Vec::new();
        if !self.expect_p("[") {
            return out;
        }
        if self.eat_p("]") {
            return out;
        }
        while let Some(n) = self.ident("an enum member") {
            let v = if self.eat_p("=") {
                Some(self.expr())
            } else {
                None
            };
            out.push((n, v));
            if !self.eat_p(",") {
                break;
            }
        }
        self.expect_p("]");
        out
    }

    pub(super) fn decl(&mut self) -> Option<Decl> {
        let kw = match self.tok() {
            Tok::Ident(_) => self.keyword(),
            _ => {
                self.error("E0120", "a declaration (type, unit, enum, struct, actor, scenario, action, modifier, extend, global)");
                self.recover();
                return None;
            }
        };
        match kw {
            "type" => {
                self.bump();
                let name = self.ident("a physical type name")?;
                if !(self.eat_kw("is") && self.eat_kw("SI") && self.expect_p("(")) {
                    self.error("E0121", "'is SI(...)'");
                    self.recover();
                    return None;
                }
                let si = self.args(")");
                self.end_line();
                Some(Decl::PhysicalType { name, si })
            }
            "unit" => {
                self.bump();
                let name = self.ident("a unit name")?;
                let (of, args) = if self.eat_kw("of") {
                    let of = self.ident("a physical type")?;
                    if !(self.eat_kw("is") && self.eat_kw("SI") && self.expect_p("(")) {
                        self.error("E0121", "'is SI(...)'");
                        self.recover();
                        return None;
                    }
                    (of, self.args(")"))
                } else if self.eat_kw("is") {
                    // Foretify: `unit kph is speed(factor: 0.277)`.
                    let of = self.ident("a physical type")?;
                    let args = if self.eat_p("(") {
                        self.args(")")
                    } else {
                        Vec::new()
                    };
                    (of, args)
                } else {
                    self.error("E0121", "'of TYPE is SI(...)' or 'is TYPE(factor: …)'");
                    self.recover();
                    return None;
                };
                self.end_line();
                Some(Decl::Unit { name, of, args })
            }
            "enum" => {
                self.bump();
                let name = self.ident("an enum name")?;
                self.expect_p(":");
                let members = self.enum_members();
                self.end_line();
                Some(Decl::Enum { name, members })
            }
            "struct" | "actor" | "scenario" | "action" | "modifier" => self.compound(kw),
            "extend" => {
                self.bump();
                let target = self.qual_name("a type to extend")?;
                if self.is_p(":") && matches!(self.nth(1), Tok::Punct("[")) {
                    self.bump();
                    let members = self.enum_members();
                    self.end_line();
                    return Some(Decl::ExtendEnum {
                        name: target.name,
                        members,
                    });
                }
                let members = self.block(|p| p.member());
                Some(Decl::Extend { target, members })
            }
            "global" => {
                self.bump();
                match self.field(false)? {
                    Member::Field(f) => Some(Decl::Global(f)),
                    _ => None,
                }
            }
            "import" => {
                let span = self.span();
                self.diags.push(
                    Diagnostic::error("E0122", span, "imports must come before all declarations")
                        .with_hint("move this import to the top of the file"),
                );
                self.recover();
                None
            }
            _ => {
                self.error("E0120", "a declaration (type, unit, enum, struct, actor, scenario, action, modifier, extend, global)");
                self.recover();
                None
            }
        }
    }

    /// A compound declaration (`kw` is struct, actor, scenario, action or
    /// modifier): its name, `of`, `inherits` with a condition, members.
    pub(super) fn compound(&mut self, kw: &str) -> Option<Decl> {
        self.bump();
        let kind = match kw {
            "struct" => DeclKind::Struct,
            "actor" => DeclKind::Actor,
            "scenario" => DeclKind::Scenario,
            "action" => DeclKind::Action,
            _ => DeclKind::Modifier,
        };
        let name = self.qual_name("a name")?;
        let of = if kind == DeclKind::Modifier && self.eat_kw("of") {
            self.qual_name("a behaviour")
        } else {
            None
        };
        let inherits = if self.eat_kw("inherits") {
            let base = self.qual_name("a base type")?;
            let cond = if self.eat_p("(") {
                let c = self.expr();
                self.expect_p(")");
                Some(c)
            } else {
                None
            };
            Some((base, cond))
        } else {
            None
        };
        let members = if self.is_p(":") {
            self.block(|p| p.member())
        } else {
            self.end_line();
            Vec::new()
        };
        Some(Decl::Compound {
            kind,
            name,
            inherits,
            of,
            members,
        })
    }
}
