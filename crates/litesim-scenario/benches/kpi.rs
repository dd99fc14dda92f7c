//! The checkers at scale (`cargo bench -p litesim-scenario --bench kpi`):
//! 500 steps (10 s at 20 ms) of n vehicles in traffic on a six-lane road,
//! every pair's distance, TTC and collisions tracked — with the broad phase
//! (sort-and-sweep) in front of the exact box tests, for n = 10, 100, 1,000.
#![allow(missing_docs)]

use criterion::Criterion;
use litesim_scenario::kpi::Kpis;
use litesim_scenario::state::BodyState;
use std::hint::black_box;

/// n vehicles in six lanes, 12 m apart, speeds 20–30 m/s (both directions).
fn traffic(n: usize, k: usize) -> Vec<BodyState> {
    (0..n)
        .map(|i| {
            let lane = i % 6;
            let dir = if lane < 3 { 1.0 } else { -1.0 };
            let v = dir * (20.0 + (i % 11) as f64);
            let x0 = (i / 6) as f64 * 12.0 * dir;
            BodyState {
                x: x0 + v * 0.02 * k as f64,
                y: lane as f64 * 3.5,
                yaw: if dir > 0.0 { 0.0 } else { std::f64::consts::PI },
                length: 4.6,
                width: 1.9,
                vx: v,
                vy: 0.0,
                speed: v.abs(),
                acceleration: 0.0,
            }
        })
        .collect()
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let mut g = c.benchmark_group("kpi_10s");
    g.sample_size(10);
    for n in [10usize, 100, 1000] {
        let frames: Vec<Vec<BodyState>> = (0..500).map(|k| traffic(n, k)).collect();
        let ids: Vec<String> = (0..n).map(|i| format!("v{i}")).collect();
        let planned: Vec<(f64, f64, f64)> = vec![(0.0, 0.0, 0.0); n];
        let off = vec![false; n];
        g.bench_function(format!("{n}_vehicles_500_steps"), |b| {
            b.iter(|| {
                let mut k = Kpis::new(&ids);
                for (s, f) in frames.iter().enumerate() {
                    k.step(s as f64 * 0.02, f, &planned, &off);
                }
                k.finish();
                black_box(k.pairs.len())
            })
        });
    }
    g.finish();
    c.final_summary();
}
