//! The analytic singular solution of paper section 5.1.
//!
//! For a path `Ω_p` satisfying Properties 1–3,
//! `ξ̃ = IΩ̇_p − (IΩ_p) × Ω_p`, `ξ_p = ξ̃/|ξ̃|` (eq. `xi_p_eq`) solves the singular problem with
//! `q(Ω_p, ξ_p) = 0`, `|ξ_p| = 1`, `⟨Ω_p, ξ_p⟩ = 0` (if `Ω_p` lies on `E`) and
//! `λ(Ω_p, ξ_p) = |ξ̃|`. Its exact derivative, from `Ω̈_p`, is
//! `ξ̃̇ = IΩ̈_p − (IΩ̇_p) × Ω_p − (IΩ_p) × Ω̇_p` and `ξ̇_p = (ξ̃̇ − ξ_p⟨ξ_p, ξ̃̇⟩)/|ξ̃|`.
//!
//! This plain-Rust version is an independent cross-check of the generated one.

use nalgebra::Vector3;

use super::desired::DesiredPath;
use super::ellipsoid::Inertia;
use super::SuslovError;

/// `|ξ̃|` below `SINGULAR_REL_TOL · (|IΩ̇| + |IΩ||Ω|)` counts as 0 (Property 3 violated).
pub const SINGULAR_REL_TOL: f64 = 1e-10;

/// The singular control at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingularControl {
    /// `ξ̃ = IΩ̇ − (IΩ) × Ω`
    pub xi_tilde: Vector3<f64>,
    /// `ξ_p = ξ̃/|ξ̃|`
    pub xi: Vector3<f64>,
    /// `ξ̇_p`
    pub xi_dot: Vector3<f64>,
    /// `λ(Ω_p, ξ_p) = |ξ̃|`
    pub lambda: f64,
}

/// `ξ_p`, `ξ̇_p` from `Ω_p`, `Ω̇_p`, `Ω̈_p` (paper eq. `xi_p_eq`).
///
/// Errors with [`SuslovError::EulerSolution`] when `|ξ̃|` is ~0 (relative to
/// `|IΩ̇| + |IΩ||Ω|`, see [`SINGULAR_REL_TOL`]) or non-finite.
pub fn singular_control(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    omega_dot: &Vector3<f64>,
    omega_ddot: &Vector3<f64>,
) -> Result<SingularControl, SuslovError> {
    let i_om = inertia.apply(omega);
    let i_om_dot = inertia.apply(omega_dot);
    let xi_tilde = i_om_dot - i_om.cross(omega);
    let norm = xi_tilde.norm();
    let scale = i_om_dot.norm() + i_om.norm() * omega.norm();
    if !(norm.is_finite() && norm > SINGULAR_REL_TOL * scale) {
        return Err(SuslovError::EulerSolution { norm, scale });
    }
    let xi = xi_tilde / norm;
    let xi_tilde_dot = inertia.apply(omega_ddot) - i_om_dot.cross(omega) - i_om.cross(omega_dot);
    let xi_dot = (xi_tilde_dot - xi * xi.dot(&xi_tilde_dot)) / norm;
    Ok(SingularControl {
        xi_tilde,
        xi,
        xi_dot,
        lambda: norm,
    })
}

/// [`singular_control`] of a path at time `t`, with its exact derivatives.
pub fn singular_control_at(
    path: &dyn DesiredPath,
    inertia: &Inertia,
    t: f64,
) -> Result<SingularControl, SuslovError> {
    let jet = path.jet(t);
    singular_control(inertia, &jet.value, &jet.d1, &jet.d2).map_err(|e| match e {
        SuslovError::EulerSolution { norm, scale } => {
            SuslovError::EulerSolutionAt { t, norm, scale }
        }
        other => other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::suslov::desired::{finite_difference_derivatives, Constant, PaperSpiral, PathEval};
    use crate::suslov::equations::{suslov_multiplier, suslov_residual};
    use approx::assert_relative_eq;

    #[test]
    fn singular_control_solves_suslov_on_the_projected_spiral() {
        let p = PaperSpiral::paper();
        let i = Inertia::paper();
        for t in [0.0, 0.5, 2.0, 4.0, 6.3, 9.0, 10.0] {
            let jet = p.phi_par().jet(t);
            let c = singular_control(&i, &jet.value, &jet.d1, &jet.d2).unwrap();
            assert_relative_eq!(c.xi.norm(), 1.0, epsilon = 1e-15);
            assert!(jet.value.dot(&c.xi).abs() < 1e-13, "t = {t}");
            let q = suslov_residual(&i, &jet.value, &jet.d1, &c.xi, &c.xi_dot);
            assert!(q.norm() < 1e-12, "t = {t}: q = {q:?}");
            assert_relative_eq!(
                suslov_multiplier(&i, &jet.value, &c.xi, &c.xi_dot),
                c.lambda,
                max_relative = 1e-12
            );
            // |xi| = 1 for all t, so <xi, xi_dot> = 0.
            assert!(c.xi.dot(&c.xi_dot).abs() < 1e-13);
        }
    }

    #[test]
    fn xi_dot_is_the_exact_derivative_of_xi() {
        // Wrap xi_p(t) of phi_par as a path and compare its FD derivative with xi_dot.
        struct Xi(PaperSpiral);
        impl DesiredPath for Xi {
            fn jet(&self, t: f64) -> crate::suslov::desired::Jet {
                let c = singular_control_at(self.0.phi_par(), &Inertia::paper(), t).unwrap();
                crate::suslov::desired::Jet {
                    value: c.xi,
                    d1: c.xi_dot,
                    d2: Vector3::zeros(),
                    d3: Vector3::zeros(),
                }
            }
        }
        let xi = Xi(PaperSpiral::paper());
        for t in [0.7, 3.3, 8.1] {
            let (fd, _, _) = finite_difference_derivatives(&xi, t, 1e-2);
            assert_relative_eq!(xi.jet(t).d1, fd, max_relative = 1e-8, epsilon = 1e-9);
        }
    }

    #[test]
    fn euler_solution_is_rejected() {
        // Omega along a principal axis and constant: I Om_dot - (I Om) x Om = 0.
        let i = Inertia::paper();
        let c = Constant(Vector3::new(5.0, 0.0, 0.0));
        let err = singular_control_at(&c, &i, 0.0).unwrap_err();
        assert!(matches!(err, SuslovError::EulerSolutionAt { t, .. } if t == 0.0));
        // A constant Omega off the axes is not an Euler solution: allowed.
        let om = Vector3::from(PaperSpiral::paper().phi_par().eval(3.0));
        assert!(singular_control_at(&Constant(om), &i, 0.0).is_ok());
    }
}
