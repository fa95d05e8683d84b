//! End to end: the paper's two cases (section 5.3) and a fixed-terminal-time case, solved from
//! the analytic singular solution through the staged homotopy, then verified a posteriori.

use suslov::suslov::diagnostics::{diagnose, reintegrate_check};
use suslov::suslov::paper;
use suslov::suslov::solve::{solve, SolveOptions, SuslovSolution};

fn solve_quietly(problem: &suslov::suslov::problem::SuslovProblem) -> SuslovSolution {
    solve(problem, &SolveOptions::default(), &mut |_| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn verify(sol: &SuslovSolution) {
    let d = diagnose(sol);
    assert!(sol.bvp.is_success());
    assert!(
        d.max_abs_constraint <= 1e-9,
        "max |<Om, xi>| = {:e}",
        d.max_abs_constraint
    );
    assert!(d.energy_drift <= 1e-8, "energy drift {:e}", d.energy_drift);
    assert!(d.bc_residual <= 1e-8, "BC residual {:e}", d.bc_residual);
    assert!(
        d.omega_b_error <= 1e-8,
        "|Omega(b) - Omega_b| = {:e}",
        d.omega_b_error
    );
    assert!(d.cost.is_finite() && d.cost > 0.0);
    let r = reintegrate_check(sol).expect("re-integration runs");
    assert!(
        r.max_abs_diff <= 1e-7,
        "re-integrated Omega differs by {:e}",
        r.max_abs_diff
    );
}

#[test]
fn reproduces_the_published_terminal_times() {
    for case in paper::CASES {
        let sol = solve_quietly(&paper::problem(case.eta));
        let b = sol.terminal_time();
        assert!(
            (b - case.published_b).abs() <= 0.01,
            "{}: b = {b}, published {}",
            case.name,
            case.published_b
        );
        assert_eq!(
            sol.start.case, 3,
            "the paper's Omega_d is admissible up to 1e-4"
        );
        let names: Vec<&str> = sol.stages.iter().map(|s| s.name).collect();
        assert_eq!(
            names,
            ["start", "beta", "eta", "free-time start", "delta", "polish"]
        );
        verify(&sol);
    }
}

#[test]
fn solves_a_fixed_terminal_time_case() {
    let sol = solve_quietly(&paper::fixed_time_problem(0.01, 10.0));
    assert_eq!(sol.terminal_time(), 10.0);
    let names: Vec<&str> = sol.stages.iter().map(|s| s.name).collect();
    assert_eq!(names, ["start", "beta", "eta", "polish"]);
    verify(&sol);
}
