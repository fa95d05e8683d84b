//! `suslov solve` for a problem file of a model other than so(3) (`model = "se2"`, …): solve
//! with the generic layer ([`crate::lie`]), verify, reconstruct the group motion, and write
//!
//! ```text
//! DIR/problem.toml          a copy of the input
//! DIR/trajectory.csv        t, the model's state names (Ω, ξ, ξ̇, κ), Ω_d on a uniform grid
//! DIR/motion.csv            t, g(t) row-major (ġ = g Ω̂, g(a) = identity), when the model
//!                           has a matrix representation; for planar rigid motions (se(2))
//!                           also x, y, theta
//! DIR/path.png              for planar rigid motions: the path (x, y) with headings θ
//! DIR/summary.json          one case, last
//! ```
//!
//! A stage that stops writes `trajectory.partial.csv`; a solution that fails its checks
//! writes `trajectory.unverified.csv` (no motion), as for so(3).

use std::path::Path;
use std::time::Instant;

use crate::config::{generic::LoadedModelProblem, ModelFile};
use crate::lie::{self, LieSolution, LieSolveError};
use crate::model::Model;
use crate::reconstruct::{reconstruct, ReconstructOptions, Representation, StepSize};
use crate::report::{self, CaseStatus, CaseSummary, OutputDir};
use crate::suslov::controllability::RANK_RTOL;
use crate::suslov::verify::Verdict;

use super::{finish, stage_summaries_of, AppError, AppEvent, OUTPUT_POINTS};

/// Heading ticks drawn along the planar path (`path.png`).
const PATH_HEADINGS: usize = 25;

/// Times along the solution at which the accessibility rank is evaluated.
const ACCESSIBILITY_POINTS: usize = 101;

/// Every file a case of this kind may write.
fn files() -> Vec<std::path::PathBuf> {
    [
        "trajectory.csv",
        "trajectory.unverified.csv",
        "trajectory.partial.csv",
        "motion.csv",
        "path.png",
    ]
    .iter()
    .map(Into::into)
    .collect()
}

fn csv_number(s: &mut String, x: f64) {
    use std::fmt::Write;
    let _ = write!(s, "{x:e}");
}

/// `t, <state names>, omega_d1..n` on `points` uniform times of `[a, b]`.
fn trajectory_csv<M: Model>(sol: &LieSolution<M>, points: usize) -> String {
    let n = M::DIM;
    let mut header = vec!["t".to_string()];
    header.extend(M::STATE_NAMES.iter().map(|s| s.to_string()));
    header.extend((1..=n).map(|i| format!("omega_d{i}")));
    let mut s = header.join(",");
    s.push('\n');
    let (a, b) = (sol.problem.t0, sol.terminal_time());
    let mut y = vec![0.0; M::N_STATE];
    let mut jet = vec![0.0; 4 * n];
    for k in 0..points {
        let t = if k + 1 == points {
            b
        } else {
            a + (b - a) * k as f64 / (points - 1) as f64
        };
        sol.state_into(t, &mut y);
        sol.problem.desired.jet_into(t, &mut jet);
        csv_number(&mut s, t);
        for v in y.iter().chain(&jet[..n]) {
            s.push(',');
            csv_number(&mut s, *v);
        }
        s.push('\n');
    }
    s
}

/// The reconstructed motion: `motion.csv` (`t, g11, g12, …`, and for se(2) `x, y, theta`), the
/// reconstruction's step-doubling error estimate, and for se(2) the planar path.
struct Motion {
    csv: String,
    error_estimate: f64,
    planar: Option<[Vec<f64>; 3]>,
}

/// Whether the representation is of planar rigid motions: `3 × 3` matrices with a zero last
/// row and an antisymmetric top-left `2 × 2` block (se(2) in homogeneous coordinates), so that
/// `g = [[cos θ, −sin θ, x], [sin θ, cos θ, y], [0, 0, 1]]`.
fn is_planar_rigid(k: usize, flat: &[f64]) -> bool {
    k == 3
        && flat.chunks_exact(9).all(|e| {
            e[6] == 0.0 && e[7] == 0.0 && e[8] == 0.0 && e[0] == 0.0 && e[4] == 0.0 && e[1] == -e[3]
        })
}

/// The reconstructed motion `ġ = g Ω̂`, `g(a) = 1` (see [`Motion`]); `None` without a matrix
/// representation.
fn motion<M: Model>(sol: &LieSolution<M>, points: usize) -> Result<Option<Motion>, String> {
    let Some((k, flat)) = M::REPRESENTATION else {
        return Ok(None);
    };
    let rep = Representation::new(M::DIM, k, flat.to_vec()).map_err(|e| e.to_string())?;
    let (a, b) = (sol.problem.t0, sol.terminal_time());
    let times: Vec<f64> = (0..points)
        .map(|i| {
            if i + 1 == points {
                b
            } else {
                a + (b - a) * i as f64 / (points - 1) as f64
            }
        })
        .collect();
    let mut identity = vec![0.0; k * k];
    for i in 0..k {
        identity[i * k + i] = 1.0;
    }
    let mut y = vec![0.0; M::N_STATE];
    let omega = |t: f64, w: &mut [f64]| {
        sol.state_into(t.clamp(a, b), &mut y);
        w.copy_from_slice(&y[M::OMEGA]);
    };
    let opts = ReconstructOptions {
        step: StepSize::MaxStep(((b - a) / 4000.0).min(0.01)),
        ..Default::default()
    };
    let rec = reconstruct(&rep, &identity, &times, omega, &opts).map_err(|e| e.to_string())?;
    let planar = is_planar_rigid(k, flat);
    let mut header = vec!["t".to_string()];
    for r in 1..=k {
        for c in 1..=k {
            header.push(format!("g{r}{c}"));
        }
    }
    if planar {
        header.extend(["x", "y", "theta"].map(String::from));
    }
    let mut s = header.join(",");
    s.push('\n');
    let mut path: [Vec<f64>; 3] = Default::default();
    for (i, t) in times.iter().enumerate() {
        let g = rec.at(i);
        csv_number(&mut s, *t);
        for v in g {
            s.push(',');
            csv_number(&mut s, *v);
        }
        if planar {
            // θ unwrapped (continuous in t).
            let mut theta = g[3].atan2(g[0]);
            if let Some(prev) = path[2].last() {
                let turns = ((prev - theta) / std::f64::consts::TAU).round();
                theta += turns * std::f64::consts::TAU;
            }
            for (col, v) in path.iter_mut().zip([g[2], g[5], theta]) {
                s.push(',');
                csv_number(&mut s, v);
                col.push(v);
            }
        }
        s.push('\n');
    }
    Ok(Some(Motion {
        csv: s,
        error_estimate: rec.error_estimate,
        planar: planar.then_some(path),
    }))
}

fn summarize<M: Model>(name: &str, sol: &LieSolution<M>) -> (CaseSummary, bool) {
    let lie::verify::Verified {
        diagnostics: d,
        reintegration,
        verification,
    } = lie::verify_solution(sol);
    let verified = verification.passed();
    let status = match verification.verdict() {
        Verdict::Verified => CaseStatus::Converged,
        Verdict::Unverified { reason } => CaseStatus::Unverified(reason),
    };
    let eta = M::WEIGHTS
        .iter()
        .find(|w| w.role == crate::model::HomotopyRole::Smoothing)
        .map_or(f64::NAN, |w| sol.problem.params()[w.index]);
    let mut c = CaseSummary {
        name: name.to_string(),
        eta,
        terminal_time: d.terminal_time,
        cost: d.cost,
        max_abs_constraint: d.max_abs_constraint,
        xi_norm_min: d.xi_norm_min,
        xi_norm_max: d.xi_norm_max,
        energy_drift: d.energy_drift,
        omega_b_error: d.omega_b_error,
        max_residual: d.max_residual,
        mesh_nodes: sol.bvp.num_nodes(),
        continuation_steps: sol.stages.iter().map(|s| s.steps).sum(),
        newton_iterations: sol.stages.iter().map(|s| s.newton_iterations).sum(),
        status: status.to_string(),
        verification: Some((&verification).into()),
        stages: stage_summaries_of(&sol.stages),
        reintegration_max_diff: reintegration.as_ref().ok().map(|r| r.max_abs_diff),
        ..Default::default()
    };
    c.extra.insert("model".into(), serde_json::json!(M::NAME));
    let params: serde_json::Map<String, serde_json::Value> = Problem::<M>::user_metas()
        .map(|m| {
            (
                m.name.to_string(),
                serde_json::json!(sol.problem.params()[m.index]),
            )
        })
        .collect();
    c.extra
        .insert("parameters".into(), serde_json::Value::Object(params));
    c.extra
        .insert("omega_a".into(), serde_json::json!(sol.problem.omega_a));
    c.extra
        .insert("omega_b".into(), serde_json::json!(sol.problem.omega_b));
    c.extra
        .insert("bc_residual".into(), serde_json::json!(d.bc_residual));
    c.extra.insert(
        "energy".into(),
        serde_json::json!(if sol.problem.conserves_energy() {
            "conserved: energy_drift is max |T(t) - T(a)|"
        } else {
            "balanced (nonzero constraint value): energy_drift is max |T(t) - T(a) - int lambda \
             <Omega, xi> dt|"
        }),
    );
    if let Some(mu) = sol.start_multiplier() {
        // The multiplier of the start constraint phi(a) = 0 (src/lie/problem.rs).
        c.extra
            .insert("start_multiplier".into(), serde_json::json!(mu));
    }
    // The accessibility rank test along the solution (paper section 4.3, any model).
    let rank = lie::controllability::rank_along(sol, ACCESSIBILITY_POINTS, RANK_RTOL);
    c.extra.insert(
        "accessibility".into(),
        serde_json::json!({
            "points": ACCESSIBILITY_POINTS,
            "rtol": rank.rtol,
            "dim_m": rank.dim_m,
            "min_rank": rank.min_rank,
            "max_rank": rank.max_rank,
            "min_sigma_dim_m": rank.min_sigma_dim_m,
            "max_sigma_next": rank.max_sigma_next,
            "max_constraint": rank.max_constraint,
        }),
    );
    c.extra.insert(
        "start".into(),
        serde_json::json!({
            "omega_p": sol.start.omega_p,
            "paper_case": sol.start.case,
            "b_p": sol.start.b_p,
            "beta_m": sol.start.beta_m,
        }),
    );
    (c, verified)
}

use crate::lie::Problem;

/// `suslov solve` for a [`ModelFile`] of model `M` (see the module docs).
pub fn run_model_solve<M: Model>(
    file: &ModelFile,
    text: &str,
    config_path: &Path,
    out: &Path,
    events: &mut dyn FnMut(AppEvent),
) -> Result<report::Summary, AppError> {
    let LoadedModelProblem {
        name,
        problem,
        options,
    } = file.build::<M>()?;
    let mut dir = OutputDir::open(out)?;
    dir.check_free(
        files()
            .into_iter()
            .chain(["problem.toml".into(), report::SUMMARY_FILE.into()]),
    )?;
    let copy = dir.write("problem.toml", text.as_bytes())?;
    events(AppEvent::Wrote(&copy));
    events(AppEvent::CaseStarted { name: &name });
    let clock = Instant::now();
    let result = lie::solve(&problem, &options, &mut |e| events(AppEvent::Solve(e)));
    let mut write = |dir: &mut OutputDir, file: &str, bytes: &[u8]| -> Result<(), AppError> {
        let path = dir.write(file, bytes)?;
        events(AppEvent::Wrote(&path));
        Ok(())
    };
    let mut case = match result {
        Ok(sol) => {
            let (mut c, verified) = summarize(&name, &sol);
            let stem = if verified {
                "trajectory.csv"
            } else {
                "trajectory.unverified.csv"
            };
            write(
                &mut dir,
                stem,
                trajectory_csv(&sol, OUTPUT_POINTS).as_bytes(),
            )?;
            if verified {
                match motion(&sol, OUTPUT_POINTS) {
                    Ok(Some(m)) => {
                        write(&mut dir, "motion.csv", m.csv.as_bytes())?;
                        c.extra.insert(
                            "motion_error_estimate".into(),
                            serde_json::json!(m.error_estimate),
                        );
                        if let Some([x, y, theta]) = &m.planar {
                            let title = format!("{name}: the path in the plane");
                            let png = report::render_planar_path_png(
                                &title,
                                x,
                                y,
                                theta,
                                PATH_HEADINGS,
                                (1200, 900),
                            )?;
                            write(&mut dir, "path.png", &png)?;
                        }
                    }
                    Ok(None) => {}
                    Err(e) => {
                        c.extra.insert("motion_error".into(), serde_json::json!(e));
                    }
                }
            }
            c
        }
        Err(LieSolveError::StageFailed {
            stage,
            parameter,
            reached,
            target,
            reason,
            partial,
        }) => {
            let (mut c, _) = summarize(&name, &partial);
            let at = if reached.is_finite() && target.is_finite() {
                format!(" at {parameter} = {reached} (target {target})")
            } else {
                String::new()
            };
            c.status =
                CaseStatus::Partial(format!("stage '{stage}' stopped{at}: {reason}")).to_string();
            write(
                &mut dir,
                "trajectory.partial.csv",
                trajectory_csv(&partial, OUTPUT_POINTS).as_bytes(),
            )?;
            c
        }
        Err(e) => CaseSummary {
            name: name.clone(),
            eta: f64::NAN,
            terminal_time: f64::NAN,
            cost: f64::NAN,
            max_abs_constraint: f64::NAN,
            xi_norm_min: f64::NAN,
            xi_norm_max: f64::NAN,
            energy_drift: f64::NAN,
            omega_b_error: f64::NAN,
            max_residual: f64::NAN,
            status: CaseStatus::Failed(e.to_string()).to_string(),
            ..Default::default()
        },
    };
    case.wall_seconds = clock.elapsed().as_secs_f64();
    case.extra.insert(
        "problem_file".into(),
        serde_json::json!(config_path.display().to_string()),
    );
    events(AppEvent::CaseFinished(&case));
    let summary = report::Summary { cases: vec![case] };
    finish(dir, &summary, events)?;
    Ok(summary)
}

/// `suslov certify FILE` for a [`ModelFile`] of model `M`: solve, verify, certify on the
/// solution's own mesh ([`crate::lie::certify`]); the report as for so(3).
pub fn run_model_certify<M: Model>(
    file: &ModelFile,
    tolerance: Option<f64>,
    json: Option<&Path>,
    events: &mut dyn FnMut(AppEvent),
) -> Result<Vec<report::CertificateReport>, AppError> {
    use crate::ocp::{NewtonOptions, SecondOrderOptions};
    use report::CertificateReport;
    super::prepare_certificate_json(json)?;
    let LoadedModelProblem {
        name,
        problem,
        mut options,
    } = file.build::<M>()?;
    if let Some(t) = tolerance {
        options.tol = t;
    }
    events(AppEvent::CaseStarted { name: &name });
    let clock = Instant::now();
    let solved = lie::solve(&problem, &options, &mut |e| events(AppEvent::Solve(e)));
    let solve_seconds = clock.elapsed().as_secs_f64();
    let mut report = match solved {
        Err(e) => CertificateReport::error(&name, format!("the solve failed: {e}")),
        Ok(sol) => {
            let verification = lie::verify_solution(&sol).verification;
            let clock = Instant::now();
            let cert = lie::certify::certify(
                &sol,
                &NewtonOptions::default(),
                &SecondOrderOptions::default(),
            );
            let mut r = match cert {
                Ok(c) => CertificateReport::from_certificate(&name, &c),
                Err(e) => CertificateReport::error(&name, format!("certificate: {e}")),
            };
            r.certify_seconds = clock.elapsed().as_secs_f64();
            r.solution_status = Some(CaseStatus::from(verification.verdict()).to_string());
            r
        }
    };
    report.solve_seconds = solve_seconds;
    events(AppEvent::Certified(&report));
    let reports = vec![report];
    super::write_certificate_json(json, &reports, events)?;
    Ok(reports)
}

/// `suslov controllability --along FILE` for a [`ModelFile`] of model `M`: solve, verify, and
/// test the accessibility rank at `points` times along the solution
/// ([`crate::lie::controllability`]).
pub fn run_model_rank_along<M: Model>(
    file: &ModelFile,
    points: usize,
    rtol: f64,
    events: &mut dyn FnMut(AppEvent),
) -> Result<super::RankAlong, AppError> {
    let LoadedModelProblem {
        name,
        problem,
        options,
    } = file.build::<M>()?;
    events(AppEvent::CaseStarted { name: &name });
    let sol = match lie::solve(&problem, &options, &mut |e| events(AppEvent::Solve(e))) {
        Ok(sol) => sol,
        Err(e) => {
            events(AppEvent::CaseEnded { name: &name });
            return Ok(super::RankAlong {
                text: format!("case {name}: the solve failed: {e}\n"),
                all_accessible: false,
            });
        }
    };
    let mut text = String::new();
    let verification = lie::verify_solution(&sol).verification;
    let mut all_accessible = true;
    if let Verdict::Unverified { reason } = verification.verdict() {
        all_accessible = false;
        text += &format!(
            "case {name}: the solution did not pass its a-posteriori checks ({reason}); the \
             rank test below runs along it anyway\n"
        );
    }
    let r = lie::controllability::rank_along(&sol, points, rtol);
    all_accessible &= r.min_rank == r.dim_m && r.max_rank == r.dim_m;
    let (a, b) = (sol.problem.t0, sol.terminal_time());
    text += &format!(
        "case {name} (model {}): rank of V {} at all {points} times of [{a}, {b:.6}] (dim M = \
         {})\n  smallest sigma_(dim M)/sigma_1 {:.4e}; largest sigma_(dim M + 1)/sigma_1 \
         {:.1e}; the solution's max |<Omega, xi>|/(|Omega| |xi|) {:.1e} (xi projected onto \
         Omega^perp for the test)\n",
        M::NAME,
        if r.min_rank == r.max_rank {
            format!("= {}", r.min_rank)
        } else {
            format!("in {}..={}", r.min_rank, r.max_rank)
        },
        r.dim_m,
        r.min_sigma_dim_m,
        r.max_sigma_next,
        r.max_constraint,
    );
    events(AppEvent::CaseEnded { name: &name });
    Ok(super::RankAlong {
        text,
        all_accessible,
    })
}
