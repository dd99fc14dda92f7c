//! Property tests of the pure core: normalisation and trajectories never
//! panic, and accepted values are always in range.

use litesim_core::*;
use proptest::prelude::*;

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![4 => -100.0f64..100.0, 1 => Just(f64::NAN), 1 => Just(f64::INFINITY), 1 => any::<f64>()]
}

proptest! {
    #[test]
    fn normalisation_is_total_and_in_range(t in any_f64(), b in any_f64(), s in any_f64(), clamp in any::<bool>(), force in any::<bool>()) {
        let limits = ActuatorLimits { policy: if clamp { RangePolicy::Clamp } else { RangePolicy::Reject }, ..ActuatorLimits::default() };
        let cmd = if force {
            DynamicCommand { throttle: PedalInput::ForceN(t * 100.0), brake: PedalInput::ForceN(b * 100.0), steering: SteeringInput::TorqueNm(s) }
        } else {
            DynamicCommand::fractions(t, b, s)
        };
        if let Ok(n) = normalize_command(&cmd, &limits) {
            prop_assert!((0.0..=1.0).contains(&n.throttle) && (0.0..=1.0).contains(&n.brake) && (-1.0..=1.0).contains(&n.steering));
        }
    }

    #[test]
    fn trajectories_never_panic(points in prop::collection::vec((any_f64(), any_f64(), any_f64()), 0..8), t in any_f64()) {
        let pts: Vec<TimedPoint> = points.iter().map(|&(t, x, y)| TimedPoint { t, position: Vec3::new(x, y, 0.0), yaw: None, speed: None }).collect();
        if let Ok(tr) = Trajectory::new(pts)
            && let Some(s) = tr.sample(t) {
                prop_assert!(!t.is_finite() || (s.position.x.is_finite() && s.speed.is_finite()));
            }
    }

    #[test]
    fn wrap_angle_stays_in_range(a in -1e6f64..1e6) {
        let w = wrap_angle(a);
        prop_assert!(w > -std::f64::consts::PI && w <= std::f64::consts::PI);
    }

    #[test]
    fn models_stay_finite(a in -50.0f64..50.0, d in -2.0f64..2.0, v0 in 0.0f64..60.0) {
        let input = VehicleInput::Direct { acceleration: a, steering_angle: d };
        let mut models = [VehicleModelKind::Ssp(SspDynamics::for_length(4.5)), VehicleModelKind::Bicycle(KinematicBicycle::new(2.7))];
        for m in &mut models {
            let mut st = VehicleState { v: v0, ..VehicleState::default() };
            for _ in 0..200 {
                m.step(&mut st, &input, 0.02);
            }
            prop_assert!(st.x.is_finite() && st.y.is_finite() && st.v >= 0.0);
        }
    }

    /// The models' caches (steering, turning radius, heading trig) only skip
    /// recomputing identical arguments: a model stepped with warm caches
    /// gives the same bits as one whose caches are emptied before every step
    /// (serde skips them), even when commands repeat, alternate, or the
    /// public geometry changes mid-run.
    #[test]
    fn caches_never_change_results(
        commands in prop::collection::vec((0usize..4, -1.2f64..1.2, 0.0f64..1.0), 1..6),
        steps in prop::collection::vec((0usize..6, any::<bool>()), 1..80),
        v0 in 0.0f64..30.0,
    ) {
        let inputs: Vec<VehicleInput> = commands.iter().map(|&(kind, s, t)| match kind {
            0 => VehicleInput::Direct { acceleration: t * 3.0, steering_angle: s * 0.5 },
            1 => VehicleInput::Direct { acceleration: -t, steering_angle: 0.0 },
            2 => VehicleInput::Pedals(NormalizedPedals { throttle: t, brake: 0.0, steering: s.clamp(-1.0, 1.0) }),
            _ => VehicleInput::Pedals(NormalizedPedals { throttle: 0.0, brake: t * 0.2, steering: 0.0 }),
        }).collect();
        let mut cg = KinematicBicycle::new(2.7);
        cg.reference = ReferencePoint::CenterOfGravity;
        let models = [
            VehicleModelKind::Ssp(SspDynamics::for_length(4.5)),
            VehicleModelKind::Bicycle(KinematicBicycle::new(2.7)),
            VehicleModelKind::Bicycle(cg),
            VehicleModelKind::Lag(ActuatorLag::new(KinematicBicycle::new(2.7), 0.2, 0.1, 0.04, 0.02)),
        ];
        for model in models {
            let mut warm = model.clone();
            let mut cold = model;
            let mut a = VehicleState { v: v0, ..VehicleState::default() };
            let mut b = a;
            for &(i, reshape) in &steps {
                if reshape {
                    // Change the public geometry between steps, on both.
                    for m in [&mut warm, &mut cold] {
                        match m {
                            VehicleModelKind::Ssp(m) => m.wheelbase += 0.1,
                            VehicleModelKind::Bicycle(m) => m.wheelbase += 0.1,
                            VehicleModelKind::Lag(m) => m.inner.wheelbase += 0.1,
                        }
                    }
                }
                let input = inputs[i % inputs.len()];
                cold = serde_json::from_str(&serde_json::to_string(&cold).unwrap()).unwrap();
                warm.step(&mut a, &input, 0.02);
                cold.step(&mut b, &input, 0.02);
                prop_assert_eq!(format!("{a:?}"), format!("{b:?}"));
            }
        }
    }
}
