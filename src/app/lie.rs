//! `suslov solve` for a problem file of a model other than so(3) (`model = "se2"`, …): solve
//! with the generic layer ([`crate::lie`]), verify, reconstruct the group motion, and write
//!
//! ```text
//! DIR/problem.toml          the input, every default filled in (config::resolved)
//! DIR/trajectory.csv        t, the model's state names (Ω, ξ, ξ̇, κ), Ω_d on a uniform grid
//! DIR/motion.csv            t, g(t) row-major (ġ = g Ω̂, g(a) = identity), when the model
//!                           has a matrix representation; for planar rigid motions (se(2))
//!                           also x, y, theta
//! DIR/path.png              for planar rigid motions: the path (x, y) with headings θ
//! DIR/summary.json          one case, last
//! ```
//!
//! A stage that stops writes `trajectory.partial.csv`, and, when its evidence shows the
//! problem's infimum approached as `ξ → 0`, the ε-optimal control `trajectory.infimum.csv`
//! ([`INFIMUM_FILE`]); so does a start that fails on every route when the direct method's
//! minimum shows it; a solution that fails its checks writes `trajectory.unverified.csv` (no
//! motion), as for so(3).

use std::path::Path;
use std::time::Instant;

use crate::config::{generic::LoadedModelProblem, ModelFile};
use crate::lie::checks::Verdict;
use crate::lie::controllability::{AccessibilityVerdict, RANK_RTOL};
use crate::lie::{self, LieSolution, LieSolveError};
use crate::model::{Model, ParamMeta};
use crate::reconstruct::{reconstruct, ReconstructOptions, Representation, StepSize};
use crate::report::{self, CaseStatus, CaseSummary, OutputDir};

use super::{finish, finite, stage_summaries_of, AppError, AppEvent};

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
        "trajectory.npz",
        "trajectory.unverified.npz",
        "trajectory.partial.npz",
        "collocation.csv",
        "collocation.unverified.csv",
        "collocation.partial.csv",
        INFIMUM_FILE,
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

/// The columns of `trajectory.csv`/`.npz`: their names (`t`, the state names, `omega_d1..n`)
/// and values on the output grid ([`super::output_times`]: `points` uniform times of `[a, b]`
/// and the mesh nodes).
fn trajectory_columns<M: Model>(
    sol: &LieSolution<M>,
    points: usize,
) -> (Vec<String>, Vec<Vec<f64>>) {
    let n = M::DIM;
    let mut names = vec!["t".to_string()];
    names.extend(M::STATE_NAMES.iter().map(|s| s.to_string()));
    names.extend((1..=n).map(|i| format!("omega_d{i}")));
    let times = super::output_times(sol.problem.t0, sol.t_span, points, &sol.bvp.x);
    let mut columns = vec![Vec::with_capacity(times.len()); names.len()];
    let mut y = vec![0.0; M::N_STATE];
    let mut jet = vec![0.0; 4 * n];
    for t in times {
        sol.state_into(t, &mut y);
        sol.problem.desired.jet_into(t, &mut jet);
        for (col, v) in columns
            .iter_mut()
            .zip(std::iter::once(&t).chain(&y).chain(&jet[..n]))
        {
            col.push(*v);
        }
    }
    (names, columns)
}

/// The file of a stop's ε-optimal control: the relaxed minimum's motion driven by a vanishing
/// `ξ` ([`lie::collapse::samples_control`]), written when the stop's evidence is undercut and
/// that control is the cheapest of it, or within [`INFIMUM_RTOL`] of the cheapest (the
/// problem's infimum is approached as `ξ → 0`), and the direct method's minimum is not cheaper
/// ([`lie::collapse::CollapseEvidence::cheaper_discrete`]).
pub const INFIMUM_FILE: &str = "trajectory.infimum.csv";

/// How far (relative) the relaxed minimum's control may cost above the cheapest control of a
/// stop's evidence and still be written as its ε-optimal control: where the projected segment
/// is itself the relaxed minimum (corpus problems issue12-142, short-196: equal to 1e-13), or
/// without a term in `Ω̇`, where the projected desired path comes 3.7e-7 closer to the
/// pointwise infimum than the discrete relaxed minimum (spiral-129).
pub const INFIMUM_RTOL: f64 = 1e-6;

/// The table of [`INFIMUM_FILE`] for a stop of `problem` with the evidence `found` (`t`, `Ω`,
/// `ξ`, `ξ̇` in the model's state names, `Ω_d`, on the output grid and the relaxed mesh's
/// times) and the control it holds, or `None` when the evidence does not call for one. The
/// evidence is a partial solution's ([`LieSolution::collapse`]) or a failed start's
/// ([`LieSolveError::Start`]).
#[allow(clippy::type_complexity)]
pub(super) fn infimum_csv<M: Model>(
    problem: &lie::Problem<M>,
    found: &lie::collapse::CollapseEvidence,
    points: usize,
) -> Option<Result<(String, lie::collapse::CollapsedControl), lie::collapse::CollapseError>> {
    use lie::collapse::{Motion, RelaxedOutcome};
    if found.cheaper_discrete.is_some() {
        return None;
    }
    let relaxed = found
        .controls
        .iter()
        .find(|c| c.motion == Motion::RelaxedMinimum)?;
    if !(found.undercuts && relaxed.cost <= found.least.cost * (1.0 + INFIMUM_RTOL)) {
        return None;
    }
    let Some(RelaxedOutcome::Computed { times, omegas, .. }) = &found.relaxed else {
        return None;
    };
    let n = M::DIM;
    let at = super::output_times(problem.t0, relaxed.span, points, times);
    let rows = match lie::collapse::samples_control(problem, times, omegas, &at) {
        Ok(rows) => rows,
        Err(e) => return Some(Err(e)),
    };
    let mut names = vec!["t".to_string()];
    names.extend(M::STATE_NAMES[..M::XIDOT.end].iter().map(|s| s.to_string()));
    names.extend((1..=n).map(|i| format!("omega_d{i}")));
    let mut columns = vec![Vec::with_capacity(at.len()); names.len()];
    let mut jet = vec![0.0; 4 * n];
    for (t, row) in at.iter().zip(&rows) {
        problem.desired.jet_into(*t, &mut jet);
        for (col, v) in columns
            .iter_mut()
            .zip(std::iter::once(t).chain(row).chain(&jet[..n]))
        {
            col.push(*v);
        }
    }
    Some(Ok((trajectory_csv(&names, &columns), *relaxed)))
}

/// [`INFIMUM_FILE`]'s text for a stop of `problem` with the evidence `found`, when the
/// evidence calls for one ([`infimum_csv`]); records the control in `extra`
/// (`infimum_trajectory`), or why it could not be computed (`infimum_trajectory_error`).
pub(super) fn infimum_output<M: Model>(
    problem: &lie::Problem<M>,
    found: Option<&lie::collapse::CollapseEvidence>,
    points: usize,
    extra: &mut serde_json::Map<String, serde_json::Value>,
) -> Option<InfimumOutput> {
    match infimum_csv(problem, found?, points)? {
        Ok((text, control)) => {
            extra.insert("infimum_trajectory".into(), infimum_record(&control));
            Some(InfimumOutput { text, control })
        }
        Err(e) => {
            extra.insert(
                "infimum_trajectory_error".into(),
                serde_json::json!(e.to_string()),
            );
            None
        }
    }
}

/// A stop's ε-optimal control: [`INFIMUM_FILE`]'s text and the control it holds.
pub(super) struct InfimumOutput {
    /// The file's text.
    pub text: String,
    /// The control.
    pub control: lie::collapse::CollapsedControl,
}

impl InfimumOutput {
    /// The case's status once this file is written: the problem has no minimizer (its
    /// infimum is approached as `ξ → 0`); `stop` says where the homotopy stopped and why.
    pub fn status(&self, stop: &str) -> CaseStatus {
        let c = &self.control;
        CaseStatus::NoMinimizer(format!(
            "the infimum is approached as xi -> 0, where Suslov's equations are singular; \
             {INFIMUM_FILE} holds an admissible control with |xi| = {:e} over b - a = {} \
             of cost J = {}; {stop}",
            c.eps,
            crate::echo::Num(c.span),
            crate::echo::Num(c.cost)
        ))
    }
}

/// What `summary.json` records of a written [`INFIMUM_FILE`].
pub(super) fn infimum_record(control: &lie::collapse::CollapsedControl) -> serde_json::Value {
    serde_json::json!({
        "file": INFIMUM_FILE,
        "cost": control.cost,
        "eps": control.eps,
        "span": control.span,
        "reintegration_error": control.reintegration_error,
    })
}

/// `trajectory.csv` from [`trajectory_columns`].
fn trajectory_csv(names: &[String], columns: &[Vec<f64>]) -> String {
    let mut s = names.join(",");
    s.push('\n');
    for row in 0..columns.first().map_or(0, Vec::len) {
        for (k, col) in columns.iter().enumerate() {
            if k > 0 {
                s.push(',');
            }
            csv_number(&mut s, col[row]);
        }
        s.push('\n');
    }
    s
}

/// `trajectory.npz` from [`trajectory_columns`]: one named array per column.
fn trajectory_npz(names: &[String], columns: &[Vec<f64>]) -> Result<Vec<u8>, AppError> {
    let named: Vec<(&str, &[f64])> = names
        .iter()
        .zip(columns)
        .map(|(n, c)| (n.as_str(), c.as_slice()))
        .collect();
    Ok(report::npz_bytes(&named)?)
}

/// The collocation solution itself (`collocation.csv`): at every collocation point in time
/// order — each mesh node and the two interior points of each interval, `3N + 1` rows —
/// `t`, `interior` (0 at a mesh node, 1 at an interior point), the states (`<state names>`)
/// and their time derivatives (`d_<state name>`). These are the values the collocation
/// equations hold for, not interpolated ones, and they define the solution everywhere: on
/// `[t_i, t_{i+1}]` it is the value at `t_i` plus the integral of the cubic that interpolates
/// the derivatives at the interval's four points (what `trajectory.csv` samples).
pub fn collocation_csv<M: Model>(sol: &LieSolution<M>) -> String {
    let mut header = vec!["t".to_string(), "interior".to_string()];
    header.extend(M::STATE_NAMES.iter().map(|s| s.to_string()));
    header.extend(M::STATE_NAMES.iter().map(|s| format!("d_{s}")));
    let mut s = header.join(",");
    s.push('\n');
    let (x, y, dy) = sol.bvp.collocation_points();
    let n = M::N_STATE;
    let (t0, span) = (sol.problem.t0, sol.t_span);
    for (k, ((x, row), drow)) in x
        .iter()
        .zip(y.chunks_exact(n))
        .zip(dy.chunks_exact(n))
        .enumerate()
    {
        csv_number(&mut s, t0 + span * x);
        s.push_str(if k % 3 == 0 { ",0" } else { ",1" });
        for v in row {
            s.push(',');
            csv_number(&mut s, *v);
        }
        // The BVP runs on s = (t - t0) / span: d/dt = (d/ds) / span.
        for v in drow {
            s.push(',');
            csv_number(&mut s, v / span);
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

/// The reconstructed motion `ġ = g Ω̂`, `g(a) = 1` (see [`Motion`]) at the rows of `trajectory.csv`; `None` without a matrix
/// representation.
fn motion<M: Model>(sol: &LieSolution<M>, points: usize) -> Result<Option<Motion>, String> {
    let Some((k, flat)) = M::REPRESENTATION else {
        return Ok(None);
    };
    let rep = Representation::new(M::DIM, k, flat.to_vec()).map_err(|e| e.to_string())?;
    let (a, b) = (sol.problem.t0, sol.terminal_time());
    // The rows of trajectory.csv.
    let times = super::output_times(a, sol.t_span, points, &sol.bvp.x);
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

/// Diagnose and verify `sol` ([`lie::verify_solution`]) and fill a case summary (any model):
/// status "converged" only if every check passes at the solution's requested tolerance,
/// "unverified: …" otherwise (the caller overrides it for a partial result); with the
/// problem's constants, end states, start and stages, and the accessibility rank along the
/// solution. Returns whether the checks passed.
pub(super) fn summarize<M: Model>(name: &str, sol: &LieSolution<M>) -> (CaseSummary, bool) {
    let lie::verify::Verified {
        diagnostics: d,
        reintegration,
        open_loop,
        verification,
    } = lie::verify_solution(sol);
    let verified = verification.passed();
    let status = CaseStatus::from(verification.verdict());
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
        verification: Some((&verification).into()),
        stages: stage_summaries_of(&sol.stages),
        reintegration_max_diff: reintegration.as_ref().ok().map(|r| r.max_abs_diff),
        ..Default::default()
    };
    c.set_status(&status);
    c.model = M::NAME.to_string();
    c.model_source_hash = crate::model::source_hash_of(M::NAME).to_string();
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
    c.extra.insert(
        "bc_residual".into(),
        serde_json::json!(finite(d.bc_residual)),
    );
    // The grid the checks (max |<Omega, xi>|, |xi| range, energy drift, residuals) are
    // taken on: every mesh interval cut into `FINE_PER_INTERVAL` pieces.
    c.extra
        .insert("check_grid_points".into(), serde_json::json!(d.grid_points));
    c.extra.insert(
        "max_relative_residual".into(),
        serde_json::json!(finite(d.max_relative_residual)),
    );
    // The Newton matrix of the final mesh: the solution's sensitivity to its boundary data,
    // the matrix's condition estimate, which structured factorisation solved it (LU, or QR
    // where the LU's growth or a pivot was unsafe), its growth (at most 1e3 for the LU, 1 for
    // the QR) and its smallest pivot relative to its column.
    let stats = &sol.bvp.stats;
    c.extra.insert(
        "newton_matrix".into(),
        serde_json::json!({
            "bc_condition": finite(stats.bc_condition),
            "condition_estimate": finite(stats.condition_estimate),
            "factorization": stats.factorization.name(),
            "factor_growth": finite(stats.factor_growth),
            "factor_min_pivot": finite(stats.factor_min_pivot),
        }),
    );
    // The discrete equations on the final mesh, in tolerance units: their largest defect, and
    // the same before the allowance for the rounding of f (above 1: they hold to f's rounding,
    // not to the tolerance, on some intervals; bvp::mesh).
    c.extra.insert(
        "discrete_defect".into(),
        serde_json::json!({
            "max": finite(stats.max_defect),
            "before_rounding_allowance": finite(stats.max_raw_defect),
        }),
    );
    if let Err(e) = &reintegration {
        c.extra
            .insert("reintegration_error".into(), serde_json::json!(e));
    }
    if let Ok(r) = &reintegration {
        c.extra
            .insert("reintegration_windows".into(), serde_json::json!(r.windows));
    }
    // Not judged: the open-loop re-integration from Omega_a over [a, b] (the motion's
    // sensitivity; lie::checks::REINTEGRATION_WINDOW_ANGLE).
    match &open_loop {
        Ok(r) => c.extra.insert(
            "reintegration_open_loop_max_diff".into(),
            serde_json::json!(finite(r.max_abs_diff)),
        ),
        Err(e) => c
            .extra
            .insert("reintegration_open_loop_error".into(), serde_json::json!(e)),
    };
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
        "routes".into(),
        serde_json::json!(sol
            .routes
            .iter()
            .map(|r| serde_json::json!({
                "route": r.route,
                "stopped": r.stopped,
                "seconds": r.seconds,
            }))
            .collect::<Vec<_>>()),
    );
    // A solution reached past a fold may be a saddle or a maximizer: the second-order
    // certificate says which (issue #12: no saddle passed off as a minimum).
    let folds: Vec<f64> = sol
        .stages
        .iter()
        .flat_map(|s| s.folds.iter().copied())
        .collect();
    if !folds.is_empty() {
        use crate::ocp::{NewtonOptions, SecondOrderOptions};
        let certified = lie::certify::certify(
            sol,
            &NewtonOptions::default(),
            &SecondOrderOptions::default(),
        );
        c.extra.insert(
            "after_fold".into(),
            match certified {
                Ok(cert) => serde_json::json!({
                    "folds": folds,
                    "verdict": cert.verdict(),
                    "sentence": cert.verdict().sentence(),
                }),
                Err(e) => serde_json::json!({
                    "folds": folds,
                    "verdict": "none",
                    "sentence": format!("the certificate could not be computed: {e}"),
                }),
            },
        );
    }
    // Controls with a vanishing xi (lie::collapse): on a stop, the solver's evidence; on a
    // verified extremal, whether one costs less (then the extremal is a local minimum only).
    let collapse = match &sol.collapse {
        Some(found) => Some(found.clone()),
        None if verified => lie::collapse::for_solution(sol, d.cost, 0.0),
        None => None,
    };
    if let Some(found) = collapse {
        c.extra.insert("collapse".into(), serde_json::json!(found));
    }
    if !sol.time_scan.is_empty() {
        c.extra.insert(
            "time_scan".into(),
            serde_json::json!(sol
                .time_scan
                .iter()
                .map(|s| serde_json::json!({
                    "span": s.span,
                    "cost": s.cost,
                    "stopped": s.stopped,
                    "reached_by": if s.continued {
                        "continuation in b - a from the fixed-time solution at b_p"
                    } else {
                        "its own homotopy"
                    },
                }))
                .collect::<Vec<_>>()),
        );
    }
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
    (config_path, out): (&Path, &Path),
    output: &super::OutputOptions,
    events: &mut dyn FnMut(AppEvent),
) -> Result<report::Summary, AppError> {
    let LoadedModelProblem {
        name,
        problem,
        options,
        resolved,
    } = file.build::<M>()?;
    let input = super::InputCopy::new(&resolved, config_path, text, out);
    let mut dir = OutputDir::open(out)?;
    dir.check_free(
        files()
            .into_iter()
            .chain(input.files())
            .chain([report::SUMMARY_FILE.into()]),
    )?;
    input.write(&mut dir, events)?;
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
            let (stem, colloc) = if verified {
                ("trajectory", "collocation.csv")
            } else {
                ("trajectory.unverified", "collocation.unverified.csv")
            };
            let (names, columns) = trajectory_columns(&sol, output.points);
            write(
                &mut dir,
                &format!("{stem}.csv"),
                trajectory_csv(&names, &columns).as_bytes(),
            )?;
            write(
                &mut dir,
                &format!("{stem}.npz"),
                &trajectory_npz(&names, &columns)?,
            )?;
            write(&mut dir, colloc, collocation_csv(&sol).as_bytes())?;
            if verified {
                match motion(&sol, output.points) {
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
                format!(
                    " at {parameter} = {} (target {})",
                    crate::echo::Num(reached),
                    crate::echo::Num(target)
                )
            } else {
                String::new()
            };
            let stop = format!("stage '{stage}' stopped{at}: {reason}");
            c.set_status(&CaseStatus::Partial(stop.clone()));
            let (names, columns) = trajectory_columns(&partial, output.points);
            write(
                &mut dir,
                "trajectory.partial.csv",
                trajectory_csv(&names, &columns).as_bytes(),
            )?;
            write(
                &mut dir,
                "trajectory.partial.npz",
                &trajectory_npz(&names, &columns)?,
            )?;
            write(
                &mut dir,
                "collocation.partial.csv",
                collocation_csv(&partial).as_bytes(),
            )?;
            let found = partial.collapse.as_ref();
            if let Some(infimum) =
                infimum_output(&partial.problem, found, output.points, &mut c.extra)
            {
                write(&mut dir, INFIMUM_FILE, infimum.text.as_bytes())?;
                c.set_status(&infimum.status(&stop));
            }
            c
        }
        Err(e) => {
            let mut c = CaseSummary::failed(
                &name,
                &e.to_string(),
                M::NAME,
                crate::model::source_hash_of(M::NAME),
            );
            // A start that fails on every route, explained by the direct method's minimum:
            // that evidence, and where the minimizing controls collapse, the ε-optimal control.
            if let LieSolveError::Start {
                collapse: Some(found),
                ..
            } = &e
            {
                c.extra.insert("collapse".into(), serde_json::json!(found));
                if let Some(infimum) =
                    infimum_output(&problem, Some(found), output.points, &mut c.extra)
                {
                    write(&mut dir, INFIMUM_FILE, infimum.text.as_bytes())?;
                    c.set_status(&infimum.status(&e.to_string()));
                }
            }
            c
        }
    };
    case.wall_seconds = clock.elapsed().as_secs_f64();
    case.input = Some(resolved.to_json());
    case.extra.insert(
        "problem_file".into(),
        serde_json::json!(config_path.display().to_string()),
    );
    events(AppEvent::CaseFinished(&case));
    let summary = report::Summary::new(vec![case]);
    finish(dir, &summary, events)?;
    Ok(summary)
}

/// The certificate report of one solve (any model): the solve's error, or the solution
/// verified and certified on its own mesh ([`crate::lie::certify`]), with both times.
pub(super) fn certify_solved<M: Model>(
    name: &str,
    solved: Result<LieSolution<M>, impl std::fmt::Display>,
    solve_seconds: f64,
) -> report::CertificateReport {
    use crate::ocp::{NewtonOptions, SecondOrderOptions};
    use report::CertificateReport;
    let mut report = match solved {
        Err(e) => CertificateReport::error(name, format!("the solve failed: {e}")),
        Ok(sol) => {
            let verification = lie::verify_solution(&sol).verification;
            let clock = Instant::now();
            let cert = lie::certify::certify(
                &sol,
                &NewtonOptions::default(),
                &SecondOrderOptions::default(),
            );
            let mut r = match cert {
                Ok(c) => CertificateReport::from_certificate(name, &c),
                Err(e) => CertificateReport::error(name, format!("certificate: {e}")),
            };
            r.certify_seconds = clock.elapsed().as_secs_f64();
            r.solution_status = Some(CaseStatus::from(verification.verdict()).to_string());
            r
        }
    };
    report.solve_seconds = solve_seconds;
    report
}

/// `suslov certify FILE` for a [`ModelFile`] of model `M`: solve, verify, certify on the
/// solution's own mesh ([`crate::lie::certify`]); the report as for so(3).
pub fn run_model_certify<M: Model>(
    file: &ModelFile,
    tolerance: Option<f64>,
    json: Option<&Path>,
    events: &mut dyn FnMut(AppEvent),
) -> Result<Vec<report::CertificateReport>, AppError> {
    super::prepare_certificate_json(json)?;
    let LoadedModelProblem {
        name,
        problem,
        mut options,
        ..
    } = file.build::<M>()?;
    if let Some(t) = tolerance {
        options.tol = t;
    }
    events(AppEvent::CaseStarted { name: &name });
    let clock = Instant::now();
    let solved = lie::solve(&problem, &options, &mut |e| events(AppEvent::Solve(e)));
    let solve_seconds = clock.elapsed().as_secs_f64();
    let report = certify_solved(&name, solved, solve_seconds);
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
        ..
    } = file.build::<M>()?;
    events(AppEvent::CaseStarted { name: &name });
    let sol = match lie::solve(&problem, &options, &mut |e| events(AppEvent::Solve(e))) {
        Ok(sol) => sol,
        Err(e) => {
            events(AppEvent::CaseEnded { name: &name });
            return Ok(super::RankAlong {
                text: format!("case {name}: the solve failed: {e}\n"),
                all_accessible: false,
                cases: vec![serde_json::json!({
                    "name": name,
                    "model": M::NAME,
                    "solve_error": e.to_string(),
                })],
            });
        }
    };
    let mut text = String::new();
    let verification = lie::verify_solution(&sol).verification;
    let mut all_accessible = true;
    let verdict = verification.verdict();
    let unverified = match &verdict {
        Verdict::Unverified { reason } => Some(reason.clone()),
        Verdict::Verified => None,
    };
    if let Some(reason) = &unverified {
        all_accessible = false;
        text += &format!(
            "case {name}: the solution did not pass its a-posteriori checks ({reason}); the \
             rank test below runs along it anyway\n"
        );
    }
    let r = lie::controllability::rank_along(&sol, points, rtol);
    all_accessible &= r.min_rank == r.dim_m && r.max_rank == r.dim_m;
    let (a, b) = (sol.problem.t0, sol.terminal_time());
    // The constraint's residual: <Omega, xi> for the paper's constraint, <Omega, xi> - gamma
    // with a constraint value gamma (so3_inhomogeneous: ⟨Ω, ξ⟩ = c).
    let (residual, moved) = if M::HAS_CONSTRAINT_VALUE {
        (
            "|<Omega, xi> - gamma|/(|Omega| |xi|) (gamma the constraint value)",
            "xi moved onto the constraint level <Omega, xi> = gamma",
        )
    } else {
        (
            "|<Omega, xi>|/(|Omega| |xi|)",
            "xi projected onto Omega^perp",
        )
    };
    text += &format!(
        "case {name} (model {}): rank of V {} at all {points} times of [{a}, {b:.6}] (dim M = \
         {})\n  smallest sigma_(dim M)/sigma_1 {:.4e}; largest sigma_(dim M + 1)/sigma_1 \
         {:.1e}; the solution's max {residual} {:.1e} at these times ({moved} for the test)\n",
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
    let case = serde_json::json!({
        "name": name,
        "model": M::NAME,
        "unverified": unverified,
        "t0": a,
        "terminal_time": b,
        "dim_m": r.dim_m,
        "max_constraint": r.max_constraint,
        "rank": r,
    });
    Ok(super::RankAlong {
        text,
        all_accessible,
        cases: vec![case],
    })
}

/// A number in a message or a header: plain when moderate, else in exponent notation.
fn num(v: f64) -> String {
    if v == 0.0 || (1e-4..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `[a, b, …]` with [`num`].
fn vec_text(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| num(*x)).collect();
    format!("[{}]", parts.join(", "))
}

/// The parameters `metas` with their docs, for a message.
fn parameter_list(metas: &[ParamMeta]) -> String {
    metas
        .iter()
        .map(|m| format!("{} ({})", m.name, m.doc))
        .collect::<Vec<_>>()
        .join(", ")
}

/// An admissible example `name=value,…` of `metas`: the lower bound + 1, or 0 when unbounded
/// below (the upper bound if 0 exceeds it).
fn parameter_example(metas: &[ParamMeta]) -> String {
    metas
        .iter()
        .map(|m| {
            let v = match (m.lower, m.upper) {
                (Some(lo), Some(hi)) => (lo + 1.0).min(hi),
                (Some(lo), None) => lo + 1.0,
                (None, Some(hi)) => hi.min(0.0),
                (None, None) => 0.0,
            };
            format!("{}={}", m.name, num(v))
        })
        .collect::<Vec<_>>()
        .join(",")
}

/// Reads `name=value,…` for the parameters `metas` of model `M` from the flag `flag` (every
/// one required, each admissible) into `p`.
fn parse_named_parameters<M: Model>(
    flag: &str,
    what: &str,
    text: &str,
    metas: &[ParamMeta],
    p: &mut [f64],
) -> Result<(), AppError> {
    let err = |message: String| AppError::InvalidArgument(format!("{flag}: {message}"));
    let usage = || {
        format!(
            "model {} takes its {what} as name=value pairs, e.g. {flag} {}; its parameters: {}",
            M::NAME,
            parameter_example(metas),
            parameter_list(metas)
        )
    };
    let mut given: Vec<&str> = Vec::new();
    for entry in text.split(',') {
        let Some((name, value)) = entry.split_once('=') else {
            return Err(err(format!(
                "{} is not name=value; {}",
                crate::echo::echo(entry.trim()),
                usage()
            )));
        };
        let (name, value) = (name.trim(), value.trim());
        let Some(meta) = metas.iter().find(|m| m.name == name) else {
            return Err(err(format!(
                "model {} has no parameter {}; {}",
                M::NAME,
                crate::echo::echo(name),
                usage()
            )));
        };
        if given.contains(&meta.name) {
            return Err(err(format!(
                "{} is given twice; give each parameter once",
                meta.name
            )));
        }
        let v: f64 = value.parse().map_err(|e| {
            err(format!(
                "{}={}: not a number ({e}); {}: {}",
                meta.name,
                crate::echo::echo(value),
                meta.name,
                meta.doc
            ))
        })?;
        if !v.is_finite() {
            return Err(err(format!(
                "{} = {v} is not a finite number; {}: {}",
                meta.name, meta.name, meta.doc
            )));
        }
        if !meta.admits(v) {
            return Err(err(format!(
                "{} = {} is not admissible: {}",
                meta.name,
                num(v),
                meta.doc
            )));
        }
        p[meta.index] = v;
        given.push(meta.name);
    }
    let missing: Vec<&str> = metas
        .iter()
        .map(|m| m.name)
        .filter(|name| !given.contains(name))
        .collect();
    if !missing.is_empty() {
        return Err(err(format!("missing {}; {}", missing.join(", "), usage())));
    }
    Ok(())
}

/// Reads `n` comma-separated finite numbers (a vector of the Lie algebra of `M`).
fn parse_algebra_vector<M: Model>(flag: &str, text: &str) -> Result<Vec<f64>, AppError> {
    let n = M::DIM;
    let shape = || {
        format!(
            "model {} has dimension n = {n} (basis {}): give {n} comma-separated numbers, e.g. \
             {}",
            M::NAME,
            M::BASIS_NAMES.join(", "),
            (0..n)
                .map(|i| if i == 0 { "1" } else { "0" })
                .collect::<Vec<_>>()
                .join(",")
        )
    };
    let parts: Vec<&str> = text.split(',').collect();
    if parts.len() != n {
        return Err(AppError::InvalidArgument(format!(
            "{flag}: {} has {} comma-separated entries; {}",
            crate::echo::echo(text),
            parts.len(),
            shape()
        )));
    }
    let v = parts
        .iter()
        .map(|s| {
            s.trim().parse::<f64>().map_err(|e| {
                AppError::InvalidArgument(format!(
                    "{flag}: {} is not a number ({e}); {}",
                    crate::echo::echo(s.trim()),
                    shape()
                ))
            })
        })
        .collect::<Result<Vec<f64>, _>>()?;
    if !v.iter().all(|x| x.is_finite()) {
        return Err(AppError::InvalidArgument(format!(
            "{flag}: {} is not {n} finite numbers; {}",
            crate::echo::echo(text),
            shape()
        )));
    }
    Ok(v)
}

/// The constants `p` of model `M` from `--inertia` and `--constraint` (the weights, which the
/// control fields do not involve, stay 0), checked and with the derived constants filled.
pub(crate) fn rank_parameters<M: Model>(
    inertia: Option<&str>,
    constraint: Option<&str>,
) -> Result<Vec<f64>, AppError> {
    let mut p = vec![0.0; M::N_PARAM];
    let inertia = inertia.ok_or_else(|| {
        AppError::InvalidArgument(format!(
            "--inertia: model {} needs its inertia parameters as name=value pairs, e.g. \
             --inertia {}; its parameters: {}",
            M::NAME,
            parameter_example(M::INERTIA_PARAMS),
            parameter_list(M::INERTIA_PARAMS)
        ))
    })?;
    parse_named_parameters::<M>(
        "--inertia",
        "inertia parameters",
        inertia,
        M::INERTIA_PARAMS,
        &mut p,
    )?;
    constraint_parameters::<M>(constraint, &mut p)?;
    crate::model::fill_derived::<M>(&mut p).map_err(|e| {
        AppError::InvalidArgument(format!(
            "--inertia: {e} (give parameters of a positive definite inertia, e.g. --inertia {})",
            parameter_example(M::INERTIA_PARAMS)
        ))
    })?;
    Ok(p)
}

/// Reads `--constraint` (`name=value` pairs of the constraint parameters of `M`) into `p`:
/// required for a model with constraint parameters, refused for the others.
pub(crate) fn constraint_parameters<M: Model>(
    constraint: Option<&str>,
    p: &mut [f64],
) -> Result<(), AppError> {
    match (constraint, M::CONSTRAINT_PARAMS.is_empty()) {
        (Some(_), true) => {
            let with: Vec<String> = crate::model::MODEL_NAMES
                .iter()
                .filter_map(|name| {
                    crate::model::with_model!(*name, N => {
                        (!N::CONSTRAINT_PARAMS.is_empty()).then(|| {
                            format!(
                                "{name} ({})",
                                N::CONSTRAINT_PARAMS
                                    .iter()
                                    .map(|m| m.name)
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            )
                        })
                    }, _ => None)
                })
                .collect();
            Err(AppError::InvalidArgument(format!(
                "--constraint: model {} has no constraint parameters (its constraint is \
                 <Omega, xi> = 0); drop --constraint (models with constraint parameters: {})",
                M::NAME,
                if with.is_empty() {
                    "none".to_string()
                } else {
                    with.join(", ")
                }
            )))
        }
        (None, false) => Err(AppError::InvalidArgument(format!(
            "--constraint: model {} needs its constraint parameters as name=value pairs, \
                 e.g. --constraint {}; its parameters: {}",
            M::NAME,
            parameter_example(M::CONSTRAINT_PARAMS),
            parameter_list(M::CONSTRAINT_PARAMS)
        ))),
        (Some(text), false) => parse_named_parameters::<M>(
            "--constraint",
            "constraint parameters",
            text,
            M::CONSTRAINT_PARAMS,
            p,
        ),
        (None, true) => Ok(()),
    }
}

/// `suslov controllability [--omega … --xi …]` for model `M` (not so3, whose table is the
/// so(3) layer's): the accessibility rank test ([`lie::controllability::rank_at`]) at one
/// state or at `--samples` seeded states of `M` ([`lie::controllability::sample_states`]);
/// every argument is checked (named in the error) before any work. Returns the table and its
/// verdict (rank `dim M` at every state of `M` tested, or not).
pub fn run_model_rank_at_states<M: Model>(
    a: &super::RankAtStates,
) -> Result<super::RankTable, AppError> {
    use crate::lie::controllability::{rank_at, sample_states, ON_LEVEL_RTOL};
    use crate::so3::controllability as c;
    use std::fmt::Write;
    c::check_rtol(a.rtol).map_err(|e| AppError::InvalidArgument(e.to_string()))?;
    let p = rank_parameters::<M>(a.inertia, a.constraint)?;
    let n = M::DIM;
    let conserves_energy = crate::model::constraint_value_vanishes::<M>(&p);
    let dim_m = lie::controllability::dim_m::<M>(&p);
    let (states, origin) = match a.state {
        Some((om, xi)) => {
            let mut x = parse_algebra_vector::<M>("--omega", om)?;
            x.extend(parse_algebra_vector::<M>("--xi", xi)?);
            if x[M::XI].iter().all(|v| *v == 0.0) {
                return Err(AppError::InvalidArgument(
                    "--xi: xi = 0 is no constraint (M needs xi != 0); give a nonzero xi".into(),
                ));
            }
            (vec![x], "the state given (--omega, --xi)".to_string())
        }
        None => {
            if !(1..=c::MAX_STATES).contains(&a.samples) {
                return Err(AppError::InvalidArgument(format!(
                    "--samples must be between 1 and {}, got {}",
                    c::MAX_STATES,
                    a.samples
                )));
            }
            let omega_a = match a.omega_a {
                Some(text) => parse_algebra_vector::<M>("--omega-a", text)?,
                None => (0..n).map(|i| if i == 0 { 5.0 } else { 0.0 }).collect(),
            };
            if omega_a.iter().all(|v| *v == 0.0) {
                return Err(AppError::InvalidArgument(
                    "--omega-a = 0: the sampled states need a positive kinetic energy; give a \
                     nonzero vector"
                        .into(),
                ));
            }
            let states = sample_states::<M>(&p, &omega_a, a.samples, a.seed)
                .map_err(|e| AppError::InvalidArgument(format!("--omega-a with --inertia: {e}")))?;
            let mut inertia = vec![0.0; n * n];
            M::inertia_matrix(&p, &mut inertia);
            let level: f64 = (0..n)
                .map(|i| omega_a[i] * (0..n).map(|j| inertia[i * n + j] * omega_a[j]).sum::<f64>())
                .sum();
            let choice = if conserves_energy {
                String::new()
            } else {
                " (with a nonzero constraint value M is the constraint level alone and the \
                 energy is not fixed on it: fixing it is one choice of states of M)"
                    .to_string()
            };
            (
                states,
                format!(
                    "{} seeded random states (--seed {}): Omega drawn uniformly in [-1, 1]^{n} and \
                     projected radially onto the energy level set <Omega, I Omega> = {} through \
                     Omega_a = {}{choice}; xi drawn uniformly in [-1, 1]^{n}",
                    a.samples,
                    a.seed,
                    num(level),
                    vec_text(&omega_a)
                ),
            )
        }
    };
    let rows = states
        .iter()
        .map(|x| rank_at::<M>(x, &p, a.rtol))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| {
            let flag = if a.state.is_some() {
                "--omega, --xi"
            } else {
                "--omega-a with --inertia"
            };
            AppError::InvalidArgument(format!("{flag}: {e}"))
        })?;

    let mut s = String::new();
    let parameters: Vec<String> = M::INERTIA_PARAMS
        .iter()
        .chain(M::CONSTRAINT_PARAMS)
        .map(|m| format!("{} = {}", m.name, num(p[m.index])))
        .collect();
    let _ = writeln!(
        s,
        "Accessibility of Suslov's pure equations, model {}: {}\n\
         x = [Omega, xi], u = xi' (paper section 4.3, for any Lie algebra); {}; basis {}\n\
         V = [g_1 .. g_{n}, [g_i, g_j] (i < j)] ({n} + {} columns); rank = #{{sigma_k > {:e} \
         sigma_1}}",
        M::NAME,
        M::TITLE,
        parameters.join(", "),
        M::BASIS_NAMES.join(", "),
        M::N_BRACKETS,
        a.rtol
    );
    let _ = writeln!(
        s,
        "{}\nStates: {origin}.\nEach row is the state tested: the state moved onto the \
         constraint level phi = <Omega, xi> - gamma(xi) = 0 (xi along dphi/dxi){}; \
         |phi|/(|Om||xi|) is that of the state before the move.\n",
        if conserves_energy {
            format!(
                "M = {{<Omega, xi> = 0, 1/2 <I Omega, Omega> = e > 0, xi != 0}}: dim M = 2n - 2 \
                 = {dim_m}"
            )
        } else {
            format!(
                "M = {{phi = <Omega, xi> - gamma(xi) = 0, Omega != 0}} (the energy is not \
                 conserved: dT/dt = lambda gamma): dim M = 2n - 1 = {dim_m}"
            )
        },
        if conserves_energy {
            ", with xi scaled to unit length (the rank does not depend on it, the \
             conditioning does)"
        } else {
            ""
        }
    );
    let cell = |x: f64| {
        if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
            format!("{x:7.3}")
        } else {
            format!("{x:7.1e}")
        }
    };
    let vector = |v: &[f64]| {
        let parts: Vec<String> = v.iter().map(|x| cell(*x)).collect();
        format!("[{}]", parts.join(", "))
    };
    let width = 9 * n;
    let (label_dim, label_next) = (
        format!("sigma_{dim_m}/sigma_1"),
        format!("sigma_{}/sigma_1", dim_m + 1),
    );
    let _ = writeln!(
        s,
        "{:>3}  {:>width$}  {:>width$}  {:>16}  {:>4}  {:>4}  {:>ld$}  {:>ln$}",
        "#",
        "Omega",
        "xi",
        "|phi|/(|Om||xi|)",
        "on M",
        "rank",
        label_dim,
        label_next,
        ld = label_dim.len(),
        ln = label_next.len(),
    );
    for (k, r) in rows.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:>3}  {:>width$}  {:>width$}  {:>16.1e}  {:>4}  {:>4}  {:>ld$.3e}  {:>ln$.1e}",
            k,
            vector(&r.tested[M::OMEGA]),
            vector(&r.tested[M::XI]),
            r.violation,
            if r.on_m { "yes" } else { "no" },
            r.rank,
            r.sigma_dim_m,
            r.sigma_next,
            ld = label_dim.len(),
            ln = label_next.len(),
        );
    }
    for ((k, r), given) in rows.iter().enumerate().zip(&states) {
        if r.moved {
            let _ = writeln!(
                s,
                "state {k} as given, Omega = {}, xi = {}, is off the constraint level \
                 (|phi|/(|Omega||xi|) = {:.3e} > {ON_LEVEL_RTOL:e}): the row is the nearest \
                 state on it",
                vec_text(&given[M::OMEGA]),
                vec_text(&given[M::XI]),
                r.violation
            );
        }
    }
    if rows.iter().any(|r| r.scales != (0, 0)) {
        let _ = writeln!(
            s,
            "(states with a component beyond 2^20 or all below 2^-20 in size: V and its \
             singular values are evaluated at Omega and xi rescaled by exact powers of two, \
             which leaves the rank and M unchanged)"
        );
    }
    let on_m_rows: Vec<_> = rows.iter().filter(|r| r.on_m).collect();
    let off_m: Vec<_> = rows.iter().filter(|r| !r.on_m).collect();
    let span = |v: &[&lie::controllability::StateRank]| match (
        v.iter().map(|r| r.rank).min(),
        v.iter().map(|r| r.rank).max(),
    ) {
        (Some(lo), Some(hi)) if lo == hi => format!("{lo}"),
        (Some(lo), Some(hi)) => format!("{lo}..{hi}"),
        _ => "-".into(),
    };
    let failing = on_m_rows.iter().filter(|r| r.rank != dim_m).count();
    let verdict = if on_m_rows.is_empty() {
        AccessibilityVerdict::NoStateOnM
    } else if failing == 0 {
        AccessibilityVerdict::Accessible {
            on_m: on_m_rows.len(),
        }
    } else {
        AccessibilityVerdict::RankDeficient {
            on_m: on_m_rows.len(),
            failing,
        }
    };
    let _ = writeln!(
        s,
        "\nrank on M (Omega != 0, |phi| <= {ON_LEVEL_RTOL:e} |Om||xi| at the state tested): {} \
         ({} states); off M: {} ({} states)",
        span(&on_m_rows),
        on_m_rows.len(),
        span(&off_m),
        off_m.len()
    );
    match verdict {
        AccessibilityVerdict::NoStateOnM => {
            let _ = writeln!(
                s,
                "No state tested lies on M (Omega = 0, or the state could not be moved onto the \
                 constraint level): the rank condition on M says nothing about them."
            );
        }
        AccessibilityVerdict::RankDeficient { on_m, failing } => {
            let _ = writeln!(
                s,
                "rank V != {dim_m} = dim M at {failing} of the {on_m} states of M: the \
                 first-order brackets do NOT span the tangent space of M there at this \
                 threshold (check --rtol)."
            );
        }
        AccessibilityVerdict::Accessible { on_m } => {
            let margin = on_m_rows
                .iter()
                .map(|r| r.sigma_dim_m)
                .fold(f64::INFINITY, f64::min);
            let _ = writeln!(
                s,
                "rank V = {dim_m} = dim M at all {on_m} states of M tested (smallest \
                 sigma_{dim_m}/sigma_1 {margin:.3e}): the accessibility rank condition holds \
                 there with first-order brackets (every field is tangent to M, so dim M is the \
                 largest rank possible)."
            );
        }
    }
    let json = serde_json::json!({
        "model": M::NAME,
        "parameters": M::INERTIA_PARAMS
            .iter()
            .chain(M::CONSTRAINT_PARAMS)
            .map(|m| (m.name.to_string(), serde_json::json!(p[m.index])))
            .collect::<serde_json::Map<_, _>>(),
        "rtol": a.rtol,
        "dim_m": dim_m,
        "states": rows,
        "verdict": verdict,
    });
    Ok(super::RankTable {
        text: s,
        verdict,
        json,
    })
}
