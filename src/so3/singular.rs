//! The analytic singular solution of paper section 5.1.
//!
//! For a path `Ω_p` satisfying Properties 1–3,
//! `ξ̃ = IΩ̇_p − (IΩ_p) × Ω_p`, `ξ_p = ξ̃/|ξ̃|` (eq. `xi_p_eq`) solves the singular problem with
//! `q(Ω_p, ξ_p) = 0`, `|ξ_p| = 1`, `⟨Ω_p, ξ_p⟩ = 0` (if `Ω_p` lies on `E`) and
//! `λ(Ω_p, ξ_p) = |ξ̃|`. Its exact derivative, from `Ω̈_p`, is
//! `ξ̃̇ = IΩ̈_p − (IΩ̇_p) × Ω_p − (IΩ_p) × Ω̇_p` and `ξ̇_p = (ξ̃̇ − ξ_p⟨ξ_p, ξ̃̇⟩)/|ξ̃|`.
//!
//! With `Ω⃛_p` also `ξ̃̈ = IΩ⃛_p − (IΩ̈_p) × Ω_p − 2(IΩ̇_p) × Ω̇_p − (IΩ_p) × Ω̈_p`,
//! `λ̇ = ⟨ξ_p, ξ̃̇⟩`, `λ̈ = ⟨ξ̇_p, ξ̃̇⟩ + ⟨ξ_p, ξ̃̈⟩` and `ξ̈_p = (ξ̃̈ − 2λ̇ξ̇_p − λ̈ξ_p)/λ`
//! ([`singular_jet`]), e.g. for the derivative of a BVP initial guess containing `ξ̇`.
//!
//! All of it is the generated `singular_jet` (derived in `codegen/`, for any Lie algebra:
//! `ξ̃ = IΩ̇ − ad*_Ω IΩ`); this module adds the Property 3 check and `nalgebra` types. The
//! tests compare it with an independent evaluation of the formulas above.

use nalgebra::Vector3;

use super::desired::{DesiredPath, Jet};
use super::ellipsoid::Inertia;
use super::layout::stack;
use super::problem::inertia_params;
use super::SuslovError;
use crate::model::generated::{self as g, DIM};

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
    /// `λ̇ = ⟨ξ_p, ξ̃̇⟩`
    pub lambda_dot: f64,
}

/// The singular control with its second derivative.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingularJet {
    /// `ξ̃`, `ξ_p`, `ξ̇_p`, `λ`, `λ̇`.
    pub control: SingularControl,
    /// `ξ̈_p` (exact, from `Ω⃛_p`).
    pub xi_ddot: Vector3<f64>,
}

/// The generated `singular_jet` at `[Ω_p, Ω̇_p, Ω̈_p, Ω⃛_p]`, checked for Property 3:
/// `(control, ξ̈_p)`.
fn evaluate(
    inertia: &Inertia,
    [omega, omega_dot, omega_ddot, omega_dddot]: [&Vector3<f64>; 4],
) -> Result<(SingularControl, Vector3<f64>), SuslovError> {
    let input: [f64; 4 * DIM] = stack(&[
        omega.as_slice(),
        omega_dot.as_slice(),
        omega_ddot.as_slice(),
        omega_dddot.as_slice(),
    ]);
    // [ξ̃, ξ_p, ξ̇_p, ξ̈_p] and [λ, λ̇, λ̈].
    let mut xi = [0.0; 4 * DIM];
    let mut lambda = [0.0; 3];
    g::singular_jet(&input, &inertia_params(inertia), &mut xi, &mut lambda);
    let [norm, lambda_dot, _] = lambda;
    let scale = inertia.apply(omega_dot).norm() + inertia.apply(omega).norm() * omega.norm();
    if !(norm.is_finite() && norm > SINGULAR_REL_TOL * scale) {
        return Err(SuslovError::EulerSolution { norm, scale });
    }
    let mut blocks = xi.chunks_exact(DIM).map(Vector3::from_column_slice);
    let mut next = || blocks.next().expect("four blocks");
    let control = SingularControl {
        xi_tilde: next(),
        xi: next(),
        xi_dot: next(),
        lambda: norm,
        lambda_dot,
    };
    Ok((control, next()))
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
    // Ω⃛ only enters ξ̈_p and λ̈, which are dropped.
    let unused = Vector3::zeros();
    evaluate(inertia, [omega, omega_dot, omega_ddot, &unused]).map(|(c, _)| c)
}

/// [`singular_control`] plus `ξ̈_p`, from the full jet `(Ω_p, Ω̇_p, Ω̈_p, Ω⃛_p)`.
pub fn singular_jet(inertia: &Inertia, jet: &Jet) -> Result<SingularJet, SuslovError> {
    let (control, xi_ddot) = evaluate(inertia, [&jet.value, &jet.d1, &jet.d2, &jet.d3])?;
    Ok(SingularJet { control, xi_ddot })
}

/// [`singular_control`] of a path at time `t`, with its exact derivatives.
pub fn singular_control_at(
    path: &dyn DesiredPath,
    inertia: &Inertia,
    t: f64,
) -> Result<SingularControl, SuslovError> {
    let jet = path.jet(t);
    singular_control(inertia, &jet.value, &jet.d1, &jet.d2).map_err(|e| at_time(e, t))
}

/// [`singular_jet`] of a path at time `t`, with its exact derivatives.
pub fn singular_jet_at(
    path: &dyn DesiredPath,
    inertia: &Inertia,
    t: f64,
) -> Result<SingularJet, SuslovError> {
    singular_jet(inertia, &path.jet(t)).map_err(|e| at_time(e, t))
}

fn at_time(e: SuslovError, t: f64) -> SuslovError {
    match e {
        SuslovError::EulerSolution { norm, scale } => {
            SuslovError::EulerSolutionAt { t, norm, scale }
        }
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::so3::desired::{finite_difference_derivatives, Constant, PaperSpiral, PathEval};
    use crate::so3::equations::{suslov_multiplier, suslov_residual};
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
            fn jet(&self, t: f64) -> Jet {
                let c = singular_control_at(self.0.phi_par(), &Inertia::paper(), t).unwrap();
                Jet {
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
    fn xi_ddot_and_lambda_dot_are_exact() {
        // FD of (xi_dot, lambda) from singular_control_at vs xi_ddot, lambda_dot.
        struct XiDot(PaperSpiral, usize);
        impl DesiredPath for XiDot {
            fn jet(&self, t: f64) -> Jet {
                let c = singular_control_at(self.0.phi_par(), &Inertia::paper(), t).unwrap();
                let value = if self.1 == 0 {
                    c.xi_dot
                } else {
                    Vector3::new(c.lambda, 0.0, 0.0)
                };
                Jet {
                    value,
                    d1: Vector3::zeros(),
                    d2: Vector3::zeros(),
                    d3: Vector3::zeros(),
                }
            }
        }
        let p = PaperSpiral::paper();
        for t in [0.0, 0.7, 3.3, 8.1, 10.0] {
            let j = singular_jet_at(p.phi_par(), &Inertia::paper(), t).unwrap();
            let (fd, _, _) = finite_difference_derivatives(&XiDot(p.clone(), 0), t, 1e-2);
            assert_relative_eq!(j.xi_ddot, fd, max_relative = 1e-8, epsilon = 1e-8);
            let (fd, _, _) = finite_difference_derivatives(&XiDot(p.clone(), 1), t, 1e-2);
            assert_relative_eq!(
                j.control.lambda_dot,
                fd[0],
                max_relative = 1e-8,
                epsilon = 1e-9
            );
            // |xi| = 1: <xi, xi_ddot> = -|xi_dot|^2.
            assert_relative_eq!(
                j.control.xi.dot(&j.xi_ddot),
                -j.control.xi_dot.norm_squared(),
                max_relative = 1e-12,
                epsilon = 1e-12
            );
        }
    }

    /// The formulas of the module docs, evaluated independently of the generator (nalgebra,
    /// diagonal `I`).
    fn by_hand(i: &Inertia, jet: &Jet) -> (SingularControl, Vector3<f64>) {
        let (om, d1, d2) = (&jet.value, &jet.d1, &jet.d2);
        let i_om = i.apply(om);
        let i_d1 = i.apply(d1);
        let xi_tilde = i_d1 - i_om.cross(om);
        let norm = xi_tilde.norm();
        let xi = xi_tilde / norm;
        let xi_tilde_dot = i.apply(d2) - i_d1.cross(om) - i_om.cross(d1);
        let lambda_dot = xi.dot(&xi_tilde_dot);
        let xi_dot = (xi_tilde_dot - xi * lambda_dot) / norm;
        let xi_tilde_ddot =
            i.apply(&jet.d3) - i.apply(d2).cross(om) - i_d1.cross(d1) * 2.0 - i_om.cross(d2);
        let lambda_ddot = xi_dot.dot(&xi_tilde_dot) + xi.dot(&xi_tilde_ddot);
        let xi_ddot = (xi_tilde_ddot - xi_dot * (2.0 * lambda_dot) - xi * lambda_ddot) / norm;
        let c = SingularControl {
            xi_tilde,
            xi,
            xi_dot,
            lambda: norm,
            lambda_dot,
        };
        (c, xi_ddot)
    }

    #[test]
    fn generated_jet_agrees_with_an_independent_evaluation() {
        let p = PaperSpiral::paper();
        let segment = crate::so3::desired::ProjectedSegment::new(
            Inertia::paper(),
            p.omega_a(),
            p.omega_b(),
            0.0,
            10.0,
        )
        .unwrap();
        for i in [Inertia::paper(), Inertia::new([0.7, 1.9, 2.6]).unwrap()] {
            for path in [p.phi_par() as &dyn DesiredPath, &p, &segment] {
                for t in [0.0, 0.7, 3.3, 8.1, 9.9, 10.0] {
                    let jet = path.jet(t);
                    let (want, want_dd) = by_hand(&i, &jet);
                    let got = singular_jet(&i, &jet).unwrap();
                    let c = got.control;
                    let close = |a: &Vector3<f64>, b: &Vector3<f64>| {
                        (a - b).norm() <= 1e-12 * b.norm().max(1.0)
                    };
                    assert!(close(&c.xi_tilde, &want.xi_tilde), "t = {t}");
                    assert!(close(&c.xi, &want.xi), "t = {t}");
                    assert!(close(&c.xi_dot, &want.xi_dot), "t = {t}");
                    assert!(close(&got.xi_ddot, &want_dd), "t = {t}");
                    assert_relative_eq!(c.lambda, want.lambda, max_relative = 1e-14);
                    assert_relative_eq!(
                        c.lambda_dot,
                        want.lambda_dot,
                        max_relative = 1e-12,
                        epsilon = 1e-12
                    );
                    // Without Ω⃛ (singular_control): the same ξ̃, ξ_p, ξ̇_p, λ, λ̇, bit for bit.
                    let c2 = singular_control(&i, &jet.value, &jet.d1, &jet.d2).unwrap();
                    assert_eq!(c2, c);
                }
            }
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
