//! Ambient traffic around sut.car: driver-controlled vehicles `traffic.N`
//! placed at the test's seed within the declared radius, stepped by the
//! [`Traffic`] engine each step beside the scenario's own actors (which
//! they follow and yield to as [`Obstacle`]s), and kept around sut.car as
//! it moves: a vehicle that falls out of range or leaves the map is taken
//! off the road and placed again in a free spot at the far side of the
//! range, ahead of or behind sut.car (same id: the simulator's actor list
//! stays fixed during a run; the summary counts these re-entries).

use super::spawn::{Density, fill};
use super::{LaneGraph, Obstacle, StopLine, Traffic};
use crate::elab::{ActorKind, TrafficDecl};
use crate::error::ScenarioError;
use crate::plan::{ActorPlan, Plan, PlanSample};
use litesim_core::Vec2;
use litesim_core::geometry::Pose;
use litesim_core::rng::Rng;
use litesim_map::{Located, RoadNetwork};
use litesim_ssp::api::{Coord6, XyTrajectory};
use std::sync::Arc;

/// Length and width of an ambient vehicle (m): a mid-size car.
pub const SIZE: (f64, f64) = (4.5, 1.8);
/// How often vehicles out of range are placed again (steps of 20 ms: 0.5 s).
const RECYCLE_EVERY_S: f64 = 0.5;
/// A vehicle farther than this many radii from sut.car is out of range.
const OUT_OF_RANGE: f64 = 1.2;

/// The ambient traffic of one run.
#[derive(Debug)]
pub struct Ambient {
    /// The map's lanes.
    pub graph: Arc<LaneGraph>,
    /// The engine and its vehicles (slot k is actor `traffic.k`).
    pub traffic: Traffic,
    /// The declaration.
    pub decl: TrafficDecl,
    /// Vehicles placed again after leaving the range or the map.
    pub recycled: u64,
    /// Where each traffic-light box's stop lines are: (lane, u).
    box_lines: Vec<Vec<(u32, f64)>>,
    /// Each plan actor's last map location (a hint for the next).
    hints: Vec<Option<Located>>,
    rng: Rng,
    poses: Vec<Pose>,
}

impl Ambient {
    /// Places the declared traffic around sut.car's start, avoiding the
    /// scenario's actors; returns it and one plan entry per vehicle (its
    /// start), to be appended to the plan's actors.
    pub fn place(
        decl: &TrafficDecl,
        graph: Arc<LaneGraph>,
        net: &RoadNetwork,
        plan: &Plan,
        dt: f64,
        seed: u64,
    ) -> Result<(Self, Vec<ActorPlan>), ScenarioError> {
        let at = &decl.at;
        if graph.is_empty() {
            return Err(ScenarioError::Elaboration(format!(
                "{at}: ambient traffic needs driving lanes, and the map has none"
            )));
        }
        let ego = plan.actors.iter().find(|a| a.ego).ok_or_else(|| {
            ScenarioError::Elaboration(format!(
                "{at}: ambient traffic surrounds sut.car, which takes part in no phase"
            ))
        })?;
        let centre = Vec2::new(ego.samples[0].x, ego.samples[0].y);
        // Its own stream: the scenario's draws stay as they were.
        let mut rng = Rng::new(seed ^ 0x7472_6166_6669_6300);
        let mut me = Ambient {
            graph: graph.clone(),
            traffic: Traffic::new(dt),
            decl: decl.clone(),
            recycled: 0,
            box_lines: Vec::new(),
            hints: vec![None; plan.actors.len()],
            rng: Rng::new(0),
            poses: Vec::new(),
        };
        let start: Vec<(Vec2, f64, f64, f64)> = plan
            .actors
            .iter()
            .map(|a| {
                let s = a.samples[0];
                (Vec2::new(s.x, s.y), s.yaw, s.v, a.length)
            })
            .collect();
        let obstacles = me.obstacles(net, &start);
        let d = Density {
            per_km_per_lane: decl.density,
            speed: decl.speed,
            size: SIZE,
        };
        let r2 = decl.radius * decl.radius;
        let slots = fill(
            &mut me.traffic,
            &graph,
            &d,
            &mut rng,
            &obstacles,
            |lane, u| {
                graph.pose(net, lane, u, 0.0).is_some_and(|p| {
                    let d = p.position.xy() - centre;
                    d.dot(d) <= r2
                })
            },
        )
        .map_err(|e| ScenarioError::Elaboration(format!("{at}: {e}")))?;
        let mut actors = Vec::with_capacity(slots.len());
        for &k in &slots {
            let v = &mut me.traffic.vehicles[k as usize];
            v.params.time_gap = decl.time_gap;
            v.params.politeness = decl.politeness;
            let p = graph
                .pose(net, v.lane, v.u, 0.0)
                .unwrap_or(Pose::planar(0.0, 0.0, 0.0));
            me.poses.push(p);
            actors.push(ActorPlan {
                id: format!("traffic.{k}"),
                kind: ActorKind::Vehicle,
                ego: false,
                category: "car".into(),
                model: None,
                length: SIZE.0,
                width: SIZE.1,
                samples: vec![PlanSample {
                    t: 0.0,
                    x: p.position.x,
                    y: p.position.y,
                    yaw: p.yaw,
                    v: v.v,
                    a: 0.0,
                }],
                heading_trig: Default::default(),
            });
        }
        me.rng = rng;
        Ok((me, actors))
    }

    /// The stop lines of the simulator's traffic-light boxes (`road` is
    /// each box's road index): one per lane the box controls, where it
    /// stands along the lane.
    pub fn set_lights(
        &mut self,
        net: &RoadNetwork,
        boxes: &[litesim_ssp::traffic::TrafficLightBox],
        roads: &[Option<usize>],
    ) {
        self.box_lines = boxes
            .iter()
            .zip(roads)
            .map(|(b, road)| {
                let Some(road) = *road else {
                    return Vec::new();
                };
                let r = &net.roads()[road];
                let sec = r.section_index(b.s);
                let ids: Vec<i32> = if b.valid_lanes.is_empty() {
                    let s = &r.sections[sec];
                    s.left.iter().chain(&s.right).map(|l| l.id).collect()
                } else {
                    b.valid_lanes.clone()
                };
                ids.into_iter()
                    .filter_map(|id| self.graph.at_road_s(net, road, id, b.s))
                    .collect()
            })
            .collect();
    }

    /// Where the actors the engine does not drive stand, in lanes: each
    /// (position, heading, speed, length); one straddling two lanes counts
    /// in both.
    fn obstacles(&mut self, net: &RoadNetwork, actors: &[(Vec2, f64, f64, f64)]) -> Vec<Obstacle> {
        let mut out = Vec::with_capacity(actors.len());
        for (i, &(xy, _yaw, speed, length)) in actors.iter().enumerate() {
            let hint = self.hints.get(i).copied().flatten();
            let found = net.locate_near(xy, hint);
            if let Some(h) = self.hints.get_mut(i) {
                *h = found;
            }
            let Some((lane, u, lat)) = found.and_then(|p| self.graph.locate(net, &p)) else {
                continue;
            };
            let o = Obstacle {
                lane,
                u,
                v: speed.max(0.0),
                a: 0.0,
                length,
            };
            out.push(o);
            let info = &self.graph.lanes[lane as usize];
            let beside = if lat > 0.25 * info.width {
                info.left
            } else if lat < -0.25 * info.width {
                info.right
            } else {
                None
            };
            if let Some(b) = beside {
                out.push(Obstacle { lane: b, ..o });
            }
        }
        out
    }

    /// One step: the other actors as they stand (`actors[i]` for plan
    /// actor `i`; the traffic's own entries are skipped by `driven`), the
    /// lights' red flags per box, then every vehicle's trajectory for the
    /// coming step from `now_ms` (in the map's frame; `send` gets slot and
    /// trajectory).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        net: &RoadNetwork,
        actors: &[(Vec2, f64, f64, f64)],
        red: &[bool],
        now_ms: u64,
        step_ms: u64,
        ego: Option<Vec2>,
        mut send: impl FnMut(u32, XyTrajectory) -> Result<(), ScenarioError>,
    ) -> Result<(), ScenarioError> {
        let obstacles = self.obstacles(net, actors);
        self.traffic.stop_lines.clear();
        for (lines, &is_red) in self.box_lines.iter().zip(red) {
            for &(lane, u) in lines {
                self.traffic.stop_lines.push(StopLine {
                    lane,
                    u,
                    red: is_red,
                });
            }
        }
        let every = ((RECYCLE_EVERY_S * 1000.0) as u64 / step_ms.max(1)).max(1);
        let mut jumped = vec![false; self.traffic.vehicles.len()];
        if let Some(c) = ego
            && self.traffic.tick().is_multiple_of(every)
        {
            self.recycle(net, c, &obstacles, &mut jumped);
        }
        self.traffic.step(&self.graph, &obstacles);
        for (k, v) in self.traffic.vehicles.iter().enumerate() {
            let before = self.poses[k];
            let after = if v.active {
                self.graph.pose(net, v.lane, v.u, v.lat).unwrap_or(before)
            } else {
                before
            };
            self.poses[k] = after;
            let from = if jumped[k] { after } else { before };
            let pt = |p: Pose| Coord6::xy_yaw(p.position.x, p.position.y, p.yaw);
            send(
                k as u32,
                XyTrajectory {
                    start_time_ms: now_ms,
                    end_time_ms: now_ms + step_ms,
                    points: vec![pt(from), pt(after)],
                    point_times_ms: vec![now_ms, now_ms + step_ms],
                    speeds: vec![v.v, v.v],
                },
            )?;
        }
        Ok(())
    }

    /// Vehicles out of range of sut.car (or off the map) go back on the
    /// road at a free spot 0.6 … 1 radius ahead of or behind it.
    fn recycle(
        &mut self,
        net: &RoadNetwork,
        centre: Vec2,
        obstacles: &[Obstacle],
        jumped: &mut [bool],
    ) {
        let r = self.decl.radius;
        let far2 = (OUT_OF_RANGE * r) * (OUT_OF_RANGE * r);
        let Some(here) = net.locate(centre).and_then(|p| self.graph.locate(net, &p)) else {
            return;
        };
        for k in 0..self.traffic.vehicles.len() {
            let out = {
                let v = &self.traffic.vehicles[k];
                let d = self.poses[k].position.xy() - centre;
                !v.active || d.dot(d) > far2
            };
            if !out {
                continue;
            }
            // A few tries at a random spot; none free: it waits a round.
            for _ in 0..4 {
                let ahead = self.rng.unit() < 0.5;
                let d = r * (0.6 + 0.4 * self.rng.unit());
                let Some((lane, u)) = self.walk(here.0, here.1, if ahead { d } else { -d }) else {
                    continue;
                };
                let lane = self.side_lane(lane);
                if self.free(lane, u, obstacles) {
                    let v0 = self.decl.speed.0
                        + self.rng.unit() * (self.decl.speed.1 - self.decl.speed.0);
                    let v = &mut self.traffic.vehicles[k];
                    v.lane = lane;
                    v.u = u;
                    v.v = v0;
                    v.a = 0.0;
                    v.lat = 0.0;
                    v.from = None;
                    v.active = true;
                    v.at_dead_end = false;
                    v.params.desired_speed = v0;
                    self.poses[k] = self.graph.pose(net, lane, u, 0.0).unwrap_or(self.poses[k]);
                    jumped[k] = true;
                    self.recycled += 1;
                    break;
                }
            }
        }
    }

    /// The lane and `u` `d` metres along the lanes from (`lane`, `u`),
    /// forwards (d > 0, first successors) or backwards (first predecessors).
    fn walk(&self, mut lane: u32, mut u: f64, d: f64) -> Option<(u32, f64)> {
        let g = &self.graph;
        u += d;
        for _ in 0..64 {
            let len = g.lanes[lane as usize].length;
            if u > len {
                u -= len;
                lane = *g.lanes[lane as usize].next.first()?;
            } else if u < 0.0 {
                lane = *g.lanes[lane as usize].prev.first()?;
                u += g.lanes[lane as usize].length;
            } else {
                return Some((lane, u));
            }
        }
        None
    }

    /// A seeded pick among `lane` and its neighbours to both sides.
    fn side_lane(&mut self, lane: u32) -> u32 {
        let g = &self.graph;
        let mut all = vec![lane];
        let mut l = lane;
        while let Some(n) = g.lanes[l as usize].left {
            all.push(n);
            l = n;
        }
        l = lane;
        while let Some(n) = g.lanes[l as usize].right {
            all.push(n);
            l = n;
        }
        all[(self.rng.next_u64() % all.len() as u64) as usize]
    }

    /// Nobody (vehicle or obstacle) within a safe distance of `u` in `lane`.
    fn free(&self, lane: u32, u: f64, obstacles: &[Obstacle]) -> bool {
        let room = 2.0 * (SIZE.0 + 2.0) + self.decl.speed.1 * self.decl.time_gap;
        let vehicles = self
            .traffic
            .vehicles
            .iter()
            .filter(|v| v.active)
            .flat_map(|v| {
                [Some(v.lane), v.from]
                    .into_iter()
                    .flatten()
                    .map(move |l| (l, v.u))
            });
        let others = obstacles.iter().map(|o| (o.lane, o.u));
        vehicles
            .chain(others)
            .all(|(l, x)| l != lane || (x - u).abs() > room)
    }
}
