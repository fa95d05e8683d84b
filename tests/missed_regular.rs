//! Regular minima the homotopy misses: the direct-method reference (`bench/casadi_direct.py`,
//! CasADi/IPOPT from the "segment-invdyn" guess at the target weights) found smooth minima with
//! |ξ| ≈ 1 for corpus problems on which every route of [`suslov::lie::solve`] stops. Are they
//! solutions of *our* BVP? A warm start ([`suslov::lie::solve_from`]) from the direct solution
//! (its Ω, ξ, ξ̇ on every 5th collocation point, the costate κ = 0: the direct method has none)
//! answers it: for fast-119 and issue12-080 our BVP converges, the solution passes its checks
//! and its cost is IPOPT's, for fast-119, issue12-080 and (since its Newton matrix's condition
//! is measured in the unknowns' own scales) fast-199.

use std::path::{Path, PathBuf};

use suslov::lie::{self, solve::WARM_START_ROUTE, LieSolveError, WarmStart};
use suslov::model::generated as so3;
use suslov::so3::solve::SolveOptions;

fn hard(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/corpus/hard")
        .join(file)
}

/// A direct-method CSV (`t,omega1..3,xi1..3,xidot1..3`, `#` comments) as a warm start with
/// κ = 0.
fn warm_start(csv: &str) -> WarmStart {
    let text = std::fs::read_to_string(hard(csv)).unwrap();
    let (mut times, mut states) = (Vec::new(), Vec::new());
    for line in text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('t'))
    {
        let v: Vec<f64> = line.split(',').map(|s| s.parse().unwrap()).collect();
        assert_eq!(v.len(), 10, "{line}");
        times.push(v[0]);
        states.extend_from_slice(&v[1..]);
        states.extend_from_slice(&[0.0; 3]); // κ
    }
    assert_eq!(states.len(), times.len() * so3::N_STATE);
    WarmStart { times, states }
}

/// Solve `problem_file` from `csv` with the default route as the only fallback.
fn solve_from(
    problem_file: &str,
    csv: &str,
) -> Result<lie::LieSolution<so3::So3>, LieSolveError<so3::So3>> {
    let loaded = suslov::config::load(&hard(problem_file)).unwrap();
    let problem = loaded.problem.to_generic().unwrap();
    let options = SolveOptions {
        max_routes: 1,
        ..loaded.options
    };
    lie::solve_from(&problem, &options, &warm_start(csv), &mut |_| {})
}

fn min_xi(sol: &suslov::bvp::Solution) -> f64 {
    sol.y
        .chunks_exact(so3::N_STATE)
        .map(|y| y[so3::XI].iter().map(|v| v * v).sum::<f64>().sqrt())
        .fold(f64::INFINITY, f64::min)
}

/// `file` (a hard file) solved with default settings, by the direct start as its last route,
/// and verified: the solution and its verified cost.
fn solved_by_the_direct_start(file: &str) -> (lie::LieSolution<so3::So3>, f64) {
    use suslov::lie::solve::DIRECT_START_ROUTE;
    let loaded = suslov::config::load(&hard(file)).unwrap();
    let problem = loaded.problem.to_generic().unwrap();
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    let last = sol.routes.last().unwrap();
    assert_eq!(
        (last.route, last.stopped.as_deref()),
        (DIRECT_START_ROUTE, None)
    );
    let verified = lie::verify_solution(&sol);
    assert!(
        verified.verification.passed(),
        "{file}: {:?}",
        verified.verification
    );
    let cost = verified.diagnostics.cost;
    (sol, cost)
}

/// The warm start alone solves it (no homotopy), verified, at IPOPT's cost (given to 7 and 10
/// digits: relative 7e-8 and 8e-10 measured).
fn assert_reaches(problem_file: &str, csv: &str, ipopt_cost: f64) {
    let sol = solve_from(problem_file, csv).unwrap_or_else(|e| panic!("{problem_file}: {e}"));
    assert_eq!(sol.routes.len(), 1, "{:?}", sol.routes);
    assert_eq!(sol.routes[0].route, WARM_START_ROUTE);
    assert_eq!(sol.routes[0].stopped, None);
    let verified = lie::verify_solution(&sol);
    assert!(
        verified.verification.passed(),
        "{problem_file}: {:?}",
        verified.verification
    );
    let cost = verified.diagnostics.cost;
    assert!(
        ((cost - ipopt_cost) / ipopt_cost).abs() < 1e-6,
        "{problem_file}: cost {cost} vs IPOPT's {ipopt_cost}"
    );
    // Regular: |ξ| stays near 1 (the routes' partial results collapse ξ or stop at a fold).
    assert!(min_xi(&sol.bvp) > 0.99, "min |xi| {}", min_xi(&sol.bvp));
}

#[test]
fn fast_119s_direct_minimum_is_a_solution_of_our_bvp() {
    assert_reaches(
        "fast_119_missed_regular.toml",
        "fast_119_missed_regular.csv",
        114.8380278,
    );
}

#[test]
fn issue12_080s_direct_minimum_is_a_solution_of_our_bvp() {
    assert_reaches(
        "issue12_080_missed_regular.toml",
        "issue12_080_missed_regular.csv",
        0.002548219,
    );
}

/// fast-199 (γ = η = 0, cost 1.5e-5: ξ almost constant, |Ω| up to 75, the costate at most
/// 3e-5): from IPOPT's regular minimum the BVP converges, and the solution passes its checks at
/// IPOPT's cost (1.523130473e-5, agreeing to its 10 printed digits). Until session 31 the
/// conditioning guard stopped it: equilibrated in its rows only, the Newton matrix's
/// condition estimate was 4.6e12 (above `1e-3 / eps`), because the costate's columns are
/// 1e6 times smaller than Ω's; equilibrated in its columns too it is 6e10 at the first
/// solve and 9e7 at the verified solution.
#[test]
fn fast_199s_direct_minimum_is_a_solution_of_our_bvp() {
    assert_reaches(
        "fast_199_gamma_zero_singular.toml",
        "fast_199_gamma_zero_singular.csv",
        1.523130473e-5,
    );
}

/// The direct start ([`suslov::lie::direct`]) on fast-199 in the reduced form. Its relaxation
/// (without the start condition `⟨Ω_a, ξ(a)⟩ = 0`) converges to a point that is no motion of
/// Suslov's problem (`⟨Ω, ξ⟩ = −0.18` throughout, the energy more than doubling on the way:
/// drift 1.09, cost 2.02e-5; until session 33 this was the direct start, and no BVP
/// converged from it).
/// So the start condition is imposed, and the SQP from the projected segment, after
/// feasibility restorations (its filter blocks every step more than once), converges to a
/// regular minimum, |ξ| ≈ 1, cost 1.6079e-5 on 100 intervals (IPOPT's on its own
/// transcription: 1.5231e-5), that is a motion: `⟨Ω, ξ⟩ = 0` at every point (measured 5e-9)
/// and the energy constant.
#[test]
fn fast_199s_direct_start_reaches_a_motion_of_suslovs_problem() {
    use suslov::lie::direct::{direct_start, DirectGuess};
    let loaded = suslov::config::load(&hard("fast_199_gamma_zero_singular.toml")).unwrap();
    let problem = loaded.problem.to_generic().unwrap();
    let start = direct_start(&problem, 100, DirectGuess::Segment).expect("the SQP converges");
    eprintln!(
        "fast-199 direct: {} iterations, {} restorations, J = {:e}, min |xi| = {}",
        start.report.iterations, start.report.restorations, start.cost, start.min_xi
    );
    assert!(start.start_imposed, "the relaxation's minimum is a motion");
    assert!(start.report.restorations > 0);
    assert!(start.min_xi > 0.99, "{}", start.min_xi);
    assert!(start.cost > 1.5e-5 && start.cost < 1.7e-5, "{}", start.cost);
    let drift = suslov::lie::direct::energy_drift(&problem, &start);
    assert!(drift < 1e-6, "energy drift {drift}");
    let residual = start.report.residual;
    assert!(residual.relative_stationarity() <= suslov::lie::direct::DIRECT_TOLERANCE);
    assert!(residual.feasibility <= suslov::lie::direct::DIRECT_TOLERANCE);
    assert_eq!(start.warm.times.len(), 301);
    let inertia = problem.inertia_matrix();
    let energy = |y: &[f64]| -> f64 {
        (0..3)
            .map(|i| {
                (0..3)
                    .map(|j| y[i] * inertia[i * 3 + j] * y[j])
                    .sum::<f64>()
            })
            .sum::<f64>()
            / 2.0
    };
    let e0 = energy(&problem.omega_a);
    for y in start.warm.states.chunks_exact(so3::N_STATE) {
        let (omega, xi) = (&y[so3::OMEGA], &y[so3::XI]);
        let c: f64 = omega.iter().zip(xi).map(|(a, b)| a * b).sum();
        assert!(c.abs() < 1e-6, "<Omega, xi> = {c}");
        assert!(
            ((energy(omega) - e0) / e0).abs() < 1e-5,
            "energy {}",
            energy(omega)
        );
    }
}

/// The reduced form's relaxation is kept where its minimum is a motion of the problem: on
/// short-116 the SQP converges in 18 iterations to 7.16068615 (the verified solution's
/// cost, 7.1606861, `tests/routes.rs`), with `⟨Ω, ξ⟩` within 4e-7 of 0 and the energy
/// constant to 2e-9 relative. With the start
/// condition imposed it would land on another minimum, whose ξ dips to 2e-4 (7.173468), from
/// which the BVP does not converge (measured in session 33).
#[test]
fn short_116s_relaxed_direct_minimum_is_a_motion_and_is_kept() {
    use suslov::lie::direct::{direct_start, energy_drift, DirectGuess};
    let loaded = suslov::config::load(&hard("short_116_direct_start.toml")).unwrap();
    let problem = loaded.problem.to_generic().unwrap();
    let start = direct_start(&problem, 100, DirectGuess::Segment).expect("the SQP converges");
    let drift = energy_drift(&problem, &start);
    eprintln!(
        "short-116 direct: {} iterations, J = {:.10}, min |xi| = {}, drift {drift:e}",
        start.report.iterations, start.cost, start.min_xi
    );
    assert!(!start.start_imposed);
    assert!(drift < 1e-7, "energy drift {drift}");
    assert!((start.cost - 7.16068615).abs() < 1e-7, "{}", start.cost);
    assert!(start.min_xi > 0.9, "{}", start.min_xi);
}

/// fast-199 from its problem file alone, default settings: every continuation route stops;
/// the direct start's minimum above, with `κ = 0` (the fit to the SQP's multipliers is too
/// rough here), is taken up by the BVP: verified, at IPOPT's cost to its 10 printed digits.
#[test]
fn fast_199_is_solved_by_the_direct_start_with_a_vanishing_costate() {
    let (sol, cost) = solved_by_the_direct_start("fast_199_gamma_zero_singular.toml");
    assert!(
        ((cost - 1.523130473e-5) / 1.523130473e-5).abs() < 1e-8,
        "{cost}"
    );
    assert!(min_xi(&sol.bvp) > 0.99, "{}", min_xi(&sol.bvp));
}

/// fast-119 from its problem file alone, default settings: every continuation route stops,
/// the direct start on 100 intervals finds only a collapsed minimum (min |ξ| 0.001), and its
/// retry on 200 intervals finds the regular one, which the BVP takes up: verified, at IPOPT's
/// cost, |ξ| near 1.
#[test]
fn fast_119_is_solved_by_the_direct_start_on_the_finer_mesh() {
    let (sol, cost) = solved_by_the_direct_start("fast_119_missed_regular.toml");
    assert!(((cost - 114.8380278) / 114.8380278).abs() < 1e-6, "{cost}");
    assert!(min_xi(&sol.bvp) > 0.99, "{}", min_xi(&sol.bvp));
}

/// issue12-080 (γ = 0) from its problem file alone, default settings: every continuation
/// route stops, and the direct start in the reduced form stops at a failed inertia correction
/// on both meshes; in the multiplier form (`λ` a control, `φ = 0` at every point) the SQP
/// reaches the regular minimum IPOPT finds, and the BVP takes it up: verified, at IPOPT's
/// cost (0.002548219), |ξ| near 1.
#[test]
fn issue12_080_is_solved_by_the_direct_start_in_the_multiplier_form() {
    let (sol, cost) = solved_by_the_direct_start("issue12_080_missed_regular.toml");
    assert!(((cost - 0.002548219) / 0.002548219).abs() < 1e-6, "{cost}");
    assert!(min_xi(&sol.bvp) > 0.99, "{}", min_xi(&sol.bvp));
}

/// fast-198 (γ = 0, |Ω_a| ≈ 9.4 over b − a = 16.2) from its problem file alone, default
/// settings: every analytic start fails; the direct start's SQP finds a regular minimum on 100
/// intervals (multiplier form; the reduced form's line search stops), from which the BVP does
/// not converge. Refined to 200 intervals, with κ recovered from the SQP's multipliers, it
/// does; the polish to 1e-8 then ends rounding-limited (the Newton matrix's condition
/// estimate is 7.5e8 equilibrated in rows and columns; in rows only, before session 31, about
/// 3e12). Verified, at the cost the direct minima approach as the mesh is
/// refined (169.599053, 169.599046, 169.599044 on 100, 200, 400 intervals), with |ξ| ≥ 0.89.
#[test]
fn fast_198_is_solved_from_the_refined_direct_minimum() {
    let (sol, cost) = solved_by_the_direct_start("fast_198_rounding_limited.toml");
    assert!((cost - 169.59903114).abs() < 1e-6, "{cost}");
    assert!(cost < 169.599044, "below the finest direct minimum: {cost}");
    assert!(min_xi(&sol.bvp) > 0.89, "{}", min_xi(&sol.bvp));
    assert!(
        sol.bvp.stats.condition_estimate > 1e8,
        "{:e}",
        sol.bvp.stats.condition_estimate
    );
}

/// The direct start's `κ` is recovered from the SQP's multipliers (the reduced form's
/// least-squares multipliers at the minimum, whichever form found it, read as classical
/// costates): on a fixed-time example solved by the homotopy, both forms' warm starts carry
/// the BVP solution's `κ` to within the SQP's tolerance and the mesh's error (4.6e-4 of its
/// largest entry measured); the multiplier form's own multipliers would not (its state
/// constraint shifts the costates: 0.6 of the scale off).
#[test]
fn the_direct_starts_kappa_is_the_bvps() {
    use suslov::lie::direct::{direct_start_in, DirectForm, DirectGuess};
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/spiral_fixed_time.toml");
    let loaded = suslov::config::load(&file).unwrap();
    let problem = loaded.problem.to_generic().unwrap();
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    for form in [DirectForm::Multiplier, DirectForm::Reduced] {
        let start = direct_start_in(&problem, 100, DirectGuess::Segment, form).unwrap();
        assert!(start.kappa_fitted, "{form:?}");
        let (mut worst, mut scale) = (0.0_f64, 0.0_f64);
        for (t, y) in start
            .warm
            .times
            .iter()
            .zip(start.warm.states.chunks_exact(so3::N_STATE))
        {
            let exact = sol.state(*t);
            for i in so3::KAPPA {
                worst = worst.max((exact[i] - y[i]).abs());
                scale = scale.max(exact[i].abs());
            }
        }
        assert!(worst < 2e-3 * scale, "{form:?}: {worst:e} of {scale:e}");
    }
}

/// spiral-129 (η = 0, fixed b): every analytic start fails, and the direct method's minimum is
/// a regular one, converged in the mesh (0.544341, 0.544726, 0.544740, 0.544739 on 100, 200,
/// 400 and 800 intervals, min |ξ| 0.025 to 0.017) and below every control with a vanishing ξ
/// (the relaxed minimum's, 0.659168). The BVP converges from it refined to 400 intervals (not
/// from 100 or 200): solved with default settings since session 20, where sessions 16–19
/// stopped (16–18 calling the relaxed control ε-optimal).
#[test]
fn spiral_129s_regular_minimum_is_reached_from_the_direct_minimum_refined_to_400_intervals() {
    let (sol, cost) = solved_by_the_direct_start("spiral_129_refined_direct.toml");
    assert!((cost - 0.54474012).abs() < 1e-7, "{cost}");
    let least = min_xi(&sol.bvp);
    assert!(least > 0.01 && least < 0.03, "min |xi| {least}");
}
