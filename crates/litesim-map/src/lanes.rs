//! Lane walking: positions on the lane graph (road, lane, s) moved along
//! the direction of travel across road ends, neighbouring lanes, lane poses.
//! What the scenario engine's placement and motion are built on.

use crate::network::{LaneRef, RoadNetwork};
use crate::road::Direction;
use litesim_core::geometry::Pose;

/// Where an actor is on the lane graph.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LanePos {
    /// Road index in [`RoadNetwork::roads`].
    pub road: usize,
    /// Lane id.
    pub lane: i32,
    /// s along the road's reference line (m).
    pub s: f64,
}

impl RoadNetwork {
    /// Whether the lane at `p` runs along increasing s.
    pub fn travels_forward(&self, p: LanePos) -> bool {
        self.roads()[p.road].lane_direction(p.s, p.lane) != Direction::Backward
    }

    /// Moves `ds` metres along the direction of travel (negative = back),
    /// across road ends through the lane graph.
    pub fn advance(&self, p: LanePos, ds: f64) -> LanePos {
        self.advance_rest(p, ds).0
    }

    /// [`Self::advance`], and the part of `|ds|` that could not be
    /// travelled because the lane ends (a dead end or the map's edge) —
    /// 0 when the whole move fits. Placement uses it to tell a position
    /// that lies beyond the map from one that is on it.
    pub fn advance_rest(&self, p: LanePos, ds: f64) -> (LanePos, f64) {
        self.advance_choosing(p, ds, &|next: &[LaneRef]| next.first().copied())
    }

    /// [`Self::advance_rest`], `choose` picking the lane to go on in from
    /// the successors where the lane leaves its road forwards (a route's
    /// next road at a junction); none chosen is a dead end.
    pub fn advance_choosing(
        &self,
        mut p: LanePos,
        mut ds: f64,
        choose: &dyn Fn(&[LaneRef]) -> Option<LaneRef>,
    ) -> (LanePos, f64) {
        for _ in 0..64 {
            let road = &self.roads()[p.road];
            let dir = if self.travels_forward(p) { 1.0 } else { -1.0 };
            let s_new = p.s + dir * ds;
            if (0.0..=road.length).contains(&s_new) {
                p.s = s_new;
                return (p, 0.0);
            }
            // Leaving this road: the remaining distance continues on the next lane.
            let (edge, rest) = if s_new > road.length {
                (road.length, s_new - road.length)
            } else {
                (0.0, -s_new)
            };
            let leaving_forward = (s_new > road.length) == (dir > 0.0);
            let here = LaneRef {
                road: p.road,
                section: road.section_index(edge.clamp(0.0, road.length)),
                lane: p.lane,
            };
            let next = if leaving_forward {
                choose(&self.successors(here))
            } else {
                self.predecessor(here)
            };
            let Some(n) = next else {
                p.s = edge;
                return (p, rest);
            };
            let nr = &self.roads()[n.road];
            let probe = LanePos {
                road: n.road,
                lane: n.lane,
                s: nr.sections[n.section].s + 0.01,
            };
            let nf = self.travels_forward(probe);
            p = LanePos {
                road: n.road,
                lane: n.lane,
                s: if nf == leaving_forward {
                    0.0
                } else {
                    nr.length
                },
            };
            // The rest of the move keeps its sense: backwards stays
            // backwards on the predecessor (a `behind` placement across a
            // junction lands on the incoming road, not back on this one).
            ds = if leaving_forward { rest } else { -rest };
        }
        (p, 0.0)
    }

    /// Moves `dist` metres of *travelled path* along the lane: `s` runs along
    /// the road's reference line, so on a curve a lane centre away from it is
    /// longer or shorter than `ds`; one secant correction makes the path
    /// length match (the planned speed is then the speed a car really has).
    /// `at_p` is `p`'s pose when the caller has it already (the sampler does).
    pub fn advance_path(&self, p: LanePos, dist: f64, at_p: Option<Pose>) -> LanePos {
        self.advance_path_pose(p, dist, at_p).0
    }

    /// [`Self::advance_path`], with the lane-centre pose at the place it
    /// returns where it computed that pose on the way (a straight lane: the
    /// chord is the distance and the corrected move lands where the first
    /// did) — a caller stepping along a lane then needs one pose per step
    /// instead of two. The same place and pose as computing them anew.
    pub fn advance_path_pose(
        &self,
        p: LanePos,
        dist: f64,
        at_p: Option<Pose>,
    ) -> (LanePos, Option<Pose>) {
        let q = self.advance(p, dist);
        let a = at_p.unwrap_or_else(|| self.lane_pos_pose(p, 0.0));
        let b = self.lane_pos_pose(q, 0.0);
        let chord = a.position.xy().distance(b.position.xy());
        // Chords of long placement moves (tens of metres) are shorter than
        // arcs; the error stays below 0.1 % on lanes of radius > 50 m.
        if chord > 1e-6 && q.road == p.road {
            let r = self.advance(p, dist * dist.abs() / chord);
            (r, (r == q).then_some(b))
        } else {
            (q, Some(b))
        }
    }

    /// A lane whose successor is `to`.
    pub fn predecessor(&self, to: LaneRef) -> Option<LaneRef> {
        for (ri, r) in self.roads().iter().enumerate() {
            for (si, sec) in r.sections.iter().enumerate() {
                for l in sec.left.iter().chain(sec.right.iter()) {
                    let from = LaneRef {
                        road: ri,
                        section: si,
                        lane: l.id,
                    };
                    if from != to && self.successors(from).contains(&to) {
                        return Some(from);
                    }
                }
            }
        }
        None
    }

    /// Driving lanes of a road at `s` that run the same way as `lane`, ordered
    /// from the rightmost (number 1) to the leftmost in the direction of travel.
    pub fn lanes_same_way(&self, road: usize, s: f64, fwd: bool) -> Vec<i32> {
        let r = &self.roads()[road];
        let mut v: Vec<i32> = r
            .lane_spans(s)
            .into_iter()
            .filter(|sp| r.lane(s, sp.id).is_some_and(|l| l.is_drivable()))
            .map(|sp| sp.id)
            .filter(|id| (r.lane_direction(s, *id) != Direction::Backward) == fwd)
            .collect();
        // Rightmost first: in the direction of travel, right is smaller t.
        v.sort_by(|a, b| {
            let ta = r.lane_span(s, *a).map_or(0.0, |x| x.t_center());
            let tb = r.lane_span(s, *b).map_or(0.0, |x| x.t_center());
            if fwd {
                ta.total_cmp(&tb)
            } else {
                tb.total_cmp(&ta)
            }
        });
        v
    }

    /// The lane `n` lanes to the left (negative: right) of `p`'s lane. Left of
    /// the leftmost lane of a direction is the nearest lane of the opposite
    /// direction (across the centre line), as on a two-way road.
    pub fn lane_beside(&self, p: LanePos, n: i32) -> Option<i32> {
        let fwd = self.travels_forward(p);
        let lanes = self.lanes_same_way(p.road, p.s, fwd);
        let i = lanes.iter().position(|l| *l == p.lane)? as i32 + n;
        if (0..lanes.len() as i32).contains(&i) {
            return Some(lanes[i as usize]);
        }
        if n > 0 {
            let opposite = self.lanes_same_way(p.road, p.s, !fwd);
            let k = (i - lanes.len() as i32) as usize;
            // Opposite lanes are listed rightmost (outermost) first: the
            // innermost is last.
            return opposite.iter().rev().nth(k).copied();
        }
        None
    }

    /// The pose at `p`, `offset` m left of the lane centre (the origin when
    /// the lane is not there).
    pub fn lane_pos_pose(&self, p: LanePos, offset: f64) -> Pose {
        self.lane_pose_at(p.road, p.lane, p.s, offset)
            .unwrap_or_else(|| Pose::planar(0.0, 0.0, 0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight() -> RoadNetwork {
        let p = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/maps/straight.xodr"
        );
        RoadNetwork::from_xodr(&std::fs::read_to_string(p).unwrap(), "straight.xodr").unwrap()
    }

    #[test]
    fn lanes_are_walked_in_their_direction_of_travel() {
        let net = straight();
        let right = LanePos {
            road: 0,
            lane: -1,
            s: 100.0,
        };
        let left = LanePos { lane: 1, ..right };
        assert!(net.travels_forward(right) && !net.travels_forward(left));
        assert_eq!(net.advance(right, 10.0).s, 110.0);
        assert_eq!(net.advance(left, 10.0).s, 90.0);
        // A dead end holds at the road's end.
        assert_eq!(net.advance(right, 1000.0).s, 500.0);
        // Lanes numbered from the right in the direction of travel; left of
        // the innermost is the innermost of the other direction.
        assert_eq!(net.lanes_same_way(0, 100.0, true), vec![-3, -2, -1]);
        assert_eq!(net.lane_beside(right, 1), Some(1));
        assert_eq!(net.lane_beside(LanePos { lane: -3, ..right }, 1), Some(-2));
        assert_eq!(net.lane_beside(LanePos { lane: -3, ..right }, -1), None);
        let p = net.lane_pos_pose(right, 0.0);
        assert!((p.position.x - 100.0).abs() < 1e-9 && (p.position.y + 1.75).abs() < 1e-9);
        // The part of a move beyond a dead end is returned.
        assert_eq!(
            net.advance_rest(right, 430.0),
            (LanePos { s: 500.0, ..right }, 30.0)
        );
        assert_eq!(
            net.advance_rest(right, -130.0),
            (LanePos { s: 0.0, ..right }, 30.0)
        );
        assert_eq!(net.advance_rest(right, 30.0).1, 0.0);
    }

    #[test]
    fn a_move_backwards_across_a_junction_continues_backwards() {
        let p = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/maps/junction.xodr"
        );
        let net = RoadNetwork::from_xodr(&std::fs::read_to_string(p).unwrap(), "j").unwrap();
        for (i, r) in net.roads().iter().enumerate() {
            let Some(_) = r.junction.as_ref() else {
                continue;
            };
            let start = LanePos {
                road: i,
                lane: -1,
                s: 1.0,
            };
            // 10 m back from 1 m into a connecting road: 9 m before the
            // junction on the incoming arm, whose end is at the junction.
            let (q, rest) = net.advance_rest(start, -10.0);
            assert_eq!(rest, 0.0);
            assert!(net.roads()[q.road].junction.is_none(), "{} -> {q:?}", r.id);
            let to_end = if net.travels_forward(q) {
                net.roads()[q.road].length - q.s
            } else {
                q.s
            };
            assert!((to_end - 9.0).abs() < 1e-9, "{} -> {q:?}", r.id);
            // And forwards again enters the junction (by its first
            // connecting road: the arm has several).
            let (back, _) = net.advance_rest(q, 10.0);
            assert!(net.roads()[back.road].junction.is_some(), "{}", r.id);
        }
    }
}
