//! One Newton step on the final mesh of each paper case, for the same-run comparison of
//! issue #13: main's example `step_ab` (Cargo.toml), which `bench/issue13/targets.py` also
//! copies into `examples/` of the baseline (commit 47a60f5 with
//! `bench/issue13/base_newton_step.patch`). It uses only API that both trees have.
//!
//! Each paper case is solved (default options), then `bvp::NewtonStep` on its final mesh is
//! repeated for about `STEP_BUDGET_MS` (default 1500) milliseconds, at least 9 times, with the
//! desired path behind `lie::path::Memo` as the solver evaluates it (the patch's `Memo` on the
//! baseline is the identity: its solver had none). One JSON line per case on standard output:
//! the intervals, the median wall and thread CPU milliseconds per step, the repetitions, and
//! the correction's max-norm (the same in every tree up to rounding: the steps do the same
//! mathematics).

use std::sync::Arc;
use std::time::{Duration, Instant};
use suslov::bvp::{BvpProblem, Guess, NewtonStep, Options};
use suslov::lie::path::{Memo, Path};

/// CPU time of the calling thread in seconds.
fn thread_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid timespec to write into.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Median wall and thread-CPU seconds of `step.run()`, the repetitions, and the last
/// correction's norm.
fn median_step<P: BvpProblem + ?Sized>(
    step: &mut NewtonStep<'_, P>,
    budget: Duration,
) -> (f64, f64, usize, f64) {
    let (mut wall, mut cpu) = (vec![], vec![]);
    let mut norm = f64::NAN;
    let start = Instant::now();
    while wall.len() < 9 || (start.elapsed() < budget && wall.len() < 1001) {
        let t = Instant::now();
        let c = thread_cpu_seconds();
        norm = step.run().expect("a nonsingular Newton matrix");
        cpu.push(thread_cpu_seconds() - c);
        wall.push(t.elapsed().as_secs_f64());
    }
    wall.sort_by(f64::total_cmp);
    cpu.sort_by(f64::total_cmp);
    (wall[wall.len() / 2], cpu[cpu.len() / 2], wall.len(), norm)
}

fn main() {
    let budget_ms: u64 = std::env::var("STEP_BUDGET_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1500);
    let opts = Options {
        tol: 1e-8,
        ..Options::default()
    };
    for eta in [1.0, 0.01] {
        let problem = suslov::paper::problem(eta);
        let sol = suslov::solve(&problem, &suslov::SolveOptions::default(), &mut |_| {})
            .expect("the paper case solves");
        let generic = &sol.generic;
        let memo: Arc<dyn Path> = Arc::new(Memo::new(generic.problem.desired.clone()));
        let mut bvp = suslov::lie::LieBvp::new(&generic.problem);
        bvp.desired = &*memo;
        let guess = Guess::from_solution(&generic.bvp);
        let mut step = NewtonStep::new(&bvp, &guess, &opts).expect("valid input");
        let (wall, cpu, reps, norm) = median_step(&mut step, Duration::from_millis(budget_ms));
        println!(
            "{{\"eta\": {eta}, \"intervals\": {}, \"wall_ms\": {:.6}, \"cpu_ms\": {:.6}, \
             \"repetitions\": {reps}, \"correction_norm\": {norm:e}}}",
            step.intervals(),
            wall * 1e3,
            cpu * 1e3,
        );
    }
}
