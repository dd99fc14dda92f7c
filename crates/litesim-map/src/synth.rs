//! Synthetic town maps: OpenDRIVE text of a grid city, written the way
//! published town maps are (OpenDRIVE 1.4, junctions with connecting roads
//! and lane links, lane offsets, several lane sections per road, sidewalks
//! and shoulders, road marks with all their attributes, elevation and
//! superelevation records, traffic lights with controllers, crosswalks).
//!
//! Why it exists: loading speed and memory must be measured on maps of the
//! size and shape users load (a 1.7 MB, 234-road town; a 200 MB region),
//! and such files cannot be shipped in the repository. [`town`] writes one
//! in a few milliseconds, deterministically: the same [`TownSpec`] gives the
//! same bytes.
//!
//! The map is geometrically exact: every connecting road starts where its
//! incoming road ends, with its heading, and ends where the outgoing road
//! starts, so the loader reports no gaps and the lane graph is complete.

use crate::geometry::{Geometry, Shape};
use litesim_core::math;
use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt::Write;

/// What [`town`] builds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TownSpec {
    /// Junctions along x.
    pub nx: usize,
    /// Junctions along y.
    pub ny: usize,
    /// Distance between neighbouring junction centres (m).
    pub spacing: f64,
    /// Stubs (the roads leaving the grid) that get a further road linked to
    /// their end, to reach an exact road count.
    pub extensions: usize,
}

impl TownSpec {
    /// The 1.7 MB, 234-road town of the load benchmark: 4 × 4 four-way
    /// junctions (192 connecting roads), 24 roads between them, 16 stubs and
    /// 2 extensions.
    pub fn city() -> Self {
        Self {
            nx: 4,
            ny: 4,
            spacing: 100.0,
            extensions: 2,
        }
    }

    /// A square town of about `bytes` bytes of OpenDRIVE text.
    pub fn of_size(bytes: usize) -> Self {
        // Bytes per junction with its share of the streets, measured on
        // larger towns (the stubs of small ones add a little).
        let per_junction = 98_000.0;
        let n = ((bytes as f64 / per_junction).sqrt().round() as usize).max(1);
        Self {
            nx: n,
            ny: n,
            spacing: 100.0,
            extensions: 0,
        }
    }

    /// Roads the map will have.
    pub fn road_count(&self) -> usize {
        let (nx, ny) = (self.nx, self.ny);
        12 * nx * ny
            + (nx - 1) * ny
            + nx * (ny - 1)
            + 2 * (nx + ny)
            + self.extensions.min(2 * (nx + ny))
    }
}

/// Half the size of a junction: its arms end this far from its centre (m).
const R: f64 = 15.0;
/// Stub length (m).
const STUB: f64 = 70.0;

/// Outward headings of a junction's arms: east, north, west, south.
const ARMS: [f64; 4] = [0.0, FRAC_PI_2, PI, 3.0 * FRAC_PI_2];

/// The road attached to one arm of a junction, and which of its ends is
/// there (true: its end; false: its start).
#[derive(Clone, Copy)]
struct Attach {
    road: usize,
    at_end: bool,
}

/// The town being written: the OpenDRIVE text so far, which road is on
/// each junction's arms, the next free road and signal ids, and each
/// junction's signals (for its controller).
struct Town {
    nx: usize,
    ny: usize,
    /// Distance between neighbouring junction centres (m).
    d: f64,
    out: String,
    /// arms[junction][arm] = the road there.
    arms: Vec<[Option<Attach>; 4]>,
    next_road: usize,
    next_signal: usize,
    junction_signals: Vec<Vec<usize>>,
}

/// Writes the OpenDRIVE text of a town (see the module doc).
pub fn town(spec: &TownSpec) -> String {
    let (nx, ny, d) = (spec.nx.max(1), spec.ny.max(1), spec.spacing.max(4.0 * R));
    let mut t = Town {
        nx,
        ny,
        d,
        out: String::with_capacity(spec.road_count() * 7_400 + 4_096),
        arms: vec![[None; 4]; nx * ny],
        next_road: 0,
        next_signal: 0,
        junction_signals: vec![Vec::new(); nx * ny],
    };
    t.header();
    t.streets();
    t.stubs(spec.extensions);
    let junctions = t.junctions();
    t.controllers();
    t.out.push_str(&junctions);
    t.out.push_str("</OpenDRIVE>\n");
    t.out
}

impl Town {
    fn junction_id(&self, i: usize, j: usize) -> usize {
        j * self.nx + i
    }

    fn center(&self, jn: usize) -> (f64, f64) {
        let (i, j) = (jn % self.nx, jn / self.nx);
        (i as f64 * self.d, j as f64 * self.d)
    }

    fn new_road(&mut self) -> usize {
        self.next_road += 1;
        self.next_road - 1
    }

    fn header(&mut self) {
        let (nx, ny, d) = (self.nx, self.ny, self.d);
        self.out
            .push_str("<?xml version=\"1.0\" standalone=\"yes\"?>\n<OpenDRIVE>\n");
        let _ = writeln!(
            self.out,
            "    <header revMajor=\"1\" revMinor=\"4\" name=\"litesim synthetic town\" version=\"1\" date=\"2026-11-25\" north=\"{}\" south=\"{}\" east=\"{}\" west=\"{}\" vendor=\"litesim\">",
            (ny - 1) as f64 * d + R + STUB + 60.0,
            -(R + STUB + 60.0),
            (nx - 1) as f64 * d + R + STUB + 60.0,
            -(R + STUB + 60.0),
        );
        self.out.push_str("        <geoReference><![CDATA[+proj=tmerc +lat_0=49 +lon_0=8 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs]]></geoReference>\n    </header>\n");
    }

    /// Roads between neighbouring junctions: east-west (from a junction's
    /// east arm to the next one's west arm), then south-north.
    fn streets(&mut self) {
        let (nx, ny, d) = (self.nx, self.ny, self.d);
        for (dx, dy, h) in [(1, 0, 0.0), (0, 1, FRAC_PI_2)] {
            // The arm the road leaves from; the opposite arm is two further.
            let arm = dy;
            for j in 0..ny - dy {
                for i in 0..nx - dx {
                    let (a, b) = (self.junction_id(i, j), self.junction_id(i + dx, j + dy));
                    let (cx, cy) = self.center(a);
                    let id = self.new_road();
                    self.arms[a][arm] = Some(Attach {
                        road: id,
                        at_end: false,
                    });
                    self.arms[b][arm + 2] = Some(Attach {
                        road: id,
                        at_end: true,
                    });
                    let sig = street(
                        &mut self.out,
                        id,
                        (cx + R * dx as f64, cy + R * dy as f64),
                        h,
                        d - 2.0 * R,
                        (Some(a), Some(b)),
                        None,
                        &mut self.next_signal,
                    );
                    self.junction_signals[a].push(sig.0.expect("both ends at junctions"));
                    self.junction_signals[b].push(sig.1.expect("both ends at junctions"));
                }
            }
        }
    }

    /// Stubs on every free arm, leaving the grid; the first `extensions` of
    /// them continue into one more road.
    fn stubs(&mut self, extensions: usize) {
        let mut extensions_left = extensions;
        for jn in 0..self.nx * self.ny {
            let (cx, cy) = self.center(jn);
            for (k, &h) in ARMS.iter().enumerate() {
                if self.arms[jn][k].is_some() {
                    continue;
                }
                let id = self.new_road();
                self.arms[jn][k] = Some(Attach {
                    road: id,
                    at_end: false,
                });
                let ext = (extensions_left > 0).then(|| {
                    extensions_left -= 1;
                    self.new_road()
                });
                let (hs, hc) = math::sin_cos(h);
                let start = (cx + R * hc, cy + R * hs);
                let sig = stub(&mut self.out, id, start, h, jn, ext, &mut self.next_signal);
                self.junction_signals[jn].push(sig);
                if let Some(e) = ext {
                    let (ex, ey, eh) = stub_end(start, h);
                    street(
                        &mut self.out,
                        e,
                        (ex, ey),
                        eh,
                        60.0,
                        (None, None),
                        Some(id),
                        &mut self.next_signal,
                    );
                }
            }
        }
    }

    /// Connecting roads (written to the text) and the `<junction>` elements
    /// (returned: they follow the controllers in the file).
    fn junctions(&mut self) -> String {
        let mut junctions = String::new();
        for jn in 0..self.nx * self.ny {
            let (cx, cy) = self.center(jn);
            let _ = writeln!(
                junctions,
                "    <junction id=\"{jn}\" name=\"Junction {jn}\">"
            );
            let mut connection = 0;
            for (from, &o) in ARMS.iter().enumerate() {
                let inc = self.arms[jn][from].expect("every arm has a road");
                let (os, oc) = math::sin_cos(o);
                let start = (cx + R * oc, cy + R * os);
                let travel = o + PI;
                // Straight, right, left: the arm each leads to and its curvature.
                for (to, curvature) in [
                    ((from + 2) % 4, 0.0),
                    ((from + 1) % 4, -1.0 / R),
                    ((from + 3) % 4, 1.0 / R),
                ] {
                    let out_road = self.arms[jn][to].expect("every arm has a road");
                    let id = self.new_road();
                    connecting(
                        &mut self.out,
                        id,
                        jn,
                        start,
                        travel,
                        curvature,
                        inc,
                        out_road,
                    );
                    let _ = writeln!(
                        junctions,
                        "        <connection id=\"{connection}\" incomingRoad=\"{}\" connectingRoad=\"{id}\" contactPoint=\"start\">",
                        inc.road
                    );
                    let sign = if inc.at_end { -1 } else { 1 };
                    for l in 1..=2 {
                        let _ = writeln!(
                            junctions,
                            "            <laneLink from=\"{}\" to=\"-{l}\"/>",
                            sign * l
                        );
                    }
                    junctions.push_str("        </connection>\n");
                    connection += 1;
                }
            }
            let _ = writeln!(
                junctions,
                "        <controller id=\"{jn}\" type=\"0\" sequence=\"1\"/>\n    </junction>"
            );
        }
        junctions
    }

    /// One signal controller per junction, over the signals at its arms.
    fn controllers(&mut self) {
        for (jn, sigs) in self.junction_signals.iter().enumerate() {
            let _ = writeln!(
                self.out,
                "    <controller id=\"{jn}\" name=\"Controller {jn}\" sequence=\"1\">"
            );
            for s in sigs {
                let _ = writeln!(self.out, "        <control signalId=\"{s}\" type=\"0\"/>");
            }
            self.out.push_str("    </controller>\n");
        }
    }
}

/// A stub's three pieces from `start` along `h` (see [`stub`]): line
/// 30 m, spiral 0 → 0.02 over 20 m, arc 0.02 over 20 m, each starting where
/// the previous ends, evaluated by the loader's own geometry.
fn stub_pieces(start: (f64, f64), h: f64) -> [Geometry; 3] {
    let line = Geometry::new(0.0, start.0, start.1, h, 30.0, Shape::Line);
    let a = line.eval(30.0);
    let spiral = Geometry::new(
        30.0,
        a.x,
        a.y,
        a.hdg,
        20.0,
        Shape::Spiral {
            curv_start: 0.0,
            curv_end: 0.02,
        },
    );
    let b = spiral.eval(20.0);
    let arc = Geometry::new(50.0, b.x, b.y, b.hdg, 20.0, Shape::Arc { curvature: 0.02 });
    [line, spiral, arc]
}

/// Where a stub ends and its heading there.
fn stub_end(start: (f64, f64), h: f64) -> (f64, f64, f64) {
    let e = stub_pieces(start, h)[2].eval(20.0);
    (e.x, e.y, e.hdg)
}

/// The point `len` metres along heading `h` from `(x, y)`.
fn after_line(x: f64, y: f64, h: f64, len: f64) -> (f64, f64) {
    let (hs, hc) = math::sin_cos(h);
    (x + len * hc, y + len * hs)
}

fn link_xml(out: &mut String, pred: &str, succ: &str) {
    let _ = writeln!(out, "        <link>{pred}{succ}</link>");
}

/// A lane with its width, marks, link and speed, as town maps write it.
#[allow(clippy::too_many_arguments)]
fn lane_xml(
    out: &mut String,
    id: i32,
    kind: &str,
    width: f64,
    mark: &str,
    pred: Option<i32>,
    succ: Option<i32>,
    speed: bool,
) {
    let _ = writeln!(
        out,
        "                    <lane id=\"{id}\" type=\"{kind}\" level=\"false\">"
    );
    out.push_str("                        <link>");
    if let Some(p) = pred {
        let _ = write!(out, "<predecessor id=\"{p}\"/>");
    }
    if let Some(s) = succ {
        let _ = write!(out, "<successor id=\"{s}\"/>");
    }
    out.push_str("</link>\n");
    let _ = writeln!(
        out,
        "                        <width sOffset=\"0.0\" a=\"{width}\" b=\"0.0\" c=\"0.0\" d=\"0.0\"/>"
    );
    let _ = write!(
        out,
        "                        <roadMark sOffset=\"0.0\" type=\"{mark}\" material=\"standard\" color=\"{}\" width=\"{}\" laneChange=\"{}\" height=\"0.02\"",
        if kind == "driving" {
            "white"
        } else {
            "standard"
        },
        if mark == "none" { 0.0 } else { 0.15 },
        if mark == "broken" { "both" } else { "none" },
    );
    // Marks with paint carry their line pattern (OpenDRIVE 1.4 <type>).
    match mark {
        "none" => out.push_str("/>\n"),
        _ => {
            let (len, space) = if mark == "broken" {
                (3.0, 6.0)
            } else {
                (0.0, 0.0)
            };
            let _ = writeln!(
                out,
                ">\n                            <type name=\"{mark}\" width=\"0.15\">\n                                <line length=\"{len}\" space=\"{space}\" tOffset=\"0.0\" sOffset=\"0.0\" rule=\"none\" width=\"0.15\"/>\n                            </type>\n                        </roadMark>"
            );
        }
    }
    // Authoring tools keep their own lane ids beside the map's.
    let _ = writeln!(
        out,
        "                        <userData>\n                            <vectorLane sOffset=\"0.0\" laneId=\"{{{:08x}-{:04x}-4000-8000-{:012x}}}\" travelDir=\"{}\"/>\n                        </userData>",
        (id.unsigned_abs() as usize).wrapping_mul(2_654_435_761) & 0xffff_ffff,
        width.to_bits() as usize & 0xffff,
        out.len(),
        if id < 0 { "forward" } else { "backward" },
    );
    if speed {
        out.push_str("                        <speed sOffset=\"0.0\" max=\"50\" unit=\"km/h\"/>\n");
    }
    if kind == "sidewalk" {
        out.push_str(
            "                        <height sOffset=\"0.0\" inner=\"0.15\" outer=\"0.15\"/>\n",
        );
    }
    out.push_str("                    </lane>\n");
}

/// The lanes of a street's section: sidewalk, shoulder and two driving
/// lanes on each side. `link(id)` gives the lane's neighbour ids.
fn street_lanes(
    out: &mut String,
    s: f64,
    pred: impl Fn(i32) -> Option<i32>,
    succ: impl Fn(i32) -> Option<i32>,
) {
    let _ = writeln!(
        out,
        "            <laneSection s=\"{s}\">\n                <left>"
    );
    // One side's lanes, outermost first on the left, innermost first on
    // the right (file order of published maps).
    let side = |out: &mut String, lanes: [(i32, &str, f64, &str); 4]| {
        for (id, kind, w, mark) in lanes {
            let speed = kind == "driving";
            lane_xml(out, id, kind, w, mark, pred(id), succ(id), speed);
        }
    };
    side(
        out,
        [
            (4, "sidewalk", 2.0, "none"),
            (3, "shoulder", 0.5, "solid"),
            (2, "driving", 3.5, "broken"),
            (1, "driving", 3.25, "broken"),
        ],
    );
    out.push_str("                </left>\n                <center>\n                    <lane id=\"0\" type=\"none\" level=\"false\">\n                        <link/>\n                        <roadMark sOffset=\"0.0\" type=\"solid solid\" material=\"standard\" color=\"yellow\" width=\"0.15\" laneChange=\"none\" height=\"0.02\"/>\n                    </lane>\n                </center>\n                <right>\n");
    side(
        out,
        [
            (-1, "driving", 3.25, "broken"),
            (-2, "driving", 3.5, "solid"),
            (-3, "shoulder", 0.5, "solid"),
            (-4, "sidewalk", 2.0, "none"),
        ],
    );
    out.push_str("                </right>\n            </laneSection>\n");
}

/// A street's four lane sections, each lane linked to its namesake in
/// the next section; at the road's ends only when `pred` / `succ` (a road
/// continues there, not a junction).
fn sections(out: &mut String, len: f64, pred: bool, succ: bool) {
    const SECTIONS: usize = 4;
    for k in 0..SECTIONS {
        let first = k == 0;
        let last = k + 1 == SECTIONS;
        street_lanes(
            out,
            len * k as f64 / SECTIONS as f64,
            |l| (!first || pred).then_some(l),
            |l| (!last || succ).then_some(l),
        );
    }
}

fn profiles(out: &mut String, len: f64) {
    let h = len / 2.0;
    let _ = writeln!(
        out,
        "        <elevationProfile>\n            <elevation s=\"0.0\" a=\"0.0\" b=\"0.0\" c=\"{}\" d=\"{}\"/>\n            <elevation s=\"{h}\" a=\"0.3\" b=\"0.0\" c=\"{}\" d=\"{}\"/>\n        </elevationProfile>\n        <lateralProfile>\n            <superelevation s=\"0.0\" a=\"0.0\" b=\"0.0\" c=\"0.0\" d=\"0.0\"/>\n        </lateralProfile>",
        0.9 / (h * h),
        -0.6 / (h * h * h),
        -0.9 / (h * h),
        0.6 / (h * h * h),
    );
}

/// A lane offset that moves the lanes 0.25 m to the left in the middle of
/// the road and is zero at both ends (so junctions meet the lanes exactly).
fn lane_offset(out: &mut String, len: f64) {
    let (h, m) = (len / 2.0, 0.25);
    let _ = writeln!(
        out,
        "            <laneOffset s=\"0.0\" a=\"0.0\" b=\"0.0\" c=\"{}\" d=\"{}\"/>\n            <laneOffset s=\"{h}\" a=\"{m}\" b=\"0.0\" c=\"{}\" d=\"{}\"/>",
        3.0 * m / (h * h),
        -2.0 * m / (h * h * h),
        -3.0 * m / (h * h),
        2.0 * m / (h * h * h),
    );
}

fn junction_link(tag: &str, j: Option<usize>) -> String {
    j.map_or(String::new(), |j| {
        format!("<{tag} elementType=\"junction\" elementId=\"{j}\"/>")
    })
}

/// A straight street of two lane sections from `start` along `h`; its
/// start and end are at the given junctions (or at `pred_road`'s end).
/// Returns the ids of the traffic lights facing each junction.
#[allow(clippy::too_many_arguments)]
fn street(
    out: &mut String,
    id: usize,
    start: (f64, f64),
    h: f64,
    len: f64,
    ends: (Option<usize>, Option<usize>),
    pred_road: Option<usize>,
    next_signal: &mut usize,
) -> (Option<usize>, Option<usize>) {
    let _ = writeln!(
        out,
        "    <road name=\"Street {id}\" length=\"{len}\" id=\"{id}\" junction=\"-1\">"
    );
    let pred = match pred_road {
        Some(p) => {
            format!("<predecessor elementType=\"road\" elementId=\"{p}\" contactPoint=\"end\"/>")
        }
        None => junction_link("predecessor", ends.0),
    };
    link_xml(out, &pred, &junction_link("successor", ends.1));
    out.push_str("        <type s=\"0.0\" type=\"town\">\n            <speed max=\"50\" unit=\"km/h\"/>\n        </type>\n");
    let half = len / 2.0;
    let (mx, my) = after_line(start.0, start.1, h, half);
    let _ = writeln!(
        out,
        "        <planView>\n            <geometry s=\"0.0\" x=\"{}\" y=\"{}\" hdg=\"{h}\" length=\"{half}\">\n                <line/>\n            </geometry>\n            <geometry s=\"{half}\" x=\"{mx}\" y=\"{my}\" hdg=\"{h}\" length=\"{half}\">\n                <paramPoly3 aU=\"0.0\" bU=\"{half}\" cU=\"0.0\" dU=\"0.0\" aV=\"0.0\" bV=\"0.0\" cV=\"0.0\" dV=\"0.0\" pRange=\"normalized\"/>\n            </geometry>\n        </planView>",
        start.0, start.1
    );
    profiles(out, len);
    out.push_str("        <lanes>\n");
    lane_offset(out, len);
    // Within the road, each lane continues into the same id.
    sections(out, len, pred_road.is_some(), false);
    out.push_str("        </lanes>\n        <objects>\n");
    for (k, s) in [(0, 2.0), (1, len - 2.0)] {
        let _ = writeln!(
            out,
            "            <object id=\"{}\" name=\"crosswalk\" type=\"crosswalk\" s=\"{s}\" t=\"0.0\" zOffset=\"0.0\" hdg=\"0.0\" orientation=\"none\" length=\"4.0\" width=\"14.5\" height=\"0.0\" roll=\"0.0\" pitch=\"0.0\"/>",
            2 * id + k
        );
    }
    out.push_str("        </objects>\n        <signals>\n");
    let mut lights = (None, None);
    if ends.0.is_some() {
        // Facing traffic that drives to the start (on the left lanes).
        lights.0 = Some(signal_xml(out, next_signal, 3.0, 9.0, "-", (1, 2)));
    }
    if ends.1.is_some() {
        lights.1 = Some(signal_xml(out, next_signal, len - 3.0, -9.0, "+", (-2, -1)));
    }
    out.push_str("        </signals>\n    </road>\n");
    lights
}

fn signal_xml(
    out: &mut String,
    next: &mut usize,
    s: f64,
    t: f64,
    orientation: &str,
    lanes: (i32, i32),
) -> usize {
    let id = *next;
    *next += 1;
    let _ = writeln!(
        out,
        "            <signal s=\"{s}\" t=\"{t}\" id=\"{id}\" name=\"Signal_3Light_{id}\" dynamic=\"yes\" orientation=\"{orientation}\" zOffset=\"0.0\" country=\"OpenDRIVE\" type=\"1000001\" subtype=\"-1\" value=\"-1\" height=\"1.0\" width=\"0.3\" hOffset=\"0.0\" pitch=\"0.0\" roll=\"0.0\">\n                <validity fromLane=\"{}\" toLane=\"{}\"/>\n            </signal>",
        lanes.0, lanes.1
    );
    id
}

/// A stub leaving junction `jn` at its arm `start` along `h`: a line, a
/// spiral and an arc; its start is at the junction. Returns its light.
fn stub(
    out: &mut String,
    id: usize,
    start: (f64, f64),
    h: f64,
    jn: usize,
    ext: Option<usize>,
    next_signal: &mut usize,
) -> usize {
    let _ = writeln!(
        out,
        "    <road name=\"Stub {id}\" length=\"{STUB}\" id=\"{id}\" junction=\"-1\">"
    );
    let succ = ext.map_or(String::new(), |e| {
        format!("<successor elementType=\"road\" elementId=\"{e}\" contactPoint=\"start\"/>")
    });
    link_xml(out, &junction_link("predecessor", Some(jn)), &succ);
    out.push_str("        <type s=\"0.0\" type=\"town\">\n            <speed max=\"50\" unit=\"km/h\"/>\n        </type>\n");
    let [_, spiral, arc] = stub_pieces(start, h);
    let (lx, ly, x, y, hd) = (spiral.x, spiral.y, arc.x, arc.y, arc.hdg);
    let _ = writeln!(
        out,
        "        <planView>\n            <geometry s=\"0.0\" x=\"{}\" y=\"{}\" hdg=\"{h}\" length=\"30.0\">\n                <line/>\n            </geometry>\n            <geometry s=\"30.0\" x=\"{lx}\" y=\"{ly}\" hdg=\"{h}\" length=\"20.0\">\n                <spiral curvStart=\"0.0\" curvEnd=\"0.02\"/>\n            </geometry>\n            <geometry s=\"50.0\" x=\"{x}\" y=\"{y}\" hdg=\"{hd}\" length=\"20.0\">\n                <arc curvature=\"0.02\"/>\n            </geometry>\n        </planView>",
        start.0, start.1
    );
    profiles(out, STUB);
    out.push_str("        <lanes>\n");
    lane_offset(out, STUB);
    sections(out, STUB, false, ext.is_some());
    out.push_str("        </lanes>\n        <signals>\n");
    let light = signal_xml(out, next_signal, 3.0, 9.0, "-", (1, 2));
    out.push_str("        </signals>\n    </road>\n");
    light
}

/// A connecting road of junction `jn` from `start` along `h`: a straight
/// (paramPoly3) or a quarter arc of radius [`R`], with two lanes linked to
/// the incoming and outgoing roads' lanes.
#[allow(clippy::too_many_arguments)]
fn connecting(
    out: &mut String,
    id: usize,
    jn: usize,
    start: (f64, f64),
    h: f64,
    curvature: f64,
    inc: Attach,
    outr: Attach,
) {
    let len = if curvature == 0.0 {
        2.0 * R
    } else {
        FRAC_PI_2 * R
    };
    let _ = writeln!(
        out,
        "    <road name=\"Road {id}\" length=\"{len}\" id=\"{id}\" junction=\"{jn}\">"
    );
    let contact = |a: Attach| if a.at_end { "end" } else { "start" };
    link_xml(
        out,
        &format!(
            "<predecessor elementType=\"road\" elementId=\"{}\" contactPoint=\"{}\"/>",
            inc.road,
            contact(inc)
        ),
        &format!(
            "<successor elementType=\"road\" elementId=\"{}\" contactPoint=\"{}\"/>",
            outr.road,
            contact(outr)
        ),
    );
    out.push_str("        <type s=\"0.0\" type=\"town\">\n            <speed max=\"30\" unit=\"km/h\"/>\n        </type>\n        <planView>\n");
    if curvature == 0.0 {
        let _ = writeln!(
            out,
            "            <geometry s=\"0.0\" x=\"{}\" y=\"{}\" hdg=\"{h}\" length=\"{len}\">\n                <paramPoly3 aU=\"0.0\" bU=\"{len}\" cU=\"0.0\" dU=\"0.0\" aV=\"0.0\" bV=\"0.0\" cV=\"0.0\" dV=\"0.0\" pRange=\"normalized\"/>\n            </geometry>",
            start.0, start.1
        );
    } else {
        let _ = writeln!(
            out,
            "            <geometry s=\"0.0\" x=\"{}\" y=\"{}\" hdg=\"{h}\" length=\"{len}\">\n                <arc curvature=\"{curvature}\"/>\n            </geometry>",
            start.0, start.1
        );
    }
    out.push_str("        </planView>\n");
    profiles(out, len);
    out.push_str("        <lanes>\n            <laneOffset s=\"0.0\" a=\"0.0\" b=\"0.0\" c=\"0.0\" d=\"0.0\"/>\n            <laneSection s=\"0.0\">\n                <center>\n                    <lane id=\"0\" type=\"none\" level=\"false\">\n                        <link/>\n                        <roadMark sOffset=\"0.0\" type=\"none\" material=\"standard\" color=\"standard\" width=\"0.0\" laneChange=\"none\" height=\"0.0\"/>\n                    </lane>\n                </center>\n                <right>\n");
    let in_sign = if inc.at_end { -1 } else { 1 };
    let out_sign = if outr.at_end { 1 } else { -1 };
    for l in 1..=2 {
        lane_xml(
            out,
            -l,
            "driving",
            if l == 1 { 3.25 } else { 3.5 },
            "none",
            Some(in_sign * l),
            Some(out_sign * l),
            true,
        );
    }
    out.push_str(
        "                </right>\n            </laneSection>\n        </lanes>\n    </road>\n",
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RoadNetwork;

    #[test]
    fn the_city_has_234_roads_and_loads_without_gaps() {
        let spec = TownSpec::city();
        assert_eq!(spec.road_count(), 234);
        let text = town(&spec);
        assert_eq!(text, town(&spec), "deterministic");
        let net = RoadNetwork::from_xodr(&text, "town.xodr").unwrap();
        assert_eq!(net.roads().len(), 234);
        let gaps: Vec<_> = net
            .warnings
            .iter()
            .filter(|w| !w.message.contains("not interpreted"))
            .collect();
        assert!(gaps.is_empty(), "{gaps:#?}");
    }
}

/// What [`highway`] builds: a straight one-way road.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HighwaySpec {
    /// Length (m).
    pub length: f64,
    /// Driving lanes (right side, ids −1 … −lanes).
    pub lanes: u32,
    /// Lane width (m).
    pub lane_width: f64,
    /// Where the outermost lane ends (a lane drop: a second lane section
    /// with one lane fewer from there on); `None`: no drop.
    pub drop_at: Option<f64>,
}

/// A straight one-way multi-lane road (right-hand traffic along +x), with
/// an optional lane drop: the map of the traffic engine's tests and
/// benchmarks (a 6 km three-lane road is a few hundred bytes).
pub fn highway(spec: &HighwaySpec) -> String {
    let HighwaySpec {
        length,
        lanes,
        lane_width,
        drop_at,
    } = *spec;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<OpenDRIVE>\n  <header revMajor=\"1\" revMinor=\"6\" name=\"highway\" vendor=\"litesim\"/>\n  <road id=\"1\" name=\"highway\" length=\"{length}\" junction=\"-1\" rule=\"RHT\">\n    <link></link>\n    <type s=\"0\" type=\"motorway\"><speed max=\"130\" unit=\"km/h\"/></type>\n    <planView>\n      <geometry s=\"0.0\" x=\"0.0\" y=\"0.0\" hdg=\"0.0\" length=\"{length}\"><line/></geometry>\n    </planView>\n    <lanes>"
    );
    let mut section = |s: f64, n: u32, linked: bool| {
        let _ = writeln!(
            out,
            "      <laneSection s=\"{s}\">\n        <center><lane id=\"0\" type=\"none\" level=\"false\"/></center>\n        <right>"
        );
        for k in 1..=n {
            let link = if linked && k < lanes {
                format!("<link><successor id=\"-{k}\"/></link>")
            } else {
                String::new()
            };
            let _ = writeln!(
                out,
                "          <lane id=\"-{k}\" type=\"driving\" level=\"false\">{link}<width sOffset=\"0\" a=\"{lane_width}\" b=\"0\" c=\"0\" d=\"0\"/><roadMark sOffset=\"0\" type=\"broken\" color=\"standard\" width=\"0.12\"/></lane>"
            );
        }
        let _ = writeln!(out, "        </right>\n      </laneSection>");
    };
    match drop_at {
        Some(at) if at > 0.0 && at < length && lanes > 1 => {
            section(0.0, lanes, true);
            section(at, lanes - 1, false);
        }
        _ => section(0.0, lanes, false),
    }
    let _ = writeln!(out, "    </lanes>\n  </road>\n</OpenDRIVE>");
    out
}
