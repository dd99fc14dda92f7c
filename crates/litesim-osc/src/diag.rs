//! Diagnostics: where (file:line:col and the source line with a caret
//! underline), what, an error code, and a hint where one helps.

use crate::source::{SourceMap, Span};
use serde::Serialize;

/// Severity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Stops the program from being run.
    Error,
    /// Worth a look.
    Warning,
}

/// One diagnostic.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Diagnostic {
    /// Severity.
    pub severity: Severity,
    /// Stable code, e.g. `E0101`.
    pub code: &'static str,
    /// What is wrong.
    pub message: String,
    /// Where.
    pub span: Span,
    /// How to fix it, when known.
    pub hint: Option<String>,
    /// Another place that explains this one (`first defined here`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub related: Option<(Span, String)>,
}

impl Diagnostic {
    /// An error.
    pub fn error(code: &'static str, span: Span, message: impl Into<String>) -> Self {
        Self {
            severity: Severity::Error,
            code,
            message: message.into(),
            span,
            hint: None,
            related: None,
        }
    }
    /// A warning.
    pub fn warning(code: &'static str, span: Span, message: impl Into<String>) -> Self {
        Self {
            severity: Severity::Warning,
            code,
            message: message.into(),
            span,
            hint: None,
            related: None,
        }
    }
    /// Adds a hint.
    pub fn with_hint(mut self, hint: impl Into<String>) -> Self {
        self.hint = Some(hint.into());
        self
    }

    /// Points at another place (`first defined here`).
    pub fn with_related(mut self, span: Span, what: impl Into<String>) -> Self {
        self.related = Some((span, what.into()));
        self
    }

    /// Renders for a terminal: header, source line, caret underline, hint.
    pub fn render(&self, sources: &SourceMap) -> String {
        let f = sources.file(self.span.file);
        let (line, col) = f.line_col(self.span.start as usize);
        let (eline, ecol) = f.line_col(self.span.end as usize);
        let kind = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        let src = f.line(line);
        let width = if eline == line {
            ecol.saturating_sub(col).max(1)
        } else {
            src.chars().count().saturating_sub(col - 1).max(1)
        };
        let gutter = line.to_string().len();
        let mut s = format!(
            "{}:{line}:{col}: {kind}[{}]: {}\n",
            f.path, self.code, self.message
        );
        s += &format!(
            "{:gutter$} |\n{line} | {src}\n{:gutter$} | {}{}\n",
            "",
            "",
            " ".repeat(col - 1),
            "^".repeat(width)
        );
        if let Some(h) = &self.hint {
            s += &format!("{:gutter$} = hint: {h}\n", "");
        }
        if let Some((sp, what)) = &self.related {
            let g = sources.file(sp.file);
            let (l, c) = g.line_col(sp.start as usize);
            let (el, ec) = g.line_col(sp.end as usize);
            let w = if el == l {
                ec.saturating_sub(c).max(1)
            } else {
                1
            };
            let gut = l.to_string().len();
            s += &format!(
                "{}:{l}:{c}: note: {what}\n{:gut$} |\n{l} | {}\n{:gut$} | {}{}\n",
                g.path,
                "",
                g.line(l),
                "",
                " ".repeat(c - 1),
                "-".repeat(w)
            );
        }
        s
    }

    /// A JSON object for tools: file, line, column, end, severity, code, message, hint.
    /// The diagnostic as rustc writes its JSON diagnostics
    /// (`--error-format=json`): `message`, `code` {code, explanation},
    /// `level`, `spans` (file_name, byte and line/column ranges, 1-based
    /// columns in characters, `is_primary`, the source `text` with its
    /// highlight, `label`), `children` (the hint as `help`, the other
    /// location as `note` with its own span) and `rendered` (the text
    /// `litesim check` prints), so editors and CI annotators that read
    /// rustc's format read these.
    pub fn to_rustc_json(&self, sources: &SourceMap) -> serde_json::Value {
        let span = |sp: &Span, primary: bool, label: Option<&str>| {
            let f = sources.file(sp.file);
            let (l0, c0) = f.line_col(sp.start as usize);
            let (l1, c1) = f.line_col(sp.end.max(sp.start) as usize);
            let text: Vec<serde_json::Value> = (l0..=l1)
                .map(|l| {
                    let t = f.line(l);
                    let n = t.chars().count() + 1;
                    let hs = if l == l0 { c0 } else { 1 };
                    let he = if l == l1 { c1.max(hs) } else { n };
                    serde_json::json!({"text": t, "highlight_start": hs, "highlight_end": he})
                })
                .collect();
            serde_json::json!({
                "file_name": f.path, "byte_start": sp.start, "byte_end": sp.end,
                "line_start": l0, "line_end": l1, "column_start": c0, "column_end": c1,
                "is_primary": primary, "text": text, "label": label,
                "suggested_replacement": null, "suggestion_applicability": null, "expansion": null,
            })
        };
        let level = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        let mut children = Vec::new();
        if let Some((sp, what)) = &self.related {
            children.push(serde_json::json!({
                "message": what, "code": null, "level": "note",
                "spans": [span(sp, true, None)], "children": [], "rendered": null,
            }));
        }
        if let Some(h) = &self.hint {
            children.push(serde_json::json!({
                "message": h, "code": null, "level": "help",
                "spans": [], "children": [], "rendered": null,
            }));
        }
        serde_json::json!({
            "$message_type": "diagnostic",
            "message": self.message,
            "code": {"code": self.code, "explanation": null},
            "level": level,
            "spans": [span(&self.span, true, None)],
            "children": children,
            "rendered": self.render(sources),
        })
    }

    /// litesim's flat JSON form (file, line, column, … one object per
    /// diagnostic): `litesim check --json`.
    pub fn to_json(&self, sources: &SourceMap) -> serde_json::Value {
        let f = sources.file(self.span.file);
        let (line, col) = f.line_col(self.span.start as usize);
        let (eline, ecol) = f.line_col(self.span.end as usize);
        serde_json::json!({
            "file": f.path, "line": line, "column": col, "end_line": eline, "end_column": ecol,
            "severity": self.severity, "code": self.code, "message": self.message, "hint": self.hint,
            "related": self.related.as_ref().map(|(sp, what)| {
                let g = sources.file(sp.file);
                let (l, c) = g.line_col(sp.start as usize);
                serde_json::json!({"file": g.path, "line": l, "column": c, "message": what})
            }),
        })
    }
}
