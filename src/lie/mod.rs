//! Constraint control on any Lie algebra, generic over a generated [`Model`](crate::model::Model):
//! the paper's section 3 as a problem layer. Every dimension, block, index and formula comes
//! from the model (`codegen/models/<name>.py`, emitted by `codegen/generate.py`); nothing here
//! knows a dimension or a basis.
//!
//! - [`path`]: desired and start paths `Ω(t) ∈ Rⁿ` with exact derivatives, and the radial
//!   projection onto the energy level set `⟨Ω, 𝕀Ω⟩ = const` of a full inertia matrix;
//! - [`expression`]: desired paths as formulas in `t`, differentiated exactly in Taylor mode;
//! - [`problem`]: a problem as data ([`Problem`]) and its BVP ([`LieBvp`]);
//! - [`solve`](mod@solve): the analytic singular start and the staged homotopy, its stages read from the
//!   weights' [`HomotopyRole`](crate::model::HomotopyRole)s;
//! - [`checks`]: what "converged" means for every problem layer: the [`Diagnostics`](checks::Diagnostics)
//!   measured on a solution and the [`Verification`](checks::Verification) thresholds and verdict;
//! - [`verify`]: the a-posteriori checks of a [`LieSolution`];
//! - [`certify`](mod@certify): the second-order certificate (local minimum or not);
//! - [`direct`]: the direct start (a minimum of the transcribed problem by SQP) for the BVP;
//! - [`multiplier`]: the multiplier form of the control problem (`λ` a control, the constraint
//!   a path constraint; defined where `ξ` vanishes), for the direct start;
//! - [`relaxed`]: its limit `ξ → 0` (a torque `τ ⟂ Ω` as the control), whose minimum is the
//!   infimum approached by controls with a vanishing `ξ`, for the stops' evidence;
//! - [`controllability`]: the accessibility rank test along a solution.
//!
//! This layer knows nothing of the so(3) problem layer ([`crate::so3`]), which predates it
//! and still serves the paper's outputs (figures, the stability experiment, its certificate
//! and controllability reports). The so(3) layer solves through this one
//! (`SuslovProblem::to_generic`), and the types both share (options, stage records, events,
//! terminal time, diagnostics, verification, certificate) live here and are re-exported there.
//! `tests/lie_layer.rs` checks that both layers' diagnostics and certificates agree on the
//! paper's problems.

pub mod certify;
pub mod checks;
pub mod collapse;
pub mod controllability;
pub mod direct;
pub mod expression;
pub mod multiplier;
pub mod path;
pub mod problem;
pub mod relaxed;
pub mod solve;
pub mod verify;

pub use problem::{LieBvp, Problem, ProblemError};
pub use solve::{solve, solve_from, LieSolution, LieSolveError, WarmStart};
pub use verify::verify_solution;
