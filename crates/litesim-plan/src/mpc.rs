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
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};
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
#[derive(Clone, Debug)]
pub struct Mpc {
    /// Settings.
    pub cfg: MpcConfig,
}

type Mat = Vec<f64>; // row-major, dimensions carried alongside

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
        Ok(Self { cfg })
    }

    /// Solves for state `z0` = (x, y, ψ, v), the reference at t₀ + k·dt
    /// (k = 0..=N) and the command applied last (a, δ).
    pub fn solve(
        &self,
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
        // Linearisation and residuals.
        let nu = 2 * n;
        let mut g: Mat = vec![0.0; 4 * n * nu]; // rows: 4 per k = 1..=N; cols: nu
        let mut f: Vec<f64> = vec![0.0; 4 * n]; // free response e_k, k = 1..=N
        let mut e = [
            z0[0] - zr[0][0],
            z0[1] - zr[0][1],
            wrap_angle(z0[2] - zr[0][2]),
            z0[3] - zr[0][3],
        ];
        let mut gk: Vec<[f64; 4]> = vec![[0.0; 4]; nu]; // current G_k columns (each a 4-vector)
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
            let mul = |m: &[[f64; 4]; 4], x: &[f64; 4]| {
                let mut o = [0.0; 4];
                for (r, row) in m.iter().enumerate() {
                    o[r] = row[0] * x[0] + row[1] * x[1] + row[2] * x[2] + row[3] * x[3];
                }
                o
            };
            let ne = mul(&a_mat, &e);
            e = [ne[0] + ck[0], ne[1] + ck[1], ne[2] + ck[2], ne[3] + ck[3]];
            for col in gk.iter_mut().take(2 * k) {
                *col = mul(&a_mat, col);
            }
            gk[2 * k] = [b_mat[0][0], b_mat[1][0], b_mat[2][0], b_mat[3][0]];
            gk[2 * k + 1] = [b_mat[0][1], b_mat[1][1], b_mat[2][1], b_mat[3][1]];
            for r in 0..4 {
                f[4 * k + r] = e[r];
                for (j, col) in gk.iter().enumerate().take(2 * k + 2) {
                    g[(4 * k + r) * nu + j] = col[r];
                }
            }
        }
        // Cost: P = Gᵀ Q̄ G + R̄ + Dᵀ R̄d D, q = Gᵀ Q̄ f + Dᵀ R̄d d0.
        let mut p: Mat = vec![0.0; nu * nu];
        let mut q = vec![0.0; nu];
        for k in 0..n {
            let w = if k + 1 == n { c.q_terminal } else { 1.0 };
            for r in 0..4 {
                let qw = c.q[r] * w;
                if qw == 0.0 {
                    continue;
                }
                let row = &g[(4 * k + r) * nu..(4 * k + r + 1) * nu];
                let fr = f[4 * k + r];
                for i in 0..2 * (k + 1) {
                    if row[i] == 0.0 {
                        continue;
                    }
                    q[i] += qw * row[i] * fr;
                    for j in i..2 * (k + 1) {
                        p[i * nu + j] += qw * row[i] * row[j];
                    }
                }
            }
        }
        for k in 0..n {
            for m in 0..2 {
                let i = 2 * k + m;
                p[i * nu + i] += c.r[m];
                // Rate: (u_r,k + du_k) − (u_r,k−1 + du_k−1).
                let d0 = ur[k][m] - if k == 0 { prev[m] } else { ur[k - 1][m] };
                let w = c.r_rate[m];
                p[i * nu + i] += w;
                q[i] += w * d0;
                if k > 0 {
                    let jm = 2 * (k - 1) + m;
                    p[jm * nu + jm] += w;
                    p[jm * nu + i] -= w; // upper triangle (jm < i)
                    q[jm] -= w * d0;
                }
            }
        }
        // Constraints A du ≤ b.
        let mut rows: Vec<(Vec<(usize, f64)>, f64)> = Vec::with_capacity(6 * n);
        for k in 0..n {
            let (ia, id) = (2 * k, 2 * k + 1);
            rows.push((vec![(id, 1.0)], c.max_steer - ur[k][1]));
            rows.push((vec![(id, -1.0)], c.max_steer + ur[k][1]));
            rows.push((vec![(ia, 1.0)], c.max_accel - ur[k][0]));
            rows.push((vec![(ia, -1.0)], ur[k][0] - c.min_accel));
            let lim = c.max_steer_rate * dt;
            let (d_prev_ref, mut lhs_up, mut lhs_dn) = if k == 0 {
                (prev[1], vec![(id, 1.0)], vec![(id, -1.0)])
            } else {
                (
                    ur[k - 1][1],
                    vec![(id - 2, -1.0), (id, 1.0)],
                    vec![(id - 2, 1.0), (id, -1.0)],
                )
            };
            lhs_up.sort_by_key(|x| x.0);
            lhs_dn.sort_by_key(|x| x.0);
            let dr = ur[k][1] - d_prev_ref;
            rows.push((lhs_up, lim - dr));
            rows.push((lhs_dn, lim + dr));
        }
        let m = rows.len();
        let a = csc_from_rows(m, nu, &rows);
        let b: Vec<f64> = rows.iter().map(|r| r.1).collect();
        // Clarabel minimises ½xᵀPx + qᵀx: scale by 2.
        let p_csc = csc_upper(nu, &p, 2.0);
        let q2: Vec<f64> = q.iter().map(|v| 2.0 * v).collect();
        let settings = DefaultSettings::<f64> {
            verbose: false,
            max_iter: 100,
            presolve_enable: false,
            ..DefaultSettings::default()
        };
        let cones = [NonnegativeConeT(m)];
        let mut solver = DefaultSolver::new(&p_csc, &q2, &a, &b, &cones, settings)
            .map_err(|e| MpcError::Solver(format!("{e:?}")))?;
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

fn csc_upper(n: usize, dense: &[f64], scale: f64) -> CscMatrix<f64> {
    let mut colptr = vec![0];
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    for j in 0..n {
        for i in 0..=j {
            let v = dense[i * n + j];
            if v != 0.0 || i == j {
                rowval.push(i);
                nzval.push(v * scale);
            }
        }
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
