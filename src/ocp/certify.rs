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
//! of generalized eigenvalues `μ` of `(ZᵀHZ, ZᵀMZ)` below `σ`. Bisection on `σ` brackets the
//! smallest one, `μ_min`: the second variation satisfies `δ²ℒ ≥ μ_min ‖δv‖²_M` on the
//! linearized constraints, a mesh-independent number (for `ẋ = u`, `L = (u² − x²)/2`,
//! `x(0) = x(T) = 0` it tends to `1 − (T/π)²`).

use super::conjugate::{first_conjugate_point, ConjugateReport};
use super::inertia::{Inertia, InertiaError, LbltFactor};
use super::kkt::{self, KktError, KktMatrix, KktPoint, KktResidual, NewtonOptions};
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
    /// Inertia of the KKT matrix (`σ = 0`); SOSC ⇔ `(n, m, 0)`.
    pub inertia: Inertia,
    /// Number of negative eigenvalues of the reduced Hessian (`negative − m`).
    pub negative_curvature_directions: usize,
    /// The verdict.
    pub verdict: Verdict,
    /// Bracket `[lo, hi]` of the smallest generalized eigenvalue `μ_min` of the reduced
    /// Hessian in the metric `M` (`None` when degenerate or the search ran out of budget).
    pub margin: Option<(f64, f64)>,
    /// Backward error of the `σ = 0` factorization.
    pub backward_error: f64,
    /// Smallest `|pivot| / ‖K‖` of the `σ = 0` factorization.
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

/// The shifted KKT matrices `K(σ)` of one point.
struct ShiftedKkt<'k> {
    kkt: &'k KktMatrix,
    /// Values at `σ = 0` in pattern order; the first `n_var` entries are the diagonal of the
    /// unknowns (where `−σ M` goes).
    values: Vec<f64>,
    /// The Lagrangian Hessian (lower triangle), for Rayleigh quotients.
    hessian: Vec<Entry>,
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
        let values = kkt.values(&vec![0.0; nv], &hessian, &tr.jacobian(&pt.v));
        Self {
            kkt,
            values,
            hessian,
            metric: tr.metric_diagonal(&pt.v),
            n_var: nv,
            n_con: nc,
        }
    }

    fn factorize(&self, sigma: f64) -> Result<LbltFactor, InertiaError> {
        let mut values = self.values.clone();
        for (v, d) in values.iter_mut().zip(&self.metric) {
            *v -= sigma * d;
        }
        self.kkt.factorize(&values)
    }

    /// Number of eigenvalues `μ < σ` (`None` if `σ` is (numerically) an eigenvalue).
    fn count_below(&self, sigma: f64) -> Result<Option<usize>, SecondOrderError> {
        let inertia = self.factorize(sigma)?.inertia();
        self.excess(inertia)
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
    let kkt = ShiftedKkt::new(tr, kkt, pt);
    let factor = kkt.factorize(0.0)?;
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
        factorizations: 1,
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
    report.margin = margin(&kkt, k0 == 0, opts, &mut report.factorizations)?;
    if let Some((lo, hi)) = report.margin {
        if let Some((v, q)) = weakest(&kkt, lo - (hi - lo).max(1e-3 * lo.abs()))? {
            report.factorizations += 1;
            report.weakest_direction = Some(v);
            report.weakest_rayleigh = Some(q);
        }
    }
    Ok(report)
}

/// Inverse iteration for the eigenvector of `μ_min` with a shift `σ` just below it:
/// `K(σ) [v⁺; y] = [M v; 0]` keeps `v⁺` in `null(A)` and amplifies the eigenvalue nearest `σ`.
/// Returns the `M`-normalized vector and its Rayleigh quotient (`None` if the solve fails).
fn weakest(kkt: &ShiftedKkt, sigma: f64) -> Result<Option<(Vec<f64>, f64)>, SecondOrderError> {
    let Ok(factor) = kkt.factorize(sigma) else {
        return Ok(None);
    };
    let (nv, nc) = (kkt.n_var, kkt.n_con);
    let m_norm = |v: &[f64]| -> f64 {
        v.iter()
            .zip(&kkt.metric)
            .map(|(x, d)| d * x * x)
            .sum::<f64>()
            .sqrt()
    };
    // A deterministic start with every component excited.
    let mut v: Vec<f64> = (0..nv)
        .map(|i| 1.0 + 0.5 * ((i * 7919) % 13) as f64 / 13.0)
        .collect();
    for _ in 0..12 {
        let mut rhs: Vec<f64> = v.iter().zip(&kkt.metric).map(|(x, d)| d * x).collect();
        rhs.resize(nv + nc, 0.0);
        if factor.solve_in_place(&mut rhs).is_err() || !rhs.iter().all(|x| x.is_finite()) {
            return Ok(None);
        }
        rhs.truncate(nv);
        let n = m_norm(&rhs);
        if n.is_nan() || n <= 0.0 {
            return Ok(None);
        }
        v = rhs.into_iter().map(|x| x / n).collect();
    }
    // Rayleigh quotient vᵀHv (vᵀMv = 1).
    let q: f64 = kkt
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
    Ok(Some((v, q)))
}

/// Brackets `μ_min`: first a geometric search for a bracket `[lo, hi]` with no eigenvalue
/// below `lo` and at least one below `hi` (one end is 0, where the count is known), then
/// bisection to the relative width `margin_rtol`. `None` when the budget runs out.
///
/// A shift that lands on an eigenvalue (a zero pivot, or a breakdown of the factorization:
/// `K(σ)` is singular there) is moved by a relative `1e-7`. Such coincidences are not rare:
/// for a cost `|u|²/2` the metric `M` equals the control block of `H`, so `σ = 1` can be an
/// eigenvalue of high multiplicity.
fn margin(
    kkt: &ShiftedKkt,
    positive: bool,
    opts: &SecondOrderOptions,
    used: &mut usize,
) -> Result<Option<(f64, f64)>, SecondOrderError> {
    // The number of eigenvalues below σ, trying σ and two nearby shifts.
    let count = |sigma: f64, used: &mut usize| -> Result<Option<usize>, SecondOrderError> {
        for s in [
            sigma,
            sigma * (1.0 + 1e-7) + 1e-12,
            sigma * (1.0 - 1e-7) - 1e-12,
        ] {
            *used += 1;
            match kkt.count_below(s) {
                Ok(Some(c)) => return Ok(Some(c)),
                Ok(None) | Err(SecondOrderError::Factorization(InertiaError::Breakdown { .. })) => {
                }
                Err(e) => return Err(e),
            }
        }
        Ok(None)
    };
    // The first probe is away from simple numbers (see above).
    const FIRST: f64 = 0.7123;
    let (mut lo, mut hi);
    if positive {
        lo = 0.0;
        hi = FIRST;
        loop {
            if *used >= opts.max_factorizations {
                return Ok(None);
            }
            match count(hi, used)? {
                None => return Ok(None),
                Some(0) => {
                    lo = hi;
                    hi *= 4.0;
                }
                Some(_) => break,
            }
        }
    } else {
        hi = 0.0;
        lo = -FIRST;
        loop {
            if *used >= opts.max_factorizations {
                return Ok(None);
            }
            match count(lo, used)? {
                None => return Ok(None),
                Some(0) => break,
                Some(_) => {
                    hi = lo;
                    lo *= 4.0;
                }
            }
        }
    }
    while hi - lo > opts.margin_rtol * lo.abs().max(hi.abs()) {
        if *used >= opts.max_factorizations {
            return Ok(None);
        }
        let mid = 0.5 * (lo + hi);
        match count(mid, used)? {
            None => return Ok(None),
            Some(0) => lo = mid,
            Some(_) => hi = mid,
        }
    }
    Ok(Some((lo, hi)))
}

/// Everything [`certify`] establishes about a candidate solution.
#[derive(Debug, Clone, PartialEq)]
pub struct Certificate {
    /// KKT residual of the candidate itself, with its least-squares multipliers: how far the
    /// candidate (e.g. an indirect solution) is from a KKT point of the discretized problem.
    pub candidate: KktResidual,
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
    /// (the discrete conjugate point; [`super::conjugate`]).
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
/// discretized problem, and the second-order test there.
pub fn certify<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    v0: Vec<f64>,
    newton_opts: &NewtonOptions,
    opts: &SecondOrderOptions,
) -> Result<Certificate, CertifyError> {
    if v0.len() != tr.n_var() {
        return Err(CertifyError::Length {
            expected: tr.n_var(),
            got: v0.len(),
        });
    }
    let matrix = KktMatrix::new(tr, &v0)?;
    let y0 = kkt::least_squares_multipliers(tr, &matrix, &v0)?;
    let start = KktPoint { v: v0, y: y0 };
    let candidate = kkt::residual(tr, &start);
    let (point, newton) = kkt::newton(tr, &matrix, start.clone(), newton_opts)?;
    let displacement = point
        .v
        .iter()
        .zip(&start.v)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    let second_order = second_order(tr, &matrix, &point, opts)?;
    let conjugate = first_conjugate_point(tr, &point)?;
    Ok(Certificate {
        candidate,
        newton_iterations: newton.residuals.len() - 1,
        kkt: *newton.residuals.last().unwrap_or(&candidate),
        displacement,
        point,
        second_order,
        conjugate,
    })
}
