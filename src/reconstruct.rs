//! Reconstruction of the group motion `ġ = g Ω̂(t)` from a body velocity `Ω(t)`, for any
//! Lie algebra given by a matrix representation. Nothing here knows a model.
//!
//! # What is computed
//!
//! A model supplies a faithful representation of its Lie algebra: `n` matrices `E_1..E_n`,
//! each `k × k` ([`Representation`]); `Ω̂ = Σ Ω_i E_i` is the *hat* map. Given the
//! left-trivialised velocity `Ω(t) = g⁻¹ġ ∈ Rⁿ` and `g(a) = g_a`, [`reconstruct`] returns `g`
//! (a `k × k` matrix) at the requested output times, e.g. the attitude `R(t) ∈ SO(3)` of
//! Suslov's body from its body angular velocity, or a planar pose in `SE(2)`.
//!
//! # How: a 4th-order Magnus integrator
//!
//! With `A(t) = Ω̂(t)`, a step of size `h` from `t` evaluates `A` at the two Gauss–Legendre
//! points `A₁ = A(t + c₁h)`, `A₂ = A(t + c₂h)`, `c₁,₂ = 1/2 ∓ √3/6`, and sets
//!
//! ```text
//! Ω_M = h/2 (A₁ + A₂) + (√3/12) h² [A₁, A₂],     g ← g · exp(Ω_M).
//! ```
//!
//! The sign of the commutator matters. The textbook formula (Blanes, Casas, Oteo & Ros) is
//! written for *left* multiplication `Ẏ = B Y`, where `Y(t+h) = exp(Ω_B) Y(t)` with
//! `Ω_B = h/2 (B₁ + B₂) + (√3/12) h² [B₂, B₁]` (the second Magnus term is
//! `½∫∫_{s<r} [B(r), B(s)]`). Our equation `ġ = g A` is its transpose: `Y = gᵀ`, `B = Aᵀ`, so
//! `g(t+h) = g(t) exp(Ω_Bᵀ)` and `[B₂, B₁]ᵀ = [A₁, A₂]`. Hence the order of the commutator is
//! *reversed* for right multiplication. The tests check it against an exact non-commuting
//! solution, `g = exp(tX) exp(tY)`, for which `g⁻¹ġ = exp(−tY) X exp(tY) + Y`: with
//! `[A₁, A₂]` the observed order is 4; with `[A₂, A₁]` it drops to 2.
//!
//! # Why Magnus: the result stays on the group
//!
//! `Ω_M` is a linear combination of `Ω̂` values and of one bracket, so it lies in the Lie
//! algebra (the image of a representation is closed under the bracket; [`Representation`]
//! does not check this, it is the model's promise), and `exp(Ω_M)` lies in the group. Every step multiplies `g` by an exact group element up to the round-off of the
//! matrix exponential and of the product: there is no truncation drift off the group (an
//! explicit Runge–Kutta method on `ġ = gΩ̂` would leave `SO(3)` at the rate of its local
//! error). Deviations such as `‖gᵀg − I‖` on `SO(n)` grow only with the accumulated
//! round-off, at most a few units of roundoff per step (measured in the tests: `8e-14` after
//! `10⁵` steps on SO(3)).
//!
//! Whether `g` is on the group cannot be measured without knowing the group, so the
//! accuracy reported is generic instead: each reconstruction runs twice, with steps `h` and
//! `h/2`, and returns the `h/2` run together with the largest entrywise difference between
//! the two runs at the output times ([`Reconstruction::error_estimate`]). For an order-4
//! method `e_h ≈ 16 e_{h/2}`, so the difference is `≈ (15/16) e_h ≈ 15 e_{h/2}`: it estimates
//! the error of the `h` run and is, in the asymptotic regime, a conservative (about 15×)
//! bound on the error of the returned `h/2` run. Near round-off level it only says "small".
//!
//! # The matrix exponential
//!
//! [`Expm`] is the scaling and squaring method with diagonal Padé approximants of degree
//! 3, 5, 7, 9 or 13 of N. J. Higham, *The scaling and squaring method for the matrix
//! exponential revisited*, SIAM J. Matrix Anal. Appl. 26(4), 1179–1193 (2005), Algorithm 2.3,
//! with the thresholds `θ_m` of its Table 2.3 (the 1-norm bounds below which the degree-`m`
//! approximant has backward error at most the unit roundoff `2⁻⁵³`). Magnus steps are
//! short, so most calls take the cheap low-degree branches without squaring. The workspace is
//! allocated once; the integration loop does not allocate.
//!
//! # Storage
//!
//! Matrices are `&[f64]` of length `k²`, row-major: entry `(r, c)` is `m[r * k + c]`.

use serde::Serialize;

/// Failures of [`Representation::new`], [`Expm::compute`] and [`reconstruct`].
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
    /// No output times were given.
    #[error("no output times: at least the initial time a is needed")]
    NoTimes,
    /// An output time is NaN or infinite.
    #[error("output time {index} (0-based) is not finite: {value}")]
    NonFiniteTime {
        /// Position in `times`.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The output times are not strictly increasing.
    #[error("output times must be strictly increasing: times[{index}] = {value} does not exceed the previous time {previous}")]
    TimesNotIncreasing {
        /// Position of the offending time.
        index: usize,
        /// `times[index - 1]`.
        previous: f64,
        /// `times[index]`.
        value: f64,
    },
    /// The gap between two output times overflows (`times[index] − times[index − 1]` is
    /// infinite).
    #[error(
        "the interval ending at output time {index} (0-based) is too long: its length overflows"
    )]
    IntervalOverflow {
        /// Position of the later time.
        index: usize,
    },
    /// [`StepSize::MaxStep`] is not finite and positive.
    #[error("invalid options: max_step must be finite and > 0, got {value}")]
    InvalidMaxStep {
        /// The value.
        value: f64,
    },
    /// [`StepSize::Substeps`] is 0.
    #[error("invalid options: the number of substeps per output interval must be >= 1, got 0")]
    ZeroSubsteps,
    /// [`ReconstructOptions::max_steps`] is 0.
    #[error("invalid options: max_steps must be >= 1, got 0")]
    ZeroMaxSteps,
    /// The requested steps exceed [`ReconstructOptions::max_steps`].
    #[error("the step size needs at least {needed:e} Magnus steps (returned run), more than max_steps = {limit}")]
    TooManySteps {
        /// Steps of the returned (`h/2`) run counted up to the interval where the limit was
        /// passed (a lower bound on the total).
        needed: f64,
        /// The limit.
        limit: usize,
    },
    /// `Ω(t)` returned a NaN or infinite component, or did not write it (the buffer is
    /// filled with NaN before each call).
    #[error("Omega(t) at t = {t} has the non-finite component {component} (0-based): {value} (or it was not written)")]
    NonFiniteOmega {
        /// Evaluation time.
        t: f64,
        /// Component (0-based).
        component: usize,
        /// The value.
        value: f64,
    },
    /// `g` or the Magnus generator overflowed during the step that starts at `t`.
    #[error(
        "the group element became non-finite in the step from t = {t} (|Omega| h or g too large)"
    )]
    NonFiniteSolution {
        /// Start of the failing step.
        t: f64,
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

/// How each output interval `[t_i, t_{i+1}]` is split into Magnus steps. This defines the
/// step `h` of the check run; the returned run uses `h/2` (twice as many steps).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum StepSize {
    /// `N_i = ⌈(t_{i+1} − t_i)/h_max⌉` equal steps of the check run (so at most `h_max`;
    /// the returned run's steps are at most `h_max/2`). Finite and `> 0`.
    MaxStep(f64),
    /// A fixed number `N ≥ 1` of equal steps per output interval in the check run (`2N` in
    /// the returned run).
    Substeps(usize),
}

/// Options of [`reconstruct`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReconstructOptions {
    /// Step size of the check run (default: `MaxStep(0.01)`).
    pub step: StepSize,
    /// Upper bound on the number of Magnus steps of the returned run (default `10⁷`; values
    /// above `2⁵²` act as `2⁵²`); checked before any work is done.
    pub max_steps: usize,
}

impl Default for ReconstructOptions {
    fn default() -> Self {
        Self {
            step: StepSize::MaxStep(0.01),
            max_steps: 10_000_000,
        }
    }
}

impl ReconstructOptions {
    /// Checks `MaxStep` finite and `> 0`, `Substeps ≥ 1`, `max_steps ≥ 1`.
    pub fn validate(&self) -> Result<(), ReconstructError> {
        match self.step {
            StepSize::MaxStep(h) if !(h.is_finite() && h > 0.0) => {
                return Err(ReconstructError::InvalidMaxStep { value: h })
            }
            StepSize::Substeps(0) => return Err(ReconstructError::ZeroSubsteps),
            _ => {}
        }
        if self.max_steps == 0 {
            return Err(ReconstructError::ZeroMaxSteps);
        }
        Ok(())
    }
}

/// `g` at the output times, with the step-doubling error estimate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reconstruction {
    /// Matrix size.
    pub k: usize,
    /// The output times, as requested (`times[0] = a`).
    pub times: Vec<f64>,
    /// `g` at `times[i]` is `g[i k² .. (i+1) k²]`, row-major (the `h/2` run; `g` at
    /// `times[0]` is `g_a`). See [`Reconstruction::at`].
    pub g: Vec<f64>,
    /// Magnus steps of the returned (`h/2`) run.
    pub steps: usize,
    /// Magnus steps of the check (`h`) run (half of `steps`).
    pub check_steps: usize,
    /// Largest entrywise `|g_h − g_{h/2}|` at each output time.
    pub error_estimates: Vec<f64>,
    /// The largest of [`error_estimates`](Self::error_estimates): `≈ 15/16` of the error of
    /// the `h` run and asymptotically about 15 times the error of the returned `h/2` run (see
    /// the [module docs](self)).
    pub error_estimate: f64,
}

impl Reconstruction {
    /// `g` at `times[i]` (row-major `k × k`).
    ///
    /// # Panics
    /// If `i >= times.len()`.
    pub fn at(&self, i: usize) -> &[f64] {
        let kk = self.k * self.k;
        &self.g[i * kk..(i + 1) * kk]
    }
}

/// `√3`, to the precision of `f64`.
const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// `Ω_M = h/2 (A₁ + A₂) + (√3/12) h² [A₁, A₂]` (the commutator order for `ġ = g A`, see the
/// module docs). `tmp` and `tmp2` are workspace.
fn magnus_generator(
    k: usize,
    a1: &[f64],
    a2: &[f64],
    h: f64,
    out: &mut [f64],
    tmp: &mut [f64],
    tmp2: &mut [f64],
) {
    matmul(k, a1, a2, tmp);
    matmul(k, a2, a1, tmp2);
    let c = SQRT_3 / 12.0 * h * h;
    for i in 0..k * k {
        out[i] = 0.5 * h * (a1[i] + a2[i]) + c * (tmp[i] - tmp2[i]);
    }
}

/// The workspace of one Magnus run.
struct Stepper<'r> {
    rep: &'r Representation,
    omega: Vec<f64>,
    a1: Vec<f64>,
    a2: Vec<f64>,
    gen: Vec<f64>,
    e: Vec<f64>,
    tmp: Vec<f64>,
    tmp2: Vec<f64>,
    expm: Expm,
}

impl<'r> Stepper<'r> {
    fn new(rep: &'r Representation) -> Self {
        let kk = rep.k * rep.k;
        Self {
            rep,
            omega: vec![0.0; rep.n],
            a1: vec![0.0; kk],
            a2: vec![0.0; kk],
            gen: vec![0.0; kk],
            e: vec![0.0; kk],
            tmp: vec![0.0; kk],
            tmp2: vec![0.0; kk],
            expm: Expm::new(rep.k),
        }
    }

    /// `out = Ω̂(t)`, rejecting non-finite (or unwritten) components.
    fn eval_hat<F: FnMut(f64, &mut [f64])>(
        rep: &Representation,
        omega: &mut F,
        buf: &mut [f64],
        t: f64,
        out: &mut [f64],
    ) -> Result<(), ReconstructError> {
        buf.fill(f64::NAN);
        omega(t, buf);
        if let Some(component) = buf.iter().position(|v| !v.is_finite()) {
            return Err(ReconstructError::NonFiniteOmega {
                t,
                component,
                value: buf[component],
            });
        }
        rep.hat(buf, out);
        Ok(())
    }

    /// One Magnus step `g ← g exp(Ω_M)` from `t` with step `h`.
    fn step<F: FnMut(f64, &mut [f64])>(
        &mut self,
        omega: &mut F,
        t: f64,
        h: f64,
        g: &mut [f64],
    ) -> Result<(), ReconstructError> {
        let k = self.rep.k;
        let half_width = SQRT_3 / 6.0;
        Self::eval_hat(
            self.rep,
            omega,
            &mut self.omega,
            t + (0.5 - half_width) * h,
            &mut self.a1,
        )?;
        Self::eval_hat(
            self.rep,
            omega,
            &mut self.omega,
            t + (0.5 + half_width) * h,
            &mut self.a2,
        )?;
        magnus_generator(
            k,
            &self.a1,
            &self.a2,
            h,
            &mut self.gen,
            &mut self.tmp,
            &mut self.tmp2,
        );
        if !self.gen.iter().all(|v| v.is_finite()) {
            return Err(ReconstructError::NonFiniteSolution { t });
        }
        match self.expm.compute(&self.gen, &mut self.e) {
            Ok(_) => {}
            Err(ReconstructError::ExpmOverflow) => {
                return Err(ReconstructError::NonFiniteSolution { t })
            }
            Err(e) => return Err(e),
        }
        matmul(k, g, &self.e, &mut self.tmp);
        if !self.tmp.iter().all(|v| v.is_finite()) {
            return Err(ReconstructError::NonFiniteSolution { t });
        }
        g.copy_from_slice(&self.tmp);
        Ok(())
    }

    /// Integrates from `g_a` with `counts[i] * refine` equal steps on output interval `i`;
    /// writes `g` at every output time into `out`.
    fn run<F: FnMut(f64, &mut [f64])>(
        &mut self,
        omega: &mut F,
        g_a: &[f64],
        times: &[f64],
        counts: &[usize],
        refine: usize,
        out: &mut [f64],
    ) -> Result<(), ReconstructError> {
        let kk = g_a.len();
        let mut g = g_a.to_vec();
        out[..kk].copy_from_slice(&g);
        for (i, (w, &count)) in times.windows(2).zip(counts).enumerate() {
            let steps = count * refine;
            let h = (w[1] - w[0]) / steps as f64;
            for j in 0..steps {
                self.step(omega, w[0] + j as f64 * h, h, &mut g)?;
            }
            out[(i + 1) * kk..(i + 2) * kk].copy_from_slice(&g);
        }
        Ok(())
    }
}

/// Integrates `ġ = g Ω̂(t)`, `g(times[0]) = g_a`, and returns `g` at every output time.
///
/// - `g_a`: `k²` finite entries (row-major). Whether it lies in the group is the caller's
///   business; the increments `exp(Ω_M)` do.
/// - `times`: finite and strictly increasing; `times[0]` is the initial time `a`.
/// - `omega(t, out)`: writes `Ω(t)` (all `n` components; the buffer is filled with NaN before
///   each call, so an unwritten component is reported, not used). Evaluated at the two Gauss
///   points inside each step, never at the output times themselves (up to rounding), so
///   `Ω` may be discontinuous there; between output times it should be smooth for order 4.
///
/// Runs the 4th-order Magnus integrator (module docs) twice, with step `h` from
/// `opts.step` and with `h/2`, and returns the `h/2` run with the step-doubling estimate.
/// The work is `3/2 ×` [`Reconstruction::steps`] Magnus steps. Errors instead of panicking on
/// invalid input, non-finite `Ω` and overflow.
///
/// # Example: a rotation about `e_3` at unit rate, on SO(3)
///
/// ```
/// use suslov::reconstruct::{reconstruct, ReconstructOptions, Representation};
///
/// #[rustfmt::skip]
/// let so3 = Representation::new(3, 3, vec![
///     0.0, 0.0, 0.0,   0.0, 0.0, -1.0,   0.0, 1.0, 0.0,  // ê_1
///     0.0, 0.0, 1.0,   0.0, 0.0, 0.0,   -1.0, 0.0, 0.0,  // ê_2
///     0.0, -1.0, 0.0,  1.0, 0.0, 0.0,    0.0, 0.0, 0.0,  // ê_3
/// ])?;
/// let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let t1 = std::f64::consts::FRAC_PI_2;
/// let opts = ReconstructOptions::default();
/// let omega = |_t: f64, w: &mut [f64]| w.copy_from_slice(&[0.0, 0.0, 1.0]);
/// let rec = reconstruct(&so3, &identity, &[0.0, t1], omega, &opts)?;
/// let quarter_turn = [0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
/// // 316 steps of size ≤ 0.005: only round-off is left.
/// assert!(rec.at(1).iter().zip(&quarter_turn).all(|(a, b)| (a - b).abs() < 1e-13));
/// assert!(rec.error_estimate < 1e-13);
/// # Ok::<(), suslov::reconstruct::ReconstructError>(())
/// ```
pub fn reconstruct<F: FnMut(f64, &mut [f64])>(
    rep: &Representation,
    g_a: &[f64],
    times: &[f64],
    mut omega: F,
    opts: &ReconstructOptions,
) -> Result<Reconstruction, ReconstructError> {
    opts.validate()?;
    let k = rep.k;
    let kk = k * k;
    if g_a.len() != kk {
        return Err(ReconstructError::MatrixLength {
            what: "initial element g_a",
            expected: kk,
            got: g_a.len(),
        });
    }
    if let Some(pos) = g_a.iter().position(|v| !v.is_finite()) {
        return Err(ReconstructError::NonFiniteMatrix {
            what: "initial element g_a",
            row: pos / k,
            col: pos % k,
            value: g_a[pos],
        });
    }
    if times.is_empty() {
        return Err(ReconstructError::NoTimes);
    }
    if let Some(index) = times.iter().position(|t| !t.is_finite()) {
        return Err(ReconstructError::NonFiniteTime {
            index,
            value: times[index],
        });
    }
    // Steps per interval of the check run; the total of the returned run is bounded first.
    // Capped so that step counts are exact in f64 and cannot overflow usize.
    let limit = opts.max_steps.min(1 << 52);
    let mut counts = Vec::with_capacity(times.len() - 1);
    let mut total = 0.0_f64;
    for (i, w) in times.windows(2).enumerate() {
        let index = i + 1;
        if w[1] <= w[0] {
            return Err(ReconstructError::TimesNotIncreasing {
                index,
                previous: w[0],
                value: w[1],
            });
        }
        let dt = w[1] - w[0];
        if !dt.is_finite() {
            return Err(ReconstructError::IntervalOverflow { index });
        }
        let count = match opts.step {
            StepSize::MaxStep(h_max) => (dt / h_max).ceil().max(1.0),
            StepSize::Substeps(m) => m as f64,
        };
        total += 2.0 * count;
        if total > limit as f64 {
            return Err(ReconstructError::TooManySteps {
                needed: total,
                limit,
            });
        }
        counts.push(count as usize);
    }
    let mut stepper = Stepper::new(rep);
    let mut coarse = vec![0.0; times.len() * kk];
    stepper.run(&mut omega, g_a, times, &counts, 1, &mut coarse)?;
    let mut fine = vec![0.0; times.len() * kk];
    stepper.run(&mut omega, g_a, times, &counts, 2, &mut fine)?;
    let error_estimates: Vec<f64> = coarse
        .chunks_exact(kk)
        .zip(fine.chunks_exact(kk))
        .map(|(c, f)| {
            c.iter()
                .zip(f)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let error_estimate = error_estimates.iter().copied().fold(0.0, f64::max);
    let check_steps: usize = counts.iter().sum();
    Ok(Reconstruction {
        k,
        times: times.to_vec(),
        g: fine,
        steps: 2 * check_steps,
        check_steps,
        error_estimates,
        error_estimate,
    })
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

    /// se(2) in homogeneous coordinates, `Ω = (ω, v1, v2)`.
    fn se2() -> Representation {
        #[rustfmt::skip]
        let basis = vec![
            0.0, -1.0, 0.0,  1.0, 0.0, 0.0,  0.0, 0.0, 0.0,
            0.0, 0.0, 1.0,   0.0, 0.0, 0.0,  0.0, 0.0, 0.0,
            0.0, 0.0, 0.0,   0.0, 0.0, 1.0,  0.0, 0.0, 0.0,
        ];
        Representation::new(3, 3, basis).unwrap()
    }

    /// so(4), `E_ij = e_i e_jᵀ − e_j e_iᵀ` for `i < j` in lexicographic order.
    fn so4() -> Representation {
        let mut basis = Vec::new();
        for i in 0..4 {
            for j in i + 1..4 {
                let mut e = vec![0.0; 16];
                e[i * 4 + j] = 1.0;
                e[j * 4 + i] = -1.0;
                basis.extend(e);
            }
        }
        Representation::new(6, 4, basis).unwrap()
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

    fn transpose(k: usize, a: &[f64]) -> Vec<f64> {
        let mut t = vec![0.0; k * k];
        for r in 0..k {
            for c in 0..k {
                t[c * k + r] = a[r * k + c];
            }
        }
        t
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

    /// `max |gᵀg − I|`.
    fn orthogonality_defect(k: usize, g: &[f64]) -> f64 {
        max_abs_diff(&mul(k, &transpose(k, g), g), &eye(k))
    }

    /// Determinant by Gaussian elimination with partial pivoting.
    fn det(k: usize, a: &[f64]) -> f64 {
        let mut m = a.to_vec();
        let mut d = 1.0;
        for col in 0..k {
            let p = (col..k)
                .max_by(|&r, &s| m[r * k + col].abs().total_cmp(&m[s * k + col].abs()))
                .unwrap();
            if p != col {
                for c in 0..k {
                    m.swap(p * k + c, col * k + c);
                }
                d = -d;
            }
            let piv = m[col * k + col];
            d *= piv;
            for r in col + 1..k {
                let f = m[r * k + col] / piv;
                for c in col..k {
                    m[r * k + c] -= f * m[col * k + c];
                }
            }
        }
        d
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

    /// `R v` for a row-major 3×3 `R`.
    fn apply3(r: &[f64], v: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| r[3 * i] * v[0] + r[3 * i + 1] * v[1] + r[3 * i + 2] * v[2])
    }

    fn linspace(a: f64, b: f64, m: usize) -> Vec<f64> {
        (0..=m).map(|i| a + (b - a) * i as f64 / m as f64).collect()
    }

    fn opts(step: StepSize) -> ReconstructOptions {
        ReconstructOptions {
            step,
            ..ReconstructOptions::default()
        }
    }

    /// The exact non-commuting so(3) motion `g(t) = g_a exp(τX̂) exp(τŶ)`, `τ = t − a`:
    /// `g⁻¹ġ = (exp(−τŶ) x)^ + Ŷ`, i.e. `Ω(t) = R(−τ y) x + y`.
    const X: [f64; 3] = [0.9, -0.4, 0.3];
    const Y: [f64; 3] = [0.2, 0.8, -0.5];

    fn exact_omega(a: f64) -> impl Fn(f64, &mut [f64]) {
        move |t, out| {
            let r = rodrigues(Y, -(t - a));
            let v = apply3(&r, X);
            for i in 0..3 {
                out[i] = v[i] + Y[i];
            }
        }
    }

    fn exact_g(g_a: &[f64], a: f64, t: f64) -> Vec<f64> {
        let tau = t - a;
        mul(3, &mul(3, g_a, &rodrigues(X, tau)), &rodrigues(Y, tau))
    }

    /// Max entrywise error of a reconstruction against `exact` at all output times.
    fn max_error(rec: &Reconstruction, exact: impl Fn(f64) -> Vec<f64>) -> f64 {
        (0..rec.times.len())
            .map(|i| max_abs_diff(rec.at(i), &exact(rec.times[i])))
            .fold(0.0, f64::max)
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

    // ---------- so(3) ----------

    #[test]
    fn so3_constant_omega_matches_rodrigues() {
        let rep = so3();
        let w = [0.3, -1.2, 0.7];
        let a = 1.0;
        let g_a = rodrigues([0.5, 0.1, -0.8], 1.0);
        let times = linspace(a, a + 10.0, 20);
        let rec = reconstruct(
            &rep,
            &g_a,
            &times,
            |_, out| out.copy_from_slice(&w),
            &opts(StepSize::MaxStep(0.05)),
        )
        .unwrap();
        let err = max_error(&rec, |t| mul(3, &g_a, &rodrigues(w, t - a)));
        println!(
            "so3 constant: max error vs Rodrigues {err:.2e}, estimate {:.2e}, steps {}",
            rec.error_estimate, rec.steps
        );
        assert_eq!(rec.at(0), &g_a[..]);
        assert_eq!((rec.steps, rec.check_steps), (400, 200));
        assert!(err <= 1e-13, "{err}");
    }

    #[test]
    fn so3_long_time_varying_run_stays_on_so3() {
        let rep = so3();
        let times = linspace(0.0, 1000.0, 100);
        let rec = reconstruct(
            &rep,
            &eye(3),
            &times,
            |t, out| out.copy_from_slice(&[t.cos(), (2.0 * t).sin(), 0.3]),
            &opts(StepSize::MaxStep(0.02)),
        )
        .unwrap();
        let orth = (0..times.len())
            .map(|i| orthogonality_defect(3, rec.at(i)))
            .fold(0.0, f64::max);
        let det_err = (0..times.len())
            .map(|i| (det(3, rec.at(i)) - 1.0).abs())
            .fold(0.0, f64::max);
        println!(
            "so3 long run ({} steps): max |g'g - I| {orth:.2e}, max |det g - 1| {det_err:.2e}, estimate {:.2e}",
            rec.steps, rec.error_estimate
        );
        assert_eq!(rec.steps, 100_000);
        assert!(orth <= 1e-13, "{orth}");
        assert!(det_err <= 1e-13, "{det_err}");
        assert!(rec.error_estimate < 1e-6, "{}", rec.error_estimate);
    }

    #[test]
    fn so3_exact_noncommuting_solution_and_conservative_estimate() {
        let rep = so3();
        let a = -0.5;
        let g_a = rodrigues([0.1, 0.7, 0.2], 1.0);
        let times = linspace(a, a + 6.0, 12);
        let rec = reconstruct(
            &rep,
            &g_a,
            &times,
            exact_omega(a),
            &opts(StepSize::MaxStep(0.1)),
        )
        .unwrap();
        let err = max_error(&rec, |t| exact_g(&g_a, a, t));
        let ratio = rec.error_estimate / err;
        println!(
            "so3 exact non-commuting: error {err:.3e}, estimate {:.3e}, estimate/error {ratio:.2}",
            rec.error_estimate
        );
        assert!(err < 1e-6, "{err}");
        // Order 4: the h-vs-h/2 difference is ≈ 15 times the error of the h/2 run.
        assert!((12.0..18.0).contains(&ratio), "{ratio}");
    }

    /// Observed order `log2(e(h) / e(h/2))` of the returned runs for `Substeps(m)` and `2m`.
    fn observed_order(e1: f64, e2: f64) -> f64 {
        (e1 / e2).log2()
    }

    #[test]
    fn so3_order_four_against_exact_solution() {
        let rep = so3();
        let a = 0.0;
        let g_a = eye(3);
        let times = linspace(a, a + 4.0, 4);
        let run = |m: usize| {
            let rec = reconstruct(
                &rep,
                &g_a,
                &times,
                exact_omega(a),
                &opts(StepSize::Substeps(m)),
            )
            .unwrap();
            max_error(&rec, |t| exact_g(&g_a, a, t))
        };
        let (e1, e2) = (run(5), run(10));
        let p = observed_order(e1, e2);
        println!("so3 order vs exact: e(h) {e1:.3e}, e(h/2) {e2:.3e}, order {p:.3}");
        assert!((3.7..=4.3).contains(&p), "{p}");
    }

    #[test]
    fn so3_order_four_against_fine_reference() {
        let rep = so3();
        let times = linspace(0.0, 4.0, 4);
        let omega = |t: f64, out: &mut [f64]| out.copy_from_slice(&[t.cos(), (2.0 * t).sin(), 0.3]);
        let run =
            |m: usize| reconstruct(&rep, &eye(3), &times, omega, &opts(StepSize::Substeps(m)));
        let reference = run(2000).unwrap();
        let err = |m: usize| {
            let rec = run(m).unwrap();
            (0..times.len())
                .map(|i| max_abs_diff(rec.at(i), reference.at(i)))
                .fold(0.0, f64::max)
        };
        let (e1, e2) = (err(5), err(10));
        let p = observed_order(e1, e2);
        println!(
            "so3 order vs fine reference: e(h) {e1:.3e}, e(h/2) {e2:.3e}, order {p:.3} (reference estimate {:.1e})",
            reference.error_estimate
        );
        assert!(reference.error_estimate < 1e-12);
        assert!((3.7..=4.3).contains(&p), "{p}");
    }

    /// Fixed-step Magnus run with the commutator taken as `[A_first, A_second]`: the
    /// production order `(A₁, A₂)` or the left-multiplication order `(A₂, A₁)`.
    fn manual_magnus(steps: usize, t1: f64, swap: bool) -> Vec<f64> {
        let rep = so3();
        let omega = exact_omega(0.0);
        let h = t1 / steps as f64;
        let mut g = eye(3);
        let (mut a1, mut a2) = (vec![0.0; 9], vec![0.0; 9]);
        let (mut gen, mut tmp, mut tmp2, mut e) =
            (vec![0.0; 9], vec![0.0; 9], vec![0.0; 9], vec![0.0; 9]);
        let mut w = [0.0; 3];
        let mut expm = Expm::new(3);
        for j in 0..steps {
            let t = j as f64 * h;
            omega(t + (0.5 - SQRT_3 / 6.0) * h, &mut w);
            rep.hat(&w, &mut a1);
            omega(t + (0.5 + SQRT_3 / 6.0) * h, &mut w);
            rep.hat(&w, &mut a2);
            let (first, second) = if swap { (&a2, &a1) } else { (&a1, &a2) };
            magnus_generator(3, first, second, h, &mut gen, &mut tmp, &mut tmp2);
            expm.compute(&gen, &mut e).unwrap();
            g = mul(3, &g, &e);
        }
        g
    }

    #[test]
    fn commutator_order_for_right_multiplication() {
        let t1 = 4.0;
        let exact = exact_g(&eye(3), 0.0, t1);
        let order = |swap: bool| {
            let e1 = max_abs_diff(&manual_magnus(20, t1, swap), &exact);
            let e2 = max_abs_diff(&manual_magnus(40, t1, swap), &exact);
            (e1, e2, observed_order(e1, e2))
        };
        let right = order(false);
        let left = order(true);
        println!(
            "[A1, A2] (used): e(h) {:.3e}, e(h/2) {:.3e}, order {:.3}; [A2, A1] (left-multiplication formula): e(h) {:.3e}, e(h/2) {:.3e}, order {:.3}",
            right.0, right.1, right.2, left.0, left.1, left.2
        );
        assert!((3.7..=4.3).contains(&right.2), "{right:?}");
        assert!((1.7..=2.3).contains(&left.2), "{left:?}");
        assert!(left.1 > 100.0 * right.1);
    }

    // ---------- se(2) ----------

    /// Homogeneous pose `[[R(θ), p], [0, 1]]`.
    fn pose(theta: f64, x: f64, y: f64) -> Vec<f64> {
        let (s, c) = theta.sin_cos();
        vec![c, -s, x, s, c, y, 0.0, 0.0, 1.0]
    }

    /// Exact `g_a exp(τ Ω̂)` on SE(2) for constant `Ω = (ω, v1, v2)`, from the closed form of
    /// the body-frame displacement.
    fn se2_exact(g_a: &[f64], w: [f64; 3], tau: f64) -> Vec<f64> {
        let (om, v1, v2) = (w[0], w[1], w[2]);
        let (dx, dy) = if om == 0.0 {
            (v1 * tau, v2 * tau)
        } else {
            let (s, c) = (om * tau).sin_cos();
            (
                (v1 * s - v2 * (1.0 - c)) / om,
                (v1 * (1.0 - c) + v2 * s) / om,
            )
        };
        mul(3, g_a, &pose(om * tau, dx, dy))
    }

    #[test]
    fn se2_constant_twist_traces_the_exact_circle() {
        let rep = se2();
        let w = [0.7, 1.3, -0.4];
        let (theta0, x0, y0) = (0.3, 1.0, -2.0);
        let g_a = pose(theta0, x0, y0);
        let a = 2.0;
        let times = linspace(a, a + 20.0, 80);
        let rec = reconstruct(
            &rep,
            &g_a,
            &times,
            |_, out| out.copy_from_slice(&w),
            &opts(StepSize::MaxStep(0.05)),
        )
        .unwrap();
        // Closed form x(t), y(t), θ(t) = θ0 + ωτ.
        let err = max_error(&rec, |t| se2_exact(&g_a, w, t - a));
        // The circle: centre p0 + R(θ0) (−v2/ω, v1/ω), radius |v|/|ω|.
        let (s0, c0) = theta0.sin_cos();
        let (cx, cy) = (-w[2] / w[0], w[1] / w[0]);
        let centre = (x0 + c0 * cx - s0 * cy, y0 + s0 * cx + c0 * cy);
        let radius = w[1].hypot(w[2]) / w[0].abs();
        let mut radius_err: f64 = 0.0;
        let mut theta_err: f64 = 0.0;
        for (i, &t) in rec.times.iter().enumerate() {
            let g = rec.at(i);
            radius_err = radius_err.max(((g[2] - centre.0).hypot(g[5] - centre.1) - radius).abs());
            // θ(t) = θ0 + ωτ, compared through (cos θ, sin θ).
            let th = theta0 + w[0] * (t - a);
            theta_err = theta_err.max((g[0] - th.cos()).abs().max((g[3] - th.sin()).abs()));
            assert_eq!(&g[6..], &[0.0, 0.0, 1.0]);
        }
        println!(
            "se2 circle: max pose error {err:.2e}, radius error {radius_err:.2e}, theta error {theta_err:.2e}"
        );
        assert!(err <= 1e-12, "{err}");
        assert!(radius_err <= 1e-12, "{radius_err}");
        assert!(theta_err <= 1e-12, "{theta_err}");
    }

    #[test]
    fn se2_zero_rotation_is_a_straight_line() {
        let rep = se2();
        let w = [0.0, 1.5, -0.25];
        let g_a = pose(-0.8, 3.0, 0.5);
        let times = linspace(0.0, 10.0, 10);
        let rec = reconstruct(
            &rep,
            &g_a,
            &times,
            |_, out| out.copy_from_slice(&w),
            &opts(StepSize::MaxStep(0.1)),
        )
        .unwrap();
        let err = max_error(&rec, |t| se2_exact(&g_a, w, t));
        // Collinear with the start along R(θ0) v, orientation unchanged.
        let (s, c) = (-0.8f64).sin_cos();
        let dir = (c * w[1] - s * w[2], s * w[1] + c * w[2]);
        let off_line = (0..times.len())
            .map(|i| {
                let g = rec.at(i);
                ((g[2] - 3.0) * dir.1 - (g[5] - 0.5) * dir.0).abs()
            })
            .fold(0.0, f64::max);
        let rot_err = (0..times.len())
            .map(|i| max_abs_diff(&rec.at(i)[..2], &g_a[..2]))
            .fold(0.0, f64::max);
        println!("se2 line: max pose error {err:.2e}, distance off the line {off_line:.2e}");
        assert!(err <= 1e-12, "{err}");
        assert!(off_line <= 1e-12, "{off_line}");
        assert_eq!(rot_err, 0.0);
    }

    // ---------- so(4) ----------

    /// Coordinates of a skew 4×4 matrix in the `E_ij` basis: `Ω_ij = M[i][j]`.
    fn so4_coords(m: &[f64]) -> Vec<f64> {
        let mut w = Vec::new();
        for i in 0..4 {
            for j in i + 1..4 {
                w.push(m[i * 4 + j]);
            }
        }
        w
    }

    #[test]
    fn so4_constant_omega_matches_closed_form_exponential() {
        // Ω̂ = Q (θ1 J ⊕ θ2 J) Qᵀ with Q a Householder reflector, so that
        // exp(τΩ̂) = Q (R(θ1 τ) ⊕ R(θ2 τ)) Qᵀ in closed form.
        let v = [1.0, -2.0, 0.5, 3.0];
        let vv: f64 = v.iter().map(|x| x * x).sum();
        let mut q = eye(4);
        for i in 0..4 {
            for j in 0..4 {
                q[i * 4 + j] -= 2.0 * v[i] * v[j] / vv;
            }
        }
        let (th1, th2) = (1.3, -0.45);
        let block = |tau: f64, generator: bool| {
            let mut b = vec![0.0; 16];
            for (off, th) in [(0, th1), (2, th2)] {
                let (s, c) = if generator {
                    (th, 0.0)
                } else {
                    (th * tau).sin_cos()
                };
                b[off * 4 + off] = c;
                b[off * 4 + off + 1] = -s;
                b[(off + 1) * 4 + off] = s;
                b[(off + 1) * 4 + off + 1] = c;
            }
            mul(4, &mul(4, &q, &b), &transpose(4, &q))
        };
        let w = so4_coords(&block(0.0, true));
        let rep = so4();
        let mut check = vec![0.0; 16];
        rep.hat(&w, &mut check);
        assert!(max_abs_diff(&check, &block(0.0, true)) < 1e-15);
        let g_a = block(0.7, false); // some element of SO(4)
        let times = linspace(0.0, 10.0, 20);
        let rec = reconstruct(
            &rep,
            &g_a,
            &times,
            |_, out| out.copy_from_slice(&w),
            &opts(StepSize::MaxStep(0.05)),
        )
        .unwrap();
        let err = max_error(&rec, |t| mul(4, &g_a, &block(t, false)));
        println!("so4 constant: max error vs closed form {err:.2e}");
        assert!(err <= 1e-13, "{err}");
    }

    #[test]
    fn so4_time_varying_run_stays_on_so4() {
        let rep = so4();
        let times = linspace(0.0, 200.0, 50);
        let rec = reconstruct(
            &rep,
            &eye(4),
            &times,
            |t, out| {
                out.copy_from_slice(&[
                    t.cos(),
                    (2.0 * t).sin(),
                    0.3,
                    0.5 * (3.0 * t).cos(),
                    -0.2,
                    t.sin() * (0.5 * t).cos(),
                ])
            },
            &opts(StepSize::MaxStep(0.02)),
        )
        .unwrap();
        let orth = (0..times.len())
            .map(|i| orthogonality_defect(4, rec.at(i)))
            .fold(0.0, f64::max);
        let det_err = (0..times.len())
            .map(|i| (det(4, rec.at(i)) - 1.0).abs())
            .fold(0.0, f64::max);
        println!(
            "so4 run ({} steps): max |g'g - I| {orth:.2e}, |det - 1| {det_err:.2e}, estimate {:.2e}",
            rec.steps, rec.error_estimate
        );
        assert!(orth <= 1e-13, "{orth}");
        assert!(det_err <= 1e-13, "{det_err}");
        assert!(rec.error_estimate < 1e-7, "{}", rec.error_estimate);
    }

    // ---------- scalar group (k = 1): exact solution and overflow ----------

    #[test]
    fn one_dimensional_group_is_the_exponential_of_the_integral() {
        let rep = Representation::new(1, 1, vec![1.0]).unwrap();
        let times = linspace(0.0, 5.0, 10);
        let rec = reconstruct(
            &rep,
            &[2.0],
            &times,
            |t, out| out[0] = t.cos(),
            &opts(StepSize::MaxStep(0.05)),
        )
        .unwrap();
        let err = max_error(&rec, |t| vec![2.0 * t.sin().exp()]);
        println!(
            "k = 1: error {err:.2e}, estimate {:.2e}",
            rec.error_estimate
        );
        assert!(err < 1e-9 && err <= rec.error_estimate, "{err}");
        // A single time: g_a, no steps.
        let one = reconstruct(&rep, &[2.0], &[3.0], |_, o| o[0] = 1.0, &Default::default());
        let one = one.unwrap();
        assert_eq!(
            (one.g.clone(), one.steps, one.error_estimate),
            (vec![2.0], 0, 0.0)
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

    #[test]
    fn reconstruct_input_errors() {
        use ReconstructError as E;
        let rep = so3();
        let g = eye(3);
        let zero = |_: f64, o: &mut [f64]| o.fill(0.0);
        let d = ReconstructOptions::default();
        let run = |g_a: &[f64], times: &[f64], o: &ReconstructOptions| {
            reconstruct(&rep, g_a, times, zero, o)
        };
        assert_eq!(
            run(&g[..8], &[0.0, 1.0], &d),
            Err(E::MatrixLength {
                what: "initial element g_a",
                expected: 9,
                got: 8
            })
        );
        let mut bad = g.clone();
        bad[4] = f64::NAN;
        assert!(matches!(
            run(&bad, &[0.0, 1.0], &d),
            Err(E::NonFiniteMatrix { row: 1, col: 1, .. })
        ));
        assert_eq!(run(&g, &[], &d), Err(E::NoTimes));
        assert!(matches!(
            run(&g, &[0.0, f64::NAN], &d),
            Err(E::NonFiniteTime { index: 1, .. })
        ));
        assert_eq!(
            run(&g, &[0.0, 2.0, 1.0], &d),
            Err(E::TimesNotIncreasing {
                index: 2,
                previous: 2.0,
                value: 1.0
            })
        );
        assert_eq!(
            run(&g, &[0.0, 1.0, 1.0], &d),
            Err(E::TimesNotIncreasing {
                index: 2,
                previous: 1.0,
                value: 1.0
            })
        );
        assert_eq!(
            run(&g, &[-f64::MAX, f64::MAX], &d),
            Err(E::IntervalOverflow { index: 1 })
        );
        for (step, err) in [
            (StepSize::MaxStep(0.0), E::InvalidMaxStep { value: 0.0 }),
            (StepSize::MaxStep(-1.0), E::InvalidMaxStep { value: -1.0 }),
            (
                StepSize::MaxStep(f64::INFINITY),
                E::InvalidMaxStep {
                    value: f64::INFINITY,
                },
            ),
            (StepSize::Substeps(0), E::ZeroSubsteps),
        ] {
            assert_eq!(run(&g, &[0.0, 1.0], &opts(step)), Err(err));
        }
        assert!(matches!(
            run(&g, &[0.0, 1.0], &opts(StepSize::MaxStep(f64::NAN))),
            Err(E::InvalidMaxStep { value }) if value.is_nan()
        ));
        let huge = ReconstructOptions {
            step: StepSize::Substeps(usize::MAX),
            max_steps: usize::MAX,
        };
        assert!(matches!(
            run(&g, &[0.0, 1.0], &huge),
            Err(E::TooManySteps { limit, .. }) if limit == 1 << 52
        ));
        let no_steps = ReconstructOptions { max_steps: 0, ..d };
        assert_eq!(run(&g, &[0.0, 1.0], &no_steps), Err(E::ZeroMaxSteps));
        assert_eq!(
            run(&g, &[0.0, 1e9], &opts(StepSize::MaxStep(1e-3))),
            Err(E::TooManySteps {
                needed: 2e12,
                limit: 10_000_000
            })
        );
    }

    #[test]
    fn reconstruct_omega_and_overflow_errors() {
        use ReconstructError as E;
        let rep = so3();
        let g = eye(3);
        let d = opts(StepSize::MaxStep(0.1));
        // NaN after t = 0.5.
        let r = reconstruct(
            &rep,
            &g,
            &[0.0, 1.0],
            |t, o| o.copy_from_slice(&[1.0, if t > 0.5 { f64::NAN } else { 0.0 }, 0.0]),
            &d,
        );
        match r {
            Err(E::NonFiniteOmega {
                t,
                component: 1,
                value,
            }) => assert!(t > 0.5 && t < 0.6 && value.is_nan(), "t = {t}"),
            other => panic!("{other:?}"),
        }
        // Infinite component.
        assert!(matches!(
            reconstruct(&rep, &g, &[0.0, 1.0], |_, o| o.copy_from_slice(&[0.0, 0.0, f64::NEG_INFINITY]), &d),
            Err(E::NonFiniteOmega { component: 2, value, .. }) if value == f64::NEG_INFINITY
        ));
        // A component left unwritten is not silently used.
        assert!(matches!(
            reconstruct(&rep, &g, &[0.0, 1.0], |_, o| o[..2].fill(1.0), &d),
            Err(E::NonFiniteOmega { component: 2, value, .. }) if value.is_nan()
        ));
        // Overflow of g on a non-compact group: ġ = g·1000 for k = 1 (exp(1000) = inf).
        let line = Representation::new(1, 1, vec![1.0]).unwrap();
        match reconstruct(&line, &[1.0], &[0.0, 1.0], |_, o| o[0] = 1000.0, &d) {
            Err(E::NonFiniteSolution { t }) => assert!((0.0..1.0).contains(&t), "{t}"),
            other => panic!("{other:?}"),
        }
        // Overflow of the generator h Ω.
        match reconstruct(
            &line,
            &[1.0],
            &[0.0, 1e10],
            |_, o| o[0] = 1e300,
            &opts(StepSize::Substeps(1)),
        ) {
            Err(E::NonFiniteSolution { t: 0.0 }) => {}
            other => panic!("{other:?}"),
        }
    }
}
