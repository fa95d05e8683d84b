//! Solving a [`SuslovProblem`]: the so(3) problem handed to the generic layer
//! ([`crate::lie::solve`](mod@crate::lie::solve), model `so3`), which runs the analytic start
//! of paper section 5.1 and the staged homotopy of section 5.2 for every model (its module
//! docs give the stages), and the result handed back as a [`SuslovSolution`] for the so(3)
//! outputs (figures, the stability experiment, the paper's tables).
//!
//! The so(3) layer had its own copy of the homotopy; on every so(3) example both gave the same
//! verdict and `b`, `J` to 1e-15 relative (`every_so3_example_solves_the_same_in_both_layers`
//! in `tests/lie_layer.rs`), and this module now only converts.

use crate::bvp;
use crate::lie::{self, LieSolution, LieSolveError};
use crate::model::generated::{So3, N_STATE};

use super::problem::{CostWeights, ProblemError, SuslovProblem};

/// A solved Suslov problem: the generic layer's solution ([`LieSolution`], model `so3`) with
/// the so(3) view of its problem (the inertia, the weights reached, the desired path as a
/// [`super::DesiredPath`]) that the so(3) outputs use.
#[derive(Debug, Clone)]
pub struct SuslovSolution {
    /// The problem, with the weights reached and the terminal time found (for a free `b`).
    pub problem: SuslovProblem,
    /// The solution, its mesh, start, stages and requested tolerance: everything the checks
    /// ([`crate::lie::verify`]) and the certificate ([`crate::lie::certify`]) read.
    pub generic: LieSolution<So3>,
}

impl SuslovSolution {
    /// `b`.
    pub fn terminal_time(&self) -> f64 {
        self.generic.terminal_time()
    }

    /// `y(t) = [Ω, ξ, ξ̇, κ]` at physical time `t ∈ [a, b]`.
    pub fn state(&self, t: f64) -> [f64; N_STATE] {
        let mut y = [0.0; N_STATE];
        self.generic.state_into(t, &mut y);
        y
    }

    /// The states at every time of `times`, one `[Ω, ξ, ξ̇, κ]` per time.
    pub fn states_at(&self, times: &[f64]) -> Vec<[f64; N_STATE]> {
        times.iter().map(|t| self.state(*t)).collect()
    }

    /// The cost `J = ∫ C dt` (the value `summary.json` reports).
    pub fn cost(&self) -> f64 {
        self.generic.cost()
    }

    /// The a-posteriori checks ([`LieSolution::verify`]): `.verification.passed()` is what
    /// "converged" means.
    pub fn verify(&self) -> crate::lie::verify::Verified {
        self.generic.verify()
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
    /// No admissible analytic start could be built, on any route tried.
    #[error("cannot build the analytic start: {reason}")]
    Start {
        /// Why, with every route tried.
        reason: String,
        /// The direct method's minimum as evidence, where it ran (the generic layer's
        /// [`LieSolveError::Start`]).
        collapse: Option<Box<crate::lie::collapse::CollapseEvidence>>,
    },
    /// A stage did not reach its target; `partial` holds the last converged point.
    #[error(
        "stage '{stage}' stopped{}: {reason}",
        crate::lie::solve::where_stopped(parameter, *reached, *target)
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
        /// The last converged solution (its problem carries the weights reached).
        partial: Box<SuslovSolution>,
    },
    /// Invalid input reached the BVP solver (a bug in this layer).
    #[error("BVP solver rejected its input: {0}")]
    Bvp(#[from] bvp::BvpError),
}

impl SuslovSolution {
    /// The so(3) view of a generic solution of `problem` (its weights and terminal time
    /// replaced by those the generic solution reached).
    fn from_generic(problem: &SuslovProblem, sol: LieSolution<So3>) -> Self {
        let mut problem = problem.clone();
        let params = sol
            .problem
            .params()
            .try_into()
            .expect("so3: N_PARAM constants");
        problem.weights = CostWeights::from_params(params);
        problem.terminal = sol.problem.terminal;
        Self {
            problem,
            generic: sol,
        }
    }
}

/// Solve `problem` from the analytic singular solution through the staged homotopy (the
/// generic layer's, model `so3`).
pub fn solve(
    problem: &SuslovProblem,
    options: &SolveOptions,
    events: &mut dyn FnMut(&Event),
) -> Result<SuslovSolution, SolveError> {
    problem.validate()?;
    let generic = problem.to_generic().map_err(|e| SolveError::Start {
        reason: format!("the problem as a generic so3 problem: {e}"),
        collapse: None,
    })?;
    match lie::solve(&generic, options, events) {
        Ok(sol) => Ok(SuslovSolution::from_generic(problem, sol)),
        Err(LieSolveError::StageFailed {
            stage,
            parameter,
            reached,
            target,
            reason,
            partial,
        }) => Err(SolveError::StageFailed {
            stage,
            parameter,
            reached,
            target,
            reason,
            partial: Box::new(SuslovSolution::from_generic(problem, *partial)),
        }),
        Err(LieSolveError::Start { reason, collapse }) => {
            Err(SolveError::Start { reason, collapse })
        }
        Err(LieSolveError::Bvp(e)) => Err(SolveError::Bvp(e)),
        Err(other) => Err(SolveError::Start {
            reason: other.to_string(),
            collapse: None,
        }),
    }
}
