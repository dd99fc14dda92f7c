//! Scenario-engine speed (`cargo bench -p litesim-scenario --bench scenario`):
//! the seed's smoke test end to end in-process (parse with imports, load
//! the map, solve, plan, 300 steps, log serialised), the per-seed run alone,
//! a 2-thread batch of smoke runs (runs per second), and the same run over
//! a live gRPC server on loopback (the ratio to in-process is the figure).
#![allow(missing_docs)]

use criterion::Criterion;
use litesim_scenario::{LoadOptions, Prepared, RunOptions, prepare, run};
use rayon::prelude::*;
use std::hint::black_box;

// The test binaries' helpers: the repository root, a test written beside
// the examples, the traffic test (the many-actors test runs it too).
#[path = "../tests/common/mod.rs"]
mod common;
use common::{example_file, root, smoke, traffic};

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let prep = smoke();
    // The smoke test draws its duration from [3..6] s: take the first seed
    // whose run is (almost) 6 s, i.e. the 300 steps.
    let seed = (1..500)
        .find(|s| {
            let r = run(
                &prep,
                &mut litesim_scenario::in_process(),
                &RunOptions {
                    seed: Some(*s),
                    ..RunOptions::default()
                },
            )
            .unwrap();
            r.summary.steps >= 295
        })
        .unwrap();
    let opts = RunOptions {
        seed: Some(seed),
        record: true,
        ..RunOptions::default()
    };
    let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    eprintln!("smoke seed {seed}: {} steps", r.summary.steps);
    c.bench_function("smoke_end_to_end_in_process", |b| {
        b.iter(|| {
            let prep = smoke();
            let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
            let log = r.log.unwrap();
            black_box(serde_json::to_string(&r.summary).unwrap().len() + log.tick.len())
        })
    });
    let fast = RunOptions {
        seed: Some(seed),
        ..RunOptions::default()
    };
    c.bench_function("smoke_run_prepared_no_log", |b| {
        b.iter(|| black_box(run(&prep, &mut litesim_scenario::in_process(), &fast).unwrap()))
    });
    let shared: Result<Prepared, String> = Ok(prep.clone());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut g = c.benchmark_group("batch");
    g.sample_size(10);
    g.bench_function("smoke_200_runs_2_threads", |b| {
        b.iter(|| {
            pool.install(|| {
                (1..=200u64)
                    .into_par_iter()
                    .map(|s| {
                        let l = litesim_scenario::batch::run_line(
                            "smoke",
                            &shared,
                            s,
                            &RunOptions::default(),
                        );
                        usize::from(l.pass)
                    })
                    .sum::<usize>()
            })
        })
    });
    g.finish();
    // Closed loop: the same smoke run with the built-in cruise driving
    // sut.car (≤ 1.2× the planned run is the target), a 200-run batch of
    // it, and the FMT* + MPC SUT round the standing obstacle (per step).
    let acc = RunOptions {
        seed: Some(seed),
        sut: litesim_scenario::sut::SutChoice::Acc,
        ..RunOptions::default()
    };
    let mut g = c.benchmark_group("closed_loop");
    g.bench_function("smoke_run_prepared_no_log_planned", |b| {
        b.iter(|| black_box(run(&prep, &mut litesim_scenario::in_process(), &fast).unwrap()))
    });
    g.bench_function("smoke_run_prepared_no_log_acc", |b| {
        b.iter(|| black_box(run(&prep, &mut litesim_scenario::in_process(), &acc).unwrap()))
    });
    g.sample_size(10);
    let acc_base = RunOptions {
        sut: litesim_scenario::sut::SutChoice::Acc,
        ..RunOptions::default()
    };
    g.bench_function("smoke_200_runs_2_threads_acc", |b| {
        b.iter(|| {
            pool.install(|| {
                (1..=200u64)
                    .into_par_iter()
                    .map(|s| {
                        let l = litesim_scenario::batch::run_line("smoke", &shared, s, &acc_base);
                        usize::from(l.pass)
                    })
                    .sum::<usize>()
            })
        })
    });
    let obstacle = prepare(
        &root().join("examples/scenarios/obstacle_goal.osc"),
        &LoadOptions::default(),
    )
    .unwrap();
    let fm = RunOptions {
        seed: Some(1),
        sut: litesim_scenario::sut::SutChoice::FmtMpc,
        ..RunOptions::default()
    };
    let steps = run(&obstacle, &mut litesim_scenario::in_process(), &fm)
        .unwrap()
        .summary
        .steps;
    eprintln!("obstacle_goal under fmt-mpc: {steps} steps per run");
    g.bench_function("obstacle_goal_fmt_mpc_run_400_steps", |b| {
        b.iter(|| black_box(run(&obstacle, &mut litesim_scenario::in_process(), &fm).unwrap()))
    });
    // A van backing into a bay under fmt-mpc: one plan (hybrid A* with
    // reversing), 3,000 steps with gear changes.
    let bay = prepare(
        &root().join("examples/scenarios/parking_bay.osc"),
        &LoadOptions::default(),
    )
    .unwrap();
    g.bench_function("parking_bay_fmt_mpc_run_3000_steps", |b| {
        b.iter(|| black_box(run(&bay, &mut litesim_scenario::in_process(), &fm).unwrap()))
    });
    g.finish();
    // Scale: a 10 s test of n vehicles in three lanes, 8 m apart, all at
    // 30 kph (written beside the examples so its imports resolve).
    let mut g = c.benchmark_group("scale");
    g.sample_size(10);
    for n in [10usize, 100] {
        let f = example_file(&traffic(n, None));
        let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
        let one = RunOptions {
            seed: Some(1),
            ..RunOptions::default()
        };
        let r = run(&prep, &mut litesim_scenario::in_process(), &one).unwrap();
        assert!(r.summary.pass, "{:?}", r.summary.failures);
        g.bench_function(format!("{n}_vehicles_10s_run"), |b| {
            b.iter(|| black_box(run(&prep, &mut litesim_scenario::in_process(), &one).unwrap()))
        });
    }
    g.finish();
    // A run's MCAP (issue: ≤ 10 % of a run): the README example recorded
    // (run + log.json text), and its MCAP written from that log.
    let mut g = c.benchmark_group("mcap");
    let cut_in = prepare(
        &root().join("examples/scenarios/cut_in.osc"),
        &LoadOptions::default(),
    )
    .unwrap();
    let rec = RunOptions {
        record: true,
        ..RunOptions::default()
    };
    g.bench_function("cut_in_run_recorded_with_log_json", |b| {
        b.iter(|| {
            let r = run(&cut_in, &mut litesim_scenario::in_process(), &rec).unwrap();
            black_box(serde_json::to_string(&r.log.unwrap()).unwrap().len())
        })
    });
    // What `litesim.run(cut_in, record=False)` does natively (issue 21's
    // Python overhead is measured against it): load and run, no log.
    g.bench_function("cut_in_prepare_and_run", |b| {
        b.iter(|| {
            let p = prepare(
                &root().join("examples/scenarios/cut_in.osc"),
                &LoadOptions::default(),
            )
            .unwrap();
            black_box(
                run(
                    &p,
                    &mut litesim_scenario::in_process(),
                    &RunOptions::default(),
                )
                .unwrap(),
            )
        })
    });
    let log = run(&cut_in, &mut litesim_scenario::in_process(), &rec)
        .unwrap()
        .log
        .unwrap();
    g.bench_function("cut_in_write_mcap", |b| {
        b.iter(|| {
            let mut out = std::io::Cursor::new(Vec::new());
            black_box(litesim_mcap::write_to(&log, cut_in.net.as_deref(), &mut out).unwrap());
            black_box(out.into_inner().len())
        })
    });
    // What `litesim run --mcap` waits for once the log exists: the map's
    // lanes are sampled while the run goes on.
    let map = cut_in.net.as_deref().map(litesim_mcap::McapMap::new);
    g.bench_function("cut_in_write_mcap_map_sampled", |b| {
        b.iter(|| {
            let mut out = std::io::Cursor::new(Vec::new());
            black_box(litesim_mcap::write_to_with(&log, map.as_ref(), &mut out).unwrap());
            black_box(out.into_inner().len())
        })
    });
    g.finish();
    // Over gRPC: a server on loopback in this process.
    let server = litesim_grpc::LoopbackServer::start(Default::default(), 1).unwrap();
    let addr = server.addr.to_string();
    let mut g = c.benchmark_group("grpc");
    g.sample_size(10);
    g.bench_function("smoke_end_to_end_over_grpc", |b| {
        b.iter(|| {
            let prep = smoke();
            let mut remote = litesim_grpc::RemoteSsp::connect(&addr).unwrap();
            let r = run(&prep, &mut remote, &opts).unwrap();
            let log = r.log.unwrap();
            black_box(serde_json::to_string(&r.summary).unwrap().len() + log.tick.len())
        })
    });
    g.finish();
    server.stop().unwrap();
    c.final_summary();
}
