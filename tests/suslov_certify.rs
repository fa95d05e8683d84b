//! The second-order certificate on Suslov's problem (`suslov::lie::certify`, model so3,
//! `suslov certify`): the paper's extremals are certified local minima of the discretized
//! problem, on their own meshes; a fixed-time case too; the discrete multipliers are the
//! costates from κ; and on a too-coarse mesh the certificate says no (checked against a
//! dense null-space computation when the result was found, see README).

use std::path::Path;

mod ocpkit;

use suslov::lie::certify::{certify, SuslovCertificate};
use suslov::model::generated as g;
use suslov::ocp::{NewtonOptions, SecondOrderOptions, Verdict};
use suslov::{paper, solve, SolveOptions, SuslovProblem};

fn certified(problem: &SuslovProblem, tol: f64) -> SuslovCertificate {
    let opts = SolveOptions {
        tol,
        ..Default::default()
    };
    let sol = solve(problem, &opts, &mut |_| {}).expect("the solve converges");
    let cert = certify(
        &sol.generic,
        &NewtonOptions::default(),
        &SecondOrderOptions::default(),
    )
    .expect("the certificate runs");
    let c = &cert.certificate;
    let so = &c.second_order;
    if cert.verdict() == Verdict::Certified {
        // The indirect solution itself, with the best multipliers it admits (least squares),
        // is a KKT point of the discretized problem up to discretization error.
        use suslov::lie::certify::{transcription, LieOcp};
        use suslov::ocp::kkt::{self, KktMatrix, KktPoint};
        let ocp_problem = LieOcp::new(&sol.generic);
        let tr = transcription(&ocp_problem, &sol.generic).expect("transcription");
        let v = indirect_primal(&sol, &tr);
        let matrix = KktMatrix::new(&tr).expect("pattern");
        let y = kkt::least_squares_multipliers(&tr, &matrix, &v).expect("multipliers");
        let lsq = kkt::residual(&tr, &KktPoint { v, y }).relative_stationarity();
        eprintln!("tol {tol:e}: least-squares candidate stationarity {lsq:.1e}");
        assert!(lsq < 1e-5, "{lsq}");
    }
    eprintln!(
        "tol {tol:e}: {} intervals, candidate stationarity {:.1e}, Newton {} its, displacement {:.1e} (relative {:.1e}), costates vs kappa {:.1e}, inertia {} (n = {}, m = {}), margin {:?}, backward error {:.1e}; b = {:.8} (solver {:.8})",
        cert.intervals,
        c.candidate.relative_stationarity(),
        c.newton_iterations,
        c.displacement,
        cert.relative_displacement,
        cert.costate_mismatch,
        so.inertia,
        so.n_var,
        so.n_con,
        so.margin,
        so.backward_error,
        cert.terminal_time,
        sol.terminal_time()
    );
    // Whatever the verdict, the point it is about is an exact KKT point.
    assert!(c.kkt.relative_stationarity() < 1e-9 && c.kkt.feasibility < 1e-9);
    assert!(so.backward_error < 1e-12);
    assert_eq!(
        so.inertia.positive + so.inertia.negative + so.inertia.zero,
        so.n_var + so.n_con
    );
    cert
}

/// The primal point of the direct transcription `tr` that an indirect solution gives:
/// `z = [Ω, ξ, ξ̇]` of `y = [Ω, ξ, ξ̇, κ]` at every collocation point, then `b − a` when `b`
/// is free.
fn indirect_primal<P: suslov::ocp::OcpProblem>(
    sol: &suslov::SuslovSolution,
    tr: &suslov::ocp::Transcription<'_, P>,
) -> Vec<f64> {
    let mut v0: Vec<f64> = Vec::new();
    for y in sol
        .generic
        .bvp
        .collocation_values()
        .chunks_exact(g::N_STATE)
    {
        for block in [g::OMEGA, g::XI, g::XIDOT] {
            v0.extend_from_slice(&y[block]);
        }
    }
    if tr.length_index().is_some() {
        v0.push(sol.generic.t_span);
    }
    v0
}

fn assert_certified(cert: &SuslovCertificate) {
    let so = &cert.certificate.second_order;
    assert_eq!(cert.verdict(), Verdict::Certified);
    assert_eq!(
        (so.inertia.positive, so.inertia.negative, so.inertia.zero),
        (so.n_var, so.n_con, 0)
    );
    let (lo, hi) = so.margin.expect("margin bracketed");
    assert!(lo > 0.0 && hi >= lo);
    let q = so.weakest_rayleigh.expect("weakest direction");
    assert!(
        lo * (1.0 - 1e-6) <= q && q <= hi * (1.0 + 1e-6),
        "{q} not in [{lo}, {hi}]"
    );
    // The indirect solution, with its costates computed from kappa as the multipliers
    // (Newton's start), is a KKT point of the discretized problem up to discretization error
    // (which the costates add to: this is larger than the least-squares residual asserted in
    // `certified`), and one Newton step takes it to the exact one.
    assert!(cert.certificate.candidate.relative_stationarity() < 1e-4);
    assert_eq!(cert.certificate.newton_iterations, 1);
    assert!(
        cert.relative_displacement < 1e-4,
        "{}",
        cert.relative_displacement
    );
    assert!(cert.costate_mismatch < 1e-5, "{}", cert.costate_mismatch);
    assert!(cert.warning().is_none());
    // Jacobi's condition (a consequence of SOSC): no conjugate point up to b.
    assert!(cert.certificate.conjugate.first.is_none());
}

#[test]
fn paper_eta_001_is_a_certified_local_minimum_on_converging_meshes() {
    let problem = paper::problem(0.01);
    let fine = certified(&problem, 1e-8);
    assert_certified(&fine);
    assert!((fine.terminal_time - 9.84).abs() < 0.01);
    // The margin is a property of the problem, not of the mesh.
    let coarse = certified(&problem, 1e-6);
    assert_certified(&coarse);
    let mid = |c: &SuslovCertificate| {
        let (lo, hi) = c.certificate.second_order.margin.expect("margin");
        0.5 * (lo + hi)
    };
    assert!((mid(&fine) - mid(&coarse)).abs() < 2e-3 * mid(&fine));
}

#[test]
fn paper_eta_1_is_certified_but_not_on_a_too_coarse_mesh() {
    let problem = paper::problem(1.0);
    assert_certified(&certified(&problem, 1e-8));
    // At tolerance 1e-4 (75 intervals) the KKT point of the discretized problem next to the
    // extremal is a saddle: negative curvature directions, and a warning that the mesh is too
    // coarse for the verdict to describe the computed solution. The certificate says no.
    let coarse = certified(&problem, 1e-4);
    assert_eq!(coarse.verdict(), Verdict::NotMinimum);
    let so = &coarse.certificate.second_order;
    assert!(so.negative_curvature_directions > 0);
    assert_eq!(
        so.inertia.negative,
        so.n_con + so.negative_curvature_directions
    );
    assert!(so.margin.expect("margin").1 < 0.0);
    assert!(coarse.warning().is_some());
    // Variations with fixed ends already lower the cost on part of [a, b]: a conjugate point.
    let conj = coarse.certificate.conjugate.first.expect("conjugate point");
    eprintln!("coarse mesh: first conjugate point {conj:?}");
    assert!(conj.time > problem.t0 && conj.time < coarse.terminal_time);
}

#[test]
fn fixed_time_example_is_certified() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/spiral_fixed_time.toml");
    let loaded = suslov::config::load(&path).expect("example loads");
    let cert = certified(&loaded.problem, loaded.options.tol);
    assert!(!cert.free_time);
    assert_certified(&cert);
    assert_eq!(cert.terminal_time, 10.5);
}

#[test]
fn certify_job_writes_json_and_says_the_verdict() {
    let dir = std::env::temp_dir().join(format!("suslov-certify-{}", std::process::id()));
    let json = dir.join("sub/certificate.json");
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/segment.toml");
    let jobs = suslov::app::case_jobs(Some(&config), None).expect("jobs");
    let reports = suslov::app::run_certify(&jobs, Some(&json), &mut |_| {}).expect("runs");
    assert_eq!(reports.len(), 1);
    assert_eq!(reports[0].verdict, "certified");
    let text = reports[0].text();
    assert!(text.contains("local minimum certified for the discretized problem"));
    assert!(text.contains("indirect solution as a KKT point (its costates as multipliers)"));
    let parsed: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("written")).expect("valid JSON");
    let case = &parsed["cases"][0];
    assert_eq!(case["name"], "segment");
    assert_eq!(case["verdict"], "certified");
    assert_eq!(case["inertia"][2], 0);
    assert_eq!(case["inertia"][0], case["unknowns"]);
    assert_eq!(case["inertia"][1], case["constraints"]);
    assert!(case["margin_low"].as_f64().expect("number") > 0.0);
    assert_eq!(case["candidate_multipliers"], "costates");
    std::fs::remove_dir_all(&dir).ok();
    // A bad tolerance is an error naming the flag.
    let err = suslov::app::case_jobs(None, Some(-1.0))
        .err()
        .expect("rejected");
    assert!(err.to_string().contains("--tolerance"));
}

/// The coarse-mesh "no" above, against an independent dense computation: an orthonormal
/// null-space basis Z of the constraint Jacobian (eigenvectors of AᵀA) and the eigenvalues of
/// ZᵀHZ in the metric M at the same KKT point.
#[test]
fn coarse_mesh_saddle_matches_a_dense_null_space_computation() {
    use suslov::lie::certify::{transcription, LieOcp};
    use suslov::ocp::certify::second_order;
    use suslov::ocp::kkt::{self, KktMatrix, KktPoint};

    let problem = paper::problem(1.0);
    let opts = SolveOptions {
        tol: 1e-4,
        ..Default::default()
    };
    let sol = solve(&problem, &opts, &mut |_| {}).expect("solves");
    let ocp = LieOcp::new(&sol.generic);
    let tr = transcription(&ocp, &sol.generic).expect("transcription");
    let v0 = indirect_primal(&sol, &tr);
    // The KKT pattern comes from the positions alone: those of the evaluated derivatives.
    let pos = |e: Vec<(usize, usize, f64)>| -> Vec<(usize, usize)> {
        e.into_iter().map(|(r, c, _)| (r, c)).collect()
    };
    assert_eq!(pos(tr.jacobian(&v0)), pos(tr.jacobian_positions()));
    let y_any: Vec<f64> = (0..tr.n_con()).map(|i| (i % 7) as f64 - 3.0).collect();
    assert_eq!(
        pos(tr.lagrangian_hessian(&v0, &y_any)),
        pos(tr.lagrangian_hessian_positions())
    );
    let matrix = KktMatrix::new(&tr).expect("pattern");
    let y0 = kkt::least_squares_multipliers(&tr, &matrix, &v0).expect("multipliers");
    let (pt, _) = kkt::newton(
        &tr,
        &matrix,
        KktPoint { v: v0, y: y0 },
        &NewtonOptions::default(),
    )
    .expect("KKT point");
    let so_opts = SecondOrderOptions {
        margin_rtol: 1e-5,
        ..Default::default()
    };
    let rep = second_order(&tr, &matrix, &pt, &so_opts).expect("second order");

    let (negative, mu) = ocpkit::dense_reduced(&tr, &pt);
    let (lo, hi) = rep.margin.expect("margin");
    eprintln!(
        "{} intervals: sparse {} negative directions, mu_min in [{lo:.6}, {hi:.6}]; dense {negative} negative, mu_min = {mu:.6}",
        tr.n_intervals(),
        rep.negative_curvature_directions
    );
    assert_eq!(rep.verdict, Verdict::NotMinimum);
    assert_eq!(rep.negative_curvature_directions, negative);
    assert!(lo - 1e-6 <= mu && mu <= hi + 1e-6);
}

/// The certificate starts Newton from the multipliers that the indirect solution's costates
/// give (no factorization); started from the least-squares multipliers instead (a
/// factorization more), it reaches the same KKT point with the same verdict, inertia and
/// margin. The least-squares residual of the indirect solution is smaller than the costates':
/// it is the best any multipliers do for that primal point.
#[test]
fn costate_start_reaches_the_least_squares_start_point() {
    use suslov::lie::certify::{transcription, LieOcp};
    use suslov::ocp;

    let problem = paper::problem(0.01);
    let sol = solve(&problem, &SolveOptions::default(), &mut |_| {}).expect("solves");
    let (newton, second) = (NewtonOptions::default(), SecondOrderOptions::default());
    let seeded = certify(&sol.generic, &newton, &second).expect("certificate");
    let ocp_problem = LieOcp::new(&sol.generic);
    let tr = transcription(&ocp_problem, &sol.generic).expect("transcription");
    let v0 = indirect_primal(&sol, &tr);
    let plain = ocp::certify(&tr, v0, &newton, &second).expect("certificate");
    let (a, b) = (&seeded.certificate, &plain);
    let gap = |x: &[f64], y: &[f64]| {
        let scale = y.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        x.iter()
            .zip(y)
            .fold(0.0_f64, |m, (p, q)| m.max((p - q).abs()))
            / scale
    };
    let (dv, dy) = (gap(&a.point.v, &b.point.v), gap(&a.point.y, &b.point.y));
    eprintln!(
        "costate start: candidate {:.1e}, {} Newton iterations; least squares: candidate {:.1e}, {}; points apart {dv:.1e} (v), {dy:.1e} (y); margins {:?} and {:?}",
        a.candidate.relative_stationarity(),
        a.newton_iterations,
        b.candidate.relative_stationarity(),
        b.newton_iterations,
        a.second_order.margin,
        b.second_order.margin
    );
    assert!(dv < 1e-9 && dy < 1e-8, "{dv:e} {dy:e}");
    assert_eq!(a.second_order.verdict, Verdict::Certified);
    assert_eq!(a.second_order.verdict, b.second_order.verdict);
    assert_eq!(a.second_order.inertia, b.second_order.inertia);
    let (p, q) = (
        a.second_order.margin.expect("margin"),
        b.second_order.margin.expect("margin"),
    );
    assert!((p.0 - q.0).abs() < 1e-6 * q.0 && (p.1 - q.1).abs() < 1e-6 * q.1);
    assert_eq!(a.newton_iterations, b.newton_iterations);
    assert_eq!(a.multipliers_from, ocp::MultiplierStart::Costates);
    assert_eq!(b.multipliers_from, ocp::MultiplierStart::LeastSquares);
    assert!(b.candidate.relative_stationarity() < 1e-7);
    assert!(b.candidate.relative_stationarity() < a.candidate.relative_stationarity());
}

/// `suslov controllability --along FILE`: the accessibility rank along a solved trajectory.
#[test]
fn rank_along_a_solved_trajectory_is_four() {
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/segment.toml");
    let jobs = suslov::app::case_jobs(Some(&config), None).expect("jobs");
    let result = suslov::app::run_rank_along(&jobs, 51, 1e-9, &mut |_| {}).expect("runs");
    assert!(result.all_accessible);
    let text = result.text;
    eprintln!("{text}");
    assert!(text.contains("rank of V = 4 at all 51 times"), "{text}");
    assert!(text.contains("accessible along the whole optimal trajectory"));
    let err = suslov::app::run_rank_along(&jobs, 1, 1e-9, &mut |_| {}).expect_err("rejected");
    assert!(err.to_string().contains("--points"));
}
