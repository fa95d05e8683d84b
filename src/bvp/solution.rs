//! What the solver returns: [`Solution`] (mesh, values, parameters, dense output, [`Stats`],
//! [`Status`]), what it accepts as a starting point ([`Guess`]) and what it reports while
//! running ([`Progress`]).

use super::abd::Factorization;
use super::collocation::{eval_collocation_polynomial, Tableau};

/// How a solve ended. Only [`Status::Converged`] is a success; use
/// [`Status::is_success`] rather than comparing variants.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Status {
    /// Newton converged, every interval meets the error tolerance, the discrete equations
    /// hold and `max |g| <= bc_tol` (all verified on the returned solution).
    Converged,
    /// Fixed mesh (`adapt_mesh = false`): the discrete system was solved but the error
    /// estimate exceeds the tolerance.
    ToleranceNotMet,
    /// Meeting the tolerance would need more than `max_nodes` nodes.
    MaxNodes,
    /// `max_mesh_passes` mesh passes did not reach the tolerance.
    MaxMeshPasses,
    /// The Newton matrix (a stage block or the global system) is singular, or so
    /// ill-conditioned that the solution is not determined to the tolerance
    /// (`stats.bc_condition * tol > conditioning_limit`, or
    /// `stats.condition_estimate * eps > 1e-3`).
    SingularJacobian,
    /// Damped Newton failed repeatedly (even after mesh halving).
    NoConvergence,
    /// The problem returned NaN or infinity.
    NonFinite,
    /// Everything converged except the boundary conditions: `max |g| > bc_tol`.
    BcTolNotMet,
}

impl Status {
    /// True only for [`Status::Converged`].
    pub fn is_success(self) -> bool {
        self == Status::Converged
    }

    /// What happened, in a few words and no Rust names (for one-line reports, e.g.
    /// `"Newton's method did not converge"`); [`Status::message`] adds what to try.
    pub fn describe(self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::ToleranceNotMet => "the error estimate exceeds the tolerance on the fixed mesh",
            Status::MaxNodes => "meeting the tolerance would need more mesh nodes than allowed",
            Status::MaxMeshPasses => "the mesh-pass limit was reached before the tolerance",
            Status::SingularJacobian => "the Newton matrix is singular or too ill-conditioned",
            Status::NoConvergence => {
                "Newton's method did not converge, even after refining the mesh"
            }
            Status::NonFinite => "the equations returned NaN or infinity",
            Status::BcTolNotMet => "the boundary conditions do not meet their tolerance",
        }
    }

    /// A human explanation with what to try next.
    pub fn message(self) -> &'static str {
        match self {
            Status::Converged => "The algorithm converged to the desired accuracy.",
            Status::ToleranceNotMet => {
                "The collocation equations were solved on the fixed mesh, but the error estimate \
                 exceeds the tolerance; refine the mesh or enable mesh adaptation."
            }
            Status::MaxNodes => {
                "The maximum number of mesh nodes would be exceeded; allow more nodes, loosen the \
                 tolerance, or provide a better initial guess/mesh."
            }
            Status::MaxMeshPasses => {
                "The maximum number of mesh passes was reached before the tolerance was met; \
                 allow more mesh passes or provide a better initial mesh."
            }
            Status::SingularJacobian => {
                "A singular Jacobian was encountered when solving the collocation system; the \
                 problem may be ill-posed (no or non-unique solution) or the guess degenerate."
            }
            Status::NoConvergence => {
                "Newton's method did not converge, even after refining the mesh; try a better \
                 initial guess or continuation from an easier problem."
            }
            Status::NonFinite => {
                "The problem returned NaN or infinity; check the domain of f and g along the \
                 iterates."
            }
            Status::BcTolNotMet => {
                "The solution meets the error tolerance but the boundary conditions do not \
                 meet their tolerance."
            }
        }
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}: {}", self, self.message())
    }
}

/// Counters and final measures of a solve.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Stats {
    /// Newton iterations over all meshes (simplified iterations included).
    pub newton_iterations: usize,
    /// Global Newton Jacobians evaluated (each needs `df/dy` at `3m - 2` points).
    pub jacobian_evaluations: usize,
    /// Numeric sparse LU factorisations of the global system.
    pub factorizations: usize,
    /// Evaluations of `f` (finite-difference evaluations included).
    pub f_evaluations: usize,
    /// Evaluations of `g` (finite-difference evaluations included).
    pub bc_evaluations: usize,
    /// Mesh passes (Newton solve + error estimate).
    pub mesh_passes: usize,
    /// Number of nodes of the mesh of every pass, in order. (If a coarsening attempt after
    /// convergence failed, the returned solution is from the pass before it.)
    pub mesh_history: Vec<usize>,
    /// Largest per-interval error estimate (normalised: `<= 1` meets the tolerance).
    pub max_error: f64,
    /// Largest per-interval RMS relative residual `|u' - f| / (1 + |f|)` (scipy's measure).
    pub max_residual: f64,
    /// `max |g(y(a), y(b), p)|` at the returned solution.
    pub bc_residual: f64,
    /// Largest scaled defect of the discrete equations (continuity and stage equations,
    /// accumulated over the horizon, in tolerance units; `<= 1` for a converged solution),
    /// after the allowance for the rounding of `f` (`bvp::mesh` module docs).
    pub max_defect: f64,
    /// [`Self::max_defect`] before that allowance. Above 1, the discrete equations hold to the
    /// rounding of `f` on some intervals, not to the tolerance: `f` there is a small difference
    /// of large terms, and the solution's accuracy rests on its error estimate and checks.
    pub max_raw_defect: f64,
    /// Sensitivity of the discrete solution to the boundary data on the last mesh:
    /// `max_r ||J^{-1} e_r||_inf` over boundary rows `r` (see `Options::conditioning_limit`).
    pub bc_condition: f64,
    /// Estimate of the 1-norm condition number of the condensed global Newton matrix on the
    /// last mesh, equilibrated in its rows and columns (Hager-Higham; the units of the
    /// unknowns do not count). Above `1e-3 / eps` the matrix counts as numerically singular.
    pub condition_estimate: f64,
    /// Growth of the structured factorisation of that matrix: the largest entry of its
    /// triangular factor (and, for elimination, of every intermediate carried row) relative to
    /// the 2-norm of its column of the row-equilibrated matrix. For the structured QR at most
    /// 1 up to rounding; for either LU (the default) the elimination's growth factor, at
    /// most `1e3` (beyond that the factorisation is redone by QR); reported as evidence of a
    /// stable solve. Which of the two: [`factorization`](Self::factorization).
    pub factor_growth: f64,
    /// Smallest pivot of that factorisation relative to its column of the row-equilibrated
    /// matrix (small when the matrix is near singular; in (0, 1] for QR, at least `1e-10` for
    /// LU, whose tinier pivots switch to QR).
    pub factor_min_pivot: f64,
    /// The reduction of that factorisation: separated LU (boundary conditions separated),
    /// structured LU, or structured QR when elimination grew too much or met a tiny pivot.
    pub factorization: Factorization,
    /// Newton solves (over all meshes) that stopped rounding-limited: a fresh correction
    /// below the tolerance that no longer contracts (`bvp::newton` module docs).
    pub rounding_limited: usize,
}

/// One report to the progress hook.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    /// Mesh pass (0-based).
    pub pass: usize,
    /// Nodes of the current mesh.
    pub nodes: usize,
    /// What happened.
    pub event: ProgressEvent,
}

/// Events reported through [`Progress`].
#[derive(Debug, Clone, PartialEq)]
pub enum ProgressEvent {
    /// An accepted Newton step.
    NewtonStep {
        /// Iteration on this mesh (0-based).
        iteration: usize,
        /// Scaled max-norm of the correction (1 = tolerance level).
        correction_norm: f64,
        /// Damping factor used.
        damping: f64,
        /// Whether the Jacobian was evaluated at this iterate (false: reused).
        fresh_jacobian: bool,
    },
    /// A mesh pass finished.
    MeshPass {
        /// Did Newton converge on this mesh?
        newton_converged: bool,
        /// Largest normalised error estimate.
        max_error: f64,
        /// Largest RMS relative residual.
        max_residual: f64,
        /// Largest scaled defect of the discrete equations after Newton (continuity and stage
        /// defects accumulated over the horizon, in tolerance units: `<= 1` passes), after
        /// the allowance for the rounding of `f`.
        max_defect: f64,
        /// The same before that allowance.
        max_raw_defect: f64,
        /// `max |g|` of the boundary conditions.
        bc_residual: f64,
        /// Nodes of the next mesh, if there is one.
        next_nodes: Option<usize>,
    },
}

impl std::fmt::Display for Progress {
    /// One log line, e.g. for `-v` output of a CLI.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "pass {} ({} nodes): ", self.pass, self.nodes)?;
        match &self.event {
            ProgressEvent::NewtonStep { iteration, correction_norm, damping, fresh_jacobian } => write!(
                f,
                "Newton {iteration}: |dx| = {correction_norm:.2e}, damping {damping:.3}, {} Jacobian",
                if *fresh_jacobian { "new" } else { "reused" }
            ),
            ProgressEvent::MeshPass {
                newton_converged,
                max_error,
                max_residual,
                max_defect,
                max_raw_defect,
                bc_residual,
                next_nodes,
            } => {
                write!(
                    f,
                    "Newton {}, max error {max_error:.2e}, max residual {max_residual:.2e}, \
                     discrete defect {max_defect:.2e}",
                    if *newton_converged { "converged" } else { "failed" }
                )?;
                if max_raw_defect > max_defect {
                    write!(f, " ({max_raw_defect:.2e} before the rounding of f)")?;
                }
                write!(f, ", boundary residual {bc_residual:.1e}")?;
                match next_nodes {
                    Some(m) => write!(f, ", next mesh {m} nodes"),
                    None => write!(f, ", done"),
                }
            }
        }
    }
}

/// A starting point: mesh, values at the nodes, parameters, and optionally the interior
/// stage values (a warm start from a [`Solution`] carries them, which makes it exact).
///
/// The solver only reads a guess; it never modifies the caller's data.
#[derive(Debug, Clone, PartialEq)]
pub struct Guess {
    pub(crate) x: Vec<f64>,
    pub(crate) y: Vec<f64>,
    pub(crate) p: Vec<f64>,
    pub(crate) stages: Option<Vec<f64>>,
}

impl Guess {
    /// Values `y` (row-major `m x n`: `y[i*n + j]` = component `j` at node `x[i]`) on the mesh
    /// `x`, with parameters `p`. Interior stages are interpolated linearly.
    pub fn from_values(x: Vec<f64>, y: Vec<f64>, p: Vec<f64>) -> Self {
        Self {
            x,
            y,
            p,
            stages: None,
        }
    }

    /// Sample `y0(x, out)` (writes `n` values) at the nodes of `x` and at the interior
    /// collocation points.
    pub fn from_fn(x: &[f64], n: usize, p: Vec<f64>, mut y0: impl FnMut(f64, &mut [f64])) -> Self {
        let m = x.len();
        let mut y = vec![0.0; m * n];
        for (i, &xi) in x.iter().enumerate() {
            y0(xi, &mut y[i * n..(i + 1) * n]);
        }
        let tab = Tableau::lobatto_iiia4();
        let mut stages = vec![0.0; m.saturating_sub(1) * 2 * n];
        for i in 0..m.saturating_sub(1) {
            let h = x[i + 1] - x[i];
            for s in 0..2 {
                let off = (2 * i + s) * n;
                y0(x[i] + tab.c[s + 1] * h, &mut stages[off..off + n]);
            }
        }
        Self {
            x: x.to_vec(),
            y,
            p,
            stages: Some(stages),
        }
    }

    /// A warm start from a previous solution: its mesh, node and stage values and
    /// parameters (an exact restart: Newton converges at once if nothing changed).
    pub fn from_solution(sol: &Solution) -> Self {
        Self {
            x: sol.x.clone(),
            y: sol.y.clone(),
            p: sol.p.clone(),
            stages: Some(sol.stages.clone()),
        }
    }

    /// A previous solution resampled on another mesh `x` through its dense output.
    pub fn from_solution_on_mesh(sol: &Solution, x: &[f64]) -> Self {
        let n = sol.n;
        let p = sol.p.clone();
        Self::from_fn(x, n, p, |t, out| sol.eval_into(t, out))
    }

    /// Replace the parameters (e.g. a continuation predictor).
    pub fn with_parameters(mut self, p: Vec<f64>) -> Self {
        self.p = p;
        self
    }

    /// Mesh.
    pub fn x(&self) -> &[f64] {
        &self.x
    }
    /// Node values, row-major `m x n`.
    pub fn y(&self) -> &[f64] {
        &self.y
    }
    /// Parameters.
    pub fn p(&self) -> &[f64] {
        &self.p
    }
}

impl From<&Solution> for Guess {
    fn from(sol: &Solution) -> Self {
        Guess::from_solution(sol)
    }
}

/// The result of a solve. Check [`status`](Self::status) (or [`is_success`](Self::is_success))
/// before trusting the values: a non-converged result still carries the last iterate.
///
/// Dense output: on each interval the collocation polynomial (quartic, C1 across nodes since
/// its derivative equals `f` at both ends) is evaluated by [`eval`](Self::eval) and
/// [`eval_derivative`](Self::eval_derivative); its uniform error is `O(h^5)`, at the nodes
/// `O(h^6)`.
#[derive(Debug, Clone)]
pub struct Solution {
    /// How the solve ended.
    pub status: Status,
    /// Mesh nodes (`m`).
    pub x: Vec<f64>,
    /// Values at the nodes, row-major `m x n`.
    pub y: Vec<f64>,
    /// `f(x_i, y_i, p)` at the nodes, row-major `m x n`.
    pub yp: Vec<f64>,
    /// Unknown parameters (`k`).
    pub p: Vec<f64>,
    /// Per-interval normalised error estimates (`N = m - 1`; `<= 1` meets the tolerance).
    pub errors: Vec<f64>,
    /// Per-interval RMS relative residuals (scipy's measure).
    pub residuals: Vec<f64>,
    /// Counters and final measures.
    pub stats: Stats,
    pub(crate) n: usize,
    pub(crate) k: usize,
    pub(crate) stages: Vec<f64>,
    pub(crate) stage_f: Vec<f64>,
    pub(crate) tab: Tableau,
}

impl std::fmt::Display for Solution {
    /// A termination report in the style of bvp4c's `Stats` output.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.stats;
        writeln!(f, "{}", self.status)?;
        writeln!(
            f,
            "Mesh of {} nodes after {} passes {:?}; max error estimate {:.2e} (tolerance = 1), \
             max RMS relative residual {:.2e}, max |bc| {:.2e}.",
            self.num_nodes(),
            s.mesh_passes,
            s.mesh_history,
            s.max_error,
            s.max_residual,
            s.bc_residual
        )?;
        write!(
            f,
            "{} Newton iterations, {} Jacobians, {} factorisations, {} calls of f, {} of g; \
             BC sensitivity {:.1e}, condition estimate {:.1e}.",
            s.newton_iterations,
            s.jacobian_evaluations,
            s.factorizations,
            s.f_evaluations,
            s.bc_evaluations,
            s.bc_condition,
            s.condition_estimate
        )
    }
}

impl Solution {
    /// Number of states `n`.
    pub fn n(&self) -> usize {
        self.n
    }
    /// Number of parameters `k`.
    pub fn k(&self) -> usize {
        self.k
    }
    /// Number of mesh nodes `m`.
    pub fn num_nodes(&self) -> usize {
        self.x.len()
    }
    /// True only if the status is [`Status::Converged`].
    pub fn is_success(&self) -> bool {
        self.status.is_success()
    }
    /// Human explanation of the status.
    pub fn message(&self) -> &'static str {
        self.status.message()
    }
    /// Values at node `i`.
    pub fn y_at(&self, i: usize) -> &[f64] {
        &self.y[i * self.n..(i + 1) * self.n]
    }

    /// The discrete solution at every collocation point, in time order: node `x_i`, the two
    /// interior stages of interval `i`, …, the last node (`3N + 1` points, row-major
    /// `(3N + 1) × n`). These are the values the collocation equations hold for, not
    /// interpolated ones.
    pub fn collocation_values(&self) -> Vec<f64> {
        let (n, nn) = (self.n, self.x.len() - 1);
        let mut out = Vec::with_capacity((3 * nn + 1) * n);
        for i in 0..nn {
            out.extend_from_slice(self.y_at(i));
            out.extend_from_slice(&self.stages[i * 2 * n..(i + 1) * 2 * n]);
        }
        out.extend_from_slice(self.y_at(nn));
        out
    }

    /// The collocation points in order — node `x_i`, the interior points `x_i + c_2 h_i`,
    /// `x_i + c_3 h_i` of interval `i`, …, the last node (`3N + 1` points) — with the solution's
    /// values and derivatives there (row-major `(3N + 1) × n` each): exactly the data of the
    /// dense output, since on `[x_i, x_{i+1}]` the solution is `y_i` plus the integral of the
    /// cubic that interpolates its four derivative samples.
    pub fn collocation_points(&self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let (n, nn) = (self.n, self.x.len() - 1);
        let mut x = Vec::with_capacity(3 * nn + 1);
        let mut dy = Vec::with_capacity((3 * nn + 1) * n);
        for i in 0..nn {
            let h = self.x[i + 1] - self.x[i];
            x.push(self.x[i]);
            x.push(self.x[i] + self.tab.c[1] * h);
            x.push(self.x[i] + self.tab.c[2] * h);
            dy.extend_from_slice(&self.yp[i * n..(i + 1) * n]);
            dy.extend_from_slice(&self.stage_f[2 * i * n..(2 * i + 2) * n]);
        }
        x.push(self.x[nn]);
        dy.extend_from_slice(&self.yp[nn * n..(nn + 1) * n]);
        (x, self.collocation_values(), dy)
    }

    /// Interval containing `x` and local coordinate `t` (outside `[a, b]` the end
    /// polynomials are extrapolated).
    fn locate(&self, x: f64) -> (usize, f64) {
        let m = self.x.len();
        let i = self
            .x
            .partition_point(|&v| v <= x)
            .saturating_sub(1)
            .min(m - 2);
        let h = self.x[i + 1] - self.x[i];
        (i, (x - self.x[i]) / h)
    }

    fn eval_parts(&self, x: f64, y_out: &mut [f64], dy_out: &mut [f64]) {
        let n = self.n;
        let (i, t) = self.locate(x);
        let h = self.x[i + 1] - self.x[i];
        eval_collocation_polynomial(
            &self.tab,
            n,
            h,
            &self.y[i * n..(i + 1) * n],
            &self.yp[i * n..(i + 1) * n],
            &self.stage_f[2 * i * n..(2 * i + 2) * n],
            &self.yp[(i + 1) * n..(i + 2) * n],
            t,
            y_out,
            dy_out,
        );
    }

    /// `y(x)` from the dense output, written into `out` (length `n`).
    pub fn eval_into(&self, x: f64, out: &mut [f64]) {
        self.eval_parts(x, out, &mut []);
    }
    /// `y(x)` from the dense output.
    pub fn eval(&self, x: f64) -> Vec<f64> {
        let mut out = vec![0.0; self.n];
        self.eval_into(x, &mut out);
        out
    }
    /// `y'(x)` from the dense output, written into `out` (length `n`).
    pub fn eval_derivative_into(&self, x: f64, out: &mut [f64]) {
        self.eval_parts(x, &mut [], out);
    }
    /// `y'(x)` from the dense output.
    pub fn eval_derivative(&self, x: f64) -> Vec<f64> {
        let mut out = vec![0.0; self.n];
        self.eval_derivative_into(x, &mut out);
        out
    }
}
