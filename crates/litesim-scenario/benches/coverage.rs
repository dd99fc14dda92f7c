//! What coverage costs (`cargo bench -p litesim-scenario --bench coverage`):
//! the coverage example run with its ten `cover`/`record` items and
//! without them (the same test, the items' lines removed), in one run of
//! the benchmark; and folding 100,000 runs' samples into coverage.json.
#![allow(missing_docs)]

use criterion::Criterion;
use litesim_scenario::coverage::{Fold, Sample, SampleValue};
use litesim_scenario::{LoadOptions, RunOptions, prepare, run};
use std::hint::black_box;
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let path = root().join("examples/scenarios/cut_in_coverage.osc");
    let text = std::fs::read_to_string(&path).unwrap();
    let bare: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("cover(") && !l.trim_start().starts_with("record("))
        .map(|l| format!("{l}\n"))
        .collect();
    let f = tempfile::Builder::new()
        .suffix(".osc")
        .tempfile_in(root().join("examples/scenarios"))
        .unwrap();
    std::fs::write(f.path(), bare).unwrap();
    let with = prepare(&path, &LoadOptions::default()).unwrap();
    let without = prepare(f.path(), &LoadOptions::default()).unwrap();
    assert_eq!(with.test.covers.len(), 10);
    assert!(without.test.covers.is_empty());
    let opts = RunOptions {
        seed: Some(3),
        ..RunOptions::default()
    };
    let mut g = c.benchmark_group("coverage");
    g.bench_function("run_without_items", |b| {
        b.iter(|| black_box(run(&without, &mut litesim_scenario::in_process(), &opts).unwrap()))
    });
    g.bench_function("run_with_10_items", |b| {
        b.iter(|| black_box(run(&with, &mut litesim_scenario::in_process(), &opts).unwrap()))
    });
    // 100k runs × 10 samples folded (what a batch does once at its end).
    let defs: Vec<_> = with.test.covers.iter().map(|c| c.def()).collect();
    let runs: Vec<Vec<Sample>> = (0..100_000u64)
        .map(|k| {
            defs.iter()
                .map(|d| Sample {
                    item: d.name.clone(),
                    value: Some(if d.values.is_empty() {
                        SampleValue::Num(((k * 7919) % 1000) as f64 / 10.0)
                    } else {
                        SampleValue::Word(d.values[(k % 2) as usize % d.values.len()].clone())
                    }),
                    t: 10.0,
                })
                .collect()
        })
        .collect();
    g.sample_size(10);
    g.bench_function("fold_100k_runs", |b| {
        b.iter(|| {
            let mut fold = Fold::default();
            for d in &defs {
                fold.declare("t.osc", d);
            }
            for r in &runs {
                fold.add("t.osc", r);
            }
            black_box(fold.finish().holes)
        })
    });
    g.finish();
    c.final_summary();
}
