//! Actors: who they are ([`ActorDescription`]) and where they are ([`ActorState`]).

use crate::geometry::{Pose, Vec3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// An actor's id, unique within a world. Strings, as in the SSP API.
pub type ActorId = String;

/// Vehicle categories (OpenSCENARIO DSL `vehicle_category` plus a few more).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum VehicleCategory {
    /// A passenger car (sedan, hatchback, SUV).
    #[default]
    Car,
    /// A van or light commercial vehicle.
    Van,
    /// A bus.
    Bus,
    /// A truck.
    Truck,
    /// A truck with trailer or semi-trailer.
    Semitrailer,
    /// A motorbike.
    Motorbike,
    /// An emergency vehicle (police, ambulance, fire).
    Emergency,
}

/// What kind of thing an actor is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "category")]
pub enum ActorKind {
    /// A motor vehicle.
    Vehicle(VehicleCategory),
    /// A pedestrian.
    Person,
    /// A cyclist (bicycle and rider).
    Cyclist,
    /// An animal.
    Animal,
    /// A stationary object (cone, barrier, parked trailer…).
    StationaryObject,
}

impl ActorKind {
    /// True for vehicles (the only kind dynamic control applies to by default).
    pub fn is_vehicle(self) -> bool {
        matches!(self, ActorKind::Vehicle(_))
    }

    /// The kind without a vehicle's category.
    pub fn class(self) -> ActorClass {
        match self {
            ActorKind::Vehicle(_) => ActorClass::Vehicle,
            ActorKind::Person => ActorClass::Person,
            ActorKind::Cyclist => ActorClass::Cyclist,
            ActorKind::Animal => ActorClass::Animal,
            ActorKind::StationaryObject => ActorClass::Stationary,
        }
    }
}

/// What kind of thing an actor is, without a vehicle's category: what a
/// scenario declares (`vehicle`, `person`, …) before a model is chosen.
/// [`ActorKind`] is the same with the category ([`ActorKind::class`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActorClass {
    /// A vehicle (cars, trucks, …; the ego is one).
    Vehicle,
    /// A pedestrian.
    Person,
    /// A cyclist.
    Cyclist,
    /// An animal.
    Animal,
    /// A stationary object (obstacle, cone, parked box).
    Stationary,
}

/// An actor's description, given at creation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActorDescription {
    /// What kind of actor.
    pub kind: ActorKind,
    /// Free-text type as in Foretify ("Ego", "Vehicle", "Pedestrian").
    pub actor_type: String,
    /// Model / blueprint name, e.g. `vehicle.tesla.model3`.
    pub model: String,
    /// Bounding-box length (m).
    pub length: f64,
    /// Bounding-box width (m).
    pub width: f64,
    /// Bounding-box height (m).
    pub height: f64,
    /// Mass (kg).
    pub mass: f64,
    /// Free-form properties, sorted by key so that outputs are deterministic.
    pub properties: BTreeMap<String, String>,
}

impl ActorDescription {
    /// A passenger car with typical dimensions (4.6 × 1.9 × 1.5 m, 1,500 kg).
    pub fn car(model: &str) -> Self {
        Self {
            kind: ActorKind::Vehicle(VehicleCategory::Car),
            actor_type: "Vehicle".into(),
            model: model.into(),
            length: 4.6,
            width: 1.9,
            height: 1.5,
            mass: 1500.0,
            properties: BTreeMap::new(),
        }
    }
}

/// Whether an actor following an xy trajectory is still on it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrajectoryStatus {
    /// Not in trajectory mode.
    #[default]
    None,
    /// Placed on the trajectory at the current time.
    Following,
    /// The current time is before the first point: the actor holds the first point.
    NotStarted,
    /// The trajectory ran out: the actor holds its last point.
    Exhausted,
}

/// An actor's state at one instant, in the world frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActorState {
    /// 6-DoF pose (m, rad).
    pub pose: Pose,
    /// Velocity in the world frame (m/s).
    pub velocity: Vec3,
    /// Acceleration in the world frame (m/s²).
    pub acceleration: Vec3,
    /// Yaw rate (rad/s).
    pub yaw_rate: f64,
    /// Signed longitudinal speed (m/s).
    pub speed: f64,
    /// Longitudinal acceleration along the heading (m/s²).
    pub long_acceleration: f64,
    /// Trajectory-following status.
    pub trajectory: TrajectoryStatus,
}

impl ActorState {
    /// A state at rest at `pose`.
    pub fn at_rest(pose: Pose) -> Self {
        Self {
            pose,
            ..Self::default()
        }
    }
    /// True when every number is finite.
    pub fn is_finite(&self) -> bool {
        self.pose.is_finite()
            && self.velocity.is_finite()
            && self.acceleration.is_finite()
            && self.yaw_rate.is_finite()
            && self.speed.is_finite()
            && self.long_acceleration.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_class_is_the_kind_without_category_and_keeps_the_scenario_words() {
        let kinds = [
            (ActorKind::Vehicle(VehicleCategory::Bus), "\"vehicle\""),
            (ActorKind::Person, "\"person\""),
            (ActorKind::Cyclist, "\"cyclist\""),
            (ActorKind::Animal, "\"animal\""),
            (ActorKind::StationaryObject, "\"stationary\""),
        ];
        for (kind, word) in kinds {
            assert_eq!(serde_json::to_string(&kind.class()).unwrap(), word);
        }
    }
}
