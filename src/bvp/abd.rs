//! Structured factorisation (elimination, with orthogonal reduction as its fallback) of the
//! bordered almost-block-diagonal Newton matrix.
//!
//! The condensed collocation matrix (see [`linear`](super::linear)) has `N` interval block
//! rows `[A_i B_i | P_i]` coupling `y_i`, `y_{i+1}` and the `k` parameters, and `n + k`
//! boundary rows `[G_a . G_b | G_p]` coupling `y_0`, `y_N` and `p`. Two layouts serve it.
//!
//! # Separated boundary rows (the first choice)
//!
//! When every boundary row touches `y_0` or `y_N` but not both (the `n_a` rows at `a`, the
//! `n + k - n_a` others; Suslov's problem has `n_a = n / 2`), the matrix with the rows at `a`
//! first, then the interval rows, then the rest, is almost block diagonal in the classical
//! sense (SOLVEBLOK, de Boor & Weiss 1980): the columns of `y_t` meet only the `n_a` rows
//! carried from the left and the `n` rows of interval `t`. So `y_0, y_1, .., y_{N-1}` are
//! eliminated one node at a time, each from a block of `n_a + n` rows and `2n + k` columns
//! `[y_t | y_{t+1} | p]`, and the `n_a` rows left over are carried; the last block, of order
//! `n + k` in `(y_N, p)`, is the carried rows over the rows at `b`. Because the pivot of a
//! column is chosen among all the rows where that column is nonzero, this is Gaussian
//! elimination with partial pivoting of the whole (reordered) matrix, only with the zeros
//! skipped; there is no `y_0` border, so a block has about half the arithmetic of the
//! general layout's. Elimination with partial pivoting is not unconditionally stable here
//! either (Wright 1993 has separated examples), so the same growth and pivot checks apply,
//! and a factorisation that fails them is redone in the general layout below.
//!
//! # General boundary rows
//!
//! When some row couples `y_0` and `y_N` (periodic conditions, say), the interior nodes are
//! eliminated one at a time by *structured
//! QR* (Wright, 1992): after eliminating `y_1 .. y_{t-1}` there are `n` "carried" rows that
//! involve only `y_0`, `y_t` and `p`; stacked on the rows of interval `t` they form a
//! `2n`-row block whose `y_t` columns are reduced by `n` Householder reflections. The top
//! `n` rows become the rows of `R` that determine `y_t`; the bottom `n` rows, free of `y_t`,
//! are carried to the next interval:
//!
//! ```text
//!           y_t    y_{t+1}   y_0    p                        y_t    y_{t+1}   y_0    p
//! carried | F    |  0      | E    | Q  |     Q_t^T     R rows | R_tt | R_t,t+1 | R_t0 | R_tp |
//! Phi_t   | A_t  |  B_t    | 0    | P_t|   -------->  carried |  0   | F'      | E'   | Q'   |
//! ```
//!
//! What remains after `y_{N-1}` is a dense square block of order `2n + k` in `(y_0, y_N, p)`
//! (the last carried rows over the boundary rows), reduced by Householder QR as well. Work
//! is `O(N n^2 (n + k))`, the only fill is in the border columns `y_0` and `p` (which the
//! block rows have anyway), storage is one `2n x (3n + k)` block per interval, and nothing
//! is allocated after `BorderedAbd::new`.
//!
//! Each `2n`-row block is first reduced by Gaussian elimination with partial pivoting
//! inside the block (*structured elimination*, Wright 1992: the same carried-row scheme, `n`
//! eliminations instead of `n` reflections, about half the arithmetic). That can amplify
//! rounding errors on some well-conditioned boundary value problems (Wright 1993: pivoting
//! restricted to the block order can keep picking the carried rows while the border
//! columns grow geometrically), which orthogonal transformations cannot. So the elimination
//! watches its growth and is abandoned for Householder QR of the same blocks when the
//! growth exceeds `LU_GROWTH_LIMIT` (1e3) or a pivot falls below `LU_MIN_PIVOT` (1e-10) relative to
//! its column (or is zero); `BorderedAbd::method` says which reduction the factors are.
//! Because QR is not invariant under row scaling (nor is the choice of pivots), the matrix
//! is row-equilibrated first: every row is divided by its largest entry (so a boundary
//! condition written in other units changes nothing), and `BorderedAbd::factor` factors
//! `D J` with `D = diag(1 / max_j |J_rj|)`. The scaled factorisation is exposed as well: the
//! condition estimate of the Newton matrix is taken for `D J`.
//!
//! The factorisation reports its growth: the largest ratio, over the columns, of an entry of
//! the triangular factor (`R` or `U`; for elimination also of every carried row, which are
//! intermediate results) to the 2-norm of that column of `D J`. Column `j` of `R` is `Q^T`
//! applied to column `j` of `D J`, so for the orthogonal reduction the ratio is at most 1
//! (up to rounding) whatever the matrix; above that means a bug, not an unlucky matrix. For
//! elimination it is the growth factor measured the same way: unbounded in principle, at most
//! `LU_GROWTH_LIMIT` (1e3) when elimination is kept (either layout).
//! It also reports the smallest pivot relative to its column, `min_j |U_jj| /
//! ||(D J)_j||_2` (`R_jj` for QR: the part of a column independent of the columns before
//! it): small when the matrix is near singular.
//!
//! # References
//! * C. de Boor, R. Weiss, *SOLVEBLOK: a package for solving almost block diagonal linear
//!   systems*, ACM Trans. Math. Software 6 (1980) 80-87.
//! * S. J. Wright, *Stable parallel algorithms for two-point boundary value problems*, SIAM
//!   J. Sci. Stat. Comput. 13 (1992) 742-764 (structured QR and structured elimination).
//! * S. J. Wright, *A collection of problems for which Gaussian elimination with partial
//!   pivoting is unstable*, SIAM J. Sci. Comput. 14 (1993) 231-238.
//! * U. Ascher, R. Mattheij, R. Russell, *Numerical Solution of Boundary Value Problems for
//!   Ordinary Differential Equations*, SIAM 1995, ch. 7 (almost block diagonal systems).

use super::dense::{abs_max, avx2, axpy, dot};

/// The reduction behind a factorisation (`BorderedAbd::method`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Factorization {
    /// Gaussian elimination with partial pivoting inside every `2n`-row block.
    #[default]
    StructuredLu,
    /// Householder QR of every `2n`-row block (the fallback).
    StructuredQr,
    /// Boundary conditions separated (every boundary row touches `y_0` or `y_N`, not both):
    /// Gaussian elimination with partial pivoting of the matrix with the rows at `a` first,
    /// which eliminates `y_0 .. y_{N-1}` in blocks of `n_a + n` rows and `2n + k` columns
    /// (no `y_0` border). The first choice when the rows are separated.
    SeparatedLu,
}

impl Factorization {
    /// A short name for reports: `"structured LU"` or `"structured QR"`.
    pub fn name(self) -> &'static str {
        match self {
            Factorization::StructuredLu => "structured LU",
            Factorization::StructuredQr => "structured QR",
            Factorization::SeparatedLu => "separated LU",
        }
    }
}

/// Elimination whose growth (largest reduced entry over its column's 2-norm) exceeds this
/// is abandoned for the orthogonal reduction: it would cost up to that factor in backward
/// error, against QR's bound of 1.
pub(crate) const LU_GROWTH_LIMIT: f64 = 1e3;

/// Elimination whose smallest pivot relative to its column is below this is abandoned for
/// the orthogonal reduction (whose pivots then say how near singular the matrix is).
pub(crate) const LU_MIN_PIVOT: f64 = 1e-10;

/// Why a factorisation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum AbdError {
    /// A row is zero or not finite (before scaling), or a diagonal entry of `R` vanished or is
    /// not finite: the matrix is singular (to working precision) or contains NaN/inf.
    Singular,
}

/// The block layout of a factorisation: how many rows are carried from block to block and
/// how wide the `y_0` border is (which also says which node the first block eliminates:
/// [`Shape::first_node`]).
///
/// * General boundary rows: `nc = n` carried rows (interval 0's rows to begin with), a
///   border of `bw = n` columns (`y_0`), blocks eliminating `y_1 .. y_{N-1}` (`t0 = 1`); the
///   last block has order `2n + k` in `(y_0, y_N, p)`.
/// * Separated boundary rows: `nc = n_a` carried rows (the `n_a` rows at `a` to begin with),
///   no border (`bw = 0`), blocks eliminating `y_0 .. y_{N-1}` (`t0 = 0`); the last block has
///   order `n + k` in `(y_N, p)`: the carried rows over the `n + k - n_a` rows at `b`.
///
/// A block has `nc + n` rows and `2n + bw + k` columns `[y_t | y_{t+1} | y_0 (bw) | p]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Shape {
    nc: usize,
    bw: usize,
}

impl Shape {
    fn general(n: usize) -> Self {
        Shape { nc: n, bw: n }
    }

    /// The node the first block eliminates, `t0`: `y_1` with the `y_0` border (interval 0's
    /// rows are the first carried rows), `y_0` without it.
    fn first_node(self) -> usize {
        usize::from(self.bw > 0)
    }
}

/// The factorisation of one bordered ABD matrix of `N` interval blocks of `n` rows and
/// `2n + k` columns plus `n + k` boundary rows (sizes fixed at construction).
#[derive(Debug, Clone)]
pub(crate) struct BorderedAbd {
    n: usize,
    k: usize,
    /// Number of interval blocks `N` (`m - 1`).
    intervals: usize,
    /// `D`: the reciprocal of every row's largest entry.
    row_scale: Vec<f64>,
    /// The layout of the current factorisation.
    shape: Shape,
    /// The boundary rows (indices among the `n + k`) that start the elimination as its first
    /// carried rows (separated: the rows at `a`; general: none, interval 0's rows start it).
    bc_first: Vec<usize>,
    /// The boundary rows of the last block, in order (separated: the rows at `b`; general:
    /// all `n + k`).
    bc_last: Vec<usize>,
    /// One column-major `(nc + n) x (2n + bw + k)` block per eliminated node (see [`Shape`]):
    /// the top `n` rows are rows of `R` (upper triangle in the `y_t` columns), below the
    /// diagonal of the `y_t` columns are the Householder vectors (QR) or the multipliers
    /// (LU), and the bottom `nc` rows of the other columns are the carried rows.
    steps: Vec<f64>,
    /// Householder scalars of every step (`n` each; QR).
    taus: Vec<f64>,
    /// Row interchanges of every step (`n` each, rows of the block; LU).
    pivots: Vec<usize>,
    /// The final column-major block of order `n + bw + k` in `(y_0 (bw), y_N, p)`.
    last: Vec<f64>,
    last_taus: Vec<f64>,
    last_pivots: Vec<usize>,
    /// The reduction of the last successful factorisation.
    method: Factorization,
    /// Whether to try structured LU first (tests switch it off to compare with QR).
    try_lu: bool,
    /// Whether to try the separated layout when the boundary rows allow it (tests switch it
    /// off to compare the layouts).
    try_separated: bool,
    /// `max_ij |R_ij| / ||(D J)_j||_2` of the last factorisation.
    growth: f64,
    /// `min_j |R_jj| / ||(D J)_j||_2` of the last factorisation.
    min_pivot: f64,
    /// Squared column norms of `D J`, columns ordered `y_0 .. y_N, p`.
    col_norm2: Vec<f64>,
    /// Their reciprocal square roots (`1 / ||(D J)_j||_2`).
    col_inv_norm: Vec<f64>,
    factored: bool,
    /// Workspaces of the solves (`2n + k` and `n + k`).
    active: Vec<f64>,
    border: Vec<f64>,
    /// Workspace of [`Self::solve_scaled_multi_in_place`] (grown on demand, kept).
    multi: Vec<f64>,
}

impl BorderedAbd {
    /// Storage for `intervals >= 1` blocks of `n` states and `k` parameters.
    pub fn new(n: usize, k: usize, intervals: usize) -> Self {
        let s = 2 * n;
        let cols = 3 * n + k;
        let q = 2 * n + k;
        // The general layout's blocks; the separated layout's fit in that storage whenever
        // `n_a <= n` (more rows at `a` than states grow it on first use).
        let eliminated = intervals.saturating_sub(1);
        Self {
            n,
            k,
            intervals,
            row_scale: vec![0.0; intervals * n + n + k],
            shape: Shape::general(n),
            bc_first: Vec::with_capacity(n + k),
            bc_last: Vec::with_capacity(n + k),
            steps: vec![0.0; (eliminated * s * cols).max(intervals * (2 * n) * (2 * n + k))],
            taus: vec![0.0; intervals * n],
            pivots: vec![0; intervals * n],
            last: vec![0.0; q * q],
            last_taus: vec![0.0; q],
            last_pivots: vec![0; q],
            method: Factorization::StructuredLu,
            try_lu: true,
            try_separated: true,
            growth: f64::NAN,
            min_pivot: f64::NAN,
            col_norm2: vec![0.0; (intervals + 1) * n + k],
            col_inv_norm: vec![0.0; (intervals + 1) * n + k],
            factored: false,
            active: vec![0.0; q],
            border: vec![0.0; n + k],
            multi: Vec::new(),
        }
    }

    /// Order of the matrix, `(N + 1) n + k`.
    #[cfg(test)]
    pub fn order(&self) -> usize {
        (self.intervals + 1) * self.n + self.k
    }

    /// The row scaling `D` of the last factorisation.
    pub fn row_scale(&self) -> &[f64] {
        &self.row_scale
    }

    /// The reduction of the last successful factorisation.
    pub fn method(&self) -> Factorization {
        self.method
    }

    /// Whether [`factor`](Self::factor) tries elimination first (default); `false` forces
    /// the orthogonal reduction.
    #[cfg(test)]
    pub fn set_try_lu(&mut self, on: bool) {
        self.try_lu = on;
    }

    /// Whether [`factor`](Self::factor) uses the separated layout when the boundary rows are
    /// separated (default); `false` forces the general layout.
    #[cfg(test)]
    pub fn set_try_separated(&mut self, on: bool) {
        self.try_separated = on;
    }

    /// Growth of the last successful factorisation: `max_ij |R_ij| / ||(D J)_j||_2` (at most
    /// 1 up to rounding; NaN before a factorisation).
    pub fn growth(&self) -> f64 {
        self.growth
    }

    /// Smallest pivot of the last successful factorisation relative to its column:
    /// `min_j |R_jj| / ||(D J)_j||_2` (in (0, 1]; `|R_jj|` is the part of column `j` not in
    /// the span of the columns eliminated before it, so a small value means a column nearly
    /// dependent on earlier ones: a matrix near singular. NaN before a factorisation).
    pub fn min_pivot(&self) -> f64 {
        self.min_pivot
    }

    /// Factor the matrix given by `values`: the `N` interval blocks `[A_i B_i P_i]`
    /// (row-major `n x (2n + k)` each), then the boundary block `[G_a G_b G_p]` (row-major
    /// `(n + k) x (2n + k)`).
    pub fn factor(&mut self, values: &[f64]) -> Result<(), AbdError> {
        avx2!(fn(this: &mut BorderedAbd, values: &[f64]) -> Result<(), AbdError> {
            this.factor_impl(values)
        }, self, values)
    }

    #[inline(always)]
    fn factor_impl(&mut self, values: &[f64]) -> Result<(), AbdError> {
        self.factored = false;
        let (n, k, nn) = (self.n, self.k, self.intervals);
        let wc = 2 * n + k;
        debug_assert_eq!(values.len(), (nn * n + n + k) * wc);
        for (d, row) in self.row_scale.iter_mut().zip(values.chunks_exact(wc)) {
            // `bad` is NaN when an entry is infinite or NaN (`v * 0`).
            let (max, bad) = abs_max(row);
            if max == 0.0 || !max.is_finite() || bad.is_nan() {
                return Err(AbdError::Singular);
            }
            *d = 1.0 / max;
        }
        let po = (nn + 1) * n;
        let col_norm2 = &mut self.col_norm2;
        col_norm2.fill(0.0);
        // Row by row, in order (the interval blocks' rows, then the boundary rows).
        let (blocks, boundary) = values.split_at(nn * n * wc);
        for (i, (block, scale)) in blocks
            .chunks_exact(n * wc)
            .zip(self.row_scale.chunks_exact(n))
            .enumerate()
        {
            for (row, d) in block.chunks_exact(wc).zip(scale) {
                let d2 = d * d;
                add_squares(&mut col_norm2[i * n..(i + 1) * n], &row[..n], d2);
                add_squares(&mut col_norm2[(i + 1) * n..(i + 2) * n], &row[n..2 * n], d2);
                add_squares(&mut col_norm2[po..po + k], &row[2 * n..], d2);
            }
        }
        for (r, row) in boundary.chunks_exact(wc).enumerate() {
            let d2 = self.row_scale[nn * n + r] * self.row_scale[nn * n + r];
            add_squares(&mut col_norm2[..n], &row[..n], d2);
            add_squares(&mut col_norm2[nn * n..(nn + 1) * n], &row[n..2 * n], d2);
            add_squares(&mut col_norm2[po..po + k], &row[2 * n..], d2);
        }
        for (inv, norm2) in self.col_inv_norm.iter_mut().zip(col_norm2.iter()) {
            *inv = 1.0 / norm2.sqrt();
        }
        // Separated boundary rows: the rows touching only y_0 (and p) start the elimination,
        // all others (touching y_N, or only p) end it.
        let separated = self.try_separated
            && boundary.chunks_exact(wc).all(|row| {
                row[..n].iter().all(|v| *v == 0.0) || row[n..2 * n].iter().all(|v| *v == 0.0)
            });
        let acceptable =
            |this: &Self| this.growth <= LU_GROWTH_LIMIT && this.min_pivot >= LU_MIN_PIVOT;
        if self.try_lu && separated {
            self.bc_first.clear();
            self.bc_last.clear();
            for (r, row) in boundary.chunks_exact(wc).enumerate() {
                if row[n..2 * n].iter().all(|v| *v == 0.0) && row[..n].iter().any(|v| *v != 0.0) {
                    self.bc_first.push(r);
                } else {
                    self.bc_last.push(r);
                }
            }
            let nc = self.bc_first.len();
            let need = nn * (nc + n) * (2 * n + k);
            if self.steps.len() < need {
                self.steps.resize(need, 0.0);
            }
            self.shape = Shape { nc, bw: 0 };
            if self.sweep_sized(values, Factorization::SeparatedLu).is_ok() && acceptable(self) {
                self.method = Factorization::SeparatedLu;
                self.factored = true;
                return Ok(());
            }
        }
        // The general layout: elimination first; orthogonal reduction if it grows or meets a
        // tiny or zero pivot.
        self.shape = Shape::general(n);
        self.bc_first.clear();
        self.bc_last.clear();
        self.bc_last.extend(0..n + k);
        if self.try_lu
            && self
                .sweep_sized(values, Factorization::StructuredLu)
                .is_ok()
            && acceptable(self)
        {
            self.method = Factorization::StructuredLu;
        } else {
            self.sweep_sized(values, Factorization::StructuredQr)?;
            self.method = Factorization::StructuredQr;
        }
        self.factored = true;
        Ok(())
    }

    /// [`sweep`](Self::sweep) with the common dimensions as constants (fixed trip counts in
    /// the inlined kernels; the same operations, so the same bits).
    #[inline(always)]
    fn sweep_sized(&mut self, values: &[f64], method: Factorization) -> Result<(), AbdError> {
        // Suslov's conditions: n / 2 rows at a (Omega and the natural condition on xi).
        match (self.n, self.k, self.shape.nc, self.shape.bw) {
            (12, 1, 12, 12) => self.sweep(values, method, 12, 1, 12, 12),
            (12, 1, 6, 0) => self.sweep(values, method, 12, 1, 6, 0),
            (24, 1, 24, 24) => self.sweep(values, method, 24, 1, 24, 24),
            (24, 1, 12, 0) => self.sweep(values, method, 24, 1, 12, 0),
            (n, k, nc, bw) => self.sweep(values, method, n, k, nc, bw),
        }
    }

    /// Reduce the row-scaled matrix (`row_scale`, `col_norm2`, `shape` and the boundary row
    /// lists are set) by `method`; sets `growth` and `min_pivot`. Elimination stops early
    /// (with an error) once its growth exceeds `LU_GROWTH_LIMIT` (1e3).
    #[inline(always)]
    fn sweep(
        &mut self,
        values: &[f64],
        method: Factorization,
        n: usize,
        k: usize,
        nc: usize,
        bw: usize,
    ) -> Result<(), AbdError> {
        debug_assert_eq!((nc, bw), (self.shape.nc, self.shape.bw));
        let nn = self.intervals;
        let lu = method != Factorization::StructuredQr;
        let t0 = self.shape.first_node();
        let wc = 2 * n + k;
        let po = (nn + 1) * n;
        let s = nc + n;
        let pc = 2 * n + bw;
        let cols = pc + k;
        let block = s * cols;
        let mut growth = 0.0_f64;
        let mut min_pivot = f64::INFINITY;
        let col_inv_norm = &self.col_inv_norm;
        let row_scale = &self.row_scale;
        // max_i |col_i| / ||(D J)_j||.
        let ratio = |col: &[f64], j: usize| {
            let m = abs_max(col).0;
            if m == 0.0 {
                0.0
            } else {
                m * col_inv_norm[j]
            }
        };
        // Scaled entry (r, c) of the block row of interval i, and of boundary row r.
        let entry =
            |i: usize, r: usize, c: usize| values[(i * n + r) * wc + c] * row_scale[i * n + r];
        let boundary = |r: usize, c: usize| {
            let row = nn * n + r;
            values[row * wc + c] * row_scale[row]
        };
        for t in t0..nn {
            let idx = t - t0;
            let (done, rest) = self.steps.split_at_mut(idx * block);
            let step = &mut rest[..block];
            // Zero blocks: y_{t+1} in the carried rows, y_0 in interval t's rows.
            for c in n..2 * n {
                step[c * s..c * s + nc].fill(0.0);
            }
            for c in 2 * n..pc {
                step[c * s + nc..(c + 1) * s].fill(0.0);
            }
            // Top rows: the carried rows (to begin with, interval 0 itself, or the rows at a).
            if idx == 0 && bw > 0 {
                for r in 0..n {
                    for c in 0..n {
                        step[c * s + r] = entry(0, r, n + c); // y_1: B_0
                        step[(2 * n + c) * s + r] = entry(0, r, c); // y_0: A_0
                    }
                    for c in 0..k {
                        step[(pc + c) * s + r] = entry(0, r, 2 * n + c);
                    }
                }
            } else if idx == 0 {
                for (r, &b) in self.bc_first.iter().enumerate() {
                    for c in 0..n {
                        step[c * s + r] = boundary(b, c); // y_0: G_a
                    }
                    for c in 0..k {
                        step[(pc + c) * s + r] = boundary(b, 2 * n + c);
                    }
                }
            } else {
                let prev = &done[(idx - 1) * block..];
                for r in 0..nc {
                    for c in 0..n {
                        step[c * s + r] = prev[(n + c) * s + n + r];
                    }
                    for c in 2 * n..cols {
                        step[c * s + r] = prev[c * s + n + r];
                    }
                }
            }
            // Bottom rows: interval t.
            for r in 0..n {
                for c in 0..n {
                    step[c * s + nc + r] = entry(t, r, c); // y_t: A_t
                    step[(n + c) * s + nc + r] = entry(t, r, n + c); // y_{t+1}: B_t
                }
                for c in 0..k {
                    step[(pc + c) * s + nc + r] = entry(t, r, 2 * n + c);
                }
            }
            if lu {
                lu_panel(step, s, n, cols, &mut self.pivots[idx * n..(idx + 1) * n])?;
            } else {
                householder_qr(step, s, n, cols, &mut self.taus[idx * n..(idx + 1) * n])?;
            }
            // Growth: the rows of R (U), and for elimination also the carried rows (they
            // are intermediate results, which an orthogonal reduction keeps bounded anyway).
            let rows = if lu { s } else { n };
            for c in 0..cols {
                let (top, j) = if c < n {
                    (c + 1, t * n + c)
                } else if c < 2 * n {
                    (rows, (t + 1) * n + c - n)
                } else if c < pc {
                    (rows, c - 2 * n)
                } else {
                    (rows, po + c - pc)
                };
                growth = growth.max(ratio(&step[c * s..c * s + top], j));
                if c < n {
                    min_pivot = min_pivot.min(step[c * s + c].abs() * col_inv_norm[j]);
                }
            }
            if lu && (growth > LU_GROWTH_LIMIT || growth.is_nan()) {
                return Err(AbdError::Singular);
            }
        }
        // The last block: carried rows over the boundary rows that end the elimination,
        // columns (y_0 (bw), y_N, p).
        let q = n + bw + k;
        let last = &mut self.last;
        for r in 0..nc {
            if nn == t0 {
                // General layout on one interval: nothing eliminated, interval 0 is carried.
                for c in 0..n {
                    last[c * q + r] = entry(0, r, c);
                    last[(n + c) * q + r] = entry(0, r, n + c);
                }
                for c in 0..k {
                    last[(2 * n + c) * q + r] = entry(0, r, 2 * n + c);
                }
            } else {
                let prev = &self.steps[(nn - t0 - 1) * block..];
                for c in 0..bw {
                    last[c * q + r] = prev[(2 * n + c) * s + n + r];
                }
                for c in 0..n {
                    last[(bw + c) * q + r] = prev[(n + c) * s + n + r];
                }
                for c in 0..k {
                    last[(bw + n + c) * q + r] = prev[(pc + c) * s + n + r];
                }
            }
        }
        // A boundary row's columns (y_0, y_N, p) from its y_0 part on (general) or from its
        // y_N part on (separated: its y_0 part is zero).
        let from = n - bw;
        for (i, &b) in self.bc_last.iter().enumerate() {
            for c in 0..q {
                last[c * q + nc + i] = boundary(b, from + c);
            }
        }
        if lu {
            lu_panel(last, q, q, q, &mut self.last_pivots[..q])?;
        } else {
            householder_qr(last, q, q, q, &mut self.last_taus[..q])?;
        }
        for c in 0..q {
            let j = if c < bw {
                c
            } else if c < bw + n {
                nn * n + c - bw
            } else {
                po + c - bw - n
            };
            growth = growth.max(ratio(&last[c * q..c * q + c + 1], j));
            min_pivot = min_pivot.min(last[c * q + c].abs() * col_inv_norm[j]);
        }
        self.growth = growth;
        self.min_pivot = min_pivot;
        Ok(())
    }

    /// Solve `J x = b` in place (`b` ordered by rows: interval blocks, then boundary rows;
    /// `x` by columns: `y_0 .. y_N`, then `p`). Returns `false` without a factorisation.
    pub fn solve_in_place(&mut self, b: &mut [f64]) -> bool {
        if !self.factored {
            return false;
        }
        for (v, d) in b.iter_mut().zip(&self.row_scale) {
            *v *= d;
        }
        self.solve_scaled_in_place(b)
    }

    /// Solve `(D J) x = b` in place (the row-equilibrated matrix).
    pub fn solve_scaled_in_place(&mut self, x: &mut [f64]) -> bool {
        avx2!(fn(this: &mut BorderedAbd, x: &mut [f64]) -> bool {
            // The common sizes as constants (as in `sweep_sized`; the same bits).
            match (this.n, this.k, this.shape.nc, this.shape.bw) {
                (12, 1, 12, 12) => this.solve_scaled_impl(x, 12, 1, 12, 12),
                (12, 1, 6, 0) => this.solve_scaled_impl(x, 12, 1, 6, 0),
                (24, 1, 24, 24) => this.solve_scaled_impl(x, 24, 1, 24, 24),
                (24, 1, 12, 0) => this.solve_scaled_impl(x, 24, 1, 12, 0),
                (n, k, nc, bw) => this.solve_scaled_impl(x, n, k, nc, bw),
            }
        }, self, x)
    }

    #[inline(always)]
    fn solve_scaled_impl(
        &mut self,
        x: &mut [f64],
        n: usize,
        k: usize,
        nc: usize,
        bw: usize,
    ) -> bool {
        debug_assert_eq!(
            (n, k, nc, bw),
            (self.n, self.k, self.shape.nc, self.shape.bw)
        );
        if !self.factored {
            return false;
        }
        let nn = self.intervals;
        let t0 = self.shape.first_node();
        let s = nc + n;
        let pc = 2 * n + bw;
        let block = s * (pc + k);
        let q = n + bw + k;
        let qr = self.method == Factorization::StructuredQr;
        let v = &mut self.active;
        // Forward: apply every step's eliminations (reflections) to [carried; b of interval
        // t], the carried rows being interval 0's or the rows at a to begin with.
        if bw > 0 {
            v[..n].copy_from_slice(&x[..n]);
        } else {
            for (vr, &b) in v.iter_mut().zip(&self.bc_first) {
                *vr = x[nn * n + b];
            }
        }
        for t in t0..nn {
            let idx = t - t0;
            let step = &self.steps[idx * block..(idx + 1) * block];
            v[nc..s].copy_from_slice(&x[t * n..(t + 1) * n]);
            if qr {
                apply_qt(step, s, n, &self.taus[idx * n..(idx + 1) * n], &mut v[..s]);
            } else {
                apply_lu(
                    step,
                    s,
                    n,
                    &self.pivots[idx * n..(idx + 1) * n],
                    &mut v[..s],
                );
            }
            x[t * n..(t + 1) * n].copy_from_slice(&v[..n]);
            v.copy_within(n..s, 0);
        }
        // The last block: [carried; boundary rows at the end] -> (y_0 (bw), y_N, p).
        for (i, &b) in self.bc_last.iter().enumerate() {
            v[nc + i] = x[nn * n + b];
        }
        if qr {
            apply_qt(&self.last, q, q, &self.last_taus, &mut v[..q]);
        } else {
            apply_lu(&self.last, q, q, &self.last_pivots, &mut v[..q]);
        }
        solve_upper(&self.last, q, q, &mut v[..q]);
        x[..bw].copy_from_slice(&v[..bw]);
        x[nn * n..nn * n + n + k].copy_from_slice(&v[bw..q]);
        // Back substitution for y_{N-1} .. y_t0: R_tt y_t = c_t - R_t,t+1 y_{t+1} - R_t0 y_0
        // - R_tp p.
        let border = &mut self.border;
        border[..bw].copy_from_slice(&x[..bw]);
        border[bw..bw + k].copy_from_slice(&x[(nn + 1) * n..(nn + 1) * n + k]);
        for t in (t0..nn).rev() {
            let idx = t - t0;
            let step = &self.steps[idx * block..(idx + 1) * block];
            let (head, tail) = x.split_at_mut((t + 1) * n);
            let c = &mut head[t * n..];
            let next = &tail[..n];
            for j in 0..n {
                let col = &step[(n + j) * s..(n + j) * s + n];
                axpy(c, -next[j], col);
                if j < bw {
                    let col = &step[(2 * n + j) * s..(2 * n + j) * s + n];
                    axpy(c, -border[j], col);
                }
            }
            for j in 0..k {
                let col = &step[(pc + j) * s..(pc + j) * s + n];
                axpy(c, -border[bw + j], col);
            }
            solve_upper(step, s, n, c);
        }
        x.iter().all(|v| v.is_finite())
    }

    /// Solve `(D J) X = B` in place for `r` right-hand sides at once: `x` is row-major
    /// `order x r` (`x[i * r + c]` is entry `i` of column `c`), each column ordered as in
    /// [`Self::solve_scaled_in_place`]. Every column goes through the operations of that
    /// solve in the same order (so gets the same values, up to the sign of a zero), but each
    /// block of the factorisation is read once for all columns and the inner loops run
    /// along the columns.
    ///
    /// With `zero_intervals` the caller promises that the interval rows (all rows before the
    /// boundary rows) of every column are zero: in the general layout the forward sweep,
    /// which would only carry those zeros, is skipped. Returns `false` without a
    /// factorisation or if a result is not finite.
    pub fn solve_scaled_multi_in_place(
        &mut self,
        x: &mut [f64],
        r: usize,
        zero_intervals: bool,
    ) -> bool {
        avx2!(fn(this: &mut BorderedAbd, x: &mut [f64], r: usize, zero_intervals: bool) -> bool {
            match (this.n, this.k, this.shape.nc, this.shape.bw) {
                (12, 1, 12, 12) => this.solve_multi_impl(x, r, zero_intervals, 12, 1, 12, 12),
                (12, 1, 6, 0) => this.solve_multi_impl(x, r, zero_intervals, 12, 1, 6, 0),
                (24, 1, 24, 24) => this.solve_multi_impl(x, r, zero_intervals, 24, 1, 24, 24),
                (24, 1, 12, 0) => this.solve_multi_impl(x, r, zero_intervals, 24, 1, 12, 0),
                (n, k, nc, bw) => this.solve_multi_impl(x, r, zero_intervals, n, k, nc, bw),
            }
        }, self, x, r, zero_intervals)
    }

    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn solve_multi_impl(
        &mut self,
        x: &mut [f64],
        r: usize,
        zero_intervals: bool,
        n: usize,
        k: usize,
        nc: usize,
        bw: usize,
    ) -> bool {
        debug_assert_eq!(
            (n, k, nc, bw),
            (self.n, self.k, self.shape.nc, self.shape.bw)
        );
        let nn = self.intervals;
        debug_assert_eq!(x.len(), ((nn + 1) * n + k) * r);
        if !self.factored || r == 0 {
            return self.factored;
        }
        let t0 = self.shape.first_node();
        let s = nc + n;
        let pc = 2 * n + bw;
        let block = s * (pc + k);
        let q = n + bw + k;
        let qr = self.method == Factorization::StructuredQr;
        let width = s.max(q);
        let need = width * r + (n + k) * r + 5 * r;
        if self.multi.len() < need {
            self.multi.resize(need, 0.0);
        }
        let (v, rest) = self.multi.split_at_mut(width * r);
        let (border, acc) = rest.split_at_mut((n + k) * r);
        let acc = &mut acc[..5 * r];
        // Forward: the eliminations (or reflections) of every step applied to
        // [carried; rows of interval t]; in the general layout, with zero interval rows,
        // everything stays zero (the separated layout carries the rows at a).
        if bw > 0 && zero_intervals {
            v[..n * r].fill(0.0);
        } else {
            if bw > 0 {
                v[..n * r].copy_from_slice(&x[..n * r]);
            } else {
                for (i, &b) in self.bc_first.iter().enumerate() {
                    let row = nn * n + b;
                    v[i * r..(i + 1) * r].copy_from_slice(&x[row * r..(row + 1) * r]);
                }
            }
            for t in t0..nn {
                let idx = t - t0;
                let step = &self.steps[idx * block..(idx + 1) * block];
                v[nc * r..s * r].copy_from_slice(&x[t * n * r..(t + 1) * n * r]);
                if qr {
                    multi_apply_qt(
                        step,
                        s,
                        n,
                        &self.taus[idx * n..(idx + 1) * n],
                        &mut v[..s * r],
                        r,
                        acc,
                    );
                } else {
                    multi_apply_lu(
                        step,
                        s,
                        n,
                        &self.pivots[idx * n..(idx + 1) * n],
                        &mut v[..s * r],
                        r,
                    );
                }
                x[t * n * r..(t + 1) * n * r].copy_from_slice(&v[..n * r]);
                v.copy_within(n * r..s * r, 0);
            }
        }
        // The last block: [carried; boundary rows at the end] -> (y_0 (bw), y_N, p).
        for (i, &b) in self.bc_last.iter().enumerate() {
            let row = nn * n + b;
            v[(nc + i) * r..(nc + i + 1) * r].copy_from_slice(&x[row * r..(row + 1) * r]);
        }
        if qr {
            multi_apply_qt(&self.last, q, q, &self.last_taus, &mut v[..q * r], r, acc);
        } else {
            multi_apply_lu(&self.last, q, q, &self.last_pivots, &mut v[..q * r], r);
        }
        multi_solve_upper(&self.last, q, q, &mut v[..q * r], r);
        x[..bw * r].copy_from_slice(&v[..bw * r]);
        x[nn * n * r..(nn * n + n + k) * r].copy_from_slice(&v[bw * r..q * r]);
        // Back substitution for y_{N-1} .. y_t0, as in the single solve.
        border[..bw * r].copy_from_slice(&x[..bw * r]);
        border[bw * r..(bw + k) * r].copy_from_slice(&x[(nn + 1) * n * r..((nn + 1) * n + k) * r]);
        for t in (t0..nn).rev() {
            let idx = t - t0;
            let step = &self.steps[idx * block..(idx + 1) * block];
            let (head, tail) = x.split_at_mut((t + 1) * n * r);
            let c = &mut head[t * n * r..];
            let next = &tail[..n * r];
            for j in 0..n {
                let col = &step[(n + j) * s..(n + j) * s + n];
                multi_axpy(c, &next[j * r..(j + 1) * r], col, r);
                if j < bw {
                    let col = &step[(2 * n + j) * s..(2 * n + j) * s + n];
                    multi_axpy(c, &border[j * r..(j + 1) * r], col, r);
                }
            }
            for j in 0..k {
                let col = &step[(pc + j) * s..(pc + j) * s + n];
                multi_axpy(c, &border[(bw + j) * r..(bw + j + 1) * r], col, r);
            }
            multi_solve_upper(step, s, n, c, r);
        }
        x.iter().all(|v| v.is_finite())
    }

    /// Solve `(D J)^T x = b` in place (`b` ordered by columns, `x` by rows).
    pub fn solve_scaled_transpose_in_place(&mut self, x: &mut [f64]) -> bool {
        avx2!(fn(this: &mut BorderedAbd, x: &mut [f64]) -> bool {
            this.solve_scaled_transpose_impl(x)
        }, self, x)
    }

    #[inline(always)]
    fn solve_scaled_transpose_impl(&mut self, x: &mut [f64]) -> bool {
        if !self.factored {
            return false;
        }
        let (n, k, nn) = (self.n, self.k, self.intervals);
        let Shape { nc, bw } = self.shape;
        let t0 = self.shape.first_node();
        let s = nc + n;
        let pc = 2 * n + bw;
        let block = s * (pc + k);
        let q = n + bw + k;
        let qr = self.method == Factorization::StructuredQr;
        // R^T w = b, forward over the eliminated nodes: R_tt^T w_t = b_t - R_{t-1,t}^T w_{t-1}.
        for t in t0..nn {
            let idx = t - t0;
            let step = &self.steps[idx * block..(idx + 1) * block];
            let (head, tail) = x.split_at_mut(t * n);
            let w = &mut tail[..n];
            if idx > 0 {
                let prev = &self.steps[(idx - 1) * block..idx * block];
                let wp = &head[(t - 1) * n..];
                for (j, wj) in w.iter_mut().enumerate() {
                    *wj -= dot(&prev[(n + j) * s..(n + j) * s + n], wp);
                }
            }
            solve_upper_transpose(step, s, n, w);
        }
        // The border: b(y_0 (bw), y_N, p) - sum_t R_t,border^T w_t, then R_last^T w_last = that.
        let v = &mut self.active;
        v[..bw].copy_from_slice(&x[..bw]);
        v[bw..q].copy_from_slice(&x[nn * n..nn * n + n + k]);
        for t in t0..nn {
            let idx = t - t0;
            let step = &self.steps[idx * block..(idx + 1) * block];
            let w = &x[t * n..(t + 1) * n];
            for j in 0..bw {
                v[j] -= dot(&step[(2 * n + j) * s..(2 * n + j) * s + n], w);
            }
            for j in 0..k {
                v[bw + n + j] -= dot(&step[(pc + j) * s..(pc + j) * s + n], w);
            }
            if t == nn - 1 {
                for j in 0..n {
                    v[bw + j] -= dot(&step[(n + j) * s..(n + j) * s + n], w);
                }
            }
        }
        solve_upper_transpose(&self.last, q, q, &mut v[..q]);
        // x = Q w: the last block's eliminations (reflections), then every step's in reverse.
        if qr {
            apply_q(&self.last, q, q, &self.last_taus, &mut v[..q]);
        } else {
            apply_lu_transpose(&self.last, q, q, &self.last_pivots, &mut v[..q]);
        }
        for (i, &b) in self.bc_last.iter().enumerate() {
            x[nn * n + b] = v[nc + i];
        }
        for t in (t0..nn).rev() {
            let idx = t - t0;
            let step = &self.steps[idx * block..(idx + 1) * block];
            // [carried_{t-1}; x_t] = Q_t [w_t; carried_t].
            v.copy_within(0..nc, n);
            v[..n].copy_from_slice(&x[t * n..(t + 1) * n]);
            if qr {
                apply_q(step, s, n, &self.taus[idx * n..(idx + 1) * n], &mut v[..s]);
            } else {
                apply_lu_transpose(
                    step,
                    s,
                    n,
                    &self.pivots[idx * n..(idx + 1) * n],
                    &mut v[..s],
                );
            }
            x[t * n..(t + 1) * n].copy_from_slice(&v[nc..s]);
        }
        if bw > 0 {
            x[..n].copy_from_slice(&v[..n]);
        } else {
            for (i, &b) in self.bc_first.iter().enumerate() {
                x[nn * n + b] = v[i];
            }
        }
        x.iter().all(|v| v.is_finite())
    }
}

/// `acc_c += x_c^2 d2` for every `c`.
#[inline(always)]
fn add_squares(acc: &mut [f64], x: &[f64], d2: f64) {
    for (a, v) in acc.iter_mut().zip(x) {
        *a += v * v * d2;
    }
}

/// The offsets of the two node blocks that row `row` of the matrix touches: `y_i` and
/// `y_{i+1}` for a row of interval `i`, `y_0` and `y_N` for a boundary row (the `p` columns
/// come after `y_N` in every row).
pub(crate) fn row_nodes(row: usize, n: usize, intervals: usize) -> (usize, usize) {
    if row < intervals * n {
        let i = row / n;
        (i * n, (i + 1) * n)
    } else {
        (0, intervals * n)
    }
}

/// Householder QR of the first `p` columns of the column-major `rows x cols` matrix `a`
/// (leading dimension `rows`), applied to all `cols` columns (LAPACK's `dgeqr2` + `dorm2r`
/// in one sweep). On return the upper triangle of the first `p` columns is `R`, the
/// reflectors' vectors (with an implicit leading 1) lie below it, `tau[j]` are their
/// scalars. Fails if a diagonal entry of `R` is zero or not finite.
#[inline(always)]
fn householder_qr(
    a: &mut [f64],
    rows: usize,
    p: usize,
    cols: usize,
    tau: &mut [f64],
) -> Result<(), AbdError> {
    for j in 0..p {
        let (left, right) = a.split_at_mut((j + 1) * rows);
        let col = &mut left[j * rows + j..];
        let t = make_reflector(col);
        tau[j] = t;
        if !col[0].is_finite() || col[0].abs() < f64::MIN_POSITIVE {
            return Err(AbdError::Singular); // zero or NaN
        }
        if t != 0.0 {
            let v = &col[1..];
            for c in j + 1..cols {
                let other = &mut right[(c - j - 1) * rows + j..(c - j) * rows];
                let mut w = other[0] + dot(v, &other[1..]);
                w *= t;
                other[0] -= w;
                axpy(&mut other[1..], -w, v);
            }
        }
    }
    Ok(())
}

/// Gaussian elimination with partial pivoting of the first `p` columns of the column-major
/// `rows x cols` matrix `a` (leading dimension `rows`), the pivot of column `j` chosen among
/// rows `j .. rows`, applied to all `cols` columns. On return the upper triangle of the
/// first `p` columns and the first `p` rows of the others are `U`; below the diagonal of
/// column `j` are its multipliers, in the row order at step `j` (`piv[j]` is the row
/// swapped with row `j` at step `j`; earlier columns' multipliers are not swapped, so
/// [`apply_lu`] interleaves the interchanges with the eliminations). Fails if a pivot is
/// zero, subnormal or not finite.
#[inline(always)]
fn lu_panel(
    a: &mut [f64],
    rows: usize,
    p: usize,
    cols: usize,
    piv: &mut [usize],
) -> Result<(), AbdError> {
    for j in 0..p {
        let col = &a[j * rows..(j + 1) * rows];
        let mut best = j;
        let mut best_val = col[j].abs();
        for (r, v) in col.iter().enumerate().skip(j + 1) {
            if v.abs() > best_val {
                best = r;
                best_val = v.abs();
            }
        }
        if best_val < f64::MIN_POSITIVE || !best_val.is_finite() {
            return Err(AbdError::Singular);
        }
        piv[j] = best;
        if best != j {
            for c in j..cols {
                a.swap(c * rows + j, c * rows + best);
            }
        }
        let (left, right) = a.split_at_mut((j + 1) * rows);
        let col = &mut left[j * rows + j..];
        let inv = 1.0 / col[0];
        for v in &mut col[1..] {
            *v *= inv;
        }
        let l = &col[1..];
        for c in j + 1..cols {
            let other = &mut right[(c - j - 1) * rows + j..(c - j) * rows];
            let u = other[0];
            if u != 0.0 {
                axpy(&mut other[1..], -u, l);
            }
        }
    }
    Ok(())
}

/// `v = L^{-1} P v` with the eliminations of the first `p` columns of `a` ([`lu_panel`]).
#[inline(always)]
fn apply_lu(a: &[f64], rows: usize, p: usize, piv: &[usize], v: &mut [f64]) {
    for j in 0..p {
        v.swap(j, piv[j]);
        let vj = v[j];
        if vj != 0.0 {
            axpy(&mut v[j + 1..], -vj, &a[j * rows + j + 1..(j + 1) * rows]);
        }
    }
}

/// `v = (L^{-1} P)^T v`: the transposed eliminations in reverse order.
#[inline(always)]
fn apply_lu_transpose(a: &[f64], rows: usize, p: usize, piv: &[usize], v: &mut [f64]) {
    for j in (0..p).rev() {
        v[j] -= dot(&a[j * rows + j + 1..(j + 1) * rows], &v[j + 1..]);
        v.swap(j, piv[j]);
    }
}

/// Turn `x` into `beta e_1` by a reflection `I - tau u u^T` with `u = (1, v)`: on return
/// `x[0] = beta` and `x[1..] = v`; returns `tau` (0 when `x[1..]` is zero already). The norm
/// is computed with scaling, so entries near the overflow threshold are safe.
#[inline(always)]
fn make_reflector(x: &mut [f64]) -> f64 {
    let scale = x.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    if scale == 0.0 || !scale.is_finite() {
        return 0.0;
    }
    let inv_scale = 1.0 / scale;
    let tail = x[1..].iter().fold(0.0, |acc, v| {
        let w = v * inv_scale;
        acc + w * w
    });
    if tail == 0.0 {
        return 0.0;
    }
    let alpha = x[0];
    let norm = scale * ((alpha * inv_scale) * (alpha * inv_scale) + tail).sqrt();
    let beta = if alpha >= 0.0 { -norm } else { norm };
    let tau = (beta - alpha) / beta;
    let inv = 1.0 / (alpha - beta);
    for v in &mut x[1..] {
        *v *= inv;
    }
    x[0] = beta;
    tau
}

/// `v = Q^T v` with the reflectors of the first `p` columns of `a` (leading dimension `rows`).
#[inline(always)]
fn apply_qt(a: &[f64], rows: usize, p: usize, tau: &[f64], v: &mut [f64]) {
    for j in 0..p {
        reflect(&a[j * rows + j + 1..(j + 1) * rows], tau[j], &mut v[j..]);
    }
}

/// `v = Q v` (the reflectors in reverse order).
#[inline(always)]
fn apply_q(a: &[f64], rows: usize, p: usize, tau: &[f64], v: &mut [f64]) {
    for j in (0..p).rev() {
        reflect(&a[j * rows + j + 1..(j + 1) * rows], tau[j], &mut v[j..]);
    }
}

/// `x = (I - tau u u^T) x` with `u = (1, v)`.
#[inline(always)]
fn reflect(v: &[f64], tau: f64, x: &mut [f64]) {
    if tau == 0.0 {
        return;
    }
    let w = tau * (x[0] + dot(v, &x[1..]));
    x[0] -= w;
    axpy(&mut x[1..], -w, v);
}

/// Solve `R y = c` in place, `R` the upper triangle of the leading `p x p` block of the
/// column-major `a` (leading dimension `rows`); column-oriented.
#[inline(always)]
fn solve_upper(a: &[f64], rows: usize, p: usize, c: &mut [f64]) {
    for j in (0..p).rev() {
        let col = &a[j * rows..j * rows + j + 1];
        c[j] /= col[j];
        let cj = c[j];
        axpy(&mut c[..j], -cj, &col[..j]);
    }
}

/// Solve `R^T y = c` in place (forward substitution; `R` as in [`solve_upper`]).
#[inline(always)]
fn solve_upper_transpose(a: &[f64], rows: usize, p: usize, c: &mut [f64]) {
    for j in 0..p {
        let col = &a[j * rows..j * rows + j + 1];
        let s = dot(&col[..j], &c[..j]);
        c[j] = (c[j] - s) / col[j];
    }
}

/// `Y[i] -= w * col[i]` for the rows `i` of `col`, every column of the `r`-column row-major
/// `y` with its own `w` (the single solves' `axpy(y, -w, col)` per column).
#[inline(always)]
fn multi_axpy(y: &mut [f64], w: &[f64], col: &[f64], r: usize) {
    for (row, &a) in y.chunks_exact_mut(r).zip(col) {
        for (yv, wv) in row.iter_mut().zip(w) {
            *yv += -wv * a;
        }
    }
}

/// [`apply_lu`] on every column of the `r`-column row-major `v`.
#[inline(always)]
fn multi_apply_lu(a: &[f64], rows: usize, p: usize, piv: &[usize], v: &mut [f64], r: usize) {
    for j in 0..p {
        if piv[j] != j {
            let (lo, hi) = v.split_at_mut(piv[j] * r);
            lo[j * r..(j + 1) * r].swap_with_slice(&mut hi[..r]);
        }
        let (head, tail) = v.split_at_mut((j + 1) * r);
        let vj = &head[j * r..];
        multi_axpy(tail, vj, &a[j * rows + j + 1..(j + 1) * rows], r);
    }
}

/// [`apply_qt`] on every column of the `r`-column row-major `v`; `acc` holds `5 r` values.
#[inline(always)]
fn multi_apply_qt(
    a: &[f64],
    rows: usize,
    p: usize,
    tau: &[f64],
    v: &mut [f64],
    r: usize,
    acc: &mut [f64],
) {
    for j in 0..p {
        let t = tau[j];
        if t == 0.0 {
            continue;
        }
        let u = &a[j * rows + j + 1..(j + 1) * rows];
        let x = &mut v[j * r..];
        // w = tau (x_0 + dot(u, x_1..)), the dot with `dot`'s four partial sums.
        acc.fill(0.0);
        let (parts, tails) = acc.split_at_mut(4 * r);
        let full = u.len() / 4 * 4;
        for i in (0..full).step_by(4) {
            for q in 0..4 {
                let row = &x[(1 + i + q) * r..(2 + i + q) * r];
                for (s, xv) in parts[q * r..(q + 1) * r].iter_mut().zip(row) {
                    *s += u[i + q] * xv;
                }
            }
        }
        for i in full..u.len() {
            let row = &x[(1 + i) * r..(2 + i) * r];
            for (s, xv) in tails.iter_mut().zip(row) {
                *s += u[i] * xv;
            }
        }
        for c in 0..r {
            let d = (parts[c] + parts[2 * r + c]) + (parts[r + c] + parts[3 * r + c]) + tails[c];
            tails[c] = t * (x[c] + d);
        }
        let (first, below) = x.split_at_mut(r);
        for (xv, w) in first.iter_mut().zip(tails.iter()) {
            *xv -= w;
        }
        multi_axpy(below, tails, u, r);
    }
}

/// [`solve_upper`] on every column of the `r`-column row-major `c`.
#[inline(always)]
fn multi_solve_upper(a: &[f64], rows: usize, p: usize, c: &mut [f64], r: usize) {
    for j in (0..p).rev() {
        let col = &a[j * rows..j * rows + j + 1];
        let (head, tail) = c.split_at_mut(j * r);
        let cj = &mut tail[..r];
        for v in cj.iter_mut() {
            *v /= col[j];
        }
        multi_axpy(head, cj, &col[..j], r);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A deterministic pseudo-random stream in [-1, 1] (no dependency on a RNG crate; the
    /// tests of `bvp::linear` use it too).
    pub(crate) fn stream(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    /// Random blocks in the layout of `BorderedAbd::factor` and the same matrix dense.
    fn random_system(n: usize, k: usize, nn: usize, seed: u64) -> (Vec<f64>, DMatrix<f64>) {
        let wc = 2 * n + k;
        let mut rnd = stream(seed);
        let rows = nn * n + n + k;
        let order = (nn + 1) * n + k;
        let values: Vec<f64> = (0..rows * wc).map(|_| rnd()).collect();
        let mut dense = DMatrix::zeros(order, order);
        for i in 0..nn {
            for r in 0..n {
                for c in 0..2 * n {
                    dense[(i * n + r, i * n + c)] = values[(i * n + r) * wc + c];
                }
                for c in 0..k {
                    dense[(i * n + r, (nn + 1) * n + c)] = values[(i * n + r) * wc + 2 * n + c];
                }
            }
        }
        for r in 0..n + k {
            let row = nn * n + r;
            for c in 0..n {
                dense[(row, c)] = values[row * wc + c];
                dense[(row, nn * n + c)] = values[row * wc + n + c];
            }
            for c in 0..k {
                dense[(row, (nn + 1) * n + c)] = values[row * wc + 2 * n + c];
            }
        }
        (values, dense)
    }

    fn max_rel(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        a.iter()
            .zip(b)
            .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }

    /// The solve and the transposed solve agree with nalgebra's dense LU on random matrices
    /// of every shape the solver meets: one interval (no elimination), two (one step), many;
    /// with and without parameters; the growth is modest.
    #[test]
    fn solves_match_dense_lu() {
        for (n, k, nn) in [
            (1, 0, 1),
            (2, 1, 1),
            (2, 0, 2),
            (3, 2, 2),
            (2, 1, 7),
            (4, 1, 30),
            (12, 1, 40),
        ] {
            for lu in [true, false] {
                let (values, dense) = random_system(n, k, nn, (n * 100 + k * 10 + nn) as u64);
                let mut abd = BorderedAbd::new(n, k, nn);
                abd.set_try_lu(lu);
                abd.factor(&values)
                    .expect("random matrices are nonsingular");
                let growth = abd.growth();
                if lu {
                    assert_eq!(abd.method(), Factorization::StructuredLu);
                    assert!(growth > 0.1 && growth <= LU_GROWTH_LIMIT, "growth {growth}");
                } else {
                    assert_eq!(abd.method(), Factorization::StructuredQr);
                    assert!(growth > 0.1 && growth <= 1.0 + 1e-12, "growth {growth}");
                }
                let pivot = abd.min_pivot();
                assert!(pivot > 0.0 && pivot.is_finite(), "min pivot {pivot}");
                if !lu {
                    assert!(pivot <= 1.0 + 1e-12, "min pivot {pivot}");
                }
                assert_solves_match_dense(&mut abd, &dense, 7, &format!("({n},{k},{nn})"));
            }
        }
    }

    /// The blocked solve gives every column the bits of its own solve (zeros up to sign),
    /// with general right-hand sides and with zero interval rows (forward sweep skipped),
    /// after structured LU and after structured QR, for the sizes with constant dimensions
    /// (n = 12, 24 with k = 1) and others.
    #[test]
    fn blocked_solves_equal_single_solves_bit_for_bit() {
        for (n, k, nn, r) in [
            (1, 0, 1, 1),
            (2, 1, 3, 4),
            (3, 2, 9, 5),
            (12, 1, 40, 13),
            (24, 1, 6, 25),
        ] {
            for lu in [true, false] {
                let (values, _) = random_system(n, k, nn, (n * 31 + k * 7 + nn) as u64);
                let mut abd = BorderedAbd::new(n, k, nn);
                abd.set_try_lu(lu);
                abd.factor(&values)
                    .expect("random matrices are nonsingular");
                let label = format!("({n},{k},{nn}) lu {lu}");
                assert_blocked_equals_single(&mut abd, n, nn, r, 11 + r as u64, &label);
            }
        }
    }

    /// A random right-hand side `b` (`seed`): the solve and the transposed solve (of the
    /// row-equilibrated matrix) agree with nalgebra's dense LU to 1e-10; returns `b` and the
    /// solution.
    fn assert_solves_match_dense(
        abd: &mut BorderedAbd,
        dense: &DMatrix<f64>,
        seed: u64,
        label: &str,
    ) -> (Vec<f64>, Vec<f64>) {
        let mut rnd = stream(seed);
        let b: Vec<f64> = (0..dense.nrows()).map(|_| rnd()).collect();
        let expected = dense
            .clone()
            .lu()
            .solve(&DVector::from_vec(b.clone()))
            .unwrap();
        let mut x = b.clone();
        assert!(abd.solve_in_place(&mut x));
        let err = max_rel(&x, expected.as_slice());
        assert!(err < 1e-10, "{label} solve error {err:e}");
        // (D J)^T x = b.
        let d = DMatrix::from_diagonal(&DVector::from_vec(abd.row_scale().to_vec()));
        let scaled_t = (&d * dense).transpose();
        let expected = scaled_t.lu().solve(&DVector::from_vec(b.clone())).unwrap();
        let mut xt = b.clone();
        assert!(abd.solve_scaled_transpose_in_place(&mut xt));
        let err = max_rel(&xt, expected.as_slice());
        assert!(err < 1e-10, "{label} transposed solve error {err:e}");
        (b, x)
    }

    /// `r` random right-hand sides (`seed`), once as they are and once with their interval
    /// rows zeroed (`zero_intervals`): the blocked solve gives every column the bits of its
    /// own single solve.
    fn assert_blocked_equals_single(
        abd: &mut BorderedAbd,
        n: usize,
        nn: usize,
        r: usize,
        seed: u64,
        label: &str,
    ) {
        let order = abd.order();
        for zero_intervals in [false, true] {
            let mut rnd = stream(seed);
            let mut cols: Vec<Vec<f64>> = (0..r)
                .map(|_| (0..order).map(|_| rnd()).collect())
                .collect();
            if zero_intervals {
                for c in &mut cols {
                    c[..nn * n].fill(0.0);
                }
            }
            let mut x = vec![0.0; order * r];
            for (c, col) in cols.iter().enumerate() {
                for (i, v) in col.iter().enumerate() {
                    x[i * r + c] = *v;
                }
            }
            assert!(abd.solve_scaled_multi_in_place(&mut x, r, zero_intervals));
            for (c, col) in cols.iter_mut().enumerate() {
                assert!(abd.solve_scaled_in_place(col));
                for (i, v) in col.iter().enumerate() {
                    assert!(
                        x[i * r + c] == *v,
                        "{label} zero {zero_intervals}: column {c} entry {i}: {} against {v}",
                        x[i * r + c]
                    );
                }
            }
        }
    }

    /// `J x` for the block layout of `BorderedAbd::factor` (`x` by columns).
    fn multiply(values: &[f64], n: usize, k: usize, nn: usize, x: &[f64]) -> Vec<f64> {
        let wc = 2 * n + k;
        let po = (nn + 1) * n;
        values
            .chunks_exact(wc)
            .enumerate()
            .map(|(r, row)| {
                let (first, second) = row_nodes(r, n, nn);
                (0..n)
                    .map(|c| row[c] * x[first + c] + row[n + c] * x[second + c])
                    .chain((0..k).map(|c| row[2 * n + c] * x[po + c]))
                    .sum()
            })
            .collect()
    }

    /// Random systems with a known solution: elimination and the orthogonal reduction both
    /// recover it, and agree with each other to rounding.
    #[test]
    fn elimination_and_qr_recover_a_known_solution() {
        for (n, k, nn) in [(1, 0, 3), (2, 1, 5), (3, 0, 17), (12, 1, 60), (5, 2, 9)] {
            let (values, _) = random_system(n, k, nn, (7 * n + 3 * k + nn) as u64);
            let order = (nn + 1) * n + k;
            let mut rnd = stream(99);
            let x: Vec<f64> = (0..order).map(|_| rnd()).collect();
            let b = multiply(&values, n, k, nn, &x);
            let mut solutions = vec![];
            for lu in [true, false] {
                let mut abd = BorderedAbd::new(n, k, nn);
                abd.set_try_lu(lu);
                abd.factor(&values).unwrap();
                let expected = if lu {
                    Factorization::StructuredLu
                } else {
                    Factorization::StructuredQr
                };
                assert_eq!(abd.method(), expected);
                let mut y = b.clone();
                assert!(abd.solve_in_place(&mut y));
                let err = max_rel(&y, &x);
                assert!(err < 1e-10, "({n},{k},{nn}) lu {lu}: error {err:e}");
                solutions.push(y);
            }
            let diff = max_rel(&solutions[0], &solutions[1]);
            assert!(diff < 1e-10, "({n},{k},{nn}) LU vs QR {diff:e}");
        }
    }

    /// Wright's (1993) kind of example: `y_{t+1} = T y_t` with `T = [[0.5, 0.9], [0.9,
    /// 0.5]]` (modes growing by 1.4 and decaying by -0.4 per interval), the decaying mode set
    /// at the start and the growing one at the end: a well-conditioned matrix on which
    /// elimination restricted to the block order pivots on the carried rows (their entries
    /// are 1, those of `T` below 1) and the border column `y_0` grows like 1.4^t. On 10
    /// intervals the growth (about 1.4^10) stays below the limit and elimination is kept; on
    /// 60 (about 1e9) the factorisation falls back to QR, and both solve accurately.
    #[test]
    fn growth_switches_to_qr() {
        let (n, k) = (2, 0);
        let wc = 2 * n + k;
        let t = [[0.5, 0.9], [0.9, 0.5]];
        for (nn, method) in [
            (10, Factorization::StructuredLu),
            (60, Factorization::StructuredQr),
        ] {
            let mut values = vec![0.0; (nn * n + n + k) * wc];
            for i in 0..nn {
                for r in 0..n {
                    let row = &mut values[(i * n + r) * wc..(i * n + r + 1) * wc];
                    for c in 0..n {
                        row[c] = -t[r][c];
                    }
                    row[n + r] = 1.0;
                }
            }
            let bc = &mut values[nn * n * wc..];
            bc[..wc].copy_from_slice(&[1.0, -1.0, 0.0, 0.0]); // decaying mode at a
            bc[wc..2 * wc].copy_from_slice(&[0.0, 0.0, 1.0, 1.0]); // growing mode at b
            let order = (nn + 1) * n + k;
            let x: Vec<f64> = (0..order).map(|i| (0.3 * i as f64).cos()).collect();
            let b = multiply(&values, n, k, nn, &x);
            let mut abd = BorderedAbd::new(n, k, nn);
            abd.set_try_separated(false);
            abd.factor(&values).unwrap();
            assert_eq!(abd.method(), method, "N = {nn}");
            let growth = abd.growth();
            match method {
                Factorization::StructuredLu => assert!(growth > 10.0, "growth {growth}"),
                _ => assert!(growth <= 1.0 + 1e-12, "growth {growth}"),
            }
            let mut y = b.clone();
            assert!(abd.solve_in_place(&mut y));
            let err = max_rel(&y, &x);
            assert!(err < 1e-12, "N = {nn}: error {err:e}");
            // Forced elimination on 60 intervals: the growth is what the fallback avoids.
            if nn == 60 {
                abd.sweep_sized(&values, Factorization::StructuredLu)
                    .expect_err("elimination stops once its growth passes the limit");
            }
            // The boundary rows are separated: elimination over whole columns (the rows at
            // a first) does not grow here, on either mesh, and solves as accurately.
            let mut sep = BorderedAbd::new(n, k, nn);
            sep.factor(&values).unwrap();
            assert_eq!(sep.method(), Factorization::SeparatedLu, "N = {nn}");
            let growth = sep.growth();
            assert!(
                growth > 0.1 && growth < 10.0,
                "N = {nn}: separated growth {growth}"
            );
            let mut y = b.clone();
            assert!(sep.solve_in_place(&mut y));
            let err = max_rel(&y, &x);
            assert!(err < 1e-12, "N = {nn}: separated error {err:e}");
        }
    }

    /// `random_system` with separated boundary rows: `na` of them (every other one, from
    /// the second) touch only `y_0` and `p`, the others only `y_N` and `p`.
    fn random_separated(
        n: usize,
        k: usize,
        nn: usize,
        na: usize,
        seed: u64,
    ) -> (Vec<f64>, DMatrix<f64>) {
        let (mut values, mut dense) = random_system(n, k, nn, seed);
        let wc = 2 * n + k;
        let at_a: Vec<usize> = (0..n + k)
            .map(|r| (2 * r + 1) % (n + k + (n + k + 1) % 2))
            .filter(|&r| r < n + k)
            .take(na)
            .collect();
        assert_eq!(at_a.len(), na);
        for r in 0..n + k {
            let row = nn * n + r;
            let (zero, dense_cols) = if at_a.contains(&r) {
                (n..2 * n, nn * n..(nn + 1) * n)
            } else {
                (0..n, 0..n)
            };
            values[row * wc + zero.start..row * wc + zero.end].fill(0.0);
            for c in dense_cols {
                dense[(row, c)] = 0.0;
            }
        }
        (values, dense)
    }

    /// Separated boundary rows, as many at `a` as none, some, `n`, and all `n + k`: the
    /// separated elimination is chosen, and its solve, transposed solve and blocked solve
    /// agree with nalgebra's dense LU and with each other bit for bit (blocked against
    /// single); the general layout on the same matrix agrees to rounding.
    #[test]
    fn separated_solves_match_dense_lu() {
        for (n, k, nn, na) in [
            (1, 0, 1, 1),
            (2, 1, 1, 1),
            (2, 0, 3, 0),
            (3, 1, 5, 4),
            (3, 2, 4, 2),
            (4, 1, 30, 2),
            (12, 1, 40, 6),
            (12, 1, 7, 12),
            (24, 1, 6, 12),
        ] {
            let (values, dense) = random_separated(n, k, nn, na, (n * 13 + k * 5 + nn + na) as u64);
            let mut abd = BorderedAbd::new(n, k, nn);
            abd.factor(&values)
                .expect("random matrices are nonsingular");
            assert_eq!(
                abd.method(),
                Factorization::SeparatedLu,
                "({n},{k},{nn},{na})"
            );
            let growth = abd.growth();
            assert!(growth > 0.1 && growth <= LU_GROWTH_LIMIT, "growth {growth}");
            let pivot = abd.min_pivot();
            assert!(pivot > 0.0 && pivot.is_finite(), "min pivot {pivot}");
            let (b, x) =
                assert_solves_match_dense(&mut abd, &dense, 5, &format!("({n},{k},{nn},{na})"));
            // Blocked solves: every column the bits of its own solve, also with zero
            // interval rows (the separated layout still carries the rows at a).
            let label = format!("({n},{k},{nn},{na})");
            assert_blocked_equals_single(&mut abd, n, nn, 3, 17, &label);
            // The general layout of the same matrix: the same solution to rounding.
            let mut general = BorderedAbd::new(n, k, nn);
            general.set_try_separated(false);
            general.factor(&values).unwrap();
            assert_ne!(general.method(), Factorization::SeparatedLu);
            let mut y = b.clone();
            assert!(general.solve_in_place(&mut y));
            let err = max_rel(&y, &x);
            assert!(
                err < 1e-10,
                "({n},{k},{nn},{na}) separated vs general {err:e}"
            );
        }
    }

    /// Rows scaled by 1e±150 change nothing but `D`: the solution of the scaled system is the
    /// same to rounding.
    #[test]
    fn row_scaling_is_removed() {
        let (n, k, nn) = (3, 1, 5);
        let (mut values, _) = random_system(n, k, nn, 11);
        let wc = 2 * n + k;
        let mut abd = BorderedAbd::new(n, k, nn);
        abd.factor(&values).unwrap();
        let order = abd.order();
        let b: Vec<f64> = (0..order).map(|i| (i as f64).sin()).collect();
        let mut x0 = b.clone();
        assert!(abd.solve_in_place(&mut x0));
        let mut b1 = b.clone();
        for (r, row) in values.chunks_exact_mut(wc).enumerate() {
            let f = if r % 2 == 0 { 1e150 } else { 1e-150 };
            row.iter_mut().for_each(|v| *v *= f);
            b1[r] *= f;
        }
        abd.factor(&values).unwrap();
        assert!(abd.solve_in_place(&mut b1));
        assert!(max_rel(&b1, &x0) < 1e-12);
    }

    /// Singular and non-finite matrices are refused, not solved: a zero row, a NaN entry, and
    /// two equal interval blocks with a repeated boundary row (rank deficient).
    #[test]
    fn singular_matrices_are_refused() {
        let (n, k, nn) = (2, 0, 3);
        let wc = 2 * n + k;
        let (values, _) = random_system(n, k, nn, 3);
        let mut abd = BorderedAbd::new(n, k, nn);
        let mut zero_row = values.clone();
        zero_row[wc..2 * wc].fill(0.0);
        assert_eq!(abd.factor(&zero_row), Err(AbdError::Singular));
        let mut nan = values.clone();
        nan[5] = f64::NAN;
        assert_eq!(abd.factor(&nan), Err(AbdError::Singular));
        assert!(!abd.solve_in_place(&mut vec![1.0; abd.order()]));
        // The node y_1 appears in no equation: its columns are zero, the panel has rank 0.
        let mut no_y1 = values.clone();
        for r in 0..n {
            for c in n..2 * n {
                no_y1[r * wc + c] = 0.0; // B_0
            }
            for c in 0..n {
                no_y1[(n + r) * wc + c] = 0.0; // A_1
            }
        }
        assert_eq!(abd.factor(&no_y1), Err(AbdError::Singular));
        // Nearly: the first two columns of y_1 (in B_0 and A_1) parallel to 1e-9.
        let mut weak_y1 = values.clone();
        for r in 0..2 * n {
            let (row, c0) = if r < n { (r, n) } else { (r, 0) };
            weak_y1[row * wc + c0 + 1] = weak_y1[row * wc + c0] * (1.0 + 1e-9 * r as f64);
        }
        abd.factor(&values).unwrap();
        let healthy = abd.min_pivot();
        abd.factor(&weak_y1).unwrap();
        assert!(
            abd.min_pivot() < 1e-6 * healthy,
            "{} vs {healthy}",
            abd.min_pivot()
        );
    }
}
