//! Control commands and their normalisation (the seed's `normalize_command`).
//!
//! Simulators speak different actuator units: CARLA takes pedals in 0..1 and
//! steering in −1..1, the dummy model takes forces in N, others a steering
//! wheel angle or a torque. [`normalize_command`] turns any of them into
//! [`NormalizedPedals`] — throttle and brake in `[0, 1]`, steering in
//! `[−1, 1]` of full lock, positive to the left — and rejects NaN, infinities,
//! negative pedals and out-of-range values with an error naming the field,
//! unless the profile asks for a clamp ([`RangePolicy::Clamp`]).

use serde::{Deserialize, Serialize};

/// A pedal command in one of the units simulators use.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "unit", content = "value")]
pub enum PedalInput {
    /// Pedal position as a fraction, `0..=1`.
    Fraction(f64),
    /// Force at the wheels in N; converted through the vehicle's maximum force.
    ForceN(f64),
}

/// A steering command in one of the units simulators use. Positive turns left.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "unit", content = "value")]
pub enum SteeringInput {
    /// Fraction of full lock, `−1..=1`.
    Fraction(f64),
    /// Road-wheel angle in rad (limited by `max_wheel_angle_rad`).
    WheelAngleRad(f64),
    /// Steering-wheel angle in rad (limited by `max_steering_wheel_angle_rad`).
    SteeringWheelAngleRad(f64),
    /// Steering torque in N·m; full lock is reached at `max_steering_torque_nm`
    /// (a linear, quasi-static steering rack: angle ∝ torque).
    TorqueNm(f64),
}

/// A dynamic (pedals and steering) command as sent by a client.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynamicCommand {
    /// Throttle.
    pub throttle: PedalInput,
    /// Brake.
    pub brake: PedalInput,
    /// Steering.
    pub steering: SteeringInput,
}

impl DynamicCommand {
    /// A command in fractions: throttle and brake in `0..=1`, steering in `−1..=1`.
    pub fn fractions(throttle: f64, brake: f64, steering: f64) -> Self {
        Self {
            throttle: PedalInput::Fraction(throttle),
            brake: PedalInput::Fraction(brake),
            steering: SteeringInput::Fraction(steering),
        }
    }
}

/// What to do with a value outside its range.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RangePolicy {
    /// Reject with [`ControlError::OutOfRange`] (the default: silent clamping hides bugs).
    #[default]
    Reject,
    /// Clamp into range. NaN, infinities and negative pedals are still rejected.
    Clamp,
}

/// The actuator limits a normalisation needs (from the profile and the actor).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActuatorLimits {
    /// Drive force at full throttle (N); usually mass × max acceleration.
    pub max_drive_force_n: f64,
    /// Brake force at full brake (N); usually mass × brake deceleration.
    pub max_brake_force_n: f64,
    /// Steering-wheel angle at full lock (rad).
    pub max_steering_wheel_angle_rad: f64,
    /// Road-wheel angle at full lock (rad).
    pub max_wheel_angle_rad: f64,
    /// Steering torque at full lock (N·m).
    pub max_steering_torque_nm: f64,
    /// Out-of-range policy.
    pub policy: RangePolicy,
}

impl Default for ActuatorLimits {
    /// A 1,500 kg car: 4 m/s² drive, 30 m/s² brake (the seed's brake
    /// deceleration), 450° steering-wheel lock, 35° road-wheel lock, 15 N·m at lock.
    fn default() -> Self {
        Self {
            max_drive_force_n: 1500.0 * 4.0,
            max_brake_force_n: 1500.0 * 30.0,
            max_steering_wheel_angle_rad: crate::vehicle::MAX_STEERING_WHEEL_ANGLE,
            max_wheel_angle_rad: 35f64.to_radians(),
            max_steering_torque_nm: 15.0,
            policy: RangePolicy::Reject,
        }
    }
}

/// Pedals and steering in normalised units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NormalizedPedals {
    /// Throttle, `0..=1`.
    pub throttle: f64,
    /// Brake, `0..=1`.
    pub brake: f64,
    /// Steering as a fraction of full lock, `−1..=1`, positive left.
    pub steering: f64,
}

/// A command that cannot be applied; every variant names the offending field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ControlError {
    /// NaN or infinite.
    #[error("{field} is not a finite number ({value})")]
    NotFinite {
        /// The field, e.g. `throttle`.
        field: &'static str,
        /// The value received.
        value: f64,
    },
    /// A pedal below zero.
    #[error("{field} must not be negative (got {value})")]
    Negative {
        /// The field.
        field: &'static str,
        /// The value received.
        value: f64,
    },
    /// Outside `[min, max]`.
    #[error("{field} = {value} is outside [{min}, {max}] {unit}")]
    OutOfRange {
        /// The field.
        field: &'static str,
        /// The value received.
        value: f64,
        /// Lower bound.
        min: f64,
        /// Upper bound.
        max: f64,
        /// Unit of the bounds.
        unit: &'static str,
    },
    /// The limits themselves are unusable (zero or negative maxima).
    #[error("actuator limit {field} must be positive and finite (got {value})")]
    BadLimit {
        /// The limit.
        field: &'static str,
        /// Its value.
        value: f64,
    },
}

fn finite(field: &'static str, value: f64) -> Result<f64, ControlError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ControlError::NotFinite { field, value })
    }
}

fn positive_limit(field: &'static str, value: f64) -> Result<f64, ControlError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ControlError::BadLimit { field, value })
    }
}

fn ranged(
    field: &'static str,
    value: f64,
    min: f64,
    max: f64,
    unit: &'static str,
    policy: RangePolicy,
) -> Result<f64, ControlError> {
    if (min..=max).contains(&value) {
        return Ok(value);
    }
    match policy {
        RangePolicy::Clamp => Ok(value.clamp(min, max)),
        RangePolicy::Reject => Err(ControlError::OutOfRange {
            field,
            value,
            min,
            max,
            unit,
        }),
    }
}

fn pedal(
    field: &'static str,
    input: PedalInput,
    max_force: f64,
    policy: RangePolicy,
) -> Result<f64, ControlError> {
    let (value, unit) = match input {
        PedalInput::Fraction(v) => (v, "fraction"),
        PedalInput::ForceN(v) => (v, "N"),
    };
    finite(field, value)?;
    if value < 0.0 {
        return Err(ControlError::Negative { field, value });
    }
    match input {
        PedalInput::Fraction(v) => ranged(field, v, 0.0, 1.0, unit, policy),
        PedalInput::ForceN(f) => Ok(ranged(field, f, 0.0, max_force, unit, policy)? / max_force),
    }
}

/// Normalises a [`DynamicCommand`] under the given limits.
pub fn normalize_command(
    cmd: &DynamicCommand,
    limits: &ActuatorLimits,
) -> Result<NormalizedPedals, ControlError> {
    let p = limits.policy;
    let throttle = match cmd.throttle {
        PedalInput::ForceN(_) => pedal(
            "throttle",
            cmd.throttle,
            positive_limit("max_drive_force_n", limits.max_drive_force_n)?,
            p,
        )?,
        PedalInput::Fraction(_) => pedal("throttle", cmd.throttle, 1.0, p)?,
    };
    let brake = match cmd.brake {
        PedalInput::ForceN(_) => pedal(
            "brake",
            cmd.brake,
            positive_limit("max_brake_force_n", limits.max_brake_force_n)?,
            p,
        )?,
        PedalInput::Fraction(_) => pedal("brake", cmd.brake, 1.0, p)?,
    };
    let steering = match cmd.steering {
        SteeringInput::Fraction(v) => {
            ranged("steering", finite("steering", v)?, -1.0, 1.0, "fraction", p)?
        }
        SteeringInput::WheelAngleRad(v) => {
            let m = positive_limit("max_wheel_angle_rad", limits.max_wheel_angle_rad)?;
            ranged(
                "steering",
                finite("steering", v)?,
                -m,
                m,
                "rad (road wheel)",
                p,
            )? / m
        }
        SteeringInput::SteeringWheelAngleRad(v) => {
            let m = positive_limit(
                "max_steering_wheel_angle_rad",
                limits.max_steering_wheel_angle_rad,
            )?;
            ranged(
                "steering",
                finite("steering", v)?,
                -m,
                m,
                "rad (steering wheel)",
                p,
            )? / m
        }
        SteeringInput::TorqueNm(v) => {
            let m = positive_limit("max_steering_torque_nm", limits.max_steering_torque_nm)?;
            ranged("steering", finite("steering", v)?, -m, m, "N·m", p)? / m
        }
    };
    Ok(NormalizedPedals {
        throttle,
        brake,
        steering,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(cmd: DynamicCommand, expect: Result<NormalizedPedals, &str>) {
        let got = normalize_command(&cmd, &ActuatorLimits::default()).map_err(|e| e.to_string());
        assert_eq!(got, expect.map_err(str::to_string));
    }

    #[test]
    fn units() {
        let n = |t, b, s| NormalizedPedals {
            throttle: t,
            brake: b,
            steering: s,
        };
        check(
            DynamicCommand::fractions(0.5, 0.0, -0.25),
            Ok(n(0.5, 0.0, -0.25)),
        );
        check(
            DynamicCommand {
                throttle: PedalInput::ForceN(3000.0),
                brake: PedalInput::ForceN(4500.0),
                steering: SteeringInput::TorqueNm(7.5),
            },
            Ok(n(0.5, 0.1, 0.5)),
        );
        check(
            DynamicCommand {
                throttle: PedalInput::Fraction(0.0),
                brake: PedalInput::Fraction(0.0),
                steering: SteeringInput::WheelAngleRad(-35f64.to_radians()),
            },
            Ok(n(0.0, 0.0, -1.0)),
        );
    }

    #[test]
    fn bad_values_name_the_field() {
        check(
            DynamicCommand::fractions(f64::NAN, 0.0, 0.0),
            Err("throttle is not a finite number (NaN)"),
        );
        check(
            DynamicCommand::fractions(0.0, -0.1, 0.0),
            Err("brake must not be negative (got -0.1)"),
        );
        check(
            DynamicCommand::fractions(0.0, 0.0, 1.5),
            Err("steering = 1.5 is outside [-1, 1] fraction"),
        );
        check(
            DynamicCommand::fractions(0.0, 0.0, f64::INFINITY),
            Err("steering is not a finite number (inf)"),
        );
    }

    #[test]
    fn clamp_policy() {
        let limits = ActuatorLimits {
            policy: RangePolicy::Clamp,
            ..ActuatorLimits::default()
        };
        let got = normalize_command(&DynamicCommand::fractions(1.7, 0.0, -3.0), &limits).unwrap();
        assert_eq!((got.throttle, got.steering), (1.0, -1.0));
        // Clamping never hides NaN or negative pedals.
        assert!(normalize_command(&DynamicCommand::fractions(-0.5, 0.0, 0.0), &limits).is_err());
    }
}
