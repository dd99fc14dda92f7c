//! Starts and goals anywhere (issue 50's bad input): inside obstacles, off
//! the map, NaN, inside the margin, forwards and reversing — the start
//! check and the curvature-bounded search end in a path or a precise
//! error, within bounded time, never a panic.

use litesim_core::Vec2;
use litesim_map::OccupancyGrid;
use litesim_plan::escape::{StartError, from_start, max_escape};
use litesim_plan::{HybridConfig, PlanningGrid, hybrid_astar};
use proptest::prelude::*;
use std::time::{Duration, Instant};

/// A 40 m × 20 m yard at 0.2 m with a wall and a block in it.
fn yard(bus: bool) -> PlanningGrid {
    let mut g = OccupancyGrid::new(Vec2::new(0.0, 0.0), Vec2::new(40.0, 20.0), 0.2).unwrap();
    let w = g.width;
    for j in 0..60 {
        for i in 95..100 {
            g.occupied[j * w + i] = true;
        }
    }
    for j in 70..85 {
        for i in 150..170 {
            g.occupied[j * w + i] = true;
        }
    }
    if bus {
        PlanningGrid::with_footprint(g, 12.0, 2.55, 3.0, 0.4)
    } else {
        PlanningGrid::with_footprint(g, 4.6, 1.85, 0.95, 0.3)
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]
    #[test]
    fn random_starts_and_goals_end_in_a_path_or_an_error_in_bounded_time(
        sx in -5.0f64..45.0,
        sy in -5.0f64..25.0,
        yaw in -4.0f64..4.0,
        gx in -5.0f64..45.0,
        gy in -5.0f64..25.0,
        reverse in any::<bool>(),
        bus in any::<bool>(),
        nan in 0u8..10,
    ) {
        let g = yard(bus);
        let (mut start, mut goal) = (Vec2::new(sx, sy), Vec2::new(gx, gy));
        match nan {
            0 => start.x = f64::NAN,
            1 => goal.y = f64::NAN,
            2 => start.y = f64::INFINITY,
            _ => {}
        }
        let kappa = if bus { 0.1 } else { 0.15 };
        let t = Instant::now();
        match from_start(&g, start, yaw, kappa, 0.1, max_escape(if bus { 12.0 } else { 4.6 })) {
            Err(e) => {
                // Refused with what and where.
                let text = e.to_string();
                match e {
                    StartError::NotFinite { .. } => prop_assert!(nan <= 2, "{text}"),
                    StartError::Overlap { depth, .. } => prop_assert!(depth > 0.0, "{text}"),
                    StartError::NoEscape { .. } => prop_assert!(text.contains("inside the margin"), "{text}"),
                }
            }
            Ok(esc) => {
                let (p, h) = esc.as_ref().map_or((start, yaw), |e| (e.end, e.end_yaw));
                prop_assert!(g.pose_free(p, h));
                let cfg = HybridConfig {
                    reverse,
                    max_expansions: 20_000,
                    goal_tolerance: 0.5,
                    ..HybridConfig::new(kappa, 0.2)
                };
                match hybrid_astar(&g, p, h, goal, &cfg) {
                    Ok(path) => {
                        prop_assert!(goal.x.is_finite() && goal.y.is_finite());
                        let end = *path.points.last().unwrap();
                        prop_assert!(end.distance(goal) <= 0.5 + 1e-6, "{end:?} {goal:?}");
                        prop_assert!(path.points.iter().all(|q| q.x.is_finite() && q.y.is_finite()));
                        prop_assert!(reverse || path.segments.iter().all(|s| !s.reverse));
                    }
                    Err(e) => prop_assert!(!e.to_string().is_empty()),
                }
            }
        }
        // Bounded: a debug build expands 20,000 poses in a few seconds.
        prop_assert!(t.elapsed() < Duration::from_secs(60), "{:?}", t.elapsed());
    }
}

/// The public configuration of the issue: a 12 m bus whose rear stands
/// 0.70 m from the map's edge (inside the 0.4 m margin and a cell's
/// diagonal) starts there.
#[test]
fn a_bus_with_its_rear_070_m_from_the_edge_starts_where_it_stands() {
    let g = yard(true);
    let e = from_start(&g, Vec2::new(3.7, 10.0), 0.0, 0.1, 0.1, 12.0)
        .unwrap()
        .expect("inside the margin");
    assert!(!e.reverse, "{e:?}");
    assert!(e.depth > 0.0 && e.depth < 0.1, "{}", e.depth);
    assert!(e.length <= 0.2, "{}", e.length);
}
