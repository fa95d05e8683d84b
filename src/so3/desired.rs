//! Desired body angular velocities `Ω_d(t)` with *exact* time derivatives.
//!
//! Every path is written once, generically over a scalar type `D: Scalar` (plain `f64` or a
//! forward-mode dual number of `num-dual`), in [`PathEval::eval`]. The blanket
//! [`DesiredPath`] implementation evaluates it on a third-order dual number
//! `Dual3 = t + ε` and reads off the exact value and first three derivatives as a [`Jet`].
//! No finite differences are involved; the tests compare against high-order finite differences.
//!
//! # Built-in paths
//! - [`Spiral`]: the paper's `φ(t) = [c, t cos t, t sin t]` (eq. `eq_phi`, `c = 10`).
//! - [`Projected`]: the radial projection `[P(t)]_∥` of any path onto `E(I, Ω_a)`; this is how
//!   an admissible `Ω_p` (Property 2) is built from a path that leaves `E`.
//!   `Projected<Spiral>` is the paper's `φ_∥` (eq. `eq_proj_spiral`).
//! - [`PaperSpiral`]: the paper's desired trajectory `Ω_d(t) = φ_∥(t)(1 − s(t)) + Ω_b s(t)`,
//!   `s(t) = σ(t − b_d)`, `σ(t) = ½[1 + tanh(t/w)]` (eqs. `eq_phi` … `eq_Om_d`), with
//!   `Ω_b = φ_∥(b_d)` computed.
//! - [`Constant`]: `Ω(t) = v`.
//! - [`SampledPath`]: the natural cubic spline through samples `(t_k, Ω_k)` (C²).
//! - [`ProjectedSegment`]: a geodesic-like path on `E` from `Ω_a` at `t = a` to `Ω_b` at
//!   `t = b`: the radial projection of the straight segment, traversed at constant parameter
//!   speed (the paper's suggested nominal `Ω_p` when `γ = 0`, section 5.2).
//!
//! # Writing a path
//! Implement [`PathEval`] once, generically; [`DesiredPath::jet`] then gives exact
//! derivatives. The scalar methods (`sin`, `exp`, `sqrt`, …) come from [`DualNum`], re-exported
//! here.
//!
//! ```
//! use suslov::so3::desired::{DesiredPath, DualNum, PathEval, Scalar};
//!
//! /// Ω(t) = [1, sin t, e^{-t}]
//! struct MyPath;
//! impl PathEval for MyPath {
//!     fn eval<D: Scalar>(&self, t: D) -> [D; 3] {
//!         [D::from(1.0), t.sin(), (-t).exp()]
//!     }
//! }
//! let jet = MyPath.jet(0.0);
//! assert_eq!(jet.d1[1], 1.0); // d/dt sin t at 0
//! assert_eq!(jet.d3[2], -1.0); // d³/dt³ e^{-t} at 0
//! ```
//!
//! # tanh at large arguments
//! `num-dual` evaluates `tanh` of a dual number as `sinh/cosh`, which is `inf/inf = NaN` for
//! `|x| ≳ 710`. The sigmoid here uses [`stable_tanh`], which only ever exponentiates
//! `−2|x|`: at `x = −1000` the value is exactly `−1` and the derivatives underflow to `0`
//! (never NaN). Note that in `f64` already `tanh(x) = ±1` exactly for `|x| > 19.1`, so
//! `σ(a − b_d) = ½(1 + tanh(−1000)) = 0` exactly, and `s(t) = 0` exactly for
//! `t < b_d − 19.1 w ≈ 9.809`: there `Ω_d = φ_∥` bit for bit.

use std::sync::Arc;

use nalgebra::Vector3;
use num_dual::Dual3;
pub use num_dual::DualNum;

use super::ellipsoid::{EnergyEllipsoid, Inertia};
use super::problem::ENERGY_REL_TOL;
use super::SuslovError;
use crate::lie::path::Sampled;

pub use crate::lie::path::Scalar;

/// The value and first three time derivatives of a vector path at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jet {
    /// `Ω(t)`
    pub value: Vector3<f64>,
    /// `Ω̇(t)`
    pub d1: Vector3<f64>,
    /// `Ω̈(t)`
    pub d2: Vector3<f64>,
    /// `d³Ω/dt³(t)`
    pub d3: Vector3<f64>,
}

/// A vector path written once, generically over the scalar type.
pub trait PathEval {
    /// `Ω(t)` for a (dual) time `t`.
    fn eval<D: Scalar>(&self, t: D) -> [D; 3];
}

/// An so(3) desired path as a path of the generic layer ([`crate::lie::path::Path`],
/// dimension [`DIM`](crate::model::generated::DIM)): the bridge that lets the generic layer
/// solve the so(3) layer's problems.
#[derive(Clone)]
pub struct AsLiePath(pub Arc<dyn DesiredPath + Send + Sync>);

impl crate::lie::path::Path for AsLiePath {
    fn dim(&self) -> usize {
        crate::model::generated::DIM
    }

    fn jet_into(&self, t: f64, out: &mut [f64]) {
        let n = crate::model::generated::DIM;
        assert_eq!(
            out.len(),
            4 * n,
            "AsLiePath::jet_into: out has the wrong length"
        );
        let j = self.0.jet(t);
        for (block, v) in out.chunks_exact_mut(n).zip([j.value, j.d1, j.d2, j.d3]) {
            block.copy_from_slice(v.as_slice());
        }
    }

    fn value_into(&self, t: f64, out: &mut [f64]) {
        out.copy_from_slice(self.0.value(t).as_slice());
    }
}

/// A path of the generic layer in three dimensions as a [`DesiredPath`] (the reverse of
/// [`AsLiePath`]): e.g. a formula path ([`crate::lie::expression::Expression`]) in an so(3)
/// problem file. Its `dim()` must be 3.
#[derive(Clone)]
pub struct FromLiePath(pub Arc<dyn crate::lie::path::Path>);

impl DesiredPath for FromLiePath {
    fn jet(&self, t: f64) -> Jet {
        use crate::model::generated::DIM;
        let mut out = [0.0; 4 * DIM];
        self.0.jet_into(t, &mut out);
        let block = |k: usize| Vector3::from_column_slice(&out[k * DIM..(k + 1) * DIM]);
        Jet {
            value: block(0),
            d1: block(1),
            d2: block(2),
            d3: block(3),
        }
    }
}

/// A desired body angular velocity with exact derivatives (dyn-compatible).
pub trait DesiredPath {
    /// Value and first three derivatives at `t`.
    fn jet(&self, t: f64) -> Jet;

    /// Value only.
    fn value(&self, t: f64) -> Vector3<f64> {
        self.jet(t).value
    }
}

impl<P: PathEval> DesiredPath for P {
    fn jet(&self, t: f64) -> Jet {
        let r = self.eval(Dual3::from_re(t).derivative());
        let pick = |f: fn(&Dual3<f64>) -> f64| Vector3::new(f(&r[0]), f(&r[1]), f(&r[2]));
        Jet {
            value: pick(|d| d.re),
            d1: pick(|d| d.v1),
            d2: pick(|d| d.v2),
            d3: pick(|d| d.v3),
        }
    }

    fn value(&self, t: f64) -> Vector3<f64> {
        Vector3::from(self.eval(t))
    }
}

/// `tanh(x)` that stays finite (with finite derivatives) for all finite `x`, for any
/// [`Scalar`]. Uses `tanh(x) = sign(x) (1 − 2e/(1 + e))`, `e = exp(−2|x|)`.
pub fn stable_tanh<D: Scalar>(x: D) -> D {
    let negative = x.re() < 0.0;
    let ax = if negative { -x } else { x };
    let e = (ax * -2.0).exp();
    let t = D::one() - e * 2.0 * (e + 1.0).recip();
    if negative {
        -t
    } else {
        t
    }
}

fn lift<D: Scalar>(v: &Vector3<f64>) -> [D; 3] {
    [D::from(v[0]), D::from(v[1]), D::from(v[2])]
}

/// The constant path `Ω(t) = v`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Constant(pub Vector3<f64>);

impl PathEval for Constant {
    fn eval<D: Scalar>(&self, _t: D) -> [D; 3] {
        lift(&self.0)
    }
}

/// The paper's planar spiral `φ(t) = [c, t cos t, t sin t]` (eq. `eq_phi`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spiral {
    /// The constant first component (paper: `c = 10`).
    pub c: f64,
}

impl PathEval for Spiral {
    fn eval<D: Scalar>(&self, t: D) -> [D; 3] {
        [D::from(self.c), t * t.cos(), t * t.sin()]
    }
}

/// The radial projection `[P(t)]_∥` of a path `P` onto an energy ellipsoid (eq. `eq_par_proj`),
/// with exact derivatives. Undefined (non-finite) where `P(t) = 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct Projected<P> {
    /// The projected path.
    pub inner: P,
    /// The target ellipsoid `E(I, Ω_a)`.
    pub ellipsoid: EnergyEllipsoid,
}

impl<P> Projected<P> {
    /// `[inner(t)]_∥` onto `ellipsoid`.
    pub fn new(inner: P, ellipsoid: EnergyEllipsoid) -> Self {
        Self { inner, ellipsoid }
    }
}

impl<P: PathEval> PathEval for Projected<P> {
    fn eval<D: Scalar>(&self, t: D) -> [D; 3] {
        self.ellipsoid.project_generic(self.inner.eval(t))
    }
}

/// The paper's desired trajectory (section 5.3, eqs. `eq_phi` … `eq_Om_d`):
/// `Ω_d(t) = φ_∥(t)(1 − s(t)) + Ω_b s(t)`, `s(t) = σ(t − b_d)`, `σ(t) = ½[1 + tanh(t/w)]`.
#[derive(Debug, Clone, PartialEq)]
pub struct PaperSpiral {
    phi_par: Projected<Spiral>,
    width: f64,
    b_d: f64,
    omega_a: Vector3<f64>,
    omega_b: Vector3<f64>,
}

impl PaperSpiral {
    /// The paper's values: `c = 10`, `w = 0.01`, `b_d = 10`, `I = diag(1, 2, 3)`,
    /// `Ω_a = φ(0)/2 = [5, 0, 0]`.
    pub fn paper() -> Self {
        let c = 10.0;
        Self::new(
            c,
            0.01,
            10.0,
            Inertia::paper(),
            Vector3::new(c / 2.0, 0.0, 0.0),
        )
        .expect("the paper's parameters are valid")
    }

    /// General parameters: spiral offset `c`, sigmoid width `width > 0`, switching time `b_d`,
    /// inertia and `Ω_a` (which fixes `E`). `Ω_b = φ_∥(b_d)` is computed.
    pub fn new(
        c: f64,
        width: f64,
        b_d: f64,
        inertia: Inertia,
        omega_a: Vector3<f64>,
    ) -> Result<Self, SuslovError> {
        if !(width.is_finite() && width > 0.0 && c.is_finite() && b_d.is_finite()) {
            return Err(SuslovError::InvalidInput {
                what: format!(
                    "PaperSpiral needs finite c, b_d and width > 0; got c = {c}, b_d = {b_d}, width = {width}"
                ),
            });
        }
        let ellipsoid = EnergyEllipsoid::through(inertia, &omega_a)?;
        let spiral = Spiral { c };
        let omega_b = ellipsoid.project(&Vector3::from(spiral.eval(b_d)))?;
        Ok(Self {
            phi_par: Projected::new(spiral, ellipsoid),
            width,
            b_d,
            omega_a,
            omega_b,
        })
    }

    /// `φ_∥ = [φ]_∥`, the projected spiral (eq. `eq_proj_spiral`).
    pub fn phi_par(&self) -> &Projected<Spiral> {
        &self.phi_par
    }

    /// The spiral offset `c`.
    pub fn c(&self) -> f64 {
        self.phi_par.inner.c
    }

    /// The sigmoid width `w` (paper: 0.01).
    pub fn width(&self) -> f64 {
        self.width
    }

    /// The switching time `b_d` (paper: 10).
    pub fn b_d(&self) -> f64 {
        self.b_d
    }

    /// The ellipsoid `E(I, Ω_a)`.
    pub fn ellipsoid(&self) -> &EnergyEllipsoid {
        &self.phi_par.ellipsoid
    }

    /// `Ω_a` (paper: `φ(0)/2 = [5, 0, 0]`).
    pub fn omega_a(&self) -> Vector3<f64> {
        self.omega_a
    }

    /// `Ω_b = φ_∥(b_d)` (paper, rounded: `[2.7541, −2.3109, −1.4983]`).
    pub fn omega_b(&self) -> Vector3<f64> {
        self.omega_b
    }

    /// The translated sigmoid `s(t) = σ(t − b_d) = ½[1 + tanh((t − b_d)/w)]` (eqs. `eq_sigmoid`,
    /// `eq_tran_sigmoid`).
    pub fn switch<D: Scalar>(&self, t: D) -> D {
        (stable_tanh((t - self.b_d) * self.width.recip()) + 1.0) * 0.5
    }
}

impl PathEval for PaperSpiral {
    fn eval<D: Scalar>(&self, t: D) -> [D; 3] {
        let phi = self.phi_par.eval(t);
        let s = self.switch(t);
        let one_minus_s = D::one() - s;
        let b = lift::<D>(&self.omega_b);
        [
            phi[0] * one_minus_s + b[0] * s,
            phi[1] * one_minus_s + b[1] * s,
            phi[2] * one_minus_s + b[2] * s,
        ]
    }
}

/// A geodesic-like path on `E` from `Ω_a` (at `t = a`) to `Ω_b` (at `t = b`): the radial
/// projection of the straight segment `Ω_a + (t − a)/(b − a) (Ω_b − Ω_a)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectedSegment {
    omega_a: Vector3<f64>,
    omega_b: Vector3<f64>,
    a: f64,
    b: f64,
    ellipsoid: EnergyEllipsoid,
}

impl ProjectedSegment {
    /// The path from `omega_a` at `t = a` to `omega_b` at `t = b > a` on `E(I, Ω_a)`.
    ///
    /// `Ω_b` may be off `E` by up to [`ENERGY_REL_TOL`] (relative energy), the tolerance
    /// [`SuslovProblem::validate`](super::problem::SuslovProblem::validate) allows; the path
    /// ends at its radial projection onto `E` (a change of at most ~`ENERGY_REL_TOL / 2`
    /// relative), so that it lies on `E` everywhere. `Ω_b = Ω_a` gives the constant path.
    ///
    /// Errors if `a >= b`, if `Ω_b` is off `E` by more than `ENERGY_REL_TOL`, or if the
    /// segment passes through (or within `1e-8·|Ω_a|` of) the origin, where the projection
    /// is undefined ([`SuslovError::SegmentThroughOrigin`]).
    pub fn new(
        inertia: Inertia,
        omega_a: Vector3<f64>,
        omega_b: Vector3<f64>,
        a: f64,
        b: f64,
    ) -> Result<Self, SuslovError> {
        if !(a.is_finite() && b.is_finite() && a < b) {
            return Err(SuslovError::InvalidInput {
                what: format!("ProjectedSegment needs finite a < b; got a = {a}, b = {b}"),
            });
        }
        let ellipsoid = EnergyEllipsoid::through(inertia, &omega_a)?;
        ellipsoid.check_on("Omega_b", &omega_b, ENERGY_REL_TOL)?;
        let omega_b = ellipsoid.project(&omega_b)?;
        // Distance from the origin to the segment, computed in units of the larger end
        // point (no overflow; no 0/0 when the end points coincide).
        let scale = omega_a.amax().max(omega_b.amax());
        let (a_s, b_s) = (omega_a / scale, omega_b / scale);
        let d = b_s - a_s;
        let along = if d.norm_squared() > 0.0 {
            (-a_s.dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let closest = (a_s + d * along).norm();
        if closest <= 1e-8 * a_s.norm() {
            return Err(SuslovError::SegmentThroughOrigin {
                closest: closest * scale,
                size: omega_a.norm(),
            });
        }
        Ok(Self {
            omega_a,
            omega_b,
            a,
            b,
            ellipsoid,
        })
    }

    /// The time interval `[a, b]`.
    pub fn interval(&self) -> (f64, f64) {
        (self.a, self.b)
    }
}

impl PathEval for ProjectedSegment {
    fn eval<D: Scalar>(&self, t: D) -> [D; 3] {
        let u = (t - self.a) * (self.b - self.a).recip();
        let a = lift::<D>(&self.omega_a);
        let d = self.omega_b - self.omega_a;
        self.ellipsoid
            .project_generic([a[0] + u * d[0], a[1] + u * d[1], a[2] + u * d[2]])
    }
}

/// A path through samples `(t_k, Ω_k)`: per component the natural cubic spline (C², second
/// derivative 0 at both ends), extended linearly outside `[t_0, t_n]` (which keeps it C²).
/// Written generically, so [`DesiredPath::jet`] gives its exact derivatives (the third is
/// piecewise constant, discontinuous at the knots). Wrap it in [`Projected`] to put it on an
/// energy ellipsoid.
///
/// This is [`crate::lie::path::Sampled`] with `n = 3` (same numbers, bit for bit).
#[derive(Debug, Clone, PartialEq)]
pub struct SampledPath {
    spline: Sampled,
}

impl SampledPath {
    /// The spline through `values[k]` at `times[k]`; needs at least 2 samples, finite values
    /// and strictly increasing times (errors: [`SuslovError::InvalidInput`] with the message
    /// of the [`PathError`](crate::lie::path::PathError)).
    pub fn new(times: &[f64], values: &[[f64; 3]]) -> Result<Self, SuslovError> {
        Sampled::from_rows(times, values)
            .map(|spline| Self { spline })
            .map_err(|e| SuslovError::InvalidInput {
                what: e.to_string(),
            })
    }

    /// The sample times `t_0 < … < t_n`.
    pub fn times(&self) -> &[f64] {
        self.spline.times()
    }
}

impl PathEval for SampledPath {
    fn eval<D: Scalar>(&self, t: D) -> [D; 3] {
        let mut out = [D::from(0.0); 3];
        self.spline.eval_with(t, |c, x| out[c] = x);
        out
    }
}

/// 8th-order central finite-difference derivatives of `path.value` (test oracle only):
/// returns `(Ω̇, Ω̈, d³Ω/dt³)` with step `h`.
pub fn finite_difference_derivatives(
    path: &dyn DesiredPath,
    t: f64,
    h: f64,
) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    // Stencil values f(t + k h), k = -4..=4.
    let f: Vec<Vector3<f64>> = (-4..=4).map(|k| path.value(t + k as f64 * h)).collect();
    let at = |k: i32| f[(k + 4) as usize];
    // Standard 8th-order (1st, 2nd) and 6th-order (3rd) central coefficients.
    let d1 = ((at(-4) - at(4)) * (1.0 / 280.0)
        + (at(3) - at(-3)) * (4.0 / 105.0)
        + (at(-2) - at(2)) * (1.0 / 5.0)
        + (at(1) - at(-1)) * (4.0 / 5.0))
        / h;
    let d2 = ((at(-4) + at(4)) * (-1.0 / 560.0)
        + (at(3) + at(-3)) * (8.0 / 315.0)
        + (at(-2) + at(2)) * (-1.0 / 5.0)
        + (at(1) + at(-1)) * (8.0 / 5.0)
        + at(0) * (-205.0 / 72.0))
        / (h * h);
    let d3 = ((at(-4) - at(4)) * (-7.0 / 240.0)
        + (at(3) - at(-3)) * (-3.0 / 10.0)
        + (at(-2) - at(2)) * (-169.0 / 120.0)
        + (at(-1) - at(1)) * (61.0 / 30.0))
        / (h * h * h);
    (d1, d2, d3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// Relative agreement of exact and finite-difference derivatives (scale = max(|fd|, 1)).
    fn check_fd(path: &dyn DesiredPath, t: f64, h: f64, tol: [f64; 3]) {
        let jet = path.jet(t);
        let (d1, d2, d3) = finite_difference_derivatives(path, t, h);
        for (k, (exact, fd)) in [(jet.d1, d1), (jet.d2, d2), (jet.d3, d3)]
            .into_iter()
            .enumerate()
        {
            let err = (exact - fd).norm() / fd.norm().max(1.0);
            assert!(
                err < tol[k],
                "t = {t}: derivative {} exact {exact:?} vs fd {fd:?}: rel err {err:e}",
                k + 1
            );
        }
        assert_eq!(jet.value, path.value(t));
    }

    #[test]
    fn paper_omega_a_and_omega_b() {
        let p = PaperSpiral::paper();
        assert_eq!(p.value(0.0), Vector3::new(5.0, 0.0, 0.0));
        assert_eq!(p.omega_a(), Vector3::new(5.0, 0.0, 0.0));
        let b = p.omega_b();
        let rounded = b.map(|x| (x * 1e4).round() / 1e4);
        assert_eq!(rounded, Vector3::new(2.7541, -2.3109, -1.4983));
        assert_relative_eq!(p.ellipsoid().relative_mismatch(&b), 0.0, epsilon = 1e-15);
        // Om_d(b_d) = (phi_par(b_d) + Om_b)/2 = Om_b.
        assert_relative_eq!(p.value(10.0), b, epsilon = 1e-15);
        // Far past b_d, Om_d = Om_b.
        assert_eq!(p.value(20.0), b);
    }

    #[test]
    fn sigmoid_is_exactly_zero_and_one_far_from_b_d() {
        let p = PaperSpiral::paper();
        assert_eq!(p.switch(0.0), 0.0);
        assert_eq!(0.5 * (1.0 + (-1000.0f64).tanh()), 0.0);
        assert_eq!(p.switch(9.8), 0.0);
        assert_eq!(p.switch(20.0), 1.0);
        assert_eq!(p.switch(10.0), 0.5);
    }

    #[test]
    fn stable_tanh_has_no_nan_at_large_arguments() {
        for x in [-1000.0f64, -710.0, -50.0, 50.0, 710.0, 1000.0, 1e300] {
            let d = stable_tanh(Dual3::from_re(x).derivative());
            assert_eq!(d.re, x.signum());
            for v in [d.v1, d.v2, d.v3] {
                assert!(v.is_finite() && v.abs() < 1e-20, "x = {x}: {d:?}");
            }
            // The library's own tanh is NaN there (documented reason for stable_tanh).
            if x.abs() >= 1000.0 {
                assert!(Dual3::from_re(x).derivative().tanh().re.is_nan());
            }
        }
        // Exact agreement with the derivative identities at moderate arguments.
        for x in [-2.0, -0.3, 0.0, 0.7, 3.0] {
            let d = stable_tanh(Dual3::from_re(x).derivative());
            let t = x.tanh();
            let s2 = 1.0 - t * t;
            assert_relative_eq!(d.re, t, epsilon = 1e-15);
            assert_relative_eq!(d.v1, s2, epsilon = 1e-14);
            assert_relative_eq!(d.v2, -2.0 * t * s2, epsilon = 1e-14);
            assert_relative_eq!(d.v3, -2.0 * s2 * (1.0 - 3.0 * t * t), epsilon = 1e-14);
        }
        // The paper's sigmoid at t = a = 0 (argument -1000) through the full path.
        let jet = PaperSpiral::paper().jet(0.0);
        for v in [jet.value, jet.d1, jet.d2, jet.d3] {
            assert!(v.iter().all(|x| x.is_finite()), "{jet:?}");
        }
        assert_eq!(jet.value, Vector3::new(5.0, 0.0, 0.0));
    }

    #[test]
    fn exact_derivatives_match_finite_differences() {
        let p = PaperSpiral::paper();
        let e = *p.ellipsoid();
        // Measured worst cases: 1e-13, 4e-11, 2.4e-9 on the smooth part; 5e-12, 3.7e-9,
        // 1.6e-6 inside the sigmoid layer, where the 3rd-derivative stencil (h = 2e-4) is
        // limited by round-off eps/h^3.
        let tol = [1e-10, 1e-8, 1e-7];
        for t in [0.0, 0.3, 1.0, 2.5, 5.0, 7.7, 9.5] {
            check_fd(&p, t, 1e-2, tol);
            check_fd(p.phi_par(), t, 1e-2, tol);
            check_fd(&Spiral { c: 10.0 }, t, 1e-2, tol);
            check_fd(&Projected::new(p.clone(), e), t, 1e-2, tol);
        }
        // Near b_d the sigmoid has width 0.01: use a step well below it.
        for t in [9.99, 10.0, 10.004, 10.02] {
            check_fd(&p, t, 2e-4, [1e-10, 1e-7, 1e-5]);
            check_fd(&Projected::new(p.clone(), e), t, 2e-4, [1e-10, 1e-7, 1e-5]);
        }
        let seg = ProjectedSegment::new(*e.inertia(), p.omega_a(), p.omega_b(), 0.0, 10.0).unwrap();
        for t in [0.0, 3.0, 10.0] {
            check_fd(&seg, t, 1e-2, tol);
        }
        let c = Constant(Vector3::new(1.0, 2.0, 3.0));
        let jet = c.jet(4.0);
        assert_eq!(jet.value, Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(jet.d1 + jet.d2 + jet.d3, Vector3::zeros());
    }

    #[test]
    fn invalid_parameters_are_errors() {
        let i = Inertia::paper();
        let om_a = Vector3::new(5.0, 0.0, 0.0);
        assert!(PaperSpiral::new(10.0, 0.0, 10.0, i, om_a).is_err());
        assert!(PaperSpiral::new(10.0, 0.01, f64::NAN, i, om_a).is_err());
        assert!(PaperSpiral::new(10.0, 0.01, 10.0, i, Vector3::zeros()).is_err());
        // c = 0 puts phi(0) = 0: Omega_b is still defined (b_d != 0), phi_par(0) is not.
        let p = PaperSpiral::new(0.0, 0.01, 10.0, i, om_a).unwrap();
        assert!(!p.phi_par().value(0.0)[0].is_finite());
        assert!(ProjectedSegment::new(i, om_a, om_a, 1.0, 1.0).is_err());
    }

    #[test]
    fn spiral_jet_is_analytic() {
        let t: f64 = 1.3;
        let jet = Spiral { c: 10.0 }.jet(t);
        let (s, c) = t.sin_cos();
        assert_relative_eq!(
            jet.d1,
            Vector3::new(0.0, c - t * s, s + t * c),
            epsilon = 1e-15
        );
        assert_relative_eq!(
            jet.d2,
            Vector3::new(0.0, -2.0 * s - t * c, 2.0 * c - t * s),
            epsilon = 1e-14
        );
        assert_relative_eq!(
            jet.d3,
            Vector3::new(0.0, -3.0 * c + t * s, -3.0 * s - t * c),
            epsilon = 1e-14
        );
    }

    #[test]
    fn projected_segment_joins_end_points_on_e() {
        let p = PaperSpiral::paper();
        let seg =
            ProjectedSegment::new(Inertia::paper(), p.omega_a(), p.omega_b(), 1.0, 3.0).unwrap();
        assert_relative_eq!(seg.value(1.0), p.omega_a(), epsilon = 1e-15);
        assert_relative_eq!(seg.value(3.0), p.omega_b(), epsilon = 1e-14);
        for t in [1.5, 2.0, 2.9] {
            let jet = seg.jet(t);
            assert_relative_eq!(
                p.ellipsoid().relative_mismatch(&jet.value),
                0.0,
                epsilon = 1e-15
            );
            // Tangent to E.
            let i = Inertia::paper();
            assert!(i.apply(&jet.value).dot(&jet.d1).abs() < 1e-13);
        }
        // Antipodal end points: the segment crosses 0.
        assert!(
            ProjectedSegment::new(Inertia::paper(), p.omega_a(), -p.omega_a(), 0.0, 1.0).is_err()
        );
        // Within ENERGY_REL_TOL of E: accepted, and the path ends on E.
        let off = Vector3::new(1.0, 2.0, 0.0) * (1.0 + 5e-10f64).sqrt();
        let om_a = Vector3::new(3.0, 0.0, 0.0);
        let seg = ProjectedSegment::new(Inertia::paper(), om_a, off, 0.0, 1.0).unwrap();
        let e = EnergyEllipsoid::through(Inertia::paper(), &om_a).unwrap();
        assert!(e.relative_mismatch(&seg.value(1.0)).abs() < 1e-15);
        assert!((seg.value(1.0) - off).norm() < 1e-9);
        // Omega_b = Omega_a: the constant path.
        let seg = ProjectedSegment::new(Inertia::paper(), om_a, om_a, 0.0, 1.0).unwrap();
        assert_eq!(seg.jet(0.5).value, om_a);
        assert_eq!(seg.jet(0.5).d1, Vector3::zeros());
        // Nearly opposite: the distance in the error is finite.
        let err = ProjectedSegment::new(Inertia::paper(), om_a, -om_a, 0.0, 1.0).unwrap_err();
        assert!(
            matches!(err, SuslovError::SegmentThroughOrigin { closest, .. } if closest == 0.0),
            "{err}"
        );
        // Omega_b off E.
        assert!(ProjectedSegment::new(
            Inertia::paper(),
            p.omega_a(),
            Vector3::new(2.7541, -2.3109, -1.4983),
            0.0,
            1.0
        )
        .is_err());
    }
}

/// The radial projection onto `E` of any [`DesiredPath`] (including trait objects), with exact
/// derivatives: the inner path's jet is lifted to a third-order dual number and pushed through
/// the projection, so `Ω̇, Ω̈, d³Ω/dt³` of the projection are exact to rounding.
#[derive(Clone)]
pub struct ProjectedPath {
    /// The projected path.
    pub inner: std::sync::Arc<dyn DesiredPath + Send + Sync>,
    /// The target ellipsoid.
    pub ellipsoid: EnergyEllipsoid,
}

impl DesiredPath for ProjectedPath {
    fn jet(&self, t: f64) -> Jet {
        let j = self.inner.jet(t);
        let lift = |i: usize| Dual3::new(j.value[i], j.d1[i], j.d2[i], j.d3[i]);
        let r = self.ellipsoid.project_generic([lift(0), lift(1), lift(2)]);
        let pick = |f: fn(&Dual3<f64>) -> f64| Vector3::new(f(&r[0]), f(&r[1]), f(&r[2]));
        Jet {
            value: pick(|d| d.re),
            d1: pick(|d| d.v1),
            d2: pick(|d| d.v2),
            d3: pick(|d| d.v3),
        }
    }
}

#[cfg(test)]
mod sampled_path_tests {
    use super::*;

    #[test]
    fn the_spline_interpolates_is_c2_and_reproduces_lines() {
        let times = [0.0, 0.5, 1.3, 2.0, 3.1];
        let values: Vec<[f64; 3]> = times
            .iter()
            .map(|&t: &f64| [t.sin(), 2.0 - t, t * t])
            .collect();
        let p = SampledPath::new(&times, &values).unwrap();
        for (t, v) in times.iter().zip(&values) {
            let got = p.value(*t);
            for c in 0..3 {
                assert!((got[c] - v[c]).abs() < 1e-14, "t = {t}: {got} vs {v:?}");
            }
        }
        // A line is reproduced exactly (natural end conditions hold for it).
        let j = p.jet(0.9);
        assert!((j.value[1] - 1.1).abs() < 1e-14 && (j.d1[1] + 1.0).abs() < 1e-14);
        assert!(j.d2[1].abs() < 1e-13 && j.d3[1].abs() < 1e-12);
        // C2 at interior knots and at both ends (linear extension).
        for &t in &[0.0, 0.5, 1.3, 2.0, 3.1] {
            let (l, r) = (p.jet(t - 1e-9), p.jet(t + 1e-9));
            assert!((l.value - r.value).norm() < 1e-7, "value at {t}");
            assert!((l.d1 - r.d1).norm() < 1e-7, "d1 at {t}");
            assert!(
                (l.d2 - r.d2).norm() < 1e-6,
                "d2 at {t}: {} vs {}",
                l.d2,
                r.d2
            );
        }
        // Linear outside, second derivative 0.
        assert_eq!(p.jet(-1.0).d2, Vector3::zeros());
        assert_eq!(p.jet(5.0).d2, Vector3::zeros());
        // Exact derivatives against finite differences inside an interval.
        let (d1, d2, _) = finite_difference_derivatives(&p, 0.9, 1e-3);
        let j = p.jet(0.9);
        assert!((j.d1 - d1).norm() < 1e-9 && (j.d2 - d2).norm() < 1e-6);
    }

    #[test]
    fn bad_samples_are_errors() {
        assert!(SampledPath::new(&[0.0], &[[1.0; 3]]).is_err());
        assert!(SampledPath::new(&[0.0, 0.0], &[[1.0; 3]; 2]).is_err());
        assert!(SampledPath::new(&[0.0, 1.0], &[[1.0; 3], [f64::NAN, 1.0, 1.0]]).is_err());
        assert!(SampledPath::new(&[0.0, 1.0], &[[1.0; 3]]).is_err());
        // Two samples: the straight line.
        let p = SampledPath::new(&[0.0, 2.0], &[[0.0; 3], [2.0, 4.0, 6.0]]).unwrap();
        assert_eq!(p.value(1.0), Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(p.value(3.0), Vector3::new(3.0, 6.0, 9.0));
    }
}

#[cfg(test)]
mod projected_path_tests {
    use super::*;

    #[test]
    fn projecting_a_trait_object_equals_the_generic_projection() {
        let spiral = PaperSpiral::paper();
        let e = *spiral.ellipsoid();
        let generic = Projected::new(spiral.clone(), e);
        let dynamic = ProjectedPath {
            inner: std::sync::Arc::new(spiral),
            ellipsoid: e,
        };
        for &t in &[0.0, 1.3, 7.7, 9.995, 10.0, 10.02] {
            let (a, b) = (generic.jet(t), dynamic.jet(t));
            for (x, y) in [(a.value, b.value), (a.d1, b.d1), (a.d2, b.d2), (a.d3, b.d3)] {
                assert!(
                    (x - y).norm() <= 1e-9 * (1.0 + x.norm()),
                    "t = {t}: {x} vs {y}"
                );
            }
        }
    }
}
