//! `suslov`: the command line, a thin shell over [`suslov::app`].
//!
//! Exit statuses (README, "What happens on failure"):
//!
//! | status | meaning |
//! |---|---|
//! | 0 | success: every case converged and verified / certified / rank dim M on M (4 for so3) |
//! | 1 | error: a bad problem file or argument, an unwritable or busy output; nothing was solved, or the run stopped |
//! | 2 | usage: the command line itself is malformed (clap) |
//! | 3 | the run completed and wrote its results, but the answer is negative: some case did not converge or failed its verification, is not certified as a local minimum, or the rank test is not dim M on M |
//! | 128 + n | stopped by signal n (130: SIGINT, 143: SIGTERM, 129: SIGHUP); temporary files removed, the output directory keeps its `INCOMPLETE` mark |
//!
//! Nothing here panics on a closed standard output or error (`suslov … | head -1`): text
//! that cannot be written is dropped, the run goes on and writes its files.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use suslov::app::{self, AppEvent};
use suslov::suslov::controllability::AccessibilityVerdict;
use suslov::suslov::solve::Event;

#[derive(Parser)]
#[command(
    name = "suslov",
    version,
    about = "Optimal control of Suslov's problem: the constraint is the control"
)]
struct Cli {
    /// Print nothing but errors.
    #[arg(short, long, global = true)]
    quiet: bool,
    /// Print every continuation step, Newton step and mesh pass (also on a terminal).
    #[arg(short, long, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Reproduce the paper (section 5.3): both cases (eta = 1 and eta = 0.01), verified,
    /// with summary.json, trajectory.csv and figures under DIR.
    Paper {
        /// Output directory (created if missing).
        #[arg(long, default_value = "out")]
        out: PathBuf,
    },
    /// Solve your own problem, described in a TOML file (schema: README, "Your own
    /// problems"), verified, with summary.json, trajectory.csv, figures and a copy of the
    /// file under DIR.
    Solve {
        /// The problem file (TOML).
        config: PathBuf,
        /// Output directory (created if missing).
        #[arg(long)]
        out: PathBuf,
    },
    /// Accessibility rank test of Suslov's pure equations (paper section 4.3) for any model
    /// (--model): rank of V = [g_1 .. g_n, [g_i, g_j]] and its singular values at one state
    /// (--omega and --xi) or at random states of M with the energy of --omega-a (or along
    /// optimal trajectories, --along).
    Controllability(ControllabilityArgs),
    /// Second-order certificate: solve the paper's two cases (or CONFIG), transcribe each
    /// solution directly on its own mesh, move it to the exact KKT point of the discretized
    /// problem and decide from the inertia of the KKT matrix whether it is a strict local
    /// minimum. Exit status 0: every case certified; 3: some case is not (or has no
    /// verdict, or its solution failed its checks); 1: an error (bad file, unwritable JSON);
    /// 2: a malformed command line.
    Certify {
        /// A problem file (TOML, as for `solve`); without it, the paper's two cases.
        config: Option<PathBuf>,
        /// Also write the reports as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Final BVP tolerance of the solves (the mesh the certificate runs on); default:
        /// the problem's (1e-8 for the paper).
        #[arg(long, allow_hyphen_values = true)]
        tolerance: Option<f64>,
    },
}

/// Arguments of `suslov controllability`.
#[derive(clap::Args)]
struct ControllabilityArgs {
    /// The model (codegen/models/<NAME>.py): so3 (the paper's), so3_full, se2, so4,
    /// so3_inhomogeneous, ...
    #[arg(long, default_value = "so3", conflicts_with = "along")]
    model: String,
    /// Inertia: for so3 the principal moments, e.g. `1,2,3` (the paper's, the default) or
    /// `I1=1,I2=2,I3=3`; for the other models their inertia parameters as name=value pairs,
    /// e.g. `m=1,Ic=0.5,c1=0.3,c2=0.1` (se2).
    #[arg(long, allow_hyphen_values = true)]
    inertia: Option<String>,
    /// The constraint parameters of a model that has them, as name=value pairs, e.g. `c=0.25`
    /// (so3_inhomogeneous: <Omega, xi> = c).
    #[arg(long, allow_hyphen_values = true, conflicts_with = "along")]
    constraint: Option<String>,
    /// Evaluate at this Omega (needs --xi; one entry per basis element), e.g. `5,0,0`.
    #[arg(long, allow_hyphen_values = true, requires = "xi")]
    omega: Option<String>,
    /// Evaluate at this xi (needs --omega), e.g. `0,1,0`; off the constraint level, the
    /// nearest state on it is tested.
    #[arg(long, allow_hyphen_values = true, requires = "omega")]
    xi: Option<String>,
    /// Without --omega/--xi: sample states of M on the energy level set through this Omega
    /// [default: 5,0,...,0].
    #[arg(long, allow_hyphen_values = true)]
    omega_a: Option<String>,
    /// Number of random states of M (at most 100000).
    #[arg(long, default_value_t = 8)]
    samples: usize,
    /// Seed of the random states.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Relative rank threshold: sigma_k counts if sigma_k > rtol * sigma_1; in [1e-14, 1e-3].
    #[arg(long, allow_hyphen_values = true, default_value_t = suslov::suslov::controllability::RANK_RTOL)]
    rtol: f64,
    /// Instead: solve `paper` (both cases) or a problem file and evaluate the rank along the
    /// optimal trajectory (Omega(t), xi(t)) at --points times.
    #[arg(long, conflicts_with_all = ["omega", "xi"])]
    along: Option<PathBuf>,
    /// Times sampled along the trajectory (with --along; 2 to 100000).
    #[arg(long, default_value_t = 401, requires = "along")]
    points: usize,
}

/// How a run ended, as an exit status (the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// 0.
    Success,
    /// 1: bad input, unwritable or busy output.
    Error,
    /// 3: results written, but not converged / not certified / not rank dim M.
    Negative,
}

impl Outcome {
    fn code(self) -> ExitCode {
        ExitCode::from(match self {
            Outcome::Success => 0,
            Outcome::Error => 1,
            Outcome::Negative => 3,
        })
    }
}

/// Writes to standard error; a closed or broken stream drops the text (never a panic).
macro_rules! say {
    ($($arg:tt)*) => {{
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// Writes to standard output; a closed pipe drops the text (never a panic).
fn out(text: &str) {
    let mut stdout = std::io::stdout().lock();
    let _ = stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush());
}

/// SIGINT, SIGTERM and SIGHUP end the process after removing the temporary files being
/// written ([`suslov::report::remove_in_flight`]); an output directory keeps its
/// `INCOMPLETE` mark (its lock goes with the process). A run killed outright (SIGKILL) leaves
/// its temporaries to the next run into the same directory, which sweeps them.
fn install_signal_handlers() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        say!("warning: cannot install signal handlers; an interrupted run may leave temporary files, which the next run into the same directory removes");
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            let removed = suslov::report::remove_in_flight();
            let name = match signal {
                SIGINT => "SIGINT",
                SIGTERM => "SIGTERM",
                _ => "SIGHUP",
            };
            say!(
                "interrupted by {name}: stopped ({} temporary file(s) removed); an output \
                 directory being written is left marked INCOMPLETE",
                removed.len()
            );
            std::process::exit(128 + signal);
        }
    });
}

/// Progress on stderr: a spinner per case on a terminal, log lines otherwise.
struct Reporter {
    quiet: bool,
    verbose: bool,
    bar: Option<ProgressBar>,
    terminal: bool,
}

impl Reporter {
    fn line(&self, text: String) {
        if self.quiet {
            return;
        }
        match &self.bar {
            Some(bar) => bar.println(text),
            None => say!("{text}"),
        }
    }

    fn event(&mut self, e: AppEvent) {
        match e {
            AppEvent::CaseStarted { name } => {
                if self.terminal && !self.quiet && !self.verbose {
                    // Per stage: the homotopy parameter from 0 to 100 %.
                    let bar = ProgressBar::new(100);
                    bar.set_style(
                        ProgressStyle::with_template(
                            "{spinner} {prefix} [{bar:20}] {pos:>3}% {wide_msg} [{elapsed}]",
                        )
                        .expect("valid template")
                        .progress_chars("=> "),
                    );
                    bar.set_prefix(name.to_string());
                    bar.enable_steady_tick(std::time::Duration::from_millis(120));
                    self.bar = Some(bar);
                } else {
                    self.line(format!("case {name}: solving"));
                }
            }
            AppEvent::Solve(Event::StageStarted { name, from, to }) => {
                let text = if from == to {
                    format!("  stage {name}")
                } else {
                    format!("  stage {name}: {from:.6} -> {to:.6}")
                };
                if let Some(bar) = &self.bar {
                    bar.set_position(0);
                    bar.set_message(text.trim().to_string());
                } else if self.verbose {
                    tracing::info!("{}", text.trim());
                } else {
                    self.line(text);
                }
            }
            AppEvent::Solve(Event::Step { stage, record }) => {
                let text = format!(
                    "    {stage} lambda = {:.4}: {} ({} Newton iterations, {} nodes)",
                    record.lambda,
                    if record.accepted {
                        "accepted".to_string()
                    } else {
                        format!("rejected, {:?}", record.status)
                    },
                    record.newton_iterations,
                    record.nodes
                );
                if let Some(bar) = &self.bar {
                    if record.accepted {
                        bar.set_position((record.lambda.clamp(0.0, 1.0) * 100.0).round() as u64);
                    }
                    bar.set_message(text.trim().to_string());
                }
                if self.verbose {
                    tracing::info!("{}", text.trim());
                }
            }
            AppEvent::Solve(Event::Bvp {
                stage,
                lambda,
                progress,
            }) => {
                let text = format!("{stage} lambda = {lambda:.4}: {progress}");
                if let Some(bar) = &self.bar {
                    bar.set_message(text.clone());
                }
                if self.verbose {
                    tracing::debug!("{text}");
                }
            }
            AppEvent::Solve(Event::RouteStarted { route, after }) => {
                // Always said (not only with --verbose): the run takes another way.
                self.line(format!(
                    "  route '{route}' (the previous one stopped: {after})"
                ));
            }
            AppEvent::Solve(Event::StageFinished(r)) => {
                let what = if r.outcome.is_completed() {
                    "done".to_string()
                } else {
                    r.outcome.to_string()
                };
                let text = format!(
                    "stage {} {what}: {} steps, {} recovered failures, {} Newton iterations, {} nodes, {:.3} s",
                    r.name, r.steps, r.failures_recovered, r.newton_iterations, r.nodes, r.seconds
                );
                if let Some(bar) = &self.bar {
                    bar.set_position(100);
                } else if self.verbose {
                    tracing::info!("{text}");
                } else {
                    self.line(format!("  {text}"));
                }
            }
            AppEvent::CaseFinished(c) => {
                if let Some(bar) = self.bar.take() {
                    bar.finish_and_clear();
                }
                self.line(format!(
                    "case {}: {}; b = {:.4}, cost = {:.6}, constraint residual max|<Om,xi> - c| = {:.1e}, nodes = {}, {:.2} s",
                    c.name, c.status, c.terminal_time, c.cost, c.max_abs_constraint, c.mesh_nodes, c.wall_seconds
                ));
            }
            AppEvent::CaseEnded { .. } => {
                if let Some(bar) = self.bar.take() {
                    bar.finish_and_clear();
                }
            }
            AppEvent::Certified(r) => {
                if let Some(bar) = self.bar.take() {
                    bar.finish_and_clear();
                }
                self.line(format!("case {}: {}", r.name, r.message));
            }
            AppEvent::Warning(w) => self.line(format!("warning: {w}")),
            AppEvent::Wrote(path) => {
                if self.verbose {
                    tracing::info!("wrote {}", path.display());
                }
            }
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    install_signal_handlers();
    if cli.verbose && !cli.quiet {
        // -v: structured logs (tracing) of every stage, continuation step, Newton step and
        // mesh pass on stderr, instead of the progress bar.
        tracing_subscriber::fmt()
            .with_writer(std::io::stderr)
            .with_max_level(tracing::Level::DEBUG)
            .with_target(false)
            .without_time()
            // Its own fallback on a failed write is `eprintln!`, which panics on a closed
            // stderr: drop such events instead.
            .log_internal_errors(false)
            .init();
    }
    let mut reporter = Reporter {
        quiet: cli.quiet,
        verbose: cli.verbose,
        bar: None,
        terminal: std::io::stderr().is_terminal(),
    };
    let outcome = match cli.command {
        Command::Controllability(a) if a.along.is_some() => {
            let along = a.along.as_deref().unwrap_or(std::path::Path::new("paper"));
            let config = (along != std::path::Path::new("paper")).then_some(along);
            let result =
                app::run_rank_along_any(config, a.points, a.rtol, &mut |e| reporter.event(e));
            match result {
                Ok(r) => {
                    out(&r.text);
                    if r.all_accessible {
                        Outcome::Success
                    } else {
                        Outcome::Negative
                    }
                }
                Err(e) => fail(&e),
            }
        }
        Command::Controllability(a) => {
            let request = app::RankAtStates {
                model: &a.model,
                inertia: a.inertia.as_deref(),
                constraint: a.constraint.as_deref(),
                state: a.omega.as_deref().zip(a.xi.as_deref()),
                omega_a: a.omega_a.as_deref(),
                samples: a.samples,
                seed: a.seed,
                rtol: a.rtol,
            };
            match app::run_rank_at_states(&request) {
                Ok((table, verdict)) => {
                    out(&table);
                    match verdict {
                        AccessibilityVerdict::RankDeficient { .. } => Outcome::Negative,
                        _ => Outcome::Success,
                    }
                }
                Err(e) => fail(&e),
            }
        }
        Command::Certify {
            config,
            json,
            tolerance,
        } => {
            let result =
                app::run_certify_any(config.as_deref(), tolerance, json.as_deref(), &mut |e| {
                    reporter.event(e)
                });
            match result {
                Ok(reports) => {
                    for r in &reports {
                        out(&r.text());
                    }
                    let certified = |r: &suslov::report::CertificateReport| {
                        r.verdict == "certified"
                            && r.solution_status.as_deref() == Some("converged")
                    };
                    if reports.iter().all(certified) {
                        Outcome::Success
                    } else {
                        say!(
                            "not every case is certified as a local minimum of a verified solution"
                        );
                        Outcome::Negative
                    }
                }
                Err(e) => fail(&e),
            }
        }
        Command::Paper { out } => solved(
            app::run_paper(&out, &mut |e| reporter.event(e)),
            &out,
            cli.quiet,
        ),
        Command::Solve { config, out } => solved(
            app::run_solve(&config, &out, &mut |e| reporter.event(e)),
            &out,
            cli.quiet,
        ),
    };
    outcome.code()
}

/// Prints the error of a job that stopped.
fn fail(e: &app::AppError) -> Outcome {
    say!("error: {e}");
    Outcome::Error
}

/// The outcome of `paper` / `solve`.
fn solved(
    result: Result<suslov::report::Summary, app::AppError>,
    out: &std::path::Path,
    quiet: bool,
) -> Outcome {
    match result {
        Ok(summary) => {
            if !quiet {
                say!("wrote {}", out.join(suslov::report::SUMMARY_FILE).display());
            }
            if summary.cases.iter().all(|c| c.status == "converged") {
                Outcome::Success
            } else {
                say!("not every case converged (see summary.json)");
                Outcome::Negative
            }
        }
        Err(e) => fail(&e),
    }
}
