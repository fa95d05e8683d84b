//! The accessibility rank test (paper section 4.3) for any model, along a solution.
//!
//! Suslov's pure equations as a control-affine system `ẋ = f(x) + Σᵢ gᵢ(x) uᵢ`, `x = [Ω, ξ]`
//! (`2n`), `u = ξ̇`: the fields and the first-order Lie brackets `[gᵢ, gⱼ]` are the model's
//! generated `control_fields` and `lie_brackets`. The accessibility matrix
//! `V = [g₁ … gₙ, [gᵢ, gⱼ] (i < j)]` has at most rank `dim M` on the manifold `M` every field
//! is tangent to:
//! - constraint value 0: `M = {⟨Ω, ξ⟩ = 0, ½⟨Ω, 𝕀Ω⟩ = e}`, `dim M = 2n − 2`;
//! - a nonzero constraint value `γ`: the energy is not conserved (`Ṫ = λγ`), and
//!   `M = {⟨Ω, ξ⟩ = γ(ξ)}`, `dim M = 2n − 1`.
//!
//! The numerical rank is `#{k : σₖ > rtol · σ₁}` (SVD), as in
//! [`crate::suslov::controllability`]; along a solution the state tested is the nearest one on
//! the constraint level `φ = ⟨Ω, ξ⟩ − γ(ξ) = 0` (`ξ` moved along `∂φ/∂ξ` by Newton steps on the
//! generated `constraint_residual`) and, for `γ = 0`, `ξ` is scaled to unit length (the rank
//! does not depend on it, the conditioning does).

use nalgebra::DMatrix;

use crate::model::Model;

use super::solve::LieSolution;

/// The rank test at one state.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RankAt {
    /// Time.
    pub t: f64,
    /// Numerical rank of `V`.
    pub rank: usize,
    /// `σ_{dim M} / σ₁`: the smallest singular value that full rank on `M` needs, relative.
    pub sigma_dim_m: f64,
    /// `σ_{dim M + 1} / σ₁`: the first one that must vanish on `M`, relative.
    pub sigma_next: f64,
}

/// The rank test along a solution.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RankAlong {
    /// `dim M`: `2n − 2`, or `2n − 1` with a nonzero constraint value (module docs).
    pub dim_m: usize,
    /// The relative threshold.
    pub rtol: f64,
    /// Smallest rank met.
    pub min_rank: usize,
    /// Largest rank met.
    pub max_rank: usize,
    /// Smallest `σ_{dim M} / σ₁` met (the margin of full rank).
    pub min_sigma_dim_m: f64,
    /// Largest `σ_{dim M + 1} / σ₁` met (0 up to round-off: the states tested are on `M`).
    pub max_sigma_next: f64,
    /// The solution's largest `|φ| / (|Ω| |ξ|)`, `φ = ⟨Ω, ξ⟩ − γ(ξ)`, at the sampled times
    /// (the states tested are moved onto `φ = 0`).
    pub max_constraint: f64,
    /// Every sampled state.
    pub samples: Vec<RankAt>,
}

/// The singular values of `V` at `x = [Ω, ξ]` (`2n` entries), largest first.
pub fn singular_values<M: Model>(x: &[f64], params: &[f64]) -> Vec<f64> {
    let nx = M::XIDOT.start;
    let mut fields = vec![0.0; (M::DIM + 1) * nx];
    let mut brackets = vec![0.0; M::N_BRACKETS * nx];
    M::control_fields(x, params, &mut fields);
    M::lie_brackets(x, params, &mut brackets);
    // Columns of V: g_1..g_n (rows 1..=n of `fields`; row 0 is f), then the brackets.
    let cols: Vec<&[f64]> = fields
        .chunks_exact(nx)
        .skip(1)
        .chain(brackets.chunks_exact(nx))
        .collect();
    let v = DMatrix::from_fn(nx, cols.len(), |r, c| cols[c][r]);
    let mut sv: Vec<f64> = v.singular_values().iter().copied().collect();
    sv.sort_by(|a, b| b.total_cmp(a));
    sv
}

/// Move `x = [Ω, ξ]` onto the constraint level `φ = 0` along `∂φ/∂ξ` (a few Newton steps on
/// the generated `constraint_residual`; one is exact for a `γ` that does not depend on `ξ`).
/// Returns `|φ|` before the move.
pub fn onto_constraint_level<M: Model>(x: &mut [f64], params: &[f64]) -> f64 {
    let mut grad = vec![0.0; M::XIDOT.start];
    let before = M::constraint_residual(x, params, &mut grad);
    let mut phi = before;
    for _ in 0..8 {
        let g = &grad[M::XI];
        let g2: f64 = g.iter().map(|v| v * v).sum();
        if phi == 0.0 || g2.is_nan() || g2 <= 0.0 {
            break;
        }
        let step = phi / g2;
        let g = g.to_vec();
        x[M::XI]
            .iter_mut()
            .zip(&g)
            .for_each(|(xi, gi)| *xi -= step * gi);
        let next = M::constraint_residual(x, params, &mut grad);
        if next.is_nan() || next.abs() >= phi.abs() {
            break;
        }
        phi = next;
    }
    before
}

/// The rank test at `points` uniform times of `sol`'s interval.
pub fn rank_along<M: Model>(sol: &LieSolution<M>, points: usize, rtol: f64) -> RankAlong {
    let conserves_energy = sol.problem.conserves_energy();
    let dim_m = M::XIDOT.start - if conserves_energy { 2 } else { 1 };
    let (a, b) = (sol.problem.t0, sol.terminal_time());
    let mut y = vec![0.0; M::N_STATE];
    let mut samples = Vec::with_capacity(points);
    let mut violation = 0.0_f64;
    for k in 0..points {
        let t = a + (b - a) * k as f64 / (points.max(2) - 1) as f64;
        sol.state_into(t, &mut y);
        let mut x = y[..M::XIDOT.start].to_vec();
        // The solution keeps φ = 0 to ~1e-10, and off the constraint level the rank rises by
        // one with a singular value ∝ |φ|: test the state of M nearest to it and report the
        // violation separately.
        let norm = |v: &[f64]| v.iter().map(|e| e * e).sum::<f64>().sqrt();
        let scale = norm(&x[M::OMEGA]) * norm(&x[M::XI]);
        let phi = onto_constraint_level::<M>(&mut x, sol.problem.params());
        violation = violation.max(phi.abs() / scale);
        if conserves_energy {
            // ⟨Ω, ξ⟩ = 0 is homogeneous in ξ: scale it to unit length.
            let xi_norm = norm(&x[M::XI]);
            x[M::XI].iter_mut().for_each(|v| *v /= xi_norm);
        }
        let sv = singular_values::<M>(&x, sol.problem.params());
        let top = sv[0];
        let rank = sv.iter().filter(|s| **s > rtol * top).count();
        let at = |k: usize| sv.get(k).map_or(0.0, |s| s / top);
        samples.push(RankAt {
            t,
            rank,
            sigma_dim_m: at(dim_m - 1),
            sigma_next: at(dim_m),
        });
    }
    RankAlong {
        dim_m,
        rtol,
        min_rank: samples.iter().map(|s| s.rank).min().unwrap_or(0),
        max_rank: samples.iter().map(|s| s.rank).max().unwrap_or(0),
        min_sigma_dim_m: samples
            .iter()
            .map(|s| s.sigma_dim_m)
            .fold(f64::INFINITY, f64::min),
        max_sigma_next: samples.iter().map(|s| s.sigma_next).fold(0.0, f64::max),
        max_constraint: violation,
        samples,
    }
}
