//! Loading a program: the entry file and everything it imports.
//!
//! Import paths expand `$VAR` and `${VAR}` from the environment (the seed's
//! `$FTX/...`), are resolved relative to the importing file, then against the
//! search paths (`-I`) in order. Each file is parsed once; an import cycle,
//! a missing file or an unreadable one is a diagnostic at the import.

use crate::ast::FileAst;
use crate::diag::Diagnostic;
use crate::source::{SourceMap, Span};
use litesim_core::files::{MAX_INPUT_BYTES, ReadError, read_text};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A loaded program.
#[derive(Debug, Default)]
pub struct Program {
    /// All files.
    pub sources: SourceMap,
    /// Parsed files, in load order (imports before importers).
    pub files: Vec<(u32, FileAst)>,
    /// Every diagnostic.
    pub diagnostics: Vec<Diagnostic>,
    /// The conventions the program follows (asked for or detected).
    pub dialect: Dialect,
    /// What lowering a CARLA-dialect program found (its map).
    pub carla: Option<crate::carla::CarlaInfo>,
}

/// Which OpenSCENARIO DSL conventions a program follows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Dialect {
    /// litesim's (and the seed's Foretify-style) conventions: `sut.car`,
    /// `extend top.main`, `test_config`.
    #[default]
    Litesim,
    /// CARLA scenario_runner's: `import basic.osc`, `scenario top`,
    /// `ego_vehicle`, `Path.set_map`, `drive(path)`; lowered to litesim's
    /// before elaboration (see [`crate::carla`]).
    Carla,
}

impl std::str::FromStr for Dialect {
    type Err = UnknownDialect;
    fn from_str(s: &str) -> Result<Self, UnknownDialect> {
        match s {
            "litesim" => Ok(Dialect::Litesim),
            "carla" => Ok(Dialect::Carla),
            _ => Err(UnknownDialect(s.to_string())),
        }
    }
}

/// A dialect's name that is none of litesim's.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown dialect '{0}': expected litesim or carla")]
pub struct UnknownDialect(pub String);

/// A path names an environment variable that is not set (or a `${` that
/// is not closed: then the text after the `$`).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("${0} is not set")]
pub struct UnsetVar(pub String);

/// The text declares `actor Path` (the mark of a CARLA scenario_runner
/// library): a line that is exactly that declaration.
fn declares_carla_path(text: &str) -> bool {
    text.lines().any(|l| {
        let l = l.trim();
        l.strip_prefix("actor Path")
            .is_some_and(|rest| rest.is_empty() || rest.starts_with([' ', ':', '#']))
    })
}

impl Program {
    /// Whether file `file` is part of litesim's built-in library (not one
    /// of the user's files).
    pub fn is_builtin_file(&self, file: u32) -> bool {
        self.sources
            .files
            .get(file as usize)
            .is_some_and(|f| crate::builtin::is_builtin(Path::new(&f.path)))
    }

    /// True when some diagnostic is an error.
    pub fn has_errors(&self) -> bool {
        self.diagnostics
            .iter()
            .any(|d| d.severity == crate::Severity::Error)
    }
}

/// Expands `$VAR` / `${VAR}`; the error names the unset variable.
pub fn expand_env(path: &str, env: &dyn Fn(&str) -> Option<String>) -> Result<String, UnsetVar> {
    let mut out = String::new();
    let mut rest = path;
    while let Some(i) = rest.find('$') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let (name, len) = if let Some(stripped) = after.strip_prefix('{') {
            match stripped.find('}') {
                Some(j) => (&stripped[..j], j + 2),
                None => return Err(UnsetVar(after.to_string())),
            }
        } else {
            let j = after
                .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            (&after[..j], j)
        };
        if name.is_empty() {
            out.push('$');
            rest = after;
            continue;
        }
        out.push_str(&env(name).ok_or_else(|| UnsetVar(name.to_string()))?);
        rest = &after[len..];
    }
    out.push_str(rest);
    Ok(out)
}

struct Loader<'a> {
    prog: Program,
    search: &'a [PathBuf],
    loaded: BTreeMap<PathBuf, u32>,
    stack: Vec<PathBuf>,
    env: &'a dyn Fn(&str) -> Option<String>,
    /// The dialect asked for (`None`: detect).
    dialect: Option<Dialect>,
}

impl Loader<'_> {
    fn load_file(&mut self, path: &Path, text: String) {
        let canon = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        let id = self.prog.sources.add(path.display().to_string(), text);
        self.loaded.insert(canon.clone(), id);
        self.stack.push(canon);
        let text = self.prog.sources.file(id).text.clone();
        let (toks, mut diags) = crate::lexer::lex(&text, id);
        let (ast, d2) = crate::parser::parse(toks);
        diags.extend(d2);
        self.prog.diagnostics.extend(diags);
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        for imp in &ast.imports {
            self.import(&dir, &imp.path, imp.span);
        }
        self.stack.pop();
        self.prog.files.push((id, ast));
    }

    /// Loads the built-in file at virtual path `path` (under
    /// [`crate::builtin::ROOT`]; `..` resolved) unless it is loaded already.
    fn load_builtin(&mut self, path: &Path, span: Span) {
        let path = crate::builtin::normalise(path);
        if self.stack.contains(&path) {
            self.prog.diagnostics.push(Diagnostic::error(
                "E0203",
                span,
                format!("import cycle through '{}'", path.display()),
            ));
            return;
        }
        if self.loaded.contains_key(&path) {
            return;
        }
        match crate::builtin::text_of(&path) {
            Some(text) => self.load_file(&path, text.to_string()),
            None => self.prog.diagnostics.push(Diagnostic::error(
                "E0202",
                span,
                format!("cannot find imported file '{}'", path.display()),
            )),
        }
    }

    fn import(&mut self, dir: &Path, raw: &str, span: Span) {
        // Inside litesim's built-in library, imports stay inside it.
        if crate::builtin::is_builtin(dir) {
            self.load_builtin(&dir.join(raw), span);
            return;
        }
        let expanded = match expand_env(raw, self.env) {
            Ok(p) => p,
            Err(UnsetVar(var)) => {
                self.prog.diagnostics.push(
                    Diagnostic::error(
                        "E0201",
                        span,
                        format!("environment variable ${var} in import path is not set"),
                    )
                    .with_hint(format!(
                        "set {var}, e.g. `export {var}=/path/to/litesim/osc`"
                    )),
                );
                return;
            }
        };
        // `import a.b.c` names a file a/b/c.osc.
        let rel = if expanded.ends_with(".osc") || expanded.contains('/') {
            PathBuf::from(&expanded)
        } else {
            PathBuf::from(expanded.replace('.', "/") + ".osc")
        };
        let mut candidates = Vec::new();
        if rel.is_absolute() {
            candidates.push(rel.clone());
        } else if raw.starts_with('$') {
            // `$FTX/...` with a relative $FTX means what it means in a shell:
            // relative to where the user runs litesim, not to the importing file.
            candidates.push(rel.clone());
        } else {
            candidates.push(dir.join(&rel));
            candidates.extend(self.search.iter().map(|s| s.join(&rel)));
        }
        let found = candidates.into_iter().find(|c| c.is_file());
        // CARLA's `import basic.osc`: litesim's CARLA library when there is
        // no such file. scenario_runner's own (it declares `actor Path`) is
        // read as written, after litesim's: its declarations take
        // precedence over litesim's of the same names (`crate::precedence`).
        let carla_basic = self.dialect != Some(Dialect::Litesim)
            && rel.file_name().is_some_and(|f| f == "basic.osc")
            && rel.components().count() == 1;
        if carla_basic {
            let theirs = found
                .as_ref()
                .and_then(|f| read_text(f, MAX_INPUT_BYTES).ok())
                .is_some_and(|t| declares_carla_path(&t));
            if found.is_none() || theirs {
                self.load_builtin(&crate::builtin::path_of(crate::builtin::CARLA_BASIC), span);
            }
            if found.is_none() {
                return;
            }
        }
        let Some(found) = found else {
            self.prog.diagnostics.push(
                Diagnostic::error(
                    "E0202",
                    span,
                    format!("cannot find imported file '{}'", rel.display()),
                )
                .with_hint("paths are relative to the importing file, then to each -I search path"),
            );
            return;
        };
        let canon = found.canonicalize().unwrap_or_else(|_| found.clone());
        if let Some(pos) = self.stack.iter().position(|p| *p == canon) {
            let cycle: Vec<String> = self.stack[pos..]
                .iter()
                .chain(std::iter::once(&canon))
                .map(|p| {
                    p.file_name()
                        .map_or(String::new(), |f| f.to_string_lossy().to_string())
                })
                .collect();
            self.prog.diagnostics.push(Diagnostic::error(
                "E0203",
                span,
                format!("import cycle: {}", cycle.join(" → ")),
            ));
            return;
        }
        if self.loaded.contains_key(&canon) {
            return; // parsed once
        }
        match read_text(&found, MAX_INPUT_BYTES) {
            Ok(text) => self.load_file(&found, text),
            Err(ReadError::NotUtf8 {
                line, column, byte, ..
            }) => self.prog.diagnostics.push(Diagnostic::error(
                "E0204",
                span,
                format!(
                    "'{}' is not UTF-8 text (byte 0x{byte:02X} at {}:{line}:{column})",
                    found.display(),
                    found.display()
                ),
            )),
            Err(e) => self.prog.diagnostics.push(Diagnostic::error(
                "E0205",
                span,
                format!("cannot read '{}': {}", found.display(), e.reason()),
            )),
        }
    }
}

/// Why the entry file of a program could not be read at all (everything
/// after that — imports, syntax, types — is a diagnostic of the
/// [`Program`], never an error here).
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read (missing, not a regular file, larger
    /// than [`MAX_INPUT_BYTES`]).
    #[error(transparent)]
    Read(ReadError),
    /// The file is not UTF-8 text.
    #[error("{path}:{line}:{column}: not UTF-8 text (byte 0x{byte:02X}; save the file as UTF-8)")]
    NotUtf8 {
        /// The file.
        path: String,
        /// Line of the first byte that is not UTF-8 (1-based).
        line: usize,
        /// Its column, in characters (1-based).
        column: usize,
        /// The byte.
        byte: u8,
    },
}

/// Loads `entry` and its imports. `env` looks up environment variables.
/// The dialect is detected (see [`load_with`]).
pub fn load(
    entry: &Path,
    search: &[PathBuf],
    env: &dyn Fn(&str) -> Option<String>,
) -> Result<Program, LoadError> {
    load_with(entry, search, env, None)
}

/// [`load`] in a given dialect, or detecting it (`None`): a program is
/// CARLA's when it loads litesim's CARLA library (`import basic.osc`) or
/// declares `actor Path`. A CARLA program is checked with the dialect's
/// rules and then lowered to litesim's conventions ([`crate::carla`]).
pub fn load_with(
    entry: &Path,
    search: &[PathBuf],
    env: &dyn Fn(&str) -> Option<String>,
    dialect: Option<Dialect>,
) -> Result<Program, LoadError> {
    let text = read_text(entry, MAX_INPUT_BYTES).map_err(|e| match e {
        ReadError::NotUtf8 {
            line, column, byte, ..
        } => LoadError::NotUtf8 {
            path: entry.display().to_string(),
            line,
            column,
            byte,
        },
        other => LoadError::Read(other),
    })?;
    let mut l = Loader {
        prog: Program::default(),
        search,
        loaded: BTreeMap::new(),
        stack: Vec::new(),
        env,
        dialect,
    };
    l.load_file(entry, text);
    let carla = crate::builtin::path_of(crate::builtin::CARLA_BASIC);
    if dialect == Some(Dialect::Carla) && !l.loaded.contains_key(&carla) {
        // Asked for: the dialect's names are there even without an import.
        // The entry stays file 0; the library goes first in reading order,
        // as an import would.
        let before = l.prog.files.len();
        let at = Span {
            file: 0,
            start: 0,
            end: 0,
        };
        l.load_builtin(&carla, at);
        let added = l.prog.files.len() - before;
        l.prog.files.rotate_right(added);
    }
    l.prog.dialect = dialect.unwrap_or_else(|| {
        let declared = l
            .prog
            .sources
            .files
            .iter()
            .any(|f| declares_carla_path(&f.text));
        if l.loaded.contains_key(&carla) || declared {
            Dialect::Carla
        } else {
            Dialect::Litesim
        }
    });
    // Semantic checks need every file: only run them when all parsed cleanly,
    // so that a syntax error is not followed by a cascade of unknown names.
    if !l.prog.has_errors() {
        let sem = crate::check::check(&l.prog);
        l.prog.diagnostics.extend(sem);
    }
    if l.prog.dialect == Dialect::Carla && !l.prog.has_errors() {
        let d = crate::carla::lower(&mut l.prog);
        l.prog.diagnostics.extend(d);
    }
    // Report in reading order: by file, then position (stable for equal places).
    l.prog
        .diagnostics
        .sort_by_key(|d| (d.span.file, d.span.start));
    Ok(l.prog)
}
