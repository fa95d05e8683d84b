//! Termination statuses of failing solves and `Err` for invalid input.

mod common;
use common::*;
use std::f64::consts::PI;
use suslov::bvp::{solve, BvpError, BvpProblem, Guess, Options, Status};

/// scipy's "undefined" problem: y' = 0 (both components), y0(0) = 0, y0(1) = 1: nothing fixes
/// y1, so the Jacobian is exactly singular.
struct Undetermined;
impl BvpProblem for Undetermined {
    fn n(&self) -> usize {
        2
    }
    fn f(&self, _x: f64, _y: &[f64], _p: &[f64], dy: &mut [f64]) {
        dy.fill(0.0);
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0];
        r[1] = yb[0] - 1.0;
    }
}

/// y'' + y = 0 on [0, pi], y(0) = 0, y(pi) = 1: no solution (resonance).
struct NoSolution;
impl BvpProblem for NoSolution {
    fn n(&self) -> usize {
        2
    }
    fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -y[0];
    }
    fn jac(&self, _x: f64, _y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, -1.0, 0.0]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0];
        r[1] = yb[0] - 1.0;
    }
}

/// y' = sqrt(y) type domain error: f is NaN for y < 0, and the guess is negative.
struct DomainError;
impl BvpProblem for DomainError {
    fn n(&self) -> usize {
        1
    }
    fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        dy[0] = y[0].sqrt();
    }
    fn bc(&self, ya: &[f64], _yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0] - 1.0;
    }
}

fn zeros(x: &[f64], n: usize) -> Guess {
    Guess::from_values(x.to_vec(), vec![0.0; x.len() * n], vec![])
}

#[test]
fn singular_jacobian() {
    let sol = solve(
        &Undetermined,
        &zeros(&uniform(0.0, 1.0, 4), 2),
        &Options::default(),
    )
    .unwrap();
    assert_eq!(sol.status, Status::SingularJacobian, "{}", sol.message());
    assert!(!sol.is_success());
}

#[test]
fn no_solution_is_never_converged() {
    for tol in [1e-3, 1e-6, 1e-8] {
        let sol = solve(
            &NoSolution,
            &zeros(&uniform(0.0, PI, 10), 2),
            &Options {
                tol,
                ..Options::default()
            },
        )
        .unwrap();
        assert_ne!(
            sol.status,
            Status::Converged,
            "tol {tol}: spurious solution of size {:e}",
            sol.y[1]
        );
        assert!(
            matches!(
                sol.status,
                Status::SingularJacobian | Status::NoConvergence | Status::MaxNodes
            ),
            "tol {tol}: {:?}",
            sol.status
        );
    }
}

#[test]
fn bratu_beyond_the_fold_does_not_converge() {
    // lambda = 5 > lambda* = 3.51...: Bratu has no solution.
    let prob = Bratu {
        lambda: 5.0,
        theta: f64::NAN,
    };
    let sol = solve(
        &prob,
        &zeros(&uniform(0.0, 1.0, 10), 2),
        &Options::default(),
    )
    .unwrap();
    assert_eq!(sol.status, Status::NoConvergence, "{}", sol.message());
}

#[test]
fn node_cap_gives_max_nodes() {
    let prob = InteriorLayer { w: 0.01 };
    let g = Guess::from_fn(&uniform(0.0, 1.0, 10), 2, vec![], |x, o| {
        o.copy_from_slice(&[2.0 * x - 1.0, 2.0])
    });
    let sol = solve(
        &prob,
        &g,
        &Options {
            tol: 1e-8,
            max_nodes: 60,
            ..Options::default()
        },
    )
    .unwrap();
    assert_eq!(sol.status, Status::MaxNodes, "{}", sol.message());
    assert!(sol.num_nodes() <= 60);
}

#[test]
fn nan_from_f_gives_non_finite() {
    let g = Guess::from_values(uniform(0.0, 1.0, 5), vec![-1.0; 6], vec![]);
    let sol = solve(&DomainError, &g, &Options::default()).unwrap();
    assert_eq!(sol.status, Status::NonFinite, "{}", sol.message());
}

#[test]
fn nan_appearing_during_iteration_gives_non_finite() {
    /// f is NaN once the iterate leaves [-2, 2]; the solution (y = 10 x) does.
    struct Blowup;
    impl BvpProblem for Blowup {
        fn n(&self) -> usize {
            1
        }
        fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
            dy[0] = if y[0].abs() > 2.0 { f64::NAN } else { 10.0 };
        }
        fn bc(&self, ya: &[f64], _yb: &[f64], _p: &[f64], r: &mut [f64]) {
            r[0] = ya[0];
        }
    }
    let sol = solve(
        &Blowup,
        &zeros(&uniform(0.0, 1.0, 5), 1),
        &Options::default(),
    )
    .unwrap();
    assert_eq!(sol.status, Status::NonFinite);
}

#[test]
fn bc_tolerance_not_met() {
    /// A boundary condition that cannot be satisfied better than rounding of a large number.
    struct Big;
    impl BvpProblem for Big {
        fn n(&self) -> usize {
            1
        }
        fn f(&self, _x: f64, _y: &[f64], _p: &[f64], dy: &mut [f64]) {
            dy[0] = 1.0;
        }
        fn bc(&self, ya: &[f64], _yb: &[f64], _p: &[f64], r: &mut [f64]) {
            r[0] = 1e20 * (ya[0] - 1.0 / 3.0) + 123.456;
        }
    }
    let opts = Options {
        bc_tol: Some(1e-6),
        ..Options::default()
    };
    let sol = solve(
        &Big,
        &Guess::from_values(uniform(0.0, 1.0, 3), vec![0.1; 4], vec![]),
        &opts,
    )
    .unwrap();
    assert_eq!(
        sol.status,
        Status::BcTolNotMet,
        "bc residual {:e}",
        sol.stats.bc_residual
    );
    assert!(sol.stats.bc_residual > 1e-6);
}

#[test]
fn fixed_mesh_reports_tolerance_not_met() {
    let prob = InteriorLayer { w: 0.01 };
    let g = Guess::from_fn(&uniform(0.0, 1.0, 40), 2, vec![], |x, o| {
        o.copy_from_slice(&prob.exact(x))
    });
    let sol = solve(
        &prob,
        &g,
        &Options {
            adapt_mesh: false,
            tol: 1e-8,
            ..Options::default()
        },
    )
    .unwrap();
    assert_eq!(sol.status, Status::ToleranceNotMet);
    assert_eq!(sol.num_nodes(), 41);
}

#[test]
fn invalid_input_is_an_error() {
    let x = uniform(0.0, 1.0, 4);
    let good = zeros(&x, 2);
    let opts = Options::default();
    // Wrong number of values.
    let e = solve(
        &Linear,
        &Guess::from_values(x.clone(), vec![0.0; 9], vec![]),
        &opts,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            BvpError::DimensionMismatch {
                expected: 10,
                found: 9,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("expected length 10, found 9"), "{e}");
    // Parameters for a problem without parameters, and missing ones.
    let e = solve(&Linear, &good.clone().with_parameters(vec![1.0]), &opts).unwrap_err();
    assert!(
        matches!(
            e,
            BvpError::DimensionMismatch {
                expected: 0,
                found: 1,
                ..
            }
        ),
        "{e}"
    );
    let e = solve(&SturmLiouville, &good, &opts).unwrap_err();
    assert!(
        matches!(
            e,
            BvpError::DimensionMismatch {
                expected: 1,
                found: 0,
                ..
            }
        ),
        "{e}"
    );
    // Non-increasing mesh, and a > b.
    let e = solve(&Linear, &zeros(&[0.0, 0.5, 0.5, 1.0], 2), &opts).unwrap_err();
    assert!(
        matches!(e, BvpError::MeshNotIncreasing { index: 1, .. }),
        "{e}"
    );
    let e = solve(&Linear, &zeros(&[1.0, 0.0], 2), &opts).unwrap_err();
    assert!(
        matches!(e, BvpError::MeshNotIncreasing { index: 0, .. }),
        "{e}"
    );
    let e = solve(&Linear, &zeros(&[0.0], 2), &opts).unwrap_err();
    assert_eq!(e, BvpError::MeshTooShort { found: 1 });
    // NaN in the guess.
    let e = solve(
        &Linear,
        &Guess::from_values(x.clone(), vec![f64::NAN; 10], vec![]),
        &opts,
    )
    .unwrap_err();
    assert!(matches!(e, BvpError::NonFiniteInput { .. }), "{e}");
    // Bad options.
    for bad in [
        Options {
            tol: 0.0,
            ..Options::default()
        },
        Options {
            tol: -1e-3,
            ..Options::default()
        },
        Options {
            atol: Some(f64::NAN),
            ..Options::default()
        },
        Options {
            max_nodes: 1,
            ..Options::default()
        },
        Options {
            max_newton_iter: 0,
            ..Options::default()
        },
        Options {
            min_damping: 2.0,
            ..Options::default()
        },
    ] {
        let e = solve(&Linear, &good, &bad).unwrap_err();
        assert!(matches!(e, BvpError::InvalidOption { .. }), "{e}");
    }
    let e = solve(
        &Linear,
        &good,
        &Options {
            scale: Some(vec![1.0]),
            ..Options::default()
        },
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            BvpError::DimensionMismatch {
                expected: 2,
                found: 1,
                ..
            }
        ),
        "{e}"
    );
}
