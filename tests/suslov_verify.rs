//! "Converged" is gated by the a-posteriori checks (`suslov::lie::verify`): a loose tolerance is
//! never reported converged, the paper's cases still are (unchanged), the measured ratios
//! behind the thresholds (docs/verification.md) hold, and a stage that fails says
//! so in its `StageFinished` event.

use std::path::Path;

use suslov::lie::checks::{
    Verdict, Verification, K_CONSTRAINT, K_ENERGY, K_LOCAL_ERROR, K_REINTEGRATION,
    REINTEGRATION_FLOOR, TOLERANCE, TOL_MAX,
};
use suslov::so3::solve::{solve, Event, SolveError, SolveOptions, StageOutcome, StartStrategy};
use suslov::{paper, SuslovSolution};

/// The checks of a so(3) solution (the generic layer's, on its model `so3` solution).
fn verify_solution(sol: &SuslovSolution) -> Verification {
    suslov::lie::verify_solution(&sol.generic).verification
}

fn example(name: &str) -> suslov::config::LoadedProblem {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name);
    suslov::config::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn solved(name: &str, tol: f64) -> SuslovSolution {
    let loaded = example(name);
    let options = SolveOptions {
        tol,
        ..loaded.options
    };
    solve(&loaded.problem, &options, &mut |_| {}).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The tester's defect: `solver.tolerance = 1.0` converged on 4 nodes and was reported
/// "converged". The solver still succeeds there; the summary must not say converged.
#[test]
fn a_loose_tolerance_is_not_reported_converged() {
    for tol in [1.0, 1e-2] {
        let sol = solved("segment.toml", tol);
        assert!(
            sol.generic.bvp.is_success(),
            "the BVP solve itself succeeds"
        );
        let summary = suslov::app::summarize("segment", &sol, 0.0);
        assert!(
            summary.status.starts_with("unverified: "),
            "tol = {tol}: {}",
            summary.status
        );
        let v = summary.verification.expect("verification recorded");
        assert!(!v.passed);
        assert_eq!(v.tolerance, tol);
        assert_eq!(v.effective_tolerance, TOL_MAX);
        let failed: Vec<&str> = v
            .checks
            .iter()
            .filter(|c| !c.passed)
            .map(|c| c.name.as_str())
            .collect();
        // Not only the tolerance rule: judged at 1e-4, the quantities themselves fail.
        assert!(failed.contains(&TOLERANCE), "{failed:?}");
        assert!(failed.contains(&"local_error"), "{failed:?}");
        assert!(failed.contains(&"energy"), "{failed:?}");
        assert!(
            summary.status.contains("local_error = "),
            "{}",
            summary.status
        );
    }
}

/// End to end through `run_case`: status and the verification block in `summary.json`.
#[test]
fn run_case_records_an_unverified_loose_solve_in_summary_json() {
    let dir = std::env::temp_dir().join(format!("suslov-unverified-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let loaded = example("segment.toml");
    let options = SolveOptions {
        tol: 1.0,
        ..loaded.options
    };
    let mut out = suslov::report::OutputDir::open(&dir).expect("output directory");
    let case = suslov::app::run_case(
        "segment",
        &loaded.problem,
        (&mut out, std::path::Path::new("")),
        &options,
        &suslov::app::OutputOptions::default(),
        &mut |_| {},
    )
    .expect("outputs written");
    drop(out);
    // Only a verified solution looks final.
    assert!(dir.join("trajectory.unverified.csv").exists());
    assert!(!dir.join("trajectory.csv").exists());
    assert!(!dir.join("omega.png").exists());
    assert_ne!(case.status, "converged");
    assert!(case.status.starts_with("unverified: "), "{}", case.status);
    let summary = suslov::report::Summary::new(vec![case]);
    let text = summary.to_json_string().expect("json");
    let v: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
    let checks = v["cases"][0]["verification"]["checks"]
        .as_array()
        .expect("checks");
    assert_eq!(checks.len(), 7);
    for c in checks {
        for key in ["name", "quantity", "value", "threshold", "passed"] {
            assert!(c.get(key).is_some(), "{key} missing in {c}");
        }
    }
    assert_eq!(v["cases"][0]["verification"]["passed"], false);
    std::fs::remove_dir_all(&dir).ok();
}

/// The paper's two cases at the default options: converged, every quantity check passed with
/// a margin of at least 10, and b and the cost exactly as recorded (from `suslov paper`; the
/// gate only judges a solution and must not change it). Re-recorded when the generator moved
/// to model files: sympy orders the terms of a sum by symbol name, so renaming intermediates of
/// the generated code reordered a few sums; that moved b (eta = 1) by 5e-16 relative
/// (11.35961620347682 -> ...826) and the costs by 6e-16 and 2e-15 (was 15.394760771339975 and
/// 2.6658490597410194). Re-recorded again when the so(3) layer handed its solve to the generic
/// layer (the same homotopy written over slices, whose sums round differently): b (eta = 1)
/// 11.359616203476826 -> ...827, the costs 15.394760771339984 -> ...985 and
/// 2.6658490597410136 -> ...167 (1e-16 to 1.2e-15 relative). Re-recorded when the Newton
/// matrix went from faer's sparse LU to the structured QR (#13; other rounding): b (eta = 1)
/// 11.359616203476824 -> ...822, the costs 15.394760771339968 -> ...978 and
/// 2.665849059741015 -> 2.6658490597410074 (2e-16 to 2.8e-15 relative). Re-recorded when
/// the Newton matrix went to structured LU and the stage blocks to block elimination (#13,
/// branch s12-speed; other rounding): b (eta = 1) 11.359616203476822 -> ...826, b (eta =
/// 0.01) unchanged, the costs 15.394760771339978 -> ...97 and 2.6658490597410074 -> ...136
/// (3e-16 to 2.3e-15 relative). Re-recorded when boundary rows that are separated (the
/// paper's are) got their own elimination (`Factorization::SeparatedLu`, #13; other
/// rounding): both b unchanged, the costs 15.39476077133997 -> ...978 and
/// 2.6658490597410136 -> ...015 (5e-16 relative).
#[test]
fn the_paper_cases_still_converge_with_unchanged_results() {
    for (eta, b, cost) in [
        (1.0, 11.359616203476826, 15.394760771339978),
        (0.01, 9.838326431487959, 2.665849059741015),
    ] {
        let sol = solve(&paper::problem(eta), &SolveOptions::default(), &mut |_| {})
            .unwrap_or_else(|e| panic!("{e}"));
        let summary = suslov::app::summarize("paper", &sol, 0.0);
        assert_eq!(summary.status, "converged", "eta = {eta}");
        // Bit for bit: the gate only judges the solution, it must not change it.
        assert_eq!(summary.terminal_time, b, "eta = {eta}");
        assert_eq!(summary.cost, cost, "eta = {eta}");
        let v = verify_solution(&sol);
        assert_eq!(v.verdict(), Verdict::Verified);
        for c in v.checks.iter().filter(|c| c.name != TOLERANCE) {
            assert!(
                c.value <= c.threshold / 10.0,
                "eta = {eta}: {} = {:e}, threshold {:e}",
                c.name,
                c.value,
                c.threshold
            );
        }
    }
}

/// The README's table of `value / tol` (release build) for two examples: the ratios come out
/// as recorded (within 10 %; re-integration within a factor 2, see below), and each is at
/// least 10 times below its K.
#[test]
fn measured_ratios_match_the_readme_table() {
    // (file, tol, local error, constraint, energy, re-integration), each divided by tol. The
    // re-integration is the windowed one (restarted every radian of rotation, 9 to 12 windows
    // here), re-measured when it replaced the open-loop one (2.09e-3, 1.11e-3, 7.88e-3).
    let table = [
        ("segment.toml", 1e-6, 7.69e-1, 1.55e-2, 4.88e-2, 2.92e-3),
        ("segment.toml", 1e-8, 1.26e0, 2.19e-2, 5.43e-2, 1.11e-3),
        ("no_tracking.toml", 1e-8, 4.71e-1, 2.63e-3, 1.60e-1, 2.83e-3),
    ];
    for (file, tol, loc, con, en, re) in table {
        let v = verify_solution(&solved(file, tol));
        let ratio = |name: &str| v.check(name).expect(name).value / tol;
        for (name, recorded, k) in [
            ("local_error", loc, K_LOCAL_ERROR),
            ("constraint", con, K_CONSTRAINT),
            ("energy", en, K_ENERGY),
            ("reintegration", re, K_REINTEGRATION),
        ] {
            let r = ratio(name);
            // Re-integration at tol <= 1e-6 sits at the IVP integrator's own error floor, so
            // a rounding change in the model code moves it by tens of percent (9.13e-3 ->
            // 7.88e-3 for no_tracking at 1e-8 when sums were reordered): a factor 2 there;
            // the margin to K below is the real guard.
            let within = if name == "reintegration" {
                (0.5..=2.0).contains(&(r / recorded))
            } else {
                (r / recorded - 1.0).abs() <= 0.1
            };
            assert!(
                within,
                "{file} at {tol:e}: {name} / tol = {r:.3e}, README {recorded:.3e}"
            );
            assert!(
                r * 10.0 <= k,
                "{file} at {tol:e}: {name} / tol = {r:.3e}, K = {k}"
            );
        }
        // Newton meets the boundary conditions to rounding.
        assert!(ratio("omega_b") <= 1e-6 && ratio("boundary_conditions") <= 1e-6);
        assert_eq!(v.verdict(), Verdict::Verified, "{file} at {tol:e}");
        let re_threshold = v.check("reintegration").expect("reintegration").threshold;
        assert_eq!(re_threshold, K_REINTEGRATION * tol + REINTEGRATION_FLOOR);
    }
}

/// The terminal-condition checks can fail: the same solution judged against a moved `Ω_b`.
#[test]
fn a_solution_of_another_problem_fails_its_boundary_checks() {
    let mut sol = solved("segment.toml", 1e-8);
    assert_eq!(verify_solution(&sol).verdict(), Verdict::Verified);
    for v in &mut sol.generic.problem.omega_b {
        *v *= 1.0 + 1e-6;
    }
    let v = verify_solution(&sol);
    let failed: Vec<&str> = v.failures().map(|c| c.name).collect();
    assert_eq!(failed, ["omega_b", "boundary_conditions"]);
    match v.verdict() {
        Verdict::Unverified { reason } => {
            assert!(
                reason.starts_with("omega_b = 1.000e-6 exceeds 1.000e-8"),
                "{reason}"
            )
        }
        Verdict::Verified => panic!("verified against the wrong Omega_b"),
    }
}

/// The `reintegration` check can fail: the same solution with its control `ξ̇` moved by a
/// relative 1e-6 (the constraint and the energy do not see it: they use `Ω` and `ξ` only), and
/// judged against a problem whose third moment of inertia is 1e-6 larger (`Ω_a` and `Ω_b`
/// of segment.toml have no third component, so both stay on the same level set).
#[test]
fn a_perturbed_control_or_inertia_fails_the_windowed_reintegration() {
    use suslov::lie::checks::REINTEGRATION_WINDOW_ANGLE;
    use suslov::lie::verify::reintegrate_windowed;
    use suslov::lie::Problem;
    use suslov::model::generated::So3;
    use suslov::model::Model;

    let sol = solved("segment.toml", 1e-8);
    let verified = suslov::lie::verify_solution(&sol.generic);
    assert_eq!(verified.verification.verdict(), Verdict::Verified);
    let windows = verified.reintegration.as_ref().expect("runs").windows;
    assert!(windows > 1, "segment.toml turns by more than one radian");
    let failed_of = |v: &Verification| v.failures().map(|c| c.name).collect::<Vec<&str>>();

    // ξ̇ moved by a constant 1e-6 max |ξ̇| at every node (and so in every interval).
    let mut perturbed = sol.generic.clone();
    let n = So3::N_STATE;
    let nodes = perturbed.bvp.x.len();
    let xidot_max = (0..nodes)
        .flat_map(|i| perturbed.bvp.y[i * n..(i + 1) * n][So3::XIDOT].to_vec())
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    for i in 0..nodes {
        for v in &mut perturbed.bvp.y[i * n..(i + 1) * n][So3::XIDOT] {
            *v += 1e-6 * xidot_max;
        }
    }
    let v = suslov::lie::verify_solution(&perturbed).verification;
    let failed = failed_of(&v);
    assert!(failed.contains(&"reintegration"), "{failed:?}");
    assert!(!failed.contains(&"constraint") && !failed.contains(&"energy"));
    let r = v.check("reintegration").expect("reintegration");
    assert!(
        r.value > 10.0 * r.threshold,
        "{} vs {}",
        r.value,
        r.threshold
    );
    let windowed = reintegrate_windowed(&perturbed, REINTEGRATION_WINDOW_ANGLE).expect("runs");
    assert_eq!(windowed.windows, windows, "the same mesh, the same windows");

    // The solution judged against a body whose third moment is 1e-6 larger.
    let mut other = sol.generic.clone();
    let p = &sol.generic.problem;
    let mut user = p.user_params().to_vec();
    user[So3::INERTIA_PARAMS[2].index] *= 1.0 + 1e-6;
    other.problem = Problem::<So3>::new(
        &user,
        p.t0,
        p.omega_a.clone(),
        p.omega_b.clone(),
        p.terminal,
        p.desired.clone(),
    )
    .expect("the same level set");
    let v = suslov::lie::verify_solution(&other).verification;
    let failed = failed_of(&v);
    assert!(failed.contains(&"reintegration"), "{failed:?}");
    let r = v.check("reintegration").expect("reintegration");
    assert!(
        r.value > 10.0 * r.threshold,
        "{} vs {}",
        r.value,
        r.threshold
    );
}

/// "A failing stage still prints 'stage … done'": the `StageFinished` event of a failed stage
/// carries the failure, and so does the summary's stage record.
#[test]
fn a_failing_stage_says_so_in_its_stage_finished_event() {
    // The polish at 1e-8 needs ~280 nodes; capped at 230 it stops with MaxNodes (see
    // tests/suslov_problem.rs).
    let options = SolveOptions {
        max_nodes: 230,
        ..Default::default()
    };
    let mut finished: Vec<(&'static str, StageOutcome)> = Vec::new();
    let result = solve(&paper::problem(0.01), &options, &mut |e| {
        if let Event::StageFinished(r) = e {
            finished.push((r.name, r.outcome.clone()));
        }
    });
    let Err(SolveError::StageFailed { stage, partial, .. }) = result else {
        panic!("the polish must fail");
    };
    assert_eq!(stage, "polish");
    let (last, outcome) = finished.last().expect("events");
    assert_eq!(*last, "polish");
    match outcome {
        StageOutcome::Stopped { reason } => assert!(
            reason.contains("more mesh nodes than allowed") && reason.contains("solver.max_nodes"),
            "{reason}"
        ),
        StageOutcome::Completed => panic!("a failed polish reported as completed"),
    }
    assert!(finished[..finished.len() - 1]
        .iter()
        .all(|(_, o)| o.is_completed()));
    let summary = suslov::app::summarize("capped", &partial, 0.0);
    let stages = &summary.stages;
    assert!(stages
        .last()
        .expect("stages")
        .outcome
        .starts_with("stopped: "));
    assert!(stages[..stages.len() - 1]
        .iter()
        .all(|s| s.outcome == "completed"));

    // A start that fails (the paper's problem forced to the segment start, docs/paper.md "Choices
    // made") ends its stage with the reason too.
    // One route: one stage event.
    let options = SolveOptions {
        start: StartStrategy::Segment,
        max_routes: 1,
        ..Default::default()
    };
    let mut finished = Vec::new();
    let result = solve(&paper::problem(0.01), &options, &mut |e| {
        if let Event::StageFinished(r) = e {
            finished.push((r.name, r.outcome.clone()));
        }
    });
    assert!(matches!(result, Err(SolveError::Start { .. })));
    assert_eq!(finished.len(), 1);
    assert_eq!(finished[0].0, "start");
    assert!(!finished[0].1.is_completed());
    // Every route: the forced start is kept (no "segment start" route); the start at the
    // target beta succeeds (from the forced segment) and that route stops in a later stage,
    // the furthest any route got, so its stop is the error, and every route tried is listed
    // with why it stopped.
    let options = SolveOptions {
        max_routes: 1 + 3,
        ..options
    };
    let mut finished = Vec::new();
    let result = solve(&paper::problem(0.01), &options, &mut |e| {
        if let Event::StageFinished(r) = e {
            finished.push((r.name, r.outcome.clone()));
        }
    });
    let starts: Vec<bool> = finished
        .iter()
        .filter(|(name, _)| *name == "start")
        .map(|(_, o)| o.is_completed())
        .collect();
    // The fourth route, the shorter horizon, starts at b - a / 4 and / 8 and stops in the
    // gamma stage at both: its stops count as a failed start of the problem's own horizon.
    assert_eq!(starts, [false, false, true, true, true], "{finished:?}");
    let (_, outcome) = finished.last().expect("events");
    assert!(!outcome.is_completed());
    let Err(SolveError::StageFailed {
        stage,
        reason,
        partial,
        ..
    }) = result
    else {
        panic!("the furthest route stops in a stage");
    };
    let furthest = finished
        .iter()
        .rev()
        .find(|(name, _)| *name != "start")
        .expect("a later stage");
    assert_eq!(stage, furthest.0);
    assert!(!furthest.1.is_completed());
    assert!(
        reason.ends_with(&format!(
            "[on route '{}', the furthest of the routes tried]",
            suslov::lie::solve::BETA_M_AT_BETA
        )),
        "{reason}"
    );
    let routes: Vec<(&str, bool)> = partial
        .generic
        .routes
        .iter()
        .map(|r| (r.route, r.stopped.is_some()))
        .collect();
    assert_eq!(
        routes,
        [
            ("default", true),
            ("finer mesh", true),
            (suslov::lie::solve::BETA_M_AT_BETA, true),
            (suslov::lie::solve::SHORTER_HORIZON, true)
        ]
    );
}

/// `suslov certify` and `controllability --along` use the solution they get; an unverified
/// one is flagged.
#[test]
fn certify_and_rank_along_flag_an_unverified_solution() {
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/segment.toml");
    // `--tolerance 1e-2` is refused on the command line (no solution at it can pass); set
    // through the library, the gate still flags it.
    assert!(suslov::app::case_jobs(Some(&config), Some(1e-2)).is_err());
    let mut jobs = suslov::app::case_jobs(Some(&config), None).expect("jobs");
    jobs[0].options.tol = 1e-2;
    let along = suslov::app::run_rank_along(&jobs, 11, 1e-9, &mut |_| {}).expect("runs");
    assert!(!along.all_accessible);
    let text = along.text;
    assert!(
        text.contains("did not pass its a-posteriori checks (local_error = "),
        "{text}"
    );
    let reports = suslov::app::run_certify(&jobs, None, &mut |_| {}).expect("runs");
    let status = reports[0].solution_status.as_deref().expect("solved");
    assert!(status.starts_with("unverified: "), "{status}");
    assert!(reports[0]
        .text()
        .contains("did not pass its a-posteriori checks"));
    // At the example's own tolerance the solution is verified and nothing is flagged.
    let jobs = suslov::app::case_jobs(Some(&config), None).expect("jobs");
    let along = suslov::app::run_rank_along(&jobs, 11, 1e-9, &mut |_| {}).expect("runs");
    assert!(along.all_accessible);
    let text = along.text;
    assert!(!text.contains("a-posteriori"), "{text}");
}
