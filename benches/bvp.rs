//! Benchmarks of the BVP solver (plain binary, `harness = false`; run with
//! `cargo bench --bench bvp`). Reports medians of repeated solves; never asserts times.
//!
//! 1. The test problems of `tests/common` (same guesses and meshes as
//!    `bench/scipy_bvp.py`) at tol 1e-6, 1e-8 (as scipy) and 1e-10 (to match scipy's delivered
//!    accuracy): median time, nodes, Newton iterations,
//!    f evaluations, max error against the exact solution.
//! 2. Scaling: one Newton solve of a linear problem on fixed uniform meshes of
//!    N = 1e2, 1e3, 1e4 intervals (n = 2 and n = 12): time per interval should be flat.
//! 3. One Newton step (residual, Jacobians, condensation, factorisation, correction;
//!    `bvp::NewtonStep`) on the final meshes of the paper's two cases (n = 12, k = 1) and of
//!    the so(4) example `examples/so4_body.toml` (n = 24, k = 1), and on uniform meshes of N = 1e2 .. 1e4 intervals for the n = 12 oscillators: time per step and
//!    per interval (wall), and the median thread CPU time per step (what a shared machine's
//!    load does not inflate).

#[path = "../tests/common/mod.rs"]
mod common;

use common::*;
use std::time::{Duration, Instant};
use suslov::bvp::{solve, BvpProblem, Guess, NewtonStep, Options, Solution};

/// Median wall time of `f` over repetitions (at least 5, at most 101, about `budget` total).
fn median_time(budget: Duration, mut f: impl FnMut() -> Solution) -> (Duration, Solution) {
    let mut times = vec![];
    let start = Instant::now();
    let mut last;
    loop {
        let t = Instant::now();
        last = f();
        times.push(t.elapsed());
        if (times.len() >= 5 && start.elapsed() > budget) || times.len() >= 101 {
            break;
        }
    }
    times.sort();
    (times[times.len() / 2], last)
}

fn coarse() -> Vec<f64> {
    uniform(0.0, 1.0, 10)
}

fn bench_problem<P: Exact>(name: &str, prob: &P, guess: &Guess) {
    for tol in [1e-6, 1e-8, 1e-10] {
        let opts = Options {
            tol,
            ..Options::default()
        };
        let (t, sol) = median_time(Duration::from_millis(400), || {
            solve(prob, guess, &opts).unwrap()
        });
        let mut err = node_error(prob, &sol).max(dense_error(prob, &sol, 2000));
        for (pv, pe) in sol.p.iter().zip(prob.exact_p()) {
            err = err.max((pv - pe).abs() / (1.0 + pe.abs()));
        }
        println!(
            "| {name:<22} | {tol:.0e} | {:>10.3} | {:>6} | {:>6} | {:>5} | {:>8} | {:>8.1e} | {:?} |",
            t.as_secs_f64() * 1e3,
            sol.num_nodes(),
            sol.stats.newton_iterations,
            sol.stats.jacobian_evaluations,
            sol.stats.f_evaluations,
            err,
            sol.status
        );
    }
}

/// Six coupled linear oscillators (n = 12): y_j'' = -w_j^2 y_j + 0.1 (y_{j-1} - 2 y_j + y_{j+1})
/// + sin(j x); y_j(0) = 1, y_j(1) = 0. Well posed (w_j = j + 1/2 is not a multiple of pi).
struct Oscillators;
impl BvpProblem for Oscillators {
    fn n(&self) -> usize {
        12
    }
    fn f(&self, x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        for j in 0..6 {
            let w = j as f64 + 0.5;
            let left = if j > 0 { y[2 * j - 2] } else { 0.0 };
            let right = if j < 5 { y[2 * j + 2] } else { 0.0 };
            dy[2 * j] = y[2 * j + 1];
            dy[2 * j + 1] =
                -w * w * y[2 * j] + 0.1 * (left - 2.0 * y[2 * j] + right) + (j as f64 * x).sin();
        }
    }
    fn jac(&self, _x: f64, _y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.fill(0.0);
        for j in 0..6 {
            let w = j as f64 + 0.5;
            dfdy[(2 * j) * 12 + 2 * j + 1] = 1.0;
            dfdy[(2 * j + 1) * 12 + 2 * j] = -w * w - 0.2;
            if j > 0 {
                dfdy[(2 * j + 1) * 12 + 2 * j - 2] = 0.1;
            }
            if j < 5 {
                dfdy[(2 * j + 1) * 12 + 2 * j + 2] = 0.1;
            }
        }
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        for j in 0..6 {
            r[j] = ya[2 * j] - 1.0;
            r[6 + j] = yb[2 * j];
        }
    }
    fn bc_jac(
        &self,
        _ya: &[f64],
        _yb: &[f64],
        _p: &[f64],
        dya: &mut [f64],
        dyb: &mut [f64],
        _dp: &mut [f64],
    ) -> bool {
        dya.fill(0.0);
        dyb.fill(0.0);
        for j in 0..6 {
            dya[j * 12 + 2 * j] = 1.0;
            dyb[(6 + j) * 12 + 2 * j] = 1.0;
        }
        true
    }
}

fn bench_scaling<P: BvpProblem>(name: &str, prob: &P) {
    for intervals in [100, 1_000, 10_000] {
        let x = uniform(0.0, 1.0, intervals);
        let guess = Guess::from_values(x.clone(), vec![0.0; x.len() * prob.n()], vec![]);
        let opts = Options {
            adapt_mesh: false,
            tol: 1e-6,
            ..Options::default()
        };
        let (t, sol) = median_time(Duration::from_millis(1500), || {
            solve(prob, &guess, &opts).unwrap()
        });
        println!(
            "| {name:<14} | {:>6} | {intervals:>7} | {:>10.3} | {:>8.3} | {:>6} | {:>5} | {:?} |",
            prob.n(),
            t.as_secs_f64() * 1e3,
            t.as_secs_f64() * 1e6 / intervals as f64,
            sol.stats.newton_iterations,
            sol.stats.factorizations,
            sol.status
        );
    }
}

/// Warm start cost: re-solve from a converged solution (exact restart) and from a
/// neighbouring parameter value (one continuation step).
fn bench_warm_start() {
    let prob = InteriorLayer { w: 0.01 };
    let g = Guess::from_fn(&coarse(), 2, vec![], |x, o| {
        o.copy_from_slice(&[2.0 * x - 1.0, 2.0])
    });
    let opts = Options {
        tol: 1e-8,
        ..Options::default()
    };
    let sol = solve(&prob, &g, &opts).unwrap();
    let warm = Guess::from_solution(&sol);
    let (t, s) = median_time(Duration::from_millis(400), || {
        solve(&prob, &warm, &opts).unwrap()
    });
    println!(
        "| exact restart, tanh w=0.01   | {:>10.3} | {:>6} | {:>6} | {:?} |",
        t.as_secs_f64() * 1e3,
        s.num_nodes(),
        s.stats.newton_iterations,
        s.status
    );
    let next = InteriorLayer { w: 0.0105 };
    let (t, s) = median_time(Duration::from_millis(400), || {
        solve(&next, &warm, &opts).unwrap()
    });
    println!(
        "| w 0.01 -> 0.0105, tanh       | {:>10.3} | {:>6} | {:>6} | {:?} |",
        t.as_secs_f64() * 1e3,
        s.num_nodes(),
        s.stats.newton_iterations,
        s.status
    );
}

/// CPU time of the calling thread in seconds (unaffected by waiting for a core when the
/// machine is shared).
fn thread_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid timespec to write into.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Median wall and thread-CPU seconds of `step.run()` (at least 9 repetitions, about
/// `budget` in total).
fn median_step<P: BvpProblem + ?Sized>(
    step: &mut NewtonStep<'_, P>,
    budget: Duration,
) -> (f64, f64) {
    let mut times = vec![];
    let mut cpu = vec![];
    let start = Instant::now();
    while times.len() < 9 || (start.elapsed() < budget && times.len() < 1001) {
        let t = Instant::now();
        let c = thread_cpu_seconds();
        step.run().expect("a nonsingular Newton matrix");
        cpu.push(thread_cpu_seconds() - c);
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    cpu.sort_by(f64::total_cmp);
    (times[times.len() / 2], cpu[cpu.len() / 2])
}

/// One Newton step on the final mesh of each paper case, and on uniform meshes (oscillators).
fn bench_newton_step() {
    let opts = Options {
        tol: 1e-8,
        ..Options::default()
    };
    // `STEP_ETA=0.01` (or 1) measures that paper case alone (e.g. under `perf`).
    let only: Option<f64> = std::env::var("STEP_ETA").ok().and_then(|v| v.parse().ok());
    for eta in [1.0, 0.01] {
        if only.is_some_and(|o| o != eta) {
            continue;
        }
        let problem = suslov::paper::problem(eta);
        let sol = suslov::solve(&problem, &suslov::SolveOptions::default(), &mut |_| {})
            .expect("the paper case solves");
        let generic = &sol.generic;
        let bvp = suslov::lie::LieBvp::new(&generic.problem);
        let guess = Guess::from_solution(&generic.bvp);
        let mut step = NewtonStep::new(&bvp, &guess, &opts).expect("valid input");
        let (t, c) = median_step(&mut step, Duration::from_millis(1500));
        println!(
            "| paper eta = {eta:<5} | {:>6} | {:>10.3} | {:>8.3} | {:>10.3} |",
            step.intervals(),
            t * 1e3,
            t * 1e6 / step.intervals() as f64,
            c * 1e3
        );
    }
    if only.is_some() {
        return;
    }
    // The so(4) example (n = 24, k = 1) on its final mesh.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/so4_body.toml");
    let (loaded, _) = suslov::config::load_any(&path).expect("the so4 example loads");
    let suslov::config::Loaded::Other(file) = loaded else {
        panic!("examples/so4_body.toml is not an so4 file")
    };
    let built = file
        .build::<suslov::model::so4::So4>()
        .expect("the so4 example is valid");
    let sol = suslov::lie::solve(&built.problem, &built.options, &mut |_| {})
        .expect("the so4 example solves");
    let bvp = suslov::lie::LieBvp::new(&sol.problem);
    let guess = Guess::from_solution(&sol.bvp);
    let mut step = NewtonStep::new(&bvp, &guess, &opts).expect("valid input");
    let (t, c) = median_step(&mut step, Duration::from_millis(1500));
    println!(
        "| so4 example n=24   | {:>6} | {:>10.3} | {:>8.3} | {:>10.3} |",
        step.intervals(),
        t * 1e3,
        t * 1e6 / step.intervals() as f64,
        c * 1e3
    );
    for intervals in [100, 1_000, 10_000] {
        let x = uniform(0.0, 1.0, intervals);
        let guess = Guess::from_values(x.clone(), vec![0.0; x.len() * 12], vec![]);
        let mut step = NewtonStep::new(&Oscillators, &guess, &opts).expect("valid input");
        let (t, c) = median_step(&mut step, Duration::from_millis(1500));
        println!(
            "| oscillators n=12   | {:>6} | {:>10.3} | {:>8.3} | {:>10.3} |",
            step.intervals(),
            t * 1e3,
            t * 1e6 / step.intervals() as f64,
            c * 1e3
        );
    }
}

fn main() {
    // Optional filter: `cargo bench --bench bvp -- scaling` (or `problems`, `warm`).
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let run =
        |section: &str| filter.is_empty() || filter.iter().any(|f| section.contains(f.as_str()));
    if run("problems") {
        println!("## Test problems (median of repeated cold solves from the same guess)\n");
        println!("| problem                | tol   | median ms  | nodes  | Newton | Jacs  | f evals  | max err  | status |");
        println!("|------------------------|-------|------------|--------|--------|-------|----------|----------|--------|");
        let zero = Guess::from_values(coarse(), vec![0.0; 22], vec![]);
        bench_problem("linear", &Linear, &zero);
        let g = Guess::from_fn(&coarse(), 2, vec![], |x, o| {
            o.copy_from_slice(&[4.0 - 3.0 * x, -3.0])
        });
        bench_problem("nonlinear y''=1.5y^2", &Quadratic, &g);
        let g = Guess::from_fn(&coarse(), 2, vec![3.0], |x, o| {
            o.copy_from_slice(&[(3.0 * x).sin(), 3.0 * (3.0 * x).cos()])
        });
        bench_problem("sturm-liouville (k=1)", &SturmLiouville, &g);
        let g = Guess::from_fn(&coarse(), 2, vec![], |x, o| o.copy_from_slice(&[x, 1.0]));
        bench_problem("boundary layer 1e-3", &BoundaryLayer { eps: 1e-3 }, &g);
        bench_problem("bratu lower", &Bratu::new(1.0, 1.0), &zero);
        let g = Guess::from_fn(&coarse(), 2, vec![], |_, o| o.copy_from_slice(&[3.0, 0.0]));
        bench_problem("bratu upper", &Bratu::new(1.0, 10.0), &g);
        let g = Guess::from_fn(&coarse(), 2, vec![], |x, o| {
            o.copy_from_slice(&[2.0 * x - 1.0, 2.0])
        });
        bench_problem("tanh layer w=0.01", &InteriorLayer { w: 0.01 }, &g);
        bench_problem(
            "layered n=12 k=1",
            &LayeredSystem,
            &LayeredSystem::guess(&uniform(0.0, 1.0, 20)),
        );
    }
    if run("warm") {
        println!("\n## Warm starts (tol 1e-8)\n");
        println!("| case                         | median ms  | nodes  | Newton | status |");
        println!("|------------------------------|------------|--------|--------|--------|");
        bench_warm_start();
    }
    if run("scaling") {
        println!("\n## Scaling: one Newton solve of a linear problem on a fixed uniform mesh\n");
        println!("| problem        | n      | N       | median ms  | us/N     | Newton | LUs   | status |");
        println!("|----------------|--------|---------|------------|----------|--------|-------|--------|");
        bench_scaling("linear", &Linear);
        bench_scaling("oscillators", &Oscillators);
    }
    if run("step") {
        println!("\n## One Newton step on a fixed mesh (median)\n");
        println!("| case               | N      | ms/step    | us/N     | cpu ms/step |");
        println!("|--------------------|--------|------------|----------|------------|");
        bench_newton_step();
    }
}
