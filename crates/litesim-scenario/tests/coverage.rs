//! `cover`/`record` sampled where the test says, on the simulated state.

mod common;
use common::example_file;
use litesim_scenario::coverage::SampleValue;
use litesim_scenario::{LoadOptions, RunOptions, in_process, prepare, run};

const TWO: &str = "import \"../../osc/domain/config.osc\"
extend test_config:
    set map = \"../maps/straight.xodr\"
extend top.main:
    do serial():
        f: sut.first()
        s: sut.second()
scenario sut.first:
    r: two_way_road
    other: vehicle
    cover(v_first, expression: sut.car.speed, unit: kph, range: [0..100], every: 10)
    cover(v_start, expression: sut.car.speed, unit: mps, event: start)
    record(gap, expression: sut.car.gap_to(other), unit: m)
    record(lane, expression: sut.car.lane)
    do parallel(overlap: equal):
        sut.car.drive() with:
            speed(30kph)
            along(r, at: start)
            lane(1, at: start)
        other.drive() with:
            speed(30kph)
            lane(same_as: sut.car, at: start)
            position(20m, ahead_of: sut.car, at: start)
    with: duration(3s)
scenario sut.second:
    do sut.car.drive() with:
        speed(60kph)
        duration(4s)
extend sut.second:
    cover(v_second, expression: sut.car.speed, unit: kph, range: [0..100], every: 10)
";

#[test]
fn items_are_sampled_at_their_scenarios_end_their_event_and_in_extends() {
    let f = example_file(TWO);
    let prep = prepare(f.path(), &LoadOptions::default()).unwrap();
    let r = run(&prep, &mut in_process(), &RunOptions::default()).unwrap();
    assert!(r.summary.pass, "{:?}", r.summary.failures);
    let get = |n: &str| {
        r.summary
            .coverage
            .iter()
            .find(|s| s.item == n)
            .unwrap_or_else(|| panic!("no sample of {n}: {:?}", r.summary.coverage))
            .clone()
    };
    let num = |n: &str| match get(n).value {
        Some(SampleValue::Num(x)) => x,
        other => panic!("{n}: {other:?}"),
    };
    // The end of the first scenario (3 s), not of the run (7 s).
    assert!((get("f.v_first").t - 3.0).abs() < 1e-9);
    assert!(
        (num("f.v_first") - 30.0).abs() < 2.0,
        "{}",
        num("f.v_first")
    );
    // event: start — the first step, in the item's unit (m/s).
    assert!(get("f.v_start").t < 0.05);
    assert!((num("f.v_start") - 30.0 / 3.6).abs() < 0.5);
    // `position(20m, ahead_of:)` is bumper to bumper: the boxes 20 m apart.
    assert!((num("f.gap") - 20.0).abs() < 0.5, "{}", num("f.gap"));
    // The lane id from the map (right-hand lanes are negative).
    assert!(num("f.lane") < 0.0);
    // Declared in an `extend`: sampled at its scenario's end, the run's end.
    assert!((get("s.v_second").t - 7.0).abs() < 1e-9);
    assert!((num("s.v_second") - 60.0).abs() < 1.0);
}
