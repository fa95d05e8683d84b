//! Discrete conjugate points: *where* in time the second variation first loses positivity.
//!
//! Jacobi's condition in discrete form. For a mesh node `t_j`, restrict the second variation
//! at a KKT point to the variations supported on `[t0, t_j]`: `δz_p = 0` at every collocation
//! point from `t_j` on (so `δx(t_j) = 0`: the variation rejoins the extremal there) and
//! `δT = 0`. They are admissible variations of the full problem (extended by zero), so its
//! KKT matrix restricted to them is a principal submatrix `K_j` — the unknowns of the points
//! before `t_j`, the collocation constraints of the intervals before `t_j` and the start
//! conditions — and, as in [`mod@super::certify`], `K_j` has `m_j` negative eigenvalues plus one
//! per direction of negative curvature. The first node where that excess is positive is the
//! discrete **conjugate point**: the smallest horizon over which a variation with fixed ends
//! lowers the cost.
//!
//! The excess grows with `j` (more variations), so a bisection over the nodes finds the first
//! one with `⌈log₂ N⌉ + 1` factorizations. Each is a factorization of the full KKT pattern
//! (analysed once, [`KktMatrix`]) with the rows and columns outside `K_j` set to zero, which
//! the factorization deflates and counts as zero eigenvalues (as many as were removed).
//!
//! A certified minimum has no conjugate point: its variations include all of these. Precisely,
//! for `A_j` of rank `r` and `Z_j` a basis of its null space,
//! `inertia(K_j) = inertia(Z_jᵀ H_j Z_j) + (r, r, m_j − r)`, so the excess (negative and zero
//! eigenvalues beyond `m_j`) counts the nonpositive eigenvalues of `Z_jᵀ H_j Z_j`; the
//! variations in `null(A_j)`, extended by zero, lie in `null(A)`, where `H` is positive
//! definite when the KKT matrix has the inertia `(n, m, 0)`. So [`super::certify::certify`]
//! calls [`first_conjugate_point`] only for points that are not certified: at a certified point
//! the answer "none" follows from the inertia of the certificate's own factorization. The
//! exception is a problem with linear start conditions ([`super::problem::Boundary`]):
//! `K_j` keeps the prescribed start components but not those conditions, so its variations
//! need not satisfy them, and the search runs.
//! A point that is not a minimum may have one (the oscillator `ẋ = u`, `L = (u² − x²)/2` has
//! it at `t = π`) or not (when negative curvature needs the free end data, `δx(b)` or `δT`).
//! Zero eigenvalues of `K_j` are attributed to dependent constraints, not to curvature (see
//! `excess_at`): the test reports strict negative curvature.

use super::certify::SecondOrderError;
use super::kkt::{KktMatrix, KktPoint};
use super::problem::OcpProblem;
use super::transcription::Transcription;

/// The first discrete conjugate point, if any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConjugatePoint {
    /// Mesh node index `j` (`1..=N`).
    pub node: usize,
    /// Its time `t_j`.
    pub time: f64,
    /// The time of the node before it: the conjugate point lies in `(previous, time]`.
    pub previous: f64,
}

/// The outcome of [`first_conjugate_point`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConjugateReport {
    /// The first conjugate point, `None` if there is none up to the last node.
    pub first: Option<ConjugatePoint>,
    /// Factorizations done.
    pub factorizations: usize,
}

/// The restricted KKT matrix `K_j` (see the module docs), as the full matrix with the other
/// rows and columns zeroed, and its excess of negative eigenvalues over the constraints.
fn excess_at<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    values: &[f64],
    j: usize,
) -> Result<Option<usize>, SecondOrderError> {
    let (n, nz, nv) = (tr.n_state(), tr.nz(), tr.n_var());
    let stage_rows = 3 * tr.n_intervals() * n;
    let n_start = tr.boundary().start.len();
    // Kept: unknowns of the points 0..3j, constraints of the intervals 0..j, start rows.
    let kept_var = 3 * j * nz;
    let kept_con = 3 * j * n;
    let kept = |i: usize| -> bool {
        i < kept_var
            || (i >= nv && i < nv + kept_con)
            || (i >= nv + stage_rows && i < nv + stage_rows + n_start)
    };
    let removed = kkt.n_var() + kkt.n_con() - (kept_var + kept_con + n_start);
    let inertia = kkt
        .factorize(&kkt.principal_values(values, kept))?
        .inertia();
    // Zero eigenvalues are counted with the constraints: fixing the whole state at `t_j` can
    // make the constraints dependent (a conserved quantity of the dynamics, such as Suslov's
    // ⟨Ω, ξ⟩, is fixed at `t_j` by the start data already), which shows as zero eigenvalues,
    // not as curvature. The removed rows are exactly zero: `removed` zero eigenvalues.
    Ok((inertia.negative + inertia.zero)
        .checked_sub(removed)
        .and_then(|k| k.checked_sub(kept_con + n_start)))
}

/// The first discrete conjugate point of the KKT point `pt` (see the module docs).
pub fn first_conjugate_point<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    pt: &KktPoint,
) -> Result<ConjugateReport, SecondOrderError> {
    let values = kkt.values(
        &vec![0.0; tr.n_var()],
        &tr.lagrangian_hessian(&pt.v, &pt.y),
        &tr.jacobian(&pt.v),
    );
    let mut factorizations = 0;
    let conjugate = |j: usize, count: &mut usize| -> Result<bool, SecondOrderError> {
        *count += 1;
        Ok(excess_at(tr, kkt, &values, j)?.is_some_and(|e| e > 0))
    };
    let last = tr.n_intervals();
    if !conjugate(last, &mut factorizations)? {
        return Ok(ConjugateReport {
            first: None,
            factorizations,
        });
    }
    // Invariant: no conjugate point at `lo` (0: no variation at all), one at `hi`.
    let (mut lo, mut hi) = (0, last);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if conjugate(mid, &mut factorizations)? {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let t_len = tr.length(&pt.v);
    let time = |j: usize| tr.horizon().t0() + tr.mesh()[j] * t_len;
    Ok(ConjugateReport {
        first: Some(ConjugatePoint {
            node: hi,
            time: time(hi),
            previous: time(lo),
        }),
        factorizations,
    })
}
