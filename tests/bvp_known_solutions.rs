//! Adaptive solves of the test problems against their exact solutions, with analytic and
//! with finite-difference Jacobians (as scipy's `test_bvp.py` does for every problem).

mod common;
use common::*;
use suslov::bvp::{solve, Guess, JacobianSource, Options, Solution, Status};

/// Solve with both Jacobian sources; check status, accuracy against the exact solution
/// (nodes, dense output, parameters), that the dense output interpolates the nodes and
/// that its derivative is `f` there, and that both Jacobian sources agree.
fn check<P: Exact>(name: &str, prob: &P, guess: &Guess, tol: f64, max_nodes: usize) -> Solution {
    let mut sols = vec![];
    for jac in [JacobianSource::Analytic, JacobianSource::FiniteDifference] {
        let guess_before = guess.clone();
        let opts = Options {
            tol,
            jacobian: jac,
            ..Options::default()
        };
        let sol = solve(prob, guess, &opts).expect("valid input");
        assert_eq!(
            guess, &guess_before,
            "{name}: the guess must not be modified"
        );
        assert_eq!(
            sol.status,
            Status::Converged,
            "{name} ({jac:?}): {}",
            sol.message()
        );
        assert!(sol.is_success());
        assert!(
            sol.num_nodes() <= max_nodes,
            "{name} ({jac:?}): {} nodes > {max_nodes}",
            sol.num_nodes()
        );
        // Accuracy against the exact solution, measured relative to 1 + |y|.
        let (en, ed) = (node_error(prob, &sol), dense_error(prob, &sol, 4001));
        assert!(
            en <= 10.0 * tol,
            "{name} ({jac:?}): node error {en:e} > 10 tol"
        );
        assert!(
            ed <= 10.0 * tol,
            "{name} ({jac:?}): dense-output error {ed:e} > 10 tol"
        );
        for (pv, pe) in sol.p.iter().zip(prob.exact_p()) {
            assert!(
                (pv - pe).abs() <= 10.0 * tol * (1.0 + pe.abs()),
                "{name}: p = {pv} vs {pe}"
            );
        }
        // The reported measures hold on the returned solution.
        assert!(sol.stats.max_error <= 1.0);
        assert!(sol.stats.bc_residual <= tol);
        assert!(sol.errors.iter().all(|&e| e <= 1.0));
        assert_eq!(sol.stats.mesh_history.last(), Some(&sol.num_nodes()));
        // Dense output: interpolates the nodes, derivative = f at the nodes (C1).
        let mut f = vec![0.0; prob.n()];
        for i in 0..sol.num_nodes() {
            let (x, y) = (sol.x[i], sol.y_at(i).to_vec());
            prob.f(x, &y, &sol.p, &mut f);
            for (a, b) in sol.eval(x).iter().zip(&y) {
                assert!(
                    (a - b).abs() <= 1e-10 * (1.0 + b.abs()),
                    "{name}: eval at node {i}"
                );
            }
            for (a, b) in sol.eval_derivative(x).iter().zip(&f) {
                assert!(
                    (a - b).abs() <= 1e-8 * (1.0 + b.abs()),
                    "{name}: eval_derivative at node {i}"
                );
            }
        }
        sols.push(sol);
    }
    // Analytic and FD Jacobians give the same solution (to the tolerance).
    let (a, b) = prob.interval();
    for x in uniform(a, b, 997) {
        for (u, v) in sols[0].eval(x).iter().zip(sols[1].eval(x)) {
            assert!(
                (u - v).abs() <= 10.0 * tol * (1.0 + u.abs()),
                "{name}: analytic vs FD at {x}: {u} vs {v}"
            );
        }
    }
    sols.swap_remove(0)
}

fn coarse() -> Vec<f64> {
    uniform(0.0, 1.0, 10)
}

#[test]
fn linear() {
    for tol in [1e-6, 1e-8] {
        let g = Guess::from_values(coarse(), vec![0.0; 22], vec![]);
        check("linear", &Linear, &g, tol, 60);
    }
}

#[test]
fn nonlinear() {
    for tol in [1e-6, 1e-8] {
        let g = Guess::from_fn(&coarse(), 2, vec![], |x, o| {
            o.copy_from_slice(&[4.0 - 3.0 * x, -3.0])
        });
        check("quadratic", &Quadratic, &g, tol, 60);
    }
}

#[test]
fn unknown_parameter_sturm_liouville() {
    for tol in [1e-6, 1e-8] {
        let g = Guess::from_fn(&coarse(), 2, vec![3.0], |x, o| {
            o.copy_from_slice(&[(3.0 * x).sin(), 3.0 * (3.0 * x).cos()])
        });
        let sol = check("sturm-liouville", &SturmLiouville, &g, tol, 60);
        assert!((sol.p[0] - std::f64::consts::PI).abs() < 10.0 * tol * 4.2);
    }
}

#[test]
fn boundary_layer_eps_1e_3() {
    let prob = BoundaryLayer { eps: 1e-3 };
    for tol in [1e-6, 1e-8] {
        let g = Guess::from_fn(&coarse(), 2, vec![], |x, o| o.copy_from_slice(&[x, 1.0]));
        check("boundary layer", &prob, &g, tol, 400);
    }
}

#[test]
fn bratu_both_branches() {
    for tol in [1e-6, 1e-8] {
        // Lower branch from y = 0, upper branch from y = 3 (scipy's documented example).
        let lower = Bratu::new(1.0, 1.0);
        let upper = Bratu::new(1.0, 10.0);
        assert!(
            (lower.theta - 1.517_164_599_050_754).abs() < 1e-12,
            "theta = {}",
            lower.theta
        );
        assert!(upper.theta > 10.0);
        let g0 = Guess::from_values(coarse(), vec![0.0; 22], vec![]);
        let g3 = Guess::from_fn(&coarse(), 2, vec![], |_, o| o.copy_from_slice(&[3.0, 0.0]));
        let lo = check("bratu lower", &lower, &g0, tol, 60);
        let hi = check("bratu upper", &upper, &g3, tol, 200);
        assert!(
            lo.eval(0.5)[0] < 0.2 && hi.eval(0.5)[0] > 3.5,
            "branches: {} {}",
            lo.eval(0.5)[0],
            hi.eval(0.5)[0]
        );
    }
}

#[test]
fn interior_tanh_layer_width_0_01() {
    let prob = InteriorLayer { w: 0.01 };
    for tol in [1e-6, 1e-8] {
        let g = Guess::from_fn(&coarse(), 2, vec![], |x, o| {
            o.copy_from_slice(&[2.0 * x - 1.0, 2.0])
        });
        let sol = check("tanh layer", &prob, &g, tol, 600);
        // The mesh concentrates in the layer: most intervals within 0.5 +- 0.1.
        let inside = sol.x.iter().filter(|&&x| (x - 0.5).abs() < 0.1).count();
        assert!(
            2 * inside > sol.num_nodes(),
            "{inside} of {} nodes in the layer",
            sol.num_nodes()
        );
    }
}

#[test]
fn residual_control_also_converges() {
    let prob = InteriorLayer { w: 0.01 };
    let g = Guess::from_fn(&coarse(), 2, vec![], |x, o| {
        o.copy_from_slice(&[2.0 * x - 1.0, 2.0])
    });
    let opts = Options {
        tol: 1e-6,
        error_control: suslov::bvp::ErrorControl::Residual,
        ..Options::default()
    };
    let sol = solve(&prob, &g, &opts).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message());
    assert!(sol.stats.max_residual <= 1e-6);
    assert!(node_error(&prob, &sol) <= 1e-6);
}
