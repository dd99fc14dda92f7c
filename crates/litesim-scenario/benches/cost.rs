//! What a run costs (`cargo bench -p litesim-scenario --bench cost`): the
//! figures of the issue "a run costs what its physics costs", each as a
//! user meets it.
//! - 200-run batches on 2 threads of the seed's smoke test and of
//!   `cut_in.osc` under `--sut planned` and `--sut acc` (runs per second =
//!   200 / the median);
//! - `cut_in.osc` stepped from outside ([`Stepped`]): reset (solve, plan,
//!   runtime) and one step with a command, the engine under the gym env.
#![allow(missing_docs)]

use criterion::Criterion;
use litesim_scenario::sut::{SutChoice, SutCommand};
use litesim_scenario::{Prepared, RunOptions, Stepped};
use rayon::prelude::*;
use std::hint::black_box;
use std::sync::Arc;

#[path = "../tests/common/mod.rs"]
mod common;
use common::{example, smoke};

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut g = c.benchmark_group("batch_200_runs_2_threads");
    g.sample_size(10);
    let tests = [
        ("smoke", smoke(), SutChoice::Planned),
        ("cut_in_planned", example("cut_in"), SutChoice::Planned),
        ("cut_in_acc", example("cut_in"), SutChoice::Acc),
    ];
    for (name, prep, sut) in tests {
        let shared: Result<Prepared, String> = Ok(prep);
        let opts = RunOptions {
            sut,
            ..RunOptions::default()
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                pool.install(|| {
                    (1..=200u64)
                        .into_par_iter()
                        .map(|s| {
                            let l = litesim_scenario::batch::run_line(name, &shared, s, &opts);
                            usize::from(l.pass)
                        })
                        .sum::<usize>()
                })
            })
        });
    }
    g.finish();

    let prep = Arc::new(example("cut_in"));
    let opts = |seed| RunOptions {
        seed: Some(seed),
        record: false,
        ..RunOptions::default()
    };
    let cmd = SutCommand::Pedals {
        throttle: 0.3,
        brake: 0.0,
        steering: 0.0,
    };
    let mut g = c.benchmark_group("stepped_cut_in");
    g.bench_function("reset", |b| {
        b.iter(|| {
            let mut run = Stepped::start(Arc::clone(&prep), &opts(1)).unwrap();
            black_box(run.observation().unwrap().is_some())
        })
    });
    // One step: the run is started once per 500 steps, its steps timed.
    g.bench_function("step", |b| {
        b.iter_custom(|iters| {
            let mut total = std::time::Duration::ZERO;
            let mut done = 0;
            while done < iters {
                let mut run = Stepped::start(Arc::clone(&prep), &opts(1)).unwrap();
                run.observation().unwrap();
                let t = std::time::Instant::now();
                while done < iters && run.step(cmd).unwrap() {
                    black_box(run.observation().unwrap().map(|o| o.ego.speed));
                    done += 1;
                }
                total += t.elapsed();
            }
            total
        })
    });
    g.finish();
}
