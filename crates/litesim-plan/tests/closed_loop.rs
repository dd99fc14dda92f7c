//! Closed-loop runs on the example maps, FMT* against the visibility-graph
//! optimum, MPC constraints and tracking, determinism, bad input.

use litesim_core::Vec2;
use litesim_map::{Obstacle, OccupancyGrid};
use litesim_plan::closed_loop::parse_config;
use litesim_plan::corridor::RefState;
use litesim_plan::*;
use std::path::PathBuf;

fn example(name: &str) -> ClosedLoopConfig {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/plan")
        .join(name);
    parse_config(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn grid_of(cfg: &ClosedLoopConfig) -> OccupancyGrid {
    let m = &cfg.map;
    OccupancyGrid::from_obstacles(
        Vec2::new(m.origin[0], m.origin[1]),
        (m.size[0], m.size[1]),
        m.resolution,
        &m.obstacles,
    )
    .unwrap()
}

#[test]
fn closed_loop_reaches_the_goal_on_five_maps_without_touching_obstacles() {
    for name in [
        "single_rect.toml",
        "narrow_passage.toml",
        "s_bend.toml",
        "forest.toml",
        "parking_lot.toml",
    ] {
        let cfg = example(name);
        let r = run_closed_loop(&cfg, grid_of(&cfg)).unwrap_or_else(|e| panic!("{name}: {e}"));
        println!(
            "{name}: reached {} in {:.1} s, path {:.1} m, cte max {:.2} mean {:.2}, clearance {:.2}",
            r.reached_goal,
            r.time,
            r.path_length,
            r.max_cross_track,
            r.mean_cross_track,
            r.min_clearance
        );
        assert!(r.reached_goal, "{name}: goal not reached");
        assert!(!r.collided, "{name}: touched an obstacle");
        assert!(
            r.max_cross_track <= 0.03 && r.mean_cross_track <= 0.02,
            "{name}: cross-track error max {} mean {}",
            r.max_cross_track,
            r.mean_cross_track
        );
        assert!(r.collision.is_none());
        // The reference's speed profile changes acceleration no faster than
        // the jerk limit (interior points; the start and the stop excluded).
        let c = &r.corridor;
        assert!(c.jerk_limited, "{name}: jerk program had no answer");
        let (v, s) = (&c.speed, &c.s);
        let dt = |i: usize| 2.0 * (s[i + 1] - s[i]) / (v[i] + v[i + 1]).max(1e-9);
        let worst = (1..v.len() - 2)
            .map(|i| {
                let (d0, d1) = (dt(i - 1), dt(i));
                let (a0, a1) = ((v[i] - v[i - 1]) / d0, (v[i + 1] - v[i]) / d1);
                ((a1 - a0) / (0.5 * (d0 + d1))).abs()
            })
            .fold(0.0, f64::max);
        println!("{name}: largest jerk of the reference {worst:.3} m/s³");
        assert!(
            worst <= litesim_plan::closed_loop::JERK_MAX * 1.01,
            "{name}: jerk {worst}"
        );
    }
}

/// Shortest path around one axis-aligned rectangle for a point robot: the
/// better of going over or under it (visibility graph through the corners).
#[test]
fn fmt_cost_is_within_three_percent_of_the_visibility_graph_optimum() {
    let rect = (Vec2::new(30.0, 10.0), Vec2::new(50.0, 30.0));
    let g = OccupancyGrid::from_obstacles(
        Vec2::new(0.0, 0.0),
        (80.0, 40.0),
        0.2,
        &[Obstacle::Rect {
            min: [rect.0.x, rect.0.y],
            max: [rect.1.x, rect.1.y],
        }],
    )
    .unwrap();
    let pg = PlanningGrid::new(g, 0.0, 0.0);
    let (start, goal) = (Vec2::new(5.0, 18.0), Vec2::new(75.0, 22.0));
    // The grid marks cells whose centres are inside, so the free boundary
    // lies half a cell outside the rectangle's cells: use its true corners.
    let over = start.distance(Vec2::new(30.0, 30.0)) + 20.0 + Vec2::new(50.0, 30.0).distance(goal);
    let under = start.distance(Vec2::new(30.0, 10.0)) + 20.0 + Vec2::new(50.0, 10.0).distance(goal);
    let optimum = over.min(under);
    let r = fmt_star(
        &pg,
        start,
        goal,
        &FmtConfig {
            samples: 2000,
            radius: Radius::Eta(0.5),
            seed: 1,
        },
    )
    .unwrap();
    let ratio = r.path_cost / optimum;
    println!(
        "FMT* n=2000: {:.3} m vs optimum {:.3} m ({:.2}%)",
        r.path_cost,
        optimum,
        (ratio - 1.0) * 100.0
    );
    assert!((0.999..=1.03).contains(&ratio), "ratio {ratio}");
    // More samples: closer (asymptotic optimality, not monotone per seed, so compare far apart).
    let r200 = fmt_star(
        &pg,
        start,
        goal,
        &FmtConfig {
            samples: 200,
            radius: Radius::Eta(0.5),
            seed: 1,
        },
    )
    .unwrap();
    assert!(r200.path_cost >= r.path_cost - 0.5);
    // The tree and its edge order are returned for the debug view.
    assert_eq!(
        r.edges.len(),
        r.parent.iter().filter(|p| p.is_some()).count()
    );
    assert!(r.collision_checks >= r.edges.len());
}

#[test]
fn fmt_errors_say_which_end_is_wrong() {
    let g = OccupancyGrid::from_obstacles(
        Vec2::new(0.0, 0.0),
        (20.0, 10.0),
        0.2,
        &[Obstacle::Rect {
            min: [9.0, 0.0],
            max: [11.0, 10.0],
        }],
    )
    .unwrap();
    let pg = PlanningGrid::new(g, 0.5, 0.1);
    let cfg = FmtConfig::default();
    assert!(matches!(
        fmt_star(&pg, Vec2::new(10.0, 5.0), Vec2::new(18.0, 5.0), &cfg),
        Err(FmtError::StartInCollision(..))
    ));
    assert!(matches!(
        fmt_star(&pg, Vec2::new(2.0, 5.0), Vec2::new(30.0, 5.0), &cfg),
        Err(FmtError::GoalInCollision(..))
    ));
    assert!(matches!(
        fmt_star(&pg, Vec2::new(2.0, 5.0), Vec2::new(18.0, 5.0), &cfg),
        Err(FmtError::NoPath { .. })
    ));
    let all = OccupancyGrid::from_obstacles(
        Vec2::new(0.0, 0.0),
        (5.0, 5.0),
        0.5,
        &[Obstacle::Rect {
            min: [0.0, 0.0],
            max: [5.0, 5.0],
        }],
    )
    .unwrap();
    let pg = PlanningGrid::new(all, 0.5, 0.0);
    assert!(fmt_star(&pg, Vec2::new(1.0, 1.0), Vec2::new(4.0, 4.0), &cfg).is_err());
    assert!(matches!(
        fmt_star(
            &PlanningGrid::new(
                OccupancyGrid::new(Vec2::new(0.0, 0.0), Vec2::new(5.0, 5.0), 0.5).unwrap(),
                0.1,
                0.0
            ),
            Vec2::new(1.0, 1.0),
            Vec2::new(4.0, 4.0),
            &FmtConfig { samples: 0, ..cfg }
        ),
        Err(FmtError::BadConfig(_))
    ));
}

fn line_refs(n: usize, dt: f64, v: f64, y: f64) -> Vec<RefState> {
    (0..=n)
        .map(|k| RefState {
            p: Vec2::new(v * dt * k as f64, y),
            heading: 0.0,
            speed: v,
            curvature: 0.0,
            s: v * dt * k as f64,
        })
        .collect()
}

#[test]
fn mpc_respects_every_constraint() {
    let cfg = MpcConfig::default();
    let mut mpc = Mpc::new(cfg.clone()).unwrap();
    // A large offset pushes for extreme commands.
    let refs = line_refs(cfg.horizon, cfg.dt, 10.0, 0.0);
    let sol = mpc.solve([0.0, 5.0, 0.8, 2.0], &refs, [0.0, 0.1]).unwrap();
    let mut prev = 0.1;
    for u in &sol.inputs {
        assert!(
            u[0] >= cfg.min_accel - 1e-6 && u[0] <= cfg.max_accel + 1e-6,
            "accel {u:?}"
        );
        assert!(u[1].abs() <= cfg.max_steer + 1e-6, "steer {u:?}");
        assert!(
            (u[1] - prev).abs() <= cfg.max_steer_rate * cfg.dt + 1e-6,
            "steer rate {} -> {}",
            prev,
            u[1]
        );
        prev = u[1];
    }
    assert_eq!(sol.predicted.len(), cfg.horizon + 1);
    assert!(
        Mpc::new(MpcConfig {
            dt: 0.0,
            ..cfg.clone()
        })
        .is_err()
    );
    assert!(
        Mpc::new(MpcConfig {
            horizon: 0,
            ..cfg.clone()
        })
        .is_err()
    );
    assert!(mpc.solve([0.0; 4], &refs[..3], [0.0, 0.0]).is_err());
}

/// Closed loop with the bicycle model: a straight line and a circle.
fn track(refs_at: impl Fn(f64) -> RefState, z0: [f64; 4], secs: f64) -> (f64, f64) {
    use litesim_core::{KinematicBicycle, VehicleInput, VehicleModel, VehicleState};
    let cfg = MpcConfig::default();
    let mut mpc = Mpc::new(cfg.clone()).unwrap();
    let mut bike = KinematicBicycle::new(cfg.wheelbase);
    bike.max_steering_angle = cfg.max_steer;
    let mut st = VehicleState {
        x: z0[0],
        y: z0[1],
        yaw: z0[2],
        v: z0[3],
        ..VehicleState::default()
    };
    let mut prev = [0.0, 0.0];
    let mut worst_late: f64 = 0.0;
    let steps = (secs / cfg.dt) as usize;
    let mut last_err = 0.0;
    for k in 0..steps {
        let t = k as f64 * cfg.dt;
        let refs: Vec<RefState> = (0..=cfg.horizon)
            .map(|j| refs_at(t + j as f64 * cfg.dt))
            .collect();
        let sol = mpc.solve([st.x, st.y, st.yaw, st.v], &refs, prev).unwrap();
        prev = [sol.acceleration, sol.steering];
        // Two simulation steps of dt/2 per control period.
        for _ in 0..2 {
            bike.step(
                &mut st,
                &VehicleInput::Direct {
                    acceleration: sol.acceleration,
                    steering_angle: sol.steering,
                },
                cfg.dt / 2.0,
            );
        }
        let r = refs_at(t + cfg.dt);
        let err = Vec2::new(st.x, st.y).distance(r.p);
        last_err = err;
        if t > secs / 2.0 {
            worst_late = worst_late.max(err);
        }
    }
    (worst_late, last_err)
}

#[test]
fn mpc_tracks_a_straight_line_and_a_circle() {
    let (late, _) = track(
        |t| RefState {
            p: Vec2::new(8.0 * t, 0.0),
            heading: 0.0,
            speed: 8.0,
            curvature: 0.0,
            s: 8.0 * t,
        },
        [0.0, 1.5, 0.2, 6.0],
        12.0,
    );
    assert!(late < 0.15, "straight line: {late}");
    let r = 20.0;
    let w = 6.0 / r;
    let circle = move |t: f64| RefState {
        p: Vec2::new(r * (w * t).sin(), r - r * (w * t).cos()),
        heading: w * t,
        speed: 6.0,
        curvature: 1.0 / r,
        s: 6.0 * t,
    };
    let (late, _) = track(circle, [0.0, -1.0, 0.0, 6.0], 20.0);
    assert!(late < 0.3, "circle: {late}");
}

#[test]
fn closed_loop_log_is_deterministic() {
    let cfg = example("single_rect.toml");
    let a = run_closed_loop(&cfg, grid_of(&cfg)).unwrap();
    let b = run_closed_loop(&cfg, grid_of(&cfg)).unwrap();
    let ja = serde_json::to_string(&a.log).unwrap();
    let jb = serde_json::to_string(&b.log).unwrap();
    assert!(ja == jb);
    let t = a.log.tracking.as_ref().unwrap();
    assert!(!t.predictions.is_empty() && t.predictions[0].len() == 21);
    let p = a.log.plan.as_ref().unwrap();
    assert_eq!(p.samples.len(), 2002);
    let digest = litesim_ssp_free_fnv(ja.as_bytes());
    println!("closed-loop log: {} bytes, digest {digest:#018x}", ja.len());
    assert_eq!(
        (ja.len(), digest),
        (GOLDEN_LEN, GOLDEN_DIGEST),
        "closed-loop log changed"
    );
}

const GOLDEN_LEN: usize = 574_950;
const GOLDEN_DIGEST: u64 = 0xb4ba_4c73_066e_829f;

fn litesim_ssp_free_fnv(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &x in bytes {
        h ^= u64::from(x);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[test]
fn bad_configurations_are_clear_errors() {
    let mut cfg = example("single_rect.toml");
    cfg.goal.x = 500.0;
    let e = run_closed_loop(&cfg, grid_of(&cfg))
        .unwrap_err()
        .to_string();
    assert!(e.contains("the goal (500.00, 20.00) is off the map"), "{e}");
    let mut cfg = example("single_rect.toml");
    cfg.simulation.dt = 0.03;
    let e = run_closed_loop(&cfg, grid_of(&cfg))
        .unwrap_err()
        .to_string();
    assert!(e.contains("whole multiple"), "{e}");
    let mut cfg = example("single_rect.toml");
    cfg.vehicle.preset = "hovercraft".into();
    let e = run_closed_loop(&cfg, grid_of(&cfg))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown vehicle preset 'hovercraft'"), "{e}");
    let e = parse_config("[map]\nresolution = 0.2\nsize = [1, 1]\ncolour = 3")
        .unwrap_err()
        .to_string();
    assert!(e.contains("colour"), "{e}");
    assert!(OccupancyGrid::from_obstacles(Vec2::new(0.0, 0.0), (10.0, 10.0), -1.0, &[]).is_err());
    assert!(
        OccupancyGrid::from_obstacles(
            Vec2::new(0.0, 0.0),
            (10.0, 10.0),
            0.5,
            &[Obstacle::Circle {
                center: [1.0, f64::NAN],
                radius: 1.0
            }]
        )
        .is_err()
    );
    let e = OccupancyGrid::from_png(b"not a png at all", 0.2, Vec2::new(0.0, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a readable PNG"), "{e}");
    // A map that is all obstacle: the start is in collision.
    let all = OccupancyGrid::from_obstacles(
        Vec2::new(0.0, 0.0),
        (80.0, 40.0),
        0.5,
        &[Obstacle::Rect {
            min: [0.0, 0.0],
            max: [80.0, 40.0],
        }],
    )
    .unwrap();
    let e = run_closed_loop(&example("single_rect.toml"), all)
        .unwrap_err()
        .to_string();
    // Refused before any planner runs, with the place and the overlap.
    assert!(
        e.contains("cannot stand at its start (5.00, 20.00)") && e.contains("overlaps an obstacle"),
        "{e}"
    );
}

/// A goal behind a car in a street too narrow to turn round in: no
/// forward path, so the search reverses, and the vehicle — in reverse gear
/// from the start — backs onto it, its path tracked as tightly as a
/// forward one.
#[test]
fn a_goal_behind_in_a_narrow_street_is_reached_backwards() {
    let cfg = parse_config(
        r#"
[map]
size = [60.0, 20.0]
resolution = 0.2
obstacles = [
  { shape = "rect", min = [0.0, 0.0], max = [60.0, 7.0] },
  { shape = "rect", min = [0.0, 13.0], max = [60.0, 20.0] },
]
[start]
x = 40.0
y = 10.0
[goal]
x = 12.0
y = 10.0
[vehicle]
preset = "compact"
[planner]
margin = 0.3
[tracker]
dt = 0.1
[simulation]
dt = 0.05
horizon = 60.0
"#,
    )
    .unwrap();
    let r = run_closed_loop(&cfg, grid_of(&cfg)).unwrap();
    assert!(
        r.reached_goal,
        "{:.3} m, {:.3} m/s",
        r.goal_distance, r.final_speed
    );
    assert!(!r.collided);
    assert_eq!(r.legs.len(), 1);
    assert!(r.legs[0].reverse);
    assert!(
        r.max_cross_track <= 0.03 && r.mean_cross_track <= 0.02,
        "{} {}",
        r.max_cross_track,
        r.mean_cross_track
    );
    // Backwards the whole way: the speed never positive, the heading kept.
    let ego = &r.log.tracks[0];
    assert!(ego.state.speed.iter().all(|v| *v <= 0.0));
    assert!(ego.state.speed.iter().any(|v| *v < -1.0));
    assert!(ego.state.yaw.iter().all(|y| y.abs() < 0.05));
    assert!(matches!(r.planner, PathPlanner::Hybrid { cusps: 0, .. }));
}

/// The narrow passage with a bus: through the gap forwards, then backing
/// into the goal's corner — two legs, the gear changed at the cusp where
/// the bus stands still, the corridor shown with both (speeds negative on
/// the reversing leg), and the planner saying so.
#[test]
fn a_bus_changes_gear_at_a_cusp_and_arrives_on_its_path() {
    let mut cfg = example("narrow_passage.toml");
    cfg.vehicle.preset = "bus".into();
    let r = run_closed_loop(&cfg, grid_of(&cfg)).unwrap();
    assert!(r.reached_goal && !r.collided, "{:.3} m", r.goal_distance);
    assert!(r.max_cross_track <= 0.03 && r.mean_cross_track <= 0.02);
    assert_eq!(
        r.legs.iter().map(|l| l.reverse).collect::<Vec<_>>(),
        [false, true]
    );
    let text = r.planner.to_string();
    assert!(text.contains(", reversing once; "), "{text}");
    assert_eq!(r.log.meta.get("planner"), Some(&text));
    let ego = &r.log.tracks[0];
    let (fwd, back) = (
        ego.state.speed.iter().cloned().fold(0.0, f64::max),
        ego.state.speed.iter().cloned().fold(0.0, f64::min),
    );
    assert!(fwd > 1.0 && back < -1.0, "{fwd} {back}");
    // Stopped at the cusp: no step goes from forwards to backwards
    // without standing still in between.
    for w in ego.state.speed.windows(2) {
        assert!(!(w[0] > 0.0 && w[1] < 0.0), "{w:?}");
    }
    let c = &r.corridor;
    let n0 = r.legs[0].corridor.points.len();
    assert_eq!(c.points.len(), n0 + r.legs[1].corridor.points.len());
    assert!(c.speed[..n0].iter().all(|v| *v >= 0.0));
    assert!(c.speed[n0..].iter().all(|v| *v <= 0.0));
    assert!(c.s.windows(2).all(|w| w[1] >= w[0]));
}

/// Goals that are not a place the vehicle can be are refused before any
/// planner runs, with the place and why (issue 50's bad input); a start
/// inside the margin is left along its escape leg, which the result and
/// the log's `start` meta describe.
#[test]
fn bad_goals_are_refused_with_their_place_and_a_start_inside_the_margin_is_left() {
    let cfg = example("parking_lot.toml");
    let run = |gx: f64, gy: f64| {
        let mut c = cfg.clone();
        c.goal.x = gx;
        c.goal.y = gy;
        run_closed_loop(&c, grid_of(&c))
            .map(|_| ())
            .unwrap_err()
            .to_string()
    };
    let e = run(20.0, 10.0);
    assert!(
        e.contains("the goal (20.00, 10.00) lies inside an obstacle"),
        "{e}"
    );
    let e = run(80.0, 10.0);
    assert!(
        e.contains("the goal (80.00, 10.00) is off the map, which spans x 0.0..50.0 m"),
        "{e}"
    );
    let e = run(f64::NAN, 10.0);
    assert!(e.contains("goal: (NaN, 10) is not a finite point"), "{e}");
    // The bus of the parking lot: its rear on the map's edge.
    let mut bus = cfg.clone();
    bus.vehicle.preset = "bus".into();
    bus.goal.tolerance = 0.5;
    let r = run_closed_loop(&bus, grid_of(&bus)).unwrap();
    assert!(r.reached_goal && !r.collided);
    let esc = r
        .start_escape
        .clone()
        .expect("the start is inside the margin");
    assert!(
        !esc.reverse && esc.depth > 0.5 && esc.length < 1.5,
        "{esc:?}"
    );
    let t = esc.inside_s.expect("it left the margin");
    assert!(t > 0.0 && t < 10.0, "{t}");
    assert_eq!(r.log.meta.get("start"), Some(&esc.to_string()));
    assert!(
        esc.to_string()
            .starts_with("inside the margin by 0.68 m: left along a 0.80 m leg forwards")
    );
}
