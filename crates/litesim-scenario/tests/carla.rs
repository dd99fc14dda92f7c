//! CARLA-dialect scenarios run end to end: examples/carla, CARLA's lane
//! numbering (from the left), blueprint sizes and models, the map folder,
//! and `path_over_junction`'s road choice.

use litesim_scenario::{LoadOptions, RunOptions, prepare, run};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn carla(name: &str) -> PathBuf {
    root().join("examples/carla").join(name)
}

fn go(test: &Path, sut: &str) -> litesim_scenario::RunResult {
    let prep = prepare(test, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let opts = RunOptions {
        npc: litesim_scenario::Npc::Planned,
        record: true,
        sut: litesim_scenario::sut::SutChoice::builtin(sut).unwrap(),
        ..RunOptions::default()
    };
    run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_carla_example_runs_and_passes_as_planned_and_under_acc() {
    for name in ["cut_in.osc", "slow_lead.osc", "junction_approach.osc"] {
        for sut in ["planned", "acc"] {
            let r = go(&carla(name), sut);
            assert!(
                r.summary.pass,
                "{name} --sut {sut}: {:?}",
                r.summary.failures
            );
            assert_eq!(r.summary.profile, "carla-0.9.15", "{name}");
        }
    }
}

fn go_seed(test: &Path, sut: &str, seed: u64) -> litesim_scenario::RunResult {
    let prep = prepare(test, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let opts = RunOptions {
        npc: litesim_scenario::Npc::Planned,
        record: true,
        seed: Some(seed),
        sut: litesim_scenario::sut::SutChoice::builtin(sut).unwrap(),
        ..RunOptions::default()
    };
    run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap_or_else(|e| panic!("{e}"))
}

/// examples/carla/runner: scenarios beside a library written as
/// scenario_runner's is (its own units, `dut`, `Path`), read as it is.
#[test]
fn scenarios_with_scenario_runners_own_library_run_and_pass() {
    let dir = root().join("examples/carla/runner");
    let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "osc") && !p.ends_with("basic.osc"))
        .collect();
    names.sort();
    assert!(names.len() >= 6, "{names:?}");
    for test in &names {
        for sut in ["planned", "acc"] {
            for seed in 1..=3 {
                let r = go_seed(test, sut, seed);
                assert!(
                    r.summary.pass,
                    "{} --sut {sut} --seed {seed}: {:?} {:?}",
                    test.display(),
                    r.summary.failures,
                    r.summary.invalid
                );
                assert_eq!(r.summary.profile, "carla-0.9.15");
            }
        }
    }
}

#[test]
fn a_range_of_lane_changes_draws_each_count_with_the_seed() {
    // The ego starts in the rightmost of three lanes and changes one or
    // two lanes to the left: both counts appear over a few seeds, and a
    // seed always draws the same.
    let test = root().join("examples/carla/runner/lane_change_range.osc");
    let end_y = |seed| {
        let r = go_seed(&test, "planned", seed);
        let log = r.log.unwrap();
        let ego = log.tracks.iter().find(|t| t.id == "sut.car").unwrap();
        (ego.state.y[ego.state.y.len() - 1] * 10.0).round() / 10.0
    };
    let ends: std::collections::BTreeSet<i64> = (1..=8).map(|s| (end_y(s) * 10.0) as i64).collect();
    assert_eq!(ends.len(), 2, "{ends:?}");
    assert_eq!(end_y(2), end_y(2));
}

#[test]
fn blueprints_lanes_from_the_left_and_the_cut_in_happen() {
    let r = go(&carla("cut_in.osc"), "planned");
    let log = r.log.unwrap();
    let track = |id: &str| log.tracks.iter().find(|t| t.id == id).unwrap();
    let (ego, npc) = (track("sut.car"), track("npc"));
    assert_eq!(ego.model, "vehicle.tesla.model3");
    assert_eq!((ego.length, ego.width), (4.79, 2.16));
    assert_eq!(npc.model, "vehicle.jeep.wrangler_rubicon");
    assert_eq!(npc.length, 3.87);
    // straight.xodr: three lanes each way, centres at y = −1.75, −5.25,
    // −8.75 for the right-hand side. CARLA's lane 1 is the leftmost.
    assert!((ego.state.y[0] + 1.75).abs() < 0.01, "{}", ego.state.y[0]);
    // The npc starts right of the ego and 15 m (boxes) behind …
    assert!((npc.state.y[0] + 5.25).abs() < 0.01, "{}", npc.state.y[0]);
    assert!(npc.state.x[0] < ego.state.x[0] - 15.0);
    // … and ends in the ego's lane, ahead of it.
    let last = npc.state.y.len() - 1;
    assert!((npc.state.y[last] + 1.75).abs() < 0.05);
    assert!(npc.state.x[last] > ego.state.x[ego.state.x.len() - 1]);
}

#[test]
fn path_over_junction_picks_a_road_that_reaches_the_junction() {
    let prep = prepare(&carla("junction_approach.osc"), &LoadOptions::default()).unwrap();
    let net = prep.net.as_ref().unwrap();
    for seed in 1..=8 {
        let opts = RunOptions {
            npc: litesim_scenario::Npc::Planned,
            seed: Some(seed),
            plan_only: true,
            ..RunOptions::default()
        };
        let r = run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
        let road = &r.summary.roads["top.path"];
        let s = net
            .road_summaries()
            .into_iter()
            .find(|s| &s.id == road)
            .unwrap();
        assert!(
            s.into_junction && s.junction.is_none(),
            "seed {seed}: road {road}"
        );
    }
}

#[test]
fn a_missing_map_names_where_it_looked_and_the_place_that_asked() {
    let empty = tempfile::tempdir().unwrap();
    let e = prepare(
        &carla("cut_in.osc"),
        &LoadOptions {
            map_dir: Some(empty.path().to_path_buf()),
            ..LoadOptions::default()
        },
    )
    .unwrap_err();
    // The typed cause: which name, where litesim looked.
    assert!(matches!(
        &e,
        litesim_scenario::ScenarioError::MapFile {
            source: litesim_scenario::MapFileError::NotFound { .. },
            ..
        }
    ));
    // The whole message is the error and its causes (`chain`).
    let e = e.chain();
    assert!(e.contains("cut_in.osc:11:5"), "{e}");
    assert!(e.contains("no straight.xodr in"), "{e}");
    assert!(e.contains("--map-dir"), "{e}");
    // A name that is a path is refused, not followed.
    assert!(litesim_scenario::carla_map_file(&carla("cut_in.osc"), "../secret", None).is_err());
    assert!(litesim_scenario::carla_map_file(&carla("cut_in.osc"), "", None).is_err());
    // --map-dir finds the map; --map overrides it.
    let dir = root().join("examples/maps");
    let p = prepare(
        &carla("cut_in.osc"),
        &LoadOptions {
            map_dir: Some(dir),
            ..LoadOptions::default()
        },
    )
    .unwrap();
    assert!(p.map_name.ends_with("straight.xodr"), "{}", p.map_name);
}
