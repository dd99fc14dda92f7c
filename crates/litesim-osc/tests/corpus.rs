//! Data-driven tests: programs that must parse clean (with a check of the
//! tree's shape) and programs with expected diagnostics (code, line:col).

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

/// Expects exactly these (code, line, col) errors, in order.
fn errors(src: &str, expect: &[(&str, usize, usize)]) {
    let (sources, _, diags) = parse_str("t.osc", src);
    let got: Vec<(String, usize, usize)> = diags
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .map(|d| {
            let (l, c) = sources.file(0).line_col(d.span.start as usize);
            (d.code.to_string(), l, c)
        })
        .collect();
    let want: Vec<(String, usize, usize)> = expect
        .iter()
        .map(|(c, l, k)| (c.to_string(), *l, *k))
        .collect();
    let rendered: Vec<String> = diags.iter().map(|d| d.render(&sources)).collect();
    assert_eq!(got, want, "for:\n{src}\n{}", rendered.join("\n"));
}

const CLEAN: &[&str] = &[
    "type speed is SI(m: 1, s: -1)\n",
    "unit kph of speed is SI(m: 1, s: -1, factor: 0.277777)\n",
    "unit kph is speed(factor: 0.277777)\n",
    "enum color: [red, green = 2, blue = 0x10]\n",
    "enum color: [\n    red,\n    green\n]\n",
    "extend color: [yellow]\n",
    "struct p:\n    x: length = 0m\n    y, z: length\n",
    "actor car inherits vehicle\n",
    "actor police inherits vehicle(vehicle_category == emergency)\n",
    "actor a:\n    v: speed with:\n        keep(it < 100kph)\n",
    "scenario sut.s:\n    do drive()\n",
    "scenario s:\n    car: vehicle\n    do car.drive() with:\n        speed(20kph)\n",
    "scenario s:\n    var n: int = 3\n",
    "scenario s:\n    var t: time = sample(x.speed, @e)\n",
    "scenario s:\n    keep(default x == 3)\n    keep(hard y < -2.5m)\n    remove_default(x)\n",
    "scenario s:\n    event go\n    event near is (gap < 10m)\n    event e2 is @go if x > 1\n    event tick is every(1s, offset: 0.5s)\n",
    "scenario s:\n    def f(a: int, b: speed = 3mps) -> int is expression a + 1\n    def g() is undefined\n    def h() is external m.h()\n",
    "scenario s:\n    cover(speed, unit: kph, range: [0..100])\n    record(x)\n",
    "scenario s:\n    on @e:\n        emit done\n        call log(\"x\")\n",
    "scenario s:\n    do serial():\n        a.drive()\n        wait elapsed(3s)\n        wait @b.end\n        emit ok\n",
    "scenario s:\n    do parallel(overlap: equal):\n        a.drive()\n        b.drive()\n    with:\n        until rise(a.speed > 30kph)\n",
    "scenario s:\n    do one_of:\n        a.drive()\n        b.drive()\n",
    "scenario s:\n    do l1: serial:\n        x: a.drive() with:\n            p: position(10m, ahead_of: b)\n            lane(same_as: b)\n",
    "modifier m of vehicle.drive:\n    d: length\n",
    "modifier car.m\n",
    "global g: int = 5\n",
    "extend top.main:\n    do s: sut.smoke() with:\n        keep(s.r1 == s.r2)\n",
    "extend test_config:\n    set map = \"$FTX/maps/circ.xodr\"\n",
    "scenario s:\n    x: float = 1.5e3\n    y: float = .5\n    z: int = a-1\n",
    "scenario s:\n    keep(a => b)\n    keep(not a == b)\n    keep(c ? 1 : 2)\n    keep(x in [1..5])\n    keep(y in [1.5..2.5]m)\n",
    "scenario s:\n    keep(v in [30..]kph)\n    keep(v in range(1, 3))\n    keep(w == -[15..20]kph)\n",
    "scenario s:\n    keep(a.b.c[2].as(vehicle).is(car))\n    keep(c == color!red)\n",
    "scenario s:\n    keep(|foot/s|(3) == x)\n    keep(s == 15|foot/s|)\n",
    "scenario s:\n    keep(x == \"a\\\"b\" + 'c' + \"\"\"multi\nline\"\"\")\n",
    "scenario s:\n    keep(f(a,\n           b) == 2)\n",
    "scenario s:\n    keep(x == \\\n         1)\n",
    "# comment only\n\n\nscenario s:   # trailing\n\n    # inside\n    x: int\n",
    "/* block /* nested */ comment */\nscenario s:\n    x: int\n",
    "import \"a.osc\"\nimport b.c\nscenario s:\n    x: int\n",
    "scenario s:\n    do t: a.drive()\n",
    "scenario s:\n\tx: int\n\ty: int\n",
    "scenario s:\n    do serial():\n        p0: parallel(overlap:equal):\n            e0: sut.car.drive() with:\n                speed(20kph, run_mode: best_effort)\n        with: duration([3..6]s, run_mode: best_effort)\n",
    "scenario s:\n    do:\n        a.drive()\n",
    "action vehicle.drive\naction person.walk inherits move\n",
    "struct s\nstruct t\n",
];

#[test]
fn clean_corpus_parses_without_errors() {
    for src in CLEAN {
        clean(src);
    }
    assert!(CLEAN.len() >= 40);
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
fn errors_are_precise_and_do_not_hide_each_other() {
    errors("scenario s:\n    x int\n", &[("E0112", 2, 5)]);
    errors("scenario s:\n    x: \n", &[("E0102", 2, 8)]);
    errors("enum c: [a, b\n", &[("E0009", 2, 1), ("E0101", 2, 1)]);
    errors("scenario s:\n  a: int\n    b: int\n", &[("E0110", 3, 5)]);
    errors(
        "scenario s:\n        a: int\n    b: int\n",
        &[("E0002", 3, 1)],
    );
    errors("scenario s:\n    keep(x == )\n", &[("E0107", 2, 15)]);
    errors(
        "scenario s:\n    keep(x == 1\n    y: int\n",
        &[("E0101", 3, 5), ("E0009", 4, 1)],
    );
    errors("scenario s:\n    do car.drive\n", &[("E0114", 2, 8)]);
    errors("scenario s:\n    do serial()\n", &[("E0101", 2, 16)]);
    errors("frobnicate x\n", &[("E0120", 1, 1)]);
    errors(
        "scenario s:\n    x: int\nimport \"a.osc\"\n",
        &[("E0122", 3, 1)],
    );
    errors(
        "scenario s:\n    keep(x == \"open)\n",
        &[("E0005", 2, 15), ("E0009", 3, 1), ("E0101", 3, 1)],
    );
    errors("scenario s:\n    keep(f(a: 1, 2))\n", &[("E0105", 2, 18)]);
    errors(
        "scenario s:\n    keep(x == 99999999999999999999999)\n",
        &[("E0007", 2, 15), ("E0107", 2, 38)],
    );
    errors("scenario s:\n    keep(x == 1) ~\n", &[("E0001", 2, 18)]);
    errors("type t is foo\n", &[("E0121", 1, 11)]);
    errors("unit u speed\n", &[("E0121", 1, 8)]);
    errors("scenario s:\n    def f() is banana\n", &[("E0111", 2, 16)]);
    errors(
        "scenario s:\n    x: int\n    y int\n    z: int\n    w int\n",
        &[("E0112", 3, 5), ("E0112", 5, 5)],
    );
    errors("/* never closed\nscenario s:\n", &[("E0003", 1, 1)]);
    errors("scenario s:\n    keep(x == [1, 2]s)\n", &[("E0106", 2, 20)]);
    errors(")\n", &[("E0008", 1, 1), ("E0120", 1, 1)]);
    errors("scenario s:\n    x: int\n  y: int\n", &[("E0002", 3, 1)]);
    errors(
        "scenario s:\n    keep(a \\ b)\n",
        &[("E0004", 2, 12), ("E0101", 2, 14)],
    );
    errors(
        "scenario s:\n    do serial():\n        a.drive() with:\n            speed(1kph)\n        with: duration(3s)\n",
        &[("E0114", 5, 9)],
    );
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
    fn never_panics_on_mutated_programs(i in 0usize..40, pos in 0usize..200, ins in proptest::sample::select(vec!["(", ")", "[", "]", ":", "\n", "    ", "\t", "\"", "'", "|", "..", "-", "@", "with", "do", "\\\n", "#", "/*", "]s"])) {
        let mut s = CLEAN[i % CLEAN.len()].to_string();
        let p = pos.min(s.len());
        if s.is_char_boundary(p) {
            s.insert_str(p, ins);
        }
        let _ = parse_str("fuzz.osc", &s);
    }
}
