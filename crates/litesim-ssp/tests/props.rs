//! Property tests: no sequence of calls with any numbers (NaN, infinities,
//! huge values) panics a session, and every refused call leaves the session
//! usable.

use litesim_ssp::*;
use proptest::prelude::*;

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1e3f64..1e3,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => any::<f64>(),
        1 => Just(0.0),
    ]
}

fn opt_f64() -> impl Strategy<Value = Option<f64>> {
    prop::option::of(any_f64())
}

fn coord() -> impl Strategy<Value = Coord6> {
    (opt_f64(), opt_f64(), opt_f64(), opt_f64()).prop_map(|(x, y, z, yaw)| Coord6 {
        x,
        y,
        z,
        yaw,
        ..Coord6::default()
    })
}

#[derive(Clone, Debug)]
enum Call {
    Create(String, Coord6, Option<f64>),
    Destroy(String),
    Xy(String, Vec<Coord6>, u64, u64),
    Pedals(String, f64, f64, f64, u64),
    Physical(String, f64, f64, f64),
    Direct(String, f64, f64),
    External(String, String, Option<f64>),
    Step(Option<u64>),
    StartStep,
    WaitStep,
    End,
    Weather(f64, f64),
}

fn id() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("a".to_string()),
        Just("b".to_string()),
        Just("".to_string()),
        "[a-z]{1,3}"
    ]
}

fn call() -> impl Strategy<Value = Call> {
    prop_oneof![
        (id(), coord(), opt_f64()).prop_map(|(i, c, l)| Call::Create(i, c, l)),
        id().prop_map(Call::Destroy),
        (
            id(),
            prop::collection::vec(coord(), 0..5),
            0u64..500,
            0u64..500
        )
            .prop_map(|(i, p, s, e)| Call::Xy(i, p, s, e)),
        (id(), any_f64(), any_f64(), any_f64(), 0u64..200)
            .prop_map(|(i, t, b, s, v)| Call::Pedals(i, t, b, s, v)),
        (id(), any_f64(), any_f64(), any_f64()).prop_map(|(i, t, b, s)| Call::Physical(i, t, b, s)),
        (id(), any_f64(), any_f64()).prop_map(|(i, a, d)| Call::Direct(i, a, d)),
        (
            id(),
            prop_oneof![
                Just("idm".to_string()),
                Just("cruise".to_string()),
                Just("stop".to_string()),
                Just("release".to_string()),
                Just("warp".to_string())
            ],
            opt_f64()
        )
            .prop_map(|(i, c, v)| Call::External(i, c, v)),
        prop::option::of(0u64..400).prop_map(Call::Step),
        Just(Call::StartStep),
        Just(Call::WaitStep),
        Just(Call::End),
        (any_f64(), any_f64()).prop_map(|(a, b)| Call::Weather(a, b)),
    ]
}

fn apply(s: &mut Session, c: &Call) -> SspResult<()> {
    match c.clone() {
        Call::Create(id, position, length) => s
            .create_actor(CreateActor {
                actor_id: id,
                position,
                spec: ActorSpec {
                    length,
                    ..ActorSpec::default()
                },
                ..CreateActor::default()
            })
            .map(|_| ()),
        Call::Destroy(id) => s.destroy_actor(&id),
        Call::Xy(id, points, start, end) => s.set_xy_trajectory(
            &id,
            XyTrajectory {
                start_time_ms: start,
                end_time_ms: end,
                points,
                ..XyTrajectory::default()
            },
        ),
        Call::Pedals(id, throttle, brake, steering, until) => s.set_dynamic_move(
            &id,
            DynamicMove::Normalized {
                throttle,
                brake,
                steering,
            },
            until,
        ),
        Call::Physical(id, d, b, t) => s.set_dynamic_move(
            &id,
            DynamicMove::Physical {
                drive_force_n: d,
                brake_force_n: b,
                steer: PhysicalSteer::TorqueNm(t),
            },
            0,
        ),
        Call::Direct(id, a, d) => s.set_dynamic_move(
            &id,
            DynamicMove::Direct {
                acceleration: a,
                steering_angle_rad: d,
            },
            0,
        ),
        Call::External(id, controller, desired_speed) => s.set_external_controller(
            &id,
            ExternalMove {
                controller,
                desired_speed,
                ..ExternalMove::default()
            },
        ),
        Call::Step(t) => s.step(t, &ActorFilter::default()).map(|_| ()),
        Call::StartStep => s.start_step(None).map(|_| ()),
        Call::WaitStep => s.wait_step(0).map(|_| ()),
        Call::End => s.end_simulation("prop").map(|_| ()),
        Call::Weather(a, b) => s
            .set_weather(Weather {
                cloudiness: a,
                sun_altitude_deg: b,
                ..Weather::default()
            })
            .map(|_| ()),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn no_call_sequence_panics_or_corrupts(calls in prop::collection::vec(call(), 1..40)) {
        let mut s = Session::default();
        s.init(InitRequest::default()).unwrap();
        s.start_simulation(0).unwrap();
        s.wait_start_simulation(0).unwrap();
        for c in &calls {
            let _ = apply(&mut s, c);
            // Whatever happened, every reported number is finite.
            if let Ok(states) = s.get_actors_states(&ActorFilter::default()) {
                for st in states {
                    prop_assert!(st.pose.position.x.is_finite() && st.pose.position.y.is_finite(), "{st:?} after {c:?}");
                    prop_assert!(st.speed.is_finite() && st.yaw_rate.is_finite() && st.velocity.x.is_finite());
                }
            }
        }
    }

    #[test]
    fn refused_calls_change_nothing(c in call()) {
        let mut s = Session::default();
        s.init(InitRequest::default()).unwrap();
        s.start_simulation(0).unwrap();
        s.wait_start_simulation(0).unwrap();
        s.create_actor(CreateActor { actor_id: "a".into(), position: Coord6::xy_yaw(1.0, 2.0, 0.3), ..CreateActor::default() }).unwrap();
        let before = s.get_actors_states(&ActorFilter::default()).unwrap();
        let t0 = s.sim_time_ms();
        if apply(&mut s, &c).is_err() {
            prop_assert_eq!(s.sim_time_ms(), t0);
            prop_assert_eq!(s.get_actors_states(&ActorFilter::default()).unwrap_or_default(), before);
        }
    }
}

/// A trajectory point's values are checked one by one where one is bad:
/// the message names the point, the field and what was wrong; the
/// session keeps the actor's previous move.
#[test]
fn bad_trajectory_points_are_named() {
    let mut s = Session::default();
    s.init(InitRequest::default()).unwrap();
    s.start_simulation(0).unwrap();
    s.wait_start_simulation(0).unwrap();
    s.create_actor(CreateActor {
        actor_id: "a".into(),
        position: Coord6::xy_yaw(1.0, 2.0, 0.3),
        ..CreateActor::default()
    })
    .unwrap();
    let traj = |bad: Coord6| XyTrajectory {
        start_time_ms: 0,
        end_time_ms: 200,
        points: vec![
            Coord6::xy_yaw(1.0, 2.0, 0.3),
            bad,
            Coord6::xy_yaw(5.0, 2.0, 0.3),
        ],
        ..XyTrajectory::default()
    };
    let before = s.get_actors_states(&ActorFilter::default()).unwrap();
    for (bad, says) in [
        (Coord6::xy_yaw(f64::NAN, 2.0, 0.0), "polyline[1].x"),
        (Coord6::xy_yaw(3.0, f64::INFINITY, 0.0), "polyline[1].y"),
        (
            Coord6::xy_yaw(3.0, 2.0, f64::NEG_INFINITY),
            "polyline[1].yaw",
        ),
        (
            Coord6 {
                z: Some(2e9),
                ..Coord6::xy_yaw(3.0, 2.0, 0.0)
            },
            "polyline[1].z = 2000000000 is beyond ±1e9",
        ),
        (
            Coord6 {
                pitch: Some(f64::NAN),
                ..Coord6::xy_yaw(3.0, 2.0, 0.0)
            },
            "polyline[1].pitch",
        ),
        (
            Coord6 {
                y: None,
                ..Coord6::xy_yaw(3.0, 2.0, 0.0)
            },
            "polyline[1]: x and y are mandatory",
        ),
    ] {
        let e = s.set_xy_trajectory("a", traj(bad)).unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArgument, "{e:?}");
        assert!(e.message.contains(says), "{says}: {}", e.message);
        assert_eq!(
            s.get_actors_states(&ActorFilter::default()).unwrap(),
            before
        );
    }
    // A good one is taken and followed.
    s.set_xy_trajectory("a", traj(Coord6::xy_yaw(3.0, 2.0, 0.0)))
        .unwrap();
    let (_, st) = s.step(None, &ActorFilter::default()).unwrap();
    assert!(st[0].pose.position.x > 1.0, "{:?}", st[0]);
}
