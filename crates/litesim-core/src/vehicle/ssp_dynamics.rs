//! The seed's Model SSP vehicle model, transcribed equation by equation.
//!
//! Seed 000 §489.2.3, in its order:
//! 1. acceleration from pedals — brake wins over throttle; with no pedal the
//!    car coasts at `free_deceleration` against its motion;
//! 2. angular velocity from the steering wheel, with the speed *before* this
//!    step's update: `wheels_angle = swp / MAX_STEERING_WHEEL_ANGLE ·
//!    max_wheels_angle` (degrees, because the seed then calls
//!    `math.radians(wheels_angle)`), `R = wheelbase / sin(wheels_angle)`,
//!    `ω = v / R` (zero when the wheels are straight: the seed would divide by
//!    zero there);
//! 3. `v += a·dt`, capped to `[0, 40 m/s]`; heading `+= ω·dt`; position
//!    `+= v·(cos, sin)(heading)·dt` with the *new* speed and heading.
//!
//! Where the seed is silent litesim chooses, and documents:
//! * `MAX_STEERING_WHEEL_ANGLE` = 450° = 7.853981633974483 rad (1.25 turns
//!   lock-to-centre, typical for passenger cars);
//! * `max_wheels_angle` in degrees, default 35°;
//! * `max_acceleration` default 4 m/s² (profiles override per vehicle);
//! * heading is wrapped into (−π, π] after each update so that it stays
//!   precise over millions of steps (the seed lets it grow).

use super::{VehicleInput, VehicleModel, VehicleState, applied_acceleration};
use crate::geometry::wrap_angle;
use crate::math::{self, SinCosCache};
use serde::{Deserialize, Serialize};

/// Deceleration at full brake (m/s²), the seed's `brake_deceleration`,
/// the same for every vehicle.
pub const BRAKE_DECELERATION: f64 = 30.0;

/// Steering-wheel angle at full lock (rad): 450°. The seed uses the constant
/// without giving its value.
pub const MAX_STEERING_WHEEL_ANGLE: f64 = 7.853_981_633_974_483;

/// The seed's `MAX_LINEAR_VELOCITY` (m/s).
pub const MAX_LINEAR_VELOCITY: f64 = 40.0;

/// The seed's dynamic model (see the module docs for every constant).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SspDynamics {
    /// `0.6 · length` (m).
    pub wheelbase: f64,
    /// Acceleration at full throttle (m/s²).
    pub max_acceleration: f64,
    /// Road-wheel angle at full lock (degrees, as in the seed).
    pub max_wheels_angle_deg: f64,
    /// Deceleration at full brake (m/s²); the seed's 30.
    pub brake_deceleration: f64,
    /// Coasting deceleration (m/s²); the seed's 2.
    pub free_deceleration: f64,
    /// Speed cap (m/s); the seed's 40.
    pub max_linear_velocity: f64,
    /// Reverse gear (not in the seed, whose vehicles only go forwards):
    /// the speed runs between −`max_linear_velocity` and 0. A `Direct`
    /// acceleration stays the rate of change of the signed speed, limited
    /// to `max_acceleration` speeding up (negative) and the brakes'
    /// deceleration slowing down; pedals push backwards. Off (the
    /// default), the seed's model exactly.
    #[serde(default)]
    pub reverse: bool,
    // Caches: (wheel angle, wheelbase, curvature sin / L, radius L / sin) of
    // the last steering command (the wheelbase is in the key because it is a
    // public field), and (sin, cos) of the last heading. They only skip
    // recomputation of identical arguments, so results are bit-identical
    // with and without them.
    #[serde(skip)]
    cache_wheels: Option<(f64, f64, f64, f64)>,
    #[serde(skip)]
    cache_yaw: SinCosCache,
    // (steering fraction, max wheel angle, wheel angle) of the last pedals.
    #[serde(skip)]
    cache_steering: Option<(f64, f64, f64)>,
}

/// The seed's wheelbase rule: 60 % of the vehicle's length (m). The seed's
/// model always uses it; elsewhere it is the wheelbase of a vehicle that
/// gives none (a catalogue entry without one, a drawing, a log's steering
/// read back). The one place the rule is written.
pub fn seed_wheelbase(length: f64) -> f64 {
    0.6 * length
}

impl SspDynamics {
    /// The seed's model for a vehicle of the given length (m), with the
    /// defaults documented at module level.
    pub fn for_length(length: f64) -> Self {
        Self::new(seed_wheelbase(length), 4.0, 35.0)
    }

    /// A model with explicit wheelbase (m), max acceleration (m/s²) and max
    /// road-wheel angle (degrees); the seed's constants for the rest.
    pub fn new(wheelbase: f64, max_acceleration: f64, max_wheels_angle_deg: f64) -> Self {
        Self {
            wheelbase,
            max_acceleration,
            max_wheels_angle_deg,
            brake_deceleration: BRAKE_DECELERATION,
            free_deceleration: 2.0,
            max_linear_velocity: MAX_LINEAR_VELOCITY,
            reverse: false,
            cache_wheels: None,
            cache_yaw: SinCosCache::default(),
            cache_steering: None,
        }
    }

    /// The seed's `wheels_angle` (degrees) for a steering fraction:
    /// `swp = steering · MAX_STEERING_WHEEL_ANGLE`, then
    /// `swp / MAX_STEERING_WHEEL_ANGLE · max_wheels_angle` — the division
    /// skipped when the fraction is the last one seen.
    #[inline]
    fn wheels_from_steering(&mut self, steering: f64) -> f64 {
        match self.cache_steering {
            Some((f, m, w)) if f == steering && m == self.max_wheels_angle_deg => w,
            _ => {
                let steering_wheel_position = steering * MAX_STEERING_WHEEL_ANGLE;
                let w =
                    steering_wheel_position / MAX_STEERING_WHEEL_ANGLE * self.max_wheels_angle_deg;
                self.cache_steering = Some((steering, self.max_wheels_angle_deg, w));
                w
            }
        }
    }

    /// `(κ = sin δ / L, R = L / sin δ)` for a non-zero wheel angle δ (degrees).
    #[inline]
    fn turning(&mut self, wheels_angle_deg: f64) -> (f64, f64) {
        match self.cache_wheels {
            Some((a, l, k, r)) if a == wheels_angle_deg && l == self.wheelbase => (k, r),
            _ => {
                let s = math::sin(wheels_angle_deg.to_radians());
                let (k, r) = (s / self.wheelbase, self.wheelbase / s);
                self.cache_wheels = Some((wheels_angle_deg, self.wheelbase, k, r));
                (k, r)
            }
        }
    }
}

/// How a command sets the acceleration of one SSP step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum SspAccel {
    /// A fixed value (m/s²): brake, throttle, or a direct request.
    Fixed(f64),
    /// No pedal: the car coasts at `free_deceleration` against its motion.
    Coast,
}

/// The parts of one SSP step that depend on the command only, not on the
/// state: what [`SspDynamics::step`] computes first, and what a batch of
/// vehicles keeps for as long as their commands stand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SspTerms {
    pub accel: SspAccel,
    /// Road-wheel angle (degrees).
    pub wheels_deg: f64,
    /// `sin δ / L` (1/m); 0 when the wheels are straight.
    pub curvature: f64,
    /// Turning radius `L / sin δ` (m) when the car turns (`ω = v / R`).
    pub radius: Option<f64>,
}

impl SspDynamics {
    /// The command's terms (seed steps 1 and 2 up to the speed). In reverse
    /// gear the pedals push backwards, and a direct acceleration (the
    /// signed speed's rate) is limited the other way round: speeding up
    /// backwards by the engine, slowing down by the brakes.
    #[inline]
    pub(crate) fn terms(&mut self, input: &VehicleInput) -> SspTerms {
        let gear = if self.reverse { -1.0 } else { 1.0 };
        let (accel, wheels_deg) = match *input {
            VehicleInput::Pedals(p) => {
                let a = if p.brake > 0.0 {
                    SspAccel::Fixed(gear * -p.brake * self.brake_deceleration)
                } else if p.throttle > 0.0 {
                    SspAccel::Fixed(gear * p.throttle * self.max_acceleration)
                } else {
                    SspAccel::Coast
                };
                (a, self.wheels_from_steering(p.steering))
            }
            VehicleInput::Direct {
                acceleration,
                steering_angle,
            } => (
                SspAccel::Fixed(if self.reverse {
                    math::clamp(
                        acceleration,
                        -self.max_acceleration,
                        self.brake_deceleration,
                    )
                } else {
                    math::clamp(
                        acceleration,
                        -self.brake_deceleration,
                        self.max_acceleration,
                    )
                }),
                math::clamp(
                    steering_angle.to_degrees(),
                    -self.max_wheels_angle_deg,
                    self.max_wheels_angle_deg,
                ),
            ),
        };
        // ω = v / R with R = L / sin δ, as the seed writes it (zero when the
        // wheels are straight, where the seed would divide by zero).
        let (curvature, radius) = if wheels_deg == 0.0 {
            (0.0, None)
        } else {
            let (k, r) = self.turning(wheels_deg);
            (k, if k == 0.0 { None } else { Some(r) })
        };
        SspTerms {
            accel,
            wheels_deg,
            curvature,
            radius,
        }
    }
}

/// Seed step 3 up to the position, from speed `v` and heading `yaw` under
/// acceleration `a` and angular velocity `w`, the speed kept within
/// `(v_min, v_max)` (`(0, cap)` in drive, `(−cap, 0)` in reverse):
/// `(v_new, heading, applied acceleration)`. `wrap` is `wrap_angle`, or in
/// the batch loops its one-correction form (exactly `wrap_angle` for the
/// headings they accept); one body for both, so they cannot drift apart.
#[inline(always)]
pub(crate) fn ssp_advance(
    v: f64,
    yaw: f64,
    a: f64,
    w: f64,
    (v_min, v_max): (f64, f64),
    dt: f64,
    wrap: impl Fn(f64) -> f64,
) -> (f64, f64, f64) {
    let v_free = v + a * dt;
    let v_new = v_free.min(v_max).max(v_min);
    let yaw = if w == 0.0 { yaw } else { wrap(yaw + w * dt) };
    (v_new, yaw, applied_acceleration(a, v, v_free, v_new, dt))
}

impl VehicleModel for SspDynamics {
    #[inline]
    fn step(&mut self, st: &mut VehicleState, input: &VehicleInput, dt: f64) {
        let v = st.v;
        let terms = self.terms(input);
        let acceleration = match terms.accel {
            SspAccel::Fixed(a) => a,
            SspAccel::Coast => -self.free_deceleration.copysign(v),
        };
        let angular_velocity = match terms.radius {
            Some(r) => v / r,
            None => 0.0,
        };
        // A stop is a stop: the gear does not flip by itself.
        let speeds = if self.reverse {
            (-self.max_linear_velocity, 0.0)
        } else {
            (0.0, self.max_linear_velocity)
        };
        let (v_new, yaw, applied) = ssp_advance(
            v,
            st.yaw,
            acceleration,
            angular_velocity,
            speeds,
            dt,
            wrap_angle,
        );
        let (s, c) = self.cache_yaw.get(yaw);
        st.x += v_new * c * dt;
        st.y += v_new * s * dt;
        st.yaw = yaw;
        st.v = v_new;
        st.yaw_rate = angular_velocity;
        st.acceleration = applied;
        st.steering_angle = terms.wheels_deg.to_radians();
        st.curvature = terms.curvature;
        st.slip_angle = 0.0;
    }
    fn wheelbase(&self) -> f64 {
        self.wheelbase
    }
    fn name(&self) -> &'static str {
        "ssp"
    }
}
