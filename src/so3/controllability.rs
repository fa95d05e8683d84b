//! Controllability and accessibility of Suslov's pure equations (paper section 4.3,
//! `sec_controllability`).
//!
//! With the state `x = [Ω, ξ] ∈ ℝ⁶` and the control `u = ξ̇`, Suslov's pure equations are the
//! control-affine system `ẋ = f(x) + Σᵢ gᵢ(x) uᵢ` (eq. `state_eqns`). The fields are *derived*
//! in `codegen/control.py` from the generator's own Suslov equations (`gᵢ = ∂ẋ/∂uᵢ`,
//! `f = ẋ|_{u=0}`, affinity checked symbolically) and the Lie brackets
//! `[gᵢ, gⱼ] = (Dgⱼ) gᵢ − (Dgᵢ) gⱼ` by sympy Jacobians; they are emitted as
//! [`generated::control_fields`] and [`generated::lie_brackets`]. Writing `η = I⁻¹ξ` and
//! `den = ⟨ξ, η⟩`:
//!
//! - `f = [I⁻¹((IΩ) × Ω) − η ⟨(IΩ) × Ω, η⟩/den ; 0]` (eq. `state_f`),
//! - `gᵢ = [−Ωᵢ η/den ; eᵢ]` (eq. `state_gi`),
//! - `[gᵢ, gⱼ] = [(Ωⱼηᵢ − Ωᵢηⱼ) η/den² + I⁻¹(Ωᵢeⱼ − Ωⱼeᵢ)/den ; 0]` (the paper's bracket).
//!
//! All three agree exactly with the paper's printed formulas, and `V = [g₁, g₂, g₃, [g₁,g₂],
//! [g₁,g₃], [g₂,g₃]]` with its eqs. `Veqn`/`Aeqn` (symbolic test
//! `codegen/tests/test_control.py`; numerically in this module's tests).
//!
//! # Ranks (exact rational arithmetic in the Python test, SVD here)
//!
//! - **On `M = {½⟨IΩ,Ω⟩ = e_S > 0, ⟨Ω,ξ⟩ = 0, ξ ≠ 0}`: rank V = 4 = dim M** (the paper's
//!   theorem). Every field is tangent to `M`; `V = [[B, I⁻¹A/den], [Id, 0]]` has rank
//!   `3 + rank A`, and the columns of `A` lie in `Ω^⊥ ∩ η^⊥`, a line (Ω ∦ η on `M` since
//!   `⟨η, ξ⟩ > 0 = ⟨Ω, ξ⟩`), with `A ≠ 0`. Adding `f` and `[f, gᵢ]` does not raise it.
//! - **Off `M` (generic `x ∈ ℝ⁶` with `⟨Ω,ξ⟩ ≠ 0`): rank V = 5.** The fields preserve
//!   `⟨Ω,ξ⟩` identically (they come from `d/dt⟨Ω,ξ⟩ = 0`) but not the energy, whose rate along
//!   `gᵢ` is `−Ωᵢ⟨Ω,ξ⟩/den`. So the accessibility distribution is the 5-dimensional tangent
//!   space of the level set of `⟨Ω,ξ⟩`. The 5th singular value is proportional to `|⟨Ω,ξ⟩|`.
//! - At rest (`Ω = 0`, `e_S = 0`) rank V = 3: `gᵢ = [0; eᵢ]` and the brackets vanish. (There
//!   the paper's `Φ` is not a submersion either: its first row `(IΩ, 0)` vanishes.)
//! - `I = c·Id` makes `f ≡ 0` on all of `ℝ⁶` (driftless, so controllable on `M`); otherwise
//!   `f ≠ 0` at generic points of `M` (accessible). `f` vanishes e.g. where `Ω` is a principal
//!   axis (then `(IΩ) × Ω = 0`).
//!
//! # Numerical rank
//!
//! `rank = #{k : σₖ > rtol · σ₁}` with the singular values `σ₁ ≥ … ≥ σ₆` of `V` (nalgebra SVD)
//! and by default `rtol = `[`RANK_RTOL`]` = 1e-9`. The identity block makes `σ₁ ≥ 1`, and `1` is
//! a singular value of multiplicity ≥ 2 (left singular vectors `[0; y]`, `y ⊥ Ω`, because the
//! `Ω`-block of the `gᵢ` is `−ηΩᵀ/den`). Round-off in the emitted fields puts the structurally
//! zero singular values at ~1e-16·σ₁, while `σ₄` is ≥ 0.17 at 2000 random states of `M` with
//! `|Ω| ∈ [0.2, 3.5]`, `|ξ| = 1` (and exactly 1 at the paper's scale `|Ω| ~ 5`,
//! `I = diag(1,2,3)`), so the threshold sits in a gap of ≥ 14 decades ([`RankReport::gap`]
//! reports `σ_{r+1}/σ_r`, measured ≤ 1.6e-15). Scaling matters: under `ξ → sξ` the `Ω`-rows of the `gᵢ` scale as `1/s`
//! and of the brackets as `1/s²`, so evaluate at `|ξ| ~ 1`. Along a numerically computed
//! trajectory, the constraint drift `⟨Ω,ξ⟩ ≈ ε` yields a 5th singular value `∝ ε`; it is
//! counted only if it exceeds `rtol · σ₁` (see [`RankReport::relative_constraint`]).

use nalgebra::{SMatrix, SVector, Vector3};

use super::ellipsoid::Inertia;
use super::layout::stack;
use super::problem::{model_params, CostWeights};
use super::SuslovError;
pub use crate::lie::controllability::{AccessibilityVerdict, RANK_RTOL, STATE_SCALE_MAX_EXP};
use crate::model::generated::{self, DIM, N_BRACKETS, N_PARAM};

/// Entries of the state `x = [Ω, ξ]`.
pub const NX: usize = 2 * DIM;

/// Columns of `V`: the control fields `gᵢ` (one per entry of `u = ξ̇`), then their brackets.
pub const NV: usize = DIM + N_BRACKETS;

/// `dim M = NX − 2` (`M` is cut out by the energy level and `⟨Ω, ξ⟩ = 0`): the rank of `V`
/// on `M` that the theorem asserts.
pub const DIM_M: usize = NX - 2;

/// A vector field on the state space `x = [Ω, ξ]`, at one state.
pub type Field = SVector<f64, NX>;

/// The accessibility matrix `V` (columns: the control fields, then their brackets).
pub type AccessibilityMatrix = SMatrix<f64, NX, NV>;

/// A state `x = [Ω, ξ]`, as the pair `(Ω, ξ)`.
pub type State = (Vector3<f64>, Vector3<f64>);

/// The drift, the control fields and their brackets at one state `x = [Ω, ξ]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlFields {
    /// The drift `f(x)`.
    pub drift: Field,
    /// The control fields `g₁, g₂, g₃`.
    pub g: [Field; DIM],
    /// `[g₁, g₂]`, `[g₁, g₃]`, `[g₂, g₃]`.
    pub brackets: [Field; N_BRACKETS],
}

impl ControlFields {
    /// The paper's `V = [g₁, g₂, g₃, [g₁,g₂], [g₁,g₃], [g₂,g₃]]` (eq. `Veqn`), as columns.
    pub fn accessibility_matrix(&self) -> AccessibilityMatrix {
        let cols: Vec<Field> = self.g.iter().chain(&self.brackets).copied().collect();
        AccessibilityMatrix::from_columns(&cols)
    }
}

/// The generated functions' constant vector `p` (only `I₁, I₂, I₃` enter these fields).
/// The fields are homogeneous of degree 0 in `I` (Suslov's equations do not change when `I`
/// is multiplied by a constant), so `I` is passed scaled to `max Iₖ = 1`: their products
/// (up to `I⁴`) would overflow for moments ~1e80 and up.
fn params(inertia: &Inertia) -> [f64; N_PARAM] {
    let d = inertia.diag();
    // A power of two, so that the scaling is exact: the fields are bit-for-bit those of the
    // unscaled moments wherever those are finite.
    let m = 2f64.powi(d.max().log2().floor() as i32);
    model_params((d / m).into(), &CostWeights::ZERO)
}

/// A number for a message: plain when moderate, else in exponent notation (`{}` of 1e300
/// prints 301 digits).
fn num(v: f64) -> String {
    if v == 0.0 || (1e-4..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `[a, b, c]` with [`num`] (`{:?}` of a vector prints nested brackets).
fn fmt3(v: &Vector3<f64>) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

fn state(omega: &Vector3<f64>, xi: &Vector3<f64>) -> Result<[f64; NX], SuslovError> {
    let x: [f64; NX] = stack(&[omega.as_slice(), xi.as_slice()]);
    if x.iter().any(|v| !v.is_finite()) {
        return Err(SuslovError::InvalidInput {
            what: format!(
                "state Omega = {}, xi = {}: need finite values",
                fmt3(omega),
                fmt3(xi)
            ),
        });
    }
    if xi.iter().all(|v| *v == 0.0) {
        return Err(SuslovError::InvalidInput {
            what: format!(
                "state Omega = {}, xi = {}: xi = 0 is no constraint (M needs xi != 0); give \
                 a nonzero xi, e.g. 0,1,0",
                fmt3(omega),
                fmt3(xi)
            ),
        });
    }
    Ok(x)
}

/// `f`, `gᵢ` and `[gᵢ, gⱼ]` at `x = [Ω, ξ]`, from the generated code. Errors if `ξ = 0` or a
/// value is not finite.
pub fn control_fields(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    xi: &Vector3<f64>,
) -> Result<ControlFields, SuslovError> {
    let x = state(omega, xi)?;
    let p = params(inertia);
    // Rows: the drift f, then g_1 .. g_DIM.
    let mut fg = [[0.0; NX]; 1 + DIM];
    let mut br = [[0.0; NX]; N_BRACKETS];
    generated::control_fields(&x, &p, &mut fg);
    generated::lie_brackets(&x, &p, &mut br);
    // Not finite in f64 (|Ω| ~1e150, moments 1e300 apart): an error, never NaN in the SVD,
    // which does not return on a NaN matrix.
    if fg.iter().chain(&br).flatten().any(|v| !v.is_finite()) {
        return Err(SuslovError::InvalidInput {
            what: format!(
                "the control fields at Omega = {}, xi = {} with I = diag({}, {}, {}) are not \
                 finite in f64 (products of the moments of inertia and up to three powers of \
                 Omega or xi overflow or underflow); rescale: the rank does not change with \
                 |xi| or with the scale of I, e.g. |xi| = 1 and max I_k = 1",
                fmt3(omega),
                fmt3(xi),
                num(inertia.diag()[0]),
                num(inertia.diag()[1]),
                num(inertia.diag()[2])
            ),
        });
    }
    let v = |a: &[f64; NX]| Field::from_column_slice(a);
    let (drift, g) = fg.split_first().expect("the drift row");
    Ok(ControlFields {
        drift: v(drift),
        g: std::array::from_fn(|i| v(&g[i])),
        brackets: br.each_ref().map(v),
    })
}

/// The accessibility rank test at one state.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RankReport {
    /// Numerical rank of `V`: `#{k : σₖ > threshold}`.
    pub rank: usize,
    /// Singular values of `V`, descending.
    pub singular_values: [f64; NX],
    /// The absolute threshold `rtol · σ₁` used.
    pub threshold: f64,
    /// `σ_rank`, the smallest singular value counted (0 if the rank is 0).
    pub smallest_significant: f64,
    /// `σ_{rank+1}/σ_rank`: how cleanly the rank is separated (0 if the rank is 6).
    pub gap: f64,
    /// `|f(x)|`, the Euclidean norm of the drift.
    pub drift_norm: f64,
    /// `⟨Ω, ξ⟩` (0 on `M`).
    pub constraint: f64,
    /// `⟨Ω, ξ⟩ / (|Ω| |ξ|)` (0 on `M`; 0 if `Ω = 0`).
    pub relative_constraint: f64,
    /// `(e_Ω, e_ξ)`: `V` and its singular values are those at `(2^{−e_Ω} Ω, 2^{−e_ξ} ξ)`
    /// ([`state_scales`]; `(0, 0)` at the usual scales).
    pub scales: (i32, i32),
}

/// `(e_Ω, e_ξ)`: exponents of the powers of two that bring `max |Ωₖ|` and `max |ξₖ|` near 1,
/// `0` where they already lie in `[2^−20, 2^20]` (or the vector is zero or not finite).
///
/// The rank of `V` does not depend on them: with `Ω → λΩ` the `Ω`-rows of `V` scale by `λ`;
/// with `ξ → sξ` the `Ω`-rows of the `gᵢ` scale by `1/s` and of the brackets by `1/s²`, and
/// `rank V = 3 + rank` of the bracket block either way (module docs). Without rescaling,
/// `|Ω| ~ 1e150` overflows the fields, and far from unit scale the relative threshold would
/// misjudge the rank. Powers of two keep the rescaling exact.
pub fn state_scales(omega: &Vector3<f64>, xi: &Vector3<f64>) -> (i32, i32) {
    let exponent = |v: &Vector3<f64>| {
        let m = v.amax();
        if !(m.is_finite() && m > 0.0) {
            return 0;
        }
        let e = m.log2().round() as i32;
        if e.abs() <= STATE_SCALE_MAX_EXP {
            0
        } else {
            e
        }
    };
    (exponent(omega), exponent(xi))
}

/// `2^{−e} v`, exactly (in two steps, so that neither factor overflows or underflows).
fn unscale(v: &Vector3<f64>, e: i32) -> Vector3<f64> {
    let half = -e / 2;
    v * 2f64.powi(half) * 2f64.powi(-e - half)
}

/// Singular values of `V`, sorted descending.
pub fn singular_values(v: &AccessibilityMatrix) -> [f64; NX] {
    let mut s: [f64; NX] = v
        .singular_values()
        .as_slice()
        .try_into()
        .expect("NX singular values");
    s.sort_by(|a, b| b.total_cmp(a));
    s
}

/// Numerical rank of descending singular values with the relative threshold `rtol`
/// (`σₖ > rtol · σ₁`); returns `(rank, threshold)`.
pub fn numerical_rank(sv: &[f64; NX], rtol: f64) -> (usize, f64) {
    let threshold = rtol * sv[0];
    (sv.iter().filter(|s| **s > threshold).count(), threshold)
}

/// Evaluates `V` at `x = [Ω, ξ]`, its singular values and numerical rank (threshold
/// `rtol · σ₁`, see the module docs; use [`RANK_RTOL`] by default).
pub fn rank_report(
    inertia: &Inertia,
    omega: &Vector3<f64>,
    xi: &Vector3<f64>,
    rtol: f64,
) -> Result<RankReport, SuslovError> {
    let scales = state_scales(omega, xi);
    let (om_s, xi_s) = (unscale(omega, scales.0), unscale(xi, scales.1));
    let fields = control_fields(inertia, &om_s, &xi_s)?;
    let sv = singular_values(&fields.accessibility_matrix());
    let (rank, threshold) = numerical_rank(&sv, rtol);
    let constraint = omega.dot(xi);
    let scale = om_s.norm() * xi_s.norm();
    Ok(RankReport {
        rank,
        singular_values: sv,
        threshold,
        smallest_significant: if rank == 0 { 0.0 } else { sv[rank - 1] },
        gap: if rank == 0 || rank == sv.len() {
            0.0
        } else {
            sv[rank] / sv[rank - 1]
        },
        // f is quadratic in Ω and independent of the scale of ξ.
        drift_norm: fields.drift.norm() * 2f64.powi(scales.0) * 2f64.powi(scales.0),
        constraint,
        relative_constraint: if scale > 0.0 {
            om_s.dot(&xi_s) / scale
        } else {
            0.0
        },
        scales,
    })
}

/// The rank test along a trajectory.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TrajectoryRank {
    /// Number of states evaluated.
    pub points: usize,
    /// Smallest numerical rank.
    pub min_rank: usize,
    /// Largest numerical rank.
    pub max_rank: usize,
    /// Smallest `σ_rank` over the points whose rank is `min_rank`: the margin of the rank.
    pub min_significant: f64,
    /// Time of `min_significant`.
    pub t_min_significant: f64,
    /// Largest `σ_{rank+1}/σ_rank` (how close the threshold came to being ambiguous).
    pub max_gap: f64,
    /// Largest `|⟨Ω, ξ⟩|` (0 on `M`).
    pub max_abs_constraint: f64,
    /// Largest `|f|`.
    pub max_drift_norm: f64,
    /// The per-point reports, with their times.
    pub reports: Vec<(f64, RankReport)>,
}

/// [`rank_report`] at a list of states `(t, Ω, ξ)`. Errors on an empty list or a bad state.
pub fn rank_along(
    inertia: &Inertia,
    states: &[(f64, Vector3<f64>, Vector3<f64>)],
    rtol: f64,
) -> Result<TrajectoryRank, SuslovError> {
    if states.is_empty() {
        return Err(SuslovError::InvalidInput {
            what: "rank_along needs at least one state".into(),
        });
    }
    let reports = states
        .iter()
        .map(|(t, om, xi)| rank_report(inertia, om, xi, rtol).map(|r| (*t, r)))
        .collect::<Result<Vec<_>, _>>()?;
    let min_rank = reports.iter().map(|(_, r)| r.rank).min().unwrap_or(0);
    let max_rank = reports.iter().map(|(_, r)| r.rank).max().unwrap_or(0);
    let (t_min_significant, min_significant) = reports
        .iter()
        .filter(|(_, r)| r.rank == min_rank)
        .map(|(t, r)| (*t, r.smallest_significant))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((f64::NAN, f64::NAN));
    let fold = |g: fn(&RankReport) -> f64| reports.iter().map(|(_, r)| g(r)).fold(0.0, f64::max);
    Ok(TrajectoryRank {
        points: reports.len(),
        min_rank,
        max_rank,
        min_significant,
        t_min_significant,
        max_gap: fold(|r| r.gap),
        max_abs_constraint: fold(|r| r.constraint.abs()),
        max_drift_norm: fold(|r| r.drift_norm),
        reports,
    })
}

/// [`rank_along`] for a trajectory given as a closure `t ↦ (Ω(t), ξ(t))` (e.g. a BVP
/// solution's interpolant, or a path with its singular control), sampled at `times`.
pub fn rank_along_fn(
    inertia: &Inertia,
    trajectory: &dyn Fn(f64) -> Result<State, SuslovError>,
    times: &[f64],
    rtol: f64,
) -> Result<TrajectoryRank, SuslovError> {
    let states = times
        .iter()
        .map(|&t| trajectory(t).map(|(om, xi)| (t, om, xi)))
        .collect::<Result<Vec<_>, _>>()?;
    rank_along(inertia, &states, rtol)
}

/// A unit `ξ ⊥ Ω` in the direction `Ω × r` (an admissible constraint for `Ω`); `None` if
/// `Ω × r` is ~0.
pub fn admissible_xi(omega: &Vector3<f64>, r: &Vector3<f64>) -> Option<Vector3<f64>> {
    let c = omega.cross(r);
    let n = c.norm();
    (n > 1e-12 * omega.norm() * r.norm() && n.is_finite()).then(|| c / n)
}

/// `n` deterministic pseudo-random states of `M` for the energy of `omega_a`: `Ω` uniform in
/// direction and scaled onto the ellipsoid `½⟨IΩ,Ω⟩ = ½⟨IΩ_a,Ω_a⟩`, `ξ` a unit vector `⊥ Ω`
/// in a random direction. (SplitMix64 generator seeded by `seed`.) Errors unless the energy
/// of `omega_a` is finite and positive.
pub fn sample_states_on_m(
    inertia: &Inertia,
    omega_a: &Vector3<f64>,
    n: usize,
    seed: u64,
) -> Result<Vec<State>, SuslovError> {
    let mut s = seed;
    let mut next = move || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        2.0 * ((z >> 11) as f64 / (1u64 << 53) as f64) - 1.0
    };
    let energy2 = inertia.apply(omega_a).dot(omega_a);
    if !(energy2.is_finite() && energy2 > 0.0) {
        return Err(SuslovError::InvalidInput {
            what: format!("Omega_a = {omega_a:?} must have finite positive energy"),
        });
    }
    let mut out = Vec::with_capacity(n);
    // A draw is rejected with probability ~1e-9 (|d| < 1e-3, or r ∥ Ω) at a sane scale; when
    // every draw is rejected (the state underflows: moments 1e600 apart), stop instead of
    // looping forever.
    let mut attempts = 0_usize;
    while out.len() < n {
        attempts += 1;
        if attempts > 1000 + 10 * n {
            return Err(SuslovError::InvalidInput {
                what: format!(
                    "no state of M with the energy of Omega_a = {} for I = diag({}, {}, {}) is \
                     representable in f64 (Omega on the energy ellipsoid underflows or \
                     overflows in some direction); bring the moments of inertia closer \
                     together (their ratios, not their scale, matter)",
                    fmt3(omega_a),
                    num(inertia.diag()[0]),
                    num(inertia.diag()[1]),
                    num(inertia.diag()[2])
                ),
            });
        }
        let d = Vector3::new(next(), next(), next());
        let r = Vector3::new(next(), next(), next());
        let q = inertia.apply(&d).dot(&d);
        if d.norm() < 1e-3 || q <= 0.0 {
            continue;
        }
        let om = d * (energy2 / q).sqrt();
        if let Some(xi) = admissible_xi(&om, &r) {
            out.push((om, xi));
        }
    }
    Ok(out)
}

/// Parses `"a,b,c"` into a vector (for the command line).
pub fn parse_vec3(s: &str) -> Result<Vector3<f64>, SuslovError> {
    let parts: Vec<&str> = s.splitn(4, ',').collect();
    if parts.len() != 3 {
        return Err(SuslovError::InvalidInput {
            what: format!(
                "{} has {} comma-separated entries, expected 3 (e.g. 1,2,3)",
                crate::echo::echo(s),
                s.split(',').count()
            ),
        });
    }
    let mut v = [0.0; 3];
    for (x, p) in v.iter_mut().zip(&parts) {
        *x = p
            .trim()
            .parse::<f64>()
            .map_err(|e| SuslovError::InvalidInput {
                what: format!(
                    "{} is not three comma-separated numbers: {} is not a number ({e})",
                    crate::echo::echo(s),
                    crate::echo::echo(p.trim())
                ),
            })?;
    }
    Ok(Vector3::from(v))
}

/// A state counts as on `M` when `Ω ≠ 0`, `ξ ≠ 0` and `|⟨Ω, ξ⟩| < ON_M_RTOL · |Ω||ξ|`.
pub const ON_M_RTOL: f64 = 1e-12;

/// The drift counts as nonzero at a state when `|f| > DRIFT_RTOL · |Ω|²` (`f` is quadratic in
/// `Ω`; round-off in `f` is ~1e-16·|Ω|²).
pub const DRIFT_RTOL: f64 = 1e-12;

/// Accepted range of the relative rank threshold `rtol`: below it round-off (~1e-16·σ₁ in
/// the structurally zero singular values) could be counted; above it a genuine small
/// `σ₄` (≥ 0.17 at the paper's scale, see the module docs) could be missed.
pub const RTOL_RANGE: (f64, f64) = (1e-14, 1e-3);

/// Largest number of states `suslov controllability` evaluates (`--samples`, `--points`):
/// one row of text each; 1e5 rows take about a second and a few MB.
pub const MAX_STATES: usize = 100_000;

/// Checks a relative rank threshold: finite and in [`RTOL_RANGE`].
pub fn check_rtol(rtol: f64) -> Result<f64, SuslovError> {
    let (lo, hi) = RTOL_RANGE;
    if rtol.is_finite() && (lo..=hi).contains(&rtol) {
        Ok(rtol)
    } else {
        Err(SuslovError::InvalidInput {
            what: format!(
                "--rtol = {rtol}: the relative rank threshold must be a number in [{lo:e}, \
                 {hi:e}] (default {RANK_RTOL:e}); below, round-off counts as rank, above, \
                 genuine singular values are dropped"
            ),
        })
    }
}

/// Whether `(Ω, ξ)` lies on `M` in the sense of [`ON_M_RTOL`].
pub fn is_on_m(omega: &Vector3<f64>, xi: &Vector3<f64>) -> bool {
    let (so, sx) = state_scales(omega, xi);
    let (omega, xi) = (unscale(omega, so), unscale(xi, sx));
    let scale = omega.norm() * xi.norm();
    scale > 0.0 && scale.is_finite() && omega.dot(&xi).abs() < ON_M_RTOL * scale
}

/// The `suslov controllability` table: one row per state `(Ω, ξ)` with `⟨Ω, ξ⟩`, whether it
/// is on `M`, the rank, the singular values of `V` and `|f|`; then what the numbers show
/// (every sentence follows from the rows printed) and the theorem it checks.
pub fn report_table(
    inertia: &Inertia,
    states: &[State],
    rtol: f64,
) -> Result<(String, AccessibilityVerdict), SuslovError> {
    report_table_rows(inertia, states, rtol).map(|(text, verdict, _)| (text, verdict))
}

/// The table of [`report_table_rows`]: its text, its verdict, and per state its
/// [`RankReport`] and whether it is on `M`.
pub type RankTableRows = (String, AccessibilityVerdict, Vec<(RankReport, bool)>);

/// [`report_table`] with its rows as data: the [`RankReport`] of every state and whether it
/// is on `M` (for machine-readable output).
pub fn report_table_rows(
    inertia: &Inertia,
    states: &[State],
    rtol: f64,
) -> Result<RankTableRows, SuslovError> {
    use std::fmt::Write;
    check_rtol(rtol)?;
    let mut reports = Vec::with_capacity(states.len());
    let d = inertia.diag();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Accessibility of Suslov's pure equations, x = [Omega, xi], u = xi' (paper section 4.3)\n\
         I = diag({}, {}, {}); V = [g1, g2, g3, [g1,g2], [g1,g3], [g2,g3]]; \
         rank = #{{sigma_k > {rtol:e} sigma_1}}\n",
        num(d[0]),
        num(d[1]),
        num(d[2])
    );
    let _ = writeln!(
        s,
        "{:>3}  {:>26}  {:>26}  {:>9}  {:>4}  {:>4}  {:>54}  {:>9}",
        "#", "Omega", "xi", "<Om,xi>", "on M", "rank", "singular values of V", "|f|"
    );
    // (rank, on M, drift nonzero, |f|)
    let mut rows = Vec::with_capacity(states.len());
    let mut rescaled = false;
    for (k, (om, xi)) in states.iter().enumerate() {
        let r = rank_report(inertia, om, xi, rtol)?;
        // Fixed point for the usual scale, exponent notation beyond it (`{:7.3}` of 1e300
        // prints 301 digits).
        let c = |x: f64| {
            if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
                format!("{x:7.3}")
            } else {
                format!("{x:7.1e}")
            }
        };
        let v3 = |v: &Vector3<f64>| format!("[{}, {}, {}]", c(v[0]), c(v[1]), c(v[2]));
        let sv = r
            .singular_values
            .iter()
            .map(|v| format!("{v:8.2e}"))
            .collect::<Vec<_>>()
            .join(" ");
        let on_m = is_on_m(om, xi);
        let _ = writeln!(
            s,
            "{:>3}  {:>26}  {:>26}  {:>9.1e}  {:>4}  {:>4}  {:>54}  {:>9.3e}",
            k,
            v3(om),
            v3(xi),
            r.constraint,
            if on_m { "yes" } else { "no" },
            r.rank,
            sv,
            r.drift_norm
        );
        // Judged at the rescaled state (f is quadratic in Ω).
        let om_s = unscale(om, r.scales.0);
        let f_s = r.drift_norm * 2f64.powi(-r.scales.0) * 2f64.powi(-r.scales.0);
        let drifts = f_s > DRIFT_RTOL * om_s.norm_squared() || (f_s == 0.0 && r.drift_norm > 0.0);
        rescaled |= r.scales != (0, 0);
        rows.push((r.rank, on_m, drifts, r.drift_norm));
        reports.push((r, on_m));
    }
    if rescaled {
        let _ = writeln!(
            s,
            "(states with a component beyond 2^20 or all below 2^-20 in size: V and its singular \
             values are evaluated at Omega and xi rescaled by exact powers of two, which leaves \
             the rank and M unchanged)"
        );
    }
    let on_m: Vec<_> = rows.iter().filter(|r| r.1).collect();
    let off_m: Vec<_> = rows.iter().filter(|r| !r.1).collect();
    let span = |v: &[&(usize, bool, bool, f64)]| match (
        v.iter().map(|r| r.0).min(),
        v.iter().map(|r| r.0).max(),
    ) {
        (Some(a), Some(b)) if a == b => format!("{a}"),
        (Some(a), Some(b)) => format!("{a}..{b}"),
        _ => "-".into(),
    };
    let failing = on_m.iter().filter(|r| r.0 != DIM_M).count();
    let verdict = if on_m.is_empty() {
        AccessibilityVerdict::NoStateOnM
    } else if failing == 0 {
        AccessibilityVerdict::Accessible { on_m: on_m.len() }
    } else {
        AccessibilityVerdict::RankDeficient {
            on_m: on_m.len(),
            failing,
        }
    };
    let _ = writeln!(
        s,
        "\nrank on M (Omega != 0, xi != 0, |<Om,xi>| < {ON_M_RTOL:e} |Om||xi|): {} ({} states); \
         off M: {} ({} states)",
        span(&on_m),
        on_m.len(),
        span(&off_m),
        off_m.len()
    );
    let max_f = on_m.iter().map(|r| r.3).fold(0.0, f64::max);
    let with_drift = on_m.iter().filter(|r| r.2).count();
    match verdict {
        AccessibilityVerdict::NoStateOnM => {
            let _ = writeln!(
                s,
                "No state tested lies on M: the theorem below says nothing about them (off M \
                 the rank is 5 generically, 3 at Omega = 0)."
            );
        }
        AccessibilityVerdict::RankDeficient { on_m, failing } => {
            let _ = writeln!(
                s,
                "rank V != {DIM_M} at {failing} of the {on_m} states of M: NOT consistent with the \
                 theorem at this threshold (check --rtol and the scale of xi, |xi| ~ 1)."
            );
        }
        AccessibilityVerdict::Accessible { on_m } => {
            let drift = if with_drift == 0 {
                format!(
                    "the drift vanishes at all of them (max |f| {max_f:.1e} <= {DRIFT_RTOL:e} \
                     |Omega|^2): driftless there, so the rank condition gives controllability \
                     on M"
                )
            } else {
                format!(
                    "the drift is nonzero at {with_drift} of them (max |f| {max_f:.3e}): the \
                     system has drift and the rank condition gives accessibility"
                )
            };
            let _ = writeln!(
                s,
                "rank V = {DIM_M} = dim M at all {on_m} states of M tested; {drift}."
            );
        }
    }
    let _ = writeln!(
        s,
        "Theorem (paper section 4.3): rank V = 4 = dim M at every point of \
         M = {{1/2 <I Om, Om> = e_S > 0, <Om, xi> = 0, xi != 0}}; off M the rank is 5 \
         (only <Om, xi> is invariant), at Omega = 0 it is 3."
    );
    Ok((s, verdict, reports))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::so3::desired::{DesiredPath, PaperSpiral};
    use crate::so3::singular::singular_control_at;
    use nalgebra::{Matrix6, Vector6};

    fn rng(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Random inertia in [0.5, 3]³, `Ω` in [-2, 2]³, a unit `ξ ⊥ Ω`.
    fn random_admissible(next: &mut impl FnMut() -> f64) -> (Inertia, Vector3<f64>, Vector3<f64>) {
        loop {
            let mut u = |lo: f64, hi: f64| lo + (hi - lo) * next();
            let inertia = Inertia::new([u(0.5, 3.0), u(0.5, 3.0), u(0.5, 3.0)]).unwrap();
            let om = Vector3::new(u(-2.0, 2.0), u(-2.0, 2.0), u(-2.0, 2.0));
            let r = Vector3::new(u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0));
            if om.norm() < 0.2 {
                continue;
            }
            if let Some(xi) = admissible_xi(&om, &r) {
                return (inertia, om, xi);
            }
        }
    }

    /// The paper's eqs. `Veqn`/`Aeqn`, transcribed by hand from the LaTeX.
    fn paper_v(inertia: &Inertia, om: &Vector3<f64>, xi: &Vector3<f64>) -> Matrix6<f64> {
        let eta = inertia.apply_inv(xi);
        let den = xi.dot(&eta);
        let p = nalgebra::Matrix3::new(-om[1], -om[2], 0.0, om[0], 0.0, -om[2], 0.0, om[0], om[1]);
        let d = nalgebra::Matrix3::new(0.0, 0.0, -1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
        let a = p + xi * (om.cross(&eta).transpose() * d) / den;
        let iinv = nalgebra::Matrix3::from_diagonal(&inertia.diag().map(|v| 1.0 / v));
        let mut v = Matrix6::zeros();
        v.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(-(iinv / den) * xi * om.transpose()));
        v.fixed_view_mut::<3, 3>(0, 3).copy_from(&(iinv / den * a));
        v.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&nalgebra::Matrix3::identity());
        v
    }

    #[test]
    fn rank_is_4_at_random_admissible_states() {
        let mut next = rng(1);
        let mut worst_gap: f64 = 0.0;
        let mut min_s4 = f64::INFINITY;
        for _ in 0..2000 {
            let (inertia, om, xi) = random_admissible(&mut next);
            let r = rank_report(&inertia, &om, &xi, RANK_RTOL).unwrap();
            assert_eq!(r.rank, 4, "{r:?} at {om:?}, {xi:?}, {inertia:?}");
            assert!(r.relative_constraint.abs() < 1e-14);
            worst_gap = worst_gap.max(r.gap);
            min_s4 = min_s4.min(r.smallest_significant);
        }
        eprintln!("on M: worst sigma_5/sigma_4 = {worst_gap:e}, min sigma_4 = {min_s4:e}");
        // The structurally zero singular values are round-off: many decades below sigma_4.
        assert!(worst_gap < 1e-12, "gap {worst_gap:e}");
        assert!(min_s4 > 1e-4, "sigma_4 {min_s4:e}");
    }

    #[test]
    fn rank_is_5_off_m_and_3_at_rest() {
        // Off M only <Omega, xi> is invariant (derivation, codegen/control.py): rank 5 at
        // generic states of R^6; sigma_5 ~ |<Omega, xi>|.
        let mut next = rng(2);
        let mut min_s5 = f64::INFINITY;
        for _ in 0..500 {
            let (inertia, om, _) = random_admissible(&mut next);
            let xi = Vector3::new(next() - 0.5, next() - 0.5, next() + 0.2).normalize();
            let r = rank_report(&inertia, &om, &xi, RANK_RTOL).unwrap();
            if r.relative_constraint.abs() > 1e-3 {
                assert_eq!(r.rank, 5, "{r:?}");
                min_s5 = min_s5.min(r.smallest_significant / r.relative_constraint.abs());
                assert!(r.singular_values[5] < 1e-12 * r.singular_values[0]);
            }
        }
        eprintln!("off M: min sigma_5 / |<Om,xi>|_rel = {min_s5:e}");
        let r = rank_report(
            &Inertia::paper(),
            &Vector3::zeros(),
            &Vector3::new(0.0, 1.0, 0.0),
            RANK_RTOL,
        )
        .unwrap();
        assert_eq!(r.rank, 3, "{r:?}");
        assert!(rank_report(&Inertia::paper(), &Vector3::x(), &Vector3::zeros(), 1e-9).is_err());
    }

    #[test]
    fn spherical_body_is_driftless_and_others_are_not() {
        let mut next = rng(3);
        let mut min_drift = f64::INFINITY;
        let mut max_sphere: f64 = 0.0;
        for _ in 0..1000 {
            let (inertia, om, xi) = random_admissible(&mut next);
            let c = 0.5 + 2.5 * next();
            let sphere = Inertia::new([c, c, c]).unwrap();
            let f = control_fields(&sphere, &om, &xi).unwrap().drift;
            assert!(f.amax() <= 1e-14, "|f| = {:e}", f.amax());
            max_sphere = max_sphere.max(f.amax());
            // also off M: f = 0 identically for I = c Id
            let f_off = control_fields(&sphere, &om, &(xi + om * 0.3))
                .unwrap()
                .drift;
            assert!(f_off.amax() <= 1e-14, "|f| = {:e}", f_off.amax());
            let d = inertia.diag();
            let spread = (d.max() - d.min()) / d.max();
            if spread > 0.1 {
                let r = rank_report(&inertia, &om, &xi, RANK_RTOL).unwrap();
                min_drift = min_drift.min(r.drift_norm / om.norm_squared());
                assert!(r.drift_norm > 0.0);
            }
        }
        // Paper's inertia, Omega on a principal axis: (I Om) x Om = 0, so f = 0 there.
        let f = control_fields(
            &Inertia::paper(),
            &Vector3::new(5.0, 0.0, 0.0),
            &Vector3::y(),
        )
        .unwrap()
        .drift;
        assert_eq!(f.amax(), 0.0);
        eprintln!("sphere: max |f| = {max_sphere:e}; non-spherical (spread > 0.1): min |f|/|Om|^2 = {min_drift:e}");
        assert!(min_drift > 0.0);
    }

    #[test]
    fn brackets_match_finite_differences_of_the_emitted_fields() {
        let mut next = rng(4);
        let mut worst: f64 = 0.0;
        for k in 0..200 {
            let (inertia, om, mut xi) = random_admissible(&mut next);
            if k % 2 == 1 {
                xi += om * 0.2; // also off M: the bracket identity holds in all of R^6
            }
            let fields = control_fields(&inertia, &om, &xi).unwrap();
            let at = |x: &Vector6<f64>| {
                control_fields(
                    &inertia,
                    &x.fixed_rows::<3>(0).into(),
                    &x.fixed_rows::<3>(3).into(),
                )
                .unwrap()
            };
            let x0 = Vector6::new(om[0], om[1], om[2], xi[0], xi[1], xi[2]);
            // (Dg_j) v by a central difference along v.
            let dir = |j: usize, v: &Vector6<f64>| {
                let h = 1e-5 / v.norm();
                (at(&(x0 + v * h)).g[j] - at(&(x0 - v * h)).g[j]) / (2.0 * h)
            };
            for (b, (i, j)) in [(0, 1), (0, 2), (1, 2)].into_iter().enumerate() {
                let fd = dir(j, &fields.g[i]) - dir(i, &fields.g[j]);
                let err = (fd - fields.brackets[b]).amax() / (1.0 + fields.brackets[b].amax());
                worst = worst.max(err);
            }
        }
        eprintln!("brackets vs central differences: worst relative error {worst:e}");
        assert!(worst < 1e-7, "worst relative FD error {worst:e}");
    }

    #[test]
    fn v_matches_the_papers_eqs_veqn_aeqn() {
        let mut next = rng(5);
        let mut worst: f64 = 0.0;
        for _ in 0..500 {
            let (inertia, om, xi) = random_admissible(&mut next);
            let xi = xi * (0.5 + next()); // not only unit xi
            let v = control_fields(&inertia, &om, &xi)
                .unwrap()
                .accessibility_matrix();
            let p = paper_v(&inertia, &om, &xi);
            worst = worst.max((v - p).amax() / p.amax());
        }
        eprintln!("V vs eqs. Veqn/Aeqn: worst relative difference {worst:e}");
        assert!(worst < 1e-13, "worst relative difference {worst:e}");
    }

    #[test]
    fn fields_are_tangent_to_m() {
        // Phi_* = [[I Om, 0], [xi, Om]] annihilates f, g_i and the brackets on M (eq. Phi_*).
        let mut next = rng(6);
        for _ in 0..500 {
            let (inertia, om, xi) = random_admissible(&mut next);
            let fl = control_fields(&inertia, &om, &xi).unwrap();
            let i_om = inertia.apply(&om);
            let all = [fl.drift, fl.g[0], fl.g[1], fl.g[2]]
                .into_iter()
                .chain(fl.brackets);
            for v in all {
                let (vo, vx) = (v.fixed_rows::<3>(0), v.fixed_rows::<3>(3));
                let scale = 1.0 + v.amax() * (i_om.norm() + om.norm() + xi.norm());
                assert!(i_om.dot(&vo).abs() < 1e-13 * scale);
                assert!((xi.dot(&vo) + om.dot(&vx)).abs() < 1e-13 * scale);
            }
        }
    }

    #[test]
    fn rank_is_4_along_the_singular_solution_of_the_paper_spiral() {
        // (Omega_p, xi_p) with Omega_p = phi_par on E and xi_p its singular control lies on M.
        let spiral = PaperSpiral::paper();
        let path = spiral.phi_par();
        let inertia = Inertia::paper();
        let traj = |t: f64| singular_control_at(path, &inertia, t).map(|c| (path.value(t), c.xi));
        let times: Vec<f64> = (0..=400).map(|k| 10.0 * k as f64 / 400.0).collect();
        let tr = rank_along_fn(&inertia, &traj, &times, RANK_RTOL).unwrap();
        assert_eq!((tr.min_rank, tr.max_rank, tr.points), (4, 4, 401));
        eprintln!(
            "paper spiral: rank {}..{}, min sigma_4 {:e} at t = {}, max gap {:e}, max |<Om,xi>| {:e}",
            tr.min_rank, tr.max_rank, tr.min_significant, tr.t_min_significant, tr.max_gap,
            tr.max_abs_constraint
        );
        assert!(tr.max_abs_constraint < 1e-12);
        assert!(tr.min_significant > 1e-3, "{}", tr.min_significant);
        assert!(tr.max_gap < 1e-12);
        assert!(rank_along(&inertia, &[], RANK_RTOL).is_err());
    }

    #[test]
    fn sampled_states_lie_on_m() {
        let inertia = Inertia::paper();
        let oa = Vector3::new(5.0, 0.0, 0.0);
        let e = inertia.apply(&oa).dot(&oa);
        for (om, xi) in sample_states_on_m(&inertia, &oa, 100, 7).unwrap() {
            assert!((inertia.apply(&om).dot(&om) / e - 1.0).abs() < 1e-14);
            assert!(om.dot(&xi).abs() < 1e-13 * om.norm());
            assert!((xi.norm() - 1.0).abs() < 1e-14);
            assert_eq!(rank_report(&inertia, &om, &xi, RANK_RTOL).unwrap().rank, 4);
        }
        assert!(sample_states_on_m(&inertia, &Vector3::zeros(), 1, 7).is_err());
        let (table, verdict) = report_table(
            &inertia,
            &sample_states_on_m(&inertia, &oa, 3, 1).unwrap(),
            1e-9,
        )
        .unwrap();
        assert!(
            table.contains("): 4 (3 states); off M: - (0 states)"),
            "{table}"
        );
        assert_eq!(verdict, AccessibilityVerdict::Accessible { on_m: 3 });
        assert!(
            table.contains("the drift is nonzero at 3 of them"),
            "{table}"
        );
    }

    #[test]
    fn the_rank_does_not_depend_on_the_scale_of_the_state() {
        // Exact powers of two leave every singular value at the usual scale unchanged, and at
        // extreme scales the rank is judged at the rescaled state.
        let inertia = Inertia::paper();
        let om = Vector3::new(1.0, 2.0, 3.0);
        // Integer components: their products with 5e-324 = 2^-1074 are exact subnormals, so
        // every scaled state below is on M exactly.
        let xi = Vector3::new(2.0, -1.0, 0.0);
        let base = rank_report(&inertia, &om, &xi, RANK_RTOL).unwrap();
        assert_eq!((base.rank, base.scales), (4, (0, 0)));
        for (lo, lx) in [
            (1e150, 1.0),
            (1e-150, 1.0),
            (1.0, 1e-300),
            (5e-324, 5e-324),
            (1e300, 1e-200),
        ] {
            let r = rank_report(&inertia, &(om * lo), &(xi * lx), RANK_RTOL).unwrap();
            assert_eq!(r.rank, 4, "|Omega| ~ {lo:e}, |xi| ~ {lx:e}: {r:?}");
            assert!(is_on_m(&(om * lo), &(xi * lx)));
        }
        // The drift at the state as given: quadratic in Omega.
        let r = rank_report(&inertia, &(om * 2f64.powi(40)), &xi, RANK_RTOL).unwrap();
        let expected = base.drift_norm * 2f64.powi(80);
        assert!((r.drift_norm / expected - 1.0).abs() < 1e-12, "{r:?}");
    }

    #[test]
    fn the_verdict_follows_from_the_rows() {
        let inertia = Inertia::paper();
        let xi = Vector3::new(0.0, 1.0, 0.0);
        // At rest: not on M (rank 3); the table must not claim accessibility or drift.
        let (text, verdict) = report_table(&inertia, &[(Vector3::zeros(), xi)], RANK_RTOL).unwrap();
        assert_eq!(verdict, AccessibilityVerdict::NoStateOnM);
        assert!(!text.contains("accessib"), "{text}");
        assert!(text.contains("No state tested lies on M"), "{text}");
        // On a principal axis the drift vanishes: on M with rank 4 but no drift.
        let (text, verdict) =
            report_table(&inertia, &[(Vector3::new(5.0, 0.0, 0.0), xi)], RANK_RTOL).unwrap();
        assert_eq!(verdict, AccessibilityVerdict::Accessible { on_m: 1 });
        assert!(text.contains("the drift vanishes at all of them"), "{text}");
        assert!(!text.contains("has drift"), "{text}");
        // Off M.
        let (_, verdict) = report_table(
            &inertia,
            &[(Vector3::new(1.0, 1.0, 0.0), Vector3::new(1.0, 0.0, 0.0))],
            RANK_RTOL,
        )
        .unwrap();
        assert_eq!(verdict, AccessibilityVerdict::NoStateOnM);
        // A threshold that counts round-off: rejected, not "rank 5 on M".
        for bad in [f64::NAN, f64::INFINITY, 2.0, -1.0, 0.0, 1e-20, 0.5] {
            let err = report_table(&inertia, &[(Vector3::x(), xi)], bad).unwrap_err();
            assert!(err.to_string().contains("--rtol"), "{err}");
        }
    }
}
