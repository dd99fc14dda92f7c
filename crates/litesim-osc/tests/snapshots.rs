//! Data-driven snapshot tests over `tests/corpus`:
//!
//! - `ok/*.osc` must load without errors; their syntax tree (spans
//!   stripped, so a snapshot reads as structure) is snapshotted;
//! - `err/*.osc` must produce at least one error; the rendered diagnostics
//!   (file:line:col, source line, caret, code, hint) are snapshotted.
//!
//! A file whose first line is `import "config.osc"` is loaded against
//! litesim's `osc/domain` library and semantically checked; any other file
//! is a syntax-level case (parsed alone, so it may use undeclared names).
//! `corpus/lib/` holds files the cases import (a rule's "across an
//! import" form); they are not cases themselves.
//! Review changed snapshots with `cargo insta review` (or set
//! `INSTA_UPDATE=always` and read the diff).

use litesim_osc::{Diagnostic, Severity, SourceMap, parse_str};
use std::path::{Path, PathBuf};

const SEMANTIC: &str = "import \"config.osc\"";

fn domain() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../osc/domain"))
}

/// Loads a corpus file the way its first line asks; returns the tree of
/// the file itself, the sources and all diagnostics.
fn load(path: &Path) -> (serde_json::Value, SourceMap, Vec<Diagnostic>) {
    let text = std::fs::read_to_string(path).unwrap();
    // Relative names keep rendered diagnostics machine-independent.
    let name = format!(
        "{}/{}",
        path.parent()
            .unwrap()
            .file_name()
            .unwrap()
            .to_string_lossy(),
        path.file_name().unwrap().to_string_lossy()
    );
    if text.starts_with(SEMANTIC) {
        let mut prog = litesim_osc::load(path, &[domain()], &|_| None).unwrap();
        let root = prog.files.iter().find(|(id, _)| *id == 0).unwrap();
        let tree = serde_json::to_value(&root.1).unwrap();
        prog.sources.files[0].path = name;
        // Library files too (notes point into them): machine-independent,
        // named by their folder (`domain/`, the corpus's own `lib/`).
        for f in prog.sources.files.iter_mut().skip(1) {
            let p = Path::new(&f.path);
            let name = |p: Option<&Path>| {
                p.and_then(Path::file_name)
                    .map_or(String::new(), |n| n.to_string_lossy().into_owned())
            };
            f.path = format!("{}/{}", name(p.parent()), name(Some(p)));
        }
        (tree, prog.sources, prog.diagnostics)
    } else {
        let (sources, ast, diags) = parse_str(&name, &text);
        (serde_json::to_value(&ast).unwrap(), sources, diags)
    }
}

fn strip_spans(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.remove("span");
            m.values_mut().for_each(strip_spans);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip_spans),
        _ => {}
    }
}

#[test]
fn ok_corpus_loads_clean_and_matches_tree_snapshots() {
    insta::glob!("corpus/ok/*.osc", |path| {
        let (mut tree, sources, diags) = load(path);
        let errs: Vec<String> = diags
            .iter()
            .filter(|d| d.severity == Severity::Error)
            .map(|d| d.render(&sources))
            .collect();
        assert!(errs.is_empty(), "{}:\n{}", path.display(), errs.join("\n"));
        strip_spans(&mut tree);
        insta::assert_snapshot!(serde_json::to_string_pretty(&tree).unwrap());
    });
}

#[test]
fn err_corpus_reports_errors_matching_snapshots() {
    insta::glob!("corpus/err/*.osc", |path| {
        let (_, sources, diags) = load(path);
        assert!(
            diags.iter().any(|d| d.severity == Severity::Error),
            "{} should have errors",
            path.display()
        );
        let text: Vec<String> = diags.iter().map(|d| d.render(&sources)).collect();
        insta::assert_snapshot!(text.join("\n"));
    });
}

#[test]
fn corpus_is_large_enough() {
    let count = |d: &str| {
        std::fs::read_dir(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/corpus")
                .join(d),
        )
        .unwrap()
        .count()
    };
    assert!(count("ok") >= 100, "ok corpus has {}", count("ok"));
    assert!(count("err") >= 40, "err corpus has {}", count("err"));
}
