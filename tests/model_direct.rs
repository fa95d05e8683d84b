//! The point functions of the direct transcription (`direct_dynamics`, `direct_cost`,
//! `direct_hessian`; z = [Omega, xi, xi'], x = [Omega, xi], u = xi') at seeded random points,
//! admissible (<Omega, xi> = 0) and not, xi away from 0:
//!
//! * every derivative against Richardson-extrapolated central differences of the generated
//!   function it differentiates (df/dz of f, dL/dz and dL/dOmega_d of L, the Hessian of the
//!   point Lagrangian of its gradient w l_z + sum_i lam_i f_z[i] and w l_d);
//! * consistency with the existing functions: f[0..3] = `suslov_omega_dot`, L = `cost_integrand`;
//! * Pontryagin's stationarity: with w = 1 and lam = +pi (`classical_costates`), the u-part of
//!   l_z + sum_i lam_i f_z[i] vanishes, i.e. H = L + <pi, f> with the sign of
//!   `tests/model_invariants.rs` (with -pi it does not vanish).

mod modelkit;
use modelkit::{close, derivative, Path, Rng};
use suslov::model::generated as g;

const POINTS: usize = 120;
/// Relative tolerance, as in `tests/model_jacobians.rs`.
const TOL: f64 = 1e-6;

/// The three outputs a negative control can corrupt.
#[derive(Clone, Copy)]
enum Corrupt {
    Fz(usize, usize),
    Lz(usize),
    Hzz(usize, usize),
}

/// Failing entries and the worst relative error |a - f| / (|f| + 1e-3 scale) per check.
#[derive(Default)]
struct Outcome {
    bad: Vec<String>,
    worst_fz: f64,
    worst_l: f64,
    worst_h: f64,
}

/// Compares analytic and FD entries; an entry fails if it differs by more than
/// TOL * (|fd| + 1e-3 * scale), scale being the largest entry of its row.
fn mismatches(analytic: &[f64], fd: &[f64], what: &str, out: &mut Vec<String>, worst: &mut f64) {
    let scale = fd.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-8);
    for (j, (a, f)) in analytic.iter().zip(fd).enumerate() {
        let bound = f.abs() + 1e-3 * scale;
        let ok = (a - f).abs() <= TOL * bound; // false for NaN too
        *worst = worst.max((a - f).abs() / bound);
        if !ok {
            out.push(format!(
                "{what} [{j}]: analytic {a:e}, finite difference {f:e}"
            ));
        }
    }
}

fn step(x: f64) -> f64 {
    1e-3 * (1.0 + x.abs())
}

struct Point {
    y: [f64; 12],
    z: [f64; 9],
    p: [f64; 8],
    od: [f64; 3],
    w: f64,
    lam: [f64; 6],
}

fn random_point(rng: &mut Rng) -> Point {
    let admissible = rng.next_u64().is_multiple_of(2);
    // xi away from 0: projecting xi onto Omega^perp (admissible points) can make it small,
    // where Suslov's equations degenerate (den = <xi, I^-1 xi> -> 0) and differences fail.
    let y = loop {
        let y = modelkit::random_state(rng, admissible);
        if y[3..6].iter().map(|v| v * v).sum::<f64>() >= 0.3 * 0.3 {
            break y;
        }
    };
    let mut z = [0.0; 9];
    z.copy_from_slice(&y[..9]);
    let p = modelkit::random_params(rng);
    let od = [
        rng.uniform(-2.0, 2.0),
        rng.uniform(-2.0, 2.0),
        rng.uniform(-2.0, 2.0),
    ];
    let w = rng.uniform(0.1, 2.0);
    let mut lam = [0.0; 6];
    for l in lam.iter_mut() {
        *l = rng.uniform(-2.0, 2.0);
    }
    Point {
        y,
        z,
        p,
        od,
        w,
        lam,
    }
}

fn dynamics(z: &[f64; 9], p: &[f64; 8]) -> ([f64; 6], [[f64; 9]; 6]) {
    let mut f = [0.0; 6];
    let mut f_z = [[f64::NAN; 9]; 6];
    g::direct_dynamics(z, p, &mut f, &mut f_z);
    (f, f_z)
}

fn cost(z: &[f64; 9], p: &[f64; 8], od: &[f64; 3]) -> (f64, [f64; 9], [f64; 3]) {
    let mut l_z = [f64::NAN; 9];
    let mut l_d = [f64::NAN; 3];
    let l = g::direct_cost(z, p, od, &mut l_z, &mut l_d);
    (l, l_z, l_d)
}

/// The gradient of the point Lagrangian w L + <lam, f> w.r.t. v = [z, Omega_d] (12 entries),
/// assembled from the generated first derivatives.
fn lagrangian_gradient(pt: &Point, z: &[f64; 9], od: &[f64; 3]) -> [f64; 12] {
    let (_, f_z) = dynamics(z, &pt.p);
    let (_, l_z, l_d) = cost(z, &pt.p, od);
    let mut out = [0.0; 12];
    for j in 0..9 {
        out[j] = pt.w * l_z[j] + (0..6).map(|i| pt.lam[i] * f_z[i][j]).sum::<f64>();
    }
    for k in 0..3 {
        out[9 + k] = pt.w * l_d[k];
    }
    out
}

/// All derivative checks at one point.
fn check_point(rng: &mut Rng, corrupt: Option<(Corrupt, f64)>) -> Outcome {
    let pt = random_point(rng);
    let (z, p, od) = (pt.z, pt.p, pt.od);
    let mut o = Outcome::default();

    // (a) df/dz.
    let (_, mut f_z) = dynamics(&z, &p);
    if let Some((Corrupt::Fz(i, j), rel)) = corrupt {
        f_z[i][j] *= 1.0 + rel;
    }
    let mut fd = [[0.0; 6]; 9];
    for (j, col) in fd.iter_mut().enumerate() {
        *col = derivative(
            |x| {
                let mut zz = z;
                zz[j] = x;
                dynamics(&zz, &p).0
            },
            z[j],
            step(z[j]),
        );
    }
    for (i, row) in f_z.iter().enumerate() {
        let fd_row: Vec<f64> = (0..9).map(|j| fd[j][i]).collect();
        mismatches(
            row,
            &fd_row,
            &format!("df_{i}/dz"),
            &mut o.bad,
            &mut o.worst_fz,
        );
    }

    // (b) dL/dz and dL/dOmega_d.
    let (_, mut l_z, l_d) = cost(&z, &p, &od);
    if let Some((Corrupt::Lz(j), rel)) = corrupt {
        l_z[j] *= 1.0 + rel;
    }
    let fd_z: Vec<f64> = (0..9)
        .map(|j| {
            derivative(
                |x| {
                    let mut zz = z;
                    zz[j] = x;
                    [cost(&zz, &p, &od).0]
                },
                z[j],
                step(z[j]),
            )[0]
        })
        .collect();
    mismatches(&l_z, &fd_z, "dL/dz", &mut o.bad, &mut o.worst_l);
    let fd_d: Vec<f64> = (0..3)
        .map(|k| {
            derivative(
                |x| {
                    let mut dd = od;
                    dd[k] = x;
                    [cost(&z, &p, &dd).0]
                },
                od[k],
                step(od[k]),
            )[0]
        })
        .collect();
    mismatches(&l_d, &fd_d, "dL/dOmega_d", &mut o.bad, &mut o.worst_l);

    // (c) the Hessian of w L + <lam, f> w.r.t. v = [z, Omega_d], against differences of the
    // gradient; h_zd is checked both as d(grad_z)/dOmega_d and as d(grad_d)/dz.
    let mut h_zz = [[f64::NAN; 9]; 9];
    let mut h_zd = [[f64::NAN; 3]; 9];
    let mut h_dd = [[f64::NAN; 3]; 3];
    g::direct_hessian(&z, &p, &od, pt.w, &pt.lam, &mut h_zz, &mut h_zd, &mut h_dd);
    for (i, row) in h_zz.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            assert!(
                v.to_bits() == h_zz[j][i].to_bits(),
                "h_zz not exactly symmetric at [{i}][{j}]"
            );
        }
    }
    if let Some((Corrupt::Hzz(i, j), rel)) = corrupt {
        h_zz[i][j] *= 1.0 + rel;
    }
    let mut h = [[0.0; 12]; 12];
    for (i, row) in h.iter_mut().enumerate() {
        for (j, e) in row.iter_mut().enumerate() {
            *e = match (i < 9, j < 9) {
                (true, true) => h_zz[i][j],
                (true, false) => h_zd[i][j - 9],
                (false, true) => h_zd[j][i - 9],
                (false, false) => h_dd[i - 9][j - 9],
            };
        }
    }
    let mut fd_h = [[0.0; 12]; 12]; // fd_h[j][i] = d grad_i / d v_j
    for (j, col) in fd_h.iter_mut().enumerate() {
        *col = derivative(
            |x| {
                let (mut zz, mut dd) = (z, od);
                if j < 9 {
                    zz[j] = x;
                } else {
                    dd[j - 9] = x;
                }
                lagrangian_gradient(&pt, &zz, &dd)
            },
            if j < 9 { z[j] } else { od[j - 9] },
            step(if j < 9 { z[j] } else { od[j - 9] }),
        );
    }
    for (i, row) in h.iter().enumerate() {
        let fd_row: Vec<f64> = (0..12).map(|j| fd_h[j][i]).collect();
        mismatches(
            row,
            &fd_row,
            &format!("d2l/dv_{i}dv"),
            &mut o.bad,
            &mut o.worst_h,
        );
    }
    o
}

#[test]
fn direct_derivatives_match_finite_differences() {
    let mut rng = Rng::new(2027);
    let mut failures = Vec::new();
    let (mut wf, mut wl, mut wh) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..POINTS {
        let o = check_point(&mut rng, None);
        wf = wf.max(o.worst_fz);
        wl = wl.max(o.worst_l);
        wh = wh.max(o.worst_h);
        failures.extend(o.bad.into_iter().map(|f| format!("point {k}: {f}")));
    }
    println!(
        "worst relative error vs finite differences over {POINTS} points (tolerance {TOL:e}): \
         f_z {wf:.1e}, l_z/l_d {wl:.1e}, Hessian {wh:.1e}"
    );
    assert!(
        failures.is_empty(),
        "{}",
        modelkit::failure_report(&failures)
    );
}

#[test]
fn a_wrong_direct_derivative_is_caught() {
    // Negative control: corrupt one entry of f_z, l_z or h_zz by a relative 1e-3 (as a
    // missing small term would); the same comparison must flag it at (nearly) every point.
    let mut rng = Rng::new(8);
    let trials = 45;
    let mut caught = 0;
    for k in 0..trials {
        let c = match k % 3 {
            0 => Corrupt::Fz((k / 3) % 3, (k / 3) % 9),
            1 => Corrupt::Lz((k / 3) % 9),
            _ => Corrupt::Hzz((k / 3) % 9, (5 * k) % 9),
        };
        if !check_point(&mut rng, Some((c, 1e-3))).bad.is_empty() {
            caught += 1;
        }
    }
    println!("{caught} of {trials} corruptions caught");
    assert!(
        caught >= trials - 2,
        "only {caught} of {trials} corruptions caught"
    );
}

#[test]
fn direct_functions_agree_with_the_existing_ones() {
    // (d) f[0..3] is Suslov's Omega' (`suslov_omega_dot`), f[3..6] = u = xi', and L is the
    // on-shell cost integrand (`cost_integrand`, for any kappa and Omega_d').
    let mut rng = Rng::new(31);
    for k in 0..POINTS {
        let pt = random_point(&mut rng);
        let (f, _) = dynamics(&pt.z, &pt.p);
        let mut om_dot = [0.0; 3];
        g::suslov_omega_dot(&pt.z, &pt.p, &mut om_dot);
        for i in 0..3 {
            assert!(
                close(f[i], om_dot[i], 1e-13, om_dot[i].abs()),
                "point {k}: f[{i}] = {:e}, suslov_omega_dot {:e}",
                f[i],
                om_dot[i]
            );
            assert!(f[3 + i] == pt.z[6 + i], "point {k}: f[{}] != u", 3 + i);
        }
        let (l, _, _) = cost(&pt.z, &pt.p, &pt.od);
        let wpath = [
            pt.od[0],
            pt.od[1],
            pt.od[2],
            rng.uniform(-2.0, 2.0),
            rng.uniform(-2.0, 2.0),
            rng.uniform(-2.0, 2.0),
        ];
        let c = g::cost_integrand(&pt.y, &pt.p, &wpath);
        assert!(
            close(l, c, 1e-13, c.abs()),
            "point {k}: L = {l:e}, cost_integrand {c:e}"
        );
    }
}

/// The u-part of l_z + sum_i lam_i f_z[i] (d/du of w L + <lam, f> with w = 1).
fn h_u(z: &[f64; 9], p: &[f64; 8], od: &[f64; 3], lam: &[f64; 6]) -> ([f64; 3], f64) {
    let (_, f_z) = dynamics(z, p);
    let (_, l_z, _) = cost(z, p, od);
    let mut out = [0.0; 3];
    let mut scale = 1.0f64;
    for j in 0..3 {
        out[j] = l_z[6 + j] + (0..6).map(|i| lam[i] * f_z[i][6 + j]).sum::<f64>();
        scale = scale.max(l_z[6 + j].abs());
    }
    for l in lam {
        scale = scale.max(l.abs());
    }
    (out, scale)
}

#[test]
fn classical_costates_make_h_u_vanish() {
    // (e) Pontryagin's stationarity with H = L + <pi, f> (w = 1, lam = +pi from
    // `classical_costates`, pi = -[p_Omega; p_xi]): H_u = 0 at every point, admissible or not
    // (it is an identity in kappa: the kappa terms of pi cancel through
    // dOmega'/dxi' = -I^-1 xi Omega^T / <xi, I^-1 xi>). With lam = -pi it does not vanish.
    let mut rng = Rng::new(41);
    let mut worst = 0.0f64;
    let mut wrong_sign_vanishes = 0;
    for k in 0..POINTS {
        let pt = random_point(&mut rng);
        let path = Path::random(&mut rng);
        let wpath = path.w(0.5);
        let od = [wpath[0], wpath[1], wpath[2]];
        let mut pi = [0.0; 6];
        g::classical_costates(&pt.y, &pt.p, &wpath, &mut pi);
        let (hu, scale) = h_u(&pt.z, &pt.p, &od, &pi);
        for (j, v) in hu.iter().enumerate() {
            worst = worst.max(v.abs() / scale);
            assert!(close(*v, 0.0, 1e-10, scale), "point {k}: H_u[{j}] = {v:e}");
        }
        let minus_pi = pi.map(|v| -v);
        let (hu_wrong, scale) = h_u(&pt.z, &pt.p, &od, &minus_pi);
        if hu_wrong.iter().all(|v| close(*v, 0.0, 1e-6, scale)) {
            wrong_sign_vanishes += 1;
        }
    }
    println!("H_u with lam = +pi: worst |H_u| / scale = {worst:.1e} over {POINTS} points");
    assert!(
        wrong_sign_vanishes <= 2,
        "H_u also vanishes with lam = -pi at {wrong_sign_vanishes} points: the check is not live"
    );
}
