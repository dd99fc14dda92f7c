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

/// Lexes one file.
pub fn lex(text: &str, file: u32) -> (Vec<Token<'_>>, Vec<Diagnostic>) {
    let b = text.as_bytes();
    // About one token per six bytes of OSC text: reserving it saves the
    // copies of a growing vector (3 % of a 10k-line check).
    let mut toks: Vec<Token> = Vec::with_capacity(text.len() / 6 + 16);
    let mut diags = Vec::new();
    let mut indents: Vec<usize> = vec![0];
    let mut depth: i32 = 0;
    let mut i = 0;
    let mut at_line_start = true;
    let mut continuation = false;
    let sp = |s: usize, e: usize| Span {
        file,
        start: s as u32,
        end: e as u32,
    };
    while i < b.len() {
        if at_line_start && depth == 0 && !continuation {
            // Measure indentation; skip blank and comment-only lines.
            let start = i;
            let mut col = 0usize;
            let mut saw_tab = false;
            let mut saw_space = false;
            while i < b.len() && matches!(b[i], b' ' | b'\t' | b'\x0c') {
                match b[i] {
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
                i += 1;
            }
            let blank = i >= b.len()
                || matches!(b[i], b'\n' | b'\r' | b'#')
                || (b[i] == b'/' && b.get(i + 1) == Some(&b'*'));
            if !blank {
                if saw_tab && saw_space {
                    diags.push(
                        Diagnostic::warning(
                            "W0001",
                            sp(start, i),
                            "indentation mixes tabs and spaces",
                        )
                        .with_hint("indent with spaces only"),
                    );
                }
                let top = *indents.last().unwrap_or(&0);
                if col > top {
                    indents.push(col);
                    toks.push(Token {
                        tok: Tok::Indent,
                        span: sp(i, i),
                    });
                } else if col < top {
                    while indents.len() > 1 && *indents.last().unwrap_or(&0) > col {
                        indents.pop();
                        toks.push(Token {
                            tok: Tok::Dedent,
                            span: sp(i, i),
                        });
                    }
                    if *indents.last().unwrap_or(&0) != col {
                        diags.push(
                            Diagnostic::error("E0002", sp(start, i), "inconsistent dedent: this line matches no enclosing indentation level")
                                .with_hint("indent it like the block it belongs to"),
                        );
                        // Recover by keeping the line in the block it partly
                        // left: undo the last DEDENT and adopt this column.
                        if matches!(toks.last().map(|t| &t.tok), Some(Tok::Dedent)) {
                            toks.pop();
                        }
                        indents.push(col);
                    }
                }
                at_line_start = false;
            }
            if i >= b.len() {
                break;
            }
        }
        let c = b[i];
        match c {
            b'\n' | b'\r' => {
                let s = i;
                i += if c == b'\r' && b.get(i + 1) == Some(&b'\n') {
                    2
                } else {
                    1
                };
                let logical_end = depth == 0 && !continuation;
                let has_content = !matches!(
                    toks.last().map(|t| &t.tok),
                    None | Some(Tok::Newline | Tok::Indent | Tok::Dedent)
                );
                if logical_end && has_content {
                    toks.push(Token {
                        tok: Tok::Newline,
                        span: sp(s, s),
                    });
                }
                // Only the start of a new logical line measures indentation.
                at_line_start = logical_end;
                continuation = false;
            }
            b' ' | b'\t' | b'\x0c' => i += 1,
            b'#' => {
                while i < b.len() && b[i] != b'\n' && b[i] != b'\r' {
                    i += 1;
                }
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                // Block comment (lenient extension), nestable.
                let s = i;
                let mut level = 0;
                while i < b.len() {
                    if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                        level += 1;
                        i += 2;
                    } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                        level -= 1;
                        i += 2;
                        if level == 0 {
                            break;
                        }
                    } else {
                        i += 1;
                    }
                }
                if level > 0 {
                    diags.push(Diagnostic::error(
                        "E0003",
                        sp(s, s + 2),
                        "unterminated block comment",
                    ));
                }
            }
            b'\\' => {
                // Explicit line joining: `\` then only spaces until the end of the line.
                let mut j = i + 1;
                while j < b.len() && matches!(b[j], b' ' | b'\t') {
                    j += 1;
                }
                if j >= b.len() || matches!(b[j], b'\n' | b'\r') {
                    continuation = true;
                    i = j;
                } else {
                    diags.push(Diagnostic::error(
                        "E0004",
                        sp(i, i + 1),
                        "a backslash joins lines only at the end of a line",
                    ));
                    i += 1;
                }
            }
            b'"' | b'\'' => {
                let s = i;
                let q = c;
                let triple = b.get(i + 1) == Some(&q) && b.get(i + 2) == Some(&q);
                i += if triple { 3 } else { 1 };
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
                if !closed {
                    diags.push(Diagnostic::error("E0005", sp(s, i), "unterminated string literal").with_hint("close the string on the same line, or use \"\"\" for several lines"));
                }
                toks.push(Token {
                    tok: Tok::Str(out),
                    span: sp(s, i),
                });
            }
            b'|' => {
                let s = i;
                let mut j = i + 1;
                while j < b.len() && b[j] != b'|' && b[j] != b'\n' {
                    j += 1;
                }
                if j < b.len() && b[j] == b'|' && j > i + 1 {
                    toks.push(Token {
                        tok: Tok::Quoted(&text[i + 1..j]),
                        span: sp(s, j + 1),
                    });
                    i = j + 1;
                } else {
                    diags.push(Diagnostic::error(
                        "E0006",
                        sp(s, s + 1),
                        "unterminated quoted identifier: expected |name|",
                    ));
                    i += 1;
                }
            }
            // `.5` (but not the `.` of a field access before a digit, `a.5`).
            b'0'..=b'9' | b'.'
                if c != b'.'
                    || (b.get(i + 1).is_some_and(|d| d.is_ascii_digit())
                        && toks.last().is_none_or(|t| t.tok != Tok::Punct("."))) =>
            {
                let s = i;
                let mut is_float = false;

                if c == b'0'
                    && matches!(b.get(i + 1), Some(b'x' | b'X'))
                    && b.get(i + 2).is_some_and(|d| d.is_ascii_hexdigit())
                {
                    i += 2;
                    let h = i;
                    while i < b.len() && b[i].is_ascii_hexdigit() {
                        i += 1;
                    }
                    match u64::from_str_radix(&text[h..i], 16) {
                        Ok(v) => toks.push(Token {
                            tok: Tok::Int(v),
                            span: sp(s, i),
                        }),
                        Err(_) => diags.push(Diagnostic::error(
                            "E0007",
                            sp(s, i),
                            "hex literal does not fit in 64 bits",
                        )),
                    }
                    continue;
                }
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
                    i += len;
                    if unit.is_empty() {
                        diags.push(Diagnostic::error(
                            "E0006",
                            sp(s, i),
                            "unterminated quoted unit name",
                        ));
                    }
                    toks.push(Token {
                        tok: Tok::Physical(value, unit, !is_float),
                        span: sp(s, i),
                    });
                } else if is_float {
                    toks.push(Token {
                        tok: Tok::Float(value),
                        span: sp(s, i),
                    });
                } else {
                    match lit.parse::<u64>() {
                        Ok(v) => toks.push(Token {
                            tok: Tok::Int(v),
                            span: sp(s, i),
                        }),
                        Err(_) => diags.push(Diagnostic::error(
                            "E0007",
                            sp(s, i),
                            format!("integer literal {lit} does not fit in 64 bits"),
                        )),
                    }
                }
            }
            _ => {
                let rest = &text[i..];
                let ch = rest.chars().next().unwrap_or('\u{fffd}');
                if is_id_start(ch) {
                    let len = ident_len(rest);
                    toks.push(Token {
                        tok: Tok::Ident(&rest[..len]),
                        span: sp(i, i + len),
                    });
                    i += len;
                    continue;
                }
                // Only the operators starting with this byte are tried.
                match PUNCT
                    .iter()
                    .find(|p| p.as_bytes()[0] == c && rest.starts_with(**p))
                {
                    Some(p) => {
                        let s = i;
                        i += p.len();
                        match *p {
                            "(" | "[" => depth += 1,
                            ")" | "]" => {
                                if depth == 0 {
                                    diags.push(Diagnostic::error(
                                        "E0008",
                                        sp(s, i),
                                        format!("unmatched '{p}'"),
                                    ));
                                } else {
                                    depth -= 1;
                                }
                            }
                            _ => {}
                        }
                        // `]unit`: a unit for both bounds of a range.
                        if *p == "]" {
                            let r2 = &text[i..];
                            if r2.chars().next().is_some_and(is_id_start) {
                                let len = ident_len(r2);
                                toks.push(Token {
                                    tok: Tok::CloseUnit(&r2[..len]),
                                    span: sp(s, i + len),
                                });
                                i += len;
                                continue;
                            }
                        }
                        toks.push(Token {
                            tok: Tok::Punct(p),
                            span: sp(s, i),
                        });
                    }
                    None => {
                        diags.push(Diagnostic::error(
                            "E0001",
                            sp(i, i + ch.len_utf8()),
                            format!("unexpected character {ch:?}"),
                        ));
                        i += ch.len_utf8();
                    }
                }
            }
        }
    }
    let end = text.len();
    if toks
        .last()
        .is_some_and(|t| !matches!(t.tok, Tok::Newline | Tok::Dedent | Tok::Indent))
    {
        toks.push(Token {
            tok: Tok::Newline,
            span: sp(end, end),
        });
    }
    if depth > 0 {
        diags.push(Diagnostic::error(
            "E0009",
            sp(end, end),
            "end of file inside brackets: a '(' or '[' is not closed",
        ));
    }
    while indents.len() > 1 {
        indents.pop();
        toks.push(Token {
            tok: Tok::Dedent,
            span: sp(end, end),
        });
    }
    toks.push(Token {
        tok: Tok::Eof,
        span: sp(end, end),
    });
    (toks, diags)
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
