//! # litesim-osc
//!
//! An OpenSCENARIO DSL 2.0 front end: [`lexer`] (layout-aware: NEWLINE,
//! INDENT, DEDENT), [`parser`] (resilient recursive descent: a tree *and*
//! all diagnostics), [`loader`] (imports with `$ENV` expansion, search paths,
//! cycle detection, each file parsed once) and [`diag`] (file:line:col,
//! source line, caret underline, error code, hint; JSON for tools).
//!
//! Invariant: no input makes it panic, hang or go quadratic; every problem
//! is a [`Diagnostic`] with a place.
#![warn(missing_docs)]

pub mod ast;
pub mod builtin;
pub mod carla;
pub mod check;
pub mod diag;
pub mod index;
pub mod lexer;
pub mod loader;
pub mod parser;
mod precedence;
pub mod source;

pub use diag::{Diagnostic, Severity};
pub use loader::{Dialect, LoadError, Program, UnknownDialect, UnsetVar, load, load_with};
pub use source::{SourceMap, Span};

/// Lexes and parses one text (file index 0 of a fresh source map).
pub fn parse_str(path: &str, text: &str) -> (SourceMap, ast::FileAst, Vec<Diagnostic>) {
    let mut sources = SourceMap::default();
    let id = sources.add(path, text);
    let (toks, mut diags) = lexer::lex(text, id);
    let (ast, d2) = parser::parse(toks);
    diags.extend(d2);
    diags.sort_by_key(|d| (d.span.file, d.span.start));
    (sources, ast, diags)
}
