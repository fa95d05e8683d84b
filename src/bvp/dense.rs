//! Small dense kernels for the per-interval stage blocks (`2n x 2n`, row-major).
//!
//! Written by hand on slices so that condensation allocates nothing per interval and per
//! iteration (faer's own guidance: it targets medium/large matrices).

/// In-place LU factorisation with partial pivoting of the row-major `n x n` matrix `a`.
///
/// On return `a` holds `L` (unit lower, below the diagonal) and `U`; `piv[i]` is the row
/// swapped with row `i` at step `i`. Returns `false` if a pivot is zero or not finite (the
/// matrix is singular to working precision or contains NaN).
pub(crate) fn lu_factor(a: &mut [f64], n: usize, piv: &mut [usize]) -> bool {
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
        if best != col {
            for c in 0..n {
                a.swap(col * n + c, best * n + c);
            }
        }
        let inv = 1.0 / a[col * n + col];
        for r in col + 1..n {
            let l = a[r * n + col] * inv;
            a[r * n + col] = l;
            if l != 0.0 {
                for c in col + 1..n {
                    a[r * n + c] -= l * a[col * n + c];
                }
            }
        }
    }
    true
}

/// Solve `A X = B` in place with the factors from [`lu_factor`]; `b` is row-major
/// `n x ncols`.
pub(crate) fn lu_solve(a: &[f64], n: usize, piv: &[usize], b: &mut [f64], ncols: usize) {
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

/// `c -= a * b` with `a` row-major `r x q`, `b` row-major `q x s`, `c` row-major `r x s`.
pub(crate) fn sub_mat_mul(c: &mut [f64], a: &[f64], b: &[f64], r: usize, q: usize, s: usize) {
    for i in 0..r {
        for l in 0..q {
            let ail = a[i * q + l];
            if ail != 0.0 {
                let brow = &b[l * s..(l + 1) * s];
                let crow = &mut c[i * s..(i + 1) * s];
                for (cv, bv) in crow.iter_mut().zip(brow) {
                    *cv -= ail * bv;
                }
            }
        }
    }
}
