//! Evaluation on one road: reference pose, lane offset, lane boundaries, (s, t) → (x, y, z).

use crate::geometry::RefPoint;
use crate::model::{Lane, LaneSection, Road, Rule, eval_cubics};
use litesim_core::math;

/// Lateral extent of a lane at some s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneSpan {
    /// Lane id.
    pub id: i32,
    /// Inner boundary t (m, towards the centre lane).
    pub t_inner: f64,
    /// Outer boundary t (m).
    pub t_outer: f64,
}

impl LaneSpan {
    /// Centre t (m).
    pub fn t_center(&self) -> f64 {
        0.5 * (self.t_inner + self.t_outer)
    }
    /// Width (m), never negative.
    pub fn width(&self) -> f64 {
        (self.t_outer - self.t_inner).abs()
    }
    /// True when `t` lies within the lane.
    pub fn contains(&self, t: f64) -> bool {
        let (lo, hi) = if self.t_inner <= self.t_outer {
            (self.t_inner, self.t_outer)
        } else {
            (self.t_outer, self.t_inner)
        };
        t >= lo && t <= hi
    }
}

/// Travel direction of a lane relative to the road's s.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// Along +s.
    Forward,
    /// Along −s.
    Backward,
    /// Either (bidirectional lanes, `direction="both"`).
    Both,
}

impl Road {
    /// Reference-line point at `s` (clamped to the road).
    pub fn reference(&self, s: f64) -> RefPoint {
        let s = s.clamp(0.0, self.length);
        let g = &self.plan_view[self.geometry_index(s)];
        g.eval(s - g.s)
    }

    /// Index of the plan-view geometry in force at `s` (the first before
    /// its start).
    pub fn geometry_index(&self, s: f64) -> usize {
        self.plan_view.partition_point(|g| g.s <= s).max(1) - 1
    }

    /// Lane offset of the centre lane and its slope at `s`.
    pub fn lane_offset(&self, s: f64) -> (f64, f64) {
        eval_cubics(&self.lane_offsets, s)
    }

    /// Elevation z (m) at `s`.
    pub fn elevation(&self, s: f64) -> f64 {
        eval_cubics(&self.elevation, s).0
    }

    /// Index of the lane section in force at `s`.
    pub fn section_index(&self, s: f64) -> usize {
        self.sections.partition_point(|x| x.s <= s).max(1) - 1
    }

    /// Sections for the left and right side at `s` (`singleSide` sections
    /// only replace their own side).
    fn sides(&self, s: f64) -> (&LaneSection, &LaneSection) {
        // Most roads have one section: it is both sides everywhere.
        if let [only] = &self.sections[..] {
            return (only, only);
        }
        let upto = self.sections.partition_point(|x| x.s <= s).max(1);
        (self.side_upto(upto, true), self.side_upto(upto, false))
    }

    /// The section in force for one side among the first `upto` sections:
    /// the last that is not `singleSide` or that has lanes on that side.
    fn side_upto(&self, upto: usize, left: bool) -> &LaneSection {
        self.sections[..upto]
            .iter()
            .rev()
            .find(|sec| {
                !sec.single_side
                    || if left {
                        !sec.left.is_empty()
                    } else {
                        !sec.right.is_empty()
                    }
            })
            .unwrap_or(&self.sections[0])
    }

    /// The section in force at `s` for lane `id`'s side (`s` in range):
    /// [`Road::sides`]' answer for that side, without the other.
    fn side_of(&self, s: f64, id: i32) -> &LaneSection {
        if let [only] = &self.sections[..] {
            return only;
        }
        let upto = self.sections.partition_point(|x| x.s <= s).max(1);
        self.side_upto(upto, id > 0)
    }

    /// The lane spans at `s`, left lanes (outward) then right lanes (outward).
    pub fn lane_spans(&self, s: f64) -> Vec<LaneSpan> {
        let mut out = Vec::new();
        self.find_span(s, |l| {
            out.push(l);
            false
        });
        out
    }

    /// The first lane span at `s`, in [`Road::lane_spans`] order, for which
    /// `pick` answers true; without building the list (the per-step road
    /// lookups of a scenario run call this for every vehicle).
    pub fn find_span(&self, s: f64, mut pick: impl FnMut(LaneSpan) -> bool) -> Option<LaneSpan> {
        let s = s.clamp(0.0, self.length);
        let (o, _) = self.lane_offset(s);
        let (ls, rs) = self.sides(s);
        side_span(&ls.left, (ls.s, s, o, 1.0), &mut pick)
            .or_else(|| side_span(&rs.right, (rs.s, s, o, -1.0), &mut pick))
    }

    /// The lane (of non-zero width) whose span holds `t` at `s`: the same
    /// answer as `find_span(s, |l| l.width() > 1e-3 && l.contains(t))`,
    /// with only `t`'s side of the centre lane evaluated (every left lane
    /// lies at or left of the lane offset, every right lane at or right of
    /// it). What locating a point asks for every vehicle at every step.
    pub fn lane_holding(&self, s: f64, t: f64) -> Option<LaneSpan> {
        let s = s.clamp(0.0, self.length);
        let (o, _) = self.lane_offset(s);
        let (ls, rs) = self.sides(s);
        let mut pick = |l: LaneSpan| l.width() > 1e-3 && l.contains(t);
        // NaN on either side: both sides, as the two-sided search does.
        let side = t.partial_cmp(&o);
        let found = if side != Some(std::cmp::Ordering::Less) {
            side_span(&ls.left, (ls.s, s, o, 1.0), &mut pick)
        } else {
            None
        };
        if found.is_some() || side == Some(std::cmp::Ordering::Greater) {
            return found;
        }
        side_span(&rs.right, (rs.s, s, o, -1.0), &mut pick)
    }

    /// The span of one lane at `s`.
    pub fn lane_span(&self, s: f64, lane: i32) -> Option<LaneSpan> {
        self.lane_span_of(s, lane).map(|(span, _)| span)
    }

    /// A lane of the section in force at `s`.
    pub fn lane(&self, s: f64, id: i32) -> Option<&Lane> {
        let sec = self.side_of(s.clamp(0.0, self.length), id);
        if id > 0 {
            sec.left.iter().find(|l| l.id == id)
        } else {
            sec.right.iter().find(|l| l.id == id)
        }
    }

    /// World point `(x, y, z)` of road coordinates `(s, t)` with superelevation.
    pub fn st_to_xyz(&self, s: f64, t: f64) -> (f64, f64, f64) {
        let (x, y, z, _) = self.st_to_xyz_hdg(s, t);
        (x, y, z)
    }

    /// [`Road::st_to_xyz`] and the reference line's heading at `s` (one
    /// evaluation of the reference line for both).
    pub fn st_to_xyz_hdg(&self, s: f64, t: f64) -> (f64, f64, f64, f64) {
        let r = self.reference(s);
        let roll = eval_cubics(&self.superelevation, s).0;
        let (t_h, dz) = if roll == 0.0 {
            (t, 0.0)
        } else {
            (t * math::cos(roll), -t * math::sin(roll))
        };
        let (sn, cs) = r.sin_cos();
        (
            r.x - t_h * sn,
            r.y + t_h * cs,
            self.elevation(s) + dz,
            r.hdg,
        )
    }

    /// Direction of travel of lane `id` under the road's rule.
    pub fn lane_direction(&self, s: f64, id: i32) -> Direction {
        self.direction_of(self.lane(s, id), id)
    }

    /// [`Road::lane_direction`] of lane `id` found as `lane` (`None`: not
    /// in the section; the rule alone decides).
    pub(crate) fn direction_of(&self, lane: Option<&Lane>, id: i32) -> Direction {
        if lane.is_some_and(|l| l.direction == "both" || l.kind == "bidirectional") {
            return Direction::Both;
        }
        let forward = match self.rule {
            Rule::Rht => id < 0,
            Rule::Lht => id > 0,
        };
        let reversed = lane.is_some_and(|l| l.direction == "reversed");
        if forward != reversed {
            Direction::Forward
        } else {
            Direction::Backward
        }
    }

    /// [`Road::lane_span`] and the lane [`Road::lane`] finds for `lane`
    /// (`None` for an id on the wrong side of its section), the section
    /// looked up once: a lane pose asks for both at every step.
    pub(crate) fn lane_span_of(&self, s: f64, lane: i32) -> Option<(LaneSpan, Option<&Lane>)> {
        // Only the lane's own side: the other side's widths do not move it
        // (the same numbers as `find_span`, without evaluating the left
        // lanes for every right lane). Ids on the wrong side, which a
        // hand-written map may have, go the long way.
        let sc = s.clamp(0.0, self.length);
        let (o, _) = self.lane_offset(sc);
        let sec = self.side_of(sc, lane);
        let (lanes, sign) = if lane > 0 {
            (&sec.left, 1.0)
        } else {
            (&sec.right, -1.0)
        };
        let mut t = o;
        for l in lanes {
            let t_out = outer(l, sec.s, sc, t, o, sign);
            if l.id == lane {
                let span = LaneSpan {
                    id: lane,
                    t_inner: t,
                    t_outer: t_out,
                };
                return Some((span, Some(l)));
            }
            t = t_out;
        }
        self.find_span(s, |l| l.id == lane)
            .map(|span| (span, self.lane(s, lane)))
    }
}

/// The first span of one side's `lanes` (section start, road s, lane
/// offset, +1 left / −1 right) that `pick` takes, from the centre out.
fn side_span(
    lanes: &[Lane],
    (sec_s, s, o, sign): (f64, f64, f64, f64),
    pick: &mut impl FnMut(LaneSpan) -> bool,
) -> Option<LaneSpan> {
    let mut t = o;
    for lane in lanes {
        let t_out = outer(lane, sec_s, s, t, o, sign);
        let span = LaneSpan {
            id: lane.id,
            t_inner: t,
            t_outer: t_out,
        };
        if pick(span) {
            return Some(span);
        }
        t = t_out;
    }
    None
}

fn outer(lane: &Lane, sec_s: f64, s: f64, t_inner: f64, offset: f64, sign: f64) -> f64 {
    let ds = s - sec_s;
    if !lane.widths.is_empty() {
        let i = lane.widths.partition_point(|w| w.s <= ds).max(1) - 1;
        let w = &lane.widths[i];
        t_inner + sign * w.at(ds - w.s).max(0.0)
    } else {
        // Border: the outer edge directly, measured from the centre lane.
        let i = lane.borders.partition_point(|w| w.s <= ds).max(1) - 1;
        let b = &lane.borders[i];
        offset + sign * b.at(ds - b.s).abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RoadNetwork;

    /// A road of three sections — the second replaces only its right side
    /// (`singleSide`), the last has a reversed and a bidirectional lane and
    /// widths that change along s.
    fn road() -> RoadNetwork {
        let lane = |id: i32, extra: &str, b: f64| {
            format!(
                r#"<lane id="{id}" type="driving"{extra}><width sOffset="0" a="3.5" b="{b}" c="0" d="0"/></lane>"#
            )
        };
        let section = |s: f64, single: bool, left: &[String], right: &[String]| {
            let side = |name: &str, l: &[String]| {
                if l.is_empty() {
                    String::new()
                } else {
                    format!("<{name}>{}</{name}>", l.join(""))
                }
            };
            format!(
                r#"<laneSection s="{s}"{}>{}<center><lane id="0" type="none"/></center>{}</laneSection>"#,
                if single { r#" singleSide="true""# } else { "" },
                side("left", left),
                side("right", right)
            )
        };
        let text = format!(
            r#"<?xml version="1.0"?><OpenDRIVE><header revMajor="1" revMinor="8"/>
            <road id="1" length="300" junction="-1" rule="RHT"><planView>
            <geometry s="0" x="0" y="0" hdg="0.3" length="300"><arc curvature="0.002"/></geometry>
            </planView><lanes>
            <laneOffset s="0" a="0.2" b="0.001" c="0" d="0"/>
            {}{}{}
            </lanes></road></OpenDRIVE>"#,
            section(
                0.0,
                false,
                &[lane(1, "", 0.0), lane(2, "", 0.0)],
                &[lane(-1, "", 0.0), lane(-2, "", 0.0)]
            ),
            section(
                100.0,
                true,
                &[],
                &[lane(-1, "", 0.01), lane(-2, "", 0.0), lane(-3, "", 0.0)]
            ),
            section(
                200.0,
                false,
                &[
                    lane(1, r#" direction="reversed""#, 0.0),
                    lane(2, r#" direction="both""#, 0.0)
                ],
                &[
                    lane(-1, r#" direction="reversed""#, -0.005),
                    lane(-2, "", 0.0)
                ]
            ),
        );
        RoadNetwork::from_xodr(&text, "sections.xodr").unwrap()
    }

    /// `lane_span_of` (what a lane pose uses) measures the span the long
    /// way (`find_span`) measures and finds the lane `Road::lane` finds, so
    /// `direction_of` its lane is `lane_direction` — on every section, a
    /// single-sided one among them, and for ids a section does not have.
    #[test]
    fn one_lookup_answers_as_the_separate_ones_do() {
        let net = road();
        let r = &net.roads()[0];
        let mut checked = 0;
        for k in -4..=620 {
            let s = k as f64 * 0.5 + 0.013;
            for id in [-4, -3, -2, -1, 1, 2, 3] {
                let long = r.find_span(s, |l| l.id == id);
                let got = r.lane_span_of(s, id);
                assert_eq!(got.map(|(sp, _)| sp), long, "span of {id} at s {s}");
                assert_eq!(r.lane_span(s, id), long, "lane_span of {id} at s {s}");
                if let Some((_, lane)) = got {
                    assert_eq!(
                        lane.map(|l| l as *const Lane),
                        r.lane(s, id).map(|l| l as *const Lane),
                        "lane {id} at s {s}"
                    );
                    assert_eq!(
                        r.direction_of(lane, id),
                        r.lane_direction(s, id),
                        "{id} at {s}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 2500, "{checked}");
        // The single-sided section keeps the first section's left lanes.
        assert!(r.lane(150.0, 2).is_some() && r.lane(150.0, -3).is_some());
        assert_eq!(r.lane_direction(250.0, 1), Direction::Forward);
        assert_eq!(r.lane_direction(250.0, 2), Direction::Both);
        assert_eq!(r.lane_direction(250.0, -1), Direction::Backward);
    }
}
