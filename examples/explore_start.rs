use std::sync::Arc;
use suslov::bvp::{solve, Guess, Options};
use suslov::model::generated as g;
use suslov::suslov::problem::*;
use suslov::suslov::*;

fn main() {
    let spiral = PaperSpiral::paper();
    let ell = spiral.ellipsoid().clone();
    let omega_b = spiral.omega_b();
    let omega_p = Projected::new(spiral.clone(), ell);
    let beta_m: f64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(1e-3);
    let problem = SuslovProblem {
        inertia: Inertia::paper(),
        weights: CostWeights {
            alpha: 1.0,
            beta: beta_m,
            gamma: 1.0,
            eta: 0.0,
            delta: 0.0,
        },
        t0: 0.0,
        omega_a: spiral.omega_a(),
        omega_b,
        terminal: TerminalTime::Fixed(10.0),
        desired: Arc::new(spiral.clone()),
    };
    problem.validate().unwrap();
    let bvp = SuslovBvp::new(&problem);
    let params = problem.params();
    let x: Vec<f64> = (0..=200).map(|i| i as f64 / 200.0).collect();
    let guess = Guess::from_fn(&x, 12, vec![], |s, out| {
        let j = omega_p.jet(10.0 * s);
        let om = [
            j.value[0], j.value[1], j.value[2], j.d1[0], j.d1[1], j.d1[2], j.d2[0], j.d2[1],
            j.d2[2],
        ];
        let mut xi = [0.0; 6];
        g::singular_control(&om, &params, &mut xi);
        out[..3].copy_from_slice(&om[..3]);
        out[3..9].copy_from_slice(&xi);
        out[9..].fill(0.0);
    });
    let mut opts = Options::default();
    opts.tol = 1e-6;
    let t = std::time::Instant::now();
    let sol = solve(&bvp, &guess, &opts).unwrap();
    println!(
        "{:?} {} nodes={} stats={:?} in {:?}",
        sol.status,
        sol.status.message(),
        sol.num_nodes(),
        sol.stats,
        t.elapsed()
    );
}
