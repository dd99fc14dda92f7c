//! The bundled demo client: the seed's smoke test, driven through the SSP API.
//!
//! An ego car on pedals (forces in N, a speed PI loop with the profile's
//! calibrated gains) accelerates to 20 km/h and changes lane; an NPC car is
//! moved kinematically by xy trajectories refreshed every 200 ms, like a
//! scenario engine does; a pedestrian and a cone keep what they were given.

use anyhow::{Result, anyhow};
use litesim_log::{ActorSample, ControlSample, LogRecorder, SimulationLog};
use litesim_ssp::*;
use std::path::PathBuf;
use std::time::Instant;

/// Demo options.
#[derive(clap::Args, Clone, Debug)]
pub struct DemoOptions {
    /// Simulated time (s).
    #[arg(long, default_value_t = 6.0)]
    pub duration: f64,
    /// Output folder for log.json and log.csv.
    #[arg(short = 'o', long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Profile.
    #[arg(long, default_value = "dummy")]
    pub profile: String,
    /// Model.
    #[arg(long, default_value = "dummy")]
    pub model: String,
}

fn e(err: SspError) -> anyhow::Error {
    anyhow!("{:?}: {}", err.code, err.message)
}

/// Starts a server on a free loopback port in this process and runs the demo against it over gRPC.
pub fn run_with_local_server(opts: &DemoOptions) -> Result<()> {
    let server = litesim_grpc::LoopbackServer::start(litesim_grpc::ServerConfig::default(), 1)?;
    let addr = server.addr;
    println!("litesim demo: server on {addr}, client over gRPC");
    let mut client = litesim_grpc::RemoteSsp::connect(&addr.to_string()).map_err(e)?;
    let result = run(&mut client, opts, &format!("gRPC {addr}"));
    // Graceful shutdown waits for open connections: close ours first.
    drop(client);
    server.stop().map_err(|e| anyhow!(e))?;
    result
}

/// Runs the demo through any [`Ssp`].
pub fn run(ssp: &mut dyn Ssp, opts: &DemoOptions, transport: &str) -> Result<()> {
    let init = ssp
        .init(InitRequest {
            client_name: "litesim demo".into(),
            profile: opts.profile.clone(),
            model: opts.model.clone(),
            seed: 1,
            ..InitRequest::default()
        })
        .map_err(e)?;
    for d in &init.diagnostics {
        println!("note: {d}");
    }
    let step_ms = u64::from(init.capabilities.step_size_ms);
    let dt = step_ms as f64 / 1000.0;
    let steps = litesim_core::steps_for_horizon(opts.duration, dt);
    let physical = init.capabilities.pedal_encoding == PedalEncoding::Physical;
    let profile = Profile::builtin(&init.capabilities.profile).map_err(e)?;
    ssp.start_simulation(0).map_err(e)?;
    ssp.wait_start_simulation(1000).map_err(e)?;

    let (ego, entry, npc) = create_actors(ssp, &profile)?;
    let target = 20.0 / 3.6; // the smoke test's 20 kph
    let gains = profile.calibration;
    let mut integral = 0.0;
    let mut rec = LogRecorder::new(dt);
    rec.meta("profile", &init.capabilities.profile);
    rec.meta("model", &init.capabilities.model);
    rec.meta("transport", transport);
    let mut speed = 0.0;
    let mut y = 0.0;
    let mut yaw: f64 = 0.0;
    let mut min_gap = f64::INFINITY;
    let started = Instant::now();
    for k in 0..steps {
        let now_ms = k * step_ms;
        if k % (200 / step_ms).max(1) == 0 {
            npc_trajectory(ssp, now_ms, step_ms, target)?;
        }
        // Ego: PI speed loop with the profile's calibrated gains (per m/s of
        // error); after 2 s a lane change to y = 3.5 m, into the NPC's lane behind it.
        let err = target - speed;
        integral = (integral + err * dt).clamp(-5.0, 5.0);
        let u = gains.throttle.kp * err + gains.throttle.ki * integral;
        let lane = if now_ms >= 2000 { 3.5 } else { 0.0 };
        let steer = (0.08 * (lane - y) - 0.8 * yaw).clamp(-0.3, 0.3);
        let (throttle, brake) = if u >= 0.0 {
            (u.min(1.0), 0.0)
        } else {
            (
                0.0,
                (-u * gains.brake.kp / gains.throttle.kp.max(1e-9)).min(1.0),
            )
        };
        let cmd = if physical {
            DynamicMove::Physical {
                drive_force_n: throttle * entry.mass * entry.max_accel,
                brake_force_n: brake * entry.mass * entry.max_decel,
                steer: PhysicalSteer::TorqueNm(steer * profile.max_steering_torque_nm),
            }
        } else {
            DynamicMove::Normalized {
                throttle,
                brake,
                steering: steer,
            }
        };
        ssp.set_dynamic_move("sut.car", cmd, 0).map_err(e)?;
        let (info, states) = ssp.step(None, &ActorFilter::default()).map_err(e)?;
        rec.begin(info.step_index, info.sim_time_ms as f64 / 1000.0);
        if let Some(e) = record(&mut rec, &states, (&ego, &npc, &entry)) {
            (speed, y, yaw) = e;
        }
        let pos = |id: &str| {
            states
                .iter()
                .find(|s| &*s.actor_id == id)
                .map(|s| s.pose.position.xy())
        };
        if let (Some(a), Some(b)) = (pos("sut.car"), pos("car1")) {
            min_gap = min_gap.min(a.distance(b));
        }
    }
    let wall = started.elapsed();
    ssp.end_simulation("demo finished").map_err(e)?;
    let log = rec.finish();
    std::fs::create_dir_all(&opts.out)?;
    log.write_json(&opts.out.join("log.json"))?;
    log.write_csv(&opts.out.join("log.csv"))?;
    summary(&log, steps, wall, min_gap, transport);
    println!(
        "wrote {} and {}",
        opts.out.join("log.json").display(),
        opts.out.join("log.csv").display()
    );
    Ok(())
}

/// The demo's actors: sut.car (its catalogue entry too), a car beside it
/// and a pedestrian ahead.
fn create_actors(
    ssp: &mut dyn Ssp,
    profile: &Profile,
) -> Result<(ActualDescription, CatalogEntry, ActualDescription)> {
    let ego = ssp
        .create_actor(CreateActor {
            actor_id: "sut.car".into(),
            spec: ActorSpec {
                actor_type: "Ego".into(),
                ..ActorSpec::default()
            },
            position: Coord6::xy_yaw(0.0, 0.0, 0.0),
            ..CreateActor::default()
        })
        .map_err(e)?;
    let entry = profile.entry(&ego.model_id).map_err(e)?.clone();
    let npc = ssp
        .create_actor(CreateActor {
            actor_id: "car1".into(),
            position: Coord6::xy_yaw(8.0, 3.5, 0.0),
            ..CreateActor::default()
        })
        .map_err(e)?;
    ssp.create_actor(CreateActor {
        actor_id: "walker".into(),
        spec: ActorSpec {
            actor_type: "Pedestrian".into(),
            category: ActorCategory::Pedestrian,
            ..ActorSpec::default()
        },
        position: Coord6::xy_yaw(40.0, -4.0, std::f64::consts::FRAC_PI_2),
        ..CreateActor::default()
    })
    .map_err(e)?;
    Ok((ego, entry, npc))
}

/// The kinematic NPC: 20 kph along y = 3.5, one point per coming step,
/// 240 ms ahead.
fn npc_trajectory(ssp: &mut dyn Ssp, now_ms: u64, step_ms: u64, target: f64) -> Result<()> {
    let n = 240 / step_ms + 1;
    let points = (0..=n)
        .map(|j| {
            let t = (now_ms + j * step_ms) as f64 / 1000.0;
            Coord6 {
                x: Some(8.0 + target * t),
                y: Some(3.5),
                ..Coord6::default()
            }
        })
        .collect();
    ssp.set_xy_trajectory(
        "car1",
        XyTrajectory {
            start_time_ms: now_ms,
            end_time_ms: now_ms + n * step_ms,
            points,
            ..XyTrajectory::default()
        },
    )
    .map_err(e)?;
    Ok(())
}

/// Records a step's states; gives sut.car's speed, y and yaw when it is
/// among them.
fn record(
    rec: &mut LogRecorder,
    states: &[ReportedState],
    (ego, npc, entry): (&ActualDescription, &ActualDescription, &CatalogEntry),
) -> Option<(f64, f64, f64)> {
    let mass = |id: &str| if id == "walker" { 75.0 } else { entry.mass };
    let mut ego_state = None;
    for s in states {
        let mut sample = ActorSample::from_kinematics(
            s.pose,
            s.velocity,
            s.acceleration,
            s.yaw_rate,
            s.speed,
            mass(&s.actor_id),
        );
        if &*s.actor_id == "sut.car" {
            ego_state = Some((s.speed, s.pose.position.y, s.pose.yaw));
            sample.control = ControlSample {
                throttle: s.controls.throttle_pedal_pos.unwrap_or(f64::NAN),
                brake: s.controls.brake_pedal_pos.unwrap_or(f64::NAN),
                steering: s.controls.steering_wheel_angle.map_or(f64::NAN, |a| {
                    a / (entry.steering_ratio * entry.max_steer_angle_deg.to_radians())
                }),
                acceleration: f64::NAN,
                steering_angle: f64::NAN,
            };
        }
        let (len, wid, model) = match &*s.actor_id {
            "sut.car" => (ego.length, ego.width, ego.model_id.clone()),
            "car1" => (npc.length, npc.width, npc.model_id.clone()),
            _ => (0.5, 0.6, "pedestrian".into()),
        };
        rec.actor(
            &s.actor_id,
            if &*s.actor_id == "walker" {
                "person"
            } else {
                "vehicle/car"
            },
            &model,
            len,
            wid,
            mass(&s.actor_id),
        );
        let mode = match s.mode {
            MoveMode::Dynamic => "dynamic",
            MoveMode::External => "external",
            _ if s.trajectory != litesim_core::TrajectoryStatus::None => "trajectory",
            _ => "stored",
        };
        rec.sample(&s.actor_id, mode, &sample);
    }
    ego_state
}

fn summary(
    log: &SimulationLog,
    steps: u64,
    wall: std::time::Duration,
    min_gap: f64,
    transport: &str,
) {
    let sim = log.time.last().copied().unwrap_or(0.0);
    println!(
        "\n{steps} steps of {:.0} ms ({sim:.2} s simulated) in {:.1} ms over {transport}: {:.0}× real time",
        log.dt * 1000.0,
        wall.as_secs_f64() * 1000.0,
        sim / wall.as_secs_f64().max(1e-9)
    );
    println!(
        "{:<10} {:<11} {:>9} {:>9} {:>8} {:>10}",
        "actor", "mode", "x [m]", "y [m]", "yaw", "v [km/h]"
    );
    for t in &log.tracks {
        let i = t.len().saturating_sub(1);
        if t.is_empty() {
            continue;
        }
        println!(
            "{:<10} {:<11} {:>9.2} {:>9.2} {:>8.3} {:>10.1}",
            t.id,
            t.mode[i],
            t.state.x[i],
            t.state.y[i],
            t.state.yaw[i],
            t.state.speed[i] * 3.6
        );
    }
    println!("closest approach sut.car ↔ car1: {min_gap:.2} m");
}
