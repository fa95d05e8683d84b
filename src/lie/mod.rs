//! Constraint control on any Lie algebra, generic over a generated [`Model`](crate::model::Model):
//! the paper's section 3 as a problem layer. Every dimension, block, index and formula comes
//! from the model (`codegen/models/<name>.py`, emitted by `codegen/generate.py`); nothing here
//! knows a dimension or a basis.
//!
//! - [`path`]: desired and start paths `Ω(t) ∈ Rⁿ` with exact derivatives, and the radial
//!   projection onto the energy level set `⟨Ω, 𝕀Ω⟩ = const` of a full inertia matrix;
//! - [`problem`]: a problem as data ([`Problem`]) and its BVP ([`LieBvp`]);
//! - [`solve`](mod@solve): the analytic singular start and the staged homotopy, its stages read from the
//!   weights' [`HomotopyRole`](crate::model::HomotopyRole)s;
//! - [`verify`]: the a-posteriori checks, with the so(3) layer's thresholds and verdict;
//! - [`certify`](mod@certify): the second-order certificate (local minimum or not);
//! - [`controllability`]: the accessibility rank test along a solution.
//!
//! The so(3) problem layer ([`crate::suslov`]) predates this one and still serves the paper
//! (its figures, certificate and controllability report); `tests/lie_layer.rs` checks that
//! this layer reproduces its results on the paper's problems.

pub mod certify;
pub mod controllability;
pub mod path;
pub mod problem;
pub mod solve;
pub mod verify;

pub use problem::{LieBvp, Problem, ProblemError};
pub use solve::{solve, LieSolution, LieSolveError};
pub use verify::verify_solution;
