//! The drivers' controller: the traffic engine ([`Driven`]) drives the
//! scenario's other vehicles under `--npc driver` and the ambient traffic.
//! Each step it reads every actor from the same world the SUT sees, the
//! lights' colours, and sends each driven actor's trajectory for the coming
//! step.

use super::{Act, Controller, Flow, See, ssp_err, to_sim};
use crate::error::ScenarioError;
use crate::runtime::traffic::driven::Driven;
use litesim_core::Vec2;
use litesim_map::RoadNetwork;
use std::sync::Arc;

/// The traffic engine behind the controller trait (it owns the engine for
/// the run and gives it back at the end: what the drivers asked and met).
pub(crate) struct Drivers {
    /// The engine and its vehicles.
    pub driven: Driven,
    net: Arc<RoadNetwork>,
    /// Every actor's (position, heading, speed, length) this step: one
    /// buffer for the run.
    states: Vec<(Vec2, f64, f64, f64)>,
}

impl Drivers {
    /// The engine on `net`, told where the lights' stop lines are.
    pub fn new(mut driven: Driven, net: Arc<RoadNetwork>, lights: &super::Lights) -> Self {
        if let Some(l) = lights.info.as_ref() {
            driven.set_lights(&net, &l.boxes, &lights.box_roads);
        }
        Drivers {
            driven,
            net,
            states: Vec::new(),
        }
    }
}

impl Controller for Drivers {
    fn command(&mut self, see: &See<'_>, act: &mut Act<'_>) -> Result<Flow, ScenarioError> {
        let mut states = std::mem::take(&mut self.states);
        states.clear();
        states.extend((0..see.plan.actors.len()).map(|i| {
            let o = see.world.get(i);
            (Vec2::new(o.x, o.y), o.yaw, o.speed, o.length)
        }));
        let ego_xy = see.ego_index.map(|e| states[e].0);
        self.driven.see_located(see.world.located());
        let yellow = see.lights.yellow();
        let (plan, mirror) = (see.plan, see.mirror);
        let ssp = &mut *act.ssp;
        let stepped = self.driven.step(
            &self.net,
            plan,
            &states,
            (&see.lights.red, &yellow),
            see.now_ms(),
            see.step_ms,
            ego_xy,
            |i, traj| {
                if mirror {
                    traj.points.iter_mut().for_each(|c| *c = to_sim(*c, true));
                }
                ssp.set_xy_trajectory_ref(&plan.actors[i].id, traj)
                    .map_err(ssp_err)
            },
        );
        self.states = states;
        stepped?;
        Ok(Flow::Go)
    }
}
