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

    /// The lane position and sideways offset of `place` for the phase
    /// `l` (its action named in the errors: a point off the roads, an
    /// unknown road or lane, an `s` beyond the road).
    pub(super) fn resolve_place(
        &self,
        l: &RLeaf,
        place: &Place,
    ) -> Result<(LanePos, f64), ScenarioError> {
        let net = self.cx.net;
        let err = |what: String| self.action_err(l, what);
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
        Ok((pos, lateral))
    }

    /// `assign_position`: the actor is at `place` from sample `k` on.
    pub(super) fn teleport(
        &mut self,
        l: &RLeaf,
        k: usize,
        place: &Place,
    ) -> Result<(), ScenarioError> {
        let (pos, lateral) = self.resolve_place(l, place)?;
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

    /// `change_position(target)`: the actor drives on (its speed, its
    /// modifiers) to the target, changing to the target's lane when it is
    /// one beside its own on the same road; the phase ends when it is
    /// level with the target (`Reach::Place`).
    pub(super) fn start_change_position(
        &mut self,
        l: &RLeaf,
        t: f64,
        place: &Place,
    ) -> Result<(), ScenarioError> {
        let (pos, lateral) = self.resolve_place(l, place)?;
        let net = self.cx.net;
        let p = net.lane_pos_pose(pos, lateral);
        let here = net.lane_pos_pose(self.mo.pos, self.mo.lateral);
        let ahead = litesim_core::ahead_along(here.position.xy(), here.yaw, p.position.xy());
        if ahead <= 0.0 {
            return Err(self.action_err(
                l,
                format!("the target is not ahead of it ({:.1} m behind)", -ahead),
            ));
        }
        if pos.road == self.mo.pos.road && pos.lane != self.mo.pos.lane {
            let beside = (-3..=3).any(|d| net.lane_beside(self.mo.pos, d) == Some(pos.lane));
            if !beside {
                return Err(self.action_err(
                    l,
                    format!(
                        "lane {} is not beside its lane {} on road {}",
                        pos.lane,
                        self.mo.pos.lane,
                        net.roads()[pos.road].id
                    ),
                ));
            }
            self.mo.change = Some((
                self.mo.pos.lane,
                pos.lane,
                t,
                t + super::super::LANE_CHANGE_S,
            ));
        }
        self.needs_speed(l, "change its position")?;
        self.reaching = Some((l.id, Reach::Place(p.position.x, p.position.y), t));
        Ok(())
    }

    /// A `change_position` level with its target at `t` (the target no
    /// longer ahead along the actor's heading): it ends at `t`. Checked
    /// before the phases that start at `t` are entered.
    pub(super) fn place_reached(&mut self, t: f64) {
        let Some((id, Reach::Place(x, y), t0)) = self.reaching else {
            return;
        };
        let here = self.cx.net.lane_pos_pose(self.mo.pos, self.mo.lateral);
        let ahead =
            litesim_core::ahead_along(here.position.xy(), here.yaw, litesim_core::Vec2::new(x, y));
        if ahead <= 0.0 && t > t0 + 1e-9 {
            self.out
                .reached
                .push((super::super::timer::reach_key(id), t - t0));
            self.reaching = None;
        }
    }
}
