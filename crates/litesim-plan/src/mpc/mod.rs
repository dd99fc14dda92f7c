//! Tracking MPC for the kinematic bicycle, linearised along the reference
//! (linear time-varying), condensed to a dense QP in the input deviations
//! and solved by a dual active-set method ([`crate::qp`]).
//!
//! State z = (x, y, ψ, v), input u = (a, δ). Around the reference
//! (z_r,k, u_r,k) with δ_r = atan(L·κ_r) and a_r = Δv_r/dt:
//! `e_{k+1} = A_k e_k + B_k Δu_k + c_k`, where A_k, B_k are the Jacobians
//! of the Euler-discretised bicycle and c_k its residual on the reference.
//! Cost: Σ e_kᵀQe_k (terminal weight scaled) + Σ Δu_kᵀRΔu_k + Σ
//! (u_k − u_{k−1})ᵀR_d(u_k − u_{k−1}). Constraints: |δ| ≤ δ_max,
//! a_min ≤ a ≤ a_max, |δ_k − δ_{k−1}| ≤ δ̇_max·dt (from the applied δ).
//!
//! One QP per control cycle around the reference, i.e. a real-time
//! iteration: the reference already is the shifted previous plan (the
//! corridor moves with the vehicle), so the linearisation point needs no
//! extra warm start. The structure is used where it pays: Aₖ and Bₖ have
//! six non-constant entries, so condensing is O(N²) small vector
//! operations; the dual active-set solver starts from the unconstrained
//! optimum, which is the answer whenever no limit binds. Clarabel solves
//! the same QP in sparse form as the reference ([`Mpc::solve_reference`]).

mod reference;
pub(crate) use reference::csc_from_rows;
use reference::*;

use crate::corridor::RefState;
use crate::qp::{DenseQp, SparseRow};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, ZeroConeT,
};
use litesim_core::{math, wrap_angle};
use serde::{Deserialize, Serialize};

/// MPC settings. `dt` and `wheelbase` must be the tracked vehicle's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MpcConfig {
    /// Horizon N (steps).
    pub horizon: usize,
    /// Step of the prediction model (s).
    pub dt: f64,
    /// Wheelbase of the prediction model (m).
    pub wheelbase: f64,
    /// State weights (x, y, ψ, v).
    pub q: [f64; 4],
    /// Terminal weight multiplier.
    pub q_terminal: f64,
    /// Input-deviation weights (a, δ).
    pub r: [f64; 2],
    /// Input-rate weights (a, δ).
    pub r_rate: [f64; 2],
    /// Steering limit (rad).
    pub max_steer: f64,
    /// Steering-rate limit (rad/s).
    pub max_steer_rate: f64,
    /// Lowest acceleration (m/s², negative).
    pub min_accel: f64,
    /// Highest acceleration (m/s²).
    pub max_accel: f64,
    /// Euler sub-steps per prediction step: the plant's integration step
    /// is `dt / substeps`. Predicting with the plant's own discretisation
    /// removes the steady cross-track bias a coarser model leaves on
    /// curves (one 0.1 s Euler step misplaces a car at 9 m/s on a 25 m
    /// radius by centimetres against two 0.05 s steps).
    #[serde(default = "one")]
    pub substeps: usize,
}

fn one() -> usize {
    1
}

impl Default for MpcConfig {
    fn default() -> Self {
        Self {
            horizon: 20,
            dt: 0.1,
            wheelbase: 2.7,
            q: [2.0, 2.0, 4.0, 0.5],
            q_terminal: 4.0,
            r: [0.05, 0.5],
            r_rate: [0.1, 5.0],
            max_steer: 0.6,
            max_steer_rate: 0.8,
            min_accel: -4.0,
            max_accel: 2.0,
            substeps: 1,
        }
    }
}

/// Why a solve failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MpcError {
    /// Settings out of range.
    #[error("invalid MPC settings: {0}")]
    BadConfig(String),
    /// The reference has the wrong length.
    #[error("the MPC needs {expected} reference points (N + 1), got {got}")]
    Reference {
        /// N + 1.
        expected: usize,
        /// Given.
        got: usize,
    },
    /// The solver did not converge.
    #[error("QP solver finished with status {0}")]
    Solver(String),
}

/// The command and the predicted horizon.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MpcSolution {
    /// Acceleration to apply (m/s²).
    pub acceleration: f64,
    /// Steering angle to apply (rad).
    pub steering: f64,
    /// Predicted states (x, y, ψ, v), k = 0..=N.
    pub predicted: Vec<[f64; 4]>,
    /// Planned inputs (a, δ), k = 0..N.
    pub inputs: Vec<[f64; 2]>,
    /// Solver iterations (active-set changes for the structured solver,
    /// interior-point iterations for the reference).
    pub iterations: u32,
    /// Set when the QP could not be solved and the command is the best
    /// admissible one instead (the reason).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fallback: Option<String>,
}

/// A tracking MPC. Its buffers are kept between cycles, so a control loop
/// allocates only the returned solution.
pub struct Mpc {
    /// Settings.
    pub cfg: MpcConfig,
    qp: DenseQp,
    h: Vec<f64>,
    g: Vec<f64>,
    f: Vec<[f64; 4]>,
    psi: Vec<[[f64; 4]; 4]>,
    du: Vec<f64>,
}

impl std::fmt::Debug for Mpc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mpc").field("cfg", &self.cfg).finish()
    }
}

impl Mpc {
    /// An MPC with validated settings.
    pub fn new(cfg: MpcConfig) -> Result<Self, MpcError> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(MpcError::BadConfig(format!(
                    "{name} must be positive, got {v}"
                )))
            }
        };
        if cfg.horizon == 0 || cfg.horizon > 200 {
            return Err(MpcError::BadConfig(format!(
                "horizon must be 1..=200 steps, got {}",
                cfg.horizon
            )));
        }
        pos("dt", cfg.dt)?;
        if cfg.substeps == 0 || cfg.substeps > 100 {
            return Err(MpcError::BadConfig(format!(
                "substeps must be 1..=100, got {}",
                cfg.substeps
            )));
        }
        pos("wheelbase", cfg.wheelbase)?;
        pos("max_steer", cfg.max_steer)?;
        pos("max_steer_rate", cfg.max_steer_rate)?;
        pos("max_accel", cfg.max_accel)?;
        if !(cfg.min_accel.is_finite() && cfg.min_accel < 0.0) {
            return Err(MpcError::BadConfig(format!(
                "min_accel must be negative, got {}",
                cfg.min_accel
            )));
        }
        if cfg
            .q
            .iter()
            .chain(&cfg.r)
            .chain(&cfg.r_rate)
            .chain([&cfg.q_terminal])
            .any(|w| !(w.is_finite() && *w >= 0.0))
        {
            return Err(MpcError::BadConfig("weights must be finite and ≥ 0".into()));
        }
        // Strict convexity in every input (else the optimum is not unique).
        for (m, name) in ["acceleration", "steering"].iter().enumerate() {
            if cfg.r[m] + cfg.r_rate[m] <= 0.0 {
                return Err(MpcError::BadConfig(format!(
                    "the {name} input needs a positive weight (r or r_rate)"
                )));
            }
        }
        Ok(Self {
            cfg,
            qp: DenseQp::default(),
            h: Vec::new(),
            g: Vec::new(),
            f: Vec::new(),
            psi: Vec::new(),
            du: Vec::new(),
        })
    }

    /// Solves for state `z0` = (x, y, ψ, v), the reference at t₀ + k·dt
    /// (k = 0..=N) and the command applied last (a, δ), with the structured
    /// dense solver.
    ///
    /// Never fails on the numbers: a QP the solver cannot answer (non-finite
    /// state or reference, degenerate data) yields the best admissible
    /// command — the reference's feedforward limited to what the actuators
    /// can reach from `prev` — with [`MpcSolution::fallback`] saying why.
    pub fn solve(
        &mut self,
        z0: [f64; 4],
        refs: &[RefState],
        prev: [f64; 2],
    ) -> Result<MpcSolution, MpcError> {
        let lin = self.linearise(z0, refs, prev)?;
        let n = self.cfg.horizon;
        let nu = 2 * n;
        let mut du = std::mem::take(&mut self.du);
        du.clear();
        du.resize(nu, 0.0);
        let outcome = if lin.finite {
            self.condense(&lin);
            let rows = constraint_rows(&self.cfg, &lin);
            self.qp
                .solve(nu, &self.h, &self.g, &rows, &mut du)
                .map(|info| info.changes as u32)
                .map_err(|e| e.to_string())
        } else {
            Err("non-finite state, reference or previous command".to_string())
        };
        let sol = match outcome {
            Ok(changes) => self.finish(z0, &lin, &du, changes, None),
            Err(why) => self.fallback(z0, &lin, why),
        };
        self.du = du;
        Ok(sol)
    }

    /// The same QP solved by Clarabel (interior point) to tolerance `tol`:
    /// the reference the structured solver is tested against, and the
    /// solver this crate used before it.
    pub fn solve_reference(
        &mut self,
        z0: [f64; 4],
        refs: &[RefState],
        prev: [f64; 2],
        tol: f64,
    ) -> Result<MpcSolution, MpcError> {
        let lin = self.linearise(z0, refs, prev)?;
        if !lin.finite {
            return Err(MpcError::Solver("non-finite data".into()));
        }
        let du = clarabel_solve(&self.cfg, &lin, tol)?;
        Ok(self.finish(z0, &lin, &du.0, du.1, None))
    }

    /// The QP's objective (½ΔuᵀHΔu + gᵀΔu, up to a constant) at planned
    /// `inputs`, for comparing answers of different solvers.
    pub fn objective(
        &mut self,
        z0: [f64; 4],
        refs: &[RefState],
        prev: [f64; 2],
        inputs: &[[f64; 2]],
    ) -> Result<f64, MpcError> {
        let lin = self.linearise(z0, refs, prev)?;
        self.condense(&lin);
        let nu = 2 * self.cfg.horizon;
        let x: Vec<f64> = (0..nu)
            .map(|i| inputs.get(i / 2).map_or(0.0, |u| u[i % 2]) - lin.ur[i / 2][i % 2])
            .collect();
        let mut v = 0.0;
        for c in 0..nu {
            let hx: f64 = (0..nu).map(|r| self.h[c * nu + r] * x[r]).sum();
            v += 0.5 * x[c] * hx + self.g[c] * x[c];
        }
        Ok(v)
    }

    /// Reference inputs, reference states and the LTV model along them.
    fn linearise(
        &self,
        z0: [f64; 4],
        refs: &[RefState],
        prev: [f64; 2],
    ) -> Result<Linearised, MpcError> {
        let c = &self.cfg;
        let n = c.horizon;
        if refs.len() != n + 1 {
            return Err(MpcError::Reference {
                expected: n + 1,
                got: refs.len(),
            });
        }
        let (l, dt) = (c.wheelbase, c.dt);
        let finite = z0.iter().chain(&prev).all(|v| v.is_finite())
            && refs.iter().all(|r| {
                [r.p.x, r.p.y, r.heading, r.speed, r.curvature]
                    .iter()
                    .all(|v| v.is_finite())
            });
        let prev = if finite {
            [
                prev[0].clamp(c.min_accel, c.max_accel),
                prev[1].clamp(-c.max_steer, c.max_steer),
            ]
        } else {
            [0.0, 0.0]
        };
        let ur: Vec<[f64; 2]> = (0..n)
            .map(|k| {
                let a = ((refs[k + 1].speed - refs[k].speed) / dt).clamp(c.min_accel, c.max_accel);
                let d = math::atan(l * refs[k].curvature).clamp(-c.max_steer, c.max_steer);
                [a, d]
            })
            .collect();
        let zr: Vec<[f64; 4]> = refs
            .iter()
            .map(|r| [r.p.x, r.p.y, r.heading, r.speed])
            .collect();
        let e0 = [
            z0[0] - zr[0][0],
            z0[1] - zr[0][1],
            wrap_angle(z0[2] - zr[0][2]),
            z0[3] - zr[0][3],
        ];
        let mut model = Vec::with_capacity(n);
        let mut ck = Vec::with_capacity(n);
        let m_sub = c.substeps;
        let h = dt / m_sub as f64;
        for k in 0..n {
            // Compose the sub-steps along the reference: A = Π A_m,
            // B = Σ (Π later A) B_m, and the end point for the residual.
            // Each A_m is unit upper triangular with zeros at (0,1), a
            // pattern products keep, so `Ltv` stores five entries of A.
            let [_, d] = ur[k];
            let tan_d = math::tan(d);
            let cos_d = math::cos(d);
            let mut z = zr[k];
            let mut a_acc = Ltv::identity(dt);
            for _ in 0..m_sub {
                let [_, _, psi, v] = z;
                let (s, co) = math::sin_cos(psi);
                let step = Ltv {
                    a02: -v * s * h,
                    a03: co * h,
                    a12: v * co * h,
                    a13: s * h,
                    a23: tan_d / l * h,
                    b: [
                        [0.0, 0.0],
                        [0.0, 0.0],
                        [0.0, v / (l * cos_d * cos_d) * h],
                        [h, 0.0],
                    ],
                    dt,
                };
                a_acc = step.compose(&a_acc);
                z = [
                    z[0] + v * co * h,
                    z[1] + v * s * h,
                    psi + v * tan_d / l * h,
                    v + ur[k][0] * h,
                ];
            }
            model.push(a_acc);
            ck.push([
                z[0] - zr[k + 1][0],
                z[1] - zr[k + 1][1],
                wrap_angle(z[2] - zr[k + 1][2]),
                z[3] - zr[k + 1][3],
            ]);
        }
        Ok(Linearised {
            ur,
            e0,
            model,
            c: ck,
            prev,
            dt,
            finite,
        })
    }

    /// Eliminates the states: H = P_u + Σ GₖᵀWₖGₖ and g = q_u + Σ GₖᵀWₖfₖ
    /// (fₖ the free response), by backward adjoint recursions that use the
    /// sparsity of Aₖ and Bₖ: O(N²) small vector operations instead of
    /// dense 4N × 2N products.
    fn condense(&mut self, lin: &Linearised) {
        let c = &self.cfg;
        let n = c.horizon;
        let nu = 2 * n;
        let h = &mut self.h;
        let g = &mut self.g;
        h.clear();
        h.resize(nu * nu, 0.0);
        g.clear();
        g.resize(nu, 0.0);
        let w = |k: usize| state_weight(c, k);
        free_response(&mut self.f, lin);
        adjoint_gradient(g, &self.f, lin, &w);
        lyapunov(&mut self.psi, lin, &w);
        prediction_blocks(h, &self.psi, lin);
        // Inputs: deviation weights and the rate coupling.
        let (diag, off, q) = input_cost(c, lin);
        for i in 0..nu {
            h[i * nu + i] += diag[i];
            g[i] += q[i];
            if i >= 2 {
                h[(i - 2) * nu + i] += off[i];
                h[i * nu + i - 2] += off[i];
            }
        }
        // Mirror the lower triangle (the recursion filled rows i ≥ j).
        for col in 0..nu {
            for row in col + 1..nu {
                h[row * nu + col] = h[col * nu + row];
            }
        }
    }

    /// Inputs = reference + Δu (clamped against rounding), and the
    /// nonlinear prediction under them.
    fn finish(
        &self,
        z0: [f64; 4],
        lin: &Linearised,
        du: &[f64],
        iterations: u32,
        fallback: Option<String>,
    ) -> MpcSolution {
        let c = &self.cfg;
        let inputs: Vec<[f64; 2]> = (0..c.horizon)
            .map(|k| {
                [
                    (lin.ur[k][0] + du[2 * k]).clamp(c.min_accel, c.max_accel),
                    (lin.ur[k][1] + du[2 * k + 1]).clamp(-c.max_steer, c.max_steer),
                ]
            })
            .collect();
        let (l, h) = (c.wheelbase, c.dt / c.substeps as f64);
        let mut predicted = Vec::with_capacity(c.horizon + 1);
        let mut z = z0;
        predicted.push(z);
        for u in &inputs {
            let kappa = math::tan(u[1]) / l;
            for _ in 0..c.substeps {
                let (s, co) = math::sin_cos(z[2]);
                z = [
                    z[0] + z[3] * co * h,
                    z[1] + z[3] * s * h,
                    z[2] + z[3] * kappa * h,
                    (z[3] + u[0] * h).max(0.0),
                ];
            }
            predicted.push(z);
        }
        MpcSolution {
            acceleration: inputs[0][0],
            steering: inputs[0][1],
            predicted,
            inputs,
            iterations,
            fallback,
        }
    }

    /// The best admissible command when the QP has no answer: each step's
    /// feedforward, moved from the previous input by at most the rate limit.
    fn fallback(&self, z0: [f64; 4], lin: &Linearised, why: String) -> MpcSolution {
        let c = &self.cfg;
        let lim = c.max_steer_rate * c.dt;
        let mut last = lin.prev;
        let mut du = vec![0.0; 2 * c.horizon];
        for k in 0..c.horizon {
            let want = if lin.finite { lin.ur[k] } else { last };
            let a = want[0].clamp(c.min_accel, c.max_accel);
            let d = want[1].clamp(last[1] - lim, last[1] + lim);
            last = [a, d];
            if lin.finite {
                du[2 * k] = a - lin.ur[k][0];
                du[2 * k + 1] = d - lin.ur[k][1];
            }
        }
        if lin.finite {
            self.finish(z0, lin, &du, 0, Some(why))
        } else {
            // Nothing to predict from: hold the (admissible) last command.
            let inputs = vec![last; c.horizon];
            MpcSolution {
                acceleration: last[0],
                steering: last[1],
                predicted: Vec::new(),
                inputs,
                iterations: 0,
                fallback: Some(why),
            }
        }
    }
}

/// The LTV model of one step: the non-constant entries of Aₖ (unit upper
/// triangular, zero at (0,1)) and Bₖ (4 × 2).
#[derive(Clone, Copy, Debug)]
struct Ltv {
    a02: f64,
    a03: f64,
    a12: f64,
    a13: f64,
    a23: f64,
    b: [[f64; 2]; 4],
    dt: f64,
}

impl Ltv {
    fn identity(dt: f64) -> Self {
        Self {
            a02: 0.0,
            a03: 0.0,
            a12: 0.0,
            a13: 0.0,
            a23: 0.0,
            b: [[0.0; 2]; 4],
            dt,
        }
    }
    /// `self ∘ earlier`: A = A_self·A_earlier, B = A_self·B_earlier + B_self.
    fn compose(&self, earlier: &Ltv) -> Ltv {
        let e = earlier;
        let mut b = self.b;
        for (m, _) in [0, 1].iter().enumerate() {
            let col = self.apply([e.b[0][m], e.b[1][m], e.b[2][m], e.b[3][m]]);
            for r in 0..4 {
                b[r][m] += col[r];
            }
        }
        Ltv {
            a02: e.a02 + self.a02,
            a03: e.a03 + self.a02 * e.a23 + self.a03,
            a12: e.a12 + self.a12,
            a13: e.a13 + self.a12 * e.a23 + self.a13,
            a23: e.a23 + self.a23,
            b,
            dt: self.dt,
        }
    }
    fn apply(&self, v: [f64; 4]) -> [f64; 4] {
        [
            v[0] + self.a02 * v[2] + self.a03 * v[3],
            v[1] + self.a12 * v[2] + self.a13 * v[3],
            v[2] + self.a23 * v[3],
            v[3],
        ]
    }
    fn at(&self, v: [f64; 4]) -> [f64; 4] {
        [
            v[0],
            v[1],
            self.a02 * v[0] + self.a12 * v[1] + v[2],
            self.a03 * v[0] + self.a13 * v[1] + self.a23 * v[2] + v[3],
        ]
    }
    fn bt(&self, v: [f64; 4]) -> [f64; 2] {
        let b = &self.b;
        [
            b[0][0] * v[0] + b[1][0] * v[1] + b[2][0] * v[2] + b[3][0] * v[3],
            b[0][1] * v[0] + b[1][1] * v[1] + b[2][1] * v[2] + b[3][1] * v[3],
        ]
    }
    fn b_col(&self, m: usize) -> [f64; 4] {
        [self.b[0][m], self.b[1][m], self.b[2][m], self.b[3][m]]
    }
}

/// The QP's data for one cycle, shared by both solvers.
#[derive(Clone, Debug)]
struct Linearised {
    /// Reference inputs (a, δ), k = 0..N.
    ur: Vec<[f64; 2]>,
    /// Initial error.
    e0: [f64; 4],
    model: Vec<Ltv>,
    /// Residual of the model on the reference.
    c: Vec<[f64; 4]>,
    /// The applied command, clamped to the limits.
    prev: [f64; 2],
    dt: f64,
    /// All inputs finite.
    finite: bool,
}

/// Weight of the state error e_k, k = 1..=N (P's diagonal: 2·q, times the
/// terminal factor at N).
fn state_weight(c: &MpcConfig, k: usize) -> [f64; 4] {
    let t = if k == c.horizon { c.q_terminal } else { 1.0 };
    [
        2.0 * c.q[0] * t,
        2.0 * c.q[1] * t,
        2.0 * c.q[2] * t,
        2.0 * c.q[3] * t,
    ]
}

/// The free response f_k (no input deviation), k = 0..=N, into `f`.
fn free_response(f: &mut Vec<[f64; 4]>, lin: &Linearised) {
    f.clear();
    f.push(lin.e0);
    for (k, m) in lin.model.iter().enumerate() {
        let nx = m.apply(f[k]);
        f.push(add4(nx, lin.c[k]));
    }
}

/// Adds the free response's gradient Σ GₖᵀWₖfₖ to `g`, by the adjoint λ
/// run backwards from the horizon.
fn adjoint_gradient(
    g: &mut [f64],
    f: &[[f64; 4]],
    lin: &Linearised,
    w: &dyn Fn(usize) -> [f64; 4],
) {
    let n = lin.model.len();
    let mut lam = mul4(w(n), f[n]);
    for j in (0..n).rev() {
        let bt = lin.model[j].bt(lam);
        g[2 * j] += bt[0];
        g[2 * j + 1] += bt[1];
        if j > 0 {
            lam = add4(mul4(w(j), f[j]), lin.model[j].at(lam));
        }
    }
}

/// Ψ_i = Σ_{k>i} Φ(k, i+1)ᵀ W_k Φ(k, i+1) for i = 0..N, by the backward
/// Lyapunov recursion Ψ_{N−1} = W_N, Ψ_{i−1} = W_i + A_iᵀΨ_iA_i.
fn lyapunov(psi: &mut Vec<[[f64; 4]; 4]>, lin: &Linearised, w: &dyn Fn(usize) -> [f64; 4]) {
    let n = lin.model.len();
    psi.clear();
    psi.resize(n, [[0.0; 4]; 4]);
    let wn = w(n);
    for r in 0..4 {
        psi[n - 1][r][r] = wn[r];
    }
    for i in (1..n).rev() {
        let (m, wi) = (&lin.model[i], w(i));
        // ΨA column by column, then Aᵀ(ΨA).
        let p = psi[i];
        let col = |v: [f64; 4]| -> [f64; 4] {
            let mut o = [0.0; 4];
            for (r, or) in o.iter_mut().enumerate() {
                *or = p[r][0] * v[0] + p[r][1] * v[1] + p[r][2] * v[2] + p[r][3] * v[3];
            }
            o
        };
        let pa = [
            col([1.0, 0.0, 0.0, 0.0]),
            col([0.0, 1.0, 0.0, 0.0]),
            col([m.a02, m.a12, 1.0, 0.0]),
            col([m.a03, m.a13, m.a23, 1.0]),
        ];
        let mut next = [[0.0; 4]; 4];
        for (c, pac) in pa.iter().enumerate() {
            let atc = m.at(*pac);
            for r in 0..4 {
                next[r][c] = atc[r];
            }
        }
        for r in 0..4 {
            next[r][r] += wi[r];
        }
        psi[i - 1] = next;
    }
}

/// Adds the Hessian's state blocks H(i, j) = B_iᵀ Ψ_i G_{i+1,j} for i ≥ j
/// to `h` (row-major, 2N × 2N; rows i ≥ j only), the prediction columns
/// G_{i+1,j} = A_i G_{i,j} run forward from B_j.
fn prediction_blocks(h: &mut [f64], psi: &[[[f64; 4]; 4]], lin: &Linearised) {
    let n = lin.model.len();
    let nu = 2 * n;
    let kk: Vec<[[f64; 4]; 2]> = (0..n)
        .map(|i| {
            let (b, p) = (&lin.model[i].b, &psi[i]);
            let row = |m: usize| {
                let mut o = [0.0; 4];
                for (c, oc) in o.iter_mut().enumerate() {
                    *oc = b[0][m] * p[0][c]
                        + b[1][m] * p[1][c]
                        + b[2][m] * p[2][c]
                        + b[3][m] * p[3][c];
                }
                o
            };
            [row(0), row(1)]
        })
        .collect();
    for j in 0..n {
        let mut ga = lin.model[j].b_col(0);
        let mut gd = lin.model[j].b_col(1);
        for i in j..n {
            if i > j {
                ga = lin.model[i].apply(ga);
                gd = lin.model[i].apply(gd);
            }
            // K_i = B_iᵀΨ_i (2 × 4, once per i), times G_{i+1,j}.
            let [ka, kd] = &kk[i];
            let dot4 =
                |a: &[f64; 4], b: &[f64; 4]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
            let (ca, cd) = (2 * j * nu, (2 * j + 1) * nu);
            h[ca + 2 * i] += dot4(ka, &ga);
            h[ca + 2 * i + 1] += dot4(kd, &ga);
            h[cd + 2 * i] += dot4(ka, &gd);
            h[cd + 2 * i + 1] += dot4(kd, &gd);
        }
    }
}

fn add4(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}
fn mul4(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2], a[3] * b[3]]
}
