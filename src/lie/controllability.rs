//! The accessibility rank test (paper section 4.3) for any model: along a solution, at a
//! given state and at seeded random states of `M`.
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
//! [`crate::so3::controllability`]; along a solution ([`rank_along`]) and at a given state
//! ([`rank_at`]) the state tested is the nearest one on the constraint level
//! `φ = ⟨Ω, ξ⟩ − γ(ξ) = 0` (`ξ` moved along `∂φ/∂ξ` by Newton steps on the generated
//! `constraint_residual`; the violation of the state as given is reported separately) and, for
//! `γ = 0`, `ξ` is scaled to unit length (the rank does not depend on it, the conditioning
//! does). At a given state, `Ω` and `ξ` far from unit scale (a component beyond `2²⁰`, or all
//! below `2⁻²⁰`) are rescaled by exact powers of two before `V` is evaluated, as in the so(3)
//! layer ([`StateRank::scales`]).
//!
//! [`sample_states`] draws seeded random states of `M`: `Ω` a point drawn uniformly in
//! `[−1, 1]ⁿ`, projected radially ([`LevelSet::project`]) onto the energy level set
//! `⟨Ω, 𝕀Ω⟩ = ⟨Ω_a, 𝕀Ω_a⟩` through a given `Ω_a`, `ξ` uniform in `[−1, 1]ⁿ` and moved onto
//! the constraint level. With a nonzero constraint value `M` is the constraint level alone and
//! the energy is not fixed on it; `Ω` is put on the level set of `Ω_a` all the same: that is
//! one choice of states of `M` (a slice of it), not the only one.
//!
//! # Example: the rank along the paper's η = 0.01 solution
//!
//! ```
//! use suslov::lie::controllability::{rank_along, RANK_RTOL};
//! use suslov::{paper, solve, SolveOptions};
//!
//! let solution = solve(&paper::problem(0.01), &SolveOptions::default(), &mut |_| {})?;
//! let along = rank_along(&solution.generic, 50, RANK_RTOL);
//! assert_eq!(along.dim_m, 4); // so(3): M = {⟨Ω, ξ⟩ = 0, energy fixed}, 2n − 2 = 4
//! assert_eq!((along.min_rank, along.max_rank), (4, 4)); // accessible at every sample
//! assert!(along.min_sigma_dim_m > 1e-6 && along.max_sigma_next < 1e-9);
//! # Ok::<(), suslov::SolveError>(())
//! ```

use nalgebra::DMatrix;

use crate::model::{constraint_value_vanishes, Model};

use super::path::{LevelSet, PathError};
use super::solve::LieSolution;

/// Default relative threshold of the numerical rank: `σₖ` counts if `σₖ > RANK_RTOL · σ₁`.
pub const RANK_RTOL: f64 = 1e-9;

/// A state's components are used as given while `max |vₖ|` lies in `[2^−20, 2^20]`; beyond,
/// the vector is rescaled by an exact power of two first.
pub const STATE_SCALE_MAX_EXP: i32 = 20;

/// What the states tested show about the accessibility theorem (rank `V` = `dim M` on `M`;
/// 4 for so(3), the paper's).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "verdict", rename_all = "snake_case")]
pub enum AccessibilityVerdict {
    /// Rank `dim M` at every state of `M` tested (and there was at least one).
    Accessible {
        /// States of `M` tested.
        on_m: usize,
    },
    /// Some state of `M` has a numerical rank other than `dim M`.
    RankDeficient {
        /// States of `M` tested.
        on_m: usize,
        /// Those whose rank is not `dim M`.
        failing: usize,
    },
    /// No state tested lies on `M`: the theorem says nothing about them.
    NoStateOnM,
}

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

/// The accessibility matrix `V = [g₁ … gₙ, [gᵢ, gⱼ] (i < j)]` at `x = [Ω, ξ]` (`2n` rows).
fn accessibility_matrix<M: Model>(x: &[f64], params: &[f64]) -> DMatrix<f64> {
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
    DMatrix::from_fn(nx, cols.len(), |r, c| cols[c][r])
}

fn sorted_singular_values(v: &DMatrix<f64>) -> Vec<f64> {
    let mut sv: Vec<f64> = v.singular_values().iter().copied().collect();
    sv.sort_by(|a, b| b.total_cmp(a));
    sv
}

/// The singular values of `V` at `x = [Ω, ξ]` (`2n` entries), largest first.
pub fn singular_values<M: Model>(x: &[f64], params: &[f64]) -> Vec<f64> {
    sorted_singular_values(&accessibility_matrix::<M>(x, params))
}

/// [`singular_values`], or `None` when an entry of `V` is not finite in `f64` (the SVD is
/// not run on such a matrix: it need not return).
pub fn try_singular_values<M: Model>(x: &[f64], params: &[f64]) -> Option<Vec<f64>> {
    let v = accessibility_matrix::<M>(x, params);
    v.iter()
        .all(|e| e.is_finite())
        .then(|| sorted_singular_values(&v))
}

/// `dim M` for the constants `params`: `2n − 2` when the constraint value vanishes (the
/// energy is conserved), `2n − 1` otherwise (module docs).
pub fn dim_m<M: Model>(params: &[f64]) -> usize {
    M::XIDOT.start
        - if constraint_value_vanishes::<M>(params) {
            2
        } else {
            1
        }
}

/// The power of two nearest to `max |vₖ|` (1 for a zero or non-finite `v`): dividing by it is
/// exact and brings the entries near 1.
fn power_of_two_scale(v: &[f64]) -> f64 {
    let m = v.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
    if m > 0.0 && m.is_finite() {
        2f64.powi(m.log2().round() as i32)
    } else {
        1.0
    }
}

/// `|v|`, without over- or underflow in the squares.
fn norm(v: &[f64]) -> f64 {
    let m = power_of_two_scale(v);
    m * v.iter().map(|e| (e / m) * (e / m)).sum::<f64>().sqrt()
}

/// `|φ| / (|Ω| |ξ|)` (`|φ|` when `Ω = 0` or `ξ = 0`), without over- or underflow in the
/// norms and their product.
fn relative_violation<M: Model>(x: &[f64], phi: f64) -> f64 {
    let (a, b) = (norm(&x[M::OMEGA]), norm(&x[M::XI]));
    if a > 0.0 && b > 0.0 {
        phi.abs() / a / b
    } else {
        phi.abs()
    }
}

/// `φ = ⟨Ω, ξ⟩ − γ(ξ)` at `x`.
fn constraint_value_at<M: Model>(x: &[f64], params: &[f64]) -> f64 {
    let mut grad = vec![0.0; M::XIDOT.start];
    M::constraint_residual(x, params, &mut grad)
}

/// Moves `x` onto the constraint level ([`onto_constraint_level`]) and, when the energy is
/// conserved (`⟨Ω, ξ⟩ = 0`, homogeneous in `ξ`), scales `ξ` to unit length. Returns `φ`
/// before the move.
fn onto_m<M: Model>(x: &mut [f64], params: &[f64], conserves_energy: bool) -> f64 {
    let phi = onto_constraint_level::<M>(x, params);
    if conserves_energy {
        let xi_norm = norm(&x[M::XI]);
        if xi_norm > 0.0 && xi_norm.is_finite() {
            x[M::XI].iter_mut().for_each(|v| *v /= xi_norm);
        }
    }
    phi
}

/// Move `x = [Ω, ξ]` onto the constraint level `φ = 0` along `∂φ/∂ξ` (a few Newton steps on
/// the generated `constraint_residual`; one is exact for a `γ` that does not depend on `ξ`).
/// Returns `|φ|` before the move.
pub fn onto_constraint_level<M: Model>(x: &mut [f64], params: &[f64]) -> f64 {
    let mut grad = vec![0.0; M::XIDOT.start];
    let before = M::constraint_residual(x, params, &mut grad);
    let mut phi = before;
    for _ in 0..8 {
        // The step φ ∇/|∇|² with ∇ scaled by a power of two m (exact, and the same bits
        // wherever the unscaled squares neither over- nor underflow).
        let m = power_of_two_scale(&grad[M::XI]);
        let g: Vec<f64> = grad[M::XI].iter().map(|v| v / m).collect();
        let g2: f64 = g.iter().map(|v| v * v).sum();
        if phi == 0.0 || g2.is_nan() || g2 <= 0.0 {
            break;
        }
        let step = phi / m / g2;
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
        let scale = norm(&x[M::OMEGA]) * norm(&x[M::XI]);
        let phi = onto_m::<M>(&mut x, sol.problem.params(), conserves_energy);
        violation = violation.max(phi.abs() / scale);
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

/// A state counts as on the constraint level when `|φ| ≤ ON_LEVEL_RTOL · |Ω| |ξ|`; the state
/// tested is on `M` when, in addition, `Ω ≠ 0` (at rest the energy is 0, and with a nonzero
/// constraint value `φ(0, ξ) = −γ(ξ)` cannot vanish).
pub const ON_LEVEL_RTOL: f64 = 1e-12;

/// Why the rank test cannot run at a state, or no states can be sampled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StateError {
    /// The state does not have `2n` entries.
    #[error("the state [Omega, xi] has {got} entries; model {model} needs 2n = {expected}")]
    Length {
        /// The model.
        model: &'static str,
        /// `2n`.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// An entry of the state is not finite.
    #[error("the state [Omega, xi] has an entry that is not a finite number")]
    NotFinite,
    /// `ξ = 0`: no constraint.
    #[error("xi = 0 is no constraint (M needs xi != 0); give a nonzero xi")]
    ZeroXi,
    /// Moving onto the constraint level sends `ξ` to 0 (e.g. `ξ ∥ Ω` for `⟨Ω, ξ⟩ = 0`).
    #[error(
        "the nearest state on the constraint level has xi = 0 (xi lies along the gradient of \
         the constraint, e.g. parallel to Omega for <Omega, xi> = 0); give a xi with a \
         component across it"
    )]
    XiVanishesOnLevel,
    /// `V` is not finite in `f64` at the state.
    #[error(
        "the accessibility matrix V at this state is not finite in f64 (products of the \
         inertia parameters and powers of Omega or xi overflow or underflow); bring Omega and \
         the inertia parameters nearer to unit scale"
    )]
    FieldsNotFinite,
    /// No energy level set through `Ω_a` (zero, not finite, or its level out of range).
    #[error("{0}")]
    LevelSet(#[from] PathError),
    /// Every draw was rejected.
    #[error(
        "no state of M on the energy level set through Omega_a could be represented in f64 in \
         {attempts} draws (the projection onto the level set or the fields over- or \
         underflow); bring the inertia parameters and Omega_a nearer to unit scale"
    )]
    NoSample {
        /// Draws made.
        attempts: usize,
    },
}

/// The rank test at one state `x = [Ω, ξ]` ([`rank_at`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StateRank {
    /// `dim M` (`2n − 2`, or `2n − 1` with a nonzero constraint value).
    pub dim_m: usize,
    /// `|φ| / (|Ω| |ξ|)` at the state as given (`|φ|` if `Ω = 0`): 0 on the constraint level.
    pub violation: f64,
    /// Whether the state as given was off the constraint level by more than
    /// [`ON_LEVEL_RTOL`], so that the state tested is another one.
    pub moved: bool,
    /// The state tested, `[Ω, ξ]`: the given one moved onto the constraint level and, when the
    /// energy is conserved, with `ξ` of unit length.
    pub tested: Vec<f64>,
    /// `|φ| / (|Ω| |ξ|)` at the state tested.
    pub residual: f64,
    /// Whether the state tested lies on `M` ([`ON_LEVEL_RTOL`], `Ω ≠ 0`).
    pub on_m: bool,
    /// Numerical rank of `V` at the state tested.
    pub rank: usize,
    /// Singular values of `V`, largest first.
    pub singular_values: Vec<f64>,
    /// `σ_{dim M} / σ₁`.
    pub sigma_dim_m: f64,
    /// `σ_{dim M + 1} / σ₁` (0 if `V` has fewer singular values).
    pub sigma_next: f64,
    /// `(e_Ω, e_ξ)`: `V` and its singular values are those at `(2^{−e_Ω} Ω, 2^{−e_ξ} ξ)` of the
    /// state tested, which leaves the rank unchanged (`(0, 0)` while every `max |vₖ|` lies in
    /// `[2^−20, 2^20]`; always `(0, 0)` for a `ξ`-dependent constraint value).
    pub scales: (i32, i32),
}

/// The accessibility rank test at the state `x = [Ω, ξ]` (`2n` entries) of model `M` with the
/// constants `params` (inertia and constraint parameters, derived constants filled): the state
/// is moved onto the constraint level (its violation is reported), `ξ` is scaled to unit length
/// when the energy is conserved, and the rank of `V` there is `#{σₖ > rtol · σ₁}`.
///
/// Errors for a wrong length, a non-finite entry, `ξ = 0` (also after the move), and a `V`
/// that is not finite in `f64`.
pub fn rank_at<M: Model>(x: &[f64], params: &[f64], rtol: f64) -> Result<StateRank, StateError> {
    let nx = M::XIDOT.start;
    if x.len() != nx {
        return Err(StateError::Length {
            model: M::NAME,
            expected: nx,
            got: x.len(),
        });
    }
    if !x.iter().all(|v| v.is_finite()) {
        return Err(StateError::NotFinite);
    }
    if x[M::XI].iter().all(|v| *v == 0.0) {
        return Err(StateError::ZeroXi);
    }
    let conserves_energy = constraint_value_vanishes::<M>(params);
    let dim_m = nx - if conserves_energy { 2 } else { 1 };
    let mut tested = x.to_vec();
    let phi = onto_m::<M>(&mut tested, params, conserves_energy);
    if !tested.iter().all(|v| v.is_finite()) {
        return Err(StateError::FieldsNotFinite);
    }
    if tested[M::XI].iter().all(|v| *v == 0.0) {
        return Err(StateError::XiVanishesOnLevel);
    }
    let violation = relative_violation::<M>(x, phi);
    let residual = relative_violation::<M>(&tested, constraint_value_at::<M>(&tested, params));
    let (evaluated, scales) = evaluation_state::<M>(&tested);
    let sv = try_singular_values::<M>(&evaluated, params).ok_or(StateError::FieldsNotFinite)?;
    let top = sv[0];
    let rank = sv.iter().filter(|s| **s > rtol * top).count();
    let at = |k: usize| sv.get(k).map_or(0.0, |s| s / top);
    Ok(StateRank {
        dim_m,
        violation,
        moved: violation > ON_LEVEL_RTOL,
        on_m: residual <= ON_LEVEL_RTOL && tested[M::OMEGA].iter().any(|v| *v != 0.0),
        residual,
        rank,
        sigma_dim_m: at(dim_m - 1),
        sigma_next: at(dim_m),
        singular_values: sv,
        tested,
        scales,
    })
}

/// The exponent `e` of the power of two that brings `max |vₖ|` near 1, `0` where it already
/// lies in `[2^−STATE_SCALE_MAX_EXP, 2^STATE_SCALE_MAX_EXP]` (or `v` is zero or not finite).
fn scale_exponent(v: &[f64]) -> i32 {
    let m = v.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
    if !(m.is_finite() && m > 0.0) {
        return 0;
    }
    let e = m.log2().round() as i32;
    if e.abs() <= STATE_SCALE_MAX_EXP {
        0
    } else {
        e
    }
}

/// The state at which `V` is evaluated for the state `x`, and its scales `(e_Ω, e_ξ)`:
/// `(2^{−e_Ω} Ω, 2^{−e_ξ} ξ)` ([`StateRank::scales`]). Without a `ξ`-dependent constraint
/// value the rank of `V` does not depend on them: `Ω̇ = 𝕀⁻¹(ad*_Ω 𝕀Ω + λξ)` with `λ` from
/// `φ̇ = 0` makes the `Ω`-block of each `gᵢ` and `[gᵢ, gⱼ]` homogeneous of degree 1 in `Ω`
/// (so `V(sΩ, ξ) = diag(s, 1) V(Ω, ξ)`) and of degrees −1 and −2 in `ξ` (a row and a column
/// scaling), while the `ξ`-block is `[Id, 0]`. With a `ξ`-dependent `γ` it is used as given.
fn evaluation_state<M: Model>(x: &[f64]) -> (Vec<f64>, (i32, i32)) {
    if M::CONSTRAINT_VALUE_DEPENDS_ON_XI {
        return (x.to_vec(), (0, 0));
    }
    let scales = (scale_exponent(&x[M::OMEGA]), scale_exponent(&x[M::XI]));
    let mut y = x.to_vec();
    for (block, e) in [(M::OMEGA, scales.0), (M::XI, scales.1)] {
        // In two steps, so that neither factor overflows or underflows; exact.
        let half = -e / 2;
        y[block]
            .iter_mut()
            .for_each(|v| *v = *v * 2f64.powi(half) * 2f64.powi(-e - half));
    }
    (y, scales)
}

/// SplitMix64, as uniform numbers in `[−1, 1)` (the so(3) layer's sampler uses the same).
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        2.0 * ((z >> 11) as f64 / (1u64 << 53) as f64) - 1.0
    }
}

/// `samples` seeded random states `[Ω, ξ]` of `M` for model `M` with the constants `params`
/// (module docs): `Ω` drawn uniformly in `[−1, 1]ⁿ`, projected radially onto the energy level set
/// `⟨Ω, 𝕀Ω⟩ = ⟨Ω_a, 𝕀Ω_a⟩` (𝕀 the model's `inertia_matrix`); `ξ` uniform in `[−1, 1]ⁿ`,
/// moved onto the constraint level ([`onto_constraint_level`]) and, when the energy is
/// conserved, scaled to unit length. With a nonzero constraint value `M` is the constraint
/// level alone (`dim M = 2n − 1`) and fixing the energy of `Ω` is one choice of states on it.
///
/// A draw is rejected (and another made) when its direction is short (`|d| < 1e-3`), its
/// projection or its `V` is not finite, or its `ξ` nearly vanishes on the level. Errors when
/// `omega_a` spans no level set (zero, not finite, wrong length, level out of range) or every
/// one of `1000 + 10 · samples` draws is rejected.
pub fn sample_states<M: Model>(
    params: &[f64],
    omega_a: &[f64],
    samples: usize,
    seed: u64,
) -> Result<Vec<Vec<f64>>, StateError> {
    let n = M::DIM;
    let mut inertia = vec![0.0; n * n];
    M::inertia_matrix(params, &mut inertia);
    let set = LevelSet::through(&inertia, n, omega_a)?;
    let conserves_energy = constraint_value_vanishes::<M>(params);
    let mut rng = SplitMix(seed);
    let mut out = Vec::with_capacity(samples);
    let max_attempts = 1000 + 10 * samples;
    let mut attempts = 0;
    while out.len() < samples {
        attempts += 1;
        if attempts > max_attempts {
            return Err(StateError::NoSample {
                attempts: max_attempts,
            });
        }
        let d: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        let r: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        if norm(&d) < 1e-3 {
            continue;
        }
        let Ok(omega) = set.project(&d) else {
            continue;
        };
        let mut x = vec![0.0; M::XIDOT.start];
        x[M::OMEGA].copy_from_slice(&omega);
        x[M::XI].copy_from_slice(&r);
        onto_constraint_level::<M>(&mut x, params);
        let xi_norm = norm(&x[M::XI]);
        if !(xi_norm.is_finite() && xi_norm > 1e-3 * norm(&r)) {
            continue;
        }
        if conserves_energy {
            x[M::XI].iter_mut().for_each(|v| *v /= xi_norm);
        }
        let on_level =
            relative_violation::<M>(&x, constraint_value_at::<M>(&x, params)) <= ON_LEVEL_RTOL;
        if !on_level || try_singular_values::<M>(&evaluation_state::<M>(&x).0, params).is_none() {
            continue;
        }
        out.push(x);
    }
    Ok(out)
}
