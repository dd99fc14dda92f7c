//! Front-end speed (`cargo bench -p litesim-osc --bench osc`): lex and parse
//! 10,000 lines; read, parse and semantically check the same 10,000 lines
//! against the domain library (without and with freeing the result); load the seed's smoke test with all its imports.

use criterion::Criterion;

// The allocator the `litesim` binary uses (crates/litesim-cli/src/main.rs):
// what `litesim check` costs a user.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;
use std::hint::black_box;

fn ten_thousand_lines() -> String {
    let mut s = String::new();
    let mut lines = 0;
    let mut k = 0;
    while lines < 10_000 {
        s += &format!(
            "scenario sut.s{k}:\n    r{k}: one_way_road\n    car{k}: vehicle with:\n        keep(it.max_speed <= 120kph)\n    keep(default r{k}.min_lanes >= 2 and r{k}.length in [100..500]m)\n    event near is (car{k}.speed > 10mps)\n    do serial():\n        p: parallel(overlap: equal):\n            a: sut.car.drive() with:\n                speed(20kph, run_mode: best_effort)\n                along(r{k}, at: start)\n            b: car{k}.drive() with:\n                position(time: [1.5..3]s, ahead_of: sut.car)\n        with: duration([3..6]s)\n        wait elapsed(2s)\n\n"
        );
        lines += 16;
        k += 1;
    }
    s
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let text = ten_thousand_lines();
    assert!(text.lines().count() >= 10_000);
    let (_, _, d) = litesim_osc::parse_str("big.osc", &text);
    assert!(d.is_empty(), "{d:?}");
    c.bench_function("parse_10k_lines", |b| {
        b.iter(|| litesim_osc::parse_str("big.osc", black_box(&text)))
    });
    let osc = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../osc"));
    let dir = std::env::temp_dir().join(format!("litesim-osc-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let big = dir.join("big.osc");
    std::fs::write(&big, format!("import \"config.osc\"\n{text}")).unwrap();
    let domain = [osc.join("domain")];
    let p = litesim_osc::load(&big, &domain, &|_| None).unwrap();
    assert!(p.diagnostics.is_empty(), "{:?}", &p.diagnostics[..1]);
    // What `litesim check` pays: read, lex, parse, check. The program it
    // returns is dropped outside the timed part, as the CLI never frees it
    // (it exits right after printing); the second figure includes the free.
    c.bench_function("parse_and_check_10k_lines", |b| {
        b.iter_with_large_drop(|| litesim_osc::load(&big, &domain, &|_| None).unwrap())
    });
    c.bench_function("parse_and_check_10k_lines_and_free", |b| {
        b.iter(|| litesim_osc::load(&big, &domain, &|_| None).unwrap())
    });
    let smoke = osc.join("env/basic/exe_platforms/model_ssp/test/dummy_smoke.osc");
    let ftx = osc.display().to_string();
    let env = move |n: &str| (n == "FTX").then(|| ftx.clone());
    let p = litesim_osc::load(&smoke, &[], &env).unwrap();
    assert!(!p.has_errors() && p.sources.files.len() == 10);
    c.bench_function("load_seed_smoke_with_imports", |b| {
        b.iter(|| litesim_osc::load(&smoke, &[], &env).unwrap())
    });
    c.final_summary();
    let _ = std::fs::remove_dir_all(&dir);
}
