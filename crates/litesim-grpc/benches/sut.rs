//! One lock-step round trip to an external system under test
//! (`cargo bench -p litesim-grpc --bench sut`): litesim's `GrpcSut` asks a
//! `litesim.sut.v1` server on loopback (serving the built-in cruise) for a
//! command; the same step in-process is the reference.
#![allow(missing_docs)]

use criterion::Criterion;
use litesim_grpc::sut::{BuiltinFactory, GrpcSut, LoopbackSutServer};
use litesim_scenario::sut::{ObjectState, Observation, Route, Sut, SutInfo};
use std::hint::black_box;
use std::sync::Arc;

fn info() -> SutInfo {
    let pts: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 5.0, 0.0]).collect();
    SutInfo {
        test: "bench".into(),
        seed: 1,
        step_ms: 20,
        ego_id: "sut.car".into(),
        length: 4.6,
        width: 1.9,
        wheelbase: 2.76,
        max_steer: 0.6,
        max_accel: 4.0,
        max_decel: 8.0,
        route: Route::new(&pts, &vec![15.0; 100]),
        timeout_s: 1.0,
        ..SutInfo::default()
    }
}

fn obs() -> Observation {
    let car = |id: &str, x: f64, y: f64, v: f64| ObjectState {
        id: id.into(),
        kind: "vehicle".into(),
        x,
        y,
        speed: v,
        vx: v,
        length: 4.6,
        width: 1.9,
        ..ObjectState::default()
    };
    Observation {
        tick: 10,
        time: 0.2,
        ego: car("sut.car", 50.0, 0.0, 14.0),
        objects: (0..10)
            .map(|i| {
                car(
                    &format!("v{i}"),
                    60.0 + 15.0 * i as f64,
                    (i % 2) as f64 * 3.5,
                    12.0,
                )
            })
            .collect(),
        requested_speed: 15.0,
        distance_to_goal: 400.0,
        ..Observation::default()
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let server = LoopbackSutServer::start(Arc::new(BuiltinFactory("acc".into()))).unwrap();
    let mut remote = GrpcSut::new(&server.addr.to_string()).unwrap();
    remote.reset(&info()).unwrap();
    let mut local = litesim_scenario::sut::acc::Acc::default();
    local.reset(&info()).unwrap();
    let o = obs();
    c.bench_function("sut_step_acc_in_process", |b| {
        b.iter(|| black_box(local.step(&o).unwrap()))
    });
    c.bench_function("sut_step_acc_grpc_loopback_round_trip", |b| {
        b.iter(|| black_box(remote.step(&o).unwrap()))
    });
    drop(remote);
    drop(server);
    c.final_summary();
}
