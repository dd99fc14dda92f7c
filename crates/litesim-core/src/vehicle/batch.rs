//! Many vehicles stepped together, column by column.
//!
//! A world of a thousand cars pays most of a step for per-vehicle overhead:
//! one `sin_cos` at a time, branches on the command, stores scattered over
//! large actor records. Here the vehicle states live in columns
//! ([`VehicleColumns`], one `Vec<f64>` per field) and each vehicle's
//! standing command is compiled once into the terms that do not change from
//! step to step ([`Compiled`], kept in [`CommandColumns`]). A step is then
//! one branch-free loop per model over contiguous runs of vehicles, which
//! the compiler vectorises; on x86-64 it is compiled for the baseline and
//! for AVX2 and AVX-512 and the best the machine has is picked at run time
//! (the `pulp` crate; no `unsafe` in litesim).
//!
//! **Bit-identical to [`VehicleModel::step`].** The loops do the very
//! operations of the scalar models in the same order; vector lanes round
//! like scalars (IEEE 754, no fused multiply-add, which Rust never forms), so
//! every instruction-set level gives the same bits (property test
//! `batch_equals_scalar_models` in `tests/props.rs`). Where the shortcut
//! would differ — a heading outside (−π, π] (the scalar `wrap_angle` then
//! takes its slow branch), a turn so fast that one step could wrap twice,
//! non-finite limits — [`SspDynamics::compile`] and
//! [`KinematicBicycle::compile`] refuse and the caller steps that vehicle
//! with its model.
//!
//! [`VehicleModel::step`]: super::VehicleModel::step

use super::bicycle::{KinematicBicycle, bicycle_advance};
use super::ssp_dynamics::{SspAccel, SspDynamics, ssp_advance};
use super::{VehicleInput, VehicleState};
use crate::math;
use std::f64::consts::{PI, TAU};
use std::ops::Range;

/// The largest |heading change| (rad) one compiled step may make: with the
/// heading in (−π, π] the sum stays in (−π−3, π+3], where one correction by
/// 2π is exactly what `wrap_angle` does.
const MAX_TURN_PER_STEP: f64 = 3.0;

/// Vehicle states as columns: element `i` of every vector is vehicle `i`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VehicleColumns {
    /// East (m).
    pub x: Vec<f64>,
    /// North (m).
    pub y: Vec<f64>,
    /// Height (m).
    pub z: Vec<f64>,
    /// Heading (rad).
    pub yaw: Vec<f64>,
    /// Speed (m/s).
    pub v: Vec<f64>,
    /// Yaw rate of the last step (rad/s).
    pub yaw_rate: Vec<f64>,
    /// Acceleration of the last step (m/s²).
    pub acceleration: Vec<f64>,
    /// Road-wheel angle of the last step (rad).
    pub steering_angle: Vec<f64>,
    /// Curvature of the last step (1/m).
    pub curvature: Vec<f64>,
    /// Side-slip angle of the last step (rad).
    pub slip_angle: Vec<f64>,
}

impl VehicleColumns {
    /// Number of vehicles.
    pub fn len(&self) -> usize {
        self.x.len()
    }
    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
    /// Appends a vehicle.
    pub fn push(&mut self, s: &VehicleState) {
        self.x.push(s.x);
        self.y.push(s.y);
        self.z.push(s.z);
        self.yaw.push(s.yaw);
        self.v.push(s.v);
        self.yaw_rate.push(s.yaw_rate);
        self.acceleration.push(s.acceleration);
        self.steering_angle.push(s.steering_angle);
        self.curvature.push(s.curvature);
        self.slip_angle.push(s.slip_angle);
    }
    /// Vehicle `i` (panics when out of range, like indexing).
    pub fn get(&self, i: usize) -> VehicleState {
        VehicleState {
            x: self.x[i],
            y: self.y[i],
            z: self.z[i],
            yaw: self.yaw[i],
            v: self.v[i],
            yaw_rate: self.yaw_rate[i],
            acceleration: self.acceleration[i],
            steering_angle: self.steering_angle[i],
            curvature: self.curvature[i],
            slip_angle: self.slip_angle[i],
        }
    }
    /// Overwrites vehicle `i`.
    pub fn set(&mut self, i: usize, s: &VehicleState) {
        self.x[i] = s.x;
        self.y[i] = s.y;
        self.z[i] = s.z;
        self.yaw[i] = s.yaw;
        self.v[i] = s.v;
        self.yaw_rate[i] = s.yaw_rate;
        self.acceleration[i] = s.acceleration;
        self.steering_angle[i] = s.steering_angle;
        self.curvature[i] = s.curvature;
        self.slip_angle[i] = s.slip_angle;
    }
    /// Writes what vehicle `i` reports for every step of compiled command
    /// `c` — steering angle, curvature, slip ([`Compiled::constant_outputs`]):
    /// the batch loops do not write them.
    pub fn set_command_outputs(&mut self, i: usize, c: &Compiled) {
        let (steering, curvature, slip) = c.constant_outputs();
        self.steering_angle[i] = steering;
        self.curvature[i] = curvature;
        self.slip_angle[i] = slip;
    }
    /// Removes vehicle `i`; later ones move down by one.
    pub fn remove(&mut self, i: usize) {
        for c in [
            &mut self.x,
            &mut self.y,
            &mut self.z,
            &mut self.yaw,
            &mut self.v,
            &mut self.yaw_rate,
            &mut self.acceleration,
            &mut self.steering_angle,
            &mut self.curvature,
            &mut self.slip_angle,
        ] {
            c.remove(i);
        }
    }
}

/// Which loop steps a compiled vehicle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// [`SspDynamics`].
    Ssp,
    /// [`KinematicBicycle`] (either reference point).
    Bicycle,
}

/// A standing command compiled for the batch loops: the terms of a step
/// that depend on the command and the model's parameters, not on the state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Compiled {
    /// An [`SspDynamics`] step.
    Ssp {
        /// Fixed acceleration (m/s²); unused when coasting.
        acceleration: f64,
        /// Coasting: acceleration = −free_deceleration · sign(v).
        coast: bool,
        /// Coasting deceleration (m/s²).
        free_deceleration: f64,
        /// Turning radius (m) when the car turns.
        radius: Option<f64>,
        /// Speed cap (m/s).
        max_speed: f64,
        /// Road-wheel angle (rad), reported.
        steering_angle: f64,
        /// Curvature (1/m), reported.
        curvature: f64,
    },
    /// A [`KinematicBicycle`] step.
    Bicycle {
        /// Saturated acceleration (m/s²).
        acceleration: f64,
        /// Saturated road-wheel angle (rad), reported.
        steering_angle: f64,
        /// `tan δ / L` (1/m).
        curvature: f64,
        /// Side-slip β (rad).
        beta: f64,
        /// cos β.
        cos_beta: f64,
        /// Speed limit (m/s).
        max_speed: f64,
    },
}

impl Compiled {
    /// The loop that steps it.
    pub fn kernel(&self) -> Kernel {
        match self {
            Compiled::Ssp { .. } => Kernel::Ssp,
            Compiled::Bicycle { .. } => Kernel::Bicycle,
        }
    }
    /// What a step reports as (steering angle, curvature, slip angle): the
    /// same every step of the command, so written once, not every step.
    pub fn constant_outputs(&self) -> (f64, f64, f64) {
        match *self {
            Compiled::Ssp {
                steering_angle,
                curvature,
                ..
            } => (steering_angle, curvature, 0.0),
            Compiled::Bicycle {
                steering_angle,
                curvature,
                beta,
                ..
            } => (steering_angle, curvature, beta),
        }
    }
}

fn heading_in_range(yaw: f64) -> bool {
    yaw > -PI && yaw <= PI
}

impl SspDynamics {
    /// Compiles `input` for the batch loops, or `None` where they would not
    /// give [`VehicleModel::step`](super::VehicleModel::step)'s bits (see
    /// the module docs); `state` is the vehicle's state now, `dt` the step.
    pub fn compile(
        &mut self,
        input: &VehicleInput,
        state: &VehicleState,
        dt: f64,
    ) -> Option<Compiled> {
        // The loops drive forwards only; reversing is stepped one by one.
        if self.reverse {
            return None;
        }
        let t = self.terms(input);
        let (acceleration, coast) = match t.accel {
            SspAccel::Fixed(a) => (a, false),
            SspAccel::Coast => (0.0, true),
        };
        let finite = [
            acceleration,
            self.free_deceleration,
            self.max_linear_velocity,
            t.radius.unwrap_or(1.0),
            t.curvature,
            dt,
        ]
        .iter()
        .all(|x| x.is_finite());
        let heading_ok = match t.radius {
            // Straight: the heading is kept; `sin_cos` is exact up to 1024 rad.
            None => state.yaw.abs() < 1024.0,
            Some(r) => {
                // |v| never exceeds the larger of its start and the cap
                // (limits are public fields: a negative cap is possible).
                let v_max = state.v.abs().max(self.max_linear_velocity.abs());
                heading_in_range(state.yaw) && v_max / r.abs() * dt <= MAX_TURN_PER_STEP
            }
        };
        (finite && heading_ok).then_some(Compiled::Ssp {
            acceleration,
            coast,
            free_deceleration: self.free_deceleration,
            radius: t.radius,
            max_speed: self.max_linear_velocity,
            steering_angle: t.wheels_deg.to_radians(),
            curvature: t.curvature,
        })
    }
}

impl KinematicBicycle {
    /// Compiles `input` for the batch loops, or `None` where they would not
    /// give [`VehicleModel::step`](super::VehicleModel::step)'s bits (see
    /// the module docs); `state` is the vehicle's state now, `dt` the step.
    pub fn compile(
        &mut self,
        input: &VehicleInput,
        state: &VehicleState,
        dt: f64,
    ) -> Option<Compiled> {
        // The loops drive forwards only; reversing is stepped one by one.
        if self.reverse {
            return None;
        }
        let (a, delta) = self.saturate(input);
        let (curvature, beta, cos_beta) = self.steer_terms(delta);
        let finite = [a, delta, curvature, beta, cos_beta, self.max_speed, dt]
            .iter()
            .all(|x| x.is_finite());
        // |v| never exceeds the larger of its start and the limit (limits
        // are public fields: a negative limit is possible).
        let v_max = state.v.abs().max(self.max_speed.abs());
        let ok = finite
            && heading_in_range(state.yaw)
            && v_max * (cos_beta * curvature).abs() * dt <= MAX_TURN_PER_STEP;
        ok.then_some(Compiled::Bicycle {
            acceleration: a,
            steering_angle: delta,
            curvature,
            beta,
            cos_beta,
            max_speed: self.max_speed,
        })
    }
}

/// Compiled commands as columns, index-aligned with a [`VehicleColumns`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CommandColumns {
    kernel: Vec<Option<Kernel>>,
    acceleration: Vec<f64>,
    coast: Vec<bool>,
    free_deceleration: Vec<f64>,
    turning: Vec<bool>,
    radius: Vec<f64>,
    max_speed: Vec<f64>,
    curvature: Vec<f64>,
    beta: Vec<f64>,
    cos_beta: Vec<f64>,
}

impl CommandColumns {
    /// `n` vehicles, none compiled.
    pub fn with_len(n: usize) -> Self {
        let mut c = Self::default();
        c.resize(n);
        c
    }
    /// Grows or shrinks to `n` vehicles; new ones are not compiled.
    pub fn resize(&mut self, n: usize) {
        self.kernel.resize(n, None);
        self.acceleration.resize(n, 0.0);
        self.coast.resize(n, false);
        self.free_deceleration.resize(n, 0.0);
        self.turning.resize(n, false);
        self.radius.resize(n, 1.0);
        self.max_speed.resize(n, 0.0);
        self.curvature.resize(n, 0.0);
        self.beta.resize(n, 0.0);
        self.cos_beta.resize(n, 1.0);
    }
    /// Number of vehicles.
    pub fn len(&self) -> usize {
        self.kernel.len()
    }
    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.kernel.is_empty()
    }
    /// The loop vehicle `i` is stepped by, if compiled.
    pub fn kernel(&self, i: usize) -> Option<Kernel> {
        self.kernel[i]
    }
    /// Sets (or with `None` clears) vehicle `i`'s compiled command.
    pub fn set(&mut self, i: usize, c: Option<Compiled>) {
        self.kernel[i] = c.map(|c| c.kernel());
        match c {
            None => {}
            Some(Compiled::Ssp {
                acceleration,
                coast,
                free_deceleration,
                radius,
                max_speed,
                curvature,
                ..
            }) => {
                self.acceleration[i] = acceleration;
                self.coast[i] = coast;
                self.free_deceleration[i] = free_deceleration;
                self.turning[i] = radius.is_some();
                self.radius[i] = radius.unwrap_or(1.0);
                self.max_speed[i] = max_speed;
                self.curvature[i] = curvature;
            }
            Some(Compiled::Bicycle {
                acceleration,
                curvature,
                beta,
                cos_beta,
                max_speed,
                ..
            }) => {
                self.acceleration[i] = acceleration;
                self.curvature[i] = curvature;
                self.beta[i] = beta;
                self.cos_beta[i] = cos_beta;
                self.max_speed[i] = max_speed;
            }
        }
    }
    /// Maximal runs of consecutive vehicles stepped by the same loop, in order.
    pub fn runs(&self) -> Vec<(Kernel, Range<usize>)> {
        let mut runs: Vec<(Kernel, Range<usize>)> = Vec::new();
        self.runs_into(&mut runs);
        runs
    }

    /// [`CommandColumns::runs`] into `runs` (emptied first): a world that
    /// recompiles an actor every step keeps one list.
    pub fn runs_into(&self, runs: &mut Vec<(Kernel, Range<usize>)>) {
        runs.clear();
        for (i, k) in self.kernel.iter().enumerate() {
            let Some(k) = *k else { continue };
            match runs.last_mut() {
                Some((last, r)) if *last == k && r.end == i => r.end = i + 1,
                _ => runs.push((k, i..i + 1)),
            }
        }
    }
}

/// Steps vehicles `range` (all compiled for `kernel`) by `dt`: position,
/// heading, speed, yaw rate and acceleration. Steering angle, curvature and
/// slip are the same every step of a command
/// ([`Compiled::constant_outputs`]); the caller writes them when it compiles
/// ([`VehicleColumns::set_command_outputs`]).
///
/// Panics when `range` is out of bounds of either set of columns.
pub fn step_run(
    states: &mut VehicleColumns,
    cmds: &CommandColumns,
    kernel: Kernel,
    range: Range<usize>,
    dt: f64,
) {
    step_run_at(Level::Best, states, cmds, kernel, range, dt);
}

/// The instruction-set levels the loops are compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// The best this machine has (what [`step_run`] uses).
    Best,
    /// Baseline of the target (SSE2 on x86-64).
    Baseline,
    /// x86-64-v3 (AVX2).
    #[cfg(target_arch = "x86_64")]
    V3,
    /// x86-64-v4 (AVX-512).
    #[cfg(target_arch = "x86_64")]
    V4,
}

impl Level {
    /// Every level this machine can run, best first.
    pub fn available() -> Vec<Level> {
        #[allow(unused_mut)]
        let mut v = vec![Level::Best, Level::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if pulp::x86::V3::try_new().is_some() {
                v.push(Level::V3);
            }
            if pulp::x86::V4::try_new().is_some() {
                v.push(Level::V4);
            }
        }
        v
    }
    /// Runs `f` compiled for this level; false (and `f` not run) when the
    /// machine lacks it.
    fn run(self, f: impl FnOnce()) -> bool {
        use pulp::Simd;
        match self {
            Level::Best => pulp::Arch::new().dispatch(f),
            Level::Baseline => pulp::Scalar::new().vectorize(f),
            #[cfg(target_arch = "x86_64")]
            Level::V3 => match pulp::x86::V3::try_new() {
                Some(simd) => simd.vectorize(f),
                None => return false,
            },
            #[cfg(target_arch = "x86_64")]
            Level::V4 => match pulp::x86::V4::try_new() {
                Some(simd) => simd.vectorize(f),
                None => return false,
            },
        }
        true
    }
}

/// [`step_run`] compiled for a chosen instruction-set level (for tests and
/// benchmarks: every level gives the same bits); false when the machine
/// lacks the level.
pub fn step_run_at(
    level: Level,
    states: &mut VehicleColumns,
    cmds: &CommandColumns,
    kernel: Kernel,
    range: Range<usize>,
    dt: f64,
) -> bool {
    let r = range;
    let VehicleColumns {
        x,
        y,
        yaw,
        v,
        yaw_rate,
        acceleration,
        ..
    } = states;
    let (x, y, yaw, v) = (
        &mut x[r.clone()],
        &mut y[r.clone()],
        &mut yaw[r.clone()],
        &mut v[r.clone()],
    );
    let (yaw_rate, acc_out) = (&mut yaw_rate[r.clone()], &mut acceleration[r.clone()]);
    let acc = &cmds.acceleration[r.clone()];
    let vmax = &cmds.max_speed[r.clone()];
    match kernel {
        Kernel::Ssp => {
            let (coast, free) = (&cmds.coast[r.clone()], &cmds.free_deceleration[r.clone()]);
            let (turning, radius) = (&cmds.turning[r.clone()], &cmds.radius[r.clone()]);
            level.run(
                #[inline(always)]
                || {
                    ssp_loop(
                        x, y, yaw, v, yaw_rate, acc_out, acc, free, radius, vmax, coast, turning,
                        dt,
                    )
                },
            )
        }
        Kernel::Bicycle => {
            let (curvature, beta) = (&cmds.curvature[r.clone()], &cmds.beta[r.clone()]);
            let cos_beta = &cmds.cos_beta[r.clone()];
            level.run(
                #[inline(always)]
                || {
                    bicycle_loop(
                        x, y, yaw, v, yaw_rate, acc_out, acc, curvature, beta, cos_beta, vmax, dt,
                    )
                },
            )
        }
    }
}

/// `wrap_angle` for a heading in (−π, π] plus at most 3 rad: one
/// correction, as a select so that the loop vectorises.
#[inline(always)]
fn wrap_once(a: f64) -> f64 {
    if a > PI {
        a - TAU
    } else if a <= -PI {
        a + TAU
    } else {
        a
    }
}

/// [`SspDynamics::step`](super::VehicleModel::step), operation for
/// operation, over columns: state `[x, y, yaw, v, yaw_rate, acceleration]`,
/// constants `[acceleration, free_deceleration, radius, max_speed]`, flags
/// `[coast, turning]`.
///
/// The columns come in as separate slices (not fields of a struct) so that
/// the compiler knows the mutable ones do not overlap — without that it
/// cannot vectorise the loop (measured: 8.3 vs ~3 ns per vehicle).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn ssp_loop(
    x: &mut [f64],
    y: &mut [f64],
    yaw: &mut [f64],
    v: &mut [f64],
    yaw_rate: &mut [f64],
    acc_out: &mut [f64],
    acc: &[f64],
    free: &[f64],
    radius: &[f64],
    vmax: &[f64],
    coast: &[bool],
    turning: &[bool],
    dt: f64,
) {
    let n = x.len();
    let (x, y, yaw, v) = (&mut x[..n], &mut y[..n], &mut yaw[..n], &mut v[..n]);
    let (yaw_rate, acc_out) = (&mut yaw_rate[..n], &mut acc_out[..n]);
    let (acc, free, radius, vmax) = (&acc[..n], &free[..n], &radius[..n], &vmax[..n]);
    let (coast, turning) = (&coast[..n], &turning[..n]);
    for i in 0..n {
        // Every operand loaded unconditionally: a load inside a branch
        // cannot be vectorised (the compiler may not read what the scalar
        // code would not).
        let (v0, fixed, free, radius) = (v[i], acc[i], free[i], radius[i]);
        let a = if coast[i] { -free.copysign(v0) } else { fixed };
        let w = if turning[i] { v0 / radius } else { 0.0 };
        let (v_new, h, applied) = ssp_advance(v0, yaw[i], a, w, (0.0, vmax[i]), dt, wrap_once);
        let (s, c) = math::sin_cos_reduced(h);
        x[i] += v_new * c * dt;
        y[i] += v_new * s * dt;
        yaw[i] = h;
        v[i] = v_new;
        yaw_rate[i] = w;
        acc_out[i] = applied;
    }
}

/// [`KinematicBicycle::integrate`], operation for operation, over columns:
/// state `[x, y, yaw, v, yaw_rate, acceleration]`, constants
/// `[acceleration, curvature, β, cos β, max_speed]` (separate slices for
/// the reason given at [`ssp_loop`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn bicycle_loop(
    x: &mut [f64],
    y: &mut [f64],
    yaw: &mut [f64],
    v: &mut [f64],
    yaw_rate: &mut [f64],
    acc_out: &mut [f64],
    acc: &[f64],
    curvature: &[f64],
    beta: &[f64],
    cos_beta: &[f64],
    vmax: &[f64],
    dt: f64,
) {
    let n = x.len();
    let (x, y, yaw, v) = (&mut x[..n], &mut y[..n], &mut yaw[..n], &mut v[..n]);
    let (yaw_rate, acc_out) = (&mut yaw_rate[..n], &mut acc_out[..n]);
    let (acc, curvature, beta) = (&acc[..n], &curvature[..n], &beta[..n]);
    let (cos_beta, vmax) = (&cos_beta[..n], &vmax[..n]);
    for i in 0..n {
        let v0 = v[i];
        let (s, c) = math::sin_cos_reduced(yaw[i] + beta[i]);
        x[i] += v0 * c * dt;
        y[i] += v0 * s * dt;
        let steer = (cos_beta[i], curvature[i]);
        let (w, h, v_new, applied) =
            bicycle_advance(v0, yaw[i], acc[i], steer, (0.0, vmax[i]), dt, wrap_once);
        yaw[i] = h;
        v[i] = v_new;
        yaw_rate[i] = w;
        acc_out[i] = applied;
    }
}
