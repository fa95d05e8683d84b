//! End to end: the paper's two cases (section 5.3) and a fixed-terminal-time case, solved from
//! the analytic singular solution through the staged homotopy, then verified a posteriori.

use suslov::lie::verify::{diagnose, reintegrate_difference};
use suslov::so3::paper;
use suslov::so3::solve::{solve, SolveOptions, SuslovSolution};

fn solve_quietly(problem: &suslov::so3::problem::SuslovProblem) -> SuslovSolution {
    solve(problem, &SolveOptions::default(), &mut |_| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn verify(sol: &SuslovSolution) {
    let d = diagnose(&sol.generic);
    assert!(sol.generic.bvp.is_success());
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
    let r = reintegrate_difference(&sol.generic).expect("re-integration runs");
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
            sol.generic.start.case, 3,
            "the paper's Omega_d is admissible up to 1e-4"
        );
        let names: Vec<&str> = sol.generic.stages.iter().map(|s| s.name).collect();
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
    let names: Vec<&str> = sol.generic.stages.iter().map(|s| s.name).collect();
    assert_eq!(names, ["start", "beta", "eta", "polish"]);
    verify(&sol);
}

/// The paper's stability experiment (section 5.3) as README reports it: a zero-mean relative
/// modulation of ξ̇ by 1e-3 moves Ω by at most 0.029 (η = 1) / 0.0036 (η = 0.01), a steady
/// additive 1e-3 by 2.0 / 0.76; ξ itself moves by at most the integrated perturbation.
#[test]
fn the_stability_experiment_gives_the_readme_numbers() {
    use suslov::so3::stability::{stability_runs, PERTURBATION};
    for (eta, modulated, additive) in [(1.0, 0.029, 2.02), (0.01, 0.0036, 0.764)] {
        let sol = solve_quietly(&paper::problem(eta));
        let runs = stability_runs(&sol).expect("the re-integrations run");
        assert_eq!(runs.len(), 2);
        let (m, a) = (&runs[0].1, &runs[1].1);
        eprintln!(
            "eta = {eta}: modulated {:e}, additive {:e}",
            m.max_deviation, a.max_deviation
        );
        assert!(
            (m.max_deviation / modulated - 1.0).abs() < 0.05,
            "eta = {eta}"
        );
        assert!(
            (a.max_deviation / additive - 1.0).abs() < 0.05,
            "eta = {eta}"
        );
        // |δξ| ≤ ∫|δξ̇| dt ≤ ε |ξ̇|_max T (modulated) and ε T (additive).
        let span = sol.terminal_time() - sol.problem.t0;
        assert!(a.max_xi_deviation <= PERTURBATION * span * (1.0 + 1e-6));
    }
}
