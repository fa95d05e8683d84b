//! The generic problem layer (`suslov::lie`): it reproduces the so(3) layer on the paper's
//! problem, and it solves the se(2) and so(4) examples from their problem files, verified —
//! and the files it writes pass independent checks (constraint, energy, end points, and for
//! se(2) the reconstructed planar motion against an independent integration of the pose).

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use suslov::lie::{self, Problem};
use suslov::model::so3::So3;
use suslov::model::Model;
use suslov::so3::paper;
use suslov::so3::problem::TerminalTime;
use suslov::so3::solve::SolveOptions;

mod paper_lie;
use paper_lie::So3Path;

/// The paper's problem (section 5.3) through the generic layer, parameters set by name.
fn paper_generic(eta: f64) -> Problem<So3> {
    paper_lie::paper_problem::<So3>(eta)
}

#[test]
fn the_generic_layer_reproduces_the_papers_b_and_cost_on_so3() {
    // Recorded by the so(3) layer (tests/suslov_verify.rs), eta = 1: b and J.
    let (b_ref, j_ref) = (11.359616203476826, 15.394760771339984);
    let problem = paper_generic(1.0);
    assert!(matches!(problem.terminal, TerminalTime::Free { .. }));
    let sol = lie::solve(&problem, &SolveOptions::default(), &mut |_| {}).expect("solves");
    let verified = lie::verify_solution(&sol);
    let (d, v) = (verified.diagnostics, verified.verification);
    assert!(v.passed(), "{:?}", v.verdict());
    let b = sol.terminal_time();
    assert!(
        (b - b_ref).abs() <= 1e-9 * b_ref,
        "b = {b}, so(3) layer {b_ref}"
    );
    assert!(
        (d.cost - j_ref).abs() <= 1e-9 * j_ref,
        "J = {}, so(3) layer {j_ref}",
        d.cost
    );
    // The same stages as the so(3) layer: start, beta, eta, free-time start, delta, polish.
    let names: Vec<&str> = sol.stages.iter().map(|s| s.name).collect();
    assert_eq!(
        names,
        ["start", "beta", "eta", "free-time start", "delta", "polish"]
    );
}

/// Columns of a CSV written by the tool, by header name.
fn read_csv(path: &Path) -> HashMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    for line in lines {
        for (c, v) in line.split(',').enumerate() {
            cols[c].push(v.parse().unwrap());
        }
    }
    header.into_iter().zip(cols).collect()
}

/// A fresh directory under the system's temporary directory (removed by the caller).
fn scratch(tag: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("suslov-lie-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Solve `examples/<file>` with `suslov solve` into a scratch directory named after `tag`
/// (tests run in parallel: each its own directory).
fn solve_example(file: &str, tag: &str) -> (std::path::PathBuf, serde_json::Value) {
    let dir = scratch(&format!("{tag}-{file}"));
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(file);
    let summary = suslov::app::run_solve(&path, &dir, &mut |_| {}).expect("runs");
    assert_eq!(
        summary.cases[0].status, "converged",
        "{file}: {}",
        summary.cases[0].status
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    (dir, json)
}

/// Independent checks of `trajectory.csv` of model `M`: ⟨Ω, ξ⟩ = 0, the kinetic energy
/// (from the model's inertia matrix at the file's parameters) constant, the end points.
fn check_trajectory<M: Model>(dir: &Path, json: &serde_json::Value) {
    let cols = read_csv(&dir.join("trajectory.csv"));
    let n = M::DIM;
    let col = |k: usize| &cols[M::STATE_NAMES[k]];
    let rows = cols["t"].len();
    let params = &json["cases"][0]["extra"]["parameters"];
    let mut p = vec![0.0; M::N_PARAM];
    for meta in M::INERTIA_PARAMS.iter().chain(M::WEIGHTS) {
        p[meta.index] = params[meta.name].as_f64().unwrap();
    }
    let mut inertia = vec![0.0; n * n];
    M::inertia_matrix(&p, &mut inertia);
    let energy = |r: usize| -> f64 {
        (0..n)
            .map(|i| col(i)[r] * (0..n).map(|j| inertia[i * n + j] * col(j)[r]).sum::<f64>())
            .sum()
    };
    let e0 = energy(0);
    let omega_a: Vec<f64> =
        serde_json::from_value(json["cases"][0]["extra"]["omega_a"].clone()).unwrap();
    let omega_b: Vec<f64> =
        serde_json::from_value(json["cases"][0]["extra"]["omega_b"].clone()).unwrap();
    for r in 0..rows {
        let c: f64 = (0..n).map(|i| col(i)[r] * col(n + i)[r]).sum();
        assert!(c.abs() < 1e-6, "<Omega, xi> = {c} at row {r}");
        assert!((energy(r) / e0 - 1.0).abs() < 1e-6, "energy at row {r}");
    }
    for i in 0..n {
        assert!((col(i)[0] - omega_a[i]).abs() < 1e-9);
        assert!((col(i)[rows - 1] - omega_b[i]).abs() < 1e-6);
    }
}

#[test]
fn the_steered_sleigh_solves_from_its_file_and_its_planar_path_is_right() {
    use suslov::model::se2::Se2;
    let (dir, json) = solve_example("se2_sleigh.toml", "sleigh");
    assert_eq!(json["cases"][0]["extra"]["model"], "se2");
    check_trajectory::<Se2>(&dir, &json);
    // The pose (x, y, θ) of motion.csv against an independent integration of the planar
    // kinematics ẋ = v1 cos θ − v2 sin θ, ẏ = v1 sin θ + v2 cos θ, θ̇ = ω (trapezoidal rule on
    // the trajectory's 2001 points: error O(h²) ≈ 1e-6 here).
    let traj = read_csv(&dir.join("trajectory.csv"));
    let motion = read_csv(&dir.join("motion.csv"));
    let t = &traj["t"];
    let (w, v1, v2) = (&traj["omega1"], &traj["omega2"], &traj["omega3"]);
    let (mut x, mut y, mut th) = (0.0, 0.0, 0.0);
    let rate = |k: usize, th: f64| {
        (
            v1[k] * th.cos() - v2[k] * th.sin(),
            v1[k] * th.sin() + v2[k] * th.cos(),
        )
    };
    let mut worst: f64 = 0.0;
    for k in 1..t.len() {
        let h = t[k] - t[k - 1];
        let th_new = th + 0.5 * h * (w[k - 1] + w[k]);
        let (a0, b0) = rate(k - 1, th);
        let (a1, b1) = rate(k, th_new);
        x += 0.5 * h * (a0 + a1);
        y += 0.5 * h * (b0 + b1);
        th = th_new;
        for (mine, theirs) in [
            (x, motion["x"][k]),
            (y, motion["y"][k]),
            (th, motion["theta"][k]),
        ] {
            worst = worst.max((mine - theirs).abs());
        }
    }
    assert!(worst < 1e-4, "pose differs by {worst}");
    assert!(
        json["cases"][0]["extra"]["motion_error_estimate"]
            .as_f64()
            .unwrap()
            < 1e-8
    );
    // The path figure: a PNG of the requested size.
    let png = std::fs::read(dir.join("path.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), 1200);
    assert_eq!(u32::from_be_bytes(png[20..24].try_into().unwrap()), 900);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_generalised_rigid_body_on_so4_solves_from_its_file() {
    use suslov::model::so4::So4;
    let (dir, json) = solve_example("so4_body.toml", "so4");
    assert_eq!(json["cases"][0]["extra"]["model"], "so4");
    check_trajectory::<So4>(&dir, &json);
    // The attitude in motion.csv stays in SO(4): gᵀg = 1.
    let motion = read_csv(&dir.join("motion.csv"));
    // Not planar rigid motions: no (x, y, theta), no path figure.
    assert!(!motion.contains_key("x") && !dir.join("path.png").exists());
    let rows = motion["t"].len();
    for r in [0, rows / 2, rows - 1] {
        let g = |i: usize, j: usize| motion[&format!("g{}{}", i + 1, j + 1)][r];
        for i in 0..4 {
            for j in 0..4 {
                let dot: f64 = (0..4).map(|k| g(k, i) * g(k, j)).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < 1e-10, "g^T g [{i}][{j}] = {dot}");
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The error `suslov solve` gives for the se2 example with `edit` applied to its text.
fn error_for(tag: &str, edit: impl Fn(&str) -> String) -> String {
    let src = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/se2_sleigh.toml"),
    )
    .unwrap();
    let dir = scratch(&format!("bad-{tag}"));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("problem_in.toml");
    std::fs::write(&file, edit(&src)).unwrap();
    let out = dir.join("out");
    let err = suslov::app::run_solve(&file, &out, &mut |_| {})
        .expect_err("a bad file is an error")
        .to_string();
    // Nothing was written for an invalid file.
    assert!(!out.join("summary.json").exists(), "{tag}");
    let _ = std::fs::remove_dir_all(&dir);
    err
}

#[test]
fn bad_model_files_get_messages_that_name_the_field_and_the_fix() {
    type Edit = Box<dyn Fn(&str) -> String>;
    // The message lists every shipped model.
    let all_models = suslov::model::MODEL_NAMES.join(", ");
    let unknown_model_words = ["model", all_models.as_str()];
    let cases: Vec<(&str, Edit, &[&str])> = vec![
        (
            "length",
            Box::new(|s: &str| s.replace("omega_a = [1.0, 0.5, 0.0]", "omega_a = [1.0, 0.5]")),
            &["boundary.omega_a", "2 entries, expected 3", "e0, e1, e2"],
        ),
        (
            "unknown-body-key",
            Box::new(|s: &str| s.replace("Ic = 0.5", "Ic = 0.5\ninertia = [1.0, 2.0, 3.0]")),
            &["body.inertia", "unknown key", "m, Ic, c1, c2"],
        ),
        (
            "off-level-set",
            Box::new(|s: &str| s.replace("omega_b = [-0.3872983346207417", "omega_b = [-0.5")),
            &["boundary.omega_b", "energy level set", "projection"],
        ),
        (
            "unknown-model",
            Box::new(|s: &str| s.replace("model = \"se2\"", "model = \"se3\"")),
            &unknown_model_words,
        ),
        (
            "missing-weight",
            Box::new(|s: &str| s.replace("beta = 0.1\n", "")),
            &["cost.beta", "missing", "control effort"],
        ),
        (
            "negative-mass",
            Box::new(|s: &str| s.replace("m = 1.0", "m = -1.0")),
            &["body.m", "mass"],
        ),
        (
            "nan",
            Box::new(|s: &str| s.replace("c1 = 0.3", "c1 = nan")),
            &["body.c1", "not a finite number"],
        ),
        (
            "singular-inertia",
            // I_c > 0 and m > 0 always give an SPD inertia; a huge offset overflows it.
            Box::new(|s: &str| s.replace("c1 = 0.3", "c1 = 1e200")),
            &["body"],
        ),
    ];
    for (tag, edit, words) in cases {
        let msg = error_for(tag, edit);
        for w in words {
            assert!(msg.contains(w), "{tag}: {w:?} not in {msg:?}");
        }
    }
}

/// The certificate of the paper's η = 1 case as the so(3) layer's own certificate recorded it
/// (docs/certificate.md: 377 intervals, KKT inertia (+10189, −6792, 0), μ_min in
/// [0.0493, 0.0493]); the generic certificate was checked equal to it (margin to 1e-6
/// relative, the same inertia) before the so(3) copy was removed.
#[test]
fn the_paper_certificate_is_the_recorded_one() {
    use suslov::ocp::{NewtonOptions, SecondOrderOptions, Verdict};
    let (newton, opts) = (NewtonOptions::default(), SecondOrderOptions::default());
    let sol = lie::solve(&paper_generic(1.0), &SolveOptions::default(), &mut |_| {}).unwrap();
    let cert = lie::certify::certify(&sol, &newton, &opts).unwrap();
    assert_eq!(cert.verdict(), Verdict::Certified);
    assert_eq!(cert.intervals, 377);
    let so = &cert.certificate.second_order;
    assert_eq!(
        (so.inertia.positive, so.inertia.negative, so.inertia.zero),
        (10189, 6792, 0)
    );
    let (lo, hi) = so.margin.unwrap();
    assert!(
        (0.04925..=0.04935).contains(&lo) && (0.04925..=0.04935).contains(&hi),
        "margin [{lo}, {hi}]"
    );
    assert!(cert.costate_mismatch < 1e-5, "{}", cert.costate_mismatch);
}

/// Solve and certify the example `file` of model `M` with the generic layer.
fn certify_example<M: Model>(file: &str) -> suslov::lie::certify::SuslovCertificate {
    use suslov::config::{load_any, Loaded};
    use suslov::ocp::{NewtonOptions, SecondOrderOptions};
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(file);
    let Loaded::Other(f) = load_any(&path).unwrap().0 else {
        panic!("{file} is not a file of another model")
    };
    let loaded = f.build::<M>().unwrap();
    let sol = lie::solve(&loaded.problem, &loaded.options, &mut |_| {}).unwrap();
    let cert = lie::certify::certify(
        &sol,
        &NewtonOptions::default(),
        &SecondOrderOptions::default(),
    )
    .unwrap();
    let so = &cert.certificate.second_order;
    eprintln!(
        "{file}: {:?}, inertia {:?}, margin {:?}, costates vs kappa {:.1e}, displacement {:.1e}",
        so.verdict, so.inertia, so.margin, cert.costate_mismatch, cert.relative_displacement
    );
    // Whatever the verdict: an exact KKT point of the discretized problem near the solution,
    // whose multipliers are the solution's costates.
    let c = &cert.certificate;
    assert!(c.kkt.relative_stationarity() < 1e-9 && c.kkt.feasibility < 1e-9);
    assert!(cert.relative_displacement < 1e-3);
    assert!(cert.costate_mismatch < 1e-2);
    cert
}

#[test]
fn the_sleigh_and_the_so4_body_are_certified_local_minima() {
    use suslov::ocp::Verdict;
    let se2 = certify_example::<suslov::model::se2::Se2>("se2_sleigh.toml");
    assert_eq!(se2.verdict(), Verdict::Certified);
    let so4 = certify_example::<suslov::model::so4::So4>("so4_body.toml");
    assert_eq!(so4.verdict(), Verdict::Certified);
}

#[test]
fn the_accessibility_rank_along_each_example_is_dim_m() {
    for (file, dim_m) in [("se2_sleigh.toml", 4), ("so4_body.toml", 10)] {
        let (dir, json) = solve_example(file, "rank");
        let acc = &json["cases"][0]["extra"]["accessibility"];
        assert_eq!(acc["dim_m"], dim_m, "{file}");
        assert_eq!(acc["min_rank"], dim_m, "{file}: {acc}");
        assert_eq!(acc["max_rank"], dim_m, "{file}: {acc}");
        assert!(
            acc["min_sigma_dim_m"].as_f64().unwrap() > 1e-6,
            "{file}: {acc}"
        );
        assert!(
            acc["max_sigma_next"].as_f64().unwrap() < 1e-9,
            "{file}: {acc}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn so3_full_with_principal_axes_is_the_papers_problem_and_its_example_solves() {
    use suslov::model::so3_full::So3Full;
    // The paper's problem through the full-inertia model with zero products of inertia:
    // the same b and J as the so(3) layer (the derivation differs: I^-1 enters as derived
    // constants instead of 1/I_k).
    let p = paper::problem(1.0);
    let by_name: HashMap<&str, f64> = HashMap::from([
        ("I11", 1.0),
        ("I22", 2.0),
        ("I33", 3.0),
        ("I12", 0.0),
        ("I13", 0.0),
        ("I23", 0.0),
        ("alpha", p.weights.alpha),
        ("beta", p.weights.beta),
        ("gamma", p.weights.gamma),
        ("eta", p.weights.eta),
        ("delta", p.weights.delta),
    ]);
    assert_eq!(p.inertia.diag().as_slice(), &[1.0, 2.0, 3.0]);
    let user: Vec<f64> = So3Full::PARAM_NAMES[..So3Full::N_USER_PARAM]
        .iter()
        .map(|n| by_name[n])
        .collect();
    let problem = Problem::<So3Full>::new(
        &user,
        p.t0,
        p.omega_a.as_slice().to_vec(),
        p.omega_b.as_slice().to_vec(),
        p.terminal,
        Arc::new(So3Path(p.desired.clone())),
    )
    .unwrap();
    let sol = lie::solve(&problem, &SolveOptions::default(), &mut |_| {}).unwrap();
    let verified = lie::verify_solution(&sol);
    let (d, v) = (verified.diagnostics, verified.verification);
    assert!(v.passed(), "{:?}", v.verdict());
    let (b_ref, j_ref) = (11.359616203476826, 15.394760771339984);
    assert!((sol.terminal_time() - b_ref).abs() <= 1e-9 * b_ref);
    assert!((d.cost - j_ref).abs() <= 1e-9 * j_ref);
    // A body with products of inertia, from its file.
    let (dir, json) = solve_example("so3_full_body.toml", "full");
    assert_eq!(json["cases"][0]["extra"]["model"], "so3_full");
    check_trajectory::<So3Full>(&dir, &json);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn controllability_along_a_model_file_reports_rank_dim_m() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/se2_sleigh.toml");
    let r = suslov::app::run_rank_along_any(Some(&path), 51, 1e-9, &mut |_| {}).unwrap();
    assert!(r.all_accessible, "{}", r.text);
    assert!(r.text.contains("model se2"), "{}", r.text);
    assert!(
        r.text.contains("rank of V = 4 at all 51 times"),
        "{}",
        r.text
    );
    assert!(r.text.contains("dim M = 4"), "{}", r.text);
    // Bad arguments are refused before any work.
    assert!(suslov::app::run_rank_along_any(Some(&path), 1, 1e-9, &mut |_| {}).is_err());
    assert!(suslov::app::run_rank_along_any(Some(&path), 51, 0.5, &mut |_| {}).is_err());
}

#[test]
fn a_sampled_desired_path_of_another_model_loads_projected_and_checked() {
    use suslov::config::{load_any, Loaded};
    use suslov::model::se2::Se2;
    let dir = scratch("samples");
    std::fs::create_dir_all(&dir).unwrap();
    let src = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/se2_sleigh.toml"),
    )
    .unwrap();
    let text = src.replace("gamma = 0.0", "gamma = 1.0").replace(
        "kind = \"segment\"",
        "kind = \"samples\"\nfile = \"od.csv\"",
    );
    std::fs::write(dir.join("p.toml"), &text).unwrap();
    // Samples along the straight line from omega_a to omega_b (off the level set in between:
    // the path is projected onto it), with a header and a comment.
    let (a, b) = (
        [1.0, 0.5, 0.0],
        [-0.3872983346207417, 0.7745966692414834, 0.232379000772445],
    );
    let mut csv = String::from("# t, omega, v1, v2\nt,w,v1,v2\n");
    for k in 0..=8 {
        let s = k as f64 / 8.0;
        let v: Vec<f64> = (0..3).map(|i| a[i] + s * (b[i] - a[i])).collect();
        csv += &format!("{},{},{},{}\n", 4.0 * s, v[0], v[1], v[2]);
    }
    std::fs::write(dir.join("od.csv"), &csv).unwrap();
    let Loaded::Other(file) = load_any(&dir.join("p.toml")).unwrap().0 else {
        panic!("an se2 file")
    };
    let loaded = file.build::<Se2>().unwrap();
    let problem = &loaded.problem;
    let set = problem.level_set();
    let mut jet = vec![0.0; 12];
    for t in [0.0, 0.7, 2.0, 3.3, 4.0] {
        problem.desired.jet_into(t, &mut jet);
        assert!(set.relative_mismatch(&jet[..3]).abs() < 1e-14, "t = {t}");
    }
    problem.desired.jet_into(0.0, &mut jet);
    for i in 0..3 {
        assert!((jet[i] - a[i]).abs() < 1e-12);
    }
    // A row with the wrong number of columns names the file, the line and the basis.
    std::fs::write(dir.join("od.csv"), "0,1,0.5\n1,1,0.5\n").unwrap();
    let Loaded::Other(file) = load_any(&dir.join("p.toml")).unwrap().0 else {
        panic!("an se2 file")
    };
    let err = file.build::<Se2>().unwrap_err().to_string();
    for w in ["desired.file", "line 1", "3 columns", "e0, e1, e2"] {
        assert!(err.contains(w), "{w:?} not in {err:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every so(3) example file, solved through the so(3) layer's entry (`suslov::solve`: its
/// validation, `SuslovProblem::to_generic`, the desired path shared through `AsLiePath`, the
/// so(3) view of the result) and by the generic layer directly: the same verdict, and b and J
/// to 1e-9 relative.
#[test]
fn every_so3_example_solves_the_same_in_both_layers() {
    use suslov::config::{load_any, Loaded};
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut compared = 0;
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    for path in files {
        let Loaded::So3(loaded) = load_any(&path).unwrap().0 else {
            continue;
        };
        let old = suslov::so3::solve::solve(&loaded.problem, &loaded.options, &mut |_| {});
        let generic = loaded.problem.to_generic().expect("valid in both layers");
        let new = lie::solve(&generic, &loaded.options, &mut |_| {});
        let (old, new) = match (old, new) {
            (Ok(a), Ok(b)) => (a, b),
            (a, b) => panic!(
                "{}: the layers end differently: {:?} vs {:?}",
                path.display(),
                a.err().map(|e| e.to_string()),
                b.err().map(|e| e.to_string())
            ),
        };
        let v_old = lie::verify_solution(&old.generic);
        let v_new = lie::verify_solution(&new);
        assert_eq!(
            v_old.verification.passed(),
            v_new.verification.passed(),
            "{}",
            path.display()
        );
        let (b0, b1) = (old.terminal_time(), new.terminal_time());
        let j0 = v_old.diagnostics.cost;
        let j1 = v_new.diagnostics.cost;
        eprintln!("{}: b {b0} vs {b1}, J {j0} vs {j1}", path.display());
        assert!((b0 - b1).abs() <= 1e-9 * b0.abs(), "{}: b", path.display());
        assert!((j0 - j1).abs() <= 1e-9 * j0.abs(), "{}: J", path.display());
        compared += 1;
    }
    assert!(compared >= 7, "{compared} so(3) examples");
}

/// The solver keeps its verification of the solution it returns, and `verify_solution` reads
/// it back only while the solution is what was verified: the kept result equals a fresh
/// verification (forced by putting the same path behind another `Arc`), and any change of what
/// the checks read (a node value, the tolerance, the desired path) is verified afresh.
#[test]
fn a_kept_verification_is_used_only_for_the_solution_it_judged() {
    let sol =
        lie::solve(&paper_generic(0.01), &SolveOptions::default(), &mut |_| {}).expect("solves");
    let kept = format!("{:?}", lie::verify_solution(&sol));
    // The same numbers behind another Arc: verified afresh, same result.
    let mut fresh = sol.clone();
    fresh.problem.desired = Arc::new(lie::path::Memo::new(sol.problem.desired.clone()));
    assert_eq!(format!("{:?}", lie::verify_solution(&fresh)), kept);
    // A changed node value: a different verification (the residual and re-integration move).
    let mut moved = sol.clone();
    let i = moved.bvp.y.len() / 2;
    moved.bvp.y[i] += 1e-3;
    let changed = lie::verify_solution(&moved);
    assert_ne!(format!("{changed:?}"), kept);
    assert!(
        !changed.verification.passed(),
        "{:?}",
        changed.verification.verdict()
    );
    // Another tolerance: judged against it. Set back: the kept result again.
    let mut looser = sol.clone();
    looser.tolerance = 1e-4;
    let v = lie::verify_solution(&looser);
    assert_eq!(v.verification.tolerance, 1e-4);
    looser.tolerance = sol.tolerance;
    assert_eq!(format!("{:?}", lie::verify_solution(&looser)), kept);
}
