//! The jobs behind the command line, as library functions (the binary is a thin shell).
//!
//! [`run_paper`] reproduces the paper's section 5.3: both cases are solved from the analytic
//! singular solution through the staged homotopy, verified a posteriori
//! ([`crate::lie::verify`]) and written to an output directory:
//!
//! ```text
//! DIR/summary.json             one entry per case (see report::CaseSummary)
//! DIR/<case>/trajectory.csv    t, Ω, ξ, ξ̇, κ, Ω_d on a uniform grid of [a, b]
//! DIR/<case>/trajectory.npy    the same table for numpy (float64, shape (rows, 16))
//! DIR/<case>/*.png, *.svg   Ω, Ω_d and ξ_∥ in 3-D; ⟨Ω, ξ⟩; |ξ|; κ; Ω components; ξ; ξ̇
//! ```
//!
//! [`run_solve`] does the same for one problem read from a TOML file ([`crate::config`]),
//! writing `summary.json`, the trajectory and the figures directly into its directory, with
//! the input with every default filled in as `problem.toml` (and the files it names:
//! [`config::resolved`]), so that `suslov solve DIR/problem.toml` repeats the run; `paper`
//! writes one per case directory.
//!
//! [`run_certify`] solves the paper's cases (or one problem file) and certifies each
//! solution as a local minimum of the discretized problem, or not
//! ([`crate::lie::certify`]).
//!
//! Every file is written atomically into an [`OutputDir`]: the directory is locked for the run,
//! the previous run's files are removed first, `INCOMPLETE` marks it until `summary.json`,
//! the last file, is complete. A case that fails writes what it has, marked: its summary
//! status says `partial: <stage, parameter value, reason>` and its trajectory goes to
//! `trajectory.partial.csv` (and `.npy`), and, when its evidence shows the problem's infimum
//! approached as `ξ → 0`, the ε-optimal control to `trajectory.infimum.csv`
//! ([`lie::INFIMUM_FILE`]; also for a start that fails on every route, where the direct
//! method's minimum is that evidence); a solution that fails its a-posteriori checks
//! ([`crate::lie::verify`]) has status `unverified: <checks>` and goes to
//! `trajectory.unverified.csv` (and `.npy`). Figures are drawn for verified solutions only.

use std::path::{Path, PathBuf};
use std::time::Instant;

pub mod lie;

use crate::config::{self, ConfigError};
use crate::lie::checks::Verdict;
use crate::model::generated::{DIM, KAPPA, OMEGA, XI, XIDOT};
use crate::report::{
    self, CaseStatus, CaseSummary, CertificateReport, FigureFormat, FigureOptions, OutputDir,
    ReportError, StabilityRun, StageSummary, StatusCode, Summary, TrajectoryTable,
};
use crate::so3::paper;
use crate::so3::problem::SuslovProblem;
use crate::so3::solve::{self, Event, SolveError, SolveOptions, SuslovSolution};
use crate::so3::stability::{stability_runs, PERTURBATION};

/// Uniform points of the output grid (trajectory.csv and figures) unless `--points` says
/// otherwise; the mesh nodes are added to them ([`output_times`]).
pub const OUTPUT_POINTS: usize = 2001;

/// Allowed `--points`: at least the two ends; at most a million rows (about 170 MB of CSV).
pub const OUTPUT_POINTS_RANGE: (usize, usize) = (2, 1_000_000);

/// What the jobs write besides the solution's own data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputOptions {
    /// Uniform points of `trajectory.csv`/`.npy` (the mesh nodes are added).
    pub points: usize,
}

impl Default for OutputOptions {
    fn default() -> Self {
        Self {
            points: OUTPUT_POINTS,
        }
    }
}

impl OutputOptions {
    /// `points` checked against [`OUTPUT_POINTS_RANGE`].
    ///
    /// # Errors
    /// [`AppError::InvalidArgument`] naming `--points` and the range.
    pub fn with_points(points: usize) -> Result<Self, AppError> {
        let (lo, hi) = OUTPUT_POINTS_RANGE;
        if (lo..=hi).contains(&points) {
            Ok(Self { points })
        } else {
            Err(AppError::InvalidArgument(format!(
                "--points {points}: give between {lo} and {hi} uniform output points"
            )))
        }
    }
}

/// The output grid of a solution on `[t0, t0 + span]`: `points` uniform times (the last one
/// exactly `t0 + span`) and the mesh nodes `t0 + span x_i` (`x` on `[0, 1]`), in increasing
/// order. A uniform time closer than a thousandth of the uniform step to a node is left out
/// (the node stays), so no two rows are nearly equal (a difference quotient over the grid stays
/// well conditioned).
pub fn output_times(t0: f64, span: f64, points: usize, mesh: &[f64]) -> Vec<f64> {
    let points = points.max(2);
    let b = t0 + span;
    let gap = 1e-3 * span.abs() / (points - 1) as f64;
    let uniform = (0..points).map(|k| {
        if k + 1 == points {
            b
        } else {
            t0 + span * k as f64 / (points - 1) as f64
        }
    });
    // The end nodes exactly (x = 0, 1).
    let nodes: Vec<f64> = mesh
        .iter()
        .map(|x| if *x >= 1.0 { b } else { t0 + span * x })
        .collect();
    let mut t: Vec<f64> = uniform
        .filter(|u| {
            let k = nodes.partition_point(|n| n < u);
            let near = |i: usize| nodes.get(i).is_some_and(|n| (n - u).abs() <= gap);
            !(near(k) || (k > 0 && near(k - 1)))
        })
        .chain(nodes.iter().copied())
        .collect();
    t.sort_by(f64::total_cmp);
    t.dedup();
    t
}

/// What the jobs report while running.
#[derive(Debug)]
pub enum AppEvent<'a> {
    /// A case starts.
    CaseStarted {
        /// Case name.
        name: &'a str,
    },
    /// Progress inside the solve of the current case.
    Solve(&'a Event<'a>),
    /// A case ended (converged or not).
    CaseFinished(&'a CaseSummary),
    /// A case was certified (or not).
    Certified(&'a CertificateReport),
    /// A case of a job without a summary (the rank test along a trajectory) ended.
    CaseEnded {
        /// Case name.
        name: &'a str,
    },
    /// A file was written.
    Wrote(&'a Path),
    /// The problem file is valid but something in it is probably not what was meant.
    Warning(&'a config::ConfigWarning),
}

/// Errors that stop a job (per-case solver failures do not: they are recorded).
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// Writing an output failed.
    #[error(transparent)]
    Report(#[from] ReportError),
    /// The problem file is invalid (names the field and the fix).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A command-line argument is invalid (says which and how to fix it).
    #[error("{0}")]
    InvalidArgument(String),
}

/// Sample a solution with `Ω_d` on its output grid ([`output_times`]: `points` uniform times
/// of `[a, b]` and the mesh nodes).
pub fn trajectory_table(sol: &SuslovSolution, points: usize) -> TrajectoryTable {
    let g = &sol.generic;
    let mut table = TrajectoryTable::default();
    for t in output_times(g.problem.t0, g.t_span, points, &g.bvp.x) {
        let y = sol.state(t);
        let block = |r: std::ops::Range<usize>| -> [f64; DIM] {
            y[r].try_into().expect("a state block has DIM entries")
        };
        table.t.push(t);
        table.omega.push(block(OMEGA));
        table.xi.push(block(XI));
        table.xi_dot.push(block(XIDOT));
        table.kappa.push(block(KAPPA));
        table.omega_d.push(sol.problem.desired.value(t).into());
    }
    table
}

/// The summary rows of homotopy stages (any model).
fn stage_summaries_of(stages: &[solve::StageReport]) -> Vec<StageSummary> {
    stages
        .iter()
        .map(|s| StageSummary {
            name: s.name.to_string(),
            parameter: s.parameter.to_string(),
            from: s.from,
            to: s.to,
            steps: s.steps,
            newton_iterations: s.newton_iterations,
            failures_recovered: s.failures_recovered,
            outcome: s.outcome.to_string(),
        })
        .collect()
}

/// The case summary of `sol` (the generic layer's summary, for any model: every check of
/// [`crate::lie::verify`] at the solution's requested tolerance) with the so(3) extras: the
/// start's energy deviation of the desired path and the paper's stability experiment
/// ([`stability_runs`]).
pub fn summarize(name: &str, sol: &SuslovSolution, wall_seconds: f64) -> CaseSummary {
    let (mut c, _) = lie::summarize(name, &sol.generic);
    c.wall_seconds = wall_seconds;
    if let Some(start) = c.extra.get_mut("start") {
        start["desired_energy_deviation"] =
            serde_json::json!(finite(sol.generic.start.desired_energy_deviation));
    }
    match stability_runs(sol) {
        Ok(runs) => {
            c.stability = runs
                .iter()
                .map(|(label, rep)| StabilityRun {
                    label: label.clone(),
                    perturbation: PERTURBATION,
                    max_omega_diff: rep.max_deviation,
                    max_xi_diff: rep.max_xi_deviation,
                    final_omega_diff: rep.final_deviation,
                })
                .collect();
        }
        Err(e) => {
            c.extra
                .insert("stability_error".into(), serde_json::json!(e.to_string()));
        }
    }
    c
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Every file a case may write below `sub` (whichever way it ends), for
/// [`OutputDir::check_free`] before the work.
fn case_files(sub: &Path) -> Vec<std::path::PathBuf> {
    let mut names: Vec<String> = ["trajectory", "trajectory.unverified", "trajectory.partial"]
        .iter()
        .flat_map(|stem| {
            [
                format!("{stem}.csv"),
                format!("{stem}.npy"),
                format!("{stem}.npz"),
            ]
        })
        .collect();
    names.extend(
        [Outputs::Final, Outputs::Unverified, Outputs::Partial]
            .map(|k| format!("{}.csv", collocation_stem(k))),
    );
    names.push(lie::INFIMUM_FILE.to_string());
    names.extend(report::Figure::ALL.iter().flat_map(|f| {
        FigureFormat::ALL.map(|format| format!("{}.{}", f.stem(), format.extension()))
    }));
    names.into_iter().map(|n| sub.join(n)).collect()
}

/// Which outputs a case gets: only a verified solution looks final.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outputs {
    /// Converged and verified: `trajectory.csv`/`.npy` and the figures.
    Final,
    /// Solved but failed its a-posteriori checks: `trajectory.unverified.csv`/`.npy` only.
    Unverified,
    /// A homotopy stage stopped: the last converged point as `trajectory.partial.csv`/`.npy`.
    Partial,
}

/// The stem of the collocation solution's file ([`lie::collocation_csv`]) for each kind of
/// outputs, marked as the trajectory's is.
fn collocation_stem(kind: Outputs) -> &'static str {
    match kind {
        Outputs::Final => "collocation",
        Outputs::Unverified => "collocation.unverified",
        Outputs::Partial => "collocation.partial",
    }
}

fn write_case_outputs(
    out: &mut OutputDir,
    sub: &Path,
    sol: &SuslovSolution,
    title: &str,
    (kind, output, threads): (Outputs, &OutputOptions, Threads),
    events: &mut dyn FnMut(AppEvent),
) -> Result<(), AppError> {
    let table = trajectory_table(sol, output.points);
    let stem = match kind {
        Outputs::Final => "trajectory",
        Outputs::Unverified => "trajectory.unverified",
        Outputs::Partial => "trajectory.partial",
    };
    let csv = out.write(
        sub.join(format!("{stem}.csv")),
        report::trajectory_csv_string(&table)?.as_bytes(),
    )?;
    events(AppEvent::Wrote(&csv));
    let npy = out.write(
        sub.join(format!("{stem}.npy")),
        &report::trajectory_npy_bytes(&table)?,
    )?;
    events(AppEvent::Wrote(&npy));
    let npz = out.write(
        sub.join(format!("{stem}.npz")),
        &report::trajectory_npz_bytes(&table)?,
    )?;
    events(AppEvent::Wrote(&npz));
    let colloc = out.write(
        sub.join(format!("{}.csv", collocation_stem(kind))),
        lie::collocation_csv(&sol.generic).as_bytes(),
    )?;
    events(AppEvent::Wrote(&colloc));
    if kind != Outputs::Final {
        return Ok(());
    }
    let inertia = sol.problem.inertia.diag();
    let om_a = sol.problem.omega_a;
    let ellipsoid = report::EnergyEllipsoid::through(inertia.into(), om_a.into())?;
    let mut opts = FigureOptions::new(title, ellipsoid);
    // The titles carry the weights and b, as the paper's captions do; with γ = 0, Ω_d is
    // not in the cost and is not drawn as "desired".
    let w = &sol.problem.weights;
    opts.subtitle = Some(report::case_subtitle(
        title,
        &[
            ("α", w.alpha),
            ("β", w.beta),
            ("γ", w.gamma),
            ("η", w.eta),
            ("δ", w.delta),
        ],
        sol.terminal_time(),
    ));
    opts.desired_in_cost = w.gamma > 0.0;
    // When the optimal b is shorter than the start's b_p (the paper's η = 0.01 case: b = 9.84
    // < b_d = 10), draw Ω_d up to b_p with a marker at Ω_d(b), as the paper's figure does.
    let (a, b, b_p) = (sol.problem.t0, sol.terminal_time(), sol.generic.start.b_p);
    if b_p > b {
        let n = OUTPUT_POINTS;
        opts.desired_extended = Some(
            (0..n)
                .map(|k| {
                    let t = a + (b_p - a) * k as f64 / (n - 1) as f64;
                    sol.problem.desired.value(t).into()
                })
                .collect(),
        );
    }
    // The figures are independent: render every figure in every format ([`FigureFormat::ALL`]:
    // PNG and SVG) on as many threads as the machine has cores (each taking the next figure
    // and keeping one bitmap canvas for all it draws), then write them in their usual order
    // (the bytes do not depend on which thread drew them).
    let jobs: Vec<(report::Figure, FigureOptions)> = report::Figure::ALL
        .iter()
        .flat_map(|&fig| {
            FigureFormat::ALL.map(|format| {
                let opts = FigureOptions {
                    format,
                    ..opts.clone()
                };
                (fig, opts)
            })
        })
        .collect();
    let workers = threads.count().clamp(1, jobs.len());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut rendered: Vec<Option<Result<Vec<u8>, ReportError>>> =
        (0..jobs.len()).map(|_| None).collect();
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                let (jobs, table, next) = (&jobs, &table, &next);
                scope.spawn(move || {
                    let mut canvas = Vec::new();
                    let mut done = Vec::new();
                    loop {
                        let j = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some((fig, opts)) = jobs.get(j) else {
                            break done;
                        };
                        done.push((
                            j,
                            report::render_figure_bytes_in(*fig, table, opts, &mut canvas),
                        ));
                    }
                })
            })
            .collect();
        for handle in handles {
            // A worker that panicked leaves its figures unrendered (reported below).
            if let Ok(done) = handle.join() {
                for (j, bytes) in done {
                    rendered[j] = Some(bytes);
                }
            }
        }
    });
    let rendered = rendered.into_iter().zip(&jobs).map(|(bytes, (fig, _))| {
        bytes.unwrap_or_else(|| {
            Err(ReportError::Plot {
                path: PathBuf::from(fig.stem()),
                message: "the renderer panicked".to_string(),
            })
        })
    });
    for ((fig, opts), bytes) in jobs.iter().zip(rendered) {
        let path = out.write(
            sub.join(format!("{}.{}", fig.stem(), opts.format.extension())),
            &bytes?,
        )?;
        events(AppEvent::Wrote(&path));
    }
    Ok(())
}

/// Solve one problem, verify it and write its outputs into `out` under the relative
/// directory `sub` (empty: `out` itself); never fails for a solver failure (that is recorded
/// in the returned summary).
pub fn run_case(
    name: &str,
    problem: &SuslovProblem,
    (out, sub): (&mut OutputDir, &Path),
    options: &SolveOptions,
    output: &OutputOptions,
    events: &mut dyn FnMut(AppEvent),
) -> Result<CaseSummary, AppError> {
    let SolvedCase { summary, pending } = solve_case(name, problem, options, output, events);
    pending.write(out, sub, (output, Threads::All), events)?;
    Ok(summary)
}

/// How many threads render a case's figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Threads {
    /// As many as the machine has cores.
    All,
    /// One core fewer (at least one): another thread is solving the next case meanwhile.
    AllButOne,
}

impl Threads {
    fn count(self) -> usize {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        match self {
            Threads::All => cores,
            Threads::AllButOne => cores.saturating_sub(1).max(1),
        }
    }
}

/// One case solved, verified and summarized ([`solve_case`]), its files not yet written.
struct SolvedCase {
    summary: CaseSummary,
    pending: PendingOutputs,
}

/// What a case writes: its trajectory tables, collocation solution and figures (per
/// [`Outputs`]), and the ε-optimal control's table when the evidence gives one.
struct PendingOutputs {
    /// The case's name (the figures' title).
    name: String,
    trajectory: Option<(SuslovSolution, Outputs)>,
    infimum: Option<String>,
}

impl PendingOutputs {
    /// Write the files into `out` under `sub`, rendering the figures on `threads`.
    fn write(
        &self,
        out: &mut OutputDir,
        sub: &Path,
        (output, threads): (&OutputOptions, Threads),
        events: &mut dyn FnMut(AppEvent),
    ) -> Result<(), AppError> {
        if let Some((sol, kind)) = &self.trajectory {
            write_case_outputs(out, sub, sol, &self.name, (*kind, output, threads), events)?;
        }
        if let Some(text) = &self.infimum {
            let path = out.write(sub.join(lie::INFIMUM_FILE), text.as_bytes())?;
            events(AppEvent::Wrote(&path));
        }
        Ok(())
    }
}

/// Solve one problem, verify and summarize it (the summary is final: [`AppEvent::CaseFinished`]
/// is sent), and say what it writes.
fn solve_case(
    name: &str,
    problem: &SuslovProblem,
    options: &SolveOptions,
    output: &OutputOptions,
    events: &mut dyn FnMut(AppEvent),
) -> SolvedCase {
    events(AppEvent::CaseStarted { name });
    let clock = Instant::now();
    let result = solve::solve(problem, options, &mut |e| events(AppEvent::Solve(e)));
    let (summary, pending) = match result {
        Ok(sol) => {
            let mut s = summarize(name, &sol, 0.0);
            s.wall_seconds = clock.elapsed().as_secs_f64();
            let kind = if s.status_code == StatusCode::Converged {
                Outputs::Final
            } else {
                Outputs::Unverified
            };
            let pending = PendingOutputs {
                name: name.to_string(),
                trajectory: Some((sol, kind)),
                infimum: None,
            };
            (s, pending)
        }
        Err(SolveError::StageFailed {
            stage,
            parameter,
            reached,
            target,
            reason,
            partial,
        }) => {
            let mut s = summarize(name, &partial, clock.elapsed().as_secs_f64());
            // A single-solve stage (start, polish) has no continuation parameter.
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
            s.set_status(&CaseStatus::Partial(stop.clone()));
            let (generic, found) = (&partial.generic, partial.generic.collapse.as_ref());
            let infimum = lie::infimum_output(&generic.problem, found, output.points, &mut s.extra)
                .map(|infimum| {
                    s.set_status(&infimum.status(&stop));
                    infimum.text
                });
            let pending = PendingOutputs {
                name: name.to_string(),
                trajectory: Some((*partial, Outputs::Partial)),
                infimum,
            };
            (s, pending)
        }
        Err(e) => {
            let mut s = CaseSummary {
                eta: problem.weights.eta,
                wall_seconds: clock.elapsed().as_secs_f64(),
                ..CaseSummary::failed(
                    name,
                    &e.to_string(),
                    <crate::model::generated::So3 as crate::model::Model>::NAME,
                    crate::model::generated::SOURCE_HASH,
                )
            };
            // A start that fails on every route, explained by the direct method's minimum:
            // that evidence, and where the minimizing controls collapse, the ε-optimal control.
            let mut infimum = None;
            if let (
                SolveError::Start {
                    collapse: Some(found),
                    ..
                },
                Ok(generic),
            ) = (&e, problem.to_generic())
            {
                s.extra.insert("collapse".into(), serde_json::json!(found));
                infimum = lie::infimum_output(&generic, Some(found), output.points, &mut s.extra)
                    .map(|infimum| {
                        s.set_status(&infimum.status(&e.to_string()));
                        infimum.text
                    });
            }
            let pending = PendingOutputs {
                name: name.to_string(),
                trajectory: None,
                infimum,
            };
            (s, pending)
        }
    };
    events(AppEvent::CaseFinished(&summary));
    SolvedCase { summary, pending }
}

/// `suslov paper --out DIR`: both cases of section 5.3, each in its own subdirectory, and
/// `DIR/summary.json` last ([`OutputDir`]: the directory is locked for the run and holds
/// exactly this run's files afterwards). Returns the summary.
pub fn run_paper(out: &Path, events: &mut dyn FnMut(AppEvent)) -> Result<Summary, AppError> {
    run_paper_with(out, &OutputOptions::default(), events)
}

/// [`run_paper`] with the given [`OutputOptions`].
pub fn run_paper_with(
    out: &Path,
    output: &OutputOptions,
    events: &mut dyn FnMut(AppEvent),
) -> Result<Summary, AppError> {
    let mut dir = OutputDir::open(out)?;
    dir.check_free(
        paper::CASES
            .iter()
            .flat_map(|c| {
                let mut files = case_files(Path::new(c.name));
                files.push(Path::new(c.name).join(PROBLEM_FILE));
                files
            })
            .chain([report::SUMMARY_FILE.into()]),
    )?;
    let mut summary = Summary::new(Vec::new());
    let options = SolveOptions::default();
    let mut inputs = Vec::with_capacity(paper::CASES.len());
    for case in &paper::CASES {
        let input = config::resolved::paper_case(case);
        let path = dir.write(
            Path::new(case.name).join(PROBLEM_FILE),
            input
                .toml_text(&format!("the paper's case {}", case.name))
                .as_bytes(),
        )?;
        events(AppEvent::Wrote(&path));
        inputs.push(input);
    }
    // Each case's files (trajectory tables, figures) are written on a second thread while the
    // next case is solved on this one; the directory passes from one writer to the next, and
    // the files each writer wrote are reported when it is joined. The bytes do not depend on
    // the overlap.
    let dir = std::thread::scope(|scope| -> Result<OutputDir, AppError> {
        let mut writer: Option<std::thread::ScopedJoinHandle<'_, WriterResult>> = None;
        let mut dir = Some(dir);
        let last = paper::CASES.len() - 1;
        for (k, (case, input)) in paper::CASES.iter().zip(inputs).enumerate() {
            let SolvedCase {
                summary: mut case_summary,
                pending,
            } = solve_case(
                case.name,
                &paper::problem(case.eta),
                &options,
                output,
                events,
            );
            case_summary.input = Some(input.to_json());
            summary.cases.push(case_summary);
            if let Some(handle) = writer.take() {
                dir = Some(join_writer(handle, events)?);
            }
            let Some(mut out) = dir.take() else {
                unreachable!("every writer joined above returns the directory")
            };
            let threads = if k < last {
                Threads::AllButOne
            } else {
                Threads::All
            };
            writer = Some(scope.spawn(move || {
                let mut wrote = Vec::new();
                let sub = Path::new(case.name);
                let result = pending.write(&mut out, sub, (output, threads), &mut |e| {
                    if let AppEvent::Wrote(path) = e {
                        wrote.push(path.to_path_buf());
                    }
                });
                (out, result, wrote)
            }));
        }
        match (writer, dir) {
            (Some(handle), _) => join_writer(handle, events),
            (None, Some(dir)) => Ok(dir),
            (None, None) => unreachable!("the directory is with the last writer, if any"),
        }
    })?;
    finish(dir, &summary, events)?;
    Ok(summary)
}

/// What a case's writer thread returns: the output directory, whether every file was
/// written, and the files written.
type WriterResult = (OutputDir, Result<(), AppError>, Vec<PathBuf>);

/// Wait for a writer thread, report its files, and take the directory back.
fn join_writer(
    handle: std::thread::ScopedJoinHandle<'_, WriterResult>,
    events: &mut dyn FnMut(AppEvent),
) -> Result<OutputDir, AppError> {
    let (dir, result, wrote) = handle.join().map_err(|_| {
        AppError::Report(ReportError::InvalidInput(
            "writing a case's files failed unexpectedly (its thread panicked); the output \
             directory is left marked INCOMPLETE"
                .to_string(),
        ))
    })?;
    for path in &wrote {
        events(AppEvent::Wrote(path));
    }
    result.map(|()| dir)
}

/// Writes `summary.json`, the last file of a run, and releases the directory.
fn finish(
    dir: OutputDir,
    summary: &Summary,
    events: &mut dyn FnMut(AppEvent),
) -> Result<(), AppError> {
    let text = summary
        .to_json_string()
        .map_err(|source| ReportError::Json {
            path: dir.root().join(report::SUMMARY_FILE),
            source,
        })?;
    let path = dir.finish(text.as_bytes())?;
    events(AppEvent::Wrote(&path));
    Ok(())
}

/// `suslov solve CONFIG --out DIR`: read the problem file (see [`crate::config`] for the
/// schema), solve and verify it, and write into `DIR` ([`OutputDir`]) `problem.toml` (the
/// resolved input, [`config::resolved`]), `trajectory.csv`/`.npy` (or `trajectory.partial.*`),
/// the figures and, last,
/// `summary.json` (one case). An invalid file is an error before anything is written; a
/// solver failure is not (it is recorded in the summary's status).
pub fn run_solve(
    config_path: &Path,
    out: &Path,
    events: &mut dyn FnMut(AppEvent),
) -> Result<Summary, AppError> {
    run_solve_with(config_path, out, &OutputOptions::default(), events)
}

/// [`run_solve`] with the given [`OutputOptions`].
pub fn run_solve_with(
    config_path: &Path,
    out: &Path,
    output: &OutputOptions,
    events: &mut dyn FnMut(AppEvent),
) -> Result<Summary, AppError> {
    let (loaded, text) = match config::load_any(config_path)? {
        (config::Loaded::So3(loaded), text) => (loaded, text),
        (config::Loaded::Other(file), text) => {
            return crate::model::with_model!(file.model.as_str(), M => {
                lie::run_model_solve::<M>(&file, &text, (config_path, out), output, events)
            }, _ => unreachable!("config::load_any returns generated model names only"))
        }
    };
    for w in &loaded.warnings {
        events(AppEvent::Warning(w));
    }
    let input = InputCopy::new(&loaded.resolved, config_path, &text, out);
    let mut dir = OutputDir::open(out)?;
    dir.check_free(
        case_files(Path::new(""))
            .into_iter()
            .chain(input.files())
            .chain([report::SUMMARY_FILE.into()]),
    )?;
    input.write(&mut dir, events)?;
    let mut case = run_case(
        &loaded.name,
        &loaded.problem,
        (&mut dir, Path::new("")),
        &loaded.options,
        output,
        events,
    )?;
    case.input = Some(loaded.resolved.to_json());
    case.extra.insert(
        "problem_file".into(),
        serde_json::json!(config_path.display().to_string()),
    );
    if !loaded.warnings.is_empty() {
        case.extra.insert(
            "warnings".into(),
            serde_json::json!(loaded
                .warnings
                .iter()
                .map(|w| serde_json::json!({"field": w.field(), "message": w.to_string()}))
                .collect::<Vec<_>>()),
        );
    }
    let summary = Summary::new(vec![case]);
    finish(dir, &summary, events)?;
    Ok(summary)
}

/// The resolved input of `suslov solve` in its output directory: `problem.toml` and the
/// files it names ([`config::resolved`]), so that `suslov solve DIR/problem.toml` repeats the
/// run. When the input is `DIR/problem.toml` itself (`solve DIR/problem.toml --out DIR`) it
/// stays the user's file: not rewritten, not listed for the next run to remove.
pub(crate) struct InputCopy<'a> {
    resolved: &'a config::ResolvedInput,
    source: String,
    /// The input's text as read, when the input is `DIR/problem.toml` itself.
    input_is_the_copy: Option<&'a str>,
}

impl<'a> InputCopy<'a> {
    /// `text` is the input file's text as read.
    pub(crate) fn new(
        resolved: &'a config::ResolvedInput,
        config_path: &Path,
        text: &'a str,
        out: &Path,
    ) -> Self {
        let same_file =
            |a: &Path, b: &Path| match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
                (Ok(a), Ok(b)) => a == b,
                _ => false,
            };
        Self {
            resolved,
            source: config_path.display().to_string(),
            input_is_the_copy: same_file(config_path, &out.join(PROBLEM_FILE)).then_some(text),
        }
    }

    /// The files it writes that belong to the run (for [`OutputDir::check_free`]).
    pub(crate) fn files(&self) -> Vec<PathBuf> {
        self.input_is_the_copy
            .is_none()
            .then(|| PathBuf::from(PROBLEM_FILE))
            .into_iter()
            .chain(self.resolved.files.iter().map(|(n, _)| PathBuf::from(n)))
            .collect()
    }

    /// Writes the files; call after [`OutputDir::open`] (which removes an earlier run's).
    pub(crate) fn write(
        &self,
        dir: &mut OutputDir,
        events: &mut dyn FnMut(AppEvent),
    ) -> Result<(), AppError> {
        for (name, bytes) in &self.resolved.files {
            let path = dir.write(name, bytes)?;
            events(AppEvent::Wrote(&path));
        }
        let text = match self.input_is_the_copy {
            None => self.resolved.toml_text(&self.source),
            // A copy an earlier run wrote was just removed with that run's files: write it
            // again as it was read (never lost, never changed).
            Some(text) if !dir.root().join(PROBLEM_FILE).exists() => text.to_string(),
            Some(_) => return Ok(()),
        };
        let path = dir.write(PROBLEM_FILE, text.as_bytes())?;
        events(AppEvent::Wrote(&path));
        Ok(())
    }
}

/// The resolved input's file name in an output directory.
pub const PROBLEM_FILE: &str = "problem.toml";

/// One case for [`run_certify`] and [`run_rank_along`].
pub struct CaseJob {
    /// Case name.
    pub name: String,
    /// The problem.
    pub problem: SuslovProblem,
    /// Solver options.
    pub options: SolveOptions,
    /// What the problem file's checks had to say (empty for the paper's cases).
    pub warnings: Vec<config::ConfigWarning>,
}

/// The cases of `suslov certify [CONFIG]` and `suslov controllability --along`: the problem
/// in `config`, or the paper's two;
/// `tolerance` overrides the final BVP tolerance (the mesh the certificate runs on).
pub fn case_jobs(config: Option<&Path>, tolerance: Option<f64>) -> Result<Vec<CaseJob>, AppError> {
    check_tolerance(tolerance)?;
    let loaded = config.map(config::load).transpose()?;
    Ok(so3_jobs(loaded, tolerance))
}

/// The jobs of a checked so(3) file, or the paper's two cases (`None`), with the final
/// tolerance overridden by `tolerance` (already checked).
fn so3_jobs(loaded: Option<config::LoadedProblem>, tolerance: Option<f64>) -> Vec<CaseJob> {
    let mut jobs = match loaded {
        Some(loaded) => vec![CaseJob {
            name: loaded.name,
            problem: loaded.problem,
            options: loaded.options,
            warnings: loaded.warnings,
        }],
        None => paper::CASES
            .iter()
            .map(|c| CaseJob {
                name: c.name.to_string(),
                problem: paper::problem(c.eta),
                options: SolveOptions::default(),
                warnings: Vec::new(),
            })
            .collect(),
    };
    if let Some(t) = tolerance {
        jobs.iter_mut().for_each(|j| j.options.tol = t);
    }
    jobs
}

/// `paper` (no file), or a problem file of any model read once: so(3) files become
/// [`CaseJob`]s, the others stay [`config::ModelFile`]s for their model's type.
enum AnyJobs {
    So3(Vec<CaseJob>),
    Other(config::ModelFile),
}

fn any_jobs(config: Option<&Path>, tolerance: Option<f64>) -> Result<AnyJobs, AppError> {
    check_tolerance(tolerance)?;
    let loaded = match config {
        None => None,
        Some(path) => match config::load_any(path)?.0 {
            config::Loaded::Other(file) => return Ok(AnyJobs::Other(file)),
            config::Loaded::So3(loaded) => Some(loaded),
        },
    };
    Ok(AnyJobs::So3(so3_jobs(loaded, tolerance)))
}

/// `suslov certify`: solve each case and certify the solution on its own mesh. A failed
/// solve or certificate is recorded in its report (verdict `"error"`), not returned. With
/// `json`, the reports are written there (atomically) as `{"cases": [...]}`.
pub fn run_certify(
    jobs: &[CaseJob],
    json: Option<&Path>,
    events: &mut dyn FnMut(AppEvent),
) -> Result<Vec<CertificateReport>, AppError> {
    prepare_certificate_json(json)?;
    let mut reports = Vec::new();
    for job in jobs {
        events(AppEvent::CaseStarted { name: &job.name });
        for w in &job.warnings {
            events(AppEvent::Warning(w));
        }
        let clock = Instant::now();
        let solved = solve::solve(&job.problem, &job.options, &mut |e| {
            events(AppEvent::Solve(e))
        });
        let solve_seconds = clock.elapsed().as_secs_f64();
        let report = lie::certify_solved(&job.name, solved.map(|s| s.generic), solve_seconds);
        events(AppEvent::Certified(&report));
        reports.push(report);
    }
    write_certificate_json(json, &reports, events)?;
    Ok(reports)
}

/// `suslov certify [CONFIG]` for a problem file of any model (or the paper's cases): so(3)
/// files through [`case_jobs`] and [`run_certify`], the other models through the generic
/// layer ([`lie::run_model_certify`]).
pub fn run_certify_any(
    config: Option<&Path>,
    tolerance: Option<f64>,
    json: Option<&Path>,
    events: &mut dyn FnMut(AppEvent),
) -> Result<Vec<CertificateReport>, AppError> {
    if let (Some(config), Some(json)) = (config, json) {
        if same_file(config, json) {
            return Err(AppError::InvalidArgument(format!(
                "--json-file {}: that is the problem file being certified, which the JSON would \
                 replace; give the JSON another name",
                crate::echo::echo(&json.display().to_string()),
            )));
        }
    }
    match any_jobs(config, tolerance)? {
        AnyJobs::So3(jobs) => run_certify(&jobs, json, events),
        AnyJobs::Other(file) => crate::model::with_model!(file.model.as_str(), M => {
            lie::run_model_certify::<M>(&file, tolerance, json, events)
        }, _ => unreachable!("config::load_any returns generated model names only")),
    }
}

/// Whether `a` and `b` name one existing file (through symbolic or hard links).
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        #[cfg(unix)]
        (Ok(ma), Ok(mb)) => {
            use std::os::unix::fs::MetadataExt;
            (ma.dev(), ma.ino()) == (mb.dev(), mb.ino())
        }
        #[cfg(not(unix))]
        (Ok(_), Ok(_)) => matches!(
            (a.canonicalize(), b.canonicalize()),
            (Ok(x), Ok(y)) if x == y
        ),
        _ => false,
    }
}

/// `--tolerance`, if given, within [`config::TOLERANCE_RANGE`].
fn check_tolerance(tolerance: Option<f64>) -> Result<(), AppError> {
    if let Some(t) = tolerance {
        let (lo, hi) = config::TOLERANCE_RANGE;
        if !(t.is_finite() && (lo..=hi).contains(&t)) {
            return Err(AppError::InvalidArgument(format!(
                "--tolerance must be a number in [{lo:e}, {hi:e}] (as solver.tolerance in a \
                 problem file; e.g. 1e-8), got {t:e}"
            )));
        }
    }
    Ok(())
}

/// Checks that the certificates' JSON can be written, before minutes of work.
pub(crate) fn prepare_certificate_json(json: Option<&Path>) -> Result<(), AppError> {
    // The certificate must not be lost to an unwritable path found after minutes of work.
    if let Some(path) = json {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
                path: dir.to_path_buf(),
                source,
            })?;
        }
        report::probe_writable(path)?;
        // An output directory of `paper`/`solve` holds exactly one run's files: a JSON
        // written over one of them would replace that run's result (even while it runs).
        if report::belongs_to_a_run(path) {
            return Err(AppError::InvalidArgument(format!(
                "--json-file {}: that file belongs to the `suslov paper`/`solve` run whose output \
                 directory it is in; give the JSON another name (or write it elsewhere)",
                crate::echo::echo(&path.display().to_string()),
            )));
        }
    }
    Ok(())
}

/// Writes the certificates as `{"cases": [...]}` to `json` (atomically), if given.
pub(crate) fn write_certificate_json(
    json: Option<&Path>,
    reports: &[CertificateReport],
    events: &mut dyn FnMut(AppEvent),
) -> Result<(), AppError> {
    if let Some(path) = json {
        #[derive(serde::Serialize)]
        struct Cases<'a> {
            cases: &'a [CertificateReport],
        }
        let text = serde_json::to_vec_pretty(&Cases { cases: reports }).map_err(|source| {
            ReportError::Json {
                path: path.to_path_buf(),
                source,
            }
        })?;
        report::write_atomic(path, &text)?;
        events(AppEvent::Wrote(path));
    }
    Ok(())
}

/// `suslov controllability --along paper|CONFIG` for a file of any model: so(3) files (and
/// `paper`) through [`case_jobs`] and [`run_rank_along`], the other models through
/// [`lie::run_model_rank_along`].
pub fn run_rank_along_any(
    config: Option<&Path>,
    points: usize,
    rtol: f64,
    events: &mut dyn FnMut(AppEvent),
) -> Result<RankAlong, AppError> {
    check_rank_arguments(points, rtol)?;
    let jobs = any_jobs(config, None).map_err(|e| {
        AppError::InvalidArgument(format!("--along (`paper` or a problem file): {e}"))
    })?;
    match jobs {
        AnyJobs::So3(jobs) => run_rank_along(&jobs, points, rtol, events),
        AnyJobs::Other(file) => crate::model::with_model!(file.model.as_str(), M => {
            lie::run_model_rank_along::<M>(&file, points, rtol, events)
        }, _ => unreachable!("config::load_any returns generated model names only")),
    }
}

/// `--points` (times along the trajectory) and `--rtol` of the rank test along a solution.
fn check_rank_arguments(points: usize, rtol: f64) -> Result<(), AppError> {
    use crate::so3::controllability as c;
    if !(2..=c::MAX_STATES).contains(&points) {
        return Err(AppError::InvalidArgument(format!(
            "--points must be between 2 and {} (times sampled along the trajectory), got \
             {points}",
            c::MAX_STATES
        )));
    }
    c::check_rtol(rtol).map_err(|e| AppError::InvalidArgument(e.to_string()))?;
    Ok(())
}

/// `suslov controllability --along paper|CONFIG`: solve each case and evaluate the
/// accessibility rank test ([`crate::so3::controllability`]) at `points` times along the
/// optimal trajectory. Checks `points` and `rtol` before any work.
pub fn run_rank_along(
    jobs: &[CaseJob],
    points: usize,
    rtol: f64,
    events: &mut dyn FnMut(AppEvent),
) -> Result<RankAlong, AppError> {
    use crate::so3::controllability as c;
    check_rank_arguments(points, rtol)?;
    let mut text = String::new();
    let mut cases = Vec::new();
    let mut all_accessible = true;
    for job in jobs {
        events(AppEvent::CaseStarted { name: &job.name });
        for w in &job.warnings {
            events(AppEvent::Warning(w));
        }
        let sol = match solve::solve(&job.problem, &job.options, &mut |e| {
            events(AppEvent::Solve(e))
        }) {
            Ok(sol) => sol,
            Err(e) => {
                text += &format!("case {}: the solve failed: {e}\n", job.name);
                cases.push(serde_json::json!({
                    "name": job.name,
                    "model": crate::model::so3::MODEL_NAME,
                    "solve_error": e.to_string(),
                }));
                all_accessible = false;
                events(AppEvent::CaseEnded { name: &job.name });
                continue;
            }
        };
        let verdict = crate::lie::verify_solution(&sol.generic)
            .verification
            .verdict();
        let unverified = match &verdict {
            Verdict::Unverified { reason } => Some(reason.clone()),
            Verdict::Verified => None,
        };
        if let Some(reason) = &unverified {
            all_accessible = false;
            text += &format!(
                "case {}: the solution did not pass its a-posteriori checks ({reason}); the \
                 rank test below runs along it anyway\n",
                job.name
            );
        }
        let (a, b) = (sol.problem.t0, sol.terminal_time());
        let times: Vec<f64> = (0..points)
            .map(|k| a + (b - a) * k as f64 / (points - 1) as f64)
            .collect();
        // The solution satisfies ⟨Ω, ξ⟩ = 0 to ~1e-10, and off M the rank is 5 with
        // σ₅ ∝ |⟨Ω, ξ⟩|: test the states of M nearest to it (ξ projected onto Ω^⊥) and report
        // the violation separately.
        let mut violation = 0.0_f64;
        let states: Vec<(f64, nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)> = times
            .iter()
            .map(|&t| {
                let y = sol.state(t);
                let om = nalgebra::Vector3::from_column_slice(&y[OMEGA]);
                let xi = nalgebra::Vector3::from_column_slice(&y[XI]);
                let c = om.dot(&xi);
                violation = violation.max(c.abs());
                (
                    t,
                    om,
                    xi - om * (c / om.norm_squared().max(f64::MIN_POSITIVE)),
                )
            })
            .collect();
        match c::rank_along(&sol.problem.inertia, &states, rtol) {
            Ok(r) => {
                all_accessible &= r.min_rank == c::DIM_M && r.max_rank == c::DIM_M;
                cases.push(serde_json::json!({
                    "name": job.name,
                    "model": crate::model::so3::MODEL_NAME,
                    "unverified": unverified,
                    "t0": a,
                    "terminal_time": b,
                    "dim_m": c::DIM_M,
                    "max_constraint": violation,
                    "rank": r,
                }));
                text += &format!(
                    "case {}: rank of V {} at all {} times of [{a}, {b:.6}] (dim M = {}){}\n\
                     \x20 smallest significant singular value {:.4e} (t = {:.4}); largest \
                     sigma_(rank+1)/sigma_rank {:.1e}; max |f| {:.4}; the solution's max \
                     |<Omega, xi>| {:.1e} at these times (xi projected onto Omega^perp for the \
                     test)\n",
                    job.name,
                    if r.min_rank == r.max_rank {
                        format!("= {}", r.min_rank)
                    } else {
                        format!("in {}..={}", r.min_rank, r.max_rank)
                    },
                    r.points,
                    c::DIM_M,
                    if r.min_rank == c::DIM_M && r.max_rank == c::DIM_M {
                        ": accessible along the whole optimal trajectory"
                    } else {
                        ""
                    },
                    r.min_significant,
                    r.t_min_significant,
                    r.max_gap,
                    r.max_drift_norm,
                    violation,
                );
            }
            Err(e) => {
                all_accessible = false;
                text += &format!("case {}: rank test failed: {e}\n", job.name);
                cases.push(serde_json::json!({
                    "name": job.name,
                    "model": crate::model::so3::MODEL_NAME,
                    "rank_error": e.to_string(),
                }));
            }
        }
        events(AppEvent::CaseEnded { name: &job.name });
    }
    Ok(RankAlong {
        text,
        all_accessible,
        cases,
    })
}

/// What [`run_rank_along`] found.
#[derive(Debug, Clone)]
pub struct RankAlong {
    /// The report for people.
    pub text: String,
    /// Every case solved, passed its a-posteriori checks and had rank `dim M` at every time
    /// tested.
    pub all_accessible: bool,
    /// The same per case, as data (`suslov controllability --along … --json`): `name`,
    /// `model`, and either `solve_error`, `rank_error`, or `unverified` (the failed checks, or
    /// null), `t0`, `terminal_time`, `dim_m`, `max_constraint` (max |⟨Ω, ξ⟩| at the times
    /// tested) and `rank` (the rank test's record).
    pub cases: Vec<serde_json::Value>,
}

impl RankAlong {
    /// `{"all_accessible": …, "cases": […]}`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({ "all_accessible": self.all_accessible, "cases": self.cases })
    }
}

/// What `suslov controllability` found at given states ([`run_rank_at_states`]).
#[derive(Debug, Clone)]
pub struct RankTable {
    /// The table for people.
    pub text: String,
    /// What the rows show.
    pub verdict: crate::so3::controllability::AccessibilityVerdict,
    /// The same as data (`--json`): `model`, `rtol`, `dim_m`, `states` (one record per state
    /// tested) and `verdict`.
    pub json: serde_json::Value,
}

/// Arguments of `suslov controllability` at given states (not `--along`).
#[derive(Debug, Clone)]
pub struct RankAtStates<'a> {
    /// `--model`: a generated model's name ([`crate::model::MODEL_NAMES`]).
    pub model: &'a str,
    /// `--inertia`: for so3 `"I1,I2,I3"` (default `1,2,3`) or `I1=…,I2=…,I3=…`; for the other
    /// models `name=value` pairs of the model's inertia parameters (required).
    pub inertia: Option<&'a str>,
    /// `--constraint`: `name=value` pairs of the model's constraint parameters (required for a
    /// model that has them, refused for the others).
    pub constraint: Option<&'a str>,
    /// `--omega` and `--xi`: one state.
    pub state: Option<(&'a str, &'a str)>,
    /// `--omega-a`: the energy of the sampled states (default `5,0,…,0`).
    pub omega_a: Option<&'a str>,
    /// `--samples`.
    pub samples: usize,
    /// `--seed`.
    pub seed: u64,
    /// `--rtol`.
    pub rtol: f64,
}

/// `suslov controllability` at one state or at sampled states of `M`, for any model: so3
/// through the so(3) layer ([`crate::so3::controllability::report_table`], the paper's
/// table), the other models through the generic layer ([`lie::run_model_rank_at_states`]).
/// Every argument is checked (named in the error) before any work; returns the table and its
/// verdict.
pub fn run_rank_at_states(a: &RankAtStates) -> Result<RankTable, AppError> {
    use crate::model::{with_model, MODEL_NAMES};
    if a.model == crate::model::so3::MODEL_NAME {
        return run_so3_rank_at_states(a);
    }
    with_model!(a.model, M => lie::run_model_rank_at_states::<M>(a), _ => {
        Err(AppError::InvalidArgument(format!(
            "--model: there is no model {}; the models are {}",
            crate::echo::echo(a.model),
            MODEL_NAMES.join(", ")
        )))
    })
}

/// [`run_rank_at_states`] for so3: `--inertia` as `I1,I2,I3` (or named), no `--constraint`.
fn run_so3_rank_at_states(a: &RankAtStates) -> Result<RankTable, AppError> {
    use crate::so3::controllability as c;
    use crate::so3::Inertia;
    let arg =
        |flag: &str, e: crate::so3::SuslovError| AppError::InvalidArgument(format!("{flag}: {e}"));
    let vec3 = |flag: &str, text: &str| -> Result<nalgebra::Vector3<f64>, AppError> {
        let v = c::parse_vec3(text).map_err(|e| arg(flag, e))?;
        if v.iter().all(|x| x.is_finite()) {
            Ok(v)
        } else {
            Err(AppError::InvalidArgument(format!(
                "{flag}: {} is not three finite numbers",
                crate::echo::echo(text)
            )))
        }
    };
    c::check_rtol(a.rtol).map_err(|e| AppError::InvalidArgument(e.to_string()))?;
    type So3 = crate::model::so3::So3;
    // Refuses --constraint (so3 has no constraint parameters).
    lie::constraint_parameters::<So3>(a.constraint, &mut [0.0; crate::model::generated::N_PARAM])?;
    let inertia_text = match a.inertia {
        None => "1,2,3".to_string(),
        // Named, as for the other models: in the order of the inertia parameters.
        Some(text) if text.contains('=') => {
            let p = lie::rank_parameters::<So3>(Some(text), None)?;
            <So3 as crate::model::Model>::INERTIA_PARAMS
                .iter()
                .map(|m| p[m.index].to_string())
                .collect::<Vec<_>>()
                .join(",")
        }
        Some(text) => text.to_string(),
    };
    let diag = vec3("--inertia", &inertia_text)?;
    let inertia = Inertia::new(diag.into()).map_err(|e| arg("--inertia", e))?;
    let states = match a.state {
        Some((om, xi)) => vec![(vec3("--omega", om)?, vec3("--xi", xi)?)],
        None => {
            if !(1..=c::MAX_STATES).contains(&a.samples) {
                return Err(AppError::InvalidArgument(format!(
                    "--samples must be between 1 and {}, got {}",
                    c::MAX_STATES,
                    a.samples
                )));
            }
            let om = vec3("--omega-a", a.omega_a.unwrap_or("5,0,0"))?;
            let energy2 = inertia.apply(&om).dot(&om);
            if om.iter().all(|x| *x == 0.0) {
                return Err(AppError::InvalidArgument(
                    "--omega-a = 0,0,0: the sampled states need a positive kinetic energy; \
                     give a nonzero vector"
                        .into(),
                ));
            }
            if !(energy2.is_finite() && energy2 > f64::MIN_POSITIVE) {
                return Err(AppError::InvalidArgument(format!(
                    "twice the kinetic energy <I Omega_a, Omega_a> = {energy2:e} of --omega-a \
                     with --inertia is not a positive finite number in f64; rescale --inertia \
                     or --omega-a"
                )));
            }
            c::sample_states_on_m(&inertia, &om, a.samples, a.seed)
                .map_err(|e| arg("--omega-a with --inertia", e))?
        }
    };
    let (text, verdict, rows) = c::report_table_rows(&inertia, &states, a.rtol)
        .map_err(|e| AppError::InvalidArgument(e.to_string()))?;
    let states: Vec<serde_json::Value> = rows
        .iter()
        .zip(&states)
        .map(|((r, on_m), (om, xi))| {
            serde_json::json!({
                "omega": om.as_slice(),
                "xi": xi.as_slice(),
                "on_m": on_m,
                "test": r,
            })
        })
        .collect();
    let json = serde_json::json!({
        "model": crate::model::so3::MODEL_NAME,
        "inertia": inertia.diag().as_slice(),
        "rtol": a.rtol,
        "dim_m": c::DIM_M,
        "states": states,
        "verdict": verdict,
    });
    Ok(RankTable {
        text,
        verdict,
        json,
    })
}
