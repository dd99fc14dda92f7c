//! What favours exactness over physics: `assign_position` (a jump on its
//! tick) and the plans that therefore keep their motion (`Plan::exact`).

use super::*;
use crate::intent::Place;

impl Mover<'_> {
    /// Notes that this actor's plan asks for exactness (`what` at the
    /// phase `l`), the first time.
    pub(super) fn exact(&mut self, l: &RLeaf, what: &str) {
        self.out
            .exact
            .entry(self.id.clone())
            .or_insert_with(|| format!("{what} at {}", l.at));
    }

    /// `assign_position`: the actor is at `place` from sample `k` on.
    pub(super) fn teleport(
        &mut self,
        l: &RLeaf,
        k: usize,
        place: &Place,
    ) -> Result<(), ScenarioError> {
        let net = self.cx.net;
        let err = |what: String| {
            ScenarioError::Plan(format!("{}: {}'s assign_position: {what}", l.at, self.id))
        };
        let road_of = |id: &str| {
            net.road_index(id)
                .ok_or_else(|| err(format!("the map has no road '{id}'")))
        };
        let (pos, lateral) = match place {
            &Place::Xy { x, y } => {
                let p = net
                    .locate(litesim_core::Vec2::new(x, y))
                    .ok_or_else(|| err(format!("({x:.2}, {y:.2}) is on no road of the map")))?;
                (
                    LanePos {
                        road: p.road,
                        lane: p.lane,
                        s: p.s,
                    },
                    p.offset,
                )
            }
            Place::Odr { road, lane, s, t } => {
                let r = road_of(road)?;
                let lane: i32 = lane
                    .trim()
                    .parse()
                    .map_err(|_| err(format!("lane_id '{lane}' is not a lane id (an integer)")))?;
                (
                    LanePos {
                        road: r,
                        lane,
                        s: *s,
                    },
                    *t,
                )
            }
            Place::Route { road, lane, s, t } => {
                let r = road_of(road)?;
                let lanes = net.lanes_same_way(r, *s, true);
                let Some(&id) = lanes.get(lane_index(lanes.len(), *lane)) else {
                    return Err(err(format!(
                        "road '{road}' has no lane {lane} at s = {s:.1} m"
                    )));
                };
                (
                    LanePos {
                        road: r,
                        lane: id,
                        s: *s,
                    },
                    *t,
                )
            }
        };
        let length = net.roads()[pos.road].length;
        if !(0.0..=length).contains(&pos.s)
            || net.lane_pose_at(pos.road, pos.lane, pos.s, 0.0).is_none()
        {
            return Err(err(format!(
                "road '{}' has no lane {} at s = {:.1} m",
                net.roads()[pos.road].id,
                pos.lane,
                pos.s
            )));
        }
        let mo = &mut self.mo;
        mo.pos = pos;
        mo.lateral = lateral;
        mo.change = None;
        self.reached = None;
        self.dead_end = false;
        if k > 0 {
            self.out.jumps.push(k);
        }
        self.exact(l, "assign_position");
        Ok(())
    }
}
