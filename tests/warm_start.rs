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

/// `solver.start_from`: a problem file starts from a previous `suslov solve`'s output
/// directory (its `trajectory.csv`, read by column names), skipping the homotopy.
#[test]
fn a_problem_file_starts_from_a_previous_result() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("warm_start_file");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(example("segment.toml")).unwrap();
    // The example as it is, then gamma 1 -> 1.2 starting from its result.
    let first = dir.join("first.toml");
    std::fs::write(&first, &text).unwrap();
    let out_first = dir.join("out_first");
    let s = suslov::app::run_solve(&first, &out_first, &mut |_| {}).unwrap();
    assert_eq!(s.cases[0].status, "converged");
    let next_text =
        text.replace("gamma = 1.0", "gamma = 1.2") + "\n[solver]\nstart_from = \"out_first\"\n";
    let next = dir.join("next.toml");
    std::fs::write(&next, &next_text).unwrap();
    let s = suslov::app::run_solve(&next, &dir.join("out_next"), &mut |_| {}).unwrap();
    let case = &s.cases[0];
    assert_eq!(case.status, "converged");
    let routes = case.extra["routes"].as_array().unwrap();
    assert_eq!(routes.len(), 1, "{routes:?}");
    assert_eq!(routes[0]["route"], lie::solve::WARM_START_ROUTE);
    assert!(routes[0]["stopped"].is_null());
    // The same answer as the homotopy's.
    let cold = dir.join("cold.toml");
    std::fs::write(&cold, text.replace("gamma = 1.0", "gamma = 1.2")).unwrap();
    let c = suslov::app::run_solve(&cold, &dir.join("out_cold"), &mut |_| {}).unwrap();
    let (bw, bc) = (case.terminal_time, c.cases[0].terminal_time);
    assert!((bw - bc).abs() < 1e-7 * bc, "b: warm {bw}, cold {bc}");
    assert!((case.cost - c.cases[0].cost).abs() < 1e-7 * c.cases[0].cost);
}

#[test]
fn a_bad_start_from_is_an_error_that_names_the_key() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("warm_start_bad");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(example("segment.toml")).unwrap();
    let error = |csv: Option<&str>| {
        if let Some(csv) = csv {
            std::fs::write(dir.join("start.csv"), csv).unwrap();
        }
        let path = dir.join("p.toml");
        std::fs::write(
            &path,
            text.clone() + "\n[solver]\nstart_from = \"start.csv\"\n",
        )
        .unwrap();
        config::load(&path).unwrap_err().to_string()
    };
    let missing = error(None);
    assert!(
        missing.contains("solver.start_from") && missing.contains("cannot read"),
        "{missing}"
    );
    let no_xi = error(Some("t,omega1,omega2,omega3\n0,3,0,0\n1,3,0,0\n"));
    assert!(no_xi.contains("no column `xi1`"), "{no_xi}");
    // One message, one line of words (no runs of spaces from wrapped source lines).
    for m in [&missing, &no_xi] {
        assert!(!m.contains("  "), "{m}");
    }
    let late = error(Some(
        "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3\n1,3,0,0,0,1,0,0,0,0\n2,3,0,0,0,1,0,0,0,0\n",
    ));
    assert!(
        late.contains("starts at t = 1") && !late.contains("  "),
        "{late}"
    );
    let back = error(Some(
        "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3\n0,3,0,0,0,1,0,0,0,0\n0,3,0,0,0,1,0,0,0,0\n",
    ));
    assert!(back.contains("increase strictly"), "{back}");
    let nan = error(Some(
        "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3\n0,3,0,0,0,1,0,0,0,0\n1,nan,0,0,0,1,0,0,0,0\n",
    ));
    assert!(nan.contains("not a finite number"), "{nan}");
    let some_kappa = error(Some(
        "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3,kappa1\n0,3,0,0,0,1,0,0,0,0,0\n1,3,0,0,0,1,0,0,0,0,0\n",
    ));
    assert!(some_kappa.contains("give all or none"), "{some_kappa}");
}
