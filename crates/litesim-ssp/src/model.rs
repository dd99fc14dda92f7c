//! Models: how a session turns a catalog entry into a vehicle model.
//!
//! The seed's Model SSP lets users pick a model at start-up, with a dummy
//! model by default. A [`Model`] decides which vehicle dynamics an actor gets
//! under dynamic control; kinematic control is the same for all models.

use crate::api::CatalogEntry;
use crate::error::{SspError, SspResult};
use litesim_core::{ActuatorLag, KinematicBicycle, SspDynamics, VehicleModelKind};

/// A pluggable simulator model.
pub trait Model: Send + Sync {
    /// Name used to select it.
    fn name(&self) -> &'static str;
    /// One line for `--help` and capability reports.
    fn summary(&self) -> &'static str;
    /// The vehicle dynamics of an actor created from `entry`, for steps of `dt` s.
    fn vehicle_model(&self, entry: &CatalogEntry, dt: f64) -> VehicleModelKind;
    /// Deceleration at full brake (m/s²) of a vehicle created from `entry`
    /// (`None`: no entry and no model-wide value): what a driver scales
    /// its brake commands by. The catalogue's `max_decel` unless the model
    /// has its own.
    fn brake_deceleration(&self, entry: Option<&CatalogEntry>) -> Option<f64> {
        entry.map(|e| e.max_decel)
    }
}

/// The seed's dummy model: [`SspDynamics`] with wheelbase = 0.6 · length.
#[derive(Clone, Copy, Debug, Default)]
pub struct DummyModel;

impl Model for DummyModel {
    fn name(&self) -> &'static str {
        "dummy"
    }
    fn summary(&self) -> &'static str {
        "the seed's Model SSP: stored kinematic states, SspDynamics under pedals (wheelbase = 0.6·length; max acceleration and wheel angle from the vehicle, brake 30 m/s² and top speed 40 m/s for every vehicle, as the seed states)"
    }
    fn vehicle_model(&self, entry: &CatalogEntry, _dt: f64) -> VehicleModelKind {
        // Only max_acceleration and max_wheels_angle come from the vehicle:
        // the seed's brake deceleration (30 m/s²) and MAX_LINEAR_VELOCITY
        // (40 m/s) hold for all (the catalogue's max_decel and max_speed
        // apply in the bicycle and lag models).
        VehicleModelKind::Ssp(SspDynamics::new(
            litesim_core::seed_wheelbase(entry.length),
            entry.max_accel,
            entry.max_steer_angle_deg,
        ))
    }
    fn brake_deceleration(&self, _entry: Option<&CatalogEntry>) -> Option<f64> {
        Some(litesim_core::vehicle::BRAKE_DECELERATION)
    }
}

/// Kinematic bicycle with the catalog's wheelbase and limits.
#[derive(Clone, Copy, Debug, Default)]
pub struct BicycleModel;

fn bicycle(entry: &CatalogEntry) -> KinematicBicycle {
    let mut b = KinematicBicycle::new(entry.effective_wheelbase());
    b.max_steering_angle = entry.max_steer_angle_deg.to_radians();
    b.max_acceleration = entry.max_accel;
    b.max_deceleration = entry.max_decel;
    b.max_speed = entry.max_speed;
    b
}

impl Model for BicycleModel {
    fn name(&self) -> &'static str {
        "bicycle"
    }
    fn summary(&self) -> &'static str {
        "kinematic bicycle (seed 001 §1.1) with the catalog's wheelbase, steering, acceleration, deceleration and speed limits"
    }
    fn vehicle_model(&self, entry: &CatalogEntry, _dt: f64) -> VehicleModelKind {
        VehicleModelKind::Bicycle(bicycle(entry))
    }
}

/// Kinematic bicycle with actuator lag (τ_a = 0.2 s, τ_δ = 0.1 s) and 0.1 s dead time,
/// after Autoware's simple planning simulator.
#[derive(Clone, Copy, Debug, Default)]
pub struct LagModel;

impl Model for LagModel {
    fn name(&self) -> &'static str {
        "lag"
    }
    fn summary(&self) -> &'static str {
        "kinematic bicycle whose actuators lag (first order, τ_a 0.2 s, τ_δ 0.1 s) after 0.1 s dead time"
    }
    fn vehicle_model(&self, entry: &CatalogEntry, dt: f64) -> VehicleModelKind {
        VehicleModelKind::Lag(ActuatorLag::new(bicycle(entry), 0.2, 0.1, 0.1, dt))
    }
}

/// All built-in models.
pub fn models() -> Vec<Box<dyn Model>> {
    vec![
        Box::new(DummyModel),
        Box::new(BicycleModel),
        Box::new(LagModel),
    ]
}

/// A model by name ("" = dummy); unknown names are an error listing what exists.
pub fn model_by_name(name: &str) -> SspResult<Box<dyn Model>> {
    let name = if name.is_empty() { "dummy" } else { name };
    models()
        .into_iter()
        .find(|m| m.name() == name)
        .ok_or_else(|| {
            SspError::not_found(format!(
                "unknown model '{name}'; available: {}",
                models()
                    .iter()
                    .map(|m| m.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })
}
