//! Paths `Ω(t) ∈ Rⁿ` with *exact* first three time derivatives, for models whose Lie algebra
//! has any dimension `n` (3 for so(3) and se(2), 6 for so(4), …), and the level sets
//! `{v : ⟨v, I v⟩ = level}` of a symmetric positive definite matrix `I` onto which they are
//! projected radially.
//!
//! This is the `n`-dimensional counterpart of [`crate::so3::desired`] (which is fixed to
//! `n = 3` and a diagonal inertia):
//!
//! | here | so(3) version |
//! |---|---|
//! | [`Path`] (`jet_into`: `[Ω, Ω̇, Ω̈, Ω⃛]`, `4·n` numbers) | [`DesiredPath`](crate::so3::desired::DesiredPath) |
//! | [`Constant`] | [`desired::Constant`](crate::so3::desired::Constant) |
//! | [`Segment`] | — (the inner path of a `ProjectedSegment`) |
//! | [`Sampled`] | [`SampledPath`](crate::so3::desired::SampledPath) (which *is* a `Sampled` with `n = 3`) |
//! | [`LevelSet`] | [`EnergyEllipsoid`](crate::so3::ellipsoid::EnergyEllipsoid) |
//! | [`Projected`] | [`ProjectedPath`](crate::so3::desired::ProjectedPath) |
//! | [`projected_segment`] | [`ProjectedSegment`](crate::so3::desired::ProjectedSegment) |
//!
//! Exactness: [`Constant`] and [`Segment`] are polynomials of degree ≤ 1 (their jets are
//! written out), [`Sampled`] evaluates its cubic pieces on a third-order dual number, and
//! [`Projected`] lifts the inner jet to [`Dual3`] per component and pushes it through the
//! radial projection ([`LevelSet::project_generic`]). No finite differences are involved;
//! the tests compare against 8th-order finite differences.
//!
//! Evaluation (`jet_into`, `value_into`) does not allocate for `n ≤ 16`.
//!
//! ```
//! use std::sync::Arc;
//! use suslov::lie::path::{projected_segment, LevelSet, Path};
//!
//! // so(4): a 6×6 inertia (here diagonal), the level set through Ω_a.
//! let mut inertia = vec![0.0; 36];
//! for i in 0..6 {
//!     inertia[i * 6 + i] = 1.0 + i as f64;
//! }
//! let omega_a = [1.0, 0.0, 2.0, 0.0, 0.0, 1.0];
//! let set = LevelSet::through(&inertia, 6, &omega_a)?;
//! let omega_b = set.project(&[0.0, 1.0, 0.0, 1.0, 1.0, 0.0])?;
//! let path: Arc<dyn Path> = Arc::new(projected_segment(&set, &omega_a, &omega_b, 0.0, 5.0, 1e-10)?);
//! let mut jet = [0.0; 24]; // [Ω, Ω̇, Ω̈, Ω⃛]
//! path.jet_into(2.0, &mut jet);
//! assert!(set.relative_mismatch(&jet[..6]).abs() < 1e-14); // on the level set
//! assert_eq!(path.end_time(), Some(5.0));
//! # Ok::<(), suslov::lie::path::PathError>(())
//! ```

use std::fmt;
use std::sync::Arc;

use num_dual::{Dual3, DualNum};

/// Scalars the paths are evaluated on: `f64` and the `num-dual` dual numbers over `f64`.
pub trait Scalar: DualNum<Primitive = f64> + Copy {}
impl<T: DualNum<Primitive = f64> + Copy> Scalar for T {}

/// `x` is a finite `f64` above the subnormal range (full precision).
pub(crate) fn is_normal_positive(x: f64) -> bool {
    x.is_finite() && x >= f64::MIN_POSITIVE
}

/// Where [`project_radially_in_place`] scales by `sqrt(level / q(v))` directly: beyond it the
/// third derivative of that factor, which divides by `q^(7/2)`, overflows although the value
/// does not (the formulas `1e-40 (2 + sin t)`, `0`, `0` gave a non-finite jet at t = 0; the
/// paths of 1e-200 did not, being rescaled below the normal range).
pub(crate) const DIRECT_PROJECTION_RANGE: (f64, f64) = (1e-60, 1e60);

/// The radial projection `v ← v · sqrt(level / q(v))` in place, for any positive definite
/// quadratic form `q` (here the diagonal [`Inertia`]; in [`crate::lie::path::LevelSet`] a
/// full matrix) and any [`Scalar`].
///
/// When `q(v)` or `level / q(v)` lies outside [`DIRECT_PROJECTION_RANGE`] (a huge or tiny
/// `v`), `v` is first divided by its largest `|v_i|` at the point (a constant, so dual-number
/// derivatives stay exact): the projection only depends on the ray. No other checks: a zero
/// vector gives non-finite output.
pub(crate) fn project_radially_in_place<D: Scalar>(
    level: f64,
    v: &mut [D],
    quadratic: impl Fn(&[D]) -> D,
) {
    let q = quadratic(v);
    let m = v.iter().map(|x| x.re().abs()).fold(0.0, f64::max);
    let direct = |x: f64| (DIRECT_PROJECTION_RANGE.0..=DIRECT_PROJECTION_RANGE.1).contains(&x);
    if !(direct(q.re()) && direct(level / q.re())) && m > 0.0 && m.is_finite() {
        for x in v.iter_mut() {
            *x /= m;
        }
        let scale = quadratic(v).sqrt().recip() * level.sqrt();
        for x in v.iter_mut() {
            *x *= scale;
        }
        return;
    }
    let scale = (q.recip() * level).sqrt();
    for x in v.iter_mut() {
        *x *= scale;
    }
}

/// Up to this dimension, evaluation uses stack buffers (no allocation).
const STACK_DIM: usize = 16;

/// Relative asymmetry `|I_ij − I_ji| / max|I|` accepted by [`LevelSet::through`].
const SYMMETRY_TOL: f64 = 1e-12;

/// A path in Rⁿ with exact derivatives up to third order (dyn-compatible, thread-safe).
pub trait Path: Send + Sync {
    /// n.
    fn dim(&self) -> usize;

    /// `out = [Ω(t), Ω̇(t), Ω̈(t), Ω⃛(t)]`, 4·dim entries. Panics if out has another length.
    fn jet_into(&self, t: f64, out: &mut [f64]);

    /// `out = Ω(t)` (dim entries). Panics if out has another length.
    ///
    /// The default evaluates the jet (in a stack buffer for `dim ≤ 16`); the paths of this
    /// module override it.
    fn value_into(&self, t: f64, out: &mut [f64]) {
        let n = self.dim();
        check_out("value_into", out.len(), n);
        if n <= STACK_DIM {
            let mut jet = [0.0; 4 * STACK_DIM];
            self.jet_into(t, &mut jet[..4 * n]);
            out.copy_from_slice(&jet[..n]);
        } else {
            let mut jet = vec![0.0; 4 * n];
            self.jet_into(t, &mut jet);
            out.copy_from_slice(&jet[..n]);
        }
    }

    /// The path's natural end time, if it has one (Segment: t1; Sampled: last sample time;
    /// Constant: None).
    fn end_time(&self) -> Option<f64> {
        None
    }
}

fn check_out(method: &str, got: usize, expected: usize) {
    assert!(
        got == expected,
        "Path::{method}: `out` has {got} entries, but this path needs {expected} \
         (jet_into: 4·dim, value_into: dim)"
    );
}

/// Why a path or level set cannot be built.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum PathError {
    /// A vector (or the dimension) is empty.
    #[error(
        "{what} is empty: paths and level sets need dimension n ≥ 1; pass at least one component"
    )]
    Empty {
        /// What is empty.
        what: String,
    },
    /// A vector or matrix has the wrong number of entries.
    #[error(
        "{what} has length {got}, but length {expected} is needed; pass exactly {expected} entries"
    )]
    LengthMismatch {
        /// What has the wrong length.
        what: String,
        /// The length needed.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// NaN or ±∞ where a finite number is needed.
    #[error("{what}[{index}] = {value} is not finite; pass finite numbers")]
    NotFinite {
        /// The vector, matrix or list.
        what: String,
        /// The offending index (row-major for matrices).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// Fewer than two samples for a spline.
    #[error(
        "a sampled path needs at least 2 samples, got {got}; add samples (for a single value \
         use a Constant path)"
    )]
    TooFewSamples {
        /// How many samples were given.
        got: usize,
    },
    /// Sample times that do not increase strictly.
    #[error(
        "sample times must increase strictly, but times[{index}] = {time} comes after times[{}] \
         = {previous}; sort the samples by time and drop duplicate times",
        index - 1
    )]
    TimesNotIncreasing {
        /// The index of the offending time (≥ 1).
        index: usize,
        /// `times[index − 1]`.
        previous: f64,
        /// `times[index]`.
        time: f64,
    },
    /// A time interval that is not `t0 < t1`, both finite with `t1 − t0` finite.
    #[error(
        "a segment needs finite times t0 < t1 (with t1 − t0 finite), got t0 = {t0}, t1 = {t1}; \
         swap or correct them"
    )]
    BadInterval {
        /// The start time.
        t0: f64,
        /// The end time.
        t1: f64,
    },
    /// The blending window of an [`EndBlend`] is not in `(0, b − a]`.
    #[error("the blending window {window} must lie in (0, b − a = {span}]")]
    BadWindow {
        /// The window.
        window: f64,
        /// `b − a`.
        span: f64,
    },
    /// A quantity derived from valid input overflows `f64`.
    #[error("{what} overflows f64: {fix}")]
    Overflow {
        /// What overflows, with the values involved.
        what: String,
        /// How to avoid it.
        fix: String,
    },
    /// The inertia matrix is not symmetric.
    #[error(
        "the inertia matrix is not symmetric: I[{row}][{col}] = {upper:e} but I[{col}][{row}] = \
         {lower:e}, a difference of {relative:.3e} of the largest |entry| (at most 1e-12 is \
         accepted); pass a symmetric matrix, e.g. (I + Iᵀ)/2"
    )]
    NotSymmetric {
        /// Row of the upper entry.
        row: usize,
        /// Column of the upper entry (`> row`).
        col: usize,
        /// `I[row][col]`.
        upper: f64,
        /// `I[col][row]`.
        lower: f64,
        /// `|upper − lower| / max|I|`.
        relative: f64,
    },
    /// The (symmetric) inertia matrix is not positive definite.
    #[error(
        "the inertia matrix is not positive definite: its Cholesky factorisation meets the \
         pivot {pivot:e} ≤ 0 at row {row} (relative to the largest |entry|); pass a symmetric \
         positive definite matrix (an inertia tensor has positive eigenvalues)"
    )]
    NotPositiveDefinite {
        /// The row where the factorisation fails.
        row: usize,
        /// The failing pivot `I_rr − Σ L_rk²`, divided by `max|I|`.
        pivot: f64,
    },
    /// The zero vector, which spans no ray.
    #[error(
        "{what} is the zero vector, which spans no ray: no level set passes through it and it \
         has no radial projection; pass a non-zero vector"
    )]
    ZeroVector {
        /// What is zero.
        what: String,
    },
    /// The level `⟨p, I p⟩` overflows or lies in the subnormal range.
    #[error(
        "the level ⟨p, I p⟩ = {level:e} of the point p = {point:?} is not a normal positive f64 \
         (it must be finite and at least f64::MIN_POSITIVE ≈ 2.2e-308); rescale p (or I)"
    )]
    LevelOutOfRange {
        /// `⟨p, I p⟩` as computed.
        level: f64,
        /// The point.
        point: Vec<f64>,
    },
    /// A point that should lie on the level set does not, within the tolerance.
    #[error(
        "{what} = {point:?} is off the level set ⟨v, I v⟩ = {level:e} by {mismatch:e} \
         (relative), more than the tolerance {tol:e}; use its radial projection {projection} \
         (LevelSet::project)"
    )]
    OffLevelSet {
        /// Which point.
        what: String,
        /// The point.
        point: Vec<f64>,
        /// `⟨v, I v⟩ / level − 1`.
        mismatch: f64,
        /// The tolerance.
        tol: f64,
        /// The level of the set.
        level: f64,
        /// The radial projection, formatted (or why it is undefined).
        projection: String,
    },
    /// The straight segment passes (nearly) through the origin, where the radial projection
    /// is undefined.
    #[error(
        "the straight segment from {from:?} to {to:?} passes within {closest:.3e} of the \
         origin (|from| = {size:.3e}; at most 1e-8·|from| is refused): its end points are \
         (nearly) opposite and the radial projection is undefined at the origin; go through an \
         intermediate point (two segments, or a Sampled path)"
    )]
    SegmentThroughOrigin {
        /// The start point.
        from: Vec<f64>,
        /// The end point (projected onto the set).
        to: Vec<f64>,
        /// The distance from the origin to the segment.
        closest: f64,
        /// `|from|`.
        size: f64,
    },
    /// A tolerance that is negative or not finite.
    #[error("the tolerance {tol} must be finite and ≥ 0 (e.g. 1e-10 relative energy)")]
    BadTolerance {
        /// The tolerance given.
        tol: f64,
    },
}

/// Checks that `v` (named `what`) is non-empty, has `expected` entries (if given) and is
/// finite.
fn check_vector(what: &str, v: &[f64], expected: Option<usize>) -> Result<(), PathError> {
    if let Some(expected) = expected {
        if v.len() != expected {
            return Err(PathError::LengthMismatch {
                what: what.to_string(),
                expected,
                got: v.len(),
            });
        }
    }
    if v.is_empty() {
        return Err(PathError::Empty {
            what: what.to_string(),
        });
    }
    check_finite(what, v)
}

fn check_finite(what: &str, v: &[f64]) -> Result<(), PathError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(PathError::NotFinite {
            what: what.to_string(),
            index,
            value: v[index],
        }),
        None => Ok(()),
    }
}

fn check_interval(t0: f64, t1: f64) -> Result<(), PathError> {
    if t0.is_finite() && t1.is_finite() && t0 < t1 && (t1 - t0).is_finite() {
        Ok(())
    } else {
        Err(PathError::BadInterval { t0, t1 })
    }
}

/// `max_i |v_i|`.
fn amax(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The constant path `Ω(t) = value`.
#[derive(Debug, Clone, PartialEq)]
pub struct Constant {
    value: Vec<f64>,
}

impl Constant {
    /// `Ω(t) = value` for all `t`; `value` must be non-empty and finite.
    pub fn new(value: Vec<f64>) -> Result<Self, PathError> {
        check_vector("Constant: the value", &value, None)?;
        Ok(Self { value })
    }

    /// The value.
    pub fn value(&self) -> &[f64] {
        &self.value
    }
}

impl Path for Constant {
    fn dim(&self) -> usize {
        self.value.len()
    }

    fn jet_into(&self, _t: f64, out: &mut [f64]) {
        let n = self.dim();
        check_out("jet_into", out.len(), 4 * n);
        out[..n].copy_from_slice(&self.value);
        out[n..].fill(0.0);
    }

    fn value_into(&self, _t: f64, out: &mut [f64]) {
        check_out("value_into", out.len(), self.dim());
        out.copy_from_slice(&self.value);
    }
}

/// The straight line through `from` (at `t0`) and `to` (at `t1`), traversed at constant
/// velocity `(to − from)/(t1 − t0)` and extended linearly outside `[t0, t1]`.
///
/// The value is `from + u (to − from)`, `u = (t − t0)/(t1 − t0)`, in the first half of the
/// interval and `to − w (to − from)`, `w = (t1 − t)/(t1 − t0)`, in the second, so that it is
/// *exactly* `from` at `t0` and `to` at `t1`.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    from: Vec<f64>,
    to: Vec<f64>,
    /// `to − from`.
    delta: Vec<f64>,
    /// `(to − from)/(t1 − t0)`.
    velocity: Vec<f64>,
    t0: f64,
    t1: f64,
}

impl Segment {
    /// The segment from `from` at `t0` to `to` at `t1`: both non-empty, finite and of equal
    /// length, `t0 < t1` finite; the difference `to − from` and the velocity must not
    /// overflow.
    pub fn new(from: Vec<f64>, to: Vec<f64>, t0: f64, t1: f64) -> Result<Self, PathError> {
        check_vector("Segment: from", &from, None)?;
        check_vector("Segment: to", &to, Some(from.len()))?;
        check_interval(t0, t1)?;
        let delta: Vec<f64> = to.iter().zip(&from).map(|(b, a)| b - a).collect();
        let velocity: Vec<f64> = delta.iter().map(|d| d / (t1 - t0)).collect();
        if let Some(i) = velocity.iter().position(|v| !v.is_finite()) {
            return Err(PathError::Overflow {
                what: format!(
                    "the velocity (to[{i}] − from[{i}])/(t1 − t0) = ({:e} − {:e})/({t1:e} − \
                     {t0:e}) of the segment",
                    to[i], from[i]
                ),
                fix: "make the end points smaller or the interval longer".to_string(),
            });
        }
        Ok(Self {
            from,
            to,
            delta,
            velocity,
            t0,
            t1,
        })
    }

    /// The start point (the value at `t0`).
    pub fn from(&self) -> &[f64] {
        &self.from
    }

    /// The end point (the value at `t1`).
    pub fn to(&self) -> &[f64] {
        &self.to
    }

    /// `(t0, t1)`.
    pub fn interval(&self) -> (f64, f64) {
        (self.t0, self.t1)
    }
}

impl Path for Segment {
    fn dim(&self) -> usize {
        self.from.len()
    }

    fn jet_into(&self, t: f64, out: &mut [f64]) {
        let n = self.dim();
        check_out("jet_into", out.len(), 4 * n);
        self.value_into(t, &mut out[..n]);
        out[n..2 * n].copy_from_slice(&self.velocity);
        out[2 * n..].fill(0.0);
    }

    fn value_into(&self, t: f64, out: &mut [f64]) {
        check_out("value_into", out.len(), self.dim());
        let span = self.t1 - self.t0;
        if t - self.t0 <= self.t1 - t {
            let u = (t - self.t0) / span;
            for ((o, a), d) in out.iter_mut().zip(&self.from).zip(&self.delta) {
                *o = a + u * d;
            }
        } else {
            let w = (self.t1 - t) / span;
            for ((o, b), d) in out.iter_mut().zip(&self.to).zip(&self.delta) {
                *o = b - w * d;
            }
        }
    }

    fn end_time(&self) -> Option<f64> {
        Some(self.t1)
    }
}

/// A path through samples `(t_k, Ω_k)`: per component the natural cubic spline (C², second
/// derivative 0 at both ends), extended linearly outside `[t_0, t_N]` (which keeps it C²).
/// The third derivative is piecewise constant, discontinuous at the knots (a knot belongs
/// to the interval on its right, except `t_N`, which belongs to the last interval).
///
/// This is the spline core of [`SampledPath`](crate::so3::desired::SampledPath), which is
/// a `Sampled` with `n = 3`.
#[derive(Debug, Clone, PartialEq)]
pub struct Sampled {
    dim: usize,
    knots: Vec<f64>,
    /// Per interval `k` and component `c` (index `k·dim + c`): `[a, b, c, d]` of
    /// `a + b s + c s² + d s³`, `s = t − t_k`.
    coeffs: Vec<[f64; 4]>,
    /// Value at the last knot (linear extension to the right).
    end_value: Vec<f64>,
    /// Slope at the last knot.
    end_slope: Vec<f64>,
}

impl Sampled {
    /// The spline through `values[k]` at `times[k]`: at least 2 samples, strictly increasing
    /// finite times, finite values, all rows of equal length ≥ 1. Errors
    /// ([`PathError::Overflow`]) if the spline's coefficients overflow `f64` (huge
    /// differences of values, or samples very close in time).
    pub fn new(times: &[f64], values: &[Vec<f64>]) -> Result<Self, PathError> {
        Self::from_rows(times, values)
    }

    /// [`Sampled::new`] for any kind of rows (e.g. `[f64; 3]`).
    pub(crate) fn from_rows<R: AsRef<[f64]>>(
        times: &[f64],
        values: &[R],
    ) -> Result<Self, PathError> {
        if times.len() != values.len() {
            return Err(PathError::LengthMismatch {
                what: "Sampled: values (one row per sample time)".to_string(),
                expected: times.len(),
                got: values.len(),
            });
        }
        if times.len() < 2 {
            return Err(PathError::TooFewSamples { got: times.len() });
        }
        let dim = values[0].as_ref().len();
        if dim == 0 {
            return Err(PathError::Empty {
                what: "Sampled: values[0]".to_string(),
            });
        }
        check_finite("Sampled: times", times)?;
        for (k, row) in values.iter().enumerate() {
            let row = row.as_ref();
            check_vector(&format!("Sampled: values[{k}]"), row, Some(dim))?;
        }
        if let Some(k) = (1..times.len()).find(|&k| times[k] <= times[k - 1]) {
            return Err(PathError::TimesNotIncreasing {
                index: k,
                previous: times[k - 1],
                time: times[k],
            });
        }
        let n = times.len() - 1; // intervals
        let h: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        let mut coeffs = vec![[0.0; 4]; n * dim];
        let mut end_value = vec![0.0; dim];
        let mut end_slope = vec![0.0; dim];
        for c in 0..dim {
            let y: Vec<f64> = values.iter().map(|v| v.as_ref()[c]).collect();
            // Second derivatives m[0..=n], m[0] = m[n] = 0 (Thomas algorithm on 1..n-1).
            let mut m = vec![0.0; n + 1];
            if n >= 2 {
                let mut diag = vec![0.0; n + 1];
                let mut rhs = vec![0.0; n + 1];
                for i in 1..n {
                    diag[i] = 2.0 * (h[i - 1] + h[i]);
                    rhs[i] = 6.0 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1]);
                }
                for i in 2..n {
                    let w = h[i - 1] / diag[i - 1];
                    diag[i] -= w * h[i - 1];
                    rhs[i] -= w * rhs[i - 1];
                }
                m[n - 1] = rhs[n - 1] / diag[n - 1];
                for i in (1..n - 1).rev() {
                    m[i] = (rhs[i] - h[i] * m[i + 1]) / diag[i];
                }
            }
            for i in 0..n {
                coeffs[i * dim + c] = [
                    y[i],
                    (y[i + 1] - y[i]) / h[i] - h[i] * (2.0 * m[i] + m[i + 1]) / 6.0,
                    m[i] / 2.0,
                    (m[i + 1] - m[i]) / (6.0 * h[i]),
                ];
            }
            let [_, b, cc, d] = coeffs[(n - 1) * dim + c];
            let hn = h[n - 1];
            end_value[c] = y[n];
            end_slope[c] = b + 2.0 * cc * hn + 3.0 * d * hn * hn;
        }
        // Differences of huge values, or samples very close in time, overflow f64.
        let bad = coeffs
            .chunks(dim)
            .position(|c| c.iter().flatten().any(|x| !x.is_finite()))
            .or_else(|| {
                (end_value.iter().chain(&end_slope).any(|x| !x.is_finite())).then_some(n - 1)
            });
        if let Some(k) = bad {
            return Err(PathError::Overflow {
                what: format!(
                    "the cubic spline through the samples, between sample {k} (t = {:e}) and \
                     sample {} (t = {:e}),",
                    times[k],
                    k + 1,
                    times[k + 1]
                ),
                fix: "the values are too large or too close in time; rescale them (only their \
                      directions matter after a projection) or space them further apart"
                    .to_string(),
            });
        }
        Ok(Self {
            dim,
            knots: times.to_vec(),
            coeffs,
            end_value,
            end_slope,
        })
    }

    /// The sample times `t_0 < … < t_N`.
    pub fn times(&self) -> &[f64] {
        &self.knots
    }

    /// Evaluates every component at a (dual) time: `put(c, Ω_c(t))` for `c = 0..dim`.
    pub(crate) fn eval_with<D: Scalar>(&self, t: D, mut put: impl FnMut(usize, D)) {
        let x = t.re();
        let last = self.knots[self.knots.len() - 1];
        if x > last {
            let s = t - last;
            for c in 0..self.dim {
                put(c, s * self.end_slope[c] + self.end_value[c]);
            }
            return;
        }
        // Interval k with t_k <= x < t_{k+1} (the first one left of t_0: linear there, m_0 = 0).
        let intervals = self.knots.len() - 1;
        let k = self
            .knots
            .partition_point(|&tk| tk <= x)
            .saturating_sub(1)
            .min(intervals - 1);
        let s = t - self.knots[k];
        let left = x < self.knots[0];
        let coeffs = &self.coeffs[k * self.dim..(k + 1) * self.dim];
        for (c, &[a, b, cc, d]) in coeffs.iter().enumerate() {
            put(
                c,
                if left {
                    s * b + a
                } else {
                    ((s * d + cc) * s + b) * s + a
                },
            );
        }
    }
}

impl Path for Sampled {
    fn dim(&self) -> usize {
        self.dim
    }

    fn jet_into(&self, t: f64, out: &mut [f64]) {
        let n = self.dim;
        check_out("jet_into", out.len(), 4 * n);
        self.eval_with(Dual3::from_re(t).derivative(), |c, x| {
            out[c] = x.re;
            out[n + c] = x.v1;
            out[2 * n + c] = x.v2;
            out[3 * n + c] = x.v3;
        });
    }

    fn value_into(&self, t: f64, out: &mut [f64]) {
        check_out("value_into", out.len(), self.dim);
        self.eval_with(t, |c, x| out[c] = x);
    }

    fn end_time(&self) -> Option<f64> {
        self.knots.last().copied()
    }
}

/// The level set {v : ⟨v, I v⟩ = level} of a symmetric positive definite n×n matrix I
/// (row-major), through a given point.
///
/// `level = ⟨p, I p⟩` is twice the kinetic energy of `p`; the radial projection
/// `v ↦ v·sqrt(level/⟨v, I v⟩)` maps every `v ≠ 0` onto the set along its ray.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelSet {
    n: usize,
    /// `I`, row-major, as given.
    inertia: Vec<f64>,
    /// The quadratic form packed by rows of the upper triangle: `I_ii`, then `I_ij + I_ji`
    /// for `j > i`, so that `⟨v, I v⟩ = Σ_i v_i (form_ii v_i + Σ_{j>i} form_ij v_j)` exactly
    /// in exact arithmetic, with half the products.
    form: Vec<f64>,
    level: f64,
}

impl LevelSet {
    /// The level set of `inertia` (`n × n`, row-major) through `point`.
    ///
    /// Checks: `n ≥ 1`, `inertia.len() = n²`, `point.len() = n`, all entries finite, `I`
    /// symmetric to `1e-12` relative to its largest `|entry|`, `I` positive definite
    /// (Cholesky), `point ≠ 0`, and `level = ⟨p, I p⟩` a normal positive `f64` (finite and
    /// `≥ f64::MIN_POSITIVE`).
    pub fn through(inertia: &[f64], n: usize, point: &[f64]) -> Result<Self, PathError> {
        if n == 0 {
            return Err(PathError::Empty {
                what: "LevelSet: the dimension n".to_string(),
            });
        }
        check_vector(
            "LevelSet: the inertia matrix (n×n, row-major)",
            inertia,
            Some(n.saturating_mul(n)),
        )?;
        check_vector("LevelSet: the point", point, Some(n))?;
        let scale = amax(inertia);
        for i in 0..n {
            for j in i + 1..n {
                let (upper, lower) = (inertia[i * n + j], inertia[j * n + i]);
                let relative = (upper - lower).abs() / scale;
                if relative > SYMMETRY_TOL {
                    return Err(PathError::NotSymmetric {
                        row: i,
                        col: j,
                        upper,
                        lower,
                        relative,
                    });
                }
            }
        }
        cholesky_check(inertia, n, scale)?;
        if point.iter().all(|&x| x == 0.0) {
            return Err(PathError::ZeroVector {
                what: "LevelSet: the point".to_string(),
            });
        }
        let mut form = Vec::with_capacity(n * (n + 1) / 2);
        for i in 0..n {
            form.push(inertia[i * n + i]);
            for j in i + 1..n {
                form.push(inertia[i * n + j] + inertia[j * n + i]);
            }
        }
        let mut set = Self {
            n,
            inertia: inertia.to_vec(),
            form,
            level: 1.0,
        };
        let level = set.quadratic(point);
        if !is_normal_positive(level) {
            return Err(PathError::LevelOutOfRange {
                level,
                point: point.to_vec(),
            });
        }
        set.level = level;
        Ok(set)
    }

    /// n.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// `⟨p, I p⟩` (twice the kinetic energy on the set).
    pub fn level(&self) -> f64 {
        self.level
    }

    /// The matrix `I` (row-major, as given).
    pub fn inertia(&self) -> &[f64] {
        &self.inertia
    }

    /// `⟨v, I v⟩` on any [`Scalar`], from the packed upper triangle.
    fn form_with<D: Scalar>(&self, v: impl Fn(usize) -> D) -> D {
        let mut q = D::from(0.0);
        let mut k = 0;
        for i in 0..self.n {
            let vi = v(i);
            let mut w = vi * self.form[k];
            k += 1;
            for j in i + 1..self.n {
                w += v(j) * self.form[k];
                k += 1;
            }
            q += vi * w;
        }
        q
    }

    fn quadratic_generic<D: Scalar>(&self, v: &[D]) -> D {
        self.form_with(|i| v[i])
    }

    /// `⟨v, I v⟩`. When that over- or underflows, it is evaluated on `v / max|v_i|` and
    /// scaled back (so `1e200·v` gives `∞` only if the true value exceeds `f64::MAX`, and
    /// `1e-200·v` is not flushed to 0 early). Panics if `v.len() ≠ n`.
    pub fn quadratic(&self, v: &[f64]) -> f64 {
        self.check_arg("quadratic", v.len());
        let q = self.quadratic_generic(v);
        if is_normal_positive(q) {
            return q;
        }
        let m = amax(v);
        if !(m > 0.0 && m.is_finite()) {
            return q;
        }
        self.form_with(|i| v[i] / m) * m * m
    }

    /// `⟨v, I v⟩ / level − 1` (0 on the set, `−1` at `v = 0`). Panics if `v.len() ≠ n`.
    pub fn relative_mismatch(&self, v: &[f64]) -> f64 {
        self.quadratic(v) / self.level - 1.0
    }

    /// The radial projection `v·sqrt(level/⟨v, I v⟩)` of `v` onto the set (overflow-safe, as
    /// [`EnergyEllipsoid::project`](crate::so3::ellipsoid::EnergyEllipsoid::project)).
    /// Errors for a wrong length, a non-finite or zero `v`, and if the projection overflows.
    pub fn project(&self, v: &[f64]) -> Result<Vec<f64>, PathError> {
        check_vector("LevelSet::project: v", v, Some(self.n))?;
        if v.iter().all(|&x| x == 0.0) {
            return Err(PathError::ZeroVector {
                what: "LevelSet::project: v".to_string(),
            });
        }
        let mut out = v.to_vec();
        self.project_in_place(&mut out);
        if out.iter().all(|x| x.is_finite()) {
            Ok(out)
        } else {
            Err(PathError::Overflow {
                what: format!(
                    "the radial projection of {v:?} onto the level set ⟨v, I v⟩ = {:e}",
                    self.level
                ),
                fix: "I is too ill-conditioned (tiny ⟨v, I v⟩ along this ray); rescale I or \
                      the level"
                    .to_string(),
            })
        }
    }

    /// The radial projection on dual numbers (for exact derivatives): `out = v·sqrt(level /
    /// ⟨v, I v⟩)`, with the same overflow-safe scaling as [`LevelSet::project`] (by the
    /// constant `max|v_i.re|`, so the derivatives stay exact). No checks: a zero `v` gives
    /// non-finite output. Panics if `v.len() ≠ n` or `out.len() ≠ n`.
    pub fn project_generic<D: Scalar>(&self, v: &[D], out: &mut [D]) {
        self.check_arg("project_generic (v)", v.len());
        self.check_arg("project_generic (out)", out.len());
        out.copy_from_slice(v);
        self.project_in_place(out);
    }

    fn project_in_place<D: Scalar>(&self, v: &mut [D]) {
        project_radially_in_place(self.level, v, |u| self.quadratic_generic(u));
    }

    fn check_arg(&self, method: &str, len: usize) {
        assert!(
            len == self.n,
            "LevelSet::{method}: the vector has {len} entries, but the level set is in R^{}",
            self.n
        );
    }
}

/// Errors unless the symmetric part of `I` (divided by `scale = max|I|`) has a Cholesky
/// factorisation with positive pivots.
fn cholesky_check(inertia: &[f64], n: usize, scale: f64) -> Result<(), PathError> {
    if scale == 0.0 {
        return Err(PathError::NotPositiveDefinite { row: 0, pivot: 0.0 });
    }
    let a = |i: usize, j: usize| 0.5 * (inertia[i * n + j] / scale + inertia[j * n + i] / scale);
    let mut l = vec![0.0; n * n];
    for j in 0..n {
        let pivot = a(j, j) - (0..j).map(|k| l[j * n + k] * l[j * n + k]).sum::<f64>();
        if pivot.is_nan() || pivot <= 0.0 {
            return Err(PathError::NotPositiveDefinite { row: j, pivot });
        }
        let d = pivot.sqrt();
        l[j * n + j] = d;
        for i in j + 1..n {
            let s = a(i, j) - (0..j).map(|k| l[i * n + k] * l[j * n + k]).sum::<f64>();
            l[i * n + j] = s / d;
        }
    }
    Ok(())
}

/// A path bent to given end points: `q(t) = inner(t) + w_a(t) (start − inner(a)) + w_b(t)
/// (end − inner(b))`, with `w_b(t) = S((t − b + L)/L)` and `w_a(t) = 1 − S((t − a)/L)`, where
/// `S(x) = x⁴ (35 − 84x + 70x² − 20x³)` on `[0, 1]` (0 below, 1 above) is the degree-7
/// smoothstep, whose first three derivatives vanish at both ends. So `q` is as smooth as the
/// inner path up to the jet this trait gives (`C³`), equals `start` at `a` and `end` at `b`
/// (to rounding), and equals `inner` outside the two windows of length `L`.
///
/// The homotopy's start from a desired path that does not end at `Ω_b` (a fixed terminal time
/// before the path settles, a sampled path that stops elsewhere) uses it: the projection of
/// the bent path is an admissible `Ω_p` where the desired path itself is not.
#[derive(Clone)]
pub struct EndBlend {
    inner: Arc<dyn Path>,
    a: f64,
    b: f64,
    window: f64,
    /// `start − inner(a)`.
    at_a: Vec<f64>,
    /// `end − inner(b)`.
    at_b: Vec<f64>,
}

impl EndBlend {
    /// `inner` bent to `start` at `a` and `end` at `b` over windows of length
    /// `window ∈ (0, b − a]`; errors on a wrong length, non-finite input or a bad window.
    pub fn new(
        inner: Arc<dyn Path>,
        (a, b): (f64, f64),
        start: &[f64],
        end: &[f64],
        window: f64,
    ) -> Result<Self, PathError> {
        let n = inner.dim();
        check_vector("EndBlend: start", start, Some(n))?;
        check_vector("EndBlend: end", end, Some(n))?;
        check_interval(a, b)?;
        if !(window > 0.0 && window <= b - a) {
            return Err(PathError::BadWindow {
                window,
                span: b - a,
            });
        }
        let mut at_a = vec![0.0; n];
        let mut at_b = vec![0.0; n];
        inner.value_into(a, &mut at_a);
        inner.value_into(b, &mut at_b);
        for (d, s) in at_a.iter_mut().zip(start) {
            *d = s - *d;
        }
        for (d, e) in at_b.iter_mut().zip(end) {
            *d = e - *d;
        }
        check_finite("EndBlend: start − inner(a)", &at_a)?;
        check_finite("EndBlend: end − inner(b)", &at_b)?;
        Ok(Self {
            inner,
            a,
            b,
            window,
            at_a,
            at_b,
        })
    }

    /// `[S, S', S'', S''']` at `x` (derivatives in `x`).
    fn smoothstep(x: f64) -> [f64; 4] {
        if x <= 0.0 {
            return [0.0; 4];
        }
        if x >= 1.0 {
            return [1.0, 0.0, 0.0, 0.0];
        }
        let y = 1.0 - x;
        [
            x.powi(4) * (35.0 - 84.0 * x + 70.0 * x * x - 20.0 * x.powi(3)),
            140.0 * (x * y).powi(3),
            420.0 * (x * y).powi(2) * (1.0 - 2.0 * x),
            840.0 * x * y * (1.0 - 5.0 * x + 5.0 * x * x),
        ]
    }

    /// The weights' jets `[w, w', w'', w''']` at `t` (derivatives in `t`): start, end.
    fn weights(&self, t: f64) -> ([f64; 4], [f64; 4]) {
        let l = self.window;
        let sa = Self::smoothstep((t - self.a) / l);
        let sb = Self::smoothstep((t - self.b + l) / l);
        let mut wa = [1.0 - sa[0], 0.0, 0.0, 0.0];
        let mut wb = [sb[0], 0.0, 0.0, 0.0];
        let mut scale = 1.0;
        for k in 1..4 {
            scale /= l;
            wa[k] = -sa[k] * scale;
            wb[k] = sb[k] * scale;
        }
        (wa, wb)
    }
}

impl fmt::Debug for EndBlend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("EndBlend")
            .field(
                "inner",
                &format_args!("<dyn Path, dim {}>", self.inner.dim()),
            )
            .field("interval", &(self.a, self.b))
            .field("window", &self.window)
            .field("at_a", &self.at_a)
            .field("at_b", &self.at_b)
            .finish()
    }
}

impl Path for EndBlend {
    fn dim(&self) -> usize {
        self.inner.dim()
    }

    fn jet_into(&self, t: f64, out: &mut [f64]) {
        let n = self.dim();
        check_out("jet_into", out.len(), 4 * n);
        self.inner.jet_into(t, out);
        let (wa, wb) = self.weights(t);
        for k in 0..4 {
            for i in 0..n {
                out[k * n + i] += wa[k] * self.at_a[i] + wb[k] * self.at_b[i];
            }
        }
    }

    fn end_time(&self) -> Option<f64> {
        Some(self.b)
    }
}

/// The radial projection of any path onto a level set, with exact derivatives: the inner
/// jet is lifted to a [`Dual3`] per component and pushed through
/// [`LevelSet::project_generic`]. Undefined (non-finite) where the inner path is 0.
///
/// The inner path must have the set's dimension ([`Projected::new`] checks it; evaluation
/// panics otherwise).
#[derive(Clone)]
pub struct Projected {
    /// The projected path.
    pub inner: Arc<dyn Path>,
    /// The target level set.
    pub set: LevelSet,
}

impl Projected {
    /// `inner` projected onto `set`; errors if their dimensions differ.
    pub fn new(inner: Arc<dyn Path>, set: LevelSet) -> Result<Self, PathError> {
        if inner.dim() != set.dim() {
            return Err(PathError::LengthMismatch {
                what: "Projected: each vector of the inner path (the level set is in R^n)"
                    .to_string(),
                expected: set.dim(),
                got: inner.dim(),
            });
        }
        Ok(Self { inner, set })
    }

    /// Projects the inner jet `jet` (in place) using the dual-number buffer `buf` (`dim`
    /// entries).
    fn project_jet(&self, jet: &mut [f64], buf: &mut [Dual3<f64>]) {
        let n = buf.len();
        for (i, b) in buf.iter_mut().enumerate() {
            *b = Dual3::new(jet[i], jet[n + i], jet[2 * n + i], jet[3 * n + i]);
        }
        self.set.project_in_place(buf);
        for (i, b) in buf.iter().enumerate() {
            jet[i] = b.re;
            jet[n + i] = b.v1;
            jet[2 * n + i] = b.v2;
            jet[3 * n + i] = b.v3;
        }
    }

    fn check_inner(&self) {
        assert!(
            self.inner.dim() == self.set.dim(),
            "Projected: the inner path is in R^{} but the level set in R^{} (use \
             Projected::new, which checks this)",
            self.inner.dim(),
            self.set.dim()
        );
    }
}

impl fmt::Debug for Projected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Projected")
            .field(
                "inner",
                &format_args!("<dyn Path, dim {}>", self.inner.dim()),
            )
            .field("set", &self.set)
            .finish()
    }
}

impl Path for Projected {
    fn dim(&self) -> usize {
        self.set.dim()
    }

    fn jet_into(&self, t: f64, out: &mut [f64]) {
        let n = self.dim();
        check_out("jet_into", out.len(), 4 * n);
        self.check_inner();
        self.inner.jet_into(t, out);
        if n <= STACK_DIM {
            let mut buf = [Dual3::from_re(0.0); STACK_DIM];
            self.project_jet(out, &mut buf[..n]);
        } else {
            let mut buf = vec![Dual3::from_re(0.0); n];
            self.project_jet(out, &mut buf);
        }
    }

    fn value_into(&self, t: f64, out: &mut [f64]) {
        check_out("value_into", out.len(), self.dim());
        self.check_inner();
        self.inner.value_into(t, out);
        self.set.project_in_place(out);
    }

    fn end_time(&self) -> Option<f64> {
        self.inner.end_time()
    }
}

/// A path that remembers its jets: `jet_into(t)` returns the inner path's jet at `t`,
/// computed once per distinct `t` (bit for bit) while it stays in a direct-mapped table of
/// [`Memo::SLOTS`] entries.
///
/// Why: the collocation solver evaluates the desired path at the same times over and over.
/// On a fixed horizon the nodes and stage points of a mesh do not move between Newton
/// iterations or between continuation steps on one mesh, and with a free horizon the
/// Jacobian is evaluated at the very times of the residual before it. A jet of a projected
/// path costs a third-order dual-number evaluation and a projection; a lookup costs a hash
/// and a copy. The values returned are the inner path's own (the same computation, done
/// once), so a solve gives the same bits with or without the memo.
///
/// The table is allocated at the first `jet_into`; `value_into` and `end_time` go to the
/// inner path. Non-finite `t` is never stored. Safe to share between threads (a mutex
/// guards the table; the inner path is evaluated outside it).
pub struct Memo {
    inner: Arc<dyn Path>,
    table: std::sync::Mutex<MemoTable>,
}

/// Keys (`t.to_bits()`, [`MemoTable::EMPTY`] for a free slot) and jets (`4·dim` per slot).
#[derive(Default)]
struct MemoTable {
    keys: Vec<u64>,
    jets: Vec<f64>,
}

impl MemoTable {
    /// A NaN's bits: never the key of a stored (finite) time.
    const EMPTY: u64 = u64::MAX;

    /// Fibonacci hashing of the time's bits onto `log2(SLOTS)` bits.
    fn slot(bits: u64) -> usize {
        (bits.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - Memo::SLOTS.trailing_zeros())) as usize
    }
}

impl Memo {
    /// Slots of the table (a power of two): the nodes and stage points of a mesh of a
    /// thousand intervals mostly keep a slot each.
    pub const SLOTS: usize = 4096;

    /// `inner`, remembered.
    pub fn new(inner: Arc<dyn Path>) -> Self {
        Self {
            inner,
            table: std::sync::Mutex::new(MemoTable::default()),
        }
    }

    fn table(&self) -> std::sync::MutexGuard<'_, MemoTable> {
        // Nothing that can panic runs under the lock; a poisoned lock's table is still
        // consistent (a slot's key is written after its jet).
        self.table.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl fmt::Debug for Memo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Memo")
            .field(
                "inner",
                &format_args!("<dyn Path, dim {}>", self.inner.dim()),
            )
            .finish()
    }
}

impl Path for Memo {
    fn dim(&self) -> usize {
        self.inner.dim()
    }

    fn jet_into(&self, t: f64, out: &mut [f64]) {
        let len = 4 * self.dim();
        check_out("jet_into", out.len(), len);
        if !t.is_finite() {
            self.inner.jet_into(t, out);
            return;
        }
        let bits = t.to_bits();
        let slot = MemoTable::slot(bits);
        {
            let table = self.table();
            if table.keys.get(slot) == Some(&bits) {
                out.copy_from_slice(&table.jets[slot * len..(slot + 1) * len]);
                return;
            }
        }
        self.inner.jet_into(t, out);
        let mut table = self.table();
        if table.keys.is_empty() {
            table.keys = vec![MemoTable::EMPTY; Self::SLOTS];
            table.jets = vec![0.0; Self::SLOTS * len];
        }
        table.jets[slot * len..(slot + 1) * len].copy_from_slice(out);
        table.keys[slot] = bits;
    }

    fn value_into(&self, t: f64, out: &mut [f64]) {
        self.inner.value_into(t, out);
    }

    fn end_time(&self) -> Option<f64> {
        self.inner.end_time()
    }
}

/// The projected straight segment from `from` (at `t0`) to `to` (at `t1`) on `set`.
///
/// Both end points must lie on the set within `tol` relative energy mismatch
/// (`|⟨v, I v⟩/level − 1| ≤ tol`); `to` is projected exactly onto the set first (like
/// [`ProjectedSegment::new`](crate::so3::desired::ProjectedSegment::new)), so the path
/// ends on the set; `from` is kept (it is projected at `t0` anyway). `from = to` gives the
/// constant path. Errors if the segment passes within `1e-8·|from|` of the origin (end
/// points (nearly) opposite), with the distance in the message.
pub fn projected_segment(
    set: &LevelSet,
    from: &[f64],
    to: &[f64],
    t0: f64,
    t1: f64,
    tol: f64,
) -> Result<Projected, PathError> {
    let n = set.dim();
    check_vector("projected_segment: from", from, Some(n))?;
    check_vector("projected_segment: to", to, Some(n))?;
    for (what, v) in [
        ("projected_segment: from", from),
        ("projected_segment: to", to),
    ] {
        if v.iter().all(|&x| x == 0.0) {
            return Err(PathError::ZeroVector {
                what: what.to_string(),
            });
        }
    }
    if !(tol.is_finite() && tol >= 0.0) {
        return Err(PathError::BadTolerance { tol });
    }
    check_interval(t0, t1)?;
    for (what, v) in [
        ("projected_segment: from", from),
        ("projected_segment: to", to),
    ] {
        let mismatch = set.relative_mismatch(v);
        if mismatch.is_nan() || mismatch.abs() > tol {
            let projection = match set.project(v) {
                Ok(p) => format!("{p:?}"),
                Err(e) => format!("undefined ({e})"),
            };
            return Err(PathError::OffLevelSet {
                what: what.to_string(),
                point: v.to_vec(),
                mismatch,
                tol,
                level: set.level(),
                projection,
            });
        }
    }
    let to = set.project(to)?;
    // Distance from the origin to the segment, computed in units of the larger end point
    // (no overflow; no 0/0 when the end points coincide).
    let scale = amax(from).max(amax(&to));
    let a: Vec<f64> = from.iter().map(|x| x / scale).collect();
    let d: Vec<f64> = to.iter().zip(&a).map(|(b, a)| b / scale - a).collect();
    let dd: f64 = d.iter().map(|x| x * x).sum();
    let along = if dd > 0.0 {
        (-a.iter().zip(&d).map(|(a, d)| a * d).sum::<f64>() / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let closest = norm(
        &a.iter()
            .zip(&d)
            .map(|(a, d)| a + along * d)
            .collect::<Vec<_>>(),
    );
    let size = norm(&a);
    if closest <= 1e-8 * size {
        return Err(PathError::SegmentThroughOrigin {
            from: from.to_vec(),
            to,
            closest: closest * scale,
            size: size * scale,
        });
    }
    let segment = Segment::new(from.to_vec(), to, t0, t1)?;
    Projected::new(Arc::new(segment), set.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::so3::desired::{DesiredPath, ProjectedPath, ProjectedSegment, SampledPath};
    use crate::so3::ellipsoid::{EnergyEllipsoid, Inertia};
    use nalgebra::Vector3;

    fn jet(path: &dyn Path, t: f64) -> Vec<f64> {
        let mut out = vec![0.0; 4 * path.dim()];
        path.jet_into(t, &mut out);
        out
    }

    /// An inner path that counts its evaluations.
    struct Counting {
        inner: Arc<dyn Path>,
        calls: std::sync::atomic::AtomicUsize,
    }

    impl Path for Counting {
        fn dim(&self) -> usize {
            self.inner.dim()
        }
        fn jet_into(&self, t: f64, out: &mut [f64]) {
            self.calls
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.inner.jet_into(t, out);
        }
        fn end_time(&self) -> Option<f64> {
            self.inner.end_time()
        }
    }

    /// The memo returns the inner path's jets bit for bit, evaluates the inner path once per
    /// time while the slot is kept, recomputes after a time is evicted by another in its
    /// slot, passes non-finite times through, and delegates values and the end time.
    #[test]
    fn the_memo_returns_the_inner_jets_and_evaluates_each_time_once() {
        let set = LevelSet::through(
            &[1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0],
            3,
            &[5.0, 0.0, 0.0],
        )
        .unwrap();
        let inner: Arc<dyn Path> = Arc::new(
            projected_segment(
                &set,
                &[5.0, 0.0, 0.0],
                &[0.0, 3.273268353539885, 1.0910894511799618],
                0.0,
                2.0,
                1e-10,
            )
            .unwrap(),
        );
        let counting = Arc::new(Counting {
            inner: inner.clone(),
            calls: Default::default(),
        });
        let memo = Memo::new(counting.clone());
        let calls = || counting.calls.load(std::sync::atomic::Ordering::Relaxed);
        let times: Vec<f64> = (0..=300).map(|i| i as f64 / 150.0).collect();
        let alone = distinct(&times);
        assert!(
            alone >= 250,
            "{alone} of 301 times have a slot of their own"
        );
        for round in 0..3 {
            let before = calls();
            for &t in &times {
                let (got, want) = (jet(&memo, t), jet(&*inner, t));
                assert!(
                    got.iter()
                        .zip(&want)
                        .all(|(a, b)| a.to_bits() == b.to_bits()),
                    "t = {t}: {got:?} against {want:?}"
                );
            }
            let evaluated = calls() - before;
            if round == 0 {
                assert_eq!(evaluated, times.len());
            } else {
                // Only the times that share a slot are evaluated again.
                assert!(
                    evaluated <= times.len() - alone,
                    "round {round}: {evaluated}"
                );
            }
        }
        // Two times in one slot: both still correct, in any order.
        let t1 = 0.25_f64;
        let slot = MemoTable::slot(t1.to_bits());
        let t2 = (1..1_000_000)
            .map(|i| 0.25 + i as f64 * 1e-9)
            .find(|t: &f64| MemoTable::slot(t.to_bits()) == slot)
            .expect("a colliding time");
        for t in [t1, t2, t1, t2] {
            assert_eq!(jet(&memo, t), jet(&*inner, t));
        }
        // Non-finite times are not stored (the inner path decides what they give).
        let before = calls();
        let nan = jet(&memo, f64::NAN);
        assert!(nan.iter().all(|v| v.is_nan()) || nan == jet(&*inner, f64::NAN));
        jet(&memo, f64::NAN);
        assert_eq!(calls(), before + 2);
        assert_eq!(value(&memo, 0.7), value(&*inner, 0.7));
        assert_eq!(memo.end_time(), Some(2.0));
        assert_eq!(memo.dim(), 3);
    }

    /// Times of `times` whose slot no other of them shares.
    fn distinct(times: &[f64]) -> usize {
        let mut count = std::collections::HashMap::new();
        for t in times {
            *count.entry(MemoTable::slot(t.to_bits())).or_insert(0) += 1;
        }
        count.values().filter(|&&c| c == 1).count()
    }

    fn value(path: &dyn Path, t: f64) -> Vec<f64> {
        let mut out = vec![0.0; path.dim()];
        path.value_into(t, &mut out);
        out
    }

    fn dot(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }

    fn dist(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt()
    }

    /// `I v` for a row-major n×n matrix.
    fn apply(inertia: &[f64], v: &[f64]) -> Vec<f64> {
        let n = v.len();
        (0..n)
            .map(|i| dot(&inertia[i * n..(i + 1) * n], v))
            .collect()
    }

    /// 8th-order central finite differences of `value_into` (6th order for the third
    /// derivative), as `finite_difference_derivatives` in `so3::desired`.
    fn finite_differences(path: &dyn Path, t: f64, h: f64) -> [Vec<f64>; 3] {
        let f: Vec<Vec<f64>> = (-4..=4).map(|k| value(path, t + k as f64 * h)).collect();
        let n = path.dim();
        let at = |k: i32, i: usize| f[(k + 4) as usize][i];
        let d1 = (0..n)
            .map(|i| {
                ((at(-4, i) - at(4, i)) * (1.0 / 280.0)
                    + (at(3, i) - at(-3, i)) * (4.0 / 105.0)
                    + (at(-2, i) - at(2, i)) * (1.0 / 5.0)
                    + (at(1, i) - at(-1, i)) * (4.0 / 5.0))
                    / h
            })
            .collect();
        let d2 = (0..n)
            .map(|i| {
                ((at(-4, i) + at(4, i)) * (-1.0 / 560.0)
                    + (at(3, i) + at(-3, i)) * (8.0 / 315.0)
                    + (at(-2, i) + at(2, i)) * (-1.0 / 5.0)
                    + (at(1, i) + at(-1, i)) * (8.0 / 5.0)
                    + at(0, i) * (-205.0 / 72.0))
                    / (h * h)
            })
            .collect();
        let d3 = (0..n)
            .map(|i| {
                ((at(-4, i) - at(4, i)) * (-7.0 / 240.0)
                    + (at(3, i) - at(-3, i)) * (-3.0 / 10.0)
                    + (at(-2, i) - at(2, i)) * (-169.0 / 120.0)
                    + (at(-1, i) - at(1, i)) * (61.0 / 30.0))
                    / (h * h * h)
            })
            .collect();
        [d1, d2, d3]
    }

    /// Exact jet against finite differences: `|exact − fd| / max(|fd|, 1) < tol[k]` for the
    /// k-th derivative; the jet's value equals `value_into` bit for bit. Returns the errors.
    fn check_fd(path: &dyn Path, t: f64, h: f64, tol: [f64; 3]) -> [f64; 3] {
        let n = path.dim();
        let j = jet(path, t);
        assert_eq!(
            &j[..n],
            &value(path, t)[..],
            "t = {t}: jet value vs value_into"
        );
        let fd = finite_differences(path, t, h);
        let mut errs = [0.0; 3];
        for k in 0..3 {
            let exact = &j[(k + 1) * n..(k + 2) * n];
            let err = dist(exact, &fd[k]) / norm(&fd[k]).max(1.0);
            assert!(
                err < tol[k],
                "t = {t}: derivative {}: exact {exact:?} vs fd {:?}: rel err {err:e}",
                k + 1,
                fd[k]
            );
            errs[k] = err;
        }
        errs
    }

    /// A non-diagonal symmetric positive definite 6×6 matrix: `AᵀA + 2·1`, `A_ij = sin(1 + i
    /// + 2j)` (exactly symmetric in f64: the same products summed in the same order).
    fn spd6() -> Vec<f64> {
        let n = 6;
        let a = |i: usize, j: usize| (1.0 + i as f64 + 2.0 * j as f64).sin();
        let mut m = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                m[i * n + j] =
                    (0..n).map(|k| a(k, i) * a(k, j)).sum::<f64>() + if i == j { 2.0 } else { 0.0 };
            }
        }
        m
    }

    const TIMES6: [f64; 6] = [0.0, 0.7, 1.5, 2.2, 3.0, 4.1];

    /// Samples of a smooth curve in R⁶ that stays away from the origin.
    fn samples6() -> Vec<Vec<f64>> {
        TIMES6
            .iter()
            .map(|&t| {
                (0..6)
                    .map(|c| {
                        let c = c as f64;
                        (if c == 0.0 { 3.0 } else { 0.0 }) + (t + c).cos() * (1.0 + 0.2 * c)
                    })
                    .collect()
            })
            .collect()
    }

    fn sampled6() -> Sampled {
        Sampled::new(&TIMES6, &samples6()).unwrap()
    }

    fn projected_sampled6() -> (Projected, Vec<f64>) {
        let inertia = spd6();
        let spline = sampled6();
        let set = LevelSet::through(&inertia, 6, &value(&spline, 0.0)).unwrap();
        (Projected::new(Arc::new(spline), set).unwrap(), inertia)
    }

    #[test]
    fn segment_jet_is_exact_and_hits_its_end_points() {
        let from = vec![1.0, -2.0, 0.5, 3.0, 0.0, 7.25];
        let to = vec![0.1, 4.0, -1.5, 3.0, 2.0, -1.0];
        let s = Segment::new(from.clone(), to.clone(), 0.3, 2.9).unwrap();
        assert_eq!(s.dim(), 6);
        assert_eq!(s.end_time(), Some(2.9));
        assert_eq!(value(&s, 0.3), from);
        assert_eq!(value(&s, 2.9), to);
        for t in [-1.0, 0.3, 1.0, 1.6, 2.5, 2.9, 4.0] {
            let errs = check_fd(&s, t, 1e-2, [1e-12, 1e-9, 1e-6]);
            assert!(errs[0] < 1e-13, "t = {t}: {errs:?}");
            let j = jet(&s, t);
            for i in 0..6 {
                let velocity = (to[i] - from[i]) / 2.6;
                assert_eq!(j[6 + i], velocity);
                assert_eq!((j[12 + i], j[18 + i]), (0.0, 0.0));
                // The straight line, extended linearly.
                let exact = from[i] + (t - 0.3) * velocity;
                assert!(
                    (j[i] - exact).abs() < 1e-14 * (1.0 + exact.abs()),
                    "t = {t}"
                );
            }
        }
    }

    #[test]
    fn constant_jet_is_the_value_and_zeros() {
        let c = Constant::new(vec![1.0, -2.0, 3.5, 0.0]).unwrap();
        assert_eq!(c.dim(), 4);
        assert_eq!(c.end_time(), None);
        assert_eq!(c.value(), &[1.0, -2.0, 3.5, 0.0]);
        let j = jet(&c, 17.0);
        assert_eq!(&j[..4], &[1.0, -2.0, 3.5, 0.0]);
        assert!(j[4..].iter().all(|&x| x == 0.0));
        assert_eq!(value(&c, -3.0), vec![1.0, -2.0, 3.5, 0.0]);
    }

    #[test]
    fn sampled_jet_matches_finite_differences_away_from_knots() {
        let p = sampled6();
        assert_eq!(p.dim(), 6);
        assert_eq!(p.end_time(), Some(4.1));
        assert_eq!(p.times(), &TIMES6);
        // The stencil t ± 4h stays inside one interval (or the linear extension). Measured
        // worst errors: 3.7e-14, 2.5e-11, 1.3e-9 (round-off of the stencil, eps/h³ for the
        // third derivative: the spline is a cubic, so the stencil has no truncation error).
        for t in [-1.0, 0.35, 1.1, 1.85, 2.6, 3.5, 6.0] {
            check_fd(&p, t, 1e-2, [1e-12, 1e-10, 1e-8]);
        }
    }

    /// The bent path: the given end points at a and b, the inner path between the windows
    /// (bit for bit), an exact jet (finite differences inside and across the windows), and
    /// the window checked.
    #[test]
    fn end_blend_meets_its_end_points_and_keeps_the_inner_path_between() {
        let inner: Arc<dyn Path> = Arc::new(sampled6());
        let (a, b) = (0.2, 3.8);
        let start = [1.0, -2.0, 0.5, 3.0, 0.0, -1.0];
        let end = [-0.5, 4.0, 2.0, -3.0, 1.5, 0.25];
        let bent = EndBlend::new(inner.clone(), (a, b), &start, &end, 0.9).unwrap();
        assert_eq!(bent.dim(), 6);
        assert_eq!(bent.end_time(), Some(b));
        assert!(
            dist(&value(&bent, a), &start) <= 1e-14,
            "{:?}",
            value(&bent, a)
        );
        assert!(
            dist(&value(&bent, b), &end) <= 1e-14,
            "{:?}",
            value(&bent, b)
        );
        for t in [a + 1.0, 1.5, 2.0, b - 1.0] {
            assert_eq!(
                jet(&bent, t),
                jet(&*inner, t),
                "t = {t}: between the windows"
            );
        }
        // Inside the windows and outside [a, b], the stencil t ± 4h clear of the spline's knots
        // and the windows' edges (where the fourth derivative jumps).
        for t in [a - 0.3, a + 0.3, a + 0.6, b - 0.5, b - 0.2, b + 0.2] {
            check_fd(&bent, t, 1e-2, [1e-10, 1e-8, 1e-6]);
        }
        for window in [0.0, -1.0, 3.7, f64::NAN] {
            let err = EndBlend::new(inner.clone(), (a, b), &start, &end, window).unwrap_err();
            assert!(
                matches!(err, PathError::BadWindow { .. }),
                "{window}: {err}"
            );
        }
        assert!(EndBlend::new(inner, (a, b), &start[..3], &end, 0.9).is_err());
    }

    #[test]
    fn projected_sampled_jet_matches_finite_differences() {
        let (p, _) = projected_sampled6();
        assert_eq!(p.end_time(), Some(4.1));
        // Measured worst errors: 4.0e-14, 2.4e-11, 1.9e-9.
        for t in [-1.0, 0.35, 1.1, 1.85, 2.6, 3.5, 6.0] {
            check_fd(&p, t, 1e-2, [1e-12, 1e-10, 1e-8]);
        }
    }

    /// On the set and tangent to it, with the derivative identities of `⟨Ω, IΩ⟩ = level`:
    /// `⟨Ω̇, IΩ⟩ = 0`, `⟨Ω̈, IΩ⟩ + ⟨Ω̇, IΩ̇⟩ = 0`, `⟨Ω⃛, IΩ⟩ + 3⟨Ω̈, IΩ̇⟩ = 0`.
    fn check_on_set(p: &Projected, inertia: &[f64], t: f64) {
        let n = p.dim();
        let j = jet(p, t);
        let (w, w1, w2, w3) = (&j[..n], &j[n..2 * n], &j[2 * n..3 * n], &j[3 * n..]);
        let mismatch = p.set.relative_mismatch(w);
        assert!(mismatch.abs() <= 1e-14, "t = {t}: mismatch {mismatch:e}");
        let (iw, iw1) = (apply(inertia, w), apply(inertia, w1));
        let scale1 = norm(w1) * norm(&iw);
        assert!(
            dot(w1, &iw).abs() <= 1e-14 * scale1,
            "t = {t}: <w1, I w> = {:e} (scale {scale1:e})",
            dot(w1, &iw)
        );
        let e2 = dot(w2, &iw) + dot(w1, &iw1);
        let scale2 = norm(w2) * norm(&iw) + norm(w1) * norm(&iw1);
        assert!(
            e2.abs() <= 1e-14 * scale2,
            "t = {t}: second identity {e2:e}"
        );
        let e3 = dot(w3, &iw) + 3.0 * dot(w2, &iw1);
        let scale3 = norm(w3) * norm(&iw) + 3.0 * norm(w2) * norm(&iw1);
        assert!(e3.abs() <= 1e-14 * scale3, "t = {t}: third identity {e3:e}");
    }

    #[test]
    fn projected_stays_on_the_level_set_and_is_tangent_to_it() {
        let (p, inertia) = projected_sampled6();
        for k in 0..=60 {
            check_on_set(&p, &inertia, -1.0 + 0.1 * k as f64);
        }
        // A projected segment on the same set.
        let from = value(&p, 0.0);
        let to = p.set.project(&[0.0, 1.0, -2.0, 0.5, 1.0, 3.0]).unwrap();
        let seg = projected_segment(&p.set, &from, &to, 1.0, 3.0, 1e-12).unwrap();
        assert_eq!(seg.end_time(), Some(3.0));
        for k in 0..=40 {
            check_on_set(&seg, &inertia, 0.5 + 0.075 * k as f64);
        }
        assert!(dist(&value(&seg, 1.0), &from) < 1e-14 * norm(&from));
        assert!(dist(&value(&seg, 3.0), &to) < 1e-14 * norm(&to));
        check_fd(&seg, 2.0, 1e-2, [1e-11, 1e-9, 1e-6]);
    }

    #[test]
    fn so3_projected_segment_equals_the_suslov_projected_segment() {
        let diag = [1.0, 1.5, 2.5];
        let inertia = Inertia::new(diag).unwrap();
        let matrix = [1.0, 0.0, 0.0, 0.0, 1.5, 0.0, 0.0, 0.0, 2.5];
        let omega_a = Vector3::new(3.0, 1.0, 0.0);
        let e = EnergyEllipsoid::through(inertia, &omega_a).unwrap();
        let omega_b = e.project(&Vector3::new(1.0, 2.0, -1.0)).unwrap();
        let old = ProjectedSegment::new(inertia, omega_a, omega_b, 0.5, 4.0).unwrap();
        let set = LevelSet::through(&matrix, 3, omega_a.as_slice()).unwrap();
        assert_eq!(set.level(), e.level());
        let new = projected_segment(
            &set,
            omega_a.as_slice(),
            omega_b.as_slice(),
            0.5,
            4.0,
            crate::lie::problem::ENERGY_REL_TOL,
        )
        .unwrap();
        // Measured worst difference: 2.0e-16.
        for k in 0..=50 {
            let t = -0.5 + 0.1 * k as f64;
            let (a, b) = (old.jet(t), jet(&new, t));
            for (d, x) in [a.value, a.d1, a.d2, a.d3].iter().enumerate() {
                let y = &b[3 * d..3 * d + 3];
                // Relative to the size of the derivative, or of Ω where it vanishes.
                let err = dist(x.as_slice(), y) / x.norm().max(omega_a.norm());
                assert!(
                    err <= 1e-13,
                    "t = {t}, derivative {d}: {x} vs {y:?}: {err:e}"
                );
            }
        }
    }

    #[test]
    fn so3_sampled_equals_sampled_path_bit_for_bit() {
        let times = [0.0, 0.5, 1.3, 2.0, 3.1];
        let rows: Vec<[f64; 3]> = times
            .iter()
            .map(|&t: &f64| [4.0 + t.sin(), 2.0 - t, t * t])
            .collect();
        let old = SampledPath::new(&times, &rows).unwrap();
        let new =
            Sampled::new(&times, &rows.iter().map(|r| r.to_vec()).collect::<Vec<_>>()).unwrap();
        for k in 0..=90 {
            let t = -1.0 + 0.05 * k as f64;
            let (a, b) = (old.jet(t), jet(&new, t));
            let a: Vec<f64> = [a.value, a.d1, a.d2, a.d3]
                .iter()
                .flat_map(|v| v.iter().copied())
                .collect();
            assert_eq!(a, b, "t = {t}");
        }
        // Projected: the n-dimensional projection agrees with the ellipsoid's.
        let inertia = Inertia::new([1.0, 2.0, 3.0]).unwrap();
        let e = EnergyEllipsoid::through(inertia, &Vector3::new(4.0, 2.0, 0.0)).unwrap();
        let old = ProjectedPath {
            inner: Arc::new(old),
            ellipsoid: e,
        };
        let set = LevelSet::through(
            &[1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0],
            3,
            &[4.0, 2.0, 0.0],
        )
        .unwrap();
        let new = Projected::new(Arc::new(new), set).unwrap();
        for k in 0..=90 {
            let t = -1.0 + 0.05 * k as f64;
            let (a, b) = (old.jet(t), jet(&new, t));
            for (d, x) in [a.value, a.d1, a.d2, a.d3].iter().enumerate() {
                let y = &b[3 * d..3 * d + 3];
                let err = dist(x.as_slice(), y) / x.norm().max(a.value.norm());
                assert!(
                    err <= 1e-13,
                    "t = {t}, derivative {d}: {x} vs {y:?}: {err:e}"
                );
            }
        }
    }

    #[test]
    fn the_spline_interpolates_reproduces_lines_and_is_c2() {
        let p = sampled6();
        let rows = samples6();
        for (t, row) in TIMES6.iter().zip(&rows) {
            let v = value(&p, *t);
            assert!(
                dist(&v, row) <= 1e-14 * norm(row),
                "t = {t}: {v:?} vs {row:?}"
            );
        }
        // C² at the knots and at both ends (linear extension); the third derivative jumps.
        for &t in &TIMES6 {
            let (l, r) = (jet(&p, t - 1e-9), jet(&p, t + 1e-9));
            assert!(dist(&l[..6], &r[..6]) < 1e-8, "value at {t}");
            assert!(dist(&l[6..12], &r[6..12]) < 1e-8, "d1 at {t}");
            assert!(dist(&l[12..18], &r[12..18]) < 1e-7, "d2 at {t}");
            // The knot itself belongs to the interval on its right, the last one to the
            // last interval (the cubic, not the linear extension).
            let side = if t == 4.1 { &l } else { &r };
            assert_eq!(jet(&p, t)[18..], side[18..], "t = {t}");
        }
        assert!(dist(&jet(&p, 0.7 - 1e-9)[18..], &jet(&p, 0.7 + 1e-9)[18..]) > 0.1);
        // Natural: second derivative 0 at both ends, exactly linear outside.
        for t in [-2.0, 0.0, 4.1, 9.0] {
            let j = jet(&p, t);
            assert!(j[12..18].iter().all(|x| x.abs() < 1e-13), "t = {t}: {j:?}");
        }
        for t in [-2.0, 9.0] {
            assert!(jet(&p, t)[12..].iter().all(|&x| x == 0.0), "t = {t}");
        }
        let (a, b) = (jet(&p, 4.1), value(&p, 9.0));
        for i in 0..6 {
            assert!(
                (a[i] + 4.9 * a[6 + i] - b[i]).abs() < 1e-13,
                "component {i}"
            );
        }
        // Straight lines (at uneven times) are reproduced exactly.
        let times = [-1.0, 0.25, 0.5, 2.0, 2.125, 7.0];
        let line = |t: f64| vec![1.0 + 2.0 * t, -3.0 * t, 0.5, 4.0 - t];
        let rows: Vec<Vec<f64>> = times.iter().map(|&t| line(t)).collect();
        let p = Sampled::new(&times, &rows).unwrap();
        for t in [-3.0, -1.0, 0.1, 0.4, 1.0, 2.1, 5.5, 7.0, 10.0] {
            let j = jet(&p, t);
            let exact = line(t);
            assert!(dist(&j[..4], &exact) < 1e-14 * norm(&exact), "t = {t}");
            assert!(dist(&j[4..8], &[2.0, -3.0, 0.0, -1.0]) < 1e-14, "t = {t}");
            assert!(j[8..].iter().all(|x| x.abs() < 1e-13), "t = {t}: {j:?}");
        }
        // Two samples: the straight line.
        let p = Sampled::new(&[0.0, 2.0], &[vec![0.0; 2], vec![2.0, 4.0]]).unwrap();
        assert_eq!(value(&p, 1.0), vec![1.0, 2.0]);
        assert_eq!(value(&p, 3.0), vec![3.0, 6.0]);
        assert_eq!(value(&p, -1.0), vec![-1.0, -2.0]);
    }

    #[test]
    fn level_set_quadratic_projection_and_overflow_safety() {
        let inertia = spd6();
        let point = [1.0, 0.5, -0.25, 2.0, 0.0, 1.0];
        let set = LevelSet::through(&inertia, 6, &point).unwrap();
        assert_eq!(set.dim(), 6);
        assert_eq!(set.inertia(), &inertia[..]);
        let exact = dot(&point, &apply(&inertia, &point));
        assert!((set.level() - exact).abs() <= 1e-14 * exact);
        assert!(set.relative_mismatch(&point).abs() < 1e-15);
        assert_eq!(set.relative_mismatch(&[0.0; 6]), -1.0);
        let v = [3.0, -1.0, 2.0, 0.5, 0.25, -4.0];
        let qv = dot(&v, &apply(&inertia, &v));
        assert!((set.quadratic(&v) - qv).abs() <= 1e-14 * qv);
        // The projection: on the set, along the ray, idempotent.
        let p = set.project(&v).unwrap();
        assert!(set.relative_mismatch(&p).abs() < 1e-15);
        let ratio = p[0] / v[0];
        assert!(ratio > 0.0 && p.iter().zip(&v).all(|(a, b)| (a - ratio * b).abs() < 1e-15));
        assert!(dist(&set.project(&p).unwrap(), &p) < 1e-14 * norm(&p));
        // Huge and tiny vectors: scaled, not overflowing or flushed to zero.
        let huge: Vec<f64> = v.iter().map(|x| x * 1e300).collect();
        let tiny: Vec<f64> = v.iter().map(|x| x * 1e-300).collect();
        assert_eq!(set.quadratic(&tiny), 0.0); // ~1e-599: truly below f64
        assert!(set.quadratic(&huge).is_infinite()); // ~1e601: truly beyond f64
        let big: Vec<f64> = v.iter().map(|x| x * 1e150).collect();
        assert!((set.quadratic(&big) / (qv * 1e300) - 1.0).abs() < 1e-14);
        let small: Vec<f64> = v.iter().map(|x| x * 1e-160).collect();
        let q_small = set.quadratic(&small); // ~1e-319: subnormal, but not 0
        assert!(q_small > 0.0 && q_small < f64::MIN_POSITIVE);
        for w in [&huge, &tiny] {
            let pw = set.project(w).unwrap();
            assert!(dist(&pw, &p) < 1e-14 * norm(&p), "{pw:?} vs {p:?}");
        }
        // The generic projection: f64 agrees with project, dual numbers carry derivatives.
        let mut out = [0.0; 6];
        set.project_generic(&v, &mut out);
        assert!(dist(&out, &p) < 1e-15 * norm(&p));
        let dual: Vec<Dual3<f64>> = v.iter().map(|&x| Dual3::new(x, 1.0, 0.0, 0.0)).collect();
        let mut dout = vec![Dual3::from_re(0.0); 6];
        set.project_generic(&dual, &mut dout);
        let re: Vec<f64> = dout.iter().map(|d| d.re).collect();
        assert!(dist(&re, &p) < 1e-15 * norm(&p));
        // d/ds of the projection of v + s·1 is tangent to the set: ⟨v1, I p⟩ = 0.
        let v1: Vec<f64> = dout.iter().map(|d| d.v1).collect();
        assert!(dot(&v1, &apply(&inertia, &p)).abs() < 1e-14 * norm(&v1) * norm(&p));
    }

    #[test]
    fn large_dimensions_use_the_heap_and_agree() {
        // n = 20 > 16: tridiagonal SPD matrix, a sampled path.
        let n = 20;
        let mut inertia = vec![0.0; n * n];
        for i in 0..n {
            inertia[i * n + i] = 2.0 + 0.1 * i as f64;
            if i + 1 < n {
                inertia[i * n + i + 1] = -0.5;
                inertia[(i + 1) * n + i] = -0.5;
            }
        }
        let times = [0.0, 1.0, 2.5, 3.0];
        let rows: Vec<Vec<f64>> = times
            .iter()
            .map(|&t: &f64| (0..n).map(|c| 1.0 + (0.3 * c as f64 + t).sin()).collect())
            .collect();
        let spline = Sampled::new(&times, &rows).unwrap();
        let set = LevelSet::through(&inertia, n, &rows[0]).unwrap();
        let p = Projected::new(Arc::new(spline), set).unwrap();
        for t in [0.3, 1.7, 2.75] {
            check_on_set(&p, &inertia, t);
        }
        check_fd(&p, 1.7, 1e-2, [1e-11, 1e-9, 1e-6]);
        // The default value_into (through the jet) for a path without an override.
        struct JetOnly(Segment);
        impl Path for JetOnly {
            fn dim(&self) -> usize {
                self.0.dim()
            }
            fn jet_into(&self, t: f64, out: &mut [f64]) {
                self.0.jet_into(t, out)
            }
        }
        for n in [3, 20] {
            let s = Segment::new(vec![1.0; n], vec![-2.0; n], 0.0, 3.0).unwrap();
            let expected = value(&s, 0.5);
            assert_eq!(value(&JetOnly(s), 0.5), expected);
        }
    }

    #[test]
    fn paths_are_shared_across_threads() {
        let (p, _) = projected_sampled6();
        let path: Arc<dyn Path> = Arc::new(p);
        let expected = jet(path.as_ref(), 1.25);
        std::thread::scope(|s| {
            for _ in 0..2 {
                let path = Arc::clone(&path);
                let expected = &expected;
                s.spawn(move || assert_eq!(&jet(path.as_ref(), 1.25), expected));
            }
        });
        // Debug shows the inner path's dimension and the set.
        let (p, _) = projected_sampled6();
        let debug = format!("{p:?}");
        assert!(
            debug.starts_with("Projected { inner: <dyn Path, dim 6>, set: LevelSet { n: 6,"),
            "{debug}"
        );
    }

    fn sampled_set() -> LevelSet {
        LevelSet::through(&[2.0, 0.0, 0.0, 1.0], 2, &[1.0, 1.0]).unwrap()
    }

    #[test]
    #[should_panic(expected = "Path::jet_into: `out` has 5 entries, but this path needs 24")]
    fn jet_into_panics_on_a_wrong_length() {
        sampled6().jet_into(0.0, &mut [0.0; 5]);
    }

    #[test]
    #[should_panic(expected = "the inner path is in R^6 but the level set in R^2")]
    fn a_projected_path_of_mismatched_dimension_panics_when_evaluated() {
        let p = Projected {
            inner: Arc::new(sampled6()),
            set: sampled_set(),
        };
        p.jet_into(0.0, &mut [0.0; 8]);
    }

    /// The variant's position, by an exhaustive match: a new variant fails to compile here
    /// until it is given a number (and a test below).
    fn variant(e: &PathError) -> usize {
        match e {
            PathError::Empty { .. } => 0,
            PathError::LengthMismatch { .. } => 1,
            PathError::NotFinite { .. } => 2,
            PathError::TooFewSamples { .. } => 3,
            PathError::TimesNotIncreasing { .. } => 4,
            PathError::BadInterval { .. } => 5,
            PathError::Overflow { .. } => 6,
            PathError::NotSymmetric { .. } => 7,
            PathError::NotPositiveDefinite { .. } => 8,
            PathError::ZeroVector { .. } => 9,
            PathError::LevelOutOfRange { .. } => 10,
            PathError::OffLevelSet { .. } => 11,
            PathError::SegmentThroughOrigin { .. } => 12,
            PathError::BadTolerance { .. } => 13,
            PathError::BadWindow { .. } => 14,
        }
    }
    const VARIANTS: usize = 15;

    #[test]
    fn every_error_variant_is_reached_by_bad_input() {
        let mut seen = [false; VARIANTS];
        let mut expect = |r: Result<(), PathError>, words: &[&str]| {
            let e = r.unwrap_err();
            let msg = e.to_string();
            for w in words {
                assert!(msg.contains(w), "{msg:?} lacks {w:?}");
            }
            seen[variant(&e)] = true;
            e
        };
        let unit = |r: Result<Projected, PathError>| r.map(|_| ());
        let id2 = [1.0, 0.0, 0.0, 1.0];
        let set = LevelSet::through(&id2, 2, &[1.0, 0.0]).unwrap();

        // Empty.
        expect(
            Constant::new(vec![]).map(|_| ()),
            &["Constant", "empty", "n ≥ 1"],
        );
        expect(
            LevelSet::through(&[], 0, &[]).map(|_| ()),
            &["dimension n", "empty"],
        );
        expect(
            Sampled::new(&[0.0, 1.0], &[vec![], vec![]]).map(|_| ()),
            &["values[0]", "empty"],
        );
        // LengthMismatch.
        expect(
            Segment::new(vec![1.0, 2.0], vec![1.0], 0.0, 1.0).map(|_| ()),
            &["Segment: to", "length 1", "length 2 is needed"],
        );
        expect(
            Sampled::new(&[0.0, 1.0, 2.0], &[vec![1.0], vec![2.0]]).map(|_| ()),
            &["one row per sample time", "length 2", "length 3 is needed"],
        );
        expect(
            Sampled::new(&[0.0, 1.0], &[vec![1.0, 2.0], vec![2.0]]).map(|_| ()),
            &["values[1]", "length 1", "length 2 is needed"],
        );
        expect(
            LevelSet::through(&[1.0, 0.0, 1.0], 2, &[1.0, 0.0]).map(|_| ()),
            &["inertia matrix", "length 3", "length 4 is needed"],
        );
        expect(
            LevelSet::through(&id2, 2, &[1.0, 0.0, 0.0]).map(|_| ()),
            &["the point", "length 3"],
        );
        expect(set.project(&[1.0]).map(|_| ()), &["project", "length 1"]);
        expect(
            unit(Projected::new(Arc::new(sampled6()), set.clone())),
            &["inner path", "length 6", "length 2 is needed"],
        );
        expect(
            unit(projected_segment(
                &set,
                &[1.0],
                &[0.0, 1.0],
                0.0,
                1.0,
                1e-10,
            )),
            &["from", "length 1"],
        );
        // NotFinite.
        expect(
            Constant::new(vec![1.0, f64::NAN]).map(|_| ()),
            &["Constant: the value[1] = NaN", "finite"],
        );
        expect(
            Segment::new(vec![1.0], vec![f64::INFINITY], 0.0, 1.0).map(|_| ()),
            &["to[0] = inf"],
        );
        expect(
            Sampled::new(&[0.0, f64::NAN], &[vec![1.0], vec![2.0]]).map(|_| ()),
            &["times[1] = NaN"],
        );
        expect(
            Sampled::new(&[0.0, 1.0], &[vec![1.0], vec![f64::NAN]]).map(|_| ()),
            &["values[1][0] = NaN"],
        );
        expect(
            LevelSet::through(&[1.0, f64::NAN, 0.0, 1.0], 2, &[1.0, 0.0]).map(|_| ()),
            &["inertia matrix", "[1] = NaN"],
        );
        expect(set.project(&[f64::NAN, 1.0]).map(|_| ()), &["v[0] = NaN"]);
        // TooFewSamples.
        expect(
            Sampled::new(&[0.0], &[vec![1.0]]).map(|_| ()),
            &["at least 2 samples, got 1", "Constant"],
        );
        // TimesNotIncreasing: unsorted and duplicate times.
        expect(
            Sampled::new(&[0.0, 2.0, 1.0], &[vec![1.0], vec![2.0], vec![3.0]]).map(|_| ()),
            &["times[2] = 1 comes after times[1] = 2", "sort"],
        );
        expect(
            Sampled::new(&[0.0, 0.0], &[vec![1.0], vec![2.0]]).map(|_| ()),
            &["times[1] = 0 comes after times[0] = 0"],
        );
        // BadInterval.
        expect(
            Segment::new(vec![1.0], vec![2.0], 1.0, 1.0).map(|_| ()),
            &["t0 < t1", "t0 = 1, t1 = 1"],
        );
        expect(
            Segment::new(vec![1.0], vec![2.0], 2.0, 1.0).map(|_| ()),
            &["t0 = 2, t1 = 1", "swap"],
        );
        expect(
            Segment::new(vec![1.0], vec![2.0], -1e308, 1e308).map(|_| ()),
            &["t1 − t0 finite"],
        );
        expect(
            unit(projected_segment(
                &set,
                &[1.0, 0.0],
                &[0.0, 1.0],
                0.0,
                f64::NAN,
                0.0,
            )),
            &["t1 = NaN"],
        );
        // Overflow: the segment's velocity, the spline, the projection.
        expect(
            Segment::new(vec![1e308], vec![-1e308], 0.0, 1.0).map(|_| ()),
            &["velocity", "overflows f64", "interval longer"],
        );
        expect(
            Segment::new(vec![0.0], vec![1.0], 0.0, 1e-320).map(|_| ()),
            &["velocity", "1e-320"],
        );
        expect(
            Sampled::new(&[0.0, 1e-300, 1.0], &[vec![10.0], vec![11.0], vec![10.0]]).map(|_| ()),
            &[
                "cubic spline",
                "between sample 0",
                "overflows f64",
                "space them",
            ],
        );
        expect(
            Sampled::new(&[0.0, 1.0, 2.0], &[vec![1e308], vec![-1e308], vec![1e308]]).map(|_| ()),
            &["cubic spline", "overflows f64"],
        );
        let skewed = LevelSet::through(&[1e-320, 0.0, 0.0, 1.0], 2, &[0.0, 1e154]).unwrap();
        expect(
            skewed.project(&[1.0, 0.0]).map(|_| ()),
            &[
                "radial projection of [1.0, 0.0]",
                "overflows f64",
                "ill-conditioned",
            ],
        );
        // NotSymmetric (relative to the largest entry).
        expect(
            LevelSet::through(&[2.0, 1.0, 1.0 + 1e-9, 3.0], 2, &[1.0, 0.0]).map(|_| ()),
            &["not symmetric", "I[0][1] = 1e0", "(I + Iᵀ)/2"],
        );
        assert!(LevelSet::through(&[2.0, 1.0, 1.0 + 1e-15, 3.0], 2, &[1.0, 0.0]).is_ok());
        // NotPositiveDefinite: indefinite, zero and negative definite matrices.
        expect(
            LevelSet::through(&[1.0, 2.0, 2.0, 1.0], 2, &[1.0, 0.0]).map(|_| ()),
            &["not positive definite", "row 1"],
        );
        expect(
            LevelSet::through(&[0.0; 4], 2, &[1.0, 0.0]).map(|_| ()),
            &["not positive definite", "row 0"],
        );
        expect(
            LevelSet::through(&[-1.0, 0.0, 0.0, -1.0], 2, &[1.0, 0.0]).map(|_| ()),
            &["not positive definite"],
        );
        // ZeroVector.
        expect(
            LevelSet::through(&id2, 2, &[0.0, 0.0]).map(|_| ()),
            &["the point is the zero vector"],
        );
        expect(
            set.project(&[0.0, -0.0]).map(|_| ()),
            &["v is the zero vector"],
        );
        expect(
            unit(projected_segment(
                &set,
                &[1.0, 0.0],
                &[0.0, 0.0],
                0.0,
                1.0,
                1e-10,
            )),
            &["to is the zero vector"],
        );
        // LevelOutOfRange: overflow and underflow of ⟨p, I p⟩.
        expect(
            LevelSet::through(&id2, 2, &[1e200, 0.0]).map(|_| ()),
            &["level ⟨p, I p⟩ = inf", "rescale"],
        );
        expect(
            LevelSet::through(&id2, 2, &[1e-160, 0.0]).map(|_| ()),
            &["not a normal positive f64"],
        );
        // OffLevelSet: either end point.
        let e = expect(
            unit(projected_segment(
                &set,
                &[1.0, 0.0],
                &[0.0, 2.0],
                0.0,
                1.0,
                1e-10,
            )),
            &["projected_segment: to = [0.0, 2.0]", "by 3e0", "[0.0, 1.0]"],
        );
        assert!(matches!(e, PathError::OffLevelSet { mismatch, .. } if mismatch == 3.0));
        expect(
            unit(projected_segment(
                &set,
                &[0.5, 0.0],
                &[0.0, 1.0],
                0.0,
                1.0,
                1e-10,
            )),
            &["from = [0.5, 0.0]", "tolerance 1e-10"],
        );
        // SegmentThroughOrigin: opposite and nearly opposite end points.
        let e = expect(
            unit(projected_segment(
                &set,
                &[1.0, 0.0],
                &[-1.0, 0.0],
                0.0,
                1.0,
                0.0,
            )),
            &[
                "passes within 0.000e0 of the origin",
                "opposite",
                "intermediate point",
            ],
        );
        assert!(
            matches!(e, PathError::SegmentThroughOrigin { closest, size, .. }
            if closest == 0.0 && size == 1.0)
        );
        let near = set.project(&[-1.0, 1e-10]).unwrap();
        let e = expect(
            unit(projected_segment(&set, &[1.0, 0.0], &near, 0.0, 1.0, 1e-15)),
            &["passes within 5.000e-11"],
        );
        assert!(matches!(e, PathError::SegmentThroughOrigin { closest, .. }
            if (closest - 5e-11).abs() < 1e-20));
        // Not quite opposite: accepted.
        let ok = set.project(&[-1.0, 1e-6]).unwrap();
        assert!(projected_segment(&set, &[1.0, 0.0], &ok, 0.0, 1.0, 1e-15).is_ok());
        // BadTolerance.
        expect(
            unit(projected_segment(
                &set,
                &[1.0, 0.0],
                &[0.0, 1.0],
                0.0,
                1.0,
                f64::NAN,
            )),
            &["tolerance NaN"],
        );
        expect(
            unit(projected_segment(
                &set,
                &[1.0, 0.0],
                &[0.0, 1.0],
                0.0,
                1.0,
                -1.0,
            )),
            &["tolerance -1", "≥ 0"],
        );
        // BadWindow.
        expect(
            EndBlend::new(Arc::new(sampled6()), (0.0, 1.0), &[1.0; 6], &[2.0; 6], 1.5).map(|_| ()),
            &["window 1.5", "(0, b − a = 1]"],
        );

        let missing: Vec<usize> = (0..VARIANTS).filter(|&i| !seen[i]).collect();
        assert!(missing.is_empty(), "variants never reached: {missing:?}");
    }

    #[test]
    fn projected_segment_edge_cases() {
        let set = LevelSet::through(&spd6(), 6, &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap();
        let a = vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        // from = to: the constant path.
        let p = projected_segment(&set, &a, &a, 0.0, 1.0, 1e-12).unwrap();
        let j = jet(&p, 0.5);
        assert!(dist(&j[..6], &a) < 1e-15);
        assert!(j[6..].iter().all(|&x| x == 0.0));
        // `to` within the tolerance: accepted, and the path ends exactly on the set.
        let b = set.project(&[0.0, 1.0, 1.0, 0.0, -1.0, 0.5]).unwrap();
        let off: Vec<f64> = b.iter().map(|x| x * (1.0 + 5e-11f64).sqrt()).collect();
        let p = projected_segment(&set, &a, &off, 0.0, 1.0, 1e-10).unwrap();
        let end = value(&p, 1.0);
        assert!(set.relative_mismatch(&end).abs() < 1e-15);
        assert!(dist(&end, &off) < 1e-10 && dist(&end, &b) < 1e-15);
        assert!(projected_segment(&set, &a, &off, 0.0, 1.0, 1e-11).is_err());
    }
}
