//! A system shaped like the target problem (n = 12, k = 1, interior tanh layer of width
//! 0.01, boundary layers of widths 1e-3 and 5e-3), solved to 1e-8 with analytic and with
//! finite-difference Jacobians.

mod common;
use common::*;
use suslov::bvp::{solve, JacobianSource, Options, Status};

#[test]
fn layered_system_n12_k1_to_1e_8() {
    let guess = LayeredSystem::guess(&uniform(0.0, 1.0, 20));
    let mut sols = vec![];
    for jacobian in [JacobianSource::Analytic, JacobianSource::FiniteDifference] {
        let opts = Options {
            tol: 1e-8,
            jacobian,
            ..Options::default()
        };
        let sol = solve(&LayeredSystem, &guess, &opts).unwrap();
        assert_eq!(
            sol.status,
            Status::Converged,
            "{jacobian:?}: {}",
            sol.message()
        );
        let err = node_error(&LayeredSystem, &sol).max(dense_error(&LayeredSystem, &sol, 4001));
        assert!(err < 1e-7, "{jacobian:?}: error {err:e}");
        assert!(
            (sol.p[0] - LayeredSystem::T).abs() < 1e-7,
            "T = {}",
            sol.p[0]
        );
        assert!(sol.num_nodes() < 2000, "{} nodes", sol.num_nodes());
        sols.push(sol);
    }
    println!(
        "layered system: nodes {} / {}, history {:?}, Newton {}, Jacobians {}",
        sols[0].num_nodes(),
        sols[1].num_nodes(),
        sols[0].stats.mesh_history,
        sols[0].stats.newton_iterations,
        sols[0].stats.jacobian_evaluations
    );
}
