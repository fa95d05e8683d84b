//! The homotopy's routes (`suslov::lie::solve::alternatives`): when the default route stops,
//! another one is tried, every route tried is listed, and `max_routes = 1` is the default route
//! alone.

use std::path::Path;

use suslov::lie::collapse::{self, Motion};
use suslov::lie::{self, LieSolveError};
use suslov::so3::solve::SolveOptions;

/// `(route, solved)` of every route `sol` lists, in order.
fn solved_by<M: suslov::model::Model>(sol: &lie::LieSolution<M>) -> Vec<(&'static str, bool)> {
    sol.routes
        .iter()
        .map(|r| (r.route, r.stopped.is_none()))
        .collect()
}

fn hard(file: &str) -> suslov::config::LoadedProblem {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/corpus/hard")
        .join(file);
    suslov::config::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The smallest |ξ| at the nodes of an so(3) solution.
fn min_xi(sol: &suslov::bvp::Solution) -> f64 {
    sol.y
        .chunks_exact(suslov::model::generated::N_STATE)
        .map(|y| {
            y[suslov::model::generated::XI]
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
                .sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The stage, reason and partial result of a hard file that no route solves.
fn stopped(
    file: &str,
) -> (
    &'static str,
    String,
    Box<lie::LieSolution<suslov::model::generated::So3>>,
) {
    let loaded = hard(file);
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    match lie::solve(&problem, &loaded.options, &mut |_| {}) {
        Err(LieSolveError::StageFailed {
            stage,
            reason,
            partial,
            ..
        }) => (stage, reason, partial),
        other => panic!("{file}: a stage should stop: {other:?}"),
    }
}

/// Issue #12's γ = 0 file: the default route stops in the tracking stage just short of
/// γ = 0 (at 6.7e-7, where β is still β_m); the joint route (every weight at once, so β grows
/// while the tracking weight goes) solves it, verified.
#[test]
fn the_joint_route_solves_the_gamma_zero_file_the_default_route_does_not() {
    let loaded = hard("issue12_gamma_zero_free.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let only_default = SolveOptions {
        max_routes: 1,
        ..loaded.options.clone()
    };
    match lie::solve(&problem, &only_default, &mut |_| {}) {
        Err(LieSolveError::StageFailed {
            stage,
            reached,
            partial,
            ..
        }) => {
            assert_eq!(stage, "gamma");
            assert!(reached > 0.0 && reached < 1e-5, "{reached} {partial:?}");
            let names: Vec<&str> = partial.routes.iter().map(|r| r.route).collect();
            assert_eq!(names, ["default"], "one route: nothing else tried");
        }
        other => panic!("the default route alone should stop: {other:?}"),
    }
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("another route solves it");
    let routes = solved_by(&sol);
    assert_eq!(routes, [("default", false), ("joint weights", true)]);
    assert!(sol.routes[0]
        .stopped
        .as_deref()
        .is_some_and(|r| r.contains("stage 'gamma'")));
    let names: Vec<&str> = sol.stages.iter().map(|s| s.name).collect();
    assert!(names.contains(&"weights"), "{names:?}");
    let v = lie::verify_solution(&sol);
    assert!(v.verification.passed(), "{:?}", v.verification.verdict());
}

/// When every route stops, the furthest route's error comes back with its evidence, and its
/// partial result lists every route tried with its reason. Issue #12's fixed-time file that
/// stops in the beta stage at 0.298 "whatever the mesh": the optimal xi shrinks toward 0
/// (|xi|^2 = 1 - (beta/alpha)|d(xi/|xi|)/dt|^2 pointwise, src/lie/solve.rs), where Suslov's
/// equations are singular. The collapse is seen from both sides: raising beta at the target
/// alpha (the default route), and lowering alpha from 100 times its target once beta is at
/// its target (the route `FIXED_FROM_ABOVE`, which gets further and is reported).
#[test]
fn a_problem_no_route_solves_lists_every_route_tried() {
    use suslov::lie::solve::FIXED_FROM_ABOVE;
    let (stage, reason, partial) = stopped("issue12_beta_stage_fixed.toml");
    let max_routes = hard("issue12_beta_stage_fixed.toml").options.max_routes;
    assert_eq!(stage, "alpha");
    assert!(
        reason.ends_with(&format!(
            "[on route '{FIXED_FROM_ABOVE}', the furthest of the routes tried]"
        )),
        "{reason}"
    );
    // The evidence: pseudo-arclength gets no further, and the control collapses (min |xi|
    // from about 0.9 to about 0.1 as alpha fell; measured: at alpha = 2.6, sqrt(alpha/beta) =
    // 0.83 rad/s against a turning rate of 1.3 rad/s).
    assert!(
        reason.contains("pseudo-arclength continuation") && reason.contains("no further than"),
        "{reason}"
    );
    assert!(reason.contains("xi collapses toward 0"), "{reason}");
    assert!(reason.contains("raise alpha"), "{reason}");
    // The default route: the beta stage stops with the same collapse (a fold at beta =
    // 0.2985 when measured).
    let default = partial.routes[0].stopped.as_deref().unwrap_or_default();
    assert!(default.starts_with("stage 'beta'"), "{default}");
    assert!(default.contains("xi collapses toward 0"), "{default}");
    let min_xi = min_xi(&partial.bvp);
    assert!(min_xi < 0.15, "{min_xi}");
    let names: Vec<&str> = partial.routes.iter().map(|r| r.route).collect();
    assert_eq!(names[0], "default");
    assert!(names.len() >= 3 && names.len() <= max_routes, "{names:?}");
    assert!(names.contains(&"joint weights") && names.contains(&"beta first"));
    assert_eq!(names[1], FIXED_FROM_ABOVE, "{names:?}");
    assert!(partial.routes.iter().all(|r| r.stopped.is_some()));
    // Where the branch heads (src/lie/collapse.rs, docs/collapse.md): a control with a
    // vanishing xi, at the target weights and the fixed b, costs less than the last
    // solution's own control there; the direct method (bench/casadi_direct.py) finds the
    // problem's infimum in that limit (44.27118405, max |xi| 3e-6), no regular minimum.
    let found = partial
        .collapse
        .as_ref()
        .expect("collapse evidence on a fixed-time stop");
    eprintln!("{found:?}");
    assert!(found.undercuts && !found.no_optimal_time, "{found:?}");
    assert!(
        reason.contains("an admissible control with |xi|"),
        "{reason}"
    );
    assert!(found.least.reintegration_error < 1e-6, "{found:?}");
    // Every control tried costs at least the infimum the direct method found (44.2712).
    for c in &found.controls {
        assert!(c.cost > 44.27, "{c:?}");
    }
    // The cheapest is the motion of the relaxed problem's minimum (the limit xi -> 0,
    // src/lie/relaxed.rs), driven by |xi| = 1e-6 and re-integrated: IPOPT's infimum to its
    // printed digits (measured 44.2711840536). The motion of our direct start's minimum (the
    // SQP in the multiplier form, which the BVP cannot take up) costs a little more (measured
    // 44.271305), and both less than the stop's own motion with a vanishing xi (44.271589).
    assert_eq!(found.least.motion, Motion::RelaxedMinimum, "{found:?}");
    assert!(
        ((found.least.cost - 44.27118405) / 44.27118405).abs() < 1e-9,
        "{found:?}"
    );
    match &found.relaxed {
        Some(collapse::RelaxedOutcome::Computed { costs, .. }) => {
            for c in costs {
                assert!(((c - 44.27118405) / 44.27118405).abs() < 1e-9, "{costs:?}");
            }
        }
        other => panic!("{other:?}"),
    }
    assert!(reason.contains("the relaxed problem"), "{reason}");
    let direct = found
        .controls
        .iter()
        .find(|c| c.motion == Motion::DirectMinimum)
        .expect("the direct minimum's motion");
    assert!(
        (direct.cost - 44.27118405) / 44.27118405 < 2e-5,
        "{found:?}"
    );
    let own = found
        .controls
        .iter()
        .find(|c| c.motion == Motion::Solution)
        .expect("the stop's own motion");
    assert!(found.least.cost < own.cost, "{found:?}");
}

/// Issue #12's free-time file whose delta stage stops at 0.020 (target 1.22): the fixed-time
/// scan is the evidence. Its verified samples give J*(T) increasing with T (the time weight
/// 1.22 dominates: J*(1.008) = 1.27, J*(1.344) = 1.67, J*(2.016) = 2.50 when measured), so
/// the optimal b - a lies below the shortest T solved; the error says so with the samples.
#[test]
fn a_stalled_time_stage_is_explained_by_the_fixed_time_value_function() {
    use suslov::lie::solve::{TIME_SCAN, TIME_SCAN_FACTORS};
    let (stage, reason, partial) = stopped("issue12_delta_stage_free.toml");
    assert_eq!(stage, "delta");
    assert!(reason.contains("J*(T) increases with T"), "{reason}");
    // Why no shorter T was solved: continuing b - a down from b_p, xi collapses (measured at
    // b - a = 0.929, min |xi| 0.031).
    assert!(
        reason.contains("continuing b - a from b_p stopped at b - a = 0.9")
            && reason.contains("where xi collapses"),
        "{reason}"
    );
    assert_eq!(partial.time_scan.len(), TIME_SCAN_FACTORS.len());
    let solved: Vec<(f64, f64)> = partial
        .time_scan
        .iter()
        .filter_map(|s| s.cost.map(|j| (s.span, j)))
        .collect();
    assert!(solved.len() >= 3, "{:?}", partial.time_scan);
    assert!(solved
        .windows(2)
        .all(|w| w[0].0 < w[1].0 && w[0].1 < w[1].1));
    // Every sample without a cost says why.
    assert!(partial
        .time_scan
        .iter()
        .all(|s| s.cost.is_some() != s.stopped.is_some()));
    // The samples next to b_p are reached by continuation in b - a from the solution at b_p
    // (measured: 1.008 below, 2.016 and 2.688 above; their own homotopies had solved 1.008
    // and 2.016 but not 2.688); where it stops, the sample it was heading for says so
    // (measured: xi collapses at b - a = 0.929 on the way to 0.672).
    let continued: Vec<f64> = partial
        .time_scan
        .iter()
        .filter(|s| s.continued && s.cost.is_some())
        .map(|s| s.span)
        .collect();
    assert!(continued.len() >= 2, "{:?}", partial.time_scan);
    assert!(
        partial.time_scan.iter().any(|s| s
            .stopped
            .as_deref()
            .is_some_and(|w| w.starts_with("the continuation in b - a from b_p stopped"))),
        "{:?}",
        partial.time_scan
    );
    let last = partial.routes.last().expect("routes");
    assert_eq!(last.route, TIME_SCAN);
    assert!(last.stopped.is_some());
    // Controls with a vanishing xi along the projected segment cost less than every
    // fixed-time extremal of the scan, at a much shorter b - a; with eta > 0 their cost grows
    // again as b -> a, so the stop does not claim that no optimal time exists.
    let found = partial
        .collapse
        .as_ref()
        .expect("collapse evidence on a free-time stop");
    eprintln!("{found:?}");
    let least_scan = solved.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    assert_eq!(found.compared_cost, least_scan);
    assert!(found.undercuts && !found.no_optimal_time, "{found:?}");
    assert!(found.least.span < solved[0].0, "{found:?}");
    assert!(
        reason.contains("less than every fixed-time extremal"),
        "{reason}"
    );
}

/// The paper's eta = 1 problem with a wide sigmoid (`width = 0.1`): the desired path leaves
/// the energy ellipsoid by more than the third case allows, so the default start (tracking from
/// 0) fails to converge; the desired-start route (the full tracking weight from the start, the
/// projection of the desired path as Omega_p) solves it, verified, near the paper's b.
#[test]
fn a_wide_spiral_sigmoid_solves_by_the_desired_start() {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paper_eta1.toml"),
    )
    .expect("the paper's file");
    assert!(text.contains("width = 0.01\n"));
    let loaded = suslov::config::from_toml_str(&text.replace("width = 0.01\n", "width = 0.1\n"))
        .unwrap_or_else(|e| panic!("{e}"));
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("a route solves it");
    let routes = solved_by(&sol);
    assert_eq!(routes, [("default", false), ("desired start", true)]);
    assert!(sol.routes[0]
        .stopped
        .as_deref()
        .is_some_and(|r| r.contains("analytic start")));
    assert_eq!(sol.start.case, 3);
    assert!(lie::verify_solution(&sol).verification.passed());
    assert!(
        (sol.terminal_time() - 11.36).abs() < 0.05,
        "{}",
        sol.terminal_time()
    );
}

/// Corpus problem fast-078 (gamma = 0, free time, |Omega_a| = 21.7): the default route stops
/// in the gamma stage; the joint route reaches the target weights. There the polish at 1e-8
/// used to fail on its first solve and reach 1e-8 only by stepping the tolerance down from the
/// continuation's (1729 nodes); its Newton corrections stall below the tolerance, at rounding
/// level, and since Newton stops rounding-limited there (`bvp::newton`) the first solve
/// converges (267 nodes): the same b and cost (5e-12 relative), verified.
#[test]
fn a_polish_limited_by_rounding_converges_at_once() {
    let sol = polished_rounding_limited(
        "fast_078_polish_steps.toml",
        6.517842210645527,
        23.839536323653604,
    );
    assert_eq!(
        solved_by(&sol),
        [("default", false), ("joint weights", true)]
    );
}

/// `file` (a hard file) solved with default settings, its polish completed with at least one
/// rounding-limited Newton stop, verified, at `b` and `cost` (session 16's values) to 1e-9.
fn polished_rounding_limited(
    file: &str,
    b: f64,
    cost: f64,
) -> lie::LieSolution<suslov::model::generated::So3> {
    let loaded = hard(file);
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    let polish = sol.stages.last().expect("stages");
    assert_eq!(polish.name, "polish");
    assert!(polish.outcome.is_completed());
    assert!(sol.bvp.stats.rounding_limited >= 1, "{:?}", sol.bvp.stats);
    let v = lie::verify_solution(&sol);
    assert!(v.verification.passed(), "{:?}", v.verification.verdict());
    let got = sol.terminal_time();
    assert!((got - b).abs() < 1e-9 * b, "{file}: b = {got}");
    assert!(
        (sol.cost() - cost).abs() < 1e-9 * cost,
        "{file}: J = {}",
        sol.cost()
    );
    sol
}

/// A solution reached past a fold is certified in its summary (it could be a saddle): the
/// summary of a solution whose stage record lists a fold carries the certificate's verdict;
/// one without folds carries none.
#[test]
fn a_solution_past_a_fold_carries_its_certificate_in_the_summary() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/segment.toml");
    let loaded = suslov::config::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let mut sol = suslov::solve(&loaded.problem, &loaded.options, &mut |_| {}).expect("solves");
    let plain = suslov::app::summarize("segment", &sol, 0.0);
    assert!(!plain.extra.contains_key("after_fold"));
    // As if the beta stage had gone round a fold at beta = 0.05.
    let stage = sol
        .generic
        .stages
        .iter_mut()
        .find(|s| s.name == "beta")
        .expect("a beta stage");
    stage.folds.push(0.05);
    let summary = suslov::app::summarize("segment", &sol, 0.0);
    let after = &summary.extra["after_fold"];
    assert_eq!(after["folds"], serde_json::json!([0.05]));
    assert_eq!(after["verdict"], "certified", "{after}");
}

/// A start that fails on every route (corpus problem spiral-088, fixed b): the error is the
/// start's, and its message lists every other route tried with why it stopped.
#[test]
fn a_start_that_fails_on_every_route_lists_them_all() {
    let loaded = hard("spiral_088_start_fails.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let err = lie::solve(&problem, &loaded.options, &mut |_| {}).expect_err("no route starts");
    let LieSolveError::Start {
        reason: message, ..
    } = err
    else {
        panic!("the start fails on every route: {err}");
    };
    for route in [
        "desired start: ",
        "segment start: ",
        "finer mesh: ",
        "start at the target beta: ",
        "shorter horizon: ",
        "smaller beta_m: ",
    ] {
        assert!(message.contains(route), "{route} not in {message}");
    }
    // Each shorter horizon tried says why it stopped.
    let span = problem.terminal.initial() - problem.t0;
    for factor in lie::solve::HORIZON_FACTORS {
        let from = format!("from b - a = {}: ", factor * span);
        assert!(message.contains(&from), "{from} not in {message}");
    }
}

/// The longest mesh step of `sol` in physical time and `max |Ω|` over its nodes: their product
/// bounds how far one mesh interval turns.
fn longest_step_and_fastest_turn(sol: &lie::LieSolution<suslov::model::so3::So3>) -> (f64, f64) {
    use suslov::model::generated::{N_STATE, OMEGA};
    let omega_max = sol
        .bvp
        .y
        .chunks_exact(N_STATE)
        .map(|y| y[OMEGA].iter().map(|v| v * v).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    let longest = sol
        .bvp
        .x
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(0.0, f64::max)
        * sol.t_span;
    (longest, omega_max)
}

/// Issue #12's hard cases on the paper's data, its desired path held for 90 time units after
/// the spiral: every start at b = 100 fails (its Newton matrix is singular), and the route
/// from a shorter horizon solves both. Fixed b = 100: solved at b = 25, then b − a continued
/// to 100 (cost 33.0217089666 when measured, the same from b = 50); its mesh has intervals of
/// about 12 time units in the held stretch, which the re-integration check cuts into windows
/// of about a radian of rotation. Free b from the guess 100: from the guess 12.5 the
/// free-time homotopy ends at the paper's own solution.
#[test]
fn a_long_horizon_is_solved_from_a_shorter_one() {
    use suslov::lie::solve::SHORTER_HORIZON;
    let loaded = hard("paper_T100_fixed.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    assert_eq!(sol.routes.last().unwrap().route, SHORTER_HORIZON);
    assert!(
        sol.stages.iter().any(|s| s.name == "b - a"),
        "{:?}",
        sol.stages
    );
    assert_eq!(sol.terminal_time(), 100.0);
    let verified = lie::verify_solution(&sol);
    assert!(
        verified.verification.passed(),
        "{:?}",
        verified.verification
    );
    let cost = verified.diagnostics.cost;
    assert!((cost - 33.0217089666).abs() < 1e-8 * 33.0, "{cost}");
    // No re-integration window turns by much more than a radian, although some mesh
    // intervals turn by tens of radians.
    let windows =
        suslov::lie::verify::rotation_windows(&sol, lie::checks::REINTEGRATION_WINDOW_ANGLE);
    let (longest_interval, omega_max) = longest_step_and_fastest_turn(&sol);
    assert!(
        longest_interval * omega_max > 10.0,
        "{longest_interval} {omega_max}"
    );
    for (t0, t1) in windows {
        assert!(
            (t1 - t0) * omega_max < 2.0 * lie::checks::REINTEGRATION_WINDOW_ANGLE + 0.5,
            "{t0}..{t1}"
        );
    }

    let loaded = hard("paper_T100_free.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    assert_eq!(sol.routes.last().unwrap().route, SHORTER_HORIZON);
    let verified = lie::verify_solution(&sol);
    assert!(
        verified.verification.passed(),
        "{:?}",
        verified.verification
    );
    // The paper's η = 1 case (README: b = 11.359616203476826, J = 15.39476077133997).
    assert!(
        (sol.terminal_time() - 11.359616203476826).abs() < 1e-8,
        "{}",
        sol.terminal_time()
    );
    let cost = verified.diagnostics.cost;
    assert!((cost - 15.39476077133997).abs() < 1e-8, "{cost}");
}

/// Corpus problem samples-071: the first free-time solve ("free-time start") fails. Its
/// partial result is the fixed-time member it stood on (a free-time problem whose solution has
/// no unknown T once made the diagnostics index an empty parameter vector), and the fixed-time
/// scan says where the optimal time lies.
#[test]
fn a_failed_first_free_time_solve_leaves_a_consistent_partial() {
    let (stage, reason, partial) = stopped("samples_071_free_time_start.toml");
    assert_eq!(stage, "free-time start");
    assert!(reason.contains("J*(T) increases with T"), "{reason}");
    assert!(matches!(
        partial.problem.terminal,
        suslov::lie::problem::TerminalTime::Fixed(_)
    ));
    assert!(partial.bvp.p.is_empty());
    // The checks run on it (they index T only for a free-time problem).
    let checked = lie::verify_solution(&partial);
    assert!(checked.diagnostics.cost.is_finite());
}

/// Corpus problem spiral-108: the paper's spiral, fixed b while the path still settles, so the
/// projected desired path misses Ω_b (Property 1 fails) and the default segment start does not
/// converge. The desired start bends the desired path to Ω_a and Ω_b over the first and last
/// quarter of [a, b] and solves the problem, verified.
#[test]
fn a_desired_path_that_misses_omega_b_is_bent_to_it_for_the_desired_start() {
    let loaded = hard("spiral_108_bent_desired.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("a route solves it");
    let routes = solved_by(&sol);
    assert_eq!(routes, [("default", false), ("desired start", true)]);
    assert_eq!(sol.start.omega_p, suslov::lie::solve::BENT_DESIRED);
    assert_eq!(sol.start.case, 3);
    assert!(lie::verify_solution(&sol).verification.passed());
}

/// Corpus problem long-134 (fixed b − a = 44.7): until session 19 the polish at 1e-8 met the
/// solver's error estimate on a mesh whose longest intervals turn by more than a radian, the
/// windowed re-integration check (windows cut at mesh nodes only) failed, and the refine stage
/// solved again at a 10 times tighter tolerance on a finer mesh. Since the check also cuts such
/// intervals into windows of about a radian, the polished solution passes it at the requested
/// tolerance and no refine stage runs.
#[test]
fn a_mesh_interval_that_turns_far_is_checked_in_windows_of_its_own() {
    let loaded = hard("long_134_refine.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("the default solves it");
    assert_eq!(solved_by(&sol), [("default", true)]);
    let names: Vec<&str> = sol.stages.iter().map(|s| s.name).collect();
    assert_eq!(names.last(), Some(&"polish"), "{names:?}");
    assert_eq!(
        sol.tolerance, loaded.options.tol,
        "judged at the requested tolerance"
    );
    let verified = lie::verify_solution(&sol);
    assert!(
        verified.verification.passed(),
        "{:?}",
        verified.verification
    );
    // Some interval turns by more than a radian: the windows inside it are what changed.
    let (longest, omega_max) = longest_step_and_fastest_turn(&sol);
    assert!(longest * omega_max > 1.0, "{longest} {omega_max}");
    let windows = verified.reintegration.as_ref().unwrap().windows;
    assert!(windows > sol.bvp.x.len() / 100, "{windows}");
}

/// Corpus problem issue12-124 (γ = 0, fixed b − a = 14.1): natural continuation of every route
/// stalls just short of γ = 0, where the branch has two folds 2e-4 apart in the stage's
/// parameter. Pseudo-arclength with small enough steps passes both, and the joint route
/// reaches the target weights; its summary carries the second-order certificate (a solution
/// past a fold could be a saddle), which certifies a local minimum.
#[test]
fn a_branch_through_two_folds_reaches_the_target_and_is_certified() {
    let loaded = hard("issue12_124_two_folds.toml");
    let sol = suslov::solve(&loaded.problem, &loaded.options, &mut |_| {}).expect("solves");
    let routes = solved_by(&sol.generic);
    assert_eq!(routes, [("default", false), ("joint weights", true)]);
    let weights = sol
        .generic
        .stages
        .iter()
        .find(|s| s.name == "weights")
        .expect("the joint stage");
    assert_eq!(weights.folds.len(), 2, "{weights:?}");
    assert!(
        weights.folds.iter().all(|&f| f > 0.999 && f < 1.0),
        "{weights:?}"
    );
    assert!(lie::verify_solution(&sol.generic).verification.passed());
    let summary = suslov::app::summarize("issue12-124", &sol, 0.0);
    let after = &summary.extra["after_fold"];
    assert_eq!(after["folds"].as_array().map(Vec::len), Some(2), "{after}");
    assert_eq!(after["verdict"], "certified", "{after}");
}

/// Corpus problem fast-199 (γ = 0): every continuation route stalls just short of γ = 0, and the default
/// route's stop carries the evidence that its branch turns singular there: the boundary
/// conditions' condition number grew by more than 10 along the stage (measured: 5.2e2 →
/// 7.2e3). (The furthest route, β first, follows a branch through γ = 0 to γ = −0.02 by
/// pseudo-arclength, but the solve at γ = 0 itself fails.)
#[test]
fn a_branch_that_turns_singular_says_so() {
    // Since session 33 the direct start solves the file (tests/missed_regular.rs); the
    // default route still stops in the γ stage, and says why.
    let loaded = hard("fast_199_gamma_zero_singular.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("the direct start");
    let default = sol.routes[0].stopped.as_deref().unwrap_or_default();
    assert!(default.starts_with("stage 'gamma'"), "{default}");
    assert!(
        default.contains("lambda crossed the stop value"),
        "{default}"
    );
    assert!(
        default.contains("the boundary conditions' condition number grew from"),
        "{default}"
    );
}

/// Corpus problem spiral-028 (β = 1.4e-3, a spiral at a fixed b): every analytic start fails
/// at `β_m` = β/100 (the default), β/10 and β/1000, and the desired start at `β_m = β` solves
/// it (no β stage), verified.
#[test]
fn a_start_too_stiff_at_a_small_beta_m_solves_at_the_target_beta() {
    use suslov::lie::solve::BETA_M_AT_BETA;
    let loaded = hard("spiral_028_start_at_beta.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("a route solves it");
    let routes = solved_by(&sol);
    assert_eq!(routes.last(), Some(&(BETA_M_AT_BETA, true)), "{routes:?}");
    assert!(routes[..routes.len() - 1].iter().all(|r| !r.1));
    assert!(sol.routes[0]
        .stopped
        .as_deref()
        .is_some_and(|r| r.starts_with("cannot build the analytic start")));
    let names: Vec<&str> = sol.stages.iter().map(|s| s.name).collect();
    assert!(!names.contains(&"beta"), "{names:?}");
    assert_eq!(
        sol.start.beta_m,
        problem.params()[suslov::model::generated::idx::BETA]
    );
    let v = lie::verify_solution(&sol);
    assert!(v.verification.passed(), "{:?}", v.verification.verdict());
}

/// Corpus problem fast-038 (free time, α = 0.18 against β = 2.57): its solution's ξ nearly
/// vanishes (min |ξ| 0.014). The polish from 1e-7 to 1e-8 used to fail there (Newton matrix
/// "singular or too ill-conditioned") and the stop said that ξ collapses; its Newton
/// corrections stall below the tolerance at rounding level, and since Newton stops
/// rounding-limited (`bvp::newton`) the polish converges: solved and verified, at the b and
/// cost of session 16's partial result (which passed every check at 1e-8 too) to 1e-9.
#[test]
fn a_polish_where_xi_nearly_vanishes_converges_rounding_limited() {
    let sol = polished_rounding_limited(
        "fast_038_polish_collapse.toml",
        15.416155959628533,
        20.6610100354725,
    );
    let min_xi = min_xi(&sol.bvp);
    assert!(min_xi < 0.05, "{min_xi}");
}

/// Corpus problem fast-139 (α = 0.16 against β = 2.98): its solution's ξ nearly vanishes
/// (min |ξ| 0.011). With the sparse LU of session 9 the polish from 1e-7 to 1e-8 failed on it;
/// with the structured QR of the Newton matrix (#13) the polish converges: solved and
/// verified this close to the collapse.
#[test]
fn a_solution_whose_xi_nearly_vanishes_is_polished_and_verified() {
    let loaded = hard("fast_139_polish_collapse.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    let polish = sol.stages.last().expect("stages");
    assert_eq!(polish.name, "polish");
    assert!(polish.outcome.is_completed());
    let min_xi = min_xi(&sol.bvp);
    assert!(min_xi < 0.05, "{min_xi}");
    let v = lie::verify_solution(&sol);
    assert!(v.verification.passed(), "{:?}", v.verification.verdict());
}

/// Corpus problem short-116 (fixed b): every continuation route stops where ξ collapses, but
/// the problem has a regular minimum. The direct start (SQP on the transcribed problem from
/// the projected segment's inverse dynamics, then one BVP solve) reaches it: verified, |ξ|
/// near 1, certified a local minimum, and cheaper than the minimum IPOPT found from its own
/// guesses (7.17345693, with a dip of |ξ| to 0.0103; bench/README.md).
#[test]
fn a_regular_minimum_no_branch_reaches_is_found_by_the_direct_start() {
    use suslov::lie::solve::DIRECT_START_ROUTE;
    use suslov::ocp::{NewtonOptions, SecondOrderOptions, Verdict};
    let loaded = hard("short_116_direct_start.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    let routes = solved_by(&sol);
    eprintln!("{routes:?}");
    assert_eq!(
        routes.last(),
        Some(&(DIRECT_START_ROUTE, true)),
        "{routes:?}"
    );
    assert!(
        routes[..routes.len() - 1].iter().all(|r| !r.1),
        "{routes:?}"
    );
    assert_eq!(sol.stages[0].name, DIRECT_START_ROUTE);
    let checked = lie::verify_solution(&sol);
    assert!(checked.verification.passed(), "{:?}", checked.verification);
    let cost = checked.diagnostics.cost;
    // Measured 7.1606861 (the SQP's discrete minimum on 100 intervals: 7.16068614).
    assert!((cost - 7.1606861).abs() < 1e-6, "{cost}");
    assert!(cost < 7.17345693 - 1e-3, "{cost}");
    assert!(min_xi(&sol.bvp) > 0.9, "{}", min_xi(&sol.bvp));
    let cert = lie::certify::certify(
        &sol,
        &NewtonOptions::default(),
        &SecondOrderOptions::default(),
    )
    .expect("certificate");
    assert_eq!(cert.verdict(), Verdict::Certified);
}

/// Corpus problem spiral-088 (fixed b): the analytic start fails on every route, so there is
/// no partial solution to compare with. The direct start's SQP (the multiplier form) converges
/// to a minimum whose ξ collapses (min |ξ| 4.5e-3 when measured); a control with a vanishing ξ
/// along its motion, re-integrated, costs no more than that minimum (85.3639 against the
/// discrete 85.3801 when measured). The start failure says so.
#[test]
fn a_failed_start_is_explained_by_the_direct_minimum() {
    let loaded = hard("spiral_088_start_fails.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let (reason, found) = match lie::solve(&problem, &loaded.options, &mut |_| {}) {
        Err(LieSolveError::Start { reason, collapse }) => {
            (reason, collapse.expect("the direct minimum's evidence"))
        }
        Err(other) => panic!("expected a failed start, got {other}"),
        Ok(_) => panic!("expected a failed start, got a solution"),
    };
    assert!(
        reason.contains("the direct method's minimum of the transcribed problem costs"),
        "{reason}"
    );
    assert!(
        reason.contains("the minimizing controls collapse, the infimum is approached as xi -> 0"),
        "{reason}"
    );
    // The cheapest control with a vanishing xi follows the relaxed minimum's motion (measured
    // 85.363837, the relaxed minimum 85.3638370 on 200 intervals), below the direct minimum's
    // motion (85.3639 in session 15) and the discrete minimum (85.3801).
    let number_after = |key: &str| -> f64 {
        let at = reason
            .find(key)
            .unwrap_or_else(|| panic!("{key}: {reason}"))
            + key.len();
        reason[at..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let cost =
        number_after("along the motion of the relaxed problem's minimum (xi -> 0) costs J = ");
    assert!((cost - 85.363837).abs() < 1e-5, "{cost}");
    let relaxed = number_after("has its minimum at J = ");
    assert!((relaxed - 85.363837).abs() < 1e-5, "{relaxed}");
    // The evidence the error carries says the same: compared with the discrete minimum, the
    // relaxed minimum's control is the cheapest, and it is what `suslov solve` writes as the
    // ε-optimal control (tests/relaxed.rs).
    assert!(found.undercuts, "{found:?}");
    assert_eq!(
        found.least.motion,
        suslov::lie::collapse::Motion::RelaxedMinimum
    );
    assert!(
        (found.least.cost - 85.363837).abs() < 1e-5,
        "{:?}",
        found.least
    );
    assert!(found.compared_cost > found.least.cost, "{found:?}");
    assert!(found.sentence.contains("the minimizing controls collapse"));
}

/// Corpus problem spiral-149 (fixed b): every continuation route stops; the direct start in
/// the reduced form solves it (cost 0.0078319 when measured), and in the multiplier form it
/// lands on another minimum, cheaper (0.0065374267 when measured), which is kept: verified,
/// and certified a local minimum.
#[test]
fn the_cheaper_of_the_two_direct_minima_is_kept() {
    use suslov::lie::solve::DIRECT_START_ROUTE;
    use suslov::ocp::{NewtonOptions, SecondOrderOptions, Verdict};
    let loaded = hard("spiral_149_two_direct_minima.toml");
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    let routes = solved_by(&sol);
    assert_eq!(
        routes.last(),
        Some(&(DIRECT_START_ROUTE, true)),
        "{routes:?}"
    );
    let checked = lie::verify_solution(&sol);
    assert!(checked.verification.passed(), "{:?}", checked.verification);
    let cost = checked.diagnostics.cost;
    assert!((cost - 0.0065374267).abs() < 1e-9, "{cost}");
    assert!(cost < 0.0078319 * 0.9, "{cost}");
    let cert = lie::certify::certify(
        &sol,
        &NewtonOptions::default(),
        &SecondOrderOptions::default(),
    )
    .expect("certificate");
    assert_eq!(cert.verdict(), Verdict::Certified);
}
