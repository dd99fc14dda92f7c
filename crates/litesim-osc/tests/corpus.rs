//! Tree shapes, rendering, and never-panic properties over the corpus
//! (the corpus snapshots themselves are in `snapshots.rs`).

use litesim_osc::{Severity, parse_str};

fn clean(src: &str) -> litesim_osc::ast::FileAst {
    let (sources, ast, diags) = parse_str("t.osc", src);
    let errs: Vec<String> = diags
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .map(|d| d.render(&sources))
        .collect();
    assert!(
        errs.is_empty(),
        "unexpected diagnostics for:\n{src}\n{}",
        errs.join("\n")
    );
    ast
}

/// The syntax-level programs of the snapshot corpus (`tests/corpus/ok`).
fn corpus() -> Vec<String> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/ok");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect()
}

#[test]
fn tree_shapes() {
    use litesim_osc::ast::*;
    let ast = clean(
        "scenario sut.smoke:\n    r1: one_way_road\n    do serial():\n        a: x.drive() with:\n            speed(20kph)\n    with: duration([3..6]s)\n",
    );
    let Decl::Compound {
        kind,
        name,
        members,
        ..
    } = &ast.decls[0]
    else {
        panic!()
    };
    assert_eq!(*kind, DeclKind::Scenario);
    assert_eq!(
        (
            name.actor.as_ref().unwrap().text.as_str(),
            name.name.text.as_str()
        ),
        ("sut", "smoke")
    );
    let Member::Do(d) = &members[1] else {
        panic!("{members:?}")
    };
    let DoKind::Composition {
        op, children, with, ..
    } = &d.kind
    else {
        panic!()
    };
    assert_eq!(op, "serial");
    assert_eq!(children[0].label.as_ref().unwrap().text, "a");
    assert!(matches!(with[0], Member::Modifier { .. }));
    let DoKind::Invoke { with, .. } = &children[0].kind else {
        panic!()
    };
    let Member::Modifier {
        call: Expr::Call { args, .. },
        ..
    } = &with[0]
    else {
        panic!()
    };
    assert!(
        matches!(args[0].value, Expr::Physical { value, ref unit, .. } if value == 20.0 && unit == "kph")
    );
    // Precedence: not binds looser than ==; * before +; unary minus folds into literals.
    let ast = clean("scenario s:\n    keep(not a == 1 + 2 * -3)\n");
    let Decl::Compound { members, .. } = &ast.decls[0] else {
        panic!()
    };
    let Member::Keep {
        expr: Expr::Unary { op, expr, .. },
        ..
    } = &members[0]
    else {
        panic!()
    };
    assert_eq!(op, "not");
    let Expr::Binary { op, rhs, .. } = &**expr else {
        panic!()
    };
    assert_eq!(op, "==");
    let Expr::Binary { op, rhs, .. } = &**rhs else {
        panic!()
    };
    assert_eq!(op, "+");
    let Expr::Binary { op, rhs, .. } = &**rhs else {
        panic!()
    };
    assert_eq!(op, "*");
    assert!(matches!(**rhs, Expr::Int { value: -3, .. }));
    // Range with a unit on both bounds.
    let ast = clean("scenario s:\n    keep(d in [3..6]s)\n");
    let Decl::Compound { members, .. } = &ast.decls[0] else {
        panic!()
    };
    let Member::Keep {
        expr: Expr::Binary { rhs, .. },
        ..
    } = &members[0]
    else {
        panic!()
    };
    assert!(matches!(&**rhs, Expr::Range { unit: Some(u), .. } if u == "s"));
}

#[test]
fn diagnostics_render_with_source_line_caret_and_hint() {
    let (sources, _, diags) = parse_str("smoke.osc", "scenario s:\n    speed 20kph\n");
    let text = diags[0].render(&sources);
    assert!(
        text.starts_with("smoke.osc:2:5: error[E0112]: expected a member"),
        "{text}"
    );
    assert!(
        text.contains("2 |     speed 20kph\n  |     ^^^^^\n"),
        "{text}"
    );
    assert!(text.contains("= hint: a field needs a type"), "{text}");
    let j = diags[0].to_json(&sources);
    assert_eq!(
        (j["line"].as_u64(), j["column"].as_u64(), j["code"].as_str()),
        (Some(2), Some(5), Some("E0112"))
    );
}

proptest::proptest! {
    #[test]
    fn never_panics_on_arbitrary_bytes(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..600)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = parse_str("fuzz.osc", &text);
    }

    #[test]
    fn never_panics_on_mutated_programs(i in 0usize..1000, pos in 0usize..200, ins in proptest::sample::select(vec!["(", ")", "[", "]", ":", "\n", "    ", "\t", "\"", "'", "|", "..", "-", "@", "with", "do", "\\\n", "#", "/*", "]s"])) {
        let all = corpus();
        let mut s = all[i % all.len()].clone();
        let p = pos.min(s.len());
        if s.is_char_boundary(p) {
            s.insert_str(p, ins);
        }
        let _ = parse_str("fuzz.osc", &s);
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(128))]
    /// The whole front end — imports, parse, the typed semantic pass —
    /// never panics on mutations of the corpus's checked programs (names
    /// swapped for others of the domain, units and values changed).
    #[test]
    fn checker_never_panics_on_mutated_checked_programs(
        i in 0usize..1000,
        pos in 0usize..600,
        ins in proptest::sample::select(vec![
            "x", ".", ".speed", "3s", "20kph", "-1", "it", "actor", "sut", "sut.car", "red", "vehicle",
            "one_way_road", "traffic_light", "speed(", ")", "keep(", "==", " and ", " in [1..2]m",
            "!", "vehicle_category!", "list of ", ": ", "\n    ", "inherits vehicle(it.speed)",
            "é", "aé", "vitesse_é", "ß",
        ]),
    ) {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/ok");
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| std::fs::read_to_string(p).unwrap().starts_with("import \"config.osc\""))
            .collect();
        files.sort();
        let mut s = std::fs::read_to_string(&files[i % files.len()]).unwrap();
        let p = pos.min(s.len());
        if s.is_char_boundary(p) {
            s.insert_str(p, ins);
        }
        let tmp = tempfile::Builder::new().suffix(".osc").tempfile().unwrap();
        std::fs::write(tmp.path(), &s).unwrap();
        let domain = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../osc/domain");
        let prog = litesim_osc::load(tmp.path(), &[domain], &|_| None).unwrap();
        for d in &prog.diagnostics {
            let _ = d.render(&prog.sources);
        }
    }
}
