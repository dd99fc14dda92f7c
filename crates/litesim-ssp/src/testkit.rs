//! Reference scenarios driven through any [`Ssp`], shared by the tests of
//! this crate, of `litesim-grpc` (over a real socket) and by benchmarks, so
//! that "in-process and remote give identical results" is checked on the
//! very same call sequence.

use crate::api::*;
use crate::error::SspResult;
use litesim_core::TrajectoryStatus;

/// The mixed 10-actor scenario: 3 stored actors (car, pedestrian, cone),
/// 3 xy-trajectory cars refreshed every 200 ms, a car on normalised pedals,
/// one on physical forces and torque, one on direct acceleration/steering,
/// and one IDM-controlled car following a trajectory car. 20 ms steps.
///
/// Returns the states read back after every step.
pub fn mixed_scenario(ssp: &mut dyn Ssp, steps: u64) -> SspResult<Vec<Vec<ReportedState>>> {
    ssp.init(InitRequest {
        client_name: "testkit".into(),
        step_size_ms: 20,
        profile: "dummy".into(),
        seed: 7,
        ..InitRequest::default()
    })?;
    ssp.start_simulation(0)?;
    ssp.wait_start_simulation(1000)?;
    mixed_cast(ssp)?;
    let mut out = Vec::with_capacity(steps as usize);
    for k in 0..steps {
        let now_ms = k * 20;
        if k % 10 == 0 {
            // A scenario engine's 200 ms refresh: one point per coming step, 12 steps ahead.
            for (i, id) in ["traj0", "traj1", "traj2"].iter().enumerate() {
                let speed = 8.0 + i as f64;
                let points = (0..=12)
                    .map(|j| {
                        let t = (now_ms + j * 20) as f64 / 1000.0;
                        let x = speed * t;
                        let y = -3.5 * i as f64 + (i as f64) * litesim_core::math::sin(0.5 * t);
                        Coord6 {
                            x: Some(x),
                            y: Some(y),
                            ..Coord6::default()
                        }
                    })
                    .collect();
                // The last refresh is skipped for traj2 so that it runs out.
                if !(i == 2 && k >= steps.saturating_sub(50)) {
                    ssp.set_xy_trajectory(
                        id,
                        XyTrajectory {
                            start_time_ms: now_ms,
                            end_time_ms: now_ms + 240,
                            points,
                            ..XyTrajectory::default()
                        },
                    )?;
                }
            }
        }
        let phase = (k / 100) % 4;
        let steering = [0.0, 0.2, -0.15, 0.05][phase as usize];
        ssp.set_dynamic_move(
            "pedals",
            DynamicMove::Normalized {
                throttle: if phase == 3 { 0.0 } else { 0.3 },
                brake: if phase == 3 { 0.05 } else { 0.0 },
                steering,
            },
            0,
        )?;
        ssp.set_dynamic_move(
            "forces",
            DynamicMove::Physical {
                drive_force_n: 1200.0 + 10.0 * phase as f64,
                brake_force_n: 0.0,
                steer: PhysicalSteer::TorqueNm(3.0 * steering),
            },
            0,
        )?;
        ssp.set_dynamic_move(
            "direct",
            DynamicMove::Direct {
                acceleration: 1.0 - 0.5 * phase as f64,
                steering_angle_rad: 0.05 * steering,
            },
            0,
        )?;
        ssp.start_step(None)?;
        ssp.wait_step(1000)?;
        out.push(ssp.get_actors_states(&ActorFilter::default())?);
    }
    ssp.end_simulation("done")?;
    Ok(out)
}

/// The mixed scenario's cast: a parked car, a pedestrian, a cone, three
/// trajectory cars, cars on pedals, forces and direct control, and an IDM
/// follower on an external controller.
fn mixed_cast(ssp: &mut dyn Ssp) -> SspResult<()> {
    let car = |id: &str, x: f64, y: f64, yaw: f64, v: f64| CreateActor {
        actor_id: id.into(),
        spec: ActorSpec {
            actor_type: "Vehicle".into(),
            ..ActorSpec::default()
        },
        position: Coord6::xy_yaw(x, y, yaw),
        speed: Coord6 {
            x: Some(v * litesim_core::math::cos(yaw)),
            y: Some(v * litesim_core::math::sin(yaw)),
            ..Coord6::default()
        },
        ..CreateActor::default()
    };
    ssp.create_actor(car("parked", 50.0, 3.5, 0.0, 0.0))?;
    ssp.create_actor(CreateActor {
        actor_id: "walker".into(),
        spec: ActorSpec {
            actor_type: "Pedestrian".into(),
            category: ActorCategory::Pedestrian,
            ..ActorSpec::default()
        },
        position: Coord6::xy_yaw(20.0, -5.0, 1.57),
        ..CreateActor::default()
    })?;
    ssp.create_actor(CreateActor {
        actor_id: "cone".into(),
        spec: ActorSpec {
            model_id: "static.cone".into(),
            ..ActorSpec::default()
        },
        position: Coord6::xy_yaw(30.0, 2.5, 0.0),
        ..CreateActor::default()
    })?;
    for (i, id) in ["traj0", "traj1", "traj2"].iter().enumerate() {
        ssp.create_actor(car(id, 0.0, -3.5 * i as f64, 0.0, 8.0))?;
    }
    ssp.create_actor(car("pedals", 0.0, 7.0, 0.0, 5.0))?;
    ssp.create_actor(car("forces", 0.0, 10.5, 0.0, 5.0))?;
    ssp.create_actor(car("direct", 0.0, 14.0, 0.0, 5.0))?;
    ssp.create_actor(car("follower", -30.0, 0.0, 0.0, 12.0))?;
    ssp.set_external_controller(
        "follower",
        ExternalMove {
            controller: "idm".into(),
            desired_speed: Some(15.0),
            ..ExternalMove::default()
        },
    )?;
    Ok(())
}

/// Canonical bytes of a run: every number's IEEE bits, little-endian, in
/// order, with ids and enum tags. Identical bytes ⇔ bit-identical runs.
pub fn encode(run: &[Vec<ReportedState>]) -> Vec<u8> {
    let mut b = Vec::new();
    for step in run {
        b.extend_from_slice(&(step.len() as u32).to_le_bytes());
        for s in step {
            b.extend_from_slice(s.actor_id.as_bytes());
            b.push(0);
            let p = &s.pose;
            for v in [
                p.position.x,
                p.position.y,
                p.position.z,
                p.roll,
                p.pitch,
                p.yaw,
                s.velocity.x,
                s.velocity.y,
                s.velocity.z,
                s.acceleration.x,
                s.acceleration.y,
                s.acceleration.z,
                s.yaw_rate,
                s.speed,
            ] {
                b.extend_from_slice(&v.to_bits().to_le_bytes());
            }
            b.push(s.mode as u8);
            b.push(match s.trajectory {
                TrajectoryStatus::None => 0,
                TrajectoryStatus::Following => 1,
                TrajectoryStatus::NotStarted => 2,
                TrajectoryStatus::Exhausted => 3,
            });
        }
    }
    b
}

/// FNV-1a, 64 bit: a small, dependency-free digest for golden tests.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &x in bytes {
        h ^= u64::from(x);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}
