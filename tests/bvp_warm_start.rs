//! Warm starts (from a `Solution`, from values, from a closure, resampled on another mesh),
//! continuation, and the progress hook.

mod common;
use common::*;
use suslov::bvp::{solve, solve_with_progress, Guess, Options, ProgressEvent, Status};

fn tanh_cold(tol: f64) -> (InteriorLayer, suslov::bvp::Solution) {
    let prob = InteriorLayer { w: 0.01 };
    let g = Guess::from_fn(&uniform(0.0, 1.0, 10), 2, vec![], |x, o| {
        o.copy_from_slice(&[2.0 * x - 1.0, 2.0])
    });
    let sol = solve(
        &prob,
        &g,
        &Options {
            tol,
            ..Options::default()
        },
    )
    .unwrap();
    assert!(sol.is_success());
    (prob, sol)
}

#[test]
fn exact_restart_from_solution_is_one_newton_step() {
    let (prob, sol) = tanh_cold(1e-8);
    let before = sol.clone();
    let again = solve(
        &prob,
        &Guess::from_solution(&sol),
        &Options {
            tol: 1e-8,
            ..Options::default()
        },
    )
    .unwrap();
    assert_eq!(again.status, Status::Converged);
    // The caller's solution is untouched, the restart is exact and cheap.
    assert_eq!(sol.y, before.y);
    assert_eq!(again.x, sol.x);
    assert_eq!(again.stats.mesh_passes, 1);
    assert_eq!(again.stats.newton_iterations, 1);
    assert_eq!(again.stats.jacobian_evaluations, 1);
    assert_eq!(again.stats.factorizations, 1);
    for (a, b) in again.y.iter().zip(&sol.y) {
        assert!((a - b).abs() <= 1e-9 * (1.0 + b.abs()));
    }
    // `From<&Solution>` is the same warm start.
    assert_eq!(Guess::from(&sol), Guess::from_solution(&sol));
}

#[test]
fn warm_start_from_values_and_from_other_mesh() {
    let (prob, sol) = tanh_cold(1e-8);
    // Values only (stages re-interpolated): still converges on the same mesh.
    let g = Guess::from_values(sol.x.clone(), sol.y.clone(), vec![]);
    let s1 = solve(
        &prob,
        &g,
        &Options {
            tol: 1e-8,
            ..Options::default()
        },
    )
    .unwrap();
    assert_eq!(s1.status, Status::Converged);
    assert!(node_error(&prob, &s1) < 1e-7);
    // Resampled on a uniform mesh of 300 intervals through the dense output.
    let g = Guess::from_solution_on_mesh(&sol, &uniform(0.0, 1.0, 300));
    assert_eq!(g.x().len(), 301);
    let s2 = solve(
        &prob,
        &g,
        &Options {
            tol: 1e-8,
            ..Options::default()
        },
    )
    .unwrap();
    assert_eq!(s2.status, Status::Converged);
    assert!(node_error(&prob, &s2) < 1e-7);
}

#[test]
fn continuation_in_bratu_lambda_with_warm_starts() {
    let opts = Options {
        tol: 1e-8,
        ..Options::default()
    };
    let first = Bratu::new(0.5, 1.0);
    let mut sol = solve(
        &first,
        &Guess::from_values(uniform(0.0, 1.0, 10), vec![0.0; 22], vec![]),
        &opts,
    )
    .unwrap();
    assert!(sol.is_success());
    let mut total_newton = 0;
    for step in 1..=12 {
        let lambda = 0.5 + 0.25 * step as f64; // up to 3.5, close to the fold at 3.5138
        let prob = Bratu::new(lambda, 1.0);
        let next = solve(&prob, &Guess::from_solution(&sol), &opts).unwrap();
        assert_eq!(
            next.status,
            Status::Converged,
            "lambda = {lambda}: {}",
            next.message()
        );
        assert!(
            node_error(&prob, &next) < 1e-7,
            "lambda = {lambda}: error {:e}",
            node_error(&prob, &next)
        );
        total_newton += next.stats.newton_iterations;
        sol = next;
    }
    assert!(
        total_newton <= 12 * 8,
        "{total_newton} Newton iterations for 12 steps"
    );
}

#[test]
fn progress_hook_reports_newton_steps_and_mesh_passes() {
    let prob = InteriorLayer { w: 0.01 };
    let g = Guess::from_fn(&uniform(0.0, 1.0, 10), 2, vec![], |x, o| {
        o.copy_from_slice(&[2.0 * x - 1.0, 2.0])
    });
    let mut events = vec![];
    let sol = solve_with_progress(
        &prob,
        &g,
        &Options {
            tol: 1e-6,
            ..Options::default()
        },
        &mut |p| events.push(p.clone()),
    )
    .unwrap();
    assert!(sol.is_success());
    let passes: Vec<_> = events
        .iter()
        .filter(|p| matches!(p.event, ProgressEvent::MeshPass { .. }))
        .collect();
    let steps = events
        .iter()
        .filter(|p| matches!(p.event, ProgressEvent::NewtonStep { .. }))
        .count();
    assert_eq!(passes.len(), sol.stats.mesh_passes);
    assert!(steps >= 1 && steps <= sol.stats.newton_iterations);
    // Mesh sizes reported in order, the last pass has no successor.
    for (p, &m) in passes.iter().zip(&sol.stats.mesh_history) {
        assert_eq!(p.nodes, m);
    }
    // Display gives one log line per event and a report for the solution.
    let first = events[0].to_string();
    assert!(first.starts_with("pass 0 (11 nodes): Newton 0:"), "{first}");
    let last_line = passes.last().unwrap().to_string();
    assert!(last_line.ends_with(", done"), "{last_line}");
    let report = sol.to_string();
    assert!(
        report.starts_with("Converged: The algorithm converged"),
        "{report}"
    );
    assert!(
        report.contains(&format!("Mesh of {} nodes", sol.num_nodes())),
        "{report}"
    );
    match passes.last().unwrap().event {
        ProgressEvent::MeshPass {
            next_nodes,
            newton_converged,
            max_error,
            ..
        } => {
            assert_eq!(next_nodes, None);
            assert!(newton_converged && max_error <= 1.0);
        }
        _ => unreachable!(),
    }
}

#[test]
fn statistics_are_consistent() {
    let (_, sol) = tanh_cold(1e-6);
    let s = &sol.stats;
    assert_eq!(s.mesh_history.len(), s.mesh_passes);
    assert!(s.factorizations == s.jacobian_evaluations);
    assert!(s.jacobian_evaluations <= s.newton_iterations);
    assert!(s.f_evaluations > 0 && s.bc_evaluations > 0);
    assert!(s.max_error <= 1.0 && s.max_residual > 0.0);
    assert_eq!(sol.errors.len(), sol.num_nodes() - 1);
    assert_eq!(sol.residuals.len(), sol.num_nodes() - 1);
    assert!(s.condition_estimate.is_finite() && s.bc_condition.is_finite());
}

#[test]
fn warm_start_from_over_resolved_mesh_coarsens() {
    // A tol = 1e-10 solution is over-resolved by about (1e4)^(1/5) = 6x for tol = 1e-6.
    let (prob, fine) = tanh_cold(1e-10);
    let opts = Options {
        tol: 1e-6,
        ..Options::default()
    };
    let sol = solve(&prob, &Guess::from_solution(&fine), &opts).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message());
    assert!(
        3 * sol.num_nodes() < fine.num_nodes(),
        "{} nodes after coarsening, warm start had {} (history {:?})",
        sol.num_nodes(),
        fine.num_nodes(),
        sol.stats.mesh_history
    );
    assert!(node_error(&prob, &sol) < 1e-5);
    assert!(sol.stats.max_error <= 1.0);
    // Without coarsening the warm-start mesh is kept.
    let kept = solve(
        &prob,
        &Guess::from_solution(&fine),
        &Options {
            coarsen: false,
            ..opts
        },
    )
    .unwrap();
    assert_eq!(kept.status, Status::Converged);
    assert_eq!(kept.num_nodes(), fine.num_nodes());
}
