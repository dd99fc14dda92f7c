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
}
