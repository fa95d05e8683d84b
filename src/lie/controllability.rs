//! The accessibility rank test (paper section 4.3) for any model, along a solution.
//!
//! Suslov's pure equations as a control-affine system `ẋ = f(x) + Σᵢ gᵢ(x) uᵢ`, `x = [Ω, ξ]`
//! (`2n`), `u = ξ̇`: the fields and the first-order Lie brackets `[gᵢ, gⱼ]` are the model's
//! generated `control_fields` and `lie_brackets`. The accessibility matrix
//! `V = [g₁ … gₙ, [gᵢ, gⱼ] (i < j)]` has at most rank `dim M = 2n − 2` on the constraint
//! manifold `M = {⟨Ω, ξ⟩ = 0, ½⟨Ω, 𝕀Ω⟩ = e}` (every field is tangent to it). The numerical rank
//! is `#{k : σₖ > rtol · σ₁}` (SVD), as in [`crate::suslov::controllability`]; along a
//! solution `ξ` is projected onto `Ω^⊥` (the nearest state of `M`) and scaled to unit length
//! (the rank does not depend on it, the conditioning does).

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
    /// `dim M = 2n − 2`.
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
    /// The solution's largest `|⟨Ω, ξ⟩| / (|Ω| |ξ|)` at the sampled times (the states
    /// tested have `ξ` projected onto `Ω^⊥`).
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

/// The rank test at `points` uniform times of `sol`'s interval.
pub fn rank_along<M: Model>(sol: &LieSolution<M>, points: usize, rtol: f64) -> RankAlong {
    let dim_m = M::XIDOT.start - 2;
    let (a, b) = (sol.problem.t0, sol.terminal_time());
    let mut y = vec![0.0; M::N_STATE];
    let mut samples = Vec::with_capacity(points);
    let mut violation = 0.0_f64;
    for k in 0..points {
        let t = a + (b - a) * k as f64 / (points.max(2) - 1) as f64;
        sol.state_into(t, &mut y);
        let mut x = y[..M::XIDOT.start].to_vec();
        // The solution keeps ⟨Ω, ξ⟩ = 0 to ~1e-10, and off M the rank rises by one with a
        // singular value ∝ |⟨Ω, ξ⟩|: test the state of M nearest to it (ξ projected onto Ω^⊥)
        // and report the violation separately.
        let (om, xi) = x.split_at_mut(M::XI.start);
        let xi = &mut xi[..M::DIM];
        let dot: f64 = om.iter().zip(xi.iter()).map(|(a, b)| a * b).sum();
        let om2: f64 = om.iter().map(|v| v * v).sum();
        let xi_norm = xi.iter().map(|v| v * v).sum::<f64>().sqrt();
        violation = violation.max(dot.abs() / (om2.sqrt() * xi_norm));
        xi.iter_mut()
            .zip(om.iter())
            .for_each(|(x, o)| *x -= o * dot / om2.max(f64::MIN_POSITIVE));
        let norm = xi.iter().map(|v| v * v).sum::<f64>().sqrt();
        xi.iter_mut().for_each(|v| *v /= norm);
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
