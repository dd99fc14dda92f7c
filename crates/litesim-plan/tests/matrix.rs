//! Every example of examples/plan/ with every vehicle preset (the table of
//! BENCHMARKS.md, `litesim plan-matrix`): a run either reaches the goal
//! within 0.5 m tracking its path to ≤ 3 cm (mean ≤ 2 cm) without touching
//! anything, or it is proven impossible ("impossible for this vehicle: …":
//! the body cannot stand at the start, or an exhaustive search found no
//! path). A run that starts and then collides, misses or wanders, or one
//! refused without a proof, is a failure.

use litesim_plan::matrix::{load_examples, markdown, proven_impossible, run_matrix, within_bounds};
use std::path::PathBuf;

fn examples() -> Vec<(
    String,
    litesim_plan::ClosedLoopConfig,
    litesim_map::OccupancyGrid,
)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/plan");
    load_examples(&dir).unwrap()
}

#[test]
fn every_example_with_every_preset_arrives_on_its_path_or_is_refused_with_a_reason() {
    let ex = examples();
    assert_eq!(ex.len(), 7, "the seven planning examples");
    let rows = run_matrix(&ex, &[], 0.5, &|| 0.0);
    println!("{}", markdown(&rows));
    assert_eq!(rows.len(), 49);
    for r in &rows {
        assert!(
            within_bounds(r) || proven_impossible(r),
            "{} × {}: reached {} collided {} xte max {} mean {} error {:?}",
            r.example,
            r.preset,
            r.reached,
            r.collided,
            r.max_xte,
            r.mean_xte,
            r.error
        );
    }
    // Where the matrix stands (BENCHMARKS.md): a guard against regressions,
    // raised as planning learns to use more of the free space.
    let arrived = rows.iter().filter(|r| within_bounds(r)).count();
    assert!(
        arrived >= 47,
        "{arrived} of 49 runs arrived within the bounds"
    );
    // The bus in the parking lot stands with its rear on the map's edge,
    // inside the margin: it leaves it along a short leg and arrives.
    let bus = |example: &str| {
        rows.iter()
            .find(|r| r.example == example && r.preset == "bus")
            .unwrap()
    };
    assert!(
        within_bounds(bus("parking_lot")),
        "{:?}",
        bus("parking_lot")
    );
    // The runs no forward path reaches: they reverse (into the goal past
    // the narrow passage's gap and the S-bend's end, a turn in the
    // warehouse's aisles, with several changes of direction) and
    // arrive within the same bounds, the gear changing at each cusp.
    for (example, preset) in [
        ("narrow_passage", "bus"),
        ("narrow_passage", "truck"),
        ("s_bend", "bus"),
        ("warehouse", "van"),
        ("warehouse", "truck"),
    ] {
        let r = rows
            .iter()
            .find(|r| r.example == example && r.preset == preset)
            .unwrap();
        assert!(within_bounds(r), "{example} × {preset}: {r:?}");
    }
    // The truck in the forest and in the parking lot starts near the map's
    // edge, its rear circle within its radius and margin of it (1.50 and
    // 1.70 m against 1.77 m): its body keeps the margin there, so the body
    // is checked exactly while it leaves its start, and it arrives.
    for example in ["forest", "parking_lot"] {
        let truck = rows
            .iter()
            .find(|r| r.example == example && r.preset == "truck")
            .unwrap();
        assert!(within_bounds(truck), "{example}: {truck:?}");
    }
    // Each example's own configuration arrives — the warehouse's too,
    // whose 90° aisle corners the smoothed FMT* path takes tighter than
    // any preset turns: the curvature-bounded search plans it instead.
    for (name, cfg, _) in &ex {
        let own = rows
            .iter()
            .find(|r| &r.example == name && r.preset == cfg.vehicle.preset)
            .unwrap();
        assert!(
            within_bounds(own),
            "{name} with its own {}: {own:?}",
            cfg.vehicle.preset
        );
    }
    // The truck on the S-bend: no forward path reaches within half the
    // tolerance of its goal (5 m from the map's edge); the search that
    // also reverses backs into it (one cusp) and ends on the goal, where
    // forward searches alone stopped 0.31 m short of it.
    let truck = rows
        .iter()
        .find(|r| r.example == "s_bend" && r.preset == "truck")
        .unwrap();
    assert!(
        within_bounds(truck) && truck.final_distance <= 0.25,
        "{truck:?}"
    );
    // The two that cannot arrive are proven impossible, each saying why:
    // the bus in the forest cannot stand at its start (its body leaves the
    // map); the bus in the warehouse has no path on the search's lattice,
    // forwards and backwards at its full steering, every reachable pose
    // expanded.
    let forest = bus("forest").error.clone().unwrap_or_default();
    assert!(
        proven_impossible(bus("forest"))
            && forest.contains("cannot stand at its start (3.00, 5.00)")
            && forest.contains("leaves the map"),
        "{forest}"
    );
    let warehouse = bus("warehouse").error.clone().unwrap_or_default();
    assert!(
        proven_impossible(bus("warehouse"))
            && warehouse.contains("no path exists on the search's lattice")
            && warehouse.contains("poses reachable from the start was expanded"),
        "{warehouse}"
    );
}
