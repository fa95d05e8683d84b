//! Pin the solver's behaviour on two problems with insta snapshots of integer statistics
//! (node counts per pass, iterations, evaluations); floats are checked elsewhere with
//! tolerances. A change in these numbers is a reviewable change of the algorithm.

mod common;
use common::*;
use suslov::bvp::{solve, Guess, Options, Solution};

fn summary(sol: &Solution) -> String {
    let s = &sol.stats;
    format!(
        "status: {:?}\nnodes: {}\nmesh_history: {:?}\nnewton_iterations: {}\njacobian_evaluations: {}\nfactorizations: {}\nf_evaluations: {}\nbc_evaluations: {}\n",
        sol.status,
        sol.num_nodes(),
        s.mesh_history,
        s.newton_iterations,
        s.jacobian_evaluations,
        s.factorizations,
        s.f_evaluations,
        s.bc_evaluations
    )
}

#[test]
fn snapshot_tanh_layer_stats() {
    let g = Guess::from_fn(&uniform(0.0, 1.0, 10), 2, vec![], |x, o| {
        o.copy_from_slice(&[2.0 * x - 1.0, 2.0])
    });
    let sol = solve(
        &InteriorLayer { w: 0.01 },
        &g,
        &Options {
            tol: 1e-6,
            ..Options::default()
        },
    )
    .unwrap();
    insta::assert_snapshot!("tanh_layer_tol_1e-6", summary(&sol));
}

#[test]
fn snapshot_sturm_liouville_stats() {
    let g = Guess::from_fn(&uniform(0.0, 1.0, 10), 2, vec![3.0], |x, o| {
        o.copy_from_slice(&[(3.0 * x).sin(), 3.0 * (3.0 * x).cos()])
    });
    let sol = solve(
        &SturmLiouville,
        &g,
        &Options {
            tol: 1e-8,
            ..Options::default()
        },
    )
    .unwrap();
    insta::assert_snapshot!("sturm_liouville_tol_1e-8", summary(&sol));
}
