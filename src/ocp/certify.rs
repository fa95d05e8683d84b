//! Second-order certificate of a KKT point of a [`Transcription`].
//!
//! # The test
//!
//! At a KKT point `(v, y)` with constraint Jacobian `A` (`m × n`, full row rank) and
//! Lagrangian Hessian `H`, the second-order sufficient condition (SOSC) for a strict local
//! minimum is `ZᵀHZ ≻ 0` for a basis `Z` of `null(A)`. By Sylvester's law of inertia,
//!
//! ```text
//! inertia [ H − σM  Aᵀ ] = (m, m, 0) + inertia Zᵀ(H − σM)Z ,
//!         [ A       0  ]
//! ```
//!
//! so one `L B Lᵀ` factorization ([`super::inertia`]) decides SOSC (`σ = 0`): the KKT matrix
//! must have exactly `n` positive and `m` negative eigenvalues. Each further negative
//! eigenvalue is a direction of negative curvature in `null(A)`: the second-order *necessary*
//! condition fails and the point is not a local minimum (a saddle or a maximum). A zero
//! eigenvalue (singular KKT matrix) is degenerate: no verdict.
//!
//! # The margin
//!
//! With `M` the metric of [`Transcription::metric_diagonal`] (`‖δv‖²_M ≈ ∫|δu|² dt` plus the
//! free initial data), the number of negative eigenvalues above `m` at shift `σ` is the number
//! of generalized eigenvalues `μ` of `(ZᵀHZ, ZᵀMZ)` below `σ`. The smallest one, `μ_min`, is
//! bracketed: the second variation satisfies `δ²ℒ ≥ μ_min ‖δv‖²_M` on the linearized
//! constraints, a mesh-independent number (for `ẋ = u`, `L = (u² − x²)/2`, `x(0) = x(T) = 0`
//! it tends to `1 − (T/π)²`). The lower end is a count (no eigenvalue below it); the upper end
//! is the Rayleigh quotient of an explicit direction in `null(A)` (Courant–Fischer), or a
//! count. Where to count is estimated by the Lanczos method with a factorization already at
//! hand (solves only); the bracket rests on the count and the direction, not on the estimate,
//! and bisection on `σ` remains the fallback (see `margin`).
//!
//! # Cost
//!
//! [`certify`] factorizes the KKT pattern for the least-squares multipliers and for each
//! Newton step (solves only: each solve's backward error is checked, no inertia is needed),
//! then, at a point it certifies, once more. [`certify_with_costates`], for a candidate with
//! costates (an indirect solution), starts Newton from the multipliers they give and saves
//! the least-squares factorization. The last factorization is the count at the margin's
//! lower end `lo > 0`, which also decides the verdict (no eigenvalue below `lo > 0` implies
//! SOSC), with the Lanczos estimate made from Newton's last factorization
//! ([`second_order_near`]). A point that is not certified costs the factorization at `σ = 0`
//! and the margin's counts.

use super::conjugate::{first_conjugate_point, ConjugateReport};
use super::inertia::{Inertia, InertiaError, LbltFactor};
use super::kkt::{
    self, KktError, KktMatrix, KktPoint, KktResidual, NewtonOptions, PrimalEvaluation,
};
use super::problem::OcpProblem;
use super::transcription::{Entry, Transcription};

/// The verdict of the second-order test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// SOSC holds: a strict local minimum of the discretized problem.
    Certified,
    /// The reduced Hessian has negative eigenvalues: not a local minimum.
    NotMinimum,
    /// The KKT matrix is singular (reduced Hessian singular, or the constraints are not
    /// independent): the test cannot decide.
    Degenerate,
}

impl Verdict {
    /// A sentence for people.
    pub fn sentence(self) -> &'static str {
        match self {
            Verdict::Certified => "local minimum certified for the discretized problem",
            Verdict::NotMinimum => {
                "NOT a local minimum of the discretized problem (negative curvature on the constraints)"
            }
            Verdict::Degenerate => {
                "not certified: the KKT matrix is singular (degenerate second variation or dependent constraints)"
            }
        }
    }
}

/// Options of [`second_order`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SecondOrderOptions {
    /// Relative width of the final bracket of `μ_min`.
    pub margin_rtol: f64,
    /// Upper bound on the number of factorizations spent on the margin.
    pub max_factorizations: usize,
}

impl Default for SecondOrderOptions {
    fn default() -> Self {
        Self {
            margin_rtol: 1e-3,
            max_factorizations: 80,
        }
    }
}

/// The outcome of the second-order test.
#[derive(Debug, Clone, PartialEq)]
pub struct SecondOrderReport {
    /// Number of unknowns `n`.
    pub n_var: usize,
    /// Number of constraints `m`.
    pub n_con: usize,
    /// Inertia of the KKT matrix (`σ = 0`); SOSC ⇔ `(n, m, 0)`. Counted from its
    /// factorization, or implied by the count at a shift `σ > 0` (see [`second_order_near`]).
    pub inertia: Inertia,
    /// Number of negative eigenvalues of the reduced Hessian (`negative − m`).
    pub negative_curvature_directions: usize,
    /// The verdict.
    pub verdict: Verdict,
    /// Bracket `[lo, hi]` of the smallest generalized eigenvalue `μ_min` of the reduced
    /// Hessian in the metric `M` (`None` when degenerate or the search ran out of budget).
    pub margin: Option<(f64, f64)>,
    /// Backward error of the factorization whose inertia decided the verdict (`σ = 0`, or
    /// the lower end of the margin when that count decided it: [`second_order_near`]).
    pub backward_error: f64,
    /// Smallest `|pivot| / ‖K‖` of that factorization.
    pub min_pivot_ratio: f64,
    /// Factorizations done.
    pub factorizations: usize,
    /// The eigenvector of `μ_min` (the weakest direction; for a point that is not a minimum,
    /// the most negative one): unknowns in transcription order, `‖δv‖_M = 1`, `A δv = 0`.
    /// `None` when the margin is not bracketed.
    pub weakest_direction: Option<Vec<f64>>,
    /// Its Rayleigh quotient `δvᵀHδv / δvᵀMδv` (inside the bracket when converged).
    pub weakest_rayleigh: Option<f64>,
}

/// Why the second-order test could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SecondOrderError {
    /// The sparse symmetric factorization failed or was not accurate enough to trust its
    /// inertia.
    #[error("the KKT matrix could not be factorized reliably: {0}")]
    Factorization(#[from] InertiaError),
    /// The inertia is impossible for a KKT matrix with independent constraints (fewer than
    /// `m` negative eigenvalues).
    #[error(
        "inconsistent inertia {inertia} for {n_con} constraints: the constraint Jacobian is \
         rank deficient"
    )]
    RankDeficient {
        /// The inertia found.
        inertia: Inertia,
        /// `m`.
        n_con: usize,
    },
}

/// A count of [`ShiftedKkt::count_while`]: the shift used, the number of eigenvalues of the
/// pencil below it, its factorization, and the work done with that factorization.
type Counted<T> = (f64, usize, LbltFactor, Option<T>);

/// The shifted KKT matrices `K(σ)` of one point.
struct ShiftedKkt<'k> {
    kkt: &'k KktMatrix,
    /// Values at `σ = 0` in pattern order; the first `n_var` entries are the diagonal of the
    /// unknowns (where `−σ M` goes).
    values: Vec<f64>,
    /// The Lagrangian Hessian (lower triangle), for Rayleigh quotients.
    hessian: Vec<Entry>,
    /// The constraint Jacobian `A`, for the residual `A v` of a direction.
    jacobian: Vec<Entry>,
    metric: Vec<f64>,
    n_var: usize,
    n_con: usize,
}

impl<'k> ShiftedKkt<'k> {
    fn new<P: OcpProblem + ?Sized>(
        tr: &Transcription<'_, P>,
        kkt: &'k KktMatrix,
        pt: &KktPoint,
    ) -> Self {
        let (nv, nc) = (tr.n_var(), tr.n_con());
        let hessian = tr.lagrangian_hessian(&pt.v, &pt.y);
        let jacobian = tr.jacobian(&pt.v);
        let values = kkt.values(&vec![0.0; nv], &hessian, &jacobian);
        Self {
            kkt,
            values,
            hessian,
            jacobian,
            metric: tr.metric_diagonal(&pt.v),
            n_var: nv,
            n_con: nc,
        }
    }

    fn factorize(&self, sigma: f64) -> Result<LbltFactor, InertiaError> {
        self.kkt.factorize(&self.shifted(sigma))
    }

    /// The values of `K(σ)`.
    fn shifted(&self, sigma: f64) -> Vec<f64> {
        let mut values = self.values.clone();
        for (v, d) in values.iter_mut().zip(&self.metric) {
            *v -= sigma * d;
        }
        values
    }

    /// `aᵀ M b`.
    fn m_dot(&self, a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .zip(&self.metric)
            .map(|((x, y), d)| d * x * y)
            .sum()
    }

    /// The unknowns `v⁺` of `K(σ) [v⁺; y] = [M v; 0]` for a factorization of `K(σ)` (`None`
    /// if the solve fails or is not finite), with iterative refinement unless `estimate`.
    fn apply_inverse(&self, factor: &LbltFactor, v: &[f64], estimate: bool) -> Option<Vec<f64>> {
        let mut rhs: Vec<f64> = v.iter().zip(&self.metric).map(|(x, d)| d * x).collect();
        rhs.resize(self.n_var + self.n_con, 0.0);
        let solved = if estimate {
            factor.solve_in_place_unrefined(&mut rhs).is_ok()
        } else {
            factor.solve_in_place(&mut rhs).is_ok()
        };
        if !solved || !rhs.iter().all(|x| x.is_finite()) {
            return None;
        }
        rhs.truncate(self.n_var);
        Some(rhs)
    }

    /// The Rayleigh quotient `vᵀHv / vᵀMv`.
    fn rayleigh(&self, v: &[f64]) -> f64 {
        let h: f64 = self
            .hessian
            .iter()
            .map(|&(r, c, x)| {
                if r == c {
                    x * v[r] * v[r]
                } else {
                    2.0 * x * v[r] * v[c]
                }
            })
            .sum();
        h / self.m_dot(v, v)
    }

    /// `‖A v‖∞ / ‖|A| |v|‖∞`: how far `v` is from `null(A)`, relative to the magnitudes that
    /// the products sum (rounding gives about `1e-16`).
    fn constraint_residual(&self, v: &[f64]) -> f64 {
        let mut r = vec![0.0; self.n_con];
        let mut m = vec![0.0; self.n_con];
        for &(i, j, a) in &self.jacobian {
            r[i] += a * v[j];
            m[i] += (a * v[j]).abs();
        }
        let top = m.iter().fold(0.0_f64, |x, y| x.max(*y));
        let res = r.iter().fold(0.0_f64, |x, y| x.max(y.abs()));
        if top > 0.0 {
            res / top
        } else {
            res
        }
    }

    /// The number of eigenvalues of the pencil below `σ` (`excess` of `K(σ)`), trying `σ` and
    /// two nearby shifts (a shift on an eigenvalue makes `K(σ)` singular): the shift used, the
    /// count and the factorization, or `None` when none of the three gave a count.
    fn count(
        &self,
        sigma: f64,
        used: &mut usize,
    ) -> Result<Option<(f64, usize, LbltFactor)>, SecondOrderError> {
        Ok(self
            .count_while(sigma, used, |_, _, _| ())?
            .map(|(s, c, factor, _)| (s, c, factor)))
    }

    /// [`Self::count`], with `work(σ, count, factor)` done with each factorization that gives
    /// a count, while the checks that prove the count run ([`KktMatrix::factorize_while`]).
    /// The result of the work on the factorization returned comes with it (`Some`: the count
    /// is read from the same pivots before and after the checks).
    fn count_while<T>(
        &self,
        sigma: f64,
        used: &mut usize,
        mut work: impl FnMut(f64, usize, &LbltFactor) -> T,
    ) -> Result<Option<Counted<T>>, SecondOrderError> {
        for s in [
            sigma,
            sigma * (1.0 + 1e-7) + 1e-12,
            sigma * (1.0 - 1e-7) - 1e-12,
        ] {
            *used += 1;
            let counted = self.kkt.factorize_while(&self.shifted(s), |factor| {
                match self.excess(factor.inertia()) {
                    Ok(Some(c)) => Some(work(s, c, factor)),
                    _ => None,
                }
            });
            match counted {
                Ok((factor, out)) => {
                    if let Some(c) = self.excess(factor.inertia())? {
                        return Ok(Some((s, c, factor, out)));
                    }
                }
                Err(InertiaError::Breakdown { .. }) => {}
                Err(e) => return Err(e.into()),
            }
        }
        Ok(None)
    }

    /// A deterministic start with every component excited.
    fn start_vector(&self) -> Vec<f64> {
        (0..self.n_var)
            .map(|i| 1.0 + 0.5 * ((i * 7919) % 13) as f64 / 13.0)
            .collect()
    }

    /// `negative − m`, the number of negative eigenvalues of the reduced matrix (`None` if
    /// singular).
    fn excess(&self, inertia: Inertia) -> Result<Option<usize>, SecondOrderError> {
        if inertia.zero > 0 {
            return Ok(None);
        }
        inertia
            .negative
            .checked_sub(self.n_con)
            .map(Some)
            .ok_or(SecondOrderError::RankDeficient {
                inertia,
                n_con: self.n_con,
            })
    }
}

/// The second-order test at a KKT point (see the module docs).
pub fn second_order<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    pt: &KktPoint,
    opts: &SecondOrderOptions,
) -> Result<SecondOrderReport, SecondOrderError> {
    second_order_near(tr, kkt, pt, opts, None)
}

/// [`second_order`], given (`near`) a factorization of a KKT matrix near this one, such as
/// the last step of Newton's method to this point ([`kkt::newton_keeping_factor`]; its
/// inertia need not be proven).
///
/// It saves the factorization at `σ = 0` of a point it certifies: the Lanczos estimate `μ̂` of
/// `μ_min` is made with `near`'s solves, and the count at the margin's lower end
/// `lo = μ̂ − h > 0` (see the module docs) decides the verdict. No eigenvalue of the pencil below
/// `lo > 0` means `Zᵀ(H − lo M)Z ≻ 0`, so `ZᵀHZ ≻ lo ZᵀMZ ⪰ 0`: SOSC holds, and the inertia
/// of `K(0)` is `(n, m, 0)` (reported as such; the backward error and the smallest pivot are
/// then those of the factorization at `lo`). The estimate only says where to count. If the
/// count disagrees (an eigenvalue below `lo`, or `lo ≤ 0`), the test starts over as
/// [`second_order`] does, and the factorizations spent are counted.
///
/// `near` is taken by value and freed once the estimate is made, before any factorization
/// of this test: a factorization's memory (6 MB on the paper's η = 0.01 mesh) is then reused
/// instead of touched afresh, which in a fresh process costs page faults.
pub fn second_order_near<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    pt: &KktPoint,
    opts: &SecondOrderOptions,
    near: Option<LbltFactor>,
) -> Result<SecondOrderReport, SecondOrderError> {
    let kkt = ShiftedKkt::new(tr, kkt, pt);
    let mut used = 0;
    if let Some(near) = near {
        if let Some(report) = certified_from_estimate(&kkt, near, opts, &mut used)? {
            return Ok(report);
        }
    }
    let factor = kkt.factorize(0.0)?;
    used += 1;
    let inertia = factor.inertia();
    let mut report = SecondOrderReport {
        n_var: kkt.n_var,
        n_con: kkt.n_con,
        inertia,
        negative_curvature_directions: 0,
        verdict: Verdict::Degenerate,
        margin: None,
        backward_error: factor.backward_error(),
        min_pivot_ratio: factor.min_pivot_ratio(),
        factorizations: used,
        weakest_direction: None,
        weakest_rayleigh: None,
    };
    let Some(k0) = kkt.excess(inertia)? else {
        return Ok(report);
    };
    report.negative_curvature_directions = k0;
    report.verdict = if k0 == 0 {
        Verdict::Certified
    } else {
        Verdict::NotMinimum
    };
    let bracket = margin(&kkt, factor, k0 == 0, opts, &mut report.factorizations)?;
    finish(&kkt, &mut report, bracket);
    Ok(report)
}

/// The certificate of [`second_order_near`] when the estimate from `near` is confirmed
/// (`None` otherwise).
fn certified_from_estimate(
    kkt: &ShiftedKkt,
    near: LbltFactor,
    opts: &SecondOrderOptions,
    used: &mut usize,
) -> Result<Option<SecondOrderReport>, SecondOrderError> {
    let estimate = lanczos(kkt, &near, 0.0, opts.margin_rtol);
    drop(near);
    let Some((mu, vector)) = estimate else {
        return Ok(None);
    };
    let h = 0.45 * opts.margin_rtol * mu.abs();
    if mu - h <= 0.0 || mu.is_nan() || *used + 1 > opts.max_factorizations {
        return Ok(None);
    }
    // The weakest direction by inverse iteration from the estimate, with the factorization
    // whose count is being proven, while it is.
    let counted = kkt.count_while(mu - h, used, |s, c, factor| {
        (c == 0 && s > 0.0).then(|| inverse_iteration(kkt, factor, vector.clone(), true))
    })?;
    let Some((lo, 0, factor, weakest)) = counted else {
        return Ok(None);
    };
    if lo <= 0.0 {
        return Ok(None);
    }
    let mut report = SecondOrderReport {
        n_var: kkt.n_var,
        n_con: kkt.n_con,
        inertia: Inertia {
            positive: kkt.n_var,
            negative: kkt.n_con,
            zero: 0,
        },
        negative_curvature_directions: 0,
        verdict: Verdict::Certified,
        margin: None,
        backward_error: factor.backward_error(),
        min_pivot_ratio: factor.min_pivot_ratio(),
        factorizations: *used,
        weakest_direction: None,
        weakest_rayleigh: None,
    };
    drop(factor);
    let bracket = match upper_end(
        kkt,
        lo,
        weakest.flatten().flatten(),
        mu + h,
        opts,
        &mut report.factorizations,
    )? {
        Ok(bracket) => Some(bracket),
        // Bisection from what is proven.
        Err((lo, hi)) => bisect(kkt, lo, hi, opts, &mut report.factorizations)?,
    };
    finish(kkt, &mut report, bracket);
    Ok(Some(report))
}

/// Fills the margin and the weakest direction of `report` from `bracket` (for a bracket
/// without a direction: inverse iteration with a factorization just below `lo`).
fn finish(kkt: &ShiftedKkt, report: &mut SecondOrderReport, bracket: Option<Bracket>) {
    let Some(bracket) = bracket else {
        return;
    };
    let (lo, hi) = (bracket.lo, bracket.hi);
    report.margin = Some((lo, hi));
    let weakest = match bracket.weakest {
        Some(weakest) => Some(weakest),
        None => {
            let sigma = lo - (hi - lo).max(1e-3 * lo.abs());
            match kkt.factorize(sigma) {
                Ok(factor) => {
                    report.factorizations += 1;
                    inverse_iteration(kkt, &factor, kkt.start_vector(), false)
                }
                Err(_) => None,
            }
        }
    };
    if let Some((v, q)) = weakest {
        report.weakest_direction = Some(v);
        report.weakest_rayleigh = Some(q);
    }
}

/// Inverse iteration for the eigenvector of `μ_min` with a factorization of `K(σ)`, `σ` just
/// below `μ_min`: `K(σ) [v⁺; y] = [M v; 0]` keeps `v⁺` in `null(A)` and amplifies the
/// eigenvalue nearest `σ`. Twelve iterations from `start`, or (`converge`) fewer once the
/// Rayleigh quotient settles (for a start that is already an estimate of the eigenvector).
/// Returns the `M`-normalized vector, signed to have a positive `M`-product with
/// [`ShiftedKkt::start_vector`], and its Rayleigh quotient (`None` if a solve fails).
fn inverse_iteration(
    kkt: &ShiftedKkt,
    factor: &LbltFactor,
    start: Vec<f64>,
    converge: bool,
) -> Option<(Vec<f64>, f64)> {
    let mut v = start;
    let mut last = f64::NAN;
    for it in 0..12 {
        v = kkt.apply_inverse(factor, &v, false)?;
        let n = kkt.m_dot(&v, &v).sqrt();
        if n.is_nan() || n <= 0.0 {
            return None;
        }
        v.iter_mut().for_each(|x| *x /= n);
        if converge {
            let q = kkt.rayleigh(&v);
            if it >= 1 && (q - last).abs() <= 1e-12 * q.abs() {
                break;
            }
            last = q;
        }
    }
    if kkt.m_dot(&v, &kkt.start_vector()) < 0.0 {
        v.iter_mut().for_each(|x| *x = -*x);
    }
    let q = kkt.rayleigh(&v);
    Some((v, q))
}

/// A bracket `[lo, hi]` of `μ_min` (no eigenvalue below `lo`, at least one at or below `hi`).
struct Bracket {
    lo: f64,
    hi: f64,
    /// The weakest direction and its Rayleigh quotient, when the bracket's construction
    /// computed them (see [`upper_end`]).
    weakest: Option<(Vec<f64>, f64)>,
}

/// The first probe of the bracket searches, away from simple numbers (see [`margin`]).
const FIRST_PROBE: f64 = 0.7123;

/// Largest [`ShiftedKkt::constraint_residual`] of a direction whose Rayleigh quotient is
/// taken as an upper end of the margin ([`upper_end`]).
const NULL_SPACE_RTOL: f64 = 1e-10;

/// Brackets `μ_min` to the relative width `margin_rtol` (`None` when the budget runs out).
///
/// 1. A shift `σ₀` with no eigenvalue below it, and its factorization: `σ₀ = 0` at a certified
///    point (the factorization of the verdict), otherwise a geometric search downwards.
/// 2. An estimate `μ̂` of `μ_min` by the Lanczos method on the shift-inverted pencil with that
///    factorization ([`lanczos`]: solves only): the eigenvalues `1/(μ − σ₀) > 0` of
///    `v ↦ K(σ₀)⁻¹[M v; 0]` (restricted to `v`), self-adjoint in the `M` inner product on
///    `null(A)`, the largest being `1/(μ_min − σ₀)`.
/// 3. The lower end `lo = μ̂ − h`, `h = 0.45 · margin_rtol · |μ̂|`, confirmed by the inertia of
///    its factorization: no eigenvalue below it. The upper end ([`upper_end`]): the Rayleigh
///    quotient of the eigenvector found by inverse iteration with that factorization, or the
///    count at `μ̂ + h`. The lower end rests on the count (Sylvester's law), the upper one on
///    an explicit direction or a count, not on the estimate.
/// 4. If the estimate is not confirmed (or not available), bisection from what is known
///    ([`bisect`]).
///
/// A shift that lands on an eigenvalue (a zero pivot, or a breakdown of the factorization:
/// `K(σ)` is singular there) is moved by a relative `1e-7` ([`ShiftedKkt::count`]), and the
/// bracket keeps the shift actually used. Such coincidences are not rare: for a cost `|u|²/2`
/// the metric `M` equals the control block of `H`, so `σ = 1` can be an eigenvalue of high
/// multiplicity.
fn margin(
    kkt: &ShiftedKkt,
    factor0: LbltFactor,
    positive: bool,
    opts: &SecondOrderOptions,
    used: &mut usize,
) -> Result<Option<Bracket>, SecondOrderError> {
    let out_of_budget = |used: usize| used >= opts.max_factorizations;
    // 1. No eigenvalue below `lo`; at least one below `hi` when known.
    let (mut lo, mut hi, base) = if positive {
        (0.0, None, factor0)
    } else {
        drop(factor0);
        let mut hi = 0.0;
        let mut probe = -FIRST_PROBE;
        loop {
            if out_of_budget(*used) {
                return Ok(None);
            }
            match kkt.count(probe, used)? {
                None => return Ok(None),
                Some((s, 0, factor)) => break (s, Some(hi), factor),
                Some((s, _, _)) => {
                    hi = s;
                    probe = 4.0 * s;
                }
            }
        }
    };
    // 2.–3. Estimate, and confirm.
    if let Some((mu, vector)) = lanczos(kkt, &base, lo, opts.margin_rtol) {
        drop(base);
        let h = 0.45 * opts.margin_rtol * mu.abs();
        if mu - h > lo && *used < opts.max_factorizations {
            let counted = kkt.count_while(mu - h, used, |_, c, factor| {
                (c == 0).then(|| inverse_iteration(kkt, factor, vector.clone(), true))
            })?;
            match counted {
                Some((s_lo, 0, factor, weakest)) => {
                    drop(factor);
                    let weakest = weakest.flatten().flatten();
                    match upper_end(kkt, s_lo, weakest, mu + h, opts, used)? {
                        Ok(bracket) => return Ok(Some(bracket)),
                        Err((l, u)) => {
                            lo = l;
                            hi = u.or(hi);
                        }
                    }
                }
                Some((s_lo, _, _, _)) => hi = Some(s_lo),
                None => {}
            }
        }
    }
    // 4. Bisection.
    bisect(kkt, lo, hi, opts, used)
}

/// The upper end of a bracket whose lower end `lo` is proven by a count (no eigenvalue below
/// it), from `weakest`: the eigenvector `v` of `μ_min` and its Rayleigh quotient, found by
/// inverse iteration from an estimate with the factorization of that count.
///
/// The eigenvector `v` is in `null(A)` up to rounding, and its Rayleigh quotient `q = vᵀHv / vᵀMv`, an upper bound of `μ_min` (Courant–Fischer:
/// `μ_min` is the smallest such quotient over `null(A)`). It is the upper end when `v` is in
/// `null(A)` to [`NULL_SPACE_RTOL`] and `[lo, q]` is as narrow as asked; otherwise the count
/// at `probe` (the estimate's `μ̂ + h`) must find an eigenvalue below it. When neither closes
/// the bracket: what is known for [`bisect`], `(lo, hi)`.
fn upper_end(
    kkt: &ShiftedKkt,
    lo: f64,
    weakest: Option<(Vec<f64>, f64)>,
    probe: f64,
    opts: &SecondOrderOptions,
    used: &mut usize,
) -> Result<Result<Bracket, (f64, Option<f64>)>, SecondOrderError> {
    let narrow = |lo: f64, hi: f64| hi - lo <= opts.margin_rtol * lo.abs().max(hi.abs());
    if let Some((v, q)) = &weakest {
        if q.is_finite()
            && *q >= lo
            && narrow(lo, *q)
            && kkt.constraint_residual(v) <= NULL_SPACE_RTOL
        {
            return Ok(Ok(Bracket {
                lo,
                hi: *q,
                weakest,
            }));
        }
    }
    if *used >= opts.max_factorizations {
        return Ok(Err((lo, None)));
    }
    Ok(match kkt.count(probe, used)? {
        Some((hi, c, _)) if c > 0 && narrow(lo, hi) => Ok(Bracket { lo, hi, weakest }),
        Some((hi, c, _)) if c > 0 => Err((lo, Some(hi))),
        Some((s, _, _)) => Err((s, None)),
        None => Err((lo, None)),
    })
}

/// Bisection on `σ` from `lo` (no eigenvalue below it) and `hi` (at least one below it, when
/// known; otherwise a geometric search for it: first probe `0.7123`, then ×4) to the relative
/// width `margin_rtol` (`None` when the budget runs out).
fn bisect(
    kkt: &ShiftedKkt,
    mut lo: f64,
    hi: Option<f64>,
    opts: &SecondOrderOptions,
    used: &mut usize,
) -> Result<Option<Bracket>, SecondOrderError> {
    let out_of_budget = |used: usize| used >= opts.max_factorizations;
    let mut hi = match hi {
        Some(hi) => hi,
        None => {
            let mut probe = if lo > 0.0 { 4.0 * lo } else { FIRST_PROBE };
            loop {
                if out_of_budget(*used) {
                    return Ok(None);
                }
                match kkt.count(probe, used)? {
                    None => return Ok(None),
                    Some((s, 0, _)) => {
                        lo = s;
                        probe = 4.0 * s;
                    }
                    Some((s, _, _)) => break s,
                }
            }
        }
    };
    while hi - lo > opts.margin_rtol * lo.abs().max(hi.abs()) {
        if out_of_budget(*used) {
            return Ok(None);
        }
        let mid = 0.5 * (lo + hi);
        match kkt.count(mid, used)? {
            None => return Ok(None),
            Some((s, 0, _)) => lo = s,
            Some((s, _, _)) => hi = s,
        }
    }
    Ok(Some(Bracket {
        lo,
        hi,
        weakest: None,
    }))
}

/// Most Lanczos steps of [`lanczos`].
const LANCZOS_MAX_STEPS: usize = 60;

/// The Lanczos method with a factorization of `K(σ)` that has no eigenvalue of the pencil
/// below `σ`: an estimate `(μ̂, v̂)` of `μ_min` and its eigenvector (`M`-normalized, in
/// `null(A)`), converged to a tenth of the bracket width `margin_rtol · |μ̂|` (by the
/// residual bound of the Ritz value, or the quadratic bound with the Ritz gap once that is
/// smaller), or `None` (no convergence in [`LANCZOS_MAX_STEPS`] steps, or a failed solve). An
/// estimate only: the caller confirms it by inertia counts, and an estimate that they reject
/// costs the factorizations of the plain test, never a wrong bracket.
///
/// The operator `S v = K(σ)⁻¹[M v; 0]` (the unknowns of the solution) is self-adjoint in the
/// `M` inner product, with eigenvalues `1/(μ − σ) > 0` on `null(A)`, the largest
/// `1/(μ_min − σ)`. `S v` depends on `v` only through the components where `M > 0` (the
/// controls, the free initial data, `T`), so the iteration runs on those: `T c = (S c)|_M`,
/// self-adjoint for the positive definite `diag(M)|_M`, with the same nonzero eigenvalues.
/// (Run on all the unknowns, `M` is only semidefinite and the rounding errors outside
/// `null(A)`, which it does not see, grow at every step.) The Ritz vector `x` is lifted to
/// `S x / θ`, exactly in `null(A)`, from the solves already done.
fn lanczos(
    kkt: &ShiftedKkt,
    factor: &LbltFactor,
    sigma: f64,
    margin_rtol: f64,
) -> Option<(f64, Vec<f64>)> {
    let visible: Vec<usize> = (0..kkt.n_var).filter(|&i| kkt.metric[i] > 0.0).collect();
    let weight: Vec<f64> = visible.iter().map(|&i| kkt.metric[i]).collect();
    let dot = |a: &[f64], b: &[f64]| -> f64 {
        a.iter()
            .zip(b)
            .zip(&weight)
            .map(|((x, y), d)| d * x * y)
            .sum()
    };
    let embed = |c: &[f64]| -> Vec<f64> {
        let mut v = vec![0.0; kkt.n_var];
        for (&i, x) in visible.iter().zip(c) {
            v[i] = *x;
        }
        v
    };
    let restrict = |v: &[f64]| -> Vec<f64> { visible.iter().map(|&i| v[i]).collect() };
    let steps = LANCZOS_MAX_STEPS.min(visible.len());
    // The first vector: one inverse iteration from the deterministic start.
    let mut q = restrict(&kkt.apply_inverse(factor, &kkt.start_vector(), true)?);
    let norm = dot(&q, &q).sqrt();
    if !(norm > 0.0 && norm.is_finite()) {
        return None;
    }
    q.iter_mut().for_each(|x| *x /= norm);
    let mut basis = vec![q];
    // S applied to each basis vector (all the unknowns).
    let mut images: Vec<Vec<f64>> = Vec::new();
    let (mut alpha, mut beta): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    for j in 0..steps {
        let image = kkt.apply_inverse(factor, &embed(&basis[j]), true)?;
        let mut w = restrict(&image);
        images.push(image);
        alpha.push(dot(&w, &basis[j]));
        for _ in 0..2 {
            for qi in &basis {
                let c = dot(&w, qi);
                w.iter_mut().zip(qi).for_each(|(x, y)| *x -= c * y);
            }
        }
        let b = dot(&w, &w).sqrt();
        // The largest Ritz value of the tridiagonal matrix, and its residual bound.
        let k = alpha.len();
        let mut t = nalgebra::DMatrix::<f64>::zeros(k, k);
        for i in 0..k {
            t[(i, i)] = alpha[i];
            if i + 1 < k {
                t[(i, i + 1)] = beta[i];
                t[(i + 1, i)] = beta[i];
            }
        }
        let eig = t.symmetric_eigen();
        let (top, &theta) = eig
            .eigenvalues
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))?;
        let s = eig.eigenvectors.column(top);
        // (A NaN `b` counts as a breakdown.)
        let invariant = b.is_nan() || b <= 1e-13 * theta.abs();
        if theta > 0.0 && theta.is_finite() {
            let mu = sigma + 1.0 / theta;
            // |θ − θ_true| ≤ ρ = b |s_k| for an eigenvalue θ_true, and ≤ ρ²/δ with δ the gap
            // from θ to the rest of the spectrum (Kato–Temple), estimated by the gap to the
            // next Ritz value (which can overstate δ: Ritz values interlace the eigenvalues);
            // dμ = dθ / θ².
            let rho = b * s[k - 1].abs();
            let next = eig
                .eigenvalues
                .iter()
                .enumerate()
                .filter(|&(i, _)| i != top)
                .fold(f64::NEG_INFINITY, |m, (_, &x)| m.max(x));
            let gap = theta - next;
            // (No gap before the second step: `next` is then −∞.)
            let bound = if gap > 0.0 && gap.is_finite() {
                rho.min(rho * rho / gap)
            } else {
                rho
            };
            let err = bound / (theta * theta);
            if invariant || err <= 0.1 * margin_rtol * mu.abs() {
                // S x / θ for the Ritz vector x = Σ s_i q_i.
                let mut v = vec![0.0; kkt.n_var];
                for (image, si) in images.iter().zip(s.iter()) {
                    v.iter_mut().zip(image).for_each(|(x, y)| *x += si * y);
                }
                let n = kkt.m_dot(&v, &v).sqrt();
                if !(n > 0.0 && n.is_finite()) {
                    return None;
                }
                v.iter_mut().for_each(|x| *x /= n);
                return Some((mu, v));
            }
        }
        if invariant || !b.is_finite() {
            return None;
        }
        w.iter_mut().for_each(|x| *x /= b);
        beta.push(b);
        basis.push(w);
    }
    None
}

/// Where Newton's method on the KKT conditions took its start multipliers from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MultiplierStart {
    /// From the candidate's costates ([`kkt::multipliers_from_costates`]).
    Costates,
    /// The least-squares multipliers at the candidate (no costates given, none they could
    /// give, or Newton failed from theirs).
    LeastSquares,
}

/// Everything [`certify`] establishes about a candidate solution.
#[derive(Debug, Clone, PartialEq)]
pub struct Certificate {
    /// KKT residual of the candidate itself, with Newton's start multipliers: how far the
    /// candidate (e.g. an indirect solution) is from a KKT point of the discretized problem.
    /// The start multipliers are the least-squares ones (the smallest residual any multipliers
    /// give at the candidate), or, with [`certify_with_costates`], those of its costates,
    /// whose own discretization error the residual then includes.
    pub candidate: KktResidual,
    /// Where Newton's start multipliers (those of `candidate`) came from.
    pub multipliers_from: MultiplierStart,
    /// Newton iterations from the candidate to the exact KKT point.
    pub newton_iterations: usize,
    /// KKT residual at the point that is certified.
    pub kkt: KktResidual,
    /// `‖v* − v₀‖∞`: how far the certified point is from the candidate.
    pub displacement: f64,
    /// The certified primal-dual point.
    pub point: KktPoint,
    /// The second-order test at that point.
    pub second_order: SecondOrderReport,
    /// Where the second variation first loses positivity among variations with fixed ends
    /// (the discrete conjugate point; [`super::conjugate`]). At a certified point, none, from
    /// the certificate's inertia (then with no factorization of its own).
    pub conjugate: ConjugateReport,
}

/// Why [`certify`] could not give a verdict.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CertifyError {
    /// The candidate has the wrong number of unknowns.
    #[error("the candidate has {got} unknowns, the transcription {expected}")]
    Length {
        /// `n_var`.
        expected: usize,
        /// Given.
        got: usize,
    },
    /// The transcription could not be built.
    #[error("invalid transcription: {0}")]
    Transcription(#[from] super::transcription::TranscriptionError),
    /// Multipliers or Newton's method on the KKT conditions failed.
    #[error(transparent)]
    Kkt(#[from] KktError),
    /// The second-order test failed.
    #[error(transparent)]
    SecondOrder(#[from] SecondOrderError),
    /// The problem has a feature the certificate does not handle (says which).
    #[error("not supported: {0}")]
    Unsupported(String),
}

/// From a candidate primal point `v0` (an indirect solution sampled at the collocation
/// points): least-squares multipliers, Newton's method to the exact KKT point of the
/// discretized problem, and the second-order test there. (With the candidate's costates,
/// [`certify_with_costates`] saves the factorization of the least-squares multipliers.)
pub fn certify<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    v0: Vec<f64>,
    newton_opts: &NewtonOptions,
    opts: &SecondOrderOptions,
) -> Result<Certificate, CertifyError> {
    certify_with_costates(tr, v0, None, newton_opts, opts)
}

/// [`certify`] with the candidate's costates `pi` (`P × n` at the transcription's points),
/// when it has them (an indirect solution): Newton's method then starts from the multipliers
/// they give ([`kkt::multipliers_from_costates`]) instead of the least-squares multipliers,
/// which saves a factorization of the KKT pattern. Without them, or where they give none,
/// as [`certify`].
pub fn certify_with_costates<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    v0: Vec<f64>,
    costates: Option<&[f64]>,
    newton_opts: &NewtonOptions,
    opts: &SecondOrderOptions,
) -> Result<Certificate, CertifyError> {
    if v0.len() != tr.n_var() {
        return Err(CertifyError::Length {
            expected: tr.n_var(),
            got: v0.len(),
        });
    }
    let matrix = KktMatrix::new(tr)?;
    let first = PrimalEvaluation::at(tr, &v0);
    let from_costates = costates.and_then(|pi| kkt::multipliers_from_costates(tr, &first, pi));
    // Newton from the costates' multipliers; where it fails (they may be far from the
    // discrete ones on a coarse mesh), from the least-squares multipliers, as without them.
    let mut first = Some(first);
    let attempt = from_costates.and_then(|y| {
        let start = KktPoint { v: v0.clone(), y };
        let eval = first.take()?;
        kkt::newton_from(tr, &matrix, start.clone(), eval, newton_opts)
            .ok()
            .map(|run| (start, MultiplierStart::Costates, run))
    });
    let (start, multipliers_from, (point, newton, near)) = match attempt {
        Some(done) => done,
        None => {
            let first = first.unwrap_or_else(|| PrimalEvaluation::at(tr, &v0));
            let y0 = kkt::least_squares_multipliers_at(&matrix, &first)?;
            let start = KktPoint { v: v0, y: y0 };
            let run = kkt::newton_from(tr, &matrix, start.clone(), first, newton_opts)?;
            (start, MultiplierStart::LeastSquares, run)
        }
    };
    // Newton's first residual is the candidate's (`kkt::residual` at `start`).
    let candidate = newton.residuals[0];
    let displacement = point
        .v
        .iter()
        .zip(&start.v)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    let second_order = second_order_near(tr, &matrix, &point, opts, near)?;
    // At a certified point there is no conjugate point, by the inertia of the certificate's
    // factorization (see `super::conjugate`): no factorization of the restricted matrices.
    // (Not with linear start conditions, which the restricted matrices leave out: their
    // variations are not all admissible for the full problem.)
    let implied =
        second_order.verdict == Verdict::Certified && tr.boundary().start_linear.is_empty();
    let conjugate = if implied {
        ConjugateReport {
            first: None,
            factorizations: 0,
        }
    } else {
        first_conjugate_point(tr, &matrix, &point)?
    };
    Ok(Certificate {
        candidate,
        multipliers_from,
        newton_iterations: newton.residuals.len() - 1,
        kkt: *newton.residuals.last().unwrap_or(&candidate),
        displacement,
        point,
        second_order,
        conjugate,
    })
}
