//! The problem interface ([`BvpProblem`]) and the finite-difference Jacobians that serve as
//! fallback and as test oracle.
//!
//! Notation: `n` states, `k` unknown parameters, `n + k` boundary conditions. All matrices
//! are dense and **row-major**: `dfdy[i * n + j] = d f_i / d y_j`.

use std::cell::Cell;

use super::options::JacobianSource;

/// A two-point boundary value problem
///
/// ```text
/// y'(x) = f(x, y, p),   a <= x <= b,   y in R^n, p in R^k,
/// g(y(a), y(b), p) = 0,                 g in R^(n+k).
/// ```
///
/// Only [`n`](Self::n), [`f`](Self::f) and [`bc`](Self::bc) are required. The Jacobian methods
/// return `false` by default, which tells the solver to use forward differences
/// ([`estimate_fun_jac`], [`estimate_bc_jac`]).
///
/// A problem signals a domain error (e.g. `ln` of a negative number) by writing NaN: the
/// solver then stops with [`Status::NonFinite`](super::Status::NonFinite) instead of panicking.
pub trait BvpProblem {
    /// Number of states `n >= 1`.
    fn n(&self) -> usize;

    /// Number of unknown parameters `k` (default 0).
    fn k(&self) -> usize {
        0
    }

    /// Right-hand side: writes `f(x, y, p)` into `dy` (length `n`).
    fn f(&self, x: f64, y: &[f64], p: &[f64], dy: &mut [f64]);

    /// Jacobians of `f`: `dfdy` (`n x n`, row-major, `dfdy[i*n+j] = df_i/dy_j`) and `dfdp`
    /// (`n x k`, row-major). Return `true` if written, `false` (default) to request finite
    /// differences.
    fn jac(&self, _x: f64, _y: &[f64], _p: &[f64], _dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        false
    }

    /// Boundary residual: writes `g(ya, yb, p)` into `res` (length `n + k`).
    fn bc(&self, ya: &[f64], yb: &[f64], p: &[f64], res: &mut [f64]);

    /// Jacobians of `g`, each `(n + k) x ...` row-major: `dya` (`n+k x n`), `dyb` (`n+k x n`),
    /// `dp` (`n+k x k`). Return `true` if written, `false` (default) for finite differences.
    fn bc_jac(
        &self,
        _ya: &[f64],
        _yb: &[f64],
        _p: &[f64],
        _dya: &mut [f64],
        _dyb: &mut [f64],
        _dp: &mut [f64],
    ) -> bool {
        false
    }
}

/// Forward-difference step for a value `v`: `sqrt(eps) * (1 + |v|)` (as scipy's
/// `estimate_fun_jac`).
fn fd_step(v: f64) -> f64 {
    f64::EPSILON.sqrt() * (1.0 + v.abs())
}

/// Forward-difference Jacobians of `f` at `(x, y, p)`.
///
/// `f0` must hold `f(x, y, p)`; `work` is scratch of length `2n + k`. Writes `dfdy` (`n x n`)
/// and `dfdp` (`n x k`), row-major. Costs `n + k` evaluations of `f`.
#[allow(clippy::too_many_arguments)]
pub fn estimate_fun_jac<P: BvpProblem + ?Sized>(
    problem: &P,
    x: f64,
    y: &[f64],
    p: &[f64],
    f0: &[f64],
    dfdy: &mut [f64],
    dfdp: &mut [f64],
    work: &mut [f64],
) {
    let n = y.len();
    let k = p.len();
    let (yh, rest) = work.split_at_mut(n);
    let (fh, ph) = rest.split_at_mut(n);
    let ph = &mut ph[..k];
    yh.copy_from_slice(y);
    ph.copy_from_slice(p);
    for j in 0..n {
        let h = fd_step(y[j]);
        yh[j] = y[j] + h;
        let h = yh[j] - y[j];
        problem.f(x, yh, p, fh);
        for i in 0..n {
            dfdy[i * n + j] = (fh[i] - f0[i]) / h;
        }
        yh[j] = y[j];
    }
    for j in 0..k {
        let h = fd_step(p[j]);
        ph[j] = p[j] + h;
        let h = ph[j] - p[j];
        problem.f(x, y, ph, fh);
        for i in 0..n {
            dfdp[i * k + j] = (fh[i] - f0[i]) / h;
        }
        ph[j] = p[j];
    }
}

/// Forward-difference Jacobians of the boundary residual `g` at `(ya, yb, p)`.
///
/// `g0` must hold `g(ya, yb, p)`; `work` is scratch of length `3n + 2k`. Writes `dya`, `dyb`
/// (`(n+k) x n`) and `dp` (`(n+k) x k`), row-major. Costs `2n + k` evaluations of `g`.
#[allow(clippy::too_many_arguments)]
pub fn estimate_bc_jac<P: BvpProblem + ?Sized>(
    problem: &P,
    ya: &[f64],
    yb: &[f64],
    p: &[f64],
    g0: &[f64],
    dya: &mut [f64],
    dyb: &mut [f64],
    dp: &mut [f64],
    work: &mut [f64],
) {
    let n = ya.len();
    let k = p.len();
    let m = n + k;
    let (yah, rest) = work.split_at_mut(n);
    let (ybh, rest) = rest.split_at_mut(n);
    let (ph, gh) = rest.split_at_mut(k);
    let gh = &mut gh[..m];
    yah.copy_from_slice(ya);
    ybh.copy_from_slice(yb);
    ph.copy_from_slice(p);
    for j in 0..n {
        let h = fd_step(ya[j]);
        yah[j] = ya[j] + h;
        let h = yah[j] - ya[j];
        problem.bc(yah, yb, p, gh);
        for i in 0..m {
            dya[i * n + j] = (gh[i] - g0[i]) / h;
        }
        yah[j] = ya[j];
    }
    for j in 0..n {
        let h = fd_step(yb[j]);
        ybh[j] = yb[j] + h;
        let h = ybh[j] - yb[j];
        problem.bc(ya, ybh, p, gh);
        for i in 0..m {
            dyb[i * n + j] = (gh[i] - g0[i]) / h;
        }
        ybh[j] = yb[j];
    }
    for j in 0..k {
        let h = fd_step(p[j]);
        ph[j] = p[j] + h;
        let h = ph[j] - p[j];
        problem.bc(ya, yb, ph, gh);
        for i in 0..m {
            dp[i * k + j] = (gh[i] - g0[i]) / h;
        }
        ph[j] = p[j];
    }
}

/// The problem as the solver sees it: one internal signature, evaluation counters, and the
/// analytic-or-FD choice made once (cf. scipy's `wrap_functions`).
pub(crate) struct Evaluator<'a, P: BvpProblem + ?Sized> {
    problem: &'a P,
    source: JacobianSource,
    pub n: usize,
    pub k: usize,
    pub f_evals: Cell<usize>,
    pub bc_evals: Cell<usize>,
    pub jac_evals: Cell<usize>,
    pub bc_jac_evals: Cell<usize>,
}

impl<'a, P: BvpProblem + ?Sized> Evaluator<'a, P> {
    pub fn new(problem: &'a P, source: JacobianSource) -> Self {
        Self {
            problem,
            source,
            n: problem.n(),
            k: problem.k(),
            f_evals: Cell::new(0),
            bc_evals: Cell::new(0),
            jac_evals: Cell::new(0),
            bc_jac_evals: Cell::new(0),
        }
    }

    /// `dy = f(x, y, p)`.
    pub fn eval_f(&self, x: f64, y: &[f64], p: &[f64], dy: &mut [f64]) {
        self.f_evals.set(self.f_evals.get() + 1);
        self.problem.f(x, y, p, dy);
    }

    /// `res = g(ya, yb, p)`.
    pub fn eval_bc(&self, ya: &[f64], yb: &[f64], p: &[f64], res: &mut [f64]) {
        self.bc_evals.set(self.bc_evals.get() + 1);
        self.problem.bc(ya, yb, p, res);
    }

    /// Jacobians of `f` (analytic, else FD). `f0 = f(x, y, p)`; `work` has length `2n + k`.
    #[allow(clippy::too_many_arguments)]
    pub fn eval_jac(
        &self,
        x: f64,
        y: &[f64],
        p: &[f64],
        f0: &[f64],
        dfdy: &mut [f64],
        dfdp: &mut [f64],
        work: &mut [f64],
    ) {
        self.jac_evals.set(self.jac_evals.get() + 1);
        if self.source == JacobianSource::Analytic && self.problem.jac(x, y, p, dfdy, dfdp) {
            return;
        }
        self.f_evals.set(self.f_evals.get() + self.n + self.k);
        estimate_fun_jac(self.problem, x, y, p, f0, dfdy, dfdp, work);
    }

    /// Jacobians of `g` (analytic, else FD). `g0 = g(ya, yb, p)`; `work` has length `3n + 2k`.
    #[allow(clippy::too_many_arguments)]
    pub fn eval_bc_jac(
        &self,
        ya: &[f64],
        yb: &[f64],
        p: &[f64],
        g0: &[f64],
        dya: &mut [f64],
        dyb: &mut [f64],
        dp: &mut [f64],
        work: &mut [f64],
    ) {
        self.bc_jac_evals.set(self.bc_jac_evals.get() + 1);
        if self.source == JacobianSource::Analytic && self.problem.bc_jac(ya, yb, p, dya, dyb, dp) {
            return;
        }
        self.bc_evals.set(self.bc_evals.get() + 2 * self.n + self.k);
        estimate_bc_jac(self.problem, ya, yb, p, g0, dya, dyb, dp, work);
    }
}
