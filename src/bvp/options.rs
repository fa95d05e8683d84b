//! Solver options: one struct, every field documented with its default.
//!
//! # Tolerances
//!
//! With `w_j(y) = atol * s_j + tol * |y_j|` (`s_j` = [`Options::scale`], default 1), a
//! per-interval error estimate `e_i` (see [`ErrorControl`]) is accepted when `e_i <= 1`, i.e.
//! the estimated error of component `j` is below `atol * s_j + tol * |y_j|`. The boundary
//! residual must satisfy `max |g| <= bc_tol`.

use super::error::BvpError;

/// What the per-interval estimate `e_i` measures (both use the same residual samples).
///
/// Let `u` be the collocation polynomial on interval `i` (width `h_i`) and
/// `r(x) = u'(x) - f(x, u(x), p)` its residual, sampled at the three interior 5-point Lobatto
/// points, where it does not vanish by construction.
///
/// ```text
/// Error    : e_i = h_i * RMS_q  max_j |r_j(x_q)| / w_j(u(x_q))           (O(h^5), default)
/// Residual : e_i = RMS_q sqrt(sum_j (r_j(x_q) / (1 + |f_j(x_q)|))^2) / tol  (O(h^4), scipy-style)
/// ```
///
/// `Error` estimates the local error of the interpolant (Kierzenka & Shampine 2008: for the
/// 4-point Lobatto IIIA scheme `h * |residual|` is an asymptotically correct estimate of the
/// true error of the continuous solution). `Residual` is the criterion of scipy's `solve_bvp`
/// and bvp4c; it is stricter and needs more nodes for the same accuracy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ErrorControl {
    /// Control `h * residual` against `atol * s + tol * |y|` (default).
    #[default]
    Error,
    /// Control the RMS relative residual `r / (1 + |f|)` against `tol` (scipy/bvp4c).
    Residual,
}

/// Where the Jacobians of `f` and `g` come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum JacobianSource {
    /// Use the problem's analytic Jacobians where it provides them, finite differences
    /// otherwise (default).
    #[default]
    Analytic,
    /// Always use forward finite differences (`h = sqrt(eps) * (1 + |y|)`), even if the
    /// problem provides analytic Jacobians. Useful as an oracle in tests.
    FiniteDifference,
}

/// Options of [`solve`](super::solve). Construct with `Options::default()` and override fields.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Relative tolerance (default: 1e-6).
    pub tol: f64,
    /// Absolute tolerance; `None` means "same as `tol`" (default: None).
    pub atol: Option<f64>,
    /// Tolerance on `max |g(y(a), y(b), p)|`; `None` means "same as `tol`" (default: None).
    pub bc_tol: Option<f64>,
    /// What the per-interval estimate measures (default: [`ErrorControl::Error`]).
    pub error_control: ErrorControl,
    /// Maximum number of mesh nodes; exceeding it stops with
    /// [`Status::MaxNodes`](super::Status::MaxNodes) (default: 10000).
    pub max_nodes: usize,
    /// Maximum number of Newton iterations on one mesh before the mesh is refined instead
    /// (default: 8). Simplified iterations with a reused Jacobian count too.
    pub max_newton_iter: usize,
    /// Maximum number of mesh passes (solve, estimate, adapt) (default: 40).
    pub max_mesh_passes: usize,
    /// Newton failures tolerated, each followed by a uniform halving of the mesh, before
    /// [`NoConvergence`](super::Status::NoConvergence) (default: 4). Continuation sets it low:
    /// there a failure means "step too large", which a smaller step fixes more cheaply than
    /// a finer mesh.
    pub max_newton_failures: usize,
    /// Newton stops when the scaled max-norm of the (simplified) correction is below this
    /// fraction of the tolerance weights `w_j` (default: 1e-2).
    pub newton_tol: f64,
    /// Smallest damping factor before Newton gives up on the current mesh (default: 1e-4).
    pub min_damping: f64,
    /// Keep the Jacobian for the next iteration when the contraction rate `theta` of a full
    /// step is below this (simplified Newton) (default: 0.25). Set 0 to refactor every step.
    pub reuse_jacobian_below: f64,
    /// Ill-posedness guard (default: 100): a candidate solution is rejected with
    /// [`SingularJacobian`](super::Status::SingularJacobian) if `kappa * tol` exceeds this, where
    /// `kappa = max_r ||J^{-1} e_r||_inf` is the response of the discrete solution to a unit
    /// change of one boundary condition ([`Stats::bc_condition`](super::Stats::bc_condition)).
    /// A BVP without solution (e.g. `y'' + y = 0`, `y(0) = 0`, `y(pi) = 1`) has a discrete
    /// "solution" whose size grows like the inverse discretisation error; this catches it.
    /// The measure depends on the scaling of `g`; set `f64::INFINITY` to disable.
    pub conditioning_limit: f64,
    /// Adapt the mesh (default: true). With `false` the system is solved on the given mesh
    /// only; the status is [`Converged`](super::Status::Converged) if the error estimate meets the
    /// tolerance and [`ToleranceNotMet`](super::Status::ToleranceNotMet) otherwise.
    pub adapt_mesh: bool,
    /// After convergence, if equidistribution of the error estimates predicts a mesh with
    /// fewer than half the intervals (e.g. a warm start from a sharper problem), solve again
    /// on that coarser mesh (at most 3 times); if that fails, the last converged solution is
    /// returned (default: true).
    pub coarsen: bool,
    /// Per-component scales `s_j > 0` (typical magnitudes) multiplying `atol` (default: None = 1).
    pub scale: Option<Vec<f64>>,
    /// Where Jacobians come from (default: [`JacobianSource::Analytic`]).
    pub jacobian: JacobianSource,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            tol: 1e-6,
            atol: None,
            bc_tol: None,
            error_control: ErrorControl::Error,
            max_nodes: 10_000,
            max_newton_iter: 8,
            max_mesh_passes: 40,
            max_newton_failures: 4,
            newton_tol: 1e-2,
            min_damping: 1e-4,
            reuse_jacobian_below: 0.25,
            conditioning_limit: 100.0,
            adapt_mesh: true,
            coarsen: true,
            scale: None,
            jacobian: JacobianSource::Analytic,
        }
    }
}

impl Options {
    /// Absolute tolerance actually used.
    pub fn atol(&self) -> f64 {
        self.atol.unwrap_or(self.tol)
    }

    /// Boundary-condition tolerance actually used.
    pub fn bc_tol(&self) -> f64 {
        self.bc_tol.unwrap_or(self.tol)
    }

    /// Check every option against its allowed range; `n` is the number of states.
    pub fn validate(&self, n: usize) -> Result<(), BvpError> {
        let positive = |name, value: f64| {
            if value > 0.0 && value.is_finite() {
                Ok(())
            } else {
                Err(BvpError::InvalidOption {
                    name,
                    value,
                    expected: "a finite number > 0",
                })
            }
        };
        positive("tol", self.tol)?;
        positive("atol", self.atol())?;
        positive("bc_tol", self.bc_tol())?;
        positive("newton_tol", self.newton_tol)?;
        if self.conditioning_limit.is_nan() || self.conditioning_limit <= 0.0 {
            return Err(BvpError::InvalidOption {
                name: "conditioning_limit",
                value: self.conditioning_limit,
                expected: "a number > 0 (infinity disables the check)",
            });
        }
        if !(self.min_damping > 0.0 && self.min_damping <= 1.0) {
            return Err(BvpError::InvalidOption {
                name: "min_damping",
                value: self.min_damping,
                expected: "a number in (0, 1]",
            });
        }
        if !(0.0..1.0).contains(&self.reuse_jacobian_below) {
            return Err(BvpError::InvalidOption {
                name: "reuse_jacobian_below",
                value: self.reuse_jacobian_below,
                expected: "a number in [0, 1)",
            });
        }
        if self.max_nodes < 2 {
            return Err(BvpError::InvalidOption {
                name: "max_nodes",
                value: self.max_nodes as f64,
                expected: "an integer >= 2",
            });
        }
        if self.max_newton_iter == 0 {
            return Err(BvpError::InvalidOption {
                name: "max_newton_iter",
                value: 0.0,
                expected: "an integer >= 1",
            });
        }
        if self.max_mesh_passes == 0 {
            return Err(BvpError::InvalidOption {
                name: "max_mesh_passes",
                value: 0.0,
                expected: "an integer >= 1",
            });
        }
        if let Some(s) = &self.scale {
            if s.len() != n {
                return Err(BvpError::DimensionMismatch {
                    what: "options.scale",
                    expected: n,
                    found: s.len(),
                });
            }
            for &v in s {
                positive("scale[j]", v)?;
            }
        }
        Ok(())
    }

    /// `atol * s_j` for every component (length `n`).
    pub(crate) fn abs_weights(&self, n: usize) -> Vec<f64> {
        let atol = self.atol();
        match &self.scale {
            Some(s) => s.iter().map(|v| atol * v).collect(),
            None => vec![atol; n],
        }
    }
}
