//! Quantities derived every step (seed 001 §1.3).

use super::VehicleState;
use serde::{Deserialize, Serialize};

/// Standard gravity (m/s²).
pub const G: f64 = 9.806_65;

/// Secondary quantities of one step.
///
/// * `curvature` κ: from the steering geometry, `tan δ / L` for the bicycle,
///   `sin δ / L` for the seed's SSP model (its turning radius is `L / sin δ`).
/// * `lateral_acceleration` a_y = v²·κ (m/s²).
/// * `longitudinal_acceleration` a_x: the speed change of the step over dt (m/s²).
/// * `slip_angle` β: kinematic side-slip at the reference point (rad); the
///   slip indicator of seed 001 (0 for rear-axle references).
/// * `force_longitudinal_n` = m·a_x and `force_lateral_n` = m·a_y (N): force
///   proxies, i.e. the net force a point mass would need.
/// * `friction_use` = √(a_x² + a_y²) / (μ·g): share of the friction circle in
///   use; above 1 a real tyre would slide.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Derived {
    /// Curvature (1/m).
    pub curvature: f64,
    /// Lateral acceleration (m/s²).
    pub lateral_acceleration: f64,
    /// Longitudinal acceleration (m/s²).
    pub longitudinal_acceleration: f64,
    /// Side-slip angle (rad).
    pub slip_angle: f64,
    /// Longitudinal force proxy (N).
    pub force_longitudinal_n: f64,
    /// Lateral force proxy (N).
    pub force_lateral_n: f64,
    /// Friction-circle use (dimensionless).
    pub friction_use: f64,
}

impl Derived {
    /// Derives the quantities from a state after a step, for a vehicle of
    /// `mass` kg on a road with friction coefficient `mu`.
    pub fn from_state(st: &VehicleState, mass: f64, mu: f64) -> Self {
        let a_y = st.v * st.v * st.curvature;
        let a_x = st.acceleration;
        let mu_g = (mu * G).max(f64::MIN_POSITIVE);
        Self {
            curvature: st.curvature,
            lateral_acceleration: a_y,
            longitudinal_acceleration: a_x,
            slip_angle: st.slip_angle,
            force_longitudinal_n: mass * a_x,
            force_lateral_n: mass * a_y,
            friction_use: (a_x * a_x + a_y * a_y).sqrt() / mu_g,
        }
    }
}
