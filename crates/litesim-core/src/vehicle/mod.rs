//! Vehicle models behind one trait, [`VehicleModel`].
//!
//! * [`SspDynamics`] — the seed's Model SSP equations, exactly.
//! * [`KinematicBicycle`] — seed 001 §1.1, rear-axle or centre-of-gravity reference.
//! * [`ActuatorLag`] — a bicycle whose actuators answer with first-order lag and dead time.
//!
//! [`batch`] steps many vehicles of these models at once, column by column,
//! with the same bits.
//!
//! [`VehicleModelKind`] dispatches statically over the built-in models so that
//! a world of thousands of actors steps without virtual calls.

pub mod batch;
mod bicycle;
mod derived;
mod lag;
mod ssp_dynamics;

pub use bicycle::{KinematicBicycle, ReferencePoint};
pub use derived::Derived;
pub use lag::ActuatorLag;
pub use ssp_dynamics::{
    BRAKE_DECELERATION, MAX_LINEAR_VELOCITY, MAX_STEERING_WHEEL_ANGLE, SspDynamics, seed_wheelbase,
};

use crate::control::NormalizedPedals;
use serde::{Deserialize, Serialize};

/// The planar state a vehicle model integrates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VehicleState {
    /// East (m).
    pub x: f64,
    /// North (m).
    pub y: f64,
    /// Height (m); kept as given (no vertical dynamics).
    pub z: f64,
    /// Heading (rad), wrapped into (−π, π].
    pub yaw: f64,
    /// Longitudinal speed (m/s), never negative (no reverse driving).
    pub v: f64,
    /// Yaw rate applied in the last step (rad/s).
    pub yaw_rate: f64,
    /// Longitudinal acceleration applied in the last step (m/s²), after saturation.
    pub acceleration: f64,
    /// Road-wheel steering angle applied in the last step (rad), after saturation.
    pub steering_angle: f64,
    /// Path curvature implied by the steering geometry (1/m).
    pub curvature: f64,
    /// Side-slip angle at the reference point (rad); 0 for rear-axle models.
    pub slip_angle: f64,
}

/// The acceleration a step applied: the commanded `a`, unless the speed
/// limits cut the free speed `v_free = v + a·dt` to `v_new` (then what was
/// achieved). No division on the common path. Shared by the models and the
/// batch loops, which must give the same bits.
#[inline(always)]
pub(crate) fn applied_acceleration(a: f64, v: f64, v_free: f64, v_new: f64, dt: f64) -> f64 {
    if v_new == v_free { a } else { (v_new - v) / dt }
}

/// What a vehicle model is told to do for one step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "type")]
pub enum VehicleInput {
    /// Pedals and steering, normalised (see [`crate::normalize_command`]).
    Pedals(NormalizedPedals),
    /// Longitudinal acceleration (m/s²) and road-wheel angle (rad), for planners and MPC.
    Direct {
        /// Requested acceleration (m/s²); saturated by the model.
        acceleration: f64,
        /// Requested road-wheel angle (rad, positive left); saturated by the model.
        steering_angle: f64,
    },
}

impl Default for VehicleInput {
    /// No pedal pressed, wheels straight.
    fn default() -> Self {
        VehicleInput::Pedals(NormalizedPedals::default())
    }
}

/// A vehicle model: integrates one fixed step.
pub trait VehicleModel {
    /// Advances `state` by `dt` seconds under `input`.
    ///
    /// Inputs are saturated to the model's limits before integration; the
    /// model never produces NaN from finite inputs.
    fn step(&mut self, state: &mut VehicleState, input: &VehicleInput, dt: f64);
    /// Wheelbase (m).
    fn wheelbase(&self) -> f64;
    /// Distance from the rear axle to the centre of gravity (m).
    fn rear_to_cg(&self) -> f64 {
        self.wheelbase() / 2.0
    }
    /// A short name for logs ("ssp", "bicycle", "lag").
    fn name(&self) -> &'static str;
}

/// The built-in models, dispatched without virtual calls.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "model")]
pub enum VehicleModelKind {
    /// [`SspDynamics`].
    Ssp(SspDynamics),
    /// [`KinematicBicycle`].
    Bicycle(KinematicBicycle),
    /// [`ActuatorLag`].
    Lag(ActuatorLag),
}

impl VehicleModelKind {
    /// Compiles a standing command for the batch loops ([`batch`]), or
    /// `None` when this model or this case is stepped one vehicle at a time.
    pub fn compile(
        &mut self,
        input: &VehicleInput,
        state: &VehicleState,
        dt: f64,
    ) -> Option<batch::Compiled> {
        match self {
            VehicleModelKind::Ssp(m) => m.compile(input, state, dt),
            VehicleModelKind::Bicycle(m) => m.compile(input, state, dt),
            // Its actuators carry state from step to step.
            VehicleModelKind::Lag(_) => None,
        }
    }
}

impl VehicleModelKind {
    /// The gear: backwards (`true`) or forwards; `None` for a model with
    /// no reverse gear (the actuator-lag model).
    pub fn reverse(&self) -> Option<bool> {
        match self {
            VehicleModelKind::Ssp(m) => Some(m.reverse),
            VehicleModelKind::Bicycle(m) => Some(m.reverse),
            VehicleModelKind::Lag(_) => None,
        }
    }

    /// The same model in the other gear, or `None` when it has no reverse.
    pub fn with_reverse(&self, reverse: bool) -> Option<Self> {
        let mut m = self.clone();
        match &mut m {
            VehicleModelKind::Ssp(x) => x.reverse = reverse,
            VehicleModelKind::Bicycle(x) => x.reverse = reverse,
            VehicleModelKind::Lag(_) => return None,
        }
        Some(m)
    }
}

impl VehicleModel for VehicleModelKind {
    #[inline]
    fn step(&mut self, state: &mut VehicleState, input: &VehicleInput, dt: f64) {
        match self {
            VehicleModelKind::Ssp(m) => m.step(state, input, dt),
            VehicleModelKind::Bicycle(m) => m.step(state, input, dt),
            VehicleModelKind::Lag(m) => m.step(state, input, dt),
        }
    }
    fn wheelbase(&self) -> f64 {
        match self {
            VehicleModelKind::Ssp(m) => m.wheelbase(),
            VehicleModelKind::Bicycle(m) => m.wheelbase(),
            VehicleModelKind::Lag(m) => m.wheelbase(),
        }
    }
    fn rear_to_cg(&self) -> f64 {
        match self {
            VehicleModelKind::Ssp(m) => m.rear_to_cg(),
            VehicleModelKind::Bicycle(m) => m.rear_to_cg(),
            VehicleModelKind::Lag(m) => m.rear_to_cg(),
        }
    }
    fn name(&self) -> &'static str {
        match self {
            VehicleModelKind::Ssp(m) => m.name(),
            VehicleModelKind::Bicycle(m) => m.name(),
            VehicleModelKind::Lag(m) => m.name(),
        }
    }
}
