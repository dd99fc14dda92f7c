//! Lexer with the layout pass: NEWLINE / INDENT / DEDENT by the standard's
//! rules (Python style; tabs to the next multiple of 8; joining inside
//! brackets and after a backslash; blank and comment-only lines ignored).
//!
//! Every word is an `Ident`; keywords are contextual and recognised by the
//! parser. `-` is always an operator (the parser folds it into literals), so
//! `a-1` works. A number glued to a word is a physical literal (`20kph`), and
//! a word glued to a closing `]` is a range unit (`[3..6]s`).
//! The lexer never fails: bad characters become diagnostics and are skipped.

use crate::diag::Diagnostic;
use crate::source::Span;
use serde::Serialize;

/// Token kinds. Words are slices of the source text: most are keywords the
/// parser only compares, so only the names it keeps are copied.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum Tok<'a> {
    /// A word (identifier or contextual keyword).
    Ident(&'a str),
    /// `|quoted identifier|`, without the bars (never a keyword).
    Quoted(&'a str),
    /// Unsigned integer.
    Int(u64),
    /// Float.
    Float(f64),
    /// Number with a glued unit: value, unit, whether written as an integer.
    Physical(f64, &'a str, bool),
    /// String literal (escapes resolved).
    Str(String),
    /// `]` immediately followed by a unit: `[3..6]s`.
    CloseUnit(&'a str),
    /// Punctuation or operator.
    Punct(&'static str),
    /// End of a logical line.
    Newline,
    /// Indentation increased.
    Indent,
    /// Indentation decreased.
    Dedent,
    /// End of file.
    Eof,
}

/// A token and where it is.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Token<'a> {
    /// Kind.
    pub tok: Tok<'a>,
    /// Span.
    pub span: Span,
}

const PUNCT: &[&str] = &[
    "...", "==", "!=", "<=", ">=", "=>", "->", "..", "::", "(", ")", "[", "]", ",", ":", ".", "=",
    "@", "?", "!", "<", ">", "+", "-", "*", "/", "%",
];

fn is_id_start(c: char) -> bool {
    c.is_alphabetic() || c == '_'
}
fn is_id_continue(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// Length in bytes of the identifier at the start of `s` (identifiers,
/// glued units `20kph`, range units `]kph`).
fn ident_len(s: &str) -> usize {
    // ASCII bytes first (nearly every name); decode characters only from
    // the first non-ASCII byte on, which is a character boundary.
    let b = s.as_bytes();
    let ascii = b
        .iter()
        .position(|c| !(c.is_ascii_alphanumeric() || *c == b'_'))
        .unwrap_or(b.len());
    if ascii == b.len() || b[ascii].is_ascii() {
        return ascii;
    }
    ascii
        + s[ascii..]
            .char_indices()
            .find(|(_, ch)| !is_id_continue(*ch))
            .map_or(s.len() - ascii, |(k, _)| k)
}

/// The lexer's state while it walks one file: the tokens and diagnostics so
/// far, the stack of indentation columns, the bracket depth (inside
/// brackets lines join) and whether a backslash joined the next line.
struct Lexer<'a> {
    text: &'a str,
    b: &'a [u8],
    file: u32,
    i: usize,
    toks: Vec<Token<'a>>,
    diags: Vec<Diagnostic>,
    indents: Vec<usize>,
    depth: i32,
    at_line_start: bool,
    continuation: bool,
}

/// Lexes one file.
pub fn lex(text: &str, file: u32) -> (Vec<Token<'_>>, Vec<Diagnostic>) {
    let mut lx = Lexer {
        text,
        b: text.as_bytes(),
        file,
        i: 0,
        // About one token per six bytes of OSC text: reserving it saves the
        // copies of a growing vector (3 % of a 10k-line check).
        toks: Vec::with_capacity(text.len() / 6 + 16),
        diags: Vec::new(),
        indents: vec![0],
        depth: 0,
        at_line_start: true,
        continuation: false,
    };
    while lx.i < lx.b.len() {
        if lx.at_line_start && lx.depth == 0 && !lx.continuation {
            lx.indentation();
            if lx.i >= lx.b.len() {
                break;
            }
        }
        lx.token();
    }
    lx.finish()
}

impl<'a> Lexer<'a> {
    fn sp(&self, s: usize, e: usize) -> Span {
        Span {
            file: self.file,
            start: s as u32,
            end: e as u32,
        }
    }

    fn push(&mut self, tok: Tok<'a>, s: usize, e: usize) {
        let span = self.sp(s, e);
        self.toks.push(Token { tok, span });
    }

    fn error(&mut self, code: &'static str, s: usize, e: usize, msg: impl Into<String>) {
        let d = Diagnostic::error(code, self.sp(s, e), msg);
        self.diags.push(d);
    }

    /// At the start of a logical line: measures its indentation and emits
    /// INDENT/DEDENT; blank and comment-only lines are skipped unmeasured.
    fn indentation(&mut self) {
        let b = self.b;
        let start = self.i;
        let mut col = 0usize;
        let mut saw_tab = false;
        let mut saw_space = false;
        while self.i < b.len() && matches!(b[self.i], b' ' | b'\t' | b'\x0c') {
            match b[self.i] {
                b'\t' => {
                    col = (col / 8 + 1) * 8;
                    saw_tab = true;
                }
                b' ' => {
                    col += 1;
                    saw_space = true;
                }
                _ => {}
            }
            self.i += 1;
        }
        let i = self.i;
        let blank = i >= b.len()
            || matches!(b[i], b'\n' | b'\r' | b'#')
            || (b[i] == b'/' && b.get(i + 1) == Some(&b'*'));
        if blank {
            return;
        }
        if saw_tab && saw_space {
            self.diags.push(
                Diagnostic::warning(
                    "W0001",
                    self.sp(start, i),
                    "indentation mixes tabs and spaces",
                )
                .with_hint("indent with spaces only"),
            );
        }
        let top = *self.indents.last().unwrap_or(&0);
        if col > top {
            self.indents.push(col);
            self.push(Tok::Indent, i, i);
        } else if col < top {
            while self.indents.len() > 1 && *self.indents.last().unwrap_or(&0) > col {
                self.indents.pop();
                self.push(Tok::Dedent, i, i);
            }
            if *self.indents.last().unwrap_or(&0) != col {
                self.diags.push(
                    Diagnostic::error(
                        "E0002",
                        self.sp(start, i),
                        "inconsistent dedent: this line matches no enclosing indentation level",
                    )
                    .with_hint("indent it like the block it belongs to"),
                );
                // Recover by keeping the line in the block it partly
                // left: undo the last DEDENT and adopt this column.
                if matches!(self.toks.last().map(|t| &t.tok), Some(Tok::Dedent)) {
                    self.toks.pop();
                }
                self.indents.push(col);
            }
        }
        self.at_line_start = false;
    }

    /// Lexes what starts at the cursor: one token, a line end, a comment or
    /// a bad character (a diagnostic).
    fn token(&mut self) {
        let b = self.b;
        let i = self.i;
        let c = b[i];
        match c {
            b'\n' | b'\r' => self.line_end(c),
            b' ' | b'\t' | b'\x0c' => self.i += 1,
            b'#' => {
                while self.i < b.len() && b[self.i] != b'\n' && b[self.i] != b'\r' {
                    self.i += 1;
                }
            }
            b'/' if b.get(i + 1) == Some(&b'*') => self.block_comment(),
            b'\\' => self.backslash(),
            b'"' | b'\'' => self.string(c),
            b'|' => self.quoted(),
            // `.5` (but not the `.` of a field access before a digit, `a.5`).
            b'0'..=b'9' | b'.'
                if c != b'.'
                    || (b.get(i + 1).is_some_and(|d| d.is_ascii_digit())
                        && self.toks.last().is_none_or(|t| t.tok != Tok::Punct("."))) =>
            {
                self.number(c)
            }
            _ => self.word_or_punct(c),
        }
    }

    /// A line break: ends the logical line unless brackets or a backslash
    /// join it to the next.
    fn line_end(&mut self, c: u8) {
        let s = self.i;
        self.i += if c == b'\r' && self.b.get(s + 1) == Some(&b'\n') {
            2
        } else {
            1
        };
        let logical_end = self.depth == 0 && !self.continuation;
        let has_content = !matches!(
            self.toks.last().map(|t| &t.tok),
            None | Some(Tok::Newline | Tok::Indent | Tok::Dedent)
        );
        if logical_end && has_content {
            self.push(Tok::Newline, s, s);
        }
        // Only the start of a new logical line measures indentation.
        self.at_line_start = logical_end;
        self.continuation = false;
    }

    /// Block comment (lenient extension), nestable.
    fn block_comment(&mut self) {
        let b = self.b;
        let s = self.i;
        let mut level = 0;
        while self.i < b.len() {
            let i = self.i;
            if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                level += 1;
                self.i += 2;
            } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                level -= 1;
                self.i += 2;
                if level == 0 {
                    break;
                }
            } else {
                self.i += 1;
            }
        }
        if level > 0 {
            self.error("E0003", s, s + 2, "unterminated block comment");
        }
    }

    /// Explicit line joining: `\` then only spaces until the end of the line.
    fn backslash(&mut self) {
        let b = self.b;
        let mut j = self.i + 1;
        while j < b.len() && matches!(b[j], b' ' | b'\t') {
            j += 1;
        }
        if j >= b.len() || matches!(b[j], b'\n' | b'\r') {
            self.continuation = true;
            self.i = j;
        } else {
            let i = self.i;
            self.error(
                "E0004",
                i,
                i + 1,
                "a backslash joins lines only at the end of a line",
            );
            self.i += 1;
        }
    }

    /// A string literal in `q` quotes, single or tripled; escapes resolved.
    fn string(&mut self, q: u8) {
        let (b, text) = (self.b, self.text);
        let s = self.i;
        let triple = b.get(s + 1) == Some(&q) && b.get(s + 2) == Some(&q);
        let mut i = s + if triple { 3 } else { 1 };
        let mut out = String::new();
        let mut closed = false;
        while i < b.len() {
            if triple && b[i] == q && b.get(i + 1) == Some(&q) && b.get(i + 2) == Some(&q) {
                i += 3;
                closed = true;
                break;
            }
            if !triple && b[i] == q {
                i += 1;
                closed = true;
                break;
            }
            if !triple && matches!(b[i], b'\n' | b'\r') {
                break;
            }
            if b[i] == b'\\' && i + 1 < b.len() {
                // The escaped character may be several bytes long.
                let e = text[i + 1..].chars().next().unwrap_or('\u{fffd}');
                out.push(match e {
                    'n' => '\n',
                    't' => '\t',
                    'r' => '\r',
                    '0' => '\0',
                    other => other,
                });
                i += 1 + e.len_utf8();
                continue;
            }
            let ch = text[i..].chars().next().unwrap_or('\u{fffd}');
            out.push(ch);
            i += ch.len_utf8();
        }
        self.i = i;
        if !closed {
            self.diags.push(
                Diagnostic::error("E0005", self.sp(s, i), "unterminated string literal").with_hint(
                    "close the string on the same line, or use \"\"\" for several lines",
                ),
            );
        }
        self.push(Tok::Str(out), s, i);
    }

    /// `|quoted identifier|` on one line.
    fn quoted(&mut self) {
        let b = self.b;
        let s = self.i;
        let mut j = s + 1;
        while j < b.len() && b[j] != b'|' && b[j] != b'\n' {
            j += 1;
        }
        if j < b.len() && b[j] == b'|' && j > s + 1 {
            self.push(Tok::Quoted(&self.text[s + 1..j]), s, j + 1);
            self.i = j + 1;
        } else {
            self.error(
                "E0006",
                s,
                s + 1,
                "unterminated quoted identifier: expected |name|",
            );
            self.i += 1;
        }
    }

    /// A number: hex, integer or float, with a glued unit a physical literal.
    fn number(&mut self, c: u8) {
        let (b, text) = (self.b, self.text);
        let s = self.i;
        if c == b'0'
            && matches!(b.get(s + 1), Some(b'x' | b'X'))
            && b.get(s + 2).is_some_and(|d| d.is_ascii_hexdigit())
        {
            return self.hex();
        }
        let mut i = s;
        let mut is_float = false;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        // A dot starts a fraction only when a digit follows: `1..5` is a range.
        if i + 1 < b.len() && b[i] == b'.' && b[i + 1].is_ascii_digit() {
            is_float = true;
            i += 1;
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
        }
        if i < b.len() && matches!(b[i], b'e' | b'E') {
            let mut j = i + 1;
            if j < b.len() && matches!(b[j], b'+' | b'-') {
                j += 1;
            }
            if j < b.len() && b[j].is_ascii_digit() {
                while j < b.len() && b[j].is_ascii_digit() {
                    j += 1;
                }
                is_float = true;
                i = j;
            }
        }
        self.i = i;
        let lit = &text[s..i];
        let value: f64 = lit.parse::<f64>().unwrap_or(f64::NAN);
        // Glued unit?
        let rest = &text[i..];
        let unit_start = rest
            .chars()
            .next()
            .filter(|ch| is_id_start(*ch) || *ch == '|');
        if unit_start.is_some() {
            let (unit, len) = if let Some(quoted) = rest.strip_prefix('|') {
                match quoted.find('|') {
                    Some(k) if k > 0 => (&quoted[..k], k + 2),
                    _ => ("", 1),
                }
            } else {
                let len = ident_len(rest);
                (&rest[..len], len)
            };
            self.i += len;
            if unit.is_empty() {
                self.error("E0006", s, self.i, "unterminated quoted unit name");
            }
            self.push(Tok::Physical(value, unit, !is_float), s, self.i);
        } else if is_float {
            self.push(Tok::Float(value), s, i);
        } else {
            match lit.parse::<u64>() {
                Ok(v) => self.push(Tok::Int(v), s, i),
                Err(_) => self.error(
                    "E0007",
                    s,
                    i,
                    format!("integer literal {lit} does not fit in 64 bits"),
                ),
            }
        }
    }

    /// `0x…`: a 64-bit unsigned integer.
    fn hex(&mut self) {
        let b = self.b;
        let s = self.i;
        let mut i = s + 2;
        let h = i;
        while i < b.len() && b[i].is_ascii_hexdigit() {
            i += 1;
        }
        self.i = i;
        match u64::from_str_radix(&self.text[h..i], 16) {
            Ok(v) => self.push(Tok::Int(v), s, i),
            Err(_) => self.error("E0007", s, i, "hex literal does not fit in 64 bits"),
        }
    }

    /// A word, an operator (tracking bracket depth; `]unit` for a range's
    /// unit) or an unexpected character.
    fn word_or_punct(&mut self, c: u8) {
        let text = self.text;
        let i = self.i;
        let rest = &text[i..];
        let ch = rest.chars().next().unwrap_or('\u{fffd}');
        if is_id_start(ch) {
            let len = ident_len(rest);
            self.push(Tok::Ident(&rest[..len]), i, i + len);
            self.i += len;
            return;
        }
        // Only the operators starting with this byte are tried.
        let Some(p) = PUNCT
            .iter()
            .find(|p| p.as_bytes()[0] == c && rest.starts_with(**p))
        else {
            self.error(
                "E0001",
                i,
                i + ch.len_utf8(),
                format!("unexpected character {ch:?}"),
            );
            self.i += ch.len_utf8();
            return;
        };
        let s = i;
        self.i += p.len();
        match *p {
            "(" | "[" => self.depth += 1,
            ")" | "]" => {
                if self.depth == 0 {
                    self.error("E0008", s, self.i, format!("unmatched '{p}'"));
                } else {
                    self.depth -= 1;
                }
            }
            _ => {}
        }
        // `]unit`: a unit for both bounds of a range.
        if *p == "]" {
            let r2 = &text[self.i..];
            if r2.chars().next().is_some_and(is_id_start) {
                let len = ident_len(r2);
                self.push(Tok::CloseUnit(&r2[..len]), s, self.i + len);
                self.i += len;
                return;
            }
        }
        self.push(Tok::Punct(p), s, self.i);
    }

    /// End of file: the last NEWLINE, an error for open brackets, and the
    /// DEDENTs that close every open block.
    fn finish(mut self) -> (Vec<Token<'a>>, Vec<Diagnostic>) {
        let end = self.text.len();
        if self
            .toks
            .last()
            .is_some_and(|t| !matches!(t.tok, Tok::Newline | Tok::Dedent | Tok::Indent))
        {
            self.push(Tok::Newline, end, end);
        }
        if self.depth > 0 {
            self.error(
                "E0009",
                end,
                end,
                "end of file inside brackets: a '(' or '[' is not closed",
            );
        }
        while self.indents.len() > 1 {
            self.indents.pop();
            self.push(Tok::Dedent, end, end);
        }
        self.push(Tok::Eof, end, end);
        (self.toks, self.diags)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// The ASCII fast path measures names exactly as the character-wise
        /// definition does, non-ASCII letters and digits included.
        #[test]
        fn ident_len_matches_the_char_definition(s in "[a-z_0-9éΩ٣ -]{0,12}") {
            let by_chars = s
                .char_indices()
                .find(|(_, ch)| !is_id_continue(*ch))
                .map_or(s.len(), |(k, _)| k);
            proptest::prop_assert_eq!(ident_len(&s), by_chars);
        }
    }
}
