//! A test of many actors: its run is stepped in several chunks and the
//! motions of its independent actors are planned on all cores. These tests
//! hold it to the same bytes as the one-thread planner before that change
//! (a golden digest blessed with it), at every thread count, inside a busy
//! pool and over gRPC.

use litesim_scenario::{Prepared, RunOptions, RunResult, prepare, run};

mod common;
use common::{example_file, traffic};

fn prepared() -> (tempfile::NamedTempFile, Prepared) {
    let f = example_file(&traffic(40, Some(4)));
    let p = prepare(f.path(), &Default::default()).unwrap();
    (f, p)
}

fn opts() -> RunOptions {
    RunOptions {
        npc: litesim_scenario::Npc::Planned,
        seed: Some(1),
        record: true,
        ..RunOptions::default()
    }
}

/// The summary (JSON) and the FNV-1a of the log's JSON text.
fn digest(r: &RunResult) -> (String, usize, u64) {
    let log = serde_json::to_vec(r.log.as_ref().unwrap()).unwrap();
    (
        serde_json::to_string(&r.summary).unwrap(),
        log.len(),
        litesim_ssp::testkit::fnv1a(&log),
    )
}

fn in_pool(threads: usize, prep: &Prepared) -> (String, usize, u64) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| digest(&run(prep, &mut litesim_scenario::in_process(), &opts()).unwrap()))
}

/// Log size and digest of the 40-vehicle run, from the planner that
/// planned one actor's motion after the other.
const GOLDEN: (usize, u64) = (3_054_868, 0x2f58_7569_96ad_2592);

#[test]
fn many_actors_give_the_same_bytes_at_every_thread_count() {
    let (_f, prep) = prepared();
    let here = digest(&run(&prep, &mut litesim_scenario::in_process(), &opts()).unwrap());
    // 40 actors × 500 steps: four chunks of 125 steps; 39 independent
    // motions, planned in parallel (from 16 on).
    assert!(here.0.contains("\"steps\":500"), "{}", here.0);
    assert!(
        !here.0.contains("\"pass\":true"),
        "the checks found nothing"
    );
    assert_eq!(
        (here.1, here.2),
        GOLDEN,
        "log size {} / digest {:#018x} changed",
        here.1,
        here.2
    );
    // One thread, two, four.
    for threads in [1, 2, 4] {
        assert_eq!(in_pool(threads, &prep), here, "{threads} threads");
    }
    // Inside a busy pool, as in a batch: every worker runs a test.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let all: Vec<_> = pool.install(|| {
        use rayon::prelude::*;
        (0..4)
            .into_par_iter()
            .map(|_| digest(&run(&prep, &mut litesim_scenario::in_process(), &opts()).unwrap()))
            .collect()
    });
    assert!(all.iter().all(|d| *d == here));
}

#[test]
fn over_grpc_the_run_of_many_actors_is_the_same() {
    let (_f, prep) = prepared();
    let here = digest(&run(&prep, &mut litesim_scenario::in_process(), &opts()).unwrap());
    let server = litesim_grpc::LoopbackServer::start(Default::default(), 1).unwrap();
    let mut remote = litesim_grpc::RemoteSsp::connect(&server.addr.to_string()).unwrap();
    let over = digest(&run(&prep, &mut remote, &opts()).unwrap());
    drop(remote);
    server.stop().unwrap();
    assert_eq!(over, here);
}

/// Many actors on a map whose lights switch mid-run (chunks end at each
/// switch, off the regular grid): the next chunk's trajectories, made while
/// a chunk is read back, are for the chunk the loop then steps (a debug
/// build asserts it), and the run is the same at every thread count.
#[test]
fn chunks_cut_by_light_switches_are_foreseen() {
    let text = traffic(20, None)
        .replace("../maps/straight.xodr", "../maps/junction.xodr")
        .replace(
            "    r: two_way_road\n",
            "    r: two_way_road\n    east_west: traffic_light with:\n        keep(it.light_id == \"c1\")\n",
        )
        .replace(
            "    do parallel(overlap: equal):\n",
            "    do parallel(overlap: equal):\n        serial():\n            wait elapsed(3.3s)\n            east_west.switch(red)\n            wait elapsed(2.8s)\n            east_west.switch(green)\n",
        );
    let f = example_file(&text);
    let prep = prepare(f.path(), &Default::default()).unwrap();
    let r = run(&prep, &mut litesim_scenario::in_process(), &opts()).unwrap();
    assert_eq!(r.plan.lights.len(), 2, "{:?}", r.plan.lights);
    assert_eq!(r.summary.steps, 500);
    let here = digest(&r);
    for threads in [1, 2] {
        assert_eq!(in_pool(threads, &prep), here, "{threads} threads");
    }
}

/// Where a run goes on: a test of many actors called from outside rayon's
/// pool runs on one of its threads (its parallel parts share their work
/// with it); a small one, or one driven by a system under test, on the
/// caller's thread. The observer sees each tick on the thread that runs.
#[test]
fn many_actors_run_on_a_pool_thread_and_the_rest_where_called() {
    use std::sync::{Arc, Mutex};
    let on = |text: String, sut: litesim_scenario::sut::SutChoice| {
        let threads: Arc<Mutex<std::collections::BTreeSet<Option<usize>>>> = Arc::default();
        let seen = Arc::clone(&threads);
        let opts = RunOptions {
            npc: litesim_scenario::Npc::Planned,
            sut,
            record: true,
            observer: Some(litesim_scenario::TickObserver(Arc::new(Mutex::new(
                move |_: &litesim_log::SimulationLog| {
                    seen.lock().unwrap().insert(rayon::current_thread_index());
                },
            )))),
            ..opts()
        };
        let f = example_file(&text);
        let prep = prepare(f.path(), &Default::default()).unwrap();
        run(&prep, &mut litesim_scenario::in_process(), &opts).unwrap();
        let t = threads.lock().unwrap().clone();
        assert_eq!(t.len(), 1, "{t:?}");
        t.into_iter().next().unwrap()
    };
    let planned = litesim_scenario::sut::SutChoice::Planned;
    assert!(on(traffic(20, None), planned.clone()).is_some());
    assert_eq!(on(traffic(4, None), planned), None);
    assert_eq!(
        on(traffic(20, None), litesim_scenario::sut::SutChoice::Acc),
        None
    );
}
