//! The pure Suslov equations with a time-varying constraint direction `ξ(t)`, as generated
//! (`suslov_omega_dot`, `suslov_q` of [`crate::model::generated`]; derived in `codegen/`):
//!
//! - `I Ω̇ = (IΩ) × Ω + λ ξ` (paper eq. `Suslov_eq_3D`),
//! - `λ = −(⟨Ω, ξ̇⟩ + ⟨(IΩ) × Ω, I⁻¹ξ⟩) / ⟨ξ, I⁻¹ξ⟩` (eq. `Suslov_lambda`),
//! - residual form `q(Ω, ξ) = ⟨ξ, I⁻¹ξ⟩[IΩ̇ − (IΩ) × Ω] + [⟨Ω, ξ̇⟩ + ⟨(IΩ) × Ω, I⁻¹ξ⟩] ξ`
//!   (eq. `Suslov_q`); `q = 0` iff `Ω̇` is the right-hand side above.
//!
//! Along a solution `⟨Ω, ξ⟩` is constant; with `⟨Ω(a), ξ(a)⟩ = 0` the energy `½⟨IΩ, Ω⟩` is
//! conserved.
//!
//! These are thin wrappers: the vectors are stacked into the generated functions' inputs
//! (`[Ω, ξ, ξ̇]`, `[Ω, Ω̇, ξ, ξ̇]`) and the constants come from [`inertia_params`] (only `I`
//! enters).

use nalgebra::Vector3;

use super::ellipsoid::Inertia;
use super::layout::stack;
use super::problem::inertia_params;
use crate::model::generated::{self as g, DIM};

/// `(Ω̇, λ)` from the generated `suslov_omega_dot`.
fn omega_dot_and_multiplier(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    xi: &Vector3<f64>,
    xi_dot: &Vector3<f64>,
) -> (Vector3<f64>, f64) {
    let x: [f64; 3 * DIM] = stack(&[omega.as_slice(), xi.as_slice(), xi_dot.as_slice()]);
    let mut omega_dot = [0.0; DIM];
    let lambda = g::suslov_omega_dot(&x, &inertia_params(inertia), &mut omega_dot);
    (Vector3::from(omega_dot), lambda)
}

/// The Lagrange multiplier `λ(Ω, ξ, ξ̇)` (eq. `Suslov_lambda`). Non-finite if `ξ = 0`.
pub fn suslov_multiplier(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    xi: &Vector3<f64>,
    xi_dot: &Vector3<f64>,
) -> f64 {
    omega_dot_and_multiplier(inertia, omega, xi, xi_dot).1
}

/// `Ω̇ = I⁻¹[(IΩ) × Ω + λ ξ]` (eq. `Suslov_eq_3D`).
pub fn suslov_rhs(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    xi: &Vector3<f64>,
    xi_dot: &Vector3<f64>,
) -> Vector3<f64> {
    omega_dot_and_multiplier(inertia, omega, xi, xi_dot).0
}

/// The residual `q(Ω, ξ)` of eq. `Suslov_q`, given `Ω̇` and `ξ̇`.
pub fn suslov_residual(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    omega_dot: &Vector3<f64>,
    xi: &Vector3<f64>,
    xi_dot: &Vector3<f64>,
) -> Vector3<f64> {
    let x: [f64; 4 * DIM] = stack(&[
        omega.as_slice(),
        omega_dot.as_slice(),
        xi.as_slice(),
        xi_dot.as_slice(),
    ]);
    let mut q = [0.0; DIM];
    g::suslov_q(&x, &inertia_params(inertia), &mut q);
    Vector3::from(q)
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

    /// The paper's formulas, evaluated independently of the generator (nalgebra, diagonal
    /// `I`): `(λ, Ω̇, q)`.
    fn by_hand(
        i: &Inertia,
        om: &Vector3<f64>,
        om_dot: &Vector3<f64>,
        xi: &Vector3<f64>,
        xi_dot: &Vector3<f64>,
    ) -> (f64, Vector3<f64>, Vector3<f64>) {
        let gyro = i.apply(om).cross(om);
        let inv_xi = i.apply_inv(xi);
        let den = xi.dot(&inv_xi);
        let lambda = -(om.dot(xi_dot) + gyro.dot(&inv_xi)) / den;
        let rhs = i.apply_inv(&(gyro + xi * lambda));
        let q = (i.apply(om_dot) - gyro) * den + xi * (om.dot(xi_dot) + gyro.dot(&inv_xi));
        (lambda, rhs, q)
    }

    #[test]
    fn the_wrappers_agree_with_an_independent_evaluation() {
        // SplitMix64, deterministic.
        let mut s = 0x5EED_u64;
        let mut next = move || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            2.0 * ((z >> 11) as f64 / (1u64 << 53) as f64) - 1.0
        };
        let mut v = || Vector3::new(2.0 * next(), 2.0 * next(), 2.0 * next());
        for k in 0..200 {
            let i = Inertia::new([1.0 + v().x.abs(), 1.0 + v().y.abs(), 0.2 + v().z.abs()])
                .expect("positive moments");
            let (om, om_dot, xi_dot) = (v(), v(), v());
            // Generic xi (not orthogonal to om), away from 0.
            let xi = v() + Vector3::new(0.5, -0.5, 0.5);
            let (lambda, rhs, q) = by_hand(&i, &om, &om_dot, &xi, &xi_dot);
            let scale = |a: &Vector3<f64>| a.norm().max(1.0);
            let lam = suslov_multiplier(&i, &om, &xi, &xi_dot);
            assert_relative_eq!(lam, lambda, max_relative = 1e-12, epsilon = 1e-12);
            let r = suslov_rhs(&i, &om, &xi, &xi_dot);
            assert!(
                (r - rhs).norm() <= 1e-12 * scale(&rhs),
                "{k}: {r:?} vs {rhs:?}"
            );
            let qq = suslov_residual(&i, &om, &om_dot, &xi, &xi_dot);
            assert!((qq - q).norm() <= 1e-12 * scale(&q), "{k}: {qq:?} vs {q:?}");
            // On a solution (Ω̇ from the right-hand side) both residuals vanish.
            let q0 = suslov_residual(&i, &om, &rhs, &xi, &xi_dot);
            assert!(q0.norm() <= 1e-12 * scale(&q), "{k}: {q0:?}");
        }
    }
}
