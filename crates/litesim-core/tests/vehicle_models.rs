//! Vehicle models against hand-computed trajectories and closed forms.

use litesim_core::{
    ActuatorLag, KinematicBicycle, NormalizedPedals, ReferencePoint, SspDynamics, VehicleInput,
    VehicleModel, VehicleModelKind, VehicleState,
};

fn pedals(throttle: f64, brake: f64, steering: f64) -> VehicleInput {
    VehicleInput::Pedals(NormalizedPedals {
        throttle,
        brake,
        steering,
    })
}

/// Expected values computed by hand with the seed's Python equations
/// (length 5 m → wheelbase 3 m, 4 m/s², 35°, dt 20 ms, v0 = 10 m/s).
#[test]
fn ssp_dynamics_reproduces_hand_computed_trajectory() {
    let mut m = SspDynamics::for_length(5.0);
    let mut st = VehicleState {
        v: 10.0,
        ..VehicleState::default()
    };
    let cmds = [
        pedals(0.5, 0.0, 0.25),
        pedals(0.5, 0.0, 0.25),
        pedals(0.0, 0.1, -0.5),
        pedals(0.0, 0.0, 0.0),
        pedals(1.0, 0.0, 1.0),
    ];
    let expect = [
        (
            0.20078967382596122,
            0.002036390155174648,
            0.01014155907932778,
            10.04,
        ),
        (
            0.40234803960262633,
            0.006133362871712663,
            0.02032368439497287,
            10.079999999999998,
        ),
        (
            0.6027480382484085,
            0.006156660307184643,
            0.0001162546682857181,
            10.019999999999998,
        ),
        (
            0.8023480368995968,
            0.006179864738922203,
            0.0001162546682857181,
            9.979999999999999,
        ),
        (
            1.0034006536516458,
            0.013879559353233747,
            0.03827820690017532,
            10.059999999999999,
        ),
    ];
    for (cmd, (x, y, h, v)) in cmds.iter().zip(expect) {
        m.step(&mut st, cmd, 0.02);
        for (got, want, what) in [
            (st.x, x, "x"),
            (st.y, y, "y"),
            (st.yaw, h, "yaw"),
            (st.v, v, "v"),
        ] {
            assert!((got - want).abs() < 1e-12, "{what}: {got} vs {want}");
        }
    }
}

#[test]
fn ssp_dynamics_limits() {
    let mut m = SspDynamics::for_length(4.5);
    let mut st = VehicleState::default();
    // Coasting from rest never reverses.
    m.step(&mut st, &pedals(0.0, 0.0, 0.0), 0.02);
    assert_eq!(st.v, 0.0);
    // Full throttle for a long time is capped at 40 m/s.
    for _ in 0..10_000 {
        m.step(&mut st, &pedals(1.0, 0.0, 0.0), 0.02);
    }
    assert_eq!(st.v, 40.0);
    // Brake wins over throttle: 30 m/s² at full brake.
    m.step(&mut st, &pedals(1.0, 1.0, 0.0), 0.02);
    assert!((st.v - (40.0 - 0.6)).abs() < 1e-12);
    // Free deceleration 2 m/s².
    m.step(&mut st, &pedals(0.0, 0.0, 0.0), 0.1);
    assert!((st.v - (39.4 - 0.2)).abs() < 1e-12);
}

#[test]
fn bicycle_drives_a_circle_of_the_right_radius() {
    let l = 2.7;
    let delta: f64 = 0.1;
    let mut m = KinematicBicycle::new(l);
    let mut st = VehicleState {
        v: 5.0,
        ..VehicleState::default()
    };
    let r = l / delta.tan();
    let input = VehicleInput::Direct {
        acceleration: 0.0,
        steering_angle: delta,
    };
    let dt = 0.001;
    let mut max_err: f64 = 0.0;
    for _ in 0..20_000 {
        m.step(&mut st, &input, dt);
        // Centre of the circle is (0, r).
        let d = (st.x * st.x + (st.y - r) * (st.y - r)).sqrt();
        max_err = max_err.max((d - r).abs());
    }
    // Explicit Euler drifts outward by O(v·dt) per revolution: stays small.
    assert!(max_err < 0.05 * r, "radius error {max_err} for r = {r}");
    assert!((st.curvature - delta.tan() / l).abs() < 1e-15);
    assert!((st.yaw_rate - 5.0 / r).abs() < 1e-12);
}

#[test]
fn bicycle_saturates_before_integrating() {
    let mut m = KinematicBicycle::new(2.7);
    let mut st = VehicleState {
        v: 10.0,
        ..VehicleState::default()
    };
    m.step(
        &mut st,
        &VehicleInput::Direct {
            acceleration: 100.0,
            steering_angle: 3.0,
        },
        0.1,
    );
    assert_eq!(st.steering_angle, m.max_steering_angle);
    assert!((st.v - (10.0 + m.max_acceleration * 0.1)).abs() < 1e-12);
    // First step integrates position with v_k and ψ_k (explicit Euler).
    assert!((st.x - 1.0).abs() < 1e-12 && st.y == 0.0);
}

#[test]
fn cg_bicycle_has_slip() {
    let mut m = KinematicBicycle::new(2.7);
    m.reference = ReferencePoint::CenterOfGravity;
    m.rear_to_cg = 1.2;
    let mut st = VehicleState {
        v: 10.0,
        ..VehicleState::default()
    };
    m.step(
        &mut st,
        &VehicleInput::Direct {
            acceleration: 0.0,
            steering_angle: 0.2,
        },
        0.01,
    );
    let beta = (1.2 / 2.7 * 0.2f64.tan()).atan();
    assert!((st.slip_angle - beta).abs() < 1e-15);
    assert!((st.y - 10.0 * beta.sin() * 0.01).abs() < 1e-15);
}

#[test]
fn actuator_lag_delays_and_smooths() {
    let dt = 0.02;
    let mut m = ActuatorLag::new(KinematicBicycle::new(2.7), 0.2, 0.1, 0.1, dt);
    assert_eq!(m.delay_steps, 5);
    let mut st = VehicleState::default();
    let cmd = VehicleInput::Direct {
        acceleration: 2.0,
        steering_angle: 0.0,
    };
    for _ in 0..5 {
        m.step(&mut st, &cmd, dt);
        assert_eq!(st.v, 0.0, "nothing happens during the dead time");
    }
    m.step(&mut st, &cmd, dt);
    let a1 = 2.0 * (1.0 - (-dt / 0.2f64).exp());
    assert!(
        (st.acceleration - a1).abs() < 1e-12,
        "{} vs {a1}",
        st.acceleration
    );
}

/// Limits are public fields: crossed or NaN limits must not panic a step
/// (`f64::clamp` would), whatever the result is worth.
#[test]
fn crossed_or_nan_limits_do_not_panic() {
    let mut b = KinematicBicycle::new(2.7);
    b.max_steering_angle = -0.5;
    b.max_deceleration = f64::NAN;
    b.max_speed = -1.0;
    let mut s = SspDynamics::for_length(4.5);
    s.max_wheels_angle_deg = -35.0;
    s.brake_deceleration = f64::NAN;
    let input = VehicleInput::Direct {
        acceleration: 1.0,
        steering_angle: 0.2,
    };
    let mut st = VehicleState {
        v: 5.0,
        ..VehicleState::default()
    };
    for _ in 0..10 {
        b.step(&mut st, &input, 0.02);
        s.step(&mut st, &input, 0.02);
    }
}

/// Reverse gear: the speed runs from 0 down to −max_speed; a Direct
/// acceleration is the rate of change of the signed speed (speeding up
/// backwards at most `max_acceleration`, slowing down at most
/// `max_deceleration`); pedals push backwards; a stop is a stop — the
/// vehicle never rolls forwards in reverse nor backwards in drive.
#[test]
fn bicycle_reverses_in_reverse_gear_and_stops_at_zero() {
    let direct = |acceleration: f64, steering_angle: f64| VehicleInput::Direct {
        acceleration,
        steering_angle,
    };
    let mut m = KinematicBicycle::new(3.0);
    m.max_speed = 2.0;
    m.reverse = true;
    let dt = 0.01;
    // x = −½ after 1 s, up to the explicit Euler step (x += v·dt with v
    // before the update): −0.495.
    reverse_sequence(&mut m, -0.495);
    // In drive the same braking stops at zero from the other side.
    let mut fwd = KinematicBicycle::new(3.0);
    let mut st = VehicleState::default();
    for _ in 0..100 {
        fwd.step(&mut st, &direct(-5.0, 0.0), dt);
    }
    assert_eq!(st.v, 0.0);
    assert_eq!(st.x, 0.0);
}

/// The seed's model in reverse gear (litesim's addition): the speed runs
/// from 0 down to −max_linear_velocity; a Direct acceleration is the rate
/// of change of the signed speed; braking stops it at zero; the batch
/// loops leave a reversing vehicle to the one-by-one step; out of reverse
/// the model is the seed's again.
#[test]
fn ssp_model_reverses_in_reverse_gear_and_stops_at_zero() {
    let mut m = SspDynamics::for_length(4.5);
    m.max_linear_velocity = 2.0;
    m.reverse = true;
    let input = VehicleInput::Direct {
        acceleration: -1.0,
        steering_angle: 0.0,
    };
    assert!(m.compile(&input, &VehicleState::default(), 0.01).is_none());
    // The seed moves with the new speed: x = −(0.01 + … + 1.00) · 0.01.
    reverse_sequence(&mut m, -0.505);
    // The gear through the model kind: Lag has none.
    let kind = VehicleModelKind::Ssp(m.clone());
    assert_eq!(kind.reverse(), Some(true));
    let fwd = kind.with_reverse(false).unwrap();
    assert_eq!(fwd.reverse(), Some(false));
    let VehicleModelKind::Ssp(back) = fwd else {
        panic!("{fwd:?}")
    };
    assert!(!back.reverse && back.max_linear_velocity == 2.0);
}

/// The reverse-gear sequence both models share, for a model whose speed
/// limit is 2 m/s, stepped at 10 ms: 1 s at −1 m/s² straight back (v = −1,
/// and x = `x_after_1s`, which depends on the model's integration), then
/// far beyond the engine (capped at −2 m/s), then braking (at rest, never
/// forwards), then throttle with the wheels left (backwards, the heading
/// turning right).
fn reverse_sequence(m: &mut dyn VehicleModel, x_after_1s: f64) {
    let direct = |acceleration: f64, steering_angle: f64| VehicleInput::Direct {
        acceleration,
        steering_angle,
    };
    let dt = 0.01;
    let mut st = VehicleState::default();
    for _ in 0..100 {
        m.step(&mut st, &direct(-1.0, 0.0), dt);
    }
    assert!((st.v + 1.0).abs() < 1e-9, "{}", st.v);
    assert!((st.x - x_after_1s).abs() < 1e-9, "{}", st.x);
    assert_eq!(st.y, 0.0);
    for _ in 0..300 {
        m.step(&mut st, &direct(-50.0, 0.0), dt);
    }
    assert_eq!(st.v, -2.0);
    for _ in 0..300 {
        m.step(&mut st, &direct(8.0, 0.0), dt);
    }
    assert_eq!(st.v, 0.0);
    for _ in 0..100 {
        m.step(&mut st, &pedals(0.2, 0.0, 0.5), dt);
    }
    assert!(st.v < 0.0 && st.yaw < 0.0, "v {} yaw {}", st.v, st.yaw);
}
