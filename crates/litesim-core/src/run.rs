//! Seed 001's run loop: a fixed number of steps, with an optional early stop.

use crate::geometry::Vec2;
use crate::world::World;

/// Number of steps for a horizon: `N = ⌈T / dt⌉`, robust to floating error.
///
/// `6.0 / 0.02` is `300.00000000000006` in binary floating point, and a naive
/// ceiling gives 301. A quotient within a relative 1e-9 of an integer counts
/// as that integer. Non-positive or non-finite input gives 0 steps.
pub fn steps_for_horizon(horizon: f64, dt: f64) -> u64 {
    if !(horizon.is_finite() && dt.is_finite() && horizon > 0.0 && dt > 0.0) {
        return 0;
    }
    let r = horizon / dt;
    let nearest = r.round();
    if (r - nearest).abs() <= 1e-9 * nearest.max(1.0) {
        nearest as u64
    } else {
        r.ceil() as u64
    }
}

/// Early stop: the actor is within `radius` of `goal` *and* slower than `speed_threshold`.
#[derive(Clone, Debug, PartialEq)]
pub struct StopCondition {
    /// The actor watched.
    pub actor: String,
    /// Final waypoint (m).
    pub goal: Vec2,
    /// Arrival radius (m).
    pub radius: f64,
    /// Stop speed (m/s).
    pub speed_threshold: f64,
}

impl StopCondition {
    /// True when the world satisfies the condition.
    pub fn reached(&self, world: &World) -> bool {
        world.actor(&self.actor).is_some_and(|a| {
            // One read: an integrating actor's state is computed when read.
            let s = a.state();
            s.pose.position.xy().distance(self.goal) <= self.radius
                && s.speed.abs() < self.speed_threshold
        })
    }
}

/// Runs `N = steps_for_horizon(horizon, dt)` steps, calling `before_step`
/// ahead of each (to set commands) and `after_step` after each (to log),
/// and stops early when `stop` is reached. Returns the steps executed.
pub fn run_loop(
    world: &mut World,
    horizon: f64,
    stop: Option<&StopCondition>,
    mut before_step: impl FnMut(&mut World),
    mut after_step: impl FnMut(&World),
) -> u64 {
    let n = steps_for_horizon(horizon, world.dt());
    for k in 0..n {
        before_step(world);
        world.step();
        after_step(world);
        if stop.is_some_and(|s| s.reached(world)) {
            return k + 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn horizon_steps() {
        assert_eq!(steps_for_horizon(6.0, 0.02), 300);
        assert_eq!(steps_for_horizon(0.3, 0.1), 3);
        assert_eq!(steps_for_horizon(0.35, 0.1), 4);
        assert_eq!(steps_for_horizon(1.0, 0.3), 4);
        assert_eq!(steps_for_horizon(0.0, 0.1), 0);
        assert_eq!(steps_for_horizon(f64::NAN, 0.1), 0);
        assert_eq!(steps_for_horizon(1.0, -0.1), 0);
        for n in 1..2000u64 {
            assert_eq!(steps_for_horizon(n as f64 * 0.02, 0.02), n, "{n}");
            assert_eq!(steps_for_horizon(n as f64 * 0.01, 0.01), n, "{n}");
        }
    }
}
