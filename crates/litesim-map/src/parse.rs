//! OpenDRIVE XML → [`OpenDrive`], with precise errors and warnings.
//!
//! Elements are matched by local name (namespaces ignored, order not
//! assumed). Unknown elements and `userData` are skipped with a warning;
//! missing required attributes, unparsable numbers, negative lengths, unknown
//! geometry and lanes without width are errors naming the element path and
//! the line.

use crate::geometry::{Geometry, Shape};
use crate::model::*;
use crate::xml::{Node, Stream, Tree, XmlError};
use std::collections::BTreeMap;

/// A load error: where (element path, line, column) and what.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{column}: {}{message}", if path.is_empty() { String::new() } else { format!("{path}: ") })]
pub struct MapError {
    /// File name (for messages).
    pub file: String,
    /// Line (1-based; 0 when not tied to a place).
    pub line: u32,
    /// Column (1-based).
    pub column: u32,
    /// Element path, e.g. `OpenDRIVE/road[id=5]/planView/geometry[2]`.
    pub path: String,
    /// What is wrong and what was expected.
    pub message: String,
}

/// A non-fatal finding.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Warning {
    /// Line (1-based; 0 when not tied to one place).
    pub line: u32,
    /// Element path.
    pub path: String,
    /// What was found.
    pub message: String,
}

struct Ctx<'a> {
    text: &'a str,
    /// Byte offsets where each line starts: a node's line is a binary
    /// search, not a scan from the file's start (roxmltree's
    /// `text_pos_at` scans, which made loading quadratic in the file's size
    /// where warnings and ignored elements need lines: 90 % of a town map's
    /// load time).
    line_starts: Vec<usize>,
    file: String,
    warnings: Vec<Warning>,
    skipped: BTreeMap<String, (u32, String, usize)>,
}

type R<T> = Result<T, MapError>;

impl<'a> Ctx<'a> {
    fn pos(&self, n: Node) -> (u32, u32) {
        self.pos_at(n.start())
    }
    fn pos_at(&self, at: usize) -> (u32, u32) {
        let text = self.text;
        let at = at.min(text.len());
        // Lines are 1-based, columns count characters from 1 (as roxmltree
        // counts them).
        let line = self.line_starts.partition_point(|&l| l <= at);
        let start = self.line_starts[line - 1];
        let col = text.get(start..at).map_or(1, |t| t.chars().count() + 1);
        (line as u32, col as u32)
    }
    fn xml_err(&self, e: XmlError) -> MapError {
        let (line, column) = self.pos_at(e.pos);
        MapError {
            file: self.file.clone(),
            line,
            column,
            path: String::new(),
            message: e.message,
        }
    }
    fn err(&self, n: Node, path: &str, message: impl Into<String>) -> MapError {
        let (line, column) = self.pos(n);
        MapError {
            file: self.file.clone(),
            line,
            column,
            path: path.to_string(),
            message: message.into(),
        }
    }
    fn warn(&mut self, n: Node, path: &str, message: impl Into<String>) {
        let (line, _) = self.pos(n);
        self.warnings.push(Warning {
            line,
            path: path.into(),
            message: message.into(),
        });
    }
    /// Records an ignored element; warnings are aggregated per element name.
    fn skip(&mut self, n: Node, path: &str) {
        // Maps repeat the same ignored element thousands of times
        // (userData per lane): only its first sighting allocates.
        if let Some(e) = self.skipped.get_mut(n.name()) {
            e.2 += 1;
            return;
        }
        let (line, _) = self.pos(n);
        self.skipped.insert(
            n.name().to_string(),
            (line, format!("{path}/{}", n.name()), 1),
        );
    }
    fn req_f64(&self, n: Node, path: &str, name: &str) -> R<f64> {
        match n.attribute(name) {
            None => Err(self.err(
                n,
                path,
                format!("missing required attribute '{name}' (a number)"),
            )),
            Some(v) => self.num(n, path, name, v),
        }
    }
    fn num(&self, n: Node, path: &str, name: &str, v: &str) -> R<f64> {
        let x: f64 = v.trim().parse().map_err(|_| {
            self.err(
                n,
                path,
                format!("attribute '{name}' = '{v}' is not a number"),
            )
        })?;
        if !x.is_finite() {
            return Err(self.err(n, path, format!("attribute '{name}' = '{v}' is not finite")));
        }
        if x.abs() > MAX_NUMBER {
            return Err(self.err(
                n,
                path,
                format!("attribute '{name}' = '{v}' is beyond ±{MAX_NUMBER:e}, the largest number a map may hold"),
            ));
        }
        Ok(x)
    }
    /// A length (road, geometry) in `(0 or more, MAX_LENGTH_M]`.
    fn length(&self, n: Node, path: &str) -> R<f64> {
        let l = self.req_f64(n, path, "length")?;
        if l > MAX_LENGTH_M {
            return Err(self.err(
                n,
                path,
                format!("length = {l} m; a road or geometry is at most {MAX_LENGTH_M} m"),
            ));
        }
        Ok(l)
    }
    /// A curvature with |k| ≤ MAX_CURVATURE.
    fn curvature(&self, n: Node, path: &str, name: &str) -> R<f64> {
        let k = self.req_f64(n, path, name)?;
        if k.abs() > MAX_CURVATURE {
            return Err(self.err(
                n,
                path,
                format!(
                    "{name} = {k} 1/m; curvatures are at most ±{MAX_CURVATURE} 1/m (a 1 cm radius)"
                ),
            ));
        }
        Ok(k)
    }
    fn opt_f64(&self, n: Node, path: &str, name: &str) -> R<Option<f64>> {
        n.attribute(name)
            .map(|v| self.num(n, path, name, v))
            .transpose()
    }
    fn f64_or(&self, n: Node, path: &str, name: &str, default: f64) -> R<f64> {
        Ok(self.opt_f64(n, path, name)?.unwrap_or(default))
    }
    fn req_str(&self, n: Node, path: &str, name: &str) -> R<String> {
        n.attribute(name)
            .map(|s| s.trim().to_string())
            .ok_or_else(|| self.err(n, path, format!("missing required attribute '{name}'")))
    }
    fn req_i32(&self, n: Node, path: &str, name: &str) -> R<i32> {
        let v = self.req_str(n, path, name)?;
        v.parse::<i32>()
            .or_else(|_| {
                v.parse::<f64>().map_err(|_| ()).and_then(|f| {
                    // A whole number within i32 (`1e300` is no lane id).
                    if f.fract() == 0.0 && f.abs() <= f64::from(i32::MAX) {
                        Ok(f as i32)
                    } else {
                        Err(())
                    }
                })
            })
            .map_err(|_| {
                self.err(
                    n,
                    path,
                    format!("attribute '{name}' = '{v}' is not an integer"),
                )
            })
    }
    fn cubic(&self, n: Node, path: &str, s_name: &str) -> R<Cubic> {
        Ok(Cubic {
            s: self.req_f64(n, path, s_name)?,
            a: self.f64_or(n, path, "a", 0.0)?,
            b: self.f64_or(n, path, "b", 0.0)?,
            c: self.f64_or(n, path, "c", 0.0)?,
            d: self.f64_or(n, path, "d", 0.0)?,
        })
    }
}

/// The offsets just after each `\n`.
fn after_newlines(text: &str) -> impl Iterator<Item = usize> + '_ {
    // match_indices on a char searches with memchr.
    text.match_indices('\n').map(|(i, _)| i + 1)
}

fn boolean(v: Option<&str>) -> bool {
    matches!(v.map(str::trim), Some("true" | "1" | "yes"))
}

/// Speed in m/s from a value and an OpenDRIVE unit (`m/s`, `km/h`, `mph`; missing = m/s).
fn speed(max: Option<&str>, unit: Option<&str>) -> Option<f64> {
    let v: f64 = max?.trim().parse().ok()?;
    Some(match unit.map(str::trim) {
        Some("km/h") => v / 3.6,
        Some("mph") => v * 0.447_04,
        _ => v,
    })
}

/// Largest magnitude of any number in a map (projected coordinates, in
/// metres, stay far below it): absurd but finite values are refused, not
/// turned into hours of sampling or gigabytes of memory.
pub const MAX_NUMBER: f64 = 1e9;

/// Longest road or geometry (m).
pub const MAX_LENGTH_M: f64 = 100_000.0;

/// Largest |curvature| of an arc or spiral (1/m).
pub const MAX_CURVATURE: f64 = 100.0;

/// Parses OpenDRIVE text. `file` names the source in messages.
pub fn parse(text: &str, file: &str) -> Result<(OpenDrive, Vec<Warning>), MapError> {
    let line_starts = std::iter::once(0).chain(after_newlines(text)).collect();
    let mut cx = Ctx {
        text,
        line_starts,
        file: file.into(),
        warnings: Vec::new(),
        skipped: BTreeMap::new(),
    };
    // The document is read one top-level element at a time (see `xml`):
    // memory stays the text plus the model, whatever the map's size.
    let (mut stream, root_tree) = Stream::open(text).map_err(|e| cx.xml_err(e))?;
    let root = root_tree.root();
    if root.name() != "OpenDRIVE" {
        return Err(cx.err(
            root,
            "",
            format!("root element is <{}>, expected <OpenDRIVE>", root.name()),
        ));
    }
    let mut od = OpenDrive::default();
    // Road id → the line of its element (duplicates point at both).
    let mut road_lines: BTreeMap<String, u32> = BTreeMap::new();
    let mut saw_header = false;
    let mut tree = Tree::new(text);
    while stream.next(&mut tree).map_err(|e| cx.xml_err(e))? {
        let n = tree.root();
        match n.name() {
            "header" => {
                saw_header = true;
                od.header = header(&mut cx, n)?;
            }
            "road" => {
                let r = road(&mut cx, n)?;
                let (line, _) = cx.pos(n);
                if let Some(first) = road_lines.insert(r.id.clone(), line) {
                    return Err(cx.err(
                        n,
                        &format!("OpenDRIVE/road[id={}]", r.id),
                        format!(
                            "road id '{}' is used twice (first defined at line {first})",
                            r.id
                        ),
                    ));
                }
                od.roads.push(r)
            }
            "junction" => od.junctions.push(junction(&mut cx, n)?),
            "controller" => {
                let path = format!(
                    "OpenDRIVE/controller[id={}]",
                    n.attribute("id").unwrap_or("?")
                );
                od.controllers.push(Controller {
                    id: cx.req_str(n, &path, "id")?,
                    name: n.attribute("name").unwrap_or("").into(),
                    signals: n
                        .elements()
                        .filter(|c| c.name() == "control")
                        .map(|c| cx.req_str(c, &format!("{path}/control"), "signalId"))
                        .collect::<R<_>>()?,
                });
            }
            _ => cx.skip(n, "OpenDRIVE"),
        }
    }
    if !saw_header {
        cx.warnings.push(Warning {
            line: 0,
            path: "OpenDRIVE".into(),
            message: "no <header>; assuming OpenDRIVE 1.4 defaults".into(),
        });
    }
    if od.roads.is_empty() {
        return Err(cx.err(
            root,
            "OpenDRIVE",
            "no <road> elements: a map needs at least one road",
        ));
    }
    // Links to roads or junctions the file does not have: one warning per
    // missing id, at the line of the road that names it.
    let junction_ids: std::collections::BTreeSet<&str> =
        od.junctions.iter().map(|j| j.id.as_str()).collect();
    for r in &od.roads {
        for (which, link) in [("predecessor", &r.predecessor), ("successor", &r.successor)] {
            let missing = match link {
                Some(LinkTarget::Road { id, .. }) if !road_lines.contains_key(id) => {
                    Some(format!("road '{id}'"))
                }
                Some(LinkTarget::Junction(id)) if !junction_ids.contains(id.as_str()) => {
                    Some(format!("junction '{id}'"))
                }
                _ => None,
            };
            if let Some(what) = missing {
                cx.warnings.push(Warning {
                    line: road_lines.get(&r.id).copied().unwrap_or(0),
                    path: format!("OpenDRIVE/road[id={}]/link/{which}", r.id),
                    message: format!(
                        "links to {what}, which is not in the file; the link is ignored"
                    ),
                });
            }
        }
    }
    let skipped = std::mem::take(&mut cx.skipped);
    for (name, (line, path, count)) in skipped {
        cx.warnings.push(Warning {
            line,
            path,
            message: format!("<{name}> is not interpreted and was ignored ({count}×)"),
        });
    }
    Ok((od, cx.warnings))
}

fn header(cx: &mut Ctx, n: Node) -> R<Header> {
    let path = "OpenDRIVE/header";
    let mut h = Header {
        rev_major: n
            .attribute("revMajor")
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(1),
        rev_minor: n
            .attribute("revMinor")
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(4),
        name: n.attribute("name").unwrap_or("").into(),
        vendor: n.attribute("vendor").unwrap_or("").into(),
        ..Header::default()
    };
    for c in n.elements() {
        match c.name() {
            "geoReference" => h.geo_reference = Some(c.text().unwrap_or("").trim().to_string()),
            "offset" => {
                let p = format!("{path}/offset");
                h.offset = Some([
                    cx.f64_or(c, &p, "x", 0.0)?,
                    cx.f64_or(c, &p, "y", 0.0)?,
                    cx.f64_or(c, &p, "z", 0.0)?,
                    cx.f64_or(c, &p, "hdg", 0.0)?,
                ]);
            }
            _ => cx.skip(c, path),
        }
    }
    Ok(h)
}

fn link(cx: &Ctx, n: Node, path: &str) -> R<LinkTarget> {
    let id = cx.req_str(n, path, "elementId")?;
    match n.attribute("elementType").map(str::trim) {
        Some("junction") => Ok(LinkTarget::Junction(id)),
        Some("road") | None => {
            let at_start =
                match n.attribute("contactPoint").map(str::trim) {
                    Some("start") => true,
                    Some("end") => false,
                    Some(other) => {
                        return Err(cx.err(
                            n,
                            path,
                            format!("contactPoint = '{other}', expected 'start' or 'end'"),
                        ));
                    }
                    None => return Err(cx.err(
                        n,
                        path,
                        "missing required attribute 'contactPoint' for a road link (start or end)",
                    )),
                };
            Ok(LinkTarget::Road { id, at_start })
        }
        Some(other) => Err(cx.err(
            n,
            path,
            format!("elementType = '{other}', expected 'road' or 'junction'"),
        )),
    }
}

fn road(cx: &mut Ctx, n: Node) -> R<Road> {
    let id = n.attribute("id").unwrap_or("?").trim().to_string();
    let path = format!("OpenDRIVE/road[id={id}]");
    let id = cx.req_str(n, &path, "id")?;
    let length = cx.length(n, &path)?;
    if length <= 0.0 {
        return Err(cx.err(n, &path, format!("length = {length} must be positive")));
    }
    let junction = n
        .attribute("junction")
        .map(str::trim)
        .filter(|j| *j != "-1" && !j.is_empty())
        .map(String::from);
    let rule = match n.attribute("rule").map(str::trim) {
        Some("LHT" | "lht") => Rule::Lht,
        _ => Rule::Rht,
    };
    let mut r = Road {
        id,
        name: n.attribute("name").unwrap_or("").into(),
        length,
        junction,
        rule,
        predecessor: None,
        successor: None,
        types: Vec::new(),
        plan_view: Vec::new(),
        elevation: Vec::new(),
        superelevation: Vec::new(),
        lane_offsets: Vec::new(),
        sections: Vec::new(),
        signals: Vec::new(),
        objects: Vec::new(),
    };
    let mut saw_plan = false;
    let mut saw_lanes = false;
    for c in n.elements() {
        match c.name() {
            "link" => road_links(cx, c, &path, &mut r)?,
            "type" => {
                let p = format!("{path}/type");
                let sp = c.elements().find(|s| s.name() == "speed");
                r.types.push(RoadType {
                    s: cx.req_f64(c, &p, "s")?,
                    kind: c.attribute("type").unwrap_or("unknown").trim().into(),
                    max_speed: sp.and_then(|s| speed(s.attribute("max"), s.attribute("unit"))),
                });
            }
            "planView" => {
                saw_plan = true;
                for (i, g) in c.elements().enumerate() {
                    let p = format!("{path}/planView/geometry[{i}]");
                    if g.name() != "geometry" {
                        cx.skip(g, &format!("{path}/planView"));
                        continue;
                    }
                    r.plan_view.push(geometry(cx, g, &p)?);
                }
            }
            "elevationProfile" => {
                for e in c.elements().filter(|e| e.name() == "elevation") {
                    r.elevation.push(cx.cubic(
                        e,
                        &format!("{path}/elevationProfile/elevation"),
                        "s",
                    )?);
                }
            }
            "lateralProfile" => {
                for e in c.elements() {
                    match e.name() {
                        "superelevation" => r.superelevation.push(cx.cubic(
                            e,
                            &format!("{path}/lateralProfile/superelevation"),
                            "s",
                        )?),
                        _ => cx.skip(e, &format!("{path}/lateralProfile")),
                    }
                }
            }
            "lanes" => {
                saw_lanes = true;
                lanes(cx, c, &path, &mut r)?;
            }
            "signals" => {
                for (i, s) in c.elements().enumerate() {
                    let p = format!("{path}/signals/signal[{i}]");
                    match s.name() {
                        "signal" => r.signals.push(signal(cx, s, &p)?),
                        _ => cx.skip(s, &format!("{path}/signals")),
                    }
                }
            }
            "objects" => objects(cx, c, &path, &mut r.objects)?,
            _ => cx.skip(c, &path),
        }
    }
    if !saw_plan || r.plan_view.is_empty() {
        return Err(cx.err(
            n,
            &path,
            "no <planView> geometry: a road needs a reference line",
        ));
    }
    if !saw_lanes || r.sections.is_empty() {
        return Err(cx.err(
            n,
            &path,
            "no <lanes>/<laneSection>: a road needs at least one lane section",
        ));
    }
    tidy_road(cx, n, &path, &mut r);
    Ok(r)
}

/// A road's `<link>`: its predecessor and successor.
fn road_links(cx: &mut Ctx, c: Node, path: &str, r: &mut Road) -> R<()> {
    for l in c.elements() {
        let p = format!("{path}/link/{}", l.name());
        match l.name() {
            "predecessor" => r.predecessor = Some(link(cx, l, &p)?),
            "successor" => r.successor = Some(link(cx, l, &p)?),
            _ => cx.skip(l, &format!("{path}/link")),
        }
    }
    Ok(())
}

/// A road's `<lanes>`: lane offsets (a negative s applies from the start,
/// with a warning) and lane sections.
fn lanes(cx: &mut Ctx, c: Node, path: &str, r: &mut Road) -> R<()> {
    for (i, e) in c.elements().enumerate() {
        match e.name() {
            "laneOffset" => {
                let p = format!("{path}/lanes/laneOffset");
                let o = cx.cubic(e, &p, "s")?;
                if o.s < 0.0 {
                    cx.warn(e, &p, format!("s = {} is negative: the offset is taken to apply from the road's start", o.s));
                }
                r.lane_offsets.push(o)
            }
            "laneSection" => {
                r.sections
                    .push(section(cx, e, &format!("{path}/lanes/laneSection[{i}]"))?)
            }
            _ => cx.skip(e, &format!("{path}/lanes")),
        }
    }
    Ok(())
}

/// A road's `<objects>`: each `<object>` with its place, heading and size.
fn objects(cx: &mut Ctx, c: Node, path: &str, out: &mut Vec<RoadObject>) -> R<()> {
    for (i, o) in c.elements().enumerate() {
        let p = format!("{path}/objects/object[{i}]");
        match o.name() {
            "object" => out.push(RoadObject {
                id: o.attribute("id").unwrap_or("").into(),
                kind: o.attribute("type").unwrap_or("none").into(),
                s: cx.req_f64(o, &p, "s")?,
                t: cx.req_f64(o, &p, "t")?,
                hdg: cx.f64_or(o, &p, "hdg", 0.0)?,
                length: cx.f64_or(o, &p, "length", 0.0)?,
                width: cx.f64_or(o, &p, "width", 0.0)?,
                radius: cx.f64_or(o, &p, "radius", 0.0)?,
            }),
            _ => cx.skip(o, &format!("{path}/objects")),
        }
    }
    Ok(())
}

/// A parsed road made consistent: records sorted by s, lane sections
/// clamped to the road's length; gaps in the reference line and a plan
/// view of another length than the road's are warnings.
fn tidy_road(cx: &mut Ctx, n: Node, path: &str, r: &mut Road) {
    r.plan_view.sort_by(|a, b| a.s.total_cmp(&b.s));
    r.elevation.sort_by(|a, b| a.s.total_cmp(&b.s));
    r.superelevation.sort_by(|a, b| a.s.total_cmp(&b.s));
    r.lane_offsets.sort_by(|a, b| a.s.total_cmp(&b.s));
    r.sections.sort_by(|a, b| a.s.total_cmp(&b.s));
    r.types.sort_by(|a, b| a.s.total_cmp(&b.s));
    for s in &mut r.sections {
        if s.s > r.length {
            cx.warn(
                n,
                path,
                format!(
                    "lane section at s = {} starts beyond the road length {}; clamped",
                    s.s, r.length
                ),
            );
            s.s = r.length;
        }
    }
    // Continuity of the reference line: gaps between pieces are warnings.
    for w in r.plan_view.windows(2) {
        let end = w[0].eval(w[0].length);
        let gap = ((end.x - w[1].x).powi(2) + (end.y - w[1].y).powi(2)).sqrt();
        if gap > 1e-3 {
            cx.warnings.push(Warning {
                line: cx.pos(n).0,
                path: path.to_string(),
                message: format!("reference line has a gap of {gap:.4} m at s = {:.3} (between pieces at s = {} and {})", w[1].s, w[0].s, w[1].s),
            });
        }
        let s_gap = (w[0].s + w[0].length - w[1].s).abs();
        if s_gap > 0.1 {
            cx.warnings.push(Warning {
                line: cx.pos(n).0,
                path: path.to_string(),
                message: format!(
                    "geometry at s = {} ends at s = {} but the next starts at s = {}",
                    w[0].s,
                    w[0].s + w[0].length,
                    w[1].s
                ),
            });
        }
    }
    let total: f64 = r.plan_view.last().map_or(0.0, |g| g.s + g.length);
    if (total - r.length).abs() > 0.1 {
        cx.warnings.push(Warning {
            line: cx.pos(n).0,
            path: path.to_string(),
            message: format!(
                "planView ends at s = {total:.3} but the road length is {}",
                r.length
            ),
        });
    }
}

fn geometry(cx: &mut Ctx, g: Node, path: &str) -> R<Geometry> {
    let s = cx.req_f64(g, path, "s")?;
    let x = cx.req_f64(g, path, "x")?;
    let y = cx.req_f64(g, path, "y")?;
    let hdg = cx.req_f64(g, path, "hdg")?;
    let length = cx.length(g, path)?;
    if length < 0.0 {
        return Err(cx.err(g, path, format!("length = {length} must not be negative")));
    }
    let shape_node = g
        .elements()
        .find(|c| matches!(c.name(), "line" | "arc" | "spiral" | "poly3" | "paramPoly3"));
    let Some(c) = shape_node else {
        let found: Vec<&str> = g.elements().map(|c| c.name()).collect();
        return Err(cx.err(
            g,
            path,
            format!("unknown geometry: expected one of line, arc, spiral, poly3, paramPoly3; found [{}]", found.join(", ")),
        ));
    };
    let p = format!("{path}/{}", c.name());
    let shape = match c.name() {
        "line" => Shape::Line,
        "arc" => Shape::Arc {
            curvature: cx.curvature(c, &p, "curvature")?,
        },
        "spiral" => Shape::Spiral {
            curv_start: cx.curvature(c, &p, "curvStart")?,
            curv_end: cx.curvature(c, &p, "curvEnd")?,
        },
        "poly3" => Shape::Poly3 {
            coef: [
                cx.f64_or(c, &p, "a", 0.0)?,
                cx.f64_or(c, &p, "b", 0.0)?,
                cx.f64_or(c, &p, "c", 0.0)?,
                cx.f64_or(c, &p, "d", 0.0)?,
            ],
        },
        _ => Shape::ParamPoly3 {
            u: [
                cx.f64_or(c, &p, "aU", 0.0)?,
                cx.f64_or(c, &p, "bU", 0.0)?,
                cx.f64_or(c, &p, "cU", 0.0)?,
                cx.f64_or(c, &p, "dU", 0.0)?,
            ],
            v: [
                cx.f64_or(c, &p, "aV", 0.0)?,
                cx.f64_or(c, &p, "bV", 0.0)?,
                cx.f64_or(c, &p, "cV", 0.0)?,
                cx.f64_or(c, &p, "dV", 0.0)?,
            ],
            normalized: c.attribute("pRange").map(str::trim) != Some("arcLength"),
        },
    };
    Ok(Geometry::new(s, x, y, hdg, length, shape))
}

fn section(cx: &mut Ctx, n: Node, path: &str) -> R<LaneSection> {
    let s0 = cx.req_f64(n, path, "s")?;
    if s0 < 0.0 {
        cx.warn(
            n,
            path,
            format!("s = {s0} is negative: the section is taken to start at the road's start"),
        );
    }
    let mut sec = LaneSection {
        s: s0,
        single_side: boolean(n.attribute("singleSide")),
        left: Vec::new(),
        center: None,
        right: Vec::new(),
    };
    for side in n.elements() {
        let side_name = side.name();
        if !matches!(side_name, "left" | "center" | "right") {
            cx.skip(side, path);
            continue;
        }
        for l in side.elements().filter(|l| l.name() == "lane") {
            let lp = format!(
                "{path}/{side_name}/lane[id={}]",
                l.attribute("id").unwrap_or("?")
            );
            let lane = lane(cx, l, &lp)?;
            let ok = match side_name {
                "left" => lane.id > 0,
                "right" => lane.id < 0,
                _ => lane.id == 0,
            };
            if !ok {
                return Err(cx.err(l, &lp, format!("lane id {} does not belong in <{side_name}> (left > 0, center = 0, right < 0)", lane.id)));
            }
            if lane.id != 0 && lane.widths.is_empty() && lane.borders.is_empty() {
                return Err(cx.err(
                    l,
                    &lp,
                    "lane has no <width> (or <border>) records: its extent is unknown",
                ));
            }
            match side_name {
                "left" => sec.left.push(lane),
                "right" => sec.right.push(lane),
                _ => sec.center = Some(lane),
            }
        }
    }
    sec.left.sort_by_key(|l| l.id);
    sec.right.sort_by_key(|l| std::cmp::Reverse(l.id));
    Ok(sec)
}

fn lane(cx: &mut Ctx, l: Node, path: &str) -> R<Lane> {
    let id = cx.req_i32(l, path, "id")?;
    // Lane ids count lanes from the centre: arithmetic on them (the lane
    // beside, the side's order) must not overflow.
    if id.unsigned_abs() > 1000 {
        return Err(cx.err(l, path, format!("lane id {id}: lane ids are within ±1000")));
    }
    let mut lane = Lane {
        id,
        kind: l.attribute("type").unwrap_or("none").trim().to_string(),
        level: boolean(l.attribute("level")),
        widths: Vec::new(),
        borders: Vec::new(),
        road_marks: Vec::new(),
        predecessor: None,
        successor: None,
        direction: l.attribute("direction").unwrap_or("standard").into(),
        max_speed: None,
    };
    // The children's paths (for messages) share one buffer: a lane has
    // several children and a town map tens of thousands of lanes.
    let mut p = String::with_capacity(path.len() + 16);
    for c in l.elements() {
        p.clear();
        p.push_str(path);
        p.push('/');
        p.push_str(c.name());
        match c.name() {
            "width" => {
                let w = cx.cubic(c, &p, "sOffset")?;
                if w.a < 0.0 {
                    cx.warn(
                        c,
                        &p,
                        format!(
                            "width a = {} is negative: the lane is taken as 0 m wide there",
                            w.a
                        ),
                    );
                }
                if w.s < 0.0 {
                    cx.warn(c, &p, format!("sOffset = {} is negative", w.s));
                }
                lane.widths.push(w)
            }
            "border" => {
                let b = cx.cubic(c, &p, "sOffset")?;
                if b.s < 0.0 {
                    cx.warn(c, &p, format!("sOffset = {} is negative", b.s));
                }
                lane.borders.push(b)
            }
            "roadMark" => lane.road_marks.push(RoadMark {
                s_offset: {
                    let o = cx.f64_or(c, &p, "sOffset", 0.0)?;
                    if o < 0.0 {
                        cx.warn(c, &p, format!("sOffset = {o} is negative"));
                    }
                    o
                },
                kind: c.attribute("type").unwrap_or("none").into(),
                color: c.attribute("color").unwrap_or("standard").into(),
                width: cx.f64_or(c, &p, "width", 0.12)?,
            }),
            "link" => {
                let base = p.len();
                for e in c.elements() {
                    p.truncate(base);
                    match e.name() {
                        which @ ("predecessor" | "successor") => {
                            p.push('/');
                            p.push_str(which);
                            let id = Some(cx.req_i32(e, &p, "id")?);
                            if which == "predecessor" {
                                lane.predecessor = id;
                            } else {
                                lane.successor = id;
                            }
                        }
                        _ => cx.skip(e, &p),
                    }
                }
            }
            "speed" => lane.max_speed = speed(c.attribute("max"), c.attribute("unit")),
            _ => cx.skip(c, path),
        }
    }
    // Duplicates with the same sOffset: the later record wins.
    lane.widths.sort_by(|a, b| a.s.total_cmp(&b.s));
    lane.widths.dedup_by(|later, earlier| {
        if later.s == earlier.s {
            *earlier = *later;
            true
        } else {
            false
        }
    });
    lane.borders.sort_by(|a, b| a.s.total_cmp(&b.s));
    Ok(lane)
}

fn signal(cx: &mut Ctx, s: Node, path: &str) -> R<Signal> {
    let validity = s.elements().find(|c| c.name() == "validity").map(|v| {
        let p = format!("{path}/validity");
        Ok::<_, MapError>((cx.req_i32(v, &p, "fromLane")?, cx.req_i32(v, &p, "toLane")?))
    });
    Ok(Signal {
        id: cx.req_str(s, path, "id")?,
        name: s.attribute("name").unwrap_or("").into(),
        s: cx.req_f64(s, path, "s")?,
        t: cx.req_f64(s, path, "t")?,
        dynamic: boolean(s.attribute("dynamic")),
        orientation: s.attribute("orientation").unwrap_or("none").into(),
        kind: s.attribute("type").unwrap_or("-1").into(),
        subtype: s.attribute("subtype").unwrap_or("-1").into(),
        country: s.attribute("country").unwrap_or("").into(),
        validity: validity.transpose()?,
    })
}

fn junction(cx: &mut Ctx, n: Node) -> R<Junction> {
    let path = format!(
        "OpenDRIVE/junction[id={}]",
        n.attribute("id").unwrap_or("?")
    );
    let mut j = Junction {
        id: cx.req_str(n, &path, "id")?,
        name: n.attribute("name").unwrap_or("").into(),
        kind: n.attribute("type").unwrap_or("default").into(),
        connections: Vec::new(),
        controllers: Vec::new(),
    };
    for c in n.elements() {
        match c.name() {
            "connection" => {
                let p = format!("{path}/connection[id={}]", c.attribute("id").unwrap_or("?"));
                let connecting = c
                    .attribute("connectingRoad")
                    .or(c.attribute("linkedRoad"))
                    .ok_or_else(|| {
                        cx.err(
                            c,
                            &p,
                            "missing required attribute 'connectingRoad' (or 'linkedRoad')",
                        )
                    })?;
                let at_start = match c.attribute("contactPoint").map(str::trim) {
                    Some("end") => false,
                    Some("start") | None => true,
                    Some(o) => {
                        return Err(cx.err(
                            c,
                            &p,
                            format!("contactPoint = '{o}', expected 'start' or 'end'"),
                        ));
                    }
                };
                let mut links = Vec::new();
                for l in c.elements().filter(|l| l.name() == "laneLink") {
                    let lp = format!("{p}/laneLink");
                    links.push((cx.req_i32(l, &lp, "from")?, cx.req_i32(l, &lp, "to")?));
                }
                j.connections.push(Connection {
                    id: c.attribute("id").unwrap_or("").into(),
                    incoming: cx.req_str(c, &p, "incomingRoad")?,
                    connecting: connecting.trim().into(),
                    at_start,
                    lane_links: links,
                });
            }
            "controller" => {
                j.controllers
                    .push(cx.req_str(c, &format!("{path}/controller"), "id")?)
            }
            _ => cx.skip(c, &path),
        }
    }
    Ok(j)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The line index gives the place roxmltree's own (scanning) lookup
    /// gives, for every element, with multi-byte characters and CRLF.
    #[test]
    fn positions_from_the_line_index_match_roxmltree() {
        let text = "<?xml version=\"1.0\"?>\r\n<!-- Straße ö -->\r\n<OpenDRIVE><header/>\n  <road id=\"ä\"><planView/></road>\r\n\n<x>  <ü a=\"1\"/><y/></x></OpenDRIVE>\n";
        let doc = roxmltree::Document::parse(text).unwrap();
        let cx = Ctx {
            text,
            line_starts: std::iter::once(0).chain(after_newlines(text)).collect(),
            file: String::new(),
            warnings: Vec::new(),
            skipped: BTreeMap::new(),
        };
        let mut n = 0;
        for node in doc.descendants().filter(|d| d.is_element()) {
            let want = doc.text_pos_at(node.range().start);
            assert_eq!(
                cx.pos_at(node.range().start),
                (want.row, want.col),
                "{:?}",
                node.tag_name()
            );
            n += 1;
        }
        assert_eq!(n, 7);
    }
}
