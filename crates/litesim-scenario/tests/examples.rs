//! The project's example scenarios (`examples/scenarios`) with assertions
//! on their outcomes, kinematic and dynamic; the seed's smoke test with only
//! `$FTX` set; determinism across runs, seeds, threads, shards and
//! transports (in-process vs a live gRPC server).

use litesim_scenario::{
    DriveMode, LoadOptions, Prepared, RunOptions, RunResult, Summary, batch, prepare, run,
};
use std::collections::BTreeMap;
use std::path::Path;

mod common;
use common::{example, example_file, phase, root, smoke};

fn go(name: &str, seed: u64, mode: DriveMode) -> RunResult {
    let prep = example(name);
    let opts = RunOptions {
        npc: litesim_scenario::Npc::Planned,
        seed: Some(seed),
        mode: Some(mode),
        record: true,
        ..RunOptions::default()
    };
    run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The header every hand-written test below starts with.
const HEADER: &str = "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/straight.xodr\"\n";

/// Runs a prepared test in-process with default options.
fn run_default(p: &Prepared) -> Result<RunResult, litesim_scenario::ScenarioError> {
    run(
        p,
        &mut litesim_scenario::in_process(),
        &RunOptions::default(),
    )
}

fn pair<'a>(s: &'a Summary, a: &str, b: &str) -> &'a litesim_scenario::kpi::PairKpi {
    s.pairs
        .iter()
        .find(|p| (p.a == a && p.b == b) || (p.a == b && p.b == a))
        .unwrap_or_else(|| panic!("no pair {a}/{b}"))
}

fn actor<'a>(s: &'a Summary, id: &str) -> &'a litesim_scenario::kpi::ActorKpi {
    s.actors.iter().find(|a| a.id == id).unwrap()
}

/// Final planned position of an actor.
fn last(r: &RunResult, id: &str) -> (f64, f64, f64) {
    let a = r.plan.actors.iter().find(|a| a.id == id).unwrap();
    let s = a.samples.last().unwrap();
    (s.x, s.y, s.v)
}

const ALL: &[&str] = &[
    "accelerate",
    "curvy_road",
    "cut_in",
    "cyclist_ahead",
    "emit_wait_until",
    "follow",
    "gentle_stop",
    "headway_change",
    "hold_and_travel",
    "jaywalker",
    "lane_change",
    "lead_brakes",
    "obstacle_avoidance",
    "oncoming",
    "one_of_speed",
    "overtake",
    "overtake_actions",
    "overtake_gap",
    "platoon",
    "pedestrian_crossing",
    "random_duration",
    "recorded_path",
    "red_light_run",
    "ring_follow",
    "same_road_pair",
    "speed_and_lane_actions",
    "speed_profile",
    "speed_relative",
    "state_conditions",
    "stationary_obstacle",
    "stop_at_junction",
    "three_abreast",
    "tow_gap",
    "truck_follow",
    "wait_then_go",
    "weather_change",
    "wide_berth",
];

#[test]
fn outcomes_of_the_example_scenarios() {
    assert!(ALL.len() >= 20);
    let mut r = BTreeMap::new();
    for n in ALL {
        r.insert(*n, go(n, 1, DriveMode::Kinematic));
    }
    let s = |n: &str| &r[n].summary;
    // Everything but the unavoidable obstacle passes, kinematic paths exact.
    for n in ALL {
        let sum = s(n);
        if *n == "stationary_obstacle" || *n == "red_light_run" {
            continue;
        }
        assert!(sum.pass, "{n}: {:?}", sum.failures);
        for a in &sum.actors {
            assert!(
                a.max_path_error < 0.05,
                "{n}/{}: {}",
                a.id,
                a.max_path_error
            );
        }
    }
    // Follow: the gap stays at 20 m.
    let d = pair(s("follow"), "sut.car", "lead").min_distance;
    assert!((d - 20.0).abs() < 0.5, "follow gap {d}");
    assert!(pair(s("follow"), "sut.car", "lead").min_ttc.is_none());
    // Cut-in: the other ends 5 m ahead in the ego's lane, slower than the
    // ego by then: the swept boxes would touch in about 2.6 s. (Passing in
    // the next lane is not a TTC: the boxes' paths never meet.)
    let c = pair(s("cut_in"), "sut.car", "other");
    assert!(
        c.collision_at.is_none() && c.min_ttc.is_some_and(|t| t > 2.0 && t < 3.0),
        "{c:?}"
    );
    assert!(c.min_ttc_at.is_some_and(|t| t > 9.0), "{c:?}");
    let (ex, ey, _) = last(&r["cut_in"], "sut.car");
    let (ox, oy, _) = last(&r["cut_in"], "other");
    let gap = ((ox - ex).powi(2) + (oy - ey).powi(2)).sqrt() - 4.6;
    assert!((gap - 5.0).abs() < 0.6, "cut-in gap at end {gap}");
    // Lane change: 3.5 m sideways at the end.
    let a = &r["lane_change"].plan.actors[0];
    let (f, l) = (a.samples[0], a.samples[a.samples.len() - 1]);
    let lateral = -(l.x - f.x) * f.yaw.sin() + (l.y - f.y) * f.yaw.cos();
    assert!((lateral - 3.5).abs() < 0.1, "lateral {lateral}");
    // Overtake: the ego ends ahead of the slow car, back in its lane.
    let (ex, ey, _) = last(&r["overtake"], "sut.car");
    let (sx, sy, _) = last(&r["overtake"], "slow");
    let yaw = r["overtake"].plan.actors[0].samples[0].yaw;
    assert!(
        (ex - sx) * yaw.cos() + (ey - sy) * yaw.sin() > 5.0,
        "overtake"
    );
    assert!(
        pair(s("overtake"), "sut.car", "slow")
            .collision_at
            .is_none()
    );
    // The obstacle: the checker sees the collision (50 m at 40 km/h ≈ 4.5 s).
    let o = pair(s("stationary_obstacle"), "sut.car", "box");
    let t = o.collision_at.expect("collision");
    assert!((4.0..5.0).contains(&t), "{t}");
    assert!(!s("stationary_obstacle").pass);
    // Avoidance: passes the box with a lane of room.
    let o = pair(s("obstacle_avoidance"), "sut.car", "box");
    assert!(o.collision_at.is_none() && o.min_distance > 0.5, "{o:?}");
    // Pedestrian: crosses ahead of the slow ego, never touched.
    let p = pair(s("pedestrian_crossing"), "sut.car", "ped");
    assert!(p.collision_at.is_none() && p.min_distance > 5.0, "{p:?}");
    let ped = actor(s("pedestrian_crossing"), "ped");
    assert!(ped.distance > 8.0, "the pedestrian walks: {}", ped.distance);
    // Junction: the ego stops, on the road.
    assert!(last(&r["stop_at_junction"], "sut.car").2.abs() < 1e-9);
    assert!(
        actor(s("stop_at_junction"), "sut.car")
            .off_road_at
            .is_none()
    );
    // Traffic lights: stopping at red passes; running it is caught, with the box and the time.
    assert!(
        actor(s("stop_at_junction"), "sut.car")
            .ran_red_light
            .is_none()
    );
    let (light, t) = actor(s("red_light_run"), "sut.car")
        .ran_red_light
        .clone()
        .unwrap();
    assert!(
        light.starts_with("tl") && (t - 9.0).abs() < 0.05,
        "{light} {t}"
    );
    assert!(!s("red_light_run").pass);
    // Lead brakes: TTC falls below 3 s.
    let b = pair(s("lead_brakes"), "sut.car", "lead");
    assert!(b.min_ttc.is_some_and(|t| t < 3.0), "{b:?}");
    // Oncoming: passes in the other lane.
    let o = pair(s("oncoming"), "sut.car", "other");
    assert!(
        o.collision_at.is_none() && o.min_distance > 1.0 && o.min_distance < 3.0,
        "{o:?}"
    );
    // Ring: 15 m kept around the ring; both travel 83 m.
    let ring = pair(s("ring_follow"), "sut.car", "lead").min_distance;
    assert!((ring - 15.0).abs() < 0.5, "ring gap {ring}");
    assert!((actor(s("ring_follow"), "lead").distance - 83.3).abs() < 1.0);
    // Curvy: on the road all the way at 60 km/h.
    assert!(actor(s("curvy_road"), "sut.car").off_road_at.is_none());
    assert!((actor(s("curvy_road"), "sut.car").max_speed - 16.67).abs() < 0.05);
    // Accelerate: 0 → 50 km/h at 2 m/s² takes 6.9 s.
    assert!((actor(s("accelerate"), "sut.car").max_speed - 13.89).abs() < 0.05);
    // Three abreast: one lane apart, no contact.
    assert!(pair(s("three_abreast"), "sut.car", "middle").min_distance > 1.0);
    assert!(pair(s("three_abreast"), "left", "middle").min_distance > 1.0);
    // Truck: 12 m long, 2 s behind at 40 km/h ≈ 22.2 m.
    let tk = r["truck_follow"]
        .plan
        .actors
        .iter()
        .find(|a| a.id == "truck1")
        .unwrap();
    assert_eq!((tk.length, tk.category.as_str()), (12.0, "truck"));
    assert!((pair(s("truck_follow"), "sut.car", "truck1").min_distance - 22.2).abs() < 0.3);
    // Wait then go: still for 2 s, then off.
    let w = &r["wait_then_go"].plan.actors[0].samples;
    assert!(w.iter().take(20).all(|x| x.v == 0.0) && w.last().unwrap().v > 8.0);
    // Speed profile: 30, 60, 40 km/h.
    let sp = &r["speed_profile"].plan.actors[0].samples;
    let at = |t: f64| sp[(t / r["speed_profile"].plan.dt).round() as usize].v * 3.6;
    assert!(
        (at(2.0) - 30.0).abs() < 0.1
            && (at(7.5) - 60.0).abs() < 0.1
            && (at(11.5) - 40.0).abs() < 0.1
    );
    // Same road: both cars on the one road chosen.
    let roads = &s("same_road_pair").roads;
    assert_eq!(
        roads
            .values()
            .collect::<std::collections::BTreeSet<_>>()
            .len(),
        1
    );
    // Events: the parked car waits for `clear` (emitted at 3 s); `until
    // elapsed(2s)` cuts the ego's 10 s phase to 2 s.
    let ewu = &r["emit_wait_until"].plan;
    // A declared event is used, not "not executed": no note about it.
    assert!(
        r["emit_wait_until"].summary.notes.is_empty(),
        "{:?}",
        r["emit_wait_until"].summary.notes
    );
    let ph = |actor: &str, action: &str| {
        ewu.phases
            .iter()
            .find(|p| p.actor == actor && p.action.name() == action)
            .map(|p| (p.t0, p.t1))
            .unwrap()
    };
    assert_eq!(ph("parked", "remain_stationary"), (0.0, 3.0));
    assert_eq!(ph("parked", "drive"), (3.0, 7.0));
    let second = ewu
        .phases
        .iter()
        .find(|p| p.label.as_deref() == Some("second"))
        .unwrap();
    assert_eq!((second.t0, second.t1), (3.0, 5.0));
    let parked = ewu.actors.iter().find(|a| a.id == "parked").unwrap();
    assert!(
        parked
            .samples
            .iter()
            .filter(|x| x.t < 3.0 - 1e-9)
            .all(|x| x.v == 0.0)
    );
    assert!(parked.samples.last().unwrap().v > 8.0);
    // Conditions over states: the pull-away ends when the ego's speed rises
    // past 40 km/h (1 s + 11.1 m/s ÷ 2 m/s² ≈ 6.56 s, on 0.1 s samples);
    // the parked car leaves once the ego passes 30 km/h (≈ 5.17 s).
    let sc = &r["state_conditions"];
    let pull = sc
        .plan
        .phases
        .iter()
        .find(|p| p.label.as_deref() == Some("pull_away"))
        .unwrap();
    assert!((6.4..=6.7).contains(&pull.t1), "{pull:?}");
    let go = sc
        .plan
        .phases
        .iter()
        .find(|p| p.actor == "other" && p.action.name() == "drive")
        .unwrap();
    assert!((5.0..=5.3).contains(&go.t0), "{go:?}");
    assert!(
        !sc.summary.notes.iter().any(|n| n.contains("condition")),
        "{:?}",
        sc.summary.notes
    );
    // Cyclist: closes in but never reaches.
    assert!(pair(s("cyclist_ahead"), "sut.car", "bike").min_distance > 15.0);
}

#[test]
fn the_red_light_run_is_caught_on_every_approach() {
    // Seeds choose among the junction's four roads; each approach has its light.
    let mut lights = std::collections::BTreeSet::new();
    for seed in 1..=8 {
        let r = go("red_light_run", seed, DriveMode::Kinematic);
        let (light, t) = actor(&r.summary, "sut.car")
            .ran_red_light
            .clone()
            .unwrap_or_else(|| {
                panic!(
                    "seed {seed} on {:?}: no red light run caught",
                    r.summary.roads
                )
            });
        assert!((t - 9.0).abs() < 0.05, "seed {seed}: {t}");
        lights.insert(light);
    }
    assert!(lights.len() >= 3, "{lights:?}");
}

#[test]
fn a_green_light_is_not_a_violation_and_unknown_lights_are_errors() {
    let text =
        std::fs::read_to_string(root().join("examples/scenarios/red_light_run.osc")).unwrap();
    let green = example_file(&text.replace("switch(red)", "switch(green)"));
    let prep = prepare(green.path(), &LoadOptions::default()).unwrap();
    let r = run_default(&prep).unwrap();
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    let wrong = example_file(&text.replace("\"c1\"", "\"c9\""));
    let prep = prepare(wrong.path(), &LoadOptions::default()).unwrap();
    let e = run_default(&prep).unwrap_err().to_string();
    assert!(
        e.contains("traffic light 'c9' is not in the map") && e.contains("c1"),
        "{e}"
    );
}

#[test]
fn seeds_draw_within_the_constraints_and_change_the_run() {
    let mut durations = std::collections::BTreeSet::new();
    let mut speeds = std::collections::BTreeSet::new();
    for seed in 1..=8 {
        let r = go("random_duration", seed, DriveMode::Kinematic);
        let d = r.plan.duration;
        assert!((3.0..=6.0).contains(&d), "{d}");
        let v = r.plan.actors[0].samples[0].v * 3.6;
        assert!((30.0 - 1e-9..=50.0 + 1e-9).contains(&v), "{v}");
        durations.insert((d * 1000.0) as i64);
        speeds.insert((v * 1000.0) as i64);
        let c = go("one_of_speed", seed, DriveMode::Kinematic);
        let v = (c.plan.actors[0].samples[0].v * 3.6).round();
        assert!(v == 30.0 || v == 70.0);
    }
    assert!(durations.len() >= 6 && speeds.len() >= 6);
}

/// Holding a speed on the seed's model is a feather-light throttle: on no
/// pedal it coasts at 2 m/s² (the drivers' first command used to be exactly
/// that, 0.09 m behind after one step). At constant speed the dynamic run
/// now matches its plan.
#[test]
fn dynamic_constant_speed_is_held_exactly() {
    for n in ["follow", "truck_follow", "three_abreast"] {
        let r = go(n, 1, DriveMode::Dynamic);
        for a in &r.summary.actors {
            // Within a few mm/s: commands travel at the profile's
            // resolution (1e-4), so a hold alternates the smallest
            // throttle and the controller's brake (an exact hold needed a
            // 2e-308 throttle).
            assert!(
                a.max_speed_error < 0.005,
                "{n}/{}: {}",
                a.id,
                a.max_speed_error
            );
            assert!(
                a.max_path_error < 0.01,
                "{n}/{}: {}",
                a.id,
                a.max_path_error
            );
        }
    }
}

#[test]
fn dynamic_runs_follow_the_plan() {
    for n in ALL {
        // assign_speed and keep_position ask for exactness over physics:
        // the plan's speed jumps (to 30 km/h, to a standstill), which no
        // vehicle model follows (tests/stdlib.rs checks that plan). The
        // long ramps of platoon, tow_gap, headway_change and overtake_gap
        // (20-40 km/h at 1-4 m/s²) add up the dummy model's steady lag on
        // a ramp (0.46 m/s at most) to 6-7 m: their speed errors are
        // checked below (tests/stdlib.rs checks their plans and their
        // driven gaps).
        if *n == "hold_and_travel" {
            continue;
        }
        let ramps = ["platoon", "tow_gap", "headway_change", "overtake_gap"].contains(n);
        let r = go(n, 1, DriveMode::Dynamic);
        // From standstill at ≥ 2 m/s² the dummy model's throttle saturates
        // (4 m/s² minus its 2 m/s² free deceleration): the lag is physical.
        // A hard stop (lead_brakes) lags its plan by about a metre under
        // the tuned brake loop; a car re-timed live (emit_wait_until's
        // parked car pulls away when the event comes) overshoots its speed
        // by 0.4 m/s after its launch: 1.4 m. A long stop to standstill
        // (gentle_stop's 7 s smooth stop) ends 1.46 m short of its plan.
        let tol = if [
            "accelerate",
            "state_conditions",
            "lead_brakes",
            "emit_wait_until",
            "speed_and_lane_actions",
            "gentle_stop",
        ]
        .contains(n)
        {
            1.5
        } else {
            1.0
        };
        for a in &r.summary.actors {
            assert!(
                ramps || a.max_path_error < tol,
                "{n}/{}: path error {}",
                a.id,
                a.max_path_error
            );
            assert!(
                a.max_speed_error < 1.0,
                "{n}/{}: speed error {}",
                a.id,
                a.max_speed_error
            );
        }
    }
}

#[test]
fn contradictions_and_bad_tests_are_precise_errors() {
    let p = example("too_many_lanes");
    let e = run_default(&p).unwrap_err().to_string();
    assert!(
        e.contains("no one_way_road in") && e.contains("circ.xodr has ≥ 3 lanes"),
        "{e}"
    );
    assert!(e.contains("road 1 (one-way, 2 lanes"), "{e}");
    // A test with a type error does not run; the diagnostics say why.
    let bad = example_file(&format!(
        "{HEADER}scenario sut.x:\n    do sut.car.drive() with:\n        speed(3s)\n"
    ));
    let e = prepare(bad.path(), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains(":6:15") && e.contains("E0303"), "{e}");
    // Missing map file.
    let nomap = example_file(&HEADER.replace("../maps/straight.xodr", "nowhere.xodr"));
    let e = prepare(nomap.path(), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("nowhere.xodr"), "{e}");
    // An empty test (no behaviour, no map) says it has nothing to run.
    let empty = example_file("");
    let p = prepare(empty.path(), &LoadOptions::default()).unwrap();
    let e = run_default(&p).unwrap_err().to_string();
    assert!(e.contains("top.main has no behaviour"), "{e}");
    // Strict speed that cannot be reached is a post-plan violation.
    let strict = example_file(&format!(
        "{HEADER}extend top.main:\n    do serial():\n        sut.car.drive() with:\n            speed(10kph)\n            duration(1s)\n        sut.car.drive() with:\n            speed(100kph)\n            duration(1s)\n"
    ));
    let p = prepare(strict.path(), &LoadOptions::default()).unwrap();
    let s = run_default(&p).unwrap().summary;
    let e = s.failures.join("; ");
    assert!(!s.pass && s.steps == 0, "{s:?}");
    assert!(e.contains("post-plan") && e.contains("strict speed"), "{e}");
}

fn fnv(bytes: &[u8]) -> u64 {
    litesim_ssp::testkit::fnv1a(bytes)
}

fn digest(r: &RunResult) -> (String, u64) {
    let log = r.log.as_ref().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("log.json");
    log.write_json(&p).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    (serde_json::to_string(&r.summary).unwrap(), fnv(&bytes))
}

#[test]
fn the_seed_smoke_test_runs_with_only_ftx_and_is_bit_stable() {
    let prep = smoke();
    // Kinematic, as the golden always was (the configuration's default,
    // dynamic, has its own golden below).
    let opts = RunOptions {
        npc: litesim_scenario::Npc::Planned,
        record: true,
        mode: Some(DriveMode::Kinematic),
        ..RunOptions::default()
    };
    let a = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    assert!(a.summary.pass, "{:?}", a.summary.failures);
    assert_eq!(a.summary.roads["s.r1"], a.summary.roads["s.r2"]);
    assert!((3.0..=6.0).contains(&a.summary.duration));
    assert_eq!(a.summary.profile, "dummy");
    // The ego's tracking columns: one per step, errors small in a kinematic run.
    let tr = a.log.as_ref().unwrap().tracking.as_ref().unwrap();
    assert_eq!(tr.tick.len() as u64, a.summary.steps);
    assert!(tr.lateral_error.iter().all(|e| e.abs() < 0.05));
    assert!(tr.progress.windows(2).all(|w| w[1] >= w[0]));
    // …and its planned path as the reference the dashboard draws.
    let planned = a.log.as_ref().unwrap().plan.as_ref().unwrap();
    assert_eq!(planned.corridor.len(), a.plan.actors[0].samples.len());
    let b = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    assert_eq!(digest(&a), digest(&b));
    // Other threads, same bytes.
    let t = std::thread::spawn(move || {
        let prep = smoke();
        let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
        digest(&r)
    })
    .join()
    .unwrap();
    assert_eq!(digest(&a), t);
    // Golden: guards determinism across commits and machines (litesim's own
    // sin_cos, the libm crate for the rest).
    let (_, d) = digest(&a);
    assert_eq!(d, GOLDEN_SMOKE_LOG, "smoke log digest changed: {d:#018x}");
}

/// FNV-1a of the smoke run's log JSON (seed 1, kinematic, dummy).
const GOLDEN_SMOKE_LOG: u64 = 0xef02_e064_66f6_8ed9;

/// The seed's dummy configuration drives with pedals and steering by
/// default ("internal dynamic simulation with preconfigured PID
/// controllers"), `--kinematic` one option away; every command is one a
/// person can read: within its travel and a multiple of the profile's
/// resolution (1e-4), never a denormal.
#[test]
fn the_dummy_configuration_drives_dynamically_with_readable_commands() {
    let prep = smoke();
    let opts = RunOptions {
        npc: litesim_scenario::Npc::Planned,
        record: true,
        ..RunOptions::default()
    };
    let a = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    assert_eq!(a.summary.mode, DriveMode::Dynamic);
    assert!(a.summary.pass, "{:?}", a.summary.failures);
    let log = a.log.as_ref().unwrap();
    let mut seen = 0;
    for track in &log.tracks {
        let c = &track.control;
        for (key, xs) in [
            ("throttle", &c.throttle),
            ("brake", &c.brake),
            ("steering", &c.steering),
        ] {
            for &x in xs.iter().filter(|x| x.is_finite()) {
                seen += 1;
                let k = x / 1e-4;
                assert!(
                    (k - k.round()).abs() < 1e-6 && x.abs() <= 1.0,
                    "{} {key} = {x:e} is not a multiple of 1e-4 within its travel",
                    track.id
                );
            }
        }
    }
    assert!(seen > 100, "no commands found in the log");
    let b = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    assert_eq!(digest(&a), digest(&b));
    let (_, d) = digest(&a);
    assert_eq!(
        d, GOLDEN_SMOKE_DYNAMIC_LOG,
        "dynamic smoke log digest changed: {d:#018x}"
    );
    let kinematic = RunOptions {
        npc: litesim_scenario::Npc::Planned,
        mode: Some(DriveMode::Kinematic),
        ..RunOptions::default()
    };
    let k = run(&prep, &mut litesim_scenario::in_process(), &kinematic).unwrap();
    assert_eq!(k.summary.mode, DriveMode::Kinematic);
}

/// FNV-1a of the smoke run's log JSON under its configuration (seed 1,
/// dynamic, dummy).
const GOLDEN_SMOKE_DYNAMIC_LOG: u64 = 0xe972_e189_2e89_0f11;

/// A run in which no actor replays its plan: sut.car under the reference
/// ACC, the other car a driver. The planned controller then has nothing
/// to send and skips its step; the log must be what it was when that
/// controller still walked every actor each step (the digest was taken
/// from the code before the skip, and 470 CLI runs compared byte for
/// byte).
#[test]
fn a_run_with_nothing_to_replay_keeps_its_log() {
    let opts = RunOptions {
        seed: Some(1),
        record: true,
        sut: litesim_scenario::sut::SutChoice::builtin("acc").unwrap(),
        mode: Some(DriveMode::Kinematic),
        ..RunOptions::default()
    };
    let a = run(
        &example("cut_in"),
        &mut litesim_scenario::in_process(),
        &opts,
    )
    .unwrap();
    assert_eq!(a.summary.steps, 500);
    let (_, d) = digest(&a);
    assert_eq!(
        d, GOLDEN_ACC_CUT_IN_LOG,
        "acc cut_in log digest changed: {d:#018x}"
    );
}

/// FNV-1a of `cut_in.osc`'s log JSON under the reference ACC (seed 1,
/// kinematic, drivers for the others).
const GOLDEN_ACC_CUT_IN_LOG: u64 = 0x81e9_7d9a_1dde_26e2;

#[test]
fn in_process_and_grpc_runs_are_identical() {
    let server = litesim_grpc::LoopbackServer::start(Default::default(), 1).unwrap();
    let addr = server.addr;
    for (name, mode) in [
        ("cut_in", DriveMode::Kinematic),
        ("overtake", DriveMode::Dynamic),
    ] {
        let local = go(name, 3, mode);
        let prep = example(name);
        let mut remote = litesim_grpc::RemoteSsp::connect(&addr.to_string()).unwrap();
        let opts = RunOptions {
            npc: litesim_scenario::Npc::Planned,
            seed: Some(3),
            mode: Some(mode),
            record: true,
            ..RunOptions::default()
        };
        let over = run(&prep, &mut remote, &opts).unwrap();
        drop(remote);
        assert_eq!(digest(&local), digest(&over), "{name} {mode:?}");
    }
    server.stop().unwrap();
}

fn batch_spec(
    out: &Path,
    shard: (u64, u64),
    threads: usize,
    seeds: (u64, u64),
) -> batch::BatchSpec {
    batch::BatchSpec {
        tests: ["follow", "cut_in", "random_duration", "too_many_lanes"]
            .iter()
            .map(|n| root().join(format!("examples/scenarios/{n}.osc")))
            .collect(),
        seed_from: seeds.0,
        seed_to: seeds.1,
        shard,
        threads: Some(threads),
        out: out.to_path_buf(),
        resume: false,
        force_new: false,
        mode: Some(DriveMode::Kinematic),
        load: LoadOptions::default(),
        calibration_dir: None,
        sut: Default::default(),
        npc: litesim_scenario::Npc::Planned,
        sut_timeout: None,
        step_ms: None,
        save_failed: false,
        save_failed_mcap: false,
        precomputed: Default::default(),
    }
}

#[test]
fn batch_results_are_identical_across_threads_shards_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one");
    let r = batch::run_batch(&batch_spec(&one, (0, 1), 1, (1, 6)), &|_, _| {}).unwrap();
    assert_eq!((r.total, r.ran), (24, 24));
    // too_many_lanes fails every seed with the solver's message.
    let text = std::fs::read_to_string(one.join("results.jsonl")).unwrap();
    assert_eq!(text.lines().filter(|l| l.contains("≥ 3 lanes")).count(), 6);
    let two = dir.path().join("two");
    batch::run_batch(&batch_spec(&two, (0, 1), 2, (1, 6)), &|_, _| {}).unwrap();
    let mut shards = Vec::new();
    for i in 0..3 {
        let d = dir.path().join(format!("shard{i}"));
        batch::run_batch(&batch_spec(&d, (i, 3), 2, (1, 6)), &|_, _| {}).unwrap();
        shards.push(d);
    }
    let merged = dir.path().join("merged");
    assert_eq!(batch::merge(&shards, &merged, false).unwrap().runs, 24);
    // Resume: half the seeds first, then all with --resume.
    let res = dir.path().join("resumed");
    batch::run_batch(&batch_spec(&res, (0, 1), 2, (1, 3)), &|_, _| {}).unwrap();
    let mut spec = batch_spec(&res, (0, 1), 2, (1, 6));
    spec.resume = true;
    let r = batch::run_batch(&spec, &|_, _| {}).unwrap();
    assert_eq!((r.skipped, r.ran), (12, 12));
    for f in ["results.jsonl", "results.csv"] {
        let a = std::fs::read(one.join(f)).unwrap();
        for d in [&two, &merged, &res] {
            assert_eq!(
                a,
                std::fs::read(d.join(f)).unwrap(),
                "{f} in {}",
                d.display()
            );
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
    /// Mangled tests never crash the engine: they fail to load with
    /// diagnostics, or fail to solve or plan with an error, or run.
    #[test]
    fn mangled_tests_never_panic(
        which in 0usize..ALL.len(),
        pos in 0usize..2000,
        ins in proptest::sample::select(vec![
            "(", ")", ":", "\n", "    ", "-", "0", "999999kph", "-5m", "[9..1]s", "speed(", "lane(9)",
            "keep(r.min_lanes == 0)\n    ", "position(-1000m, ahead_of: sut.car)", "duration(0s)", "duration(99999999s)", "x", "\"", "\n        duration(9999999s)",
        ]),
    ) {
        let name = ALL[which];
        let mut text = std::fs::read_to_string(root().join(format!("examples/scenarios/{name}.osc"))).unwrap();
        let p = pos.min(text.len());
        if text.is_char_boundary(p) {
            text.insert_str(p, ins);
        }
        let file = example_file(&text);
        if let Ok(prep) = prepare(file.path(), &LoadOptions::default()) {
            let _ = run(&prep, &mut litesim_scenario::in_process(), &RunOptions::default());
        }
    }
}

/// A test file beside the seed's smoke test that imports `config` and runs
/// `body` on the seed's map.
fn beside_smoke(config: &str, body: &str) -> (tempfile::NamedTempFile, Prepared) {
    let dir = root().join("osc/env/basic/exe_platforms/model_ssp/test");
    let file = tempfile::Builder::new()
        .suffix(".osc")
        .tempfile_in(&dir)
        .unwrap();
    std::fs::write(
        file.path(),
        format!(
            "import \"$FTX/env/basic/exe_platforms/model_ssp/config/{config}\"\nextend test_config:\n    set map = \"$FTX/smoke/maps/circ_fix.xodr\"\n{body}"
        ),
    )
    .unwrap();
    let env = BTreeMap::from([("FTX".to_string(), root().join("osc").display().to_string())]);
    let prep = prepare(
        file.path(),
        &LoadOptions {
            env: Some(env),
            ..LoadOptions::default()
        },
    )
    .unwrap();
    (file, prep)
}

const PAIR: &str = "extend top.main:\n    do s: sut.pair() with:\n        keep(s.r1 == s.r2)\nscenario sut.pair:\n    r1: one_way_road\n    r2: one_way_road\n    car1: vehicle\n    do parallel(overlap: equal):\n        sut.car.drive() with:\n            speed(30kph)\n            along(r1, at: start)\n        car1.drive() with:\n            speed(30kph)\n            along(r2, at: start)\n    with: duration(5s)\n";

#[test]
fn every_profile_and_model_config_runs_the_smoke_shape() {
    let configs = [
        ("profile_carla_0_9_12_config.osc", "carla-0.9.12", "dummy"),
        ("profile_carla_0_9_13_config.osc", "carla-0.9.13", "dummy"),
        ("profile_carla_0_9_15_config.osc", "carla-0.9.15", "dummy"),
        ("profile_sumo_config.osc", "sumo", "dummy"),
        ("profile_dspace_config.osc", "dspace", "dummy"),
        ("profile_carmaker_config.osc", "carmaker", "dummy"),
        ("profile_drivesim_config.osc", "drivesim", "dummy"),
        ("profile_simian_config.osc", "simian", "dummy"),
        ("profile_aisim_config.osc", "aisim", "dummy"),
        ("model_ssp_bicycle_config.osc", "dummy", "bicycle"),
        ("model_ssp_lag_config.osc", "dummy", "lag"),
        // The seed's own file names (Model SSP §489.5).
        ("model_dummy_config.osc", "dummy", "dummy"),
        ("model_carla_0_9_12_config.osc", "carla-0.9.12", "dummy"),
        ("model_carla_0_9_13_config.osc", "carla-0.9.13", "dummy"),
        ("model_carla_0_9_15_config.osc", "carla-0.9.15", "dummy"),
        ("model_sumo_config.osc", "sumo", "dummy"),
        ("model_dspace_config.osc", "dspace", "dummy"),
        ("model_carmaker_config.osc", "carmaker", "dummy"),
        ("model_drivesim_config.osc", "drivesim", "dummy"),
        ("model_simian_config.osc", "simian", "dummy"),
        ("model_aisim_config.osc", "aisim", "dummy"),
    ];
    for (config, profile, model) in configs {
        let (_f, prep) = beside_smoke(config, PAIR);
        for mode in [DriveMode::Kinematic, DriveMode::Dynamic] {
            let opts = RunOptions {
                npc: litesim_scenario::Npc::Planned,
                mode: Some(mode),
                ..RunOptions::default()
            };
            let r = run(&prep, &mut litesim_scenario::in_process(), &opts)
                .unwrap_or_else(|e| panic!("{config} {mode:?}: {e}"));
            let s = &r.summary;
            assert_eq!(
                (s.profile.as_str(), s.model.as_str()),
                (profile, model),
                "{config}"
            );
            // Mirrored (CARLA) frames convert at the boundary: nobody leaves the road.
            assert!(s.pass, "{config} {mode:?}: {:?}", s.failures);
            for a in &s.actors {
                assert!(a.off_road_at.is_none(), "{config} {mode:?} {}", a.id);
            }
        }
    }
}

#[test]
fn post_plan_checks_of_a_profile_stop_an_infeasible_plan_before_it_runs() {
    let harsh = "extend top.main:\n    do sut.harsh()\nscenario sut.harsh:\n    r: one_way_road\n    do serial():\n        sut.car.drive() with:\n            speed(60kph)\n            along(r, at: start)\n            duration(2s)\n        sut.car.drive() with:\n            change_speed(-60kph)\n            acceleration(12mpsps)\n            duration(3s)\n";
    let (_f, prep) = beside_smoke("profile_dspace_config.osc", harsh);
    // A failed test with its reasons (and a summary), not a crash; nothing ran.
    let s = run_default(&prep).unwrap().summary;
    assert!(!s.pass && s.steps == 0);
    assert!(
        s.notes.iter().any(|n| n.contains("not executed")),
        "{:?}",
        s.notes
    );
    let e = s.failures.join("; ");
    assert!(
        e.contains("post-plan")
            && e.contains("sut.car: deceleration 12.00 m/s²")
            && e.contains("exceeds the profile's 10.00 m/s²"),
        "{e}"
    );
    // The dummy profile has no post-plan limits: the same plan runs.
    let (_g, prep) = beside_smoke("model_ssp_dummy_config.osc", harsh);
    run_default(&prep).unwrap();
}

#[test]
fn a_left_handed_profile_sees_the_world_mirrored_like_its_map() {
    let (_f, prep) = beside_smoke("profile_carla_0_9_15_config.osc", PAIR);
    let mut session = litesim_scenario::in_process();
    // Kinematic: the dummy configuration it imports would drive dynamically.
    let kinematic = RunOptions {
        npc: litesim_scenario::Npc::Planned,
        mode: Some(DriveMode::Kinematic),
        ..RunOptions::default()
    };
    let r = run(&prep, &mut session, &kinematic).unwrap();
    // Inside the simulator (CARLA's left-handed frame) y is negated; the
    // engine converted at the boundary, so the summary is in the map's frame.
    let world = session.world().unwrap();
    let car = world.actor("sut.car").unwrap();
    let planned = r.plan.actors.iter().find(|a| a.id == "sut.car").unwrap();
    // CARLA's step: 50 ms.
    let step = f64::from(
        litesim_ssp::Profile::builtin("carla-0.9.15")
            .unwrap()
            .step_ms,
    ) / 1000.0;
    let at = planned.at(r.summary.steps as f64 * step, r.plan.dt);
    let p = car.state().pose.position;
    assert!(
        (p.x - at.x).abs() < 1e-6 && (p.y - at.y).abs() < 1e-6,
        "{p:?} vs {at:?}"
    );
    assert!(at.y.abs() > 1.0, "the test needs a point off the x axis");
}

#[test]
fn a_car_at_a_dead_end_stops_there_and_the_plan_says_so() {
    let f = example_file(&format!(
        "{HEADER}extend top.main:\n    do sut.end()\nscenario sut.end:\n    r: two_way_road\n    do sut.car.drive() with:\n        speed(50kph)\n        along(r, at: start, start_offset: 450m)\n        lane(1, at: start)\n        duration(8s)\n"
    ));
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let r = run_default(&prep).unwrap();
    assert!(
        r.summary
            .notes
            .iter()
            .any(|n| n.contains("reaches the end of road 1")),
        "{:?}",
        r.summary.notes
    );
    let last = r.plan.actors[0].samples.last().unwrap();
    assert_eq!(last.v, 0.0);
    assert!(r.summary.pass, "{:?}", r.summary.failures);
}

#[test]
fn along_at_end_is_checked_before_the_run() {
    let body = |secs: u32| {
        format!(
            "extend top.main:\n    do sut.ae()\nscenario sut.ae:\n    r: one_way_road\n    do serial():\n        sut.car.drive() with:\n            speed(50kph)\n            along(r, at: start, start_offset: 10m)\n            duration(2s)\n        sut.car.drive() with:\n            along(r, at: end)\n            duration({secs}s)\n"
        )
    };
    // 5 s more at 50 km/h stays on the 314 m road.
    let (_f, prep) = beside_smoke("model_ssp_dummy_config.osc", &body(5));
    assert!(run_default(&prep).unwrap().summary.pass);
    // 30 s more leaves it for the other half of the ring.
    let (_g, prep) = beside_smoke("model_ssp_dummy_config.osc", &body(30));
    let e = run_default(&prep).unwrap().summary.failures.join("; ");
    assert!(
        e.contains("post-plan") && e.contains("should end its phase on road"),
        "{e}"
    );
}

#[test]
fn calibration_never_does_worse_than_the_profile_and_round_trips() {
    for profile in ["dummy", "carla-0.9.15", "sumo"] {
        let c = litesim_scenario::calibrate::calibrate(profile).unwrap();
        assert!(c.best.score <= c.before.score, "{profile}: {c:?}");
        let p = litesim_ssp::Profile::builtin(profile).unwrap();
        assert_eq!(c.best.calibration.calibrated_step_ms, p.step_ms);
        let text = litesim_scenario::calibrate::to_toml(&c);
        assert!(text.contains("# held out"), "{text}");
        let back = litesim_scenario::calibrate::from_toml(&text).unwrap();
        assert_eq!(back, c.best.calibration);
    }
    assert!(litesim_scenario::calibrate::calibrate("no-such-profile").is_err());
}

/// `litesim calibrate` calibrates: from gains far off (speed gains 20
/// times the dummy profile's, steering a fifth), it tunes all nine on the
/// launch, speed steps and lane change, and the stop and the curve — never
/// used for tuning — track better in path and speed, RMS and maximum.
#[test]
fn calibration_improves_manoeuvres_it_did_not_tune_on() {
    use litesim_scenario::calibrate::{Manoeuvre, calibrate_from, errors};
    let p = litesim_ssp::Profile::builtin("dummy").unwrap();
    let mut start = p.calibration;
    for g in [&mut start.throttle, &mut start.brake] {
        g.kp *= 20.0;
        g.ki *= 20.0;
    }
    start.steering.kp *= 0.2;
    start.steering.kd *= 0.2;
    let c = calibrate_from(&p, start).unwrap();
    assert!(c.trials > 50, "{}", c.trials);
    let (b, a) = (&c.before.held_out, &c.best.held_out);
    eprintln!("held out: {b:?} → {a:?}");
    assert!(a.rms_path_error < b.rms_path_error, "{b:?} → {a:?}");
    assert!(a.max_path_error < b.max_path_error, "{b:?} → {a:?}");
    assert!(a.rms_speed_error < b.rms_speed_error, "{b:?} → {a:?}");
    assert!(a.max_speed_error < b.max_speed_error, "{b:?} → {a:?}");
    let (b, a) = (&c.before.tuned, &c.best.tuned);
    assert!(a.rms_path_error < b.rms_path_error, "{b:?} → {a:?}");
    assert!(a.rms_speed_error < b.rms_speed_error, "{b:?} → {a:?}");
    assert!(c.best.score < c.before.score);
    // Every kind of gain is in play: the brake gains decide the stop, the
    // steering's integral and derivative the curve.
    let stop = [Manoeuvre::Stop];
    let curve = [Manoeuvre::Curve];
    let base = c.best.calibration;
    let mut other = base;
    other.brake.kp *= 3.0;
    assert_ne!(
        errors(&p, &stop, &base).unwrap(),
        errors(&p, &stop, &other).unwrap()
    );
    let mut other = base;
    other.steering.ki = 0.05;
    assert_ne!(
        errors(&p, &curve, &base).unwrap(),
        errors(&p, &curve, &other).unwrap()
    );
    let mut other = base;
    other.steering.kd *= 2.0;
    assert_ne!(
        errors(&p, &curve, &base).unwrap(),
        errors(&p, &curve, &other).unwrap()
    );
}

/// The dashboard's command series of a scenario run is the plan's (labelled
/// "planned", reference "planned path"), and its steering is what the plan's
/// curvature implies: on the curvy road the dynamic driver's applied angle
/// follows it.
#[test]
fn planned_commands_label_and_follow_the_curvature() {
    let r = go("curvy_road", 1, DriveMode::Dynamic);
    let log = r.log.as_ref().unwrap();
    let tr = log.tracking.as_ref().unwrap();
    assert_eq!(tr.command_label(), "planned");
    assert_eq!(log.plan.as_ref().unwrap().reference_label(), "planned path");
    assert_eq!(tr.cmd_steering.len(), tr.tick.len());
    let planned_max = tr.cmd_steering.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    assert!(
        planned_max > 0.01,
        "the curvy road needs steering: {planned_max}"
    );
    // Applied vs planned, sample by sample (same ticks): close on average.
    let ego = log.tracks.iter().find(|t| t.id == "sut.car").unwrap();
    let applied: BTreeMap<u64, f64> = ego
        .tick
        .iter()
        .copied()
        .zip(ego.control.steering_angle.iter().copied())
        .collect();
    let diffs: Vec<f64> = tr
        .tick
        .iter()
        .zip(&tr.cmd_steering)
        .filter_map(|(k, d)| applied.get(k).map(|a| (a - d).abs()))
        .collect();
    let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
    assert!(
        mean < 0.25 * planned_max,
        "mean |applied − planned| {mean} vs max {planned_max}"
    );
    // No saw-tooth in the steady bend: the plan between its 0.1 s samples
    // follows the arc, not the chord (a chord made the driver's angle jump
    // by ~0.006 rad every 5 steps).
    let bend = &ego.control.steering_angle[500..580];
    let jump = bend
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    assert!(jump < 0.001, "steering jumps by {jump} rad between steps");
}

/// A scenario's parameter added by a later `extend` binds by name like its
/// own ones (the speed reaches the plan).
#[test]
fn parameters_added_by_extend_bind_by_name() {
    let body = "extend top.main:
    do f: sut.follow2(gap: 20m, cruise: 40kph)

scenario sut.follow2:
    gap: length
    r: two_way_road
    lead: vehicle
    do parallel(overlap: equal):
        lead.drive() with:
            speed(cruise)
            along(r, at: start)
        sut.car.drive() with:
            speed(cruise)
            position(gap, behind: lead, at: start)
            lane(same_as: lead, at: start)
    with: duration(8s)

extend sut.follow2:
    cruise: speed
";
    let f = example_file(&format!("{HEADER}{body}"));
    let p = prepare(f.path(), &LoadOptions::default()).unwrap();
    let r = run_default(&p).unwrap();
    for id in ["sut.car", "lead"] {
        let v = last(&r, id).2;
        assert!((v - 40.0 / 3.6).abs() < 1e-6, "{id}: {v} m/s");
    }
    let (xs, _, _) = last(&r, "sut.car");
    let (xl, _, _) = last(&r, "lead");
    // 20 m bumper to bumper plus one car length between the centres.
    assert!(((xl - xs).abs() - 24.6).abs() < 0.5, "{xs} {xl}");
}

#[test]
fn a_simulator_without_traffic_lights_drives_on_a_map_with_signals() {
    // Simian has no traffic-light API: the junction map's signals are not
    // simulated (the init diagnostics say so), and a test that switches
    // none runs.
    let f = example_file(
        "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/junction.xodr\"\nextend sim_info:\n    set profile = \"simian\"\nextend top.main:\n    do sut.car.drive() with:\n        speed(20kph)\n        duration(3s)\n",
    );
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let r = run_default(&prep).unwrap();
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    assert_eq!(r.summary.profile, "simian");
}

/// Profiles as the simulators are (issue 16 point 4): each default step
/// and range from the simulator's documentation (named in `step_source`),
/// not 20 ms everywhere; a configuration built on the dummy one runs at its
/// profile's step; dSPACE's post-plan checks are the full implementation,
/// CarMaker's and DriveSim's the base one (no curvature limit).
#[test]
fn profiles_take_their_steps_and_checks_from_the_simulators() {
    use litesim_ssp::profile::PostPlanLevel;
    let step = |n: &str| {
        let p = litesim_ssp::Profile::builtin(n).unwrap();
        assert!(
            !p.step_source.is_empty(),
            "{n} names no source for its step"
        );
        (p.step_ms, p.min_step_ms, p.max_step_ms)
    };
    assert_eq!(step("carla-0.9.15"), (50, 1, 100));
    assert_eq!(step("sumo"), (1000, 1, 10000));
    assert_eq!(step("dspace"), (1, 1, 100));
    assert_eq!(step("carmaker"), (1, 1, 100));
    assert_eq!(step("drivesim"), (33, 1, 1000));
    assert_eq!(step("dummy"), (20, 1, 1000));
    let level = |n: &str| litesim_ssp::Profile::builtin(n).unwrap().post_plan;
    assert_eq!(level("dspace").level, PostPlanLevel::Full);
    assert_eq!(level("carmaker").level, PostPlanLevel::Base);
    assert_eq!(level("drivesim").level, PostPlanLevel::Base);
    // The CARLA configuration runs at CARLA's 50 ms: 5 s in 100 steps.
    let (_f, prep) = beside_smoke("profile_carla_0_9_15_config.osc", PAIR);
    let s = run_default(&prep).unwrap().summary;
    assert_eq!(s.steps, 100, "{s:?}");
    // A 40 m curve against a curvature limit of 0.01 1/m: only the full
    // checks see it.
    let plan = litesim_scenario::calibrate::reference_plan(
        litesim_scenario::calibrate::Manoeuvre::Curve,
        0.02,
    );
    for (name, curvature_checked) in [("dspace", true), ("carmaker", false)] {
        let mut p = litesim_ssp::Profile::builtin(name).unwrap();
        p.post_plan.max_curvature = 0.01;
        let v = litesim_scenario::postplan::check(&plan, Some(&p), None);
        assert_eq!(
            v.iter().any(|m| m.contains("curvature")),
            curvature_checked,
            "{name}: {v:?}"
        );
    }
}

/// Many vehicles are checked on all cores: the same reports, in actor
/// order, as checking each vehicle alone.
#[test]
fn post_plan_checks_of_many_vehicles_keep_the_actor_order() {
    let one = litesim_scenario::calibrate::reference_plan(
        litesim_scenario::calibrate::Manoeuvre::Curve,
        0.02,
    );
    let mut p = litesim_ssp::Profile::builtin("dspace").unwrap();
    p.post_plan.max_curvature = 0.01;
    p.post_plan.max_speed = 1.0;
    let mut many = one.clone();
    many.actors = (0..40)
        .map(|k| {
            let mut a = one.actors[0].clone();
            a.id = format!("v{k:02}");
            a
        })
        .collect();
    let each: Vec<String> = many
        .actors
        .iter()
        .flat_map(|a| {
            let mut alone = one.clone();
            alone.actors = vec![a.clone()];
            litesim_scenario::postplan::check(&alone, Some(&p), None)
        })
        .collect();
    let got = litesim_scenario::postplan::check(&many, Some(&p), None);
    assert_eq!(got.len(), 80, "{got:?}");
    assert!(
        got[0].starts_with("v00: speed") && got[79].starts_with("v39: curvature"),
        "{got:?}"
    );
    assert_eq!(got, each);
}

/// A run's observer sees every completed tick but the last, in order, and
/// an MCAP file streamed from its pieces while the run goes on is the same
/// bytes as one written from the finished log (what `litesim run --mcap`
/// relies on); pieces of the log put together are the log.
#[test]
fn an_observed_run_streams_the_same_mcap_as_its_finished_log() {
    use std::sync::{Arc, Mutex};
    for (name, piece) in [("cut_in", 50), ("pedestrian_crossing", 7), ("overtake", 1)] {
        let prep = example(name);
        let pieces: Arc<Mutex<(usize, Vec<litesim_log::SimulationLog>)>> = Arc::default();
        let seen = Arc::clone(&pieces);
        let opts = RunOptions {
            npc: litesim_scenario::Npc::Planned,
            record: true,
            observer: Some(litesim_scenario::TickObserver(Arc::new(Mutex::new(
                move |log: &litesim_log::SimulationLog| {
                    let mut s = seen.lock().unwrap();
                    if log.tick.len() >= s.0 + piece {
                        let p = log.ticks_from(s.0);
                        s.0 = log.tick.len();
                        s.1.push(p);
                    }
                },
            )))),
            ..RunOptions::default()
        };
        let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
        let log = r.log.unwrap();
        let (sent, mut got) = std::mem::take(&mut *pieces.lock().unwrap());
        assert!(
            got.len() >= 2 && sent < log.tick.len(),
            "{name}: {sent} of {}",
            log.tick.len()
        );
        got.push(log.ticks_from(sent));
        let ticks: Vec<u64> = got.iter().flat_map(|p| p.tick.clone()).collect();
        assert_eq!(ticks, log.tick, "{name}");
        for (a, t) in log.tracks.iter().enumerate() {
            let xs: Vec<f64> = got
                .iter()
                .flat_map(|p| p.tracks[a].state.x.clone())
                .collect();
            assert_eq!(xs, t.state.x, "{name} {}", t.id);
        }
        let map = prep.net.as_deref().map(litesim_mcap::McapMap::new);
        let mut whole = std::io::Cursor::new(Vec::new());
        litesim_mcap::write_to_with(&log, map.as_ref(), &mut whole).unwrap();
        let mut streamed = std::io::Cursor::new(Vec::new());
        let mut s = litesim_mcap::McapStream::new(&mut streamed, map.as_ref(), &got[0]).unwrap();
        for p in &got {
            s.push(p).unwrap();
        }
        s.finish().unwrap();
        assert!(
            streamed.get_ref() == whole.get_ref(),
            "{name}: the streamed file differs"
        );
    }
}

/// Conditions (and every per-node state of planning) are keyed by the
/// node's place in the tree, not its address: two elaborations of the same
/// file give byte-identical plans, keys included.
#[test]
fn plan_keys_are_stable_ids_not_addresses() {
    let a = go("state_conditions", 3, DriveMode::Kinematic);
    // Something allocated in between moves the second tree elsewhere.
    let _spacer: Vec<Vec<u8>> = (0..64).map(|i| vec![0u8; 1000 + i]).collect();
    let b = go("state_conditions", 3, DriveMode::Kinematic);
    let keys: Vec<&str> = a.plan.conditions.iter().map(|c| c.key.as_str()).collect();
    assert!(!keys.is_empty(), "the example has state conditions");
    for k in &keys {
        let ok = k
            .strip_prefix("wait@")
            .or_else(|| k.strip_prefix("until@"))
            .is_some_and(|rest| {
                rest.split('.')
                    .all(|p| p.parse::<u32>().is_ok_and(|n| n < 1000))
            });
        assert!(ok, "condition key {k:?} is not a node id");
    }
    assert_eq!(
        serde_json::to_string(&a.plan).unwrap(),
        serde_json::to_string(&b.plan).unwrap()
    );
}

#[test]
fn gentle_stop_arrives_at_its_end_offset_and_stops_smoothly() {
    let r = go("gentle_stop", 1, DriveMode::Kinematic);
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    let a = &r.plan.actors[0];
    let at = |t: f64| a.at(t, r.plan.dt);
    // change_speed(-10kph) from 70 km/h: 60 km/h when it ends.
    let (_, e1) = phase(&r, "ease");
    assert!(
        (at(e1 - r.plan.dt).v - 60.0 / 3.6).abs() < 1e-6,
        "{}",
        at(e1 - r.plan.dt).v
    );
    // along(route: r, end_offset: 320m): 180 m along the 500 m road.
    let (_, a1) = phase(&r, "arrive");
    assert!((at(a1).x - 180.0).abs() < 1.0, "{}", at(a1).x);
    // The smooth stop: braking no firmer than 2.5 m/s², gentle at both
    // ends, standing at its end.
    let (s0, s1) = phase(&r, "stop");
    let log = r.log.as_ref().unwrap();
    let v = &log.tracks[0].state.speed;
    let k = |t: f64| log.time.iter().position(|&x| x >= t - 1e-9).unwrap();
    let firmest = (k(s0)..k(s1))
        .map(|i| (v[i] - v[i + 1]) / log.dt)
        .fold(0.0_f64, f64::max);
    assert!(firmest <= 2.5 + 0.05 && firmest > 2.3, "{firmest}");
    assert!(v[k(s0) + 1] > v[k(s0)] - 2.5 * log.dt * 0.2);
    assert_eq!(*v.last().unwrap(), 0.0);
}

#[test]
fn wide_berth_keeps_and_widens_the_space_beside_the_truck() {
    let r = go("wide_berth", 1, DriveMode::Kinematic);
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    let width = |id: &str| r.plan.actors.iter().find(|a| a.id == id).unwrap().width;
    let halves = (width("sut.car") + width("truck")) / 2.0;
    let free = |t: f64| {
        let (a, b) = (
            r.plan
                .actors
                .iter()
                .find(|a| a.id == "sut.car")
                .unwrap()
                .at(t, r.plan.dt),
            r.plan
                .actors
                .iter()
                .find(|a| a.id == "truck")
                .unwrap()
                .at(t, r.plan.dt),
        );
        (b.y - a.y).abs() - halves
    };
    // Kept while the truck drifts 0.8 m towards it.
    let (b0, b1) = phase(&r, "beside");
    let kept = free(b0);
    let mut t = b0;
    while t < b1 - 1e-9 {
        assert!(
            (free(t) - kept).abs() < 0.06,
            "at {t}: {} for {kept}",
            free(t)
        );
        t += 0.1;
    }
    // Widened to 2.5 m, the phase ending when it is (its last sample; the
    // next one is a step back towards the lane's centre).
    let (_, w1) = phase(&r, "widen");
    let last = w1 - r.plan.dt;
    assert!((free(last) - 2.5).abs() < 0.12, "{}", free(last));
}
