//! Measured order of convergence on successively refined *uniform fixed* meshes
//! (`adapt_mesh = false`): 6 at the mesh points (superconvergence of 4-stage Lobatto IIIA),
//! 5 uniformly for the dense output (the collocation quartic).

mod common;
use common::*;
use suslov::bvp::Status;

/// Fit the orders for `problem` on meshes with `intervals`; returns (node order, dense order).
fn measure<P: Exact>(
    name: &str,
    prob: &P,
    intervals: &[usize],
    guess: &dyn Fn(f64) -> Vec<f64>,
) -> (f64, f64) {
    let (a, b) = prob.interval();
    let mut hs = vec![];
    let mut node_errs = vec![];
    let mut dense_errs = vec![];
    for &n in intervals {
        let sol = solve_fixed(prob, n, guess, prob.exact_p());
        assert!(
            matches!(sol.status, Status::Converged | Status::ToleranceNotMet),
            "{name}, N = {n}: {:?} {}",
            sol.status,
            sol.message()
        );
        let mut e = node_error(prob, &sol);
        for (pv, pe) in sol.p.iter().zip(prob.exact_p()) {
            e = e.max((pv - pe).abs() / (1.0 + pe.abs()));
        }
        hs.push((b - a) / n as f64);
        node_errs.push(e);
        dense_errs.push(dense_error(prob, &sol, 20 * n + 7));
    }
    let (on, od) = (
        fitted_order(&hs, &node_errs),
        fitted_order(&hs, &dense_errs),
    );
    let fmt = |v: &[f64]| {
        v.iter()
            .map(|e| format!("{e:.2e}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    println!(
        "{name}: h = {}\n  node errors  {} -> order {on:.2}\n  dense errors {} -> order {od:.2}",
        fmt(&hs),
        fmt(&node_errs),
        fmt(&dense_errs)
    );
    (on, od)
}

fn assert_orders(name: &str, (node, dense): (f64, f64)) {
    assert!(
        (node - 6.0).abs() <= 0.5,
        "{name}: node order {node:.2}, expected 6 +- 0.5"
    );
    assert!(
        (dense - 5.0).abs() <= 0.5,
        "{name}: dense-output order {dense:.2}, expected 5 +- 0.5"
    );
}

#[test]
fn order_linear() {
    let o = measure("linear", &Linear, &[4, 8, 16, 32], &|x| vec![x, 1.0]);
    assert_orders("linear", o);
}

#[test]
fn order_nonlinear() {
    let o = measure("quadratic", &Quadratic, &[4, 8, 16, 32], &|x| {
        vec![4.0 - 3.0 * x, -3.0]
    });
    assert_orders("quadratic", o);
}

#[test]
fn order_parameter() {
    let o = measure("sturm-liouville", &SturmLiouville, &[4, 8, 16, 32], &|x| {
        vec![(3.0 * x).sin(), 3.0 * (3.0 * x).cos()]
    });
    assert_orders("sturm-liouville", o);
}

#[test]
fn order_boundary_layer() {
    let prob = BoundaryLayer { eps: 1e-3 };
    let o = measure("boundary layer", &prob, &[500, 1000, 2000, 4000], &|x| {
        vec![x, 1.0]
    });
    assert_orders("boundary layer", o);
}

#[test]
fn order_bratu() {
    let prob = Bratu::new(1.0, 1.0);
    let o = measure("bratu (lower)", &prob, &[4, 8, 16, 32], &|_| vec![0.0, 0.0]);
    assert_orders("bratu (lower)", o);
}

#[test]
fn order_interior_layer() {
    let prob = InteriorLayer { w: 0.01 };
    let o = measure("tanh layer", &prob, &[200, 400, 800, 1600], &|x| {
        vec![2.0 * x - 1.0, 2.0]
    });
    assert_orders("tanh layer", o);
}
