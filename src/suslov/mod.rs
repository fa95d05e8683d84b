//! The Suslov problem layer: the energy ellipsoid, desired trajectories with exact
//! derivatives, the paper's Properties 1–3, the analytic singular solution and the
//! a-posteriori re-integration of the pure Suslov equations.
//!
//! Paper: Putkaradze & Rogers, *Constraint control of nonholonomic mechanical systems*,
//! section 5 (5.1 analytic singular solution, 5.3 the desired trajectory).
//!
//! # Findings on the paper's setup (measured by `properties::tests`, 100 001 uniform samples)
//!
//! Setup: `I = diag(1, 2, 3)`, `Ω_a = [5, 0, 0]`, `Ω_b = φ_∥(10)`, interval `[0, 10]`.
//!
//! FINDINGS_PLACEHOLDER

pub mod desired;
pub mod ellipsoid;
pub mod equations;
pub mod problem;
pub mod properties;
pub mod reintegrate;
pub mod singular;

pub use desired::{
    Constant, DesiredPath, Jet, PaperSpiral, PathEval, Projected, ProjectedSegment, Scalar, Spiral,
};
pub use ellipsoid::{kinetic_energy, EnergyEllipsoid, Inertia};
pub use equations::{suslov_multiplier, suslov_residual, suslov_rhs};
pub use properties::{check_properties, PropertyReport};
pub use singular::{singular_control, singular_control_at, SingularControl};

/// Errors of the Suslov layer (misuse and undefined quantities; never non-convergence).
#[derive(Debug, thiserror::Error)]
pub enum SuslovError {
    /// The inertia moments are not all finite and positive.
    #[error("invalid inertia {inertia:?}: the principal moments must be finite and > 0")]
    InvalidInertia {
        /// The rejected moments.
        inertia: [f64; 3],
    },
    /// Radial projection onto `E` is undefined.
    #[error("cannot project {v:?} radially onto the energy ellipsoid: {reason}")]
    Projection {
        /// The vector.
        v: [f64; 3],
        /// Why.
        reason: &'static str,
    },
    /// A boundary value is off the energy ellipsoid.
    #[error("{name} is off Omega_a's energy ellipsoid by {mismatch:e} (relative); its projection is {projection}")]
    OffEllipsoid {
        /// The value's name, e.g. `Omega_b`.
        name: String,
        /// Relative energy mismatch.
        mismatch: f64,
        /// The radial projection, formatted.
        projection: String,
    },
    /// Property 3 violated: `IΩ̇ − (IΩ) × Ω ≈ 0`, so `ξ_p` is undefined.
    #[error("Property 3 violated: |I Om_dot - (I Om) x Om| = {norm:e} is ~0 (scale {scale:e}); xi_p is undefined")]
    EulerSolution {
        /// `|ξ̃|`.
        norm: f64,
        /// `|IΩ̇| + |IΩ||Ω|`.
        scale: f64,
    },
    /// Property 3 violated at a known time.
    #[error("Property 3 violated at t = {t}: |I Om_dot - (I Om) x Om| = {norm:e} is ~0 (scale {scale:e}); xi_p is undefined")]
    EulerSolutionAt {
        /// The time.
        t: f64,
        /// `|ξ̃|`.
        norm: f64,
        /// `|IΩ̇| + |IΩ||Ω|`.
        scale: f64,
    },
    /// Invalid arguments.
    #[error("invalid input: {what}")]
    InvalidInput {
        /// What is wrong, with the values.
        what: String,
    },
    /// The IVP integration failed.
    #[error(transparent)]
    Ivp(#[from] crate::ivp::IvpError),
}
