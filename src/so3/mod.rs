//! The Suslov problem layer (so(3), the paper): the energy ellipsoid, desired trajectories
//! with exact derivatives (the paper's spiral among them), the paper's Properties 1–3, the
//! analytic singular solution, the re-integration of the pure Suslov equations with the
//! paper's stability experiment ([`stability`]), and the outputs' view of a solution
//! ([`SuslovSolution`](solve::SuslovSolution)).
//!
//! Solving, the a-posteriori checks and the certificate are the generic layer's
//! ([`crate::lie`], model `so3`): [`solve::solve`] hands the problem over
//! ([`problem::SuslovProblem::to_generic`]) and a [`SuslovSolution`](solve::SuslovSolution)
//! holds the generic solution with the so(3) view of its problem.
//!
//! Paper: Putkaradze & Rogers, *Constraint control of nonholonomic mechanical systems*,
//! section 5 (5.1 analytic singular solution, 5.3 the desired trajectory).
//!
//! # Findings on the paper's setup (measured by `properties::tests`, 100 001 uniform samples)
//!
//! Setup: `I = diag(1, 2, 3)`, `Ω_a = [5, 0, 0]`, `Ω_b = φ_∥(10)`, interval `[0, 10]`.
//!
//! | candidate `Ω_p` on `[0, 10]` | P1: ‖Ω(0)−Ω_a‖, ‖Ω(10)−Ω_b‖ | P2: max rel. energy deviation (at) | P2: max abs ⟨IΩ,Ω̇⟩ (at) | P3: min ‖ξ̃‖ (at) | max ‖ξ̇_p‖ (at) |
//! |---|---|---|---|---|---|
//! | paper `Ω_d` | 0, 0 | **8.9e-6** (t = 9.988) | **1.5e-2** (t = 9.995) | 1.0 (t = 0) | 22.2 (t = 10) |
//! | `Projected(Ω_d)` | 0, 6.7e-16 | 5.7e-16 | 5.3e-15 | 1.0 (t = 0) | 22.2 (t = 10) |
//! | `φ_∥` | 0, 0 | 7.1e-16 | 5.3e-15 | 1.0 (t = 0) | 5.5 (t = 0) |
//! | `ProjectedSegment(Ω_a → Ω_b)` | 0, 6.7e-16 | 7.1e-16 | 1.0e-15 | 0.64 (t = 0.038) | 2.95 (t = 0.043) |
//!
//! - **The paper's `Ω_d` does not lie on `E` everywhere.** For `t < 9.8204` it equals `φ_∥`
//!   bit for bit (`s(t) = 0` exactly in `f64`; in particular `σ(a − b_d) = ½(1 + tanh(−1000))`
//!   is exactly 0). In the sigmoid layer it is a convex blend of two points of `E`, so it cuts
//!   inside the ellipsoid: by up to `8.9e-6` in relative energy, at `t ≈ 9.988`. It still
//!   meets P1 exactly (`Ω_d(10) = (φ_∥(10) + Ω_b)/2 = Ω_b` since `φ_∥(10) = Ω_b`) and P3.
//! - `Ω_b = φ_∥(10)` is computed, and rounds to the paper's `[2.7541, −2.3109, −1.4983]`.
//! - Distances on `[0, 10]`: `max |Projected(Ω_d) − Ω_d| = 1.7e-5`,
//!   `max |φ_∥ − Ω_d| = 3.9e-3` (both only in `[9.82, 10]`).
//! - P3 holds with margin for all projected candidates: the minimum of `|ξ̃|` is 1.0, at
//!   `t = 0`, where `Ω_a` is a principal axis (`(IΩ_a) × Ω_a = 0`) and `IΩ̇(0) = [0, 1, 0]`.
//! - **Recommended start `Ω_p = Projected(Ω_d)` on `[0, b_p = b_d = 10]`**: it is the admissible
//!   path nearest to `Ω_d` (1.7e-5), satisfies P1–P3 to round-off, and its singular control
//!   re-integrates to `Ω_p` within 2.1e-12 (see [`mod@reintegrate`]). Its cost is the sigmoid's
//!   time scale `w = 0.01` in the last ~0.2 of the interval (`|ξ̇_p|` up to 22.2 at `t = 10`,
//!   `Ω̈_p ~ 1/w`), which the BVP mesh must resolve anyway because the tracking term
//!   `γ/2 |Ω − Ω_d|²` contains `Ω_d`. The smooth alternative is `φ_∥` on `[0, 10]` (exactly
//!   on `E`, equal to `Ω_d` for `t < 9.82`, `|ξ̇_p| ≤ 5.5`, 3.9e-3 from `Ω_d` near `t = 10`).
//! - `ProjectedSegment` is the paper's nominal `Ω_p` for `γ = 0` (section 5.2); it also meets
//!   P1–P3 (min `|ξ̃|` = 0.64).

pub mod controllability;
pub mod desired;
pub mod ellipsoid;
pub mod equations;
pub mod layout;
pub mod paper;
pub mod problem;
pub mod properties;
pub mod reintegrate;
pub mod singular;
pub mod solve;
pub mod stability;

pub use desired::{
    Constant, DesiredPath, Jet, PaperSpiral, PathEval, Projected, ProjectedPath, ProjectedSegment,
    SampledPath, Scalar, Spiral,
};
pub use ellipsoid::{kinetic_energy, EnergyEllipsoid, Inertia};
pub use equations::{suslov_multiplier, suslov_residual, suslov_rhs};
pub use properties::{check_properties, PropertyReport};
pub use reintegrate::{
    compare, reintegrate, reintegrate_with_xi_dot, singular_control_fn, stability_experiment,
    Comparison, Perturbation, Reintegration, StabilityReport,
};
pub use singular::{
    singular_control, singular_control_at, singular_jet, singular_jet_at, SingularControl,
    SingularJet,
};

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
    /// The straight segment between two end points passes (nearly) through the origin,
    /// where the radial projection onto `E` is undefined.
    #[error(
        "the segment from Omega_a to Omega_b passes within {closest:.3e} of the origin \
         (|Omega_a| = {size:.3e}): its end points are (nearly) opposite, and the radial \
         projection is undefined at the origin"
    )]
    SegmentThroughOrigin {
        /// Distance from the origin to the segment.
        closest: f64,
        /// `|Ω_a|`, the scale.
        size: f64,
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
