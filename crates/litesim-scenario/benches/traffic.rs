//! The traffic engine: driven vehicles on a straight three-lane road, 10 s
//! at 20 ms steps (issue "Actors that drive": 1,000 vehicles on 6 km), at
//! 100, 1,000 and 10,000 vehicles, and the driver model's own cost per
//! call. Figures in BENCHMARKS.md, beside SUMO's on the same machine.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use litesim_core::rng::Rng;
use litesim_map::RoadNetwork;
use litesim_map::synth::{HighwaySpec, highway};
use litesim_scenario::runtime::driver::{DriverParams, Leader, acceleration};
use litesim_scenario::runtime::traffic::spawn::{Density, fill};
use litesim_scenario::runtime::traffic::{LaneGraph, Traffic};
use std::hint::black_box;

/// A run: `n` vehicles spread over a three-lane road of `n` · 6 m (6 km
/// for 1,000: 18 m apart, one per 55 m per lane … as the test),
/// stepped 500 times.
fn run(g: &LaneGraph, n: usize) -> usize {
    let lanes = 3.0;
    let length = g.lanes[0].length;
    let per_km = n as f64 / lanes / (length / 1000.0);
    let mut t = Traffic::new(0.02);
    let d = Density {
        per_km_per_lane: per_km,
        speed: (60.0 / 3.6, 79.0 / 3.6),
        size: (4.5, 1.8),
    };
    fill(&mut t, g, &d, &mut Rng::new(1), &[], |_, _| true).unwrap();
    for _ in 0..500 {
        t.step(g, &[]);
    }
    assert!(t.contacts.is_empty());
    t.vehicles.len()
}

fn road(length: f64) -> LaneGraph {
    let text = highway(&HighwaySpec {
        length,
        lanes: 3,
        lane_width: 3.5,
        drop_at: None,
    });
    LaneGraph::new(&RoadNetwork::from_xodr(&text, "highway.xodr").unwrap())
}

fn traffic(c: &mut Criterion) {
    let mut group = c.benchmark_group("traffic_10s");
    group.sample_size(10);
    for n in [100usize, 1_000, 10_000] {
        let g = road(n as f64 * 6.0);
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| run(&g, n))
        });
    }
    group.finish();
}

fn driver(c: &mut Criterion) {
    let p = DriverParams::for_category("car", 25.0);
    let leaders: Vec<Leader> = (0..1024)
        .map(|k| Leader {
            gap: 5.0 + (k % 97) as f64,
            speed: 10.0 + (k % 13) as f64,
            accel: -1.0 + (k % 5) as f64 * 0.5,
        })
        .collect();
    c.bench_function("driver_acceleration_x1024", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for (k, l) in leaders.iter().enumerate() {
                sum += acceleration(&p, 15.0 + (k % 11) as f64, Some(*l));
            }
            black_box(sum)
        })
    });
}

criterion_group!(benches, traffic, driver);
criterion_main!(benches);
