//! World behaviour that the batch loops must keep.

use litesim_core::*;

fn world(batching: bool) -> World {
    let mut w = World::with_step_ms(20).unwrap();
    w.set_batching(batching);
    let model = VehicleModelKind::Ssp(SspDynamics::for_length(4.5));
    let state = ActorState {
        speed: 10.0,
        ..ActorState::at_rest(Pose::planar(0.0, 0.0, 0.3))
    };
    w.add_actor(Actor::new(
        "car",
        ActorDescription::car("t"),
        state,
        Some(model),
    ))
    .unwrap();
    w
}

const THROTTLE: VehicleInput = VehicleInput::Pedals(NormalizedPedals {
    throttle: 0.5,
    brake: 0.0,
    steering: 0.2,
});

#[test]
fn a_command_runs_out_after_its_last_tick() {
    for batching in [true, false] {
        let mut w = world(batching);
        w.set_mode(
            "car",
            ControlMode::Dynamic {
                input: THROTTLE,
                valid_until_tick: Some(5),
            },
        )
        .unwrap();
        let mut speeds = Vec::new();
        for tick in 1..=8 {
            w.step();
            let a = w.actor("car").unwrap();
            speeds.push(a.state().speed);
            let want = if tick <= 5 {
                THROTTLE
            } else {
                VehicleInput::default()
            };
            assert_eq!(a.last_input(), want, "tick {tick}, batching {batching}");
        }
        // Throttle for five steps, then coasting at 2 m/s².
        assert!(speeds[4] > speeds[3] && speeds[5] < speeds[4], "{speeds:?}");
        assert!((speeds[6] - (speeds[5] - 2.0 * 0.02)).abs() < 1e-12);
    }
}

#[test]
fn a_state_reads_as_given_until_the_first_integrated_step() {
    for batching in [true, false] {
        let mut w = world(batching);
        let given = w.actor("car").unwrap().state();
        w.set_mode(
            "car",
            ControlMode::Dynamic {
                input: THROTTLE,
                valid_until_tick: None,
            },
        )
        .unwrap();
        assert_eq!(w.actor("car").unwrap().state(), given);
        w.step();
        let after = w.actor("car").unwrap().state();
        assert!(after.speed > given.speed && after.pose.position.x > 0.0);
        // Back to stored: the state last reported is kept.
        w.set_mode("car", ControlMode::Stored).unwrap();
        w.step();
        assert_eq!(w.actor("car").unwrap().state(), after);
        // Leaving the world, the actor takes that state along.
        assert_eq!(w.remove_actor("car").unwrap().state(), after);
    }
}

#[test]
fn typical_commands_take_the_batch_path() {
    use litesim_core::vehicle::batch::Kernel;
    let st = VehicleState {
        v: 12.0,
        yaw: 2.0,
        ..VehicleState::default()
    };
    let mut ssp = SspDynamics::for_length(4.5);
    let mut bike = KinematicBicycle::new(2.7);
    for input in [
        THROTTLE,
        VehicleInput::default(),
        VehicleInput::Direct {
            acceleration: -3.0,
            steering_angle: 0.1,
        },
    ] {
        assert_eq!(
            ssp.compile(&input, &st, 0.02).map(|c| c.kernel()),
            Some(Kernel::Ssp)
        );
        assert_eq!(
            bike.compile(&input, &st, 0.02).map(|c| c.kernel()),
            Some(Kernel::Bicycle)
        );
    }
    // A heading the scalar wrap would reduce by its slow path: one by one.
    let far = VehicleState { yaw: 7.0, ..st };
    assert!(ssp.compile(&THROTTLE, &far, 0.02).is_none());
    assert!(bike.compile(&THROTTLE, &far, 0.02).is_none());
}

#[test]
fn a_negative_speed_limit_is_left_to_the_model() {
    // Limits are public fields. With a cap of −50 m/s the bicycle's speed
    // jumps to −50 after one step and the heading then turns by ~11 rad per
    // step — more than one wrap, which only the scalar `wrap_angle` does
    // right; the start speed alone (0.5 m/s) would not show it.
    let mut bike = KinematicBicycle::new(0.05);
    bike.max_speed = -50.0;
    let st = VehicleState {
        v: 0.5,
        ..VehicleState::default()
    };
    let input = VehicleInput::Direct {
        acceleration: 1.0,
        steering_angle: 0.5,
    };
    assert!(bike.compile(&input, &st, 0.02).is_none());
    let mut s = st;
    bike.step(&mut s, &input, 0.02);
    let before = s.yaw;
    bike.step(&mut s, &input, 0.02);
    assert!((s.yaw - before).abs() > 0.1, "{before} → {}", s.yaw);
}

/// A gear change through `set_model`: the state carries on, the standing
/// command is recompiled with the new model (reversing is stepped one by
/// one, driving forwards by the batch loops), and batching changes no bit.
#[test]
fn a_model_swapped_mid_run_changes_gear_and_keeps_the_state() {
    let run = |batching: bool| {
        let mut w = World::with_step_ms(20).unwrap();
        w.set_batching(batching);
        let bike = KinematicBicycle::new(2.7);
        w.add_actor(Actor::new(
            "car",
            ActorDescription::car("t"),
            ActorState::at_rest(Pose::planar(0.0, 0.0, 0.0)),
            Some(VehicleModelKind::Bicycle(bike.clone())),
        ))
        .unwrap();
        let drive = |w: &mut World, acceleration: f64| {
            w.set_mode(
                "car",
                ControlMode::Dynamic {
                    input: VehicleInput::Direct {
                        acceleration,
                        steering_angle: 0.1,
                    },
                    valid_until_tick: None,
                },
            )
            .unwrap();
        };
        let mut trace = Vec::new();
        drive(&mut w, 1.0);
        for _ in 0..50 {
            w.step();
        }
        drive(&mut w, -2.0);
        for _ in 0..50 {
            w.step();
            trace.push(w.actor("car").unwrap().state());
        }
        // Stopped: the same braking command holds it at rest in drive.
        assert_eq!(trace.last().unwrap().speed, 0.0);
        let stopped = trace.last().unwrap().pose;
        let mut reverse = bike.clone();
        reverse.reverse = true;
        w.set_model("car", VehicleModelKind::Bicycle(reverse))
            .unwrap();
        for _ in 0..50 {
            w.step();
            trace.push(w.actor("car").unwrap().state());
        }
        let end = trace.last().unwrap();
        // Backwards now, 1 s at 2 m/s²: −2 m/s, about a metre behind.
        assert!((end.speed + 2.0).abs() < 1e-9, "{}", end.speed);
        let moved = end.pose.position.xy() - stopped.position.xy();
        assert!(
            moved.dot(Vec2::from_heading(stopped.yaw)) < -0.9,
            "{moved:?}"
        );
        assert!(matches!(
            w.set_model("nobody", VehicleModelKind::Bicycle(bike)),
            Err(WorldError::UnknownActor(_))
        ));
        trace
    };
    assert_eq!(run(true), run(false));
}

/// `position` answers by id in any order of asking — its guess (the actor
/// after the last one found) right or wrong — and after an actor is
/// removed and the positions close up.
#[test]
fn positions_answer_in_any_order_and_after_a_removal() {
    let mut w = World::new(0.02).unwrap();
    for id in ["a", "b", "c", "d"] {
        w.add_actor(Actor::new(
            id,
            ActorDescription::car("t"),
            ActorState::at_rest(Pose::planar(0.0, 0.0, 0.0)),
            None,
        ))
        .unwrap();
    }
    let asks = ["a", "b", "c", "d", "a", "d", "d", "c", "a", "b", "x", "b"];
    let expect = [0, 1, 2, 3, 0, 3, 3, 2, 0, 1, usize::MAX, 1];
    for (id, e) in asks.iter().zip(expect) {
        assert_eq!(w.position(id), (e != usize::MAX).then_some(e), "{id}");
    }
    w.remove_actor("b").unwrap();
    for (id, e) in [("a", 0), ("c", 1), ("d", 2), ("a", 0)] {
        assert_eq!(w.position(id), Some(e), "{id}");
    }
    assert_eq!(w.position("b"), None);
    let clone = w.clone();
    assert_eq!(clone.position("d"), Some(2));
    assert_eq!(clone, w);
}
