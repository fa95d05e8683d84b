//! Invariants and identities that the generated system must satisfy, at random points.
//! None of them is used to derive the system, so each is an independent check of it.

mod modelkit;
use modelkit::{close, derivative, Path, Rng};
use suslov::model::generated as g;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[test]
fn constraint_rate_vanishes_and_energy_is_conserved() {
    // d/dt <Omega, xi> = <Omega', xi> + <Omega, xi'> = 0 for any state (lambda enforces it);
    // <I Omega, Omega'> = lambda <Omega, xi> = 0 on the constraint manifold.
    let mut rng = Rng::new(1);
    for k in 0..200 {
        let admissible = k % 2 == 0;
        let y = modelkit::random_state(&mut rng, admissible);
        let p = modelkit::random_params(&mut rng);
        let w = Path::random(&mut rng).w(rng.uniform(0.0, 10.0));
        let mut f = [0.0; 12];
        g::ode_rhs(&y, &p, &w, &mut f);
        let rate = dot(&f[0..3], &y[3..6]) + dot(&y[0..3], &y[6..9]);
        let scale = dot(
            &f[0..3].iter().map(|v| v.abs()).collect::<Vec<_>>(),
            &[1.0; 3],
        );
        assert!(
            close(rate, 0.0, 1e-13, scale),
            "point {k}: d<Om,xi>/dt = {rate:e}"
        );
        if admissible {
            let i_om: Vec<f64> = (0..3).map(|i| p[i] * y[i]).collect();
            let e_rate = dot(&i_om, &f[0..3]);
            assert!(
                close(e_rate, 0.0, 1e-12, scale),
                "point {k}: dT/dt = {e_rate:e}"
            );
        }
    }
}

#[test]
fn energy_function_obeys_noethers_balance_along_the_flow() {
    // For L = C + <kappa, q>, E = <p_Om, Om'> + <p_xi, xi'> - L satisfies
    // dE/dt = -dL/dt|explicit = gamma <Omega - Omega_d, Omega_d'> along solutions. This
    // involves xi'' and kappa' (through Om'' and p'), so it checks the explicit system.
    let mut rng = Rng::new(2);
    let mut worst = 0.0f64;
    for k in 0..150 {
        let y = modelkit::random_state(&mut rng, k % 3 != 0);
        let p = modelkit::random_params(&mut rng);
        let path = Path::random(&mut rng);
        let t = rng.uniform(0.0, 10.0);
        let w = path.w(t);
        let mut f = [0.0; 12];
        g::ode_rhs(&y, &p, &w, &mut f);
        let along = |h: f64| {
            let mut yy = y;
            for i in 0..12 {
                yy[i] += h * f[i];
            }
            [g::energy_function(&yy, &p, &path.w(t + h))]
        };
        let de_dt = derivative(along, 0.0, 1e-3)[0];
        let om_minus: Vec<f64> = (0..3).map(|i| y[i] - w[i]).collect();
        let expected = p[5] * dot(&om_minus, &w[3..6]);
        let scale = f.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        worst = worst.max((de_dt - expected).abs() / scale);
        assert!(
            close(de_dt, expected, 1e-7, scale),
            "point {k}: dE/dt = {de_dt:e}, expected {expected:e}"
        );
    }
    eprintln!("worst relative defect of dE/dt: {worst:e}");
}

#[test]
fn the_balance_check_detects_a_wrong_kappa_equation() {
    // Negative control for the test above: perturbing kappa' by 1% breaks the balance.
    let mut rng = Rng::new(3);
    let mut caught = 0;
    for _ in 0..30 {
        let y = modelkit::random_state(&mut rng, true);
        let mut p = modelkit::random_params(&mut rng);
        p[6] = rng.uniform(0.5, 2.0); // eta > 0 so kappa' enters E's rate
        let path = Path::random(&mut rng);
        let w = path.w(1.0);
        let mut f = [0.0; 12];
        g::ode_rhs(&y, &p, &w, &mut f);
        for v in &mut f[9..12] {
            *v *= 1.01;
        }
        let along = |h: f64| {
            let mut yy = y;
            for i in 0..12 {
                yy[i] += h * f[i];
            }
            [g::energy_function(&yy, &p, &path.w(1.0 + h))]
        };
        let de_dt = derivative(along, 0.0, 1e-3)[0];
        let om_minus: Vec<f64> = (0..3).map(|i| y[i] - w[i]).collect();
        let expected = p[5] * dot(&om_minus, &w[3..6]);
        let scale = f.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        if !close(de_dt, expected, 1e-7, scale) {
            caught += 1;
        }
    }
    assert!(caught >= 28, "caught {caught} of 30");
}

/// A path on the energy ellipsoid <Omega, I Omega> = 2e with exact derivatives:
/// Omega = sqrt(2e) [sin th cos ph / sqrt(I1), sin th sin ph / sqrt(I2), cos th / sqrt(I3)],
/// th = th0 + th1 t, ph = ph0 + ph1 t.
fn ellipsoid_path(p: &[f64; 8], c: [f64; 5], t: f64) -> [f64; 9] {
    let [e, th0, th1, ph0, ph1] = c;
    let k: Vec<f64> = (0..3).map(|i| (2.0 * e / p[i]).sqrt()).collect();
    let (th, ph) = (th0 + th1 * t, ph0 + ph1 * t);
    let (st, ct, sp, cp) = (th.sin(), th.cos(), ph.sin(), ph.cos());
    let om = [k[0] * st * cp, k[1] * st * sp, k[2] * ct];
    let om1 = [
        k[0] * (th1 * ct * cp - ph1 * st * sp),
        k[1] * (th1 * ct * sp + ph1 * st * cp),
        -k[2] * th1 * st,
    ];
    let om2 = [
        k[0] * (-(th1 * th1 + ph1 * ph1) * st * cp - 2.0 * th1 * ph1 * ct * sp),
        k[1] * (-(th1 * th1 + ph1 * ph1) * st * sp + 2.0 * th1 * ph1 * ct * cp),
        -k[2] * th1 * th1 * ct,
    ];
    let mut out = [0.0; 9];
    out[..3].copy_from_slice(&om);
    out[3..6].copy_from_slice(&om1);
    out[6..].copy_from_slice(&om2);
    out
}

#[test]
fn analytic_singular_solution_solves_suslov_and_the_costate_equation() {
    // Section 5.1: with Omega_p on the energy ellipsoid, xi_p = xi~/|xi~| solves q = 0 and
    // kappa = 0 solves the kappa equation when Omega_d = Omega_p and eta = 0; with |xi_p| = 1
    // the xi equation gives xi'' = 0 for any beta (the singular limit beta -> 0 is consistent).
    let mut rng = Rng::new(4);
    for k in 0..100 {
        let mut p = modelkit::random_params(&mut rng);
        p[6] = 0.0; // eta
        let c = [
            rng.uniform(0.5, 3.0),
            rng.uniform(0.3, 2.8),
            rng.uniform(-1.0, 1.0),
            rng.uniform(0.0, 6.0),
            rng.uniform(-1.0, 1.0),
        ];
        let t = rng.uniform(0.0, 2.0);
        let om = ellipsoid_path(&p, c, t);
        let mut xi = [0.0; 6];
        g::singular_control(&om, &p, &mut xi);
        // xi_p' is the time derivative of xi_p along the path.
        let fd = derivative(
            |tt| {
                let mut x = [0.0; 6];
                g::singular_control(&ellipsoid_path(&p, c, tt), &p, &mut x);
                [x[0], x[1], x[2]]
            },
            t,
            1e-3,
        );
        for i in 0..3 {
            assert!(
                close(xi[3 + i], fd[i], 1e-7, 1.0),
                "point {k}: xi_p' mismatch"
            );
        }
        assert!(close(dot(&xi[..3], &xi[..3]), 1.0, 1e-14, 1.0));
        assert!(
            close(dot(&xi[..3], &om[..3]), 0.0, 1e-13, 1.0),
            "<Om_p, xi_p> != 0"
        );
        let x = [
            om[0], om[1], om[2], om[3], om[4], om[5], xi[0], xi[1], xi[2], xi[3], xi[4], xi[5],
        ];
        let mut q = [0.0; 3];
        g::suslov_q(&x, &p, &mut q);
        for v in q {
            assert!(close(v, 0.0, 1e-12, 10.0), "point {k}: q = {q:?}");
        }
        let y = [
            om[0], om[1], om[2], xi[0], xi[1], xi[2], xi[3], xi[4], xi[5], 0.0, 0.0, 0.0,
        ];
        let w = [om[0], om[1], om[2], om[3], om[4], om[5]];
        let mut f = [0.0; 12];
        g::ode_rhs(&y, &p, &w, &mut f);
        for i in 0..3 {
            assert!(close(f[i], om[3 + i], 1e-12, 10.0), "Omega' != Omega_p'");
            assert!(
                close(f[6 + i], 0.0, 1e-12, 1.0),
                "xi'' != 0: {:?}",
                &f[6..9]
            );
            assert!(
                close(f[9 + i], 0.0, 1e-12, 1.0),
                "kappa' != 0: {:?}",
                &f[9..12]
            );
        }
    }
}

#[test]
fn delta_start_zeroes_the_free_time_condition() {
    let mut rng = Rng::new(5);
    for _ in 0..100 {
        let y = modelkit::random_state(&mut rng, true);
        let mut p = modelkit::random_params(&mut rng);
        let wb = Path::random(&mut rng).w(3.0);
        let d = g::delta_start(&y, &p, &wb);
        p[7] = d;
        let r = g::free_time_condition(&y, &p, &wb);
        assert!(
            close(r, 0.0, 1e-12, d.abs()),
            "residual {r:e} at delta = {d}"
        );
    }
}

#[test]
fn classical_costates_make_the_control_gradient_vanish() {
    // Pontryagin with the 6 classical costates pi: H_u = (eta Omega' + pi_d)^T dOmega'/dxi'
    // + beta xi' + pi_e = 0 when pi comes from kappa (paper, after eq. red_Hamiltonian).
    // dOmega'/dxi' is taken by finite differences of Suslov's pure equations.
    let mut rng = Rng::new(6);
    for k in 0..100 {
        let y = modelkit::random_state(&mut rng, true);
        let p = modelkit::random_params(&mut rng);
        let w = Path::random(&mut rng).w(0.5);
        let mut pi = [0.0; 6];
        g::classical_costates(&y, &p, &w, &mut pi);
        let mut f = [0.0; 12];
        g::ode_rhs(&y, &p, &w, &mut f);
        let mut x = [0.0; 9];
        x.copy_from_slice(&y[..9]);
        let mut jac = [[0.0; 3]; 3]; // [i][j] = d Omega'_i / d xi'_j
        for j in 0..3 {
            let col = derivative(
                |v| {
                    let mut xx = x;
                    xx[6 + j] = v;
                    let mut o = [0.0; 3];
                    g::suslov_omega_dot(&xx, &p, &mut o);
                    o
                },
                x[6 + j],
                1e-3,
            );
            for i in 0..3 {
                jac[i][j] = col[i];
            }
        }
        // dOmega'/dxi' = -I^-1 xi Omega^T / <xi, I^-1 xi>. (The paper prints it with a plus
        // sign, after eq. red_Hamiltonian: a typo without consequence there, since only
        // H_uu, quadratic in it, is used; with the plus sign H_u would not vanish.)
        let den: f64 = (0..3).map(|i| y[3 + i] * y[3 + i] / p[i]).sum();
        for i in 0..3 {
            for j in 0..3 {
                let exact = -y[3 + i] / p[i] * y[j] / den;
                assert!(
                    close(jac[i][j], exact, 1e-8, 1.0),
                    "dOmega'/dxi' [{i}][{j}]"
                );
            }
        }
        for j in 0..3 {
            let hu = (0..3)
                .map(|i| (p[6] * f[i] + pi[i]) * jac[i][j])
                .sum::<f64>()
                + p[4] * y[6 + j]
                + pi[3 + j];
            let scale = pi.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            assert!(close(hu, 0.0, 1e-8, scale), "point {k}: H_u[{j}] = {hu:e}");
        }
    }
}
