//! Writes a long synthetic log, for measuring what reads logs (the viewer,
//! MCAP export) at sizes no example reaches:
//! `cargo run --release -p litesim-log --example long_log -- OUT.json TICKS ACTORS`
//! (20 ms steps; actors in parallel lanes at 10 + k m/s, weaving gently).
#![allow(missing_docs)]

use litesim_core::geometry::{Pose, Vec3};
use litesim_log::{ActorSample, LogRecorder};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: long_log OUT.json TICKS ACTORS");
        std::process::exit(64);
    }
    let (out, ticks, actors): (&str, u64, usize) = (
        &args[1],
        args[2].parse().expect("TICKS: a number"),
        args[3].parse().expect("ACTORS: a number"),
    );
    let mut rec = LogRecorder::new(0.02);
    let ids: Vec<String> = (0..actors).map(|a| format!("car{a}")).collect();
    for id in &ids {
        rec.actor(id, "vehicle/car", "car", 4.5, 1.8, 1500.0);
    }
    for k in 0..ticks {
        let t = k as f64 * 0.02;
        rec.begin(k, t);
        for (a, id) in ids.iter().enumerate() {
            let v = 10.0 + a as f64;
            let y = 3.5 * a as f64 + 0.5 * (0.1 * t + a as f64).sin();
            let s = ActorSample::from_kinematics(
                Pose::planar(v * t, y, 0.0),
                Vec3::new(v, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 0.0),
                0.0,
                v,
                1500.0,
            );
            rec.sample(id, "trajectory", &s);
        }
    }
    rec.finish()
        .write_json(std::path::Path::new(out))
        .expect("write");
}
