//! Solving a [`Problem`] of any model: the analytic singular start (paper section 5.1,
//! generalised) and the staged homotopy (section 5.2), with the stages read from the model's
//! [`HomotopyRole`]s instead of named weights.
//!
//! 1. **Start.** An admissible `Ω_p` on `[a, b_p]` (Properties 1–3: it joins `Ω_a` to `Ω_b`,
//!    lies on the energy level set, and `ξ̃ = 𝕀Ω̇_p − ad*_{Ω_p} 𝕀Ω_p` never vanishes) gives
//!    `y = [Ω_p, ξ_p, ξ̇_p, κ = 0]` by the generated `singular_control`; the BVP is solved with
//!    the `Beta` weight at `β_m`, `Smoothing` and `Time` weights at 0, fixed `T = b_p − a`.
//!    The choice of `Ω_p` and of the `Tracking` weights' start value follows the paper's three
//!    cases (section 5.2; the so(3) layer's own copy of this homotopy, which it replaced,
//!    made the same choices, and every so(3) example gave the same `b` and `J` in both):
//!    - tracking weight `> 0` and the projected desired path admissible: `Ω_p` = the desired
//!      path projected radially onto the level set; the tracking weight starts at its target
//!      (case 3) when the desired path itself lies on the level set (within
//!      [`ADMISSIBLE_ENERGY_TOL`]), else at 0 (case 2);
//!    - tracking weight `> 0`, projected desired path not admissible: `Ω_p` = the projected
//!      segment `Ω_a → Ω_b`, tracking from 0 (case 2);
//!    - tracking weight 0: `Ω_p` = the projected segment, tracked with weight 1, continued to
//!      0 (case 1).
//! 2. **Tracking stage** (cases 1, 2), 3. **β stage** (`β_m → β`, geometric), 4. **smoothing
//!    stage** (`0 → η`), 5. **constraint stage** (models with a constraint value, below),
//!    6. **time stage** (free terminal time: `T` becomes unknown; the `Time` weight goes from
//!    `δ_c`, the generated `delta_start`, to its target), 7. **polish** at the requested
//!    tolerance; 8. **refine**, only when the polished solution fails its a-posteriori checks
//!    ([`super::verify`]) although the solver's error estimate met the tolerance (a mesh too
//!    coarse for a long horizon): solves at [`REFINE_FACTORS`] times the tolerance, the first
//!    that passes the checks (at the requested tolerance) kept.
//!
//! **A nonzero constraint value** (`⟨Ω, ξ⟩ = γ` constant, e.g. the inhomogeneous Suslov
//! problem): the analytic start needs the energy level set, which only `γ = 0` keeps, and the
//! start constraint `φ(a) = 0` of [`super::problem`] is singular at `γ = 0`. So stages 1–4
//! solve the problem with every `Constraint` parameter at 0, `Ω_b` replaced by its radial
//! projection `Ω_b⁰` onto the level set of `Ω_a`, and the paper's boundary conditions. Then
//! (`Homotopy::constraint_stages`), using that a constant `γ` enters the optimality system only
//! through the start constraint:
//! - **A.** the end state moves off the level set (paper's conditions) to `Ω_b` (or, when
//!   `Ω_b` is on it, to `1.1 Ω_b⁰`): the motion's constraint level `k ≠ 0` follows from
//!   `T(b) − T(a) = k ∫λ dt`. If `k` has the other sign than `γ`, the motion is mirrored,
//!   `(ξ, ξ̇) → −(ξ, ξ̇)` (same `Ω`, level `−k`: λ is odd in ξ and λξ even), and re-solved,
//!   which checks that the model's cost is even in ξ (else the route is reported as missing);
//! - **B.** the start constraint is switched on at the target constants with its level shifted
//!   to `k` (`μ = 0` solves it exactly there) and the level is continued from `k` to `γ`,
//!   never through 0;
//! - **C.** the end state is continued to `Ω_b` at the level `γ` (regular there).
//!
//! A `γ` that depends on `ξ` is refused (it would change Suslov's equations).
//!
//! **Routes.** The order above, from the start the paper's cases choose, is the default
//! [`Route`]. When it stops, [`solve`] does not give up: it tries other routes, chosen by where
//! the default stopped ([`alternatives`]): after a failed start, the other analytic starts
//! (with tracking, the full tracking weight from the start even when the desired path leaves
//! the level set, or misses `Ω_b` at a fixed `b`: then it is bent to the end points,
//! [`BENT_DESIRED`]), a finer initial mesh, `β_m = β` ([`BETA_M_AT_BETA`]), a smaller and a
//! larger `β_m`; after a stalled
//! weight stage, where ξ collapsed the weights of role `Fixed` from 100 times their targets
//! down to them last ([`FIXED_FROM_ABOVE`]), all weights continued jointly along one
//! parameter, β before tracking, the starts not taken, a finer mesh.
//! Each starts from the beginning, at most [`SolveOptions::max_routes`] in all; every route
//! tried is listed with why it stopped ([`LieSolution::routes`], the summary's `routes`).
//! When they all stop on a fixed-`b` problem (with `max_routes > 1` and the start left to the
//! solver, [`StartStrategy::Auto`]), one more route does not
//! continue at all: the **direct start** ([`DIRECT_START_ROUTE`], [`super::direct`]) minimizes
//! the transcribed control problem by SQP from the projected segment's inverse dynamics and
//! solves the BVP once from that minimum, reaching regular minima that no branch from the
//! analytic start leads to.

use std::sync::Arc;

use crate::bvp::{self, Guess, Solution};
use crate::continuation::{self, ContinuationStatus, StepRecord};
use crate::echo::{Cost, Num};
use crate::model::{HomotopyRole, Model};

use super::direct::{DirectForm, DirectGuess, DirectStart};
use super::path::{projected_segment, EndBlend, Memo, Path, Projected};
use super::problem::{with_buffer, LieBvp, Problem, ProblemError, TerminalTime, SPAN};

/// Cap on the pseudo-arclength steps of a stage whose natural continuation stalled. Corpus
/// problem issue12-124 (γ = 0, `tests/routes.rs`) needs more than 80: its branch passes two
/// folds within 3.5e-5 of the end of the stage.
const ARCLENGTH_MAX_STEPS: usize = 300;

/// Smallest pseudo-arclength step: the folds of issue12-124 are 2e-4 apart in the stage's
/// parameter, which steps of at least 1e-5 did not resolve (measured: no fold found).
const ARCLENGTH_MIN_STEP: f64 = 1e-8;

/// `Ω_d` counts as admissible (paper's third case) when its relative energy deviation from
/// `E` stays below this and Properties 1 and 3 hold.
pub const ADMISSIBLE_ENERGY_TOL: f64 = 1e-4;

/// How the analytic start is chosen (paper section 5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StartStrategy {
    /// Decide from `γ` and the admissibility of `Ω_d` (the module docs).
    #[default]
    Auto,
    /// `Ω_p = [Ω_d]_∥` and the full `γ` from the start (the paper's third case); needs `γ > 0`.
    Desired,
    /// `Ω_p = [Ω_d]_∥`, then `γ` from 0 to `γ` (the paper's second case); needs `γ > 0`.
    DesiredGammaFromZero,
    /// `Ω_p` = the projected segment `Ω_a → Ω_b`: `γ` from 0 to `γ` if `γ > 0` (second
    /// case), from 1 to 0 tracking `Ω_p` if `γ = 0` (first case).
    Segment,
}

/// Options of [`solve`].
#[derive(Debug, Clone)]
pub struct SolveOptions {
    /// Final BVP tolerance (paper: 1e-8).
    pub tol: f64,
    /// BVP tolerance during continuation. The path only has to be followed, not resolved:
    /// the final polish solve sets the accuracy. (Paper cases: 1e-4 instead of 1e-6 gives the
    /// same b to 7 digits in about half the time.)
    pub continuation_tol: f64,
    /// `β_m`; default `1e-2 · min(α, β, γ or 1)`.
    pub beta_m: Option<f64>,
    /// Intervals of the initial uniform mesh.
    pub initial_intervals: usize,
    /// Node cap of every BVP solve.
    pub max_nodes: usize,
    /// Override of the start case (default: [`StartStrategy::Auto`]).
    pub start: StartStrategy,
    /// How many routes [`solve`] may try, the default route included (1: only the default;
    /// see [`alternatives`]).
    pub max_routes: usize,
    /// A previous solution to start from ([`solve_from`]); [`solve`] then tries it first.
    pub warm_start: Option<Arc<WarmStart>>,
    /// Stops the solve when set ([`StopFlag::stop`], e.g. from the event callback or
    /// another thread): checked before every continuation step and every route; the solve
    /// then returns [`LieSolveError::StageFailed`] at the last converged point, its reason
    /// saying it was stopped, without trying other routes.
    pub stop: Option<StopFlag>,
}

/// A flag that stops a running [`solve`] ([`SolveOptions::stop`]); clones share it.
///
/// ```
/// use suslov::lie::solve::{Event, StopFlag};
/// use suslov::{paper, solve, SolveError, SolveOptions};
///
/// let stop = StopFlag::new();
/// let options = SolveOptions { stop: Some(stop.clone()), ..Default::default() };
/// // Stop as soon as the first stage starts (a real caller might stop on a timer or a button).
/// let result = solve(&paper::problem(0.01), &options, &mut |e| {
///     if matches!(e, Event::StageStarted { .. }) {
///         stop.stop();
///     }
/// });
/// match result {
///     Err(SolveError::StageFailed { reason, .. }) => assert!(reason.contains("stopped by the caller")),
///     other => panic!("{other:?}"),
/// }
/// ```
#[derive(Debug, Clone, Default)]
pub struct StopFlag(Arc<std::sync::atomic::AtomicBool>);

impl StopFlag {
    /// A flag not yet set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Ask the solve to stop.
    pub fn stop(&self) {
        self.0.store(true, std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether [`StopFlag::stop`] was called.
    pub fn is_stopped(&self) -> bool {
        self.0.load(std::sync::atomic::Ordering::Relaxed)
    }
}

impl SolveOptions {
    /// Whether the caller asked the solve to stop ([`SolveOptions::stop`]).
    fn stopped(&self) -> bool {
        self.stop.as_ref().is_some_and(StopFlag::is_stopped)
    }
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self {
            tol: 1e-8,
            continuation_tol: 1e-4,
            beta_m: None,
            initial_intervals: 100,
            max_nodes: 20_000,
            start: StartStrategy::Auto,
            max_routes: 7,
            warm_start: None,
            stop: None,
        }
    }
}

/// Why a BVP solve of the homotopy failed, in words, with what a problem file can change
/// (the `solver.*` keys are [`SolveOptions`]' fields).
pub fn bvp_failure(status: crate::bvp::Status) -> String {
    use crate::bvp::Status;
    let what = status.describe();
    match status {
        Status::MaxNodes => format!(
            "{what}; raise `solver.max_nodes` (at most 50 000) or loosen `solver.tolerance`"
        ),
        Status::MaxMeshPasses | Status::ToleranceNotMet => {
            format!("{what}; loosen `solver.tolerance` or raise `solver.initial_intervals`")
        }
        Status::SingularJacobian => {
            format!("{what}: the problem may have no solution or no unique one near this point")
        }
        Status::NoConvergence => format!(
            "{what}; a finer first mesh (`solver.initial_intervals`) or another start \
             (`solver.start`, `solver.beta_m`) may help"
        ),
        _ => what.to_string(),
    }
}

/// Which path the analytic start used, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct StartChoice {
    /// "projected desired path" or "projected segment".
    pub omega_p: &'static str,
    /// Paper case: 1 (`γ = 0`), 2 (`Ω_d` not admissible), 3 (`Ω_d` admissible).
    pub case: u8,
    /// `b_p`.
    pub b_p: f64,
    /// `β_m`.
    pub beta_m: f64,
    /// Max relative energy deviation of `Ω_d` from `E` on `[a, b_p]`.
    pub desired_energy_deviation: f64,
}

/// The name of the route whose weights of role `Fixed` (α of so(3)) start
/// [`FIXED_FROM_ABOVE_FACTOR`] times larger and are continued down to their targets last.
///
/// For a stop where ξ collapses: a large α holds |ξ| near 1, where the collapse cannot happen,
/// so the weight stages follow a different branch; the last stage then lowers α to its target,
/// reaching the target's solution if one exists on that branch, else stopping with the
/// collapse seen from the other side (stronger evidence than one stall).
pub const FIXED_FROM_ABOVE: &str = "fixed weights from above";

/// The name of the route whose start uses `β_m = β` (the target), from the desired path when
/// the tracking weight is positive: no β stage. Corpus problems spiral-028 and spiral-089
/// (a spiral at a fixed `b`, `β` = 1.4e-3 and 5.5e-3): every start fails at `β_m` = β/1000,
/// β/100 and β/10 from either path, and the desired start solves at `β_m = β`.
pub const BETA_M_AT_BETA: &str = "start at the target beta";

/// The name of the route that starts at a shorter horizon when the start fails
/// ([`HORIZON_FACTORS`], the first that gets through): the analytic start and the weight
/// stages at that fraction of `b − a`, then, for a fixed `b`, `b − a` continued geometrically
/// to the problem's with the target weights (for a free `b`, the same fraction of the guess
/// `b_p − a`: the free-time homotopy finds `b`). Issue #12's hard cases on the paper's data,
/// its desired path held for 90 time units after the spiral (measured):
/// - `paper_T100_fixed.toml` (`b = 100`): every start at `b = 100` fails, its Newton matrix
///   singular; at `b = 25` the default route solves it, and the continuation reaches
///   `b = 100`, cost 33.0217089666 (the same from `b = 50`; from `b = 12.5` it stops at
///   93.8, out of steps);
/// - `paper_T100_free.toml` (guess 100): the free-time start stops at guess 25; at 12.5 it
///   ends at the paper's own solution, `b = 11.3596162034`, `J = 15.39476077134`.
pub const SHORTER_HORIZON: &str = "shorter horizon";

/// The fractions of `b − a` (or of the guess's) from which [`SHORTER_HORIZON`] starts, in
/// turn.
pub const HORIZON_FACTORS: [f64; 2] = [0.25, 0.125];

/// How many times its target a weight of role `Fixed` starts at on [`FIXED_FROM_ABOVE`].
pub const FIXED_FROM_ABOVE_FACTOR: f64 = 100.0;

/// The order of the weight stages after the analytic start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageOrder {
    /// Tracking, then β, then smoothing (the paper's order).
    Sequential,
    /// β first, then tracking, then smoothing: the control effort reaches its target before
    /// the tracking weight leaves the start's value (when the small `β_m` without tracking is
    /// what stalls).
    BetaFirst,
    /// Every weight at once, along one homotopy parameter (tracking and smoothing linearly,
    /// β geometrically): a different path through the space of weights.
    Joint,
}

/// A route through the homotopy: the analytic start, the order of the weight stages, `β_m`
/// and the initial mesh. [`solve`] tries [`Route::DEFAULT`] first and, when it stops, other
/// routes chosen by where it stopped (module docs); every route tried is reported
/// ([`LieSolution::routes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Route {
    /// Name, e.g. "default" or "joint weights".
    pub name: &'static str,
    /// The start (`None`: the options' [`SolveOptions::start`]).
    pub start: Option<StartStrategy>,
    /// The order of the weight stages.
    pub order: StageOrder,
    /// `β_m` is the default (or the options') times this.
    pub beta_m_factor: f64,
    /// The initial mesh has this many times the options' intervals.
    pub mesh_factor: usize,
    /// The weights with the role `Fixed` (α of so(3): the penalty on |ξ| ≠ 1) start at this
    /// many times their targets and are continued down to them (geometrically) after the
    /// smoothing stage ([`FIXED_FROM_ABOVE`]).
    pub fixed_factor: f64,
    /// `β_m` is the target β itself: the start solves the problem at its own β, and there is
    /// no β stage ([`BETA_M_AT_BETA`]).
    pub beta_m_at_beta: bool,
    /// The route solves the problem with `b − a` (fixed) or its guess (free) this many times
    /// the problem's first (and, if that stops, at the smaller [`HORIZON_FACTORS`]); a fixed
    /// `b − a` is then continued to the problem's ([`SHORTER_HORIZON`]). 1: the problem's own.
    pub horizon_factor: f64,
}

impl Route {
    /// The paper's route: the options' start, sequential stages.
    pub const DEFAULT: Self = Self {
        name: "default",
        start: None,
        order: StageOrder::Sequential,
        beta_m_factor: 1.0,
        mesh_factor: 1,
        fixed_factor: 1.0,
        beta_m_at_beta: false,
        horizon_factor: 1.0,
    };
}

/// How one route ended.
#[derive(Debug, Clone, PartialEq)]
pub struct RouteReport {
    /// The route's name.
    pub route: &'static str,
    /// `None` if it solved the problem, else why it stopped (the error's message).
    pub stopped: Option<String>,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// How a stage of the homotopy ended.
#[derive(Debug, Clone, PartialEq)]
pub enum StageOutcome {
    /// The stage reached its target (for a single solve: the BVP solver converged).
    Completed,
    /// The stage stopped before its target; [`solve`] returns [`LieSolveError::StageFailed`]
    /// (or [`LieSolveError::Start`] for the start) with the same reason.
    Stopped {
        /// Why (the continuation's or the BVP solver's status).
        reason: String,
    },
}

impl StageOutcome {
    /// Whether the stage reached its target.
    pub fn is_completed(&self) -> bool {
        matches!(self, Self::Completed)
    }
}

impl std::fmt::Display for StageOutcome {
    /// `completed`, or `stopped: <reason>`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Completed => f.write_str("completed"),
            Self::Stopped { reason } => write!(f, "stopped: {reason}"),
        }
    }
}

/// One stage of the homotopy.
#[derive(Debug, Clone, PartialEq)]
pub struct StageReport {
    /// "start", "gamma", "beta", "eta", "delta", "polish", "refine", or a stage of the
    /// constraint value (module docs).
    pub name: &'static str,
    /// The continued parameter (a weight's name, or what the stage moves), "-" for single
    /// solves.
    pub parameter: &'static str,
    /// Start value of the continued parameter.
    pub from: f64,
    /// Target value.
    pub to: f64,
    /// Accepted continuation steps.
    pub steps: usize,
    /// Rejected attempts that were recovered from.
    pub failures_recovered: usize,
    /// Newton iterations of the stage.
    pub newton_iterations: usize,
    /// Mesh nodes at the end of the stage.
    pub nodes: usize,
    /// Wall time of the stage, seconds.
    pub seconds: f64,
    /// Whether the stage reached its target.
    pub outcome: StageOutcome,
    /// The continued parameter's values at the folds (turning points) that pseudo-arclength
    /// continuation passed after natural continuation stalled (empty if it did not stall, or
    /// found none). A solution reached past a fold may be a saddle: the certificate decides.
    pub folds: Vec<f64>,
}

/// Events reported while solving.
#[derive(Debug, Clone)]
pub enum Event<'a> {
    /// A stage starts.
    StageStarted {
        /// Stage name.
        name: &'static str,
        /// From.
        from: f64,
        /// To.
        to: f64,
    },
    /// A continuation step was attempted (its parameter is the stage's homotopy variable).
    Step {
        /// Stage name.
        stage: &'static str,
        /// The attempt.
        record: &'a StepRecord,
    },
    /// A stage ended: completed, or stopped (see [`StageReport::outcome`]).
    StageFinished(&'a StageReport),
    /// The previous route stopped; another one starts from the beginning.
    RouteStarted {
        /// The route's name.
        route: &'static str,
        /// Why the previous route stopped.
        after: &'a str,
    },
    /// A Newton step or mesh pass inside a BVP solve of a stage (at parameter `lambda` of
    /// the stage's homotopy, 0 for single solves).
    Bvp {
        /// Stage name.
        stage: &'static str,
        /// Homotopy parameter of the solve.
        lambda: f64,
        /// The solver's report.
        progress: &'a bvp::Progress,
    },
}

/// A solved problem of model `M`.
#[derive(Clone)]
pub struct LieSolution<M: Model> {
    /// The problem, with the weights reached and the terminal time found (free `b`).
    pub problem: Problem<M>,
    /// The BVP solution on `s ∈ [0, 1]`.
    pub bvp: Solution,
    /// `T = b − a`.
    pub t_span: f64,
    /// The analytic start.
    pub start: StartChoice,
    /// The homotopy stages, in order.
    pub stages: Vec<StageReport>,
    /// The requested final tolerance, which the verification judges against.
    pub tolerance: f64,
    /// The routes tried, in order (the last is this solution's, unless it is a partial
    /// result).
    pub routes: Vec<RouteReport>,
    /// The value function `J*(T)` of fixed-time solves, when the time stage of a free-time
    /// problem stopped and every sample failed to lead to a free-time solution (the evidence;
    /// empty otherwise).
    pub time_scan: Vec<TimeSample>,
    /// When the homotopy stopped: what admissible controls with a vanishing `ξ` cost at the
    /// target weights ([`super::collapse::for_stop`]; `None` on a solution, or when not
    /// computed).
    pub collapse: Option<super::collapse::CollapseEvidence>,
    /// The solver's own verification of this solution, kept for [`super::verify_solution`]
    /// (which recomputes it if anything it reads has changed since).
    pub(crate) checked: Option<Arc<super::verify::KeptVerification>>,
}

impl<M: Model> std::fmt::Debug for LieSolution<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LieSolution")
            .field("problem", &self.problem)
            .field("t_span", &self.t_span)
            .field("start", &self.start)
            .field("stages", &self.stages)
            .field("tolerance", &self.tolerance)
            .field("routes", &self.routes)
            .field("time_scan", &self.time_scan)
            .finish_non_exhaustive()
    }
}

impl<M: Model> LieSolution<M> {
    /// `b`.
    pub fn terminal_time(&self) -> f64 {
        self.problem.t0 + self.t_span
    }

    /// `y(t) = [Ω, ξ, ξ̇, κ]` at physical time `t ∈ [a, b]` (`M::N_STATE` entries).
    pub fn state_into(&self, t: f64, y: &mut [f64]) {
        self.bvp.eval_into((t - self.problem.t0) / self.t_span, y);
    }

    /// The multiplier `μ` of the start constraint `φ(a) = 0` (models with a constraint value;
    /// [`super::problem`]), or `None`.
    pub fn start_multiplier(&self) -> Option<f64> {
        LieBvp::new(&self.problem).mu_index().map(|i| self.bvp.p[i])
    }

    /// `y(t)` as a vector.
    pub fn state(&self, t: f64) -> Vec<f64> {
        let mut y = vec![0.0; M::N_STATE];
        self.state_into(t, &mut y);
        y
    }

    /// The states at every time of `times` (each in `[a, b]`), row-major: `M::N_STATE` values
    /// per time in the model's layout (`M::STATE_NAMES`).
    pub fn states_at(&self, times: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; times.len() * M::N_STATE];
        for (t, y) in times.iter().zip(out.chunks_exact_mut(M::N_STATE)) {
            self.state_into(*t, y);
        }
        out
    }

    /// The cost `J = ∫ C dt` at the problem's constants (5-point Gauss–Legendre on every mesh
    /// interval; the value `summary.json` reports).
    pub fn cost(&self) -> f64 {
        self.cost_with(self.problem.params())
    }

    /// The cost of this solution's motion and control at other constants `params` (layout
    /// `M::PARAM_NAMES`, e.g. the target weights of a problem whose homotopy stopped here).
    pub fn cost_with(&self, params: &[f64]) -> f64 {
        let bvp = super::problem::LieBvp::new(&self.problem);
        let mut y = vec![0.0; M::N_STATE];
        let mut wd = vec![0.0; M::N_DESIRED];
        let mut total = 0.0;
        for w in self.bvp.x.windows(2) {
            let h = w[1] - w[0];
            for (node, weight) in super::checks::GAUSS5 {
                let s = w[0] + node * h;
                self.bvp.eval_into(s, &mut y);
                bvp.desired_at(self.problem.t0 + s * self.t_span, &mut wd);
                total += weight * h * self.t_span * M::cost_integrand(&y, params, &wd);
            }
        }
        total
    }

    /// The a-posteriori checks of this solution ([`super::verify_solution`]): its
    /// diagnostics, the windowed re-integration and the verdict (`.verification.passed()`:
    /// what "converged" means).
    pub fn verify(&self) -> super::verify::Verified {
        super::verify::verify_solution(self)
    }
}

/// Why [`solve`] failed.
#[derive(thiserror::Error)]
pub enum LieSolveError<M: Model> {
    /// The problem is invalid.
    #[error("invalid problem: {0}")]
    Invalid(#[from] ProblemError),
    /// The model's weights do not have the roles the homotopy needs.
    #[error("model {model}: {what}")]
    Roles {
        /// The model.
        model: &'static str,
        /// What is missing.
        what: String,
    },
    /// No admissible analytic start could be built, on any route tried.
    #[error("cannot build the analytic start: {reason}")]
    Start {
        /// Why, with every route tried.
        reason: String,
        /// For a fixed terminal time, the direct method's minimum as evidence
        /// ([`super::collapse`]): the controls with a vanishing `ξ` compared with it, among
        /// them the relaxed minimum's, the problem's ε-optimal control where the minimizing
        /// controls collapse. `None` where the direct method did not run.
        collapse: Option<Box<super::collapse::CollapseEvidence>>,
    },
    /// A stage did not reach its target; `partial` holds the last converged point.
    #[error(
        "stage '{stage}' stopped{}: {reason}",
        where_stopped(parameter, *reached, *target)
    )]
    StageFailed {
        /// Stage name.
        stage: &'static str,
        /// Continued parameter name.
        parameter: &'static str,
        /// Last converged value.
        reached: f64,
        /// Target value.
        target: f64,
        /// Why.
        reason: String,
        /// The last converged solution.
        partial: Box<LieSolution<M>>,
    },
    /// The continuation to a nonzero constraint value found no route (says why).
    #[error("no continuation route to the constraint value: {0}")]
    ConstraintRoute(String),
    /// The problem has a feature the homotopy does not handle (says which).
    #[error("not supported: {0}")]
    Unsupported(String),
    /// Invalid input reached the BVP solver (a bug in this layer).
    #[error("BVP solver rejected its input: {0}")]
    Bvp(#[from] bvp::BvpError),
}

/// Where a stage stopped, for its message: " at β = 0.2985 (target 3.75)", or nothing for a
/// stage that continues no parameter (the polish, the refine).
#[doc(hidden)]
pub fn where_stopped(parameter: &str, reached: f64, target: f64) -> String {
    if parameter == "-" || !reached.is_finite() {
        String::new()
    } else {
        format!(
            " at {parameter} = {} (target {})",
            Num(reached),
            Num(target)
        )
    }
}

impl<M: Model> LieSolveError<M> {
    /// A failed start without evidence.
    pub fn start(reason: impl Into<String>) -> Self {
        Self::Start {
            reason: reason.into(),
            collapse: None,
        }
    }
}

impl<M: Model> std::fmt::Debug for LieSolveError<M> {
    /// The message (a partial solution is summarised by its [`LieSolution`] `Debug`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::StageFailed { partial, .. } => write!(f, "{self} (partial: {partial:?})"),
            _ => write!(f, "{self}"),
        }
    }
}

/// The index in `p` of the one weight with `role`, if the model has exactly one.
fn one_with_role<M: Model>(role: HomotopyRole) -> Result<Option<usize>, LieSolveError<M>> {
    let mut it = M::WEIGHTS.iter().filter(|w| w.role == role);
    match (it.next(), it.next()) {
        (None, _) => Ok(None),
        (Some(w), None) => Ok(Some(w.index)),
        (Some(_), Some(_)) => Err(LieSolveError::Roles {
            model: M::NAME,
            what: format!("more than one weight has the homotopy role {role:?}"),
        }),
    }
}

/// Samples of the start path's Properties 1–3 on `[a, b_p]`.
struct PropertyReport {
    start_error: f64,
    end_error: f64,
    max_rel_energy_deviation: f64,
    min_euler_defect: f64,
    t_min_euler_defect: f64,
    finite: bool,
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn check_properties<M: Model>(
    problem: &Problem<M>,
    path: &dyn Path,
    (a, b): (f64, f64),
    samples: usize,
) -> PropertyReport {
    let n = M::DIM;
    let set = problem.level_set();
    let p = problem.params();
    let mut jet = vec![0.0; 4 * n];
    let mut xi = vec![0.0; 4 * n];
    let mut lambda = [0.0; 3];
    let mut r = PropertyReport {
        start_error: 0.0,
        end_error: 0.0,
        max_rel_energy_deviation: 0.0,
        min_euler_defect: f64::INFINITY,
        t_min_euler_defect: a,
        finite: true,
    };
    for k in 0..samples {
        let t = a + (b - a) * k as f64 / (samples - 1) as f64;
        path.jet_into(t, &mut jet);
        r.finite &= jet.iter().all(|v| v.is_finite());
        let value = &jet[..n];
        if k == 0 {
            let d: Vec<f64> = value
                .iter()
                .zip(&problem.omega_a)
                .map(|(x, y)| x - y)
                .collect();
            r.start_error = norm(&d);
        }
        if k == samples - 1 {
            let d: Vec<f64> = value
                .iter()
                .zip(&problem.omega_b)
                .map(|(x, y)| x - y)
                .collect();
            r.end_error = norm(&d);
        }
        let dev = set.relative_mismatch(value).abs();
        r.max_rel_energy_deviation = r.max_rel_energy_deviation.max(dev);
        // xi~ = I Om' - ad*_Om I Om is the first block of the generated singular jet.
        M::singular_jet(&jet, p, &mut xi, &mut lambda);
        let defect = norm(&xi[..n]);
        if defect < r.min_euler_defect || defect.is_nan() {
            r.min_euler_defect = defect;
            r.t_min_euler_defect = t;
        }
    }
    r
}

type SharedPath = Arc<dyn Path>;

/// `path` behind a [`Memo`]: the homotopy's BVPs evaluate their desired path at the same
/// times again and again.
fn remembered(path: &SharedPath) -> SharedPath {
    Arc::new(Memo::new(path.clone()))
}

/// The start path of the desired start when the desired path misses `Ω_a` or `Ω_b`: the
/// desired path bent to them ([`EndBlend`]) over the first and last quarter of `[a, b_p]`, then
/// projected onto the level set.
pub const BENT_DESIRED: &str = "projected desired path, bent to the end points";

/// Choose `Ω_p` and the paper case (module docs).
fn choose_start<M: Model>(
    problem: &Problem<M>,
    b_p: f64,
    beta_m: f64,
    gamma_positive: bool,
    strategy: StartStrategy,
) -> Result<(SharedPath, StartChoice), LieSolveError<M>> {
    let a = problem.t0;
    let samples = 4001;
    let scale = norm(&problem.omega_a);
    let inertia = problem.inertia_matrix();
    let inertia_scale = inertia.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let admissible = |r: &PropertyReport| {
        r.finite
            && r.start_error <= 1e-9 * scale
            && r.end_error <= 1e-9 * scale
            && r.min_euler_defect > 1e-6 * inertia_scale * scale * scale
    };
    let desired = check_properties(problem, &*problem.desired, (a, b_p), samples);
    let projected: SharedPath = Arc::new(Projected {
        inner: problem.desired.clone(),
        set: problem.level_set(),
    });
    let proj = check_properties(problem, &*projected, (a, b_p), samples);
    let segment = || -> Result<SharedPath, LieSolveError<M>> {
        let seg = projected_segment(
            &problem.level_set(),
            &problem.omega_a,
            &problem.omega_b,
            a,
            b_p,
            super::problem::ENERGY_REL_TOL,
        )
        .map_err(|e| LieSolveError::start(e.to_string()))?;
        let r = check_properties(problem, &seg, (a, b_p), samples);
        if !admissible(&r) {
            return Err(LieSolveError::start(format!(
                "the projected segment from omega_a to omega_b violates Property 3 \
                 (min |I Om' - ad*_Om I Om| = {:e} at t = {}): along it the free motion \
                 needs no constraint force; give a desired path instead",
                r.min_euler_defect, r.t_min_euler_defect
            )));
        }
        Ok(Arc::new(seg))
    };
    let choice = |omega_p, case| StartChoice {
        omega_p,
        case,
        b_p,
        beta_m,
        desired_energy_deviation: desired.max_rel_energy_deviation,
    };
    match strategy {
        StartStrategy::Auto => {}
        StartStrategy::Segment => {
            let case = if gamma_positive { 2 } else { 1 };
            return Ok((segment()?, choice("projected segment", case)));
        }
        StartStrategy::Desired | StartStrategy::DesiredGammaFromZero => {
            if !gamma_positive {
                let name = M::WEIGHTS
                    .iter()
                    .find(|w| w.role == HomotopyRole::Tracking)
                    .map_or("tracking weight", |w| w.name);
                return Err(LieSolveError::start(format!(
                    "a start from the desired path needs {name} > 0 (with {name} = 0 the \
                     desired path is not part of the cost); use the segment or auto start"
                )));
            }
            let case = if strategy == StartStrategy::Desired {
                3
            } else {
                2
            };
            if admissible(&proj) {
                return Ok((projected, choice("projected desired path", case)));
            }
            // A desired path that misses an end point (e.g. a fixed b before it settles):
            // bent to Omega_a and Omega_b over the first and last quarter of [a, b_p].
            let bent = EndBlend::new(
                problem.desired.clone(),
                (a, b_p),
                &problem.omega_a,
                &problem.omega_b,
                0.25 * (b_p - a),
            )
            .map(|inner| -> SharedPath {
                Arc::new(Projected {
                    inner: Arc::new(inner),
                    set: problem.level_set(),
                })
            });
            let bent_report = bent
                .as_ref()
                .map(|path| check_properties(problem, &**path, (a, b_p), samples));
            if let (Ok(path), Ok(report)) = (&bent, &bent_report) {
                if admissible(report) {
                    return Ok((path.clone(), choice(BENT_DESIRED, case)));
                }
            }
            return Err(LieSolveError::start(format!(
                "the projected desired path violates Property 1 or 3 on [a, b_p] \
                 (|Omega_p(a) - Omega_a| = {:e}, |Omega_p(b_p) - Omega_b| = {:e}, \
                 min |I Om' - ad*_Om I Om| = {:e}), and bent to the end points {}; use the \
                 segment start",
                proj.start_error,
                proj.end_error,
                proj.min_euler_defect,
                match &bent_report {
                    Ok(r) => format!(
                        "it violates Property 3 (min |I Om' - ad*_Om I Om| = {:e} at t = {})",
                        r.min_euler_defect, r.t_min_euler_defect
                    ),
                    Err(e) => format!("it is undefined ({e})"),
                }
            )));
        }
    }
    if gamma_positive {
        if admissible(&proj) {
            let case = if desired.max_rel_energy_deviation <= ADMISSIBLE_ENERGY_TOL
                && admissible(&desired)
            {
                3
            } else {
                2
            };
            return Ok((projected, choice("projected desired path", case)));
        }
        return Ok((segment()?, choice("projected segment", 2)));
    }
    Ok((segment()?, choice("projected segment", 1)))
}

/// What a homotopy stage continues: the constants, the end state, the start constraint's
/// level shift and the fixed terminal time.
#[derive(Clone)]
struct Member {
    params: Vec<f64>,
    omega_b: Vec<f64>,
    level_shift: f64,
    /// The fixed `b − a`, or `None` for a free terminal time.
    span: Option<f64>,
}

/// A homotopy stage: `at(λ, member)` moves a copy of the current member to `λ ∈ [0, 1]` and
/// returns the value of the reported `parameter` there (`from` at 0, `to` at 1).
struct StageSpec<'a> {
    name: &'static str,
    parameter: &'static str,
    from: f64,
    to: f64,
    at: &'a dyn Fn(f64, &mut Member) -> f64,
}

/// The working state of the homotopy.
#[derive(Clone)]
struct Homotopy<'p, M: Model> {
    problem: &'p Problem<M>,
    params: Vec<f64>,
    /// The current end state (`Ω_b⁰` before the constraint stage, then `Ω_b`).
    omega_b: Vec<f64>,
    /// The start constraint's level shift ([`LieBvp::level_shift`]).
    level_shift: f64,
    fixed_span: Option<f64>,
    t_span: f64,
    solution: Solution,
    start: StartChoice,
    stages: Vec<StageReport>,
    tolerance: f64,
    tracking: SharedPath,
}

impl<M: Model> Homotopy<'_, M> {
    /// The BVP of the current member with `params`; the start constraint is imposed exactly
    /// when their constraint value does not vanish (as [`LieBvp::new`] decides).
    fn bvp_with(&self, params: Vec<f64>, fixed_span: Option<f64>) -> LieBvp<'_, M> {
        LieBvp {
            start_constraint: !crate::model::constraint_value_vanishes::<M>(&params),
            params,
            omega_a: &self.problem.omega_a,
            omega_b: self.omega_b.clone(),
            t0: self.problem.t0,
            fixed_span,
            level_shift: self.level_shift,
            desired: &*self.tracking,
            model: std::marker::PhantomData,
        }
    }

    fn snapshot(&self) -> LieSolution<M> {
        let mut problem = self.problem.clone();
        for w in M::WEIGHTS.iter().chain(M::CONSTRAINT_PARAMS) {
            problem.set_weight(w.index, self.params[w.index]);
        }
        problem.omega_b.clone_from(&self.omega_b);
        // The member solved: a free-time problem stopped before its time stage was solved at
        // the fixed time b_p (its BVP has no unknown T). The solution decides, not the mode:
        // when the first free-time solve fails, the mode is free but the last solution the
        // fixed-time one.
        let solved_free = self.fixed_span.is_none()
            && self.solution.p.len()
                == crate::bvp::BvpProblem::k(&self.bvp_with(self.params.clone(), None));
        problem.terminal = if solved_free {
            TerminalTime::Free {
                guess: problem.t0 + self.t_span,
            }
        } else {
            TerminalTime::Fixed(problem.t0 + self.t_span)
        };
        LieSolution {
            problem,
            bvp: self.solution.clone(),
            t_span: self.t_span,
            start: self.start.clone(),
            stages: self.stages.clone(),
            tolerance: self.tolerance,
            routes: Vec::new(),
            time_scan: Vec::new(),
            collapse: None,
            checked: None,
        }
    }

    fn record(
        &mut self,
        report: StageReport,
        parameter: &'static str,
        reached: f64,
        events: &mut dyn FnMut(&Event),
    ) -> Result<(), LieSolveError<M>> {
        events(&Event::StageFinished(&report));
        let stopped = match &report.outcome {
            StageOutcome::Stopped { reason } => Some(reason.clone()),
            StageOutcome::Completed => None,
        };
        let (name, target) = (report.name, report.to);
        self.stages.push(report);
        if let Some(reason) = stopped {
            return Err(LieSolveError::StageFailed {
                stage: name,
                parameter,
                reached,
                target,
                reason,
                partial: Box::new(self.snapshot()),
            });
        }
        Ok(())
    }

    /// Continue constant `index` of `p` along `value(λ)`, `λ ∈ [0, 1]`.
    #[allow(clippy::too_many_arguments)]
    fn stage(
        &mut self,
        name: &'static str,
        index: usize,
        from: f64,
        to: f64,
        value: &dyn Fn(f64) -> f64,
        opts: &continuation::Options,
        events: &mut dyn FnMut(&Event),
    ) -> Result<(), LieSolveError<M>> {
        let at = |lambda: f64, m: &mut Member| {
            m.params[index] = value(lambda);
            m.params[index]
        };
        let spec = StageSpec {
            name,
            parameter: M::PARAM_NAMES[index],
            from,
            to,
            at: &at,
        };
        self.stage_with(&spec, opts, events)
    }

    /// The family member the homotopy stands on.
    fn member(&self) -> Member {
        Member {
            params: self.params.clone(),
            omega_b: self.omega_b.clone(),
            level_shift: self.level_shift,
            span: self.fixed_span,
        }
    }

    /// Continue along `spec.at(λ, member)`, `λ ∈ [0, 1]`, from the current member.
    fn stage_with(
        &mut self,
        spec: &StageSpec<'_>,
        opts: &continuation::Options,
        events: &mut dyn FnMut(&Event),
    ) -> Result<(), LieSolveError<M>> {
        let StageSpec { name, from, to, .. } = *spec;
        let clock = std::time::Instant::now();
        events(&Event::StageStarted { name, from, to });
        let base = self.member();
        let at = |lambda: f64| -> (Member, f64) {
            let mut m = base.clone();
            let reported = (spec.at)(lambda, &mut m);
            (m, reported)
        };
        let family = |lambda: f64| {
            let (m, _) = at(lambda);
            LieBvp {
                omega_b: m.omega_b,
                level_shift: m.level_shift,
                ..self.bvp_with(m.params, m.span)
            }
        };
        let shared = std::cell::RefCell::new(&mut *events);
        let outcome = continuation::natural_with_progress(
            family,
            0.0,
            1.0,
            &self.solution,
            opts,
            &mut |record| {
                (shared.borrow_mut())(&Event::Step {
                    stage: name,
                    record,
                })
            },
            &mut |lambda, progress| {
                (shared.borrow_mut())(&Event::Bvp {
                    stage: name,
                    lambda,
                    progress,
                })
            },
        )?;
        let xi_before = xi_extent::<M>(&self.solution);
        let condition_before = self.solution.stats.bc_condition;
        let mut lambda = outcome.lambda;
        let mut solution = outcome.solution.clone();
        let mut steps = outcome.steps();
        let mut failures = outcome.failures();
        let mut newton = outcome.newton_iterations();
        let mut status = if outcome.status.is_success() {
            None
        } else {
            Some(outcome.status.to_string())
        };
        let mut folds = Vec::new();
        let stopped = matches!(outcome.status, ContinuationStatus::Stopped { .. });
        if let Some(natural_reason) = status.clone().filter(|_| !stopped) {
            // Natural continuation stalled: follow the branch by pseudo-arclength from the last
            // converged point, through folds, to λ = 1 if the branch gets there.
            let arc = continuation::ArclengthOptions {
                initial_step: 0.02,
                max_step: 0.2,
                min_step: ARCLENGTH_MIN_STEP,
                max_steps: ARCLENGTH_MAX_STEPS,
                lambda_stop: Some(1.0),
                bvp: opts.bvp.clone(),
                ..Default::default()
            };
            let monitor = |s: &Solution| s.eval(0.5).iter().map(|v| v * v).sum::<f64>().sqrt();
            events(&Event::StageStarted {
                name,
                from: at(lambda).1,
                to,
            });
            if let Ok(rescue) = continuation::pseudo_arclength(
                family,
                lambda,
                &outcome.solution,
                monitor,
                &arc,
                &mut |_| {},
            ) {
                steps += rescue.steps();
                failures += rescue.failures();
                newton += rescue.newton_iterations();
                folds = rescue.folds.iter().map(|f| at(f.lambda).1).collect();
                match rescue.status {
                    continuation::ArclengthStatus::ReachedStop => {
                        lambda = 1.0;
                        solution = rescue.solution;
                        status = None;
                    }
                    other => {
                        let furthest = rescue
                            .branch
                            .iter()
                            .map(|b| b.lambda)
                            .fold(lambda, f64::max);
                        let furthest = at(furthest).1;
                        let fold_values: Vec<String> = rescue
                            .folds
                            .iter()
                            .map(|f| at(f.lambda).1.to_string())
                            .collect();
                        status = Some(if fold_values.is_empty() {
                            format!(
                                "{natural_reason}; pseudo-arclength continuation found no fold \
                                 and got no further than {} = {furthest} ({other})",
                                spec.parameter
                            )
                        } else {
                            format!(
                                "{natural_reason}; pseudo-arclength continuation passed {} \
                                 fold(s) of the branch (at {} = {}) and got no further than {} \
                                 = {furthest} ({other}): the target is not reached on this \
                                 branch",
                                fold_values.len(),
                                spec.parameter,
                                fold_values.join(", "),
                                spec.parameter,
                            )
                        });
                    }
                }
            }
        }
        if let Some(reason) = &mut status {
            if let Some(why) = xi_collapse::<M>(
                Some(xi_before),
                &solution,
                &at(lambda).0.params,
                self.problem.params(),
            ) {
                reason.push_str("; ");
                reason.push_str(&why);
            }
            if let Some(why) = conditioning_growth(condition_before, solution.stats.bc_condition) {
                reason.push_str("; ");
                reason.push_str(&why);
            }
        }
        let (reached_member, reached) = at(lambda);
        (self.params, self.omega_b, self.level_shift, self.fixed_span) = (
            reached_member.params,
            reached_member.omega_b,
            reached_member.level_shift,
            reached_member.span,
        );
        self.solution = solution;
        self.t_span = match self.fixed_span {
            Some(span) => span,
            None => self.solution.p[SPAN],
        };
        let stage_report = StageReport {
            name,
            parameter: spec.parameter,
            from,
            to,
            steps,
            failures_recovered: failures,
            newton_iterations: newton,
            nodes: self.solution.num_nodes(),
            seconds: clock.elapsed().as_secs_f64(),
            outcome: match status {
                None => StageOutcome::Completed,
                Some(reason) => StageOutcome::Stopped { reason },
            },
            folds,
        };
        self.record(stage_report, spec.parameter, reached, events)
    }

    /// Continue the fixed `b − a` from its current value to `span`, geometrically (the
    /// weights stay): the value-function scan's path between its samples.
    fn horizon_stage(&mut self, span: f64, options: &SolveOptions) -> Result<(), LieSolveError<M>> {
        let from = self.t_span;
        let (lo, hi) = (from.ln(), span.ln());
        let at = move |l: f64, m: &mut Member| {
            let t = if l >= 1.0 {
                span
            } else {
                (lo + l * (hi - lo)).exp()
            };
            m.span = Some(t);
            t
        };
        self.stage_with(
            &StageSpec {
                name: "b - a",
                parameter: "b - a",
                from,
                to: span,
                at: &at,
            },
            &continuation_options(options),
            &mut |_| {},
        )
    }

    /// The constraint level `⟨Ω, ξ⟩ − γ` (`φ`) of the current solution, at `a` (it is conserved).
    fn constraint_level(&self) -> f64 {
        let y = self.solution.eval(0.0);
        let mut grad = vec![0.0; M::XIDOT.start];
        M::constraint_residual(&y[..M::XIDOT.start], &self.params, &mut grad)
    }

    /// Stages A–C of a nonzero constant constraint value `γ` (module docs), from the solution
    /// of the problem without it (constraint parameters 0, end state `Ω_b⁰` on the level set,
    /// the paper's boundary conditions). Uses that `γ` enters the optimality system only
    /// through the start constraint (Suslov's equations contain `γ̇ = 0`).
    fn constraint_stages(
        &mut self,
        target: &Problem<M>,
        opts: &continuation::Options,
        events: &mut dyn FnMut(&Event),
    ) -> Result<(), LieSolveError<M>> {
        let gamma = crate::model::constant_constraint_value::<M>(target.params());
        let set = target.level_set();
        // A. The end state moves off the level set with the paper's conditions; the motion's
        // constraint level k follows (T(b) − T(a) = k ∫λ). To Ω_b itself when it is off the
        // level set, else to Ω_b⁰ scaled by 1.1.
        let aside: Vec<f64> = if set.relative_mismatch(&target.omega_b).abs() > 1e-3 {
            target.omega_b.clone()
        } else {
            self.omega_b.iter().map(|v| 1.1 * v).collect()
        };
        let towards = |to: Vec<f64>| {
            move |lambda: f64, m: &mut Member| {
                m.omega_b = from_to(&m.omega_b, &to, lambda);
                lambda
            }
        };
        let move_aside = towards(aside.clone());
        self.stage_with(
            &StageSpec {
                name: "end state (paper's conditions)",
                parameter: "fraction of the way to the end state",
                from: 0.0,
                to: 1.0,
                at: &move_aside,
            },
            opts,
            events,
        )?;
        self.omega_b.clone_from(&aside);
        let mut level = self.constraint_level();
        if !(level.is_finite() && level != 0.0) {
            return Err(LieSolveError::ConstraintRoute(format!(
                "the motion to the end state {aside:?} has the constraint level <Omega, xi> = \
                 {level:e}; the continuation in the level needs a nonzero start"
            )));
        }
        if level * gamma < 0.0 {
            // The mirror (ξ, ξ̇) → −(ξ, ξ̇) maps a motion on level k to one on −k with the same
            // Ω (λξ is even in ξ) when the cost is even in ξ; the solve checks that it is.
            let mut y = self.solution.y.clone();
            for row in y.chunks_exact_mut(M::N_STATE) {
                row[M::XI.start..M::XIDOT.end]
                    .iter_mut()
                    .for_each(|v| *v = -*v);
            }
            let guess = Guess::from_values(self.solution.x.clone(), y, self.solution.p.clone());
            self.single_solve("mirror xi -> -xi", &guess, &opts.bvp, events)?;
            level = self.constraint_level();
            if (level * gamma).is_nan() || level * gamma <= 0.0 {
                return Err(LieSolveError::ConstraintRoute(format!(
                    "the motion has the constraint level {:e}, of the other sign than the \
                     target value {gamma}, and its mirror xi -> -xi does not solve the problem \
                     (the model's cost is not even in xi); no continuation in the level \
                     reaches the target without crossing 0",
                    -level
                )));
            }
        }
        // B. The start constraint at the target constants, its level shifted to k, then
        // continued to γ; μ = 0 is exact at the start (the paper's conditions hold there).
        for c in M::CONSTRAINT_PARAMS {
            self.params[c.index] = target.params()[c.index];
        }
        self.level_shift = gamma - level;
        self.solution.p = self
            .bvp_with(self.params.clone(), self.fixed_span)
            .parameters(self.t_span, 0.0);
        let shift0 = self.level_shift;
        let to_level = move |lambda: f64, m: &mut Member| {
            m.level_shift = (1.0 - lambda) * shift0;
            gamma - m.level_shift
        };
        self.stage_with(
            &StageSpec {
                name: "constraint",
                parameter: "<Omega, xi>",
                from: level,
                to: gamma,
                at: &to_level,
            },
            opts,
            events,
        )?;
        self.level_shift = 0.0;
        // C. The end state to Ω_b at the target level.
        if self.omega_b != target.omega_b {
            let to_target = towards(target.omega_b.clone());
            self.stage_with(
                &StageSpec {
                    name: "end state",
                    parameter: "fraction of the way to the end state",
                    from: 0.0,
                    to: 1.0,
                    at: &to_target,
                },
                opts,
                events,
            )?;
            self.omega_b.clone_from(&target.omega_b);
        }
        Ok(())
    }

    /// The polish to the requested tolerance, then, if the solution fails its a-posteriori
    /// checks although the solver's error estimate met the tolerance (e.g. a coarse mesh over a
    /// long horizon), solves at [`REFINE_FACTORS`] times the tolerance, the first that
    /// passes the checks kept (which stay those of the requested tolerance). Every stage tried is
    /// in the returned solution's stage table.
    fn finish(
        &mut self,
        options: &SolveOptions,
        bvp_opts: &dyn Fn(f64) -> bvp::Options,
        events: &mut dyn FnMut(&Event),
    ) -> Result<LieSolution<M>, LieSolveError<M>> {
        self.polish(
            "polish",
            options.tol,
            options.continuation_tol,
            bvp_opts,
            events,
        )?;
        let mut solution = self.snapshot();
        if super::verify::verify_and_keep(&mut solution)
            .verification
            .passed()
        {
            return Ok(solution);
        }
        for factor in REFINE_FACTORS {
            if self
                .polish(
                    "refine",
                    options.tol * factor,
                    options.tol,
                    bvp_opts,
                    events,
                )
                .is_err()
            {
                break;
            }
            let mut tighter = self.snapshot();
            if super::verify::verify_and_keep(&mut tighter)
                .verification
                .passed()
            {
                return Ok(tighter);
            }
        }
        solution.stages.clone_from(&self.stages);
        Ok(solution)
    }

    /// The final solve at the requested tolerance `tol` from the current solution. When the
    /// direct solve fails, the tolerance is stepped down by factors of 100 from `from_tol`
    /// (the continuation's), each solve starting from the last, with a step of 10 where one of
    /// 100 fails: a solution that the direct polish misses (a sensitive one, near the end of a
    /// continuation) is reached in steps.
    fn polish(
        &mut self,
        name: &'static str,
        tol: f64,
        from_tol: f64,
        options: &dyn Fn(f64) -> bvp::Options,
        events: &mut dyn FnMut(&Event),
    ) -> Result<(), LieSolveError<M>> {
        let clock = std::time::Instant::now();
        events(&Event::StageStarted {
            name,
            from: 0.0,
            to: 0.0,
        });
        let mut newton = 0;
        let mut attempt = |h: &mut Self, t: f64, events: &mut dyn FnMut(&Event)| {
            let problem = h.bvp_with(h.params.clone(), h.fixed_span);
            let guess = Guess::from_solution(&h.solution);
            let sol = bvp::solve_with_progress(&problem, &guess, &options(t), &mut |progress| {
                events(&Event::Bvp {
                    stage: name,
                    lambda: 0.0,
                    progress,
                })
            })?;
            newton += sol.stats.newton_iterations;
            Ok::<_, LieSolveError<M>>(sol)
        };
        let direct = attempt(self, tol, events)?;
        let mut failure = None;
        let mut steps = 1;
        if direct.is_success() {
            self.solution = direct;
        } else {
            // The last tolerance solved at, and the step to the next (100×, or 10× after a
            // failed 100× step).
            let (mut good, mut ratio) = (from_tol, 1e-2);
            while failure.is_none() && good > tol * (1.0 + 1e-9) {
                let t = (good * ratio).max(tol);
                steps += 1;
                let sol = attempt(self, t, events)?;
                if sol.is_success() {
                    self.solution = sol;
                    (good, ratio) = (t, 1e-2);
                } else if ratio < 1e-1 && good * 1e-1 > tol * (1.0 + 1e-9) {
                    ratio = 1e-1;
                } else {
                    let mut why = format!(
                        "{} (the direct solve at {tol:e} failed too; stepping the tolerance \
                         down from {from_tol:e}, the step from {good:e} to {t:e} failed)",
                        bvp_failure(sol.status)
                    );
                    if let Some(collapse) =
                        xi_collapse::<M>(None, &self.solution, &self.params, self.problem.params())
                    {
                        why.push_str("; ");
                        why.push_str(&collapse);
                    }
                    failure = Some(why);
                }
            }
        }
        if self.fixed_span.is_none() {
            self.t_span = self.solution.p[SPAN];
        }
        let report = StageReport {
            name,
            parameter: "-",
            from: 0.0,
            to: 0.0,
            steps,
            failures_recovered: usize::from(steps > 1 && failure.is_none()),
            newton_iterations: newton,
            nodes: self.solution.num_nodes(),
            seconds: clock.elapsed().as_secs_f64(),
            outcome: match failure {
                None => StageOutcome::Completed,
                Some(reason) => StageOutcome::Stopped { reason },
            },
            folds: Vec::new(),
        };
        self.record(report, "-", f64::NAN, events)
    }

    /// One BVP solve with the current constants from `guess`.
    fn single_solve(
        &mut self,
        name: &'static str,
        guess: &Guess,
        options: &bvp::Options,
        events: &mut dyn FnMut(&Event),
    ) -> Result<(), LieSolveError<M>> {
        let clock = std::time::Instant::now();
        events(&Event::StageStarted {
            name,
            from: 0.0,
            to: 0.0,
        });
        let problem = self.bvp_with(self.params.clone(), self.fixed_span);
        let sol = bvp::solve_with_progress(&problem, guess, options, &mut |progress| {
            events(&Event::Bvp {
                stage: name,
                lambda: 0.0,
                progress,
            })
        })?;
        let report = single_solve_report(name, &sol, clock.elapsed().as_secs_f64());
        if sol.is_success() {
            self.solution = sol;
            if self.fixed_span.is_none() {
                self.t_span = self.solution.p[SPAN];
            }
        }
        self.record(report, "-", f64::NAN, events)
    }
}

/// `(min |ξ|, max |ê̇|)` over the mesh nodes of `sol`, `ê = ξ/|ξ|` the constraint direction and
/// `|ê̇| = |ξ̇ − ê⟨ê, ξ̇⟩| / |ξ|` its turning rate (physical time).
fn xi_extent<M: Model>(sol: &Solution) -> (f64, f64) {
    let (mut min_xi, mut max_turn) = (f64::INFINITY, 0.0_f64);
    for y in sol.y.chunks_exact(M::N_STATE) {
        let (xi, xi_dot) = (&y[M::XI], &y[M::XIDOT]);
        let r = norm(xi);
        min_xi = min_xi.min(r);
        let along: f64 = xi.iter().zip(xi_dot).map(|(a, b)| a * b).sum::<f64>() / (r * r);
        let turn: Vec<f64> = xi_dot.iter().zip(xi).map(|(d, x)| d - along * x).collect();
        max_turn = max_turn.max(norm(&turn) / r);
    }
    (min_xi, max_turn)
}

/// Below this `min |ξ|` (and below half its value at the stage's start) a stalled stage is
/// diagnosed as `ξ` collapsing toward 0.
const XI_COLLAPSE: f64 = 0.25;

/// Why a stage that stalled at `sol` may have no solution ahead: the constraint covector `ξ`
/// shrinking toward 0, where Suslov's equations are singular (`⟨ξ, 𝕀⁻¹ξ⟩` divides the
/// multiplier). Suslov's equations depend on `ξ` only through its direction `ê`, so a cost that
/// charges `β/2 |ξ̇|²` and holds `|ξ|` near 1 by `α/4 (|ξ|² − 1)²` (every shipped model) is
/// lowered by shrinking `ξ` wherever `ê` turns: pointwise (neglecting `d|ξ|/dt`) the optimal
/// `|ξ|² = 1 − (β/α) |ê̇|²`, which reaches 0 where `|ê̇| ≥ sqrt(α/β)`. `before` is
/// [`xi_extent`] at the stage's start (`None` for a single solve, the polish: then a small
/// `min |ξ|` alone is the evidence); the weights named are the model's `Beta` weight and,
/// when it has exactly one, its `Fixed` weight, at `params` (the stall) and `target` (the
/// problem's).
fn xi_collapse<M: Model>(
    before: Option<(f64, f64)>,
    sol: &Solution,
    params: &[f64],
    target: &[f64],
) -> Option<String> {
    let (min_xi, max_turn) = xi_extent::<M>(sol);
    if !(min_xi < XI_COLLAPSE && before.is_none_or(|b| min_xi < 0.5 * b.0)) {
        return None;
    }
    let beta = M::WEIGHTS.iter().find(|w| w.role == HomotopyRole::Beta)?;
    let mut fixed = M::WEIGHTS.iter().filter(|w| w.role == HomotopyRole::Fixed);
    let (b, name_b) = (params[beta.index], M::PARAM_NAMES[beta.index]);
    let mut why = match before {
        Some(before) => format!(
            "xi collapses toward 0 (min |xi| {:.3} at the stage's start, {min_xi:.3} here), \
             where Suslov's equations are singular: the cost shrinks xi wherever its direction \
             turns fast",
            before.0
        ),
        None => format!(
            "xi nearly vanishes on the solution (min |xi| {min_xi:.3}), where Suslov's equations \
             are singular: the cost shrinks xi wherever its direction turns fast"
        ),
    };
    if let (Some(alpha), None) = (fixed.next(), fixed.next()) {
        let (a, name_a) = (params[alpha.index], M::PARAM_NAMES[alpha.index]);
        why.push_str(&format!(
            " (|xi|^2 = 1 - ({name_b}/{name_a}) |d(xi/|xi|)/dt|^2 pointwise: 0 where the \
             direction turns faster than sqrt({name_a}/{name_b}) = {:.3} rad/s; here it turns \
             at up to {max_turn:.3} rad/s); raise {name_a} (= {}) or lower {name_b} (= {})",
            (a / b).sqrt(),
            target[alpha.index],
            target[beta.index]
        ));
    } else {
        why.push_str(&format!("; lower {name_b} (= {})", target[beta.index]));
    }
    Some(why)
}

/// How much the boundary conditions' condition number (`bvp::Stats::bc_condition`: the
/// largest change of the solution per unit change of one boundary condition) must grow along
/// a stage that stops for the stop to report it.
const CONDITIONING_GROWTH: f64 = 10.0;

/// The evidence of a stop whose branch becomes ill-conditioned: the condition number grew by
/// more than [`CONDITIONING_GROWTH`] from the stage's start to the last solution reached (as
/// at a fold, or where the target problem's solution is not isolated).
fn conditioning_growth(before: f64, at_stop: f64) -> Option<String> {
    (before.is_finite() && before > 0.0 && at_stop > CONDITIONING_GROWTH * before).then(|| {
        format!(
            "the boundary conditions' condition number grew from {before:.2e} at the \
             stage's start to {at_stop:.2e} at the last solution reached (the branch \
             approaches a singular point: a fold, or a solution that is not isolated)"
        )
    })
}

/// `a + λ (b − a)`, entrywise.
fn from_to(a: &[f64], b: &[f64], lambda: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + lambda * (y - x)).collect()
}

/// The problem the analytic start and stages 1–4 solve (module docs): `problem` itself when
/// its constraint value vanishes, else a copy with every `Constraint` parameter at 0 and `Ω_b`
/// projected radially onto the energy level set of `Ω_a`.
fn constraint_free<M: Model>(problem: &Problem<M>) -> Result<Problem<M>, LieSolveError<M>> {
    let mut base = problem.clone();
    if problem.conserves_energy() {
        return Ok(base);
    }
    for c in M::CONSTRAINT_PARAMS {
        base.set_weight(c.index, 0.0);
    }
    base.omega_b = problem.level_set().project(&problem.omega_b).map_err(|e| {
        LieSolveError::start(format!(
            "cannot project omega_b onto the energy level set of omega_a, where the start \
             (constraint value 0) must end: {e}"
        ))
    })?;
    Ok(base)
}

/// Solve `problem` from the analytic singular solution through the staged homotopy: the
/// default route first, then, if it stops, the alternatives chosen by where it stopped
/// ([`alternatives`]), until one solves the problem. When every route stops, the error of the
/// route that got furthest (most stages completed; the default on a tie) is returned, its
/// partial result listing every route tried in [`LieSolution::routes`] (a start that failed on
/// every route lists them in its message).
pub fn solve<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, LieSolveError<M>> {
    match &options.warm_start {
        Some(warm) => solve_from(problem, options, warm, events),
        None => solve_cold(problem, options, Evidence::Collapse, events),
    }
}

/// Whether a stop of [`solve_cold`] is compared with controls whose ξ vanishes
/// ([`super::collapse::for_stop`]): for the caller's problem, not for the value-function
/// scan's inner fixed-time solves, whose stops are only samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Evidence {
    Collapse,
    None,
}

/// [`solve`] from the analytic start (no warm start).
fn solve_cold<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    evidence: Evidence,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, LieSolveError<M>> {
    let mut routes = Vec::new();
    let clock = std::time::Instant::now();
    let first = match solve_route(problem, options, &Route::DEFAULT, events) {
        Ok(mut sol) => {
            sol.routes.push(RouteReport {
                route: Route::DEFAULT.name,
                stopped: None,
                seconds: clock.elapsed().as_secs_f64(),
            });
            return Ok(sol);
        }
        Err(e) => e,
    };
    let default_report = RouteReport {
        route: Route::DEFAULT.name,
        stopped: Some(first.to_string()),
        seconds: clock.elapsed().as_secs_f64(),
    };
    let others = if options.stopped() {
        None
    } else {
        alternatives(&first, options, problem)
    };
    let Some(others) = others else {
        let mut first = first;
        if let LieSolveError::StageFailed { partial, .. } = &mut first {
            partial.routes = vec![default_report];
        }
        return Err(first);
    };
    routes.push(default_report);
    // The error reported when every route stops: the one that got furthest (the most stages
    // completed; the earlier route on a tie), so the evidence is that of the furthest point.
    let progress = |e: &LieSolveError<M>| match e {
        LieSolveError::StageFailed { partial, .. } => {
            1 + partial
                .stages
                .iter()
                .filter(|s| s.outcome.is_completed())
                .count()
        }
        _ => 0,
    };
    let mut best_route = Route::DEFAULT.name;
    let mut first = first;
    for route in others
        .into_iter()
        .take(options.max_routes.saturating_sub(1))
    {
        if options.stopped() {
            break;
        }
        let clock = std::time::Instant::now();
        let after = routes
            .last()
            .and_then(|r: &RouteReport| r.stopped.clone())
            .unwrap_or_default();
        events(&Event::RouteStarted {
            route: route.name,
            after: &after,
        });
        match solve_route(problem, options, &route, events) {
            Ok(mut sol) => {
                routes.push(RouteReport {
                    route: route.name,
                    stopped: None,
                    seconds: clock.elapsed().as_secs_f64(),
                });
                sol.routes = routes;
                return Ok(sol);
            }
            Err(e) => {
                routes.push(RouteReport {
                    route: route.name,
                    stopped: Some(e.to_string()),
                    seconds: clock.elapsed().as_secs_f64(),
                });
                if progress(&e) > progress(&first) {
                    (first, best_route) = (e, route.name);
                }
            }
        }
    }
    // The direct start (fixed b): a minimum of the transcribed problem by SQP, from the
    // projected segment's inverse dynamics, as a warm start (super::direct).
    // Not when the caller fixed the analytic start: that choice (and its errors) stays theirs;
    // nor for the value-function scan's samples (`Evidence::None`), whose stops are only
    // samples and would each pay for an SQP run.
    let direct = options.max_routes > 1
        && evidence == Evidence::Collapse
        && options.start == StartStrategy::Auto
        && !options.stopped()
        && matches!(problem.terminal, TerminalTime::Fixed(_))
        && matches!(
            &first,
            LieSolveError::StageFailed { .. } | LieSolveError::Start { .. }
        );
    // The cheapest minimum of the direct start that the BVP could not take up.
    let mut direct_minimum: Option<Box<DirectStart>> = None;
    if direct {
        let clock = std::time::Instant::now();
        let after = routes
            .last()
            .and_then(|r: &RouteReport| r.stopped.clone())
            .unwrap_or_default();
        events(&Event::RouteStarted {
            route: DIRECT_START_ROUTE,
            after: &after,
        });
        match direct_route(problem, options, events) {
            Ok(mut sol) => {
                routes.push(RouteReport {
                    route: DIRECT_START_ROUTE,
                    stopped: None,
                    seconds: clock.elapsed().as_secs_f64(),
                });
                sol.routes = routes;
                return Ok(sol);
            }
            Err(failure) => {
                routes.push(RouteReport {
                    route: DIRECT_START_ROUTE,
                    stopped: Some(failure.why),
                    seconds: clock.elapsed().as_secs_f64(),
                });
                direct_minimum = failure.minimum;
                // A BVP solve from the direct minimum that reached the target weights is
                // further than an analytic start's stop: its partial solution is the result.
                if let Some(stop) = failure.stop {
                    if progress(&stop) > progress(&first) {
                        (first, best_route) = (*stop, DIRECT_START_ROUTE);
                    }
                }
            }
        }
    }
    let mut scan = None;
    let scan_time = !options.stopped()
        && matches!(
            &first,
            LieSolveError::StageFailed {
                stage: "delta" | "free-time start",
                ..
            }
        );
    if scan_time {
        let clock = std::time::Instant::now();
        events(&Event::RouteStarted {
            route: TIME_SCAN,
            after: &first.to_string(),
        });
        match time_scan(problem, options, events) {
            Ok(mut sol) => {
                routes.push(RouteReport {
                    route: TIME_SCAN,
                    stopped: None,
                    seconds: clock.elapsed().as_secs_f64(),
                });
                sol.routes = routes;
                return Ok(sol);
            }
            Err(found) => {
                routes.push(RouteReport {
                    route: TIME_SCAN,
                    stopped: Some(found.finding.clone()),
                    seconds: clock.elapsed().as_secs_f64(),
                });
                scan = Some(found);
            }
        }
    }
    Err(match first {
        LieSolveError::StageFailed {
            stage,
            parameter,
            reached,
            target,
            mut reason,
            mut partial,
        } => {
            partial.routes = routes;
            if let Some(scan) = scan {
                reason.push_str("; ");
                reason.push_str(&scan.finding);
                partial.time_scan = scan.samples;
            }
            // What controls with a vanishing xi cost at the target weights: evidence that
            // the branch heads where the optimality system is singular (lie::collapse).
            let scan_least = partial
                .time_scan
                .iter()
                .filter_map(|s| s.cost)
                .min_by(f64::total_cmp);
            if evidence == Evidence::Collapse && !options.stopped() {
                let omegas = direct_minimum.as_ref().map(|d| d.omegas::<M>());
                let direct = direct_minimum
                    .as_ref()
                    .zip(omegas.as_deref())
                    .map(|(d, o)| (d.warm.times.as_slice(), o));
                partial.collapse = super::collapse::for_stop(problem, &partial, scan_least, direct);
                if let (Some(found), Some(d)) = (partial.collapse.as_mut(), &direct_minimum) {
                    found.compare_direct(d.cost, d.min_xi);
                }
            }
            if let Some(found) = partial.collapse.as_ref().filter(|c| c.undercuts) {
                reason.push_str("; ");
                reason.push_str(&found.sentence);
            }
            if best_route != Route::DEFAULT.name {
                reason.push_str(&format!(
                    " [on route '{best_route}', the furthest of the routes tried]"
                ));
            }
            LieSolveError::StageFailed {
                stage,
                parameter,
                reached,
                target,
                reason,
                partial,
            }
        }
        LieSolveError::Start { mut reason, .. } => {
            // No partial solution to compare with: the direct start's minimum is the evidence.
            let mut collapse = None;
            if let Some((found, evidence)) = direct_minimum
                .as_deref()
                .filter(|_| evidence == Evidence::Collapse && !options.stopped())
                .map(|d| direct_finding(problem, d))
            {
                reason.push_str("; ");
                reason.push_str(&found);
                collapse = evidence.map(Box::new);
            }
            let tried: Vec<String> = routes[1..]
                .iter()
                .map(|r| format!("{}: {}", r.route, r.stopped.as_deref().unwrap_or("solved")))
                .collect();
            if !tried.is_empty() {
                reason = format!("{reason}; other routes tried: {}", tried.join("; "));
            }
            // Without routes: `solver.max_routes = 1`, or no alternative applies.
            LieSolveError::Start { reason, collapse }
        }
        other => other,
    })
}

/// The routes to try after the default route stopped with `error`, in order, or `None` when
/// no other route can help (an invalid problem, a missing role, an unsupported feature, a bug).
///
/// - A failed start: with a positive tracking weight in `problem`, the desired start (the full
///   tracking weight from the start; the desired path bent to the end points when it misses
///   them, [`BENT_DESIRED`]), the segment start (both unless the options fix the start), a 4
///   times finer initial mesh, the start at the target β ([`BETA_M_AT_BETA`]), `β_m` 10
///   times smaller, and 10 times larger.
/// - A weight stage (tracking, β, smoothing) that stopped: where ξ collapsed toward 0, first
///   the fixed weights from above ([`FIXED_FROM_ABOVE`]); the weights jointly, β first, the
///   starts the default did not take, the finer mesh.
/// - Any later stage: the fixed weights from above where ξ collapsed, the weights jointly (a
///   different point to start the later stages from), the finer mesh.
pub fn alternatives<M: Model>(
    error: &LieSolveError<M>,
    options: &SolveOptions,
    problem: &Problem<M>,
) -> Option<Vec<Route>> {
    let tracking = M::WEIGHTS
        .iter()
        .any(|w| w.role == HomotopyRole::Tracking && problem.params()[w.index] > 0.0);
    let route = |name, start, order, beta_m_factor, mesh_factor| Route {
        name,
        start,
        order,
        beta_m_factor,
        mesh_factor,
        fixed_factor: 1.0,
        beta_m_at_beta: false,
        horizon_factor: 1.0,
    };
    let start_route = |name, strategy| route(name, Some(strategy), StageOrder::Sequential, 1.0, 1);
    let desired = start_route("desired start", StartStrategy::Desired);
    let segment = start_route("segment start", StartStrategy::Segment);
    // The starts the default did not take (only when the options leave the choice open).
    let other_starts = |chosen: &StartChoice| -> Vec<Route> {
        if options.start != StartStrategy::Auto {
            return Vec::new();
        }
        match (chosen.omega_p == "projected desired path", chosen.case) {
            (true, 3) => vec![segment],
            (true, _) => vec![desired, segment],
            (false, 2) => vec![
                desired,
                start_route(
                    "desired start, tracking from 0",
                    StartStrategy::DesiredGammaFromZero,
                ),
            ],
            (false, _) => Vec::new(),
        }
    };
    let finer = route("finer mesh", None, StageOrder::Sequential, 1.0, 4);
    let joint = route("joint weights", None, StageOrder::Joint, 1.0, 1);
    match error {
        LieSolveError::Start { .. } | LieSolveError::Bvp(_) => {
            let mut r = Vec::new();
            if options.start == StartStrategy::Auto {
                // With tracking: the full tracking weight from the start, as the paper's third
                // case, also when the desired path leaves the level set (the start is its
                // projection); it pins Omega down where the weight from 0 does not.
                if tracking {
                    r.push(desired);
                }
                r.push(segment);
            }
            r.push(finer);
            r.push(Route {
                beta_m_at_beta: true,
                ..route(
                    BETA_M_AT_BETA,
                    (tracking && options.start == StartStrategy::Auto)
                        .then_some(StartStrategy::Desired),
                    StageOrder::Sequential,
                    1.0,
                    1,
                )
            });
            r.push(Route {
                horizon_factor: HORIZON_FACTORS[0],
                ..route(SHORTER_HORIZON, None, StageOrder::Sequential, 1.0, 1)
            });
            r.push(route(
                "smaller beta_m",
                None,
                StageOrder::Sequential,
                0.1,
                1,
            ));
            r.push(route(
                "larger beta_m",
                None,
                StageOrder::Sequential,
                10.0,
                1,
            ));
            Some(r)
        }
        // The polish only tightens the tolerance of a solution already found: another route
        // ends at the same solution (its failure is the node cap or the tolerance).
        LieSolveError::StageFailed {
            stage: "polish", ..
        } => None,
        // The time stage: the value function J*(T) of fixed-time solves is the evidence
        // ([`solve`] scans it after the routes).
        LieSolveError::StageFailed {
            stage: "delta" | "free-time start",
            ..
        } => Some(Vec::new()),
        LieSolveError::StageFailed { stage, partial, .. } => {
            let mut r = vec![joint];
            if xi_extent::<M>(&partial.bvp).0 < XI_COLLAPSE {
                r.insert(
                    0,
                    Route {
                        fixed_factor: FIXED_FROM_ABOVE_FACTOR,
                        ..route(FIXED_FROM_ABOVE, None, StageOrder::Sequential, 1.0, 1)
                    },
                );
            }
            if matches!(*stage, "gamma" | "beta" | "eta") {
                r.push(route("beta first", None, StageOrder::BetaFirst, 1.0, 1));
                r.extend(other_starts(&partial.start));
            }
            r.push(finer);
            Some(r)
        }
        LieSolveError::Invalid(_)
        | LieSolveError::Roles { .. }
        | LieSolveError::ConstraintRoute(_)
        | LieSolveError::Unsupported(_) => None,
    }
}

/// The name of the direct-start route (module docs, [`super::direct`]).
pub const DIRECT_START_ROUTE: &str = "direct start";

/// Intervals of the direct start's uniform mesh: at most the initial mesh's (its SQP only has
/// to land in the BVP's basin; the BVP solve adapts the mesh).
const DIRECT_MAX_INTERVALS: usize = 100;

/// Why the direct route (or one attempt) stopped, with the cheapest minimum the SQP found
/// that the BVP could not take up.
/// Why the direct-start route stopped.
struct DirectFailure<M: Model> {
    /// Every attempt's reason.
    why: String,
    /// The cheapest minimum the SQP found that the BVP could not take up (evidence for
    /// [`super::collapse::for_stop`]).
    minimum: Option<Box<DirectStart>>,
    /// The stop of a BVP solve from a minimum that reached the target weights (its polish
    /// stopped): a partial solution further than any analytic start's.
    stop: Option<Box<LieSolveError<M>>>,
}

impl<M: Model> DirectFailure<M> {
    fn new(why: String) -> Self {
        Self {
            why,
            minimum: None,
            stop: None,
        }
    }

    /// Keep the cheaper minimum and the first stop of `other`, and append its reason.
    fn absorb(&mut self, other: DirectFailure<M>, label: &str) {
        if self.why.is_empty() {
            self.why = other.why;
        } else {
            self.why = format!("{}; {label}{}", self.why, other.why);
        }
        if let Some(found) = other.minimum {
            if self.minimum.as_ref().is_none_or(|c| found.cost < c.cost) {
                self.minimum = Some(found);
            }
        }
        if self.stop.is_none() {
            self.stop = other.stop;
        }
    }
}

/// A direct start that stops is tried once more on a mesh this many times finer, and a
/// minimum the BVP does not take up is refined by this factor at a time.
const DIRECT_RETRY_FACTOR: usize = 2;

/// The finest mesh a direct minimum is refined to (from 100 intervals: 200, then 400).
/// Corpus problem spiral-129's BVP converges from its minimum refined to 400 intervals
/// (cost 0.54474012, min |ξ| 0.017), not from 100 or 200.
const DIRECT_MAX_REFINED_INTERVALS: usize = 4 * DIRECT_MAX_INTERVALS;

/// The direct-start route: [`super::direct::direct_start`], then one BVP solve from it (as
/// [`solve_from`]'s) and the a-posteriori checks; if that stops, all of it once more on a
/// [`DIRECT_RETRY_FACTOR`] times finer mesh; then, whether or not that solved, on the first
/// mesh in the multiplier form ([`super::multiplier`], `φ = 0` at every point), which passes
/// where `ξ` nears 0. Of two verified solutions the cheaper is kept. The failure gives every
/// attempt's reason, the cheapest minimum the SQP found that the BVP could not take up, and
/// the furthest BVP stop from one.
fn direct_route<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, DirectFailure<M>> {
    let intervals = options.initial_intervals.clamp(1, DIRECT_MAX_INTERVALS);
    // When the first attempt stops, once more on a twice finer mesh: corpus problem fast-119
    // (|Omega_a| = 35 over b - a = 7.3) has, on 100 intervals, only a collapsed minimum
    // (min |xi| 0.001, cost 117.69), and on 200 the regular minimum IPOPT finds (114.838).
    let mut failure = DirectFailure::new(String::new());
    let reduced = DirectForm::Reduced;
    let mut solved = match direct_attempt(problem, options, intervals, reduced, events) {
        Ok(found) => Some(found),
        Err(f) => {
            failure.absorb(f, "");
            None
        }
    };
    if solved.is_none() && !options.stopped() {
        let finer = DIRECT_RETRY_FACTOR * intervals;
        match direct_attempt(problem, options, finer, reduced, events) {
            Ok(found) => solved = Some(found),
            Err(f) => failure.absorb(f, &format!("on {finer} intervals: ")),
        }
    }
    if options.stopped() {
        return solved.map(|(sol, _)| sol).ok_or(failure);
    }
    // The multiplier form also when the reduced form solved: the two SQPs can land on
    // different minima, and the cheaper verified one is kept (corpus problem spiral-149:
    // 0.0065374 in the multiplier form against 0.0078319 in the reduced). Corpus problem
    // issue12-080 (γ = 0) is solved in the multiplier form only: the reduced form's SQP stops
    // at a failed inertia correction on both meshes.
    let multiplier = DirectForm::Multiplier;
    match (
        solved,
        direct_attempt(problem, options, intervals, multiplier, events),
    ) {
        (Some((a, cost_a)), Ok((b, cost_b))) => Ok(if cost_b < cost_a { b } else { a }),
        (Some((a, _)), Err(_)) | (None, Ok((a, _))) => Ok(a),
        (None, Err(f)) => {
            failure.absorb(f, "in the multiplier form: ");
            Err(failure)
        }
    }
}

/// `min |ξ|` of a direct minimum below which its `ξ` counts as vanishing (1e8 times below the
/// smallest `min |ξ|` of a regular minimum the corpus has, 0.015 on spiral-189).
const XI_VANISHES: f64 = 1e-10;

/// What the direct start's minimum `d` (which the BVP could not take up) says about `problem`,
/// for a stop without a partial solution. The controls with a vanishing `ξ` evaluated are the
/// one along the minimum's own motion ([`super::collapse::along_samples`]) and the one along
/// the relaxed minimum's ([`super::collapse::along_relaxed`]), both
/// re-integrated. When the cheaper costs no more than the minimum itself, the minimizing
/// controls collapse (the infimum is approached as `ξ → 0`); otherwise the minimum is a
/// regular one the BVP does not converge from. Returns the finding in words and, when a
/// control was evaluated, the evidence (its `undercuts` is the collapse: the cheapest control
/// costs no more than the minimum, within the minimum's discretization).
fn direct_finding<M: Model>(
    problem: &Problem<M>,
    d: &DirectStart,
) -> (String, Option<super::collapse::CollapseEvidence>) {
    use super::collapse::{self, CollapseEvidence, Motion, RelaxedOutcome};
    let omegas = d.omegas::<M>();
    let along_direct = collapse::along_samples(
        problem,
        problem.params(),
        &d.warm.times,
        &omegas,
        Motion::DirectMinimum,
    );
    let (relaxed, along_relaxed) = collapse::along_relaxed(problem);
    let head = format!(
        "the direct method's minimum of the transcribed problem costs {} with min |xi| {:.2e}",
        Cost(d.cost),
        d.min_xi
    );
    let controls: Vec<_> = along_direct
        .clone()
        .into_iter()
        .chain(along_relaxed)
        .collect();
    let least = collapse::cheapest(&controls);
    // The discrete cost is a quadrature on the direct mesh: a relative 1e-3 for its error.
    let collapses = least.is_some_and(|c| c.cost <= d.cost * (1.0 + collapse::DIRECT_COST_RTOL));
    let mut finding = match least {
        Some(c) if collapses => format!(
            "{head}, and an admissible control with |xi| = {:.0e} along {} costs J = {} \
             (re-integrated to within {:.1e}): the minimizing controls collapse, the infimum is \
             approached as xi -> 0, where the optimality system is singular",
            c.eps,
            c.motion.describe(),
            Cost(c.cost),
            c.reintegration_error
        ),
        // A minimum whose ξ itself vanishes is on the singular set, not a regular one, even
        // when the controls with |ξ| = ε tried cost more (a span of 1e-6 made ε = 1e-6 costly).
        Some(c) if d.min_xi < XI_VANISHES => format!(
            "{head}: its xi vanishes, so it is not a regular minimum; the least control with \
             |xi| = {:.0e} tried, along {}, costs {} (more: too large an |xi| for this problem's \
             scales to show the collapse), and the BVP does not converge from it",
            c.eps,
            c.motion.describe(),
            Cost(c.cost)
        ),
        Some(c) => format!(
            "{head} (a regular minimum: the least control with a vanishing xi, along {}, costs \
             {}), but the BVP does not converge from it",
            c.motion.describe(),
            Cost(c.cost)
        ),
        None => match along_direct {
            Err(e) => format!("{head} (its motion with a vanishing xi: {e})"),
            Ok(_) => head,
        },
    };
    if let RelaxedOutcome::Computed {
        intervals, costs, ..
    } = &relaxed
    {
        finding.push_str(&format!(
            "; the relaxed problem (the limit xi -> 0) has its minimum at J = {:.8} on {} \
             intervals ({:.8} on {})",
            costs[1], intervals[1], costs[0], intervals[0]
        ));
    }
    let found = least.map(|least| CollapseEvidence {
        controls,
        least,
        compared_cost: d.cost,
        compared_with: "the direct method's minimum of the transcribed problem",
        undercuts: collapses,
        relaxed: Some(relaxed),
        no_optimal_time: false,
        sentence: finding.clone(),
        // A regular minimum (`!collapses`): the direct minimum is cheaper than every control
        // with a vanishing ξ, beyond its quadrature (the test of `compare_direct`).
        cheaper_discrete: (!collapses).then_some(d.cost),
    });
    (finding, found)
}

/// The BVP from the direct minimum `start`: with `κ` recovered from the SQP's multipliers,
/// and when that does not converge, with `κ = 0`. Neither is right everywhere: corpus
/// problem fast-198's BVP converges only with `κ` recovered (session 17), fast-199's only
/// with `κ = 0` (its `κ` is at most 1.2e-5 at the solution; the fit gives up to 2.0e-5 on
/// 100 intervals). The first error is returned when both fail.
fn direct_warm_solve<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    start: &DirectStart,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, LieSolveError<M>> {
    let first = warm_solve(problem, options, &start.warm, WarmOrigin::Direct, events);
    match first {
        Err(e) if start.kappa_fitted && !options.stopped() => {
            let mut zero = start.warm.clone();
            for y in zero.states.chunks_exact_mut(M::N_STATE) {
                y[M::KAPPA].fill(0.0);
            }
            warm_solve(problem, options, &zero, WarmOrigin::Direct, events).map_err(|_| e)
        }
        first => first,
    }
}

/// Which costates [`direct_warm_solve`] tried, for messages.
fn kappa_tried(start: &DirectStart) -> &'static str {
    if start.kappa_fitted {
        " (kappa fitted to the multipliers, and kappa = 0)"
    } else {
        " (kappa = 0)"
    }
}

/// One attempt of [`direct_route`] on `intervals` intervals in the transcription `form`: the
/// verified solution and its cost. When the BVP does not converge from the SQP's minimum, the
/// same minimum refined to a [`DIRECT_RETRY_FACTOR`] times finer mesh (a few SQP iterations
/// from it, its points interpolated) is tried, and again, up to
/// [`DIRECT_MAX_REFINED_INTERVALS`]: corpus problem fast-198's BVP converges from its minimum
/// on 200 intervals, not on 100; spiral-129's on 400, not on 200.
fn direct_attempt<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    intervals: usize,
    form: DirectForm,
    events: &mut dyn FnMut(&Event),
) -> Result<(LieSolution<M>, f64), DirectFailure<M>> {
    let mut start = super::direct::direct_start_in(problem, intervals, DirectGuess::Segment, form)
        .map_err(|e| DirectFailure::new(e.to_string()))?;
    let mut stop = None;
    // A BVP stop past the start (a partial at the target weights), the refined minimum's
    // preferred.
    let keep_stop = |e: LieSolveError<M>, stop: &mut Option<Box<LieSolveError<M>>>| {
        if matches!(e, LieSolveError::StageFailed { .. }) {
            *stop = Some(Box::new(e));
        }
    };
    let mut solved = match direct_warm_solve(problem, options, &start, events) {
        Ok(sol) => Ok(sol),
        Err(e) => {
            let why = format!(
                "the SQP found a minimum of the transcribed problem (cost {:.6e}, min |xi| \
                 {:.2e}), but the BVP from it{} stopped: {e}",
                start.cost,
                start.min_xi,
                kappa_tried(&start)
            );
            keep_stop(e, &mut stop);
            Err(why)
        }
    };
    let mut finer = intervals;
    while let Err(why) = &mut solved {
        finer *= DIRECT_RETRY_FACTOR;
        if finer > DIRECT_MAX_REFINED_INTERVALS || options.stopped() {
            break;
        }
        match super::direct::refine_start(problem, &start, finer, form) {
            Ok(refined) => {
                match direct_warm_solve(problem, options, &refined, events) {
                    Ok(sol) => solved = Ok(sol),
                    Err(e) => {
                        why.push_str(&format!(
                            "; refined to {finer} intervals (cost {:.6e}), the BVP from it{} \
                             stopped: {e}",
                            refined.cost,
                            kappa_tried(&refined)
                        ));
                        keep_stop(e, &mut stop);
                    }
                }
                start = refined;
            }
            Err(e) => {
                why.push_str(&format!("; refining it to {finer} intervals: {e}"));
                break;
            }
        }
    }
    let failed = |why: String, start: DirectStart, stop| DirectFailure {
        why,
        minimum: Some(Box::new(start)),
        stop,
    };
    let sol = match solved {
        Ok(sol) => sol,
        Err(why) => return Err(failed(why, start, stop)),
    };
    let checked = super::verify::verify_solution(&sol);
    match checked.verification.verdict() {
        super::checks::Verdict::Verified => Ok((sol, checked.diagnostics.cost)),
        super::checks::Verdict::Unverified { reason } => Err(failed(
            format!("the BVP from the SQP's minimum failed the checks: {reason}"),
            start,
            None,
        )),
    }
}

/// The name of the value-function route of a free-time problem (module docs).
pub const TIME_SCAN: &str = "fixed-time scan";

/// The terminal times of the value-function scan, as multiples of the problem's `b_p − a`
/// (the desired path is the problem's, also beyond its own interval).
pub const TIME_SCAN_FACTORS: &[f64] = &[0.125, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 4.0, 8.0];

/// Where `J*(T)` still falls at an end of [`TIME_SCAN_FACTORS`], the scan continues `b − a`
/// past it by these factors (divided at the short end, multiplied at the long end) while
/// `J*` keeps falling.
pub const TIME_SCAN_EXTENSION: &[f64] = &[2.0, 4.0, 8.0];

/// Fewest verified samples from which the scan calls `J*(T)` monotone.
const TIME_SCAN_MIN_SOLVED: usize = 3;

/// One sample of the value function `J*(T)`: the fixed-time problem with `b − a = T`.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeSample {
    /// `T = b − a`.
    pub span: f64,
    /// The verified optimal cost `J*(T)` (the time weight's `δ T` included), or `None`.
    pub cost: Option<f64>,
    /// Why there is no cost (the solve stopped, or its solution failed its checks).
    pub stopped: Option<String>,
    /// Whether the sample was reached by continuation in `b − a` from the fixed-time solution
    /// at `b_p` (else it was solved from its own analytic start).
    pub continued: bool,
}

/// What the value-function scan found when it could not lead to a free-time solution.
struct TimeScanFinding {
    samples: Vec<TimeSample>,
    finding: String,
}

/// A sample of the value-function scan with its verified solution, if any.
type Sampled<M> = (TimeSample, Option<LieSolution<M>>);

/// What one side of the value-function scan ([`time_scan`]) found: the samples it reached
/// (by index of [`TIME_SCAN_FACTORS`]), where its continuation stopped and why, what its last
/// solution showed there, and the samples past the factors' end.
struct SideScan<M: Model> {
    found: Vec<(usize, Sampled<M>)>,
    ended: Option<(usize, String)>,
    edge: Option<String>,
    beyond: Vec<Sampled<M>>,
}

impl<M: Model> Default for SideScan<M> {
    fn default() -> Self {
        Self {
            found: Vec::new(),
            ended: None,
            edge: None,
            beyond: Vec::new(),
        }
    }
}

/// The value-function route of a free-time problem whose time stage stopped: solve the
/// fixed-time problems `T = f (b_p − a)`, `f` in [`TIME_SCAN_FACTORS`], at the target weights;
/// if the verified costs `J*(T)` have an interior minimum, solve the free-time problem from
/// the fixed-time solution there (the time weight at its target, `T` unknown), else say where
/// the optimal time lies (below the shortest or above the longest `T` solved, with the samples
/// as evidence).
///
/// The continuations toward shorter and longer `T` run on two threads, and the samples they
/// do not reach, each from its own start, on as many threads as the machine has cores: the
/// samples are independent, so the result is that of one after the other.
fn time_scan<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, TimeScanFinding> {
    let t_p = problem.terminal.initial() - problem.t0;
    let fixed_options = SolveOptions {
        max_routes: options.max_routes.min(2),
        ..options.clone()
    };
    let verified = |sol: LieSolution<M>, continued: bool| {
        let checked = super::verify::verify_solution(&sol);
        if checked.verification.passed() {
            let cost = checked.diagnostics.cost;
            (
                TimeSample {
                    span: sol.t_span,
                    cost: Some(cost),
                    stopped: None,
                    continued,
                },
                Some(sol),
            )
        } else {
            (
                TimeSample {
                    span: sol.t_span,
                    cost: None,
                    stopped: Some(match checked.verification.verdict() {
                        crate::lie::checks::Verdict::Unverified { reason } => {
                            format!("unverified: {reason}")
                        }
                        crate::lie::checks::Verdict::Verified => "unverified".to_string(),
                    }),
                    continued,
                },
                None,
            )
        }
    };
    // A fixed-time problem solved from its own analytic start (the routes inside each solve
    // are its own business; the samples are reported).
    let own = |span: f64| {
        let mut fixed = problem.clone();
        fixed.terminal = TerminalTime::Fixed(problem.t0 + span);
        match solve_cold(&fixed, &fixed_options, Evidence::None, &mut |_| {}) {
            Ok(sol) => verified(sol, false),
            Err(e) => (
                TimeSample {
                    span,
                    cost: None,
                    stopped: Some(e.to_string()),
                    continued: false,
                },
                None,
            ),
        }
    };
    let n = TIME_SCAN_FACTORS.len();
    let mut found: Vec<Option<(TimeSample, Option<LieSolution<M>>)>> = vec![None; n];
    // Where the continuation of a side stopped: the sample it was heading for, and why.
    let mut ended: Vec<(usize, String)> = Vec::new();
    // Where the continuation toward shorter (index 0) and longer (1) b − a stopped, and what
    // its last solution showed there.
    let mut edge: [Option<String>; 2] = [None, None];
    // From the fixed-time solution at b_p, continue b − a down and up through the factors
    // (the samples then lie on one branch); where the continuation stops, the remaining
    // samples of that side are solved from their own starts.
    let centre = TIME_SCAN_FACTORS.iter().position(|f| *f == 1.0);
    // The sample at the homotopy's current b − a: polished (a copy) and verified.
    let sample_here = |h: &Homotopy<'_, M>| {
        let mut polished = h.clone();
        match polished.finish(options, &|tol| bvp_options(options, tol), &mut |_| {}) {
            Ok(done) => verified(done, true),
            Err(e) => (
                TimeSample {
                    span: h.t_span,
                    cost: None,
                    stopped: Some(e.to_string()),
                    continued: true,
                },
                None,
            ),
        }
    };
    // Samples beyond the factors' ends (index 0: shorter, 1: longer), while J* keeps falling.
    let mut beyond: [Vec<(TimeSample, Option<LieSolution<M>>)>; 2] = [Vec::new(), Vec::new()];
    if let Some(k) = centre {
        let (sample, sol) = own(t_p);
        if let Some(sol) = &sol {
            found[k] = Some((sample.clone(), None));
            let centre_cost = sample.cost;
            // One side of the scan: the continuation from b_p through `indices`, then past
            // their end while J* still falls.
            let side_scan = |side: usize, indices: Vec<usize>| {
                let mut scan = SideScan::<M>::default();
                let mut h = horizon_homotopy(problem, options, sol);
                let mut completed = true;
                for &i in &indices {
                    if let Err(e) = h.horizon_stage(TIME_SCAN_FACTORS[i] * t_p, options) {
                        scan.edge = horizon_edge::<M>(&e);
                        scan.ended = Some((i, e.to_string()));
                        completed = false;
                        break;
                    }
                    scan.found.push((i, sample_here(&h)));
                }
                // Past the end while J* still falls toward it: the optimal time may lie
                // beyond the factors; continue T (no own starts) until J* rises again or the
                // branch stops, which the finding then names.
                let cost_at = |i: usize| {
                    if i == k {
                        return centre_cost;
                    }
                    scan.found
                        .iter()
                        .find(|(j, _)| *j == i)
                        .and_then(|(_, f)| f.0.cost)
                };
                let (end, before) = match indices.as_slice() {
                    [.., before, end] => (*end, *before),
                    [end] => (*end, k),
                    [] => return scan,
                };
                let mut last = match (cost_at(end), cost_at(before)) {
                    (Some(j_end), Some(j_before)) if completed && j_end < j_before => Some(j_end),
                    _ => None,
                };
                let end_span = TIME_SCAN_FACTORS[end] * t_p;
                for f in TIME_SCAN_EXTENSION {
                    let Some(previous) = last else { break };
                    let span = if side == 0 {
                        end_span / f
                    } else {
                        end_span * f
                    };
                    if let Err(e) = h.horizon_stage(span, options) {
                        scan.edge = horizon_edge::<M>(&e);
                        break;
                    }
                    let (sample, sol) = sample_here(&h);
                    last = sample.cost.filter(|j| *j < previous);
                    scan.beyond.push((sample, sol));
                }
                scan
            };
            // The two sides are independent: each continues from the solution at b_p, on its
            // own thread (the results are those of one after the other).
            let down: Vec<usize> = (0..k).rev().collect();
            let up: Vec<usize> = (k + 1..n).collect();
            let sides: Vec<SideScan<M>> = std::thread::scope(|scope| {
                let side_scan = &side_scan;
                let handles: Vec<_> = [down, up]
                    .into_iter()
                    .enumerate()
                    .map(|(side, indices)| scope.spawn(move || side_scan(side, indices)))
                    .collect();
                handles
                    .into_iter()
                    .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                    .collect()
            });
            for (side, scan) in sides.into_iter().enumerate() {
                for (i, got) in scan.found {
                    found[i] = Some(got);
                }
                ended.extend(scan.ended);
                edge[side] = scan.edge;
                beyond[side] = scan.beyond;
            }
        }
        found[k] = Some((sample, sol));
    }
    // The samples the continuation did not reach, each solved from its own start, on as many
    // threads as the machine has cores (each taking the next).
    let missing: Vec<usize> = (0..n).filter(|&i| found[i].is_none()).collect();
    let workers = std::thread::available_parallelism()
        .map_or(1, |c| c.get())
        .clamp(1, missing.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let solved_own: Vec<(usize, Sampled<M>)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                let (missing, next, own) = (&missing, &next, &own);
                scope.spawn(move || {
                    let mut done = Vec::new();
                    loop {
                        let j = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&i) = missing.get(j) else {
                            break done;
                        };
                        done.push((i, own(TIME_SCAN_FACTORS[i] * t_p)));
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    });
    for (i, got) in solved_own {
        found[i] = Some(got);
    }
    let mut samples = Vec::new();
    let mut solved: Vec<(f64, f64, LieSolution<M>)> = Vec::new();
    let [shorter, longer] = beyond;
    // Every factor has its sample now (continued, or from its own start above).
    let main = found
        .into_iter()
        .enumerate()
        .filter_map(|(i, got)| got.map(|g| (i, g)))
        .map(|(i, (mut sample, sol))| {
            if let (Some(why), Some((_, ended))) =
                (&mut sample.stopped, ended.iter().find(|e| e.0 == i))
            {
                *why = format!(
                    "the continuation in b - a from b_p stopped before it: {ended}; its own \
                     homotopy: {why}"
                );
            }
            (sample, sol)
        })
        .collect::<Vec<_>>();
    for (sample, sol) in shorter.into_iter().rev().chain(main).chain(longer) {
        if let (Some(cost), Some(sol)) = (sample.cost, sol) {
            solved.push((sample.span, cost, sol));
        }
        samples.push(sample);
    }
    let listed = samples
        .iter()
        .map(|s| match s.cost {
            Some(j) => format!("J*({:.4}) = {j:.6}", s.span),
            None => format!("J*({:.4}) = -", s.span),
        })
        .collect::<Vec<_>>()
        .join(", ");
    let Some(best) = (0..solved.len()).min_by(|&i, &j| solved[i].1.total_cmp(&solved[j].1)) else {
        return Err(TimeScanFinding {
            samples,
            finding: format!(
                "no fixed-time problem with b - a in [{:.4}, {:.4}] solved either ({listed})",
                TIME_SCAN_FACTORS[0] * t_p,
                TIME_SCAN_FACTORS[TIME_SCAN_FACTORS.len() - 1] * t_p
            ),
        });
    };
    let (lo, hi) = (solved[0].0, solved[solved.len() - 1].0);
    let interior = best > 0 && best + 1 < solved.len();
    if !interior && solved.len() < TIME_SCAN_MIN_SOLVED {
        let tried = samples.len();
        return Err(TimeScanFinding {
            samples,
            finding: format!(
                "too few fixed-time problems solved ({} of {}) to locate the optimal terminal \
                 time ({listed})",
                solved.len(),
                tried
            ),
        });
    }
    if !interior {
        let (side, mut bound) = if best == 0 {
            (
                "increases",
                format!("below {lo:.4}, the shortest b - a solved"),
            )
        } else {
            (
                "decreases",
                format!("above {hi:.4}, the longest b - a solved"),
            )
        };
        if let Some(edge) = &edge[usize::from(best != 0)] {
            bound.push_str(&format!("; continuing b - a from b_p {}", edge));
        }
        return Err(TimeScanFinding {
            samples,
            finding: format!(
                "the optimal terminal time is outside the range where fixed-time problems \
                 solve: the fixed-time value function J*(T) {side} with T = b - a over \
                 [{lo:.4}, {hi:.4}] ({} samples), so the optimal b - a lies {bound} ({listed})",
                solved.len()
            ),
        });
    }
    // An interior minimum: the free-time problem from the fixed-time solution there.
    let (span, cost, sol) = solved.swap_remove(best);
    match free_from_fixed(problem, options, &sol, events) {
        Ok(free) => Ok(free),
        Err(e) => Err(TimeScanFinding {
            samples,
            finding: format!(
                "the fixed-time value function J*(T) has its smallest sample at T = b - a = \
                 {span:.4} (J = {cost:.6}; {listed}), but the free-time solve from there \
                 stopped: {e}"
            ),
        }),
    }
}

/// What the value-function scan's continuation in `b − a` showed where it stopped (`e`, the
/// horizon stage's error): the `b − a` reached and, from its last solution, a collapse of `ξ`
/// or the folds passed.
fn horizon_edge<M: Model>(e: &LieSolveError<M>) -> Option<String> {
    let LieSolveError::StageFailed {
        reached, partial, ..
    } = e
    else {
        return None;
    };
    let (min_xi, _) = xi_extent::<M>(&partial.bvp);
    let folds = partial.stages.last().map_or(0, |s| s.folds.len());
    let mut what = format!("stopped at b - a = {reached:.4}");
    if min_xi < XI_COLLAPSE {
        what.push_str(&format!(", where xi collapses (min |xi| {min_xi:.3})"));
    } else if folds > 0 {
        what.push_str(&format!(" after {folds} fold(s) of the branch"));
    }
    Some(what)
}

/// The free-time problem solved from `fixed`, a solution of the same problem at a fixed
/// terminal time (the target weights): `T` becomes an unknown.
fn free_from_fixed<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    fixed: &LieSolution<M>,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, LieSolveError<M>> {
    let span = fixed.t_span;
    let mu = LieBvp::new(&fixed.problem)
        .mu_index()
        .map_or(0.0, |i| fixed.bvp.p[i]);
    let mut h = Homotopy {
        fixed_span: None,
        ..horizon_homotopy(problem, options, fixed)
    };
    let free = h.bvp_with(h.params.clone(), None);
    let guess = Guess::from_solution(&h.solution).with_parameters(free.parameters(span, mu));
    let bvp_opts = |tol: f64| bvp_options(options, tol);
    h.single_solve(
        "free time from J*(T)",
        &guess,
        &bvp_opts(options.continuation_tol),
        events,
    )?;
    h.finish(options, &bvp_opts, events)
}

/// A previous solution to start from ([`solve_from`]): the states at increasing physical
/// times from the problem's `t0` to the previous terminal time (any grid, e.g. the rows of a
/// previous `trajectory.csv`, which `solver.start_from` reads).
#[derive(Debug, Clone, PartialEq)]
pub struct WarmStart {
    /// Times `t_0 < t_1 < … < t_m`, at least two.
    pub times: Vec<f64>,
    /// The states at those times, row-major, [`Model::N_STATE`] per time in the model's
    /// layout (`trajectory.csv`'s state columns).
    pub states: Vec<f64>,
}

/// Where a warm start comes from (it names the route's stage and start).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum WarmOrigin {
    /// The caller's previous solution ([`solve_from`]).
    Previous,
    /// The direct start ([`super::direct`]).
    Direct,
}

/// The name under which [`solve_from`] reports the warm start in [`LieSolution::routes`].
pub const WARM_START_ROUTE: &str = "warm start";

/// Solve `problem` starting from `warm`, a solution of a nearby problem (other weights, end
/// point, horizon): one BVP solve at the continuation tolerance from it, then the usual
/// polish and a-posteriori checks, skipping the homotopy. When that fails, or the result does
/// not pass its checks, the homotopy runs from the analytic start as usual, and the warm start
/// is listed first among the routes with the reason it stopped. [`solve`] calls this when
/// [`SolveOptions::warm_start`] is set.
pub fn solve_from<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    warm: &WarmStart,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, LieSolveError<M>> {
    let clock = std::time::Instant::now();
    let stopped = match warm_solve(problem, options, warm, WarmOrigin::Previous, events) {
        Ok(mut sol) => match super::verify::verify_solution(&sol).verification.verdict() {
            super::checks::Verdict::Verified => {
                sol.routes.push(RouteReport {
                    route: WARM_START_ROUTE,
                    stopped: None,
                    seconds: clock.elapsed().as_secs_f64(),
                });
                return Ok(sol);
            }
            super::checks::Verdict::Unverified { reason } => {
                format!("its solution failed the checks: {reason}")
            }
        },
        Err(e) => e.to_string(),
    };
    let warm_report = RouteReport {
        route: WARM_START_ROUTE,
        stopped: Some(stopped.clone()),
        seconds: clock.elapsed().as_secs_f64(),
    };
    events(&Event::RouteStarted {
        route: Route::DEFAULT.name,
        after: &stopped,
    });
    let mut result = solve_cold(problem, options, Evidence::Collapse, events);
    match &mut result {
        Ok(sol) => sol.routes.insert(0, warm_report),
        Err(LieSolveError::StageFailed { partial, .. }) => partial.routes.insert(0, warm_report),
        Err(_) => {}
    }
    result
}

/// The warm start's solves: the guess from `warm` rescaled to `s ∈ [0, 1]`, one solve at the
/// continuation tolerance with the problem's own weights and end point, then
/// [`Homotopy::finish`].
fn warm_solve<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    warm: &WarmStart,
    origin: WarmOrigin,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, LieSolveError<M>> {
    let bad = |why: String| LieSolveError::start(format!("the warm start: {why}"));
    let (times, n) = (&warm.times, M::N_STATE);
    if times.len() < 2 || warm.states.len() != times.len() * n {
        return Err(bad(format!(
            "{} times and {} state values; it needs at least 2 times and {n} values per time",
            times.len(),
            warm.states.len()
        )));
    }
    if times.iter().any(|t| !t.is_finite())
        || times.windows(2).any(|w| w[1] <= w[0])
        || warm.states.iter().any(|v| !v.is_finite())
    {
        return Err(bad(
            "its times must increase strictly and its states be finite numbers".into(),
        ));
    }
    let (first, last) = (times[0], times[times.len() - 1]);
    if (first - problem.t0).abs() > 1e-9 * (1.0 + problem.t0.abs()) {
        return Err(bad(format!(
            "it starts at t = {first}, the problem at t0 = {}; start both at the same time",
            problem.t0
        )));
    }
    let previous_span = last - first;
    let (fixed_span, t_span) = match problem.terminal {
        TerminalTime::Fixed(b) => (Some(b - problem.t0), b - problem.t0),
        TerminalTime::Free { .. } => (None, previous_span),
    };
    // The previous trajectory stretched onto the new horizon: s = (t - t0) / (b_prev - t0).
    let x: Vec<f64> = times.iter().map(|t| (t - first) / previous_span).collect();
    let params = problem.params().to_vec();
    let bvp: LieBvp<'_, M> = LieBvp {
        start_constraint: !crate::model::constraint_value_vanishes::<M>(&params),
        params: params.clone(),
        omega_a: &problem.omega_a,
        omega_b: problem.omega_b.clone(),
        t0: problem.t0,
        fixed_span,
        level_shift: 0.0,
        desired: &*problem.desired,
        model: std::marker::PhantomData,
    };
    let guess = Guess::from_values(x, warm.states.clone(), vec![])
        .with_parameters(bvp.parameters(t_span, 0.0));
    let bvp_opts = |tol: f64| bvp_options(options, tol);
    let (name, omega_p) = match origin {
        WarmOrigin::Previous => (WARM_START_ROUTE, "a previous solution (warm start)"),
        WarmOrigin::Direct => (
            DIRECT_START_ROUTE,
            "the direct method's minimum (SQP on the transcribed problem)",
        ),
    };
    let clock = std::time::Instant::now();
    events(&Event::StageStarted {
        name,
        from: 0.0,
        to: 0.0,
    });
    let sol = bvp::solve_with_progress(
        &bvp,
        &guess,
        &bvp_opts(options.continuation_tol),
        &mut |progress| {
            events(&Event::Bvp {
                stage: name,
                lambda: 0.0,
                progress,
            })
        },
    )?;
    let report = single_solve_report(name, &sol, clock.elapsed().as_secs_f64());
    events(&Event::StageFinished(&report));
    if !sol.is_success() {
        return Err(bad(format!(
            "the solve from it stopped: {}",
            bvp_failure(sol.status)
        )));
    }
    let t_span = match fixed_span {
        Some(span) => span,
        None => sol.p[SPAN],
    };
    let mut h = Homotopy {
        problem,
        params,
        omega_b: problem.omega_b.clone(),
        level_shift: 0.0,
        fixed_span,
        t_span,
        solution: sol,
        start: StartChoice {
            omega_p,
            case: 0,
            b_p: problem.t0 + previous_span,
            beta_m: f64::NAN,
            desired_energy_deviation: f64::NAN,
        },
        stages: vec![report],
        tolerance: options.tol,
        tracking: remembered(&problem.desired),
    };
    h.finish(options, &bvp_opts, events)
}

/// The stage record of one BVP solve (no continuation): a single step, completed or stopped
/// with the solver's reason.
fn single_solve_report(name: &'static str, sol: &Solution, seconds: f64) -> StageReport {
    StageReport {
        name,
        parameter: "-",
        from: 0.0,
        to: 0.0,
        steps: usize::from(sol.is_success()),
        failures_recovered: 0,
        newton_iterations: sol.stats.newton_iterations,
        nodes: sol.num_nodes(),
        seconds,
        folds: Vec::new(),
        outcome: if sol.is_success() {
            StageOutcome::Completed
        } else {
            StageOutcome::Stopped {
                reason: bvp_failure(sol.status),
            }
        },
    }
}

/// The BVP solver's options for a solve at `tol`.
fn bvp_options(options: &SolveOptions, tol: f64) -> bvp::Options {
    bvp::Options {
        tol,
        max_nodes: options.max_nodes,
        ..Default::default()
    }
}

/// The options of the homotopy's natural continuation (a failed Newton solve shortens the
/// step at once: no mesh refinement inside a step).
fn continuation_options(options: &SolveOptions) -> continuation::Options {
    continuation::Options {
        bvp: bvp::Options {
            max_newton_failures: 0,
            max_newton_iter: 15,
            ..bvp_options(options, options.continuation_tol)
        },
        initial_step: Some(0.2),
        stop: options.stop.as_ref().map(|s| s.0.clone()),
        ..Default::default()
    }
}

/// The homotopy standing on `fixed`, a verified solution of `problem` at a fixed terminal
/// time with the target weights, ready to continue its `b − a` ([`Homotopy::horizon_stage`])
/// or to free it ([`free_from_fixed`]).
fn horizon_homotopy<'p, M: Model>(
    problem: &'p Problem<M>,
    options: &SolveOptions,
    fixed: &LieSolution<M>,
) -> Homotopy<'p, M> {
    Homotopy {
        problem,
        params: problem.params().to_vec(),
        omega_b: problem.omega_b.clone(),
        level_shift: 0.0,
        fixed_span: Some(fixed.t_span),
        t_span: fixed.t_span,
        solution: fixed.bvp.clone(),
        start: fixed.start.clone(),
        stages: fixed.stages.clone(),
        tolerance: options.tol,
        tracking: remembered(&problem.desired),
    }
}

/// [`SHORTER_HORIZON`]: `route` (with the problem's own horizon) on `problem` with
/// `b − a`, or its guess, `route.horizon_factor` times the problem's, and if that stops at each
/// smaller factor of [`HORIZON_FACTORS`] in turn; for a fixed `b`, `b − a` is then continued to
/// the problem's ([`Homotopy::horizon_stage`]) and the solution polished and checked. A stop
/// is reported as the route's failed start, with why each factor stopped (its partial
/// solution, at another horizon, is no evidence about the problem's own).
fn shorter_horizon<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    route: &Route,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, LieSolveError<M>> {
    let span = problem.terminal.initial() - problem.t0;
    let own = Route {
        horizon_factor: 1.0,
        ..*route
    };
    let mut stops = Vec::new();
    let factors = std::iter::once(route.horizon_factor).chain(
        HORIZON_FACTORS
            .into_iter()
            .filter(|f| *f < route.horizon_factor),
    );
    for factor in factors {
        if options.stopped() {
            break;
        }
        let short_span = factor * span;
        let mut short = problem.clone();
        short.terminal = match problem.terminal {
            TerminalTime::Fixed(_) => TerminalTime::Fixed(problem.t0 + short_span),
            TerminalTime::Free { .. } => TerminalTime::Free {
                guess: problem.t0 + short_span,
            },
        };
        let attempt = solve_route(&short, options, &own, events).and_then(|mut sol| {
            match problem.terminal {
                TerminalTime::Free { .. } => {
                    // The same problem from another guess: the solution is the problem's.
                    sol.problem.terminal = problem.terminal;
                    Ok(sol)
                }
                TerminalTime::Fixed(_) => {
                    let mut h = horizon_homotopy(problem, options, &sol);
                    h.horizon_stage(span, options)?;
                    h.finish(options, &|tol| bvp_options(options, tol), events)
                }
            }
        });
        match attempt {
            Ok(sol) => return Ok(sol),
            Err(e) => stops.push(format!("from b - a = {short_span}: {e}")),
        }
    }
    Err(LieSolveError::start(format!(
        "the shorter horizons (the problem's b - a = {span} times {}): {}",
        route.horizon_factor,
        stops.join("; ")
    )))
}

/// How much tighter the `refine` stages solve a solution that failed its a-posteriori checks
/// (in turn, until one passes them).
pub const REFINE_FACTORS: [f64; 2] = [1e-1, 1e-2];

/// Solve `problem` along one route (module docs).
fn solve_route<M: Model>(
    problem: &Problem<M>,
    options: &SolveOptions,
    route: &Route,
    events: &mut dyn FnMut(&Event),
) -> Result<LieSolution<M>, LieSolveError<M>> {
    if route.horizon_factor != 1.0 {
        return shorter_horizon(problem, options, route, events);
    }
    let p = problem.params();
    let beta = one_with_role::<M>(HomotopyRole::Beta)?.ok_or_else(|| LieSolveError::Roles {
        model: M::NAME,
        what: "no weight has the homotopy role Beta (the control effort the start needs)".into(),
    })?;
    let tracking = one_with_role::<M>(HomotopyRole::Tracking)?;
    let time = one_with_role::<M>(HomotopyRole::Time)?;
    let smoothing: Vec<usize> = M::WEIGHTS
        .iter()
        .filter(|w| w.role == HomotopyRole::Smoothing)
        .map(|w| w.index)
        .collect();
    if time.is_none() && matches!(problem.terminal, TerminalTime::Free { .. }) {
        return Err(LieSolveError::Roles {
            model: M::NAME,
            what: "a free terminal time needs a weight with the homotopy role Time".into(),
        });
    }
    let gamma = tracking.map_or(0.0, |i| p[i]);
    let b_p = problem.terminal.initial();
    let t_p = b_p - problem.t0;
    // Stages 1-4 solve the problem without its constraint value, ending at Ω_b⁰ (module docs).
    if M::CONSTRAINT_VALUE_DEPENDS_ON_XI && !problem.conserves_energy() {
        return Err(LieSolveError::Unsupported(format!(
            "model {}: the constraint value gamma(xi) depends on xi; the homotopy continues \
             constant constraint values only (they leave Suslov's equations unchanged)",
            M::NAME
        )));
    }
    let base = constraint_free(problem)?;
    let beta_m = if route.beta_m_at_beta {
        p[beta]
    } else {
        route.beta_m_factor
            * options.beta_m.unwrap_or_else(|| {
                // 1e-2 · min(fixed positive weights, β, γ or 1): for so(3), 1e-2 min(α, β, γ or 1).
                let g = if gamma > 0.0 { gamma } else { 1.0 };
                M::WEIGHTS
                    .iter()
                    .filter(|w| w.role == HomotopyRole::Fixed && p[w.index] > 0.0)
                    .map(|w| p[w.index])
                    .fold(p[beta].min(g), f64::min)
                    * 1e-2
            })
    };
    let strategy = route.start.unwrap_or(options.start);
    let (omega_p, start) = choose_start(&base, b_p, beta_m, gamma > 0.0, strategy)?;

    let mut params = base.params().to_vec();
    params[beta] = beta_m;
    let fixed: Vec<usize> = M::WEIGHTS
        .iter()
        .filter(|w| w.role == HomotopyRole::Fixed && p[w.index] > 0.0)
        .map(|w| w.index)
        .collect();
    for &i in &fixed {
        params[i] *= route.fixed_factor;
    }
    for &i in &smoothing {
        params[i] = 0.0;
    }
    if let Some(i) = time {
        params[i] = 0.0;
    }
    if let Some(i) = tracking {
        params[i] = match start.case {
            1 => 1.0,
            2 => 0.0,
            _ => gamma,
        };
    }
    let n = M::DIM;
    // A finer route's mesh stays below half the node cap.
    let m = (options.initial_intervals * route.mesh_factor)
        .min(options.initial_intervals.max(options.max_nodes / 2))
        .max(2);
    let x: Vec<f64> = (0..=m).map(|i| i as f64 / m as f64).collect();
    let mut bad = None;
    let start_bvp = LieBvp::<M> {
        params: params.clone(),
        omega_a: &base.omega_a,
        omega_b: base.omega_b.clone(),
        t0: base.t0,
        fixed_span: Some(t_p),
        desired: &*base.desired,
        start_constraint: !base.conserves_energy(), // false: base has no constraint value
        level_shift: 0.0,
        model: std::marker::PhantomData,
    };
    // μ = 0: the start lies on the constraint level φ = 0 (ξ_p is along ξ~ ⊥ Ω_p).
    let guess = Guess::from_fn(&x, M::N_STATE, start_bvp.parameters(t_p, 0.0), |s, out| {
        let t = problem.t0 + s * t_p;
        with_buffer(4 * n + 2 * n, |buf| {
            let (jet, xi) = buf.split_at_mut(4 * n);
            omega_p.jet_into(t, jet);
            // [Ω_p, Ω̇_p, Ω̈_p] in, [ξ_p, ξ̇_p] out.
            M::singular_control(&jet[..3 * n], &params, xi);
            if xi.iter().any(|v| !v.is_finite()) && bad.is_none() {
                bad = Some(t);
            }
            out[M::OMEGA].copy_from_slice(&jet[..n]);
            out[M::XI].copy_from_slice(&xi[..n]);
            out[M::XIDOT].copy_from_slice(&xi[n..]);
            out[M::KAPPA].fill(0.0);
        });
    });
    if let Some(t) = bad {
        return Err(LieSolveError::start(format!(
            "the singular control xi_p is undefined at t = {t} (Property 3 fails there)"
        )));
    }
    let bvp_opts = |tol: f64| bvp_options(options, tol);
    let cont = continuation_options(options);
    let clock = std::time::Instant::now();
    events(&Event::StageStarted {
        name: "start",
        from: beta_m,
        to: beta_m,
    });
    // Paper's first case: the start and the tracking stage track Ω_p, not Ω_d.
    let tracked = remembered(if start.case == 1 {
        &omega_p
    } else {
        &problem.desired
    });
    let start_bvp = LieBvp::<M> {
        desired: &*tracked,
        ..start_bvp
    };
    let first = bvp::solve_with_progress(
        &start_bvp,
        &guess,
        &bvp_opts(options.continuation_tol),
        &mut |progress| {
            events(&Event::Bvp {
                stage: "start",
                lambda: 0.0,
                progress,
            })
        },
    )?;
    let mut report = StageReport {
        name: "start",
        parameter: "-",
        from: beta_m,
        to: beta_m,
        steps: usize::from(first.is_success()),
        failures_recovered: 0,
        newton_iterations: first.stats.newton_iterations,
        nodes: first.num_nodes(),
        seconds: clock.elapsed().as_secs_f64(),
        outcome: StageOutcome::Completed,
        folds: Vec::new(),
    };
    if !first.is_success() {
        let advice = match first.status {
            // The mesh limits, whatever beta_m is.
            crate::bvp::Status::MaxNodes | crate::bvp::Status::MaxMeshPasses => "",
            _ => "; a smaller or larger `solver.beta_m` may help too",
        };
        let reason = format!(
            "the BVP at beta_m = {} from the analytic singular solution did not converge: \
             {}{advice}",
            Num(beta_m),
            bvp_failure(first.status)
        );
        report.outcome = StageOutcome::Stopped {
            reason: reason.clone(),
        };
        events(&Event::StageFinished(&report));
        return Err(LieSolveError::start(reason));
    }
    events(&Event::StageFinished(&report));
    let mut h = Homotopy {
        problem,
        params,
        omega_b: base.omega_b.clone(),
        level_shift: 0.0,
        fixed_span: Some(t_p),
        t_span: t_p,
        solution: first,
        start,
        stages: vec![report],
        tolerance: options.tol,
        tracking: tracked,
    };

    let beta_target = p[beta];
    let (lo, hi) = (beta_m.ln(), beta_target.ln());
    let beta_at = move |l: f64| {
        if l >= 1.0 {
            beta_target
        } else {
            (lo + l * (hi - lo)).exp()
        }
    };
    // The tracking weight's value at λ of its stage (case 1: 1 → 0, case 2: 0 → γ, case 3: γ).
    let case = h.start.case;
    let tracking_at = move |l: f64| match case {
        1 => 1.0 - l,
        2 => l * gamma,
        _ => gamma,
    };
    let tracking_stage = |h: &mut Homotopy<'_, M>, events: &mut dyn FnMut(&Event)| {
        if let Some(i) = tracking {
            if case != 3 {
                let (from, to) = (tracking_at(0.0), tracking_at(1.0));
                h.stage("gamma", i, from, to, &tracking_at, &cont, events)?;
                h.params[i] = to;
            }
        }
        Ok::<(), LieSolveError<M>>(())
    };
    let beta_stage = |h: &mut Homotopy<'_, M>, events: &mut dyn FnMut(&Event)| {
        if beta_target != beta_m {
            h.stage("beta", beta, beta_m, beta_target, &beta_at, &cont, events)?;
            h.params[beta] = beta_target;
        }
        Ok::<(), LieSolveError<M>>(())
    };
    match route.order {
        StageOrder::Sequential => {
            tracking_stage(&mut h, events)?;
            beta_stage(&mut h, events)?;
        }
        StageOrder::BetaFirst => {
            beta_stage(&mut h, events)?;
            tracking_stage(&mut h, events)?;
        }
        StageOrder::Joint => {
            let smooth = smoothing.clone();
            let weights = move |l: f64, m: &mut Member| {
                if let Some(i) = tracking {
                    m.params[i] = tracking_at(l);
                }
                m.params[beta] = beta_at(l);
                for &i in &smooth {
                    m.params[i] = if l >= 1.0 { p[i] } else { l * p[i] };
                }
                l
            };
            h.stage_with(
                &StageSpec {
                    name: "weights",
                    parameter: "fraction of the way to the weights",
                    from: 0.0,
                    to: 1.0,
                    at: &weights,
                },
                &cont,
                events,
            )?;
            for &i in &smoothing {
                h.params[i] = p[i];
            }
        }
    }
    if case == 1 {
        h.tracking = remembered(&problem.desired); // weight 0 from here on
    }
    for &i in &smoothing {
        let target = p[i];
        if target > 0.0 && h.params[i] != target {
            h.stage("eta", i, 0.0, target, &move |l| l * target, &cont, events)?;
        }
    }
    if route.fixed_factor != 1.0 {
        for &i in &fixed {
            let (from, to) = (h.params[i], p[i]);
            let (lo, hi) = (from.ln(), to.ln());
            let value = move |l: f64| {
                if l >= 1.0 {
                    to
                } else {
                    (lo + l * (hi - lo)).exp()
                }
            };
            h.stage(M::PARAM_NAMES[i], i, from, to, &value, &cont, events)?;
            h.params[i] = to;
        }
    }
    if !problem.conserves_energy() {
        h.constraint_stages(problem, &cont, events)?;
    }
    if let Some(i) = time {
        let target = p[i];
        match problem.terminal {
            // The time weight only shifts the cost at fixed time.
            TerminalTime::Fixed(_) => h.params[i] = target,
            TerminalTime::Free { .. } => {
                let yb = h.solution.eval(1.0);
                let bvp0 = h.bvp_with(h.params.clone(), h.fixed_span);
                let mut wb = vec![0.0; M::N_DESIRED];
                bvp0.desired_at(problem.t0 + t_p, &mut wb);
                let delta_c = M::delta_start(&yb, &h.params, &wb);
                h.params[i] = delta_c;
                h.fixed_span = None;
                let mu = h
                    .bvp_with(h.params.clone(), Some(t_p))
                    .mu_index()
                    .map_or(0.0, |i| h.solution.p[i]);
                let free = h.bvp_with(h.params.clone(), None);
                let guess =
                    Guess::from_solution(&h.solution).with_parameters(free.parameters(t_p, mu));
                h.single_solve(
                    "free-time start",
                    &guess,
                    &bvp_opts(options.continuation_tol),
                    events,
                )?;
                h.stage(
                    "delta",
                    i,
                    delta_c,
                    target,
                    &move |l| delta_c + l * (target - delta_c),
                    &cont,
                    events,
                )?;
            }
        }
    }
    h.finish(options, &bvp_opts, events)
}
