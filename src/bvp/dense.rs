//! Small dense kernels for the per-interval stage blocks (`2n x 2n`, row-major).
//!
//! Written by hand on slices so that condensation allocates nothing per interval and per
//! iteration (faer's own guidance: it targets medium/large matrices).
//!
//! The kernels are `#[inline(always)]` so that the callers' AVX2 copies ([`avx2!`](crate::bvp::dense::avx2))
//! compile them with 256-bit vectors. Vectorisation never reassociates or fuses floating-point
//! operations (no FMA contraction), so both copies give bitwise identical results; the sums
//! in [`dot`] are split into four fixed partial sums to give the vectors something to do.

/// Whether to run the AVX2 copies of the hot loops (see the module docs); a cached atomic
/// load after the first call.
#[inline(always)]
pub(crate) fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `$body`, compiled a second time for AVX2 and run in that copy on CPUs that have it: the
/// callee `$imp` must be `#[inline(always)]` (and so must the kernels it calls) for the copy
/// to be compiled with the wider vectors. Usage inside a method:
/// `avx2!(fn(this: &mut Self, a: &[f64]) -> R { this.imp(a) }, self, a)`.
macro_rules! avx2 {
    (fn($($p:ident : $t:ty),*) -> $r:ty $body:block, $($a:expr),*) => {{
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        fn wide($($p: $t),*) -> $r $body
        fn narrow($($p: $t),*) -> $r $body
        #[cfg(target_arch = "x86_64")]
        {
            if $crate::bvp::dense::has_avx2() {
                // SAFETY: the CPU supports AVX2, checked just above.
                unsafe { wide($($a),*) }
            } else {
                narrow($($a),*)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            narrow($($a),*)
        }
    }};
}
pub(crate) use avx2;

/// `(max_i |x_i|, sum_i 0 x_i)`: the largest magnitude (NaN entries ignored) and a value that
/// is NaN exactly when some entry is infinite or NaN. Four running maxima by comparison, so
/// that the loop vectorises (`f64::max` does not).
#[inline(always)]
pub(crate) fn abs_max(x: &[f64]) -> (f64, f64) {
    let mut m = [0.0_f64; 4];
    let mut bad = [0.0_f64; 4];
    let mut chunks = x.chunks_exact(4);
    for c in &mut chunks {
        for q in 0..4 {
            let a = c[q].abs();
            m[q] = if a > m[q] { a } else { m[q] };
            bad[q] += c[q] * 0.0;
        }
    }
    let mut tail = 0.0_f64;
    let mut tail_bad = 0.0;
    for v in chunks.remainder() {
        let a = v.abs();
        tail = if a > tail { a } else { tail };
        tail_bad += v * 0.0;
    }
    let m = m.iter().fold(tail, |a, &v| if v > a { v } else { a });
    (m, bad.iter().sum::<f64>() + tail_bad)
}

/// `sum_i |x_i|` with four partial sums (so that the loop vectorises; the order of the
/// additions is not that of a left-to-right sum).
#[inline(always)]
pub(crate) fn abs_sum(x: &[f64]) -> f64 {
    let mut acc = [0.0_f64; 4];
    let mut chunks = x.chunks_exact(4);
    for c in &mut chunks {
        for q in 0..4 {
            acc[q] += c[q].abs();
        }
    }
    let tail: f64 = chunks.remainder().iter().map(|v| v.abs()).sum();
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// In-place LU factorisation with partial pivoting of the row-major `n x n` matrix `a`.
///
/// On return `a` holds `L` (unit lower, below the diagonal) and `U`; `piv[i]` is the row
/// swapped with row `i` at step `i`. Returns `false` if a pivot is zero or not finite (the
/// matrix is singular to working precision or contains NaN).
#[inline(always)]
pub(crate) fn lu_factor(a: &mut [f64], n: usize, piv: &mut [usize]) -> bool {
    let a = &mut a[..n * n];
    let scale = abs_max(a).0;
    if !scale.is_finite() {
        return false;
    }
    let tiny = scale * f64::EPSILON * n as f64;
    for col in 0..n {
        let mut best = col;
        let mut best_val = a[col * n + col].abs();
        for r in col + 1..n {
            let v = a[r * n + col].abs();
            if v > best_val {
                best = r;
                best_val = v;
            }
        }
        piv[col] = best;
        if best_val <= tiny || !best_val.is_finite() {
            return false;
        }
        let (top, bottom) = a.split_at_mut((col + 1) * n);
        let prow = &mut top[col * n..];
        if best != col {
            prow.swap_with_slice(&mut bottom[(best - col - 1) * n..(best - col) * n]);
        }
        let prow = &prow[col..];
        let inv = 1.0 / prow[0];
        // Row updates as contiguous axpys (`y + (-l) x` is bitwise `y - l x`).
        for row in bottom.chunks_exact_mut(n) {
            let row = &mut row[col..];
            let l = row[0] * inv;
            row[0] = l;
            if l != 0.0 {
                axpy(&mut row[1..], -l, &prow[1..]);
            }
        }
    }
    true
}

/// Solve `A X = B` in place with the factors from [`lu_factor`]; `b` is row-major
/// `n x ncols`.
#[inline(always)]
pub(crate) fn lu_solve(a: &[f64], n: usize, piv: &[usize], b: &mut [f64], ncols: usize) {
    if ncols == 1 {
        lu_solve_vec(a, n, piv, b);
        return;
    }
    for (i, &p) in piv.iter().enumerate().take(n) {
        if p != i {
            for c in 0..ncols {
                b.swap(i * ncols + c, p * ncols + c);
            }
        }
    }
    for i in 0..n {
        for j in 0..i {
            let l = a[i * n + j];
            if l != 0.0 {
                for c in 0..ncols {
                    b[i * ncols + c] -= l * b[j * ncols + c];
                }
            }
        }
    }
    for i in (0..n).rev() {
        for j in i + 1..n {
            let u = a[i * n + j];
            if u != 0.0 {
                for c in 0..ncols {
                    b[i * ncols + c] -= u * b[j * ncols + c];
                }
            }
        }
        let inv = 1.0 / a[i * n + i];
        for c in 0..ncols {
            b[i * ncols + c] *= inv;
        }
    }
}

/// [`lu_solve`] for one right-hand side: the substitutions as dot products of the rows of
/// `L` and `U` (contiguous in row-major storage).
#[inline(always)]
fn lu_solve_vec(a: &[f64], n: usize, piv: &[usize], b: &mut [f64]) {
    for (i, &p) in piv.iter().enumerate().take(n) {
        b.swap(i, p);
    }
    for i in 1..n {
        let (done, rest) = b.split_at_mut(i);
        rest[0] -= dot(&a[i * n..i * n + i], done);
    }
    for i in (0..n).rev() {
        let (head, done) = b.split_at_mut(i + 1);
        let row = &a[i * n..(i + 1) * n];
        head[i] = (head[i] - dot(&row[i + 1..], done)) / row[i];
    }
}

/// `sum_i a_i b_i` over the shorter of the two, with four independent partial sums (so the
/// loop vectorizes and does not wait on one chain of additions).
#[inline(always)]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let len = a.len().min(b.len());
    let (a, b) = (&a[..len], &b[..len]);
    let mut acc = [0.0_f64; 4];
    let mut ca = a.chunks_exact(4);
    let mut cb = b.chunks_exact(4);
    for (x, y) in (&mut ca).zip(&mut cb) {
        for q in 0..4 {
            acc[q] += x[q] * y[q];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        tail += x * y;
    }
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// `y += alpha x` over the shorter of the two.
#[inline(always)]
pub(crate) fn axpy(y: &mut [f64], alpha: f64, x: &[f64]) {
    for (yv, xv) in y.iter_mut().zip(x) {
        *yv += alpha * xv;
    }
}

/// `X := X A^{-1}` in place with the factors from [`lu_factor`] (`P A = L U`); `x` is
/// row-major `nrows x n`; `work` holds at least `n * nrows` values. See
/// [`lu_right_solve_strided`].
#[inline(always)]
pub(crate) fn lu_right_solve(
    a: &[f64],
    n: usize,
    piv: &[usize],
    x: &mut [f64],
    nrows: usize,
    work: &mut [f64],
) {
    lu_right_solve_strided(a, n, piv, x, nrows, n, work);
}

/// [`lu_right_solve`] for rows `x[r * ld .. r * ld + n]` (`ld >= n`).
///
/// Solves `Y U = X`, then `Z L = Y`, then `X A^{-1} = Z P`, on the transpose of `X` (in
/// `work`, `n x nrows`), one column of `Y` (`Z`) at a time over all `nrows` rows at once: the
/// column is held in registers while the earlier columns' multiples are subtracted (full
/// vectors, where the row-by-row form has updates of length `n - i - 1`). Each entry sees the
/// same operations in the same order as in the row-by-row form, so the same bits.
#[inline(always)]
pub(crate) fn lu_right_solve_strided(
    a: &[f64],
    n: usize,
    piv: &[usize],
    x: &mut [f64],
    nrows: usize,
    ld: usize,
    work: &mut [f64],
) {
    let x = &mut x[..(nrows - 1) * ld + n];
    let t = &mut work[..n * nrows];
    for r in 0..nrows {
        for (c, v) in x[r * ld..r * ld + n].iter().enumerate() {
            t[c * nrows + r] = *v;
        }
    }
    // Y U = X, column by column: y_c = (x_c - sum_{i<c} u_ic y_i) / u_cc.
    for c in 0..n {
        let (done, rest) = t.split_at_mut(c * nrows);
        let out = &mut rest[..nrows];
        sub_combination(out, 0..c, |i| a[i * n + c], done, |i| i * nrows);
        let inv = 1.0 / a[c * n + c];
        for v in out.iter_mut() {
            *v *= inv;
        }
    }
    // Z L = Y (unit L), from the last column back: z_c = y_c - sum_{j>c} l_jc z_j (the
    // terms from the last `j` down).
    for c in (0..n.saturating_sub(1)).rev() {
        let (head, done) = t.split_at_mut((c + 1) * nrows);
        let out = &mut head[c * nrows..];
        sub_combination(
            out,
            (c + 1..n).rev(),
            |j| a[j * n + c],
            done,
            |j| (j - c - 1) * nrows,
        );
    }
    // Z P: the column swaps, last first.
    for (i, &p) in piv.iter().enumerate().take(n).rev() {
        if p != i {
            let (head, tail) = t.split_at_mut(p * nrows);
            head[i * nrows..(i + 1) * nrows].swap_with_slice(&mut tail[..nrows]);
        }
    }
    for r in 0..nrows {
        for (c, v) in x[r * ld..r * ld + n].iter_mut().enumerate() {
            *v = t[c * nrows + r];
        }
    }
}

/// `out -= sum_l coef(l) rows[at(l)..]` over the `l` of `ls` in their order, as `out +
/// (-coef(l)) row_l` term after term, by chunks of 8, 4, then 1 entries held in registers.
#[inline(always)]
fn sub_combination(
    out: &mut [f64],
    ls: impl Iterator<Item = usize> + Clone,
    coef: impl Fn(usize) -> f64,
    rows: &[f64],
    at: impl Fn(usize) -> usize,
) {
    let w = out.len();
    let mut j = 0;
    while j + 8 <= w {
        sub_combination_chunk::<8>(&mut out[j..j + 8], ls.clone(), &coef, rows, &at, j);
        j += 8;
    }
    while j + 4 <= w {
        sub_combination_chunk::<4>(&mut out[j..j + 4], ls.clone(), &coef, rows, &at, j);
        j += 4;
    }
    while j < w {
        sub_combination_chunk::<1>(&mut out[j..j + 1], ls.clone(), &coef, rows, &at, j);
        j += 1;
    }
}

/// Entries `j0 .. j0 + NR` of [`sub_combination`].
#[inline(always)]
fn sub_combination_chunk<const NR: usize>(
    out: &mut [f64],
    ls: impl Iterator<Item = usize>,
    coef: &impl Fn(usize) -> f64,
    rows: &[f64],
    at: &impl Fn(usize) -> usize,
    j0: usize,
) {
    let mut acc: [f64; NR] = out[..NR].try_into().expect("NR values");
    for l in ls {
        let neg = -coef(l);
        let start = at(l) + j0;
        let row: &[f64; NR] = rows[start..start + NR].try_into().expect("NR values");
        for (v, r) in acc.iter_mut().zip(row) {
            *v += neg * r;
        }
    }
    out[..NR].copy_from_slice(&acc);
}

/// `B := A^{-1} B` in place with the factors from [`lu_factor`]; `b` is row-major
/// `n x ncols`. Each substitution step `b_i -= sum_j l_ij b_j` is one row of
/// [`sub_mat_mul_strided`] (the row held in registers, the same order of operations as
/// row-by-row axpys).
#[inline(always)]
pub(crate) fn lu_solve_rows(a: &[f64], n: usize, piv: &[usize], b: &mut [f64], ncols: usize) {
    let b = &mut b[..n * ncols];
    for (i, &p) in piv.iter().enumerate().take(n) {
        if p != i {
            let (top, bottom) = b.split_at_mut(p * ncols);
            top[i * ncols..(i + 1) * ncols].swap_with_slice(&mut bottom[..ncols]);
        }
    }
    for i in 1..n {
        let (done, rest) = b.split_at_mut(i * ncols);
        let row = &mut rest[..ncols];
        sub_mat_mul_rows::<1>(row, ncols, 0, &a[i * n..i * n + i], done, 0, i, ncols);
    }
    for i in (0..n).rev() {
        let (head, done) = b.split_at_mut((i + 1) * ncols);
        let row = &mut head[i * ncols..];
        let urow = &a[i * n + i + 1..(i + 1) * n];
        sub_mat_mul_rows::<1>(row, ncols, 0, urow, done, 0, n - i - 1, ncols);
        let inv = 1.0 / a[i * n + i];
        for v in row.iter_mut() {
            *v *= inv;
        }
    }
}

/// `C[:, off..off+s] -= A B` with `A` row-major `r x q`, `B` row-major `q x s`, and `C`
/// row-major with `ldc` columns.
///
/// By tiles of 4 rows and 8 (then 4) columns of `C` held in registers while the `q` products
/// are subtracted, in the order of `l` (so each entry sees the operations of the axpy form
/// `c_ij - a_i0 b_0j - a_i1 b_1j - ...`, the same bits).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn sub_mat_mul_strided(
    c: &mut [f64],
    ldc: usize,
    off: usize,
    a: &[f64],
    b: &[f64],
    r: usize,
    q: usize,
    s: usize,
) {
    let mut i = 0;
    while i + 4 <= r {
        sub_mat_mul_rows::<4>(c, ldc, off, a, b, i, q, s);
        i += 4;
    }
    while i < r {
        sub_mat_mul_rows::<1>(c, ldc, off, a, b, i, q, s);
        i += 1;
    }
}

/// Rows `i0 .. i0 + MR` of [`sub_mat_mul_strided`].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sub_mat_mul_rows<const MR: usize>(
    c: &mut [f64],
    ldc: usize,
    off: usize,
    a: &[f64],
    b: &[f64],
    i0: usize,
    q: usize,
    s: usize,
) {
    let mut j = 0;
    while j + 8 <= s {
        sub_mat_mul_tile::<MR, 8>(c, ldc, off, a, b, i0, j, q, s);
        j += 8;
    }
    while j + 4 <= s {
        sub_mat_mul_tile::<MR, 4>(c, ldc, off, a, b, i0, j, q, s);
        j += 4;
    }
    while j < s {
        sub_mat_mul_tile::<MR, 1>(c, ldc, off, a, b, i0, j, q, s);
        j += 1;
    }
}

/// The `MR x NR` tile of `C` at rows `i0..`, columns `j0..` (of the `s` columns at `off`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sub_mat_mul_tile<const MR: usize, const NR: usize>(
    c: &mut [f64],
    ldc: usize,
    off: usize,
    a: &[f64],
    b: &[f64],
    i0: usize,
    j0: usize,
    q: usize,
    s: usize,
) {
    let mut acc = [[0.0_f64; NR]; MR];
    for (m, row) in acc.iter_mut().enumerate() {
        let at = (i0 + m) * ldc + off + j0;
        row.copy_from_slice(&c[at..at + NR]);
    }
    let a = &a[i0 * q..(i0 + MR) * q];
    for l in 0..q {
        let bl: &[f64; NR] = b[l * s + j0..l * s + j0 + NR]
            .try_into()
            .expect("NR values");
        for (m, row) in acc.iter_mut().enumerate() {
            let neg = -a[m * q + l];
            for (v, bv) in row.iter_mut().zip(bl) {
                *v += neg * bv;
            }
        }
    }
    for (m, row) in acc.iter().enumerate() {
        let at = (i0 + m) * ldc + off + j0;
        c[at..at + NR].copy_from_slice(row);
    }
}
