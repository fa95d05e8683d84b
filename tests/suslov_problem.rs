//! The Suslov problem layer: every invalid input gets a clear error naming the field, and the
//! `paper` job writes complete, parseable outputs.

use nalgebra::Vector3;
use suslov::so3::paper;
use suslov::so3::problem::{ProblemError, TerminalTime};

fn message(p: &suslov::so3::problem::SuslovProblem) -> String {
    p.validate().expect_err("invalid").to_string()
}

#[test]
fn the_paper_problem_is_valid() {
    for case in paper::CASES {
        paper::problem(case.eta).validate().expect("valid");
    }
}

#[test]
fn non_finite_numbers_name_their_field() {
    let mut p = paper::problem(1.0);
    p.weights.gamma = f64::NAN;
    assert!(message(&p).contains("gamma = NaN is not a finite number"));
    let mut p = paper::problem(1.0);
    p.omega_b[1] = f64::INFINITY;
    assert!(message(&p).contains("omega_b[1] = inf"));
}

#[test]
fn singular_weights_are_rejected_with_the_reason() {
    for (field, set) in [
        (
            "alpha",
            Box::new(|p: &mut suslov::so3::problem::SuslovProblem| p.weights.alpha = 0.0)
                as Box<dyn Fn(&mut _)>,
        ),
        (
            "beta",
            Box::new(|p: &mut suslov::so3::problem::SuslovProblem| p.weights.beta = -1.0),
        ),
    ] {
        let mut p = paper::problem(1.0);
        set(&mut p);
        let m = message(&p);
        assert!(m.starts_with(field), "{m}");
        assert!(
            m.contains("must be > 0") && m.contains("nonsingular"),
            "{m}"
        );
    }
    let mut p = paper::problem(1.0);
    p.weights.eta = -0.5;
    assert!(message(&p).contains("eta = -0.5: must be >= 0"));
}

#[test]
fn omega_b_off_the_ellipsoid_says_by_how_much_and_suggests_the_projection() {
    let mut p = paper::problem(1.0);
    p.omega_b *= 1.01;
    let e = p.validate().expect_err("off E");
    match &e {
        ProblemError::OffEllipsoid {
            mismatch,
            projection,
            ..
        } => {
            assert!((mismatch - (1.01f64.powi(2) - 1.0)).abs() < 1e-12);
            let proj = Vector3::from(*projection);
            assert!((proj - p.omega_b / 1.01).norm() < 1e-12);
        }
        other => panic!("wrong error {other:?}"),
    }
    let m = e.to_string();
    assert!(m.contains("omega_b") && m.contains("energy ellipsoid") && m.contains("projection"));
}

#[test]
fn degenerate_boundary_data_is_rejected() {
    let mut p = paper::problem(1.0);
    p.omega_a = Vector3::zeros();
    assert!(message(&p).contains("omega_a must be nonzero"));
    let mut p = paper::problem(1.0);
    p.terminal = TerminalTime::Fixed(-1.0);
    assert!(message(&p).contains("must be greater than t0"));
}

#[test]
fn solve_reports_an_invalid_problem_instead_of_panicking() {
    let mut p = paper::problem(1.0);
    p.weights.beta = 0.0;
    let err = suslov::so3::solve::solve(&p, &Default::default(), &mut |_| {})
        .expect_err("beta = 0 is singular");
    assert!(err.to_string().starts_with("invalid problem: beta"));
}

#[test]
fn the_paper_job_writes_complete_outputs() {
    let dir = std::env::temp_dir().join(format!("suslov-paper-job-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut wrote = Vec::new();
    let summary = suslov::app::run_paper(&dir, &mut |e| {
        if let suslov::app::AppEvent::Wrote(p) = e {
            wrote.push(p.to_path_buf());
        }
    })
    .expect("outputs written");
    assert_eq!(summary.cases.len(), 2);
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    let parsed: suslov::report::Summary = serde_json::from_str(&text).expect("valid JSON");
    assert_eq!(parsed.cases.len(), 2);
    for (case, published) in parsed.cases.iter().zip([11.36, 9.84]) {
        assert_eq!(case.status, "converged");
        assert!((case.terminal_time - published).abs() <= 0.01);
        assert!(case.reintegration_max_diff.expect("re-integrated") < 1e-7);
        assert_eq!(case.stability.len(), 2);
        let csv = std::fs::read_to_string(dir.join(&case.name).join("trajectory.csv"))
            .expect("trajectory.csv");
        let mut lines = csv.lines();
        assert_eq!(
            lines.next(),
            Some(
                "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3,kappa1,kappa2,kappa3,\
                 omegad1,omegad2,omegad3"
            )
        );
        // The uniform points and the mesh nodes (the ends are both).
        let rows = lines.count();
        let uniform = suslov::app::OUTPUT_POINTS;
        assert!(
            rows >= uniform.max(case.mesh_nodes) && rows <= uniform + case.mesh_nodes - 2,
            "{rows} rows, {} nodes",
            case.mesh_nodes
        );
        let npy = std::fs::read(dir.join(&case.name).join("trajectory.npy")).expect("npy");
        assert_eq!(&npy[..6], b"\x93NUMPY");
        let hlen = u16::from_le_bytes([npy[8], npy[9]]) as usize;
        assert_eq!(npy.len(), 10 + hlen + rows * 16 * 8);
        for fig in [
            "omega_3d",
            "constraint",
            "xi_norm",
            "kappa",
            "omega",
            "xi",
            "xi_dot",
        ] {
            let png = std::fs::read(dir.join(&case.name).join(format!("{fig}.png"))).expect(fig);
            assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
            let svg = std::fs::read_to_string(dir.join(&case.name).join(format!("{fig}.svg")))
                .expect(fig);
            assert!(svg.trim_end().ends_with("</svg>"), "{fig}.svg");
        }
    }
    assert!(wrote.iter().all(|p| p.exists()));
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .expect("dir")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn gamma_zero_starts_from_a_nominal_path_whatever_the_desired_path() {
    // Paper section 5.2, first case: with gamma = 0 the homotopy tracks Omega_p (the projected
    // segment) while gamma_c goes from 1 to 0, so Omega_d (here a constant that is not even
    // admissible as a path to Omega_b) plays no role.
    use std::sync::Arc;
    use suslov::so3::{Constant, EnergyEllipsoid};
    let mut p = paper::fixed_time_problem(0.0, 5.0);
    let e = EnergyEllipsoid::through(p.inertia, &p.omega_a).expect("ellipsoid");
    p.omega_b = e.project(&Vector3::new(1.0, 2.0, 1.0)).expect("projection");
    p.desired = Arc::new(Constant(p.omega_a));
    p.weights.gamma = 0.0;
    p.weights.delta = 0.0;
    let sol = suslov::solve(&p, &Default::default(), &mut |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sol.generic.start.case, 1);
    let names: Vec<&str> = sol.generic.stages.iter().map(|s| s.name).collect();
    assert_eq!(names, ["start", "gamma", "beta", "polish"]);
    let y = sol.state(5.0);
    assert!((Vector3::new(y[0], y[1], y[2]) - p.omega_b).norm() < 1e-8);
    let d = suslov::lie::verify::diagnose(&sol.generic);
    assert!(
        // kinetic energy T(a) = 12.5: a drift of 1e-8 relative to it
        d.max_abs_constraint < 1e-9 && d.energy_drift < 1e-8 * 12.5,
        "{d:?}"
    );
}

#[test]
fn a_failing_stage_writes_a_marked_partial_result_and_says_where() {
    // A node cap that the start and continuation stages fit in (tol 1e-4: up to ~200 nodes
    // while adapting) but the final solve at 1e-8 does not (~280): the polish stage fails
    // with MaxNodes.
    let dir = std::env::temp_dir().join(format!("suslov-partial-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let options = suslov::SolveOptions {
        max_nodes: 230,
        ..Default::default()
    };
    let problem = paper::problem(0.01);
    let mut out = suslov::report::OutputDir::open(&dir).expect("output directory");
    let summary = suslov::app::run_case(
        "capped",
        &problem,
        (&mut out, std::path::Path::new("")),
        &options,
        &suslov::app::OutputOptions::default(),
        &mut |_| {},
    )
    .expect("outputs written");
    drop(out);
    assert!(
        summary.status.starts_with("partial: stage 'polish'"),
        "{}",
        summary.status
    );
    // The node cap in words, with the key to change (no Rust variant names).
    assert!(
        summary.status.contains("more mesh nodes than allowed")
            && summary.status.contains("solver.max_nodes"),
        "{}",
        summary.status
    );
    // What it has: the last converged point (continuation tolerance) near the answer.
    assert!((summary.terminal_time - 9.84).abs() < 0.01);
    assert!(dir.join("trajectory.partial.csv").exists());
    assert!(
        !dir.join("trajectory.csv").exists(),
        "a partial result must not look final"
    );
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn the_start_case_can_be_overridden() {
    // Forcing the paper's second case (gamma_c from 0) on the paper's problem: the start BVP
    // at gamma_c = 0, beta_m = 1e-3 does not converge from the singular solution (the
    // tracking term is what pins Omega down); the automatic choice (third case) does. The
    // override must either work with the case it names or stop cleanly: at the start, or
    // (another route having passed the start) in a later stage.
    use suslov::so3::solve::{SolveError, StartStrategy};
    let problem = paper::problem(0.01);
    for (strategy, case, omega_p) in [
        (StartStrategy::Desired, 3, "projected desired path"),
        (
            StartStrategy::DesiredGammaFromZero,
            2,
            "projected desired path",
        ),
        (StartStrategy::Segment, 2, "projected segment"),
    ] {
        let options = suslov::SolveOptions {
            start: strategy,
            ..Default::default()
        };
        match suslov::solve(&problem, &options, &mut |_| {}) {
            Ok(sol) => {
                assert_eq!(
                    (sol.generic.start.case, sol.generic.start.omega_p),
                    (case, omega_p)
                );
                assert!((sol.terminal_time() - 9.84).abs() < 0.01);
            }
            Err(SolveError::Start { reason: msg, .. }) => {
                assert_ne!(strategy, StartStrategy::Desired, "{msg}");
                assert!(msg.contains("did not converge"), "{msg}");
            }
            // Another route (a larger beta_m) passed the start and stopped later: the
            // furthest stop is reported, with its route.
            Err(SolveError::StageFailed { reason, .. }) => {
                assert_ne!(strategy, StartStrategy::Desired, "{reason}");
                assert!(
                    reason.contains("the furthest of the routes tried"),
                    "{reason}"
                );
            }
            Err(e) => panic!("{strategy:?}: unexpected {e}"),
        }
    }
    // gamma = 0 is incompatible with a start from the desired path: a clean error.
    let mut p = paper::fixed_time_problem(0.0, 10.0);
    p.weights.gamma = 0.0;
    let options = suslov::SolveOptions {
        start: StartStrategy::Desired,
        ..Default::default()
    };
    let err = suslov::solve(&p, &options, &mut |_| {}).expect_err("needs gamma > 0");
    assert!(err.to_string().contains("needs gamma > 0"), "{err}");
}
