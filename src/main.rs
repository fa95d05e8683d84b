//! `suslov`: the command line, a thin shell over [`suslov::app`].
//!
//! Exit statuses (docs/failures.md, and README "When a problem does not solve"):
//!
//! | status | meaning |
//! |---|---|
//! | 0 | success: every case converged and verified / certified / rank dim M on M (4 for so3) |
//! | 1 | error: a bad problem file or argument, an unwritable or busy output; nothing was solved, or the run stopped |
//! | 2 | usage: the command line itself is malformed (clap) |
//! | 3 | the run completed and wrote its results, but the answer is negative: some case did not converge, has no minimizer (summary.json: `no_minimizer`, an ε-optimal control written) or failed its verification, is not certified as a local minimum, or the rank test is not dim M on M or found no state on M to test |
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
use suslov::report::significant;
use suslov::so3::controllability::AccessibilityVerdict;
use suslov::so3::solve::Event;

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
    /// Print the results on standard output as JSON instead of text: `summary.json`'s content
    /// for `paper` and `solve`, the certificate reports for `certify`, the rank test's results
    /// for `controllability`. Progress and logs stay on standard error.
    #[arg(long, global = true)]
    json: bool,
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
        /// Uniform points of trajectory.csv/.npy, 2 to 1000000 (the mesh nodes are added;
        /// collocation.csv holds the collocation solution itself).
        #[arg(long, default_value_t = app::OUTPUT_POINTS, value_parser = points_arg)]
        points: usize,
    },
    /// Solve your own problem, described in a TOML file (schema: README, "Your own
    /// problems"), verified, with summary.json, trajectory.csv, figures and a copy of the
    /// file under DIR.
    Solve {
        /// The problem file (TOML).
        config: PathBuf,
        /// Output directory (created if missing) [default: out/<the problem file's stem>].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Uniform points of trajectory.csv/.npy, 2 to 1000000 (the mesh nodes are added;
        /// collocation.csv holds the collocation solution itself).
        #[arg(long, default_value_t = app::OUTPUT_POINTS, value_parser = points_arg)]
        points: usize,
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
        /// Also write the reports as JSON to this file (`--json` prints them on standard
        /// output instead of the text).
        #[arg(long)]
        json_file: Option<PathBuf>,
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
    #[arg(long, allow_hyphen_values = true, conflicts_with = "along")]
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
    #[arg(long, allow_hyphen_values = true, conflicts_with = "along")]
    omega_a: Option<String>,
    /// Number of random states of M (at most 100000).
    #[arg(long, default_value_t = 8, conflicts_with = "along")]
    samples: usize,
    /// Seed of the random states.
    #[arg(long, default_value_t = 1, conflicts_with = "along")]
    seed: u64,
    /// Relative rank threshold: sigma_k counts if sigma_k > rtol * sigma_1; in [1e-14, 1e-3].
    #[arg(long, allow_hyphen_values = true, default_value_t = suslov::so3::controllability::RANK_RTOL)]
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
    /// 3: results written, but not converged / not certified / not rank dim M (or no state
    /// of M tested).
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

/// A JSON value on standard output, pretty-printed (non-finite numbers, which JSON lacks, are
/// `null`: `serde_json` writes them so).
fn print_json(value: &serde_json::Value) {
    match serde_json::to_string_pretty(value) {
        Ok(text) => out_json(&text),
        Err(e) => say!("error: cannot print the results as JSON: {e}"),
    }
}

/// JSON text on standard output, ending in one newline.
fn out_json(text: &str) {
    out(text.trim_end());
    out("\n");
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

/// Progress and logs on stderr (a bar per case and stage on a terminal, log lines
/// otherwise); each case's result line on stdout (not with `--json`, which prints the results
/// as JSON at the end).
struct Reporter {
    quiet: bool,
    verbose: bool,
    json: bool,
    bar: Option<ProgressBar>,
    terminal: bool,
    /// The case being solved (the bar's prefix, with the stage).
    case: String,
}

impl Reporter {
    /// A log line on stderr (not with `--quiet`).
    fn line(&self, text: String) {
        if self.quiet {
            return;
        }
        match &self.bar {
            Some(bar) => bar.println(text),
            None => say!("{text}"),
        }
    }

    /// A result line on stdout (not with `--json`: the JSON says it all).
    fn result(&self, text: String) {
        if self.json {
            return;
        }
        let print = || out(&format!("{text}\n"));
        match &self.bar {
            Some(bar) => bar.suspend(print),
            None => print(),
        }
    }

    fn event(&mut self, e: AppEvent) {
        match e {
            AppEvent::CaseStarted { name } => {
                self.case = name.to_string();
                if self.terminal && !self.quiet && !self.verbose {
                    // Per stage (named in the prefix): the homotopy parameter from 0 to 100 %.
                    let bar = ProgressBar::new(100);
                    bar.set_style(
                        ProgressStyle::with_template(
                            "{spinner} {prefix} [{bar:20}] {pos:>3}% {msg} [{elapsed}]",
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
                    format!(
                        "  stage {name}: {} -> {}",
                        significant(*from, 6),
                        significant(*to, 6)
                    )
                };
                if let Some(bar) = &self.bar {
                    bar.set_prefix(format!("{} {name}", self.case));
                    bar.set_position(0);
                    bar.set_message(if from == to {
                        String::new()
                    } else {
                        format!("{} -> {}", significant(*from, 4), significant(*to, 4))
                    });
                } else if self.verbose {
                    tracing::info!("{}", text.trim());
                } else {
                    self.line(text);
                }
            }
            AppEvent::Solve(Event::Step { stage, record }) => {
                let text = format!(
                    "    {stage} lambda = {}: {} ({} Newton iterations, {} nodes)",
                    significant(record.lambda, 4),
                    if record.accepted {
                        "accepted".to_string()
                    } else {
                        format!("rejected: {}", record.status.describe())
                    },
                    record.newton_iterations,
                    record.nodes
                );
                if let Some(bar) = &self.bar {
                    if record.accepted {
                        bar.set_position((record.lambda.clamp(0.0, 1.0) * 100.0).round() as u64);
                    }
                    // Short enough for any terminal: the bar's line is never cut mid-word.
                    bar.set_message(format!("{} nodes", record.nodes));
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
                let text = format!("{stage} lambda = {}: {progress}", significant(*lambda, 4));
                if let Some(bar) = &self.bar {
                    bar.set_message(format!("{} nodes", progress.nodes));
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
                self.result(case_line(c));
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

/// `--points`: a whole number in [`app::OUTPUT_POINTS_RANGE`].
fn points_arg(text: &str) -> Result<usize, String> {
    let n: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a whole number"))?;
    app::OutputOptions::with_points(n)
        .map(|o| o.points)
        .map_err(|e| e.to_string())
}

/// glibc's `mallopt` parameters (`malloc.h`).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
mod malloc_policy {
    const M_TRIM_THRESHOLD: i32 = -1;
    const M_TOP_PAD: i32 = -2;
    const M_MMAP_THRESHOLD: i32 = -3;

    extern "C" {
        fn mallopt(param: i32, value: i32) -> i32;
    }

    /// Keep freed memory in the process instead of returning it to the kernel: blocks up to
    /// 32 MiB (glibc's largest threshold) come from the heap, not from `mmap` of their own,
    /// the heap is trimmed only above 256 MiB free at its top, and it grows by 64 MiB at a
    /// time. A run factors, frees and factors again matrices of the same sizes, and memory
    /// handed back is faulted in afresh, page by page, when it is taken again. The price is a
    /// somewhat higher resident peak; a process that exits gives everything back anyway.
    /// Measured (page faults, times, peaks): bench/README.md, session 24.
    pub(super) fn keep_freed_memory() {
        // SAFETY: `mallopt` is glibc's, called before any other thread exists, with
        // parameters and values it documents; a refused value leaves the default in place.
        unsafe {
            mallopt(M_MMAP_THRESHOLD, 32 << 20);
            mallopt(M_TRIM_THRESHOLD, 256 << 20);
            mallopt(M_TOP_PAD, 64 << 20);
        }
    }

    /// `struct rlimit` (`sys/resource.h`; `rlim_t` is 64 bits wide on 64-bit Linux).
    #[repr(C)]
    struct Rlimit {
        current: u64,
        maximum: u64,
    }

    const RLIMIT_DATA: i32 = 2;
    const RLIMIT_AS: i32 = 9;
    const RLIM_INFINITY: u64 = u64::MAX;

    extern "C" {
        fn getrlimit(resource: i32, rlim: *mut Rlimit) -> i32;
    }

    /// Whether neither the address space nor the data segment (the heap) of the process is
    /// limited (`ulimit -v`, `ulimit -d`); `false` where that cannot be read.
    fn heap_unlimited() -> bool {
        if !cfg!(target_pointer_width = "64") {
            return false;
        }
        [RLIMIT_AS, RLIMIT_DATA].into_iter().all(|resource| {
            let mut limit = Rlimit {
                current: 0,
                maximum: 0,
            };
            // SAFETY: glibc's `getrlimit` writes one `struct rlimit`, which `Rlimit` lays out
            // on 64-bit Linux (checked above); on failure it writes nothing.
            let ok = unsafe { getrlimit(resource, &mut limit) } == 0;
            ok && limit.current == RLIM_INFINITY
        })
    }

    /// Size of each block that [`prefault_heap`] touches (below the 32 MiB above which a
    /// block would be `mmap`ed on its own, and given back to the kernel when freed).
    const PREFAULT_BLOCK: usize = 24 << 20;

    /// Fault in `blocks` blocks of [`PREFAULT_BLOCK`] bytes of the heap on the idle core: they
    /// are allocated here (untouched, so at no cost to this thread), then a helper thread
    /// writes one byte per page and frees them. glibc returns a freed block to the heap it
    /// came from, whichever thread frees it, and [`keep_freed_memory`] keeps it mapped, so
    /// the memory that this thread takes later is already faulted in. `suslov certify` needs
    /// about 40 MB that its solve does not, each page a fault of a few microseconds
    /// (bench/README.md, session 28).
    pub(super) fn prefault_heap(blocks: usize) {
        // Under a limit on the address space or the heap the blocks could take what the
        // certificate needs later (measured: `ulimit -v 70000` aborted `suslov certify
        // examples/segment.toml`, which runs in 35 MB without them).
        if !heap_unlimited() {
            return;
        }
        // Reserved without aborting: blocks the allocator refuses are simply not faulted in
        // ahead.
        let heap: Vec<Vec<u8>> = (0..blocks)
            .map_while(|_| {
                let mut block = Vec::new();
                block.try_reserve_exact(PREFAULT_BLOCK).ok().map(|()| block)
            })
            .collect();
        if heap.is_empty() {
            return;
        }
        // Detached: if the process ends first, nothing is lost.
        let spawned = std::thread::Builder::new()
            .name("prefault".into())
            .spawn(move || {
                let mut heap = heap;
                for block in &mut heap {
                    for byte in block.spare_capacity_mut().iter_mut().step_by(4096) {
                        byte.write(0);
                    }
                }
                // The writes must happen although the blocks are freed right after.
                drop(std::hint::black_box(heap));
            });
        // Without a thread the pages are faulted in where they are used, as without this.
        drop(spawned);
    }
}

fn main() -> ExitCode {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    malloc_policy::keep_freed_memory();
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
        json: cli.json,
        bar: None,
        terminal: std::io::stderr().is_terminal(),
        case: String::new(),
    };
    let outcome = match cli.command {
        Command::Controllability(a) if a.along.is_some() => {
            let along = a.along.as_deref().unwrap_or(std::path::Path::new("paper"));
            let config = (along != std::path::Path::new("paper")).then_some(along);
            let result =
                app::run_rank_along_any(config, a.points, a.rtol, &mut |e| reporter.event(e));
            match result {
                Ok(r) => {
                    if cli.json {
                        print_json(&r.to_json());
                    } else {
                        out(&r.text);
                    }
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
                Ok(table) => {
                    if cli.json {
                        print_json(&table.json);
                    } else {
                        out(&table.text);
                    }
                    // No state on M establishes nothing: not a success (status 3).
                    match table.verdict {
                        AccessibilityVerdict::Accessible { .. } => Outcome::Success,
                        AccessibilityVerdict::RankDeficient { .. }
                        | AccessibilityVerdict::NoStateOnM => Outcome::Negative,
                    }
                }
                Err(e) => fail(&e),
            }
        }
        Command::Certify {
            config,
            json_file,
            tolerance,
        } => {
            #[cfg(all(target_os = "linux", target_env = "gnu"))]
            malloc_policy::prefault_heap(2);
            let result = app::run_certify_any(
                config.as_deref(),
                tolerance,
                json_file.as_deref(),
                &mut |e| reporter.event(e),
            );
            match result {
                Ok(reports) => {
                    if cli.json {
                        // The same document as --json-file writes.
                        print_json(&serde_json::json!({ "cases": reports }));
                    } else {
                        for r in &reports {
                            out(&r.text());
                        }
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
        Command::Paper { out, points } => solved(
            app::run_paper_with(&out, &app::OutputOptions { points }, &mut |e| {
                reporter.event(e)
            }),
            &out,
            cli.quiet,
            cli.json,
        ),
        Command::Solve {
            config,
            out,
            points,
        } => {
            let out = out.unwrap_or_else(|| default_solve_out(&config));
            solved(
                app::run_solve_with(&config, &out, &app::OutputOptions { points }, &mut |e| {
                    reporter.event(e)
                }),
                &out,
                cli.quiet,
                cli.json,
            )
        }
    };
    outcome.code()
}

/// The result line of a case: its status, and for a solution (converged or not) its numbers
/// with significant digits, the grid the constraint residual is taken on named. A case with no
/// solution prints its status (with the reason) alone: no NaNs.
fn case_line(c: &suslov::report::CaseSummary) -> String {
    if !(c.terminal_time.is_finite() && c.cost.is_finite()) || c.mesh_nodes == 0 {
        return format!("case {}: {}", c.name, c.status);
    }
    let grid = c
        .extra
        .get("check_grid_points")
        .and_then(|v| v.as_u64())
        .map(|p| format!(" on {p} points"))
        .unwrap_or_default();
    let mut line = format!(
        "case {}: {}; b = {}, cost = {}, max |<Omega, xi> - c| = {:.1e}{grid}, {} mesh nodes, {} s",
        c.name,
        c.status,
        significant(c.terminal_time, 8),
        significant(c.cost, 8),
        c.max_abs_constraint,
        c.mesh_nodes,
        significant(c.wall_seconds, 2)
    );
    // A verified extremal that a control with a vanishing xi undercuts is a local minimum
    // only (suslov::lie::collapse): say so under the result.
    let collapse = c.extra.get("collapse");
    let undercut = collapse
        .and_then(|v| v.get("undercuts"))
        .and_then(|v| v.as_bool());
    if c.status == "converged" && undercut == Some(true) {
        if let Some(sentence) = collapse
            .and_then(|v| v.get("sentence"))
            .and_then(|v| v.as_str())
        {
            line.push_str(&format!("\n  local minimum only: {sentence}"));
        }
    }
    line
}

/// `solve FILE` without `--out`: `out/<FILE's stem>` (beside `paper`'s default `out`, never
/// the same directory, so one run does not sweep the other's files).
fn default_solve_out(config: &std::path::Path) -> PathBuf {
    let stem = config
        .file_stem()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| std::ffi::OsStr::new("problem"));
    PathBuf::from("out").join(stem)
}

/// Prints the error of a job that stopped.
fn fail(e: &app::AppError) -> Outcome {
    say!("error: {e}");
    Outcome::Error
}

/// The outcome of `paper` / `solve`; with `--json`, `summary.json`'s content on stdout.
fn solved(
    result: Result<suslov::report::Summary, app::AppError>,
    out: &std::path::Path,
    quiet: bool,
    json: bool,
) -> Outcome {
    match result {
        Ok(summary) => {
            if !quiet {
                say!("wrote {}", out.join(suslov::report::SUMMARY_FILE).display());
            }
            if json {
                match summary.to_json_string() {
                    Ok(text) => out_json(&text),
                    Err(e) => {
                        say!("error: cannot print the results as JSON: {e}");
                        return Outcome::Error;
                    }
                }
            }
            if summary.cases.iter().all(|c| c.status == "converged") {
                Outcome::Success
            } else {
                let none = summary
                    .cases
                    .iter()
                    .filter(|c| c.status_code == suslov::report::StatusCode::NoMinimizer)
                    .count();
                if none > 0 {
                    say!(
                        "not every case converged: {none} of {} ha{} no minimizer, and an \
                         epsilon-optimal control in {} (see summary.json)",
                        summary.cases.len(),
                        if none == 1 { "s" } else { "ve" },
                        suslov::app::lie::INFIMUM_FILE
                    );
                } else {
                    say!("not every case converged (see summary.json)");
                }
                Outcome::Negative
            }
        }
        Err(e) => fail(&e),
    }
}
