//! The reference solver: the same QP handed to a general interior-point
//! solver (Clarabel) in sparse form, with a polishing step; what the dense
//! solver is checked against.

use super::*;

/// The input part of the cost in Δu (½ΔuᵀPΔu + qᵀΔu): P's diagonal, its
/// rate coupling P[i−2][i] (stored at i), and q — deviation weights r and
/// rate weights r_rate on (u_k − u_{k−1}), u_{−1} being the applied
/// command. Shared by the condensed and the sparse form.
pub(super) fn input_cost(c: &MpcConfig, lin: &Linearised) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let nu = 2 * c.horizon;
    let (mut diag, mut off, mut q) = (vec![0.0; nu], vec![0.0; nu], vec![0.0; nu]);
    for k in 0..c.horizon {
        for m in 0..2 {
            let i = 2 * k + m;
            let w = c.r_rate[m];
            let before = if k == 0 {
                lin.prev[m]
            } else {
                lin.ur[k - 1][m]
            };
            let d0 = lin.ur[k][m] - before;
            diag[i] += 2.0 * (c.r[m] + w);
            q[i] += 2.0 * w * d0;
            if k > 0 {
                diag[i - 2] += 2.0 * w;
                off[i] -= 2.0 * w;
                q[i - 2] -= 2.0 * w * d0;
            }
        }
    }
    (diag, off, q)
}

/// Input bounds and steering-rate rows in Δu (the same set for both
/// solvers): |δ| ≤ δ_max, a_min ≤ a ≤ a_max, |δ_k − δ_{k−1}| ≤ δ̇_max·dt.
pub(super) fn constraint_rows(c: &MpcConfig, lin: &Linearised) -> Vec<SparseRow> {
    let n = c.horizon;
    let lim = c.max_steer_rate * lin.dt;
    let mut rows = Vec::with_capacity(6 * n);
    for k in 0..n {
        let (ia, id) = (2 * k, 2 * k + 1);
        let [ar, dr] = lin.ur[k];
        rows.push(SparseRow::single(id, -1.0, -(c.max_steer - dr)));
        rows.push(SparseRow::single(id, 1.0, -(c.max_steer + dr)));
        rows.push(SparseRow::single(ia, -1.0, -(c.max_accel - ar)));
        rows.push(SparseRow::single(ia, 1.0, c.min_accel - ar));
        if k == 0 {
            let d = dr - lin.prev[1];
            rows.push(SparseRow::single(id, -1.0, -(lim - d)));
            rows.push(SparseRow::single(id, 1.0, -(lim + d)));
        } else {
            let d = dr - lin.ur[k - 1][1];
            rows.push(SparseRow::pair(id, -1.0, id - 2, 1.0, -(lim - d)));
            rows.push(SparseRow::pair(id, 1.0, id - 2, -1.0, -(lim + d)));
        }
    }
    rows
}

/// The sparse (non-condensed) form in w = [Δu, e_1 … e_N] solved by
/// Clarabel: dynamics as equality rows, the inequality rows of
/// [`constraint_rows`]. Returns Δu and the iteration count.
pub(super) fn clarabel_solve(
    c: &MpcConfig,
    lin: &Linearised,
    tol: f64,
) -> Result<(Vec<f64>, u32), MpcError> {
    let n = c.horizon;
    let nu = 2 * n;
    let nw = nu + 4 * n;
    let col_e = |k: usize, r: usize| nu + 4 * (k - 1) + r; // e_k, k ≥ 1
    let mut rows: Vec<(Vec<(usize, f64)>, f64)> = Vec::with_capacity(10 * n);
    for k in 0..n {
        let m = &lin.model[k];
        let a_mat = [
            [1.0, 0.0, m.a02, m.a03],
            [0.0, 1.0, m.a12, m.a13],
            [0.0, 0.0, 1.0, m.a23],
            [0.0, 0.0, 0.0, 1.0],
        ];
        let b_mat = m.b;
        for r in 0..4 {
            // e_{k+1} − A_k e_k − B_k Δu_k = c_k   (A_0 e_0 moves to the right).
            let mut entries = vec![(2 * k, -b_mat[r][0]), (2 * k + 1, -b_mat[r][1])];
            let mut rhs = lin.c[k][r];
            if k == 0 {
                rhs += (0..4).map(|j| a_mat[r][j] * lin.e0[j]).sum::<f64>();
            } else {
                entries.extend((0..4).map(|j| (col_e(k, j), -a_mat[r][j])));
            }
            entries.push((col_e(k + 1, r), 1.0));
            rows.push((entries, rhs));
        }
    }
    let n_eq = rows.len();
    let (diag_u, p_off, q_u) = input_cost(c, lin);
    let mut p_diag = vec![0.0; nw];
    let mut q = vec![0.0; nw];
    p_diag[..nu].copy_from_slice(&diag_u);
    q[..nu].copy_from_slice(&q_u);
    for k in 0..n {
        let wt = if k + 1 == n { c.q_terminal } else { 1.0 };
        for r in 0..4 {
            p_diag[col_e(k + 1, r)] = 2.0 * c.q[r] * wt;
        }
    }
    // Clarabel's inequality form is b − Ax ≥ 0: a row cᵀx ≥ β becomes
    // (−c)ᵀx ≤ −β.
    for r in constraint_rows(c, lin) {
        let mut e = vec![(r.idx[0], -r.coef[0])];
        if r.coef[1] != 0.0 {
            e.push((r.idx[1], -r.coef[1]));
        }
        rows.push((e, -r.bound));
    }
    let m = rows.len();
    let b: Vec<f64> = rows.iter().map(|r| r.1).collect();
    let p_csc = p_upper(nw, &p_diag, &p_off);
    let a = csc_from_rows(m, nw, &rows);
    let settings = DefaultSettings::<f64> {
        verbose: false,
        max_iter: 200,
        presolve_enable: false,
        tol_gap_abs: tol,
        tol_gap_rel: tol,
        tol_feas: tol,
        tol_ktratio: tol,
        ..DefaultSettings::default()
    };
    let cones = [ZeroConeT(n_eq), NonnegativeConeT(m - n_eq)];
    let mut s = DefaultSolver::new(&p_csc, &q, &a, &b, &cones, settings)
        .map_err(|e| MpcError::Solver(format!("{e:?}")))?;
    s.solve();
    let status = s.solution.status;
    // The reference must be a converged answer, or a nearly converged one
    // that polishing proves optimal.
    let polished = matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved)
        .then(|| {
            polish(
                &p_diag,
                &p_off,
                &q,
                &rows,
                n_eq,
                &s.solution.x,
                &s.solution.z,
            )
        })
        .flatten();
    let x = match (status, polished) {
        (_, Some(x)) => x,
        (SolverStatus::Solved, None) => s.solution.x.clone(),
        _ => return Err(MpcError::Solver(format!("{status:?}"))),
    };
    Ok((x[..nu].to_vec(), s.solution.iterations))
}

/// Solution polishing (as OSQP does): an interior-point answer is accurate
/// to its gap tolerance, which in a weakly weighted direction (the last
/// steps of a long horizon) leaves 1e-6-sized errors even at a 1e-14
/// relative gap. Taking the rows it found active as equalities, the KKT
/// system gives the exact optimum; it is kept only if it is feasible and
/// its multipliers have the right sign, i.e. it is provably optimal.
pub(super) fn polish(
    p_diag: &[f64],
    p_off: &[f64],
    q: &[f64],
    rows: &[(Vec<(usize, f64)>, f64)],
    n_eq: usize,
    x: &[f64],
    z: &[f64],
) -> Option<Vec<f64>> {
    let nw = p_diag.len();
    let slack = |r: &(Vec<(usize, f64)>, f64), w: &[f64]| {
        r.1 - r.0.iter().map(|&(j, v)| v * w[j]).sum::<f64>()
    };
    // Active: a small slack with a multiplier that is not negligible. When
    // that guess is off (an interior point near a degenerate vertex), rows
    // that the KKT answer violates join and rows with a negative
    // multiplier leave, a few rounds at most.
    let mut active: Vec<bool> = (0..rows.len())
        .map(|i| i < n_eq || slack(&rows[i], x) < 1e-7 && z[i] > 1e-9)
        .collect();
    for _round in 0..20 {
        let eq: Vec<usize> = (0..rows.len()).filter(|&i| active[i]).collect();
        let m = eq.len();
        let dim = nw + m;
        let mut k = vec![0.0; dim * dim]; // row-major
        let mut rhs = vec![0.0; dim];
        for i in 0..nw {
            k[i * dim + i] = p_diag[i];
            rhs[i] = -q[i];
        }
        for i in 2..p_off.len() {
            k[(i - 2) * dim + i] = p_off[i];
            k[i * dim + i - 2] = p_off[i];
        }
        for (r, &row) in eq.iter().enumerate() {
            for &(j, v) in &rows[row].0 {
                k[(nw + r) * dim + j] += v;
                k[j * dim + nw + r] += v;
            }
            rhs[nw + r] = rows[row].1;
        }
        let sol = lu_solve(dim, &mut k, &mut rhs)?;
        let w = &sol[..nw];
        // Optimal when feasible and the inequality multipliers are
        // non-negative (Clarabel's convention: Pw + q + Aᵀz = 0, z ≥ 0).
        let mut changed = false;
        for (i, r) in rows.iter().enumerate().skip(n_eq) {
            if !active[i] && slack(r, w) < -1e-10 {
                active[i] = true;
                changed = true;
            }
        }
        for (r, &row) in eq.iter().enumerate() {
            if row >= n_eq && sol[nw + r] < -1e-10 {
                active[row] = false;
                changed = true;
            }
        }
        if !changed {
            return Some(w.to_vec());
        }
    }
    None
}

/// Gaussian elimination with partial pivoting (row-major `a`); `None` when
/// singular.
pub(super) fn lu_solve(n: usize, a: &mut [f64], b: &mut [f64]) -> Option<Vec<f64>> {
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[piv * n + col].abs() < 1e-300 {
            return None;
        }
        if piv != col {
            for c in 0..n {
                a.swap(piv * n + c, col * n + c);
            }
            b.swap(piv, col);
        }
        let d = a[col * n + col];
        for r in col + 1..n {
            let f = a[r * n + col] / d;
            if f != 0.0 {
                for c in col..n {
                    a[r * n + c] -= f * a[col * n + c];
                }
                b[r] -= f * b[col];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|c| a[r * n + c] * x[c]).sum();
        x[r] = (b[r] - s) / a[r * n + r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Upper triangle of P: the diagonal, plus the rate coupling P[i−2][i] of
/// the inputs. Every entry is stored, zero or not, so that the pattern never
/// changes between cycles (the solver's data updates require it).
pub(super) fn p_upper(n: usize, diag: &[f64], off: &[f64]) -> CscMatrix<f64> {
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

pub(crate) fn csc_from_rows(
    m: usize,
    n: usize,
    rows: &[(Vec<(usize, f64)>, f64)],
) -> CscMatrix<f64> {
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
