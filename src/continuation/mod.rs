//! Natural-parameter continuation of a one-parameter family of BVPs (generic: knows nothing
//! of Suslov).
//!
//! Given a family `λ ↦ P(λ)` of [`BvpProblem`]s and a solution at `λ₀`, [`natural`] follows
//! the solution to `λ₁` by a predictor–corrector loop:
//!
//! 1. **Predictor.** Secant extrapolation through the last two accepted solutions (both
//!    evaluated by their dense output on the mesh of the newer one, stage values included),
//!    or, at the first step, the last solution itself.
//! 2. **Corrector.** A full BVP solve (Newton with mesh adaptation) warm-started from the
//!    prediction. If the secant prediction fails, the step is retried once from the last
//!    solution unchanged (a zero-order predictor) before the step is cut.
//! 3. **Step control.** Easy steps (few Newton iterations) grow the step by `grow`, hard ones
//!    shrink it, failures cut it by `shrink`; below `min_step` the continuation stops with
//!    [`ContinuationStatus::StepTooSmall`], keeping the last converged point, and says where
//!    and why. Every attempt is recorded in [`Outcome::records`].
//!
//! The caller's solutions are never modified; guesses are built from copies.
//!
//! Natural-parameter continuation stops at a fold (turning point) of the branch, where the
//! fixed-`λ` problem becomes singular. [`pseudo_arclength`] (module [`arclength`]) follows
//! the branch through folds, reports them and records a branch diagram.

pub mod arclength;

pub use arclength::{
    pseudo_arclength, ArclengthOptions, ArclengthOutcome, ArclengthStatus, ArclengthStep,
    BranchPoint, Fold,
};

use crate::bvp::{self, BvpProblem, Guess, Solution, Status};

/// Options of [`natural`].
#[derive(Debug, Clone)]
pub struct Options {
    /// First step in `|λ|` units (default 0.1 of the range).
    pub initial_step: Option<f64>,
    /// Smallest step before giving up (default 1e-6 of the range).
    pub min_step: Option<f64>,
    /// Largest step (default: the whole range).
    pub max_step: Option<f64>,
    /// Cap on attempted steps (default 500).
    pub max_steps: usize,
    /// Step growth after an easy step (default 1.6).
    pub grow: f64,
    /// Step reduction after a failed step (default 0.4).
    pub shrink: f64,
    /// A step with at most this many Newton iterations is "easy" (default 4).
    pub easy_newton: usize,
    /// A step with more than this many Newton iterations shrinks the next step (default 10).
    pub hard_newton: usize,
    /// The BVP solver options of every corrector solve.
    pub bvp: bvp::Options,
    /// Checked before every step: once set, the continuation stops
    /// ([`ContinuationStatus::Stopped`]) at the last converged point.
    pub stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            initial_step: None,
            min_step: None,
            max_step: None,
            max_steps: 500,
            grow: 1.6,
            shrink: 0.4,
            easy_newton: 4,
            hard_newton: 10,
            bvp: bvp::Options::default(),
            stop: None,
        }
    }
}

/// One corrector attempt.
#[derive(Debug, Clone, PartialEq)]
pub struct StepRecord {
    /// The parameter value tried.
    pub lambda: f64,
    /// Whether the solve converged (the step was accepted).
    pub accepted: bool,
    /// The solver's status.
    pub status: Status,
    /// Newton iterations of this solve.
    pub newton_iterations: usize,
    /// Mesh nodes of the result.
    pub nodes: usize,
    /// Whether the secant predictor was used (false: the last solution as is).
    pub secant: bool,
}

/// How the continuation ended.
#[derive(Debug, Clone, PartialEq)]
pub enum ContinuationStatus {
    /// `λ₁` reached.
    Reached,
    /// The step fell below `min_step` at `reached` (the last converged value).
    StepTooSmall {
        /// Last converged parameter value.
        reached: f64,
        /// The status of the last failed corrector solve.
        last_failure: Status,
    },
    /// `max_steps` attempts were made; `reached` is the last converged value.
    MaxSteps {
        /// Last converged parameter value.
        reached: f64,
    },
    /// [`Options::stop`] was set; `reached` is the last converged value.
    Stopped {
        /// Last converged parameter value.
        reached: f64,
    },
}

impl ContinuationStatus {
    /// True when the target was reached.
    pub fn is_success(&self) -> bool {
        *self == ContinuationStatus::Reached
    }
}

impl std::fmt::Display for ContinuationStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ContinuationStatus::Reached => write!(f, "reached the target"),
            ContinuationStatus::StepTooSmall {
                reached,
                last_failure,
            } => write!(
                f,
                "step size fell below the minimum at lambda = {reached} (last failure: {})",
                last_failure.message()
            ),
            ContinuationStatus::MaxSteps { reached } => {
                write!(f, "maximum number of steps reached at lambda = {reached}")
            }
            ContinuationStatus::Stopped { reached } => {
                write!(f, "stopped by the caller at lambda = {reached}")
            }
        }
    }
}

/// The result of [`natural`]: the last converged point and the history.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// How it ended.
    pub status: ContinuationStatus,
    /// The last converged parameter value (`λ₁` on success).
    pub lambda: f64,
    /// The solution at [`lambda`](Self::lambda).
    pub solution: Solution,
    /// Every corrector attempt, in order.
    pub records: Vec<StepRecord>,
}

impl Outcome {
    /// Accepted steps.
    pub fn steps(&self) -> usize {
        self.records.iter().filter(|r| r.accepted).count()
    }
    /// Rejected attempts (failures recovered from, or the final one).
    pub fn failures(&self) -> usize {
        self.records.iter().filter(|r| !r.accepted).count()
    }
    /// Newton iterations over all attempts.
    pub fn newton_iterations(&self) -> usize {
        self.records.iter().map(|r| r.newton_iterations).sum()
    }
}

/// Follow the solution `start` of `family(lambda0)` to `family(lambda1)`.
///
/// `start` must be a converged solution at `lambda0`. `on_step` is called after every
/// corrector attempt (for progress bars and logs).
pub fn natural<P, F>(
    family: F,
    lambda0: f64,
    lambda1: f64,
    start: &Solution,
    options: &Options,
    on_step: &mut dyn FnMut(&StepRecord),
) -> Result<Outcome, bvp::BvpError>
where
    P: BvpProblem,
    F: Fn(f64) -> P,
{
    natural_with_progress(
        family,
        lambda0,
        lambda1,
        start,
        options,
        on_step,
        &mut |_, _| {},
    )
}

/// [`natural`], also passing every Newton step and mesh pass of the corrector solves to
/// `on_solve(lambda, progress)` (for logs and progress bars).
pub fn natural_with_progress<P, F>(
    family: F,
    lambda0: f64,
    lambda1: f64,
    start: &Solution,
    options: &Options,
    on_step: &mut dyn FnMut(&StepRecord),
    on_solve: &mut dyn FnMut(f64, &bvp::Progress),
) -> Result<Outcome, bvp::BvpError>
where
    P: BvpProblem,
    F: Fn(f64) -> P,
{
    let range = (lambda1 - lambda0).abs();
    let dir = if lambda1 >= lambda0 { 1.0 } else { -1.0 };
    let max_step = options.max_step.unwrap_or(range).max(f64::MIN_POSITIVE);
    let min_step = options.min_step.unwrap_or(1e-6 * range);
    let mut step = options.initial_step.unwrap_or(0.1 * range).min(max_step);
    let mut records = Vec::new();
    let mut previous: Option<(f64, Solution)> = None;
    let mut current = (lambda0, start.clone());
    let mut last_failure = Status::Converged;
    while current.0 != lambda1 {
        if options
            .stop
            .as_ref()
            .is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed))
        {
            return Ok(finish(
                ContinuationStatus::Stopped { reached: current.0 },
                current,
                records,
            ));
        }
        if records.len() >= options.max_steps {
            return Ok(finish(
                ContinuationStatus::MaxSteps { reached: current.0 },
                current,
                records,
            ));
        }
        if step < min_step {
            return Ok(finish(
                ContinuationStatus::StepTooSmall {
                    reached: current.0,
                    last_failure,
                },
                current,
                records,
            ));
        }
        let remaining = (lambda1 - current.0).abs();
        let lambda = if step >= remaining {
            lambda1
        } else {
            current.0 + dir * step
        };
        let problem = family(lambda);
        let mut attempt = |secant: bool| -> Result<(StepRecord, Solution), bvp::BvpError> {
            let guess = match (&previous, secant) {
                (Some(prev), true) => predict_secant(prev, &current, lambda),
                _ => Guess::from_solution(&current.1),
            };
            let sol = bvp::solve_with_progress(&problem, &guess, &options.bvp, &mut |p| {
                on_solve(lambda, p)
            })?;
            let record = StepRecord {
                lambda,
                accepted: sol.is_success(),
                status: sol.status,
                newton_iterations: sol.stats.newton_iterations,
                nodes: sol.num_nodes(),
                secant,
            };
            Ok((record, sol))
        };
        let mut outcome = attempt(previous.is_some())?;
        on_step(&outcome.0);
        if !outcome.0.accepted && outcome.0.secant {
            records.push(outcome.0.clone());
            outcome = attempt(false)?;
            on_step(&outcome.0);
        }
        let (record, sol) = outcome;
        let newton = record.newton_iterations;
        let accepted = record.accepted;
        last_failure = if accepted {
            last_failure
        } else {
            record.status
        };
        records.push(record);
        if accepted {
            previous = Some(std::mem::replace(&mut current, (lambda, sol)));
            if newton <= options.easy_newton {
                step = (step * options.grow).min(max_step);
            } else if newton > options.hard_newton {
                step *= 0.7;
            }
        } else {
            step *= options.shrink;
        }
    }
    Ok(finish(ContinuationStatus::Reached, current, records))
}

fn finish(
    status: ContinuationStatus,
    current: (f64, Solution),
    records: Vec<StepRecord>,
) -> Outcome {
    Outcome {
        status,
        lambda: current.0,
        solution: current.1,
        records,
    }
}

/// Secant prediction at `lambda` from `(l0, s0)` and `(l1, s1)`, on `s1`'s mesh.
fn predict_secant(prev: &(f64, Solution), cur: &(f64, Solution), lambda: f64) -> Guess {
    let (l0, s0) = prev;
    let (l1, s1) = cur;
    let theta = (lambda - l1) / (l1 - l0);
    let n = s1.n();
    let p: Vec<f64> =
        s1.p.iter()
            .zip(&s0.p)
            .map(|(a, b)| a + theta * (a - b))
            .collect();
    let mut y0 = vec![0.0; n];
    Guess::from_fn(&s1.x, n, p, |x, out| {
        s1.eval_into(x, out);
        s0.eval_into(x, &mut y0);
        for (o, v) in out.iter_mut().zip(&y0) {
            *o += theta * (*o - v);
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A family whose solution is known at every lambda:
    /// y'' + lambda^2 y = 0 on [0, 1], y(0) = 0, y'(0) = 1 (as a BC y(1) = sin(lambda)/lambda).
    struct Oscillator {
        lambda: f64,
    }

    impl BvpProblem for Oscillator {
        fn n(&self) -> usize {
            2
        }
        fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
            dy[0] = y[1];
            dy[1] = -self.lambda * self.lambda * y[0];
        }
        fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
            r[0] = ya[0];
            r[1] = yb[0] - self.lambda.sin() / self.lambda;
        }
    }

    fn solved(lambda: f64) -> Solution {
        let x: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
        let guess = Guess::from_fn(&x, 2, vec![], |t, out| {
            out[0] = t;
            out[1] = 1.0;
        });
        let opts = bvp::Options {
            tol: 1e-8,
            ..Default::default()
        };
        let sol = bvp::solve(&Oscillator { lambda }, &guess, &opts).expect("valid input");
        assert!(sol.is_success(), "{:?}", sol.status);
        sol
    }

    #[test]
    fn follows_a_family_to_the_target_and_matches_the_exact_solution() {
        let start = solved(0.5);
        let opts = Options {
            bvp: bvp::Options {
                tol: 1e-8,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut calls = 0;
        let out = natural(
            |l| Oscillator { lambda: l },
            0.5,
            3.0,
            &start,
            &opts,
            &mut |_| calls += 1,
        )
        .expect("valid input");
        assert!(out.status.is_success(), "{}", out.status);
        assert_eq!(out.lambda, 3.0);
        assert!(out.steps() >= 2);
        assert_eq!(calls, out.records.len());
        for i in 0..=20 {
            let x = i as f64 / 20.0;
            let exact = (3.0 * x).sin() / 3.0;
            assert!((out.solution.eval(x)[0] - exact).abs() < 1e-7);
        }
    }

    /// Bratu: y'' + lambda e^y = 0, y(0) = y(1) = 0; the lower branch folds at
    /// lambda* = 3.513830719 (the BVP has no solution beyond it).
    struct Bratu {
        lambda: f64,
    }

    impl BvpProblem for Bratu {
        fn n(&self) -> usize {
            2
        }
        fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
            dy[0] = y[1];
            dy[1] = -self.lambda * y[0].exp();
        }
        fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
            r[0] = ya[0];
            r[1] = yb[0];
        }
    }

    #[test]
    fn stops_at_a_fold_with_a_reason_and_keeps_the_last_point() {
        let x: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
        let guess = Guess::from_fn(&x, 2, vec![], |_, out| out.fill(0.0));
        let bvp_opts = bvp::Options {
            tol: 1e-8,
            ..Default::default()
        };
        let start = bvp::solve(&Bratu { lambda: 1.0 }, &guess, &bvp_opts).expect("valid");
        assert!(start.is_success());
        let opts = Options {
            bvp: bvp_opts,
            min_step: Some(1e-4),
            ..Default::default()
        };
        let out = natural(
            |l| Bratu { lambda: l },
            1.0,
            4.0,
            &start,
            &opts,
            &mut |_| {},
        )
        .expect("valid input");
        const FOLD: f64 = 3.513830719;
        match out.status {
            ContinuationStatus::StepTooSmall { reached, .. } => {
                assert!(
                    reached < FOLD && reached > FOLD - 0.05,
                    "stopped at {reached}"
                );
                assert_eq!(out.lambda, reached);
                assert!(out.solution.is_success());
                assert!(out.failures() > 0);
            }
            other => panic!("expected a stop before the fold, got {other}"),
        }
    }
}
