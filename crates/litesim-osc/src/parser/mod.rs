//! Resilient recursive-descent parser: always returns a tree and every
//! diagnostic; after an error it skips to the end of the logical line (and
//! any block under it) and goes on, so one typo never hides the next.

use crate::ast::*;
use crate::diag::Diagnostic;
use crate::lexer::{Tok, Token};
use crate::source::Span;

mod decls;
mod expr;
mod members;

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
