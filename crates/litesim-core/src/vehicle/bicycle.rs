//! The kinematic bicycle of seed 001 §1.1.
//!
//! Rear-axle reference (explicit Euler with the state at step k):
//! `x += v cos ψ dt; y += v sin ψ dt; ψ += v/L · tan δ · dt; v += a dt`.
//!
//! Centre-of-gravity reference: side-slip `β = atan(l_r/L · tan δ)`,
//! `x += v cos(ψ+β) dt; y += v sin(ψ+β) dt; ψ += v/L · cos β · tan δ · dt`
//! (Rajamani, *Vehicle Dynamics and Control*, §2.2).
//!
//! `a` and `δ` are saturated to the configured limits before integration;
//! the speed stays in `[0, max_speed]`.

use super::{VehicleInput, VehicleModel, VehicleState, applied_acceleration};
use crate::geometry::wrap_angle;
use crate::math::{self, SinCosCache};
use serde::{Deserialize, Serialize};

/// Which point of the vehicle the state describes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferencePoint {
    /// The rear axle centre (no side-slip at the reference).
    #[default]
    RearAxle,
    /// The centre of gravity, `rear_to_cg` ahead of the rear axle.
    CenterOfGravity,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct SteerCache {
    key: (f64, f64, f64, ReferencePoint),
    curvature: f64,
    beta: f64,
    cos_beta: f64,
}

/// Kinematic bicycle model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KinematicBicycle {
    /// Wheelbase L (m).
    pub wheelbase: f64,
    /// Rear axle to centre of gravity l_r (m).
    pub rear_to_cg: f64,
    /// Reference point of the state.
    pub reference: ReferencePoint,
    /// Road-wheel angle limit (rad).
    pub max_steering_angle: f64,
    /// Acceleration limit (m/s²).
    pub max_acceleration: f64,
    /// Deceleration limit (m/s², positive).
    pub max_deceleration: f64,
    /// Speed limit (m/s), either way.
    pub max_speed: f64,
    /// Reverse gear: the vehicle drives backwards, its speed between
    /// −`max_speed` and 0. A `Direct` acceleration stays the rate of change
    /// of the (signed) speed, limited to `max_acceleration` speeding up
    /// (negative) and `max_deceleration` slowing down; pedals push
    /// backwards. Off (the default), the speed stays between 0 and
    /// `max_speed`: braking stops the vehicle, it never rolls back.
    #[serde(default)]
    pub reverse: bool,
    // (heading argument, sin, cos) of the last step: straight driving keeps
    // the heading, and recomputing identical trig is the model's main cost.
    // Bit-identical with or without it.
    #[serde(skip)]
    trig_cache: SinCosCache,
    // The last steering command's (δ, L, l_r, reference) — the key, as the
    // geometry is public and may change — and its (κ = tan δ / L, β, cos β):
    // commands change far less often than steps. Bit-identical with or
    // without it.
    #[serde(skip)]
    steer_cache: Option<SteerCache>,
}

impl KinematicBicycle {
    /// A rear-axle bicycle with the given wheelbase and typical passenger-car
    /// limits (35°, +3 / −8 m/s², 60 m/s); `l_r = L/2`.
    pub fn new(wheelbase: f64) -> Self {
        Self {
            wheelbase,
            rear_to_cg: wheelbase / 2.0,
            reference: ReferencePoint::RearAxle,
            max_steering_angle: 35f64.to_radians(),
            max_acceleration: 3.0,
            max_deceleration: 8.0,
            max_speed: 60.0,
            reverse: false,
            trig_cache: SinCosCache::default(),
            steer_cache: None,
        }
    }

    /// Saturated `(a, δ)` for an input. Pedals map linearly: throttle to
    /// `max_acceleration`, brake to `max_deceleration` (brake wins, as in the
    /// seed), steering fraction to `max_steering_angle`.
    pub fn saturate(&self, input: &VehicleInput) -> (f64, f64) {
        let (a, d) = match *input {
            VehicleInput::Pedals(p) => {
                let a = if p.brake > 0.0 {
                    -p.brake * self.max_deceleration
                } else {
                    p.throttle * self.max_acceleration
                };
                (a, p.steering * self.max_steering_angle)
            }
            VehicleInput::Direct {
                acceleration,
                steering_angle,
            } => (acceleration, steering_angle),
        };
        let d = math::clamp(d, -self.max_steering_angle, self.max_steering_angle);
        if self.reverse {
            // Pedals act backwards; speeding up backwards is the engine's
            // limit, slowing down the brakes'.
            let a = match input {
                VehicleInput::Pedals(_) => -a,
                _ => a,
            };
            return (
                math::clamp(a, -self.max_acceleration, self.max_deceleration),
                d,
            );
        }
        (
            math::clamp(a, -self.max_deceleration, self.max_acceleration),
            d,
        )
    }

    /// `(κ = tan δ / L, β, cos β)` of a saturated road-wheel angle δ.
    #[inline]
    pub(crate) fn steer_terms(&mut self, delta: f64) -> (f64, f64, f64) {
        let key = (delta, self.wheelbase, self.rear_to_cg, self.reference);
        match self.steer_cache {
            _ if delta == 0.0 => (0.0, 0.0, 1.0),
            Some(c) if c.key == key => (c.curvature, c.beta, c.cos_beta),
            _ => {
                let tan_d = math::tan(delta);
                let beta = match self.reference {
                    ReferencePoint::CenterOfGravity if tan_d != 0.0 => {
                        math::atan(self.rear_to_cg / self.wheelbase * tan_d)
                    }
                    _ => 0.0,
                };
                let cos_beta = math::cos(beta);
                let curvature = tan_d / self.wheelbase;
                self.steer_cache = Some(SteerCache {
                    key,
                    curvature,
                    beta,
                    cos_beta,
                });
                (curvature, beta, cos_beta)
            }
        }
    }

    /// Integrates one step with already saturated `(a, δ)`.
    #[inline]
    pub fn integrate(&mut self, st: &mut VehicleState, a: f64, delta: f64, dt: f64) {
        let v = st.v;
        let (curvature, beta, cos_beta) = self.steer_terms(delta);
        let (s, c) = self.trig_cache.get(st.yaw + beta);
        st.x += v * c * dt;
        st.y += v * s * dt;
        // Backwards the speed stays in [−max_speed, 0] (a stop is a stop,
        // the gear does not flip by itself).
        let speeds = if self.reverse {
            (-self.max_speed, 0.0)
        } else {
            (0.0, self.max_speed)
        };
        let (yaw_rate, yaw, v_new, applied) =
            bicycle_advance(v, st.yaw, a, (cos_beta, curvature), speeds, dt, wrap_angle);
        st.yaw = yaw;
        st.v = v_new;
        st.yaw_rate = yaw_rate;
        st.acceleration = applied;
        st.steering_angle = delta;
        st.curvature = curvature;
        st.slip_angle = beta;
    }
}

/// One step's heading and speed from speed `v` and heading `yaw` under
/// acceleration `a`, with `(cos β, κ)` of the steering and the speed kept
/// within `(v_min, v_max)`: `(yaw rate, heading, v_new, applied
/// acceleration)`. `wrap` is `wrap_angle`, or in the batch
/// loops its one-correction form (exactly `wrap_angle` for the headings they
/// accept); one body for both, so they cannot drift apart.
#[inline(always)]
pub(crate) fn bicycle_advance(
    v: f64,
    yaw: f64,
    a: f64,
    (cos_beta, curvature): (f64, f64),
    (v_min, v_max): (f64, f64),
    dt: f64,
    wrap: impl Fn(f64) -> f64,
) -> (f64, f64, f64, f64) {
    // ψ̇ = v·κ with κ = tan δ / L (cached with δ): one multiplication
    // instead of a division per step; cos β = 1 for the rear axle.
    let yaw_rate = v * cos_beta * curvature;
    let v_free = v + a * dt;
    let v_new = math::clamp(v_free, v_min, v_max);
    (
        yaw_rate,
        wrap(yaw + yaw_rate * dt),
        v_new,
        applied_acceleration(a, v, v_free, v_new, dt),
    )
}

impl VehicleModel for KinematicBicycle {
    #[inline]
    fn step(&mut self, st: &mut VehicleState, input: &VehicleInput, dt: f64) {
        let (a, d) = self.saturate(input);
        self.integrate(st, a, d, dt);
    }
    fn wheelbase(&self) -> f64 {
        self.wheelbase
    }
    fn rear_to_cg(&self) -> f64 {
        self.rear_to_cg
    }
    fn name(&self) -> &'static str {
        "bicycle"
    }
}
