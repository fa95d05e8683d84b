//! Inertia (numbers of positive, negative and zero eigenvalues) of large sparse symmetric,
//! possibly indefinite matrices, e.g. KKT matrices `K = [[H, Aᵀ], [A, 0]]`, through a sparse
//! `P K̃ Pᵀ = L B Lᵀ` factorization (faer's supernodal factorization with Bunch–Kaufman
//! pivoting inside each supernode) of the equilibrated matrix `K̃ = D K D`.
//!
//! By Sylvester's law of inertia, `inertia(K) = inertia(K̃) = inertia(B)`, and `B` is block
//! diagonal with `1×1` and `2×2` blocks, whose signs are cheap to count. For a KKT matrix with
//! `A` (`m × n`) of full row rank and `Z` a basis of its null space,
//! `inertia(K) = inertia(ZᵀHZ) + (m, m, 0)`.
//!
//! # Workflow
//! 1. [`SymmetricPattern::new`] (or [`SymmetricPattern::with_values`]) analyses a sparsity
//!    pattern once: pairing of zero-diagonal rows, fill-reducing AMD ordering, supernodal
//!    symbolic structure.
//! 2. [`LbltFactor::factorize`] computes and checks a numeric factorization for one set of
//!    values; call it as often as needed on the same pattern (e.g. for
//!    `K(σ) = [[H − σM, Aᵀ], [A, 0]]` in a bisection on `σ`).
//! 3. [`LbltFactor::inertia`], [`LbltFactor::solve_in_place`], and the reliability measures
//!    ([`LbltFactor::backward_error`], [`LbltFactor::contraction`],
//!    [`LbltFactor::min_pivot_ratio`]).
//!
//! # Numerical safeguards
//! faer pivots only *inside* supernodes (no delayed pivots), so a factorization may meet a tiny
//! or zero pivot that it cannot avoid. Therefore:
//! - **zero-diagonal rows are paired**: a row whose diagonal is structurally zero (a KKT
//!   constraint row) is matched with a neighbour and the two are forced into the same supernode,
//!   so that Bunch–Kaufman can take the `2×2` pivot `[[h, a], [a, 0]]` (see
//!   [`SymmetricPattern`]);
//! - the factorization is always the **supernodal** one (faer's simplicial variant of
//!   `factorize_numeric_intranode_lblt` silently does an *unpivoted* `LDLᵀ`);
//! - **equilibration**: `K̃ = D K D` with `D` diagonal made of powers of two (symmetric Ruiz
//!   iteration in the ∞-norm), so that the rows of `K̃` have max-norm close to 1. Powers of two
//!   make the scaling exact in floating point, and `D K D` is congruent to `K`: the inertia is
//!   exactly preserved, and the pivot thresholds become scale invariant;
//! - **exact zero rows** (a row/column of `K` whose values are all exactly `0`) are deflated:
//!   counted as zero eigenvalues and given a unit diagonal before factorizing;
//! - **checks** (any failure gives an error, never an inertia): all factor values finite
//!   ([`InertiaError::Breakdown`]); backward error of a test solve `K x = b`, `b = K y`
//!   (`y` deterministic pseudo-random, so that the system is consistent even when `K` is
//!   singular), after up to [`MAX_REFINEMENT_STEPS`] refinement steps, at most
//!   [`BACKWARD_ERROR_TOL`]; and, when no pivot is zero, the estimated contraction factor of
//!   iterative refinement at most [`CONTRACTION_TOL`] ([`LbltFactor::contraction`]: a true
//!   value `< 1` proves that the computed factorization has the inertia of `K`)
//!   ([`InertiaError::Unreliable`]);
//! - a pivot (a `1×1` block, or an eigenvalue of a `2×2` block) is counted as **zero** when its
//!   magnitude is at most [`ZERO_PIVOT_RTOL`]` · ‖K̃‖∞`. [`LbltFactor::inertia_with_tol`] takes
//!   another threshold, and [`LbltFactor::min_pivot_ratio`] tells how close the smallest pivot
//!   is to it. The pivots are not the eigenvalues of `K` (they are related through `L`), but an
//!   exactly singular `K` gives pivots of the order of the rounding errors.
//!
//! # Conventions read from faer 0.24.4 (confirmed by the test `faer_conventions_reconstruct`)
//! - the diagonal of `B` is the diagonal of each supernode's diagonal block; `subdiag[j] != 0`
//!   marks a `2×2` block on rows/columns `(j, j + 1)` of the same supernode with off-diagonal
//!   `subdiag[j]` (and `subdiag[j + 1] == 0`). faer leaves `subdiag` untouched on columns with
//!   nothing to eliminate, so it must be zeroed before each factorization;
//! - `P = P_piv · P_fill`: row `i` of `P K̃ Pᵀ` is row `fill_fwd[piv_fwd[i]]` of `K̃`; the rows of
//!   the off-diagonal part of a supernode are in fill-reduced (pre-intranode-pivoting)
//!   coordinates, i.e. at row `piv_inv[r]` of `L`. `IntranodeLbltRef::solve_in_place_with_conj`
//!   applies both permutations itself.

use std::sync::Arc;

use crate::bvp::dense::abs_max;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::lblt::factor::LbltParams;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::supernodal::SupernodalIntranodeLbltRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, IntranodeLbltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::{amd, SupernodalThreshold};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side, Spec};

/// A pivot of magnitude at most `ZERO_PIVOT_RTOL · ‖K̃‖∞` (`K̃` the equilibrated matrix) counts
/// as a zero eigenvalue in [`LbltFactor::inertia`].
///
/// `1e-12` is about `5000 ε`: exactly singular matrices give pivots of order `ε ‖K̃‖∞` times a
/// modest growth factor, while a genuine eigenvalue this small relative to `‖K‖` is numerically
/// indistinguishable from zero anyway.
pub const ZERO_PIVOT_RTOL: f64 = 1e-12;

/// A factorization whose measured backward error (after refinement) exceeds this value is
/// rejected with [`InertiaError::Unreliable`].
pub const BACKWARD_ERROR_TOL: f64 = 1e-8;

/// A factorization without zero pivots whose refinement contraction estimate
/// ([`LbltFactor::contraction`]) exceeds this value is rejected with
/// [`InertiaError::Unreliable`]. The inertia is provably right when the true contraction is `< 1`;
/// the estimate comes from a few power iterations and may be low by a modest factor, hence the
/// margin.
pub const CONTRACTION_TOL: f64 = 0.25;

/// Number of power iterations of the contraction estimate.
const CONTRACTION_ITERATIONS: usize = 4;

/// Maximum number of iterative refinement steps in [`LbltFactor::solve_in_place`] (and in the
/// backward error measurement of [`LbltFactor::factorize`]).
pub const MAX_REFINEMENT_STEPS: usize = 2;

/// Number of symmetric Ruiz equilibration sweeps.
const EQUILIBRATION_SWEEPS: usize = 8;

/// Inertia of a symmetric matrix: the numbers of positive, negative and zero eigenvalues
/// (`positive + negative + zero = n`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Inertia {
    /// Number of positive eigenvalues.
    pub positive: usize,
    /// Number of negative eigenvalues.
    pub negative: usize,
    /// Number of zero eigenvalues (pivots below the zero threshold, see [`ZERO_PIVOT_RTOL`]).
    pub zero: usize,
}

impl std::fmt::Display for Inertia {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "(+{}, -{}, 0×{})",
            self.positive, self.negative, self.zero
        )
    }
}

/// Errors of the pattern analysis, the factorization and the solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InertiaError {
    /// The matrix has no rows.
    #[error("the matrix is empty (n = 0)")]
    Empty,
    /// An entry of the pattern lies outside the `n × n` matrix.
    #[error("pattern entry #{index} = ({row}, {col}) is out of bounds for a {n}×{n} matrix")]
    IndexOutOfBounds {
        /// Position of the entry in `entries`.
        index: usize,
        /// Row index of the entry.
        row: usize,
        /// Column index of the entry.
        col: usize,
        /// Dimension of the matrix.
        n: usize,
    },
    /// A slice has the wrong length.
    #[error("{what}: expected length {expected}, got {got}")]
    LengthMismatch {
        /// Which argument.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// An input value is NaN or infinite.
    #[error("value #{index} (entry ({row}, {col})) is not finite: {value}")]
    NonFiniteValue {
        /// Position of the value in `values`.
        index: usize,
        /// Row index of the entry (of a factorization's values: in the upper triangle,
        /// `row ≤ col`, whichever triangle the pattern gave it in).
        row: usize,
        /// Column index of the entry.
        col: usize,
        /// The value.
        value: f64,
    },
    /// faer's symbolic analysis failed (index overflow or out of memory).
    #[error("symbolic analysis failed: {0}")]
    Symbolic(String),
    /// faer chose a simplicial structure although a supernodal one was requested (it would
    /// factorize without pivoting); should not happen.
    #[error("symbolic analysis did not produce a supernodal structure (pivoting impossible)")]
    NotSupernodal,
    /// A call into faer panicked (a bug, caught so as not to unwind through the caller).
    #[error("internal error in {0}")]
    Internal(String),
    /// Allocation of the workspace failed.
    #[error("out of memory while allocating the factorization workspace")]
    OutOfMemory,
    /// The factors contain NaN or infinite values: a zero pivot was met that pivoting inside the
    /// supernode could not avoid (the matrix is singular or nearly so, or the fill-reducing
    /// ordering is unsuitable for intranode pivoting).
    #[error(
        "the LBLᵀ factorization broke down: non-finite value in the factors (first at permuted \
         column {column}); a zero pivot could not be avoided by pivoting inside supernodes \
         (smallest finite |pivot|/‖K̃‖∞ = {min_pivot_ratio:.3e}). The matrix may be singular; \
         if it has diagonal entries that vanish (e.g. a KKT (2,2) block), omit them from the \
         pattern or analyse it with `SymmetricPattern::with_values`"
    )]
    Breakdown {
        /// First (permuted) column of the factor with a non-finite value.
        column: usize,
        /// Smallest finite `|pivot| / ‖K̃‖∞` met.
        min_pivot_ratio: f64,
    },
    /// The factorization is finite but inaccurate: the backward error of a test solve exceeds
    /// [`BACKWARD_ERROR_TOL`], or (no zero pivot found) the refinement contraction estimate
    /// exceeds [`CONTRACTION_TOL`]; the computed inertia cannot be trusted.
    #[error(
        "unreliable LBLᵀ factorization: backward error {backward_error:.3e} (tolerance \
         {BACKWARD_ERROR_TOL:.0e}) after {refinement_steps} refinement step(s), refinement \
         contraction estimate {contraction:.3e} (tolerance {CONTRACTION_TOL}), smallest \
         |pivot|/‖K̃‖∞ = {min_pivot_ratio:.3e}, largest |L| entry = {max_abs_l:.3e}: tiny pivots \
         that pivoting inside supernodes could not avoid (matrix nearly singular or badly \
         conditioned)"
    )]
    Unreliable {
        /// Measured normwise backward error.
        backward_error: f64,
        /// Estimated spectral radius of `I − (LBLᵀ)⁻¹K` (see [`LbltFactor::contraction`]; NaN
        /// if not measured).
        contraction: f64,
        /// Refinement steps taken.
        refinement_steps: usize,
        /// Smallest `|pivot| / ‖K̃‖∞`.
        min_pivot_ratio: f64,
        /// Largest magnitude of an entry of `L` (element growth).
        max_abs_l: f64,
    },
}

/// The analysed pattern (shared by all factorizations).
#[derive(Debug)]
struct PatternInner {
    n: usize,
    /// Upper triangle (`row ≤ col`) of the user pattern and the whole diagonal, compressed
    /// sparse columns, rows sorted (the diagonal last in its column). The numeric work
    /// (equilibration, products, the values handed to faer) runs on this pattern; the
    /// explicit zeros of the augmented pattern (see [`SymmetricPattern`]) only shape the
    /// symbolic analysis (faer accepts any matrix whose pattern is contained in the analysed
    /// one).
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// For each user entry, its position in `row_idx`.
    entry_pos: Vec<usize>,
    /// Number of stored entries of the upper triangle of the augmented pattern.
    nnz_augmented: usize,
    /// Number of groups of rows (a structurally zero-diagonal row and its neighbour(s)) kept
    /// consecutive, in one supernode.
    n_groups: usize,
    symbolic: SymbolicCholesky<usize>,
}

impl PatternInner {
    /// The `(row, col)` of user entry `index` in the upper triangle (`row ≤ col`), for error
    /// messages (the pattern does not keep the entries as given).
    fn entry_at(&self, index: usize) -> (usize, usize) {
        let Some(&pos) = self.entry_pos.get(index) else {
            return (0, 0);
        };
        let col = self.col_ptr.partition_point(|&start| start <= pos) - 1;
        (self.row_idx[pos], col)
    }
}

/// A symmetric sparsity pattern, analysed once and reusable for any number of numeric
/// factorizations.
///
/// # Analysis
/// faer pivots only inside supernodes, so a row with a zero diagonal (e.g. a constraint row of a
/// KKT matrix) eliminated alone in its supernode would give a zero pivot. Therefore every row
/// whose diagonal is *structurally* zero (absent from `entries`) is matched with a neighbour
/// (preferably one with a structural diagonal: a maximum bipartite matching, then a greedy
/// matching among the remaining zero-diagonal rows; a row still unmatched joins the group of a
/// neighbour). The rows of each group are made indistinguishable by adding explicit zeros to the
/// pattern (same neighbours), and the AMD ordering is computed on the graph compressed by the
/// groups, then expanded with the rows of each group consecutive. Indistinguishable consecutive
/// rows always fall in the same (fundamental) supernode, so Bunch–Kaufman can use the `2×2`
/// pivot `[[h, a], [a, 0]]`. The added explicit zeros cost some fill (for a KKT matrix, the
/// constraint row takes the pattern of its partner variable and vice versa).
///
/// Hence: **omit the diagonal entries that are zero by structure** (e.g. the `(2,2)` block of a
/// KKT matrix); diagonal entries present in the pattern are assumed to be generally nonzero.
///
/// Cheap to clone (reference counted).
#[derive(Debug, Clone)]
pub struct SymmetricPattern {
    inner: Arc<PatternInner>,
}

impl SymmetricPattern {
    /// Analyses the pattern of a symmetric `n × n` matrix.
    ///
    /// `entries` lists `(row, col)` positions; give each off-diagonal pair once, in either
    /// triangle (`(i, j)` and `(j, i)` denote the same stored entry: if both are given, their
    /// values are summed). Repeated entries are allowed (their values are summed). A diagonal
    /// entry absent from `entries` is structurally zero (see the type-level documentation).
    pub fn new(n: usize, entries: &[(usize, usize)]) -> Result<Self, InertiaError> {
        Self::analyse(n, entries, None)
    }

    /// Like [`SymmetricPattern::new`], but a diagonal entry whose value in `values` (one per
    /// entry, duplicates summed) is exactly zero is treated as structurally zero for the
    /// pivoting analysis. It stays in the pattern, so later value sets may make it nonzero.
    ///
    /// Use it when the pattern lists diagonal entries that are zero in practice (e.g. the
    /// `(2,2)` block of a KKT matrix written as explicit zeros): without pairing, such rows
    /// usually give zero pivots that intranode pivoting cannot avoid
    /// ([`InertiaError::Breakdown`]).
    pub fn with_values(
        n: usize,
        entries: &[(usize, usize)],
        values: &[f64],
    ) -> Result<Self, InertiaError> {
        if values.len() != entries.len() {
            return Err(InertiaError::LengthMismatch {
                what: "values (one per pattern entry)",
                expected: entries.len(),
                got: values.len(),
            });
        }
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            let (row, col) = entries[index];
            return Err(InertiaError::NonFiniteValue {
                index,
                row,
                col,
                value: values[index],
            });
        }
        Self::analyse(n, entries, Some(values))
    }

    /// Like [`SymmetricPattern::new`], with the elimination order given by the caller instead
    /// of AMD: `groups` partitions `0..n` into pivot groups listed in elimination order; the
    /// members of a group are given the same structure (explicit zeros), so they are
    /// eliminated together in one supernode, where Bunch–Kaufman can take `2 × 2` pivots
    /// among them (e.g. a KKT pair `[[h, a], [a, 0]]` of a state and the constraint that
    /// determines it).
    ///
    /// The order of the members inside a group matters for the fill only: a group's factor
    /// reaches into a later group up to the last member that it touches (the structure below
    /// a group meets each later group in a prefix; see `group_closed_pattern`), so list first
    /// the members that earlier groups touch.
    pub fn with_groups(
        n: usize,
        entries: &[(usize, usize)],
        groups: &[Vec<usize>],
    ) -> Result<Self, InertiaError> {
        let mut seen = vec![false; n];
        for &i in groups.iter().flatten() {
            if i >= n || seen[i] {
                return Err(InertiaError::Symbolic(format!(
                    "the pivot groups must partition 0..{n}: index {i} is out of range or repeated"
                )));
            }
            seen[i] = true;
        }
        if let Some(i) = seen.iter().position(|s| !s) {
            return Err(InertiaError::Symbolic(format!(
                "the pivot groups must partition 0..{n}: index {i} is missing"
            )));
        }
        Self::analyse_with(n, entries, None, Some(groups))
    }

    fn analyse(
        n: usize,
        entries: &[(usize, usize)],
        values: Option<&[f64]>,
    ) -> Result<Self, InertiaError> {
        Self::analyse_with(n, entries, values, None)
    }

    fn analyse_with(
        n: usize,
        entries: &[(usize, usize)],
        values: Option<&[f64]>,
        given_groups: Option<&[Vec<usize>]>,
    ) -> Result<Self, InertiaError> {
        if n == 0 {
            return Err(InertiaError::Empty);
        }
        let mut has_diag = vec![false; n];
        let mut diag_sum = vec![0.0f64; n];
        for (index, &(row, col)) in entries.iter().enumerate() {
            if row >= n || col >= n {
                return Err(InertiaError::IndexOutOfBounds { index, row, col, n });
            }
            if row == col {
                has_diag[row] = true;
                diag_sum[row] += values.map_or(1.0, |v| v[index]);
            }
        }
        if values.is_some() {
            for (h, d) in has_diag.iter_mut().zip(&diag_sum) {
                *h = *h && *d != 0.0;
            }
        }
        drop(diag_sum);
        // The numeric pattern is built on a second thread while this one analyses the
        // augmented pattern (they meet in the containment check).
        std::thread::scope(|scope| {
            let numeric = scope.spawn(|| numeric_pattern(n, entries));
            Self::analyse_structure(n, entries, &has_diag, given_groups, numeric)
        })
    }

    /// The structural part of [`Self::analyse_with`]: pivot groups, ordering, augmented
    /// pattern and symbolic factorization, then the containment of `numeric`'s pattern.
    fn analyse_structure(
        n: usize,
        entries: &[(usize, usize)],
        has_diag: &[bool],
        given_groups: Option<&[Vec<usize>]>,
        numeric: std::thread::ScopedJoinHandle<'_, NumericPattern>,
    ) -> Result<Self, InertiaError> {
        // Off-diagonal adjacency (both directions), sorted and deduplicated, for the matching
        // and the compressed graph (given groups need neither: `group_closed_pattern` reads
        // the entries).
        let adj = if given_groups.is_some() {
            Csr {
                row_ptr: vec![0; n + 1],
                col_idx: Vec::new(),
            }
        } else {
            let mut edges: Vec<(usize, usize)> = Vec::with_capacity(2 * entries.len());
            for &(row, col) in entries {
                if row != col {
                    edges.push((row, col));
                    edges.push((col, row));
                }
            }
            Csr::from_pairs(n, &edges)
        };

        // Pair structurally zero-diagonal rows with neighbours; a zero-diagonal row left
        // unmatched joins the group of one of its neighbours (all of them are grouped, as the
        // matching is maximal).
        let mut group = vec![NONE; n];
        let mut members: Vec<Vec<usize>> = Vec::with_capacity(n);
        if let Some(groups) = given_groups {
            for (g, m) in groups.iter().enumerate() {
                for &i in m {
                    group[i] = g;
                }
            }
            members = groups.to_vec();
        }
        let partner = if given_groups.is_some() {
            vec![NONE; n]
        } else {
            match_zero_diagonal(n, &adj, has_diag)
        };
        let mut deferred = Vec::new();
        for i in 0..n {
            if group[i] != NONE {
                continue;
            }
            let p = partner[i];
            if p != NONE {
                group[i] = members.len();
                group[p] = members.len();
                members.push(vec![i, p]);
            } else if has_diag[i] || adj.row(i).is_empty() {
                group[i] = members.len();
                members.push(vec![i]);
            } else {
                deferred.push(i);
            }
        }
        for z in deferred {
            let target = adj
                .row(z)
                .iter()
                .map(|&w| group[w])
                .filter(|&g| g != NONE)
                .min_by_key(|&g| members[g].len());
            let g = target.unwrap_or_else(|| {
                members.push(Vec::new());
                members.len() - 1
            });
            group[z] = g;
            members[g].push(z);
        }
        let n_grouped = members.iter().filter(|m| m.len() > 1).count();
        let n_groups = members.len();

        // Compressed graph (upper triangle, sorted) and AMD on it (given groups keep their
        // order and need neither).
        let comp = if given_groups.is_none() {
            let mut cedges: Vec<(usize, usize)> =
                Vec::with_capacity(adj.col_idx.len() / 2 + n_groups);
            for i in 0..n {
                for &j in adj.row(i) {
                    let (a, b) = (group[i], group[j]);
                    if a < b {
                        cedges.push((b, a));
                    }
                }
            }
            cedges.extend((0..n_groups).map(|g| (g, g)));
            Csr::from_pairs(n_groups, &cedges)
        } else {
            Csr {
                row_ptr: vec![0; n_groups + 1],
                col_idx: Vec::new(),
            }
        };
        let mut cfwd: Vec<usize> = (0..n_groups).collect();
        let mut cinv = vec![0usize; n_groups];
        if given_groups.is_none() {
            let req = amd::order_scratch::<usize>(n_groups, comp.col_idx.len());
            let mut mem = MemBuffer::try_new(req).map_err(|_| InertiaError::OutOfMemory)?;
            guarded("AMD ordering", || {
                let csc = SymbolicSparseColMatRef::new_checked(
                    n_groups,
                    n_groups,
                    &comp.row_ptr,
                    None,
                    &comp.col_idx,
                );
                amd::order(
                    &mut cfwd,
                    &mut cinv,
                    csc,
                    amd::Control::default(),
                    MemStack::new(&mut mem),
                )
            })?
            .map_err(|e| InertiaError::Symbolic(format!("AMD ordering: {e:?}")))?;
        }
        let perm_fwd: Vec<usize> = cfwd
            .iter()
            .flat_map(|&g| members[g].iter().copied())
            .collect();
        let mut perm_inv = vec![0usize; n];
        for (k, &i) in perm_fwd.iter().enumerate() {
            perm_inv[i] = k;
        }

        // Augmented upper pattern, which contains the user pattern and the whole diagonal.
        // Given groups (eliminated in their order, members in theirs; see
        // `group_closed_pattern`) give distinct pairs, each column's rows in no particular
        // order, which faer's symbolic analysis accepts (it permutes the pattern to an
        // unsorted one first). The expansion of the compressed graph repeats pairs: sorted
        // and deduplicated.
        let aug = if given_groups.is_some() {
            group_closed_pattern(entries, &group, &members)
        } else {
            let mut upper: Vec<(usize, usize)> = Vec::new();
            // Expansion of the compressed graph: all members of adjacent groups are adjacent.
            for ga in 0..n_groups {
                for &gb in comp.row(ga) {
                    // `comp` stores (col = ga, row = gb ≤ ga).
                    for &i in &members[gb] {
                        for &j in &members[ga] {
                            upper.push((i.max(j), i.min(j)));
                        }
                    }
                }
            }
            Csr::from_pairs(n, &upper)
        };
        let (aug_col_ptr, aug_row_idx) = (aug.row_ptr, aug.col_idx);
        let NumericParts {
            col_ptr,
            row_idx,
            entry_pos,
        } = numeric.join().map_err(|_| {
            InertiaError::Symbolic("internal error: the numeric pattern's thread panicked".into())
        })??;
        // Every column of the numeric pattern is contained in the augmented one (each
        // augmented column marked, then its numeric rows looked up).
        let mut mark = vec![NONE; n];
        for c in 0..n {
            for &a in &aug_row_idx[aug_col_ptr[c]..aug_col_ptr[c + 1]] {
                mark[a] = c;
            }
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                if mark[r] != c {
                    return Err(InertiaError::Symbolic(format!(
                        "internal error: entry ({r}, {c}) missing from the augmented pattern"
                    )));
                }
            }
        }
        drop(mark);

        let nnz_augmented = aug_row_idx.len();
        let symbolic = guarded("symbolic analysis", || {
            let pattern = SymbolicSparseColMatRef::new_unsorted_checked(
                n,
                n,
                &aug_col_ptr,
                None,
                &aug_row_idx,
            );
            let perm = PermRef::new_checked(&perm_fwd, &perm_inv, n);
            factorize_symbolic_cholesky(
                pattern,
                Side::Upper,
                SymmetricOrdering::Custom(perm),
                CholeskySymbolicParams {
                    // Force the supernodal structure: faer's simplicial "intranode LBLᵀ" is an
                    // unpivoted LDLᵀ.
                    supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                    ..Default::default()
                },
            )
        })?
        .map_err(|e| InertiaError::Symbolic(format!("{e:?}")))?;
        let SymbolicCholeskyRaw::Supernodal(supernodal) = symbolic.raw() else {
            return Err(InertiaError::NotSupernodal);
        };
        if given_groups.is_some() {
            // Each group must lie in one supernode (`group_closed_pattern`); the groups are
            // consecutive in the ordering.
            let begin = supernodal.supernode_begin();
            let mut s = 0;
            let mut start = 0;
            for (g, m) in members.iter().enumerate() {
                if m.is_empty() {
                    continue;
                }
                while begin.get(s + 1).is_some_and(|&b| b <= start) {
                    s += 1;
                }
                let end = start + m.len();
                if begin.get(s + 1).is_some_and(|&b| b < end) {
                    return Err(InertiaError::Symbolic(format!(
                        "internal error: pivot group {g} is split across supernodes"
                    )));
                }
                start = end;
            }
        }
        Ok(Self {
            inner: Arc::new(PatternInner {
                n,
                col_ptr,
                row_idx,
                entry_pos,
                nnz_augmented,
                n_groups: n_grouped,
                symbolic,
            }),
        })
    }

    /// Dimension `n` of the matrix.
    pub fn n(&self) -> usize {
        self.inner.n
    }

    /// Number of stored entries of the upper triangle of the augmented pattern (diagonal and
    /// explicit zeros included).
    pub fn nnz_upper(&self) -> usize {
        self.inner.nnz_augmented
    }

    /// Number of stored values of the factor `L` (supernodal storage, explicit zeros included).
    pub fn nnz_factor(&self) -> usize {
        self.inner.symbolic.len_val()
    }

    /// Number of groups (a structurally zero-diagonal row and its neighbour(s), usually a pair)
    /// kept in one supernode.
    pub fn n_pivot_groups(&self) -> usize {
        self.inner.n_groups
    }
}

const NONE: usize = usize::MAX;

/// The numeric pattern of [`SymmetricPattern`] (its upper triangle as compressed columns) and
/// the position in it of every entry, or why an entry is missing.
type NumericPattern = Result<NumericParts, InertiaError>;

/// The parts of a [`NumericPattern`].
struct NumericParts {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    entry_pos: Vec<usize>,
}

/// The user pattern and the diagonal (upper triangle, `(col, row)` pairs, sorted): the
/// numeric pattern, and where each of `entries` is in it.
fn numeric_pattern(n: usize, entries: &[(usize, usize)]) -> NumericPattern {
    // A counting sort of the entries and the diagonal by column (the larger index), each
    // entry's slot remembered; then each column's rows sorted and deduplicated, and the slots
    // mapped to the positions they end at: no list of pairs and no searches (fresh memory costs
    // page faults, and this thread's heap is fresh).
    let mut col_ptr = vec![0usize; n + 1];
    for &(r, c) in entries {
        col_ptr[r.max(c) + 1] += 1;
    }
    for i in 0..n {
        col_ptr[i + 1] += col_ptr[i] + 1;
    }
    let total = col_ptr[n];
    let mut rows = vec![0usize; total];
    let mut next = col_ptr.clone();
    let mut entry_pos = Vec::with_capacity(entries.len());
    for &(r, c) in entries {
        let col = r.max(c);
        rows[next[col]] = r.min(c);
        entry_pos.push(next[col]);
        next[col] += 1;
    }
    for (i, slot) in next.iter().take(n).enumerate() {
        rows[*slot] = i;
    }
    drop(next);
    // `slot_to_pos[s]`: where slot `s` ends after sorting and deduplication.
    let mut slot_to_pos = vec![0usize; total];
    let mut column: Vec<(usize, usize)> = Vec::new();
    let mut len = 0;
    let mut begin = 0;
    for c in 0..n {
        let end = col_ptr[c + 1];
        column.clear();
        column.extend((begin..end).map(|s| (rows[s], s)));
        column.sort_unstable();
        let mut prev = NONE;
        for &(r, s) in &column {
            if r != prev {
                rows[len] = r;
                len += 1;
                prev = r;
            }
            slot_to_pos[s] = len - 1;
        }
        begin = end;
        col_ptr[c + 1] = len;
    }
    rows.truncate(len);
    for p in &mut entry_pos {
        *p = slot_to_pos[*p];
    }
    Ok(NumericParts {
        col_ptr,
        row_idx: rows,
        entry_pos,
    })
}

/// Compressed rows, columns sorted and distinct in each row (also used as compressed columns
/// of the transpose); from [`Csr::buckets`], in the order given and with repeats.
struct Csr {
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
}

impl Csr {
    /// From `(row, col)` pairs in any order, repeats allowed: a counting sort by row, then each
    /// (short) row sorted and deduplicated.
    fn from_pairs(n: usize, pairs: &[(usize, usize)]) -> Self {
        let Self {
            row_ptr: start,
            col_idx: mut cols,
        } = Self::buckets(n, pairs);
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0);
        let mut len = 0;
        for i in 0..n {
            let row = &mut cols[start[i]..start[i + 1]];
            row.sort_unstable();
            let mut prev = NONE;
            for k in start[i]..start[i + 1] {
                let c = cols[k];
                if c != prev {
                    cols[len] = c;
                    len += 1;
                    prev = c;
                }
            }
            row_ptr.push(len);
        }
        cols.truncate(len);
        Self {
            row_ptr,
            col_idx: cols,
        }
    }

    /// From `(row, col)` pairs in any order: the counting sort by row alone (each row's
    /// columns in the order given, repeats kept).
    fn buckets(n: usize, pairs: &[(usize, usize)]) -> Self {
        let mut start = vec![0usize; n + 1];
        for &(r, _) in pairs {
            start[r + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut next = start.clone();
        let mut cols = vec![0usize; pairs.len()];
        for &(r, c) in pairs {
            cols[next[r]] = c;
            next[r] += 1;
        }
        Self {
            row_ptr: start,
            col_idx: cols,
        }
    }

    fn row(&self, i: usize) -> &[usize] {
        &self.col_idx[self.row_ptr[i]..self.row_ptr[i + 1]]
    }
}

/// The augmented pattern of given pivot groups, eliminated in their order (group `g` before
/// `g + 1`), as the distinct rows `row ≤ col` of each column `col` (in no particular order:
/// each pair comes from one pair of groups, and the groups partition the rows), such that
/// the members of every group fall in one fundamental supernode of the factorization:
///
/// - each group is a dense block (so member `j + 1` is the parent of member `j` in the
///   elimination tree);
/// - every member of group `g` is adjacent to the same set `U_g` of rows of later groups: the
///   rows adjacent to some member of `g` (the union), closed so that `U_g` meets each later
///   group in a *prefix* of its members (if it contains a member, it contains those listed
///   before it).
///
/// Then, by induction over the groups, the structure of the factor below any column meets each
/// later group in a prefix (unions of prefixes are prefixes), so a column outside a group
/// whose elimination-tree parent lies in that group has the group's first member as parent:
/// the other members have exactly one child (their predecessor), and all members of a group
/// have the same structure below it. That is faer's criterion of a fundamental supernode.
/// Compared with making all members of adjacent groups adjacent, the factor loses the rows of
/// a later group that no member of `g` touches (for a collocation KKT matrix whose interval
/// groups list their constraints first, the next interval's unknowns).
fn group_closed_pattern(
    entries: &[(usize, usize)],
    group: &[usize],
    members: &[Vec<usize>],
) -> Csr {
    let n = group.len();
    let mut pos = vec![0usize; n];
    for m in members {
        for (k, &i) in m.iter().enumerate() {
            pos[i] = k;
        }
    }
    // The entries between two groups, as (earlier group, row of the later one), bucketed by
    // the earlier group: what each group touches later.
    let mut cross: Vec<(usize, usize)> = Vec::new();
    for &(r, c) in entries {
        let (gr, gc) = (group[r], group[c]);
        if gr < gc {
            cross.push((gr, c));
        } else if gc < gr {
            cross.push((gc, r));
        }
    }
    let later = Csr::buckets(members.len(), &cross);
    drop(cross);
    // For every group: the later groups its members touch, and how far into each.
    let mut reach = vec![NONE; members.len()];
    let mut touched: Vec<usize> = Vec::new();
    let mut reaches: Vec<(usize, usize)> = Vec::new();
    let mut first = Vec::with_capacity(members.len() + 1);
    for g in 0..members.len() {
        first.push(reaches.len());
        for &w in later.row(g) {
            let gw = group[w];
            if reach[gw] == NONE {
                touched.push(gw);
                reach[gw] = pos[w];
            } else {
                reach[gw] = reach[gw].max(pos[w]);
            }
        }
        for &gw in &touched {
            reaches.push((gw, reach[gw]));
            reach[gw] = NONE;
        }
        touched.clear();
    }
    first.push(reaches.len());
    // Every pair `(col, row)`, generated twice: counted by column, then placed (no list of
    // pairs: a million of them on a fine mesh, and fresh memory costs page faults).
    let pairs = |f: &mut dyn FnMut(usize, usize)| {
        for (g, m) in members.iter().enumerate() {
            for &i in m {
                for &j in m {
                    if j <= i {
                        f(i, j);
                    }
                }
            }
            for &(gw, last) in &reaches[first[g]..first[g + 1]] {
                for &r in &members[gw][..=last] {
                    for &j in m {
                        f(r.max(j), r.min(j));
                    }
                }
            }
        }
    };
    let mut row_ptr = vec![0usize; n + 1];
    pairs(&mut |c, _| row_ptr[c + 1] += 1);
    for i in 0..n {
        row_ptr[i + 1] += row_ptr[i];
    }
    let mut next = row_ptr[..n].to_vec();
    let mut col_idx = vec![0usize; row_ptr[n]];
    pairs(&mut |c, r| {
        col_idx[next[c]] = r;
        next[c] += 1;
    });
    Csr { row_ptr, col_idx }
}

/// Partner of each row (`NONE` if unpaired): rows without structural diagonal are matched
/// with neighbours, first with rows having a structural diagonal (maximum bipartite matching:
/// greedy start, then augmenting paths), then greedily among themselves.
fn match_zero_diagonal(n: usize, adj: &Csr, has_diag: &[bool]) -> Vec<usize> {
    let mut partner = vec![NONE; n];
    let zero: Vec<usize> = (0..n).filter(|&i| !has_diag[i]).collect();
    if zero.is_empty() {
        return partner;
    }
    let degree = |i: usize| adj.row_ptr[i + 1] - adj.row_ptr[i];
    // Greedy: the unmatched diagonal neighbour of smallest degree (least added fill).
    for &z in &zero {
        let best = adj
            .row(z)
            .iter()
            .copied()
            .filter(|&v| has_diag[v] && partner[v] == NONE)
            .min_by_key(|&v| degree(v));
        if let Some(v) = best {
            partner[z] = v;
            partner[v] = z;
        }
    }
    // Augmenting paths (iterative depth-first search) for the rows left unmatched.
    let mut visited = vec![NONE; n];
    // Frames: (zero-diagonal row, next neighbour position, neighbour chosen in this frame).
    let mut stack: Vec<(usize, usize, usize)> = Vec::new();
    for &root in &zero {
        if partner[root] != NONE {
            continue;
        }
        stack.clear();
        stack.push((root, adj.row_ptr[root], NONE));
        let mut free = NONE;
        while let Some(frame) = stack.last_mut() {
            let z = frame.0;
            if frame.1 == adj.row_ptr[z + 1] {
                stack.pop();
                continue;
            }
            let v = adj.col_idx[frame.1];
            frame.1 += 1;
            if !has_diag[v] || visited[v] == root {
                continue;
            }
            visited[v] = root;
            frame.2 = v;
            if partner[v] == NONE {
                free = v;
                break;
            }
            let next = partner[v];
            stack.push((next, adj.row_ptr[next], NONE));
        }
        if free != NONE {
            for &(z, _, v) in stack.iter().rev() {
                partner[z] = v;
                partner[v] = z;
            }
        }
    }
    // Remaining zero-diagonal rows: pair among themselves.
    for &z in &zero {
        if partner[z] != NONE {
            continue;
        }
        let best = adj
            .row(z)
            .iter()
            .copied()
            .filter(|&w| !has_diag[w] && partner[w] == NONE)
            .min_by_key(|&w| degree(w));
        if let Some(w) = best {
            partner[z] = w;
            partner[w] = z;
        }
    }
    partner
}

/// A numeric `P K̃ Pᵀ = L B Lᵀ` factorization of the equilibrated matrix `K̃ = D K D`, with its
/// inertia and reliability measures.
///
/// `P` is the composition of the fill-reducing (AMD) permutation and of the Bunch–Kaufman
/// pivoting permutations inside the supernodes; `L` is unit lower triangular; `B` is block
/// diagonal with `1×1` and `2×2` blocks.
#[derive(Debug, Clone)]
pub struct LbltFactor {
    pattern: SymmetricPattern,
    /// The upper triangle of `K` without its exact zeros off the diagonal (the diagonal is
    /// always stored, last in its column): compressed sparse columns, rows sorted, and the
    /// original (unscaled) values.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// `‖K‖∞`.
    norm_k: f64,
    /// Diagonal scaling `D` (powers of two).
    scaling: Vec<f64>,
    /// Rows/columns of `K` that are exactly zero (deflated).
    zero_rows: Vec<usize>,
    l_values: Vec<f64>,
    subdiag: Vec<f64>,
    perm_fwd: Vec<usize>,
    perm_inv: Vec<usize>,
    /// Eigenvalues of the blocks of `B` (one per row of the deflated matrix, deflated rows
    /// excluded), relative to `‖K̃‖∞`.
    pivot_ratios: Vec<f64>,
    norm_inf: f64,
    backward_error: f64,
    contraction: f64,
    refinement_steps: usize,
    max_abs_l: f64,
    n_two_by_two: usize,
}

impl LbltFactor {
    /// Factorizes the symmetric matrix with the given pattern and values.
    ///
    /// `values[k]` is the value at `entries[k]` of [`SymmetricPattern::new`] (duplicates and
    /// mirrored pairs summed). Returns an error when a value is not finite, when the
    /// factorization broke down (non-finite factors, [`InertiaError::Breakdown`]), or when it is
    /// inaccurate ([`InertiaError::Unreliable`]: backward error of the test solve above
    /// [`BACKWARD_ERROR_TOL`], or, if no pivot is zero, refinement contraction estimate above
    /// [`CONTRACTION_TOL`]). A returned factorization passed these checks.
    ///
    /// Cost: the numeric factorization, plus about `3 + MAX_REFINEMENT_STEPS +
    /// CONTRACTION_ITERATIONS` solves and products with `K` for the checks.
    pub fn factorize(pattern: &SymmetricPattern, values: &[f64]) -> Result<Self, InertiaError> {
        Self::factorize_checked(pattern, values, Checks::Proof)
    }

    /// [`LbltFactor::factorize`] without the proof of its inertia (no contraction estimate,
    /// [`LbltFactor::contraction`] is NaN): for a method that only needs steps, guarded by its
    /// own line search, such as [`mod@super::sqp`]. The test solve is made, and a non-finite
    /// backward error is still an error.
    pub fn factorize_unproven(
        pattern: &SymmetricPattern,
        values: &[f64],
    ) -> Result<Self, InertiaError> {
        Self::factorize_checked(pattern, values, Checks::BackwardError)
    }

    /// The numeric factorization alone, for solves whose accuracy the caller checks itself
    /// (by the backward error that [`LbltFactor::solve_in_place`] returns): no test solve and no
    /// contraction estimate ([`LbltFactor::backward_error`] and [`LbltFactor::contraction`] are
    /// NaN), and its inertia is not proven. Non-finite factors are still an error
    /// ([`InertiaError::Breakdown`]).
    pub fn factorize_for_solve(
        pattern: &SymmetricPattern,
        values: &[f64],
    ) -> Result<Self, InertiaError> {
        Self::factorize_checked(pattern, values, Checks::Nothing)
    }

    /// [`LbltFactor::factorize`], running `work` with the factorization on this thread while
    /// the contraction estimate that proves its inertia runs on another. `work` sees factors
    /// that are not yet checked; its result is returned only with a factorization that passed
    /// the checks (otherwise the error, as [`LbltFactor::factorize`] gives it).
    ///
    /// For work that needs the factors in any case, such as solves at a shift whose count
    /// is about to be confirmed: it then costs no time of its own up to the estimate's.
    pub fn factorize_while<T>(
        pattern: &SymmetricPattern,
        values: &[f64],
        work: impl FnOnce(&Self) -> T,
    ) -> Result<(Self, T), InertiaError> {
        Self::factorize_checked_with(pattern, values, Checks::Proof, work)
    }

    fn factorize_checked(
        pattern: &SymmetricPattern,
        values: &[f64],
        checks: Checks,
    ) -> Result<Self, InertiaError> {
        Self::factorize_checked_with(pattern, values, checks, |_| ()).map(|(factor, ())| factor)
    }

    /// The numeric factorization, `checks`, and `work` with the factors (after the test
    /// solve, concurrently with the contraction estimate of a proof).
    fn factorize_checked_with<T>(
        pattern: &SymmetricPattern,
        values: &[f64],
        checks: Checks,
        work: impl FnOnce(&Self) -> T,
    ) -> Result<(Self, T), InertiaError> {
        let p = &*pattern.inner;
        let n = p.n;
        if values.len() != p.entry_pos.len() {
            return Err(InertiaError::LengthMismatch {
                what: "values (one per pattern entry)",
                expected: p.entry_pos.len(),
                got: values.len(),
            });
        }
        let mut vals = vec![0.0; p.row_idx.len()];
        for (index, (&v, &pos)) in values.iter().zip(&p.entry_pos).enumerate() {
            if !v.is_finite() {
                let (row, col) = p.entry_at(index);
                return Err(InertiaError::NonFiniteValue {
                    index,
                    row,
                    col,
                    value: v,
                });
            }
            vals[pos] += v;
        }
        // Summing duplicates may overflow.
        if let Some(pos) = vals.iter().position(|v| !v.is_finite()) {
            let index = p.entry_pos.iter().position(|&q| q == pos).unwrap_or(0);
            let (row, col) = p.entry_at(index);
            return Err(InertiaError::NonFiniteValue {
                index,
                row,
                col,
                value: vals[pos],
            });
        }

        // The exact zeros off the diagonal are dropped (the same matrix, fewer stored
        // entries for the products, the equilibration and faer's input).
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::with_capacity(vals.len());
        let mut kept = Vec::with_capacity(vals.len());
        for j in 0..n {
            let range = p.col_ptr[j]..p.col_ptr[j + 1];
            for (&i, &v) in p.row_idx[range.clone()].iter().zip(&vals[range]) {
                if v != 0.0 || i == j {
                    row_idx.push(i);
                    kept.push(v);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let vals = kept;

        // Equilibration K̃ = D K D, and exact zero rows.
        let (scaling, mut scaled, row_max) = equilibrate(n, &col_ptr, &row_idx, &vals);
        let zero_rows: Vec<usize> = (0..n).filter(|&i| row_max[i] == 0.0).collect();
        for &i in &zero_rows {
            // The diagonal is always stored, and is the last entry of its upper column.
            scaled[col_ptr[i + 1] - 1] = 1.0;
        }
        let norm_inf = sym_norm_inf(n, &col_ptr, &row_idx, &scaled).max(f64::MIN_POSITIVE);
        let norm_k = sym_norm_inf(n, &col_ptr, &row_idx, &vals);

        // Numeric factorization.
        let symbolic = &p.symbolic;
        let SymbolicCholeskyRaw::Supernodal(supernodal) = symbolic.raw() else {
            return Err(InertiaError::NotSupernodal);
        };
        let mut l_values = vec![0.0; symbolic.len_val()];
        // Must start zeroed: faer leaves `subdiag` untouched for columns with nothing to
        // eliminate.
        let mut subdiag = vec![0.0; n];
        let mut perm_fwd = vec![0usize; n];
        let mut perm_inv = vec![0usize; n];
        let par = Par::Seq;
        // Rook pivoting (locally optimal 1×1 / 2×2 pivots inside each supernode): it bounds
        // the entries of L, which partial pivoting does not, at a small extra cost.
        let params: Spec<LbltParams, f64> = LbltParams {
            pivoting: faer::linalg::cholesky::lblt::factor::PivotingStrategy::Rook,
            ..<LbltParams as faer::Auto<f64>>::auto()
        }
        .into();
        {
            let req = symbolic.factorize_numeric_intranode_lblt_scratch::<f64>(par, params);
            let mut mem = MemBuffer::try_new(req).map_err(|_| InertiaError::OutOfMemory)?;
            guarded("numeric LBLᵀ factorization", || {
                let a_sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
                let a = SparseColMatRef::new(a_sym, &scaled);
                // The returned view borrows the buffers; they are read back below.
                let _ = symbolic.factorize_numeric_intranode_lblt(
                    &mut l_values,
                    &mut subdiag,
                    &mut perm_fwd,
                    &mut perm_inv,
                    a,
                    Side::Upper,
                    par,
                    MemStack::new(&mut mem),
                    params,
                );
            })?;
        }

        // Read B: per supernode, the diagonal of its diagonal block holds the diagonal of B;
        // `subdiag[j] != 0` marks a 2×2 block on rows/columns (j, j + 1) with off-diagonal
        // `subdiag[j]` (then `subdiag[j + 1] == 0`).
        let deflated: Vec<bool> = {
            let mut d = vec![false; n];
            for &i in &zero_rows {
                d[i] = true;
            }
            d
        };
        let sym_fwd = symbolic.perm().map(|q| q.arrays().0);
        let mut pivot_ratios = Vec::with_capacity(n);
        let mut n_two_by_two = 0usize;
        let mut max_abs_l = 0.0f64;
        let mut min_finite_ratio = f64::INFINITY;
        let mut first_bad: Option<usize> = None;
        {
            let perm = PermRef::new_checked(&perm_fwd, &perm_inv, n);
            let lref = SupernodalIntranodeLbltRef::new(supernodal, &l_values, &subdiag, perm);
            for s in 0..supernodal.n_supernodes() {
                let node = lref.supernode(s);
                let start = node.start();
                let v = node.val();
                let ncols = v.ncols();
                for j in 0..ncols {
                    let below = v.col(j).subrows(j + 1, v.nrows() - j - 1);
                    // The largest magnitude, and NaN exactly when an entry is not finite.
                    let (m, bad) = match below.try_as_col_major() {
                        Some(c) => abs_max(c.as_slice()),
                        None => {
                            let c: Vec<f64> = below.iter().copied().collect();
                            abs_max(&c)
                        }
                    };
                    if bad.is_nan() {
                        first_bad.get_or_insert(start + j);
                    }
                    max_abs_l = max_abs_l.max(m);
                }
                let mut k = 0;
                while k < ncols {
                    let j = start + k;
                    // Original index of the (permuted) column j.
                    let orig = |jj: usize| {
                        let q = perm_fwd[jj];
                        sym_fwd.map_or(q, |f| f[q])
                    };
                    if subdiag[j] != 0.0 && k + 1 < ncols {
                        let (a, b, c) = (v[(k, k)], subdiag[j], v[(k + 1, k + 1)]);
                        n_two_by_two += 1;
                        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                            first_bad.get_or_insert(j);
                        }
                        let (l1, l2) = eig2(a, b, c);
                        for (jj, l) in [(j, l1), (j + 1, l2)] {
                            if !deflated[orig(jj)] {
                                pivot_ratios.push(l / norm_inf);
                            }
                        }
                        k += 2;
                    } else {
                        let d = v[(k, k)];
                        if !d.is_finite() || subdiag[j] != 0.0 {
                            first_bad.get_or_insert(j);
                        }
                        if !deflated[orig(j)] {
                            pivot_ratios.push(d / norm_inf);
                        }
                        k += 1;
                    }
                }
            }
        }
        for r in &pivot_ratios {
            if r.is_finite() {
                min_finite_ratio = min_finite_ratio.min(r.abs());
            }
        }
        if let Some(column) = first_bad {
            return Err(InertiaError::Breakdown {
                column,
                min_pivot_ratio: min_finite_ratio,
            });
        }

        let mut factor = Self {
            pattern: pattern.clone(),
            col_ptr,
            row_idx,
            values: vals,
            norm_k,
            scaling,
            zero_rows,
            l_values,
            subdiag,
            perm_fwd,
            perm_inv,
            pivot_ratios,
            norm_inf,
            backward_error: f64::NAN,
            contraction: f64::NAN,
            refinement_steps: 0,
            max_abs_l,
            n_two_by_two,
        };

        if checks == Checks::Nothing {
            let out = work(&factor);
            return Ok((factor, out));
        }
        // The test solve (then `work`) and, for a proof, the contraction estimate: independent
        // computations with the same factors, on two threads.
        let (test, contraction, out) = if checks == Checks::Proof {
            let factor = &factor;
            std::thread::scope(|scope| {
                let contraction = scope.spawn(|| factor.estimate_contraction());
                let test = factor.test_solve();
                let out = work(factor);
                let contraction = contraction.join().unwrap_or_else(|_| {
                    Err(InertiaError::Internal(
                        "the contraction estimate's thread panicked".into(),
                    ))
                });
                (test, Some(contraction), out)
            })
        } else {
            let test = factor.test_solve();
            (test, None, work(&factor))
        };
        let (berr, steps) = test?;
        factor.backward_error = berr;
        factor.refinement_steps = steps;
        let unreliable = |f: &Self| InertiaError::Unreliable {
            backward_error: f.backward_error,
            contraction: f.contraction,
            refinement_steps: f.refinement_steps,
            min_pivot_ratio: f.min_pivot_ratio(),
            max_abs_l: f.max_abs_l,
        };
        if checks == Checks::BackwardError {
            return if berr.is_nan() {
                Err(unreliable(&factor))
            } else {
                Ok((factor, out))
            };
        }
        if let Some(contraction) = contraction {
            factor.contraction = contraction?;
        }
        if berr.is_nan() || berr > BACKWARD_ERROR_TOL {
            return Err(unreliable(&factor));
        }
        // Inertia preservation: only meaningful without zero pivots (a zero eigenvalue of K is
        // an eigenvalue 1 of I − M⁻¹K).
        let pivot_zeros = factor.inertia().zero - factor.zero_rows.len();
        let rho = factor.contraction;
        if pivot_zeros == 0 && (rho.is_nan() || rho > CONTRACTION_TOL) {
            return Err(unreliable(&factor));
        }
        Ok((factor, out))
    }

    /// Dimension `n` of the matrix.
    pub fn n(&self) -> usize {
        self.pattern.inner.n
    }

    /// Inertia, counting pivots of magnitude `≤ ZERO_PIVOT_RTOL · ‖K̃‖∞` as zero eigenvalues
    /// (see [`ZERO_PIVOT_RTOL`]); exactly zero rows of `K` count as zero eigenvalues.
    pub fn inertia(&self) -> Inertia {
        self.inertia_with_tol(ZERO_PIVOT_RTOL)
    }

    /// Inertia with a custom relative zero-pivot threshold `rtol ≥ 0` (pivots with
    /// `|pivot| ≤ rtol · ‖K̃‖∞` count as zero eigenvalues).
    ///
    /// The contraction check of [`LbltFactor::factorize`] was enforced only if no pivot is zero
    /// at the default threshold [`ZERO_PIVOT_RTOL`]; with a smaller `rtol` that turns such
    /// pivots into signs, check [`LbltFactor::contraction`]` ≤ CONTRACTION_TOL` yourself.
    pub fn inertia_with_tol(&self, rtol: f64) -> Inertia {
        let mut inertia = Inertia {
            positive: 0,
            negative: 0,
            zero: self.zero_rows.len(),
        };
        for &r in &self.pivot_ratios {
            if r.abs() <= rtol {
                inertia.zero += 1;
            } else if r > 0.0 {
                inertia.positive += 1;
            } else {
                inertia.negative += 1;
            }
        }
        inertia
    }

    /// Solves `K x = rhs` in place (`rhs.len() == n`), with up to [`MAX_REFINEMENT_STEPS`] steps
    /// of iterative refinement (kept only while they reduce the residual). Deflated zero rows
    /// of `K` get `x_i = 0`. Returns the normwise backward error
    /// `‖K x − rhs‖∞ / (‖K‖∞ ‖x‖∞ + ‖rhs‖∞)` of the returned solution.
    pub fn solve_in_place(&self, rhs: &mut [f64]) -> Result<f64, InertiaError> {
        if rhs.len() != self.n() {
            return Err(InertiaError::LengthMismatch {
                what: "right-hand side",
                expected: self.n(),
                got: rhs.len(),
            });
        }
        self.solve_refined(rhs).map(|(berr, _)| berr)
    }

    /// Solves `K x = rhs` in place with the factors once, without refinement or backward error
    /// (`rhs.len() == n`; deflated zero rows of `K` get `x_i = 0`): for estimates, such as the
    /// vectors of an iterative eigenvalue method.
    pub fn solve_in_place_unrefined(&self, rhs: &mut [f64]) -> Result<(), InertiaError> {
        if rhs.len() != self.n() {
            return Err(InertiaError::LengthMismatch {
                what: "right-hand side",
                expected: self.n(),
                got: rhs.len(),
            });
        }
        self.solve_once(rhs)
    }

    /// Normwise backward error `‖K x − b‖∞ / (‖K‖∞ ‖x‖∞ + ‖b‖∞)` of the test solve made at
    /// factorization time (`b = K y`, `y` pseudo-random in `[-1, 1]ⁿ`), after refinement.
    pub fn backward_error(&self) -> f64 {
        self.backward_error
    }

    /// Estimated spectral radius `ρ` of `I − M⁻¹K`, `M = D⁻¹Pᵀ L B Lᵀ P D⁻¹` the computed
    /// factorization (deflated zero rows excluded): the contraction factor of iterative
    /// refinement, estimated by `CONTRACTION_ITERATIONS` power iterations from a
    /// pseudo-random vector (the largest ratio is kept).
    ///
    /// Why it matters: with `E = M − K`, if `K + tE` were singular for some `t ∈ [0, 1)`, then
    /// `M⁻¹E` would have the eigenvalue `1/(1 − t) ≥ 1`. So `ρ(M⁻¹E) = ρ(I − M⁻¹K) < 1` implies
    /// that the inertia of `B` (that of `M`) is exactly the inertia of `K`, whatever the size of
    /// the rounding errors. A matrix with a zero eigenvalue has `ρ ≈ 1`, so the check is only
    /// applied when no pivot is classified as zero.
    pub fn contraction(&self) -> f64 {
        self.contraction
    }

    /// Number of refinement steps that the test solve used.
    pub fn refinement_steps(&self) -> usize {
        self.refinement_steps
    }

    /// Smallest `|pivot| / ‖K̃‖∞` over the `1×1` blocks and the eigenvalues of the `2×2` blocks
    /// of `B` (deflated zero rows excluded; `+∞` if all rows were deflated).
    pub fn min_pivot_ratio(&self) -> f64 {
        self.pivot_ratios
            .iter()
            .fold(f64::INFINITY, |m, r| m.min(r.abs()))
    }

    /// `‖K̃‖∞` of the equilibrated matrix `K̃ = D K D` (deflated rows with unit diagonal), the
    /// reference of [`LbltFactor::min_pivot_ratio`] and of the zero-pivot threshold.
    pub fn equilibrated_norm(&self) -> f64 {
        self.norm_inf
    }

    /// Largest magnitude of an entry of `L` (element growth; `≲ 10` is benign).
    pub fn max_abs_l(&self) -> f64 {
        self.max_abs_l
    }

    /// Number of `2×2` blocks in `B`.
    pub fn n_two_by_two(&self) -> usize {
        self.n_two_by_two
    }

    /// Number of exactly zero rows of `K` (deflated, counted as zero eigenvalues).
    pub fn n_zero_rows(&self) -> usize {
        self.zero_rows.len()
    }

    /// `y = K x` with the original values.
    fn matvec(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..self.n() {
            for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                let i = self.row_idx[k];
                let a = self.values[k];
                y[i] += a * x[j];
                if i != j {
                    y[j] += a * x[i];
                }
            }
        }
    }

    /// One solve with the factors: `x = D K̃⁻¹ D rhs` (deflated rows set to zero).
    fn solve_once(&self, rhs: &mut [f64]) -> Result<(), InertiaError> {
        let p = &*self.pattern.inner;
        let n = p.n;
        for (r, d) in rhs.iter_mut().zip(&self.scaling) {
            *r *= d;
        }
        let req = p.symbolic.solve_in_place_scratch::<f64>(1, Par::Seq);
        let mut mem = MemBuffer::try_new(req).map_err(|_| InertiaError::OutOfMemory)?;
        guarded("LBLᵀ solve", || {
            // faer applies both permutations: x[i] = rhs[sym_fwd[dyn_fwd[i]]] before the
            // triangular solves, and the inverse composition after.
            let perm = PermRef::new_checked(&self.perm_fwd, &self.perm_inv, n);
            let lblt = IntranodeLbltRef::new(&p.symbolic, &self.l_values, &self.subdiag, perm);
            lblt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut *rhs, n, 1),
                Par::Seq,
                MemStack::new(&mut mem),
            );
        })?;
        for (r, d) in rhs.iter_mut().zip(&self.scaling) {
            *r *= d;
        }
        for &i in &self.zero_rows {
            rhs[i] = 0.0;
        }
        Ok(())
    }

    /// The refined solve of the consistent test system `K x = b`, `b = K y` (`y`
    /// deterministic pseudo-random): its backward error and refinement steps.
    fn test_solve(&self) -> Result<(f64, usize), InertiaError> {
        let n = self.n();
        let mut rng = XorShift64::new(0x9E37_79B9_7F4A_7C15);
        let y: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let mut b = vec![0.0; n];
        self.matvec(&y, &mut b);
        self.solve_refined(&mut b)
    }

    /// Power-iteration estimate of the spectral radius of `I − M⁻¹K` (see
    /// [`LbltFactor::contraction`]).
    fn estimate_contraction(&self) -> Result<f64, InertiaError> {
        let n = self.n();
        let mut rng = XorShift64::new(0xD1B5_4A32_D192_ED03);
        let mut z: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        for &i in &self.zero_rows {
            z[i] = 0.0;
        }
        let mut u = vec![0.0; n];
        let mut rho = 0.0f64;
        for _ in 0..CONTRACTION_ITERATIONS {
            let norm = norm_inf(&z);
            if !(norm > 0.0 && norm.is_finite()) {
                break;
            }
            z.iter_mut().for_each(|v| *v /= norm);
            self.matvec(&z, &mut u);
            self.solve_once(&mut u)?;
            for (zi, ui) in z.iter_mut().zip(&u) {
                *zi -= ui;
            }
            let ratio = norm_inf(&z);
            if !ratio.is_finite() {
                return Ok(f64::INFINITY);
            }
            rho = rho.max(ratio);
        }
        Ok(rho)
    }

    /// Solve with refinement; returns (backward error, refinement steps kept).
    fn solve_refined(&self, rhs: &mut [f64]) -> Result<(f64, usize), InertiaError> {
        let n = self.n();
        let b = rhs.to_vec();
        let norm_k = self.norm_k;
        let norm_b = norm_inf(&b);
        self.solve_once(rhs)?;
        let mut r = vec![0.0; n];
        let residual = |x: &[f64], r: &mut [f64]| {
            self.matvec(x, r);
            for (ri, bi) in r.iter_mut().zip(&b) {
                *ri = bi - *ri;
            }
            let denom = norm_k * norm_inf(x) + norm_b;
            if denom > 0.0 {
                norm_inf(r) / denom
            } else {
                0.0
            }
        };
        let mut berr = residual(rhs, &mut r);
        let mut steps = 0;
        let mut candidate = vec![0.0; n];
        while steps < MAX_REFINEMENT_STEPS && berr.is_finite() && berr > 4.0 * f64::EPSILON {
            let mut dx = r.clone();
            self.solve_once(&mut dx)?;
            for ((c, x), d) in candidate.iter_mut().zip(rhs.iter()).zip(&dx) {
                *c = x + d;
            }
            let mut r_new = vec![0.0; n];
            let berr_new = residual(&candidate, &mut r_new);
            if berr_new.is_nan() || berr_new >= 0.5 * berr {
                break;
            }
            rhs.copy_from_slice(&candidate);
            r = r_new;
            berr = berr_new;
            steps += 1;
        }
        if berr.is_nan() {
            berr = f64::INFINITY;
        }
        Ok((berr, steps))
    }
}

/// What [`LbltFactor::factorize_checked`] verifies after the numeric factorization.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Checks {
    /// Test solve and contraction estimate: the inertia is proven ([`LbltFactor::factorize`]).
    Proof,
    /// Test solve only ([`LbltFactor::factorize_unproven`]).
    BackwardError,
    /// Neither ([`LbltFactor::factorize_for_solve`]).
    Nothing,
}

/// Runs a call into faer, converting a panic (a bug) into [`InertiaError::Internal`].
fn guarded<T>(what: &str, f: impl FnOnce() -> T) -> Result<T, InertiaError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|payload| {
        let msg = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        InertiaError::Internal(format!("{what}: {msg}"))
    })
}

/// Eigenvalues of the symmetric 2×2 matrix `[[a, b], [b, c]]`, larger magnitude first
/// (computed without cancellation).
fn eig2(a: f64, b: f64, c: f64) -> (f64, f64) {
    let m = 0.5 * (a + c);
    let r = (0.5 * (a - c)).hypot(b);
    let big = if m >= 0.0 { m + r } else { m - r };
    if big == 0.0 {
        return (0.0, 0.0);
    }
    // det = a c − b² = big · small.
    let small = (a * c - b * b) / big;
    (big, small)
}

fn norm_inf(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Max |entry| of each row of the symmetric matrix given by its upper triangle.
fn row_max_abs(n: usize, col_ptr: &[usize], row_idx: &[usize], vals: &[f64]) -> Vec<f64> {
    let mut r = vec![0.0f64; n];
    for j in 0..n {
        for k in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[k];
            let a = vals[k].abs();
            r[i] = r[i].max(a);
            r[j] = r[j].max(a);
        }
    }
    r
}

/// ∞-norm (max row sum) of the symmetric matrix given by its upper triangle.
fn sym_norm_inf(n: usize, col_ptr: &[usize], row_idx: &[usize], vals: &[f64]) -> f64 {
    let mut r = vec![0.0f64; n];
    for j in 0..n {
        for k in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[k];
            let a = vals[k].abs();
            r[i] += a;
            if i != j {
                r[j] += a;
            }
        }
    }
    norm_inf(&r)
}

/// Symmetric Ruiz equilibration in the ∞-norm: returns `D` (powers of two, `1` on zero rows)
/// such that the rows of `D K D` have max-norm close to 1, the values of `D K D` (exact: the
/// scalings are powers of two), and the max-norms of its rows.
fn equilibrate(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    vals: &[f64],
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut d = vec![1.0f64; n];
    let mut scaled = vals.to_vec();
    let mut r = row_max_abs(n, col_ptr, row_idx, &scaled);
    for _ in 0..EQUILIBRATION_SWEEPS {
        let mut changed = false;
        let factors: Vec<f64> = r
            .iter()
            .map(|&ri| {
                if ri > 0.7 && ri < 1.4 {
                    // −log2(ri)/2 ∈ (−0.25, 0.26): the factor below is 1.
                    1.0
                } else if ri > 0.0 && ri.is_finite() {
                    // Nearest power of two to 1/sqrt(ri).
                    let e = (-0.5 * ri.log2()).round() as i32;
                    let e = e.clamp(-500, 500);
                    if e != 0 {
                        changed = true;
                    }
                    2f64.powi(e)
                } else {
                    1.0
                }
            })
            .collect();
        if !changed {
            break;
        }
        r.iter_mut().for_each(|x| *x = 0.0);
        for j in 0..n {
            d[j] *= factors[j];
            for k in col_ptr[j]..col_ptr[j + 1] {
                let i = row_idx[k];
                scaled[k] *= factors[i] * factors[j];
                let a = scaled[k].abs();
                r[i] = r[i].max(a);
                r[j] = r[j].max(a);
            }
        }
    }
    (d, scaled, r)
}

/// Small deterministic xorshift generator (for the test right-hand side and the tests).
#[derive(Clone, Debug)]
struct XorShift64(u64);

impl XorShift64 {
    fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        x
    }
    /// Uniform in `[0, 1)`.
    fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn below(rng: &mut XorShift64, n: usize) -> usize {
        (rng.next_u64() % n as u64) as usize
    }

    /// Dense symmetric matrix from triplets (mirrored, summed).
    fn dense(n: usize, entries: &[(usize, usize)], values: &[f64]) -> faer::Mat<f64> {
        let mut m = faer::Mat::<f64>::zeros(n, n);
        for (&(i, j), &v) in entries.iter().zip(values) {
            m[(i, j)] += v;
            if i != j {
                m[(j, i)] += v;
            }
        }
        m
    }

    /// Inertia from dense eigenvalues, `|λ| ≤ rtol ‖K‖∞` counted as zero; also returns the
    /// smallest |λ| above the threshold (relative) and the largest below.
    fn dense_inertia(m: &faer::Mat<f64>, rtol: f64) -> (Inertia, f64, f64) {
        let n = m.nrows();
        let mut norm = 0.0f64;
        for i in 0..n {
            norm = norm.max((0..n).map(|j| m[(i, j)].abs()).sum());
        }
        let eig = m
            .self_adjoint_eigenvalues(Side::Lower)
            .expect("dense eigenvalues");
        let mut inertia = Inertia {
            positive: 0,
            negative: 0,
            zero: 0,
        };
        let (mut min_nonzero, mut max_zero) = (f64::INFINITY, 0.0f64);
        for &l in &eig {
            let r = l.abs() / norm;
            if r <= rtol {
                inertia.zero += 1;
                max_zero = max_zero.max(r);
            } else {
                min_nonzero = min_nonzero.min(r);
                if l > 0.0 {
                    inertia.positive += 1;
                } else {
                    inertia.negative += 1;
                }
            }
        }
        (inertia, min_nonzero, max_zero)
    }

    struct Sparse {
        n: usize,
        entries: Vec<(usize, usize)>,
        values: Vec<f64>,
    }

    impl Sparse {
        fn new(n: usize) -> Self {
            Self {
                n,
                entries: Vec::new(),
                values: Vec::new(),
            }
        }
        fn push(&mut self, i: usize, j: usize, v: f64) {
            self.entries.push((i, j));
            self.values.push(v);
        }
    }

    /// Random sparse symmetric matrix with about `per_row` off-diagonal entries per row; the
    /// diagonal is `diag(i)`.
    fn random_sym(
        n: usize,
        per_row: usize,
        seed: u64,
        mut diag: impl FnMut(usize, &mut XorShift64) -> f64,
    ) -> Sparse {
        let mut rng = XorShift64::new(seed);
        let mut s = Sparse::new(n);
        for i in 0..n {
            let d = diag(i, &mut rng);
            // A zero diagonal is left out of the pattern (structurally zero).
            if d != 0.0 {
                s.push(i, i, d);
            }
            for _ in 0..per_row / 2 {
                let j = below(&mut rng, n);
                if j != i {
                    let v = rng.uniform(-1.0, 1.0);
                    s.push(i, j, v);
                }
            }
        }
        s
    }

    fn check_against_dense(name: &str, s: &Sparse, rtol: f64) -> LbltFactor {
        let pattern = SymmetricPattern::new(s.n, &s.entries).expect("pattern");
        let f = LbltFactor::factorize(&pattern, &s.values).expect("factorization");
        let (expected, min_nonzero, max_zero) =
            dense_inertia(&dense(s.n, &s.entries, &s.values), rtol);
        eprintln!(
            "{name}: n = {}, nnz(L) = {}, inertia {} (dense {}), berr = {:.2e} ({} refinement), ρ = {:.1e}, \
             min pivot ratio = {:.2e}, max|L| = {:.2e}, 2x2 blocks = {}, dense: min nonzero |λ|/‖K‖ = {:.2e}, max zero |λ|/‖K‖ = {:.2e}",
            s.n,
            pattern.nnz_factor(),
            f.inertia(),
            expected,
            f.backward_error(),
            f.refinement_steps(),
            f.contraction(),
            f.min_pivot_ratio(),
            f.max_abs_l(),
            f.n_two_by_two(),
            min_nonzero,
            max_zero,
        );
        assert_eq!(f.inertia(), expected, "{name}");
        f
    }

    #[test]
    fn random_definite_and_indefinite() {
        for (k, &n) in [50usize, 120, 300].iter().enumerate() {
            let seed = 17 + k as u64;
            // Positive definite: strictly diagonally dominant, positive diagonal.
            let s = random_sym(n, 8, seed, |_, r| 6.0 + r.next_f64());
            check_against_dense(&format!("spd n={n}"), &s, 1e-10);
            // Negative definite.
            let s = random_sym(n, 8, seed + 100, |_, r| -6.0 - r.next_f64());
            check_against_dense(&format!("snd n={n}"), &s, 1e-10);
            // Indefinite, random diagonal.
            let s = random_sym(n, 8, seed + 200, |_, r| r.uniform(-1.0, 1.0));
            check_against_dense(&format!("indef n={n}"), &s, 1e-10);
            // Indefinite with zero diagonal.
            let s = random_sym(n, 8, seed + 300, |_, _| 0.0);
            check_against_dense(&format!("zero-diag n={n}"), &s, 1e-10);
        }
    }

    /// The three levels of checks: the same numeric factorization (the same solution bits
    /// and inertia), with the test solve and the contraction estimate made only where asked
    /// (NaN otherwise); a solve with the unchecked factorization still reports its own
    /// backward error.
    #[test]
    fn check_levels_share_one_factorization() {
        let s = random_sym(200, 8, 4242, |_, r| r.uniform(-1.0, 1.0));
        let pattern = SymmetricPattern::new(s.n, &s.entries).expect("pattern");
        let proven = LbltFactor::factorize(&pattern, &s.values).expect("proven");
        let unproven = LbltFactor::factorize_unproven(&pattern, &s.values).expect("unproven");
        let bare = LbltFactor::factorize_for_solve(&pattern, &s.values).expect("for solve");
        assert!(proven.backward_error() < 1e-12 && proven.contraction() < CONTRACTION_TOL);
        assert!(unproven.backward_error() < 1e-12 && unproven.contraction().is_nan());
        assert!(bare.backward_error().is_nan() && bare.contraction().is_nan());
        assert_eq!(proven.inertia(), bare.inertia());
        assert_eq!(proven.inertia(), unproven.inertia());
        let mut rng = XorShift64::new(7);
        let b: Vec<f64> = (0..s.n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let solve = |f: &LbltFactor| {
            let mut x = b.clone();
            let berr = f.solve_in_place(&mut x).expect("solve");
            (x, berr)
        };
        let (x_proven, _) = solve(&proven);
        let (x_bare, berr) = solve(&bare);
        assert!(berr < 1e-12, "backward error {berr:e}");
        assert_eq!(x_proven, x_bare);
    }

    /// Reconstructs `P K̃ Pᵀ` and `L B Lᵀ` densely from faer's raw output, to confirm the
    /// conventions: `subdiag[j] != 0` ⇒ 2×2 block on (j, j+1); rows of the off-diagonal part
    /// of a supernode are in pre-intranode-pivoting coordinates (mapped through the inverse
    /// intranode permutation); `P` row `i` is original row `sym_fwd[dyn_fwd[i]]`.
    fn reconstruction_error(pattern: &SymmetricPattern, f: &LbltFactor) -> f64 {
        let p = &*pattern.inner;
        let n = p.n;
        let SymbolicCholeskyRaw::Supernodal(sn) = p.symbolic.raw() else {
            panic!("not supernodal")
        };
        let perm = PermRef::new_checked(&f.perm_fwd, &f.perm_inv, n);
        let lref = SupernodalIntranodeLbltRef::new(sn, &f.l_values, &f.subdiag, perm);
        let mut l = faer::Mat::<f64>::zeros(n, n);
        let mut b = faer::Mat::<f64>::zeros(n, n);
        for s in 0..sn.n_supernodes() {
            let node = lref.supernode(s);
            let (start, v) = (node.start(), node.val());
            let w = v.ncols();
            for j in 0..w {
                l[(start + j, start + j)] = 1.0;
                for i in j + 1..w {
                    l[(start + i, start + j)] = v[(i, j)];
                }
                for (idx, &r) in node.pattern().iter().enumerate() {
                    l[(f.perm_inv[r], start + j)] = v[(w + idx, j)];
                }
                b[(start + j, start + j)] = v[(j, j)];
                if f.subdiag[start + j] != 0.0 {
                    b[(start + j + 1, start + j)] = f.subdiag[start + j];
                    b[(start + j, start + j + 1)] = f.subdiag[start + j];
                }
            }
        }
        let lblt = &l * &b * l.transpose();
        let sym_fwd = p
            .symbolic
            .perm()
            .expect("custom ordering")
            .arrays()
            .0
            .to_vec();
        let orig = |i: usize| sym_fwd[f.perm_fwd[i]];
        // Scaled, deflated matrix K̃ densely.
        let mut kt = faer::Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for k in f.col_ptr[j]..f.col_ptr[j + 1] {
                let i = f.row_idx[k];
                let v = f.values[k] * f.scaling[i] * f.scaling[j];
                kt[(i, j)] = v;
                kt[(j, i)] = v;
            }
        }
        for &i in &f.zero_rows {
            kt[(i, i)] = 1.0;
        }
        let mut err = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                err = err.max((kt[(orig(i), orig(j))] - lblt[(i, j)]).abs());
            }
        }
        err / f.norm_inf
    }

    #[test]
    fn faer_conventions_reconstruct() {
        // Zero-diagonal random matrix (2×2 pivots) and a KKT matrix: P K̃ Pᵀ = L B Lᵀ.
        let s = random_sym(80, 6, 5, |i, r| {
            if i % 3 == 0 {
                0.0
            } else {
                r.uniform(-1.0, 1.0)
            }
        });
        let pattern = SymmetricPattern::new(s.n, &s.entries).unwrap();
        let f = LbltFactor::factorize(&pattern, &s.values).unwrap();
        let err = reconstruction_error(&pattern, &f);
        eprintln!(
            "reconstruction (random, n = 80): ‖PK̃Pᵀ − LBLᵀ‖max/‖K̃‖∞ = {err:.2e}, 2x2 blocks = {}, pairs = {}",
            f.n_two_by_two(),
            pattern.n_pivot_groups()
        );
        assert!(err < 1e-12);
        assert!(f.n_two_by_two() > 0);
        let (s, _) = random_kkt(60, 20, &[1, 4], 9);
        let pattern = SymmetricPattern::new(s.n, &s.entries).unwrap();
        let f = LbltFactor::factorize(&pattern, &s.values).unwrap();
        let err = reconstruction_error(&pattern, &f);
        eprintln!(
            "reconstruction (KKT 60+20): {err:.2e}, 2x2 blocks = {}",
            f.n_two_by_two()
        );
        assert!(err < 1e-12);
    }

    /// KKT `[[H, Aᵀ], [A, 0]]` (`n` variables, `m` constraints, constraints after the variables)
    /// with `ZᵀHZ` having exactly the negative eigenvalues listed in `neg` (indices among the
    /// `n − m` null-space directions). The pattern depends only on `(n, m, seed)`.
    ///
    /// `A = [A_B, A_N]` (basic/nonbasic columns, randomly interleaved), `A_B` lower triangular
    /// with nonzero diagonal, so `Z = [−A_B⁻¹ A_N; I]`; `H = H₀ + Aᵀ W A` with `H₀` nonzero only
    /// on the nonbasic block, strictly diagonally dominant (diagonal signs = prescribed
    /// inertia; a diagonal value of magnitude `< 4` is decoupled), so `ZᵀHZ = H₀_NN`.
    fn random_kkt(n: usize, m: usize, neg: &[usize], seed: u64) -> (Sparse, Inertia) {
        random_kkt_with(n, m, seed, |t, r| {
            let d = 4.0 + r.next_f64();
            if neg.contains(&t) {
                -d
            } else {
                d
            }
        })
    }

    fn random_kkt_with(
        n: usize,
        m: usize,
        seed: u64,
        mut nonbasic_diag: impl FnMut(usize, &mut XorShift64) -> f64,
    ) -> (Sparse, Inertia) {
        assert!(m < n);
        let mut rng = XorShift64::new(seed);
        let mut order: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            order.swap(i, below(&mut rng, i + 1));
        }
        let (basic, nonbasic) = order.split_at(m);
        // Rows of A as (column, value) lists.
        let mut a_rows: Vec<Vec<(usize, f64)>> = Vec::with_capacity(m);
        for i in 0..m {
            let mut row = vec![(basic[i], 1.0 + rng.next_f64())];
            if i > 0 {
                row.push((basic[below(&mut rng, i)], rng.uniform(-1.0, 1.0)));
            }
            for _ in 0..3 {
                row.push((nonbasic[below(&mut rng, n - m)], rng.uniform(-1.0, 1.0)));
            }
            a_rows.push(row);
        }
        let mut s = Sparse::new(n + m);
        // H₀ on the nonbasic block: tridiagonal (in the nonbasic list), |offdiag| < 1, |diag| > 4.
        let mut expected = Inertia {
            positive: 0,
            negative: 0,
            zero: 0,
        };
        // A diagonal entry with |d| < 4 is decoupled (zero off-diagonal values, same pattern).
        let diag: Vec<f64> = (0..n - m).map(|t| nonbasic_diag(t, &mut rng)).collect();
        for t in 0..n - m {
            let d = diag[t];
            if d < 0.0 {
                expected.negative += 1;
            } else if d > 0.0 {
                expected.positive += 1;
            } else {
                expected.zero += 1;
            }
            s.push(nonbasic[t], nonbasic[t], d);
            if t + 1 < n - m {
                let v = rng.uniform(-0.99, 0.99);
                let v = if d.abs() < 4.0 || diag[t + 1].abs() < 4.0 {
                    0.0
                } else {
                    v
                };
                s.push(nonbasic[t + 1], nonbasic[t], v);
            }
        }
        // Aᵀ W A (duplicates summed by the factorization) and the A block.
        for (i, row) in a_rows.iter().enumerate() {
            let w = if rng.next_f64() < 0.5 { -1.0 } else { 1.0 } * rng.uniform(0.5, 1.5);
            for (p, &(cp, vp)) in row.iter().enumerate() {
                for &(cq, vq) in &row[p..] {
                    s.push(cp, cq, w * vp * vq);
                }
                s.push(n + i, cp, vp);
            }
        }
        // Sylvester: inertia(K) = inertia(ZᵀHZ) + (m, m, 0).
        expected.positive += m;
        expected.negative += m;
        (s, expected)
    }

    #[test]
    fn random_kkt_matches_sylvester_and_dense() {
        for (n, m, neg, seed) in [
            (60usize, 20usize, vec![], 1u64),
            (150, 60, vec![0, 7, 33], 2),
            (250, 100, (0..40).collect::<Vec<_>>(), 3),
            (300, 290, vec![2], 4),
        ] {
            let (s, expected) = random_kkt(n, m, &neg, seed);
            let f = check_against_dense(&format!("kkt n={n} m={m} k={}", neg.len()), &s, 1e-10);
            assert_eq!(f.inertia(), expected);
            assert!(f.backward_error() < 1e-12);
        }
    }

    /// Time-ordered collocation-like KKT: `nb` blocks of 9 variables (x: 6, u: 3) and 6
    /// constraints, interleaved `[x_t, u_t, c_t]`; `c_0: x_0 = ·`,
    /// `c_t: x_t − M_t x_{t−1} − N_t u_{t−1} = 0` (dense `M_t`, `N_t`). `H = H₀ + Aᵀ W A`, `H₀`
    /// on the controls only (diagonally dominant, coupling neighbouring blocks), so
    /// `ZᵀHZ = H₀_uu` with `k` negative eigenvalues (the first control of the blocks in `neg`).
    fn banded_kkt(nb: usize, neg: &[usize], seed: u64) -> (Sparse, Inertia) {
        let mut rng = XorShift64::new(seed);
        let x = |t: usize, i: usize| 15 * t + i;
        let u = |t: usize, i: usize| 15 * t + 6 + i;
        let c = |t: usize, i: usize| 15 * t + 9 + i;
        let mut s = Sparse::new(15 * nb);
        let mut a_rows: Vec<(usize, Vec<(usize, f64)>)> = Vec::new();
        for t in 0..nb {
            for i in 0..6 {
                let mut row = vec![(x(t, i), 1.0)];
                if t > 0 {
                    for j in 0..6 {
                        let v = 0.1 * rng.uniform(-1.0, 1.0) + if i == j { 0.8 } else { 0.0 };
                        row.push((x(t - 1, j), -v));
                    }
                    for j in 0..3 {
                        row.push((u(t - 1, j), -0.5 * rng.uniform(-1.0, 1.0)));
                    }
                }
                a_rows.push((c(t, i), row));
            }
        }
        let mut expected = Inertia {
            positive: 0,
            negative: 0,
            zero: 0,
        };
        for t in 0..nb {
            for i in 0..3 {
                let d = 4.0 + rng.next_f64();
                let d = if i == 0 && neg.contains(&t) { -d } else { d };
                if d < 0.0 {
                    expected.negative += 1;
                } else {
                    expected.positive += 1;
                }
                s.push(u(t, i), u(t, i), d);
                if i < 2 {
                    s.push(u(t, i), u(t, i + 1), rng.uniform(-0.9, 0.9));
                }
                if t + 1 < nb {
                    s.push(u(t, i), u(t + 1, i), rng.uniform(-0.9, 0.9));
                }
            }
        }
        for (ci, row) in &a_rows {
            let w = rng.uniform(0.1, 2.0) * if rng.next_f64() < 0.3 { -1.0 } else { 1.0 };
            for (p, &(cp, vp)) in row.iter().enumerate() {
                for &(cq, vq) in &row[p..] {
                    s.push(cp, cq, w * vp * vq);
                }
                s.push(*ci, cp, vp);
            }
        }
        let m = 6 * nb;
        expected.positive += m;
        expected.negative += m;
        (s, expected)
    }

    #[test]
    fn banded_collocation_kkt() {
        // Dense check at n = 1650 (110 blocks).
        let (s, expected) = banded_kkt(110, &[3, 50, 51, 109], 11);
        let f = check_against_dense("banded kkt 110 blocks", &s, 1e-10);
        assert_eq!(f.inertia(), expected);
        // Large: 1400 blocks, n = 21000, ~30 nonzeros per row; sparse only.
        let nb = 1400;
        let neg: Vec<usize> = (0..nb).step_by(97).collect();
        let (s, expected) = banded_kkt(nb, &neg, 12);
        let t0 = std::time::Instant::now();
        let pattern = SymmetricPattern::new(s.n, &s.entries).unwrap();
        let t_analyse = t0.elapsed();
        let t1 = std::time::Instant::now();
        let f = LbltFactor::factorize(&pattern, &s.values).unwrap();
        let t_factor = t1.elapsed();
        let mut user: Vec<(usize, usize)> = s
            .entries
            .iter()
            .map(|&(i, j)| (i.min(j), i.max(j)))
            .collect();
        user.sort_unstable();
        user.dedup();
        let n_diag = user.iter().filter(|(i, j)| i == j).count();
        let nnz_user = 2 * user.len() - n_diag;
        let nnz_aug = 2 * pattern.nnz_upper() - s.n;
        eprintln!(
            "banded kkt {nb} blocks: n = {}, nnz(K) = {} ({:.1}/row; {:.1}/row with the explicit \
             zeros of the pairing), nnz(L) = {}, pivot groups = {}, analyse {:.1} ms, \
             factorize+checks {:.1} ms, inertia {} (expected {}), berr = {:.2e}, ρ = {:.1e}, \
             min pivot ratio = {:.2e}, max|L| = {:.2e}, 2x2 = {}",
            s.n,
            nnz_user,
            nnz_user as f64 / s.n as f64,
            nnz_aug as f64 / s.n as f64,
            pattern.nnz_factor(),
            pattern.n_pivot_groups(),
            t_analyse.as_secs_f64() * 1e3,
            t_factor.as_secs_f64() * 1e3,
            f.inertia(),
            expected,
            f.backward_error(),
            f.contraction(),
            f.min_pivot_ratio(),
            f.max_abs_l(),
            f.n_two_by_two(),
        );
        assert_eq!(f.inertia(), expected);
        assert!(t_factor.as_secs_f64() < 2.0);
    }

    /// `0..n` shuffled and cut into groups of 1 to 6 rows.
    fn random_partition(n: usize, rng: &mut XorShift64) -> Vec<Vec<usize>> {
        let mut order: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            order.swap(i, below(rng, i + 1));
        }
        let mut groups = Vec::new();
        let mut rest = &order[..];
        while !rest.is_empty() {
            let k = (1 + below(rng, 6)).min(rest.len());
            groups.push(rest[..k].to_vec());
            rest = &rest[k..];
        }
        groups
    }

    #[test]
    fn given_groups_stay_in_supernodes() {
        // Time-ordered groups (a block, or two, per group) with their members shuffled: the
        // analysis checks that every group lies in one supernode, and the inertia is exact.
        let mut rng = XorShift64::new(5);
        for (nb, per_group) in [(30usize, 1usize), (41, 2), (25, 3)] {
            let neg: Vec<usize> = (0..nb).step_by(7).collect();
            let (s, expected) = banded_kkt(nb, &neg, 40 + nb as u64);
            let mut groups: Vec<Vec<usize>> = (0..nb.div_ceil(per_group))
                .map(|g| (15 * per_group * g..(15 * per_group * (g + 1)).min(s.n)).collect())
                .collect();
            for g in &mut groups {
                for i in (1..g.len()).rev() {
                    g.swap(i, below(&mut rng, i + 1));
                }
            }
            let pattern = SymmetricPattern::with_groups(s.n, &s.entries, &groups).unwrap();
            let f = LbltFactor::factorize(&pattern, &s.values).unwrap();
            let (dense_expected, _, _) = dense_inertia(&dense(s.n, &s.entries, &s.values), 1e-10);
            eprintln!(
                "grouped banded kkt ({nb} blocks, {per_group} per group): nnz(L) = {}, inertia {} \
                 (expected {expected}), berr = {:.1e}",
                pattern.nnz_factor(),
                f.inertia(),
                f.backward_error()
            );
            assert_eq!(f.inertia(), expected);
            assert_eq!(dense_expected, expected);
        }
        // Arbitrary patterns and partitions: the analysis never splits a group.
        for seed in 0..8u64 {
            let s = random_sym(90, 5, 60 + seed, |_, r| r.uniform(-1.0, 1.0));
            let groups = random_partition(s.n, &mut rng);
            let pattern = SymmetricPattern::with_groups(s.n, &s.entries, &groups).unwrap();
            if let Ok(f) = LbltFactor::factorize(&pattern, &s.values) {
                let (expected, _, _) = dense_inertia(&dense(s.n, &s.entries, &s.values), 1e-10);
                assert_eq!(f.inertia(), expected);
            }
        }
    }

    #[test]
    fn work_done_while_the_checks_run_sees_the_factors_that_pass_them() {
        let s = random_sym(120, 6, 77, |_, r| r.uniform(-1.0, 1.0));
        let pattern = SymmetricPattern::new(s.n, &s.entries).unwrap();
        let rhs: Vec<f64> = (0..s.n).map(|i| (i as f64 * 0.37).sin()).collect();
        let plain = LbltFactor::factorize(&pattern, &s.values).unwrap();
        let mut expected = rhs.clone();
        plain.solve_in_place_unrefined(&mut expected).unwrap();
        let (factor, (inertia, solved)) = LbltFactor::factorize_while(&pattern, &s.values, |f| {
            let mut x = rhs.clone();
            f.solve_in_place_unrefined(&mut x).unwrap();
            (f.inertia(), x)
        })
        .unwrap();
        assert_eq!(inertia, plain.inertia());
        assert_eq!(factor.inertia(), plain.inertia());
        assert_eq!(solved, expected);
        assert_eq!(
            factor.backward_error().to_bits(),
            plain.backward_error().to_bits()
        );
        assert_eq!(
            factor.contraction().to_bits(),
            plain.contraction().to_bits()
        );
        // A factorization that fails gives its error, not the work.
        let mut bad = s.values.clone();
        bad[3] = f64::NAN;
        let mut ran = false;
        let failed = LbltFactor::factorize_while(&pattern, &bad, |_| ran = true);
        assert!(matches!(failed, Err(InertiaError::NonFiniteValue { .. })));
        assert!(!ran);
    }

    #[test]
    fn the_group_closed_pattern_has_distinct_pairs_and_contains_the_matrix() {
        // Its pairs go to faer unsorted and without deduplication: none may repeat, and every
        // entry of the matrix must be among them.
        let mut rng = XorShift64::new(11);
        for seed in 0..8u64 {
            let s = random_sym(80, 5, 90 + seed, |_, r| r.uniform(-1.0, 1.0));
            let members = random_partition(s.n, &mut rng);
            let mut group = vec![NONE; s.n];
            for (g, m) in members.iter().enumerate() {
                for &i in m {
                    group[i] = g;
                }
            }
            let aug = group_closed_pattern(&s.entries, &group, &members);
            let upper: Vec<(usize, usize)> = (0..s.n)
                .flat_map(|c| aug.row(c).iter().map(move |&r| (c, r)))
                .collect();
            let mut sorted = upper.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), upper.len(), "seed {seed}: a repeated pair");
            assert!(upper.iter().all(|&(c, r)| r <= c));
            for &(r, c) in &s.entries {
                let pair = (r.max(c), r.min(c));
                assert!(
                    sorted.binary_search(&pair).is_ok(),
                    "seed {seed}: {pair:?} missing"
                );
            }
            for i in 0..s.n {
                assert!(
                    sorted.binary_search(&(i, i)).is_ok(),
                    "seed {seed}: diagonal {i}"
                );
            }
        }
    }

    /// Factorizes; if it succeeds the inertia must equal the dense one, otherwise the error is
    /// printed. Returns whether it succeeded.
    fn ok_or_error(name: &str, s: &Sparse, rtol: f64) -> bool {
        let pattern = SymmetricPattern::new(s.n, &s.entries).expect("pattern");
        let (expected, min_nonzero, max_zero) =
            dense_inertia(&dense(s.n, &s.entries, &s.values), rtol);
        match LbltFactor::factorize(&pattern, &s.values) {
            Ok(f) => {
                eprintln!(
                    "{name}: n = {}, inertia {} (dense {expected}), berr = {:.2e}, ρ = {:.1e}, \
                     min pivot ratio = {:.2e}, max|L| = {:.1e}, zero rows = {}, dense: min \
                     nonzero |λ|/‖K‖ = {min_nonzero:.2e}, max zero |λ|/‖K‖ = {max_zero:.2e}",
                    s.n,
                    f.inertia(),
                    f.backward_error(),
                    f.contraction(),
                    f.min_pivot_ratio(),
                    f.max_abs_l(),
                    f.n_zero_rows()
                );
                assert_eq!(f.inertia(), expected, "{name}");
                true
            }
            Err(e) => {
                eprintln!("{name}: n = {}, dense {expected}: error: {e}", s.n);
                false
            }
        }
    }

    #[test]
    fn singular_matrices() {
        // (a) Exact zero rows: 7 rows of an indefinite matrix zeroed (pattern kept, values 0),
        // and 3 rows without any entry.
        let mut s = random_sym(150, 8, 41, |_, r| r.uniform(-1.0, 1.0));
        let zeroed = [3usize, 17, 18, 60, 99, 120, 149];
        for (k, &(i, j)) in s.entries.iter().enumerate() {
            if zeroed.contains(&i) || zeroed.contains(&j) {
                s.values[k] = 0.0;
            }
        }
        s.n += 3;
        let f = check_against_dense("exact zero rows", &s, 1e-10);
        assert_eq!(f.inertia().zero, 10);
        assert_eq!(f.n_zero_rows(), 10);

        // (b) Duplicated row/column (exact rank deficiency 1, no zero row).
        let mut s = random_sym(120, 8, 43, |_, r| r.uniform(-2.0, 2.0));
        let last = s.n;
        s.n += 1;
        let copies: Vec<((usize, usize), f64)> = s
            .entries
            .iter()
            .zip(&s.values)
            .filter(|(&(i, j), _)| i == 0 || j == 0)
            .map(|(&e, &v)| (e, v))
            .collect();
        for ((i, j), v) in copies {
            match (i, j) {
                (0, 0) => {
                    s.push(last, last, v);
                    s.push(0, last, v);
                }
                (0, j) => s.push(last, j, v),
                (i, _) => s.push(i, last, v),
            }
        }
        assert!(ok_or_error("duplicated column", &s, 1e-10));

        // (c) Rank deficient: K = Σ_l d_l v_l v_lᵀ with sparse v_l (3 entries), rank ≤ n − 8.
        let n = 100;
        let mut rng = XorShift64::new(47);
        let mut s = Sparse::new(n);
        for l in 0..n - 8 {
            let d = if l % 3 == 0 { -1.0 } else { 1.0 } * rng.uniform(0.5, 2.0);
            let mut idx = vec![l, below(&mut rng, n), below(&mut rng, n)];
            idx.sort_unstable();
            idx.dedup();
            let v: Vec<f64> = idx.iter().map(|_| rng.uniform(0.5, 1.5)).collect();
            for p in 0..idx.len() {
                for q in p..idx.len() {
                    s.push(idx[p], idx[q], d * v[p] * v[q]);
                }
            }
        }
        let ok = ok_or_error("rank deficient (low-rank sum)", &s, 1e-10);
        eprintln!("rank deficient (low-rank sum): factorization accepted = {ok}");
    }

    #[test]
    fn nearly_singular_kkt_never_wrong() {
        // ZᵀHZ = H₀_NN has one eigenvalue ε (decoupled direction); the others are ≥ 3.
        let (n, m) = (120, 50);
        for eps in [0.0, 1e-15, -1e-15, 1e-13, -1e-13, 1e-9, -1e-9, 1e-6, -1e-6] {
            let (s, _) = random_kkt_with(n, m, 77, |t, r| {
                let d = 4.0 + r.next_f64();
                if t == 10 {
                    eps
                } else {
                    d
                }
            });
            let pattern = SymmetricPattern::new(s.n, &s.entries).unwrap();
            let sign = |x: f64| Inertia {
                positive: n - usize::from(x <= 0.0),
                negative: m + usize::from(x < 0.0),
                zero: usize::from(x == 0.0),
            };
            let with_sign = sign(eps);
            let with_zero = sign(0.0);
            match LbltFactor::factorize(&pattern, &s.values) {
                Ok(f) => {
                    eprintln!(
                        "nearly singular KKT, ε = {eps:e}: inertia {} (exact {with_sign}), \
                         min pivot ratio = {:.2e}, berr = {:.2e}, ρ = {:.1e}",
                        f.inertia(),
                        f.min_pivot_ratio(),
                        f.backward_error(),
                        f.contraction()
                    );
                    let got = f.inertia();
                    assert!(got == with_sign || got == with_zero, "ε = {eps}: {got}");
                    if eps.abs() >= 1e-9 {
                        assert_eq!(got, with_sign);
                    }
                }
                Err(e) => {
                    eprintln!("nearly singular KKT, ε = {eps:e}: error: {e}");
                    assert!(eps.abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn solve_accuracy() {
        let (s, _) = random_kkt(200, 80, &[5, 6], 21);
        let pattern = SymmetricPattern::new(s.n, &s.entries).unwrap();
        let f = LbltFactor::factorize(&pattern, &s.values).unwrap();
        let k = dense(s.n, &s.entries, &s.values);
        let mut rng = XorShift64::new(99);
        let b: Vec<f64> = (0..s.n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let mut x = b.clone();
        let berr = f.solve_in_place(&mut x).unwrap();
        // Independent residual with the dense matrix.
        let mut r = 0.0f64;
        let (mut nk, mut nx, mut nb) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..s.n {
            let mut ri = -b[i];
            let mut row = 0.0;
            for j in 0..s.n {
                ri += k[(i, j)] * x[j];
                row += k[(i, j)].abs();
            }
            r = r.max(ri.abs());
            nk = nk.max(row);
            nx = nx.max(x[i].abs());
            nb = nb.max(b[i].abs());
        }
        let dense_berr = r / (nk * nx + nb);
        eprintln!(
            "solve: n = {}, reported berr = {berr:.2e}, dense-checked berr = {dense_berr:.2e}, \
             factorization-time berr = {:.2e}",
            s.n,
            f.backward_error()
        );
        assert!(dense_berr < 1e-14 && berr < 1e-14);
        assert!(matches!(
            f.solve_in_place(&mut [0.0; 3]),
            Err(InertiaError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn pattern_reuse_and_shifts() {
        // Same pattern, two value sets with different inertia.
        let (s1, e1) = random_kkt(150, 60, &[1, 2, 3], 31);
        let (s2, e2) = random_kkt_with(150, 60, 31, |t, r| {
            let d = 4.0 + r.next_f64();
            if t % 2 == 0 {
                -d
            } else {
                d
            }
        });
        assert_eq!(s1.entries, s2.entries);
        let pattern = SymmetricPattern::new(s1.n, &s1.entries).unwrap();
        let f1 = LbltFactor::factorize(&pattern, &s1.values).unwrap();
        let f2 = LbltFactor::factorize(&pattern, &s2.values).unwrap();
        eprintln!(
            "reuse: inertia {} (expected {e1}), {} (expected {e2})",
            f1.inertia(),
            f2.inertia()
        );
        assert_eq!((f1.inertia(), f2.inertia()), (e1, e2));
        // Shifts K(σ) = [[H − σI, Aᵀ], [A, 0]] on the banded KKT, against dense eigenvalues.
        let (s, _) = banded_kkt(40, &[7], 5);
        let nv = |i: usize| i % 15 < 9;
        let pattern = SymmetricPattern::new(s.n, &s.entries).unwrap();
        for sigma in [-1.0, 0.5, 2.0, 6.0] {
            let mut vals = s.values.clone();
            for (k, &(i, j)) in s.entries.iter().enumerate() {
                if i == j && nv(i) {
                    vals[k] -= sigma;
                }
            }
            let f = LbltFactor::factorize(&pattern, &vals).unwrap();
            let (expected, min_nonzero, _) = dense_inertia(&dense(s.n, &s.entries, &vals), 1e-10);
            eprintln!(
                "shift σ = {sigma}: inertia {} (dense {expected}, min |λ|/‖K‖ = {min_nonzero:.1e}), berr = {:.1e}",
                f.inertia(),
                f.backward_error()
            );
            assert_eq!(f.inertia(), expected);
        }
    }

    #[test]
    fn input_errors() {
        assert_eq!(
            SymmetricPattern::new(0, &[]).unwrap_err(),
            InertiaError::Empty
        );
        assert!(matches!(
            SymmetricPattern::new(3, &[(0, 0), (3, 1)]),
            Err(InertiaError::IndexOutOfBounds { index: 1, .. })
        ));
        let pattern = SymmetricPattern::new(3, &[(0, 0), (1, 0), (2, 2), (1, 1)]).unwrap();
        assert!(matches!(
            LbltFactor::factorize(&pattern, &[1.0, 2.0]),
            Err(InertiaError::LengthMismatch { .. })
        ));
        assert!(matches!(
            LbltFactor::factorize(&pattern, &[1.0, f64::NAN, 1.0, 1.0]),
            Err(InertiaError::NonFiniteValue { index: 1, .. })
        ));
        // The entry is named in the upper triangle, whichever triangle it was given in; the
        // diagonal ones and the last one too (the pattern keeps positions, not the list).
        for (index, row, col) in [(0, 0, 0), (1, 0, 1), (2, 2, 2), (3, 1, 1)] {
            let mut values = [1.0; 4];
            values[index] = f64::INFINITY;
            let err = LbltFactor::factorize(&pattern, &values).unwrap_err();
            assert_eq!(
                err,
                InertiaError::NonFiniteValue {
                    index,
                    row,
                    col,
                    value: f64::INFINITY
                }
            );
        }
        // Finite values whose duplicates sum to infinity: the first entry at that position.
        let doubled = SymmetricPattern::new(2, &[(0, 0), (1, 0), (0, 1), (1, 1)]).unwrap();
        assert!(matches!(
            LbltFactor::factorize(&doubled, &[1.0, f64::MAX, f64::MAX, 1.0]),
            Err(InertiaError::NonFiniteValue {
                index: 1,
                row: 0,
                col: 1,
                ..
            })
        ));
        // [[1, 2], [2, 1]] ⊕ [-3]: eigenvalues 3, -1, -3; mirrored duplicates are summed.
        let pattern = SymmetricPattern::new(3, &[(0, 0), (1, 0), (0, 1), (2, 2), (1, 1)]).unwrap();
        let f = LbltFactor::factorize(&pattern, &[1.0, 1.5, 0.5, -3.0, 1.0]).unwrap();
        assert_eq!(
            f.inertia(),
            Inertia {
                positive: 1,
                negative: 2,
                zero: 0
            }
        );
        let msg = InertiaError::Unreliable {
            backward_error: 1e-3,
            contraction: 3.0,
            refinement_steps: 2,
            min_pivot_ratio: 1e-17,
            max_abs_l: 1e12,
        }
        .to_string();
        eprintln!("example error message: {msg}");
    }

    #[test]
    fn explicit_zero_diagonal_in_pattern() {
        // The (2,2) block of a KKT matrix given as explicit zeros instead of being omitted: no
        // pairing happens, so the constraint rows rely on intranode pivoting alone. The result
        // must be right or an error, never a wrong inertia.
        let mut accepted = 0;
        for seed in 0..6u64 {
            let (mut s, expected) = random_kkt(100, 40, &[3], 100 + seed);
            for i in 100..140 {
                s.push(i, i, 0.0);
            }
            let pattern = SymmetricPattern::new(s.n, &s.entries).unwrap();
            match LbltFactor::factorize(&pattern, &s.values) {
                Ok(f) => {
                    accepted += 1;
                    assert_eq!(f.inertia(), expected);
                }
                Err(e) => eprintln!("explicit zero diagonal, seed {seed}: {e}"),
            }
            // Analysed with representative values: the zero diagonal entries are paired.
            let pattern = SymmetricPattern::with_values(s.n, &s.entries, &s.values).unwrap();
            assert_eq!(pattern.n_pivot_groups(), 40);
            let f = LbltFactor::factorize(&pattern, &s.values).unwrap();
            assert_eq!(f.inertia(), expected);
        }
        eprintln!(
            "explicit zero diagonal: {accepted}/6 factorizations accepted with `new` (all \
             correct); 6/6 correct with `with_values`"
        );
    }

    #[test]
    fn tiny_unpaired_pivots_are_caught() {
        // (2,2) block given as −δ I with tiny δ (present in the pattern, so not paired): the
        // constraint rows are pivots of size δ with huge multipliers. Right or error, never
        // wrong.
        for (k, delta) in [1e-6, 1e-10, 1e-14, 1e-18].into_iter().enumerate() {
            let (mut s, _) = random_kkt(100, 40, &[3], 200 + k as u64);
            for i in 100..140 {
                s.push(i, i, -delta);
            }
            ok_or_error(
                &format!("KKT with (2,2) = -{delta:e} I, not paired"),
                &s,
                1e-10,
            );
        }
    }
}
