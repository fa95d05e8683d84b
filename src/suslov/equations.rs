//! The pure Suslov equations with a time-varying constraint direction `ξ(t)`.
//!
//! - `I Ω̇ = (IΩ) × Ω + λ ξ` (paper eq. `Suslov_eq_3D`),
//! - `λ = −(⟨Ω, ξ̇⟩ + ⟨(IΩ) × Ω, I⁻¹ξ⟩) / ⟨ξ, I⁻¹ξ⟩` (eq. `Suslov_lambda`),
//! - residual form `q(Ω, ξ) = ⟨ξ, I⁻¹ξ⟩[IΩ̇ − (IΩ) × Ω] + [⟨Ω, ξ̇⟩ + ⟨(IΩ) × Ω, I⁻¹ξ⟩] ξ`
//!   (eq. `Suslov_q`); `q = 0` iff `Ω̇` is the right-hand side above.
//!
//! Along a solution `⟨Ω, ξ⟩` is constant; with `⟨Ω(a), ξ(a)⟩ = 0` the energy `½⟨IΩ, Ω⟩` is
//! conserved.

use nalgebra::Vector3;

use super::ellipsoid::Inertia;

/// The Lagrange multiplier `λ(Ω, ξ, ξ̇)` (eq. `Suslov_lambda`). Non-finite if `ξ = 0`.
pub fn suslov_multiplier(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    xi: &Vector3<f64>,
    xi_dot: &Vector3<f64>,
) -> f64 {
    let gyro = inertia.apply(omega).cross(omega);
    let inv_xi = inertia.apply_inv(xi);
    -(omega.dot(xi_dot) + gyro.dot(&inv_xi)) / xi.dot(&inv_xi)
}

/// `Ω̇ = I⁻¹[(IΩ) × Ω + λ ξ]` (eq. `Suslov_eq_3D`).
pub fn suslov_rhs(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    xi: &Vector3<f64>,
    xi_dot: &Vector3<f64>,
) -> Vector3<f64> {
    let lambda = suslov_multiplier(inertia, omega, xi, xi_dot);
    inertia.apply_inv(&(inertia.apply(omega).cross(omega) + xi * lambda))
}

/// The residual `q(Ω, ξ)` of eq. `Suslov_q`, given `Ω̇` and `ξ̇`.
pub fn suslov_residual(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    omega_dot: &Vector3<f64>,
    xi: &Vector3<f64>,
    xi_dot: &Vector3<f64>,
) -> Vector3<f64> {
    let gyro = inertia.apply(omega).cross(omega);
    let inv_xi = inertia.apply_inv(xi);
    (inertia.apply(omega_dot) - gyro) * xi.dot(&inv_xi)
        + xi * (omega.dot(xi_dot) + gyro.dot(&inv_xi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn rhs_zeroes_the_residual_and_preserves_constraint_and_energy_rates() {
        let i = Inertia::paper();
        let om = Vector3::new(1.0, -2.0, 0.5);
        // xi orthogonal to om.
        let xi = Vector3::new(2.0, 1.0, 0.0) * 0.7;
        let xi_dot = Vector3::new(0.3, -0.1, 0.9);
        let om_dot = suslov_rhs(&i, &om, &xi, &xi_dot);
        let q = suslov_residual(&i, &om, &om_dot, &xi, &xi_dot);
        assert!(q.norm() < 1e-14, "{q:?}");
        // d/dt <Om, xi> = <Om_dot, xi> + <Om, xi_dot> = 0.
        assert_relative_eq!(om_dot.dot(&xi) + om.dot(&xi_dot), 0.0, epsilon = 1e-14);
        // dT/dt = lambda <Om, xi> = 0.
        assert_relative_eq!(i.apply(&om).dot(&om_dot), 0.0, epsilon = 1e-14);
        // Scale invariance of q in xi (paper eq. Suslov_q_sub, constant factor).
        let q2 = suslov_residual(&i, &om, &om_dot, &(xi * 3.0), &(xi_dot * 3.0));
        assert!(q2.norm() < 1e-13, "{q2:?}");
    }
}
