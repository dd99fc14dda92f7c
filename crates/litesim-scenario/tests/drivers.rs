//! Actors that drive (`--npc driver`, ambient traffic): each acceptance
//! case of the issue as a user would try it, on the bundled examples.

use litesim_scenario::sut::SutChoice;
use litesim_scenario::{LoadOptions, Npc, RunOptions, RunResult, prepare, run};
use rayon::prelude::*;

mod common;
use common::{example, example_file};

fn go(name: &str, seed: u64, sut: SutChoice, record: bool) -> RunResult {
    let opts = RunOptions {
        seed: Some(seed),
        record,
        sut,
        ..RunOptions::default()
    };
    run(&example(name), &mut litesim_scenario::in_process(), &opts)
        .unwrap_or_else(|e| panic!("{name} seed {seed}: {e}"))
}

/// Collisions in a summary between two actors that are not sut.car.
fn collisions_without_the_sut(r: &RunResult) -> Vec<String> {
    r.summary
        .pairs
        .iter()
        .filter(|p| p.collision_at.is_some() && p.a != "sut.car" && p.b != "sut.car")
        .map(|p| format!("{} and {} at {:?}", p.a, p.b, p.collision_at))
        .collect()
}

#[test]
fn a_thousand_seeds_of_dense_traffic_under_acc_have_no_collision_between_vehicles_that_are_not_the_sut()
 {
    let prep = example("dense_traffic");
    let bad: Vec<String> = (1..=1000u64)
        .into_par_iter()
        .flat_map_iter(|seed| {
            let opts = RunOptions {
                seed: Some(seed),
                sut: SutChoice::Acc,
                ..RunOptions::default()
            };
            let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
            assert!(
                r.summary.actors.len() > 40,
                "seed {seed}: only {} actors",
                r.summary.actors.len()
            );
            collisions_without_the_sut(&r)
                .into_iter()
                .map(move |c| format!("seed {seed}: {c}"))
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{} collisions: {:?}",
        bad.len(),
        &bad[..bad.len().min(10)]
    );
}

#[test]
fn under_a_planned_sut_collisions_with_it_are_its_own_rear_end_runs() {
    // The planned sut.car drives 90 km/h through traffic it ignores: it
    // runs into slower cars ahead. The drivers never run into it: at every
    // collision the other car is ahead of sut.car along its heading.
    let mut seen = 0;
    for seed in 1..=40 {
        let r = go("dense_traffic", seed, SutChoice::Planned, true);
        assert!(collisions_without_the_sut(&r).is_empty(), "seed {seed}");
        let log = r.log.as_ref().unwrap();
        let dt = log.dt;
        for p in r.summary.pairs.iter().filter(|p| p.collision_at.is_some()) {
            seen += 1;
            let other = if p.a == "sut.car" { &p.b } else { &p.a };
            let k = (p.collision_at.unwrap() / dt).round() as usize;
            let (e, o) = (log.track("sut.car").unwrap(), log.track(other).unwrap());
            let at = |t: &litesim_log::ActorTrack| {
                let i = t.tick.iter().position(|&x| x as usize >= k).unwrap();
                (t.state.x[i], t.state.y[i], t.state.yaw[i])
            };
            let ((ex, ey, eyaw), (ox, oy, _)) = (at(e), at(o));
            let along = (ox - ex) * eyaw.cos() + (oy - ey) * eyaw.sin();
            let across = -(ox - ex) * eyaw.sin() + (oy - ey) * eyaw.cos();
            assert!(
                along > 0.0,
                "seed {seed}: {other} hit at {:?}: {along:.2} m ahead, {across:.2} m across",
                p.collision_at
            );
        }
    }
    assert!(
        seen > 10,
        "the planned SUT should run into traffic ({seen})"
    );
}

#[test]
fn at_a_signalised_junction_drivers_stop_on_red_and_go_on_green() {
    let mut stood = 0;
    let mut went = 0;
    for seed in 1..=60 {
        let r = go("junction_traffic", seed, SutChoice::Acc, true);
        assert!(collisions_without_the_sut(&r).is_empty(), "seed {seed}");
        let ran: Vec<_> = r
            .summary
            .actors
            .iter()
            .filter(|a| a.id.starts_with("traffic.") && a.ran_red_light.is_some())
            .map(|a| (&a.id, &a.ran_red_light))
            .collect();
        assert!(ran.is_empty(), "seed {seed}: {ran:?}");
        let off: Vec<_> = r
            .summary
            .actors
            .iter()
            .filter(|a| a.off_road_at.is_some())
            .collect();
        assert!(off.is_empty(), "seed {seed}: off the road {off:?}");
        let log = r.log.as_ref().unwrap();
        for t in log.tracks.iter().filter(|t| t.id.starts_with("traffic.")) {
            let v = &t.state.speed;
            // Standing for a red light for at least two seconds, then
            // driving again.
            let still = v.windows(100).position(|w| w.iter().all(|s| *s < 0.05));
            if let Some(i) = still {
                stood += 1;
                if v[i + 100..].iter().any(|s| *s > 5.0) {
                    went += 1;
                }
            }
        }
    }
    assert!(stood > 20 && went > 10, "stood {stood}, went on {went}");
}

#[test]
fn cut_in_under_acc_is_realised_within_the_cruise_envelope() {
    let r = go("cut_in", 1, SutChoice::Acc, true);
    let s = &r.summary;
    assert!(
        s.notes
            .iter()
            .any(|n| n == "driven by drivers (--npc driver): other"),
        "{:?}",
        s.notes
    );
    assert!(s.pairs.iter().all(|p| p.collision_at.is_none()));
    // The cut-in happened: the gap goal is met at the phase's end.
    let g = &s.goals[0];
    assert!(g.met && (g.got - 5.0).abs() <= 1.0, "{g:?}");
    assert!(
        !s.notes
            .iter()
            .any(|n| n.starts_with("scenario not realised")),
        "{:?}",
        s.notes
    );
    assert!(s.pass, "{:?}", s.failures);
    // … and the reference cruise met it as ISO 15622 allows.
    let ego = s.ego.as_ref().unwrap();
    assert!(ego.max_decel <= 3.5 && ego.max_jerk <= 2.5, "{ego:?}");
    // Under the planned ego the driver meets its gap too.
    let p = go("cut_in", 1, SutChoice::Planned, false);
    assert!(p.summary.goals[0].met, "{:?}", p.summary.goals);
    assert!(p.summary.pass, "{:?}", p.summary.failures);
}

/// The cut-in of cut_in.osc with a third phase: sut.car is asked to slow
/// to 40 km/h, the cutting car to keep 60 km/h.
const CUT_IN_THEN_SLOW: &str = r#"import "../../osc/domain/config.osc"
extend test_config:
    set map = "../maps/straight.xodr"
extend top.main:
    do c: sut.cut_in_then_slow()
scenario sut.cut_in_then_slow:
    r: two_way_road
    other: vehicle
    do serial():
        a: parallel(overlap: equal):
            sut.car.drive() with:
                speed(60kph)
                along(r, at: start)
                lane(1, at: start)
            other.drive() with:
                speed(75kph)
                lane(left_of: sut.car, at: start)
                position(15m, behind: sut.car, at: start)
        with: duration(6s)
        b: parallel(overlap: equal):
            sut.car.drive() with:
                speed(60kph)
            other.drive() with:
                lane(same_as: sut.car, at: end)
                position(5m, ahead_of: sut.car, at: end)
        with: duration(4s)
        c: parallel(overlap: equal):
            sut.car.drive() with:
                speed(40kph)
            other.drive() with:
                speed(60kph)
        with: duration(4s)
"#;

/// A slower car cuts in close: sut.car at 70 km/h, `other` at 40 km/h in
/// the next lane, 25 m ahead, moves over in front of it. A driver would
/// not (it changes lanes only into a free gap): the cut-in is replayed
/// (`--npc planned`).
const SLOW_CUT_IN: &str = r#"import "../../osc/domain/config.osc"
extend test_config:
    set map = "../maps/straight.xodr"
extend top.main:
    do c: sut.slow_cut_in()
scenario sut.slow_cut_in:
    r: two_way_road
    other: vehicle
    do serial():
        a: parallel(overlap: equal):
            sut.car.drive() with:
                speed(70kph)
                along(r, at: start)
                lane(1, at: start)
            other.drive() with:
                speed(40kph)
                lane(left_of: sut.car, at: start)
                position(25m, ahead_of: sut.car, at: start)
        with: duration(1s)
        b: parallel(overlap: equal):
            sut.car.drive() with:
                speed(70kph)
            other.drive() with:
                speed(40kph)
                lane(same_as: sut.car, at: end)
        with: duration(2s)
        c: parallel(overlap: equal):
            sut.car.drive() with:
                speed(70kph)
            other.drive() with:
                speed(40kph)
        with: duration(4s)
"#;

#[test]
fn after_the_cut_in_the_cutting_car_does_not_follow_the_egos_braking() {
    let f = example_file(CUT_IN_THEN_SLOW);
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let opts = RunOptions {
        seed: Some(1),
        record: true,
        sut: SutChoice::Acc,
        ..RunOptions::default()
    };
    let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    let log = r.log.as_ref().unwrap();
    let other = r
        .summary
        .actors
        .iter()
        .map(|a| a.id.as_str())
        .find(|id| *id != "sut.car")
        .unwrap()
        .to_string();
    let (e, o) = (log.track("sut.car").unwrap(), log.track(&other).unwrap());
    let k10 = log.time.iter().position(|&t| t >= 10.0).unwrap();
    let last = log.time.len() - 1;
    // sut.car slows to its 40 km/h after 10 s …
    assert!(
        e.state.speed[last] < 40.0 / 3.6 + 0.6,
        "{}",
        e.state.speed[last]
    );
    // … the car ahead of it does not brake with it: it goes back to its
    // 60 km/h (never slowing by more than rounding) and pulls away.
    let v = &o.state.speed[k10..];
    assert!(
        v.windows(2).all(|w| w[1] >= w[0] - 1e-3),
        "{other} braked after the cut-in"
    );
    assert!(
        v[v.len() - 1] > 60.0 / 3.6 - 0.3,
        "{other} ends at {}",
        v[v.len() - 1]
    );
    assert!(r.summary.pass, "{:?}", r.summary.failures);
}

/// A SUT that cruises, then brakes hard from 7 s: before the cut-in ends.
struct BrakesEarly(litesim_scenario::sut::acc::Acc);

impl litesim_scenario::sut::Sut for BrakesEarly {
    fn name(&self) -> String {
        "brakes-early".into()
    }
    fn reset(
        &mut self,
        info: &litesim_scenario::sut::SutInfo,
    ) -> Result<(), litesim_scenario::sut::SutError> {
        self.0.reset(info)
    }
    fn step(
        &mut self,
        obs: &litesim_scenario::sut::Observation,
    ) -> Result<litesim_scenario::sut::SutCommand, litesim_scenario::sut::SutError> {
        let c = self.0.step(obs)?;
        Ok(match c {
            litesim_scenario::sut::SutCommand::Accel { curvature, .. } if obs.time >= 7.0 => {
                litesim_scenario::sut::SutCommand::Accel {
                    acceleration: -6.0,
                    curvature,
                    reverse: false,
                }
            }
            c => c,
        })
    }
}

struct BrakesEarlyFactory;

impl litesim_scenario::sut::SutFactory for BrakesEarlyFactory {
    fn name(&self) -> String {
        "brakes-early".into()
    }
    fn create(
        &self,
    ) -> Result<Box<dyn litesim_scenario::sut::Sut>, litesim_scenario::sut::SutError> {
        Ok(Box::new(BrakesEarly(Default::default())))
    }
}

#[test]
fn a_gap_goal_missed_because_the_sut_braked_is_the_scenario_not_realised() {
    let sut = SutChoice::External(std::sync::Arc::new(BrakesEarlyFactory));
    let r = go("cut_in", 1, sut, false);
    let s = &r.summary;
    assert!(s.pairs.iter().all(|p| p.collision_at.is_none()));
    assert!(!s.goals[0].met, "{:?}", s.goals);
    // Not the SUT's failure: the scenario did not happen, and the verdict
    // names the intent and why.
    assert_eq!(s.verdict, litesim_scenario::Verdict::Invalid);
    assert!(!s.pass && s.failures.is_empty(), "{:?}", s.failures);
    let why = &s.invalid[0];
    assert!(
        why.starts_with("scenario not realised: ")
            && why.contains("other ended")
            && why.contains("wanted 5 m ± 1 m")
            && why.contains("sut.car braked at up to 6.0 m/s² from 7.0")
            && why.contains("other needed")
            && why.contains("its limit is"),
        "{why}"
    );
    assert_eq!(litesim_scenario::Verdict::Invalid.exit_code(), 3);
}

/// sut.car at 30 km/h; `other` 20 m behind it in its lane at 60 km/h,
/// replayed (`--npc planned`): it runs into sut.car's rear.
const REAR_ENDED: &str = r#"import "../../osc/domain/config.osc"
extend test_config:
    set map = "../maps/straight.xodr"
extend top.main:
    do c: sut.rear_ended()
scenario sut.rear_ended:
    r: two_way_road
    other: vehicle
    do parallel(overlap: equal):
        sut.car.drive() with:
            speed(30kph)
            along(r, at: start)
            lane(1, at: start)
        other.drive() with:
            speed(60kph)
            lane(same_as: sut.car, at: start)
            position(20m, behind: sut.car, at: start)
    with: duration(5s)
"#;

#[test]
fn sut_car_rear_ended_while_keeping_its_lane_is_not_its_failure() {
    let f = example_file(REAR_ENDED);
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let opts = RunOptions {
        seed: Some(1),
        npc: Npc::Planned,
        ..RunOptions::default()
    };
    let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    let s = &r.summary;
    let p = s.pairs.iter().find(|p| p.collision_at.is_some()).unwrap();
    let c = p.contact.as_ref().unwrap();
    assert_eq!(c.kind, litesim_scenario::kpi::ContactKind::RearEnd);
    assert_eq!(
        (c.striker.as_str(), c.responsible.as_deref()),
        ("other", Some("other"))
    );
    assert_eq!(
        s.verdict,
        litesim_scenario::Verdict::Pass,
        "{:?}",
        s.failures
    );
    assert!(
        s.notes
            .iter()
            .any(|n| n.starts_with("collision between sut.car and other at")
                && n.contains(
                    "other's front struck sut.car's rear (rear-end); other is responsible"
                )
                && n.ends_with("(not sut.car's failure)")),
        "{:?}",
        s.notes
    );
    // The same contact with sut.car driving into a slower car ahead is
    // sut.car's failure, said the same way.
    let f = example_file(
        &REAR_ENDED
            .replace("position(20m, behind:", "position(20m, ahead_of:")
            .replace("speed(60kph)", "speed(10kph)"),
    );
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    let s = &r.summary;
    assert_eq!(s.verdict, litesim_scenario::Verdict::Fail);
    assert!(
        s.failures.iter().any(|f| f
            .contains("sut.car's front struck other's rear (rear-end); sut.car is responsible")),
        "{:?}",
        s.failures
    );
}

#[test]
fn post_encroachment_time_is_measured_at_the_junctions_conflict_areas() {
    let f = example_file(
        "import \"junction_traffic.osc\"\nextend test_config:\n    set min_pet = 9s\n",
    );
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let opts = RunOptions {
        seed: Some(1),
        sut: SutChoice::Acc,
        ..RunOptions::default()
    };
    let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    let pets = &r.summary.ego.as_ref().unwrap().pets;
    assert!(!pets.is_empty(), "no actor crossed sut.car's path");
    let p = pets.iter().min_by(|a, b| a.pet.total_cmp(&b.pet)).unwrap();
    assert!(p.pet >= 0.0 && p.pet < 9.0, "{p:?}");
    let want = format!(
        "post-encroachment time of sut.car and {} at junction {} is {:.2} s",
        p.id, p.junction, p.pet
    );
    assert!(
        r.summary
            .failures
            .iter()
            .any(|f| f.starts_with(&want) && f.ends_with("below the test's min_pet 9 s")),
        "{:?}",
        r.summary.failures
    );
}

#[test]
fn the_reference_cruise_fails_a_slow_close_cut_in_and_its_aeb_avoids_it() {
    let f = example_file(SLOW_CUT_IN);
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let go = |sut| {
        let opts = RunOptions {
            seed: Some(1),
            sut,
            npc: Npc::Planned,
            ..RunOptions::default()
        };
        run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap()
    };
    // The cruise's 3.5 m/s² is not enough: a collision, its failure.
    let acc = go(SutChoice::Acc);
    assert!(!acc.summary.pass, "{:?}", acc.summary.notes);
    assert!(
        acc.summary
            .failures
            .iter()
            .any(|f| f.starts_with("collision between sut.car and other")),
        "{:?}",
        acc.summary.failures
    );
    let aeb = go(SutChoice::AccAeb);
    assert!(
        aeb.summary.pairs.iter().all(|p| p.collision_at.is_none()),
        "{:?}",
        aeb.summary.failures
    );
    assert!(
        aeb.summary
            .notes
            .iter()
            .any(|n| n.starts_with("acc-aeb: emergency braking decided at t=")),
        "{:?}",
        aeb.summary.notes
    );
}

#[test]
fn the_same_seed_gives_the_same_bytes_at_any_thread_count() {
    let prep = example("highway_traffic");
    let one = |seed: u64| {
        let opts = RunOptions {
            seed: Some(seed),
            record: true,
            sut: SutChoice::Acc,
            ..RunOptions::default()
        };
        let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
        (
            serde_json::to_string(&r.summary).unwrap(),
            serde_json::to_string(r.log.as_ref().unwrap()).unwrap(),
        )
    };
    let serial: Vec<_> = (1..=6).map(one).collect();
    let parallel: Vec<_> = (1..=6u64).into_par_iter().map(one).collect();
    assert_eq!(serial, parallel);
    assert!(serial[0].1.contains("\"traffic.0\""));
}

#[test]
fn planned_npcs_are_the_player_and_drivers_are_named_in_the_summary() {
    let opts = |npc| RunOptions {
        seed: Some(1),
        npc,
        ..RunOptions::default()
    };
    let prep = example("follow");
    let d = run(
        &prep,
        &mut litesim_scenario::in_process(),
        &opts(Npc::Driver),
    )
    .unwrap();
    let p = run(
        &prep,
        &mut litesim_scenario::in_process(),
        &opts(Npc::Planned),
    )
    .unwrap();
    let json = |r: &RunResult| serde_json::to_string(&r.summary).unwrap();
    assert!(json(&d).contains("\"npc\":\"driver\""));
    assert!(
        !json(&p).contains("\"npc\""),
        "a planned summary is as before drivers"
    );
    assert!(d.summary.pass && p.summary.pass);
}

fn elaboration_error(config: &str) -> String {
    let text = format!(
        "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/highway.xodr\"\n{config}\nextend top.main:\n    do sut.car.drive() with:\n        speed(20kph)\n        duration(2s)\n"
    );
    let f = example_file(&text);
    let prep = prepare(f.path(), &LoadOptions::default());
    let e = match prep {
        Err(e) => e,
        Ok(p) => run(
            &p,
            &mut litesim_scenario::in_process(),
            &RunOptions::default(),
        )
        .expect_err("the run must be refused"),
    };
    let name = f.path().file_name().unwrap().to_string_lossy().to_string();
    let text = e.to_string();
    assert!(text.contains(&name), "no file named in: {text}");
    text
}

#[test]
fn bad_traffic_settings_are_errors_at_their_place() {
    let cases: [(&str, &str); 6] = [
        ("    set traffic_density = -1", "traffic_density = -1"),
        ("    set traffic_density = 1000", "out of range"),
        (
            "    set traffic_density = 10\n    set traffic_radius = 0m",
            "radius above 0 m",
        ),
        (
            "    set traffic_density = 10\n    set traffic_min_speed = 120kph\n    set traffic_max_speed = 60kph",
            "above traffic_max_speed",
        ),
        (
            "    set traffic_density = 10\n    set traffic_time_gap = 0.01s",
            "driver parameter time_gap = 0.01",
        ),
        (
            "    set traffic_density = 10\n    set traffic_politeness = 9",
            "politeness = 9",
        ),
    ];
    for (config, want) in cases {
        let e = elaboration_error(config);
        assert!(e.contains(want), "{config}: {e}");
        assert!(
            e.contains(":4:"),
            "{config}: the line of traffic_density: {e}"
        );
    }
}

#[test]
fn traffic_on_a_map_without_driving_lanes_is_an_error() {
    // A road of bidirectional lanes: sut.car can be placed on it, but no
    // one-way lane is there for drivers.
    let xodr = litesim_map::synth::highway(&litesim_map::synth::HighwaySpec {
        length: 300.0,
        lanes: 2,
        lane_width: 3.5,
        drop_at: None,
    })
    .replace("type=\"driving\"", "type=\"bidirectional\"");
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/maps");
    let map = tempfile::Builder::new()
        .suffix(".xodr")
        .tempfile_in(&dir)
        .unwrap();
    std::fs::write(map.path(), xodr).unwrap();
    let name = map
        .path()
        .file_name()
        .unwrap()
        .to_string_lossy()
        .to_string();
    let text = format!(
        "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/{name}\"\n    set traffic_density = 10\nextend top.main:\n    do sut.car.drive() with:\n        speed(20kph)\n        duration(2s)\n"
    );
    let f = example_file(&text);
    let prep = prepare(f.path(), &LoadOptions::default());
    let e = match prep {
        Err(e) => e.to_string(),
        Ok(p) => run(
            &p,
            &mut litesim_scenario::in_process(),
            &RunOptions::default(),
        )
        .expect_err("refused")
        .to_string(),
    };
    assert!(e.contains("driving") && e.contains(":4:"), "{e}");
}

#[test]
fn lane_n_beside_a_position_relative_to_another_actor_is_honoured_and_clashes_are_errors() {
    let test = |lanes: &str| {
        format!(
            "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/highway.xodr\"\nextend top.main:\n    do sut.two()\nscenario sut.two:\n    r: one_way_road\n    v1: vehicle\n    do parallel(overlap: equal):\n        sut.car.drive() with:\n            speed(80kph)\n            along(r, start_offset: 500m, at: start)\n            lane(1, at: start)\n        v1.drive() with:\n            speed(80kph)\n{lanes}            position(8m, ahead_of: sut.car, at: start)\n    with: duration(3s)\n"
        )
    };
    let f = example_file(&test("            lane(2, at: start)\n"));
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let r = run(
        &prep,
        &mut litesim_scenario::in_process(),
        &RunOptions::default(),
    )
    .unwrap();
    let start = |id: &str| {
        let a = r.plan.actors.iter().find(|a| a.id == id).unwrap();
        (a.samples[0].x, a.samples[0].y)
    };
    let ((ex, ey), (vx, vy)) = (start("sut.car"), start("v1"));
    // Lane 2 is one lane (3.5 m) left of sut.car's lane 1, 8 m ahead
    // bumper to bumper along it.
    assert!(
        (vy - ey - 3.5).abs() < 1e-6,
        "v1 at y {vy}, sut.car at {ey}"
    );
    assert!(
        (vx - ex - 8.0 - 4.6).abs() < 0.5,
        "v1 at x {vx}, sut.car at {ex}"
    );
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    // Two lanes asked at once: an error naming both.
    let f = example_file(&test(
        "            lane(2, at: start)\n            lane(3, at: start)\n",
    ));
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let e = run(
        &prep,
        &mut litesim_scenario::in_process(),
        &RunOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains(":16:13: lane(…) and ") && e.contains(":17:13: lane(…)"),
        "{e}"
    );
    // A lane the road does not have beside sut.car: an error.
    let f = example_file(&test("            lane(5, at: start)\n"));
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let e = run(
        &prep,
        &mut litesim_scenario::in_process(),
        &RunOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("lane 5 asked for v1 beside sut.car"), "{e}");
}

/// A person that steps off the kerb into the side of a parked car.
const INTO_A_PARKED_CAR: &str = "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/straight.xodr\"\nextend top.main:\n    do sut.blocked()\nscenario sut.blocked:\n    r: two_way_road\n    parked: vehicle\n    ped: person\n    do parallel(overlap: equal):\n        sut.car.drive() with:\n            speed(0kph)\n            along(r, at: start)\n            lane(1, at: start)\n        parked.drive() with:\n            speed(0kph)\n            lane(same_as: sut.car, at: start)\n            position(20m, ahead_of: sut.car, at: start)\n        ped.walk() with:\n            position(20m, ahead_of: sut.car, at: start)\n            lateral(3m, side_of: sut.car, side: right, measure_by: center_to_center, at: start)\n            speed(5kph)\n    with: duration(8s)\n";

#[test]
fn a_person_stops_rather_than_walk_into_a_vehicle_in_its_way() {
    let f = example_file(INTO_A_PARKED_CAR);
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let opts = |npc| RunOptions {
        seed: Some(1),
        npc,
        ..RunOptions::default()
    };
    let planned = run(
        &prep,
        &mut litesim_scenario::in_process(),
        &opts(Npc::Planned),
    )
    .unwrap();
    assert!(
        planned
            .summary
            .failures
            .iter()
            .any(|f| f.contains("collision between parked and ped")),
        "the planned person walks into the car: {:?}",
        planned.summary.failures
    );
    let driver = run(
        &prep,
        &mut litesim_scenario::in_process(),
        &opts(Npc::Driver),
    )
    .unwrap();
    assert!(driver.summary.pass, "{:?}", driver.summary.failures);
}

#[test]
fn drivers_and_traffic_give_the_same_bytes_in_process_and_over_grpc() {
    let server = litesim_grpc::LoopbackServer::start(Default::default(), 1).unwrap();
    for name in ["highway_traffic", "cut_in", "junction_traffic"] {
        let prep = example(name);
        let opts = RunOptions {
            seed: Some(4),
            record: true,
            sut: SutChoice::Acc,
            ..RunOptions::default()
        };
        let local = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
        let mut remote = litesim_grpc::RemoteSsp::connect(&server.addr.to_string()).unwrap();
        let over = run(&prep, &mut remote, &opts).unwrap();
        drop(remote);
        let bytes = |r: &RunResult| {
            (
                serde_json::to_string(&r.summary).unwrap(),
                serde_json::to_string(r.log.as_ref().unwrap()).unwrap(),
            )
        };
        assert!(
            bytes(&local) == bytes(&over),
            "{name}: in-process and gRPC differ"
        );
    }
    server.stop().unwrap();
}

/// `other`, 30 m ahead of sut.car in its lane, changes one lane left over a
/// phase of `PHASE` seconds.
fn lane_change_over(phase: f64) -> String {
    format!(
        "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/straight.xodr\"\nextend top.main:\n    do sut.lc()\nscenario sut.lc:\n    r: two_way_road\n    other: vehicle\n    do serial():\n        parallel(overlap: equal):\n            sut.car.drive() with:\n                speed(50kph)\n                along(r, at: start)\n                lane(1, at: start)\n            other.drive() with:\n                speed(50kph)\n                lane(same_as: sut.car, at: start)\n                position(30m, ahead_of: sut.car, at: start)\n        with: duration(2s)\n        parallel(overlap: equal):\n            sut.car.drive() with:\n                speed(50kph)\n            other.drive() with:\n                change_lane(1, side: left)\n        with: duration({phase}s)\n        parallel(overlap: equal):\n            sut.car.drive() with:\n                speed(50kph)\n            other.drive() with:\n                speed(50kph)\n        with: duration(3s)\n"
    )
}

#[test]
fn a_driver_changes_lanes_over_the_duration_the_scenario_gives() {
    for phase in [2.5, 5.5] {
        let f = example_file(&lane_change_over(phase));
        let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
        let opts = RunOptions {
            seed: Some(1),
            record: true,
            ..RunOptions::default()
        };
        let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
        assert!(r.summary.pass, "{phase}: {:?}", r.summary.failures);
        let log = r.log.as_ref().unwrap();
        let t = log.track("other").unwrap();
        let moving: Vec<f64> = t
            .state
            .y
            .windows(2)
            .zip(&t.tick)
            .filter(|(w, _)| (w[1] - w[0]).abs() > 1e-6)
            .map(|(_, k)| *k as f64 * log.dt)
            .collect();
        let took = moving.last().unwrap() - moving.first().unwrap();
        assert!(
            (took - phase).abs() < 0.2,
            "phase {phase} s: the change took {took:.2} s"
        );
    }
}

/// `other` at 100 km/h for 60 s on a 300-odd-metre road.
const TO_THE_EDGE: &str = r#"import "../../osc/domain/config.osc"
extend test_config:
    set map = "../maps/straight.xodr"
extend top.main:
    do sut.edge()
scenario sut.edge:
    r: two_way_road
    other: vehicle
    do parallel(overlap: equal):
        sut.car.drive() with:
            speed(10kph)
            along(r, at: start)
            lane(1, at: start)
        other.drive() with:
            speed(100kph)
            lane(left_of: sut.car, at: start)
            position(20m, ahead_of: sut.car, at: start)
    with: duration(60s)
"#;

#[test]
fn a_driver_that_reaches_the_end_of_its_lane_stops_there_with_a_note() {
    let f = example_file(TO_THE_EDGE);
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let opts = RunOptions {
        seed: Some(1),
        record: true,
        ..RunOptions::default()
    };
    let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
    let s = &r.summary;
    assert!(
        s.notes
            .iter()
            .any(|n| n.starts_with("other reaches the end of road 1 lane -2")
                && n.ends_with("no lane continues, it stops there")),
        "{:?}",
        s.notes
    );
    // It never leaves the road, and it stands at the end.
    assert_eq!(
        s.verdict,
        litesim_scenario::Verdict::Pass,
        "{:?}",
        s.failures
    );
    let o = r.log.as_ref().unwrap().track("other").unwrap();
    assert!(o.state.speed.last().unwrap().abs() < 0.05);
}

/// `other` placed a seeded distance ahead of sut.car, up to far beyond
/// the end of the 500 m road.
const PLACED_BEYOND: &str = r#"import "../../osc/domain/config.osc"
extend test_config:
    set map = "../maps/straight.xodr"
extend top.main:
    do sut.far()
scenario sut.far:
    r: two_way_road
    other: vehicle
    d: length with:
        keep(it in [10m..700m])
    do parallel(overlap: equal, duration: 3s):
        sut.car.drive() with:
            speed(60kph)
            along(r, start_offset: 100m, at: start)
            lane(1, at: start)
        other.drive() with:
            speed(60kph)
            lane(same_as: sut.car, at: start)
            position(d, ahead_of: sut.car, at: start)
"#;

#[test]
fn an_actor_that_cannot_be_placed_with_its_seed_is_an_invalid_run() {
    let f = example_file(PLACED_BEYOND);
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let (mut invalid, mut passed) = (0, 0);
    for seed in 1..=40 {
        let opts = RunOptions {
            seed: Some(seed),
            ..RunOptions::default()
        };
        let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
        let s = &r.summary;
        // sut.car's front is at 102.3 m of 500 m: 395.4 m of lane ahead
        // for other's rear, the centre-to-centre room minus the lengths.
        let d = r.plan.actors[1].samples[0].x - r.plan.actors[0].samples[0].x - 4.6;
        match s.verdict {
            litesim_scenario::Verdict::Invalid => {
                invalid += 1;
                assert_eq!(s.steps, 0, "not executed");
                assert_eq!(s.invalid.len(), 1, "{:?}", s.invalid);
                let why = &s.invalid[0];
                assert!(
                    why.contains(":19:13: other could not be placed")
                        && why.contains(
                            "ahead of sut.car: sut.car's lane (road 1 lane -3) ends 395.4 m"
                        )
                        && why.ends_with(" short"),
                    "{why}"
                );
                assert_eq!(s.verdict.exit_code(), 3);
            }
            litesim_scenario::Verdict::Pass => {
                passed += 1;
                assert!(s.steps > 0 && s.invalid.is_empty());
                assert!(d < 395.5, "placed {d} m ahead, beyond the lane");
            }
            v => panic!("seed {seed}: {v:?} {:?}", s.failures),
        }
    }
    assert!(
        invalid > 10 && passed > 5,
        "{invalid} invalid, {passed} passed"
    );
}

#[test]
fn a_batch_counts_unplaced_seeds_as_invalid_with_their_reason() {
    let f = example_file(PLACED_BEYOND);
    let dir = tempfile::tempdir().unwrap();
    let spec = litesim_scenario::batch::BatchSpec {
        tests: vec![f.path().to_path_buf()],
        seed_from: 1,
        seed_to: 30,
        shard: (0, 1),
        threads: Some(2),
        out: dir.path().to_path_buf(),
        resume: false,
        force_new: false,
        mode: None,
        load: LoadOptions::default(),
        calibration_dir: None,
        sut: Default::default(),
        npc: Npc::Driver,
        sut_timeout: None,
        step_ms: None,
        save_failed: false,
        save_failed_mcap: false,
        precomputed: Default::default(),
    };
    let report = litesim_scenario::batch::run_batch(&spec, &|_, _| {}).unwrap();
    assert!(report.invalid > 5 && report.invalid < 30, "{report:?}");
    assert_eq!(
        (report.errors, report.passed + report.invalid),
        (0, 30),
        "{report:?}"
    );
    assert_eq!(report.verdict, litesim_scenario::Verdict::Invalid);
    let lines = std::fs::read_to_string(dir.path().join("results.jsonl")).unwrap();
    let invalid: Vec<&str> = lines
        .lines()
        .filter(|l| l.contains(r#""verdict":"invalid""#))
        .collect();
    assert_eq!(invalid.len() as u64, report.invalid);
    assert!(
        invalid.iter().all(|l| l.contains("could not be placed")),
        "{invalid:?}"
    );
}
