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

fn batch_model(kind: usize) -> VehicleModelKind {
    match kind {
        0 => VehicleModelKind::Ssp(SspDynamics::for_length(4.5)),
        1 => VehicleModelKind::Bicycle(KinematicBicycle::new(2.7)),
        _ => {
            let mut cg = KinematicBicycle::new(2.9);
            cg.reference = ReferencePoint::CenterOfGravity;
            VehicleModelKind::Bicycle(cg)
        }
    }
}

fn batch_input(kind: usize, a: f64, s: f64) -> VehicleInput {
    match kind {
        0 => VehicleInput::Direct {
            acceleration: a * 12.0,
            steering_angle: s,
        },
        1 => VehicleInput::Pedals(NormalizedPedals {
            throttle: a.max(0.0),
            brake: 0.0,
            steering: s.clamp(-1.0, 1.0),
        }),
        2 => VehicleInput::Pedals(NormalizedPedals {
            throttle: 0.3,
            brake: (-a).max(0.0),
            steering: 0.0,
        }),
        // No pedal: the SSP model coasts.
        _ => VehicleInput::Pedals(NormalizedPedals {
            throttle: 0.0,
            brake: 0.0,
            steering: s.clamp(-1.0, 1.0),
        }),
    }
}

proptest! {
    /// The batch loops give exactly the bits of the scalar models, at every
    /// instruction-set level this machine has: SSP and both bicycles, all
    /// kinds of command (coasting, braking past zero, speeds above the cap,
    /// headings next to ±π, full lock), many steps.
    #[test]
    fn batch_equals_scalar_models(
        fleet in prop::collection::vec(
            (0usize..3, 0usize..4, -1.0f64..1.0, -1.2f64..1.2, -3.2f64..3.2, 0.0f64..70.0),
            1..24,
        ),
        steps in 1usize..60,
        dt in prop_oneof![Just(0.01), Just(0.02), Just(0.05), Just(0.1)],
    ) {
        let mut models = Vec::new();
        let mut states = Vec::new();
        let mut inputs = Vec::new();
        for &(m, k, a, s, yaw, v) in &fleet {
            models.push(batch_model(m));
            // Headings right at the wrap boundary matter most.
            let yaw = if yaw > std::f64::consts::PI { std::f64::consts::PI } else { yaw };
            states.push(VehicleState { x: a * 100.0, y: s * 50.0, yaw, v, ..VehicleState::default() });
            inputs.push(batch_input(k, a, s));
        }
        check_batch(&models, &states, &inputs, steps, dt)?;
    }

    /// The same with odd public limits — tiny or negative wheelbases, caps
    /// below zero, NaN and infinite limits, full-lock wheel angles of 90° —
    /// where the batch must either reproduce the model or leave the vehicle
    /// to it.
    #[test]
    fn batch_equals_scalar_models_with_odd_limits(
        fleet in prop::collection::vec(
            (0usize..3, 0usize..4, -1.0f64..1.0, -1.2f64..1.2, -3.2f64..3.2, 0.0f64..70.0, odd_limit(), odd_limit(), odd_limit()),
            1..16,
        ),
        steps in 1usize..40,
    ) {
        let mut models = Vec::new();
        let mut states = Vec::new();
        let mut inputs = Vec::new();
        for &(m, k, a, s, yaw, v, l1, l2, l3) in &fleet {
            let mut model = batch_model(m);
            match &mut model {
                VehicleModelKind::Ssp(ssp) => {
                    ssp.wheelbase = l1;
                    ssp.max_linear_velocity = l2;
                    ssp.max_wheels_angle_deg = l3 * 30.0;
                    ssp.free_deceleration = l2 / 10.0;
                }
                VehicleModelKind::Bicycle(b) => {
                    b.wheelbase = l1;
                    b.max_speed = l2;
                    b.max_steering_angle = l3;
                    b.rear_to_cg = l1 / 3.0;
                }
                VehicleModelKind::Lag(_) => {}
            }
            models.push(model);
            states.push(VehicleState { x: a * 100.0, y: s * 50.0, yaw: yaw.min(std::f64::consts::PI), v, ..VehicleState::default() });
            inputs.push(batch_input(k, a, s));
        }
        check_batch(&models, &states, &inputs, steps, 0.02)?;
    }
}

/// A model limit as a user might set one: mostly plausible, sometimes not.
fn odd_limit() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => 0.5f64..60.0,
        1 => 1e-6f64..1e-2,
        1 => -60.0f64..0.0,
        1 => Just(0.0),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(3.0),
    ]
}

/// Steps every vehicle `steps` times by its model and, at every
/// instruction-set level, by the batch loops (vehicles they refuse by the
/// model), and demands the same bits.
fn check_batch(
    models: &[VehicleModelKind],
    states: &[VehicleState],
    inputs: &[VehicleInput],
    steps: usize,
    dt: f64,
) -> Result<(), TestCaseError> {
    use litesim_core::vehicle::batch::{CommandColumns, Level, VehicleColumns, step_run_at};
    let mut reference = states.to_vec();
    let mut ref_models = models.to_vec();
    for _ in 0..steps {
        for ((m, st), input) in ref_models.iter_mut().zip(&mut reference).zip(inputs) {
            m.step(st, input, dt);
        }
    }
    for level in Level::available() {
        let mut models = models.to_vec();
        let mut cols = VehicleColumns::default();
        for st in states {
            cols.push(st);
        }
        let mut cmds = CommandColumns::with_len(states.len());
        for (i, m) in models.iter_mut().enumerate() {
            let c = m.compile(&inputs[i], &states[i], dt);
            if let Some(c) = &c {
                cols.set_command_outputs(i, c);
            }
            cmds.set(i, c);
        }
        for _ in 0..steps {
            for (kernel, range) in cmds.runs() {
                prop_assert!(step_run_at(level, &mut cols, &cmds, kernel, range, dt));
            }
            for (i, m) in models.iter_mut().enumerate() {
                if cmds.kernel(i).is_none() {
                    let mut st = cols.get(i);
                    m.step(&mut st, &inputs[i], dt);
                    cols.set(i, &st);
                }
            }
        }
        for (i, want) in reference.iter().enumerate() {
            let got = cols.get(i);
            let bits = |s: &VehicleState| {
                [
                    s.x,
                    s.y,
                    s.z,
                    s.yaw,
                    s.v,
                    s.yaw_rate,
                    s.acceleration,
                    s.steering_angle,
                    s.curvature,
                    s.slip_angle,
                ]
                .map(f64::to_bits)
            };
            prop_assert_eq!(
                bits(&got),
                bits(want),
                "vehicle {} at {:?}: {:?} vs {:?}",
                i,
                level,
                got,
                want
            );
        }
    }

    Ok(())
}

#[derive(Clone, Debug)]
enum WorldOp {
    Pedals(usize, f64, f64, f64, Option<u64>),
    Direct(usize, f64, f64),
    External(usize, u8, f64),
    Trajectory(usize, f64),
    SetState(usize, f64, f64),
    Remove(usize),
    Step(u8),
}

fn world_op() -> impl Strategy<Value = WorldOp> {
    prop_oneof![
        4 => (0usize..10, 0.0f64..1.0, prop_oneof![3 => Just(0.0), 1 => 0.0f64..1.0], -1.0f64..1.0, prop::option::of(0u64..6))
            .prop_map(|(i, t, b, s, u)| WorldOp::Pedals(i, t, b, s, u)),
        2 => (0usize..10, -10.0f64..10.0, -0.8f64..0.8).prop_map(|(i, a, d)| WorldOp::Direct(i, a, d)),
        1 => (0usize..10, 0u8..3, 0.0f64..30.0).prop_map(|(i, k, v)| WorldOp::External(i, k, v)),
        1 => (0usize..10, -20.0f64..20.0).prop_map(|(i, x)| WorldOp::Trajectory(i, x)),
        1 => (0usize..10, -4.0f64..4.0, 0.0f64..50.0).prop_map(|(i, yaw, v)| WorldOp::SetState(i, yaw, v)),
        1 => (0usize..10).prop_map(WorldOp::Remove),
        5 => (1u8..12).prop_map(WorldOp::Step),
    ]
}

fn apply(w: &mut World, op: &WorldOp) -> String {
    let id = |i: usize| format!("a{i}");
    let r = match *op {
        WorldOp::Pedals(i, throttle, brake, steering, until) => w.set_mode(
            &id(i),
            ControlMode::Dynamic {
                input: VehicleInput::Pedals(NormalizedPedals {
                    throttle,
                    brake,
                    steering,
                }),
                valid_until_tick: until.map(|u| w.tick() + u),
            },
        ),
        WorldOp::Direct(i, acceleration, steering_angle) => w.set_mode(
            &id(i),
            ControlMode::Dynamic {
                input: VehicleInput::Direct {
                    acceleration,
                    steering_angle,
                },
                valid_until_tick: None,
            },
        ),
        WorldOp::External(i, k, v) => w.set_mode(
            &id(i),
            ControlMode::External(match k {
                0 => litesim_core::world::ExternalController::Cruise {
                    desired_speed: v,
                    max_acceleration: 2.0,
                },
                1 => litesim_core::world::ExternalController::Stop { deceleration: 3.0 },
                _ => litesim_core::world::ExternalController::Idm {
                    desired_speed: v,
                    max_acceleration: 1.5,
                    comfortable_deceleration: 2.0,
                    time_headway: 1.2,
                    min_gap: 2.0,
                    lane_half_width: 2.0,
                },
            }),
        ),
        WorldOp::Trajectory(i, x) => {
            let t0 = w.time();
            let pts = [0.0, 1.0].map(|dt| TimedPoint {
                t: t0 + dt,
                position: Vec3::new(x + 10.0 * dt, 1.0, 0.0),
                yaw: None,
                speed: None,
            });
            match Trajectory::new(pts.to_vec()) {
                Ok(tr) => w.set_mode(&id(i), ControlMode::Trajectory(tr)),
                Err(e) => return format!("{e}"),
            }
        }
        WorldOp::SetState(i, yaw, v) => w.set_state(
            &id(i),
            ActorState {
                speed: v,
                ..ActorState::at_rest(Pose::planar(1.0, 2.0, yaw))
            },
        ),
        WorldOp::Remove(i) => w.remove_actor(&id(i)).map(|_| ()),
        WorldOp::Step(n) => {
            for _ in 0..n {
                w.step();
            }
            Ok(())
        }
    };
    format!("{r:?}")
}

fn world_view(w: &World) -> String {
    w.actors()
        .map(|a| {
            format!(
                "{} {:?} {:?} {:?} {:?} {:?}\n",
                a.id(),
                a.mode(),
                a.state(),
                a.vehicle_state(),
                a.last_input(),
                a.derived()
            )
        })
        .collect()
}

proptest! {
    /// A world that steps dynamic actors in batches and one that steps them
    /// one by one give the same bits after every call: all modes, command
    /// changes between steps, commands that run out, states set (headings
    /// outside ±π included), actors removed.
    #[test]
    fn batched_world_equals_one_by_one(
        actors in prop::collection::vec((0usize..5, -4.0f64..4.0, 0.0f64..45.0), 1..10),
        ops in prop::collection::vec(world_op(), 1..40),
    ) {
        let mut worlds = [World::with_step_ms(20).unwrap(), World::with_step_ms(20).unwrap()];
        worlds[1].set_batching(false);
        for w in &mut worlds {
            for (i, &(m, yaw, v)) in actors.iter().enumerate() {
                let model = match m {
                    0 | 1 => Some(batch_model(m)),
                    2 => Some(batch_model(2)),
                    3 => Some(VehicleModelKind::Lag(ActuatorLag::new(KinematicBicycle::new(2.7), 0.2, 0.1, 0.04, 0.02))),
                    _ => None,
                };
                let state = ActorState { speed: v, ..ActorState::at_rest(Pose::planar(0.0, 5.0 * i as f64, yaw)) };
                w.add_actor(Actor::new(format!("a{i}"), ActorDescription::car("t"), state, model)).unwrap();
            }
        }
        for op in &ops {
            let [a, b] = &mut worlds;
            let (ra, rb) = (apply(a, op), apply(b, op));
            prop_assert_eq!(ra, rb);
            prop_assert_eq!(world_view(a), world_view(b), "after {:?}", op);
        }
    }
}
