//! Bench client: gRPC lock-step latency (p50/p99) and server memory.
//!
//! ```text
//! cargo run --release -p litesim-grpc --example lockstep -- [ITERATIONS] [MEMORY_STEPS]
//! ```
//!
//! Starts a server on loopback in this process (its own runtime and threads),
//! creates 10 actors (5 on pedals, 5 on trajectories) and measures, per step:
//! * unary: StartStep + WaitStep + GetActorsStates (three round trips);
//! * unary Step (one round trip);
//! * StepStream: one StepCommand → one StepResult.
//!
//! Then it streams MEMORY_STEPS steps (default 1,000,000) and prints the
//! process's resident memory every 10% to show it stays flat.
//!
//! `ADDR=127.0.0.1:50051` drives a server in another process (`litesim
//! serve`) instead. Lock-step traffic strictly alternates, so where the two
//! sides run matters more than anything in the code: on a VM, waking a
//! thread on another vCPU costs tens of µs. Pinning client and server to one
//! CPU (`taskset -c 0 …` for both) removes that cost; `BENCHMARKS.md` gives
//! both figures.

use litesim_grpc::pb;
use litesim_grpc::{RemoteSsp, ServerConfig};
use litesim_ssp::*;
use std::time::Instant;

fn rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| {
            s.split_whitespace()
                .nth(1)
                .and_then(|p| p.parse::<u64>().ok())
        })
        .map_or(0, |pages| pages * 4)
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn setup(addr: &str) -> RemoteSsp {
    let mut c = RemoteSsp::connect(addr).unwrap();
    c.init(InitRequest::default()).unwrap();
    c.start_simulation(0).unwrap();
    c.wait_start_simulation(1000).unwrap();
    for i in 0..10 {
        let id = format!("a{i}");
        c.create_actor(CreateActor {
            actor_id: id.clone(),
            position: Coord6::xy_yaw(0.0, 4.0 * i as f64, 0.0),
            ..CreateActor::default()
        })
        .unwrap();
        if i < 5 {
            c.set_dynamic_move(
                &id,
                DynamicMove::Normalized {
                    throttle: 0.2,
                    brake: 0.0,
                    steering: 0.05,
                },
                0,
            )
            .unwrap();
        } else {
            c.set_xy_trajectory(
                &id,
                XyTrajectory {
                    start_time_ms: 0,
                    end_time_ms: 3_600_000,
                    points: vec![
                        Coord6::xy_yaw(0.0, 4.0 * i as f64, 0.0),
                        Coord6::xy_yaw(36_000.0, 4.0 * i as f64, 0.0),
                    ],
                    ..XyTrajectory::default()
                },
            )
            .unwrap();
        }
    }
    c
}

fn tcp_floor(iters: usize) -> Vec<f64> {
    use std::io::{Read, Write};
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async move {
            use tokio::io::{AsyncReadExt, AsyncWriteExt};
            let l = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            tx.send(l.local_addr().unwrap()).unwrap();
            let (mut s, _) = l.accept().await.unwrap();
            s.set_nodelay(true).unwrap();
            let mut buf = [0u8; 600];
            while s.read_exact(&mut buf).await.is_ok() {
                if s.write_all(&buf).await.is_err() {
                    break;
                }
            }
        });
    });
    let mut s = std::net::TcpStream::connect(rx.recv().unwrap()).unwrap();
    s.set_nodelay(true).unwrap();
    let mut buf = [7u8; 600];
    let mut us = Vec::with_capacity(iters);
    for _ in 0..iters {
        let t = Instant::now();
        s.write_all(&buf).unwrap();
        s.read_exact(&mut buf).unwrap();
        us.push(t.elapsed().as_secs_f64() * 1e6);
    }
    us
}

/// A server on loopback in this process: its own tokio runtime (`WORKERS`
/// worker threads, default 1). Returns its address.
fn in_process_server() -> String {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(
                std::env::var("WORKERS")
                    .ok()
                    .and_then(|w| w.parse().ok())
                    .unwrap_or(1),
            )
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async move {
            let l = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            tx.send(l.local_addr().unwrap()).unwrap();
            litesim_grpc::serve(l, ServerConfig::default(), std::future::pending())
                .await
                .unwrap();
        });
    });
    rx.recv().unwrap().to_string()
}

fn report(name: &str, mut us: Vec<f64>) {
    let n = us.len();
    println!(
        "{name:<44} n={n:>6}  p50 {:>7.1} µs  p99 {:>7.1} µs",
        pct(&mut us, 0.5),
        pct(&mut us, 0.99)
    );
}

fn main() {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let iters = args.first().copied().unwrap_or(20_000) as usize;
    let memory_steps = args.get(1).copied().unwrap_or(1_000_000);

    let addr = match std::env::var("ADDR") {
        Ok(external) => {
            println!("server: {external} (another process)");
            external
        }
        Err(_) => in_process_server(),
    };
    let all = ActorFilter::default();

    // The floor: a raw TCP echo round trip through the same kind of server
    // runtime (one tokio worker) from a blocking client, 600 bytes each way.
    report("floor: raw TCP echo round trip (600 B)", tcp_floor(iters));

    let mut c = setup(&addr);
    let mut unary = Vec::with_capacity(iters);
    for _ in 0..iters {
        let t = Instant::now();
        c.start_step(None).unwrap();
        c.wait_step(0).unwrap();
        let s = c.get_actors_states(&all).unwrap();
        unary.push(t.elapsed().as_secs_f64() * 1e6);
        assert_eq!(s.len(), 10);
    }
    report("unary start_step+wait_step+get_states (10)", unary);
    let mut step = Vec::with_capacity(iters);
    for _ in 0..iters {
        let t = Instant::now();
        let (_, s) = c.step(None, &all).unwrap();
        step.push(t.elapsed().as_secs_f64() * 1e6);
        assert_eq!(s.len(), 10);
    }
    report("unary Step (10 actors)", step);

    let sid = c.session_id().to_string();
    let (rt, raw) = c.raw();
    let mut raw = raw.clone();
    let (stream_us, mem) = rt.block_on(async move {
        let (tx, rx) = tokio::sync::mpsc::channel(1);
        let mut out = raw
            .step_stream(tokio_stream::wrappers::ReceiverStream::new(rx))
            .await
            .unwrap()
            .into_inner();
        let mut us = Vec::with_capacity(iters);
        let mut mem = Vec::new();
        let total = iters as u64 + memory_steps;
        for seq in 0..total {
            let t = Instant::now();
            let cmd = pb::StepCommand {
                session_id: if seq == 0 { sid.clone() } else { String::new() },
                seq,
                ..Default::default()
            };
            tx.send(cmd).await.unwrap();
            let r = out.message().await.unwrap().unwrap();
            if seq < iters as u64 {
                us.push(t.elapsed().as_secs_f64() * 1e6);
            } else if (seq - iters as u64).is_multiple_of((memory_steps / 10).max(1)) {
                mem.push((seq - iters as u64, rss_kib()));
            }
            assert_eq!(r.states.len(), 10);
        }
        mem.push((memory_steps, rss_kib()));
        (us, mem)
    });
    report("StepStream (10 actors)", stream_us);
    let whose = if std::env::var("ADDR").is_ok() {
        "this client only; the server is another process"
    } else {
        "server + client, one process"
    };
    println!("\nresident memory while streaming {memory_steps} more steps ({whose}):");
    for (step, kib) in mem {
        println!("  after {step:>9} steps: {:>8.1} MiB", kib as f64 / 1024.0);
    }
}
