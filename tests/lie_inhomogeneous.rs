//! The inhomogeneous Suslov problem (model `so3_inhomogeneous`, `⟨Ω, ξ⟩ = c`): the start
//! constraint `φ(a) = 0` with its multiplier `μ` (src/lie/problem.rs), the continuation in
//! `c` and in the end state (src/lie/solve.rs), the energy balance, the certificate and the
//! accessibility rank `2n − 1`, and checks of what `suslov solve` writes that do not use the
//! generated code.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use suslov::bvp::{self, BvpProblem, Guess};
use suslov::config::{load_any, Loaded};
use suslov::lie::{self, LieBvp, Problem};
use suslov::model::so3::So3;
use suslov::model::so3_inhomogeneous::So3Inhomogeneous;
use suslov::model::Model;
use suslov::so3::solve::SolveOptions;

mod paper_lie;
use paper_lie::paper_problem;

type Inh = So3Inhomogeneous;

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/so3_inhomogeneous.toml")
}

fn load_example() -> suslov::config::generic::LoadedModelProblem<Inh> {
    let Loaded::Other(f) = load_any(&example()).unwrap().0 else {
        panic!("not a file of another model")
    };
    f.build::<Inh>().unwrap()
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("suslov-inh-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn read_csv(path: &Path) -> HashMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let mut cols = vec![Vec::new(); header.len()];
    for line in lines {
        for (c, v) in line.split(',').enumerate() {
            cols[c].push(v.parse().unwrap());
        }
    }
    header.into_iter().zip(cols).collect()
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `suslov solve` on the example, then checks of `trajectory.csv` written without the
/// generated code: `⟨Ω, ξ⟩ = c` at every row, the end points, the kinetic energy doubles
/// (no control reaches `Ω_b` when `c = 0`), and the motion obeys Suslov's equation with a
/// force along ξ: `𝕀Ω̇ − 𝕀Ω × Ω ∥ ξ` (`Ω̇` by central differences of the written `Ω`).
#[test]
fn the_example_solves_verified_and_its_trajectory_keeps_omega_xi_equal_to_c() {
    let dir = scratch("solve");
    let summary = suslov::app::run_solve(&example(), &dir, &mut |_| {}).expect("runs");
    assert_eq!(summary.cases[0].status, "converged");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let extra = &json["cases"][0]["extra"];
    assert_eq!(extra["model"], "so3_inhomogeneous");
    assert_eq!(extra["parameters"]["c"], 0.25);
    assert!(extra["energy"].as_str().unwrap().starts_with("balanced"));
    assert!(extra["start_multiplier"].as_f64().unwrap().is_finite());
    // The accessibility rank along the solution: 2n - 1 = 5 (the energy is no invariant).
    // The stage table names what each stage continues: the constraint level from the
    // level of the paper's conditions (0.2032) to c.
    let stages = json["cases"][0]["stages"].as_array().unwrap();
    let level = stages.iter().find(|s| s["name"] == "constraint").unwrap();
    assert_eq!(level["parameter"], "<Omega, xi>");
    assert!(
        (level["from"].as_f64().unwrap() - 0.2032).abs() < 1e-4,
        "{level}"
    );
    assert_eq!(level["to"], 0.25);
    let beta = stages.iter().find(|s| s["name"] == "beta").unwrap();
    assert_eq!(beta["parameter"], "beta");
    let acc = &extra["accessibility"];
    assert_eq!(acc["dim_m"], 5, "{acc}");
    assert_eq!(acc["min_rank"], 5, "{acc}");
    assert_eq!(acc["max_rank"], 5, "{acc}");

    let cols = read_csv(&dir.join("trajectory.csv"));
    let col = |name: &str| &cols[name];
    let rows = cols["t"].len();
    let inertia = [1.0, 2.0, 3.0];
    let (c, omega_a, omega_b) = (0.25, [2.0, 0.5, 0.0], [0.5, 1.5, 1.2]);
    let om = |r: usize| [col("omega1")[r], col("omega2")[r], col("omega3")[r]];
    let xi = |r: usize| [col("xi1")[r], col("xi2")[r], col("xi3")[r]];
    let energy = |w: [f64; 3]| 0.5 * (0..3).map(|i| inertia[i] * w[i] * w[i]).sum::<f64>();
    for r in 0..rows {
        let dot: f64 = (0..3).map(|i| om(r)[i] * xi(r)[i]).sum();
        assert!((dot - c).abs() < 1e-6, "<Omega, xi> = {dot} at row {r}");
    }
    for i in 0..3 {
        assert!((om(0)[i] - omega_a[i]).abs() < 1e-9);
        assert!((om(rows - 1)[i] - omega_b[i]).abs() < 1e-6);
    }
    let ratio = energy(om(rows - 1)) / energy(om(0));
    assert!((ratio - 9.07 / 4.5).abs() < 1e-6, "T(b)/T(a) = {ratio}");
    let t = &cols["t"];
    let mut worst = 0.0_f64;
    for r in 1..rows - 1 {
        let h = t[r + 1] - t[r - 1];
        let w = om(r);
        let dw: Vec<f64> = (0..3).map(|i| (om(r + 1)[i] - om(r - 1)[i]) / h).collect();
        let m = [inertia[0] * w[0], inertia[1] * w[1], inertia[2] * w[2]];
        let mxw = cross(m, w);
        let force = [
            inertia[0] * dw[0] - mxw[0],
            inertia[1] * dw[1] - mxw[1],
            inertia[2] * dw[2] - mxw[2],
        ];
        let x = xi(r);
        let off = cross(force, x);
        let size = force.iter().map(|v| v * v).sum::<f64>().sqrt()
            * x.iter().map(|v| v * v).sum::<f64>().sqrt();
        worst = worst.max(off.iter().map(|v| v * v).sum::<f64>().sqrt() / size.max(1.0));
    }
    assert!(worst < 1e-3, "the force is not along xi: {worst:e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The paper's conditions `p_ξ(a) = 0` without the start constraint, solved from the
/// constrained solution as they stand (same weights, same `c`, same fixed time): Newton
/// converges to a motion on another constraint level, `⟨Ω, ξ⟩ ≠ c`. This is why the start
/// imposes `φ(a) = 0` with its multiplier for a model with a constraint value.
#[test]
fn the_papers_start_conditions_miss_the_constraint_level_when_c_is_nonzero() {
    struct PaperConditions<'a>(LieBvp<'a, Inh>);
    impl BvpProblem for PaperConditions<'_> {
        fn n(&self) -> usize {
            Inh::N_STATE
        }
        fn k(&self) -> usize {
            0
        }
        fn f(&self, s: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
            self.0.f(s, y, &[0.0], dy);
        }
        fn jac(&self, s: f64, y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
            self.0.jac(s, y, &[0.0], dfdy, &mut [0.0; Inh::N_STATE])
        }
        fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], res: &mut [f64]) {
            let (a, b) = res.split_at_mut(Inh::N_BC_ENDPOINT);
            Inh::bc_endpoint(ya, &self.0.params, self.0.omega_a, a);
            Inh::bc_endpoint(yb, &self.0.params, &self.0.omega_b, b);
        }
        fn bc_jac(
            &self,
            ya: &[f64],
            yb: &[f64],
            _p: &[f64],
            dya: &mut [f64],
            dyb: &mut [f64],
            _dp: &mut [f64],
        ) -> bool {
            let (n, nb) = (Inh::N_STATE, Inh::N_BC_ENDPOINT);
            dya.fill(0.0);
            dyb.fill(0.0);
            Inh::bc_endpoint_jac(ya, &self.0.params, self.0.omega_a, &mut dya[..nb * n]);
            Inh::bc_endpoint_jac(yb, &self.0.params, &self.0.omega_b, &mut dyb[nb * n..]);
            true
        }
    }
    let loaded = load_example();
    let sol = lie::solve(&loaded.problem, &loaded.options, &mut |_| {}).unwrap();
    let mu = sol.start_multiplier().unwrap();
    eprintln!("mu = {mu:e}");
    assert!(mu.abs() > 1e-3, "the multiplier is active: mu = {mu:e}");
    let paper_form = PaperConditions(LieBvp {
        fixed_span: Some(sol.t_span),
        ..LieBvp::new(&sol.problem)
    });
    let guess = Guess::from_solution(&sol.bvp).with_parameters(vec![]);
    let other = bvp::solve(&paper_form, &guess, &bvp::Options::default()).unwrap();
    assert!(other.is_success(), "{:?}", other.status);
    let level = |s: f64| {
        let y = other.eval(s);
        (0..3)
            .map(|i| y[Inh::OMEGA][i] * y[Inh::XI][i])
            .sum::<f64>()
    };
    eprintln!("<Omega, xi> with the paper's conditions: {}", level(0.0));
    assert!(
        (level(0.0) - 0.25).abs() > 1e-3,
        "<Omega, xi> = {}",
        level(0.0)
    );
    assert!((level(1.0) - level(0.0)).abs() < 1e-8, "conserved");
}

/// With `c = 0` the model is the paper's: its problem gives the paper's `b` and `J` (as the so3
/// model does, to 1e-9), with the paper's boundary conditions (no start multiplier: the start
/// constraint is redundant at `c = 0`, module docs of src/lie/problem.rs).
#[test]
fn with_c_zero_the_model_reproduces_the_paper() {
    let opts = SolveOptions::default();
    let plain = lie::solve(&paper_problem::<So3>(1.0), &opts, &mut |_| {}).unwrap();
    let with_mu = lie::solve(&paper_problem::<Inh>(1.0), &opts, &mut |_| {}).unwrap();
    assert!(with_mu.problem.conserves_energy());
    let (b0, b1) = (plain.terminal_time(), with_mu.terminal_time());
    let cost = |d: &suslov::lie::checks::Diagnostics| d.cost;
    let (j0, j1) = (
        cost(&lie::verify::diagnose(&plain)),
        cost(&lie::verify::diagnose(&with_mu)),
    );
    eprintln!(
        "b {b0} vs {b1}, J {j0} vs {j1}, mu {:?}",
        with_mu.start_multiplier()
    );
    assert!((b0 - 11.359616203476826).abs() < 1e-9 * b0);
    assert!((b1 - b0).abs() < 1e-9 * b0, "b {b1} vs {b0}");
    assert!((j1 - j0).abs() < 1e-9 * j0, "J {j1} vs {j0}");
    assert_eq!(with_mu.start_multiplier(), None);
    assert!(lie::verify_solution(&with_mu).verification.passed());
}

/// The example's solution is a certified local minimum of the discretized problem with the
/// start constraint `⟨Ω_a, ξ(a)⟩ = c`, whose multipliers are the solution's costates.
#[test]
fn the_example_is_a_certified_local_minimum() {
    use suslov::ocp::{NewtonOptions, SecondOrderOptions, Verdict};
    let loaded = load_example();
    let sol = lie::solve(&loaded.problem, &loaded.options, &mut |_| {}).unwrap();
    let cert = lie::certify::certify(
        &sol,
        &NewtonOptions::default(),
        &SecondOrderOptions::default(),
    )
    .unwrap();
    let c = &cert.certificate;
    eprintln!(
        "{:?}, inertia {:?}, margin {:?}, costates {:.1e}, displacement {:.1e}",
        c.second_order.verdict,
        c.second_order.inertia,
        c.second_order.margin,
        cert.costate_mismatch,
        cert.relative_displacement
    );
    assert!(c.kkt.relative_stationarity() < 1e-9 && c.kkt.feasibility < 1e-9);
    assert!(cert.relative_displacement < 1e-3);
    assert!(cert.costate_mismatch < 1e-2);
    assert_eq!(cert.verdict(), Verdict::Certified);
}

/// Hostile edits of the example name the field and the fix.
#[test]
fn bad_constraint_sections_get_messages_that_name_the_field() {
    let text = std::fs::read_to_string(example()).unwrap();
    let dir = scratch("hostile");
    std::fs::create_dir_all(&dir).unwrap();
    let error_for = |edited: String| -> String {
        let path = dir.join("p.toml");
        std::fs::write(&path, edited).unwrap();
        match load_any(&path) {
            Err(e) => e.to_string(),
            Ok((Loaded::Other(f), _)) => match f.build::<Inh>() {
                Err(e) => e.to_string(),
                Ok(_) => panic!("accepted"),
            },
            Ok(_) => panic!("loaded as so3"),
        }
    };
    let with_c =
        |v: &str| text.replace("[constraint]\nc = 0.25", &format!("[constraint]\nc = {v}"));
    let cases: Vec<(String, &[&str])> = vec![
        (
            text.replace("[constraint]\nc = 0.25\n", ""),
            &["constraint", "c"],
        ),
        (with_c("\"half\""), &["constraint.c"]),
        (with_c("nan"), &["constraint.c"]),
        (with_c("0.5\nd = 1.0"), &["constraint.d", "c"]),
        (
            text.replace("[constraint]\nc = 0.25", "[constraint]"),
            &["constraint.c"],
        ),
        (
            text.replace("omega_b = [0.5, 1.5, 1.2]", "omega_b = [0.0, 0.0, 0.0]"),
            &["omega_b", "nonzero"],
        ),
        // With c = 0 the energy is conserved again: omega_b off the level set is refused.
        (with_c("0.0"), &["omega_b", "level set"]),
    ];
    for (edited, words) in cases {
        let message = error_for(edited);
        for w in words {
            assert!(message.contains(w), "{message:?} lacks {w:?}");
        }
    }
    // A [constraint] table in the file of a model without a constraint value.
    let so4 = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/so4_body.toml"),
    )
    .unwrap();
    let path = dir.join("so4.toml");
    std::fs::write(&path, format!("{so4}\n[constraint]\nc = 1.0\n")).unwrap();
    let Loaded::Other(f) = load_any(&path).unwrap().0 else {
        panic!()
    };
    let message = f
        .build::<suslov::model::so4::So4>()
        .unwrap_err()
        .to_string();
    assert!(message.contains("constraint"), "{message}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The BVP with the start constraint and a free terminal time (unknowns `[T, μ]`): `jac` and
/// `bc_jac` against central differences of `f` and `bc`, in the state and in `[T, μ]`.
#[test]
fn the_bvp_jacobians_with_the_start_constraint_and_free_time_match_finite_differences() {
    let loaded = load_example();
    let problem = &loaded.problem;
    let bvp = LieBvp {
        fixed_span: None,
        ..LieBvp::new(problem)
    };
    assert!(bvp.start_constraint);
    let (n, k) = (bvp.n(), bvp.k());
    assert_eq!(
        (n, k, bvp.span_index(), bvp.mu_index()),
        (12, 2, Some(0), Some(1))
    );
    let y: Vec<f64> = (0..n)
        .map(|i| 0.3 + 0.1 * i as f64 * (-1.0f64).powi(i as i32))
        .collect();
    let yb: Vec<f64> = (0..n).map(|i| -0.2 + 0.07 * i as f64).collect();
    let p = vec![3.7, -0.4];
    let h = 1e-6;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * (1.0 + b.abs());
    // f and its Jacobians
    let (mut dfdy, mut dfdp) = (vec![0.0; n * n], vec![f64::NAN; n * k]);
    assert!(bvp.jac(0.4, &y, &p, &mut dfdy, &mut dfdp));
    let f_at = |y: &[f64], p: &[f64]| {
        let mut out = vec![0.0; n];
        bvp.f(0.4, y, p, &mut out);
        out
    };
    for j in 0..n {
        let (mut a, mut b) = (y.clone(), y.clone());
        a[j] += h;
        b[j] -= h;
        let (fa, fb) = (f_at(&a, &p), f_at(&b, &p));
        for i in 0..n {
            assert!(
                close(dfdy[i * n + j], (fa[i] - fb[i]) / (2.0 * h)),
                "df{i}/dy{j}"
            );
        }
    }
    for j in 0..k {
        let (mut a, mut b) = (p.clone(), p.clone());
        a[j] += h;
        b[j] -= h;
        let (fa, fb) = (f_at(&y, &a), f_at(&y, &b));
        for i in 0..n {
            assert!(
                close(dfdp[i * k + j], (fa[i] - fb[i]) / (2.0 * h)),
                "df{i}/dp{j}"
            );
        }
    }
    // bc and its Jacobians: n + k rows
    let rows = n + k;
    let (mut dya, mut dyb, mut dp) = (
        vec![0.0; rows * n],
        vec![0.0; rows * n],
        vec![0.0; rows * k],
    );
    assert!(bvp.bc_jac(&y, &yb, &p, &mut dya, &mut dyb, &mut dp));
    let bc_at = |ya: &[f64], yb: &[f64], p: &[f64]| {
        let mut out = vec![0.0; rows];
        bvp.bc(ya, yb, p, &mut out);
        out
    };
    for j in 0..n {
        let (mut a, mut b) = (y.clone(), y.clone());
        a[j] += h;
        b[j] -= h;
        let (ga, gb) = (bc_at(&a, &yb, &p), bc_at(&b, &yb, &p));
        let (mut c, mut d) = (yb.clone(), yb.clone());
        c[j] += h;
        d[j] -= h;
        let (gc, gd) = (bc_at(&y, &c, &p), bc_at(&y, &d, &p));
        for i in 0..rows {
            assert!(
                close(dya[i * n + j], (ga[i] - gb[i]) / (2.0 * h)),
                "dbc{i}/dya{j}"
            );
            assert!(
                close(dyb[i * n + j], (gc[i] - gd[i]) / (2.0 * h)),
                "dbc{i}/dyb{j}"
            );
        }
    }
    for j in 0..k {
        let (mut a, mut b) = (p.clone(), p.clone());
        a[j] += h;
        b[j] -= h;
        let (ga, gb) = (bc_at(&y, &yb, &a), bc_at(&y, &yb, &b));
        for i in 0..rows {
            assert!(
                close(dp[i * k + j], (ga[i] - gb[i]) / (2.0 * h)),
                "dbc{i}/dp{j}"
            );
        }
    }
}

/// The example with a free terminal time (δ = 0.15): the constraint stages run at the guessed
/// time, then the time stage with the unknowns `[T, μ]`; verified.
#[test]
fn the_example_with_a_free_terminal_time_solves_verified() {
    let text = std::fs::read_to_string(example())
        .unwrap()
        .replace(
            "terminal_time = { fixed = 4.0 }",
            "terminal_time = { free = true, guess = 4.0 }",
        )
        .replace("\neta = 0.1\n", "\neta = 0.1\ndelta = 0.15\n");
    let dir = scratch("free");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("free.toml");
    std::fs::write(&path, text).unwrap();
    let Loaded::Other(f) = load_any(&path).unwrap().0 else {
        panic!()
    };
    let loaded = f.build::<Inh>().unwrap();
    let sol = lie::solve(&loaded.problem, &loaded.options, &mut |_| {}).unwrap();
    let names: Vec<&str> = sol.stages.iter().map(|s| s.name).collect();
    eprintln!(
        "b = {}, stages {names:?}, mu = {:?}",
        sol.terminal_time(),
        sol.start_multiplier()
    );
    assert!(names.contains(&"constraint") && names.contains(&"delta"));
    let checked = lie::verify_solution(&sol);
    assert!(checked.verification.passed(), "{:?}", checked.verification);
    assert!(checked.diagnostics.max_abs_constraint < 1e-8);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `c → −c` is a symmetry of the problem: `(ξ, ξ̇, μ) → −(ξ, ξ̇, μ)` with the same `Ω` (λ is odd
/// in ξ, λξ even, the cost even in ξ). The example with `c = −0.25` (which the homotopy reaches
/// by mirroring the motion after stage A, whose level is positive) gives the same cost and
/// `Ω(t)`, and the opposite `ξ(t)` and `μ`.
#[test]
fn the_mirrored_constraint_value_gives_the_mirrored_solution() {
    let loaded = load_example();
    let mut user = loaded.problem.user_params().to_vec();
    let c_index = Inh::CONSTRAINT_PARAMS[0].index;
    user[c_index] = -user[c_index];
    let p = &loaded.problem;
    let mirrored = Problem::<Inh>::new(
        &user,
        p.t0,
        p.omega_a.clone(),
        p.omega_b.clone(),
        p.terminal,
        p.desired.clone(),
    )
    .unwrap();
    let plus = lie::solve(&loaded.problem, &loaded.options, &mut |_| {}).unwrap();
    let minus = lie::solve(&mirrored, &loaded.options, &mut |_| {}).unwrap();
    let names: Vec<&str> = minus.stages.iter().map(|s| s.name).collect();
    assert!(names.contains(&"mirror xi -> -xi"), "{names:?}");
    let (j_plus, j_minus) = (
        lie::verify::diagnose(&plus).cost,
        lie::verify::diagnose(&minus).cost,
    );
    assert!(
        (j_plus - j_minus).abs() < 1e-9 * j_plus,
        "J {j_plus} vs {j_minus}"
    );
    let (mu_plus, mu_minus) = (
        plus.start_multiplier().unwrap(),
        minus.start_multiplier().unwrap(),
    );
    assert!(
        (mu_plus + mu_minus).abs() < 1e-7 * mu_plus.abs(),
        "mu {mu_plus} vs {mu_minus}"
    );
    for k in 0..=40 {
        let t = 4.0 * k as f64 / 40.0;
        let (a, b) = (plus.state(t), minus.state(t));
        for i in Inh::OMEGA {
            assert!((a[i] - b[i]).abs() < 1e-7, "Omega at t = {t}");
        }
        for i in Inh::XI.start..Inh::XIDOT.end {
            assert!((a[i] + b[i]).abs() < 1e-7, "xi, xi' at t = {t}");
        }
    }
    assert!(lie::verify_solution(&minus).verification.passed());
}
