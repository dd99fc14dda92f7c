//! Tracking MPC for the kinematic bicycle, linearised along the reference
//! (linear time-varying), condensed to a dense QP in the input deviations
//! and solved by Clarabel (an interior-point solver in pure Rust).
//!
//! State z = (x, y, ψ, v), input u = (a, δ). Around the reference
//! (z_r,k, u_r,k) with δ_r = atan(L·κ_r) and a_r = Δv_r/dt:
//! `e_{k+1} = A_k e_k + B_k Δu_k + c_k`, where A_k, B_k are the Jacobians
//! of the Euler-discretised bicycle and c_k its residual on the reference.
//! Cost: Σ e_kᵀQe_k (terminal weight scaled) + Σ Δu_kᵀRΔu_k + Σ
//! (u_k − u_{k−1})ᵀR_d(u_k − u_{k−1}). Constraints: |δ| ≤ δ_max,
//! a_min ≤ a ≤ a_max, |δ_k − δ_{k−1}| ≤ δ̇_max·dt (from the applied δ).
//!
//! Clarabel has no warm start (interior-point methods rarely profit from
//! one); what carries over between cycles is the previous command, which
//! anchors the rate constraint and the rate penalty.

use crate::corridor::RefState;
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
    /// Solver iterations.
    pub iterations: u32,
}

/// A tracking MPC.
///
/// The QP's sparsity pattern is the same every cycle (P dense upper
/// triangle, A fixed by the constraint layout), so the Clarabel solver is
/// built once and later cycles only update P, q and b: the symbolic
/// factorisation and the equilibration are reused.
pub struct Mpc {
    /// Settings.
    pub cfg: MpcConfig,
    solver: Option<DefaultSolver<f64>>,
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
        Ok(Self { cfg, solver: None })
    }

    /// Solves for state `z0` = (x, y, ψ, v), the reference at t₀ + k·dt
    /// (k = 0..=N) and the command applied last (a, δ).
    pub fn solve(
        &mut self,
        z0: [f64; 4],
        refs: &[RefState],
        prev: [f64; 2],
    ) -> Result<MpcSolution, MpcError> {
        let c = &self.cfg;
        let n = c.horizon;
        if refs.len() != n + 1 {
            return Err(MpcError::Reference {
                expected: n + 1,
                got: refs.len(),
            });
        }
        let (l, dt) = (c.wheelbase, c.dt);
        let prev = [
            prev[0].clamp(c.min_accel, c.max_accel),
            prev[1].clamp(-c.max_steer, c.max_steer),
        ];
        // Reference inputs.
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
        // Sparse (non-condensed) QP in w = [Δu_0 … Δu_{N−1}, e_1 … e_N]:
        // the dynamics are equality rows, P is (block) diagonal, and the KKT
        // system stays banded — far cheaper to factor than the dense
        // condensed form.
        let nu = 2 * n;
        let nw = nu + 4 * n;
        let col_e = |k: usize, r: usize| nu + 4 * (k - 1) + r; // e_k, k ≥ 1
        let mut rows: Vec<(Vec<(usize, f64)>, f64)> = Vec::with_capacity(10 * n);
        let e0 = [
            z0[0] - zr[0][0],
            z0[1] - zr[0][1],
            wrap_angle(z0[2] - zr[0][2]),
            z0[3] - zr[0][3],
        ];
        for k in 0..n {
            let [_, _, psi, v] = zr[k];
            let [_, d] = ur[k];
            let (s, co) = math::sin_cos(psi);
            let tan_d = math::tan(d);
            let cos_d = math::cos(d);
            let a_mat = [
                [1.0, 0.0, -v * s * dt, co * dt],
                [0.0, 1.0, v * co * dt, s * dt],
                [0.0, 0.0, 1.0, tan_d / l * dt],
                [0.0, 0.0, 0.0, 1.0],
            ];
            let b_mat = [
                [0.0, 0.0],
                [0.0, 0.0],
                [0.0, v / (l * cos_d * cos_d) * dt],
                [dt, 0.0],
            ];
            let next = [
                zr[k][0] + v * co * dt,
                zr[k][1] + v * s * dt,
                psi + v * tan_d / l * dt,
                v + ur[k][0] * dt,
            ];
            let ck = [
                next[0] - zr[k + 1][0],
                next[1] - zr[k + 1][1],
                wrap_angle(next[2] - zr[k + 1][2]),
                next[3] - zr[k + 1][3],
            ];
            for r in 0..4 {
                // e_{k+1} − A_k e_k − B_k Δu_k = c_k   (A_0 e_0 moves to the right).
                let mut entries = vec![(2 * k, -b_mat[r][0]), (2 * k + 1, -b_mat[r][1])];
                let mut rhs = ck[r];
                if k == 0 {
                    rhs += (0..4).map(|j| a_mat[r][j] * e0[j]).sum::<f64>();
                } else {
                    entries.extend((0..4).map(|j| (col_e(k, j), -a_mat[r][j])));
                }
                entries.push((col_e(k + 1, r), 1.0));
                rows.push((entries, rhs));
            }
        }
        let n_eq = rows.len();
        // Cost (½wᵀPw + qᵀw): inputs with rate coupling, then states.
        let mut p_diag = vec![0.0; nw];
        let mut p_off = vec![0.0; nu]; // P[i−2][i] for the rate coupling
        let mut q = vec![0.0; nw];
        for k in 0..n {
            for m in 0..2 {
                let i = 2 * k + m;
                let w = c.r_rate[m];
                let d0 = ur[k][m] - if k == 0 { prev[m] } else { ur[k - 1][m] };
                p_diag[i] += 2.0 * (c.r[m] + w);
                q[i] += 2.0 * w * d0;
                if k > 0 {
                    p_diag[i - 2] += 2.0 * w;
                    p_off[i] -= 2.0 * w;
                    q[i - 2] -= 2.0 * w * d0;
                }
            }
            let wt = if k + 1 == n { c.q_terminal } else { 1.0 };
            for r in 0..4 {
                p_diag[col_e(k + 1, r)] = 2.0 * c.q[r] * wt;
            }
        }
        // Input constraints (NonnegativeCone rows after the equalities).
        for k in 0..n {
            let (ia, id) = (2 * k, 2 * k + 1);
            rows.push((vec![(id, 1.0)], c.max_steer - ur[k][1]));
            rows.push((vec![(id, -1.0)], c.max_steer + ur[k][1]));
            rows.push((vec![(ia, 1.0)], c.max_accel - ur[k][0]));
            rows.push((vec![(ia, -1.0)], ur[k][0] - c.min_accel));
            let lim = c.max_steer_rate * dt;
            let (d_prev_ref, lhs_up, lhs_dn) = if k == 0 {
                (prev[1], vec![(id, 1.0)], vec![(id, -1.0)])
            } else {
                (
                    ur[k - 1][1],
                    vec![(id - 2, -1.0), (id, 1.0)],
                    vec![(id - 2, 1.0), (id, -1.0)],
                )
            };
            let dr = ur[k][1] - d_prev_ref;
            rows.push((lhs_up, lim - dr));
            rows.push((lhs_dn, lim + dr));
        }
        let m = rows.len();
        let b: Vec<f64> = rows.iter().map(|r| r.1).collect();
        let p_csc = p_upper(nw, &p_diag, &p_off);
        let q2 = q;
        let solver = match self.solver.as_mut() {
            Some(s) => {
                let bad = |e| MpcError::Solver(format!("data update: {e:?}"));
                s.update_P(&p_csc.nzval).map_err(bad)?;
                s.update_q(&q2).map_err(bad)?;
                s.update_b(&b).map_err(bad)?;
                // The dynamics rows change with the reference.
                s.update_A(&csc_from_rows(m, nw, &rows).nzval)
                    .map_err(bad)?;
                s
            }
            None => {
                let a = csc_from_rows(m, nw, &rows);
                let settings = DefaultSettings::<f64> {
                    verbose: false,
                    max_iter: 100,
                    presolve_enable: false,
                    // 1e-7 instead of 1e-8: far below what a vehicle can
                    // act on, and saves interior-point iterations.
                    tol_gap_abs: 1e-7,
                    tol_gap_rel: 1e-7,
                    tol_feas: 1e-7,
                    // Iterative refinement of each KKT solve costs more than
                    // the factorisation itself on this small, well-scaled
                    // problem (390 → 256 µs at N = 20); the constraint and
                    // tracking tests hold without it.
                    iterative_refinement_enable: false,
                    ..DefaultSettings::default()
                };
                let cones = [ZeroConeT(n_eq), NonnegativeConeT(m - n_eq)];
                let s = DefaultSolver::new(&p_csc, &q2, &a, &b, &cones, settings)
                    .map_err(|e| MpcError::Solver(format!("{e:?}")))?;
                self.solver.insert(s)
            }
        };
        solver.solve();
        let status = solver.solution.status;
        if !matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved) {
            return Err(MpcError::Solver(format!("{status:?}")));
        }
        let du = &solver.solution.x;
        let inputs: Vec<[f64; 2]> = (0..n)
            .map(|k| {
                [
                    (ur[k][0] + du[2 * k]).clamp(c.min_accel, c.max_accel),
                    (ur[k][1] + du[2 * k + 1]).clamp(-c.max_steer, c.max_steer),
                ]
            })
            .collect();
        // Predicted states from the nonlinear model under the planned inputs.
        let mut predicted = Vec::with_capacity(n + 1);
        let mut z = z0;
        predicted.push(z);
        for u in &inputs {
            let (s, co) = math::sin_cos(z[2]);
            z = [
                z[0] + z[3] * co * dt,
                z[1] + z[3] * s * dt,
                z[2] + z[3] * math::tan(u[1]) / l * dt,
                (z[3] + u[0] * dt).max(0.0),
            ];
            predicted.push(z);
        }
        Ok(MpcSolution {
            acceleration: inputs[0][0],
            steering: inputs[0][1],
            predicted,
            inputs,
            iterations: solver.solution.iterations,
        })
    }
}

/// Upper triangle of P: the diagonal, plus the rate coupling P[i−2][i] of
/// the inputs. Every entry is stored, zero or not, so that the pattern never
/// changes between cycles (the solver's data updates require it).
fn p_upper(n: usize, diag: &[f64], off: &[f64]) -> CscMatrix<f64> {
    let mut colptr = vec![0];
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    for j in 0..n {
        if j < off.len() && j >= 2 {
            rowval.push(j - 2);
            nzval.push(off[j]);
        }
        rowval.push(j);
        nzval.push(diag[j]);
        colptr.push(rowval.len());
    }
    CscMatrix::new(n, n, colptr, rowval, nzval)
}

fn csc_from_rows(m: usize, n: usize, rows: &[(Vec<(usize, f64)>, f64)]) -> CscMatrix<f64> {
    let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for (i, (entries, _)) in rows.iter().enumerate() {
        for &(j, v) in entries {
            cols[j].push((i, v));
        }
    }
    let mut colptr = vec![0];
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    for c in cols {
        for (i, v) in c {
            rowval.push(i);
            nzval.push(v);
        }
        colptr.push(rowval.len());
    }
    CscMatrix::new(m, n, colptr, rowval, nzval)
}
