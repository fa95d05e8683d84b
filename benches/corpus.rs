//! The robustness benchmark of issue #12 (plain binary, `harness = false`):
//! `cargo bench --bench corpus`. Generates the seeded corpus of `tests/corpus/mod.rs`, solves
//! every problem exactly as `suslov solve FILE --out DIR` does (`suslov::app::run_solve`),
//! each in a child process of this binary (so a hang is cut by a timeout and an abort is
//! recorded, not fatal), classifies it (solved and verified / explained / unexplained / false
//! "converged", the last from an independent check of the written `trajectory.csv`) and prints
//! a markdown table per category, the explained reasons by stage, and every unsolved problem.
//!
//! Environment:
//! - `CORPUS_N` (default 200): generated problems;
//! - `CORPUS_SEED` (default `corpus::SEED`);
//! - `CORPUS_ONLY`: `hard` (the files of `tests/corpus/hard/` only), `all` (generated and
//!   hard), a category name, or a comma-separated list of problem ids;
//! - `CORPUS_TIMEOUT` (seconds, default 300) per problem;
//! - `CORPUS_JOBS` (default 1): problems solved at once (timings are per problem; keep 1
//!   for timings on a shared machine);
//! - `CORPUS_WORK`: work directory (default `target/tmp/corpus`); the unsolved problems'
//!   directories (problem file and outputs) are kept there, every problem's with
//!   `CORPUS_KEEP=1`;
//! - `CORPUS_REPORT`: also write the report to this file.
//!
//! Timings are wall times of `run_solve` (figures and all outputs included) on whatever
//! machine runs it; the load average is printed next to them. Nothing is asserted.

#[path = "../tests/corpus/mod.rs"]
mod corpus;

use corpus::{CorpusProblem, Outcome, RunResult, Verdict};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

const CHILD_PROBLEM: &str = "CORPUS_CHILD_PROBLEM";
const CHILD_OUT: &str = "CORPUS_CHILD_OUT";
const RUN_FILE: &str = "run.json";

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    match std::env::var(name) {
        Ok(v) => v
            .parse()
            .unwrap_or_else(|_| panic!("{name} = {v:?} is not a valid value")),
        Err(_) => default,
    }
}

/// In the child: solve one problem, write how `run_solve` ended next to its output directory.
fn child(problem: &Path, out: &Path) {
    // The panic message is recorded in run.json; keep stderr quiet.
    std::panic::set_hook(Box::new(|_| {}));
    let (run, seconds) = corpus::run_solve_caught(problem, out);
    let (kind, text) = match run {
        RunResult::Ok => ("ok", String::new()),
        RunResult::Err(e) => ("err", e),
        RunResult::Panic(p) => ("panic", p),
    };
    let json = serde_json::json!({"kind": kind, "text": text, "seconds": seconds});
    let path = out.parent().unwrap().join(RUN_FILE);
    std::fs::write(path, json.to_string()).expect("write run.json");
}

/// In the parent: solve `p` in a child process under `work/<id>` and classify it.
fn run_problem(p: &CorpusProblem, work: &Path, timeout: Duration) -> Outcome {
    let dir = work.join(&p.id);
    let _ = std::fs::remove_dir_all(&dir);
    let path = corpus::write_problem(p, &dir).expect("writable work directory");
    let out = dir.join("out");
    let clock = Instant::now();
    let mut proc = Command::new(std::env::current_exe().expect("own path"))
        .env(CHILD_PROBLEM, &path)
        .env(CHILD_OUT, &out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("spawn the child");
    let status = loop {
        if let Some(s) = proc.try_wait().expect("wait for the child") {
            break Some(s);
        }
        if clock.elapsed() > timeout {
            let _ = proc.kill();
            let _ = proc.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let wall = clock.elapsed().as_secs_f64();
    let unexplained = |m: String, seconds| Outcome {
        verdict: Verdict::Unexplained(m),
        seconds,
        check: None,
        route: None,
        collapse: None,
        infimum: None,
    };
    let Some(status) = status else {
        return unexplained(format!("timeout after {} s", timeout.as_secs()), wall);
    };
    let run: Option<serde_json::Value> = std::fs::read_to_string(dir.join(RUN_FILE))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok());
    let Some(run) = run else {
        return unexplained(format!("child died ({status}) without a result"), wall);
    };
    let text = run["text"].as_str().unwrap_or("").to_string();
    let seconds = run["seconds"].as_f64().unwrap_or(wall);
    let result = match run["kind"].as_str() {
        Some("ok") => RunResult::Ok,
        Some("err") => RunResult::Err(text),
        _ => RunResult::Panic(text),
    };
    let (verdict, check) = corpus::classify(&result, &p.toml, &dir, &out);
    Outcome {
        verdict,
        seconds,
        check,
        route: corpus::last_route(&out),
        collapse: corpus::collapse_flags(&out),
        infimum: corpus::infimum_check(&p.toml, &dir, &out),
    }
}

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

fn commit() -> String {
    let out = Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output();
    let dirty = Command::new("git")
        .args(["status", "--porcelain", "--untracked-files=no"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .map(|o| !o.stdout.is_empty())
        .unwrap_or(false);
    match out {
        Ok(o) if o.status.success() => format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout).trim(),
            if dirty { " (with local changes)" } else { "" }
        ),
        _ => "unknown".into(),
    }
}

fn date() -> String {
    Command::new("date")
        .args(["-u", "+%Y-%m-%d %H:%M UTC"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|_| "unknown".into())
}

/// The `q`-quantile (nearest rank) of sorted `v`.
fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[k - 1]
}

#[derive(Default)]
struct Row {
    problems: usize,
    solved: usize,
    explained: usize,
    no_minimizer: usize,
    unexplained: usize,
    false_converged: usize,
    fixed: usize,
    fixed_solved: usize,
    fixed_no_minimizer: usize,
    seconds: Vec<f64>,
}

impl Row {
    fn add(&mut self, p: &CorpusProblem, o: &Outcome) {
        self.problems += 1;
        match o.verdict {
            Verdict::Solved => self.solved += 1,
            Verdict::Explained { .. } => self.explained += 1,
            Verdict::NoMinimizer { .. } => self.no_minimizer += 1,
            Verdict::Unexplained(_) => self.unexplained += 1,
            Verdict::FalseConverged(_) => self.false_converged += 1,
        }
        if p.fixed_time {
            self.fixed += 1;
            match o.verdict {
                Verdict::Solved => self.fixed_solved += 1,
                Verdict::NoMinimizer { .. } => self.fixed_no_minimizer += 1,
                _ => {}
            }
        }
        self.seconds.push(o.seconds);
    }

    fn line(&mut self, name: &str) -> String {
        self.seconds.sort_by(f64::total_cmp);
        let pct = |a: usize, b: usize| {
            if b == 0 {
                "-".to_string()
            } else {
                format!("{a}/{b} ({:.0} %)", 100.0 * a as f64 / b as f64)
            }
        };
        format!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} |",
            self.problems,
            pct(self.solved, self.problems),
            self.no_minimizer,
            self.explained,
            self.unexplained,
            self.false_converged,
            pct(self.fixed_solved, self.fixed),
            pct(self.fixed_solved + self.fixed_no_minimizer, self.fixed),
            quantile(&self.seconds, 0.5),
            quantile(&self.seconds, 0.9),
            self.seconds.last().copied().unwrap_or(f64::NAN),
        )
    }
}

fn shorten(s: &str, n: usize) -> String {
    let s = s.replace('\n', " ").replace('|', "\\|");
    if s.chars().count() <= n {
        s
    } else {
        format!("{}…", s.chars().take(n).collect::<String>())
    }
}

fn main() {
    if let (Ok(problem), Ok(out)) = (std::env::var(CHILD_PROBLEM), std::env::var(CHILD_OUT)) {
        child(Path::new(&problem), Path::new(&out));
        return;
    }
    let n: usize = env_or("CORPUS_N", corpus::DEFAULT_N);
    let seed: u64 = env_or("CORPUS_SEED", corpus::SEED);
    let only = std::env::var("CORPUS_ONLY").unwrap_or_default();
    let timeout = Duration::from_secs_f64(env_or("CORPUS_TIMEOUT", 300.0));
    let jobs: usize = env_or("CORPUS_JOBS", 1usize).max(1);
    let work = std::env::var("CORPUS_WORK")
        .map(PathBuf::from)
        .unwrap_or_else(|_| Path::new(env!("CARGO_TARGET_TMPDIR")).join("corpus"));

    let problems: Vec<CorpusProblem> = match only.as_str() {
        "" => corpus::generate(n, seed),
        "hard" => corpus::hard_problems(),
        "all" => {
            let mut v = corpus::generate(n, seed);
            v.extend(corpus::hard_problems());
            v
        }
        filter => {
            let wanted: Vec<&str> = filter.split(',').map(str::trim).collect();
            let mut v = corpus::generate(n, seed);
            v.extend(corpus::hard_problems());
            v.retain(|p| wanted.contains(&p.category.as_str()) || wanted.contains(&p.id.as_str()));
            v
        }
    };
    assert!(
        !problems.is_empty(),
        "CORPUS_ONLY = {only:?} selects no problem"
    );

    let load_before = loadavg();
    let started = date();
    eprintln!(
        "corpus: {} problems (seed {seed}, N {n}, only {only:?}), {jobs} job(s), work dir {}",
        problems.len(),
        work.display()
    );
    let keep = std::env::var("CORPUS_KEEP").is_ok_and(|v| v == "1");
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Outcome>>> = Mutex::new(vec![None; problems.len()]);
    let clock = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(p) = problems.get(k) else { break };
                let o = run_problem(p, &work, timeout);
                let extra = match &o.verdict {
                    Verdict::Solved => String::new(),
                    Verdict::Explained { reason, .. } => shorten(reason, 140),
                    Verdict::NoMinimizer { reason } => shorten(reason, 140),
                    Verdict::Unexplained(m) => shorten(m, 140),
                    Verdict::FalseConverged(f) => shorten(&f.join("; "), 300),
                };
                eprintln!(
                    "[{:>3}/{}] {:<22} {:>7.2} s  {:<15} {extra}",
                    k + 1,
                    problems.len(),
                    p.id,
                    o.seconds,
                    o.verdict.label()
                );
                if o.verdict == Verdict::Solved && !keep {
                    let _ = std::fs::remove_dir_all(work.join(&p.id));
                }
                results.lock().unwrap()[k] = Some(o);
            });
        }
    });
    let total_wall = clock.elapsed().as_secs_f64();
    let results: Vec<Outcome> = results
        .into_inner()
        .unwrap()
        .into_iter()
        .map(|o| o.expect("every problem ran"))
        .collect();

    // Per category and total.
    let mut rows: BTreeMap<String, Row> = BTreeMap::new();
    let mut total = Row::default();
    let mut reasons: BTreeMap<String, usize> = BTreeMap::new();
    let mut solved_by: BTreeMap<String, usize> = BTreeMap::new();
    let mut unresolved = 0usize;
    let (mut unverified_checked, mut unverified_passing) = (0usize, 0usize);
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for (p, o) in problems.iter().zip(&results) {
        rows.entry(p.category.clone()).or_default().add(p, o);
        total.add(p, o);
        if let Verdict::Explained { key, .. } = &o.verdict {
            *reasons.entry(key.clone()).or_default() += 1;
        }
        if o.verdict == Verdict::Solved {
            let route = o.route.clone().unwrap_or_else(|| "(none listed)".into());
            *solved_by.entry(route).or_default() += 1;
        }
        // A no-minimizer's check is of its ε-optimal control (counted below, with the others).
        if matches!(o.verdict, Verdict::NoMinimizer { .. }) {
            continue;
        }
        if let (Verdict::Explained { .. }, Some(c)) = (&o.verdict, &o.check) {
            unverified_checked += 1;
            if c.passed() {
                unverified_passing += 1;
            }
            continue;
        }
        if let Some(c) = &o.check {
            if c.unresolved_rows * 10 > c.rows {
                unresolved += 1;
            }
            worst.0 = worst.0.max(c.max_constraint);
            worst.1 = worst.1.max(c.max_energy_drift);
            worst.2 = worst.2.max(c.max_equation);
        }
    }
    let mut r = String::new();
    let _ = writeln!(
        r,
        "Corpus run {started}, commit {}, seed {seed}, {} problems (CORPUS_N = {n}, CORPUS_ONLY = \
         {only:?}), {jobs} job(s), timeout {} s; load average (1/5/15 min) {load_before} before, \
         {} after; total wall {total_wall:.0} s.\n",
        commit(),
        problems.len(),
        timeout.as_secs(),
        loadavg()
    );
    let _ = writeln!(
        r,
        "| category | problems | solved + verified | no minimizer (eps-optimal, checked) | \
         explained | unexplained | false converged | fixed-time solved | fixed-time solved or \
         no minimizer | median s | 90 % s | max s |"
    );
    let _ = writeln!(r, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, row) in rows.iter_mut() {
        let _ = writeln!(r, "{}", row.line(name));
    }
    let _ = writeln!(r, "{}", total.line("**total**"));
    if total.solved + total.false_converged == 0 {
        let _ = writeln!(r, "\nNo converged trajectory to check independently.\n");
    } else {
        let _ = writeln!(
            r,
            "\nIndependent check of the converged trajectories: largest |<Ω, ξ>|/(|Ω||ξ|) \
             {:.1e}, energy drift {:.1e}, Suslov residual / scale {:.1e}; {unresolved} \
             converged problem(s) with more than 10 % of the rows too coarse on the written grid \
             (2001 uniform times and the mesh nodes) for the Suslov-equation test.\n",
            worst.0, worst.1, worst.2
        );
    }
    let _ = writeln!(
        r,
        "Of the {unverified_checked} `unverified` solutions (the tool's own checks failed), \
         {unverified_passing} pass the independent check of their `trajectory.unverified.csv`.\n"
    );
    let _ = writeln!(
        r,
        "Solved and verified, by the homotopy route that solved them:\n"
    );
    let _ = writeln!(r, "| route | problems |\n|---|---|");
    for (k, c) in &solved_by {
        let _ = writeln!(r, "| {k} | {c} |");
    }
    let _ = writeln!(r);
    // What the controls with a vanishing xi showed (summary.json's extra.collapse).
    let mut collapse: BTreeMap<(&str, String), usize> = BTreeMap::new();
    for (p, o) in problems.iter().zip(&results) {
        let kind = match (&o.verdict, p.fixed_time) {
            (Verdict::Solved, _) => "solved + verified",
            (Verdict::Explained { .. }, true) => "explained, fixed b",
            (Verdict::Explained { .. }, false) => "explained, free b",
            (Verdict::NoMinimizer { .. }, true) => "no minimizer, fixed b",
            (Verdict::NoMinimizer { .. }, false) => "no minimizer, free b",
            _ => "other",
        };
        let found = match o.collapse {
            None => "not evaluated".to_string(),
            Some(f) if f.no_optimal_time => "undercut: no optimal b".to_string(),
            Some(f) if f.undercuts => format!(
                "undercut (cheapest: {})",
                f.least_motion.unwrap_or("unknown")
            ),
            Some(_) => "not undercut".to_string(),
        };
        let found = match o.collapse.and_then(|f| f.relaxed) {
            Some(status) => format!("{found}; relaxed minimum {status}"),
            None => found,
        };
        *collapse.entry((kind, found)).or_default() += 1;
    }
    let _ = writeln!(
        r,
        "Controls with a vanishing xi (`suslov::lie::collapse`; `undercut`: one costs less than \
         the extremal, or than the stop's comparison; the cheapest control's motion in \
         parentheses; for a fixed b, whether the relaxed problem's minimum, the limit xi -> 0, \
         was computed):\n"
    );
    let _ = writeln!(r, "| problems | finding | count |\n|---|---|---|");
    for ((kind, found), c) in &collapse {
        let _ = writeln!(r, "| {kind} | {found} | {c} |");
    }
    let _ = writeln!(r);
    // The stops' ε-optimal controls (trajectory.infimum.csv), checked independently.
    let written: Vec<(&CorpusProblem, &corpus::TrajectoryCheck)> = problems
        .iter()
        .zip(&results)
        .filter_map(|(p, o)| o.infimum.as_ref().map(|c| (p, c)))
        .collect();
    let fixed = written.iter().filter(|(p, _)| p.fixed_time).count();
    let passed = written.iter().filter(|(_, c)| c.passed()).count();
    let worst = |f: fn(&corpus::TrajectoryCheck) -> f64| {
        written.iter().map(|(_, c)| f(c)).fold(0.0_f64, f64::max)
    };
    let _ = writeln!(
        r,
        "Stops whose infimum is approached as xi -> 0 and that wrote its eps-optimal control \
         (`trajectory.infimum.csv`, the relaxed minimum's motion with |xi| = 1e-6): {} ({} with \
         a fixed b); {passed} pass the independent check of the written file (largest \
         |<Omega, xi>|/(|Omega||xi|) {:.1e}, energy drift {:.1e}, Suslov residual / scale \
         {:.1e}).",
        written.len(),
        fixed,
        worst(|c| c.max_constraint),
        worst(|c| c.max_energy_drift),
        worst(|c| c.max_equation),
    );
    for (p, c) in written.iter().filter(|(_, c)| !c.passed()) {
        let _ = writeln!(r, "- {}: {}", p.id, c.failures.join("; "));
    }
    let _ = writeln!(r);
    let _ = writeln!(r, "Explained stops by stage (or check):\n");
    let _ = writeln!(r, "| stage | problems |\n|---|---|");
    for (k, c) in &reasons {
        let _ = writeln!(r, "| {k} | {c} |");
    }
    let _ = writeln!(r, "\nEvery problem not solved and verified:\n");
    let _ = writeln!(
        r,
        "| id | fixed b | verdict | s | reason | independent check |\n|---|---|---|---|---|---|"
    );
    for (p, o) in problems.iter().zip(&results) {
        let reason = match &o.verdict {
            Verdict::Solved => continue,
            Verdict::Explained { reason, .. } => reason.clone(),
            Verdict::NoMinimizer { reason } => reason.clone(),
            Verdict::Unexplained(m) => m.clone(),
            Verdict::FalseConverged(f) => f.join("; "),
        };
        let check = match &o.check {
            None => "-".to_string(),
            Some(c) if c.passed() => "passes".to_string(),
            Some(c) => format!("fails: {}", shorten(&c.failures.join("; "), 160)),
        };
        let _ = writeln!(
            r,
            "| {} | {} | {} | {:.2} | {} | {check} |",
            p.id,
            if p.fixed_time { "yes" } else { "no" },
            o.verdict.label(),
            o.seconds,
            shorten(&reason, 220)
        );
    }
    println!("{r}");
    if let Ok(path) = std::env::var("CORPUS_REPORT") {
        std::fs::write(&path, &r).expect("write CORPUS_REPORT");
    }
}
