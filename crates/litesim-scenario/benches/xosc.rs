//! An OpenSCENARIO XML run's cost (`cargo bench -p litesim-scenario
//! --bench xosc`): the two-vehicle cut-in (`examples/xosc/cut_in.xosc`),
//! 20 s at 10 ms steps, 50 runs one after the other on one core — the
//! storyboard driving both cars, and the reference ACC driving the ego.
//! The bound is 2 ms per run.
#![allow(missing_docs)]

use criterion::Criterion;
use litesim_scenario::sut::SutChoice;
use litesim_scenario::{LoadOptions, Prepared, RunOptions, prepare};
use std::hint::black_box;

#[path = "../tests/common/mod.rs"]
mod common;

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let path = common::root().join("examples/xosc/cut_in.xosc");
    let prep: Result<Prepared, String> = Ok(prepare(&path, &LoadOptions::default()).unwrap());
    let mut g = c.benchmark_group("xosc_cut_in_50_runs_1_core");
    g.sample_size(10);
    for (name, sut) in [("storyboard", SutChoice::Planned), ("acc", SutChoice::Acc)] {
        let opts = RunOptions {
            sut,
            step_ms: Some(10),
            ..RunOptions::default()
        };
        let l = litesim_scenario::batch::run_line(name, &prep, 1, &opts);
        assert_eq!(l.steps, 2002, "20 s at 10 ms (and the stop trigger's step)");
        g.bench_function(name, |b| {
            b.iter(|| {
                (1..=50u64)
                    .map(|s| {
                        let l = litesim_scenario::batch::run_line(name, &prep, s, &opts);
                        black_box(l.steps)
                    })
                    .sum::<u64>()
            })
        });
    }
    g.finish();
}
