//! The KKT conditions of a [`Transcription`]: residuals, least-squares multipliers at a given
//! primal point, and Newton's method on the KKT system (to move from an indirect solution,
//! which satisfies the discrete conditions only up to discretization error, to the exact KKT
//! point of the discretized problem nearby).
//!
//! The KKT matrix, unknowns `[v (n_var) | y (n_con)]`:
//!
//! ```text
//! K = [ H   Aᵀ ]     H = ∇²ℒ(v, y) (or the identity, for least squares),
//!     [ A   0  ]     A = ∂c/∂v
//! ```

use super::inertia::{InertiaError, LbltFactor, SymmetricPattern, BACKWARD_ERROR_TOL};
use super::problem::OcpProblem;
use super::transcription::{Entry, Transcription};

/// A primal-dual point: unknowns `v` and constraint multipliers `y`.
#[derive(Debug, Clone, PartialEq)]
pub struct KktPoint {
    /// The NLP unknowns.
    pub v: Vec<f64>,
    /// The multipliers of the constraints, in constraint order.
    pub y: Vec<f64>,
}

/// Sizes of the KKT residual at a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KktResidual {
    /// `‖∇J + Aᵀ y‖∞`.
    pub stationarity: f64,
    /// `‖∇J‖∞`, the scale of the stationarity residual.
    pub gradient_scale: f64,
    /// `‖c(v)‖∞`.
    pub feasibility: f64,
}

impl KktResidual {
    /// The stationarity residual relative to `‖∇J‖∞` (or absolute below 1).
    pub fn relative_stationarity(&self) -> f64 {
        self.stationarity / self.gradient_scale.max(1.0)
    }
}

/// Why a KKT computation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KktError {
    /// The KKT matrix could not be factorized or solved reliably.
    #[error("the KKT matrix is singular to working precision ({what}): {reason}")]
    Singular {
        /// Which system.
        what: &'static str,
        /// The factorization's reason.
        reason: String,
    },
    /// The pattern analysis failed.
    #[error("KKT pattern analysis: {0}")]
    Pattern(#[from] InertiaError),
    /// Newton's method did not reach the tolerance.
    #[error(
        "Newton's method on the KKT system did not converge in {iterations} iterations \
         (stationarity {stationarity:.2e}, feasibility {feasibility:.2e})"
    )]
    NotConverged {
        /// Iterations done.
        iterations: usize,
        /// Last relative stationarity residual.
        stationarity: f64,
        /// Last feasibility residual.
        feasibility: f64,
    },
}

/// `y ← y + Aᵀ x` for entries of `A`.
fn add_transpose_product(a: &[Entry], x: &[f64], y: &mut [f64]) {
    for &(r, c, v) in a {
        y[c] += v * x[r];
    }
}

/// The first-order pieces of the KKT conditions at a primal point `v`, evaluated once and
/// shared by the computations that need them there (least-squares multipliers, the first
/// Newton iteration).
#[derive(Debug, Clone, PartialEq)]
pub struct PrimalEvaluation {
    /// The constraint Jacobian `A = ∂c/∂v`.
    pub jacobian: Vec<Entry>,
    /// `∇J(v)`.
    pub gradient: Vec<f64>,
    /// `c(v)`.
    pub constraints: Vec<f64>,
}

impl PrimalEvaluation {
    /// The pieces at `v`.
    pub fn at<P: OcpProblem + ?Sized>(tr: &Transcription<'_, P>, v: &[f64]) -> Self {
        Self {
            jacobian: tr.jacobian(v),
            gradient: tr.gradient(v),
            constraints: tr.constraints(v),
        }
    }
}

/// The KKT residual at `(v, y)`.
pub fn residual<P: OcpProblem + ?Sized>(tr: &Transcription<'_, P>, pt: &KktPoint) -> KktResidual {
    let g = tr.gradient(&pt.v);
    let gradient_scale = norm_inf(&g);
    let mut r = g;
    add_transpose_product(&tr.jacobian(&pt.v), &pt.y, &mut r);
    KktResidual {
        stationarity: norm_inf(&r),
        gradient_scale,
        feasibility: norm_inf(&tr.constraints(&pt.v)),
    }
}

fn norm_inf(x: &[f64]) -> f64 {
    x.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// The KKT matrices `[[D, Aᵀ], [A, 0]]` of one transcription: the symmetric pattern
/// (diagonal of the unknowns, Lagrangian Hessian, constraint Jacobian) analysed once, with the
/// transcription's time-ordered pivot groups ([`Transcription::kkt_pivot_groups`]), and
/// factorized by a pivoted `L B Lᵀ` ([`super::inertia`]) for every solve and inertia count.
pub struct KktMatrix {
    pattern: SymmetricPattern,
    /// The `(row, column)` of each value, in the order of [`KktMatrix::values`].
    entries: Vec<(usize, usize)>,
    n_var: usize,
    n_con: usize,
    /// Whether the constraint block has a diagonal (for [`KktMatrix::values_regularized`]).
    constraint_diagonal: bool,
}

impl KktMatrix {
    /// The pattern of `tr`'s KKT matrices. The positions do not depend on the point: they are
    /// the transcription's structure ([`Transcription::jacobian_positions`],
    /// [`Transcription::lagrangian_hessian_positions`]), found without evaluating the problem.
    pub fn new<P: OcpProblem + ?Sized>(tr: &Transcription<'_, P>) -> Result<Self, KktError> {
        Self::build(tr, false)
    }

    /// [`KktMatrix::new`] with a diagonal in the constraint block too, for the matrices
    /// `[[H + δ_w I, Aᵀ], [A, −δ_c I]]` of [`KktMatrix::values_regularized`] (a constraint
    /// Jacobian that loses rank).
    pub fn regularizable<P: OcpProblem + ?Sized>(
        tr: &Transcription<'_, P>,
    ) -> Result<Self, KktError> {
        Self::build(tr, true)
    }

    fn build<P: OcpProblem + ?Sized>(
        tr: &Transcription<'_, P>,
        constraint_diagonal: bool,
    ) -> Result<Self, KktError> {
        let (nv, nc) = (tr.n_var(), tr.n_con());
        let hessian = tr.lagrangian_hessian_positions();
        let jacobian = tr.jacobian_positions();
        // Exactly sized: the list is a quarter of a million entries on a paper mesh.
        let extra = if constraint_diagonal { nc } else { 0 };
        let mut entries = Vec::with_capacity(nv + hessian.len() + jacobian.len() + extra);
        entries.extend((0..nv).map(|i| (i, i)));
        entries.extend(hessian.iter().map(|&(r, c, _)| (r, c)));
        drop(hessian);
        entries.extend(jacobian.iter().map(|&(r, c, _)| (nv + r, c)));
        drop(jacobian);
        if constraint_diagonal {
            entries.extend((nv..nv + nc).map(|i| (i, i)));
        }
        let groups = tr.kkt_pivot_groups();
        let pattern = SymmetricPattern::with_groups(nv + nc, &entries, &groups)?;
        Ok(Self {
            pattern,
            entries,
            n_var: nv,
            n_con: nc,
            constraint_diagonal,
        })
    }

    /// Values of `[[H + diag, Aᵀ], [A, −δ_c I]]` in pattern order (a matrix built by
    /// [`KktMatrix::regularizable`]; for another, `δ_c` must be 0).
    pub fn values_regularized(
        &self,
        diag: &[f64],
        h: &[Entry],
        a: &[Entry],
        delta_c: f64,
    ) -> Vec<f64> {
        let mut values = self.values(diag, h, a);
        if self.constraint_diagonal {
            let start = values.len() - self.n_con;
            values[start..].fill(-delta_c);
        }
        values
    }

    /// A factorization of the matrix with `values`, without the proof of its inertia
    /// ([`LbltFactor::factorize_unproven`]).
    pub fn factorize_unproven(&self, values: &[f64]) -> Result<LbltFactor, InertiaError> {
        LbltFactor::factorize_unproven(&self.pattern, values)
    }

    /// Values in pattern order: the diagonal `diag` (`n_var`, added to the Hessian's), the
    /// Hessian entries `h` (lower triangle), the Jacobian `a` (both as the transcription
    /// returns them).
    pub fn values(&self, diag: &[f64], h: &[Entry], a: &[Entry]) -> Vec<f64> {
        let mut values = Vec::with_capacity(self.entries.len());
        values.extend_from_slice(diag);
        values.extend(h.iter().map(|e| e.2));
        values.extend(a.iter().map(|e| e.2));
        if self.constraint_diagonal {
            values.resize(self.entries.len(), 0.0);
        }
        values
    }

    /// [`Self::values`] with every Hessian entry 0, without evaluating the Hessian (its entries
    /// are the pattern's between the diagonal and the Jacobian's).
    pub fn values_without_hessian(&self, diag: &[f64], a: &[Entry]) -> Vec<f64> {
        let extra = if self.constraint_diagonal {
            self.n_con
        } else {
            0
        };
        let n_hessian = self.entries.len() - diag.len() - a.len() - extra;
        let mut values = Vec::with_capacity(self.entries.len());
        values.extend_from_slice(diag);
        values.resize(diag.len() + n_hessian, 0.0);
        values.extend(a.iter().map(|e| e.2));
        values.resize(self.entries.len(), 0.0);
        values
    }

    /// `values` with every entry in a row or column outside `kept` set to zero: the principal
    /// submatrix on `kept`, bordered by exactly zero rows (which a factorization deflates and
    /// counts as zero eigenvalues: `inertia = inertia(submatrix) + (0, 0, #removed)`), on the
    /// same analysed pattern.
    pub fn principal_values(&self, values: &[f64], kept: impl Fn(usize) -> bool) -> Vec<f64> {
        values
            .iter()
            .zip(&self.entries)
            .map(|(&v, &(r, c))| if kept(r) && kept(c) { v } else { 0.0 })
            .collect()
    }

    /// A factorization of the matrix with `values`.
    pub fn factorize(&self, values: &[f64]) -> Result<LbltFactor, InertiaError> {
        LbltFactor::factorize(&self.pattern, values)
    }

    /// [`KktMatrix::factorize`], with `work` done with the factors while their checks run
    /// ([`LbltFactor::factorize_while`]).
    pub fn factorize_while<T>(
        &self,
        values: &[f64],
        work: impl FnOnce(&LbltFactor) -> T,
    ) -> Result<(LbltFactor, T), InertiaError> {
        LbltFactor::factorize_while(&self.pattern, values, work)
    }

    /// A factorization of the matrix with `values` for solves only
    /// ([`LbltFactor::factorize_for_solve`]: each solve's backward error is the check).
    pub fn factorize_for_solve(&self, values: &[f64]) -> Result<LbltFactor, InertiaError> {
        LbltFactor::factorize_for_solve(&self.pattern, values)
    }

    /// Number of unknowns.
    pub fn n_var(&self) -> usize {
        self.n_var
    }

    /// Number of constraints.
    pub fn n_con(&self) -> usize {
        self.n_con
    }
}

/// Solves `K x = rhs` in place with a fresh factorization of `values` (returned, for further
/// solves with the same matrix). The solve, refined, must have a backward error of at most
/// [`BACKWARD_ERROR_TOL`] and a finite solution: that is the check of the factorization (its
/// inertia is not needed, and not proven).
fn solve_kkt(
    kkt: &KktMatrix,
    values: &[f64],
    rhs: &mut [f64],
    what: &'static str,
) -> Result<LbltFactor, KktError> {
    let singular = |e: InertiaError| KktError::Singular {
        what,
        reason: e.to_string(),
    };
    let factor = kkt.factorize_for_solve(values).map_err(singular)?;
    let berr = factor.solve_in_place(rhs).map_err(singular)?;
    if !rhs.iter().all(|v| v.is_finite()) {
        return Err(KktError::Singular {
            what,
            reason: "non-finite solution".into(),
        });
    }
    if berr.is_nan() || berr > BACKWARD_ERROR_TOL {
        return Err(KktError::Singular {
            what,
            reason: format!(
                "the solve's backward error {berr:.1e} exceeds {BACKWARD_ERROR_TOL:.0e} after \
                 refinement"
            ),
        });
    }
    Ok(factor)
}

/// The multipliers that minimize `‖∇J(v) + Aᵀ y‖₂` at a fixed primal point (the best
/// multipliers a primal point admits; exact if `v` is a KKT point and `A` has full rank).
pub fn least_squares_multipliers<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    v: &[f64],
) -> Result<Vec<f64>, KktError> {
    multipliers_from(kkt, &tr.jacobian(v), &tr.gradient(v))
}

/// [`least_squares_multipliers`] at the point of `eval`.
pub fn least_squares_multipliers_at(
    kkt: &KktMatrix,
    eval: &PrimalEvaluation,
) -> Result<Vec<f64>, KktError> {
    multipliers_from(kkt, &eval.jacobian, &eval.gradient)
}

/// Multipliers at the point of `eval` from costates `pi` (`P × n`, e.g. an indirect
/// solution's at the transcription's points), without a factorization: the dynamics rows
/// from [`Transcription::dynamics_multipliers_from_costates`], then the boundary rows by
/// least squares on the stationarity residual of the unknowns they involve (a dense problem
/// of at most a few dozen entries). `None` when the transcription has path constraints (whose
/// multipliers the costates do not give), when `pi` has the wrong length, or when the result
/// is not finite: the caller then uses [`least_squares_multipliers_at`].
///
/// They are not the least-squares multipliers: they carry the costates' discretization error
/// (the certificate's `costate_mismatch` measures its size), which one Newton step on the
/// KKT conditions removes together with the primal point's.
pub fn multipliers_from_costates<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    eval: &PrimalEvaluation,
    pi: &[f64],
) -> Option<Vec<f64>> {
    if tr.n_path() > 0 || pi.len() != tr.n_points() * tr.n_state() {
        return None;
    }
    let mut y = tr.dynamics_multipliers_from_costates(pi);
    let mut r = eval.gradient.clone();
    add_transpose_product(&eval.jacobian, &y, &mut r);
    let rows = tr.boundary_rows();
    let entries: Vec<&Entry> = eval
        .jacobian
        .iter()
        .filter(|e| rows.contains(&e.0))
        .collect();
    let mut cols: Vec<usize> = entries.iter().map(|e| e.1).collect();
    cols.sort_unstable();
    cols.dedup();
    // No boundary rows, or none that involves an unknown (a linear condition without
    // coefficients): nothing to fit, and their minimum-norm multipliers are 0 (a dense
    // problem without rows or columns is not handed to the SVD, which rejects it).
    if cols.is_empty() {
        return y.iter().all(|v| v.is_finite()).then_some(y);
    }
    // min ‖r_cols + Bᵀ μ‖ over the boundary multipliers μ, B the boundary rows' entries.
    let mut bt = nalgebra::DMatrix::<f64>::zeros(cols.len(), rows.len());
    for &&(row, col, value) in &entries {
        if let Ok(c) = cols.binary_search(&col) {
            bt[(c, row - rows.start)] += value;
        }
    }
    let rhs = nalgebra::DVector::from_iterator(cols.len(), cols.iter().map(|&c| -r[c]));
    let mu = bt.svd(true, true).solve(&rhs, 1e-14).ok()?;
    y[rows].copy_from_slice(mu.as_slice());
    y.iter().all(|v| v.is_finite()).then_some(y)
}

/// The least-squares multipliers from the Jacobian `a` and the gradient `g` at a point.
fn multipliers_from(kkt: &KktMatrix, a: &[Entry], g: &[f64]) -> Result<Vec<f64>, KktError> {
    let (nv, nc) = (kkt.n_var(), kkt.n_con());
    // [[I, Aᵀ], [A, 0]] [r; y] = [−∇J; 0]  ⇒  r = −∇J − Aᵀy with A r = 0.
    let values = kkt.values_without_hessian(&vec![1.0; nv], a);
    let mut rhs = vec![0.0; nv + nc];
    for (r, g) in rhs.iter_mut().zip(g) {
        *r = -g;
    }
    solve_kkt(kkt, &values, &mut rhs, "least-squares multipliers")?;
    Ok(rhs[nv..].to_vec())
}

/// Options of [`newton`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// Stop when the relative stationarity and the feasibility are both below this.
    pub tolerance: f64,
    /// Iteration limit.
    pub max_iterations: usize,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-10,
            max_iterations: 12,
        }
    }
}

/// The history of a Newton run.
#[derive(Debug, Clone, PartialEq)]
pub struct NewtonReport {
    /// Residuals before each iteration and after the last.
    pub residuals: Vec<KktResidual>,
}

/// Newton's method on the KKT conditions from `start` (full steps: it is meant for a start
/// that is already close, such as an indirect solution). Returns the converged point.
pub fn newton<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    start: KktPoint,
    opts: &NewtonOptions,
) -> Result<(KktPoint, NewtonReport), KktError> {
    newton_keeping_factor(tr, kkt, start, opts).map(|(pt, report, _)| (pt, report))
}

/// [`newton`], also returning the factorization of its last step (of the KKT matrix at the
/// last iterate before the converged point; `None` when the start had converged): a matrix
/// near the one at the converged point, whose solves can seed estimates there (see
/// [`super::certify::second_order_near`]). Its inertia is not proven.
pub fn newton_keeping_factor<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    start: KktPoint,
    opts: &NewtonOptions,
) -> Result<(KktPoint, NewtonReport, Option<LbltFactor>), KktError> {
    let first = PrimalEvaluation::at(tr, &start.v);
    newton_from(tr, kkt, start, first, opts)
}

/// [`newton_keeping_factor`] given `first`, the [`PrimalEvaluation`] at `start.v` (already
/// computed by the caller, e.g. for the least-squares multipliers). Its first residual
/// (`residuals[0]` of the report) is [`residual`] at `start`, to the bit.
pub fn newton_from<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    start: KktPoint,
    first: PrimalEvaluation,
    opts: &NewtonOptions,
) -> Result<(KktPoint, NewtonReport, Option<LbltFactor>), KktError> {
    let zeros = vec![0.0; tr.n_var()];
    let mut pt = start;
    let mut residuals = Vec::new();
    let mut last_factor = None;
    let mut it = 0;
    let mut eval = Some(first);
    loop {
        // The residual as [`residual`] computes it, its pieces kept for the step.
        let PrimalEvaluation {
            jacobian: a,
            gradient,
            constraints,
        } = eval
            .take()
            .unwrap_or_else(|| PrimalEvaluation::at(tr, &pt.v));
        let mut stationarity = gradient;
        let gradient_scale = norm_inf(&stationarity);
        add_transpose_product(&a, &pt.y, &mut stationarity);
        let res = KktResidual {
            stationarity: norm_inf(&stationarity),
            gradient_scale,
            feasibility: norm_inf(&constraints),
        };
        residuals.push(res);
        if res.relative_stationarity() <= opts.tolerance && res.feasibility <= opts.tolerance {
            return Ok((pt, NewtonReport { residuals }, last_factor));
        }
        let finite = res.stationarity.is_finite() && res.feasibility.is_finite();
        if it == opts.max_iterations || !finite {
            return Err(KktError::NotConverged {
                iterations: it,
                stationarity: res.relative_stationarity(),
                feasibility: res.feasibility,
            });
        }
        let mut rhs = stationarity;
        rhs.extend(constraints);
        rhs.iter_mut().for_each(|r| *r = -*r);
        let values = kkt.values(&zeros, &tr.lagrangian_hessian(&pt.v, &pt.y), &a);
        last_factor = Some(solve_kkt(kkt, &values, &mut rhs, "Newton step")?);
        for (x, d) in pt.v.iter_mut().chain(pt.y.iter_mut()).zip(&rhs) {
            *x += d;
        }
        it += 1;
    }
}
