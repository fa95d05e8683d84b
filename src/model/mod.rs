//! The Suslov optimal-control model, generated from first principles.
//!
//! Everything in [`generated`] is emitted by the sympy program in `codegen/` (see
//! `codegen/README.md`): the model (`codegen/model.py`: inertia, the constraint `⟨Ω, ξ⟩ = 0`
//! and the cost integrand) is turned into Suslov's equations, the costate (κ) equations, the
//! explicit `ξ̈` by Sherman–Morrison, the boundary conditions and every Jacobian, and printed as
//! allocation-free Rust functions writing into caller-provided fixed-size arrays.
//!
//! Layout of the arrays (also available as constants, so no caller hard-codes them):
//! - `y` = [`generated::STATE_NAMES`]: `[Ω₁, Ω₂, Ω₃, ξ₁, ξ₂, ξ₃, ξ̇₁, ξ̇₂, ξ̇₃, κ₁, κ₂, κ₃]`;
//! - `p` = [`generated::PARAM_NAMES`]: `[I₁, I₂, I₃, α, β, γ, η, δ]`;
//! - `w` = `[Ω_d, Ω̇_d]`, the desired path and its time derivative at the current time.

/// The generated functions and metadata (`@generated` by `codegen/generate.py`).
#[allow(
    clippy::all,
    non_snake_case,
    unused_variables,
    unused_parens,
    clippy::too_many_arguments
)]
pub mod generated {
    include!(concat!(env!("OUT_DIR"), "/suslov_model.rs"));
}
