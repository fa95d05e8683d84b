//! Every generated Jacobian against finite differences of the generated function it
//! differentiates, at seeded random points (>= 100 each), including the T column (which
//! goes through Omega_d(a + s T)) and the free-time condition's dependence on T.

mod modelkit;
use modelkit::{derivative, Path, Rng};
use suslov::model::generated as g;

const POINTS: usize = 120;
/// Relative tolerance. Richardson-extrapolated central differences reach ~1e-9 here; a wrong
/// term (even one contributing 1e-4 of an entry) is far above this (see the negative control).
const TOL: f64 = 1e-6;

/// Compares analytic and FD entries; an entry fails if it differs by more than
/// TOL * (|fd| + 1e-3 * scale), scale being the largest entry of its row.
fn mismatches(analytic: &[f64], fd: &[f64], what: &str, out: &mut Vec<String>) {
    let scale = fd.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-8);
    for (j, (a, f)) in analytic.iter().zip(fd).enumerate() {
        let ok = (a - f).abs() <= TOL * (f.abs() + 1e-3 * scale); // false for NaN too
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

/// All Jacobian checks at one point; returns the list of failing entries.
fn check_point(rng: &mut Rng, perturb: Option<(usize, usize, f64)>) -> Vec<String> {
    let admissible = rng.next_u64().is_multiple_of(2);
    let y = modelkit::random_state(rng, admissible);
    let p = modelkit::random_params(rng);
    let path = Path::random(rng);
    let t_span = rng.uniform(1.0, 12.0);
    let s = rng.uniform(0.0, 1.0);
    let mut bad = Vec::new();

    // ODE: d(T f)/dy and d(T f)/dT.
    let w = path.w(s * t_span);
    let mut dgdy = [[0.0; 12]; 12];
    let mut dgdt = [0.0; 12];
    g::ode_jac_scaled(&y, &p, &w, t_span, s, &mut dgdy, &mut dgdt);
    if let Some((i, j, rel)) = perturb {
        dgdy[i][j] *= 1.0 + rel;
    }
    let rhs = |y: &[f64; 12], t_span: f64| {
        let mut out = [0.0; 12];
        g::ode_rhs_scaled(y, &p, &path.w(s * t_span), t_span, &mut out);
        out
    };
    let mut fd_cols = [[0.0; 12]; 12];
    for (j, col) in fd_cols.iter_mut().enumerate() {
        *col = derivative(
            |x| {
                let mut yy = y;
                yy[j] = x;
                rhs(&yy, t_span)
            },
            y[j],
            step(y[j]),
        );
    }
    for i in 0..12 {
        let fd_row: Vec<f64> = (0..12).map(|j| fd_cols[j][i]).collect();
        mismatches(&dgdy[i], &fd_row, &format!("d(Tf)_{i}/dy"), &mut bad);
    }
    let fd_t = derivative(|t| rhs(&y, t), t_span, step(t_span));
    mismatches(&dgdt, &fd_t, "d(Tf)/dT", &mut bad);

    // Boundary conditions at an end point.
    let om_end = [
        rng.uniform(-2.0, 2.0),
        rng.uniform(-2.0, 2.0),
        rng.uniform(-2.0, 2.0),
    ];
    let mut d_y = [[0.0; 12]; 6];
    g::bc_endpoint_jac(&y, &p, &om_end, &mut d_y);
    let bc = |y: &[f64; 12]| {
        let mut out = [0.0; 6];
        g::bc_endpoint(y, &p, &om_end, &mut out);
        out
    };
    let mut fd_bc = [[0.0; 6]; 12];
    for (j, col) in fd_bc.iter_mut().enumerate() {
        *col = derivative(
            |x| {
                let mut yy = y;
                yy[j] = x;
                bc(&yy)
            },
            y[j],
            step(y[j]),
        );
    }
    for i in 0..6 {
        let fd_row: Vec<f64> = (0..12).map(|j| fd_bc[j][i]).collect();
        mismatches(&d_y[i], &fd_row, &format!("dbc_{i}/dy"), &mut bad);
    }

    // Free-time condition: d/dy(b) and d/dT through Omega_d(b = a + T), with a = 0.
    let wb = path.w(t_span);
    let mut d_yb = [0.0; 12];
    let d_t = g::free_time_condition_jac(&y, &p, &wb, &mut d_yb);
    let ftc = |y: &[f64; 12], t: f64| [g::free_time_condition(y, &p, &path.w(t))];
    let fd_y: Vec<f64> = (0..12)
        .map(|j| {
            derivative(
                |x| {
                    let mut yy = y;
                    yy[j] = x;
                    ftc(&yy, t_span)
                },
                y[j],
                step(y[j]),
            )[0]
        })
        .collect();
    mismatches(&d_yb, &fd_y, "d free_time/dy", &mut bad);
    let fd_tt = derivative(|t| ftc(&y, t), t_span, step(t_span));
    mismatches(&[d_t], &fd_tt, "d free_time/dT", &mut bad);
    bad
}

#[test]
fn generated_jacobians_match_finite_differences() {
    let mut rng = Rng::new(2026);
    let mut failures = Vec::new();
    for k in 0..POINTS {
        for f in check_point(&mut rng, None) {
            failures.push(format!("point {k}: {f}"));
        }
    }
    assert!(
        failures.is_empty(),
        "{}",
        modelkit::failure_report(&failures)
    );
}

#[test]
fn a_wrong_jacobian_term_is_caught() {
    // Negative control: corrupt one entry of d(Tf)/dy by a relative 1e-3 (as a missing small
    // term would) and the same comparison must flag it at (nearly) every point.
    let mut rng = Rng::new(7);
    let mut caught = 0;
    let trials = 40;
    for k in 0..trials {
        let (i, j) = (6 + k % 6, k % 12); // rows of xi'' and kappa': the intricate ones
        if !check_point(&mut rng, Some((i, j, 1e-3))).is_empty() {
            caught += 1;
        }
    }
    assert!(
        caught >= trials - 2,
        "only {caught} of {trials} corruptions caught"
    );
}
