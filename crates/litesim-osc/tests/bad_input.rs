//! Issue 17's bad input, as a user would meet it: a 50,000-line file, 10,000
//! levels of nesting (in an expression and in `do` blocks), invalid UTF-8
//! (the entry file and an import). Each ends in a precise diagnostic — no
//! panic, no hang. Time bounds: ≤ 1 s in a release build (the issue's
//! figure; `cargo test --release -p litesim-osc --test bad_input`), and a
//! generous hang guard in debug builds.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn domain() -> Vec<PathBuf> {
    vec![PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../osc/domain"
    ))]
}

fn limit() -> Duration {
    if cfg!(debug_assertions) {
        Duration::from_secs(30)
    } else {
        Duration::from_secs(1)
    }
}

fn load(
    path: &Path,
) -> (
    Result<litesim_osc::Program, litesim_osc::LoadError>,
    Duration,
) {
    let t = Instant::now();
    let r = litesim_osc::load(path, &domain(), &|_| None);
    (r, t.elapsed())
}

/// Every diagnostic of `p` as a user sees it.
fn rendered(p: &litesim_osc::Program) -> Vec<String> {
    p.diagnostics.iter().map(|d| d.render(&p.sources)).collect()
}

fn scenario(k: usize) -> String {
    format!(
        "scenario sut.s{k}:\n    r{k}: one_way_road\n    car{k}: vehicle\n    do serial():\n        a: sut.car.drive() with:\n            speed(20kph)\n        wait elapsed(2s)\n\n"
    )
}

#[test]
fn fifty_thousand_lines_with_an_error_at_the_end() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("import \"config.osc\"\n");
    let mut k = 0;
    while text.lines().count() < 50_000 {
        text += &scenario(k);
        k += 1;
    }
    let line = text.lines().count() + 1;
    text += "scenario sut.last:\n    do serial():\n        sut.car.drive() with:\n            speed(20 furlongs)\n";
    let path = dir.path().join("big.osc");
    std::fs::write(&path, &text).unwrap();
    let (r, took) = load(&path);
    let p = r.unwrap();
    let errors: Vec<_> = p
        .diagnostics
        .iter()
        .filter(|d| d.severity == litesim_osc::Severity::Error)
        .collect();
    assert_eq!(errors.len(), 1, "{errors:?}");
    let shown = errors[0].render(&p.sources);
    assert!(shown.contains("furlongs"), "{shown}");
    assert!(shown.contains(&format!("big.osc:{}:", line + 3)), "{shown}");
    assert!(took <= limit(), "{took:?}");
}

#[test]
fn ten_thousand_levels_of_nesting_are_refused_with_a_place() {
    let dir = tempfile::tempdir().unwrap();
    // An expression.
    let deep = format!(
        "scenario sut.deep:\n    keep(default x == {}1{})\n    x: int\n",
        "(".repeat(10_000),
        ")".repeat(10_000)
    );
    let path = dir.path().join("parens.osc");
    std::fs::write(&path, &deep).unwrap();
    let (r, took) = load(&path);
    let p = r.unwrap();
    let shown = rendered(&p);
    assert!(
        shown
            .iter()
            .any(|s| s.contains("nested too deeply") && s.contains("parens.osc:2:")),
        "{shown:?}"
    );
    assert!(took <= limit(), "{took:?}");
    // `do` blocks, one more space of indentation each (50 MB of text;
    // four spaces a level would be 200 MB).
    let mut blocks = String::from("scenario sut.deep:\n    do serial():\n");
    for level in 0..10_000 {
        blocks += &" ".repeat(8 + level);
        blocks += "serial():\n";
    }
    let path = dir.path().join("blocks.osc");
    std::fs::write(&path, &blocks).unwrap();
    let (r, took) = load(&path);
    let p = r.unwrap();
    assert!(p.has_errors());
    let shown = rendered(&p);
    assert!(
        shown.iter().any(|s| s.contains("E0191")
            && s.contains("blocks nested too deeply")
            && s.contains("blocks.osc:")),
        "{shown:?}"
    );
    assert!(took <= limit(), "{took:?}");
}

#[test]
fn invalid_utf8_names_the_file_and_the_place() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("latin1.osc");
    std::fs::write(&path, b"scenario sut.s:\n    # caf\xe9\n").unwrap();
    let (r, took) = load(&path);
    let err = r.unwrap_err();
    // Typed: where and which byte, and the same words as ever.
    assert!(
        matches!(
            err,
            litesim_osc::LoadError::NotUtf8 {
                line: 2,
                byte: 0xE9,
                ..
            }
        ),
        "{err:?}"
    );
    let e = err.to_string();
    assert!(
        e.contains("latin1.osc:2:") && e.contains("not UTF-8 text"),
        "{e}"
    );
    assert!(took <= limit());
    // The same bytes as an import: a diagnostic at the import.
    let main = dir.path().join("main.osc");
    std::fs::write(&main, "import \"latin1.osc\"\n").unwrap();
    let (r, _) = load(&main);
    let p = r.unwrap();
    let shown = rendered(&p);
    assert!(
        shown.iter().any(|s| s.contains("E0204")
            && s.contains("latin1.osc:2:")
            && s.contains("not UTF-8 text")),
        "{shown:?}"
    );
}

#[test]
fn a_missing_entry_file_is_a_typed_read_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nowhere.osc");
    let (r, _) = load(&path);
    let err = r.unwrap_err();
    assert!(
        matches!(&err, litesim_osc::LoadError::Read(litesim_core::files::ReadError::Io { path: p, source }) if p.ends_with("nowhere.osc") && source.kind() == std::io::ErrorKind::NotFound),
        "{err:?}"
    );
    assert!(err.to_string().contains("nowhere.osc: "), "{err}");
    // A directory or a device is refused before it is read.
    let (r, _) = load(dir.path());
    assert!(
        matches!(
            r,
            Err(litesim_osc::LoadError::Read(
                litesim_core::files::ReadError::NotAFile { .. }
            ))
        ),
        "{r:?}"
    );
}
