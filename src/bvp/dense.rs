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

/// In-place LU factorisation with partial pivoting of the row-major `n x n` matrix `a`.
///
/// On return `a` holds `L` (unit lower, below the diagonal) and `U`; `piv[i]` is the row
/// swapped with row `i` at step `i`. Returns `false` if a pivot is zero or not finite (the
/// matrix is singular to working precision or contains NaN).
#[inline(always)]
pub(crate) fn lu_factor(a: &mut [f64], n: usize, piv: &mut [usize]) -> bool {
    let a = &mut a[..n * n];
    let scale = a.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
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
/// row-major `nrows x n`. Solves `Y U = X`, then `Z L = Y`, then `X A^{-1} = Z P`, row by row
/// with contiguous rows of `U` and `L`.
#[inline(always)]
pub(crate) fn lu_right_solve(a: &[f64], n: usize, piv: &[usize], x: &mut [f64], nrows: usize) {
    lu_right_solve_strided(a, n, piv, x, nrows, n);
}

/// [`lu_right_solve`] for rows `x[r * ld .. r * ld + n]` (`ld >= n`).
#[inline(always)]
pub(crate) fn lu_right_solve_strided(
    a: &[f64],
    n: usize,
    piv: &[usize],
    x: &mut [f64],
    nrows: usize,
    ld: usize,
) {
    let x = &mut x[..(nrows - 1) * ld + n];
    // Column by column over all rows: one division per pivot, contiguous row updates.
    for i in 0..n {
        let urow = &a[i * n..(i + 1) * n];
        let inv = 1.0 / urow[i];
        for r in 0..nrows {
            let row = &mut x[r * ld..r * ld + n];
            row[i] *= inv;
            let yi = row[i];
            axpy(&mut row[i + 1..], -yi, &urow[i + 1..]);
        }
    }
    for j in (1..n).rev() {
        let lrow = &a[j * n..j * n + j];
        for r in 0..nrows {
            let row = &mut x[r * ld..r * ld + n];
            let zj = row[j];
            axpy(&mut row[..j], -zj, lrow);
        }
    }
    for r in 0..nrows {
        let row = &mut x[r * ld..r * ld + n];
        for (i, &p) in piv.iter().enumerate().take(n).rev() {
            row.swap(i, p);
        }
    }
}

/// `B := A^{-1} B` in place with the factors from [`lu_factor`]; `b` is row-major
/// `n x ncols` (the substitutions as contiguous row axpys).
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
        for j in 0..i {
            let l = a[i * n + j];
            if l != 0.0 {
                axpy(row, -l, &done[j * ncols..(j + 1) * ncols]);
            }
        }
    }
    for i in (0..n).rev() {
        let (head, done) = b.split_at_mut((i + 1) * ncols);
        let row = &mut head[i * ncols..];
        for j in i + 1..n {
            let u = a[i * n + j];
            if u != 0.0 {
                axpy(row, -u, &done[(j - i - 1) * ncols..(j - i) * ncols]);
            }
        }
        let inv = 1.0 / a[i * n + i];
        for v in row.iter_mut() {
            *v *= inv;
        }
    }
}

/// `C[:, off..off+s] -= A B` with `A` row-major `r x q`, `B` row-major `q x s`, and `C`
/// row-major with `ldc` columns.
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
    for i in 0..r {
        let crow = &mut c[i * ldc + off..i * ldc + off + s];
        for l in 0..q {
            let ail = a[i * q + l];
            if ail != 0.0 {
                axpy(crow, -ail, &b[l * s..(l + 1) * s]);
            }
        }
    }
}
