//! The standard library's actions against today's nearest equivalent
//! (`cargo bench -p litesim-scenario --bench stdlib`): a 10-actor test
//! planned and run (drivers, in-process) written with the new actions —
//! a platoon of nine `keep_time_headway` followers behind sut.car, which
//! `change_speed`s and `keep_speed`s — and the same test written as
//! before, every follower a `drive()` with the lead's absolute speeds.
#![allow(missing_docs)]

use criterion::Criterion;
use litesim_scenario::{LoadOptions, RunOptions, prepare, run};
use std::hint::black_box;

#[path = "../tests/common/mod.rs"]
mod common;
use common::example_file;

const HEADER: &str = "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/highway.xodr\"\nextend top.main:\n    do sut.p()\nscenario sut.p:\n    r: one_way_road\n";

/// The 10-actor test: sut.car's speed profile, and nine followers 30 m
/// apart, each given `follow(k)` (its own phase over the whole test).
fn platoon(follow: impl Fn(usize) -> String, extra: &str, profile: &str) -> String {
    let mut t = String::from(HEADER);
    for k in 1..10 {
        t += &format!("    f{k}: vehicle\n");
    }
    t += "    do parallel(overlap: equal):\n        serial():\n";
    t += profile;
    for k in 1..10 {
        let ahead = if k == 1 {
            "sut.car".to_string()
        } else {
            format!("f{}", k - 1)
        };
        t += &format!(
            "        f{k}.{} with:\n            lane(same_as: sut.car, at: start)\n            position(30m, behind: {ahead}, at: start)\n{extra}",
            follow(k)
        );
    }
    t
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let start = "            sut.car.drive() with:\n                speed(80kph)\n                along(r, start_offset: 500m, at: start)\n                lane(2, at: start)\n                duration(4s)\n";
    let actions = platoon(
        |k| {
            let ahead = if k == 1 {
                "sut.car".to_string()
            } else {
                format!("f{}", k - 1)
            };
            format!("keep_time_headway({ahead})")
        },
        "",
        &format!(
            "{start}            sut.car.change_speed(50kph, rate_peak: 2mpsps)\n            sut.car.keep_speed() with:\n                duration(4s)\n            sut.car.change_speed(90kph, rate_peak: 1.5mpsps)\n            sut.car.keep_speed() with:\n                duration(6s)\n"
        ),
    );
    // The same motion of sut.car with today's modifiers (the phases'
    // durations as the actions take them), and followers that drive at
    // the lead's speeds in their own phases: the nearest equivalent.
    let before = platoon(
        |_| "drive()".to_string(),
        "            speed(80kph)\n",
        &format!(
            "{start}            sut.car.drive() with:\n                speed(50kph)\n                acceleration(2mpsps)\n                duration(4.2s)\n            sut.car.drive() with:\n                duration(4s)\n            sut.car.drive() with:\n                speed(90kph)\n                acceleration(1.5mpsps)\n                duration(7.5s)\n            sut.car.drive() with:\n                duration(6s)\n"
        ),
    );
    // The two tests as files, for timing `litesim run` on them (the
    // user's path): `LITESIM_BENCH_WRITE=DIR` writes them into DIR (give
    // examples/scenarios, where their relative imports resolve).
    if let Ok(dir) = std::env::var("LITESIM_BENCH_WRITE") {
        let dir = std::path::Path::new(&dir);
        std::fs::write(dir.join("bench_stdlib_actions.osc"), &actions).unwrap();
        std::fs::write(dir.join("bench_stdlib_before.osc"), &before).unwrap();
    }
    let fa = example_file(&actions);
    let fb = example_file(&before);
    let pa = prepare(fa.path(), &LoadOptions::default()).unwrap();
    let pb = prepare(fb.path(), &LoadOptions::default()).unwrap();
    let opts = RunOptions {
        seed: Some(1),
        ..RunOptions::default()
    };
    for (name, p) in [("actions", &pa), ("before", &pb)] {
        let r = run(p, &mut litesim_scenario::in_process(), &opts).unwrap();
        assert_eq!(r.plan.actors.len(), 10, "{name}");
        eprintln!("{name}: {} steps, pass {}", r.summary.steps, r.summary.pass);
    }
    let mut g = c.benchmark_group("stdlib_10_actors");
    g.bench_function("keep_time_headway_platoon", |b| {
        b.iter(|| black_box(run(&pa, &mut litesim_scenario::in_process(), &opts).unwrap()))
    });
    g.bench_function("drive_with_speeds_equivalent", |b| {
        b.iter(|| black_box(run(&pb, &mut litesim_scenario::in_process(), &opts).unwrap()))
    });
    // The breakdown: planning alone (solve and plan, no simulation).
    let plan_only = RunOptions {
        plan_only: true,
        ..opts.clone()
    };
    g.bench_function("plan_only/keep_time_headway_platoon", |b| {
        b.iter(|| black_box(run(&pa, &mut litesim_scenario::in_process(), &plan_only).unwrap()))
    });
    g.bench_function("plan_only/drive_with_speeds_equivalent", |b| {
        b.iter(|| black_box(run(&pb, &mut litesim_scenario::in_process(), &plan_only).unwrap()))
    });
    g.finish();
    c.final_summary();
}
