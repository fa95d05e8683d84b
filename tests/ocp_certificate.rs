//! The generic direct transcription, KKT Newton and second-order certificate (`suslov::ocp`)
//! on problems with known answers:
//! - derivatives of the NLP (gradient, constraint Jacobian, Lagrangian Hessian, including the
//!   free length T and explicit time dependence) against finite differences;
//! - the inertia test and its margin against a dense null-space computation;
//! - the oscillator `ẋ = u`, `L = (u² − x²)/2`, `x(0) = 0`, `x(T) = 1`: the extremal
//!   `x = sin t / sin T` is a minimum for `T < π` and a saddle for `T > π` (conjugate point at
//!   π), with margin `μ_min → 1 − (T/π)²`: the certificate must say yes, and no;
//! - a free-time problem with optimal `T* = 1/√(2δ)`;
//! - the globalized SQP: the minimum from a rough start, no stop at a saddle, a certified
//!   minimum of a nonlinear problem.

mod ocpkit;
use ocpkit::{dense, dense_reduced};
use suslov::ocp::certify::{second_order, second_order_near};
use suslov::ocp::kkt::{self, KktMatrix, KktPoint};
use suslov::ocp::{
    certify, certify_with_costates, sqp, Boundary, Certificate, Horizon, LinearCondition,
    MultiplierStart, NewtonOptions, OcpProblem, SecondOrderOptions, SqpError, SqpOptions,
    Transcription, Verdict,
};

/// `ẋ = u`, `L = s (u² − k x²)/2 + δ`: the oscillator (`s = k = 1`, `δ = 0`), its
/// maximization in disguise (`s = −1`), and a minimum-energy transfer with a price on time
/// (`k = 0`, `δ > 0`).
struct Quadratic {
    sign: f64,
    k: f64,
    delta: f64,
}

impl Quadratic {
    fn oscillator(flip: bool) -> Self {
        Self {
            sign: if flip { -1.0 } else { 1.0 },
            k: 1.0,
            delta: 0.0,
        }
    }
}

impl OcpProblem for Quadratic {
    fn n_state(&self) -> usize {
        1
    }
    fn n_control(&self) -> usize {
        1
    }
    fn dynamics(&self, _t: f64, z: &[f64], f: &mut [f64], f_z: &mut [f64], f_t: &mut [f64]) {
        f[0] = z[1];
        f_z.copy_from_slice(&[0.0, 1.0]);
        f_t[0] = 0.0;
    }
    fn running_cost(&self, _t: f64, z: &[f64], l_z: &mut [f64]) -> (f64, f64) {
        let s = self.sign;
        l_z[0] = -s * self.k * z[0];
        l_z[1] = s * z[1];
        (
            s * 0.5 * (z[1] * z[1] - self.k * z[0] * z[0]) + self.delta,
            0.0,
        )
    }
    fn lagrangian_hessian(&self, _t: f64, _z: &[f64], w: f64, _lam: &[f64], h: &mut [f64]) {
        h.fill(0.0);
        h[0] = -self.sign * self.k * w;
        h[4] = self.sign * w;
    }
}

/// A nonlinear, explicitly time-dependent problem (n = 2, m = 1) for derivative checks:
/// `f = [x₂, u − sin x₁ + 0.3 t x₁]`, `L = u²/2 + x₁² cos(t)/2 + 0.1 x₂ u² + δ`; with
/// `path`, the path constraint `g = x₁ u + 0.2 sin(t) x₂ − 0.1 = 0` (nonlinear, time-dependent).
struct Pendulum {
    delta: f64,
    path: bool,
}

impl OcpProblem for Pendulum {
    fn n_state(&self) -> usize {
        2
    }
    fn n_control(&self) -> usize {
        1
    }
    fn dynamics(&self, t: f64, z: &[f64], f: &mut [f64], f_z: &mut [f64], f_t: &mut [f64]) {
        let (x1, x2, u) = (z[0], z[1], z[2]);
        f[0] = x2;
        f[1] = u - x1.sin() + 0.3 * t * x1;
        f_z.copy_from_slice(&[0.0, 1.0, 0.0, -x1.cos() + 0.3 * t, 0.0, 1.0]);
        f_t[0] = 0.0;
        f_t[1] = 0.3 * x1;
    }
    fn running_cost(&self, t: f64, z: &[f64], l_z: &mut [f64]) -> (f64, f64) {
        let (x1, x2, u) = (z[0], z[1], z[2]);
        l_z[0] = x1 * t.cos();
        l_z[1] = 0.1 * u * u;
        l_z[2] = u + 0.2 * x2 * u;
        (
            0.5 * u * u + 0.5 * x1 * x1 * t.cos() + 0.1 * x2 * u * u + self.delta,
            -0.5 * x1 * x1 * t.sin(),
        )
    }
    fn n_path(&self) -> usize {
        usize::from(self.path)
    }
    fn path(&self, t: f64, z: &[f64], g: &mut [f64], g_z: &mut [f64], g_t: &mut [f64]) {
        let (x1, x2, u) = (z[0], z[1], z[2]);
        g[0] = x1 * u + 0.2 * t.sin() * x2 - 0.1;
        g_z.copy_from_slice(&[u, 0.2 * t.sin(), x1]);
        g_t[0] = 0.2 * t.cos() * x2;
    }
    fn lagrangian_hessian(&self, t: f64, z: &[f64], w: f64, lam: &[f64], h: &mut [f64]) {
        let (x1, x2, u) = (z[0], z[1], z[2]);
        assert_eq!(lam.len(), 2 + self.n_path(), "λ then μ");
        h.fill(0.0);
        let mut set = |r: usize, c: usize, v: f64| {
            h[r * 4 + c] += v;
            if r != c {
                h[c * 4 + r] += v;
            }
        };
        set(0, 0, w * t.cos() + lam[1] * x1.sin());
        set(0, 3, -w * x1 * t.sin() + 0.3 * lam[1]);
        set(1, 2, 0.2 * w * u);
        set(2, 2, w * (1.0 + 0.2 * x2));
        set(3, 3, -0.5 * w * x1 * x1 * t.cos());
        if self.path {
            let mu = lam[2];
            set(0, 2, mu);
            set(1, 3, 0.2 * mu * t.cos());
            set(3, 3, -0.2 * mu * t.sin() * x2);
        }
    }
}

/// Deterministic pseudo-random numbers in [lo, hi).
struct Rng(u64);
impl Rng {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn uniform_mesh(n: usize) -> Vec<f64> {
    let mut m: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).collect();
    m[n] = 1.0;
    m
}

/// A graded mesh (so that interval lengths differ).
fn graded_mesh(n: usize) -> Vec<f64> {
    (0..=n).map(|i| (i as f64 / n as f64).powf(1.3)).collect()
}

fn central(mut f: impl FnMut(f64) -> f64, x: f64, h: f64) -> f64 {
    // Richardson-extrapolated central difference.
    let d = |h: f64, f: &mut dyn FnMut(f64) -> f64| (f(x + h) - f(x - h)) / (2.0 * h);
    let (d1, d2) = (d(h, &mut f), d(h / 2.0, &mut f));
    (4.0 * d2 - d1) / 3.0
}

fn pendulum_transcription(p: &Pendulum, free: bool) -> Transcription<'_, Pendulum> {
    let horizon = if free {
        Horizon::Free { t0: 0.3 }
    } else {
        Horizon::Fixed {
            t0: 0.3,
            length: 2.0,
        }
    };
    // With the path constraint, a linear end condition too (x₁ + 0.5 x₂ = 0.1 at the end).
    let end_linear = if p.path {
        vec![LinearCondition {
            coefficients: vec![(0, 1.0), (1, 0.5)],
            value: 0.1,
        }]
    } else {
        vec![]
    };
    let boundary = Boundary {
        start: vec![(0, 0.5), (1, 0.0)],
        end: vec![(0, 0.0)],
        start_linear: vec![],
        end_linear,
    };
    Transcription::new(p, boundary, horizon, graded_mesh(4)).expect("valid transcription")
}

#[test]
fn nlp_derivatives_match_finite_differences() {
    let mut rng = Rng(0x9e3779b97f4a7c15);
    let mut worst = [0.0_f64; 3];
    for (free, path) in [(false, false), (true, false), (false, true), (true, true)] {
        let prob = Pendulum { delta: 0.2, path };
        let tr = pendulum_transcription(&prob, free);
        assert_eq!(tr.n_path(), usize::from(path));
        let (nv, nc) = (tr.n_var(), tr.n_con());
        for _ in 0..3 {
            let mut v: Vec<f64> = (0..nv).map(|_| rng.uniform(-1.0, 1.0)).collect();
            if let Some(i) = tr.length_index() {
                v[i] = rng.uniform(1.0, 3.0);
            }
            let y: Vec<f64> = (0..nc).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let g = tr.gradient(&v);
            let a = dense(&tr.jacobian(&v), nc, nv, false);
            let h = dense(&tr.lagrangian_hessian(&v, &y), nv, nv, true);
            // The KKT pattern is built from the positions alone (no evaluation): they must be
            // those of the evaluated derivatives, entry for entry.
            let pos = |e: &[(usize, usize, f64)]| -> Vec<(usize, usize)> {
                e.iter().map(|&(r, c, _)| (r, c)).collect()
            };
            assert_eq!(pos(&tr.jacobian(&v)), pos(&tr.jacobian_positions()));
            assert_eq!(
                pos(&tr.lagrangian_hessian(&v, &y)),
                pos(&tr.lagrangian_hessian_positions())
            );
            let lagr_grad = |v: &[f64]| -> Vec<f64> {
                let mut r = tr.gradient(v);
                for (row, col, val) in tr.jacobian(v) {
                    r[col] += val * y[row];
                }
                r
            };
            for j in 0..nv {
                let at = |x: f64| {
                    let mut w = v.clone();
                    w[j] = x;
                    w
                };
                let fd = central(|x| tr.objective(&at(x)), v[j], 1e-4);
                worst[0] = worst[0].max((fd - g[j]).abs() / (1.0 + g[j].abs()));
                for r in 0..nc {
                    let fd = central(|x| tr.constraints(&at(x))[r], v[j], 1e-4);
                    worst[1] = worst[1].max((fd - a[(r, j)]).abs() / (1.0 + a[(r, j)].abs()));
                }
                for r in 0..nv {
                    let fd = central(|x| lagr_grad(&at(x))[r], v[j], 1e-4);
                    worst[2] = worst[2].max((fd - h[(r, j)]).abs() / (1.0 + h[(r, j)].abs()));
                }
            }
        }
    }
    eprintln!(
        "max relative FD mismatch: gradient {:.1e}, Jacobian {:.1e}, Hessian {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(worst.iter().all(|&w| w < 1e-7), "FD mismatch {worst:?}");
}

#[test]
fn inertia_and_margin_match_a_dense_null_space_computation() {
    let prob = Pendulum {
        delta: 0.2,
        path: false,
    };
    let mut rng = Rng(12345);
    let opts = SecondOrderOptions {
        margin_rtol: 1e-6,
        ..Default::default()
    };
    let mut seen = [0usize; 2];
    for free in [false, true] {
        let tr = pendulum_transcription(&prob, free);
        for trial in 0..6 {
            // The inertia identity holds at any point with A of full rank, KKT or not.
            let mut v: Vec<f64> = (0..tr.n_var()).map(|_| rng.uniform(-1.0, 1.0)).collect();
            if let Some(i) = tr.length_index() {
                v[i] = rng.uniform(1.0, 3.0);
            }
            let amp = if trial % 2 == 0 { 0.1 } else { 5.0 };
            let y: Vec<f64> = (0..tr.n_con()).map(|_| rng.uniform(-amp, amp)).collect();
            let pt = KktPoint { v, y };
            let matrix = KktMatrix::new(&tr).expect("pattern");
            let rep = second_order(&tr, &matrix, &pt, &opts).expect("second-order test runs");
            let (neg, mu) = dense_reduced(&tr, &pt);
            let (lo, hi) = rep.margin.expect("margin bracketed");
            eprintln!(
                "free={free} trial {trial}: inertia {} (n = {}, m = {}), dense: {neg} negative, mu_min = {mu:.6e}, bracket [{lo:.6e}, {hi:.6e}]",
                rep.inertia, rep.n_var, rep.n_con
            );
            assert_eq!(rep.negative_curvature_directions, neg);
            assert_eq!(rep.verdict == Verdict::Certified, neg == 0);
            assert!(
                lo - 1e-9 * mu.abs() <= mu && mu <= hi + 1e-9 * mu.abs(),
                "mu {mu} not in [{lo}, {hi}]"
            );
            seen[usize::from(neg == 0)] += 1;
        }
    }
    assert!(
        seen[0] > 0 && seen[1] > 0,
        "both verdicts exercised: {seen:?}"
    );
}

fn oscillator_transcription(
    prob: &Quadratic,
    t_len: f64,
    n: usize,
) -> Transcription<'_, Quadratic> {
    let boundary = Boundary {
        start: vec![(0, 0.0)],
        end: vec![(0, 1.0)],
        start_linear: vec![],
        end_linear: vec![],
    };
    let horizon = Horizon::Fixed {
        t0: 0.0,
        length: t_len,
    };
    Transcription::new(prob, boundary, horizon, uniform_mesh(n)).expect("valid")
}

/// The exact extremal `x = sin t / sin T`, `u = cos t / sin T` (a KKT point of the continuous
/// problem, as an indirect method would deliver it), sampled at the collocation points.
fn oscillator_extremal(tr: &Transcription<'_, Quadratic>, t_len: f64) -> Vec<f64> {
    let st = t_len.sin();
    tr.primal_from_fn(t_len, |t, z| {
        z[0] = t.sin() / st;
        z[1] = t.cos() / st;
    })
}

/// The costate of that extremal, `π = −u = −cos t / sin T` (`∂H/∂u = u + π = 0`), at the
/// collocation points.
fn oscillator_costate(tr: &Transcription<'_, Quadratic>, t_len: f64) -> Vec<f64> {
    (0..tr.n_points())
        .map(|p| -tr.point_time(p, t_len).cos() / t_len.sin())
        .collect()
}

/// `max_i |a_i − b_i|`.
fn gap(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

fn certify_default(tr: &Transcription<'_, Quadratic>, v0: Vec<f64>) -> Certificate {
    certify(
        tr,
        v0,
        &NewtonOptions::default(),
        &SecondOrderOptions::default(),
    )
    .expect("certificate")
}

#[test]
fn oscillator_minimum_and_saddle_are_told_apart() {
    let prob = Quadratic::oscillator(false);
    let pi = std::f64::consts::PI;
    // (T, expected verdict, expected negative directions)
    for (t_len, verdict, neg) in [
        (2.0, Verdict::Certified, 0),
        (3.0, Verdict::Certified, 0),
        (4.0, Verdict::NotMinimum, 1),
        (7.0, Verdict::NotMinimum, 2),
    ] {
        // Step 0.05 in time for every T.
        let tr = oscillator_transcription(&prob, t_len, (20.0 * t_len) as usize);
        let st = t_len.sin();
        let cert = certify_default(&tr, oscillator_extremal(&tr, t_len));
        let so = &cert.second_order;
        let (lo, hi) = so.margin.expect("margin");
        let exact = 1.0 - (t_len / pi).powi(2);
        eprintln!(
            "T = {t_len}: candidate stationarity {:.1e} feasibility {:.1e}; Newton {} its, displacement {:.1e}; inertia {}; {}; mu_min in [{lo:.5}, {hi:.5}], continuous 1 - (T/pi)^2 = {exact:.5}",
            cert.candidate.relative_stationarity(),
            cert.candidate.feasibility,
            cert.newton_iterations,
            cert.displacement,
            so.inertia,
            so.verdict.sentence()
        );
        assert_eq!(so.verdict, verdict);
        assert_eq!(so.negative_curvature_directions, neg);
        // Jacobi's condition, discretely: the first conjugate point is at π when T > π.
        let conj = cert.conjugate.first;
        eprintln!(
            "  first conjugate point {conj:?} ({} factorizations)",
            cert.conjugate.factorizations
        );
        match conj {
            None => assert!(t_len < pi),
            Some(c) => {
                assert!(t_len > pi);
                assert!(c.previous < pi + 0.01 && pi - 0.01 < c.time, "{c:?}");
            }
        }
        assert!(cert.kkt.relative_stationarity() < 1e-10 && cert.kkt.feasibility < 1e-10);
        // The exact extremal is a KKT point of the discretization up to discretization error.
        assert!(
            cert.displacement < 1e-5 / st.abs(),
            "displacement {}",
            cert.displacement
        );
        assert!((0.5 * (lo + hi) - exact).abs() < 2e-3 * (1.0 + exact.abs()));
        // The eigenvector from inverse iteration: its Rayleigh quotient lies in the bracket.
        let q = so.weakest_rayleigh.expect("weakest direction");
        assert!(
            lo - 1e-6 * lo.abs() <= q && q <= hi + 1e-6 * hi.abs(),
            "{q} not in [{lo}, {hi}]"
        );
        // The discrete multipliers are the costate π = −u (H = L + π u, H_u = u + π = 0).
        let omega = tr.quadrature_weights();
        let lam = tr.point_multipliers(&cert.point.y);
        let mut worst = 0.0_f64;
        for p in 0..tr.n_points() {
            let t = tr.point_time(p, t_len);
            worst = worst.max((lam[p] / omega[p] + t.cos() / st).abs());
        }
        eprintln!("  max |lambda_p/omega_p - pi(t_p)| = {worst:.1e}");
        assert!(worst < 1e-5 / st.abs(), "costate mismatch {worst}");
    }
}

/// The test seeded by Newton's last factorization (`second_order_near`, what `certify` runs)
/// against the plain test at the same point: the same verdict, inertia and negative
/// directions; margins that overlap and contain the dense `μ_min`; for a minimum, the
/// factorization at `σ = 0` saved; for a saddle, the seed rejected by its count and the plain
/// test run after it.
#[test]
fn the_test_seeded_by_newton_agrees_with_the_plain_test() {
    let prob = Quadratic::oscillator(false);
    let opts = SecondOrderOptions::default();
    for (t_len, verdict) in [(2.0, Verdict::Certified), (4.0, Verdict::NotMinimum)] {
        let tr = oscillator_transcription(&prob, t_len, (20.0 * t_len) as usize);
        let v0 = oscillator_extremal(&tr, t_len);
        let matrix = KktMatrix::new(&tr).expect("pattern");
        let y0 = kkt::least_squares_multipliers(&tr, &matrix, &v0).expect("multipliers");
        let start = KktPoint { v: v0, y: y0 };
        let (point, _, near) =
            kkt::newton_keeping_factor(&tr, &matrix, start, &NewtonOptions::default())
                .expect("Newton");
        let near = near.expect("the extremal is not the discrete KKT point: a Newton step");
        let plain = second_order(&tr, &matrix, &point, &opts).expect("plain");
        let seeded = second_order_near(&tr, &matrix, &point, &opts, Some(near)).expect("seeded");
        let (_, mu) = dense_reduced(&tr, &point);
        eprintln!(
            "T = {t_len}: plain {} {:?} ({} factorizations), seeded {} {:?} ({}), dense mu_min {mu:.6e}",
            plain.inertia, plain.margin, plain.factorizations, seeded.inertia, seeded.margin,
            seeded.factorizations
        );
        assert_eq!(plain.verdict, verdict);
        assert_eq!(seeded.verdict, verdict);
        assert_eq!(seeded.inertia, plain.inertia);
        assert_eq!(
            seeded.negative_curvature_directions,
            plain.negative_curvature_directions
        );
        let (a, b) = plain.margin.expect("plain margin");
        let (c, d) = seeded.margin.expect("seeded margin");
        let slack = 1e-9 * mu.abs();
        assert!(a - slack <= mu && mu <= b + slack && c - slack <= mu && mu <= d + slack);
        if verdict == Verdict::Certified {
            assert!(seeded.factorizations < plain.factorizations);
        } else {
            assert!(seeded.factorizations > plain.factorizations);
        }
    }
}

#[test]
fn a_maximizer_is_not_certified() {
    // L = −(u² − x²)/2 for T = 2: the extremal maximizes; every direction curves down.
    let prob = Quadratic::oscillator(true);
    let tr = oscillator_transcription(&prob, 2.0, 20);
    let cert = certify_default(&tr, oscillator_extremal(&tr, 2.0));
    let so = &cert.second_order;
    eprintln!(
        "maximizer: inertia {}, {} negative directions, margin {:?}",
        so.inertia, so.negative_curvature_directions, so.margin
    );
    assert_eq!(so.verdict, Verdict::NotMinimum);
    // All of null(A) (dimension n − m = #controls − 1 here) curves down.
    assert_eq!(so.negative_curvature_directions, tr.n_var() - tr.n_con());
    // ... already on the first interval.
    assert_eq!(cert.conjugate.first.expect("conjugate point").node, 1);
}

#[test]
fn free_time_optimum_is_found_and_certified() {
    // ẋ = u, L = u²/2 + δ, x(0) = 0, x(T) = 1: u = 1/T, J = 1/(2T) + δT, T* = 1/√(2δ).
    let delta = 0.125;
    let prob = Quadratic {
        sign: 1.0,
        k: 0.0,
        delta,
    };
    let boundary = Boundary {
        start: vec![(0, 0.0)],
        end: vec![(0, 1.0)],
        start_linear: vec![],
        end_linear: vec![],
    };
    let tr = Transcription::new(&prob, boundary, Horizon::Free { t0: 1.0 }, uniform_mesh(5))
        .expect("valid");
    let guess = 1.6; // T* = 2
    let v0 = tr.primal_from_fn(guess, |t, z| {
        z[0] = (t - 1.0) / guess;
        z[1] = 1.0 / guess;
    });
    let cert = certify_default(&tr, v0);
    let t_star = tr.length(&cert.point.v);
    eprintln!(
        "free time: T = {t_star:.12} (exact {:.12}), Newton {} its, {}, margin {:?}",
        1.0 / (2.0 * delta).sqrt(),
        cert.newton_iterations,
        cert.second_order.verdict.sentence(),
        cert.second_order.margin
    );
    assert!((t_star - 1.0 / (2.0 * delta).sqrt()).abs() < 1e-10);
    assert_eq!(cert.second_order.verdict, Verdict::Certified);
    assert!((tr.objective(&cert.point.v) - 2.0 * (2.0 * delta).sqrt() / 2.0).abs() < 1e-10);
}

#[test]
fn least_squares_multipliers_vanish_residual_at_kkt_point() {
    let prob = Quadratic::oscillator(false);
    let tr = oscillator_transcription(&prob, 2.0, 10);
    let v0 = oscillator_extremal(&tr, 2.0);
    let matrix = KktMatrix::new(&tr).expect("pattern");
    let (pt, _) = kkt::newton(
        &tr,
        &matrix,
        KktPoint {
            y: kkt::least_squares_multipliers(&tr, &matrix, &v0).expect("multipliers"),
            v: v0,
        },
        &NewtonOptions::default(),
    )
    .expect("newton");
    let y = kkt::least_squares_multipliers(&tr, &matrix, &pt.v).expect("multipliers");
    let r = kkt::residual(
        &tr,
        &KktPoint {
            v: pt.v.clone(),
            y: y.clone(),
        },
    );
    assert!(r.relative_stationarity() < 1e-12, "{r:?}");
    let diff = y
        .iter()
        .zip(&pt.y)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff < 1e-10, "multipliers differ by {diff}");
}

/// The globalized SQP ([`suslov::ocp::sqp`]) from a start far from the answer (everything 0,
/// the end condition violated) finds the oscillator's minimum for `T = 2 < π`: the KKT point
/// Newton's method reaches from the exact extremal, certified a minimum.
#[test]
fn sqp_finds_the_oscillator_minimum_from_a_rough_start() {
    let prob = Quadratic::oscillator(false);
    let t_len = 2.0;
    let tr = oscillator_transcription(&prob, t_len, 40);
    let (point, report) = sqp(&tr, vec![0.0; tr.n_var()], &SqpOptions::default()).expect("sqp");
    let reference = certify_default(&tr, oscillator_extremal(&tr, t_len));
    let gap = point
        .v
        .iter()
        .zip(&reference.point.v)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    eprintln!(
        "oscillator T = 2: {} SQP iterations, |v_sqp - v_newton| = {gap:.1e}, J = {}",
        report.iterations, report.objective
    );
    assert!(gap < 1e-8, "{gap}");
    assert!(report.residual.feasibility <= SqpOptions::default().tolerance);
    assert_eq!(report.history.len(), report.iterations);
    // Exact extremal's cost x(T) x'(T) / 2 = cot(T) / 2 (discretization error O(h^4)).
    let exact = 0.5 / t_len.tan();
    assert!(
        (report.objective - exact).abs() < 1e-6,
        "{} vs {exact}",
        report.objective
    );
    assert_eq!(
        certify_default(&tr, point.v).second_order.verdict,
        Verdict::Certified
    );
}

/// For `T = 4 > π` the oscillator's extremal is a saddle and the cost is unbounded below.
/// Newton's method on the KKT conditions converges to the saddle; the SQP, whose inertia
/// correction makes every step a descent step, must not report it (nor anything) as a
/// minimum: it stops without a KKT point.
#[test]
fn sqp_does_not_stop_at_a_saddle() {
    let prob = Quadratic::oscillator(false);
    let t_len = 4.0;
    let tr = oscillator_transcription(&prob, t_len, 40);
    let saddle = certify_default(&tr, oscillator_extremal(&tr, t_len));
    assert_eq!(saddle.second_order.verdict, Verdict::NotMinimum);
    let saddle_cost = tr.objective(&saddle.point.v);
    let start = tr.primal_from_fn(t_len, |t, z| {
        z[0] = t / t_len;
        z[1] = 1.0 / t_len;
    });
    let options = SqpOptions {
        max_iterations: 60,
        ..SqpOptions::default()
    };
    match sqp(&tr, start, &options) {
        Ok((point, report)) => panic!(
            "the SQP reported a KKT point of an unbounded problem: J = {}, {} iterations, \
             |v| = {}",
            report.objective,
            report.iterations,
            point.v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
        ),
        Err(e) => {
            eprintln!("saddle T = 4 (J = {saddle_cost}): {e}");
            assert!(
                matches!(
                    e,
                    SqpError::NotConverged { .. }
                        | SqpError::LineSearch { .. }
                        | SqpError::NonFiniteStart
                ),
                "{e}"
            );
        }
    }
}

/// A nonlinear, time-dependent problem from zeros: the SQP's point is a KKT point that the
/// certificate certifies as a minimum (Newton's method moves it by no more than the
/// tolerance allows).
#[test]
fn sqp_minimum_of_a_nonlinear_problem_is_certified() {
    let p = Pendulum {
        delta: 0.0,
        path: false,
    };
    let boundary = Boundary {
        start: vec![(0, 0.0), (1, 0.0)],
        end: vec![(0, 1.0), (1, 0.0)],
        start_linear: vec![],
        end_linear: vec![],
    };
    let horizon = Horizon::Fixed {
        t0: 0.0,
        length: 2.0,
    };
    let tr = Transcription::new(&p, boundary, horizon, uniform_mesh(30)).expect("valid");
    let (point, report) = sqp(&tr, vec![0.0; tr.n_var()], &SqpOptions::default()).expect("sqp");
    let residual = kkt::residual(&tr, &point);
    assert!(residual.relative_stationarity() <= 1e-8, "{residual:?}");
    assert!(residual.feasibility <= 1e-8, "{residual:?}");
    let cert = certify(
        &tr,
        point.v.clone(),
        &NewtonOptions::default(),
        &SecondOrderOptions::default(),
    )
    .expect("certificate");
    eprintln!(
        "pendulum: {} SQP iterations ({} regularized), J = {}, Newton moved it {:.1e}",
        report.iterations, report.regularized, report.objective, cert.displacement
    );
    assert_eq!(cert.second_order.verdict, Verdict::Certified);
    assert!(cert.displacement < 1e-6, "{}", cert.displacement);

    // Started from costates: those of the KKT point itself (λ_p / ω_p) reach it too; from
    // costates far off (10⁸, alternating) Newton needs two iterations, so with a limit of
    // one it fails from them, and the certificate falls back to the least-squares start: its
    // candidate residual is then the plain one, to the bit.
    let w = tr.quadrature_weights();
    let nx = tr.n_state();
    let own: Vec<f64> = tr
        .point_multipliers(&point.y)
        .iter()
        .enumerate()
        .map(|(i, l)| l / w[i / nx])
        .collect();
    let wild: Vec<f64> = (0..own.len())
        .map(|i| if i % 2 == 0 { 1e8 } else { -1e8 })
        .collect();
    let (newton, second) = (NewtonOptions::default(), SecondOrderOptions::default());
    let from_own = certify_with_costates(&tr, point.v.clone(), Some(&own), &newton, &second)
        .expect("certificate");
    let one = NewtonOptions {
        max_iterations: 1,
        ..newton
    };
    let from_wild = certify_with_costates(&tr, point.v.clone(), Some(&wild), &one, &second)
        .expect("certificate");
    let unlimited = certify_with_costates(&tr, point.v.clone(), Some(&wild), &newton, &second)
        .expect("certificate");
    assert!(unlimited.newton_iterations > 1);
    assert!(unlimited.candidate.relative_stationarity() > 1e6);
    for other in [&from_own, &from_wild] {
        eprintln!(
            "from costates: Newton {} its, gap v {:.1e}, y {:.1e}, candidate {:?}",
            other.newton_iterations,
            gap(&other.point.v, &cert.point.v),
            gap(&other.point.y, &cert.point.y),
            other.candidate
        );
        assert_eq!(other.second_order.verdict, Verdict::Certified);
        assert!(gap(&other.point.v, &cert.point.v) < 1e-8);
        assert!(gap(&other.point.y, &cert.point.y) < 1e-8);
    }
    assert!(from_own.candidate.relative_stationarity() < 1e-5);
    assert_eq!(from_own.multipliers_from, MultiplierStart::Costates);
    assert_eq!(from_wild.candidate, cert.candidate);
    assert_eq!(from_wild.multipliers_from, MultiplierStart::LeastSquares);
    assert_eq!(cert.multipliers_from, MultiplierStart::LeastSquares);
}

/// One evaluation at the start shared by the multipliers and Newton (what `certify` does)
/// gives what the separate evaluations give, to the bit: the multipliers, every residual
/// (the first being `kkt::residual` at the start), the converged point.
#[test]
fn a_shared_first_evaluation_changes_no_bit() {
    let prob = Quadratic::oscillator(false);
    let tr = oscillator_transcription(&prob, 2.0, 10);
    let v0 = oscillator_extremal(&tr, 2.0);
    let matrix = KktMatrix::new(&tr).expect("pattern");
    let first = kkt::PrimalEvaluation::at(&tr, &v0);
    let y_shared = kkt::least_squares_multipliers_at(&matrix, &first).expect("multipliers");
    let y = kkt::least_squares_multipliers(&tr, &matrix, &v0).expect("multipliers");
    assert_eq!(y_shared, y);
    let start = KktPoint { v: v0, y };
    let opts = NewtonOptions::default();
    let (pt_shared, report_shared, _) =
        kkt::newton_from(&tr, &matrix, start.clone(), first, &opts).expect("Newton");
    let (pt, report, _) =
        kkt::newton_keeping_factor(&tr, &matrix, start.clone(), &opts).expect("Newton");
    assert_eq!(report_shared.residuals[0], kkt::residual(&tr, &start));
    assert_eq!(report_shared.residuals, report.residuals);
    assert!(report.residuals.len() >= 2, "a Newton step was taken");
    assert_eq!(pt_shared, pt);
}

/// The multipliers read from costates (`kkt::multipliers_from_costates`, Newton's start in
/// `certify_with_costates`) on the oscillator at `T = 2`, whose exact costate is `π = −u`
/// (`∂H/∂u = u + π = 0`): they approach the discrete (least-squares, here exact) multipliers
/// as the mesh is refined; a constant costate is reproduced exactly (the last stage of
/// Lobatto IIIA is its quadrature, `a_3j = b_j`); the certificate started from them reaches
/// the point the least-squares start reaches, with the same verdict; and where they are not
/// defined (path constraints, a costate array of the wrong length) there are none.
#[test]
fn multipliers_from_costates_approach_the_discrete_ones() {
    let prob = Quadratic::oscillator(false);
    let t_len: f64 = 2.0;
    let mut errors = Vec::new();
    for n in [10, 20, 40, 80] {
        let tr = oscillator_transcription(&prob, t_len, n);
        let v0 = oscillator_extremal(&tr, t_len);
        let pi = oscillator_costate(&tr, t_len);
        let first = kkt::PrimalEvaluation::at(&tr, &v0);
        let from_pi = kkt::multipliers_from_costates(&tr, &first, &pi).expect("multipliers");
        let matrix = KktMatrix::new(&tr).expect("pattern");
        let lsq = kkt::least_squares_multipliers_at(&matrix, &first).expect("multipliers");
        let scale = lsq.iter().fold(0.0_f64, |m, y| m.max(y.abs()));
        let err = gap(&from_pi, &lsq) / scale;
        errors.push(err);
        // A constant costate: λ_p = ω_p π exactly (to rounding).
        let ones = vec![1.0; tr.n_points()];
        let lam = tr.point_multipliers(&tr.dynamics_multipliers_from_costates(&ones));
        for (l, w) in lam.iter().zip(tr.quadrature_weights()) {
            assert!((l - w).abs() <= 1e-15, "{l} against {w}");
        }
        // The certificate from them: the point and verdict of the least-squares start.
        let opts = (NewtonOptions::default(), SecondOrderOptions::default());
        let plain = certify(&tr, v0.clone(), &opts.0, &opts.1).expect("certificate");
        let seeded =
            certify_with_costates(&tr, v0, Some(&pi), &opts.0, &opts.1).expect("certificate");
        assert!(gap(&plain.point.v, &seeded.point.v) < 1e-12);
        assert!(gap(&plain.point.y, &seeded.point.y) < 1e-12 * scale);
        assert_eq!(plain.second_order.verdict, seeded.second_order.verdict);
        assert_eq!(plain.second_order.inertia, seeded.second_order.inertia);
        assert!(seeded.newton_iterations <= plain.newton_iterations);
    }
    let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("multipliers from costates against least squares: {errors:?}, orders {orders:?}");
    assert!(errors[0] < 1e-2, "{errors:?}");
    assert!(orders.iter().all(|&q| q > 2.5), "{orders:?}");

    // Without boundary conditions there are no boundary multipliers to fit: the dynamics
    // rows alone (free ends, where the fit of the costate π = −u of this extremal is still
    // close to the least-squares multipliers).
    let tr = Transcription::new(
        &prob,
        Boundary {
            start: vec![],
            end: vec![],
            start_linear: vec![],
            end_linear: vec![],
        },
        Horizon::Fixed {
            t0: 0.0,
            length: t_len,
        },
        uniform_mesh(20),
    )
    .expect("valid");
    let v0 = oscillator_extremal(&tr, t_len);
    let pi = oscillator_costate(&tr, t_len);
    let first = kkt::PrimalEvaluation::at(&tr, &v0);
    let y = kkt::multipliers_from_costates(&tr, &first, &pi).expect("multipliers");
    assert_eq!(y.len(), tr.n_con());
    assert_eq!(y, tr.dynamics_multipliers_from_costates(&pi));
    // A boundary row that involves no unknown (a linear condition without coefficients):
    // nothing to fit either, its multiplier 0.
    let tr = tr
        .with_boundary(Boundary {
            start: vec![],
            end: vec![],
            start_linear: vec![LinearCondition {
                coefficients: vec![],
                value: 0.0,
            }],
            end_linear: vec![],
        })
        .expect("valid");
    let first = kkt::PrimalEvaluation::at(&tr, &v0);
    let y = kkt::multipliers_from_costates(&tr, &first, &pi).expect("multipliers");
    assert_eq!(y.len(), tr.n_con());
    assert_eq!(y[tr.boundary_rows()], [0.0]);

    // No multipliers where the costates do not give them all.
    let pend = Pendulum {
        delta: 0.2,
        path: true,
    };
    let tr = pendulum_transcription(&pend, false);
    let v: Vec<f64> = (0..tr.n_var()).map(|i| 0.1 * (i % 5) as f64).collect();
    let first = kkt::PrimalEvaluation::at(&tr, &v);
    let pi = vec![0.5; tr.n_points() * tr.n_state()];
    assert!(kkt::multipliers_from_costates(&tr, &first, &pi).is_none());
    let pend = Pendulum {
        delta: 0.2,
        path: false,
    };
    let tr = pendulum_transcription(&pend, false);
    let first = kkt::PrimalEvaluation::at(&tr, &v[..tr.n_var()]);
    assert!(kkt::multipliers_from_costates(&tr, &first, &pi[1..]).is_none());
    assert!(kkt::multipliers_from_costates(&tr, &first, &pi).is_some());
}
