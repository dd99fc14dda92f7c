//! A dense, strictly convex QP solver for small problems with sparse
//! inequality rows: the dual active-set method of Goldfarb and Idnani
//! (Math. Programming 27, 1983).
//!
//! minimise ½ xᵀHx + gᵀx  subject to  cᵢᵀx ≥ bᵢ  (each cᵢ has one or two
//! non-zeros).
//!
//! Why this method for the tracking MPC: it starts from the unconstrained
//! minimum, which is feasible whenever the vehicle tracks its reference
//! inside its limits (the usual case: one Cholesky factorisation and a
//! feasibility check, no iterations), and each constraint that binds costs
//! one O(n²) update of the factors. The answer is the exact optimum up to
//! rounding — there is no tolerance to tune, unlike an interior-point or
//! first-order method — and it is a deterministic function of the data.
//!
//! Storage is dense column-major `n × n`, kept in [`DenseQp`] between solves
//! so that a control loop allocates nothing after its first call.

/// One inequality row `coef[0]·x[idx[0]] + coef[1]·x[idx[1]] ≥ bound`
/// (a single-variable row repeats its index with a zero second coefficient).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SparseRow {
    /// Variable indices.
    pub idx: [usize; 2],
    /// Coefficients.
    pub coef: [f64; 2],
    /// Right-hand side.
    pub bound: f64,
}

impl SparseRow {
    /// `c·x[i] ≥ bound`.
    pub fn single(i: usize, c: f64, bound: f64) -> Self {
        Self {
            idx: [i, i],
            coef: [c, 0.0],
            bound,
        }
    }
    /// `c0·x[i] + c1·x[j] ≥ bound`.
    pub fn pair(i: usize, c0: f64, j: usize, c1: f64, bound: f64) -> Self {
        Self {
            idx: [i, j],
            coef: [c0, c1],
            bound,
        }
    }
    fn dot(&self, x: &[f64]) -> f64 {
        self.coef[0] * x[self.idx[0]] + self.coef[1] * x[self.idx[1]]
    }
    /// Slack `cᵀx − b` (negative = violated).
    fn slack(&self, x: &[f64]) -> f64 {
        self.dot(x) - self.bound
    }
}

/// Why a QP has no answer.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum QpError {
    /// H is not positive definite (to working precision).
    #[error("the Hessian is not positive definite (pivot {0})")]
    NotConvex(usize),
    /// The constraints contradict each other.
    #[error("the constraints are infeasible (row {0})")]
    Infeasible(usize),
    /// The active-set iteration did not settle (degenerate data).
    #[error("no convergence after {0} active-set changes")]
    NoConvergence(usize),
    /// NaN or infinity in the data.
    #[error("non-finite data")]
    NonFinite,
}

/// Solver workspace, reused between solves of the same size.
#[derive(Clone, Debug, Default)]
pub struct DenseQp {
    n: usize,
    /// Cholesky factor L of H (lower, column-major).
    l: Vec<f64>,
    /// V = L⁻¹N: one row of n per active constraint.
    v: Vec<f64>,
    /// T = chol(VᵀV) (lower, row-major with stride n).
    t: Vec<f64>,
    vp: Vec<f64>,
    zt: Vec<f64>,
    z: Vec<f64>,
    s: Vec<f64>,
    y: Vec<f64>,
    rv: Vec<f64>,
    u: Vec<f64>,
    active: Vec<usize>,
    is_active: Vec<bool>,
}

/// Outcome of a solve: the number of active-set changes and the active rows.
#[derive(Clone, Debug, PartialEq)]
pub struct QpInfo {
    /// Constraints added or dropped.
    pub changes: usize,
    /// Indices of the rows active at the optimum.
    pub active: Vec<usize>,
}

const TOL: f64 = 1e-12;

impl DenseQp {
    /// Solves the QP; `h` is the full symmetric `n × n` matrix (column-major,
    /// only the lower triangle is read), `x` receives the optimum.
    pub fn solve(
        &mut self,
        n: usize,
        h: &[f64],
        g: &[f64],
        rows: &[SparseRow],
        x: &mut [f64],
    ) -> Result<QpInfo, QpError> {
        debug_assert!(h.len() >= n * n && g.len() >= n && x.len() >= n);
        if h[..n * n].iter().chain(&g[..n]).any(|v| !v.is_finite())
            || rows
                .iter()
                .any(|r| !(r.bound.is_finite() && r.coef.iter().all(|c| c.is_finite())))
        {
            return Err(QpError::NonFinite);
        }
        self.resize(n);
        self.cholesky(n, h)?;
        // Unconstrained minimum: x = −H⁻¹g.
        for (xi, gi) in x[..n].iter_mut().zip(&g[..n]) {
            *xi = -gi;
        }
        self.solve_l(n, x);
        self.solve_lt(n, x);
        self.is_active.clear();
        self.is_active.resize(rows.len(), false);
        self.active.clear();
        self.u.clear();
        let Some(mut p) = most_violated(rows, x, &self.is_active) else {
            return Ok(QpInfo {
                changes: 0,
                active: Vec::new(),
            });
        };
        let mut changes = 0usize;
        let limit = 10 * (n + rows.len()) + 10;
        loop {
            // The violated row p enters with multiplier 0.
            let mut up = 0.0;
            loop {
                changes += 1;
                if changes > limit {
                    return Err(QpError::NoConvergence(changes));
                }
                let q = self.active.len();
                // In the metric of H (range space, L = chol H):
                // v_p = L⁻¹n_p, s = Vᵀv_p, r = (VᵀV)⁻¹s (dual direction),
                // z = L⁻ᵀ(v_p − Vr) (primal direction, H-orthogonal to
                // every active normal).
                self.load_row(n, &rows[p]);
                for i in 0..q {
                    self.s[i] = dot(&self.v[i * n..(i + 1) * n], &self.vp[..n]);
                }
                self.solve_t(q);
                self.zt[..n].copy_from_slice(&self.vp[..n]);
                for i in 0..q {
                    let ri = self.rv[i];
                    for (zk, vk) in self.zt[..n].iter_mut().zip(&self.v[i * n..(i + 1) * n]) {
                        *zk -= ri * vk;
                    }
                }
                self.z[..n].copy_from_slice(&self.zt[..n]);
                self.solve_lt_z(n);
                // Partial step: the first active multiplier to reach zero.
                let mut t1 = f64::INFINITY;
                let mut drop = usize::MAX;
                for i in 0..q {
                    if self.rv[i] > TOL {
                        let t = self.u[i] / self.rv[i];
                        if t < t1 {
                            t1 = t;
                            drop = i;
                        }
                    }
                }
                // Full step: row p becomes satisfied with equality.
                let zc = rows[p].dot(&self.z);
                let t2 = if zc.abs() > TOL {
                    -rows[p].slack(x) / zc
                } else {
                    f64::INFINITY
                };
                let t = t1.min(t2);
                if !t.is_finite() {
                    return Err(QpError::Infeasible(p));
                }
                if t2.is_finite() {
                    for (xk, zk) in x[..n].iter_mut().zip(&self.z[..n]) {
                        *xk += t * zk;
                    }
                }
                for i in 0..q {
                    self.u[i] -= t * self.rv[i];
                }
                up += t;
                if t2 <= t1 {
                    self.add(n, q);
                    self.active.push(p);
                    self.u.push(up);
                    self.is_active[p] = true;
                    break;
                }
                let gone = self.active[drop];
                self.is_active[gone] = false;
                self.drop(n, drop);
            }
            match most_violated(rows, x, &self.is_active) {
                Some(next) => p = next,
                None => {
                    return Ok(QpInfo {
                        changes,
                        active: self.active.clone(),
                    });
                }
            }
        }
    }

    fn resize(&mut self, n: usize) {
        if self.n != n {
            self.n = n;
            self.l = vec![0.0; n * n];
            self.v = vec![0.0; n * n];
            self.t = vec![0.0; n * n];
            self.vp = vec![0.0; n];
            self.zt = vec![0.0; n];
            self.z = vec![0.0; n];
            self.s = vec![0.0; n];
            self.y = vec![0.0; n];
            self.rv = vec![0.0; n];
        }
    }

    /// H = LLᵀ, right-looking: after column k is scaled, every later
    /// column j takes an axpy of column k. L is column-major (column j holds
    /// rows j..n contiguously), so each update is a contiguous element-wise
    /// loop the compiler vectorises without reordering any sum. Reads H's
    /// lower triangle (column-major).
    fn cholesky(&mut self, n: usize, h: &[f64]) -> Result<(), QpError> {
        let l = &mut self.l;
        l[..n * n].copy_from_slice(&h[..n * n]);
        for k in 0..n {
            let pivot = l[k * n + k];
            // Relative pivot test: a pivot lost to cancellation is not
            // positive definite.
            // (NaN fails the comparison too.)
            if pivot.partial_cmp(&(1e-14 * h[k * n + k].abs().max(1e-300)))
                != Some(std::cmp::Ordering::Greater)
            {
                return Err(QpError::NotConvex(k));
            }
            let d = pivot.sqrt();
            let inv = 1.0 / d;
            l[k * n + k] = d;
            for v in &mut l[k * n + k + 1..(k + 1) * n] {
                *v *= inv;
            }
            let (done, rest) = l.split_at_mut((k + 1) * n);
            let colk = &done[k * n..(k + 1) * n];
            for j in k + 1..n {
                let a = colk[j];
                if a != 0.0 {
                    let off = (j - k - 1) * n;
                    for (x, c) in rest[off + j..off + n].iter_mut().zip(&colk[j..n]) {
                        *x -= a * c;
                    }
                }
            }
        }
        Ok(())
    }

    /// y ← L⁻¹y (column sweep).
    fn solve_l(&self, n: usize, y: &mut [f64]) {
        for i in 0..n {
            let c = i * n;
            y[i] /= self.l[c + i];
            let v = y[i];
            for (yk, lk) in y[i + 1..n].iter_mut().zip(&self.l[c + i + 1..c + n]) {
                *yk -= lk * v;
            }
        }
    }

    /// y ← L⁻ᵀy (column i of L below the diagonal is contiguous).
    fn solve_lt(&self, n: usize, y: &mut [f64]) {
        for i in (0..n).rev() {
            let c = i * n;
            y[i] = (y[i] - dot(&self.l[c + i + 1..c + n], &y[i + 1..n])) / self.l[c + i];
        }
    }

    /// v_p = L⁻¹c for a sparse row c (the forward solve starts at c's
    /// first non-zero: everything before it stays zero).
    fn load_row(&mut self, n: usize, row: &SparseRow) {
        let vp = &mut self.vp[..n];
        vp.fill(0.0);
        vp[row.idx[0]] += row.coef[0];
        vp[row.idx[1]] += row.coef[1];
        let first = row.idx[0].min(row.idx[1]);
        for i in first..n {
            let c = i * n;
            vp[i] /= self.l[c + i];
            let v = vp[i];
            for (yk, lk) in vp[i + 1..].iter_mut().zip(&self.l[c + i + 1..c + n]) {
                *yk -= lk * v;
            }
        }
    }

    /// z ← L⁻ᵀz.
    fn solve_lt_z(&mut self, n: usize) {
        let z = &mut self.z[..n];
        for i in (0..n).rev() {
            let c = i * n;
            z[i] = (z[i] - dot(&self.l[c + i + 1..c + n], &z[i + 1..n])) / self.l[c + i];
        }
    }

    /// y = T⁻¹s and rv = T⁻ᵀy = (VᵀV)⁻¹s over the q active rows.
    fn solve_t(&mut self, q: usize) {
        let n = self.n;
        for i in 0..q {
            let r = i * n;
            self.y[i] = (self.s[i] - dot(&self.t[r..r + i], &self.y[..i])) / self.t[r + i];
        }
        for i in 0..q {
            self.rv[i] = self.y[i];
        }
        for i in (0..q).rev() {
            let r = i * n;
            self.rv[i] /= self.t[r + i];
            let v = self.rv[i];
            for k in 0..i {
                self.rv[k] -= self.t[r + k] * v;
            }
        }
    }

    /// Appends v_p to V and its row to T (y = T⁻¹s is still in place).
    fn add(&mut self, n: usize, q: usize) {
        self.v[q * n..(q + 1) * n].copy_from_slice(&self.vp[..n]);
        let r = q * n;
        self.t[r..r + q].copy_from_slice(&self.y[..q]);
        // ‖v_p‖² − ‖y‖² = ‖z̃‖²: positive, or the full step was not taken.
        let d = dot(&self.zt[..n], &self.zt[..n]);
        self.t[r + q] = d.max(f64::MIN_POSITIVE).sqrt();
    }

    /// Removes active position k: V loses its row, T is refactored from
    /// VᵀV (q is small; a refactorisation costs less than bookkeeping).
    fn drop(&mut self, n: usize, k: usize) {
        let q = self.active.len();
        self.v.copy_within((k + 1) * n..q * n, k * n);
        self.active.remove(k);
        self.u.remove(k);
        let q = q - 1;
        for i in 0..q {
            for jc in 0..=i {
                let sij = dot(&self.v[i * n..(i + 1) * n], &self.v[jc * n..(jc + 1) * n]);
                let s = sij - dot(&self.t[i * n..i * n + jc], &self.t[jc * n..jc * n + jc]);
                self.t[i * n + jc] = if i == jc {
                    s.max(f64::MIN_POSITIVE).sqrt()
                } else {
                    s / self.t[jc * n + jc]
                };
            }
        }
    }
}

/// Inner product with four independent partial sums (a fixed order, so
/// results are reproducible, and one the compiler can keep in vector
/// registers).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 4];
    let mut ca = a.chunks_exact(4);
    let mut cb = b.chunks_exact(4);
    for (x, y) in (&mut ca).zip(&mut cb) {
        acc[0] += x[0] * y[0];
        acc[1] += x[1] * y[1];
        acc[2] += x[2] * y[2];
        acc[3] += x[3] * y[3];
    }
    let mut s = (acc[0] + acc[2]) + (acc[1] + acc[3]);
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        s += x * y;
    }
    s
}

/// The most violated inactive row (beyond a tolerance scaled to the row).
fn most_violated(rows: &[SparseRow], x: &[f64], active: &[bool]) -> Option<usize> {
    let mut best = None;
    let mut worst = 0.0;
    for (i, r) in rows.iter().enumerate() {
        if active[i] {
            continue;
        }
        let scale = r.coef[0].abs() + r.coef[1].abs();
        let s = r.slack(x) / scale.max(1e-300);
        if s < -1e-10 && s < worst {
            worst = s;
            best = Some(i);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_constrained_diagonal_qp_is_a_clamp() {
        // min ½Σ(xᵢ − tᵢ)² with −1 ≤ xᵢ ≤ 1: the answer is clamp(t).
        let n = 3;
        let mut h = vec![0.0; 9];
        for i in 0..n {
            h[i * n + i] = 1.0;
        }
        let t = [2.0, -0.5, -3.0];
        let g: Vec<f64> = t.iter().map(|v| -v).collect();
        let mut rows = Vec::new();
        for i in 0..n {
            rows.push(SparseRow::single(i, 1.0, -1.0));
            rows.push(SparseRow::single(i, -1.0, -1.0));
        }
        let mut x = vec![0.0; n];
        let info = DenseQp::default().solve(n, &h, &g, &rows, &mut x).unwrap();
        assert_eq!(x, vec![1.0, -0.5, -1.0]);
        assert_eq!(info.active.len(), 2);
    }

    #[test]
    fn coupled_rows_and_infeasibility() {
        // min ½‖x‖² − x₀ − x₁ s.t. x₀ + x₁ ≤ 1 → x = (½, ½).
        let h = vec![1.0, 0.0, 0.0, 1.0];
        let g = [-1.0, -1.0];
        let rows = [SparseRow::pair(0, -1.0, 1, -1.0, -1.0)];
        let mut x = [0.0; 2];
        DenseQp::default().solve(2, &h, &g, &rows, &mut x).unwrap();
        assert!((x[0] - 0.5).abs() < 1e-14 && (x[1] - 0.5).abs() < 1e-14);
        // x₀ ≥ 1 and x₀ ≤ 0.
        let rows = [
            SparseRow::single(0, 1.0, 1.0),
            SparseRow::single(0, -1.0, 0.0),
        ];
        let e = DenseQp::default().solve(2, &h, &g, &rows, &mut x);
        assert!(matches!(e, Err(QpError::Infeasible(_))), "{e:?}");
        let bad = vec![1.0, 0.0, 0.0, -1.0];
        assert!(matches!(
            DenseQp::default().solve(2, &bad, &g, &[], &mut x),
            Err(QpError::NotConvex(1))
        ));
        let nan = vec![f64::NAN, 0.0, 0.0, 1.0];
        assert_eq!(
            DenseQp::default().solve(2, &nan, &g, &[], &mut x),
            Err(QpError::NonFinite)
        );
    }
}
