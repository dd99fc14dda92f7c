//! Golden digest of the mixed 10-actor, 1,000-step run (all control modes).
//!
//! Size first: a size change means the encoding changed; a digest change with
//! the same size means values changed. Update both only for an intended change.

use litesim_ssp::Session;
use litesim_ssp::testkit::{encode, fnv1a, mixed_scenario};

const GOLDEN_SIZE: usize = 1_211_000;
const GOLDEN_DIGEST: u64 = 0x68ff_e051_f822_7f24;

#[test]
fn golden_digest_of_mixed_run() {
    let run = mixed_scenario(&mut Session::default(), 1000).expect("scenario runs");
    let bytes = encode(&run);
    println!("size {} digest {:#018x}", bytes.len(), fnv1a(&bytes));
    assert_eq!(bytes.len(), GOLDEN_SIZE, "encoding changed");
    assert_eq!(fnv1a(&bytes), GOLDEN_DIGEST, "values changed");
}

#[test]
fn repeated_runs_are_identical() {
    let a = encode(&mixed_scenario(&mut Session::default(), 300).unwrap());
    let b = encode(&mixed_scenario(&mut Session::default(), 300).unwrap());
    assert_eq!(a, b);
}

#[test]
fn runs_on_other_threads_are_identical() {
    let here = encode(&mixed_scenario(&mut Session::default(), 300).unwrap());
    let handles: Vec<_> = (0..4)
        .map(|_| {
            std::thread::spawn(|| encode(&mixed_scenario(&mut Session::default(), 300).unwrap()))
        })
        .collect();
    for h in handles {
        assert_eq!(h.join().unwrap(), here);
    }
}

#[test]
fn mixed_run_behaves() {
    let run = mixed_scenario(&mut Session::default(), 1000).unwrap();
    let last = run.last().unwrap();
    let get = |id: &str| last.iter().find(|s| &*s.actor_id == id).unwrap();
    for s in last {
        println!(
            "{:>8} x={:9.3} y={:8.3} yaw={:6.3} v={:6.3} {:?} {:?}",
            s.actor_id,
            s.pose.position.x,
            s.pose.position.y,
            s.pose.yaw,
            s.speed,
            s.mode,
            s.trajectory
        );
    }
    // Stored actors never move.
    assert_eq!(get("parked").pose.position.x, 50.0);
    assert_eq!(get("cone").pose.position.y, 2.5);
    // Trajectory cars are where their trajectory says at t = 20 s.
    assert!((get("traj0").pose.position.x - 160.0).abs() < 1e-9);
    assert_eq!(
        get("traj2").trajectory,
        litesim_core::TrajectoryStatus::Exhausted
    );
    assert_eq!(
        get("traj1").trajectory,
        litesim_core::TrajectoryStatus::Following
    );
    // The IDM follower never runs into traj0, which it follows.
    for step in &run {
        let f = step.iter().find(|s| &*s.actor_id == "follower").unwrap();
        let l = step.iter().find(|s| &*s.actor_id == "traj0").unwrap();
        assert!(
            l.pose.position.x - f.pose.position.x > 4.6,
            "follower too close"
        );
    }
}

#[test]
fn traffic_lights_come_from_the_map() {
    use litesim_ssp::*;
    let map = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/maps/junction.xodr"
    );
    let mut s = Session::default();
    s.init(InitRequest {
        map: Some(map.into()),
        ..InitRequest::default()
    })
    .unwrap();
    s.start_simulation(0).unwrap();
    s.wait_start_simulation(0).unwrap();
    let tl = s.list_traffic_lights().unwrap();
    assert_eq!(tl.boxes.len(), 4);
    assert_eq!(
        tl.logical
            .iter()
            .map(|l| l.box_ids.len())
            .collect::<Vec<_>>(),
        vec![2, 2]
    );
    assert_eq!(tl.boxes[0].bulbs.len(), 3);
    assert_eq!(tl.boxes[0].valid_lanes, vec![-1]);
    let green = BulbState {
        icon: BulbIcon::None,
        color: BulbColor::Green,
        mode: BulbMode::On,
    };
    let affected = s
        .set_traffic_light_state(LightTarget::Logical("c1".into()), vec![green])
        .unwrap();
    assert_eq!(
        affected.iter().map(|b| b.id.as_str()).collect::<Vec<_>>(),
        vec!["tl1", "tl3"]
    );
    // A broken map is refused at init with the map's own message.
    let mut bad = Session::default();
    let e = bad
        .init(InitRequest {
            map: Some("<OpenDRIVE><road id=\"1\" length=\"-1\"/></OpenDRIVE>".into()),
            ..InitRequest::default()
        })
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArgument);
    assert!(
        e.message.contains("length = -1 must be positive"),
        "{}",
        e.message
    );
}
