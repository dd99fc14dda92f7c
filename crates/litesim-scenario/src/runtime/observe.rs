//! Building observations: the one picture of the world every controller
//! reads at a step — the SUT's [`Observation`], kept between steps.
//!
//! The object list holds every actor as the simulator last reported it
//! (before the first step: as planned). With a SUT, sut.car is the
//! observation's `ego` and the list holds the others, which is exactly what
//! the SUT is sent; [`World::get`] hides the split from everyone else.

use super::lights::Lights;
use crate::plan::{ActorPlan, Plan};
use crate::state::BodyState;
use crate::sut::{ObjectState, Observation, RoadPos, Route};
use litesim_core::math;
use litesim_map::{LocateMemo, RoadNetwork};
use std::sync::Arc;

/// Every actor as last reported, in the SUT's layout.
pub struct World {
    /// The observation (with a SUT, `ego` is sut.car and `objects` the
    /// others, in plan order). Shared with a SUT that keeps it past its
    /// call (a Python object holds it): changed copy-on-write
    /// ([`Arc::make_mut`]), so a copy is made only while the SUT still
    /// holds last step's, and what the SUT holds never changes under it.
    pub obs: Arc<Observation>,
    /// sut.car's plan index when a SUT drives it.
    ego: Option<usize>,
    /// Per actor (plan order): its last map location with the question
    /// that found it, so that the read-back and the drivers locate an
    /// actor once a step between them.
    located: Vec<LocateMemo>,
}

/// An actor as its plan starts it.
fn start_state(a: &ActorPlan, length: f64, width: f64) -> ObjectState {
    let p = a.samples[0];
    let (sy, cy) = math::sin_cos(p.yaw);
    ObjectState {
        id: a.id.clone(),
        kind: format!("{:?}", a.kind).to_lowercase(),
        x: p.x,
        y: p.y,
        yaw: p.yaw,
        speed: p.v,
        vx: p.v * cy,
        vy: p.v * sy,
        acceleration: 0.0,
        length,
        width,
    }
}

impl World {
    /// No world: nobody observes it (open loop).
    pub fn empty() -> Self {
        World {
            obs: Arc::default(),
            ego: None,
            located: Vec::new(),
        }
    }

    /// The actors as planned at the start (`dims`: length, width, mass);
    /// `ego`: the actor a SUT drives.
    pub fn start(plan: &Plan, dims: &[(f64, f64, f64)], ego: Option<usize>) -> Self {
        let mut objects: Vec<ObjectState> = plan
            .actors
            .iter()
            .zip(dims)
            .map(|(a, d)| start_state(a, d.0, d.1))
            .collect();
        let mut obs = Observation::default();
        if let Some(e) = ego {
            obs.ego = objects.remove(e);
        }
        obs.objects = objects;
        World {
            obs: Arc::new(obs),
            ego,
            located: vec![LocateMemo::default(); plan.actors.len()],
        }
    }

    /// Every actor's last map location and its question (plan order).
    pub(crate) fn located(&self) -> &[LocateMemo] {
        &self.located
    }

    /// Keeps actor `i`'s map location (see [`World::located`]).
    pub(crate) fn keep_located(&mut self, i: usize, m: LocateMemo) {
        if let Some(slot) = self.located.get_mut(i) {
            *slot = m;
        }
    }

    /// Actor `i` (plan order).
    pub fn get(&self, i: usize) -> &ObjectState {
        match self.ego {
            Some(e) if i == e => &self.obs.ego,
            Some(e) if i > e => &self.obs.objects[i - 1],
            _ => &self.obs.objects[i],
        }
    }

    /// Actor `i` (plan order), to update.
    pub fn get_mut(&mut self, i: usize) -> &mut ObjectState {
        let obs = Arc::make_mut(&mut self.obs);
        match self.ego {
            Some(e) if i == e => &mut obs.ego,
            Some(e) if i > e => &mut obs.objects[i - 1],
            _ => &mut obs.objects[i],
        }
    }

    /// Actor `i`'s state (plan order).
    pub fn state(&self, i: usize) -> BodyState {
        let o = self.get(i);
        BodyState {
            x: o.x,
            y: o.y,
            yaw: o.yaw,
            length: o.length,
            width: o.width,
            vx: o.vx,
            vy: o.vy,
            speed: o.speed,
            acceleration: o.acceleration,
        }
    }
}

/// What the SUT's observation adds to the object list: where sut.car
/// stands on its route and road, what the scenario asks of it, the lights.
pub(crate) struct Observer {
    /// sut.car's route: its planned path.
    pub route: Route,
    /// The route segment last found (the search starts there).
    hint: usize,
}

impl Observer {
    /// sut.car's route from its plan.
    pub fn new(ego: &ActorPlan) -> Self {
        let pts: Vec<[f64; 2]> = ego.samples.iter().map(|p| [p.x, p.y]).collect();
        let sp: Vec<f64> = ego.samples.iter().map(|p| p.v).collect();
        Observer {
            route: Route::new(&pts, &sp),
            hint: 0,
        }
    }

    /// Completes the observation of step `k` for sut.car (plan index `e`,
    /// last located at `pos`); returns its sideways offset from its route
    /// (what lane goals that follow sut.car follow).
    #[allow(clippy::too_many_arguments)]
    pub fn observe(
        &mut self,
        world: &mut World,
        plan: &Plan,
        (k, t): (u64, f64),
        e: usize,
        pos: Option<&litesim_map::Located>,
        net: Option<&RoadNetwork>,
        lights: &mut Lights,
    ) -> Option<f64> {
        let obs = Arc::make_mut(&mut world.obs);
        obs.tick = k;
        obs.time = t;
        let rp = self.route.project(obs.ego.x, obs.ego.y, self.hint);
        if let Some(p) = rp {
            self.hint = p.segment;
        }
        obs.distance_to_goal = rp.map_or(0.0, |p| self.route.length() - p.s);
        obs.requested_speed = plan.actors[e].speed_at(t, plan.dt);
        // Updated in place: the road's name is copied only when it changes
        // (not an allocation a step).
        match (pos.zip(net), &mut obs.road) {
            (Some((p, n)), Some(r)) => {
                let id = &n.od.roads[p.road].id;
                if r.road != *id {
                    r.road.clone_from(id);
                }
                r.lane = p.lane;
                r.s = p.s;
                r.offset = p.offset;
            }
            (Some((p, n)), slot) => {
                *slot = Some(RoadPos {
                    road: n.od.roads[p.road].id.clone(),
                    lane: p.lane,
                    s: p.s,
                    offset: p.offset,
                })
            }
            (None, slot) => *slot = None,
        }
        if !lights.seen {
            obs.lights = lights.states();
            lights.seen = true;
        }
        rp.map(|p| p.lateral)
    }
}
