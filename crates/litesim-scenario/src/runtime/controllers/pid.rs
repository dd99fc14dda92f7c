//! The pedal-and-steering law of dynamic mode: a PID on the speed error
//! (with the planned acceleration as feed-forward) for throttle and brake,
//! and a curvature feed-forward plus PID on lateral and heading error for
//! steering (docs/drivers.md); the gains are the profile's calibration.

use super::ssp_err;
use crate::error::ScenarioError;
use litesim_core::math;
use litesim_log::ControlSample;
use litesim_ssp::api::{CatalogEntry, DynamicMove, Ssp};
use litesim_ssp::profile::{Calibration, PidGains};

/// A vehicle's limits from the simulator's catalogue (defaults: the
/// seed's 0.6 · length wheelbase, 35°, 4 and 8 m/s²): what the drivers
/// scale their commands by and what the SUT is told.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Limits {
    pub wheelbase: f64,
    pub max_steer: f64,
    pub max_accel: f64,
    pub max_decel: f64,
}

impl Limits {
    /// The limits of catalogue entry `e` (the defaults without one).
    pub fn of(e: Option<&CatalogEntry>, length: f64) -> Self {
        Limits {
            wheelbase: e.map_or(litesim_core::seed_wheelbase(length), |e| {
                e.effective_wheelbase()
            }),
            max_steer: e.map_or(35f64, |e| e.max_steer_angle_deg).to_radians(),
            max_accel: e.map_or(4.0, |e| e.max_accel),
            max_decel: e.map_or(8.0, |e| e.max_decel),
        }
    }
}

/// One dynamic actor's pedal and steering loops.
pub(crate) struct Pid {
    /// Integral of the speed error (m).
    integral: f64,
    /// Last speed error (m/s), for its rate.
    last_err: f64,
    /// Integral of the steering error (m·s).
    steer_integral: f64,
    /// Last steering error (m), for its rate.
    last_steer_err: f64,
    /// The vehicle's limits (the brake's as the model really brakes).
    pub lim: Limits,
    mirror: bool,
    /// The profile's command resolution (a fraction of full travel).
    resolution: f64,
}

/// Lever (m) that turns a heading error into the steering error: the
/// steering loop acts on `e_lat + HEADING_LEVER · e_yaw`, the lateral offset
/// of a point this far ahead of the car (docs/drivers.md).
pub const HEADING_LEVER_M: f64 = 1.0;

impl Pid {
    /// Loops at rest for a vehicle with limits `lim`, in a frame that is
    /// `mirror`ed or not, commanding at the profile's `resolution`.
    pub fn new(lim: Limits, mirror: bool, resolution: f64) -> Self {
        Pid {
            integral: 0.0,
            last_err: 0.0,
            steer_integral: 0.0,
            last_steer_err: 0.0,
            lim,
            mirror,
            resolution,
        }
    }

    /// The pedal command (in units of the maximum acceleration; negative =
    /// brake) that gives the planned acceleration `a` by itself.
    pub fn feed_forward(&self, a: f64) -> f64 {
        a / self.lim.max_accel
    }

    /// One step of the speed loop (docs/drivers.md): feed-forward plus PID
    /// on the speed error, with the throttle gains while the car is too
    /// slow and the brake gains while it is too fast. Returns `u` in units
    /// of the maximum acceleration (negative = brake).
    pub fn longitudinal(
        &mut self,
        g: &Calibration,
        a_ref: f64,
        v_ref: f64,
        v: f64,
        dt: f64,
    ) -> f64 {
        let err = v_ref - v;
        self.integral = (self.integral + err * dt).clamp(-5.0, 5.0);
        let derr = (err - self.last_err) / dt;
        self.last_err = err;
        let k = if err >= 0.0 { &g.throttle } else { &g.brake };
        self.feed_forward(a_ref) + k.kp * err + k.ki * self.integral + k.kd * derr
    }

    /// Throttle and brake fractions for `u` (units of the maximum
    /// acceleration, negative = brake), clamped and rounded to the
    /// profile's resolution. In the seed's model a car on no pedal coasts
    /// at 2 m/s²: while the plan holds or gains speed, a command that
    /// rounds to no pedal at all becomes the smallest throttle instead (a
    /// readable 0.0001, where an exact hold would need a denormal).
    pub fn pedals(&self, u: f64, a_ref: f64, v_ref: f64) -> (f64, f64) {
        let r = self.resolution;
        let (throttle, brake) = if u >= 0.0 {
            (quantise(u.clamp(0.0, 1.0), r), 0.0)
        } else {
            let b = -u * self.lim.max_accel / self.lim.max_decel;
            (0.0, quantise(b.clamp(0.0, 1.0), r))
        };
        if throttle == 0.0 && brake == 0.0 && v_ref > 0.01 && a_ref >= 0.0 {
            (r, 0.0)
        } else {
            (throttle, brake)
        }
    }

    /// One step of the steering loop: the reference curvature's wheel
    /// angle plus PID on `e = e_lat + HEADING_LEVER_M · e_yaw`. Returns the
    /// wheel angle (rad).
    pub fn lateral(&mut self, g: &PidGains, kappa: f64, e_lat: f64, e_yaw: f64, dt: f64) -> f64 {
        let e = e_lat + HEADING_LEVER_M * e_yaw;
        self.steer_integral = (self.steer_integral + e * dt).clamp(-2.0, 2.0);
        let de = (e - self.last_steer_err) / dt;
        self.last_steer_err = e;
        math::atan(self.lim.wheelbase * kappa) + g.kp * e + g.ki * self.steer_integral + g.kd * de
    }
}

/// `x` rounded to a multiple of `res` (commands travel at the resolution
/// the profile declares).
pub(crate) fn quantise(x: f64, res: f64) -> f64 {
    if res > 0.0 {
        (x / res).round() * res
    } else {
        x
    }
}

/// Sends a dynamic actor's pedals and steering, recorded in `control`.
pub(crate) fn send_dynamic(
    ssp: &mut dyn Ssp,
    id: &str,
    (throttle, brake): (f64, f64),
    steer: f64,
    d: &Pid,
    control: &mut ControlSample,
) -> Result<(), ScenarioError> {
    let steer = quantise(steer.clamp(-1.0, 1.0), d.resolution);
    let mv = pedals(throttle, brake, steer, &d.lim, d.mirror, control);
    ssp.set_dynamic_move(id, mv, 0).map_err(ssp_err)
}

/// Normalised pedals and steering (+ = left in the map's frame) as a move,
/// recorded in `control`.
pub(crate) fn pedals(
    throttle: f64,
    brake: f64,
    steer: f64,
    lim: &Limits,
    mirror: bool,
    control: &mut ControlSample,
) -> DynamicMove {
    *control = ControlSample {
        throttle,
        brake,
        steering: steer,
        steering_angle: steer * lim.max_steer,
        ..ControlSample::default()
    };
    DynamicMove::Normalized {
        throttle,
        brake,
        // A mirrored (left-handed) profile turns the other way for the same sign.
        steering: if mirror { -steer } else { steer },
    }
}
