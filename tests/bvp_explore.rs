mod common;
use common::*;
use suslov::bvp::*;

fn report<P: Exact>(name: &str, prob: &P, guess: Guess, tol: f64) {
    for jac in [JacobianSource::Analytic, JacobianSource::FiniteDifference] {
        let opts = Options { tol, jacobian: jac, ..Options::default() };
        let sol = solve(prob, &guess, &opts).unwrap();
        println!(
            "{name:12} {:?} status={:?} nodes={} p={:?} node_err={:.2e} dense_err={:.2e} hist={:?} newton={} jac={} fev={} maxerr={:.2e} maxres={:.2e} bc={:.1e} kappa={:.1e} cond={:.1e}",
            jac, sol.status, sol.num_nodes(), sol.p, node_error(prob, &sol), dense_error(prob, &sol, 5000),
            sol.stats.mesh_history, sol.stats.newton_iterations, sol.stats.jacobian_evaluations, sol.stats.f_evaluations,
            sol.stats.max_error, sol.stats.max_residual, sol.stats.bc_residual, sol.stats.bc_condition, sol.stats.condition_estimate
        );
    }
}

#[test]
fn explore() {
    let x = uniform(0.0, 1.0, 10);
    for tol in [1e-6, 1e-8] {
        report("linear", &Linear, Guess::from_values(x.clone(), vec![0.0; 22], vec![]), tol);
        report("quadratic", &Quadratic, Guess::from_fn(&x, 2, vec![], |t, o| { o[0] = 4.0 - 3.0 * t; o[1] = -3.0; }), tol);
        report("sturm", &SturmLiouville, Guess::from_fn(&x, 2, vec![3.0], |t, o| { o[0] = (3.0 * t).sin(); o[1] = 3.0 * (3.0*t).cos(); }), tol);
        report("layer", &BoundaryLayer { eps: 1e-3 }, Guess::from_fn(&x, 2, vec![], |t, o| { o[0] = t; o[1] = 1.0; }), tol);
        let lo = Bratu::new(1.0, 1.0);
        report("bratu-lo", &lo, Guess::from_values(x.clone(), vec![0.0; 22], vec![]), tol);
        let hi = Bratu::new(1.0, 10.0);
        report("bratu-hi", &hi, Guess::from_fn(&x, 2, vec![], |_t, o| { o[0] = 3.0; o[1] = 0.0; }), tol);
        report("tanh", &InteriorLayer { w: 0.01 }, Guess::from_fn(&x, 2, vec![], |t, o| { o[0] = 2.0 * t - 1.0; o[1] = 2.0; }), tol);
    }
}

#[test]
fn explore_newton() {
    let x = uniform(0.0, 1.0, 10);
    let hi = Bratu::new(1.0, 10.0);
    for (name, prob, guess) in [
        ("linear", &Linear as &dyn BvpProblem, Guess::from_values(x.clone(), vec![0.0; 22], vec![])),
        ("bratu-hi", &hi as &dyn BvpProblem, Guess::from_fn(&x, 2, vec![], |_t, o| { o[0] = 3.0; o[1] = 0.0; })),
    ] {
        for jac in [JacobianSource::Analytic, JacobianSource::FiniteDifference] {
            println!("== {name} {jac:?}");
            let opts = Options { tol: 1e-6, jacobian: jac, ..Options::default() };
            let sol = solve_with_progress(prob, &guess, &opts, &mut |p| println!("  {p:?}")).unwrap();
            println!("  -> {:?}", sol.status);
        }
    }
}

struct NoSolution;
impl BvpProblem for NoSolution {
    fn n(&self) -> usize { 2 }
    fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) { dy[0] = y[1]; dy[1] = -y[0]; }
    fn jac(&self, _x: f64, _y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, -1.0, 0.0]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) { r[0] = ya[0]; r[1] = yb[0] - 1.0; }
}
struct Undefined;
impl BvpProblem for Undefined {
    fn n(&self) -> usize { 2 }
    fn f(&self, _x: f64, _y: &[f64], _p: &[f64], dy: &mut [f64]) { dy[0] = 0.0; dy[1] = 0.0; }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) { r[0] = ya[0]; r[1] = yb[0] - 1.0; }
}

#[test]
fn explore_fail() {
    let x = uniform(0.0, std::f64::consts::PI, 10);
    let g = Guess::from_values(x.clone(), vec![0.0; 22], vec![]);
    for tol in [1e-3, 1e-6, 1e-8] {
        let sol = solve(&NoSolution, &g, &Options { tol, ..Options::default() }).unwrap();
        println!("nosol tol {tol}: {:?} cond {:e} kappa {:e} nodes {} ymax {:?} hist {:?}", sol.status, sol.stats.condition_estimate, sol.stats.bc_condition, sol.num_nodes(), sol.y.iter().fold(0.0f64, |a, v| a.max(v.abs())), sol.stats.mesh_history);
    }
    let x = uniform(0.0, 1.0, 4);
    let sol = solve(&Undefined, &Guess::from_values(x.clone(), vec![0.0; 10], vec![]), &Options::default()).unwrap();
    println!("undefined: {:?}", sol.status);
    let b = Bratu::new(5.0, 1.0);
    let x = uniform(0.0, 1.0, 10);
    let sol = solve(&b, &Guess::from_values(x.clone(), vec![0.0; 22], vec![]), &Options::default()).unwrap();
    println!("bratu5: {:?} hist {:?}", sol.status, sol.stats.mesh_history);
    let sol = solve(&SturmLiouville, &Guess::from_fn(&x, 2, vec![3.0], |t, o| { o[0] = (3.0 * t).sin(); o[1] = 3.0 * (3.0*t).cos(); }), &Options { bc_tol: Some(1e-300), ..Options::default() }).unwrap();
    println!("sturm bc: {:?} bc {:e}", sol.status, sol.stats.bc_residual);
}

#[test]
fn explore_nosol() {
    let x = uniform(0.0, std::f64::consts::PI, 10);
    let g = Guess::from_values(x.clone(), vec![0.0; 22], vec![]);
    let sol = solve_with_progress(&NoSolution, &g, &Options { tol: 1e-6, ..Options::default() }, &mut |p| println!("{p:?}")).unwrap();
    println!("{:?} {:e}", sol.status, sol.stats.bc_condition);
    for i in 0..sol.num_nodes() { println!("{} {:?}", sol.x[i], sol.y_at(i)); }
}
