//! Driving planned legs: the MPC cycle of a closed loop, one leg after the
//! other, the gear changing at each cusp.
//!
//! One follower serves both callers that drive a plan: the planning
//! example's closed loop ([`crate::closed_loop`]) and the `fmt-mpc` system
//! under test in scenarios. Each MPC cycle it is given the vehicle's state
//! and answers with the command for the model (the signed speed's rate and
//! the road-wheel angle) and the gear. A reversing leg is tracked by the
//! vehicle turned around (heading + π, speed and commands negated: the same
//! bicycle equations forwards); the next leg starts once the vehicle has
//! stopped at the end of the one before (or stalled within half a metre of
//! it for a second), rebuilt from where the vehicle actually stands.

use crate::closed_loop::{Leg, turned_around};
use crate::corridor::RefState;
use crate::grid::PlanningGrid;
use crate::mpc::{Mpc, MpcError};
use litesim_core::Vec2;
use litesim_core::geometry::wrap_angle;
use std::cell::OnceCell;

/// A leg counts as driven this close to its end (m) …
const LEG_END: f64 = 0.1;
/// … at this speed or less (m/s).
const LEG_STOP: f64 = 0.1;

/// The grids a plan was made on: the vehicle's footprint with its margin,
/// and the same body mirrored for stretches driven backwards (made the
/// first time one is needed).
#[derive(Debug)]
pub struct Grids {
    /// The grid for forward driving.
    pub forward: PlanningGrid,
    backward: OnceCell<PlanningGrid>,
}

impl Grids {
    /// The grids of `forward` (the mirrored one made on demand).
    pub fn new(forward: PlanningGrid) -> Self {
        Self {
            forward,
            backward: OnceCell::new(),
        }
    }

    /// The forward grid, given back.
    pub fn into_forward(self) -> PlanningGrid {
        self.forward
    }

    /// The grid for driving forwards or (`reverse`) backwards.
    pub fn for_direction(&self, reverse: bool) -> &PlanningGrid {
        // (The mirrored body is made once, the first time it is asked for.)
        if reverse {
            self.backward.get_or_init(|| self.forward.reversed())
        } else {
            &self.forward
        }
    }
}

/// The vehicle as the follower needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FollowerVehicle {
    /// Wheelbase (m).
    pub wheelbase: f64,
    /// Steering limit (rad).
    pub max_steer: f64,
    /// Steering-rate limit (rad/s).
    pub max_steer_rate: f64,
}

/// One MPC cycle's answer.
#[derive(Clone, Debug, PartialEq)]
pub struct Steer {
    /// The command's acceleration: the rate of the signed speed (m/s²;
    /// reversing, negative speeds the vehicle up backwards).
    pub acceleration: f64,
    /// The road-wheel angle (rad, + = left), as the model takes it.
    pub steering: f64,
    /// The gear: the leg being driven reverses.
    pub reverse: bool,
    /// The gear changed this cycle (a new leg began in the other
    /// direction).
    pub gear_changed: bool,
    /// Signed distance from the leg's reference (m).
    pub lateral_error: f64,
    /// Heading error against the reference (rad), in the direction of
    /// travel.
    pub heading_error: f64,
    /// Arc length driven along all legs (m).
    pub progress: f64,
    /// The MPC's predicted states `[x, y, heading, speed]` in the world's
    /// frame (heading the body's, speed signed).
    pub predicted: Vec<[f64; 4]>,
    /// Why the MPC fell back, when it did.
    pub fallback: Option<String>,
    /// Wall time of the MPC solve (s, from the caller's clock).
    pub solve_s: f64,
}

/// Drives a plan's legs in order.
#[derive(Debug)]
pub struct LegFollower {
    legs: Vec<Leg>,
    vehicle: FollowerVehicle,
    /// Spacing of a rebuilt leg's corridor (m).
    ds: f64,
    leg: usize,
    /// Arc length of the legs before the current one (m).
    before: f64,
    hint: usize,
    /// Cycles spent stopped near a leg's end without reaching it.
    stalled: u32,
    /// Time the reference still waits at a leg's start (s): the wheels
    /// turn at standstill to the leg's first curvature before it moves.
    dwell: f64,
    /// The last command (signed acceleration, wheel angle).
    prev: [f64; 2],
}

impl LegFollower {
    /// A follower of `legs` (at least one) for `vehicle`; a leg rebuilt
    /// from where the vehicle stands is resampled every `ds` m.
    pub fn new(legs: Vec<Leg>, vehicle: FollowerVehicle, ds: f64) -> Self {
        Self {
            legs,
            vehicle,
            ds,
            leg: 0,
            before: 0.0,
            hint: 0,
            stalled: 0,
            dwell: 0.0,
            prev: [0.0, 0.0],
        }
    }

    /// The legs (the current one rebuilt where the vehicle restarted it).
    pub fn legs(&self) -> &[Leg] {
        &self.legs
    }

    /// The legs, given back.
    pub fn into_legs(self) -> Vec<Leg> {
        self.legs
    }

    /// The leg being driven (its index).
    pub fn leg(&self) -> usize {
        self.leg
    }

    /// Whether the leg being driven is the last one.
    pub fn on_last_leg(&self) -> bool {
        self.leg + 1 >= self.legs.len()
    }

    /// One MPC cycle from the vehicle's position, heading and signed
    /// speed; `tracker_dt` is the MPC's step, `clock` times the solve.
    pub fn command(
        &mut self,
        grids: &Grids,
        mpc: &mut Mpc,
        (pos, heading, speed): (Vec2, f64, f64),
        tracker_dt: f64,
        clock: &dyn Fn() -> f64,
    ) -> Result<Steer, MpcError> {
        let veh = self.vehicle;
        // The next leg once this one is driven: the vehicle stopped at its
        // end (or stalled within half a metre of it for a second). The
        // gear changes with it.
        let (mut s, mut lat, mut i) = self.legs[self.leg].corridor.project(pos, self.hint);
        let was = self.legs[self.leg].reverse;
        while self.leg + 1 < self.legs.len() {
            let left = self.legs[self.leg].corridor.length() - s;
            if left <= LEG_END && speed.abs() <= LEG_STOP {
                self.stalled = 0;
            } else if left <= 0.5 && speed.abs() <= LEG_STOP {
                self.stalled += 1;
                if self.stalled < 10 {
                    break;
                }
                self.stalled = 0;
            } else {
                self.stalled = 0;
                break;
            }
            self.before += self.legs[self.leg].corridor.length();
            self.leg += 1;
            self.hint = 0;
            let leg = &mut self.legs[self.leg];
            let (sign, turn) = turned_around(leg.reverse);
            let g = grids.for_direction(leg.reverse);
            if let Some(c) = leg.restarted_at(pos, wrap_angle(heading + turn), g, self.ds) {
                leg.corridor = c;
            }
            (s, lat, i) = leg.corridor.project(pos, self.hint);
            let k0 = leg.corridor.curvature.first().copied().unwrap_or(0.0);
            let need = sign
                * litesim_core::math::atan(veh.wheelbase * k0).clamp(-veh.max_steer, veh.max_steer);
            self.dwell = (need - self.prev[1]).abs() / veh.max_steer_rate + tracker_dt;
        }
        self.hint = i;
        let Leg {
            corridor, reverse, ..
        } = &self.legs[self.leg];
        // Backwards: the vehicle turned around (heading + π, speed and
        // commands negated) drives the leg forwards.
        let (flip, turn) = turned_around(*reverse);
        let yaw = if *reverse {
            wrap_angle(heading + turn)
        } else {
            heading
        };
        let z0 = [pos.x, pos.y, yaw, flip * speed];
        let t0 = corridor.time_at_s(s);
        let n_h = mpc.cfg.horizon;
        let refs: Vec<RefState> = (0..=n_h)
            .map(|k| corridor.at_time(t0 + k as f64 * tracker_dt - self.dwell))
            .collect();
        self.dwell = (self.dwell - tracker_dt).max(0.0);
        let t_mpc = clock();
        let solved = mpc.solve(z0, &refs, [flip * self.prev[0], flip * self.prev[1]]);
        let solve_s = clock() - t_mpc;
        let sol = solved?;
        let (acceleration, steering) = (flip * sol.acceleration, flip * sol.steering);
        self.prev = [acceleration, steering];
        let predicted = if *reverse {
            sol.predicted
                .iter()
                .map(|&[x, y, h, v]| [x, y, wrap_angle(h + turn), -v])
                .collect()
        } else {
            sol.predicted.clone()
        };
        Ok(Steer {
            acceleration,
            steering,
            reverse: *reverse,
            gear_changed: *reverse != was,
            lateral_error: lat,
            heading_error: wrap_angle(yaw - corridor.heading_at_s(s)),
            progress: self.before + s,
            predicted,
            fallback: sol.fallback.clone(),
            solve_s,
        })
    }
}
