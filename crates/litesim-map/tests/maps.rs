//! The shipped maps, queries, routing, rasterising and bad input.

use litesim_core::Vec2;
use litesim_map::{Direction, RoadNetwork};
use proptest::prelude::*;
use std::path::PathBuf;

fn map(name: &str) -> RoadNetwork {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/maps")
        .join(name);
    RoadNetwork::load(&p).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn shipped_maps_load_cleanly_and_are_continuous_to_a_millimetre() {
    for name in ["straight.xodr", "circ.xodr", "curvy.xodr", "junction.xodr"] {
        let m = map(name);
        assert!(m.warnings.is_empty(), "{name}: {:?}", m.warnings);
        for r in m.roads() {
            for w in r.plan_view.windows(2) {
                let a = w[0].eval(w[0].length);
                let gap = ((a.x - w[1].x).powi(2) + (a.y - w[1].y).powi(2)).sqrt();
                assert!(
                    gap < 1e-3,
                    "{name} road {} gap {gap} at s = {}",
                    r.id,
                    w[1].s
                );
                let dh = litesim_core::wrap_angle(a.hdg - w[1].hdg).abs();
                assert!(dh < 1e-6, "{name} road {} heading jump {dh}", r.id);
            }
        }
    }
}

#[test]
fn straight_road_queries() {
    let m = map("straight.xodr");
    let r = m.road("1").unwrap();
    let spans = r.lane_spans(100.0);
    assert_eq!(
        spans.iter().map(|l| l.id).collect::<Vec<_>>(),
        vec![1, 2, 3, 4, -1, -2, -3, -4]
    );
    let p = m.to_road(Vec2::new(100.0, -5.25)).unwrap();
    assert_eq!((p.road.as_str(), p.lane), ("1", -2));
    assert!((p.s - 100.0).abs() < 1e-9 && p.offset.abs() < 1e-9);
    assert!(m.to_road(Vec2::new(100.0, 40.0)).is_none());
    assert_eq!(r.lane_direction(10.0, -1), Direction::Forward);
    assert_eq!(r.lane_direction(10.0, 1), Direction::Backward);
    let pose = m.lane_pose("1", 2, 50.0, 0.0).unwrap();
    assert!(
        (pose.position.y - 5.25).abs() < 1e-9
            && (pose.yaw.abs() - std::f64::consts::PI).abs() < 1e-9
    );
    let sum = &m.road_summaries()[0];
    assert_eq!(
        (sum.min_forward_lanes, sum.min_backward_lanes, sum.one_way),
        (3, 3, false)
    );
    // Spawn positions keep clear of occupied points.
    let spawns = m.spawn_positions("1", -1, 20.0, 8.0, &[Vec2::new(110.0, -1.75)]);
    assert_eq!(spawns.len(), 24);
    assert!(
        spawns
            .iter()
            .all(|p| p.position.xy().distance(Vec2::new(110.0, -1.75)) >= 8.0)
    );
}

#[test]
fn circ_has_two_one_way_roads_linked_in_a_ring() {
    let m = map("circ.xodr");
    let sums = m.road_summaries();
    assert!(
        sums.iter()
            .all(|s| s.one_way && s.max_driving_lanes == 2 && s.min_forward_lanes == 2)
    );
    let a = m.lane_at("1", -1, 0.0).unwrap();
    let b = m.lane_at("2", -1, 0.0).unwrap();
    assert_eq!(m.successors(a), vec![b]);
    assert_eq!(m.successors(b), vec![a]);
    // Right lanes lie outside the counter-clockwise ring: 101.75 m from the centre.
    let p = m.to_road(Vec2::new(0.0, -101.75)).unwrap();
    assert_eq!(p.lane, -1);
    let pose = m.lane_pose("1", -1, 0.0, 0.0).unwrap();
    assert!((pose.position.y - -101.75).abs() < 1e-9 && pose.yaw.abs() < 1e-9);
}

#[test]
fn curvy_round_trip_and_elevation() {
    let m = map("curvy.xodr");
    let r = m.road("1").unwrap();
    assert!((r.elevation(100.0) - 1.0).abs() < 1e-12);
    for k in 0..90 {
        let s = 1.0 + k as f64 * 5.0;
        for t in [-4.0, -1.0, 1.5, 5.0] {
            let (x, y, _) = r.st_to_xyz(s, t);
            let p = m
                .to_road(Vec2::new(x, y))
                .unwrap_or_else(|| panic!("s={s} t={t} not found"));
            assert!(
                (p.s - s).abs() < 1e-6 && (p.t - t).abs() < 1e-6,
                "s={s} t={t}: {p:?}"
            );
        }
    }
    // The widening lane -2 is 3 m at s = 0 and 3 + 3e-5 s² further on.
    let w = r.lane_span(200.0, -2).unwrap().width();
    assert!((w - (3.0 + 3e-5 * 200.0 * 200.0)).abs() < 1e-9);
}

#[test]
fn junction_graph_routes_and_signals() {
    let m = map("junction.xodr");
    assert_eq!(m.roads().len(), 16);
    assert_eq!(m.od.junctions[0].connections.len(), 12);
    assert_eq!(m.roads().iter().map(|r| r.signals.len()).sum::<usize>(), 4);
    assert_eq!(m.od.controllers.len(), 2);
    for arm in ["1", "2", "3", "4"] {
        let n = m.lane_at(arm, -1, 50.0).unwrap();
        assert_eq!(m.successors(n).len(), 3, "arm {arm}: straight, right, left");
    }
    // West arm (1) to north arm (4): a left turn through connecting road 103.
    let from = m.lane_at("1", -1, 0.0).unwrap();
    let to = m.lane_at("4", 1, 0.0).unwrap();
    let route = m.route(from, to).unwrap();
    let ids: Vec<&str> = route
        .iter()
        .map(|n| m.roads()[n.road].id.as_str())
        .collect();
    assert_eq!(ids, vec!["1", "103", "4"]);
    // The connecting roads end exactly at their exit lanes.
    for r in m.roads().iter().filter(|r| r.junction.is_some()) {
        let end = m.lane_pose(&r.id, -1, r.length, 0.0).unwrap();
        let p = m.to_road(end.position.xy()).unwrap();
        assert!(p.offset.abs() < 1e-6, "road {} ends off-lane: {p:?}", r.id);
    }
    // Nothing routes against traffic.
    assert!(m.route(m.lane_at("4", 1, 0.0).unwrap(), from).is_none());
}

#[test]
fn rasterise_straight_road() {
    let m = map("straight.xodr");
    let g = m.rasterise(0.25, 2.0).unwrap();
    // Drivable: 500 m × 6 lanes × 3.5 m = 10,500 m², minus the cone (π·0.3² ≈ 0.28 m²).
    let area = g.free_cells() as f64 * 0.0625;
    assert!((area - 10_500.0).abs() < 10_500.0 * 0.01, "{area}");
    assert!(!g.is_occupied(Vec2::new(100.0, 0.5)));
    assert!(
        g.is_occupied(Vec2::new(100.0, 12.0)),
        "sidewalks are not drivable"
    );
    assert!(
        g.is_occupied(Vec2::new(250.0, -5.25)),
        "the cone is an obstacle"
    );
    assert!(m.rasterise(0.0, 0.0).is_err());
    assert!(m.rasterise(1e-5, 0.0).is_err(), "absurd sizes are refused");
}

fn err(xml: &str) -> String {
    RoadNetwork::from_xodr(xml, "t.xodr")
        .unwrap_err()
        .to_string()
}

const GOOD: &str = r#"<OpenDRIVE><header revMajor="1" revMinor="6"/>
<road id="1" length="10" junction="-1"><planView>
<geometry s="0" x="0" y="0" hdg="0" length="10"><line/></geometry>
</planView><lanes><laneSection s="0"><right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane></right></laneSection></lanes></road>
</OpenDRIVE>"#;

#[test]
fn bad_input_names_element_and_line() {
    assert!(RoadNetwork::from_xodr(GOOD, "t.xodr").is_ok());
    let e = err("<OpenDRIVE><road id=\"1\" length=\"10\"></OpenDRIVE>");
    assert!(
        e.starts_with("t.xodr:1:") && e.contains("malformed XML"),
        "{e}"
    );
    let e = err(&GOOD.replace(" hdg=\"0\"", ""));
    assert_eq!(
        e,
        "t.xodr:3:1: OpenDRIVE/road[id=1]/planView/geometry[0]: missing required attribute 'hdg' (a number)"
    );
    let e = err(&GOOD.replace("length=\"10\"><line/>", "length=\"-3\"><line/>"));
    assert!(
        e.contains("geometry[0]: length = -3 must not be negative"),
        "{e}"
    );
    let e = err(&GOOD.replace("<line/>", "<clothoid/>"));
    assert!(e.contains("unknown geometry: expected one of line, arc, spiral, poly3, paramPoly3; found [clothoid]"), "{e}");
    let e = err(&GOOD.replace(
        "<width sOffset=\"0\" a=\"3.5\" b=\"0\" c=\"0\" d=\"0\"/>",
        "",
    ));
    assert!(e.contains("lane[id=-1]: lane has no <width>"), "{e}");
    let e = err(&GOOD.replace("a=\"3.5\"", "a=\"wide\""));
    assert!(e.contains("attribute 'a' = 'wide' is not a number"), "{e}");
    let e = err("<OpenDRIVE><header/></OpenDRIVE>");
    assert!(e.contains("no <road> elements"), "{e}");
}

#[test]
fn gaps_and_unknown_elements_are_warnings() {
    let xml = GOOD.replace(
        "<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"10\"><line/></geometry>",
        "<geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"5\"><line/></geometry><geometry s=\"5\" x=\"5.02\" y=\"0\" hdg=\"0\" length=\"5\"><line/><userData/></geometry><fancy/>",
    );
    let m = RoadNetwork::from_xodr(&xml, "t.xodr").unwrap();
    let text: Vec<&str> = m.warnings.iter().map(|w| w.message.as_str()).collect();
    assert!(
        text.iter()
            .any(|w| w.contains("gap of 0.0200 m at s = 5.000")),
        "{text:?}"
    );
    assert!(
        text.iter()
            .any(|w| w.contains("<fancy> is not interpreted")),
        "{text:?}"
    );
    // The namespace variants load too.
    let ns = GOOD.replace(
        "<OpenDRIVE>",
        "<OpenDRIVE xmlns=\"http://www.opendrive.org\">",
    );
    assert!(RoadNetwork::from_xodr(&ns, "t.xodr").is_ok());
}

proptest! {
    #[test]
    fn loader_never_panics_on_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = RoadNetwork::from_xodr(&text, "fuzz.xodr");
    }

    #[test]
    fn loader_never_panics_on_mutated_maps(pos in 0usize..600, ch in prop::sample::select(vec!["", "-", "9e999", "\"", "<", "NaN", "0"])) {
        let mut s = GOOD.to_string();
        let p = pos.min(s.len());
        if s.is_char_boundary(p) {
            s.insert_str(p, ch);
        }
        let _ = RoadNetwork::from_xodr(&s, "fuzz.xodr");
    }
}

proptest! {
    #[test]
    fn st_xy_round_trip_on_curvy(s in 0.5f64..449.5, t in -6.4f64..6.4) {
        let m = map("curvy.xodr");
        let r = m.road("1").unwrap();
        // Stay inside the lanes (lane -2 widens with s).
        let outer = r.lane_spans(s).iter().map(|l| l.t_outer.abs()).fold(0.0, f64::max);
        prop_assume!(t.abs() < outer - 0.01 && t.abs() > 0.01);
        let (x, y, _) = r.st_to_xyz(s, t);
        let p = m.to_road(Vec2::new(x, y)).unwrap();
        prop_assert!((p.s - s).abs() < 1e-6 && (p.t - t).abs() < 1e-6, "{s} {t} -> {p:?}");
    }
}

#[test]
fn lanes_by_type_and_object_footprints() {
    let m = map("straight.xodr");
    assert_eq!(m.lanes_of_type("sidewalk").len(), 2);
    assert_eq!(m.lanes_of_type("driving").len(), 6);
    let f = m.object_footprints();
    assert_eq!(f.len(), 1);
    assert!(
        f[0].1
            .iter()
            .all(|p| (p.distance(Vec2::new(250.0, -5.25)) - 0.3).abs() < 1e-9)
    );
}

#[test]
fn a_point_before_a_junction_is_on_the_incoming_road_not_the_junction_road() {
    // Road 4 runs from (0, 110) down to the junction at (0, 10); the
    // junction's roads start there. 6 m before the junction the point
    // belongs to road 4 (a junction road used to claim it by projecting
    // the point onto its own start).
    let m = map("junction.xodr");
    for (y, s) in [(16.0, 94.0), (10.5, 99.5), (50.0, 60.0)] {
        let rp = m.to_road(Vec2::new(-1.75, y)).unwrap();
        assert_eq!((rp.road.as_str(), rp.lane), ("4", -1), "at y = {y}: {rp:?}");
        assert!((rp.s - s).abs() < 1e-6, "{rp:?}");
    }
}

/// Road marks come out as runs along the lane's outer border, cut where a
/// record's `sOffset` starts (sharing the boundary point), and the centre
/// lane's marks along the reference line; lane polylines stay without the
/// zero-width centre lane.
#[test]
fn road_marks_follow_their_records() {
    let xml = r#"<OpenDRIVE><header revMajor="1" revMinor="6"/>
<road id="1" length="100" junction="-1"><planView>
<geometry s="0" x="0" y="0" hdg="0" length="100"><line/></geometry>
</planView><lanes><laneSection s="0">
<center><lane id="0" type="none"><roadMark sOffset="0" type="solid" color="yellow" width="0.15"/></lane></center>
<right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/>
<roadMark sOffset="61.3" type="solid" color="standard" width="0.12"/>
<roadMark sOffset="0" type="broken" color="standard" width="0.12"/></lane></right>
</laneSection></lanes></road></OpenDRIVE>"#;
    let m = RoadNetwork::from_xodr(xml, "marks.xodr").unwrap();
    assert_eq!(
        m.lane_polylines(0.1).len(),
        1,
        "no polyline for the centre lane"
    );
    let marks = m.road_marks(0.1);
    let kinds: Vec<(&str, &str)> = marks
        .iter()
        .map(|r| (r.kind.as_str(), r.color.as_str()))
        .collect();
    assert_eq!(
        kinds,
        [
            ("solid", "yellow"),
            ("broken", "standard"),
            ("solid", "standard")
        ]
    );
    let (centre, broken, solid) = (&marks[0], &marks[1], &marks[2]);
    assert!(centre.points.iter().all(|p| p.y.abs() < 1e-9));
    assert!((centre.points.last().unwrap().x - 100.0).abs() < 1e-3);
    assert!(broken.points.iter().all(|p| (p.y + 3.5).abs() < 1e-9));
    assert!((broken.points[0].x).abs() < 1e-9);
    let cut = broken.points.last().unwrap().x;
    assert!(
        (cut - 61.3).abs() < 1e-9,
        "the broken run ends at 61.3 m: {cut}"
    );
    assert_eq!(
        solid.points[0],
        *broken.points.last().unwrap(),
        "runs share the cut"
    );
    assert!((solid.points.last().unwrap().x - 100.0).abs() < 1e-3);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// A walk of small steps (a vehicle at up to 40 m/s, 20 ms steps) in
    /// any direction from a lane centre: `locate_near` with the last answer
    /// as its hint finds what the full search finds, on every shipped map.
    #[test]
    fn locate_near_agrees_with_the_full_search(
        map_k in 0usize..4, road_k in 0usize..64, frac in 0.0f64..1.0,
        heading in -3.2f64..3.2, turn in -0.05f64..0.05, step in 0.0f64..0.8,
    ) {
        let name = ["straight.xodr", "circ.xodr", "curvy.xodr", "junction.xodr"][map_k];
        let m = map(name);
        let r = &m.roads()[road_k % m.roads().len()];
        let lane = r.lane_spans(frac * r.length).into_iter().find(|l| l.width() > 1e-3);
        prop_assume!(lane.is_some());
        let (x, y, _) = r.st_to_xyz(frac * r.length, lane.unwrap().t_center());
        let (mut p, mut h) = (Vec2::new(x, y), heading);
        let mut hint = m.locate(p);
        for _ in 0..200 {
            h += turn;
            p = Vec2::new(p.x + step * h.cos(), p.y + step * h.sin());
            let (near, full) = (m.locate_near(p, hint), m.locate(p));
            match (near, full) {
                (Some(a), Some(b)) => {
                    prop_assert_eq!((a.road, a.lane), (b.road, b.lane));
                    prop_assert!((a.s - b.s).abs() < 1e-6 && (a.t - b.t).abs() < 1e-6, "{:?} vs {:?}", a, b);
                }
                (a, b) => prop_assert_eq!(a, b),
            }
            hint = near;
        }
    }
}

#[test]
fn licence_headers_byte_order_marks_and_crlf_are_accepted() {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/maps/straight.xodr");
    let text = std::fs::read_to_string(p).unwrap();
    let plain = RoadNetwork::from_xodr(&text, "plain").unwrap();
    let body = text.trim_start();
    assert!(
        body.starts_with("<?xml"),
        "the fixture starts with its declaration"
    );
    let forms = [
        format!("<!-- Licence: CC-BY 4.0, (c) somebody -->\n{body}"),
        format!("\n\n   \n{body}"),
        format!("\u{feff}{body}"),
        format!("\u{feff}<!-- header -->\r\n{}", body.replace('\n', "\r\n")),
        body.replace('\n', "\r\n"),
    ];
    for (k, f) in forms.iter().enumerate() {
        let n = RoadNetwork::from_xodr(f, "form").unwrap_or_else(|e| panic!("form {k}: {e}"));
        assert_eq!(n.roads().len(), plain.roads().len(), "form {k}");
        assert_eq!(n.roads()[0].length, plain.roads()[0].length, "form {k}");
    }
    // Line numbers of later errors stay true after a header.
    let broken = format!(
        "<!-- header -->\n{}",
        body.replacen("<road ", "<road length=\"x\" ", 1)
    );
    let e = RoadNetwork::from_xodr(&broken, "broken").unwrap_err();
    let line = body.lines().position(|l| l.contains("<road ")).unwrap() + 2;
    assert_eq!(e.line as usize, line, "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Any numeric attribute of a shipped map set to an extreme finite value
    /// (or a tiny or negative one) gives an answer — a network or an error —
    /// quickly, and `map info`'s queries on the result stay bounded too.
    #[test]
    fn extreme_numbers_are_answered_in_bounded_time(
        map_k in 0usize..4, which in 0usize..10_000,
        value in proptest::sample::select(vec![
            "1e300", "-1e300", "1e9", "-1e9", "1e6", "-1e6", "1e-300", "0", "-1",
        ]),
    ) {
        let name = ["straight.xodr", "circ.xodr", "curvy.xodr", "junction.xodr"][map_k];
        let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/maps").join(name);
        let text = std::fs::read_to_string(p).unwrap();
        // The numeric attribute values, by position in the text.
        let re_like: Vec<(usize, usize)> = text
            .match_indices("=\"")
            .filter_map(|(i, _)| {
                let start = i + 2;
                let end = start + text[start..].find('"')?;
                text[start..end].parse::<f64>().ok().map(|_| (start, end))
            })
            .collect();
        prop_assume!(!re_like.is_empty());
        let (a, b) = re_like[which % re_like.len()];
        let mangled = format!("{}{}{}", &text[..a], value, &text[b..]);
        let started = std::time::Instant::now();
        if let Ok(net) = RoadNetwork::from_xodr(&mangled, "mangled") {
            let _ = net.road_summaries();
            let _ = net.to_road(Vec2::new(1.0, 1.0));
        }
        let took = started.elapsed();
        // Generous: a debug build on a shared two-core machine; what this
        // guards against is minutes and gigabytes (a 1e300 length once
        // allocated 5.6 GB and never finished).
        prop_assert!(took < std::time::Duration::from_secs(10), "{} = {} took {:?}", &text[a.saturating_sub(20)..a], value, took);
    }
}

#[test]
fn load_errors_and_warnings_name_the_place() {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/maps/straight.xodr");
    let text = std::fs::read_to_string(p).unwrap();
    // A truncated file: the error is where the input ended, with no empty field.
    let cut = &text[..text.len() / 2];
    let e = RoadNetwork::from_xodr(cut, "cut.xodr").unwrap_err();
    assert_eq!(e.line as usize, cut.matches('\n').count() + 1, "{e}");
    assert!(!e.to_string().contains(": :"), "{e}");
    // A duplicate road id points at the second element and names the first.
    let (i, j) = (
        text.find("<road ").unwrap(),
        text.find("</road>").unwrap() + 7,
    );
    let dup = format!("{}\n{}{}", &text[..j], &text[i..j], &text[j..]);
    let e = RoadNetwork::from_xodr(&dup, "dup.xodr").unwrap_err();
    let first = text[..i].matches('\n').count() + 1;
    assert!(e.line as usize > first, "{e}");
    assert!(
        e.to_string()
            .contains(&format!("first defined at line {first}")),
        "{e}"
    );
    // Links to roads and junctions that are not there: one warning each, with the road's line.
    let linked = text.replacen(
        "<planView>",
        "<link><predecessor elementType=\"road\" elementId=\"nowhere\" contactPoint=\"end\"/><successor elementType=\"junction\" elementId=\"j404\"/></link><planView>",
        1,
    );
    let n = RoadNetwork::from_xodr(&linked, "linked.xodr").unwrap();
    for id in ["road 'nowhere'", "junction 'j404'"] {
        let w = n
            .warnings
            .iter()
            .find(|w| w.message.contains(id))
            .unwrap_or_else(|| panic!("{id}: {:?}", n.warnings));
        assert_eq!(w.line as usize, first, "{w:?}");
    }
    // A negative lane width and section start are warnings naming the element.
    let neg = text.replacen("<laneSection s=\"0", "<laneSection s=\"-5", 1);
    let n = RoadNetwork::from_xodr(&neg, "neg.xodr").unwrap();
    assert!(
        n.warnings
            .iter()
            .any(|w| w.message.contains("s = -5") && w.path.contains("laneSection")),
        "{:?}",
        n.warnings
    );
    // So are negative offsets: a lane offset's s, a road mark's and a
    // border's sOffset, each at its element's line.
    let i = text.find("<laneSection").unwrap();
    let line = text[..i].matches('\n').count() + 1;
    let with_offset = format!(
        "{}<laneOffset s=\"-2\" a=\"0\" b=\"0\" c=\"0\" d=\"0\"/>{}",
        &text[..i],
        &text[i..]
    );
    let n = RoadNetwork::from_xodr(&with_offset, "off.xodr").unwrap();
    let w = n
        .warnings
        .iter()
        .find(|w| w.path.ends_with("laneOffset"))
        .unwrap_or_else(|| panic!("{:?}", n.warnings));
    assert!(w.message.contains("s = -2 is negative"), "{w:?}");
    assert_eq!(w.line as usize, line, "{w:?}");
    let mark = text.replacen("<roadMark sOffset=\"0", "<roadMark sOffset=\"-1", 1);
    assert_ne!(mark, text, "the map has a road mark with sOffset 0");
    let n = RoadNetwork::from_xodr(&mark, "mark.xodr").unwrap();
    assert!(
        n.warnings
            .iter()
            .any(|w| w.message.contains("sOffset = -1") && w.path.ends_with("roadMark")),
        "{:?}",
        n.warnings
    );
}

/// The shortcut in `lane_pose_at` (no central difference on roads whose
/// lanes run parallel to the reference line) rests on the difference being
/// exactly 0 there: checked on every lane of every such road of the
/// shipped and test maps, and the roads with changing widths are not
/// taken for parallel.
#[test]
fn parallel_lanes_have_exactly_no_lateral_slope() {
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/");
    let mut nets: Vec<(String, RoadNetwork)> = ["straight", "curvy", "circ", "junction"]
        .iter()
        .map(|n| (n.to_string(), map(&format!("{n}.xodr"))))
        .collect();
    for f in ["widths.xodr", "fuzz_cubic_width.xodr"] {
        let text = std::fs::read_to_string(format!("{data}{f}")).unwrap();
        nets.push((f.into(), RoadNetwork::from_xodr(&text, f).unwrap()));
    }
    let (mut parallel, mut checked) = (0, 0);
    for (name, net) in &nets {
        for (ri, r) in net.roads().iter().enumerate() {
            let varies = r.sections.len() > 1
                || r.sections
                    .iter()
                    .flat_map(|s| s.left.iter().chain(&s.right))
                    .any(|l| {
                        l.widths.len() != 1
                            || l.widths
                                .iter()
                                .any(|w| w.b != 0.0 || w.c != 0.0 || w.d != 0.0)
                    });
            if varies {
                assert!(!net.lanes_parallel(ri), "{name} road {}: widths vary", r.id);
            }
            if !net.lanes_parallel(ri) {
                continue;
            }
            parallel += 1;
            let lanes: Vec<i32> = r.lane_spans(0.0).iter().map(|l| l.id).collect();
            for k in 0..=50 {
                let s = r.length * k as f64 / 50.0;
                let (a, b) = ((s - 0.05).max(0.0), (s + 0.05).min(r.length));
                for &lane in &lanes {
                    let t = |x: f64| r.lane_span(x, lane).map_or(0.0, |l| l.t_center());
                    assert_eq!(
                        t(b) - t(a),
                        0.0,
                        "{name} road {} lane {lane} at s = {s}",
                        r.id
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(
        parallel >= 2 && checked > 100,
        "{parallel} roads, {checked} checks"
    );
    assert!(
        nets[0].1.lanes_parallel(0),
        "straight.xodr's road runs parallel"
    );
}
