//! Test problems with exact solutions, shared by the `bvp_*` integration tests.
//! Each problem implements `BvpProblem` with analytic Jacobians and has an `exact(x)`.
#![allow(dead_code)]

use std::f64::consts::PI;
use suslov::bvp::{solve, BvpProblem, Guess, Options, Solution};

/// A problem with a known solution (states only; parameters in `exact_p`).
pub trait Exact: BvpProblem {
    fn exact(&self, x: f64) -> Vec<f64>;
    fn exact_p(&self) -> Vec<f64> {
        vec![]
    }
    fn interval(&self) -> (f64, f64) {
        (0.0, 1.0)
    }
}

/// Linear, non-autonomous: y'' = pi^2 (y - x^2) - 2 pi^2 sin(pi x) + 2, y(0) = 0, y(1) = 1;
/// y = sin(pi x) + x^2.
pub struct Linear;
impl BvpProblem for Linear {
    fn n(&self) -> usize {
        2
    }
    fn f(&self, x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = PI * PI * (y[0] - x * x) - 2.0 * PI * PI * (PI * x).sin() + 2.0;
    }
    fn jac(&self, _x: f64, _y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, PI * PI, 0.0]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0];
        r[1] = yb[0] - 1.0;
    }
    fn bc_jac(
        &self,
        _ya: &[f64],
        _yb: &[f64],
        _p: &[f64],
        dya: &mut [f64],
        dyb: &mut [f64],
        _dp: &mut [f64],
    ) -> bool {
        dya.copy_from_slice(&[1.0, 0.0, 0.0, 0.0]);
        dyb.copy_from_slice(&[0.0, 0.0, 1.0, 0.0]);
        true
    }
}
impl Exact for Linear {
    fn exact(&self, x: f64) -> Vec<f64> {
        vec![(PI * x).sin() + x * x, PI * (PI * x).cos() + 2.0 * x]
    }
}

/// Nonlinear: y'' = 1.5 y^2, y(0) = 4, y(1) = 1; y = 4 / (1 + x)^2.
pub struct Quadratic;
impl BvpProblem for Quadratic {
    fn n(&self) -> usize {
        2
    }
    fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = 1.5 * y[0] * y[0];
    }
    fn jac(&self, _x: f64, y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, 3.0 * y[0], 0.0]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0] - 4.0;
        r[1] = yb[0] - 1.0;
    }
}
impl Exact for Quadratic {
    fn exact(&self, x: f64) -> Vec<f64> {
        vec![4.0 / (1.0 + x).powi(2), -8.0 / (1.0 + x).powi(3)]
    }
}

/// Sturm-Liouville eigenvalue (scipy's example): y'' + p^2 y = 0, y(0) = y(1) = 0,
/// y'(0) = p; first eigenpair p = pi, y = sin(pi x).
pub struct SturmLiouville;
impl BvpProblem for SturmLiouville {
    fn n(&self) -> usize {
        2
    }
    fn k(&self) -> usize {
        1
    }
    fn f(&self, _x: f64, y: &[f64], p: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -p[0] * p[0] * y[0];
    }
    fn jac(&self, _x: f64, y: &[f64], p: &[f64], dfdy: &mut [f64], dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, -p[0] * p[0], 0.0]);
        dfdp.copy_from_slice(&[0.0, -2.0 * p[0] * y[0]]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], p: &[f64], r: &mut [f64]) {
        r[0] = ya[0];
        r[1] = yb[0];
        r[2] = ya[1] - p[0];
    }
    fn bc_jac(
        &self,
        _ya: &[f64],
        _yb: &[f64],
        _p: &[f64],
        dya: &mut [f64],
        dyb: &mut [f64],
        dp: &mut [f64],
    ) -> bool {
        dya.copy_from_slice(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        dyb.copy_from_slice(&[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
        dp.copy_from_slice(&[0.0, 0.0, -1.0]);
        true
    }
}
impl Exact for SturmLiouville {
    fn exact(&self, x: f64) -> Vec<f64> {
        vec![(PI * x).sin(), PI * (PI * x).cos()]
    }
    fn exact_p(&self) -> Vec<f64> {
        vec![PI]
    }
}

/// Boundary layer at x = 0: eps y'' + y' = 0, y(0) = 0, y(1) = 1;
/// y = (1 - exp(-x/eps)) / (1 - exp(-1/eps)).
pub struct BoundaryLayer {
    pub eps: f64,
}
impl BvpProblem for BoundaryLayer {
    fn n(&self) -> usize {
        2
    }
    fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -y[1] / self.eps;
    }
    fn jac(&self, _x: f64, _y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, 0.0, -1.0 / self.eps]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0];
        r[1] = yb[0] - 1.0;
    }
}
impl Exact for BoundaryLayer {
    fn exact(&self, x: f64) -> Vec<f64> {
        let e = self.eps;
        let d = -(-1.0 / e).exp_m1();
        vec![-(-x / e).exp_m1() / d, (-x / e).exp() / (e * d)]
    }
}

/// Bratu: y'' + lambda exp(y) = 0, y(0) = y(1) = 0. Exact: y = -2 ln(cosh((x - 1/2) theta/2) /
/// cosh(theta/4)) with theta = sqrt(2 lambda) cosh(theta/4) (two roots for lambda < 3.51).
pub struct Bratu {
    pub lambda: f64,
    pub theta: f64,
}
impl Bratu {
    /// The root of `theta = sqrt(2 lambda) cosh(theta/4)` reached by Newton from `theta0`.
    pub fn new(lambda: f64, theta0: f64) -> Self {
        let s = (2.0 * lambda).sqrt();
        let mut t = theta0;
        for _ in 0..100 {
            let g = t - s * (t / 4.0).cosh();
            let dg = 1.0 - s * (t / 4.0).sinh() / 4.0;
            t -= g / dg;
        }
        Self { lambda, theta: t }
    }
}
impl BvpProblem for Bratu {
    fn n(&self) -> usize {
        2
    }
    fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -self.lambda * y[0].exp();
    }
    fn jac(&self, _x: f64, y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, -self.lambda * y[0].exp(), 0.0]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0];
        r[1] = yb[0];
    }
}
impl Exact for Bratu {
    fn exact(&self, x: f64) -> Vec<f64> {
        let t = self.theta;
        let s = (x - 0.5) * t / 2.0;
        vec![-2.0 * (s.cosh() / (t / 4.0).cosh()).ln(), -t * s.tanh()]
    }
}

/// Interior layer, manufactured: y'' = y^3 + (Y'' - Y^3), Y = tanh((x - 1/2)/w), with
/// y(0) = Y(0), y(1) = Y(1). Exact solution Y (width w, e.g. 0.01).
pub struct InteriorLayer {
    pub w: f64,
}
impl InteriorLayer {
    fn profile(&self, x: f64) -> (f64, f64, f64) {
        let u = ((x - 0.5) / self.w).tanh();
        let du = (1.0 - u * u) / self.w;
        let d2u = -2.0 * u * du / self.w;
        (u, du, d2u)
    }
}
impl BvpProblem for InteriorLayer {
    fn n(&self) -> usize {
        2
    }
    fn f(&self, x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        let (u, _, d2u) = self.profile(x);
        dy[0] = y[1];
        dy[1] = y[0].powi(3) + d2u - u.powi(3);
    }
    fn jac(&self, _x: f64, y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, 3.0 * y[0] * y[0], 0.0]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0] - self.profile(0.0).0;
        r[1] = yb[0] - self.profile(1.0).0;
    }
}
impl Exact for InteriorLayer {
    fn exact(&self, x: f64) -> Vec<f64> {
        let (u, du, _) = self.profile(x);
        vec![u, du]
    }
}

/// Uniform mesh of `intervals` intervals on `[a, b]`.
pub fn uniform(a: f64, b: f64, intervals: usize) -> Vec<f64> {
    (0..=intervals)
        .map(|i| a + (b - a) * i as f64 / intervals as f64)
        .collect()
}

/// Max over nodes and components of |y - exact| relative to 1 + |exact| (first component
/// only if `first_only`).
pub fn node_error<P: Exact>(prob: &P, sol: &Solution) -> f64 {
    let mut e = 0.0_f64;
    for (i, &x) in sol.x.iter().enumerate() {
        let ex = prob.exact(x);
        for (a, b) in sol.y_at(i).iter().zip(&ex) {
            e = e.max((a - b).abs() / (1.0 + b.abs()));
        }
    }
    e
}

/// Same as [`node_error`] but through the dense output on a fine uniform grid.
pub fn dense_error<P: Exact>(prob: &P, sol: &Solution, samples: usize) -> f64 {
    let (a, b) = prob.interval();
    let mut e = 0.0_f64;
    for x in uniform(a, b, samples) {
        let ex = prob.exact(x);
        for (v, w) in sol.eval(x).iter().zip(&ex) {
            e = e.max((v - w).abs() / (1.0 + w.abs()));
        }
    }
    e
}

/// Solve on a fixed uniform mesh starting from a perturbation-free, exact-solution-free
/// guess `guess(x)`.
pub fn solve_fixed<P: Exact>(
    prob: &P,
    intervals: usize,
    guess: &dyn Fn(f64) -> Vec<f64>,
    p: Vec<f64>,
) -> Solution {
    let (a, b) = prob.interval();
    let x = uniform(a, b, intervals);
    let g = Guess::from_fn(&x, prob.n(), p, |t, out| out.copy_from_slice(&guess(t)));
    let opts = Options {
        adapt_mesh: false,
        max_newton_iter: 30,
        tol: 1e-10,
        ..Options::default()
    };
    solve(prob, &g, &opts).expect("valid input")
}

/// Least-squares slope of log(err) against log(h).
pub fn fitted_order(hs: &[f64], errs: &[f64]) -> f64 {
    let lx: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let ly: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
    let mx = lx.iter().sum::<f64>() / lx.len() as f64;
    let my = ly.iter().sum::<f64>() / ly.len() as f64;
    let num: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let den: f64 = lx.iter().map(|a| (a - mx) * (a - mx)).sum();
    num / den
}

/// A manufactured system shaped like the target problem: n = 12 (six pairs u_j, v_j),
/// k = 1 (a parameter T, exact value 2), an interior tanh layer of width 0.01, boundary
/// layers of widths 1e-3 (left) and 5e-3 (right), nonlinear and coupled:
///
/// ```text
/// u_j' = v_j,
/// v_j' = k_j^2 (u_j - U_j) + (u_j^3 - U_j^3) + U_j'' + (T - 2) u_j + c (u_{j+1} - U_{j+1}),
/// u_j(0) = U_j(0), u_j(1) = U_j(1) (j = 0..5),   v_0(0) = U_0'(0)   (13 conditions),
/// ```
///
/// with `k_j = 1 + j`, `c = 0.1`; exact solution `u_j = U_j`, `v_j = U_j'`, `T = 2`.
pub struct LayeredSystem;
impl LayeredSystem {
    pub const T: f64 = 2.0;
    /// (U, U', U'') of profile j at s.
    pub fn profile(j: usize, s: f64) -> (f64, f64, f64) {
        match j {
            0 => {
                let w = 0.01;
                let u = ((s - 0.5) / w).tanh();
                let du = (1.0 - u * u) / w;
                (u, du, -2.0 * u * du / w)
            }
            1 => {
                let b = 1e-3;
                let e = (-s / b).exp();
                (e + s, -e / b + 1.0, e / (b * b))
            }
            2 => (
                (3.0 * s).sin(),
                3.0 * (3.0 * s).cos(),
                -9.0 * (3.0 * s).sin(),
            ),
            3 => {
                let b = 5e-3;
                let e = ((s - 1.0) / b).exp();
                (e, e / b, e / (b * b))
            }
            4 => (s * s, 2.0 * s, 2.0),
            _ => {
                let w = 0.05;
                let u = ((s - 0.3) / w).tanh();
                let du = (1.0 - u * u) / w;
                (u, du, -2.0 * u * du / w)
            }
        }
    }
    fn kk(j: usize) -> f64 {
        let k = 1.0 + j as f64;
        k * k
    }
}
impl BvpProblem for LayeredSystem {
    fn n(&self) -> usize {
        12
    }
    fn k(&self) -> usize {
        1
    }
    fn f(&self, s: f64, y: &[f64], p: &[f64], dy: &mut [f64]) {
        for j in 0..6 {
            let (uu, _, d2u) = Self::profile(j, s);
            let u = y[2 * j];
            let couple = if j < 5 {
                0.1 * (y[2 * j + 2] - Self::profile(j + 1, s).0)
            } else {
                0.0
            };
            dy[2 * j] = y[2 * j + 1];
            dy[2 * j + 1] = Self::kk(j) * (u - uu)
                + (u * u * u - uu * uu * uu)
                + d2u
                + (p[0] - Self::T) * u
                + couple;
        }
    }
    fn jac(&self, _s: f64, y: &[f64], p: &[f64], dfdy: &mut [f64], dfdp: &mut [f64]) -> bool {
        dfdy.fill(0.0);
        for j in 0..6 {
            let u = y[2 * j];
            dfdy[(2 * j) * 12 + 2 * j + 1] = 1.0;
            dfdy[(2 * j + 1) * 12 + 2 * j] = Self::kk(j) + 3.0 * u * u + (p[0] - Self::T);
            if j < 5 {
                dfdy[(2 * j + 1) * 12 + 2 * j + 2] = 0.1;
            }
            dfdp[2 * j] = 0.0;
            dfdp[2 * j + 1] = u;
        }
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        for j in 0..6 {
            r[j] = ya[2 * j] - Self::profile(j, 0.0).0;
            r[6 + j] = yb[2 * j] - Self::profile(j, 1.0).0;
        }
        r[12] = ya[1] - Self::profile(0, 0.0).1;
    }
}
impl Exact for LayeredSystem {
    fn exact(&self, s: f64) -> Vec<f64> {
        (0..6)
            .flat_map(|j| {
                let (u, du, _) = Self::profile(j, s);
                [u, du]
            })
            .collect()
    }
    fn exact_p(&self) -> Vec<f64> {
        vec![Self::T]
    }
}

impl LayeredSystem {
    /// A crude guess: straight lines between the boundary values, T = 2.5.
    pub fn guess(x: &[f64]) -> Guess {
        Guess::from_fn(x, 12, vec![2.5], |s, out| {
            for j in 0..6 {
                let (a, b) = (Self::profile(j, 0.0).0, Self::profile(j, 1.0).0);
                out[2 * j] = a + (b - a) * s;
                out[2 * j + 1] = b - a;
            }
        })
    }
}
