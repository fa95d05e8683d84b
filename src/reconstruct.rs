//! Reconstruction of the group motion `ġ = g Ω̂(t)` from a body velocity `Ω(t)`, for any
//! Lie algebra given by a matrix representation. Nothing here knows a model.
//!
//! The building blocks: [`Representation`] (the basis `E_1..E_n` and the hat map
//! `Ω̂ = Σ Ω_i E_i`) and [`Expm`], the matrix exponential.
//!
//! # The matrix exponential
//!
//! [`Expm`] is the scaling and squaring method with diagonal Padé approximants of degree
//! 3, 5, 7, 9 or 13 of N. J. Higham, *The scaling and squaring method for the matrix
//! exponential revisited*, SIAM J. Matrix Anal. Appl. 26(4), 1179–1193 (2005), Algorithm 2.3,
//! with the thresholds `θ_m` of its Table 2.3 (the 1-norm bounds below which the degree-`m`
//! approximant has backward error at most the unit roundoff `2⁻⁵³`). The workspace is
//! allocated once, so repeated calls do not allocate.
//!
//! # Storage
//!
//! Matrices are `&[f64]` of length `k²`, row-major: entry `(r, c)` is `m[r * k + c]`.

/// Failures of [`Representation::new`] and [`Expm::compute`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReconstructError {
    /// The matrix size `k` is 0.
    #[error("matrix size k must be at least 1, got k = 0")]
    ZeroMatrixSize,
    /// The number of basis matrices `n` is 0.
    #[error("the basis must contain at least one matrix (n >= 1), got n = 0")]
    EmptyBasis,
    /// The basis slice does not hold `n` matrices of size `k × k`.
    #[error("the basis has {got} entries, expected n*k*k = {n}*{k}*{k} = {expected}")]
    BasisLength {
        /// Number of basis matrices.
        n: usize,
        /// Matrix size.
        k: usize,
        /// `n k²`.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// A basis matrix has a NaN or infinite entry.
    #[error("basis matrix {index} (0-based) has the non-finite entry {value} at row {row}, column {col}")]
    NonFiniteBasis {
        /// Which basis matrix (0-based).
        index: usize,
        /// Row (0-based).
        row: usize,
        /// Column (0-based).
        col: usize,
        /// The entry.
        value: f64,
    },
    /// A matrix argument (`g_a`, or the argument or output of [`Expm::compute`]) has the
    /// wrong length.
    #[error("{what} has {got} entries, expected k*k = {expected}")]
    MatrixLength {
        /// Which matrix.
        what: &'static str,
        /// `k²`.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// A matrix argument (`g_a`, or the argument of [`Expm::compute`]) has a NaN or infinite
    /// entry.
    #[error("{what} has the non-finite entry {value} at row {row}, column {col}")]
    NonFiniteMatrix {
        /// Which matrix.
        what: &'static str,
        /// Row (0-based).
        row: usize,
        /// Column (0-based).
        col: usize,
        /// The entry.
        value: f64,
    },
    /// [`Expm::compute`] overflowed: the 1-norm of the argument, or an entry of the result,
    /// is not representable.
    #[error("matrix exponential overflows: the 1-norm of the argument or an entry of exp(A) is not representable")]
    ExpmOverflow,
    /// The Padé denominator was numerically singular. This cannot happen for finite input
    /// (after scaling its condition number is small, Higham 2005, §2); reported rather than
    /// panicking.
    #[error("matrix exponential: singular Padé denominator (degree {degree})")]
    ExpmSingular {
        /// Padé degree used.
        degree: u32,
    },
}

/// A matrix representation of an `n`-dimensional Lie algebra: `n` basis matrices of size
/// `k × k`, row-major, stored one after the other.
#[derive(Debug, Clone, PartialEq)]
pub struct Representation {
    k: usize,
    n: usize,
    basis: Vec<f64>,
}

impl Representation {
    /// Checks `k ≥ 1`, `n ≥ 1`, `basis.len() = n k²` and that every entry is finite.
    /// `basis[i k² + r k + c]` is entry `(r, c)` of `E_{i+1}`.
    pub fn new(n: usize, k: usize, basis: Vec<f64>) -> Result<Self, ReconstructError> {
        if k == 0 {
            return Err(ReconstructError::ZeroMatrixSize);
        }
        if n == 0 {
            return Err(ReconstructError::EmptyBasis);
        }
        let expected = n
            .checked_mul(k)
            .and_then(|nk| nk.checked_mul(k))
            .unwrap_or(usize::MAX);
        if basis.len() != expected {
            return Err(ReconstructError::BasisLength {
                n,
                k,
                expected,
                got: basis.len(),
            });
        }
        if let Some(pos) = basis.iter().position(|v| !v.is_finite()) {
            let kk = k * k;
            return Err(ReconstructError::NonFiniteBasis {
                index: pos / kk,
                row: (pos % kk) / k,
                col: pos % k,
                value: basis[pos],
            });
        }
        Ok(Self { k, n, basis })
    }

    /// Dimension `n` of the Lie algebra (number of basis matrices).
    pub fn n(&self) -> usize {
        self.n
    }

    /// Size `k` of the matrices.
    pub fn k(&self) -> usize {
        self.k
    }

    /// Basis matrix `E_{i+1}` (row-major, `k²` entries).
    ///
    /// # Panics
    /// If `i >= n`.
    pub fn basis_matrix(&self, i: usize) -> &[f64] {
        let kk = self.k * self.k;
        &self.basis[i * kk..(i + 1) * kk]
    }

    /// The hat map: `out = Σ omega[i] E_{i+1}` (row-major `k × k`).
    ///
    /// # Panics
    /// If `omega.len() != n` or `out.len() != k²` (a programming error, not a data error).
    pub fn hat(&self, omega: &[f64], out: &mut [f64]) {
        let kk = self.k * self.k;
        assert_eq!(omega.len(), self.n, "hat: omega must have n entries");
        assert_eq!(out.len(), kk, "hat: out must have k*k entries");
        out.fill(0.0);
        for (w, e) in omega.iter().zip(self.basis.chunks_exact(kk)) {
            if *w != 0.0 {
                for (o, x) in out.iter_mut().zip(e) {
                    *o += w * x;
                }
            }
        }
    }
}

/// `out = a b` for row-major `k × k` matrices (`out` must not alias `a` or `b`).
fn matmul(k: usize, a: &[f64], b: &[f64], out: &mut [f64]) {
    for r in 0..k {
        let row = &mut out[r * k..(r + 1) * k];
        row.fill(0.0);
        // No skipping of zero entries: 0 · ∞ must stay NaN so that overflow is detected.
        for (l, &arl) in a[r * k..(r + 1) * k].iter().enumerate() {
            for (o, x) in row.iter_mut().zip(&b[l * k..(l + 1) * k]) {
                *o += arl * x;
            }
        }
    }
}

/// 1-norm (largest column sum of absolute values) of a row-major `k × k` matrix.
fn norm1(k: usize, a: &[f64]) -> f64 {
    (0..k)
        .map(|c| (0..k).map(|r| a[r * k + c].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Solves `a x = b` in place (`b` becomes `x`; `k` right-hand sides, all `k × k` row-major)
/// by Gaussian elimination with partial pivoting. `false` if a pivot is zero or not finite.
fn solve_in_place(k: usize, a: &mut [f64], b: &mut [f64]) -> bool {
    for col in 0..k {
        let mut p = col;
        let mut best = a[col * k + col].abs();
        for r in col + 1..k {
            let v = a[r * k + col].abs();
            if v > best {
                best = v;
                p = r;
            }
        }
        if !(best > 0.0 && best.is_finite()) {
            return false;
        }
        if p != col {
            for c in 0..k {
                a.swap(p * k + c, col * k + c);
                b.swap(p * k + c, col * k + c);
            }
        }
        let pivot = a[col * k + col];
        for r in col + 1..k {
            let f = a[r * k + col] / pivot;
            if f != 0.0 {
                for c in col..k {
                    a[r * k + c] -= f * a[col * k + c];
                }
                for c in 0..k {
                    b[r * k + c] -= f * b[col * k + c];
                }
            }
        }
    }
    for row in (0..k).rev() {
        let diag = a[row * k + row];
        for c in 0..k {
            let mut s = b[row * k + c];
            for j in row + 1..k {
                s -= a[row * k + j] * b[j * k + c];
            }
            b[row * k + c] = s / diag;
        }
    }
    true
}

/// Coefficients `b_0..b_m` of the degree-`m` diagonal Padé approximant `p(x)/p(−x)` to `eˣ`
/// (Higham 2005, eq. (2.5) and Algorithm 2.3).
const PADE3: [f64; 4] = [120.0, 60.0, 12.0, 1.0];
const PADE5: [f64; 6] = [30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0];
const PADE7: [f64; 8] = [
    17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0,
];
const PADE9: [f64; 10] = [
    17643225600.0,
    8821612800.0,
    2075673600.0,
    302702400.0,
    30270240.0,
    2162160.0,
    110880.0,
    3960.0,
    90.0,
    1.0,
];
const PADE13: [f64; 14] = [
    64764752532480000.0,
    32382376266240000.0,
    7771770303897600.0,
    1187353796428800.0,
    129060195264000.0,
    10559470521600.0,
    670442572800.0,
    33522128640.0,
    1323241920.0,
    40840800.0,
    960960.0,
    16380.0,
    182.0,
    1.0,
];
/// `θ_m` for `m = 3, 5, 7, 9, 13` (Higham 2005, Table 2.3): for `‖A‖₁ ≤ θ_m` the degree-`m`
/// approximant has relative backward error at most `2⁻⁵³`.
const THETA: [(u32, f64); 5] = [
    (3, 1.495585217958292e-2),
    (5, 2.53939833006323e-1),
    (7, 9.504178996162932e-1),
    (9, 2.097847961257068e0),
    (13, 5.371920351148152e0),
];

/// What one [`Expm::compute`] call did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExpmInfo {
    /// Degree `m` of the Padé approximant (3, 5, 7, 9 or 13).
    pub degree: u32,
    /// Number of squarings `s` (the argument was scaled by `2⁻ˢ`).
    pub squarings: u32,
}

/// Matrix exponential of small dense `k × k` matrices by scaling and squaring with Padé
/// approximants (Higham 2005, Algorithm 2.3; see the [module docs](self)). Holds its
/// workspace, so repeated calls do not allocate.
#[derive(Debug, Clone)]
pub struct Expm {
    k: usize,
    a: Vec<f64>,
    a2: Vec<f64>,
    a4: Vec<f64>,
    a6: Vec<f64>,
    a8: Vec<f64>,
    u: Vec<f64>,
    v: Vec<f64>,
    w: Vec<f64>,
}

impl Expm {
    /// Workspace for `k × k` matrices.
    pub fn new(k: usize) -> Self {
        let z = vec![0.0; k * k];
        Self {
            k,
            a: z.clone(),
            a2: z.clone(),
            a4: z.clone(),
            a6: z.clone(),
            a8: z.clone(),
            u: z.clone(),
            v: z.clone(),
            w: z,
        }
    }

    /// Matrix size `k`.
    pub fn k(&self) -> usize {
        self.k
    }

    /// `out = exp(a)` (row-major `k × k`). Errors on wrong lengths, non-finite entries, or
    /// overflow (of the 1-norm of `a` or of the result); `out` then holds garbage.
    /// In exact arithmetic the scaled Padé approximant equals `exp(a + Δa)` with
    /// `‖Δa‖₁ ≤ u‖a‖₁` (Higham 2005, §2); rounding in its evaluation and in the squarings adds
    /// to this. The tests measure relative errors of at most `2e-13` (`exp(700)` as a 1×1
    /// matrix, whose condition number is 700) and `1.3e-14` for a rotation by 300 rad.
    pub fn compute(&mut self, a: &[f64], out: &mut [f64]) -> Result<ExpmInfo, ReconstructError> {
        let k = self.k;
        let kk = k * k;
        for (what, len) in [("expm argument", a.len()), ("expm output", out.len())] {
            if len != kk {
                return Err(ReconstructError::MatrixLength {
                    what,
                    expected: kk,
                    got: len,
                });
            }
        }
        if let Some(pos) = a.iter().position(|v| !v.is_finite()) {
            return Err(ReconstructError::NonFiniteMatrix {
                what: "expm argument",
                row: pos / k,
                col: pos % k,
                value: a[pos],
            });
        }
        let norm = norm1(k, a);
        if !norm.is_finite() {
            return Err(ReconstructError::ExpmOverflow);
        }
        self.a.copy_from_slice(a);
        let mut info = ExpmInfo {
            degree: 13,
            squarings: 0,
        };
        if let Some(&(m, _)) = THETA[..4].iter().find(|(_, theta)| norm <= *theta) {
            info.degree = m;
        } else {
            // Smallest s >= 0 with norm / 2^s <= θ_13; the scaling by 2^-s is exact.
            let theta13 = THETA[4].1;
            let mut scaled = norm;
            while scaled > theta13 {
                scaled *= 0.5;
                info.squarings += 1;
            }
            if info.squarings > 0 {
                // 2^-s in (at most) two exact factors, each a normal number.
                let s = info.squarings as i32;
                let (s1, s2) = (s / 2, s - s / 2);
                let f1 = 2f64.powi(-s1);
                let f2 = 2f64.powi(-s2);
                for x in &mut self.a {
                    *x = *x * f1 * f2;
                }
            }
        }
        self.pade(info.degree, out)?;
        for _ in 0..info.squarings {
            matmul(k, out, out, &mut self.w);
            out.copy_from_slice(&self.w);
        }
        if out.iter().all(|v| v.is_finite()) {
            Ok(info)
        } else {
            Err(ReconstructError::ExpmOverflow)
        }
    }

    /// `out = r_m(self.a) = (V − U)⁻¹ (V + U)`, the degree-`m` Padé approximant.
    fn pade(&mut self, m: u32, out: &mut [f64]) -> Result<(), ReconstructError> {
        let k = self.k;
        let Self {
            a,
            a2,
            a4,
            a6,
            a8,
            u,
            v,
            w,
            ..
        } = self;
        matmul(k, a, a, a2);
        // w = odd-part polynomial (U = A w), v = even part.
        if m == 13 {
            let b = &PADE13;
            matmul(k, a2, a2, a4);
            matmul(k, a4, a2, a6);
            // u = b13 A6 + b11 A4 + b9 A2 (temporarily), then w = A6 u + b7 A6 + b5 A4 + b3 A2 + b1 I.
            for i in 0..k * k {
                u[i] = b[13] * a6[i] + b[11] * a4[i] + b[9] * a2[i];
            }
            matmul(k, a6, u, w);
            for i in 0..k * k {
                w[i] += b[7] * a6[i] + b[5] * a4[i] + b[3] * a2[i];
            }
            for i in 0..k * k {
                u[i] = b[12] * a6[i] + b[10] * a4[i] + b[8] * a2[i];
            }
            matmul(k, a6, u, v);
            for i in 0..k * k {
                v[i] += b[6] * a6[i] + b[4] * a4[i] + b[2] * a2[i];
            }
            for d in 0..k {
                w[d * k + d] += b[1];
                v[d * k + d] += b[0];
            }
        } else {
            let b: &[f64] = match m {
                3 => &PADE3,
                5 => &PADE5,
                7 => &PADE7,
                _ => &PADE9,
            };
            if m >= 5 {
                matmul(k, a2, a2, a4);
            }
            if m >= 7 {
                matmul(k, a4, a2, a6);
            }
            if m >= 9 {
                matmul(k, a6, a2, a8);
            }
            let powers: [&[f64]; 4] = [a2, a4, a6, a8];
            w.fill(0.0);
            v.fill(0.0);
            // Powers A^(2j), j = 1..=(m-1)/2: w += b_(2j+1) A^(2j), v += b_(2j) A^(2j).
            for (j, p) in powers.iter().enumerate().take((m as usize - 1) / 2) {
                let (bo, be) = (b[2 * j + 3], b[2 * j + 2]);
                for i in 0..k * k {
                    w[i] += bo * p[i];
                    v[i] += be * p[i];
                }
            }
            for d in 0..k {
                w[d * k + d] += b[1];
                v[d * k + d] += b[0];
            }
        }
        matmul(k, a, w, u); // U = A * odd part
                            // out = V + U (right-hand side), w = V − U (matrix).
        for i in 0..k * k {
            out[i] = v[i] + u[i];
            w[i] = v[i] - u[i];
        }
        if solve_in_place(k, w, out) {
            Ok(())
        } else {
            Err(ReconstructError::ExpmSingular { degree: m })
        }
    }
}

/// `exp(a)` of a row-major `k × k` matrix, allocating its result (see [`Expm`] for the
/// workspace form).
pub fn expm(k: usize, a: &[f64]) -> Result<Vec<f64>, ReconstructError> {
    let mut out = vec![0.0; k * k];
    Expm::new(k).compute(a, &mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    // ---------- helpers (model-specific representations live only here) ----------

    /// so(3), hat map: `ŵ x = w × x`.
    fn so3() -> Representation {
        #[rustfmt::skip]
        let basis = vec![
            0.0, 0.0, 0.0,   0.0, 0.0, -1.0,   0.0, 1.0, 0.0,
            0.0, 0.0, 1.0,   0.0, 0.0, 0.0,    -1.0, 0.0, 0.0,
            0.0, -1.0, 0.0,  1.0, 0.0, 0.0,    0.0, 0.0, 0.0,
        ];
        Representation::new(3, 3, basis).unwrap()
    }

    fn eye(k: usize) -> Vec<f64> {
        let mut m = vec![0.0; k * k];
        for d in 0..k {
            m[d * k + d] = 1.0;
        }
        m
    }

    fn mul(k: usize, a: &[f64], b: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; k * k];
        matmul(k, a, b, &mut out);
        out
    }

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        assert_eq!(a.len(), b.len());
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    fn max_abs(a: &[f64]) -> f64 {
        a.iter().map(|x| x.abs()).fold(0.0, f64::max)
    }

    /// Rodrigues: `exp(t ŵ)`.
    fn rodrigues(w: [f64; 3], t: f64) -> Vec<f64> {
        let th = t * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        let wt = [w[0] * t, w[1] * t, w[2] * t];
        let mut hat = vec![0.0; 9];
        so3().hat(&wt, &mut hat);
        let hat2 = mul(3, &hat, &hat);
        let (a, b) = if th.abs() < 1e-8 {
            (1.0 - th * th / 6.0, 0.5 - th * th / 24.0)
        } else {
            (th.sin() / th, (1.0 - th.cos()) / (th * th))
        };
        let mut r = eye(3);
        for i in 0..9 {
            r[i] += a * hat[i] + b * hat2[i];
        }
        r
    }

    // ---------- representation ----------

    #[test]
    fn hat_of_so3_is_the_cross_product_matrix() {
        let rep = so3();
        assert_eq!((rep.n(), rep.k()), (3, 3));
        let mut h = vec![0.0; 9];
        rep.hat(&[1.0, 2.0, 3.0], &mut h);
        assert_eq!(h, vec![0.0, -3.0, 2.0, 3.0, 0.0, -1.0, -2.0, 1.0, 0.0]);
        assert_eq!(
            rep.basis_matrix(2),
            &[0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        );
    }

    // ---------- matrix exponential ----------

    fn rel_err(a: &[f64], reference: &[f64]) -> f64 {
        max_abs_diff(a, reference) / max_abs(reference)
    }

    #[test]
    fn expm_diagonalizable_all_degrees() {
        // A = S diag(λ) S⁻¹ with S unit upper bidiagonal (not normal).
        let s = [1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0];
        let s_inv = [1.0, -1.0, 1.0, 0.0, 1.0, -1.0, 0.0, 0.0, 1.0];
        let diag = |l: [f64; 3]| {
            let mut d = vec![0.0; 9];
            for i in 0..3 {
                d[4 * i] = l[i];
            }
            d
        };
        let mut degrees = Vec::new();
        let mut worst: f64 = 0.0;
        let mut ws = Expm::new(3);
        for (scale, lambda) in [
            (1e-3, [1.0, -2.0, 0.5]),
            (0.02, [1.0, -2.0, 0.5]),
            (0.05, [1.0, -2.0, 0.5]),
            (0.2, [1.0, -2.0, 0.5]),
            (0.5, [1.0, -2.0, 0.5]),
            (1.0, [1.0, -2.0, 0.5]),
            (3.0, [1.0, -2.0, 0.5]),
            (1.0, [4.0, -7.0, 2.5]),
        ] {
            let l = lambda.map(|x| x * scale);
            let a = mul(3, &mul(3, &s, &diag(l)), &s_inv);
            let reference = mul(3, &mul(3, &s, &diag(l.map(f64::exp))), &s_inv);
            let mut e = vec![0.0; 9];
            let info = ws.compute(&a, &mut e).unwrap();
            let r = rel_err(&e, &reference);
            println!(
                "expm diagonalizable ‖A‖₁ = {:.3}: {info:?}, rel error {r:.2e}",
                norm1(3, &a)
            );
            degrees.push(info.degree);
            worst = worst.max(r);
        }
        assert!(worst <= 1e-12, "{worst}");
        for m in [3, 5, 7, 9, 13] {
            assert!(
                degrees.contains(&m),
                "degree {m} not exercised: {degrees:?}"
            );
        }
    }

    #[test]
    fn expm_nilpotent_is_exact() {
        // A⁴ = 0: exp(A) = I + A + A²/2 + A³/6; entries chosen so that it is representable.
        #[rustfmt::skip]
        let a = vec![
            0.0, 2.0, -4.0, 8.0,
            0.0, 0.0, 3.0, 6.0,
            0.0, 0.0, 0.0, -2.0,
            0.0, 0.0, 0.0, 0.0,
        ];
        let a2 = mul(4, &a, &a);
        let a3 = mul(4, &a2, &a);
        let mut reference = eye(4);
        for i in 0..16 {
            reference[i] += a[i] + a2[i] / 2.0 + a3[i] / 6.0;
        }
        let mut e = vec![0.0; 16];
        let info = Expm::new(4).compute(&a, &mut e).unwrap();
        let r = rel_err(&e, &reference);
        println!("expm nilpotent: {info:?}, rel error {r:.2e}");
        assert!(info.squarings >= 1);
        assert!(r <= 1e-14, "{r}");
        // exp(0) = I exactly.
        assert_eq!(expm(4, &[0.0; 16]).unwrap(), eye(4));
    }

    #[test]
    fn expm_large_norm_rotation_matches_rodrigues() {
        let rep = so3();
        let mut worst: f64 = 0.0;
        for (norm, dir) in [
            (50.0_f64, [0.3_f64, -0.5, 0.8]),
            (47.0, [1.0, 0.2, -0.1]),
            (300.0, [-0.6, 0.6, 0.5]),
        ] {
            let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
            let w = dir.map(|x| x * norm / len);
            let mut a = vec![0.0; 9];
            rep.hat(&w, &mut a);
            let e = expm(3, &a).unwrap();
            let r = rel_err(&e, &rodrigues(w, 1.0));
            let info = Expm::new(3).compute(&a, &mut [0.0; 9]).unwrap();
            println!(
                "expm rotation |w| = {norm}: ‖A‖₁ = {:.1}, {info:?}, rel error {r:.2e}",
                norm1(3, &a)
            );
            worst = worst.max(r);
        }
        assert!(worst <= 1e-12, "{worst}");
    }

    #[test]
    fn expm_scalar_matches_exp() {
        // The relative condition number of exp at x is |x|, and each squaring doubles the
        // relative error of the Padé value (itself up to ~e^θ₁₃ u from cancellation in the
        // denominator for x > 0): exp(700) (8 squarings) is off by ~1.7e-13.
        for x in [-30.0_f64, -1.0, 1e-10, 0.1, 4.0, 20.0, 700.0] {
            let e = expm(1, &[x]).unwrap()[0];
            let r = (e - x.exp()).abs() / x.exp();
            println!("expm scalar x = {x}: rel error {r:.2e}");
            assert!(r <= 1e-12, "exp({x}): {e} vs {}, rel {r:e}", x.exp());
        }
    }

    #[test]
    fn expm_errors() {
        let mut ws = Expm::new(2);
        let mut out = vec![0.0; 4];
        assert_eq!(
            ws.compute(&[0.0; 3], &mut out),
            Err(ReconstructError::MatrixLength {
                what: "expm argument",
                expected: 4,
                got: 3
            })
        );
        assert!(matches!(
            ws.compute(&[0.0, 1.0, f64::NAN, 0.0], &mut out),
            Err(ReconstructError::NonFiniteMatrix { row: 1, col: 0, .. })
        ));
        assert_eq!(
            ws.compute(&[f64::MAX, 0.0, f64::MAX, 0.0], &mut out),
            Err(ReconstructError::ExpmOverflow)
        );
        // Finite norm, but exp(A) is not representable.
        assert_eq!(
            ws.compute(&[800.0, 0.0, 0.0, -1.0], &mut out),
            Err(ReconstructError::ExpmOverflow)
        );
    }

    // ---------- errors ----------

    #[test]
    fn representation_errors() {
        use ReconstructError as E;
        assert_eq!(Representation::new(1, 0, vec![]), Err(E::ZeroMatrixSize));
        assert_eq!(Representation::new(0, 3, vec![]), Err(E::EmptyBasis));
        assert_eq!(
            Representation::new(2, 3, vec![0.0; 17]),
            Err(E::BasisLength {
                n: 2,
                k: 3,
                expected: 18,
                got: 17
            })
        );
        let mut basis = vec![0.0; 18];
        basis[9 + 5] = f64::INFINITY;
        assert_eq!(
            Representation::new(2, 3, basis),
            Err(E::NonFiniteBasis {
                index: 1,
                row: 1,
                col: 2,
                value: f64::INFINITY
            })
        );
        let msg = E::BasisLength {
            n: 2,
            k: 3,
            expected: 18,
            got: 17,
        }
        .to_string();
        assert_eq!(msg, "the basis has 17 entries, expected n*k*k = 2*3*3 = 18");
    }
}
