//! `suslov`: the command line, a thin shell over [`suslov::app`].

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use suslov::app::{self, AppEvent};
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
    /// Accessibility rank test of Suslov's pure equations (paper section 4.3): rank of
    /// V = [g1, g2, g3, [g_i, g_j]], its singular values and the drift, at one state
    /// (--omega and --xi) or at random states of M with the energy of --omega-a.
    Controllability(ControllabilityArgs),
    /// Second-order certificate: solve the paper's two cases (or CONFIG), transcribe each
    /// solution directly on its own mesh, move it to the exact KKT point of the discretized
    /// problem and decide from the inertia of the KKT matrix whether it is a strict local
    /// minimum. Exit status 0: every case certified; 2: some case is not (or has no
    /// verdict); 1: an error (bad file, unwritable JSON).
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
    /// Principal moments of inertia, e.g. `1,2,3` (the paper's).
    #[arg(long, default_value = "1,2,3", allow_hyphen_values = true)]
    inertia: String,
    /// Evaluate at this Omega (needs --xi), e.g. `5,0,0`.
    #[arg(long, allow_hyphen_values = true, requires = "xi")]
    omega: Option<String>,
    /// Evaluate at this xi (needs --omega), e.g. `0,1,0`.
    #[arg(long, allow_hyphen_values = true, requires = "omega")]
    xi: Option<String>,
    /// Without --omega/--xi: sample states of M on the energy ellipsoid through this Omega.
    #[arg(long, default_value = "5,0,0", allow_hyphen_values = true)]
    omega_a: String,
    /// Number of random states of M.
    #[arg(long, default_value_t = 8)]
    samples: usize,
    /// Seed of the random states.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Relative rank threshold: sigma_k counts if sigma_k > rtol * sigma_1.
    #[arg(long, default_value_t = suslov::suslov::controllability::RANK_RTOL)]
    rtol: f64,
    /// Instead: solve `paper` (both cases) or a problem file and evaluate the rank along the
    /// optimal trajectory (Omega(t), xi(t)) at --points times.
    #[arg(long, conflicts_with_all = ["omega", "xi"])]
    along: Option<PathBuf>,
    /// Times sampled along the trajectory (with --along).
    #[arg(long, default_value_t = 401, requires = "along")]
    points: usize,
}

fn run_controllability(a: &ControllabilityArgs) -> Result<String, suslov::suslov::SuslovError> {
    use suslov::suslov::controllability as c;
    let inertia = suslov::suslov::Inertia::new(c::parse_vec3(&a.inertia)?.into())?;
    let states = match (&a.omega, &a.xi) {
        (Some(om), Some(xi)) => vec![(c::parse_vec3(om)?, c::parse_vec3(xi)?)],
        _ => c::sample_states_on_m(&inertia, &c::parse_vec3(&a.omega_a)?, a.samples, a.seed)?,
    };
    c::report_table(&inertia, &states, a.rtol)
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
            None => eprintln!("{text}"),
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
            AppEvent::Solve(Event::StageFinished(r)) => {
                let text = format!(
                    "stage {} done: {} steps, {} recovered failures, {} Newton iterations, {} nodes, {:.3} s",
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
                    "case {}: {}; b = {:.4}, cost = {:.6}, max|<Om,xi>| = {:.1e}, nodes = {}, {:.2} s",
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
    if cli.verbose && !cli.quiet {
        // -v: structured logs (tracing) of every stage, continuation step, Newton step and
        // mesh pass on stderr, instead of the progress bar.
        tracing_subscriber::fmt()
            .with_writer(std::io::stderr)
            .with_max_level(tracing::Level::DEBUG)
            .with_target(false)
            .without_time()
            .init();
    }
    let mut reporter = Reporter {
        quiet: cli.quiet,
        verbose: cli.verbose,
        bar: None,
        terminal: std::io::stderr().is_terminal(),
    };
    let (result, out) = match cli.command {
        Command::Controllability(a) if a.along.is_some() => {
            let along = a.along.as_deref().unwrap_or(std::path::Path::new("paper"));
            let config = (along != std::path::Path::new("paper")).then_some(along);
            let result = app::case_jobs(config, None).and_then(|jobs| {
                app::run_rank_along(&jobs, a.points, a.rtol, &mut |e| reporter.event(e))
            });
            return match result {
                Ok(text) => {
                    print!("{text}");
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            };
        }
        Command::Controllability(a) => {
            return match run_controllability(&a) {
                Ok(table) => {
                    print!("{table}");
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            };
        }
        Command::Certify {
            config,
            json,
            tolerance,
        } => {
            let result = app::case_jobs(config.as_deref(), tolerance).and_then(|jobs| {
                app::run_certify(&jobs, json.as_deref(), &mut |e| reporter.event(e))
            });
            return match result {
                Ok(reports) => {
                    for r in &reports {
                        print!("{}", r.text());
                    }
                    if reports.iter().all(|r| r.verdict == "certified") {
                        ExitCode::SUCCESS
                    } else {
                        eprintln!("not every case is certified as a local minimum");
                        ExitCode::from(2)
                    }
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            };
        }
        Command::Paper { out } => (app::run_paper(&out, &mut |e| reporter.event(e)), out),
        Command::Solve { config, out } => (
            app::run_solve(&config, &out, &mut |e| reporter.event(e)),
            out,
        ),
    };
    match result {
        Ok(summary) => {
            let failed = summary.cases.iter().any(|c| c.status != "converged");
            if !cli.quiet {
                eprintln!("wrote {}", out.join("summary.json").display());
            }
            if failed {
                eprintln!("error: not every case converged (see summary.json)");
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
