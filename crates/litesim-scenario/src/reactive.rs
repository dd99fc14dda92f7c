//! Non-SUT actors that react to what the others actually do.
//!
//! Each non-SUT actor follows its planned path, but on its own clock: its
//! plan time τ = t + lag. While a phase asks it to end at a gap to another
//! actor ([`GapGoal`]), the gap is re-solved every step against where that
//! actor really is: the actor keeps, relative to the actual reference, the
//! gap its plan had to the planned reference (one second ahead, so it
//! closes any difference within about a second), which ends at the goal's
//! gap — rate-limited to [`ACCEL_UP`] / [`ACCEL_DOWN`]. Outside goals its
//! speed returns to the plan's. The warp only stretches time along the plan, so paths, lane
//! changes and headings stay as planned; an actor that never reacts keeps
//! τ = t exactly (lag 0.0), which is the scenario player's behaviour bit
//! for bit.

use crate::plan::{ActorPlan, GapGoal};
use crate::state::BodyState;
use litesim_core::math;
use serde::Serialize;

/// Speed-up limit of a reacting actor (m/s²).
pub const ACCEL_UP: f64 = 3.0;
/// Slow-down limit of a reacting actor (m/s²).
pub const ACCEL_DOWN: f64 = 6.0;
/// Tolerance of a strict gap goal (m).
pub const GAP_TOLERANCE: f64 = 1.0;

/// One actor's clock.
#[derive(Clone, Copy, Debug, Default)]
pub struct Warp {
    /// τ − t (s).
    pub lag: f64,
    /// dτ/dt.
    pub rate: f64,
    /// Lag when the actor's trajectory was last sent.
    pub sent_lag: f64,
    /// The re-timed motion's acceleration over the last step (m/s²): what
    /// a pedal driver feeds forward.
    pub accel: f64,
    /// Sideways shift of the actor's planned path (m, left +): a lane goal
    /// follows its reference's shift from the reference's own plan.
    pub offset: f64,
    /// Offset when the actor's trajectory was last sent.
    pub sent_offset: f64,
}

/// What a goal came to at its phase's end.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GoalResult {
    /// The goal.
    pub actor: String,
    /// Reference actor.
    pub reference: String,
    /// In front of or behind the reference.
    pub relation: crate::intent::Order,
    /// Wanted gap (m).
    pub wanted: f64,
    /// Gap at the phase's end (m, bumper to bumper, + on the wanted side).
    pub got: f64,
    /// Phase end (s).
    pub t: f64,
    /// Met within the tolerance.
    pub met: bool,
    /// Strict (a miss fails the run).
    pub strict: bool,
    /// Where the modifier is.
    pub at: String,
    /// The reference's hardest braking during the phase (m/s², positive)
    /// and when it first braked harder than 0.5 m/s² (s); absent when it
    /// did not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_braking: Option<(f64, f64)>,
    /// For a driver's goal: the hardest deceleration its pursuit asked
    /// (m/s², positive) and the limit it brakes within; absent when it
    /// asked none beyond the limit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub needed: Option<(f64, f64)>,
}

/// Sideways speed of a lane goal's shift (m/s): a lane (3.5 m) in about
/// 2.3 s, a brisk lane change.
pub const LATERAL_SPEED: f64 = 1.5;

/// What a lane goal came to at its phase's end.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LaneResult {
    /// The actor.
    pub actor: String,
    /// Reference actor.
    pub reference: String,
    /// Which lane of the reference's.
    pub relation: crate::intent::LaneRelation,
    /// The lane wanted (OpenDRIVE id), when the reference is on a road.
    pub wanted: Option<i32>,
    /// The lane the actor is in, when on a road.
    pub got: Option<i32>,
    /// Phase end (s).
    pub t: f64,
    /// Met.
    pub met: bool,
    /// Strict (a miss fails the run).
    pub strict: bool,
    /// Where the modifier is.
    pub at: String,
}

/// A planned point moved `offset` m to its left.
pub fn shifted(mut p: crate::plan::PlanSample, offset: f64) -> crate::plan::PlanSample {
    if offset != 0.0 {
        let (s, c) = math::sin_cos(p.yaw);
        p.x -= s * offset;
        p.y += c * offset;
    }
    p
}

impl Warp {
    /// Moves the path's sideways shift towards `target` (m) for one step.
    pub fn shift_towards(&mut self, target: f64, dt: f64) {
        let step = LATERAL_SPEED * dt;
        self.offset += (target - self.offset).clamp(-step, step);
    }
}

/// The gap of `me` to `reference` along the reference's heading, bumper to
/// bumper, positive on the goal's side.
pub fn gap(goal: &GapGoal, me: &BodyState, reference: &BodyState) -> f64 {
    let along = litesim_core::ahead_along(
        litesim_core::Vec2::new(reference.x, reference.y),
        reference.yaw,
        litesim_core::Vec2::new(me.x, me.y),
    );
    goal.sign * along - 0.5 * (me.length + reference.length)
}

impl Warp {
    /// The identity clock.
    pub fn new() -> Self {
        Warp {
            lag: 0.0,
            rate: 1.0,
            sent_lag: 0.0,
            accel: 0.0,
            offset: 0.0,
            sent_offset: 0.0,
        }
    }

    /// Plan time at simulation time `t`.
    pub fn tau(&self, t: f64) -> f64 {
        t + self.lag
    }

    /// Advances the clock by one step `dt` at time `t`: towards the goal's
    /// speed when `goal` is given (with the two bodies), else back to the
    /// plan's speed.
    pub fn advance(
        &mut self,
        plan: &ActorPlan,
        plan_dt: f64,
        t: f64,
        dt: f64,
        goal: Option<(&GapGoal, &BodyState, &BodyState, f64)>,
    ) {
        let tau = self.tau(t);
        let v_plan = plan.speed_at(tau, plan_dt);
        let v_now = v_plan * self.rate;
        let v_want = match goal {
            Some((g, me, other, planned_gap)) => {
                let lead = (g.t1 - t).clamp(dt, 1.0);
                let err = planned_gap - gap(g, me, other);
                (other.speed + g.sign * err / lead).max(0.0)
            }
            None => {
                if self.rate == 1.0 {
                    return;
                }
                v_plan
            }
        };
        let v_new = v_now + (v_want - v_now).clamp(-ACCEL_DOWN * dt, ACCEL_UP * dt);
        self.accel = (v_new - v_now) / dt;
        let rate = if v_plan > 0.5 {
            (v_new / v_plan).clamp(0.0, 4.0)
        } else {
            1.0
        };
        // Back on the plan's speed: the identity again (no drift from
        // rounding).
        self.rate = if goal.is_none() && (rate - 1.0).abs() < 1e-9 {
            1.0
        } else {
            rate
        };
        self.lag += (self.rate - 1.0) * dt;
    }
}
