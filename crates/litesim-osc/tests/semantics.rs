//! Semantic checks against litesim's osc/ domain model.

use std::path::PathBuf;

fn check(src: &str) -> Vec<(String, usize, usize)> {
    // A folder per call: tests run in parallel.
    static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = N.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let dir = std::env::temp_dir().join(format!("litesim-osc-sem-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("t.osc");
    std::fs::write(&file, format!("import \"config.osc\"\n{src}")).unwrap();
    let domain = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../osc/domain"));
    let prog = litesim_osc::load(&file, &[domain], &|_| None).unwrap();
    let out = prog
        .diagnostics
        .iter()
        .map(|d| {
            let (l, c) = prog
                .sources
                .file(d.span.file)
                .line_col(d.span.start as usize);
            (d.code.to_string(), l, c)
        })
        .collect();
    std::fs::remove_dir_all(&dir).unwrap();
    out
}

fn expect(src: &str, want: &[(&str, usize, usize)]) {
    let got = check(src);
    let want: Vec<(String, usize, usize)> = want
        .iter()
        .map(|(c, l, k)| (c.to_string(), *l, *k))
        .collect();
    assert_eq!(got, want, "for:\n{src}");
}

#[test]
fn clean_programs() {
    expect(
        "scenario sut.s:\n    r: one_way_road\n    c: vehicle\n    do c.drive() with:\n        speed(20kph)\n        speed([10..20]mps, run_mode: best_effort)\n        along(r, at: start)\n",
        &[],
    );
    expect(
        "extend top.main:\n    do s: sut.s2()\nscenario sut.s2:\n    do sut.car.drive() with:\n        duration([3..6]s)\n",
        &[],
    );
    expect(
        "struct p:\n    d: length = 3km\n    t: time = 200ms\n    keep(d > 10m)\n",
        &[],
    );
    expect(
        "actor bus inherits vehicle:\n    keep(max_speed < 100kph)\n",
        &[],
    );
}

#[test]
fn unknown_names_and_wrong_dimensions() {
    // Line numbers count the import line added by `check`.
    expect("struct p:\n    x: lenght\n", &[("E0301", 3, 8)]);
    expect("struct p:\n    x: length = 3kps\n", &[("E0302", 3, 17)]);
    expect("struct p:\n    x: length = 3s\n", &[("E0303", 3, 17)]);
    expect(
        "scenario s:\n    c: vehicle\n    do c.drive() with:\n        speed(3s)\n",
        &[("E0303", 5, 15)],
    );
    expect(
        "scenario s:\n    c: vehicle\n    do c.drive() with:\n        speed(3kph, runmode: strict)\n",
        &[("E0308", 5, 21)],
    );
    expect(
        "scenario s:\n    c: vehicle\n    do c.drive() with:\n        velocity(3kph)\n",
        &[("E0304", 5, 9)],
    );
    expect(
        "scenario s:\n    c: vehicle\n    do c.teleport()\n",
        &[("E0309", 4, 10)],
    );
    expect("actor a inherits nothing_here\n", &[("E0305", 2, 18)]);
    expect("extend no_such:\n    x: int\n", &[("E0306", 2, 8)]);
    expect("struct twice\nstruct twice\n", &[("E0307", 3, 8)]);
    expect("struct p:\n    keep(3m < 2s)\n", &[("E0303", 3, 10)]);
}
