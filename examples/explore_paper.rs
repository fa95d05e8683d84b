use std::sync::Arc;
use suslov::suslov::problem::*;
use suslov::suslov::solve::*;
use suslov::suslov::*;

fn main() {
    let eta: f64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(1.0);
    let spiral = PaperSpiral::paper();
    let problem = SuslovProblem {
        inertia: Inertia::paper(),
        weights: CostWeights::paper(eta),
        t0: 0.0,
        omega_a: spiral.omega_a(),
        omega_b: spiral.omega_b(),
        terminal: TerminalTime::Free { guess: 10.0 },
        desired: Arc::new(spiral.clone()),
    };
    let clock = std::time::Instant::now();
    let res = solve(&problem, &SolveOptions::default(), &mut |e| match e {
        Event::StageStarted { name, from, to } => eprintln!("stage {name}: {from} -> {to}"),
        Event::Step { stage, record } => eprintln!(
            "  {stage} lambda={:.4} ok={} newton={} nodes={} secant={}",
            record.lambda, record.accepted, record.newton_iterations, record.nodes, record.secant
        ),
        Event::StageFinished(r) => eprintln!("  done {r:?}"),
    });
    match res {
        Ok(sol) => {
            println!(
                "eta={eta}: b = {:.6}, nodes = {}, in {:?}; start {:?}",
                sol.terminal_time(),
                sol.bvp.num_nodes(),
                clock.elapsed(),
                sol.start
            );
            let c = std::time::Instant::now();
            let d = suslov::suslov::diagnostics::diagnose(&sol);
            println!("{d:#?} in {:?}", c.elapsed());
            let c = std::time::Instant::now();
            let r = suslov::suslov::diagnostics::reintegrate_check(&sol);
            println!("{r:#?} in {:?}", c.elapsed());
        }
        Err(e) => println!("FAILED: {e}"),
    }
}
