//! Setting the stage: the simulator is initialised with the profile and
//! model asked for, and every plan actor is created in it with a catalogue
//! model of its category, at its planned start.

use super::ExecConfig;
use super::controllers::pid::Limits;
use super::controllers::{ssp_err, to_sim};
use crate::error::ScenarioError;
use crate::plan::{ActorPlan, Plan};
use litesim_core::math;
use litesim_log::LogRecorder;
use litesim_ssp::api::*;
use litesim_ssp::profile::{Calibration, Profile};

/// What the simulator said it is, and what follows from it.
pub(crate) struct Sim {
    /// Its capabilities (profile, model, catalogue, step).
    pub caps: Capabilities,
    /// The step (ms).
    pub step_ms: u64,
    /// The step (s).
    pub dt: f64,
    /// Pedal-driver gains (the test's, else the profile's).
    pub calibration: Calibration,
    /// A left-handed frame (CARLA): y and yaw mirrored at the boundary.
    pub mirror: bool,
    /// The model's brake (what the pedal drivers scale brake commands by).
    pub model: Option<Box<dyn litesim_ssp::model::Model>>,
    /// The profile's command resolution.
    pub resolution: f64,
}

/// Initialises the simulator and starts its simulation.
pub(crate) fn init(ssp: &mut dyn Ssp, cfg: &ExecConfig) -> Result<Sim, ScenarioError> {
    let init = ssp
        .init(InitRequest {
            client_name: "litesim scenario".into(),
            step_size_ms: cfg.step_ms,
            map: cfg.map_text.as_deref().cloned(),
            profile: cfg.profile.clone(),
            model: cfg.model.clone(),
            seed: cfg.seed,
            ..InitRequest::default()
        })
        .map_err(ssp_err)?;
    let caps = init.capabilities;
    let step_ms = u64::from(caps.step_size_ms.max(1));
    // The profile the simulator reports (it may differ from the one asked for).
    let profile = Profile::builtin(&caps.profile).ok();
    let calibration = cfg
        .calibration
        .unwrap_or_else(|| profile.as_ref().map(|p| p.calibration).unwrap_or_default());
    // Profiles with a left-handed frame (CARLA) see y and yaw mirrored; the
    // engine works in the map's frame and converts at the boundary, so the
    // simulator's world matches its map (traffic lights, its own roads).
    let mirror = profile.as_ref().is_some_and(|p| p.mirror_y);
    // The model the simulator reports: its brake decides the drivers'.
    let model = litesim_ssp::model::model_by_name(&caps.model).ok();
    let resolution = profile
        .as_ref()
        .map_or(litesim_ssp::profile::DEFAULT_COMMAND_RESOLUTION, |p| {
            p.command_resolution
        });
    ssp.start_simulation(0).map_err(ssp_err)?;
    ssp.wait_start_simulation(1000).map_err(ssp_err)?;
    Ok(Sim {
        caps,
        step_ms,
        dt: step_ms as f64 / 1000.0,
        calibration,
        mirror,
        model,
        resolution,
    })
}

/// The actors as created.
pub(crate) struct Cast {
    /// Per actor: length, width, mass (as the simulator made it).
    pub dims: Vec<(f64, f64, f64)>,
    /// Per actor: its limits, the brake as the model really brakes.
    pub limits: Vec<Limits>,
    /// Per actor: its limits as the catalogue gives them (what a SUT is
    /// told).
    pub catalogue: Vec<Limits>,
}

/// How an actor is created: its category and the type the simulator sees.
fn category(a: &ActorPlan) -> (ActorCategory, &'static str) {
    use litesim_core::ActorClass;
    match a.kind {
        ActorClass::Vehicle => (
            ActorCategory::Vehicle,
            if a.ego { "Ego" } else { "Vehicle" },
        ),
        ActorClass::Person => (ActorCategory::Pedestrian, "Pedestrian"),
        ActorClass::Cyclist => (ActorCategory::Cyclist, "Cyclist"),
        ActorClass::Animal => (ActorCategory::Animal, "Animal"),
        ActorClass::Stationary => (ActorCategory::StaticObject, "Object"),
    }
}

/// The catalogue entry for `a`: the model the test names (honoured or
/// refused, never swapped for another of the category), else one of its
/// category, else none (the simulator's default vehicle).
fn entry<'c>(
    caps: &'c Capabilities,
    a: &ActorPlan,
) -> Result<Option<&'c CatalogEntry>, ScenarioError> {
    if let Some(m) = &a.model {
        let e = caps
            .catalog
            .iter()
            .find(|e| &e.model_id == m)
            .ok_or_else(|| {
                ScenarioError::Simulator(format!(
                    "actor '{}': model '{m}' is not in the {} profile's catalogue (it has: {})",
                    a.id,
                    caps.profile,
                    caps.catalog
                        .iter()
                        .map(|e| e.model_id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })?;
        return Ok(Some(e));
    }
    let (category, _) = category(a);
    Ok(caps
        .catalog
        .iter()
        .find(|e| e.category == a.category)
        .or_else(|| {
            caps.catalog.iter().find(|e| match category {
                ActorCategory::Pedestrian => e.category == "pedestrian",
                ActorCategory::StaticObject => e.category == "static",
                _ => false,
            })
        }))
}

/// Creates every plan actor at its planned start; `dynamic[i]`: actor i is
/// moved by pedals and steering (its initial mode). Each is announced to
/// the log recorder, when there is one.
pub(crate) fn create(
    ssp: &mut dyn Ssp,
    sim: &Sim,
    plan: &Plan,
    dynamic: &[bool],
    mut rec: Option<&mut LogRecorder>,
) -> Result<Cast, ScenarioError> {
    let caps = &sim.caps;
    let mut cast = Cast {
        dims: Vec::with_capacity(plan.actors.len()),
        limits: Vec::with_capacity(plan.actors.len()),
        catalogue: Vec::with_capacity(plan.actors.len()),
    };
    for (a, &dynamic) in plan.actors.iter().zip(dynamic) {
        let s0 = a.samples[0];
        let (category, actor_type) = category(a);
        let entry = entry(caps, a)?;
        let (sy, cy) = math::sin_cos(s0.yaw);
        let desc = ssp
            .create_actor(CreateActor {
                actor_id: a.id.clone(),
                spec: ActorSpec {
                    actor_type: actor_type.into(),
                    category,
                    model_id: entry.map(|e| e.model_id.clone()).unwrap_or_default(),
                    length: Some(a.length),
                    width: Some(a.width),
                    ..ActorSpec::default()
                },
                position: to_sim(Coord6::xy_yaw(s0.x, s0.y, s0.yaw), sim.mirror),
                speed: to_sim(
                    Coord6 {
                        x: Some(s0.v * cy),
                        y: Some(s0.v * sy),
                        ..Coord6::default()
                    },
                    sim.mirror,
                ),
                initial_mode: if dynamic {
                    MoveMode::Dynamic
                } else {
                    MoveMode::Kinematic
                },
                ..CreateActor::default()
            })
            .map_err(ssp_err)?;
        let e = caps.catalog.iter().find(|e| e.model_id == desc.model_id);
        let mass = e.map_or(1500.0, |e| e.mass);
        if let Some(r) = rec.as_deref_mut() {
            r.actor(
                &a.id,
                actor_type,
                &desc.model_id,
                desc.length,
                desc.width,
                mass,
            );
        }
        let lim = Limits::of(e, desc.length);
        cast.catalogue.push(lim);
        cast.dims.push((desc.length, desc.width, mass));
        // The drivers scale brake commands by the deceleration the model
        // really has (the seed's dummy brakes at 30 m/s² whatever the
        // catalogue says).
        let mut lim = lim;
        if let Some(d) = sim.model.as_ref().and_then(|m| m.brake_deceleration(e)) {
            lim.max_decel = d;
        }
        cast.limits.push(lim);
    }
    Ok(cast)
}
