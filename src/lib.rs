//! # suslov
//!
//! Optimal control of nonholonomic mechanical systems in which the constraint itself is the
//! control. The reference system is Suslov's problem: a rigid body whose body angular velocity
//! `Ω` must stay orthogonal to a direction `ξ(t)` that we steer in time (Putkaradze & Rogers).
//!
//! Layers, from the bottom up:
//! - [`model`]: the Suslov equations, costate equations, boundary conditions and all their
//!   Jacobians, *generated* from first principles by the sympy program in `codegen/`.
//! - [`bvp`]: a generic two-point boundary value problem solver that knows nothing of Suslov
//!   (4-stage Lobatto IIIA collocation, order 6, adaptive mesh, structured Newton).
//! - [`continuation`]: natural-parameter and pseudo-arclength continuation of BVP families.
//! - [`ocp`]: generic optimal control: direct transcription, KKT conditions and the
//!   second-order (local minimum) certificate.
//! - [`ivp`]: adaptive high-order IVP integration, for a-posteriori checks.
//! - [`reconstruct`]: the group motion `ġ = g Ω̂` on any matrix Lie group (4th-order Magnus).
//! - [`so3`](mod@so3): the problem layer (problem data and validation, desired paths with
//!   exact derivatives, the analytic singular start, the staged homotopy of the paper's
//!   section 5.2, the paper's stability experiment).
//! - [`report`]: outputs (CSV, JSON, figures, atomic writes).
//!
//! # Example: the paper's η = 0.01 case
//!
//! ```
//! use suslov::lie::verify::diagnose;
//! use suslov::{paper, solve, SolveOptions};
//!
//! let problem = paper::problem(0.01); // free terminal time, published b = 9.84
//! let solution = solve(&problem, &SolveOptions::default(), &mut |_event| {})?;
//! assert!((solution.terminal_time() - 9.84).abs() < 0.01);
//! assert!((solution.cost() - 2.66585).abs() < 1e-5); // J = ∫ C dt
//! let checks = diagnose(&solution.generic);
//! assert!(checks.max_abs_constraint < 1e-9); // ⟨Ω, ξ⟩ = 0 on a fine grid
//! // "Converged" means every a-posteriori check passed at the requested tolerance:
//! assert!(solution.verify().verification.passed());
//! let y = solution.state(5.0); // [Ω, ξ, ξ̇, κ] at t = 5, in the generated layout
//! assert_eq!(y.len(), suslov::model::generated::N_STATE);
//! let omega = &y[suslov::model::generated::OMEGA];
//! assert_eq!(omega.len(), suslov::model::generated::DIM); // Ω
//! // On an array of times:
//! let rows = solution.states_at(&[0.0, 2.5, solution.terminal_time()]);
//! assert_eq!(rows.len(), 3);
//! # Ok::<(), suslov::so3::solve::SolveError>(())
//! ```
//!
//! # Example: your own problem
//!
//! A fixed terminal time and a desired path that runs along the energy ellipsoid from `Ω_a`
//! to `Ω_b` (the radial projection of the straight segment):
//!
//! ```
//! use std::sync::Arc;
//! use nalgebra::Vector3;
//! use suslov::so3::{EnergyEllipsoid, Inertia, ProjectedSegment};
//! use suslov::{solve, CostWeights, SolveOptions, SuslovProblem, TerminalTime};
//!
//! let inertia = Inertia::new([1.0, 1.5, 2.5])?;
//! let omega_a = Vector3::new(3.0, 1.0, 0.0);
//! let e = EnergyEllipsoid::through(inertia, &omega_a)?;
//! let omega_b = e.project(&Vector3::new(1.0, 2.0, -1.0))?; // on Ω_a's ellipsoid
//! let desired = ProjectedSegment::new(inertia, omega_a, omega_b, 0.0, 6.0)?;
//! let problem = SuslovProblem {
//!     inertia,
//!     weights: CostWeights { alpha: 1.0, beta: 0.1, gamma: 1.0, eta: 0.1, delta: 0.0 },
//!     t0: 0.0,
//!     omega_a,
//!     omega_b,
//!     terminal: TerminalTime::Fixed(6.0),
//!     desired: Arc::new(desired),
//! };
//! let solution = solve(&problem, &SolveOptions::default(), &mut |_event| {})?;
//! let y_end = solution.state(6.0);
//! let omega_end = Vector3::from_column_slice(&y_end[suslov::model::generated::OMEGA]);
//! assert!((omega_end - omega_b).norm() < 1e-8);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

//!
//! # Example: a problem file, any model
//!
//! The problem files of `suslov solve` (README, "Your own problems") are read by [`config`];
//! the same text gives the same problem as the command line solves:
//!
//! ```
//! let text = r#"
//! [body]
//! inertia = [1.0, 2.0, 3.0]
//! [boundary]
//! omega_a = [3.0, 0.0, 0.0]
//! omega_b = [1.0, 2.0, 0.0]
//! terminal_time = { fixed = 4.0 }
//! [cost]
//! alpha = 1.0
//! beta = 0.1
//! gamma = 0.0
//! "#;
//! let loaded = suslov::config::from_toml_str(text)?;
//! let problem = loaded.problem.to_generic()?; // the generic layer's problem (model so3)
//! let solution = suslov::lie::solve(&problem, &loaded.options, &mut |_event| {})?;
//! assert!(solution.verify().verification.passed());
//! assert_eq!(solution.terminal_time(), 4.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # What is API and what is the command line's
//!
//! The API: [`solve`] and [`SuslovProblem`] (so(3), the paper's model; the rest of its
//! layer in [`so3`](mod@so3)), [`lie::solve()`] and [`lie::Problem`] (any generated model),
//! the solutions' `cost`, `state`, `states_at` and `verify`, [`config`] to read problem
//! files, [`lie::certify`] and [`lie::controllability`], and [`report`] to write what the
//! command line writes. The command line's jobs (`app`) are public only so that tests and
//! benchmarks run exactly what the command line runs; they are not API and not documented
//! here.

#[doc(hidden)]
pub mod app;
pub mod bvp;
pub mod config;
pub mod continuation;
pub mod echo;
pub mod ivp;
pub mod lie;
pub mod model;
pub mod ocp;
pub mod reconstruct;
pub mod report;
pub mod so3;

pub use so3::paper;
pub use so3::problem::{CostWeights, ProblemError, SuslovProblem, TerminalTime};
pub use so3::solve::{solve, SolveError, SolveOptions, SuslovSolution};
