//! # suslov
//!
//! Optimal control of nonholonomic mechanical systems in which the constraint itself is the
//! control. The reference system is Suslov's problem: a rigid body whose body angular velocity
//! `Ω` must stay orthogonal to a direction `ξ(t)` that we steer in time (Putkaradze & Rogers).
//!
//! Layers, from the bottom up:
//! - [`model`]: the Suslov equations, costate equations, boundary conditions and all their
//!   Jacobians, *generated* from first principles by the sympy program in `codegen/`.
//! - [`bvp`]: a generic two-point boundary value problem solver that knows nothing of Suslov.
//! - [`config`]: users' own problems as TOML files (`suslov solve problem.toml`).

pub mod app;
pub mod bvp;
pub mod config;
pub mod continuation;
pub mod ivp;
pub mod model;
pub mod report;
pub mod suslov;
