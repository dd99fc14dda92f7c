//! The map's content: the road network as Foxglove scene entities (`/map`)
//! and as OSI lanes and boundaries (the first ground truth), built once.

use super::*;

/// The map as OSI lanes and lane boundaries (ids from `first_id`), and as a
/// Foxglove scene entity of line strips.
pub(super) struct MapContent {
    pub(super) lanes: Vec<osi3::Lane>,
    pub(super) boundaries: Vec<osi3::LaneBoundary>,
    pub(super) entity: Option<fg::SceneEntity>,
}

pub(super) fn v3(x: f64, y: f64, z: f64) -> osi3::Vector3d {
    osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    }
}

pub(super) fn id(v: u64) -> osi3::Identifier {
    osi3::Identifier { value: Some(v) }
}

/// Lane polylines are exported to this tolerance (m).
pub(super) const MAP_TOLERANCE: f64 = 0.05;

/// The map's lane and mark polylines, sampled once per map: the costly part
/// of a file's map content and independent of the run, so a caller can
/// build it while the run is still going (see [`write_with`]).
#[derive(Clone, Debug)]
pub struct McapMap {
    pub(super) polys: Vec<litesim_map::network::LanePolyline>,
}

impl McapMap {
    /// Samples `net`'s lanes and marks (to 5 cm).
    pub fn new(net: &RoadNetwork) -> McapMap {
        McapMap {
            polys: net.all_lane_polylines(MAP_TOLERANCE),
        }
    }
}

pub(super) fn map_content(map: &McapMap, first_id: u64) -> MapContent {
    use osi3::lane::classification::Type as LaneType;
    use osi3::lane_boundary::classification::{Color, Type as LineType};
    let polys = &map.polys;
    let mut next = first_id;
    let mut take = || {
        next += 1;
        next - 1
    };
    let mut lanes = Vec::new();
    let mut boundaries = Vec::new();
    let mut lines = Vec::new();
    let grey = fg::Color {
        r: 0.55,
        g: 0.55,
        b: 0.55,
        a: 1.0,
    };
    for l in polys.iter().filter(|l| l.lane != 0) {
        let boundary = |pts: &[litesim_core::Vec2], ty: LineType, colour: Color, bid: u64| {
            osi3::LaneBoundary {
                id: Some(id(bid)),
                boundary_line: pts
                    .iter()
                    .map(|p| osi3::lane_boundary::BoundaryPoint {
                        position: Some(v3(p.x, p.y, 0.0)),
                        ..Default::default()
                    })
                    .collect(),
                classification: Some(osi3::lane_boundary::Classification {
                    r#type: Some(ty as i32),
                    color: Some(colour as i32),
                    ..Default::default()
                }),
                ..Default::default()
            }
        };
        // The outer border carries the lane's road mark (the first run's
        // type; a border without a painted mark is "no line").
        let mark = l.marks.first();
        let (ty, colour) = match mark.map(|m| (m.kind.trim(), m.color.trim())) {
            Some(("solid" | "solid solid", c)) => (LineType::SolidLine, mark_colour(c)),
            Some(("broken" | "broken broken" | "solid broken" | "broken solid", c)) => {
                (LineType::DashedLine, mark_colour(c))
            }
            _ => (LineType::NoLine, Color::None),
        };
        let (inner_id, outer_id) = (take(), take());
        boundaries.push(boundary(&l.inner, LineType::NoLine, Color::None, inner_id));
        boundaries.push(boundary(&l.outer, ty, colour, outer_id));
        // Right lanes (negative ids) have their inner border on the left.
        let (left, right) = if l.lane < 0 {
            (inner_id, outer_id)
        } else {
            (outer_id, inner_id)
        };
        let drivable = litesim_map::model::is_drivable_kind(&l.kind);
        lanes.push(osi3::Lane {
            id: Some(id(take())),
            classification: Some(osi3::lane::Classification {
                r#type: Some(if drivable {
                    LaneType::Driving
                } else {
                    LaneType::Nondriving
                } as i32),
                centerline: l.center.iter().map(|p| v3(p.x, p.y, 0.0)).collect(),
                // litesim's right lanes run along the reference line.
                centerline_is_driving_direction: Some(l.lane < 0),
                left_lane_boundary_id: vec![id(left)],
                right_lane_boundary_id: vec![id(right)],
                ..Default::default()
            }),
            ..Default::default()
        });
        lines.push(strip(&l.inner, 0.05, grey));
        lines.push(strip(&l.outer, 0.05, grey));
    }
    lines.extend(mark_lines(polys));
    let entity = (!lines.is_empty()).then(|| fg::SceneEntity {
        timestamp: Some(stamp(0)),
        frame_id: WORLD_FRAME.into(),
        id: "map".into(),
        lifetime: None,
        frame_locked: false,
        lines,
        ..Default::default()
    });
    MapContent {
        lanes,
        boundaries,
        entity,
    }
}

/// A line strip through `pts`, `thickness` wide, in colour `c`.
pub(super) fn strip(pts: &[litesim_core::Vec2], thickness: f64, c: fg::Color) -> fg::LinePrimitive {
    fg::LinePrimitive {
        r#type: fg::line_primitive::Type::LineStrip as i32,
        pose: None,
        thickness,
        scale_invariant: false,
        points: pts
            .iter()
            .map(|p| fg::Point3 {
                x: p.x,
                y: p.y,
                z: 0.0,
            })
            .collect(),
        color: Some(c),
        colors: vec![],
        indices: vec![],
    }
}

/// The road marks as line strips: yellow or white, as wide as marked
/// (within 8–30 cm); none for `none` marks.
pub(super) fn mark_lines(polys: &[litesim_map::network::LanePolyline]) -> Vec<fg::LinePrimitive> {
    use osi3::lane_boundary::classification::Color;
    let mut lines = Vec::new();
    for m in polys.iter().flat_map(|l| &l.marks) {
        let kind = m.kind.trim();
        if matches!(kind, "" | "none") || m.points.len() < 2 {
            continue;
        }
        let yellow = matches!(mark_colour(&m.color), Color::Yellow);
        let c = if yellow {
            fg::Color {
                r: 0.95,
                g: 0.75,
                b: 0.1,
                a: 1.0,
            }
        } else {
            fg::Color {
                r: 1.0,
                g: 1.0,
                b: 1.0,
                a: 1.0,
            }
        };
        lines.push(strip(&m.points, m.width.clamp(0.08, 0.3), c));
    }
    lines
}

pub(super) fn mark_colour(c: &str) -> osi3::lane_boundary::classification::Color {
    use osi3::lane_boundary::classification::Color;
    match c.trim().to_ascii_lowercase().as_str() {
        "yellow" | "orange" => Color::Yellow,
        "red" => Color::Red,
        "blue" => Color::Blue,
        "green" => Color::Green,
        _ => Color::White,
    }
}
