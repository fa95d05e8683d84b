//! Solving a [`SuslovProblem`]: the analytic start and the staged homotopy of paper section 5.2.
//!
//! 1. **Start** (section 5.1). Pick an admissible `Ω_p` (Properties 1–3 on `[a, b_p]`) and
//!    build `y = [Ω_p, ξ_p, ξ̇_p, κ = 0]` with the generated `singular_control`; solve the BVP
//!    with `β = β_m ≪ min(α, β, γ)`, `η = δ = 0` at fixed `T = b_p − a`.
//!    - `γ > 0` and `Ω_d` admissible up to [`ADMISSIBLE_ENERGY_TOL`]: `Ω_p = [Ω_d]_∥` (the
//!      radial projection of `Ω_d` onto `E`), start at the full `γ` (paper's third case).
//!      For the paper's `Ω_d`, which leaves `E` by at most 8.9e-6 (relative energy) near
//!      `t = b_d` because the sigmoid blends two points of `E`, this is the choice:
//!      `|[Ω_d]_∥ − Ω_d| ≤ 1.7e-5`, far below what `β_m` changes.
//!    - `γ > 0`, `Ω_d` further from admissible: `Ω_p = [Ω_d]_∥` if that satisfies
//!      Properties 1 and 3, else the projected segment `Ω_a → Ω_b`; continue `γ` from 0
//!      (paper's second case).
//!    - `γ = 0`: `Ω_p` = projected segment, continue `γ` from 1 to 0 (paper's first case).
//! 2. **β stage**: `β_m → β` (geometric), fixed `T`.
//! 3. **η stage**: `0 → η`, fixed `T`.
//! 4. **δ stage** (free terminal time only): `T` becomes the unknown parameter; `δ` goes from
//!    `δ_c` (generated `delta_start`, eq. `delta_c_rbc`, which makes the free-time condition hold
//!    at the current solution) to `δ`.
//! 5. **Polish**: a final solve at the requested tolerance.
//!
//! Continuation steps run at `continuation_tol`; every stage's record is kept in
//! [`SuslovSolution::stages`]. A failing stage returns [`SolveError::StageFailed`] with the last
//! converged point (a partial result), the stage, the parameter value reached and the reason.

use std::sync::Arc;

use crate::bvp::{self, Guess, Solution};
use crate::continuation;
use crate::model::generated::{
    self as g, idx, DIM, KAPPA, N_PARAM, N_STATE, OMEGA, PARAM_NAMES, XI, XIDOT,
};

use super::desired::{DesiredPath, ProjectedPath, ProjectedSegment};
use super::layout::stack;
use super::problem::{CostWeights, ProblemError, SuslovBvp, SuslovProblem, TerminalTime, SPAN};
use super::properties::check_properties;

/// A solved Suslov problem.
#[derive(Debug, Clone)]
pub struct SuslovSolution {
    /// The problem, with the terminal time found (for a free `b`).
    pub problem: SuslovProblem,
    /// The BVP solution on `s ∈ [0, 1]`.
    pub bvp: Solution,
    /// `T = b − a`.
    pub t_span: f64,
    /// The analytic start.
    pub start: StartChoice,
    /// The homotopy stages, in order.
    pub stages: Vec<StageReport>,
    /// The requested final tolerance ([`SolveOptions::tol`]), which the a-posteriori
    /// verification ([`super::verify`]) judges the solution against (a partial result
    /// carries it too, though it was not reached).
    pub tolerance: f64,
}

impl SuslovSolution {
    /// `b`.
    pub fn terminal_time(&self) -> f64 {
        self.problem.t0 + self.t_span
    }

    /// `y(t) = [Ω, ξ, ξ̇, κ]` at physical time `t ∈ [a, b]`.
    pub fn state(&self, t: f64) -> [f64; N_STATE] {
        let mut y = [0.0; N_STATE];
        self.bvp
            .eval_into((t - self.problem.t0) / self.t_span, &mut y);
        y
    }
}

pub use crate::lie::solve::{
    Event, SolveOptions, StageOutcome, StageReport, StartChoice, StartStrategy,
    ADMISSIBLE_ENERGY_TOL,
};

/// Why [`solve`] failed.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// The problem is invalid.
    #[error("invalid problem: {0}")]
    Invalid(#[from] ProblemError),
    /// No admissible analytic start could be built.
    #[error("cannot build the analytic start: {0}")]
    Start(String),
    /// A stage did not reach its target; `partial` holds the last converged point.
    #[error("stage '{stage}' stopped at {parameter} = {reached} (target {target}): {reason}")]
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
        /// The last converged solution (its problem carries the weights reached).
        partial: Box<SuslovSolution>,
    },
    /// Invalid input reached the BVP solver (a bug in this layer).
    #[error("BVP solver rejected its input: {0}")]
    Bvp(#[from] bvp::BvpError),
}

/// The working state of the homotopy: constants, mode and current solution.
struct Homotopy<'p> {
    problem: &'p SuslovProblem,
    params: [f64; N_PARAM],
    fixed_span: Option<f64>,
    t_span: f64,
    solution: Solution,
    start: StartChoice,
    stages: Vec<StageReport>,
    /// [`SolveOptions::tol`].
    tolerance: f64,
    /// The path the cost tracks: `Ω_p` during the γ stage of the paper's first case
    /// (γ_c: 1 → 0 tracks `Ω_p`, paper section 5.2), `Ω_d` otherwise.
    tracking: Arc<dyn DesiredPath + Send + Sync>,
}

impl Homotopy<'_> {
    fn bvp_with(&self, params: [f64; N_PARAM], fixed_span: Option<f64>) -> SuslovBvp<'_> {
        SuslovBvp {
            params,
            omega_a: self.problem.omega_a.into(),
            omega_b: self.problem.omega_b.into(),
            t0: self.problem.t0,
            fixed_span,
            desired: &*self.tracking,
        }
    }

    fn snapshot(&self) -> SuslovSolution {
        let mut problem = self.problem.clone();
        problem.weights = CostWeights::from_params(&self.params);
        if self.fixed_span.is_none() {
            problem.terminal = TerminalTime::Free {
                guess: problem.t0 + self.t_span,
            };
        }
        SuslovSolution {
            problem,
            bvp: self.solution.clone(),
            t_span: self.t_span,
            start: self.start.clone(),
            stages: self.stages.clone(),
            tolerance: self.tolerance,
        }
    }

    /// Continue parameter `index` (an `idx::*`) of the constants along `value(λ)`, `λ ∈ [0, 1]`.
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
    ) -> Result<(), SolveError> {
        let clock = std::time::Instant::now();
        events(&Event::StageStarted { name, from, to });
        let base = self.params;
        let fixed_span = self.fixed_span;
        let family = |lambda: f64| {
            let mut p = base;
            p[index] = value(lambda);
            self.bvp_with(p, fixed_span)
        };
        // Both callbacks report through `events`; a RefCell lets them share it.
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
        self.params[index] = value(outcome.lambda);
        self.solution = outcome.solution.clone();
        if self.fixed_span.is_none() {
            self.t_span = self.solution.p[SPAN];
        }
        let report = StageReport {
            name,
            from,
            to,
            steps: outcome.steps(),
            failures_recovered: outcome.failures(),
            newton_iterations: outcome.newton_iterations(),
            nodes: self.solution.num_nodes(),
            seconds: clock.elapsed().as_secs_f64(),
            outcome: if outcome.status.is_success() {
                StageOutcome::Completed
            } else {
                StageOutcome::Stopped {
                    reason: outcome.status.to_string(),
                }
            },
        };
        events(&Event::StageFinished(&report));
        self.stages.push(report);
        if let StageOutcome::Stopped { reason } = &self.stages[self.stages.len() - 1].outcome {
            return Err(SolveError::StageFailed {
                stage: name,
                parameter: PARAM_NAMES[index],
                reached: value(outcome.lambda),
                target: to,
                reason: reason.clone(),
                partial: Box::new(self.snapshot()),
            });
        }
        Ok(())
    }

    /// One BVP solve with the current constants from `guess`; a failure is a stage failure.
    fn single_solve(
        &mut self,
        name: &'static str,
        guess: &Guess,
        options: &bvp::Options,
        events: &mut dyn FnMut(&Event),
    ) -> Result<(), SolveError> {
        let clock = std::time::Instant::now();
        events(&Event::StageStarted {
            name,
            from: 0.0,
            to: 0.0,
        });
        let problem = self.bvp_with(self.params, self.fixed_span);
        let sol = bvp::solve_with_progress(&problem, guess, options, &mut |progress| {
            events(&Event::Bvp {
                stage: name,
                lambda: 0.0,
                progress,
            })
        })?;
        let report = StageReport {
            name,
            from: 0.0,
            to: 0.0,
            steps: usize::from(sol.is_success()),
            failures_recovered: 0,
            newton_iterations: sol.stats.newton_iterations,
            nodes: sol.num_nodes(),
            seconds: clock.elapsed().as_secs_f64(),
            outcome: if sol.is_success() {
                StageOutcome::Completed
            } else {
                StageOutcome::Stopped {
                    reason: format!("{:?}: {}", sol.status, sol.status.message()),
                }
            },
        };
        events(&Event::StageFinished(&report));
        self.stages.push(report);
        if let StageOutcome::Stopped { reason } = &self.stages[self.stages.len() - 1].outcome {
            let reason = reason.clone();
            return Err(SolveError::StageFailed {
                stage: name,
                parameter: "-",
                reached: f64::NAN,
                target: f64::NAN,
                reason,
                partial: Box::new(self.snapshot()),
            });
        }
        self.solution = sol;
        if self.fixed_span.is_none() {
            self.t_span = self.solution.p[SPAN];
        }
        Ok(())
    }
}

/// Choose `Ω_p` and the paper case (section 5.2).
fn choose_start(
    problem: &SuslovProblem,
    b_p: f64,
    beta_m: f64,
    strategy: StartStrategy,
) -> Result<(Arc<dyn DesiredPath + Send + Sync>, StartChoice), SolveError> {
    let a = problem.t0;
    let e = problem.ellipsoid();
    let check = |path: &dyn DesiredPath| {
        check_properties(
            path,
            &problem.inertia,
            &problem.omega_a,
            &problem.omega_b,
            (a, b_p),
            4001,
        )
        .map_err(|err| SolveError::Start(err.to_string()))
    };
    let scale = problem.omega_a.norm();
    let desired = check(&*problem.desired)?;
    let projected: Arc<dyn DesiredPath + Send + Sync> = Arc::new(ProjectedPath {
        inner: problem.desired.clone(),
        ellipsoid: e,
    });
    let proj = check(&*projected)?;
    let admissible_ends = |r: &super::properties::PropertyReport| {
        r.start_error <= 1e-9 * scale
            && r.end_error <= 1e-9 * scale
            && r.min_euler_defect > 1e-6 * scale * scale
    };
    let segment = || -> Result<Arc<dyn DesiredPath + Send + Sync>, SolveError> {
        let seg = ProjectedSegment::new(problem.inertia, problem.omega_a, problem.omega_b, a, b_p)
            .map_err(|err| SolveError::Start(err.to_string()))?;
        let r = check(&seg)?;
        if !admissible_ends(&r) {
            return Err(SolveError::Start(format!(
                "the projected segment from omega_a to omega_b violates Property 3 \
                 (min |I Om' - (I Om) x Om| = {:e} at t = {}); give a desired path instead",
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
    let gamma_positive = problem.weights.gamma > 0.0;
    match strategy {
        StartStrategy::Auto => {}
        StartStrategy::Segment => {
            let case = if gamma_positive { 2 } else { 1 };
            return Ok((segment()?, choice("projected segment", case)));
        }
        StartStrategy::Desired | StartStrategy::DesiredGammaFromZero => {
            if !gamma_positive {
                return Err(SolveError::Start(
                    "a start from the desired path needs gamma > 0 (with gamma = 0 the \
                     desired path is not part of the cost); use the segment or auto start"
                        .into(),
                ));
            }
            if !admissible_ends(&proj) {
                return Err(SolveError::Start(format!(
                    "the projected desired path violates Property 1 or 3 on [a, b_p] \
                     (|Omega_p(a) - Omega_a| = {:e}, |Omega_p(b_p) - Omega_b| = {:e}, \
                     min |I Om' - (I Om) x Om| = {:e}); use the segment start",
                    proj.start_error, proj.end_error, proj.min_euler_defect
                )));
            }
            let case = if strategy == StartStrategy::Desired {
                3
            } else {
                2
            };
            return Ok((projected, choice("projected desired path", case)));
        }
    }
    if gamma_positive {
        if admissible_ends(&proj) {
            let case = if desired.max_rel_energy_deviation <= ADMISSIBLE_ENERGY_TOL
                && admissible_ends(&desired)
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

/// Solve `problem` from the analytic singular solution through the staged homotopy.
pub fn solve(
    problem: &SuslovProblem,
    options: &SolveOptions,
    events: &mut dyn FnMut(&Event),
) -> Result<SuslovSolution, SolveError> {
    problem.validate()?;
    let w = problem.weights;
    let b_p = problem.terminal.initial();
    let t_p = b_p - problem.t0;
    let beta_m = options.beta_m.unwrap_or_else(|| {
        let g = if w.gamma > 0.0 { w.gamma } else { 1.0 };
        1e-2 * w.alpha.min(w.beta).min(g)
    });
    let (omega_p, start) = choose_start(problem, b_p, beta_m, options.start)?;

    // Initial guess: the singular solution on a uniform mesh (stages sampled too).
    let mut params = problem.params();
    params[idx::BETA] = beta_m;
    params[idx::ETA] = 0.0;
    params[idx::DELTA] = 0.0;
    params[idx::GAMMA] = match start.case {
        1 => 1.0,
        2 => 0.0,
        _ => w.gamma,
    };
    let m = options.initial_intervals.max(2);
    let x: Vec<f64> = (0..=m).map(|i| i as f64 / m as f64).collect();
    let mut bad = None;
    let guess = Guess::from_fn(&x, N_STATE, vec![], |s, out| {
        let t = problem.t0 + s * t_p;
        let j = omega_p.jet(t);
        // [Ω_p, Ω̇_p, Ω̈_p] in, [ξ_p, ξ̇_p] out.
        let om: [f64; 3 * DIM] = stack(&[j.value.as_slice(), j.d1.as_slice(), j.d2.as_slice()]);
        let mut xi = [0.0; 2 * DIM];
        g::singular_control(&om, &params, &mut xi);
        if xi.iter().any(|v| !v.is_finite()) && bad.is_none() {
            bad = Some(t);
        }
        let (xi_p, xi_p_dot) = xi.split_at(DIM);
        out[OMEGA].copy_from_slice(j.value.as_slice());
        out[XI].copy_from_slice(xi_p);
        out[XIDOT].copy_from_slice(xi_p_dot);
        out[KAPPA].fill(0.0);
    });
    if let Some(t) = bad {
        return Err(SolveError::Start(format!(
            "the singular control xi_p is undefined at t = {t} (Property 3 fails there)"
        )));
    }
    let bvp_opts = |tol: f64| bvp::Options {
        tol,
        max_nodes: options.max_nodes,
        ..Default::default()
    };
    let cont = continuation::Options {
        bvp: bvp::Options {
            max_newton_failures: 0,
            max_newton_iter: 15,
            ..bvp_opts(options.continuation_tol)
        },
        initial_step: Some(0.2),
        ..Default::default()
    };
    let clock = std::time::Instant::now();
    events(&Event::StageStarted {
        name: "start",
        from: beta_m,
        to: beta_m,
    });
    // Paper's first case (γ = 0): the start and the γ stage track Ω_p, not Ω_d.
    let tracking = if start.case == 1 {
        omega_p.clone()
    } else {
        problem.desired.clone()
    };
    let start_bvp = SuslovBvp {
        params,
        omega_a: problem.omega_a.into(),
        omega_b: problem.omega_b.into(),
        t0: problem.t0,
        fixed_span: Some(t_p),
        desired: &*tracking,
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
        from: beta_m,
        to: beta_m,
        steps: usize::from(first.is_success()),
        failures_recovered: 0,
        newton_iterations: first.stats.newton_iterations,
        nodes: first.num_nodes(),
        seconds: clock.elapsed().as_secs_f64(),
        outcome: StageOutcome::Completed,
    };
    if !first.is_success() {
        let reason = format!(
            "the BVP at beta_m = {beta_m} from the analytic singular solution did not converge \
             ({:?}: {}); try a smaller or larger beta_m, or more initial intervals",
            first.status,
            first.status.message()
        );
        report.outcome = StageOutcome::Stopped {
            reason: reason.clone(),
        };
        events(&Event::StageFinished(&report));
        return Err(SolveError::Start(reason));
    }
    events(&Event::StageFinished(&report));
    let mut h = Homotopy {
        problem,
        params,
        fixed_span: Some(t_p),
        t_span: t_p,
        solution: first,
        start,
        stages: vec![report],
        tolerance: options.tol,
        tracking,
    };

    match h.start.case {
        1 => {
            h.stage("gamma", idx::GAMMA, 1.0, 0.0, &|l| 1.0 - l, &cont, events)?;
            h.tracking = problem.desired.clone(); // γ = 0 from here on: Ω_d has no effect
        }
        2 => {
            let gamma = w.gamma;
            h.stage(
                "gamma",
                idx::GAMMA,
                0.0,
                gamma,
                &move |l| l * gamma,
                &cont,
                events,
            )?
        }
        _ => {}
    }
    if w.beta != beta_m {
        let (lo, hi) = (beta_m.ln(), w.beta.ln());
        h.stage(
            "beta",
            idx::BETA,
            beta_m,
            w.beta,
            &move |l| (lo + l * (hi - lo)).exp(),
            &cont,
            events,
        )?;
        h.params[idx::BETA] = w.beta;
    }
    if w.eta > 0.0 {
        let eta = w.eta;
        h.stage("eta", idx::ETA, 0.0, eta, &move |l| l * eta, &cont, events)?;
    }
    match problem.terminal {
        TerminalTime::Fixed(_) => {
            if w.delta != 0.0 {
                h.params[idx::DELTA] = w.delta; // δ only shifts the cost at fixed time
            }
        }
        TerminalTime::Free { .. } => {
            let yb: [f64; N_STATE] = h.solution.eval(1.0).try_into().expect("n = N_STATE");
            let bvp0 = h.bvp_with(h.params, h.fixed_span);
            let wb = bvp0.desired_at(problem.t0 + t_p);
            let delta_c = g::delta_start(&yb, &h.params, &wb);
            h.params[idx::DELTA] = delta_c;
            h.fixed_span = None;
            let guess = Guess::from_solution(&h.solution).with_parameters(vec![t_p]);
            h.single_solve(
                "free-time start",
                &guess,
                &bvp_opts(options.continuation_tol),
                events,
            )?;
            let delta = w.delta;
            h.stage(
                "delta",
                idx::DELTA,
                delta_c,
                delta,
                &move |l| delta_c + l * (delta - delta_c),
                &cont,
                events,
            )?;
        }
    }
    let guess = Guess::from_solution(&h.solution);
    h.single_solve("polish", &guess, &bvp_opts(options.tol), events)?;
    Ok(h.snapshot())
}
