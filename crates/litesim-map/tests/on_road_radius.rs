//! `on_road_radius`: every point within the radius of a located point is
//! on a road too (what lets a run skip the per-step off-road check of a
//! vehicle that has not moved that far), on the shipped maps and on the
//! stress map of varying widths, offsets and sections.

use litesim_core::Vec2;
use litesim_map::RoadNetwork;
use proptest::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

fn maps() -> &'static [(String, RoadNetwork)] {
    static MAPS: OnceLock<Vec<(String, RoadNetwork)>> = OnceLock::new();
    MAPS.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut paths: Vec<_> = ["straight", "circ", "curvy", "junction"]
            .iter()
            .map(|n| root.join(format!("../../examples/maps/{n}.xodr")))
            .collect();
        paths.push(root.join("tests/data/widths.xodr"));
        paths
            .into_iter()
            .map(|p| {
                let net = RoadNetwork::load(&p).unwrap_or_else(|e| panic!("{e}"));
                (p.file_name().unwrap().to_string_lossy().into_owned(), net)
            })
            .collect()
    })
}

/// A point at (s, t) of a road, t spread over the road's width and 1 m
/// beyond each edge.
fn point(net: &RoadNetwork, road: f64, s: f64, t: f64) -> Vec2 {
    let roads = net.roads();
    let r = &roads[((road * roads.len() as f64) as usize).min(roads.len() - 1)];
    let s = s * r.length;
    let spans = r.lane_spans(s);
    let lo = spans.iter().map(|l| l.t_outer).fold(0.0, f64::min) - 1.0;
    let hi = spans.iter().map(|l| l.t_outer).fold(0.0, f64::max) + 1.0;
    let (x, y, _) = r.st_to_xyz(s, lo + (hi - lo) * t);
    Vec2::new(x, y)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]
    #[test]
    fn points_within_the_radius_are_on_a_road(
        m in 0usize..5,
        road in 0.0f64..1.0,
        s in 0.0f64..1.0,
        t in 0.0f64..1.0,
        angle in 0.0f64..std::f64::consts::TAU,
        u in 0.0f64..1.0,
    ) {
        let (name, net) = &maps()[m];
        let p = point(net, road, s, t);
        let Some(at) = net.locate(p) else { return Ok(()) };
        let r = net.on_road_radius(&at);
        prop_assert!(r >= 0.0 && r.is_finite());
        let q = Vec2::new(p.x + r * u * angle.cos(), p.y + r * u * angle.sin());
        prop_assert!(
            net.locate(q).is_some(),
            "{name}: {p:?} located {at:?}, radius {r}, but {q:?} is off road"
        );
    }
}

#[test]
fn the_radius_is_useful_in_a_lane_and_zero_on_an_edge() {
    let (_, net) = &maps()[0];
    let r = &net.roads()[0];
    let lane = r.lane_spans(100.0)[0];
    let (x, y, _) = r.st_to_xyz(100.0, lane.t_center());
    let at = net.locate(Vec2::new(x, y)).unwrap();
    let radius = net.on_road_radius(&at);
    // The road counts, not the lane: 90 % of the way to the nearer edge
    // (sidewalks included), less the 1 cm reserve.
    let spans = r.lane_spans(100.0);
    let edge = spans.iter().map(|l| l.t_outer).fold(0.0, f64::max);
    let low = spans.iter().map(|l| l.t_outer).fold(0.0, f64::min);
    let want = 0.9 * ((edge - at.t).min(at.t - low) - 0.01);
    assert!((radius - want).abs() < 1e-9, "{radius}, wanted {want}");
    let (x, y, _) = r.st_to_xyz(100.0, edge - 0.005);
    let at = net.locate(Vec2::new(x, y)).unwrap();
    assert_eq!(net.on_road_radius(&at), 0.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    /// `advance_path_pose` lands where `advance_path` does, and the pose it
    /// hands back (where it has one) is the lane-centre pose there, to the
    /// bit: the planner steps along lanes with it.
    #[test]
    fn advance_path_pose_is_advance_path_and_its_pose(
        m in 0usize..5,
        road in 0.0f64..1.0,
        s in 0.0f64..1.0,
        lane in 0usize..8,
        dist in -30.0f64..60.0,
        given in any::<bool>(),
    ) {
        let (name, net) = &maps()[m];
        let roads = net.roads();
        let ri = ((road * roads.len() as f64) as usize).min(roads.len() - 1);
        let r = &roads[ri];
        let spans = r.lane_spans(s * r.length);
        let Some(l) = spans.get(lane % spans.len().max(1)) else { return Ok(()) };
        let p = litesim_map::LanePos { road: ri, lane: l.id, s: s * r.length };
        let at_p = given.then(|| net.lane_pos_pose(p, 0.0));
        let (q, pose) = net.advance_path_pose(p, dist, at_p);
        prop_assert_eq!(q, net.advance_path(p, dist, at_p), "{}", name);
        if let Some(c) = pose {
            prop_assert_eq!(c, net.lane_pos_pose(q, 0.0), "{}", name);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// `lane_holding` (one side of the centre lane evaluated) gives the
    /// same lane, to the bit, as the search over both sides it replaces
    /// in the locator — on every shipped map and the stress map of widths,
    /// offsets and sections, across each road's width and beyond it.
    #[test]
    fn lane_holding_is_the_two_sided_search(m in 0usize..5, road in 0.0f64..1.0, s in -0.05f64..1.05, t in -30.0f64..30.0) {
        let (_, net) = &maps()[m % maps().len()];
        let roads = net.roads();
        let r = &roads[((road * roads.len() as f64) as usize).min(roads.len() - 1)];
        let s = s * r.length;
        let both = r.find_span(s, |l| l.width() > 1e-3 && l.contains(t));
        prop_assert_eq!(r.lane_holding(s, t), both);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// `locate_near_kept` answers as `locate_near` does, to the bit, from
    /// a memo or without one: a memo made for one question (a point and a
    /// hint from an earlier step, another caller's) is used only for the
    /// same question, and two hints that differ only where `locate_near`
    /// does not look (t, offset, lane; a road not alone in the point's
    /// cell) ask the same question.
    #[test]
    fn a_kept_location_is_the_one_locate_near_finds(
        m in 0usize..5,
        road in 0.0f64..1.0,
        s in 0.0f64..1.0,
        t in 0.0f64..1.0,
        step in -3.0f64..3.0,
        same in any::<bool>(),
        junk in -5.0f64..5.0,
    ) {
        let (name, net) = &maps()[m];
        let p0 = point(net, road, s, t);
        let hint = net.locate(p0);
        let p1 = Vec2::new(p0.x + step, p0.y + 0.3 * step);
        // The memo another caller kept: the same question, or the previous
        // step's.
        let (_, kept) = if same {
            net.locate_near_kept(p1, hint, None)
        } else {
            net.locate_near_kept(p0, None, None)
        };
        let fresh = net.locate_near(p1, hint);
        let (got, memo) = net.locate_near_kept(p1, hint, Some(&kept));
        prop_assert_eq!(got, fresh, "{}", name);
        prop_assert_eq!(net.locate_near_kept(p1, hint, None).1, memo);
        // What the answer does not depend on does not change the question.
        let blurred = hint.map(|h| litesim_map::Located { t: h.t + junk, offset: junk, lane: h.lane + 1, ..h });
        prop_assert_eq!(net.near_query(p1, blurred), net.near_query(p1, hint));
        prop_assert_eq!(net.locate_near(p1, blurred), fresh);
    }
}
