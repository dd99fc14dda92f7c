//! Resilient recursive-descent parser: always returns a tree and every
//! diagnostic; after an error it skips to the end of the logical line (and
//! any block under it) and goes on, so one typo never hides the next.

use crate::ast::*;
use crate::diag::Diagnostic;
use crate::lexer::{Tok, Token};
use crate::source::Span;

struct P<'a> {
    /// Owned so that a consumed word can be moved into the tree rather than
    /// copied: the parser never looks back at a token it has stepped past.
    toks: Vec<Token<'a>>,
    pos: usize,
    diags: Vec<Diagnostic>,
    depth: usize,
    /// Indented blocks open around the current token.
    blocks: usize,
}

/// Deepest nesting of expressions: each level is a dozen parser frames, and
/// 128 levels fit a 2 MiB thread stack even in a debug build (200 did not).
const MAX_DEPTH: usize = 128;
/// Deepest nesting of indented blocks: the tree is walked recursively (by
/// the checker, the lowering, serialisation and drop), so its depth is
/// bounded where it is built.
const MAX_BLOCKS: usize = 200;

/// A name token: an identifier or a `|quoted identifier|` (which may
/// stand wherever an identifier does, §3.1).
fn is_name(t: &Tok) -> bool {
    matches!(t, Tok::Ident(_) | Tok::Quoted(_))
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Ident(s) => format!("'{s}'"),
        Tok::Quoted(s) => format!("'|{s}|'"),
        Tok::Int(v) => format!("number {v}"),
        Tok::Float(v) => format!("number {v}"),
        Tok::Physical(v, u, _) => format!("'{v}{u}'"),
        Tok::Str(_) => "a string".into(),
        Tok::CloseUnit(u) => format!("']{u}'"),
        Tok::Punct(p) => format!("'{p}'"),
        Tok::Newline => "end of line".into(),
        Tok::Indent => "an indented block".into(),
        Tok::Dedent => "end of block".into(),
        Tok::Eof => "end of file".into(),
    }
}

impl<'a> P<'a> {
    fn tok(&self) -> &Tok<'a> {
        &self.toks[self.pos.min(self.toks.len() - 1)].tok
    }
    fn nth(&self, k: usize) -> &Tok<'a> {
        &self.toks[(self.pos + k).min(self.toks.len() - 1)].tok
    }
    fn span(&self) -> Span {
        self.toks[self.pos.min(self.toks.len() - 1)].span
    }
    fn prev_span(&self) -> Span {
        self.toks[self.pos.saturating_sub(1).min(self.toks.len() - 1)].span
    }
    /// Moves past the current token; returns its span. (No clone of the
    /// token: most callers only step over keywords and punctuation, and a
    /// clone is a string allocation for every word.)
    /// The current token's text as an owned string (moved out of a string
    /// literal, copied from the source for a word; empty for a token without
    /// one), stepping past it.
    fn take_text(&mut self) -> (String, Span) {
        let i = self.pos.min(self.toks.len() - 1);
        let text = match &mut self.toks[i].tok {
            Tok::Ident(s) | Tok::Quoted(s) | Tok::CloseUnit(s) | Tok::Physical(_, s, _) => {
                s.to_string()
            }
            Tok::Str(s) => std::mem::take(s),
            _ => String::new(),
        };
        (text, self.bump())
    }
    fn bump(&mut self) -> Span {
        let span = self.span();
        if self.pos < self.toks.len() - 1 {
            self.pos += 1;
        }
        span
    }
    /// The current word if it is one of the keywords that start a member,
    /// an invocation or a declaration, else "": the callers dispatch on it
    /// without copying the word.
    fn keyword(&self) -> &'static str {
        // A match, not a search through a list: the compiler dispatches on
        // the length first, so most words cost one comparison at most.
        match self.tok() {
            Tok::Ident(w) => match *w {
                "var" => "var",
                "keep" => "keep",
                "remove_default" => "remove_default",
                "event" => "event",
                "def" => "def",
                "cover" => "cover",
                "record" => "record",
                "do" => "do",
                "on" => "on",
                "until" => "until",
                "set" => "set",
                "serial" => "serial",
                "parallel" => "parallel",
                "one_of" => "one_of",
                "wait" => "wait",
                "emit" => "emit",
                "call" => "call",
                "type" => "type",
                "unit" => "unit",
                "enum" => "enum",
                "struct" => "struct",
                "actor" => "actor",
                "scenario" => "scenario",
                "action" => "action",
                "modifier" => "modifier",
                "extend" => "extend",
                "global" => "global",
                "import" => "import",
                _ => "",
            },
            _ => "",
        }
    }
    fn is_kw(&self, k: &str) -> bool {
        matches!(self.tok(), Tok::Ident(s) if *s == k)
    }
    fn is_p(&self, p: &str) -> bool {
        matches!(self.tok(), Tok::Punct(q) if *q == p)
    }
    fn eat_p(&mut self, p: &str) -> bool {
        if self.is_p(p) {
            self.bump();
            true
        } else {
            false
        }
    }
    fn eat_kw(&mut self, k: &str) -> bool {
        if self.is_kw(k) {
            self.bump();
            true
        } else {
            false
        }
    }
    fn error(&mut self, code: &'static str, expected: &str) {
        let found = describe(self.tok());
        let span = self.span();
        // One error per place: a follow-on complaint about the same token adds nothing.
        if self
            .diags
            .last()
            .is_some_and(|d| d.span.start == span.start && d.span.file == span.file)
        {
            return;
        }
        self.diags.push(Diagnostic::error(
            code,
            span,
            format!("expected {expected}, found {found}"),
        ));
    }
    fn expect_p(&mut self, p: &str) -> bool {
        if self.eat_p(p) {
            true
        } else {
            self.error("E0101", &format!("'{p}'"));
            false
        }
    }
    fn ident(&mut self, what: &str) -> Option<Name> {
        match self.tok() {
            Tok::Ident(_) | Tok::Quoted(_) => {
                let (text, span) = self.take_text();
                Some(Name { text, span })
            }
            _ => {
                self.error("E0102", what);
                None
            }
        }
    }
    fn end_line(&mut self) {
        match self.tok() {
            Tok::Newline => {
                self.bump();
            }
            Tok::Eof | Tok::Dedent => {}
            _ => {
                self.error("E0103", "end of line");
                self.recover();
            }
        }
    }
    /// Skips the rest of the logical line and any block under it.
    fn recover(&mut self) {
        loop {
            match self.tok() {
                Tok::Eof => return,
                Tok::Dedent => return,
                Tok::Newline => {
                    self.bump();
                    if matches!(self.tok(), Tok::Indent) {
                        self.skip_block();
                    }
                    return;
                }
                Tok::Indent => self.skip_block(),
                _ => {
                    self.bump();
                }
            }
        }
    }
    fn skip_block(&mut self) {
        let mut level = 0i32;
        loop {
            match self.tok() {
                Tok::Eof => return,
                Tok::Indent => level += 1,
                Tok::Dedent => {
                    level -= 1;
                    if level <= 0 {
                        self.bump();
                        return;
                    }
                }
                _ => {}
            }
            self.bump();
        }
    }

    /// `':' NEWLINE INDENT item+ DEDENT`, recovering per item.
    fn block<T>(&mut self, mut item: impl FnMut(&mut Self) -> Option<T>) -> Vec<T> {
        let mut out = Vec::new();
        if !self.expect_p(":") {
            self.recover();
            return out;
        }
        if !matches!(self.tok(), Tok::Newline) {
            // `with: duration(3s)` — one member on the same line (Foretify style).
            if let Some(x) = item(self) {
                out.push(x);
            }
            return out;
        }
        self.bump();
        if !matches!(self.tok(), Tok::Indent) {
            self.error("E0104", "an indented block");
            return out;
        }
        if self.blocks >= MAX_BLOCKS {
            let span = self.span();
            self.diags.push(
                Diagnostic::error(
                    "E0191",
                    span,
                    format!("blocks nested too deeply (more than {MAX_BLOCKS} levels)"),
                )
                .with_hint("flatten the nesting: a `serial` or `parallel` can hold many members at one level"),
            );
            // Skip the whole block, inner blocks included.
            let mut open = 0usize;
            loop {
                match self.tok() {
                    Tok::Indent => open += 1,
                    Tok::Dedent => {
                        open -= 1;
                        if open == 0 {
                            self.bump();
                            break;
                        }
                    }
                    Tok::Eof => break,
                    _ => {}
                }
                self.bump();
            }
            return out;
        }
        self.bump();
        self.blocks += 1;
        let out = self.block_items(out, &mut item);
        self.blocks -= 1;
        out
    }

    /// The items of a block whose `INDENT` was consumed, up to its `DEDENT`.
    fn block_items<T>(
        &mut self,
        mut out: Vec<T>,
        item: &mut impl FnMut(&mut Self) -> Option<T>,
    ) -> Vec<T> {
        loop {
            match self.tok() {
                Tok::Dedent => {
                    self.bump();
                    break;
                }
                Tok::Eof => break,
                Tok::Newline => {
                    self.bump();
                }
                _ => {
                    let before = self.pos;
                    if let Some(x) = item(self) {
                        out.push(x);
                    }
                    if self.pos == before {
                        self.bump();
                    }
                }
            }
        }
        out
    }

    fn qual_name(&mut self, what: &str) -> Option<QualName> {
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

    fn type_ref(&mut self) -> Option<TypeRef> {
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

    fn expr(&mut self) -> Expr {
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
    fn binary(&mut self, ops: &[&str], next: fn(&mut Self) -> Expr) -> Expr {
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
    fn implication(&mut self) -> Expr {
        self.binary(&["=>"], Self::disjunction)
    }
    fn disjunction(&mut self) -> Expr {
        self.binary(&["or"], Self::conjunction)
    }
    fn conjunction(&mut self) -> Expr {
        self.binary(&["and"], Self::inversion)
    }
    fn inversion(&mut self) -> Expr {
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
    fn relation(&mut self) -> Expr {
        // One level for all comparisons and `in`.
        self.binary(&["==", "!=", "<", "<=", ">", ">=", "in"], Self::sum)
    }
    fn sum(&mut self) -> Expr {
        self.binary(&["+", "-"], Self::term)
    }
    fn term(&mut self) -> Expr {
        self.binary(&["*", "/", "%"], Self::factor)
    }
    fn factor(&mut self) -> Expr {
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
    fn postfix(&mut self) -> Expr {
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
    fn args(&mut self, close: &str) -> Vec<Arg> {
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
    fn primary(&mut self) -> Expr {
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
    fn range_or_list(&mut self, span: Span) -> Expr {
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

    fn event_spec(&mut self) -> EventSpec {
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

    fn params(&mut self) -> Vec<Field> {
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

    fn field(&mut self, var: bool) -> Option<Member> {
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

    fn member(&mut self) -> Option<Member> {
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
    fn keep_member(&mut self, start: Span) -> Option<Member> {
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
    fn event_member(&mut self) -> Option<Member> {
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
    fn method(&mut self) -> Option<Member> {
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

    fn check_call(&mut self, e: &Expr) {
        if !matches!(e, Expr::Call { .. }) {
            self.diags.push(Diagnostic::error(
                "E0113",
                e.span(),
                "expected a call such as `drive()` or `speed(20kph)`",
            ));
        }
    }

    fn with_block(&mut self) -> Vec<Member> {
        if self.eat_kw("with") {
            self.block(|p| p.member())
        } else {
            Vec::new()
        }
    }

    fn do_member(&mut self) -> Option<DoMember> {
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

    fn enum_members(&mut self) -> Vec<(Name, Option<Expr>)> {
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

    fn decl(&mut self) -> Option<Decl> {
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
    fn compound(&mut self, kw: &str) -> Option<Decl> {
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

fn join(a: Span, b: Span) -> Span {
    if a.file != b.file {
        return a;
    }
    Span {
        file: a.file,
        start: a.start.min(b.start),
        end: a.end.max(b.end),
    }
}

/// Parses a token stream (from [`crate::lexer::lex`]) into a tree and diagnostics.
pub fn parse(toks: Vec<Token<'_>>) -> (FileAst, Vec<Diagnostic>) {
    let mut p = P {
        toks,
        pos: 0,
        diags: Vec::new(),
        depth: 0,
        blocks: 0,
    };
    let mut ast = FileAst::default();
    if p.toks.is_empty() {
        return (ast, p.diags);
    }
    while matches!(p.tok(), Tok::Newline) {
        p.bump();
    }
    while p.is_kw("import") {
        let start = p.bump();
        let path = match p.tok().clone() {
            Tok::Str(s) => {
                p.bump();
                Some(s)
            }
            Tok::Ident(_) => {
                let mut s = String::new();
                while let Tok::Ident(w) = p.tok().clone() {
                    s.push_str(w);
                    p.bump();
                    if p.eat_p(".") {
                        s.push('.');
                    } else {
                        break;
                    }
                }
                Some(s)
            }
            _ => {
                p.error("E0123", "a file path string after 'import'");
                None
            }
        };
        if let Some(path) = path {
            ast.imports.push(Import {
                path,
                span: join(start, p.prev_span()),
            });
        }
        p.end_line();
        while matches!(p.tok(), Tok::Newline) {
            p.bump();
        }
    }
    loop {
        match p.tok() {
            Tok::Eof => break,
            Tok::Newline | Tok::Dedent => {
                p.bump();
            }
            Tok::Indent => {
                let span = p.span();
                p.diags.push(Diagnostic::error(
                    "E0124",
                    span,
                    "unexpected indentation at top level",
                ));
                p.skip_block();
            }
            _ => {
                let before = p.pos;
                if let Some(d) = p.decl() {
                    ast.decls.push(d);
                }
                if p.pos == before {
                    p.bump();
                }
            }
        }
    }
    (ast, p.diags)
}
