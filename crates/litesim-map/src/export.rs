//! Lane polylines as GeoJSON (local metres as coordinates) or CSV.

use crate::network::LanePolyline;
use std::fmt::Write;

/// A GeoJSON FeatureCollection: one LineString per lane border and centre,
/// with road, section, lane, type and line ("center", "inner", "outer").
/// Coordinates are the map's local x/y in metres (no geo-referencing applied).
pub fn geojson(lanes: &[LanePolyline]) -> String {
    let mut features = Vec::new();
    for l in lanes {
        for (line, pts) in [
            ("center", &l.center),
            ("inner", &l.inner),
            ("outer", &l.outer),
        ] {
            features.push(serde_json::json!({
                "type": "Feature",
                "properties": { "road": l.road, "section": l.section, "lane": l.lane, "type": l.kind, "line": line },
                "geometry": { "type": "LineString", "coordinates": pts.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>() },
            }));
        }
    }
    serde_json::json!({ "type": "FeatureCollection", "features": features }).to_string()
}

/// CSV: `road,section,lane,type,line,index,x,y`, one row per vertex.
pub fn csv(lanes: &[LanePolyline]) -> String {
    let mut out = String::from("road,section,lane,type,line,index,x,y\n");
    for l in lanes {
        for (line, pts) in [
            ("center", &l.center),
            ("inner", &l.inner),
            ("outer", &l.outer),
        ] {
            for (i, p) in pts.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "{},{},{},{},{},{},{},{}",
                    l.road, l.section, l.lane, l.kind, line, i, p.x, p.y
                );
            }
        }
    }
    out
}
