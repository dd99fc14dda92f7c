//! The parsed OpenDRIVE model (1.4–1.8), in SI units, records sorted by s.

use crate::geometry::Geometry;
use serde::{Deserialize, Serialize};

/// A cubic `a + b·ds + c·ds² + d·ds³` valid from `s` on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Cubic {
    /// Start (m): road s, or sOffset within a lane section.
    pub s: f64,
    /// Coefficients.
    pub a: f64,
    /// b.
    pub b: f64,
    /// c.
    pub c: f64,
    /// d.
    pub d: f64,
}

impl Cubic {
    /// Value at `ds` from the record's start.
    pub fn at(&self, ds: f64) -> f64 {
        self.a + ds * (self.b + ds * (self.c + ds * self.d))
    }
    /// Derivative at `ds`.
    pub fn slope(&self, ds: f64) -> f64 {
        self.b + ds * (2.0 * self.c + 3.0 * ds * self.d)
    }
}

/// Evaluates a list of cubics (sorted by `s`) at `s`: the last record with
/// start ≤ s applies; before the first record the value is 0.
pub fn eval_cubics(records: &[Cubic], s: f64) -> (f64, f64) {
    let i = records.partition_point(|r| r.s <= s);
    if i == 0 {
        return (0.0, 0.0);
    }
    let r = &records[i - 1];
    (r.at(s - r.s), r.slope(s - r.s))
}

/// Traffic rule.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Rule {
    /// Right-hand traffic.
    #[default]
    Rht,
    /// Left-hand traffic.
    Lht,
}

/// What a road link points at.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum LinkTarget {
    /// A road and the end of it that touches.
    Road {
        /// Road id.
        id: String,
        /// True when its start touches, false for its end.
        at_start: bool,
    },
    /// A junction.
    Junction(String),
}

/// A road-type record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoadType {
    /// Start (m).
    pub s: f64,
    /// Type name (`town`, `motorway`, …).
    pub kind: String,
    /// Speed limit (m/s), if given as a number.
    pub max_speed: Option<f64>,
}

/// A road mark on a lane's outer border.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoadMark {
    /// Offset within the lane section (m).
    pub s_offset: f64,
    /// `solid`, `broken`, `solid solid`, …
    pub kind: String,
    /// Colour (`standard` = white).
    pub color: String,
    /// Width (m).
    pub width: f64,
}

/// A lane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lane {
    /// Id (> 0 left, < 0 right, 0 centre).
    pub id: i32,
    /// Type (`driving`, `sidewalk`, …; unknown strings kept).
    pub kind: String,
    /// Kept horizontal under superelevation.
    pub level: bool,
    /// Width records (sOffset in `s`), sorted.
    pub widths: Vec<Cubic>,
    /// Border records (outer edge t), used when there are no widths.
    pub borders: Vec<Cubic>,
    /// Road marks.
    pub road_marks: Vec<RoadMark>,
    /// Predecessor lane id.
    pub predecessor: Option<i32>,
    /// Successor lane id.
    pub successor: Option<i32>,
    /// 1.8 `direction` (`standard`, `reversed`, `both`).
    pub direction: String,
    /// Speed limit (m/s).
    pub max_speed: Option<f64>,
}

impl Lane {
    /// True for lane types a vehicle may drive in.
    pub fn is_drivable(&self) -> bool {
        is_drivable_kind(&self.kind)
    }
}

/// True for OpenDRIVE lane types a vehicle may drive in.
pub fn is_drivable_kind(kind: &str) -> bool {
    matches!(
        kind,
        "driving"
            | "entry"
            | "exit"
            | "onRamp"
            | "offRamp"
            | "connectingRamp"
            | "slipLane"
            | "bidirectional"
            | "mwyEntry"
            | "mwyExit"
    )
}

/// A lane section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaneSection {
    /// Start along the road (m).
    pub s: f64,
    /// Applies to one side only.
    pub single_side: bool,
    /// Left lanes, ordered outward (1, 2, …).
    pub left: Vec<Lane>,
    /// The centre lane.
    pub center: Option<Lane>,
    /// Right lanes, ordered outward (−1, −2, …).
    pub right: Vec<Lane>,
}

/// A signal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Signal {
    /// Id (unique per road only).
    pub id: String,
    /// Name.
    pub name: String,
    /// s (m).
    pub s: f64,
    /// t (m).
    pub t: f64,
    /// Dynamic (traffic light, VMS).
    pub dynamic: bool,
    /// `+`, `-` or `none`.
    pub orientation: String,
    /// Type code.
    pub kind: String,
    /// Subtype.
    pub subtype: String,
    /// Country.
    pub country: String,
    /// Lanes it applies to (from, to).
    pub validity: Option<(i32, i32)>,
}

/// A road object (obstacle footprint).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoadObject {
    /// Id.
    pub id: String,
    /// Type.
    pub kind: String,
    /// s (m).
    pub s: f64,
    /// t (m).
    pub t: f64,
    /// Heading relative to the road (rad).
    pub hdg: f64,
    /// Length (m).
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// Radius (m) for round objects.
    pub radius: f64,
}

/// A road.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Road {
    /// Id as in the file.
    pub id: String,
    /// Name.
    pub name: String,
    /// Reference-line length (m).
    pub length: f64,
    /// Junction id, `None` for "-1".
    pub junction: Option<String>,
    /// Traffic rule.
    pub rule: Rule,
    /// Predecessor.
    pub predecessor: Option<LinkTarget>,
    /// Successor.
    pub successor: Option<LinkTarget>,
    /// Road types.
    pub types: Vec<RoadType>,
    /// Reference line pieces, sorted by s.
    pub plan_view: Vec<Geometry>,
    /// Elevation records.
    pub elevation: Vec<Cubic>,
    /// Superelevation records (rad).
    pub superelevation: Vec<Cubic>,
    /// Lane offsets.
    pub lane_offsets: Vec<Cubic>,
    /// Lane sections, sorted by s.
    pub sections: Vec<LaneSection>,
    /// Signals.
    pub signals: Vec<Signal>,
    /// Objects.
    pub objects: Vec<RoadObject>,
}

/// A connection through a junction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Connection {
    /// Id.
    pub id: String,
    /// Incoming road.
    pub incoming: String,
    /// Connecting (or, in direct junctions, linked) road.
    pub connecting: String,
    /// True when the connecting road is entered at its start.
    pub at_start: bool,
    /// (from lane on incoming, to lane on connecting).
    pub lane_links: Vec<(i32, i32)>,
}

/// A junction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Junction {
    /// Id.
    pub id: String,
    /// Name.
    pub name: String,
    /// `default`, `direct`, `virtual`, `crossing`.
    pub kind: String,
    /// Connections.
    pub connections: Vec<Connection>,
    /// Signal controllers used.
    pub controllers: Vec<String>,
}

/// A signal controller (a group of signals sharing one cycle).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Controller {
    /// Id.
    pub id: String,
    /// Name.
    pub name: String,
    /// Signal ids controlled.
    pub signals: Vec<String>,
}

/// The header.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// revMajor.
    pub rev_major: u32,
    /// revMinor.
    pub rev_minor: u32,
    /// Name.
    pub name: String,
    /// Vendor.
    pub vendor: String,
    /// geoReference text (PROJ string), kept verbatim.
    pub geo_reference: Option<String>,
    /// `<offset x y z hdg>`.
    pub offset: Option<[f64; 4]>,
}

/// A whole OpenDRIVE file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OpenDrive {
    /// Header.
    pub header: Header,
    /// Roads in file order.
    pub roads: Vec<Road>,
    /// Junctions.
    pub junctions: Vec<Junction>,
    /// Controllers.
    pub controllers: Vec<Controller>,
}
