//! The reader: the XML tree of `litesim_map::xml` walked element by
//! element into [`crate::model`], each element checked as the schema says —
//! its attributes (required ones present, unknown ones refused), its child
//! elements (unknown ones refused, a choice made exactly once), enumerated
//! values, numbers — with parameters and expressions resolved on the way.
//!
//! Every error names `file:line:col`, the element path and what was
//! expected. The walk descends only into elements it knows, so a hostile
//! nesting stops at its first unknown element; the tree itself is built
//! without recursion.

mod actions;
mod conditions;
mod entities;
mod positions;
mod storyboard;

use crate::error::XoscError;
use crate::model::*;
use litesim_map::xml::{Node, Stream, Tree};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Files larger than this are refused before parsing: no scenario,
/// catalog or distribution comes near it, and a reader must not take a
/// machine's memory for a hostile file.
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// A parameter's declared type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ParamType {
    Bool,
    DateTime,
    Double,
    Int,
    UInt,
    String,
}

/// One scope of parameter declarations.
type Scope = BTreeMap<String, (ParamType, String)>;

/// The reading context of one file.
pub(crate) struct Cx<'a> {
    pub(crate) text: &'a str,
    line_starts: Vec<usize>,
    pub(crate) file: String,
    pub(crate) dir: PathBuf,
    path: Vec<String>,
    scopes: Vec<Scope>,
    pub(crate) version: (u32, u32),
    /// `CatalogLocations`: catalog type → directory.
    pub(crate) catalog_dirs: BTreeMap<String, PathBuf>,
    /// Catalog files already read, by directory: (catalog name, file).
    pub(crate) catalog_files: BTreeMap<PathBuf, Vec<(String, PathBuf)>>,
    /// Catalog references being resolved (a cycle is an error).
    pub(crate) resolving: Vec<String>,
}

type R<T> = Result<T, XoscError>;

impl<'a> Cx<'a> {
    pub(crate) fn new(text: &'a str, file: &Path) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(
            text.bytes()
                .enumerate()
                .filter(|(_, b)| *b == b'\n')
                .map(|(i, _)| i + 1),
        );
        Cx {
            text,
            line_starts,
            file: file.display().to_string(),
            dir: file.parent().map(Path::to_path_buf).unwrap_or_default(),
            path: Vec::new(),
            scopes: vec![Scope::new()],
            version: (1, 3),
            catalog_dirs: BTreeMap::new(),
            catalog_files: BTreeMap::new(),
            resolving: Vec::new(),
        }
    }

    /// Line and column of a byte offset.
    pub(crate) fn pos(&self, at: usize) -> (u32, u32) {
        let at = at.min(self.text.len());
        let line = self.line_starts.partition_point(|&l| l <= at);
        let start = self.line_starts[line - 1];
        let col = self
            .text
            .get(start..at)
            .map_or(1, |t| t.chars().count() + 1);
        (line as u32, col as u32)
    }

    /// An error at `n`.
    pub(crate) fn err(&self, n: Node<'_, '_>, message: impl Into<String>) -> XoscError {
        let (line, col) = self.pos(n.start());
        let mut path = self.path.join("/");
        if self
            .path
            .last()
            .is_none_or(|p| p.split('[').next() != Some(n.name()))
        {
            if !path.is_empty() {
                path.push('/');
            }
            path.push_str(n.name());
        }
        XoscError {
            file: self.file.clone(),
            line,
            col,
            path,
            message: message.into(),
        }
    }

    /// Runs `f` with `n` (labelled by its `name` attribute, when it has
    /// one) on the element path.
    pub(crate) fn within<T>(&mut self, n: Node<'_, '_>, f: impl FnOnce(&mut Self) -> R<T>) -> R<T> {
        let label = match n.attribute("name") {
            Some(name) => format!("{}[{name}]", n.name()),
            None => n.name().to_string(),
        };
        self.path.push(label);
        let r = f(self);
        self.path.pop();
        r
    }

    /// Refuses attributes other than `allowed`.
    pub(crate) fn attrs(&self, n: Node<'_, '_>, allowed: &[&str]) -> R<()> {
        for (k, _) in n.attributes() {
            if !allowed.contains(&k) {
                return Err(self.err(
                    n,
                    format!(
                        "unknown attribute '{k}' on {} (expected {})",
                        n.name(),
                        list(allowed)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Refuses child elements other than `allowed`.
    pub(crate) fn children(&self, n: Node<'_, '_>, allowed: &[&str]) -> R<()> {
        for c in n.elements() {
            if !allowed.contains(&c.name()) {
                return Err(self.err(
                    c,
                    format!(
                        "unexpected element <{}> in <{}> (expected {})",
                        c.name(),
                        n.name(),
                        if allowed.is_empty() {
                            "no child elements".to_string()
                        } else {
                            list(allowed)
                        }
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The child element `name`, if there is one (a second is an error).
    pub(crate) fn opt_child<'t>(&self, n: Node<'t, 'a>, name: &str) -> R<Option<Node<'t, 'a>>> {
        let mut it = n.elements().filter(|c| c.name() == name);
        let first = it.next();
        if let Some(second) = it.next() {
            return Err(self.err(second, format!("<{}> holds at most one <{name}>", n.name())));
        }
        Ok(first)
    }

    /// The child element `name`, required.
    pub(crate) fn child<'t>(&self, n: Node<'t, 'a>, name: &str) -> R<Node<'t, 'a>> {
        self.opt_child(n, name)?
            .ok_or_else(|| self.err(n, format!("<{}> needs a <{name}> element", n.name())))
    }

    /// Exactly one child element, one of `choices`.
    pub(crate) fn choice<'t>(&self, n: Node<'t, 'a>, choices: &[&str]) -> R<Node<'t, 'a>> {
        self.children(n, choices)?;
        let mut it = n.elements();
        let Some(first) = it.next() else {
            return Err(self.err(n, format!("<{}> needs one of {}", n.name(), list(choices))));
        };
        if let Some(second) = it.next() {
            return Err(self.err(
                second,
                format!(
                    "<{}> holds one of {}, not both <{}> and <{}>",
                    n.name(),
                    list(choices),
                    first.name(),
                    second.name()
                ),
            ));
        }
        Ok(first)
    }

    /// An attribute's value with `$param` and `${expr}` resolved.
    pub(crate) fn opt(&self, n: Node<'_, '_>, name: &str) -> R<Option<String>> {
        let Some(raw) = n.attribute(name) else {
            return Ok(None);
        };
        self.resolve(raw)
            .map(Some)
            .map_err(|m| self.err(n, format!("{name}=\"{raw}\": {m}")))
    }

    /// A required attribute's value.
    pub(crate) fn req(&self, n: Node<'_, '_>, name: &str) -> R<String> {
        self.opt(n, name)?
            .ok_or_else(|| self.err(n, format!("<{}> needs the attribute '{name}'", n.name())))
    }

    /// A number attribute, if given.
    pub(crate) fn opt_num(&self, n: Node<'_, '_>, name: &str) -> R<Option<f64>> {
        let Some(v) = self.opt(n, name)? else {
            return Ok(None);
        };
        match v.trim().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(Some(x)),
            _ => Err(self.err(
                n,
                format!("{name}=\"{v}\" is not a number (a double was expected)"),
            )),
        }
    }

    /// A required number attribute.
    pub(crate) fn num(&self, n: Node<'_, '_>, name: &str) -> R<f64> {
        self.opt_num(n, name)?
            .ok_or_else(|| self.err(n, format!("<{}> needs the attribute '{name}'", n.name())))
    }

    /// A number attribute that may not be negative.
    pub(crate) fn non_neg(&self, n: Node<'_, '_>, name: &str) -> R<f64> {
        let v = self.num(n, name)?;
        if v < 0.0 {
            return Err(self.err(
                n,
                format!("{name}=\"{v}\" is negative (at least 0 expected)"),
            ));
        }
        Ok(v)
    }

    /// An integer attribute, if given.
    pub(crate) fn opt_int(&self, n: Node<'_, '_>, name: &str) -> R<Option<i64>> {
        let Some(v) = self.opt(n, name)? else {
            return Ok(None);
        };
        let t = v.trim();
        t.parse::<i64>()
            .ok()
            .or_else(|| {
                // An expression's result is a double: an integral one is
                // an integer.
                t.parse::<f64>()
                    .ok()
                    .filter(|x| x.fract() == 0.0 && x.abs() < 9e15)
                    .map(|x| x as i64)
            })
            .map(Some)
            .ok_or_else(|| self.err(n, format!("{name}=\"{v}\" is not an integer")))
    }

    /// A boolean attribute, if given.
    pub(crate) fn opt_bool(&self, n: Node<'_, '_>, name: &str) -> R<Option<bool>> {
        let Some(v) = self.opt(n, name)? else {
            return Ok(None);
        };
        match v.trim() {
            "true" | "1" => Ok(Some(true)),
            "false" | "0" => Ok(Some(false)),
            _ => Err(self.err(
                n,
                format!("{name}=\"{v}\" is not a boolean (true or false expected)"),
            )),
        }
    }

    /// An enumerated attribute: one of `values`.
    pub(crate) fn enumer(&self, n: Node<'_, '_>, name: &str, values: &[&str]) -> R<Option<String>> {
        let Some(v) = self.opt(n, name)? else {
            return Ok(None);
        };
        if values.contains(&v.as_str()) {
            Ok(Some(v))
        } else {
            Err(self.err(n, format!("{name}=\"{v}\" is not one of {}", list(values))))
        }
    }

    /// A required enumerated attribute.
    pub(crate) fn req_enum(&self, n: Node<'_, '_>, name: &str, values: &[&str]) -> R<String> {
        self.enumer(n, name, values)?.ok_or_else(|| {
            self.err(
                n,
                format!(
                    "<{}> needs the attribute '{name}' (one of {})",
                    n.name(),
                    list(values)
                ),
            )
        })
    }

    /// Refuses an element the file's version does not have.
    pub(crate) fn since(&self, n: Node<'_, '_>, what: &str, minor: u32) -> R<()> {
        if self.version.1 < minor {
            return Err(self.err(
                n,
                format!(
                    "{what} is OpenSCENARIO 1.{minor} and later; the file's FileHeader says {}.{}",
                    self.version.0, self.version.1
                ),
            ));
        }
        Ok(())
    }

    /// Resolves `$name` (the whole value) and `${expr}`.
    pub(crate) fn resolve(&self, raw: &str) -> Result<String, String> {
        if let Some(inner) = raw.strip_prefix("${").and_then(|r| r.strip_suffix('}')) {
            if self.version.1 < 1 {
                return Err(format!(
                    "expressions are OpenSCENARIO 1.1 and later; the file's FileHeader says {}.{}",
                    self.version.0, self.version.1
                ));
            }
            let v = crate::expr::eval(inner, &|p| self.param_num(p))?;
            return Ok(format_num(v));
        }
        if let Some(name) = raw.strip_prefix('$')
            && !name.is_empty()
            && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
        {
            return self.param(name).map(|(_, v)| v.clone());
        }
        Ok(raw.to_string())
    }

    fn param(&self, name: &str) -> Result<&(ParamType, String), String> {
        self.scopes
            .iter()
            .rev()
            .find_map(|s| s.get(name))
            .ok_or_else(|| format!("unknown parameter ${name} (not declared in any enclosing ParameterDeclarations)"))
    }

    fn param_num(&self, name: &str) -> Result<f64, String> {
        let (ty, v) = self.param(name)?;
        match ty {
            ParamType::Bool => Ok(f64::from(v == "true" || v == "1")),
            ParamType::String | ParamType::DateTime => Err(format!(
                "${name} is a {} parameter; expressions take numbers and booleans",
                if *ty == ParamType::String {
                    "string"
                } else {
                    "dateTime"
                }
            )),
            _ => v
                .trim()
                .parse()
                .map_err(|_| format!("${name} = \"{v}\" is not a number")),
        }
    }

    /// Reads `ParameterDeclarations` into a new innermost scope (the caller
    /// pops it with [`Cx::pop_scope`]); `overrides` replace declared values
    /// (a catalog reference's assignments, the command line's).
    pub(crate) fn push_scope(
        &mut self,
        decls: Option<Node<'_, '_>>,
        overrides: &[(String, String)],
    ) -> R<()> {
        self.scopes.push(Scope::new());
        let Some(decls) = decls else {
            return self.check_overrides(None, overrides);
        };
        self.children(decls, &["ParameterDeclaration"])?;
        let names: Vec<String> = decls
            .elements()
            .filter_map(|d| d.attribute("name").map(String::from))
            .collect();
        for (k, d) in decls.elements().enumerate() {
            self.attrs(d, &["name", "parameterType", "value"])?;
            self.children(d, &["ConstraintGroup"])?;
            let name = d
                .attribute("name")
                .ok_or_else(|| self.err(d, "<ParameterDeclaration> needs the attribute 'name'"))?
                .to_string();
            if self.scopes.last().is_some_and(|s| s.contains_key(&name)) {
                return Err(self.err(d, format!("parameter '{name}' is declared twice")));
            }
            let ty = match self
                .req_enum(
                    d,
                    "parameterType",
                    &[
                        "boolean",
                        "dateTime",
                        "double",
                        "integer",
                        "int",
                        "string",
                        "unsignedInt",
                        "unsignedShort",
                    ],
                )?
                .as_str()
            {
                "boolean" => ParamType::Bool,
                "dateTime" => ParamType::DateTime,
                "double" => ParamType::Double,
                "int" if self.version.1 < 2 => {
                    return Err(self.err(
                        d,
                        format!(
                            "parameterType int is OpenSCENARIO 1.2 and later (integer before); the file's FileHeader says 1.{}",
                            self.version.1
                        ),
                    ));
                }
                "integer" | "int" => ParamType::Int,
                "unsignedInt" | "unsignedShort" => ParamType::UInt,
                _ => ParamType::String,
            };
            let raw = d
                .attribute("value")
                .ok_or_else(|| self.err(d, "<ParameterDeclaration> needs the attribute 'value'"))?;
            // A reference to a parameter declared later in this block (or
            // to itself): declarations resolve in order, so that is a cycle
            // or a forward reference.
            for later in &names[k..] {
                let r = format!("${later}");
                if raw == r || (raw.starts_with("${") && refers_to(raw, later)) {
                    return Err(self.err(
                        d,
                        format!(
                            "parameter '{name}' refers to ${later}, declared {} (parameters resolve in declaration order: a cycle or a forward reference)",
                            if *later == name { "by itself" } else { "after it" }
                        ),
                    ));
                }
            }
            let value = match overrides.iter().find(|(n, _)| *n == name) {
                Some((_, v)) => v.clone(),
                None => self
                    .resolve(raw)
                    .map_err(|m| self.err(d, format!("value=\"{raw}\": {m}")))?,
            };
            check_type(ty, &value).map_err(|m| self.err(d, format!("parameter '{name}': {m}")))?;
            self.scopes
                .last_mut()
                .expect("pushed above")
                .insert(name, (ty, value));
        }
        self.check_overrides(Some(decls), overrides)
    }

    fn check_overrides(
        &self,
        decls: Option<Node<'_, '_>>,
        overrides: &[(String, String)],
    ) -> R<()> {
        let scope = self.scopes.last().expect("pushed");
        for (name, _) in overrides {
            if !scope.contains_key(name) {
                let msg = format!(
                    "a value is assigned to parameter '{name}', which is not declared here (declared: {})",
                    if scope.is_empty() {
                        "none".to_string()
                    } else {
                        scope.keys().cloned().collect::<Vec<_>>().join(", ")
                    }
                );
                return Err(match decls {
                    Some(d) => self.err(d, msg),
                    None => XoscError {
                        file: self.file.clone(),
                        line: 0,
                        col: 0,
                        path: self.path.join("/"),
                        message: msg,
                    },
                });
            }
        }
        Ok(())
    }

    pub(crate) fn pop_scope(&mut self) {
        self.scopes.pop();
    }

    /// The global parameters and their values.
    pub(crate) fn globals(&self) -> Vec<(String, String)> {
        self.scopes
            .get(1)
            .map(|s| s.iter().map(|(k, (_, v))| (k.clone(), v.clone())).collect())
            .unwrap_or_default()
    }
}

/// Whether the expression text mentions `$name` as a whole token.
fn refers_to(expr: &str, name: &str) -> bool {
    let pat = format!("${name}");
    expr.match_indices(&pat).any(|(i, _)| {
        expr[i + pat.len()..]
            .chars()
            .next()
            .is_none_or(|c| !(c.is_ascii_alphanumeric() || c == '_'))
    })
}

/// A parameter value of its declared type.
fn check_type(ty: ParamType, v: &str) -> Result<(), String> {
    let t = v.trim();
    let ok = match ty {
        ParamType::Bool => matches!(t, "true" | "false" | "1" | "0"),
        ParamType::Double => t.parse::<f64>().is_ok_and(f64::is_finite),
        ParamType::Int => {
            t.parse::<i64>().is_ok() || t.parse::<f64>().is_ok_and(|x| x.fract() == 0.0)
        }
        ParamType::UInt => {
            t.parse::<u64>().is_ok() || t.parse::<f64>().is_ok_and(|x| x.fract() == 0.0 && x >= 0.0)
        }
        ParamType::String | ParamType::DateTime => true,
    };
    if ok {
        Ok(())
    } else {
        Err(format!("\"{v}\" is not a value of its type {ty:?}"))
    }
}

/// An expression's result as attribute text: integral values without a
/// fraction (so they read back as integers).
fn format_num(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 9e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

/// `a, b or c`.
pub(crate) fn list(items: &[&str]) -> String {
    match items {
        [] => String::new(),
        [one] => one.to_string(),
        [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
    }
}

/// Reads a file's text, refusing what is too large or not UTF-8.
pub(crate) fn read_text(path: &Path, what: &str) -> R<String> {
    let shown = path.display().to_string();
    let meta = std::fs::metadata(path)
        .map_err(|e| XoscError::file(&shown, format!("cannot read the {what} {shown}: {e}")))?;
    if meta.len() > MAX_FILE_BYTES {
        return Err(XoscError::file(
            &shown,
            format!(
                "the {what} is {} MB, more than the {} MB a file may have",
                meta.len() >> 20,
                MAX_FILE_BYTES >> 20
            ),
        ));
    }
    let bytes = std::fs::read(path)
        .map_err(|e| XoscError::file(&shown, format!("cannot read the {what} {shown}: {e}")))?;
    String::from_utf8(bytes)
        .map_err(|e| XoscError::file(&shown, format!("the {what} is not UTF-8 text: {e}")))
}

/// Opens a document: the stream over its top-level elements and its root.
pub(crate) fn open<'a>(cx: &Cx<'a>) -> R<(Stream<'a>, Tree<'a>)> {
    Stream::open(cx.text).map_err(|e| {
        let (line, col) = cx.pos(e.pos);
        XoscError {
            file: cx.file.clone(),
            line,
            col,
            path: String::new(),
            message: e.message,
        }
    })
}

/// The next top-level element into `tree`.
pub(crate) fn next<'a>(cx: &Cx<'a>, s: &mut Stream<'a>, tree: &mut Tree<'a>) -> R<bool> {
    s.next(tree).map_err(|e| {
        let (line, col) = cx.pos(e.pos);
        XoscError {
            file: cx.file.clone(),
            line,
            col,
            path: cx.path.join("/"),
            message: e.message,
        }
    })
}

/// Reads a scenario file, with `overrides` for its global parameters.
pub fn scenario(path: &Path, overrides: &[(String, String)]) -> R<Scenario> {
    let text = read_text(path, "scenario")?;
    scenario_text(&text, path, overrides)
}

/// Reads a scenario from its text (`path` names it and anchors relative
/// paths).
pub fn scenario_text(text: &str, path: &Path, overrides: &[(String, String)]) -> R<Scenario> {
    let mut cx = Cx::new(text, path);
    let (mut stream, root) = open(&cx)?;
    let r = root.root();
    if r.name() != "OpenSCENARIO" {
        return Err(cx.err(
            r,
            format!("the root element is <{}>, not <OpenSCENARIO>", r.name()),
        ));
    }
    cx.path.push("OpenSCENARIO".into());
    let mut sc = Scenario {
        file: path.to_path_buf(),
        version: (1, 3),
        description: String::new(),
        parameters: Vec::new(),
        variables: Vec::new(),
        map: None,
        signal_controllers: Vec::new(),
        entities: Vec::new(),
        selections: Vec::new(),
        init: Vec::new(),
        stories: Vec::new(),
        stop_trigger: None,
    };
    let mut tree = Tree::new(text);
    let mut seen: Vec<&'static str> = Vec::new();
    let mut params_read = false;
    while next(&cx, &mut stream, &mut tree)? {
        let n = tree.root();
        let name: &'static str = match n.name() {
            "FileHeader" => "FileHeader",
            "ParameterDeclarations" => "ParameterDeclarations",
            "VariableDeclarations" => "VariableDeclarations",
            "MonitorDeclarations" => "MonitorDeclarations",
            "CatalogLocations" => "CatalogLocations",
            "RoadNetwork" => "RoadNetwork",
            "Entities" => "Entities",
            "Storyboard" => "Storyboard",
            "Catalog" => {
                return Err(cx.err(n, "this is a catalog file, not a scenario (a scenario names it in CatalogLocations)"));
            }
            "ParameterValueDistribution" => {
                return Err(cx.err(n, "this is a parameter distribution file: run it with `litesim batch`, which expands it into the scenario's variations"));
            }
            other => {
                return Err(cx.err(
                    n,
                    format!("unexpected element <{other}> in <OpenSCENARIO> (expected FileHeader, ParameterDeclarations, CatalogLocations, RoadNetwork, Entities and Storyboard)"),
                ));
            }
        };
        if seen.contains(&name) {
            return Err(cx.err(n, format!("<OpenSCENARIO> holds one <{name}>")));
        }
        seen.push(name);
        if name != "FileHeader" && !seen.contains(&"FileHeader") {
            return Err(cx.err(n, "<FileHeader> must come first"));
        }
        if name != "FileHeader" && name != "ParameterDeclarations" && !params_read {
            cx.push_scope(None, overrides)?;
            params_read = true;
        }
        match name {
            "FileHeader" => {
                cx.version = header(&cx, n)?;
                sc.version = cx.version;
                sc.description = cx.req(n, "description")?;
            }
            "ParameterDeclarations" => {
                cx.within(n, |cx| cx.push_scope(Some(n), overrides))?;
                params_read = true;
            }
            "VariableDeclarations" => {
                cx.since(n, "VariableDeclarations", 2)?;
                cx.children(n, &["VariableDeclaration"])?;
                for v in n.elements() {
                    cx.attrs(v, &["name", "variableType", "value"])?;
                    cx.req_enum(
                        v,
                        "variableType",
                        &[
                            "boolean",
                            "dateTime",
                            "double",
                            "int",
                            "string",
                            "unsignedInt",
                            "unsignedShort",
                        ],
                    )?;
                    sc.variables.push((cx.req(v, "name")?, cx.req(v, "value")?));
                }
            }
            "MonitorDeclarations" => {
                return Err(cx.err(
                    n,
                    "MonitorDeclarations (1.3 monitors) are not supported by litesim's player",
                ));
            }
            "CatalogLocations" => cx.within(n, |cx| catalog_locations(cx, n))?,
            "RoadNetwork" => cx.within(n, |cx| road_network(cx, n, &mut sc))?,
            "Entities" => cx.within(n, |cx| entities::entities(cx, n, &mut sc))?,
            _ => cx.within(n, |cx| storyboard::storyboard(cx, n, &mut sc))?,
        }
    }
    for must in ["FileHeader", "RoadNetwork", "Entities", "Storyboard"] {
        if !seen.contains(&must) {
            return Err(cx.err(r, format!("<OpenSCENARIO> needs a <{must}> element")));
        }
    }
    sc.parameters = cx.globals();
    storyboard::check_references(&cx, r, &sc)?;
    Ok(sc)
}

fn catalog_locations(cx: &mut Cx<'_>, n: Node<'_, '_>) -> R<()> {
    const KINDS: [&str; 8] = [
        "VehicleCatalog",
        "ControllerCatalog",
        "PedestrianCatalog",
        "MiscObjectCatalog",
        "EnvironmentCatalog",
        "ManeuverCatalog",
        "TrajectoryCatalog",
        "RouteCatalog",
    ];
    cx.children(n, &KINDS)?;
    for c in n.elements() {
        cx.children(c, &["Directory"])?;
        let d = cx.child(c, "Directory")?;
        cx.attrs(d, &["path"])?;
        let p = cx.req(d, "path")?;
        let dir = cx.dir.join(&p);
        cx.catalog_dirs.insert(c.name().to_string(), dir);
    }
    Ok(())
}

fn road_network(cx: &mut Cx<'_>, n: Node<'_, '_>, sc: &mut Scenario) -> R<()> {
    cx.children(
        n,
        &["LogicFile", "SceneGraphFile", "TrafficSignals", "UsedArea"],
    )?;
    if let Some(l) = cx.opt_child(n, "LogicFile")? {
        cx.attrs(l, &["filepath"])?;
        let p = cx.req(l, "filepath")?;
        let path = cx.dir.join(&p);
        if !path.is_file() {
            return Err(cx.err(
                l,
                format!("the map {p} is not there (tried {})", path.display()),
            ));
        }
        sc.map = Some(path);
    }
    if let Some(t) = cx.opt_child(n, "TrafficSignals")? {
        cx.children(t, &["TrafficSignalController"])?;
        for c in t.elements() {
            cx.attrs(c, &["name", "delay", "reference"])?;
            cx.children(c, &["Phase"])?;
            let mut phases = Vec::new();
            for p in c.elements() {
                cx.attrs(p, &["name", "duration"])?;
                cx.children(p, &["TrafficSignalState", "TrafficSignalGroupState"])?;
                let mut states = Vec::new();
                for s in p.elements().filter(|s| s.name() == "TrafficSignalState") {
                    cx.attrs(s, &["trafficSignalId", "state"])?;
                    states.push((cx.req(s, "trafficSignalId")?, cx.req(s, "state")?));
                }
                phases.push(SignalPhase {
                    name: cx.req(p, "name")?,
                    duration: cx.non_neg(p, "duration")?,
                    states,
                });
            }
            sc.signal_controllers.push(SignalController {
                name: cx.req(c, "name")?,
                delay: cx.opt_num(c, "delay")?.unwrap_or(0.0),
                phases,
            });
        }
    }
    Ok(())
}

/// `file:line:col` of `n`.
pub(crate) fn at(cx: &Cx<'_>, n: Node<'_, '_>) -> At {
    let (l, c) = cx.pos(n.start());
    format!("{}:{l}:{c}", cx.file)
}

/// `FileHeader`: the version it claims (1.0 to 1.3).
fn header(cx: &Cx<'_>, n: Node<'_, '_>) -> R<(u32, u32)> {
    cx.attrs(
        n,
        &["revMajor", "revMinor", "date", "description", "author"],
    )?;
    cx.children(n, &["License", "Properties"])?;
    let major = cx
        .opt_int(n, "revMajor")?
        .ok_or_else(|| cx.err(n, "<FileHeader> needs the attribute 'revMajor'"))?;
    let minor = cx
        .opt_int(n, "revMinor")?
        .ok_or_else(|| cx.err(n, "<FileHeader> needs the attribute 'revMinor'"))?;
    for a in ["date", "description", "author"] {
        cx.req(n, a)?;
    }
    if major != 1 || !(0..=3).contains(&minor) {
        return Err(cx.err(
            n,
            format!("OpenSCENARIO {major}.{minor} is not supported (1.0 to 1.3 are)"),
        ));
    }
    Ok((1, minor as u32))
}
