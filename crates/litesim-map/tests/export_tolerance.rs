//! `map export`'s tolerance is a promise: every lane line of every example
//! map (and of `tests/data/widths.xodr`, made of what breaks samplers:
//! width records that kink and jump mid-section, cubic bulges, a lane
//! offset, a tight arc after a line), evaluated exactly every 2 cm, lies
//! within the requested tolerance of its exported polyline.

use litesim_core::geometry::Vec2;
use litesim_map::RoadNetwork;
use std::path::Path;

fn seg(p: Vec2, a: Vec2, b: Vec2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let l2 = dx * dx + dy * dy;
    let u = if l2 > 0.0 {
        (((p.x - a.x) * dx + (p.y - a.y) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((p.x - a.x - dx * u).powi(2) + (p.y - a.y - dy * u).powi(2)).sqrt()
}

/// Largest distance from the exact line (t of the lane span at s, by
/// `which`) to the polyline, sampled every 2 cm of s over the section.
fn worst(net: &RoadNetwork, pl: &litesim_map::network::LanePolyline, which: usize) -> f64 {
    let r = net.road(&pl.road).unwrap();
    let sec = &r.sections[pl.section];
    let s_end = r.sections.get(pl.section + 1).map_or(r.length, |n| n.s);
    let line = match which {
        0 => &pl.inner,
        1 => &pl.outer,
        _ => &pl.center,
    };
    if line.len() < 2 || pl.lane == 0 {
        return 0.0;
    }
    let n = ((s_end - sec.s) / 0.02).ceil() as usize;
    let mut j = 0usize;
    let mut w = 0.0f64;
    for k in 0..=n {
        let s = (sec.s + (s_end - sec.s) * k as f64 / n as f64).min(s_end - 1e-6);
        let Some(span) = r.lane_span(s, pl.lane) else {
            continue;
        };
        let t = [span.t_inner, span.t_outer, span.t_center()][which];
        let (x, y, _) = r.st_to_xyz(s, t);
        let p = Vec2::new(x, y);
        // The nearest segment near the last one (lines run forward in s).
        let lo = j.saturating_sub(3);
        let hi = (j + 60).min(line.len() - 1);
        let (mut best, mut bi) = (f64::INFINITY, j);
        for i in lo..hi {
            let d = seg(p, line[i], line[i + 1]);
            if d < best {
                best = d;
                bi = i;
            }
        }
        j = bi;
        w = w.max(best);
    }
    w
}

#[test]
fn every_exported_lane_line_is_within_the_tolerance() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/maps");
    let mut maps: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "xodr"))
        .collect();
    maps.sort();
    assert!(maps.len() >= 4);
    // And a map made to break samplers: kinks, bulges, jumps, a tight arc.
    maps.push(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/widths.xodr"));
    for m in &maps {
        let net = RoadNetwork::load(m).unwrap();
        for tol in [0.05, 0.002] {
            for pl in net.all_lane_polylines(tol) {
                for which in 0..3 {
                    let w = worst(&net, &pl, which);
                    assert!(
                        w <= tol * 1.05 + 1e-6,
                        "{}: road {} section {} lane {} line {which}: {w:.4} m off at tolerance {tol}",
                        m.display(),
                        pl.road,
                        pl.section,
                        pl.lane
                    );
                }
            }
        }
    }
}

/// A fuzz finding (load_xodr, 2026-11-24): a lane width with d = 1 grows
/// to 9e7 m over the road, every piece fails the tolerance, and halving
/// without bound took 35 s. The work is bounded now (pieces per first step
/// and per section): the polylines stay small.
#[test]
fn an_absurd_lane_width_costs_bounded_work() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz_cubic_width.xodr");
    let net = RoadNetwork::load(&p).unwrap();
    // Samples of a section: its first steps (at least 5 cm each) and at
    // most MAX_REFINED_PIECES from halving.
    let road = net.road("1").unwrap();
    let bound = (road.length / 0.05) as usize + litesim_map::network::MAX_REFINED_PIECES + 100;
    for tol in [0.5] {
        for l in net.all_lane_polylines(tol) {
            assert!(
                l.center.len() <= bound,
                "{} points at {tol}",
                l.center.len()
            );
        }
    }
}

/// A straight road with constant lane widths: every lane line is a
/// straight segment, exported with its two ends (and a point where a road
/// mark starts) rather than a sample every few metres — the 500 m road of
/// the README's example was ~100 points per line, 48 KB of MCAP map.
#[test]
fn a_straight_road_with_constant_widths_exports_its_ends() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/maps/straight.xodr");
    let net = RoadNetwork::load(&p).unwrap();
    let lines = net.all_lane_polylines(0.05);
    assert!(!lines.is_empty());
    for l in &lines {
        assert!(
            (2..=3).contains(&l.outer.len()),
            "lane {}: {} points",
            l.lane,
            l.outer.len()
        );
        assert_eq!(l.inner.len(), l.outer.len());
        assert_eq!(l.center.len(), l.outer.len());
    }
}
