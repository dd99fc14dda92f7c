//! Planner and controller benchmarks (`cargo bench -p litesim-plan --bench plan`):
//! FMT* on an 80 × 40 m map at 0.2 m with one large rectangle (n = 2,000 and
//! 50,000), the distance transform of a 400 × 200 grid, one MPC solve at
//! N = 20 (structured solver, and Clarabel on the same QP), a 150-step
//! closed loop with MPC, and the plan-matrix's slowest cells planned.

use criterion::Criterion;
use litesim_core::Vec2;
use litesim_map::{Obstacle, OccupancyGrid};
use litesim_plan::corridor::RefState;
use litesim_plan::*;
use std::hint::black_box;

fn yard() -> OccupancyGrid {
    OccupancyGrid::from_obstacles(
        Vec2::new(0.0, 0.0),
        (80.0, 40.0),
        0.2,
        &[Obstacle::Rect {
            min: [32.0, 6.0],
            max: [48.0, 34.0],
        }],
    )
    .unwrap()
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let grid = yard();
    assert_eq!((grid.width, grid.height), (400, 200));
    c.bench_function("distance_transform_400x200", |b| {
        b.iter(|| distance_transform(black_box(&grid)))
    });
    let pg = PlanningGrid::new(grid.clone(), 0.9, 0.4);
    let (start, goal) = (Vec2::new(5.0, 20.0), Vec2::new(75.0, 20.0));
    let plan = |n: usize, seed: u64, eta: f64| {
        fmt_star(
            &pg,
            start,
            goal,
            &FmtConfig {
                samples: n,
                radius: Radius::Eta(eta),
                seed,
            },
        )
        .unwrap()
    };
    // Path cost at each sample count, to compare with other planners at
    // the same n (tools/ompl_fmt.py prints OMPL's).
    for n in [2000usize, 50_000] {
        println!(
            "fmt_star n={n}: path cost {:.2} m",
            plan(n, 1, 0.5).path_cost
        );
    }
    // Over 20 seeds, as tools/ompl_fmt.py draws other samples per run; the
    // default η = 0.5, and η = 0.7, whose paths are no longer than OMPL's.
    for eta in [0.5, 0.7] {
        let mut costs: Vec<f64> = (1..=20)
            .map(|seed| plan(2000, seed, eta).path_cost)
            .collect();
        costs.sort_by(f64::total_cmp);
        println!(
            "fmt_star n=2000 eta={eta}: median path cost over seeds 1-20 {:.2} m (min {:.2}, max {:.2})",
            0.5 * (costs[9] + costs[10]),
            costs[0],
            costs[19]
        );
    }
    let mut g = c.benchmark_group("fmt_star_80x40");
    g.sample_size(20);
    for n in [2000usize, 50_000] {
        g.bench_function(format!("n{n}"), |b| b.iter(|| plan(black_box(n), 1, 0.5)));
    }
    g.bench_function("n2000_eta0.7", |b| b.iter(|| plan(black_box(2000), 1, 0.7)));
    g.finish();

    let cfg = MpcConfig::default();
    let mut mpc = Mpc::new(cfg.clone()).unwrap();
    let refs: Vec<RefState> = (0..=cfg.horizon)
        .map(|k| {
            let t = k as f64 * cfg.dt;
            let (r, w) = (25.0, 8.0 / 25.0);
            RefState {
                p: Vec2::new(r * (w * t).sin(), r - r * (w * t).cos()),
                heading: w * t,
                speed: 8.0,
                curvature: 1.0 / r,
                s: 8.0 * t,
            }
        })
        .collect();
    println!(
        "mpc iterations: {}",
        mpc.solve([0.3, -0.4, 0.05, 7.5], &refs, [0.0, 0.1])
            .unwrap()
            .iterations
    );
    // The same QP in sparse form by Clarabel (a fresh solver each call, as
    // the reference of the property test builds it), for scale.
    c.bench_function("mpc_solve_n20_clarabel", |b| {
        b.iter(|| {
            mpc.solve_reference(black_box([0.3, -0.4, 0.05, 7.5]), &refs, [0.0, 0.1], 1e-7)
                .unwrap()
        })
    });
    c.bench_function("mpc_solve_n20", |b| {
        b.iter(|| {
            mpc.solve(black_box([0.3, -0.4, 0.05, 7.5]), &refs, [0.0, 0.1])
                .unwrap()
        })
    });

    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/plan/single_rect.toml"
    ))
    .unwrap();
    let mut cl = litesim_plan::closed_loop::parse_config(&text).unwrap();
    cl.simulation.horizon = 150.0 * cl.simulation.dt; // exactly 150 steps
    let mut g = c.benchmark_group("closed_loop");
    g.sample_size(10);
    g.bench_function("150_steps_with_mpc_incl_planning", |b| {
        b.iter(|| run_closed_loop(&cl, yard()).unwrap())
    });
    g.finish();

    // The plan-matrix's slowest cells (the curvature-bounded search over
    // forward and reversing motion, and the escape from the margin): each
    // run one step long, so that the time is the planning.
    let examples = litesim_plan::matrix::load_examples(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/plan"
    )))
    .unwrap();
    let mut g = c.benchmark_group("matrix_plan");
    g.sample_size(10);
    for (example, preset) in [
        ("s_bend", "bus"),
        ("s_bend", "truck"),
        ("narrow_passage", "truck"),
        ("warehouse", "van"),
        ("parking_lot", "bus"),
    ] {
        let (_, cfg, grid) = examples.iter().find(|(n, ..)| n == example).unwrap();
        let mut cfg = cfg.clone();
        cfg.vehicle.preset = preset.into();
        cfg.goal.tolerance = 0.5;
        cfg.simulation.horizon = cfg.simulation.dt;
        g.bench_function(format!("{example}_{preset}"), |b| {
            b.iter(|| run_closed_loop(&cfg, grid.clone()).unwrap())
        });
    }
    g.finish();
    c.final_summary();
}
