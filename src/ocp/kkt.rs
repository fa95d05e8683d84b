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

use faer::linalg::solvers::SolveCore;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, MatMut};

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
    /// The sparse LU of the KKT matrix failed or produced non-finite values.
    #[error("the KKT matrix is singular to working precision ({what})")]
    Singular {
        /// Which system.
        what: &'static str,
    },
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

/// Solves `[[D, Aᵀ], [A, 0]] [dv; dy] = rhs` in place, with `D` given as lower-triangle
/// entries (mirrored here). General sparse LU (faer); the matrix is symmetric indefinite.
fn solve_kkt(
    n_var: usize,
    n_con: usize,
    h_lower: &[Entry],
    a: &[Entry],
    rhs: &mut [f64],
    what: &'static str,
) -> Result<(), KktError> {
    let order = n_var + n_con;
    let mut trip = Vec::with_capacity(2 * h_lower.len() + 2 * a.len());
    for &(r, c, v) in h_lower {
        trip.push(Triplet::new(r, c, v));
        if r != c {
            trip.push(Triplet::new(c, r, v));
        }
    }
    for &(r, c, v) in a {
        trip.push(Triplet::new(n_var + r, c, v));
        trip.push(Triplet::new(c, n_var + r, v));
    }
    let singular = || KktError::Singular { what };
    let mat = SparseColMat::<usize, f64>::try_new_from_triplets(order, order, &trip)
        .map_err(|_| singular())?;
    let lu = mat.sp_lu().map_err(|_| singular())?;
    lu.solve_in_place_with_conj(Conj::No, MatMut::from_column_major_slice_mut(rhs, order, 1));
    if rhs.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(singular())
    }
}

/// The multipliers that minimize `‖∇J(v) + Aᵀ y‖₂` at a fixed primal point (the best
/// multipliers a primal point admits; exact if `v` is a KKT point and `A` has full rank).
pub fn least_squares_multipliers<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    v: &[f64],
) -> Result<Vec<f64>, KktError> {
    let (nv, nc) = (tr.n_var(), tr.n_con());
    // [[I, Aᵀ], [A, 0]] [r; y] = [−∇J; 0]  ⇒  r = −∇J − Aᵀy with A r = 0.
    let identity: Vec<Entry> = (0..nv).map(|i| (i, i, 1.0)).collect();
    let mut rhs = vec![0.0; nv + nc];
    for (r, g) in rhs.iter_mut().zip(tr.gradient(v)) {
        *r = -g;
    }
    solve_kkt(
        nv,
        nc,
        &identity,
        &tr.jacobian(v),
        &mut rhs,
        "least-squares multipliers",
    )?;
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
    start: KktPoint,
    opts: &NewtonOptions,
) -> Result<(KktPoint, NewtonReport), KktError> {
    let (nv, nc) = (tr.n_var(), tr.n_con());
    let mut pt = start;
    let mut residuals = Vec::new();
    let mut it = 0;
    loop {
        let res = residual(tr, &pt);
        residuals.push(res);
        if res.relative_stationarity() <= opts.tolerance && res.feasibility <= opts.tolerance {
            return Ok((pt, NewtonReport { residuals }));
        }
        let finite = res.stationarity.is_finite() && res.feasibility.is_finite();
        if it == opts.max_iterations || !finite {
            return Err(KktError::NotConverged {
                iterations: it,
                stationarity: res.relative_stationarity(),
                feasibility: res.feasibility,
            });
        }
        let a = tr.jacobian(&pt.v);
        let mut rhs = tr.gradient(&pt.v);
        add_transpose_product(&a, &pt.y, &mut rhs);
        rhs.extend(tr.constraints(&pt.v));
        rhs.iter_mut().for_each(|r| *r = -*r);
        solve_kkt(
            nv,
            nc,
            &tr.lagrangian_hessian(&pt.v, &pt.y),
            &a,
            &mut rhs,
            "Newton step",
        )?;
        for (x, d) in pt.v.iter_mut().chain(pt.y.iter_mut()).zip(&rhs) {
            *x += d;
        }
        it += 1;
    }
}
