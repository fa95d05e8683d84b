//! A generic two-point boundary value problem solver of order 6.
//!
//! ```text
//! y'(x) = f(x, y, p),   a <= x <= b,   y in R^n, p in R^k (unknown parameters),
//! g(y(a), y(b), p) = 0,  g in R^(n+k).
//! ```
//!
//! The module knows nothing about any particular application: a problem implements
//! [`BvpProblem`] (dimensions, `f`, `g`, optionally analytic Jacobians), the caller gives a
//! [`Guess`] and [`Options`], and [`solve`] returns a [`Solution`] whose [`Status`] tells the
//! truth. Misuse (wrong dimensions, bad mesh, bad options) is an `Err(`[`BvpError`]`)`.
//!
//! ```
//! use suslov::bvp::{solve, BvpProblem, Guess, Options};
//!
//! /// y'' = -y on [0, pi/2], y(0) = 0, y(pi/2) = 1  (solution sin x).
//! struct Sine;
//! impl BvpProblem for Sine {
//!     fn n(&self) -> usize { 2 }
//!     fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) { dy[0] = y[1]; dy[1] = -y[0]; }
//!     fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) { r[0] = ya[0]; r[1] = yb[0] - 1.0; }
//! }
//! let x: Vec<f64> = (0..5).map(|i| i as f64 * std::f64::consts::FRAC_PI_2 / 4.0).collect();
//! let guess = Guess::from_values(x.clone(), vec![0.0; 2 * x.len()], vec![]);
//! let sol = solve(&Sine, &guess, &Options { tol: 1e-8, ..Options::default() }).unwrap();
//! assert!(sol.is_success(), "{}", sol.message());
//! assert!((sol.eval(1.0)[0] - 1.0_f64.sin()).abs() < 1e-8);
//! // Warm start (exact restart; the caller's solution is not modified):
//! let again = solve(&Sine, &Guess::from_solution(&sol), &Options::default()).unwrap();
//! assert!(again.is_success());
//! ```
//!
//! # Using the API
//!
//! * **Guesses** ([`Guess`]): [`Guess::from_values`] (mesh + node values + parameters),
//!   [`Guess::from_fn`] (a closure sampled on a given mesh, stages included),
//!   [`Guess::from_solution`] (exact warm start: mesh, node and stage values, parameters) and
//!   [`Guess::from_solution_on_mesh`] (a previous solution resampled through its dense output);
//!   [`Guess::with_parameters`] replaces `p` (e.g. a continuation predictor). The solver only
//!   borrows the guess.
//! * **Status** ([`Status`]): use [`Solution::is_success`]; [`Status::message`] explains the
//!   outcome and what to try. A non-converged [`Solution`] still holds the last iterate.
//! * **Statistics** ([`Stats`]): Newton iterations, Jacobian evaluations and factorisations,
//!   `f`/`g` evaluations, node counts per mesh pass, final error estimate, residual, boundary
//!   residual and two conditioning measures.
//! * **Progress** ([`solve_with_progress`]): a `FnMut(&Progress)` hook called after every
//!   accepted Newton step and every mesh pass; the solver itself never prints.
//!
//! ```
//! # use suslov::bvp::{solve_with_progress, BvpProblem, Guess, Options, ProgressEvent};
//! # struct Sine;
//! # impl BvpProblem for Sine {
//! #     fn n(&self) -> usize { 2 }
//! #     fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) { dy[0] = y[1]; dy[1] = -y[0]; }
//! #     fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) { r[0] = ya[0]; r[1] = yb[0] - 1.0; }
//! # }
//! let guess = Guess::from_fn(&[0.0, 0.5, 1.0, 1.5], 2, vec![], |x, y| { y[0] = x; y[1] = 1.0; });
//! let mut log = Vec::new();
//! let sol = solve_with_progress(&Sine, &guess, &Options::default(), &mut |p| {
//!     if let ProgressEvent::MeshPass { max_error, .. } = p.event {
//!         log.push(format!("pass {}: {} nodes, max error {max_error:.1e}", p.pass, p.nodes));
//!     }
//! })
//! .unwrap();
//! assert!(sol.is_success());
//! assert_eq!(log.len(), sol.stats.mesh_passes);
//! ```
//!
//! # Method: 4-stage Lobatto IIIA collocation (order 6)
//!
//! On each interval `[x_i, x_i + h_i]` the solution is a quartic polynomial `u` with
//! `u(x_i) = y_i` and `u'(x_i + c_j h_i) = f(., u, p)` at the Lobatto points
//! `c = (0, (5 - sqrt 5)/10, (5 + sqrt 5)/10, 1)`. Equivalently (Runge-Kutta form, see
//! [`collocation`]) the unknowns are the node values `y_i`, the two interior stage values
//! `Y_2, Y_3` per interval, and `p`. Properties (Ascher, Mattheij & Russell, ch. 5):
//!
//! * order 6 (superconvergence `O(h^{2s-2})`, `s = 4`) at the mesh points;
//! * the piecewise quartic is `O(h^5)` uniformly and C1 (its derivative equals `f` at both
//!   ends of every interval), so it is the dense output ([`Solution::eval`],
//!   [`Solution::eval_derivative`]) at no extra cost;
//! * Lobatto IIIA is the natural higher-order sibling of the 3-stage scheme of scipy's
//!   `solve_bvp` and bvp4c (Kierzenka & Shampine 2001) and is the scheme of bvp5c
//!   (Kierzenka & Shampine 2008), whose residual-based error estimate carries over.
//!
//! Why not the alternatives: 3-stage Gauss collocation also has order 6 at the mesh points,
//! but its collocation polynomial is a cubic, `O(h^4)` between mesh points and only C0 (its
//! derivative jumps at the nodes, where `f` is not evaluated), so the dense output that
//! callers use for mesh transfer and warm starts would be two orders worse. MIRK6 has
//! explicit stages (nothing to eliminate) but no natural continuous extension: a C1
//! interpolant of matching order needs extra stages (Muir & Enright). With condensation the
//! implicit stages of Lobatto IIIA cost only `O(n^3)` local work per interval.
//!
//! Measured on fixed uniform meshes (`tests/bvp_convergence_order.rs`): order 5.88 to 6.14 at
//! the mesh points and 4.76 to 5.22 for the dense output, on six problems.
//!
//! # Newton system and condensation
//!
//! The collocation equations of interval `i` are `2n` stage equations and `n` continuity
//! equations. The stage unknowns are Newton unknowns, but the linear algebra eliminates them
//! locally: each interval's `2n x 2n` stage block `K_i` is factored and the continuity
//! equations become a relation `A_i dy_i + B_i dy_{i+1} + P_i dp = -r_i` between neighbouring
//! node corrections (formulas in [`collocation`]). The remaining matrix is almost block
//! diagonal, bordered by the `k` parameter columns and the `n + k` boundary rows:
//!
//! ```text
//!            y_0   y_1   y_2   y_3    p
//!          +-----+-----+-----+-----+----+
//! Phi_0    | A_0 | B_0 |     |     | P_0|
//! Phi_1    |     | A_1 | B_1 |     | P_1|
//! Phi_2    |     |     | A_2 | B_2 | P_2|
//!          +-----+-----+-----+-----+----+
//! g        | Ga  |     |     | Gb  | Gp |
//!          +-----+-----+-----+-----+----+
//! ```
//!
//! It is factored one interval at a time after row equilibration ([`abd`]), by structured
//! elimination (partial pivoting inside each block; with separated boundary conditions,
//! partial pivoting over whole columns and no `y_0` border) with structured QR as the fallback when
//! the elimination's growth or a tiny pivot says it may be inaccurate: work and memory are
//! linear in the number of intervals, nothing is allocated in the Newton loop, and the growth
//! is reported in [`Stats::factor_growth`] ([`Stats::factorization`] says which reduction).
//! Newton is damped and affine invariant (Deuflhard's natural monotonicity test on the
//! simplified correction) and reuses Jacobians while the contraction is fast ([`newton`]).
//!
//! # Error estimate and mesh adaptation
//!
//! The residual `r = u' - f(x, u, p)` of the collocation polynomial vanishes at the four
//! collocation points; it is sampled at the three interior 5-point Lobatto points. By
//! default the per-interval estimate is `e_i = h_i * RMS(r / (atol s + tol |u|))`, an
//! estimate of the `O(h^5)` local error of the interpolant (Kierzenka & Shampine 2008);
//! `ErrorControl::Residual` gives scipy's relative-residual criterion instead. The mesh is
//! rebuilt by equidistribution: refinement where `e_i` is large, merging where it is far
//! below the tolerance, with a node cap ([`mesh`]). A converged solution on a mesh that
//! equidistribution would halve (typically a warm start from a harder problem or a tighter
//! tolerance) is re-solved on the coarser mesh ([`Options::coarsen`]). After convergence the returned solution
//! is verified again: error estimate, discrete equations and boundary residual must all
//! meet their tolerances or the status is not [`Status::Converged`].
//!
//! A BVP without a solution can still have a discrete "solution" that meets a residual test
//! (e.g. `y'' + y = 0`, `y(0) = 0`, `y(pi) = 1`: the discrete solution is a huge multiple of
//! `sin x`). Candidates are therefore also checked for conditioning: the response of the
//! discrete solution to a unit change of a boundary condition (with one step of iterative
//! refinement to detect singularity to working precision) and a Hager-Higham estimate of the
//! condition number of the Newton matrix equilibrated in its rows and columns (so that
//! neither the scaling of a boundary condition nor the units of an unknown count); see
//! [`Options::conditioning_limit`]. With finite-difference Jacobians these measures are less
//! reliable near singularity (the factored matrix is not the exact Jacobian).
//!
//! # References
//! * U. Ascher, R. Mattheij, R. Russell, *Numerical Solution of Boundary Value Problems for
//!   Ordinary Differential Equations*, SIAM 1995 (collocation, condensation, ABD systems).
//! * J. Kierzenka, L. F. Shampine, *A BVP solver based on residual control and the MATLAB
//!   PSE*, ACM TOMS 27 (2001); *A BVP solver that controls residual and error*, JNAIAM 3 (2008).
//! * P. Deuflhard, *Newton Methods for Nonlinear Problems*, Springer 2004.

pub mod abd;
pub mod collocation;
pub(crate) mod dense;
mod error;
pub mod linear;
pub mod mesh;
pub mod newton;
mod options;
mod problem;
mod solution;
#[cfg(test)]
mod tests;

pub use abd::Factorization;
pub use error::BvpError;
pub use linear::global_jacobian_pattern;
pub use options::{ErrorControl, JacobianSource, Options};
pub use problem::{estimate_bc_jac, estimate_fun_jac, BvpProblem};
pub use solution::{Guess, Progress, ProgressEvent, Solution, Stats, Status};

use collocation::{Collocation, Layout, Tableau};
use linear::GlobalSystem;
use mesh::{adapt_mesh, estimate_errors, halve_mesh, transfer_solution, ErrorEstimate};
use newton::{solve_newton, NewtonOutcome};
use problem::Evaluator;

/// A Jacobian with `cond_1 * eps` above this is numerically singular.
const NUMERICALLY_SINGULAR: f64 = 1e-3;

/// Coarsening passes after convergence (each at least halves the number of intervals).
const MAX_COARSENINGS: usize = 3;

/// Check the problem dimensions, the guess and the options.
fn validate_input<P: BvpProblem + ?Sized>(
    problem: &P,
    guess: &Guess,
    options: &Options,
) -> Result<(), BvpError> {
    let (n, k) = (problem.n(), problem.k());
    if n == 0 {
        return Err(BvpError::NoStates);
    }
    options.validate(n)?;
    let m = guess.x.len();
    if m < 2 {
        return Err(BvpError::MeshTooShort { found: m });
    }
    for (index, &v) in guess.x.iter().enumerate() {
        if !v.is_finite() {
            return Err(BvpError::NonFiniteInput {
                what: "mesh",
                index,
                value: v,
            });
        }
    }
    for (index, w) in guess.x.windows(2).enumerate() {
        if w[1] <= w[0] {
            return Err(BvpError::MeshNotIncreasing {
                index,
                left: w[0],
                right: w[1],
            });
        }
    }
    if guess.y.len() != m * n {
        return Err(BvpError::DimensionMismatch {
            what: "guess values (m * n)",
            expected: m * n,
            found: guess.y.len(),
        });
    }
    if guess.p.len() != k {
        return Err(BvpError::DimensionMismatch {
            what: "guess parameters (k)",
            expected: k,
            found: guess.p.len(),
        });
    }
    if let Some(s) = &guess.stages {
        let expected = (m - 1) * 2 * n;
        if s.len() != expected {
            return Err(BvpError::DimensionMismatch {
                what: "guess stage values",
                expected,
                found: s.len(),
            });
        }
    }
    let values = guess
        .y
        .iter()
        .chain(&guess.p)
        .chain(guess.stages.iter().flatten());
    for (index, &v) in values.enumerate() {
        if !v.is_finite() {
            return Err(BvpError::NonFiniteInput {
                what: "guess values",
                index,
                value: v,
            });
        }
    }
    Ok(())
}

/// The flat unknown vector of a guess (stages interpolated linearly when absent).
fn assemble_initial_unknowns(guess: &Guess, n: usize, k: usize) -> Vec<f64> {
    let lay = Layout {
        n,
        k,
        m: guess.x.len(),
    };
    let mut u = vec![0.0; lay.total()];
    u[..lay.m * n].copy_from_slice(&guess.y);
    u[lay.p_offset()..lay.p_offset() + k].copy_from_slice(&guess.p);
    let so = lay.stage_offset();
    match &guess.stages {
        Some(s) => u[so..].copy_from_slice(s),
        None => {
            let tab = Tableau::lobatto_iiia4();
            for i in 0..lay.intervals() {
                for s in 0..2 {
                    let c = tab.c[s + 1];
                    for j in 0..n {
                        u[so + (2 * i + s) * n + j] =
                            (1.0 - c) * guess.y[i * n + j] + c * guess.y[(i + 1) * n + j];
                    }
                }
            }
        }
    }
    u
}

/// Fill `stats.bc_condition` and `stats.condition_estimate` from the last factorisation and
/// return whether the problem counts as well posed at the requested tolerance (see
/// [`Options::conditioning_limit`]).
fn estimate_conditioning(
    sys: &mut GlobalSystem,
    col: &Collocation,
    options: &Options,
    stats: &mut Stats,
) -> bool {
    stats.bc_condition = sys.bc_sensitivity(col.lay.bc_offset(), col.lay.n + col.lay.k);
    stats.condition_estimate = sys.condition_estimate();
    stats.factor_growth = sys.growth();
    stats.factor_min_pivot = sys.min_pivot();
    stats.factorization = sys.method();
    stats.bc_condition * options.tol <= options.conditioning_limit
        && stats.condition_estimate * f64::EPSILON <= NUMERICALLY_SINGULAR
}

/// Package the iterate `u` on the mesh of `col` as a [`Solution`].
fn build_solution<P: BvpProblem + ?Sized>(
    ev: &Evaluator<P>,
    col: &mut Collocation,
    u: &[f64],
    est: ErrorEstimate,
    mut stats: Stats,
    status: Status,
) -> Solution {
    let lay = col.lay;
    let (n, k, m) = (lay.n, lay.k, lay.m);
    let mut res = vec![0.0; lay.total()];
    col.evaluate_residual(ev, u, &mut res);
    stats.max_error = est.max_error;
    stats.max_residual = est.max_residual;
    stats.bc_residual = est.bc_residual;
    stats.max_defect = est.max_defect;
    stats.max_raw_defect = est.max_raw_defect;
    stats.f_evaluations = ev.f_evals.get();
    stats.bc_evaluations = ev.bc_evals.get();
    Solution {
        status,
        x: col.x.clone(),
        y: u[..m * n].to_vec(),
        yp: col.fnodes.clone(),
        p: u[lay.p_offset()..lay.p_offset() + k].to_vec(),
        errors: est.errors,
        residuals: est.residuals,
        stats,
        n,
        k,
        stages: u[lay.stage_offset()..].to_vec(),
        stage_f: col.fstages.clone(),
        tab: col.tab.clone(),
    }
}

/// What to do after a mesh pass.
#[derive(Debug, Clone, PartialEq)]
enum NextStep {
    /// Stop with this status.
    Finish(Status),
    /// Solve again on this mesh (refinement, halving after a Newton failure, or the same mesh
    /// for one more try at the boundary tolerance).
    Resolve(Vec<f64>),
    /// The solution is converged; keep it and try this coarser mesh.
    Coarsen(Vec<f64>),
}

/// Counters of the outer loop that steer [`choose_next_step`].
#[derive(Debug, Default)]
struct LoopState {
    pass: usize,
    newton_failures: usize,
    bc_retry_done: bool,
    coarsenings: usize,
}

/// Decide, after a mesh pass with Newton outcome `outcome` and estimate `est` on mesh `x`,
/// whether to stop (and with which status), refine, halve or coarsen. `well_posed` is the
/// conditioning verdict (only computed for accurate candidates).
fn choose_next_step(
    x: &[f64],
    outcome: NewtonOutcome,
    est: &ErrorEstimate,
    well_posed: bool,
    options: &Options,
    state: &mut LoopState,
) -> NextStep {
    let order = match options.error_control {
        ErrorControl::Error => 5.0,
        ErrorControl::Residual => 4.0,
    };
    let newton_ok = outcome == NewtonOutcome::Converged;
    let accurate = newton_ok && est.max_error <= 1.0 && est.max_defect <= 1.0;
    let step = match outcome {
        NewtonOutcome::Singular => NextStep::Finish(Status::SingularJacobian),
        NewtonOutcome::NonFinite => NextStep::Finish(Status::NonFinite),
        _ if !est.finite => NextStep::Finish(Status::NonFinite),
        _ if accurate && !well_posed => NextStep::Finish(Status::SingularJacobian),
        _ if accurate && est.bc_residual <= options.bc_tol() => {
            let allowed =
                options.adapt_mesh && options.coarsen && state.coarsenings < MAX_COARSENINGS;
            match allowed.then(|| adapt_mesh(x, &est.errors, order, false)) {
                Some(nx) if 2 * (nx.len() - 1) < x.len() - 1 => {
                    state.coarsenings += 1;
                    NextStep::Coarsen(nx)
                }
                _ => NextStep::Finish(Status::Converged),
            }
        }
        _ if accurate && !state.bc_retry_done => {
            state.bc_retry_done = true;
            NextStep::Resolve(x.to_vec())
        }
        _ if accurate => NextStep::Finish(Status::BcTolNotMet),
        _ if !options.adapt_mesh => NextStep::Finish(if newton_ok {
            Status::ToleranceNotMet
        } else {
            Status::NoConvergence
        }),
        _ if newton_ok => {
            state.newton_failures = 0;
            NextStep::Resolve(adapt_mesh(x, &est.errors, order, true))
        }
        _ => {
            state.newton_failures += 1;
            if state.newton_failures > options.max_newton_failures {
                NextStep::Finish(Status::NoConvergence)
            } else {
                NextStep::Resolve(halve_mesh(x))
            }
        }
    };
    match step {
        NextStep::Coarsen(_) if state.pass + 1 >= options.max_mesh_passes => {
            // Out of passes: a converged solution stays converged.
            NextStep::Finish(Status::Converged)
        }
        NextStep::Resolve(_) if state.pass + 1 >= options.max_mesh_passes => {
            NextStep::Finish(Status::MaxMeshPasses)
        }
        NextStep::Resolve(nx) if nx.len() > options.max_nodes => NextStep::Finish(Status::MaxNodes),
        other => other,
    }
}

/// Solve the BVP from `guess` with `options`. Shorthand for [`solve_with_progress`] without
/// a progress hook.
pub fn solve<P: BvpProblem + ?Sized>(
    problem: &P,
    guess: &Guess,
    options: &Options,
) -> Result<Solution, BvpError> {
    solve_with_progress(problem, guess, options, &mut |_| {})
}

/// Solve the BVP from `guess` with `options`, calling `progress` after every accepted Newton
/// step and every mesh pass (e.g. to drive a progress bar or a log).
///
/// Returns `Err` only for invalid input; every algorithmic outcome is a [`Status`] in the
/// returned [`Solution`]. The guess is only read.
///
/// The outer loop: Newton on the current mesh ([`newton`]), error estimate and verification
/// ([`mesh`]), then `choose_next_step`: finish, refine (equidistribution), halve (after a
/// Newton failure) or, once converged, coarsen an over-resolved mesh.
pub fn solve_with_progress<P: BvpProblem + ?Sized>(
    problem: &P,
    guess: &Guess,
    options: &Options,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Solution, BvpError> {
    validate_input(problem, guess, options)?;
    let ev = Evaluator::new(problem, options.jacobian);
    let (n, k) = (ev.n, ev.k);
    let mut x = guess.x.clone();
    let mut u = assemble_initial_unknowns(guess, n, k);
    let mut stats = Stats::default();
    let mut state = LoopState::default();
    // The last converged solution, kept while a coarser mesh is tried.
    let mut fallback: Option<Solution> = None;
    loop {
        let mut col = Collocation::new(n, k, &x);
        let mut sys = GlobalSystem::new(n, k, x.len());
        stats.mesh_passes += 1;
        stats.mesh_history.push(x.len());
        let outcome = solve_newton(
            &ev, &mut col, &mut sys, &mut u, options, &mut stats, state.pass, progress,
        );
        let mut res = vec![0.0; col.lay.total()];
        let est = if col.evaluate_residual(&ev, &u, &mut res) {
            estimate_errors(&ev, &col, &u, &res, options)
        } else {
            ErrorEstimate::default() // finite = false
        };
        let newton_ok = outcome == NewtonOutcome::Converged;
        // Conditioning costs two blocked solves (all n + k boundary rows at once) and up to 10
        // single ones: only for candidates and final reports.
        let candidate = newton_ok && est.finite && est.max_error <= 1.0 && est.max_defect <= 1.0;
        let well_posed = candidate && estimate_conditioning(&mut sys, &col, options, &mut stats);
        let step = choose_next_step(
            &x,
            outcome,
            &est,
            well_posed || !candidate,
            options,
            &mut state,
        );
        progress(&Progress {
            pass: state.pass,
            nodes: x.len(),
            event: ProgressEvent::MeshPass {
                newton_converged: newton_ok,
                max_error: est.max_error,
                max_residual: est.max_residual,
                max_defect: est.max_defect,
                max_raw_defect: est.max_raw_defect,
                bc_residual: est.bc_residual,
                next_nodes: match &step {
                    NextStep::Resolve(nx) | NextStep::Coarsen(nx) => Some(nx.len()),
                    NextStep::Finish(_) => None,
                },
            },
        });
        let nx = match step {
            NextStep::Finish(status) => {
                if let (false, Some(sol)) = (status.is_success(), fallback.take()) {
                    // A coarser mesh failed: return the converged solution, with the total work.
                    return Ok(with_total_work(sol, &stats, &ev));
                }
                if !candidate {
                    estimate_conditioning(&mut sys, &col, options, &mut stats);
                }
                return Ok(build_solution(&ev, &mut col, &u, est, stats, status));
            }
            NextStep::Coarsen(nx) => {
                let sol = build_solution(&ev, &mut col, &u, est, stats.clone(), Status::Converged);
                fallback = Some(sol);
                nx
            }
            NextStep::Resolve(nx) => nx,
        };
        u = transfer_solution(&col, &u, &nx);
        x = nx;
        state.pass += 1;
    }
}

/// `sol` (converged earlier) with the work counters of the whole solve.
fn with_total_work<P: BvpProblem + ?Sized>(
    mut sol: Solution,
    stats: &Stats,
    ev: &Evaluator<P>,
) -> Solution {
    sol.stats = Stats {
        newton_iterations: stats.newton_iterations,
        jacobian_evaluations: stats.jacobian_evaluations,
        factorizations: stats.factorizations,
        mesh_passes: stats.mesh_passes,
        mesh_history: stats.mesh_history.clone(),
        rounding_limited: stats.rounding_limited,
        f_evaluations: ev.f_evals.get(),
        bc_evaluations: ev.bc_evals.get(),
        ..sol.stats
    };
    sol
}

/// One full Newton step on a fixed mesh, exposed for the benchmarks (`benches/bvp.rs`): not
/// part of the API. A step is what [`solve`] repeats: the residual, the Jacobians at all
/// nodes and stages, the condensation of every interval, the structured factorisation, and
/// the correction (reduction, global solve, expansion).
#[doc(hidden)]
pub struct NewtonStep<'a, P: BvpProblem + ?Sized> {
    ev: Evaluator<'a, P>,
    col: Collocation,
    sys: GlobalSystem,
    u: Vec<f64>,
    res: Vec<f64>,
    dx: Vec<f64>,
}

impl<'a, P: BvpProblem + ?Sized> NewtonStep<'a, P> {
    /// The step at `guess` (its mesh and values), or the input error.
    pub fn new(problem: &'a P, guess: &Guess, options: &Options) -> Result<Self, BvpError> {
        validate_input(problem, guess, options)?;
        let ev = Evaluator::new(problem, options.jacobian);
        let (n, k) = (ev.n, ev.k);
        let col = Collocation::new(n, k, &guess.x);
        let len = col.lay.total();
        Ok(Self {
            sys: GlobalSystem::new(n, k, guess.x.len()),
            u: assemble_initial_unknowns(guess, n, k),
            res: vec![0.0; len],
            dx: vec![0.0; len],
            col,
            ev,
        })
    }

    /// Number of intervals.
    pub fn intervals(&self) -> usize {
        self.col.lay.intervals()
    }

    /// Do the step (the iterate is not updated, so every call does the same work); returns
    /// the max-norm of the correction, or `None` if a factorisation failed.
    pub fn run(&mut self) -> Option<f64> {
        if !self.col.evaluate_residual(&self.ev, &self.u, &mut self.res) {
            return None;
        }
        self.col
            .evaluate_jacobian(&self.ev, &self.u, &self.res)
            .ok()?;
        self.col.assemble_global(&mut self.sys.values);
        self.sys.factor().ok()?;
        newton::compute_correction(&mut self.col, &mut self.sys, &self.res, &mut self.dx)
            .then(|| self.dx.iter().fold(0.0_f64, |a, v| a.max(v.abs())))
    }
}
