//! The traffic engine on its own: dense traffic drives without contact, a
//! lane drop merges by MOBIL, drivers stop on red and go on green, and a
//! run is the same bytes every time.

use litesim_core::rng::Rng;
use litesim_map::RoadNetwork;
use litesim_map::synth::{HighwaySpec, highway};
use litesim_scenario::runtime::driver::DriverParams;
use litesim_scenario::runtime::traffic::spawn::{Density, fill};
use litesim_scenario::runtime::traffic::{LaneGraph, StopLine, Traffic, Vehicle};

fn road(length: f64, lanes: u32, drop_at: Option<f64>) -> (RoadNetwork, LaneGraph) {
    let text = highway(&HighwaySpec {
        length,
        lanes,
        lane_width: 3.5,
        drop_at,
    });
    let net = RoadNetwork::from_xodr(&text, "highway.xodr").unwrap();
    let g = LaneGraph::new(&net);
    (net, g)
}

fn dense(per_km: f64, seed: u64, g: &LaneGraph) -> Traffic {
    let mut t = Traffic::new(0.02);
    let d = Density {
        per_km_per_lane: per_km,
        speed: (60.0 / 3.6, 79.0 / 3.6),
        size: (4.5, 1.8),
    };
    fill(&mut t, g, &d, &mut Rng::new(seed), &[], |_, _| true).unwrap();
    t
}

fn on_road(t: &Traffic, g: &LaneGraph) {
    for (i, v) in t.vehicles.iter().enumerate().filter(|(_, v)| v.active) {
        let l = &g.lanes[v.lane as usize];
        assert!(
            v.u >= 0.0 && v.u <= l.length && v.v >= 0.0 && v.v.is_finite(),
            "vehicle {i} left the road or its speed broke: {v:?}"
        );
    }
}

#[test]
fn a_thousand_vehicles_on_three_lanes_drive_ten_seconds_without_contact() {
    let (_net, g) = road(6000.0, 3, None);
    assert_eq!(g.lanes.len(), 3);
    let mut t = dense(1000.0 / 18.0, 1, &g);
    assert!(
        (990..=1010).contains(&t.vehicles.len()),
        "{}",
        t.vehicles.len()
    );
    for _ in 0..500 {
        t.step(&g, &[]);
    }
    assert!(
        t.contacts.is_empty(),
        "contacts: {:?}",
        &t.contacts[..t.contacts.len().min(5)]
    );
    on_road(&t, &g);
    // They drive: the mean speed is well above a standstill.
    let mean = t.vehicles.iter().map(|v| v.v).sum::<f64>() / t.vehicles.len() as f64;
    assert!(mean > 5.0, "mean speed {mean}");
}

#[test]
fn many_seeds_of_moderate_traffic_never_touch_and_change_lanes() {
    let (_net, g) = road(3000.0, 3, None);
    let mut changes = 0;
    for seed in 1..=40 {
        let mut t = dense(25.0, seed, &g);
        for _ in 0..1500 {
            t.step(&g, &[]);
        }
        assert!(t.contacts.is_empty(), "seed {seed}: {:?}", t.contacts);
        on_road(&t, &g);
        changes += t.vehicles.iter().map(|v| v.lane_changes).sum::<u32>();
    }
    assert!(changes > 50, "MOBIL changed lanes only {changes} times");
}

#[test]
fn a_lane_drop_merges_by_mobil_and_nobody_leaves_the_road() {
    let (_net, g) = road(3000.0, 3, Some(1500.0));
    assert_eq!(g.lanes.len(), 5);
    let outer = g
        .lanes
        .iter()
        .position(|l| l.s0 == 0.0 && l.node.lane == -3)
        .unwrap() as u32;
    for seed in 1..=8 {
        // Only before the drop, at a moderate density.
        let mut t = Traffic::new(0.02);
        let d = Density {
            per_km_per_lane: 18.0,
            speed: (80.0 / 3.6, 110.0 / 3.6),
            size: (4.5, 1.8),
        };
        fill(&mut t, &g, &d, &mut Rng::new(seed), &[], |lane, u| {
            g.lanes[lane as usize].s0 == 0.0 && u < 1000.0
        })
        .unwrap();
        let in_outer = t.vehicles.iter().filter(|v| v.lane == outer).count();
        assert!(in_outer > 5);
        for _ in 0..(150 * 50) {
            t.step(&g, &[]);
        }
        assert!(t.contacts.is_empty(), "seed {seed}: {:?}", t.contacts);
        on_road(&t, &g);
        let stuck: Vec<_> = t.vehicles.iter().filter(|v| v.at_dead_end).collect();
        assert!(
            stuck.is_empty(),
            "seed {seed}: {} stopped at the lane's end: {stuck:?}",
            stuck.len()
        );
        let left: Vec<_> = t.vehicles.iter().filter(|v| v.lane == outer).collect();
        assert!(
            left.is_empty(),
            "seed {seed}: still in the dropped lane: {left:?}"
        );
    }
}

#[test]
fn drivers_stop_on_red_and_go_on_green() {
    let (_net, g) = road(2000.0, 2, None);
    let mut t = dense(20.0, 3, &g);
    // Only vehicles before the line.
    t.vehicles.retain(|v| v.u < 700.0);
    let t0 = t.vehicles.clone();
    let mut t = Traffic::new(0.02);
    for v in t0 {
        t.add(v);
    }
    let line = 800.0;
    t.stop_lines = (0..g.lanes.len() as u32)
        .map(|lane| StopLine {
            lane,
            u: line,
            red: true,
            yellow: false,
        })
        .collect();
    for _ in 0..(60 * 50) {
        t.step(&g, &[]);
        for v in &t.vehicles {
            assert!(
                v.u + 0.5 * v.length <= line + 1e-6,
                "ran the red light: {v:?}"
            );
        }
    }
    // Everyone is queued and standing.
    assert!(t.vehicles.iter().all(|v| v.v < 0.1));
    let first = t.vehicles.iter().map(|v| v.u).fold(0.0, f64::max);
    assert!(first > line - 10.0, "the queue's head stands {first}");
    for s in &mut t.stop_lines {
        s.red = false;
    }
    for _ in 0..(30 * 50) {
        t.step(&g, &[]);
    }
    assert!(
        t.vehicles.iter().any(|v| v.u > line + 100.0),
        "nobody went on green"
    );
    assert!(t.contacts.is_empty());
}

#[test]
fn a_faster_car_overtakes_a_truck_on_the_left_and_returns_right() {
    let (_net, g) = road(4000.0, 2, None);
    let right = g.lanes.iter().position(|l| l.node.lane == -2).unwrap() as u32;
    let mut t = Traffic::new(0.02);
    let vehicle = |u: f64, v: f64, params: DriverParams, length: f64| Vehicle {
        lane: right,
        u,
        v,
        a: 0.0,
        lat: 0.0,
        from: None,
        length,
        width: 2.0,
        params,
        route: 1,
        at_dead_end: false,
        lane_changes: 0,
        active: true,
        goals: Default::default(),
    };
    t.add(vehicle(
        300.0,
        20.0,
        DriverParams::for_category("truck", 20.0),
        12.0,
    ));
    let car = t.add(vehicle(
        200.0,
        30.0,
        DriverParams::for_category("car", 33.0),
        4.5,
    ));
    let mut went_left = false;
    for _ in 0..(60 * 50) {
        t.step(&g, &[]);
        went_left |= t.vehicles[car as usize].lane != right;
    }
    let (c, tr) = (&t.vehicles[car as usize], &t.vehicles[0]);
    assert!(went_left, "the car never left the truck's lane");
    assert!(
        c.u > tr.u + 50.0,
        "the car did not pass: car {} truck {}",
        c.u,
        tr.u
    );
    assert_eq!(c.lane, right, "the car did not keep right again");
    assert!(t.contacts.is_empty());
}

#[test]
fn the_same_seed_gives_the_same_bits() {
    let (_net, g) = road(3000.0, 3, None);
    let run = || {
        let mut t = dense(30.0, 11, &g);
        for _ in 0..1000 {
            t.step(&g, &[]);
        }
        let mut bytes = Vec::new();
        for v in &t.vehicles {
            for x in [v.u, v.v, v.a, v.lat] {
                bytes.extend_from_slice(&x.to_bits().to_le_bytes());
            }
            bytes.extend_from_slice(&v.lane.to_le_bytes());
        }
        litesim_scenario::sha256_hex(&bytes)
    };
    assert_eq!(run(), run());
}

#[test]
fn more_than_the_documented_bound_of_vehicles_is_an_error() {
    let (_net, g) = road(100_000.0, 3, None);
    let mut t = Traffic::new(0.02);
    let d = Density {
        per_km_per_lane: 100.0,
        speed: (20.0, 30.0),
        size: (4.5, 1.8),
    };
    let e = fill(&mut t, &g, &d, &mut Rng::new(1), &[], |_, _| true).unwrap_err();
    assert!(e.to_string().contains("more than 20000 vehicles"), "{e}");
}

mod props {
    use litesim_scenario::runtime::driver::{DriverParams, Leader, acceleration};
    use proptest::prelude::*;

    proptest! {
        /// Whatever the speeds, gaps and leader's acceleration (a stop
        /// line, a leader far away, contact), a driver's acceleration is
        /// finite and within its limits.
        #[test]
        fn acceleration_is_finite_and_bounded(
            v in 0.0f64..80.0,
            v0 in 0.0f64..70.0,
            gap in prop_oneof![Just(f64::INFINITY), -5.0f64..500.0],
            vl in 0.0f64..80.0,
            al in -15.0f64..10.0,
            truck in any::<bool>(),
        ) {
            let p = DriverParams::for_category(if truck { "truck" } else { "car" }, v0);
            for leader in [None, Some(Leader { gap, speed: vl, accel: al })] {
                let a = acceleration(&p, v, leader);
                prop_assert!(a.is_finite(), "{a} for v {v} v0 {v0} {leader:?}");
                prop_assert!(a >= -p.emergency_decel && a <= p.max_accel, "{a}");
            }
        }
    }
}

mod engine_props {
    use litesim_core::rng::Rng;
    use litesim_map::RoadNetwork;
    use litesim_scenario::runtime::driver::DriverParams;
    use litesim_scenario::runtime::traffic::{LaneGraph, StopLine, Traffic, Vehicle};
    use proptest::prelude::*;
    use std::sync::OnceLock;

    fn junction() -> &'static LaneGraph {
        static G: OnceLock<LaneGraph> = OnceLock::new();
        G.get_or_init(|| {
            let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../examples/maps/junction.xodr");
            LaneGraph::new(&RoadNetwork::load(&p).unwrap())
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Any placement on the junction map, any lights: stepping never
        /// panics and every vehicle stays on a lane with a finite speed.
        #[test]
        fn any_start_steps_without_panic_and_stays_on_its_lanes(
            seed in any::<u64>(),
            n in 0usize..40,
            red in any::<bool>(),
        ) {
            let g = junction();
            prop_assert!(g.lanes.iter().any(|l| !l.conflicts.is_empty()));
            let mut rng = Rng::new(seed);
            let mut t = Traffic::new(0.02);
            for _ in 0..n {
                let lane = (rng.next_u64() % g.lanes.len() as u64) as u32;
                let u = rng.unit() * g.lanes[lane as usize].length;
                t.add(Vehicle {
                    lane,
                    u,
                    v: rng.unit() * 20.0,
                    a: 0.0,
                    lat: 0.0,
                    from: None,
                    length: 4.5,
                    width: 1.8,
                    params: DriverParams::for_category("car", 5.0 + rng.unit() * 15.0),
                    route: rng.next_u64(),
                    at_dead_end: false,
                    lane_changes: 0,
                    active: true,
                    goals: Default::default(),
                });
            }
            t.stop_lines = (0..g.lanes.len() as u32)
                .filter(|l| !g.lanes[*l as usize].junction)
                .map(|lane| StopLine { lane, u: g.lanes[lane as usize].length - 1.0, red, yellow: false })
                .collect();
            for _ in 0..200 {
                t.step(g, &[]);
            }
            for v in &t.vehicles {
                let len = g.lanes[v.lane as usize].length;
                prop_assert!(v.u.is_finite() && v.u >= 0.0 && v.u <= len + 1e-9, "{v:?}");
                prop_assert!(v.v.is_finite() && v.v >= 0.0, "{v:?}");
            }
        }
    }
}
