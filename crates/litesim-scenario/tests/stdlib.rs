//! The OSC 2.0 standard library's actions and modifiers as litesim runs
//! them (docs/osc-stdlib.md names the test of each element): their planned
//! motion exactly, the drivers that carry them in closed loop, and the
//! errors for what they cannot mean.

use litesim_scenario::{Npc, RunOptions, RunResult, ScenarioError, prepare, run};

mod common;
use common::{example, example_file};

/// Runs a prepared example with its other vehicles replaying their plans
/// (`Npc::Planned`) or driven (`Npc::Driver`), recording the log.
fn go(name: &str, npc: Npc) -> RunResult {
    let opts = RunOptions {
        npc,
        seed: Some(1),
        record: true,
        ..RunOptions::default()
    };
    run(&example(name), &mut litesim_scenario::in_process(), &opts)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The planned speed (m/s) of `id` at every plan sample.
fn planned(r: &RunResult, id: &str) -> Vec<(f64, f64)> {
    let a = r.plan.actors.iter().find(|a| a.id == id).unwrap();
    a.samples.iter().map(|s| (s.t, s.v)).collect()
}

fn kph(v: f64) -> f64 {
    v / 3.6
}

#[test]
fn speed_relative_to_another_actor_follows_its_plan_at_every_sample() {
    let r = go("speed_relative", Npc::Planned);
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    let ego = planned(&r, "sut.car");
    // sut.car speeds up from 50 to 80 km/h in the second phase.
    assert!((ego[0].1 - kph(50.0)).abs() < 1e-9);
    assert!((ego.last().unwrap().1 - kph(80.0)).abs() < 1e-9);
    for (id, offset) in [("pacer", 0.0), ("quick", 10.0), ("slow", -15.0)] {
        let me = planned(&r, id);
        assert_eq!(me.len(), ego.len());
        for ((t, v), (_, ve)) in me.iter().zip(&ego) {
            assert!(
                (v - (ve + kph(offset))).abs() < 1e-6,
                "{id} at t = {t}: {v} m/s, sut.car {ve} m/s"
            );
        }
    }
}

#[test]
fn drivers_carry_relative_speeds_in_closed_loop() {
    let r = go("speed_relative", Npc::Driver);
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    let log = r.log.as_ref().unwrap();
    let speed_at = |id: &str, k: usize| {
        let t = log.tracks.iter().find(|t| t.id == id).unwrap();
        t.state.speed[k.min(t.state.speed.len() - 1)]
    };
    let end = log.tick.len() - 1;
    let ego = speed_at("sut.car", end);
    assert!((ego - kph(80.0)).abs() < 0.05, "sut.car {ego}");
    // A driver follows its speed goal with its own acceleration: within
    // 1 m/s of the relation while sut.car speeds up (at 6 and 10 s), within
    // 0.5 m/s once it holds its speed (at the end).
    for (id, offset) in [("pacer", 0.0), ("quick", 10.0), ("slow", -15.0)] {
        for k in [300, 500] {
            let (v, target) = (speed_at(id, k), speed_at("sut.car", k) + kph(offset));
            assert!(
                (v - target).abs() < 1.0,
                "{id} at tick {k}: {v} m/s, {target} m/s asked"
            );
        }
        let v = speed_at(id, end);
        assert!(
            (v - (ego + kph(offset))).abs() < 0.5,
            "{id}: {v} m/s, sut.car {ego} m/s"
        );
    }
}

const HEADER: &str = "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/straight.xodr\"\n";

#[test]
fn two_speed_references_at_once_are_an_error_at_the_modifier() {
    let f = example_file(&format!(
        "{HEADER}extend top.main:\n    do sut.s()\nscenario sut.s:\n    r: two_way_road\n    a: vehicle\n    do parallel(overlap: equal):\n        sut.car.drive() with:\n            speed(50kph)\n            along(r, at: start)\n        a.drive() with:\n            speed(5kph, faster_than: sut.car, slower_than: sut.car)\n    with: duration(2s)\n"
    ));
    let e = prepare(f.path(), &Default::default()).unwrap_err();
    assert!(matches!(e, ScenarioError::Elaboration(_)), "{e:?}");
    let m = e.to_string();
    assert!(m.contains(":14:13"), "{m}");
    assert!(
        m.contains("faster_than and slower_than exclude each other"),
        "{m}"
    );
}

#[test]
fn a_speed_relative_to_itself_is_a_planning_error() {
    let f = example_file(&format!(
        "{HEADER}extend top.main:\n    do sut.s()\nscenario sut.s:\n    r: two_way_road\n    do sut.car.drive() with:\n        speed(same_as: sut.car)\n        along(r, at: start)\n        duration(2s)\n"
    ));
    let p = prepare(f.path(), &Default::default()).unwrap();
    let e = run(
        &p,
        &mut litesim_scenario::in_process(),
        &RunOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, ScenarioError::Plan(_)), "{e:?}");
    assert!(e.to_string().contains("relative to sut.car"), "{e}");
}
