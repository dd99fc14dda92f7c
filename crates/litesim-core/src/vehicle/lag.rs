//! Actuators with first-order lag and dead time, around a [`KinematicBicycle`].
//!
//! Real actuators do not answer at once: Autoware's simple planning simulator
//! models acceleration and steering as `u̇ = (u_cmd(t − T_d) − u) / τ`. Here
//! the command is delayed by a whole number of steps (`round(T_d / dt)`, fixed
//! at construction so the model stays tick-based) and the lag is integrated
//! exactly for a held input: `u += (u_cmd − u)·(1 − e^(−dt/τ))`.

use super::{KinematicBicycle, VehicleInput, VehicleModel, VehicleState};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// A bicycle whose acceleration and steering lag behind the command.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActuatorLag {
    /// The vehicle being actuated.
    pub inner: KinematicBicycle,
    /// Acceleration time constant τ_a (s); 0 = no lag.
    pub tau_acceleration: f64,
    /// Steering time constant τ_δ (s); 0 = no lag.
    pub tau_steering: f64,
    /// Dead time in whole steps.
    pub delay_steps: usize,
    queue: VecDeque<(f64, f64)>,
    acceleration: f64,
    steering: f64,
}

impl ActuatorLag {
    /// A lagged bicycle; `dead_time` (s) is rounded to whole steps of `dt`.
    pub fn new(
        inner: KinematicBicycle,
        tau_acceleration: f64,
        tau_steering: f64,
        dead_time: f64,
        dt: f64,
    ) -> Self {
        let delay_steps = if dt > 0.0 && dead_time > 0.0 {
            (dead_time / dt).round() as usize
        } else {
            0
        };
        Self {
            inner,
            tau_acceleration: tau_acceleration.max(0.0),
            tau_steering: tau_steering.max(0.0),
            delay_steps,
            queue: VecDeque::with_capacity(delay_steps + 1),
            acceleration: 0.0,
            steering: 0.0,
        }
    }
}

fn first_order(state: f64, target: f64, tau: f64, dt: f64) -> f64 {
    if tau <= 0.0 {
        target
    } else {
        state + (target - state) * (1.0 - libm::exp(-dt / tau))
    }
}

impl VehicleModel for ActuatorLag {
    fn step(&mut self, st: &mut VehicleState, input: &VehicleInput, dt: f64) {
        let cmd = self.inner.saturate(input);
        self.queue.push_back(cmd);
        // Until the dead time has elapsed the actuators hold their initial state.
        let delayed = if self.queue.len() > self.delay_steps {
            self.queue.pop_front().unwrap_or(cmd)
        } else {
            (self.acceleration, self.steering)
        };
        self.acceleration = first_order(self.acceleration, delayed.0, self.tau_acceleration, dt);
        self.steering = first_order(self.steering, delayed.1, self.tau_steering, dt);
        self.inner
            .integrate(st, self.acceleration, self.steering, dt);
    }
    fn wheelbase(&self) -> f64 {
        self.inner.wheelbase
    }
    fn rear_to_cg(&self) -> f64 {
        self.inner.rear_to_cg
    }
    fn name(&self) -> &'static str {
        "lag"
    }
}
