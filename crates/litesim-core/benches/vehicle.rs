//! Vehicle-model and world-step throughput.
//!
//! `cargo bench -p litesim-core --bench vehicle` measures:
//! * `SspDynamics` and `KinematicBicycle` per actor-step (straight and
//!   turning): one vehicle, 1,000 vehicles each stepped by its model, and
//!   1,000 vehicles in columns stepped by the batch loops at every
//!   instruction-set level the machine has,
//! * a world step with 1,000 dynamic actors (actor-steps per second),
//!   batched (the default) and one by one,
//!
//! and afterwards runs `benches/seed_model.py` — a plain Python transcription
//! of the seed's model — in the same session and prints the ratio.

use criterion::{BenchmarkId, Criterion, Throughput};
use litesim_core::vehicle::batch::{CommandColumns, Kernel, Level, VehicleColumns, step_run_at};
use litesim_core::{
    Actor, ActorDescription, ActorState, ControlMode, KinematicBicycle, NormalizedPedals, Pose,
    SspDynamics, VehicleInput, VehicleModel, VehicleModelKind, VehicleState, World,
};
use std::hint::black_box;

const STEPS: u64 = 1000;

fn pedals(throttle: f64, steering: f64) -> VehicleInput {
    VehicleInput::Pedals(NormalizedPedals {
        throttle,
        brake: 0.0,
        steering,
    })
}

fn models(c: &mut Criterion) {
    let mut g = c.benchmark_group("actor_step");
    g.throughput(Throughput::Elements(STEPS));
    for (name, steering) in [("straight", 0.0), ("turning", 0.2)] {
        g.bench_with_input(
            BenchmarkId::new("ssp_dynamics", name),
            &steering,
            |b, &s| {
                let input = pedals(0.3, s);
                b.iter(|| {
                    let mut m = SspDynamics::for_length(4.5);
                    let mut st = VehicleState {
                        v: 10.0,
                        ..VehicleState::default()
                    };
                    for _ in 0..STEPS {
                        m.step(&mut st, black_box(&input), 0.02);
                    }
                    black_box(st)
                })
            },
        );
        g.bench_with_input(
            BenchmarkId::new("kinematic_bicycle", name),
            &steering,
            |b, &s| {
                let input = VehicleInput::Direct {
                    acceleration: 0.5,
                    steering_angle: s * 0.5,
                };
                b.iter(|| {
                    let mut m = KinematicBicycle::new(2.7);
                    let mut st = VehicleState {
                        v: 10.0,
                        ..VehicleState::default()
                    };
                    for _ in 0..STEPS {
                        m.step(&mut st, black_box(&input), 0.02);
                    }
                    black_box(st)
                })
            },
        );
    }
    g.finish();

    // Throughput: 1,000 independent vehicles, one step each per iteration —
    // what a world of many actors pays per actor-step, free of the serial
    // dependency of one vehicle's successive steps measured above.
    let mut g = c.benchmark_group("actor_step_batch_1000");
    g.throughput(Throughput::Elements(1000));
    for (name, steering) in [("straight", 0.0), ("turning", 0.2)] {
        let input = pedals(0.3, steering);
        let mut fleet: Vec<(SspDynamics, VehicleState)> = (0..1000)
            .map(|i| {
                (
                    SspDynamics::for_length(4.5),
                    VehicleState {
                        v: 5.0 + (i % 10) as f64,
                        ..VehicleState::default()
                    },
                )
            })
            .collect();
        g.bench_function(BenchmarkId::new("ssp_dynamics", name), |b| {
            b.iter(|| {
                for (m, st) in fleet.iter_mut() {
                    m.step(st, black_box(&input), 0.02);
                }
            })
        });
        let input = VehicleInput::Direct {
            acceleration: 0.5,
            steering_angle: steering * 0.5,
        };
        let mut fleet: Vec<(KinematicBicycle, VehicleState)> = (0..1000)
            .map(|i| {
                (
                    KinematicBicycle::new(2.7),
                    VehicleState {
                        v: 5.0 + (i % 10) as f64,
                        ..VehicleState::default()
                    },
                )
            })
            .collect();
        g.bench_function(BenchmarkId::new("kinematic_bicycle", name), |b| {
            b.iter(|| {
                for (m, st) in fleet.iter_mut() {
                    m.step(st, black_box(&input), 0.02);
                }
            })
        });
    }
    g.finish();

    // The same fleets in columns, stepped by the batch loops (what a world
    // does with dynamic actors), at the best level this machine has and at
    // each level it can run (baseline x86-64 is what a machine without AVX2
    // gets).
    let mut g = c.benchmark_group("actor_step_columns_1000");
    g.throughput(Throughput::Elements(1000));
    for (name, steering) in [("straight", 0.0), ("turning", 0.2)] {
        for (model, input) in [
            ("ssp_dynamics", pedals(0.3, steering)),
            (
                "kinematic_bicycle",
                VehicleInput::Direct {
                    acceleration: 0.5,
                    steering_angle: steering * 0.5,
                },
            ),
        ] {
            let (mut cols, cmds, kernel) = columns_fleet(model, &input);
            for level in Level::available() {
                let id = match level {
                    Level::Best => model.to_string(),
                    other => format!("{model}_{}", format!("{other:?}").to_lowercase()),
                };
                g.bench_function(BenchmarkId::new(id, name), |b| {
                    b.iter(|| {
                        step_run_at(level, &mut cols, &cmds, kernel, 0..1000, black_box(0.02))
                    })
                });
            }
        }
    }
    g.finish();
}

/// 1,000 vehicles of one model in columns, each compiled for `input`.
fn columns_fleet(model: &str, input: &VehicleInput) -> (VehicleColumns, CommandColumns, Kernel) {
    let mut cols = VehicleColumns::default();
    let mut cmds = CommandColumns::with_len(1000);
    let mut kernel = Kernel::Ssp;
    for i in 0..1000 {
        let st = VehicleState {
            v: 5.0 + (i % 10) as f64,
            ..VehicleState::default()
        };
        let mut m = match model {
            "ssp_dynamics" => VehicleModelKind::Ssp(SspDynamics::for_length(4.5)),
            _ => VehicleModelKind::Bicycle(KinematicBicycle::new(2.7)),
        };
        let c = m
            .compile(input, &st, 0.02)
            .expect("a plain command compiles");
        kernel = c.kernel();
        cols.push(&st);
        cmds.set(i, Some(c));
    }
    (cols, cmds, kernel)
}

fn world_with(n: usize, turning_every: usize) -> World {
    let mut w = World::with_step_ms(20).unwrap();
    for i in 0..n {
        let id = format!("car{i:04}");
        let model = VehicleModelKind::Ssp(SspDynamics::for_length(4.5));
        w.add_actor(Actor::new(
            id.clone(),
            ActorDescription::car("bench"),
            ActorState::at_rest(Pose::planar(0.0, 4.0 * i as f64, 0.0)),
            Some(model),
        ))
        .unwrap();
        let steering = if turning_every > 0 && i % turning_every == 0 {
            0.1
        } else {
            0.0
        };
        w.set_mode(
            &id,
            ControlMode::Dynamic {
                input: pedals(0.3, steering),
                valid_until_tick: None,
            },
        )
        .unwrap();
    }
    w
}

fn world(c: &mut Criterion) {
    let mut g = c.benchmark_group("world_step_1000_dynamic");
    g.throughput(Throughput::Elements(1000));
    for (name, every) in [("straight", 0), ("10pct_turning", 10), ("all_turning", 1)] {
        let mut w = world_with(1000, every);
        g.bench_function(name, |b| b.iter(|| w.step()));
        // The same world with every actor stepped by its model, one by one.
        let mut w = world_with(1000, every);
        w.set_batching(false);
        g.bench_function(format!("{name}_one_by_one"), |b| b.iter(|| w.step()));
    }
    // A client that sends one actor a new command every step (a driver model
    // or MPC per vehicle, round robin): only that actor is recompiled.
    for batching in [true, false] {
        let mut w = world_with(1000, 1);
        w.set_batching(batching);
        let ids: Vec<String> = (0..1000).map(|i| format!("car{i:04}")).collect();
        let mut k = 0usize;
        let name = if batching {
            "all_turning_one_command_per_step"
        } else {
            "all_turning_one_command_per_step_one_by_one"
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) % ids.len();
                let steering = if k.is_multiple_of(2) { 0.1 } else { 0.12 };
                w.set_mode(
                    &ids[k],
                    ControlMode::Dynamic {
                        input: pedals(0.3, steering),
                        valid_until_tick: None,
                    },
                )
                .unwrap();
                w.step()
            })
        });
    }
    g.finish();
}

/// Median ns per actor-step from criterion's saved estimate.
fn median_ns(id: &str, elements: f64) -> Option<f64> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../target/criterion")
        .join(id)
        .join("new/estimates.json");
    let text = std::fs::read_to_string(path).ok()?;
    let start = text.find("\"median\"")?;
    let rest = &text[start..];
    let p = rest.find("\"point_estimate\":")? + "\"point_estimate\":".len();
    let end = rest[p..].find(',')?;
    rest[p..p + end].parse::<f64>().ok().map(|ns| ns / elements)
}

fn compare_with_python() {
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/seed_model.py");
    let out = std::process::Command::new("python3").arg(&script).output();
    let py_ns = match out {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout)
            .trim()
            .parse::<f64>()
            .ok(),
        _ => None,
    };
    println!("\n== seed model: litesim vs plain Python (same run) ==");
    for (id, label) in [
        ("actor_step/ssp_dynamics/straight", "SspDynamics straight"),
        ("actor_step/ssp_dynamics/turning", "SspDynamics turning"),
        (
            "actor_step/kinematic_bicycle/straight",
            "KinematicBicycle straight",
        ),
        (
            "actor_step/kinematic_bicycle/turning",
            "KinematicBicycle turning",
        ),
    ] {
        if let Some(ns) = median_ns(id, STEPS as f64) {
            match py_ns {
                Some(py) => println!(
                    "{label:<28} {ns:8.2} ns/actor-step   Python {py:8.1} ns   ratio {:6.0}×",
                    py / ns
                ),
                None => println!("{label:<28} {ns:8.2} ns/actor-step   (python3 not available)"),
            }
        }
    }
    for (id, label) in [
        (
            "actor_step_batch_1000/ssp_dynamics/straight",
            "SspDynamics straight, 1,000 vehicles",
        ),
        (
            "actor_step_batch_1000/ssp_dynamics/turning",
            "SspDynamics turning, 1,000 vehicles",
        ),
        (
            "actor_step_batch_1000/kinematic_bicycle/straight",
            "KinematicBicycle straight, 1,000",
        ),
        (
            "actor_step_batch_1000/kinematic_bicycle/turning",
            "KinematicBicycle turning, 1,000",
        ),
    ] {
        if let Some(ns) = median_ns(id, 1000.0) {
            println!("{label:<40} {ns:8.2} ns/actor-step");
        }
    }
    for (id, label) in [
        ("ssp_dynamics/straight", "SspDynamics straight, columns"),
        ("ssp_dynamics/turning", "SspDynamics turning, columns"),
        (
            "ssp_dynamics_baseline/turning",
            "SspDynamics turning, columns, baseline",
        ),
        (
            "ssp_dynamics_v3/turning",
            "SspDynamics turning, columns, AVX2",
        ),
        (
            "kinematic_bicycle/straight",
            "KinematicBicycle straight, columns",
        ),
        (
            "kinematic_bicycle/turning",
            "KinematicBicycle turning, columns",
        ),
        (
            "kinematic_bicycle_baseline/turning",
            "KinematicBicycle turning, columns, baseline",
        ),
        (
            "kinematic_bicycle_v3/turning",
            "KinematicBicycle turning, columns, AVX2",
        ),
    ] {
        if let Some(ns) = median_ns(&format!("actor_step_columns_1000/{id}"), 1000.0) {
            match py_ns {
                Some(py) => println!(
                    "{label:<44} {ns:8.2} ns/actor-step   vs Python {:6.0}×",
                    py / ns
                ),
                None => println!("{label:<44} {ns:8.2} ns/actor-step"),
            }
        }
    }
    for id in ["litesim", "libm"] {
        if let Some(ns) = median_ns(&format!("sin_cos_1000/{id}"), 1000.0) {
            println!("sin_cos, {id:<10} {ns:8.2} ns/call (1,000 headings)");
        }
    }
    for id in [
        "straight",
        "10pct_turning",
        "all_turning",
        "straight_one_by_one",
        "10pct_turning_one_by_one",
        "all_turning_one_by_one",
        "all_turning_one_command_per_step",
        "all_turning_one_command_per_step_one_by_one",
    ] {
        if let Some(ns) = median_ns(&format!("world_step_1000_dynamic/{id}"), 1000.0) {
            println!(
                "world 1,000 dynamic, {id:<44} {:8.1} M actor-steps/s",
                1000.0 / ns
            );
        }
    }
}

/// litesim's `sin_cos` against the pure-Rust `libm` it replaced, on 1,000
/// headings spread over (−π, π] (what a turning fleet evaluates per step).
fn trig(c: &mut Criterion) {
    let mut g = c.benchmark_group("sin_cos_1000");
    g.throughput(Throughput::Elements(1000));
    let xs: Vec<f64> = (0..1000)
        .map(|i| -std::f64::consts::PI + 0.006_283 * i as f64 + 1e-4)
        .collect();
    g.bench_function("litesim", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for &x in black_box(&xs) {
                let (s, c) = litesim_core::math::sin_cos(x);
                acc += s * c;
            }
            acc
        })
    });
    g.bench_function("libm", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for &x in black_box(&xs) {
                let (s, c) = libm::sincos(x);
                acc += s * c;
            }
            acc
        })
    });
    g.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    trig(&mut c);
    raw_bound(&mut c);
    models(&mut c);
    world(&mut c);
    c.final_summary();
    compare_with_python();
}

/// Lower bound for the per-model figures: the seed's turning equations on
/// plain arrays (no enum input, no caches, no derived fields), the one
/// `sin_cos` per step included. What any scalar transcription pays.
fn raw_bound(c: &mut Criterion) {
    let mut g = c.benchmark_group("raw_turning_1000");
    g.throughput(Throughput::Elements(1000));
    let n = 1000;
    let (mut x, mut y, mut yaw, mut v) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for (i, vi) in v.iter_mut().enumerate() {
        *vi = 5.0 + (i % 10) as f64;
    }
    let r = 2.7 / litesim_core::math::sin(0.12);
    g.bench_function("ssp_equations", |b| {
        b.iter(|| {
            let r = black_box(r);
            for i in 0..n {
                let w = v[i] / r;
                let vn = (v[i] + 0.3 * 4.0 * 0.02).clamp(0.0, 40.0);
                yaw[i] = litesim_core::wrap_angle(yaw[i] + w * 0.02);
                let (s, c) = litesim_core::math::sin_cos(yaw[i]);
                x[i] += vn * c * 0.02;
                y[i] += vn * s * 0.02;
                v[i] = vn;
            }
        })
    });
    g.bench_function("ssp_equations_soa_split", |b| {
        let mut w = vec![0.0; n];
        let mut sc = vec![(0.0, 0.0); n];
        b.iter(|| {
            let r = black_box(r);
            for i in 0..n {
                let vn = (v[i] + 0.3 * 4.0 * 0.02).clamp(0.0, 40.0);
                let mut a = yaw[i] + v[i] / r * 0.02;
                a = if a > std::f64::consts::PI {
                    a - std::f64::consts::TAU
                } else {
                    a
                };
                yaw[i] = a;
                w[i] = vn;
            }
            for i in 0..n {
                sc[i] = litesim_core::math::sin_cos_reduced(yaw[i]);
            }
            for i in 0..n {
                x[i] += w[i] * sc[i].1 * 0.02;
                y[i] += w[i] * sc[i].0 * 0.02;
            }
            v.copy_from_slice(&w);
        })
    });
    // One fused loop, the wrap as compare-and-select (what `wrap_angle`
    // computes for a heading plus one step's turn): the seed's turning step
    // when vehicle states live in arrays of their own rather than in actors.
    g.bench_function("ssp_equations_soa_select", |b| {
        b.iter(|| soa_select_step(&mut x, &mut y, &mut yaw, &mut v, black_box(r)))
    });
    g.finish();
}

/// The SoA turning step of `raw_bound`. A function of its own so that the
/// four slices are known not to overlap (`&mut` parameters), which is what
/// lets the compiler vectorise the loop.
#[inline(never)]
fn soa_select_step(x: &mut [f64], y: &mut [f64], yaw: &mut [f64], v: &mut [f64], r: f64) {
    let n = x.len().min(y.len()).min(yaw.len()).min(v.len());
    let (x, y, yaw, v) = (&mut x[..n], &mut y[..n], &mut yaw[..n], &mut v[..n]);
    for i in 0..n {
        let vn = (v[i] + 0.3 * 4.0 * 0.02).clamp(0.0, 40.0);
        let a = yaw[i] + v[i] / r * 0.02;
        let a = if a > std::f64::consts::PI {
            a - std::f64::consts::TAU
        } else {
            a
        };
        yaw[i] = a;
        let (s, c) = litesim_core::math::sin_cos_reduced(a);
        x[i] += vn * c * 0.02;
        y[i] += vn * s * 0.02;
        v[i] = vn;
    }
}
