//! The direct start's two transcriptions (`suslov::lie::direct`) on the paper's η = 1
//! problem with b fixed at the paper's optimum (no time weight): the reduced form (λ
//! eliminated) and the multiplier form (λ a control, `φ = 0` at every point) reach the same
//! minimum, which is the BVP's: each converges, its discrete cost is the fixed-time
//! extremal's to the discretization error of 100 uniform intervals (measured 13.12272 and
//! 13.12272), and the BVP solved from it is verified at the extremal's cost. The independent
//! direct method (`bench/casadi_direct.py`, IPOPT) gives 13.12283753 for the same problem.
//! (Imposing `dφ/dt = 0` at the points instead of `φ = 0`, tried and removed, lets the
//! discrete solution drift off the constraint: its discrete minimum was 11.716.)

use std::path::Path;

use suslov::lie::direct::{direct_start_in, DirectForm, DirectGuess};
use suslov::lie::{self};
use suslov::so3::solve::SolveOptions;

#[test]
fn every_direct_form_reaches_the_fixed_time_papers_minimum() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("examples/paper_eta1.toml"))
        .unwrap()
        .replace(
            "terminal_time = { free = true, guess = 10.0 }",
            "terminal_time = { fixed = 11.359616203476826 }",
        )
        .replace("delta = 0.2\n", "");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("direct_forms");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("paper_eta1_fixed.toml");
    std::fs::write(&path, text).unwrap();
    let loaded = suslov::config::load(&path).unwrap();
    let problem = loaded.problem.to_generic().unwrap();
    let ipopt = 13.12283753;
    for form in [DirectForm::Reduced, DirectForm::Multiplier] {
        let start = direct_start_in(&problem, 100, DirectGuess::Segment, form)
            .unwrap_or_else(|e| panic!("{form:?}: {e}"));
        let options = SolveOptions {
            max_routes: 1,
            ..loaded.options.clone()
        };
        let sol = lie::solve_from(&problem, &options, &start.warm, &mut |_| {})
            .unwrap_or_else(|e| panic!("{form:?}: {e}"));
        let checked = lie::verify_solution(&sol);
        eprintln!(
            "{form:?}: {} iterations, discrete J = {:.10}, min |xi| = {:.4}, BVP J = {:.10}",
            start.report.iterations, start.cost, start.min_xi, checked.diagnostics.cost
        );
        assert!(checked.verification.passed(), "{form:?}");
        assert!(
            ((checked.diagnostics.cost - ipopt) / ipopt).abs() < 1e-7,
            "{form:?}"
        );
        assert!(
            ((start.cost - ipopt) / ipopt).abs() < 2e-5,
            "{form:?}: {}",
            start.cost
        );
        assert!(start.min_xi > 0.8, "{form:?}: {}", start.min_xi);
    }
}
