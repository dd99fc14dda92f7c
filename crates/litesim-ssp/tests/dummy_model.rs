//! The dummy model's constants as the seed states them: brake deceleration
//! 30 m/s² and MAX_LINEAR_VELOCITY 40 m/s for every vehicle; only the
//! maximum acceleration and wheel angle come from the vehicle.

use litesim_ssp::*;

fn running(model: &str) -> Session {
    let mut s = Session::new("dummy", model, SessionLimits::default());
    s.init(InitRequest::default()).unwrap();
    s.start_simulation(0).unwrap();
    s.wait_start_simulation(100).unwrap();
    s
}

/// A running session with the catalogue's delivery van at the origin.
fn with_van(model: &str) -> Session {
    let mut s = running(model);
    s.create_actor(CreateActor {
        actor_id: "van".into(),
        spec: ActorSpec {
            model_id: "van.delivery".into(),
            ..ActorSpec::default()
        },
        position: Coord6::xy_yaw(0.0, 0.0, 0.0),
        ..CreateActor::default()
    })
    .unwrap();
    s
}

fn pedals(s: &mut Session, throttle: f64, brake: f64) {
    s.set_dynamic_move(
        "van",
        DynamicMove::Normalized {
            throttle,
            brake,
            steering: 0.0,
        },
        0,
    )
    .unwrap();
}

fn speed(s: &mut Session) -> f64 {
    s.step(None, &ActorFilter::default()).unwrap().1[0].speed
}

#[test]
fn the_van_reaches_40_m_s_and_brakes_at_30_m_s2_under_the_dummy_model() {
    let mut s = with_van("dummy");
    // Full throttle for 60 s: the van (catalogue max_speed 35 m/s) reaches
    // the seed's 40 m/s and stays there.
    pedals(&mut s, 1.0, 0.0);
    let mut v = 0.0;
    for _ in 0..3000 {
        v = speed(&mut s);
    }
    assert!((v - 40.0).abs() < 1e-6, "top speed {v}");
    // Full brake: 30 m/s² (0.6 m/s per 20 ms step; the catalogue says 8).
    pedals(&mut s, 0.0, 1.0);
    let (a, b) = (speed(&mut s), speed(&mut s));
    assert!(
        ((a - b) / 0.02 - 30.0).abs() < 1e-6,
        "deceleration {}",
        (a - b) / 0.02
    );
    let mut steps = 2;
    while speed(&mut s) > 0.0 {
        steps += 1;
        assert!(steps < 100, "does not stop");
    }
    // 40 m/s at 30 m/s² stops in 1.33 s, i.e. 67 steps.
    assert!((66..=68).contains(&steps), "{steps} steps");
    // The bicycle model keeps the catalogue's limits (documented per model).
    assert!(
        models()
            .iter()
            .any(|m| m.name() == "bicycle" && m.summary().contains("speed limits"))
    );
    assert!(
        models()
            .iter()
            .any(|m| m.name() == "dummy" && m.summary().contains("brake 30 m/s²"))
    );
}

/// `controls.gear` drives the model: R backs the van up under throttle,
/// braking stops it at rest, D drives forwards again; P and N are
/// reported only; a bad gear is refused and changes nothing.
#[test]
fn the_gear_r_reverses_and_d_drives_forwards() {
    let mut s = with_van("dummy");
    let gear = |s: &mut Session, g: &str| {
        s.set_actor_params(
            "van",
            Default::default(),
            Some(ActorControls {
                gear: g.into(),
                ..ActorControls::default()
            }),
        )
    };
    gear(&mut s, "R").unwrap();
    pedals(&mut s, 0.5, 0.0);
    let mut v = 0.0;
    for _ in 0..50 {
        v = speed(&mut s);
    }
    assert!(v < -0.5, "reversing speed {v}");
    let (_, actors) = s.step(None, &ActorFilter::default()).unwrap();
    assert!(actors[0].pose.position.x < 0.0, "{:?}", actors[0].pose);
    pedals(&mut s, 0.0, 1.0);
    for _ in 0..50 {
        v = speed(&mut s);
    }
    assert_eq!(v, 0.0);
    // Neutral is reported and changes nothing: still reversing.
    gear(&mut s, "N").unwrap();
    pedals(&mut s, 0.5, 0.0);
    assert!(speed(&mut s) < 0.0);
    assert!(gear(&mut s, "X").is_err());
    gear(&mut s, "D").unwrap();
    pedals(&mut s, 0.0, 1.0);
    for _ in 0..50 {
        speed(&mut s);
    }
    pedals(&mut s, 0.5, 0.0);
    for _ in 0..10 {
        v = speed(&mut s);
    }
    assert!(v > 0.0, "forwards again {v}");
}
