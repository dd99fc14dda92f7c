//! The SSP API over a real loopback socket: equality with the in-process
//! model, every class of bad input, sessions, streaming, health and traces.

use litesim_grpc::pb;
use litesim_grpc::{RemoteSsp, ServerConfig};
use litesim_ssp::testkit::{encode, mixed_scenario};
use litesim_ssp::*;
use std::net::SocketAddr;

mod common;
use common::health_status;

type Server = litesim_grpc::LoopbackServer;

fn start(cfg: ServerConfig) -> Server {
    litesim_grpc::LoopbackServer::start(cfg, 2).unwrap()
}

fn running(addr: SocketAddr) -> RemoteSsp {
    let mut c = RemoteSsp::connect(&addr.to_string()).unwrap();
    c.init(InitRequest::default()).unwrap();
    c.start_simulation(0).unwrap();
    c.wait_start_simulation(100).unwrap();
    c
}

fn car(id: &str) -> CreateActor {
    CreateActor {
        actor_id: id.into(),
        position: Coord6::xy_yaw(0.0, 0.0, 0.0),
        ..CreateActor::default()
    }
}

#[test]
fn remote_run_is_bit_identical_to_in_process() {
    let server = start(ServerConfig::default());
    let local = encode(&mixed_scenario(&mut Session::default(), 1000).unwrap());
    let mut remote = RemoteSsp::connect(&server.addr.to_string()).unwrap();
    let over_grpc = encode(&mixed_scenario(&mut remote, 1000).unwrap());
    assert_eq!(local.len(), over_grpc.len());
    assert!(local == over_grpc, "in-process and gRPC runs differ");
}

#[test]
fn bad_input_gets_the_right_code_and_the_server_keeps_serving() {
    let server = start(ServerConfig {
        max_message_bytes: 64 * 1024,
        ..ServerConfig::default()
    });
    let mut bystander = running(server.addr);
    bystander.create_actor(car("b")).unwrap();
    bystander
        .set_dynamic_move(
            "b",
            DynamicMove::Normalized {
                throttle: 0.5,
                brake: 0.0,
                steering: 0.0,
            },
            0,
        )
        .unwrap();
    bystander.step(None, &ActorFilter::default()).unwrap();
    let before = bystander
        .get_actors_states(&ActorFilter::default())
        .unwrap();

    let mut c = RemoteSsp::connect(&server.addr.to_string()).unwrap();
    // Wrong life-cycle state, before init: the session does not exist yet.
    let e = c.start_step(None).unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument, "{e}"); // session_id missing
    c.init(InitRequest::default()).unwrap();
    let e = c.start_step(None).unwrap_err();
    assert_eq!(e.code, ErrorCode::FailedPrecondition);
    assert!(
        e.message.contains("INITIALIZED") && e.message.contains("start_simulation"),
        "{}",
        e.message
    );
    c.start_simulation(0).unwrap();
    // Valid in another state: FAILED_PRECONDITION naming the state.
    let e = c.start_simulation(0).unwrap_err();
    assert_eq!(e.code, ErrorCode::FailedPrecondition);
    assert!(e.message.contains("STARTING"), "{}", e.message);
    c.wait_start_simulation(10).unwrap();
    let e = c.wait_step(10).unwrap_err();
    assert_eq!(e.code, ErrorCode::FailedPrecondition);

    // Missing and NaN fields.
    let e = c
        .create_actor(CreateActor {
            actor_id: "x".into(),
            position: Coord6 {
                x: Some(1.0),
                ..Coord6::default()
            },
            ..CreateActor::default()
        })
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument);
    assert!(
        e.message.contains("position.y") || e.message.contains("position.x and position.y"),
        "{}",
        e.message
    );
    let e = c
        .create_actor(CreateActor {
            actor_id: "x".into(),
            position: Coord6::xy_yaw(0.0, f64::NAN, 0.0),
            ..CreateActor::default()
        })
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument);
    assert!(e.message.contains("position.y"), "{}", e.message);
    c.create_actor(car("a")).unwrap();
    assert_eq!(
        c.create_actor(car("a")).unwrap_err().code,
        ErrorCode::AlreadyExists
    );
    let e = c
        .set_dynamic_move(
            "a",
            DynamicMove::Normalized {
                throttle: f64::NAN,
                brake: 0.0,
                steering: 0.0,
            },
            0,
        )
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument);
    assert!(e.message.contains("throttle"), "{}", e.message);
    let e = c
        .set_dynamic_move(
            "a",
            DynamicMove::Physical {
                drive_force_n: -5.0,
                brake_force_n: 0.0,
                steer: PhysicalSteer::TorqueNm(0.0),
            },
            0,
        )
        .unwrap_err();
    assert!(
        e.code == ErrorCode::InvalidArgument && e.message.contains("throttle"),
        "{e}"
    );
    let e = c
        .set_dynamic_move(
            "a",
            DynamicMove::Normalized {
                throttle: 0.0,
                brake: 0.0,
                steering: 2.0,
            },
            0,
        )
        .unwrap_err();
    assert!(e.message.contains("steering"), "{e}");
    let e = c
        .set_xy_trajectory("a", XyTrajectory::default())
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument);
    c.step(None, &ActorFilter::default()).unwrap();
    let e = c.start_step(Some(20)).unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument, "a time not after now");

    // Unknown ids.
    assert_eq!(
        c.destroy_actor("ghost").unwrap_err().code,
        ErrorCode::NotFound
    );
    assert_eq!(
        c.set_dynamic_move(
            "ghost",
            DynamicMove::Normalized {
                throttle: 0.0,
                brake: 0.0,
                steering: 0.0
            },
            0
        )
        .unwrap_err()
        .code,
        ErrorCode::NotFound
    );
    let e = c
        .get_actors_states(&ActorFilter {
            actor_ids: vec!["ghost".into()],
            ..ActorFilter::default()
        })
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::NotFound);
    let e = c
        .create_actor(CreateActor {
            spec: ActorSpec {
                model_id: "vehicle.flux.capacitor".into(),
                ..ActorSpec::default()
            },
            ..car("q")
        })
        .unwrap_err();
    assert!(
        e.code == ErrorCode::NotFound && e.message.contains("dummy.vehicle"),
        "{e}"
    );
    assert_eq!(
        c.sim_command("warp", &[]).unwrap_err().code,
        ErrorCode::Unimplemented
    );

    // Oversized request: RESOURCE_EXHAUSTED from the transport limit.
    let huge = XyTrajectory {
        start_time_ms: 0,
        end_time_ms: 100_000,
        points: (0..20_000)
            .map(|i| Coord6::xy_yaw(i as f64, 0.0, 0.0))
            .collect(),
        ..XyTrajectory::default()
    };
    let e = c.set_xy_trajectory("a", huge).unwrap_err();
    assert_eq!(e.code, ErrorCode::ResourceExhausted, "{e}");
    // Too many steps in one call.
    let e = c.start_step(Some(10_000_000_000)).unwrap_err();
    assert_eq!(e.code, ErrorCode::ResourceExhausted, "{e}");

    // The session still works after all that.
    c.step(None, &ActorFilter::default()).unwrap();
    // The bystander saw none of it.
    assert_eq!(
        bystander
            .get_actors_states(&ActorFilter::default())
            .unwrap(),
        before
    );
    bystander.step(None, &ActorFilter::default()).unwrap();

    // Unknown sessions.
    c.shutdown().unwrap();
    assert_eq!(
        c.step(None, &ActorFilter::default()).unwrap_err().code,
        ErrorCode::NotFound
    );
}

#[test]
fn session_and_actor_limits() {
    let server = start(ServerConfig {
        max_sessions: 2,
        limits: SessionLimits {
            max_actors: 3,
            ..SessionLimits::default()
        },
        ..ServerConfig::default()
    });
    let mut a = running(server.addr);
    let _b = running(server.addr);
    let mut c = RemoteSsp::connect(&server.addr.to_string()).unwrap();
    let e = c.init(InitRequest::default()).unwrap_err();
    assert_eq!(e.code, ErrorCode::ResourceExhausted);
    for i in 0..3 {
        a.create_actor(car(&format!("c{i}"))).unwrap();
    }
    assert_eq!(
        a.create_actor(car("c3")).unwrap_err().code,
        ErrorCode::ResourceExhausted
    );
    a.shutdown().unwrap();
    c.init(InitRequest::default()).unwrap();
}

#[test]
fn many_clients_run_independent_simulations_at_once() {
    let server = start(ServerConfig::default());
    let addr = server.addr;
    let local = encode(&mixed_scenario(&mut Session::default(), 200).unwrap());
    let threads: Vec<_> = (0..4)
        .map(|_| {
            std::thread::spawn(move || {
                let mut c = RemoteSsp::connect(&addr.to_string()).unwrap();
                encode(&mixed_scenario(&mut c, 200).unwrap())
            })
        })
        .collect();
    for t in threads {
        assert!(t.join().unwrap() == local);
    }
}

#[test]
fn step_stream_lock_step() {
    use pb::move_command::Cmd;
    let server = start(ServerConfig::default());
    let mut c = running(server.addr);
    c.create_actor(car("a")).unwrap();
    let sid = c.session_id().to_string();
    let (rt, raw) = c.raw();
    let mut raw = raw.clone();
    let results = rt.block_on(async move {
        let (tx, rx) = tokio::sync::mpsc::channel(4);
        let mut out = raw
            .step_stream(tokio_stream::wrappers::ReceiverStream::new(rx))
            .await
            .unwrap()
            .into_inner();
        let mut got = Vec::new();
        for seq in 1..=50u64 {
            let moves = vec![
                pb::MoveCommand {
                    cmd: Some(Cmd::Dynamic(litesim_grpc::convert::dynamic_pb(
                        "",
                        "a",
                        &DynamicMove::Normalized {
                            throttle: 0.5,
                            brake: 0.0,
                            steering: 0.1,
                        },
                        0,
                    ))),
                },
                // A bad command is rejected, the step still happens.
                pb::MoveCommand {
                    cmd: Some(Cmd::Dynamic(litesim_grpc::convert::dynamic_pb(
                        "",
                        "ghost",
                        &DynamicMove::Normalized {
                            throttle: 0.5,
                            brake: 0.0,
                            steering: 0.1,
                        },
                        0,
                    ))),
                },
            ];
            tx.send(pb::StepCommand {
                session_id: if seq == 1 { sid.clone() } else { String::new() },
                seq,
                moves,
                ..Default::default()
            })
            .await
            .unwrap();
            got.push(out.message().await.unwrap().unwrap());
        }
        got
    });
    assert_eq!(results.len(), 50);
    for (i, r) in results.iter().enumerate() {
        assert_eq!(r.seq, i as u64 + 1);
        assert_eq!(r.sim_time_ms, 20 * (i as u64 + 1));
        assert_eq!(r.rejected.len(), 1);
        assert_eq!(r.rejected[0].code, tonic::Code::NotFound as i32);
    }
    let last = &results[49].states[0];
    assert!(last.speed_mps > 0.0);
    // The same steps in-process give the same state, bit for bit.
    let mut s = Session::default();
    s.init(InitRequest::default()).unwrap();
    s.start_simulation(0).unwrap();
    s.wait_start_simulation(0).unwrap();
    s.create_actor(car("a")).unwrap();
    for _ in 0..50 {
        s.set_dynamic_move(
            "a",
            DynamicMove::Normalized {
                throttle: 0.5,
                brake: 0.0,
                steering: 0.1,
            },
            0,
        )
        .unwrap();
        s.step(None, &ActorFilter::default()).unwrap();
    }
    let st = &s.get_actors_states(&ActorFilter::default()).unwrap()[0];
    assert_eq!(
        last.position.unwrap().x.unwrap().to_bits(),
        st.pose.position.x.to_bits()
    );
    assert_eq!(last.speed_mps.to_bits(), st.speed.to_bits());
}

#[test]
fn health_reports_serving() {
    let server = start(ServerConfig::default());
    let status = health_status(&server.addr.to_string());
    assert_eq!(
        status,
        tonic_health::pb::health_check_response::ServingStatus::Serving as i32
    );
}

#[test]
fn trace_rpc_writes_every_call_as_json_lines() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("trace.jsonl");
    {
        let server = start(ServerConfig {
            trace_rpc: Some(path.clone()),
            ..ServerConfig::default()
        });
        let mut c = running(server.addr);
        c.create_actor(car("a")).unwrap();
        let _ = c.destroy_actor("ghost");
        c.step(None, &ActorFilter::default()).unwrap();
    }
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let methods: Vec<&str> = lines
        .iter()
        .map(|l| l["method"].as_str().unwrap())
        .collect();
    assert_eq!(
        methods,
        [
            "init",
            "start_simulation",
            "wait_start_simulation",
            "create_actor",
            "destroy_actor",
            "step",
            // The client frees its session when dropped.
            "shutdown"
        ]
    );
    assert_eq!(lines[3]["args"]["actor_id"], "a");
    assert_eq!(lines[4]["result"]["error"]["code"], "NOT_FOUND");
}

#[test]
fn step_many_equals_repeated_steps_and_refuses_bad_counts() {
    let server = start(ServerConfig::default());
    let mut a = running(server.addr);
    let mut local = Session::new("dummy", "dummy", SessionLimits::default());
    local.init(InitRequest::default()).unwrap();
    local.start_simulation(0).unwrap();
    local.wait_start_simulation(100).unwrap();
    for s in [&mut a as &mut dyn Ssp, &mut local] {
        let mut c = car("c");
        c.speed = Coord6 {
            x: Some(5.0),
            ..Coord6::default()
        };
        s.create_actor(c).unwrap();
        s.set_external_controller(
            "c",
            ExternalMove {
                controller: "cruise".into(),
                desired_speed: Some(10.0),
                ..ExternalMove::default()
            },
        )
        .unwrap();
    }
    let f = ActorFilter::default();
    let many = a.step_many(25, &f).unwrap();
    let one_by_one: Vec<_> = (0..25).map(|_| local.step(None, &f).unwrap()).collect();
    assert_eq!(many.len(), 25);
    assert_eq!(many, one_by_one);
    for bad in [0, MAX_STEPS_PER_CALL + 1] {
        let e = a.step_many(bad, &f).unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArgument, "{e:?}");
        assert!(e.message.contains("1 to 10000"), "{}", e.message);
    }
    // The session is intact after the refusals.
    assert_eq!(a.step(None, &f).unwrap().0.step_index, 26);
    // A reply of more than MAX_STATES_PER_CALL states is refused before
    // anything steps (100 actors × 10,000 steps = 1,000,000 states), with
    // the count that would fit; a filter makes the same call fit.
    for k in 0..99 {
        let mut c = car(&format!("x{k}"));
        c.position.y = Some(10.0 + k as f64 * 5.0);
        a.create_actor(c).unwrap();
    }
    let e = a.step_many(MAX_STEPS_PER_CALL, &f).unwrap_err();
    assert_eq!(e.code, ErrorCode::ResourceExhausted, "{e:?}");
    assert!(
        e.message.contains("at most 2000 steps per call"),
        "{}",
        e.message
    );
    assert_eq!(a.step(None, &f).unwrap().0.step_index, 27);
    let only_c = ActorFilter {
        actor_ids: vec!["c".into()],
        ..ActorFilter::default()
    };
    assert_eq!(
        a.step_many(MAX_STEPS_PER_CALL, &only_c).unwrap().len(),
        10_000
    );
}

/// `step_many_kinematics`: the in-process session writes the states from
/// its world, a remote simulator gets them with `step_many` (the trait's
/// default) — the same numbers as each step's reports, in the profile's
/// frame (CARLA's mirrored one too), ids once; too big a reply is refused
/// before anything steps.
#[test]
fn kinematic_steps_equal_the_reports_locally_and_over_the_socket() {
    let server = start(ServerConfig::default());
    for profile in ["dummy", "carla-0.9.15"] {
        let init = InitRequest {
            profile: profile.into(),
            ..InitRequest::default()
        };
        let mut remote = RemoteSsp::connect(&server.addr.to_string()).unwrap();
        let mut local = Session::default();
        let mut reports = Session::default();
        for s in [&mut remote as &mut dyn Ssp, &mut local, &mut reports] {
            s.init(init.clone()).unwrap();
            s.start_simulation(0).unwrap();
            s.wait_start_simulation(100).unwrap();
            for (k, id) in ["a", "b", "c"].into_iter().enumerate() {
                let mut c = car(id);
                c.position = Coord6::xy_yaw(10.0 * k as f64, 3.0 * k as f64, 0.2 * k as f64);
                c.speed = Coord6 {
                    x: Some(4.0 + k as f64),
                    ..Coord6::default()
                };
                s.create_actor(c).unwrap();
                s.set_external_controller(
                    id,
                    ExternalMove {
                        controller: "cruise".into(),
                        desired_speed: Some(12.0),
                        ..ExternalMove::default()
                    },
                )
                .unwrap();
            }
        }
        let mut want = KinematicSteps::default();
        for (info, states) in reports.step_many(30, &ActorFilter::default()).unwrap() {
            want.push_reported(info, &states).unwrap();
        }
        assert_eq!(want.ids, ["a", "b", "c"]);
        assert_eq!(want.states.len(), 90);
        assert_eq!(
            want.step(29)[1],
            Kinematics::from(&reports.get_actors_states(&ActorFilter::default()).unwrap()[1])
        );
        for s in [&mut remote as &mut dyn Ssp, &mut local] {
            let mut got = KinematicSteps::default();
            s.step_many_kinematics(30, &mut got).unwrap();
            assert_eq!(got, want, "{profile}");
            // The buffer is emptied and reused.
            s.step_many_kinematics(2, &mut got).unwrap();
            assert_eq!(got.infos.len(), 2);
            assert_eq!(got.infos[1].step_index, 32);
            assert_eq!(got.states.len(), 6);
        }
        // In the profile's frame, as the actor was created (CARLA's mirrored
        // one is mirrored back at the boundary both ways).
        assert!(
            (want.step(0)[1].pose.position.y - 3.0).abs() < 0.1,
            "{profile}"
        );
    }
    // 100 actors × 10,000 steps: refused with the count that fits, nothing stepped.
    let mut s = Session::default();
    s.init(InitRequest::default()).unwrap();
    s.start_simulation(0).unwrap();
    s.wait_start_simulation(100).unwrap();
    for k in 0..100 {
        let mut c = car(&format!("x{k}"));
        c.position.y = Some(k as f64 * 5.0);
        s.create_actor(c).unwrap();
    }
    let mut got = KinematicSteps::default();
    let e = s
        .step_many_kinematics(MAX_STEPS_PER_CALL, &mut got)
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::ResourceExhausted, "{e:?}");
    assert!(
        e.message.contains("at most 2000 steps per call"),
        "{}",
        e.message
    );
    let e = s.step_many_kinematics(0, &mut got).unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument, "{e:?}");
    assert_eq!(
        s.step(None, &ActorFilter::default()).unwrap().0.step_index,
        1
    );
    // Steps of one call that report other actors are refused.
    let mut steps = KinematicSteps::default();
    let (i1, one) = s.step(None, &ActorFilter::default()).unwrap();
    steps.push_reported(i1, &one).unwrap();
    let e = steps.push_reported(i1, &one[1..]).unwrap_err();
    assert_eq!(e.code, ErrorCode::Internal, "{e:?}");
    assert!(e.message.contains("other actors"), "{}", e.message);
}

#[test]
fn huge_ids_get_bounded_answers_not_transport_errors() {
    let server = start(ServerConfig::default());
    let mut c = running(server.addr);
    let huge = "x".repeat(1 << 20);
    // An unknown session named by 1 MiB: NOT_FOUND, its id cut in the message.
    let (rt, raw) = c.raw();
    let e = rt
        .block_on(raw.start_step(litesim_grpc::pb::StartStepRequest {
            session_id: huge.clone(),
            ..Default::default()
        }))
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound, "{e:?}");
    assert!(
        e.message().contains("…(1048576 bytes)") && e.message().len() < 300,
        "{}",
        &e.message()[..e.message().len().min(300)]
    );
    // Unknown actor named by 1 MiB: NOT_FOUND, bounded.
    let e = c.destroy_actor(&huge).unwrap_err();
    assert_eq!(
        e.code,
        ErrorCode::NotFound,
        "{}",
        &e.message[..200.min(e.message.len())]
    );
    assert!(e.message.len() < 300, "{} bytes", e.message.len());
    // An id over the documented maximum is refused at creation.
    let e = c.create_actor(car(&"y".repeat(257))).unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument);
    assert!(e.message.contains("at most 256 bytes"), "{}", e.message);
    c.create_actor(car(&"y".repeat(256))).unwrap();
    // The session goes on.
    c.step(None, &ActorFilter::default()).unwrap();
}

#[test]
fn odd_map_paths_are_refused_at_once_and_never_hold_up_others() {
    let dir = tempfile::tempdir().unwrap();
    // Odd files under the server's map roots (outside them nothing is
    // opened at all: tests/sessions.rs).
    let server = start(ServerConfig {
        map_roots: vec![dir.path().to_path_buf(), "/dev".into()],
        ..ServerConfig::default()
    });
    let fifo = dir.path().join("map.fifo");
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let mut bystander = running(server.addr);
    bystander.create_actor(car("b")).unwrap();
    for (path, what) in [
        (fifo.display().to_string(), "not a regular file"),
        ("/dev/zero".to_string(), "not a regular file"),
        (dir.path().display().to_string(), "directory"),
    ] {
        // Another client keeps being answered while this Init is refused.
        let addr = server.addr;
        let p = path.clone();
        let t = std::thread::spawn(move || {
            let mut c = RemoteSsp::connect(&addr.to_string()).unwrap();
            let started = std::time::Instant::now();
            let e = c
                .init(InitRequest {
                    map: Some(p),
                    ..InitRequest::default()
                })
                .unwrap_err();
            (e, started.elapsed())
        });
        let started = std::time::Instant::now();
        bystander.step(None, &ActorFilter::default()).unwrap();
        assert!(started.elapsed() < std::time::Duration::from_millis(100));
        let (e, took) = t.join().unwrap();
        assert_eq!(e.code, ErrorCode::InvalidArgument, "{path}: {e}");
        assert!(e.message.contains(what), "{path}: {}", e.message);
        assert!(took < std::time::Duration::from_secs(1), "{path}: {took:?}");
    }
}

#[test]
fn nan_traffic_light_numbers_are_invalid_arguments_naming_the_field() {
    let server = start(ServerConfig::default());
    for (mut b, field) in [
        (litesim_ssp::TrafficLightBox::default(), "pose.x"),
        (litesim_ssp::TrafficLightBox::default(), "bulbs[0].counter"),
        (litesim_ssp::TrafficLightBox::default(), ".s"),
    ] {
        b.id = "tl1".into();
        b.pose = Coord6::xy_yaw(1.0, 2.0, 0.0);
        b.bulbs = vec![litesim_ssp::Bulb::default()];
        match field {
            "pose.x" => b.pose.x = Some(f64::NAN),
            ".s" => b.s = f64::INFINITY,
            _ => b.bulbs[0].counter = Some(f64::NAN),
        }
        let mut c = RemoteSsp::connect(&server.addr.to_string()).unwrap();
        let e = c
            .init(InitRequest {
                traffic_lights: vec![b],
                ..InitRequest::default()
            })
            .unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArgument, "{field}: {e}");
        assert!(
            e.message.contains(field) && e.message.contains("tl1"),
            "{field}: {}",
            e.message
        );
    }
}

#[test]
fn with_an_idle_timeout_silent_sessions_are_reclaimed_within_the_lease() {
    let lease = std::time::Duration::from_millis(800);
    let server = start(ServerConfig {
        max_sessions: 4,
        idle_timeout: Some(lease),
        ..ServerConfig::default()
    });
    // One client keeps its session with explicit keep-alives …
    let mut keeper = RemoteSsp::connect(&server.addr.to_string()).unwrap();
    keeper.init(InitRequest::default()).unwrap();
    assert_eq!(keeper.keep_alive().unwrap(), lease);
    // … three keep their connections open but fall silent (a hung client:
    // the connection alone would keep their sessions; the lease does not).
    let mut silent = Vec::new();
    for _ in 0..3 {
        // Init through the raw client: the RemoteSsp does not know the
        // session and never renews it.
        let mut c = RemoteSsp::connect(&server.addr.to_string()).unwrap();
        let (rt, raw) = c.raw();
        rt.block_on(raw.init(pb::InitRequest::default())).unwrap();
        silent.push(c);
    }
    let mut fresh = RemoteSsp::connect(&server.addr.to_string()).unwrap();
    let e = fresh.init(InitRequest::default()).unwrap_err();
    assert_eq!(e.code, ErrorCode::ResourceExhausted);
    // Within the lease (plus the reaper's beat) their places are free again.
    let started = std::time::Instant::now();
    for _ in 0..6 {
        std::thread::sleep(lease / 4);
        keeper.keep_alive().unwrap();
    }
    let mut others = Vec::new();
    for _ in 0..3 {
        let mut c = RemoteSsp::connect(&server.addr.to_string()).unwrap();
        c.init(InitRequest::default()).unwrap();
        others.push(c);
    }
    assert!(started.elapsed() < lease * 3);
    // The kept session lived through it.
    keeper.start_simulation(0).unwrap();
}

#[test]
fn oversized_stream_messages_are_resource_exhausted() {
    let server = start(ServerConfig {
        max_message_bytes: 1 << 20,
        ..ServerConfig::default()
    });
    let mut c = running(server.addr);
    let sid = c.session_id().to_string();
    let (rt, raw) = c.raw();
    let mut raw = raw.clone();
    let code = rt.block_on(async move {
        let (tx, rx) = tokio::sync::mpsc::channel(4);
        let call = raw.step_stream(tokio_stream::wrappers::ReceiverStream::new(rx));
        // A 2 MiB command (a huge actor id list in the filter) on a server
        // that takes 1 MiB per message.
        tx.send(pb::StepCommand {
            session_id: sid,
            seq: 1,
            state_filter: Some(pb::ActorFilter {
                actor_ids: vec!["x".repeat(1 << 21)],
                ..Default::default()
            }),
            ..Default::default()
        })
        .await
        .unwrap();
        match call.await {
            Err(s) => s.code(),
            Ok(resp) => {
                let mut out = resp.into_inner();
                match out.message().await {
                    Err(s) => s.code(),
                    Ok(m) => panic!("answered: {m:?}"),
                }
            }
        }
    });
    assert_eq!(code, tonic::Code::ResourceExhausted);
}

/// Paced stepping per session (issue 16 point 5): a session that asks for
/// it answers its steps no earlier than the wall clock reaches the
/// simulated time; another session on the same server steps at full speed
/// meanwhile; pacing can be switched off again.
#[test]
fn a_session_can_ask_for_paced_stepping() {
    use litesim_ssp::{ActorFilter, Ssp};
    let server = start(ServerConfig::default());
    let mut paced = running(server.addr);
    paced.create_actor(car("a")).unwrap();
    assert_eq!(paced.set_pacing(true).unwrap(), 20);
    let fast_addr = server.addr;
    let t0 = std::time::Instant::now();
    // 25 steps of 20 ms = 0.5 s, in five StepMany calls and five Steps.
    let other = std::thread::spawn(move || {
        let mut fast = running(fast_addr);
        let t = std::time::Instant::now();
        fast.step_many(500, &ActorFilter::default()).unwrap();
        t.elapsed()
    });
    for _ in 0..4 {
        paced.step_many(5, &ActorFilter::default()).unwrap();
    }
    for _ in 0..5 {
        paced.step(None, &ActorFilter::default()).unwrap();
    }
    let took = t0.elapsed().as_secs_f64();
    assert!(
        (0.495..0.65).contains(&took),
        "25 paced steps of 20 ms took {took} s"
    );
    // 500 unpaced steps (10 s simulated) in well under their simulated time.
    assert!(other.join().unwrap().as_secs_f64() < 2.0);
    paced.set_pacing(false).unwrap();
    let t = std::time::Instant::now();
    paced.step_many(100, &ActorFilter::default()).unwrap();
    assert!(t.elapsed().as_secs_f64() < 1.0);
}
