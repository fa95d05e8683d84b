//! Warm starts ([`suslov::lie::solve_from`]): a solution of a nearby problem replaces the
//! homotopy when it leads to a verified solution, which must be the solution the homotopy
//! finds; a warm start that cannot be used falls back to the homotopy and says why.

use std::path::{Path, PathBuf};

use suslov::config::{self, Loaded};
use suslov::lie::{self, LieSolution, WarmStart};
use suslov::model::se2::Se2;

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

/// `examples/se2_sleigh.toml` with `beta` replaced, written to a scratch file and loaded.
fn sleigh(beta: &str) -> suslov::config::generic::LoadedModelProblem<Se2> {
    let text = std::fs::read_to_string(example("se2_sleigh.toml"))
        .unwrap()
        .replace("beta = 0.1", &format!("beta = {beta}"));
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("warm_start");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("sleigh_{beta}.toml"));
    std::fs::write(&path, text).unwrap();
    match config::load_any(&path).unwrap().0 {
        Loaded::Other(file) => file.build::<Se2>().unwrap(),
        Loaded::So3(_) => panic!("the sleigh is an se2 file"),
    }
}

fn warm_from(sol: &LieSolution<Se2>) -> WarmStart {
    let t0 = sol.problem.t0;
    WarmStart {
        times: sol.bvp.x.iter().map(|s| t0 + s * sol.t_span).collect(),
        states: sol.bvp.y.clone(),
    }
}

fn newton(sol: &LieSolution<Se2>) -> usize {
    sol.stages.iter().map(|s| s.newton_iterations).sum()
}

#[test]
fn a_nearby_solution_replaces_the_homotopy_and_gives_the_same_answer() {
    let first = sleigh("0.1");
    let previous = lie::solve(&first.problem, &first.options, &mut |_| {}).unwrap();
    let next = sleigh("0.12");
    let cold = lie::solve(&next.problem, &next.options, &mut |_| {}).unwrap();
    let warm = lie::solve_from(
        &next.problem,
        &next.options,
        &warm_from(&previous),
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(warm.routes.len(), 1, "{:?}", warm.routes);
    assert_eq!(warm.routes[0].route, lie::solve::WARM_START_ROUTE);
    assert_eq!(warm.routes[0].stopped, None);
    assert_eq!(warm.stages[0].name, "warm start");
    assert!(lie::verify_solution(&warm).verification.passed());
    // The same solution as the homotopy's, to the solver's tolerance (1e-8).
    let (dw, dc) = (
        lie::verify_solution(&warm).diagnostics,
        lie::verify_solution(&cold).diagnostics,
    );
    assert!(
        ((dw.cost - dc.cost) / dc.cost).abs() < 1e-7,
        "{} vs {}",
        dw.cost,
        dc.cost
    );
    let (yw, yc) = (warm.state(2.0), cold.state(2.0));
    let diff = yw
        .iter()
        .zip(&yc)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-6, "states at t = 2 differ by {diff:e}");
    // And cheaper: no homotopy.
    eprintln!(
        "Newton iterations: warm {}, cold {}",
        newton(&warm),
        newton(&cold)
    );
    assert!(
        newton(&warm) < newton(&cold),
        "warm {} vs cold {} Newton iterations",
        newton(&warm),
        newton(&cold)
    );
}

#[test]
fn an_unusable_warm_start_falls_back_to_the_homotopy_and_says_why() {
    let problem = sleigh("0.1");
    let previous = lie::solve(&problem.problem, &problem.options, &mut |_| {}).unwrap();
    // A warm start that begins at another time than the problem.
    let mut shifted = warm_from(&previous);
    for t in &mut shifted.times {
        *t += 1.0;
    }
    let sol = lie::solve_from(&problem.problem, &problem.options, &shifted, &mut |_| {}).unwrap();
    assert_eq!(sol.routes[0].route, lie::solve::WARM_START_ROUTE);
    let why = sol.routes[0].stopped.as_deref().unwrap();
    assert!(why.contains("starts at t = 1"), "{why}");
    assert_eq!(sol.routes[1].route, "default");
    assert_eq!(sol.routes[1].stopped, None);
    assert!(lie::verify_solution(&sol).verification.passed());
    // Garbage states (NaN): refused, not solved from.
    let mut garbage = warm_from(&previous);
    garbage.states[3] = f64::NAN;
    let sol = lie::solve_from(&problem.problem, &problem.options, &garbage, &mut |_| {}).unwrap();
    assert!(sol.routes[0]
        .stopped
        .as_deref()
        .unwrap()
        .contains("finite numbers"));
    // A length mismatch.
    let short = WarmStart {
        times: vec![0.0, 4.0],
        states: vec![0.0; 3],
    };
    let sol = lie::solve_from(&problem.problem, &problem.options, &short, &mut |_| {}).unwrap();
    assert!(sol.routes[0]
        .stopped
        .as_deref()
        .unwrap()
        .contains("2 times and 3 state values"));
}
