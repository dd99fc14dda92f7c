//! Light control: the simulator's traffic-light boxes, which of them show
//! red, and the plan's switches, made when their step comes.
//!
//! The colours are tracked here from the simulator's listing and from every
//! switch's answer, so that the red-light check, the drivers' stop lines
//! and the SUT's view read one record.

use super::ExecConfig;
use crate::error::ScenarioError;
use crate::plan::{LightSwitch, Plan};
use crate::sut::LightState;
use litesim_map::RoadNetwork;
use litesim_ssp::api::Ssp;
use litesim_ssp::traffic::{
    BulbColor, BulbMode, BulbState, LightTarget, TrafficLightBox, TrafficLights,
};

/// The run's traffic lights.
pub struct Lights {
    /// The simulator's boxes (`None`: the map has none, or the simulator
    /// has no traffic-light API).
    pub info: Option<TrafficLights>,
    /// Per box: shows red.
    pub red: Vec<bool>,
    /// Each box's road as an index into the map's roads (compared per
    /// vehicle and step; a box on a road the map lacks never matches).
    pub box_roads: Vec<Option<usize>>,
    /// The plan's switches made so far.
    next: super::schedule::Schedule,
    /// The SUT's view of the lights is current (it is rebuilt only after a
    /// switch).
    pub seen: bool,
}

impl Lights {
    /// Lists the simulator's lights when the plan switches some or the map
    /// has signals to check red-light crossings against.
    pub fn list(
        ssp: &mut dyn Ssp,
        plan: &Plan,
        cfg: &ExecConfig,
        net: Option<&RoadNetwork>,
    ) -> Result<Self, ScenarioError> {
        let info = if !plan.lights.is_empty() {
            Some(ssp.list_traffic_lights().map_err(ScenarioError::Ssp)?)
        } else if cfg.map_text.is_some() {
            // The map's signals, for the red-light check; a simulator
            // without a traffic-light API (Simian) has none to list, and
            // nothing switches.
            match ssp.list_traffic_lights() {
                Ok(l) => Some(l),
                Err(e) if e.code == litesim_ssp::ErrorCode::Unimplemented => None,
                Err(e) => return Err(ScenarioError::Ssp(e)),
            }
        } else {
            None
        };
        let red = info
            .as_ref()
            .map(|l| l.boxes.iter().map(shows_red).collect())
            .unwrap_or_default();
        let box_roads = match (info.as_ref(), net) {
            (Some(l), Some(n)) => l
                .boxes
                .iter()
                .map(|b| n.od.roads.iter().position(|r| r.id == b.road_id))
                .collect(),
            _ => Vec::new(),
        };
        Ok(Lights {
            info,
            red,
            box_roads,
            next: Default::default(),
            seen: false,
        })
    }

    /// Makes every switch due by step `k`.
    pub fn switch_due(
        &mut self,
        ssp: &mut dyn Ssp,
        plan: &Plan,
        k: u64,
        step_ms: u64,
    ) -> Result<(), ScenarioError> {
        while let Some(sw) = self.next.due(&plan.lights, k, step_ms) {
            let info = self.info.as_mut().ok_or_else(|| {
                ScenarioError::Plan(format!(
                    "traffic light '{}': the map has no traffic lights",
                    sw.light
                ))
            })?;
            switch_light(ssp, info, &mut self.red, sw)?;
            self.next.made();
            self.seen = false;
        }
        Ok(())
    }

    /// The step of the next switch not made yet.
    pub fn next_tick(&self, plan: &Plan, step_ms: u64) -> Option<u64> {
        self.next.next_tick(&plan.lights, step_ms)
    }

    /// The step of the first switch after step `k` (the head of the loop
    /// makes every switch due by `k` first).
    pub fn next_after(&self, plan: &Plan, k: u64, step_ms: u64) -> Option<u64> {
        self.next.next_after(&plan.lights, k, step_ms)
    }

    /// A new plan's switches: those due before step `k` belong to the past.
    pub fn replanned(&mut self, plan: &Plan, k: u64, step_ms: u64) {
        self.next.replanned(&plan.lights, k, step_ms);
    }

    /// Per box: shows yellow.
    pub fn yellow(&self) -> Vec<bool> {
        self.info
            .as_ref()
            .map(|l| {
                l.boxes
                    .iter()
                    .map(|b| shows(b, BulbColor::Yellow))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// The boxes as the SUT sees them.
    pub fn states(&self) -> Vec<LightState> {
        self.info
            .as_ref()
            .map(|l| l.boxes.iter().map(light_state).collect())
            .unwrap_or_default()
    }
}

/// Whether a box shows `color` (a bulb of that colour on or flashing).
fn shows(b: &TrafficLightBox, color: BulbColor) -> bool {
    b.bulbs
        .iter()
        .any(|x| x.color == color && matches!(x.mode, BulbMode::On | BulbMode::Flashing))
}

/// Whether a box shows red.
fn shows_red(b: &TrafficLightBox) -> bool {
    shows(b, BulbColor::Red)
}

/// Which light a switch names: logical by preference, else a box; with the
/// boxes it sets.
fn target(info: &TrafficLights, light: &str) -> Result<(LightTarget, Vec<String>), ScenarioError> {
    if let Some(l) = info
        .logical
        .iter()
        .find(|l| l.id == light || l.controller_id == light)
    {
        return Ok((LightTarget::Logical(l.id.clone()), l.box_ids.clone()));
    }
    if info.boxes.iter().any(|b| b.id == light) {
        return Ok((LightTarget::Box(light.to_string()), vec![light.to_string()]));
    }
    let known: Vec<&str> = info
        .logical
        .iter()
        .map(|l| l.id.as_str())
        .chain(info.boxes.iter().map(|b| b.id.as_str()))
        .collect();
    Err(ScenarioError::Plan(format!(
        "traffic light '{light}' is not in the map (lights: {})",
        known.join(", ")
    )))
}

/// Sets a light to one colour: that colour's bulbs on, the others off.
fn switch_light(
    ssp: &mut dyn Ssp,
    info: &mut TrafficLights,
    red: &mut [bool],
    sw: &LightSwitch,
) -> Result<(), ScenarioError> {
    let (target, boxes) = target(info, &sw.light)?;
    let want = match sw.color.as_str() {
        "red" => BulbColor::Red,
        "yellow" => BulbColor::Yellow,
        _ => BulbColor::Green,
    };
    let mut states: Vec<BulbState> = Vec::new();
    for b in info.boxes.iter().filter(|b| boxes.contains(&b.id)) {
        for bulb in &b.bulbs {
            let s = BulbState {
                icon: bulb.icon,
                color: bulb.color,
                mode: if bulb.color == want {
                    BulbMode::On
                } else {
                    BulbMode::Off
                },
            };
            if !states.contains(&s) {
                states.push(s);
            }
        }
    }
    let changed = ssp
        .set_traffic_light_state(target, states)
        .map_err(ScenarioError::Ssp)?;
    for c in changed {
        if let Some(k) = info.boxes.iter().position(|b| b.id == c.id) {
            red[k] = shows_red(&c);
            info.boxes[k] = c;
        }
    }
    Ok(())
}

/// A traffic-light box's colour as the SUT sees it.
fn light_state(b: &TrafficLightBox) -> LightState {
    let on = |c: BulbColor| shows(b, c);
    let color = if on(BulbColor::Red) {
        "red"
    } else if on(BulbColor::Yellow) {
        "yellow"
    } else if on(BulbColor::Green) {
        "green"
    } else {
        "off"
    };
    LightState {
        id: b.id.clone(),
        road: b.road_id.clone(),
        s: b.s,
        color: color.into(),
    }
}
