//! A problem whose equations round far above `ε |f|`: corpus problem fast-159 (free b, γ = 0,
//! |Ω| up to 35, β = 0.008, an optimal horizon of 80). Its costates reach 141, and the
//! optimality system's `ξ̈` (about 5e-2 on the normalized horizon) is a difference of terms
//! near 1e9: its evaluation rounds at about 3e-7. At `tol = 1e-8` the discrete equations then
//! cannot be solved below 50 tolerance units on any mesh, and before the BVP solver allowed
//! for the rounding of `f` in its defect check (`suslov::bvp` mesh module docs) every polish
//! stopped at the mesh-pass limit, although the solution at 1e-6 passed every check.

use std::path::Path;

use suslov::lie;

#[path = "corpus/mod.rs"]
mod corpus;

/// fast-159 with default settings, from its generated file alone: converged and verified at
/// `tol = 1e-8`, with discrete defects above the tolerance before the allowance for rounding
/// and within it after, at the extremal the stepped polish reached at 1e-6 (b = 79.639099,
/// J = 49.062192: below the relaxed minimum 56.792 that a collapsing control approaches).
#[test]
fn fast_159_converges_at_the_rounding_floor_of_its_equations() {
    let all = corpus::generate(corpus::DEFAULT_N, corpus::SEED);
    let p = all
        .iter()
        .find(|p| p.id == "fast-159")
        .expect("a corpus id");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rounding_floor");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("fast-159.toml");
    std::fs::write(&path, &p.toml).unwrap();
    let loaded = suslov::config::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let problem = loaded.problem.to_generic().expect("a valid so3 problem");
    let sol = lie::solve(&problem, &loaded.options, &mut |_| {}).expect("solved");
    assert_eq!(sol.tolerance, 1e-8, "the default tolerance");
    let verified = lie::verify_solution(&sol);
    assert!(
        verified.verification.passed(),
        "{:?}",
        verified.verification
    );
    let stats = &sol.bvp.stats;
    assert!(stats.max_raw_defect > 10.0, "{stats:?}");
    assert!(stats.max_defect <= 1.0, "{stats:?}");
    let b = problem.t0 + sol.t_span;
    let cost = verified.diagnostics.cost;
    assert!((b - 79.639099).abs() < 1e-5, "b = {b}");
    assert!((cost - 49.062192).abs() < 1e-5, "J = {cost}");
}
