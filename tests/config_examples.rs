//! The problem files in `examples/` load and validate, the paper's two reproduce
//! `suslov::so3::paper::problem`, and one small example solves end to end through the
//! command line.

use std::path::{Path, PathBuf};

use suslov::config;
use suslov::so3::paper;

fn examples() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_example_loads_and_validates() {
    let files = examples();
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    for expected in [
        "paper_eta1",
        "paper_eta0.01",
        "spiral_other_body",
        "spiral_fixed_time",
        "segment",
        "no_tracking",
        "spiral_samples",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "missing example {expected}"
        );
    }
    for (path, stem) in files.iter().zip(&names) {
        let (loaded, _) = config::load_any(path).unwrap_or_else(|e| panic!("{e}"));
        let name = match loaded {
            config::Loaded::So3(loaded) => {
                loaded.problem.validate().unwrap();
                loaded.name
            }
            config::Loaded::Other(file) => match file.model.as_str() {
                "se2" => file.build::<suslov::model::se2::Se2>().map(|l| l.name),
                "so4" => file.build::<suslov::model::so4::So4>().map(|l| l.name),
                "so3_full" => file
                    .build::<suslov::model::so3_full::So3Full>()
                    .map(|l| l.name),
                "so3_inhomogeneous" => file
                    .build::<suslov::model::so3_inhomogeneous::So3Inhomogeneous>()
                    .map(|l| l.name),
                other => panic!("add model {other} to this test"),
            }
            .unwrap_or_else(|e| panic!("{e}")),
        };
        assert_eq!(&name, stem, "name = file stem in {}", path.display());
    }
    // Every shipped model has an example.
    for model in suslov::model::MODEL_NAMES {
        let has = files.iter().any(|p| match config::load_any(p).unwrap().0 {
            config::Loaded::So3(_) => model == "so3",
            config::Loaded::Other(f) => f.model == model,
        });
        assert!(has, "no example for model {model}");
    }
}

#[test]
fn the_paper_examples_are_the_papers_problems() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    for (file, eta) in [("paper_eta1.toml", 1.0), ("paper_eta0.01.toml", 0.01)] {
        let loaded = config::load(&dir.join(file)).unwrap();
        let (p, q) = (&loaded.problem, paper::problem(eta));
        assert_eq!(p.inertia, q.inertia);
        assert_eq!(p.weights, q.weights);
        assert_eq!((p.t0, p.omega_a, p.omega_b), (q.t0, q.omega_a, q.omega_b));
        assert_eq!(p.terminal, q.terminal);
        for t in [0.0, 3.3, 9.99, 10.0, 11.0] {
            assert_eq!(p.desired.jet(t), q.desired.jet(t), "t = {t}");
        }
        let o = &loaded.options;
        let d = suslov::so3::solve::SolveOptions::default();
        assert_eq!(
            (
                o.tol,
                o.continuation_tol,
                o.beta_m,
                o.initial_intervals,
                o.max_nodes
            ),
            (
                d.tol,
                d.continuation_tol,
                d.beta_m,
                d.initial_intervals,
                d.max_nodes
            )
        );
    }
}

#[test]
fn the_segment_example_solves_end_to_end() {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("config_examples_segment");
    let _ = std::fs::remove_dir_all(&out);
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/segment.toml");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_suslov"))
        .arg("-q")
        .arg("solve")
        .arg(&config)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let summary: suslov::report::Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(summary.cases.len(), 1);
    let c = &summary.cases[0];
    assert_eq!(
        (c.name.as_str(), c.status.as_str()),
        ("segment", "converged")
    );
    // Measured: b = 3.68771, cost = 0.516482 (release build, tol 1e-8).
    assert!(
        (c.terminal_time - 3.68771).abs() < 1e-4,
        "{}",
        c.terminal_time
    );
    assert!((c.cost - 0.516482).abs() < 1e-5, "{}", c.cost);
    assert!(c.max_abs_constraint < 1e-8, "{}", c.max_abs_constraint);
    assert!(c.omega_b_error < 1e-10, "{}", c.omega_b_error);
    // problem.toml is the input with every default filled in: the same problem.
    let copy = suslov::config::load(&out.join("problem.toml")).unwrap();
    let original = suslov::config::load(&config).unwrap();
    assert_eq!(copy.resolved.table, original.resolved.table);
    for f in [
        "trajectory.csv",
        "omega_3d.png",
        "constraint.png",
        "xi_norm.png",
    ] {
        assert!(out.join(f).is_file(), "{f} not written");
    }
    let table = suslov::report::parse_trajectory_csv(
        &std::fs::read_to_string(out.join("trajectory.csv")).unwrap(),
    )
    .unwrap();
    // The uniform points and the mesh nodes (the ends are both).
    let uniform = suslov::app::OUTPUT_POINTS;
    assert!(table.t.len() >= uniform && table.t.len() <= uniform + c.mesh_nodes - 2);
    let om0 = table.omega[0];
    let dist = ((om0[0] - 3.0).powi(2) + om0[1].powi(2) + om0[2].powi(2)).sqrt();
    assert!(dist < 1e-12, "Omega(t0) = {om0:?}");
}
