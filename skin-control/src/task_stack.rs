//! Prioritised tasks with activations (thesis App. D): joint velocities that serve task 1 as well
//! as possible, task 2 as well as possible without disturbing task 1, and so on.
//!
//! With r_0 = 0 and P_0 = I, for each task k (Jacobian J_k, reference rho_k, activation a_k):
//!
//! ```text
//! X_k  = J_k P_(k-1)
//! r_k  = r_(k-1) + P_(k-1) X_k^# (rho_k - J_k r_(k-1))          (D.8-D.11, G_k expanded)
//! P_k  = P_(k-1) (I - X_k^# X_k)
//! q_dot = r_L
//! ```
//!
//! where X^# is the activation-weighted pseudo-inverse of [`Regularisation`]. With the plain
//! pseudo-inverse of H_k = a_k J_k, (a J)^# a rho = J^# rho for every a > 0: the activation only
//! switches a task on or off, and joint velocities jump when it does. Both regularised modes make
//! the activation act continuously:
//!
//! - [`Regularisation::Damped`]: damped least squares of H = a J,
//!   X^# = a^2 X^T (a^2 X X^T + lambda^2 I)^-1 (Nakamura; Chiaverini). Simple and fast (an m x m
//!   Cholesky per task), but it damps every direction a little, also well-conditioned ones.
//! - [`Regularisation::ActivationAware`]: the regularised pseudo-inverse of Simetti and Casalino
//!   (2016, "A novel practical technique to integrate inequality control objectives and task
//!   transitions in priority based control"), with activation matrix A = a I and Q the projector
//!   the higher tasks leave: X^# = (X^T A X + eta (I - Q)^T (I - Q) + V^T P V)^# X^T A A, where
//!   V S V^T is the eigen-decomposition of the first two terms and P = diag(b(s_i)) damps only
//!   values below `threshold` (b = lambda^2 at 0, falling smoothly to 0 at `threshold`). The eta
//!   term keeps a lower task out of directions a higher task is fading in, which it would
//!   otherwise exploit with large gains just before the higher task takes them. Well-conditioned
//!   full-activation tasks are solved exactly; a fading task fades continuously. When no s_i is
//!   below `threshold` (checked by a Cholesky factorisation of M - threshold I) the damping term
//!   is zero and X^# comes from a Cholesky solve; only otherwise is M eigen-decomposed.
//! - [`Regularisation::Exact`]: the plain pseudo-inverse (singular values under `tolerance`
//!   dropped), for reference and verification only: it has the on/off behaviour described above.

use nalgebra::{DMatrix, DVector};

/// How the pseudo-inverse is regularised; see the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Regularisation {
    /// Damped least squares of H = a J, with damping factor `lambda`.
    Damped {
        /// Damping factor (in the units of the task's singular values, e.g. metres for a linear
        /// velocity task of a Jacobian in metres).
        lambda: f64,
    },
    /// Simetti and Casalino's activation-aware regularised pseudo-inverse.
    ActivationAware {
        /// Damping of a zero singular value (lambda^2 is added to it).
        lambda: f64,
        /// Singular values of X^T A X at or above this are not damped.
        threshold: f64,
        /// Weight of the penalty on directions the higher tasks have (partly) taken.
        eta: f64,
    },
    /// The plain pseudo-inverse, singular values under `tolerance` dropped (not for control).
    Exact {
        /// Singular values under this are treated as zero.
        tolerance: f64,
    },
}

impl Default for Regularisation {
    fn default() -> Self {
        Regularisation::ActivationAware {
            lambda: 0.05,
            threshold: 0.01,
            eta: 1.0,
        }
    }
}

/// One task: J q_dot should equal `reference`, with weight `activation` in 0..=1.
#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    /// m x n Jacobian (n joints).
    pub jacobian: DMatrix<f64>,
    /// Desired task velocity, m values.
    pub reference: DVector<f64>,
    /// 0 = off, 1 = fully on; values in between fade the task in or out.
    pub activation: f64,
}

/// What can be wrong with a stack.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StackError {
    /// No task.
    #[error("the task stack is empty")]
    Empty,
    /// A task's sizes do not fit.
    #[error("task {task}: {what}")]
    Size {
        /// Index of the task, in priority order.
        task: usize,
        /// What does not fit.
        what: String,
    },
}

/// Solves a prioritised stack of tasks for one robot (n joints), reusing its buffers.
#[derive(Debug, Clone)]
pub struct TaskStack {
    joints: usize,
    regularisation: Regularisation,
    p: DMatrix<f64>,
    r: DVector<f64>,
    work: Work,
}

/// Buffers of the regularised modes (row-major), grown to the largest task seen and then reused:
/// a solve allocates nothing but its result, except when the activation-aware mode has to
/// eigen-decompose (nalgebra's decomposition allocates its own matrices).
#[derive(Debug, Clone, Default)]
struct Work {
    p: Vec<f64>,
    /// Activation-aware mode: I - P (padded rows), M and its Cholesky factor (compact n x n).
    q: Vec<f64>,
    mm: Vec<f64>,
    chol: Vec<f64>,
    x: Vec<f64>,
    g: Vec<f64>,
    y: Vec<f64>,
    t: Vec<f64>,
    j: Vec<f64>,
    e: Vec<f64>,
    r: Vec<f64>,
}

impl Work {
    /// Buffers sized for `n` joints (row stride `s`) and tasks of up to `m_max` rows; P = I,
    /// r = 0.
    fn reset(&mut self, n: usize, s: usize, m_max: usize) {
        self.p.resize(n * s, 0.0);
        self.t.resize(m_max * s, 0.0);
        self.r.resize(s, 0.0);
        self.x.resize(m_max * s, 0.0);
        self.y.resize(m_max * s, 0.0);
        self.g.resize(m_max * m_max, 0.0);
        self.j.resize(m_max * s, 0.0);
        self.e.resize(m_max, 0.0);
        self.p.fill(0.0);
        for i in 0..n {
            self.p[i * s + i] = 1.0;
        }
        self.r.fill(0.0);
        self.j.fill(0.0);
        self.t.fill(0.0);
    }

    /// Copies task `t`'s Jacobian (m rows) into `j` and computes X = J P into `x`.
    fn project(&mut self, t: &Task, m: usize, n: usize, s: usize) {
        // J row-major, so every inner loop below runs over contiguous rows.
        for i in 0..m {
            for k in 0..n {
                self.j[i * s + k] = t.jacobian[(i, k)];
            }
        }
        // X = J P (m x n), row by row: x_i = sum_k J_ik P_k.
        // Four columns at a time, held in registers across the n terms.
        for i in 0..m {
            let (xi, jr) = (&mut self.x[i * s..(i + 1) * s], &self.j[i * s..i * s + n]);
            for (c, chunk) in xi.chunks_exact_mut(LANES).enumerate() {
                let mut acc = [0.0; LANES];
                for (k, &jik) in jr.iter().enumerate() {
                    let pk = &self.p[k * s + c * LANES..k * s + (c + 1) * LANES];
                    for l in 0..LANES {
                        acc[l] += jik * pk[l];
                    }
                }
                chunk.copy_from_slice(&acc);
            }
        }
    }

    /// With Y = X^#^T in `y`: the updates of r and P shared by both regularised modes.
    fn update(&mut self, t: &Task, m: usize, n: usize, s: usize) {
        // W = P X^# = P Y^T (n x m, stored as m rows of n: row i = P y_i, P symmetric).
        for i in 0..m {
            let (yi, wi) = (&self.y[i * s..(i + 1) * s], &mut self.t[i * s..(i + 1) * s]);
            for (rr, o) in wi[..n].iter_mut().enumerate() {
                *o = dot(&self.p[rr * s..(rr + 1) * s], yi);
            }
        }
        // r += P X^# e with e = rho - J r (all of e from the old r): sum_i e_i W_i.
        for i in 0..m {
            self.e[i] = t.reference[i] - dot(&self.j[i * s..(i + 1) * s], &self.r);
        }
        for i in 0..m {
            axpy(&mut self.r, self.e[i], &self.t[i * s..(i + 1) * s]);
        }
        // P <- P - W X = P - sum_i W_i^T x_i, symmetrised.
        // Row by row, four columns at a time held in registers across the m rank-1 terms.
        for rr in 0..n {
            let row = &mut self.p[rr * s..(rr + 1) * s];
            for (c, chunk) in row.chunks_exact_mut(LANES).enumerate() {
                let mut acc = [0.0; LANES];
                acc.copy_from_slice(chunk);
                for i in 0..m {
                    let wi = self.t[i * s + rr];
                    let xi = &self.x[i * s + c * LANES..i * s + (c + 1) * LANES];
                    for l in 0..LANES {
                        acc[l] -= wi * xi[l];
                    }
                }
                chunk.copy_from_slice(&acc);
            }
        }
        for rr in 0..n {
            for c in rr + 1..n {
                let v = 0.5 * (self.p[rr * s + c] + self.p[c * s + rr]);
                self.p[rr * s + c] = v;
                self.p[c * s + rr] = v;
            }
        }
    }
}

impl TaskStack {
    /// A solver for `joints` joints.
    pub fn new(joints: usize, regularisation: Regularisation) -> TaskStack {
        TaskStack {
            joints,
            regularisation,
            p: DMatrix::identity(joints, joints),
            r: DVector::zeros(joints),
            work: Work::default(),
        }
    }

    /// Joint velocities for `tasks`, highest priority first. A task whose Jacobian, reference or
    /// activation is not finite is skipped (it contributes nothing); the result is then still
    /// usable, and all zero when no task is usable.
    pub fn solve(&mut self, tasks: &[Task]) -> Result<DVector<f64>, StackError> {
        if tasks.is_empty() {
            return Err(StackError::Empty);
        }
        let n = self.joints;
        for (k, t) in tasks.iter().enumerate() {
            if t.jacobian.ncols() != n {
                return Err(StackError::Size {
                    task: k,
                    what: format!(
                        "Jacobian has {} columns, the robot {n} joints",
                        t.jacobian.ncols()
                    ),
                });
            }
            if t.jacobian.nrows() != t.reference.len() {
                return Err(StackError::Size {
                    task: k,
                    what: format!(
                        "Jacobian has {} rows but the reference {} values",
                        t.jacobian.nrows(),
                        t.reference.len()
                    ),
                });
            }
        }
        if !matches!(self.regularisation, Regularisation::Exact { .. }) {
            return Ok(self.solve_flat(tasks));
        }
        self.p.fill_with_identity();
        self.r.fill(0.0);
        for t in tasks {
            let finite = t.activation.is_finite()
                && t.jacobian.iter().all(|v| v.is_finite())
                && t.reference.iter().all(|v| v.is_finite());
            if !finite {
                continue;
            }
            let a = t.activation.clamp(0.0, 1.0);
            let x = &t.jacobian * &self.p;
            let pinv = self.pinv(&x, a);
            let error = &t.reference - &t.jacobian * &self.r;
            self.r += &self.p * (&pinv * error);
            // P_k = P_(k-1) (I - X^# X), kept symmetric: rounding in the product otherwise
            // leaves directions of size ~1e-7 that a later task's pseudo-inverse would amplify.
            self.p = &self.p - &self.p * (&pinv * &x);
            let sym = (&self.p + self.p.transpose()) * 0.5;
            self.p = sym;
        }
        if self.r.iter().any(|v| !v.is_finite()) {
            self.r.fill(0.0);
        }
        Ok(self.r.clone())
    }

    /// The regularised recursions on flat buffers (the control loop's path), without temporary
    /// matrices: both modes compute Y = X^#^T (m rows of n) their own way, then share the
    /// updates of r and P.
    fn solve_flat(&mut self, tasks: &[Task]) -> DVector<f64> {
        let n = self.joints;
        let regularisation = self.regularisation;
        // Rows are padded with zeros to a multiple of 4 (stride `s`): the kernels then run on
        // whole chunks of 4 with independent sums, which the compiler turns into SIMD.
        let s = n.next_multiple_of(LANES);
        let w = &mut self.work;
        let m_max = tasks.iter().map(|t| t.reference.len()).max().unwrap_or(0);
        w.reset(n, s, m_max);
        for t in tasks {
            let a = t.activation;
            let finite = a.is_finite()
                && t.jacobian.iter().all(|v| v.is_finite())
                && t.reference.iter().all(|v| v.is_finite());
            if !finite || a <= 0.0 {
                continue;
            }
            let a2 = a.min(1.0).powi(2);
            let m = t.reference.len();
            w.project(t, m, n, s);
            let ok = match regularisation {
                Regularisation::Damped { lambda } => damped_y(w, m, s, a2, lambda),
                Regularisation::ActivationAware {
                    lambda,
                    threshold,
                    eta,
                } => aware_y(w, m, n, s, a.min(1.0), lambda, threshold, eta),
                Regularisation::Exact { .. } => false,
            };
            if !ok {
                continue;
            }
            w.update(t, m, n, s);
        }
        if w.r.iter().any(|v| !v.is_finite()) {
            return DVector::zeros(n);
        }
        DVector::from_column_slice(&w.r[..n])
    }

    /// X^# of the exact mode (the regularised modes have their own path, [`Self::solve_flat`]).
    fn pinv(&self, x: &DMatrix<f64>, a: f64) -> DMatrix<f64> {
        match self.regularisation {
            // (a X)^+ a = X^+ for a > 0.
            Regularisation::Exact { tolerance } if a > 0.0 => pseudo_inverse(x, tolerance),
            _ => DMatrix::zeros(x.ncols(), x.nrows()),
        }
    }
}

/// Damped least squares (see [`Regularisation::Damped`]): Y = a^2 G^-1 X with
/// G = a^2 X X^T + lambda^2 I, so that X^# = Y^T. False if G is not positive definite.
fn damped_y(w: &mut Work, m: usize, s: usize, a2: f64, lambda: f64) -> bool {
    // G = a^2 X X^T + lambda^2 I (lower triangle), Cholesky in place.
    for i in 0..m {
        for c in 0..=i {
            let d = dot(&w.x[i * s..(i + 1) * s], &w.x[c * s..(c + 1) * s]);
            w.g[i * m + c] = a2 * d + if i == c { lambda * lambda } else { 0.0 };
        }
    }
    if !cholesky_in_place(&mut w.g[..m * m], m) {
        return false;
    }
    // Y = a^2 G^-1 X (m x n), rows solved together: X^# = Y^T.
    w.y[..m * s].copy_from_slice(&w.x[..m * s]);
    for i in 0..m {
        for k in 0..i {
            let l = w.g[i * m + k];
            let (done, rest) = w.y.split_at_mut(i * s);
            axpy(&mut rest[..s], -l, &done[k * s..(k + 1) * s]);
        }
        let d = 1.0 / w.g[i * m + i];
        w.y[i * s..(i + 1) * s].iter_mut().for_each(|v| *v *= d);
    }
    for i in (0..m).rev() {
        for k in i + 1..m {
            let l = w.g[k * m + i];
            let (head, tail) = w.y.split_at_mut(k * s);
            axpy(&mut head[i * s..(i + 1) * s], -l, &tail[..s]);
        }
        let d = 1.0 / w.g[i * m + i];
        w.y[i * s..(i + 1) * s].iter_mut().for_each(|v| *v *= d);
    }
    w.y[..m * s].iter_mut().for_each(|v| *v *= a2);
    true
}

/// Simetti and Casalino's regularisation (see [`Regularisation::ActivationAware`]), with A = a I:
/// Y = a^2 X (M + V B V^T)^-1, M = a X^T X + eta (I - P)^2 (P symmetric), V S V^T = M and
/// B = diag(b(s_i)). When every s_i is at or above `threshold` (M - threshold I has a Cholesky
/// factor) B is zero and two small Cholesky factorisations replace the eigen-decomposition.
#[allow(clippy::too_many_arguments)]
fn aware_y(
    w: &mut Work,
    m: usize,
    n: usize,
    s: usize,
    a: f64,
    lambda: f64,
    threshold: f64,
    eta: f64,
) -> bool {
    // M, compact n x n row-major: M_rc = a sum_i X_ir X_ic + eta sum_k Q_kr Q_kc, Q = I - P.
    w.q.clear();
    w.q.extend_from_slice(&w.p[..n * s]);
    w.q.iter_mut().for_each(|v| *v = -*v);
    for i in 0..n {
        w.q[i * s + i] += 1.0;
    }
    w.mm.resize(n * n, 0.0);
    for r in 0..n {
        for c in 0..=r {
            let mut acc = 0.0;
            for i in 0..m {
                acc += a * w.x[i * s + r] * w.x[i * s + c];
            }
            let mut qq = 0.0;
            for k in 0..n {
                qq += w.q[k * s + r] * w.q[k * s + c];
            }
            let v = acc + eta * qq;
            w.mm[r * n + c] = v;
            w.mm[c * n + r] = v;
        }
    }
    let a2 = a * a;
    w.chol.clear();
    w.chol.extend_from_slice(&w.mm);
    for i in 0..n {
        w.chol[i * n + i] -= threshold;
    }
    let plain = cholesky_in_place(&mut w.chol, n) && {
        w.chol.clear();
        w.chol.extend_from_slice(&w.mm);
        cholesky_in_place(&mut w.chol, n)
    };
    if plain {
        for i in 0..m {
            let row = &mut w.y[i * s..(i + 1) * s];
            row.copy_from_slice(&w.x[i * s..(i + 1) * s]);
            cholesky_solve(&w.chol, n, &mut row[..n]);
            row[..n].iter_mut().for_each(|v| *v *= a2);
        }
        return true;
    }
    let eig = DMatrix::from_row_slice(n, n, &w.mm).symmetric_eigen();
    let v = &eig.eigenvectors;
    // (Reusing the Cholesky buffer: d, then V^T x.)
    w.chol.clear();
    w.chol.extend(eig.eigenvalues.iter().map(|&sv| {
        let sv = sv.max(0.0);
        let b = bell(sv, lambda * lambda, threshold);
        if sv + b > 0.0 { a2 / (sv + b) } else { 0.0 }
    }));
    w.chol.resize(2 * n, 0.0);
    for i in 0..m {
        // y_i = V D V^T x_i
        let x = &w.x[i * s..i * s + n];
        let (d, proj) = w.chol.split_at_mut(n);
        for (k, o) in proj.iter_mut().enumerate() {
            *o = d[k] * (0..n).map(|r| v[(r, k)] * x[r]).sum::<f64>();
        }
        let row = &mut w.y[i * s..(i + 1) * s];
        for (r, o) in row[..n].iter_mut().enumerate() {
            *o = (0..n).map(|k| v[(r, k)] * proj[k]).sum();
        }
    }
    true
}

/// Width of the damped path's kernels; rows are padded to a multiple of it.
const LANES: usize = 4;

/// y += a x, over whole chunks of [`LANES`] (the rows are padded).
fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    for (y, x) in y.chunks_exact_mut(LANES).zip(x.chunks_exact(LANES)) {
        for l in 0..LANES {
            y[l] += a * x[l];
        }
    }
}

/// a . b, over whole chunks of [`LANES`] with one running sum per lane.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; LANES];
    for (a, b) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
        for l in 0..LANES {
            acc[l] += a[l] * b[l];
        }
    }
    (acc[0] + acc[2]) + (acc[1] + acc[3])
}

/// Solves L L^T c = b in place (`l` from [`cholesky_in_place`], m x m row-major).
fn cholesky_solve(l: &[f64], m: usize, b: &mut [f64]) {
    for i in 0..m {
        let mut acc = b[i];
        for k in 0..i {
            acc -= l[i * m + k] * b[k];
        }
        b[i] = acc / l[i * m + i];
    }
    for i in (0..m).rev() {
        let mut acc = b[i];
        for k in i + 1..m {
            acc -= l[k * m + i] * b[k];
        }
        b[i] = acc / l[i * m + i];
    }
}

/// Cholesky factorisation of the lower triangle of a row-major m x m matrix, in place; false if it
/// is not positive definite.
fn cholesky_in_place(g: &mut [f64], m: usize) -> bool {
    for i in 0..m {
        for c in 0..=i {
            let mut acc = g[i * m + c];
            for k in 0..c {
                acc -= g[i * m + k] * g[c * m + k];
            }
            if i == c {
                if !(acc > 0.0) {
                    return false;
                }
                g[i * m + i] = acc.sqrt();
            } else {
                g[i * m + c] = acc / g[c * m + c];
            }
        }
    }
    true
}

/// The Moore-Penrose pseudo-inverse, singular values under `tolerance` dropped, from the
/// eigen-decomposition of the smaller Gram matrix (X X^T or X^T X). nalgebra's own SVD-based
/// pseudo-inverse returned a wrong result for a tall rank-1 matrix with an exactly zero singular
/// value (X X^+ X != X), found by this module's tests.
pub fn pseudo_inverse(x: &DMatrix<f64>, tolerance: f64) -> DMatrix<f64> {
    let tol2 = tolerance * tolerance;
    if x.nrows() <= x.ncols() {
        // X^+ = X^T (X X^T)^+
        x.transpose() * gram_pinv(x * x.transpose(), tol2)
    } else {
        // X^+ = (X^T X)^+ X^T
        gram_pinv(x.transpose() * x, tol2) * x.transpose()
    }
}

/// The pseudo-inverse of a symmetric positive semi-definite Gram matrix, eigenvalues under
/// `tol2` dropped.
fn gram_pinv(gram: DMatrix<f64>, tol2: f64) -> DMatrix<f64> {
    let k = gram.nrows();
    let eig = gram.symmetric_eigen();
    let mut inv = DMatrix::zeros(k, k);
    for i in 0..k {
        let l = eig.eigenvalues[i];
        if l > tol2 {
            let u = eig.eigenvectors.column(i);
            inv += u * u.transpose() / l;
        }
    }
    inv
}

/// The regularisation of a singular value s: `peak` at 0, falling to 0 at `threshold` along a
/// cosine, 0 beyond.
fn bell(s: f64, peak: f64, threshold: f64) -> f64 {
    if threshold <= 0.0 || s >= threshold {
        0.0
    } else {
        peak * 0.5 * (1.0 + (std::f64::consts::PI * s / threshold).cos())
    }
}
