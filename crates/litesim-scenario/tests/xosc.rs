//! OpenSCENARIO XML on the runtime: every file of the corpus
//! (`examples/xosc/corpus`, written by `examples/xosc/generate.py`) run,
//! and the meaning of the elements it exercises checked on the log against
//! closed-form values. Steps are 20 ms: an event whose trigger is
//! `SimulationTime > 1` starts at 1.02 s, and the log's sample at time t is
//! the state a step ending at t reached.

use litesim_scenario::{LoadOptions, RunOptions, RunResult, prepare, run};
use std::f64::consts::PI;

mod common;
use common::root;

const DT: f64 = 0.02;
/// The time a `SimulationTime > 1` trigger fires.
const T1: f64 = 1.02;

fn go_with(name: &str, opts: RunOptions) -> RunResult {
    let p = root().join(format!("examples/xosc/corpus/{name}.xosc"));
    let prep = prepare(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
    run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Runs a corpus file, recording the log.
fn go(name: &str) -> RunResult {
    go_with(
        name,
        RunOptions {
            record: true,
            ..RunOptions::default()
        },
    )
}

/// The log's tick at time `t` (s).
fn tick(r: &RunResult, t: f64) -> usize {
    let log = r.log.as_ref().unwrap();
    log.time
        .iter()
        .position(|&x| x >= t - 1e-6)
        .unwrap_or_else(|| panic!("no sample at {t} s"))
}

/// (x, y, yaw, speed) of `id`'s box centre at time `t`.
fn at(r: &RunResult, id: &str, t: f64) -> (f64, f64, f64, f64) {
    let log = r.log.as_ref().unwrap();
    let tr = log
        .tracks
        .iter()
        .find(|x| x.id == id)
        .unwrap_or_else(|| panic!("no track {id}"));
    let k = tick(r, t).min(tr.state.x.len() - 1);
    (
        tr.state.x[k],
        tr.state.y[k],
        tr.state.yaw[k],
        tr.state.speed[k],
    )
}

/// (x, y, yaw) of `id`'s reference point (the rear axle, `REAR` behind
/// the box centre) at time `t`: where OpenSCENARIO places entities.
fn refp(r: &RunResult, id: &str, t: f64) -> (f64, f64, f64) {
    let (x, y, yaw, _) = at(r, id, t);
    (x - REAR * yaw.cos(), y - REAR * yaw.sin(), yaw)
}

fn speed(r: &RunResult, id: &str, t: f64) -> f64 {
    at(r, id, t).3
}

/// When the start trigger of `element` fired (s).
fn fired(r: &RunResult, element: &str) -> f64 {
    r.summary
        .triggers
        .iter()
        .find(|f| f.element == element && f.trigger == "start")
        .unwrap_or_else(|| panic!("{element} never started: {:?}", r.summary.triggers))
        .t
}

fn fired_times(r: &RunResult, element: &str) -> Vec<f64> {
    r.summary
        .triggers
        .iter()
        .filter(|f| f.element == element)
        .map(|f| f.t)
        .collect()
}

fn near(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (±{tol})");
}

/// The cars of the corpus: 4.6 m long, their reference point 1.3 m behind
/// the box centre the log records.
const REAR: f64 = 1.3;

#[test]
fn speed_shapes_reach_their_target_at_t0_plus_their_duration() {
    for (shape, half) in [("linear", 15.0), ("cubic", 15.0), ("sinusoidal", 15.0)] {
        let r = go(&format!("speed_{shape}_time"));
        assert!(r.summary.pass, "{shape}: {:?}", r.summary.failures);
        near(fired(&r, "accelerate"), T1, 1e-9, "start");
        near(speed(&r, "Ego", T1), 10.0, 1e-9, "before");
        near(
            speed(&r, "Ego", T1 + 1.0),
            half,
            1e-6,
            &format!("{shape} midway"),
        );
        near(
            speed(&r, "Ego", T1 + 2.0),
            20.0,
            1e-9,
            &format!("{shape} at t0 + 2 s"),
        );
        near(speed(&r, "Ego", 8.0), 20.0, 1e-9, "after");
        // The shapes differ a quarter in: linear 12.5, cubic 11.5625,
        // sinusoidal 10 + 10·(1 − cos(π/4))/2.
        let q = match shape {
            "linear" => 12.5,
            "cubic" => 11.5625,
            _ => 10.0 + 5.0 * (1.0 - (PI / 4.0).cos()),
        };
        near(
            speed(&r, "Ego", T1 + 0.5),
            q,
            1e-6,
            &format!("{shape} a quarter in"),
        );
    }
}

#[test]
fn speed_step_rate_distance_and_follow() {
    let r = go("speed_step");
    near(speed(&r, "Ego", T1), 10.0, 1e-9, "step before");
    near(speed(&r, "Ego", T1 + DT), 15.0, 1e-9, "step after one step");
    // 2 m/s² from 10 to 20 m/s: 5 s.
    let r = go("speed_linear_rate");
    near(speed(&r, "Ego", T1 + 2.5), 15.0, 1e-6, "rate midway");
    near(speed(&r, "Ego", T1 + 5.0), 20.0, 1e-9, "rate at 5 s");
    // 45 m at the mean of 10 and 20 m/s: 3 s, and 45 m covered.
    let r = go("speed_linear_distance");
    near(speed(&r, "Ego", T1 + 3.0), 20.0, 1e-9, "distance at 3 s");
    let (x0, ..) = at(&r, "Ego", T1);
    let (x1, ..) = at(&r, "Ego", T1 + 3.0);
    near(x1 - x0, 45.0, 1e-6, "distance covered");
    // followingMode follow: within maxAcceleration 6 m/s².
    let r = go("speed_follow_limits");
    near(speed(&r, "Ego", T1 + 1.0), 16.0, 1e-6, "6 m/s² for 1 s");
    near(
        speed(&r, "Ego", T1 + 20.0 / 6.0 + DT),
        30.0,
        1e-9,
        "30 m/s reached",
    );
}

#[test]
fn relative_speeds_delta_and_continuous_factor() {
    let r = go("speed_relative_delta");
    near(speed(&r, "Ego", T1 + 2.0), 20.0, 1e-9, "lead's 25 − 5");
    let r = go("speed_relative_factor_continuous");
    // The lead slows to 10 m/s by 6 s; Ego keeps half its speed.
    near(speed(&r, "Lead", 7.0), 10.0, 1e-9, "lead");
    near(speed(&r, "Ego", 7.0), 5.0, 1e-6, "half the lead's");
    near(
        speed(&r, "Ego", 1.5),
        12.5,
        1e-6,
        "half of 25 before the lead slows",
    );
}

#[test]
fn a_sinusoidal_lane_change_lands_on_the_lane_centre_at_its_duration() {
    let r = go("lane_change_sinusoidal");
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    near(refp(&r, "Ego", T1).1, -5.25, 1e-9, "lane -2 before");
    near(refp(&r, "Ego", T1 + 1.5).1, -3.5, 1e-6, "halfway across");
    near(
        refp(&r, "Ego", T1 + 3.0).1,
        -1.75,
        1e-9,
        "lane -1's centre at 3 s",
    );
    near(refp(&r, "Ego", 9.0).1, -1.75, 1e-9, "stays");
    // A third in, the sinusoid: 3.5·(1 − cos(π/3))/2.
    near(
        refp(&r, "Ego", T1 + 1.0).1,
        -5.25 + 3.5 * 0.25,
        1e-6,
        "a third in",
    );
}

#[test]
fn lane_changes_over_a_distance_and_with_a_target_offset() {
    // 40 m at 20 m/s: 2 s, linear.
    let r = go("lane_change_linear_distance");
    near(refp(&r, "Ego", T1 + 1.0).1, -7.0, 1e-6, "halfway");
    near(refp(&r, "Ego", T1 + 2.0).1, -8.75, 1e-9, "lane -3");
    let r = go("lane_change_cubic_offset");
    near(
        refp(&r, "Ego", T1 + 4.0).1,
        -1.25,
        1e-9,
        "0.5 m left of lane -1's centre",
    );
    near(
        refp(&r, "Ego", T1 + 2.0).1,
        -5.25 + 0.5 * 4.0,
        1e-6,
        "cubic halfway",
    );
}

#[test]
fn lane_offsets_take_the_time_their_lateral_acceleration_gives() {
    // Sinusoidal, 1 m at 0.5 m/s²: T = π·√(1 / (2·0.5)) = π s.
    let r = go("lane_offset_absolute");
    let t_end = T1 + PI;
    near(
        refp(&r, "Ego", t_end + DT).1,
        -4.25,
        1e-9,
        "1 m left at π s",
    );
    near(refp(&r, "Ego", T1 + PI / 2.0).1, -4.75, 0.02, "halfway");
    // Cubic, 0.8 m right at 1 m/s²: T = √(6·0.8) s.
    let r = go("lane_offset_relative");
    near(
        at(&r, "Ego", T1 + (6.0f64 * 0.8).sqrt() + DT).1,
        -6.05,
        1e-9,
        "0.8 m right",
    );
}

#[test]
fn longitudinal_distance_rigid_and_with_constraints() {
    let r = go("longitudinal_distance_rigid");
    for t in [T1 + DT, 5.0, 9.0] {
        let (xe, ..) = at(&r, "Ego", t);
        let (xl, ..) = at(&r, "Lead", t);
        near(xl - xe, 25.0, 1e-6, &format!("25 m at {t}"));
    }
    let r = go("longitudinal_time_gap");
    let (xe, _, _, ve) = at(&r, "Ego", 19.0);
    let (xl, ..) = at(&r, "Lead", 19.0);
    // 1.5 s at 20 m/s, bumper to bumper (4.6 m cars).
    near(xl - xe - 4.6, 1.5 * ve, 0.3, "time gap");
    near(ve, 20.0, 0.1, "at the lead's speed");
}

#[test]
fn synchronize_brings_both_to_their_targets_together() {
    let r = go("synchronize");
    // Ego (the master) reaches s = 250 m at 10 s (from 50 m at 20 m/s).
    let (xo, _, _, vo) = at(&r, "Other", 10.0);
    near(
        xo - REAR,
        300.0,
        1.5,
        "Other at its target when Ego is at its own",
    );
    near(vo, 25.0, 1e-6, "at the final speed");
}

#[test]
fn trajectories_polyline_clothoid_nurbs_and_untimed() {
    // Timed polyline from T1: (70, −5.25) a second in, (80, −5.25) at 2 s.
    let r = go("trajectory_polyline");
    let (x, y, _, v) = at(&r, "Ego", T1 + 1.0);
    near(x - REAR, 70.0, 1e-6, "polyline x at 1 s");
    near(y, -5.25, 1e-9, "polyline y at 1 s");
    near(v, 10.0, 1e-6, "20 m in 2 s");
    let (x, y, yaw, _) = at(&r, "Ego", T1 + 4.0);
    near(x - REAR * yaw.cos(), 100.0, 1e-6, "its end");
    near(y - REAR * yaw.sin(), -1.75, 1e-6, "its end");
    // Clothoid: heading κ′L²/2 = 0.16 rad, sideways κ′L³/6 ≈ 2.13 m.
    let r = go("trajectory_clothoid");
    let (_, y, yaw, _) = at(&r, "Ego", T1 + 4.0);
    near(yaw, 0.16, 0.005, "clothoid heading");
    near(
        y - REAR * yaw.sin(),
        -5.25 + 0.0002 * 40f64.powi(3) / 6.0,
        0.02,
        "clothoid offset",
    );
    // A quadratic Bézier (NURBS of order 3, clamped): at u = ½, t = 2 s,
    // the point (80, −4.375).
    let r = go("trajectory_nurbs");
    let (x, y, yaw, _) = at(&r, "Ego", T1 + 2.0);
    near(x - REAR * yaw.cos(), 80.0, 0.05, "nurbs x");
    near(y - REAR * yaw.sin(), -4.375, 0.05, "nurbs y");
    // Untimed, followed at its own 10 m/s: 20 m along in 2 s.
    let r = go("trajectory_untimed_follow");
    near(refp(&r, "Ego", T1 + 2.0).0, 80.0, 1e-6, "untimed");
}

#[test]
fn routes_choose_the_way_through_the_junction() {
    // Road 2 leaves the junction southwards; its lane 1 is at x = −1.75.
    let r = go("assign_route");
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    let (x, y, ..) = at(&r, "Ego", 19.0);
    near(x, -1.75, 0.05, "on road 2's lane 1");
    assert!(y < -30.0, "south of the junction: {y}");
    // Acquire road 3 lane 1 at s = 40 m: (70, −1.75), straight on.
    let r = go("acquire_position");
    let log = r.log.as_ref().unwrap();
    let tr = log.tracks.iter().find(|t| t.id == "Ego").unwrap();
    let closest = (0..tr.state.x.len())
        .map(|k| (tr.state.x[k] - REAR - 70.0).hypot(tr.state.y[k] + 1.75))
        .fold(f64::INFINITY, f64::min);
    assert!(closest < 0.2, "passes its target: {closest}");
}

#[test]
fn signal_actions_and_conditions() {
    let r = go("traffic_signal_state");
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    // Green at 2.02 s (its event); the condition sees it the next step.
    near(fired(&r, "green"), 2.02, 1e-9, "green");
    near(
        fired(&r, "start"),
        2.04,
        1e-9,
        "the condition on the signal",
    );
    near(speed(&r, "Ego", 2.0), 0.0, 1e-9, "waits");
    near(speed(&r, "Ego", 2.2), 5.0, 1e-9, "goes");
    let r = go("traffic_signal_controller");
    near(fired(&r, "jump"), T1, 1e-9, "jump to go");
    near(fired(&r, "start"), T1 + DT, 1e-9, "green seen");
}

#[test]
fn entities_are_added_and_deleted() {
    let r = go("add_delete_entity");
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    assert!(at(&r, "Late", 0.5).0 < -1.0e5, "absent before");
    near(
        at(&r, "Late", 2.0).0 - REAR,
        100.0,
        1e-6,
        "added at s = 100 m",
    );
    assert!(at(&r, "Late", 4.0).0 < -1.0e5, "absent after");
}

#[test]
fn every_position_kind_places_where_it_says() {
    let r = go("positions");
    let place = |id: &str| {
        let (x, y, yaw, _) = at(&r, id, 0.5);
        (x - REAR * yaw.cos(), y - REAR * yaw.sin())
    };
    let close = |id: &str, want: (f64, f64)| {
        let got = place(id);
        assert!(
            (got.0 - want.0).abs() < 1e-6 && (got.1 - want.1).abs() < 1e-6,
            "{id}: {got:?} vs {want:?}"
        );
    };
    close("Ego", (100.0, -5.25));
    close("A", (150.0, -1.75));
    close("B", (110.0, -1.75));
    close("C", (80.0, -8.75));
    close("D", (200.0, -5.25));
    close("E", (230.0, -1.75));
    close("F", (255.0, -4.95));
    let r = go("positions_route_orientation");
    let (x, y, yaw, _) = at(&r, "Ego", 0.5);
    near(x - REAR, 130.0, 1e-6, "route pathS 120 from s = 10");
    near(y, -8.55, 1e-6, "lane -3, 0.2 m left");
    near(yaw, 0.0, 1e-9, "along the lane");
    let (x, y, ..) = at(&r, "A", 0.5);
    near(x - REAR, 115.0, 1e-6, "15 m back");
    near(y, -1.75, 1e-6, "two lanes left");
    near(at(&r, "B", 0.5).2, 0.3, 1e-9, "relative heading");
}

/// The first log time at which `f` holds.
fn first(r: &RunResult, f: impl Fn(f64) -> bool) -> f64 {
    let log = r.log.as_ref().unwrap();
    *log.time.iter().find(|&&t| f(t)).expect("never")
}

#[test]
fn a_time_headway_condition_fires_where_the_log_first_crosses_it() {
    let r = go("cond_time_headway");
    let t = fired(&r, "react");
    // The headway from the log: the gap between reference points (equal
    // boxes: between centres) over Ego's speed, at the start of a step.
    let crossed = first(&r, |t| {
        let (xe, _, _, ve) = at(&r, "Ego", t);
        let (xl, ..) = at(&r, "Lead", t);
        ve > 0.0 && (xl - xe) / ve < 1.5
    });
    near(t, crossed, 1e-9, "headway crossing");
    near(t, 2.26, 1e-9, "(60 − 10 t) / 25 < 1.5");
    near(speed(&r, "Ego", t + DT), 0.0, 1e-9, "stops");
}

#[test]
fn distance_conditions_fire_at_their_crossing() {
    // TTC, freespace: (55.4 − 10 t) / 10 < 3.
    near(fired(&go("cond_ttc"), "react"), 2.56, 1e-9, "ttc");
    // Freespace longitudinal distance 55.4 − 10 t < 20.
    near(
        fired(&go("cond_relative_distance"), "react"),
        3.56,
        1e-9,
        "relative distance",
    );
    // Within 10 m of x = 200 (50 + 20 t > 190), as the log first shows.
    let r = go("cond_distance");
    let crossed = first(&r, |t| (refp(&r, "Ego", t).0 - 200.0).abs() < 10.0);
    near(fired(&r, "react"), crossed, 1e-9, "distance to a position");
    near(crossed, 7.0, DT + 1e-9, "about 7 s");
    // Within 2 m of s = 150 (50 + 20 t > 148), as the log first shows.
    let r = go("cond_reach_position");
    let crossed = first(&r, |t| (refp(&r, "Ego", t).0 - 150.0).abs() < 2.0);
    near(fired(&r, "react"), crossed, 1e-9, "reach position");
    // Sideways, lane frame: more than 5 m, first seen on the log.
    let r = go("cond_relative_distance_lateral");
    let crossed = first(&r, |t| {
        (at(&r, "Lead", t).1 - refp(&r, "Ego", t).1).abs() > 5.0
    });
    near(fired(&r, "react"), crossed, 1e-9, "lateral crossing");
}

#[test]
fn motion_conditions_fire_at_their_crossing() {
    // 10 m/s + 1 m/s² from 0.52 s: 15 m/s at 5.52 s.
    near(fired(&go("cond_speed"), "react"), 5.52, DT + 1e-9, "speed");
    // The lead at +2 m/s² from 1.02 s: 4 m/s faster after 2 s.
    near(
        fired(&go("cond_relative_speed"), "react"),
        3.04,
        DT + 1e-9,
        "relative speed",
    );
    // Braking at 4 m/s² from 2.02 s: seen a step later.
    near(
        fired(&go("cond_acceleration"), "react"),
        2.04,
        1e-9,
        "acceleration",
    );
    // Stopped at 1.04 s, 2 s later.
    let r = go("cond_standstill");
    near(fired(&r, "react"), 3.04, 1e-9, "standstill");
    near(speed(&r, "Ego", 3.2), 5.0, 1e-9, "drives off");
    // 100 m at 20 m/s.
    near(
        fired(&go("cond_traveled_distance"), "react"),
        5.0,
        DT + 1e-9,
        "travelled",
    );
    // The motorway ends 100 m ahead at 25 m/s: 4 s, then 1 s more.
    near(
        fired(&go("cond_end_of_road"), "react"),
        5.0,
        2.0 * DT + 1e-9,
        "end of road",
    );
    // Bumper gap 25.4 m at 20 m/s.
    let r = go("cond_collision");
    near(fired(&r, "react"), 1.28, DT + 1e-9, "collision");
    assert!(!r.summary.pass, "a collision fails the run");
}

#[test]
fn offroad_fires_half_a_second_after_leaving_the_road() {
    let r = go("cond_offroad");
    // When the run's own check saw it leave the road.
    let left = r.summary.actors[0].off_road_at.expect("it leaves the road");
    near(
        fired(&r, "react"),
        left + 0.5,
        2.0 * DT + 1e-9,
        "off road + 0.5 s",
    );
    assert!(!r.summary.pass, "off the road fails the run");
}

#[test]
fn storyboard_states_priorities_and_counts() {
    // The speed-up ends in the step that reaches 20 m/s at 3.02 s (made
    // at 3.00 s); its end transition is seen by the next step's
    // conditions.
    let r = go("storyboard_element_state");
    near(fired(&r, "after"), 3.02, 1e-9, "end transition");
    // Override: the second event stops the first and holds 15 m/s.
    let r = go("priority_override");
    near(speed(&r, "Ego", 4.0), 15.0, 1e-9, "override");
    near(
        speed(&r, "Ego", 8.0),
        15.0,
        1e-9,
        "the first does not come back",
    );
    // Skip: the first runs to 30 m/s; the second never acts.
    let r = go("priority_skip");
    near(speed(&r, "Ego", 5.1), 30.0, 1e-9, "skip");
    // Parallel: both.
    let r = go("priority_parallel");
    near(speed(&r, "Ego", 5.1), 30.0, 1e-9, "parallel speed");
    near(refp(&r, "Ego", 5.1).1, -1.75, 1e-9, "parallel lane change");
    // Three executions, one per condition group, each +2 m/s.
    let r = go("event_execution_count");
    assert_eq!(fired_times(&r, "bump"), vec![1.02, 2.02, 3.02]);
    near(speed(&r, "Ego", 5.0), 16.0, 1e-9, "three bumps");
    // A maneuver group run twice: +3 m/s twice.
    let r = go("maneuver_group_count");
    near(speed(&r, "Ego", 6.0), 16.0, 1e-9, "two executions");
    // A falling edge at 3.04 s, delayed 1.5 s.
    near(
        fired(&go("edges_and_delay"), "react"),
        4.54,
        1e-9,
        "falling + delay",
    );
    // The act's stop trigger at 2.02 s leaves the speed where it was.
    let r = go("act_stop_trigger");
    near(speed(&r, "Ego", 5.0), 15.0, 1e-6, "stopped at a quarter");
    // (t > 5 and v > 100) or (t > 2).
    near(
        fired(&go("condition_groups"), "go"),
        2.02,
        1e-9,
        "groups OR'ed",
    );
}

#[test]
fn parameters_variables_and_versions() {
    let r = go("parameters_and_expressions");
    near(speed(&r, "Ego", 0.5), 7.5, 1e-9, "${$Speed / 2}");
    near(
        speed(&r, "Ego", 1.5),
        15.0,
        1e-9,
        "$Speed after the parameter condition",
    );
    let r = go("variables");
    near(fired(&r, "react"), 2.02, DT + 1e-9, "Count reaches 6");
    assert_eq!(speed(&r, "Ego", 3.0), 0.0);
    for v in ["version_1_0", "version_1_3"] {
        let r = go(v);
        near(speed(&r, "Ego", T1 + 2.0), 20.0, 1e-9, v);
    }
}

#[test]
fn catalogs_objects_selections_and_notes() {
    let r = go("catalogs_and_controllers");
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    let log = r.log.as_ref().unwrap();
    let len = |id: &str| log.tracks.iter().find(|t| t.id == id).unwrap().length;
    near(len("Ego"), 5.2, 1e-9, "assigned Length");
    near(len("Truck"), 12.0, 1e-9, "truck");
    near(speed(&r, "Truck", 6.0), 10.0, 1e-9, "truck slowed");
    let r = go("pedestrian_and_object");
    let (_, y, ..) = at(&r, "Walker", 5.0);
    near(y, -14.0 + 1.5 * (5.0 - T1), 1e-6, "walks across");
    let r = go("entity_selection");
    near(speed(&r, "A", T1 + 2.0), 20.0, 1e-9, "A");
    near(speed(&r, "B", T1 + 2.0), 20.0, 1e-9, "B");
    let r = go("notes_environment_custom");
    let notes = r.summary.notes.join("\n");
    assert!(notes.contains("EnvironmentAction"), "{notes}");
    assert!(notes.contains("CustomCommandAction type log"), "{notes}");
}

#[test]
fn the_cut_in_with_a_sut_driving_the_ego() {
    let p = root().join("examples/xosc/cut_in.xosc");
    let prep = prepare(&p, &LoadOptions::default()).unwrap();
    let opts = RunOptions {
        record: true,
        sut: litesim_scenario::sut::SutChoice::Acc,
        ..RunOptions::default()
    };
    let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    assert_eq!(r.summary.sut, "acc");
    // The cut-in starts once the cutter is 15 m ahead (bumper to bumper)
    // and lands on the ego's lane centre 3 s later.
    let t0 = fired(&r, "CutInEvent");
    // (Its catalog box's centre is 1.4 m ahead of its reference point.)
    let (_, y, yaw, _) = at(&r, "Cutter", t0 + 3.0);
    near(y - 1.4 * yaw.sin(), -5.25, 1e-6, "on the ego's lane");
    // The SUT drove the ego: it slowed below its 25 m/s.
    assert!(speed(&r, "Ego", 10.0) < 24.0);
    // Without a SUT the storyboard drives the ego into the cutter.
    let r = run(
        &prep,
        &mut litesim_scenario::in_process(),
        &RunOptions::default(),
    )
    .unwrap();
    assert!(!r.summary.pass);
    assert!(
        r.summary
            .notes
            .iter()
            .any(|n| n.contains("no system under test was given"))
    );
}

#[test]
fn runs_are_deterministic() {
    let a = go("cond_time_headway");
    let b = go("cond_time_headway");
    assert_eq!(
        serde_json::to_string(&a.summary).unwrap(),
        serde_json::to_string(&b.summary).unwrap()
    );
    // Compared as bytes (a log's NaN columns are not equal to themselves).
    assert_eq!(
        serde_json::to_string(&a.log).unwrap(),
        serde_json::to_string(&b.log).unwrap()
    );
}

#[test]
fn a_batch_runs_every_variation_of_a_distribution() {
    let out = tempfile::tempdir().unwrap();
    let spec = litesim_scenario::batch::BatchSpec {
        tests: vec![root().join("examples/xosc/cut_in_sweep.xosc")],
        seed_from: 1,
        seed_to: 1,
        shard: (0, 1),
        threads: Some(1),
        out: out.path().to_path_buf(),
        resume: false,
        force_new: false,
        mode: None,
        load: LoadOptions::default(),
        calibration_dir: None,
        sut: litesim_scenario::sut::SutChoice::Acc,
        npc: litesim_scenario::Npc::Driver,
        sut_timeout: None,
        step_ms: None,
        save_failed: false,
        precomputed: Default::default(),
        save_failed_mcap: false,
    };
    let report = litesim_scenario::batch::run_batch(&spec, &|_, _| {}).unwrap();
    assert_eq!(report.total, 6);
    assert_eq!(report.passed, 6, "{report:?}");
    let csv = std::fs::read_to_string(out.path().join("results.csv")).unwrap();
    for k in 1..=6 {
        assert!(csv.contains(&format!("cut_in_sweep.xosc#{k}\"")), "{csv}");
    }
    // The variations differ: the ego's speed decides when the cut-in
    // starts.
    let lines = std::fs::read_to_string(out.path().join("results.jsonl")).unwrap();
    assert_eq!(lines.lines().count(), 6);
}

#[test]
fn init_actions_that_take_time_go_on_after_the_start() {
    let r = go("init_actions_go_on");
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    // From 0 s: 20 m/s over 4 s, linear; lane -1 after 3 s.
    near(speed(&r, "Ego", 2.0), 10.0, 1e-6, "halfway");
    near(speed(&r, "Ego", 4.0), 20.0, 1e-9, "at 4 s");
    near(refp(&r, "Ego", 3.0).1, -1.75, 1e-9, "lane -1 at 3 s");
}
