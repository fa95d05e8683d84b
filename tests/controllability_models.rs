//! `suslov controllability` at given and sampled states for every shipped model: the generic
//! rank test (`suslov::lie::controllability::{rank_at, sample_states}`), its agreement with the
//! so(3) layer on the paper's model, and the command line (a non-so3 model, hostile inputs).

use std::process::Command;

use suslov::lie::controllability::{dim_m, rank_at, sample_states, StateRank, ON_LEVEL_RTOL};
use suslov::model::{fill_derived, Model, ParamMeta, MODEL_NAMES};

const BIN: &str = env!("CARGO_BIN_EXE_suslov");

/// The constraint value used for the models that have one (nonzero: `dim M = 2n − 1`).
const C: f64 = 0.25;

/// A valid value of a parameter from its bounds: the lower bound + 1 (+ 0.5 per earlier
/// bounded parameter, so that the moments differ), or 0.1, 0.2, … for unbounded ones (products
/// of inertia, the centre of mass); a constraint parameter gets [`C`].
fn value(meta: &ParamMeta, position: usize) -> f64 {
    let v = match (meta.role, meta.lower) {
        (suslov::model::HomotopyRole::Constraint, _) => C,
        (_, Some(lo)) => lo + 1.0 + 0.5 * position as f64,
        (_, None) => 0.1 * (position + 1) as f64,
    };
    assert!(meta.admits(v), "{}: {v}", meta.name);
    v
}

/// `name=value,…` of `metas` and the constants `p` of `M` (derived constants filled).
fn parameters<M: Model>() -> (String, Option<String>, Vec<f64>) {
    let mut p = vec![0.0; M::N_PARAM];
    let named = |metas: &[ParamMeta], p: &mut [f64]| {
        metas
            .iter()
            .enumerate()
            .map(|(k, m)| {
                p[m.index] = value(m, k);
                format!("{}={}", m.name, p[m.index])
            })
            .collect::<Vec<_>>()
            .join(",")
    };
    let inertia = named(M::INERTIA_PARAMS, &mut p);
    let constraint = named(M::CONSTRAINT_PARAMS, &mut p);
    fill_derived::<M>(&mut p).expect("the table's inertia is positive definite");
    (inertia, (!constraint.is_empty()).then_some(constraint), p)
}

/// `dim M` the task states for each shipped model (`c = 0.25` for so3_inhomogeneous).
fn expected_dim_m(name: &str) -> usize {
    match name {
        "so3" | "so3_full" | "se2" => 4,
        "so4" => 10,
        "so3_inhomogeneous" => 5,
        other => panic!("model {other} has no expected dim M in this test: add it"),
    }
}

/// Runs `check::<M>(name)` for the model named `name` (every entry of `MODEL_NAMES` must have
/// a row here: a new model fails loudly instead of being skipped).
fn for_model(name: &str, check: &mut dyn FnMut(&str, &dyn Fn() -> Checked)) {
    macro_rules! row {
        ($t:ty) => {
            check(name, &|| run_checks::<$t>(name))
        };
    }
    match name {
        "so3" => row!(suslov::model::so3::So3),
        "so3_full" => row!(suslov::model::so3_full::So3Full),
        "se2" => row!(suslov::model::se2::Se2),
        "so4" => row!(suslov::model::so4::So4),
        "so3_inhomogeneous" => row!(suslov::model::so3_inhomogeneous::So3Inhomogeneous),
        other => panic!("model {other} has no row in this test: add it"),
    }
}

/// What [`run_checks`] measured for one model.
#[derive(Debug)]
struct Checked {
    dim_m: usize,
    sampled: Vec<StateRank>,
    off_level: StateRank,
    cli_inertia: String,
    cli_constraint: Option<String>,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// The constraint value of the model at `p` (0, or its constraint parameter: every shipped
/// model's γ is a constant).
fn gamma<M: Model>(p: &[f64]) -> f64 {
    assert!(!M::CONSTRAINT_VALUE_DEPENDS_ON_XI);
    M::CONSTRAINT_PARAMS.iter().map(|m| p[m.index]).sum()
}

fn run_checks<M: Model>(name: &str) -> Checked {
    let (inertia, constraint, p) = parameters::<M>();
    let n = M::DIM;
    let dm = dim_m::<M>(&p);
    // Sampled states: on the energy level set through omega_a and on the constraint level.
    let omega_a: Vec<f64> = (0..n).map(|i| if i == 0 { 5.0 } else { 0.0 }).collect();
    let mut flat = vec![0.0; n * n];
    M::inertia_matrix(&p, &mut flat);
    let energy = |v: &[f64]| -> f64 {
        (0..n)
            .map(|i| v[i] * (0..n).map(|j| flat[i * n + j] * v[j]).sum::<f64>())
            .sum()
    };
    let states = sample_states::<M>(&p, &omega_a, 8, 1).unwrap();
    assert_eq!(states.len(), 8);
    let g = gamma::<M>(&p);
    let sampled: Vec<StateRank> = states
        .iter()
        .map(|x| {
            let (om, xi) = (&x[M::OMEGA], &x[M::XI]);
            assert!(
                (energy(om) / energy(&omega_a) - 1.0).abs() < 1e-13,
                "{name}: {x:?}"
            );
            assert!(
                (dot(om, xi) - g).abs() <= 1e-13 * norm(om) * norm(xi),
                "{name}"
            );
            let r = rank_at::<M>(x, &p, 1e-9).unwrap();
            assert!(!r.moved && r.on_m, "{name}: {r:?}");
            r
        })
        .collect();
    // The same seed gives the same states.
    assert_eq!(states, sample_states::<M>(&p, &omega_a, 8, 1).unwrap());
    assert_ne!(states, sample_states::<M>(&p, &omega_a, 8, 2).unwrap());

    // A given state off the constraint level: Omega = (2, 1, 0, …), xi = (1, 1, …, 1).
    let om: Vec<f64> = (0..n)
        .map(|i| match i {
            0 => 2.0,
            1 => 1.0,
            _ => 0.0,
        })
        .collect();
    let xi = vec![1.0; n];
    let x: Vec<f64> = om.iter().chain(&xi).copied().collect();
    let r = rank_at::<M>(&x, &p, 1e-9).unwrap();
    let violation = (dot(&om, &xi) - g).abs() / (norm(&om) * norm(&xi));
    assert!(violation > 0.1, "{name}: {violation}");
    assert!(r.moved, "{name}: {r:?}");
    assert!(
        (r.violation - violation).abs() <= 1e-14 * violation,
        "{name}: {} vs {violation}",
        r.violation
    );
    let (t_om, t_xi) = (&r.tested[M::OMEGA], &r.tested[M::XI]);
    assert_eq!(t_om, &om[..], "{name}: Omega is not moved");
    assert!((dot(t_om, t_xi) - g).abs() <= 1e-14 * norm(t_om) * norm(t_xi));
    // The nearest state: xi moved along the gradient of <Omega, xi> (= Omega), then (energy
    // conserved) scaled to unit length.
    let moved: Vec<f64> = {
        let s = (dot(&om, &xi) - g) / dot(&om, &om);
        xi.iter().zip(&om).map(|(x, o)| x - s * o).collect()
    };
    let expected: Vec<f64> = if g == 0.0 {
        moved.iter().map(|v| v / norm(&moved)).collect()
    } else {
        moved
    };
    for (a, b) in t_xi.iter().zip(&expected) {
        assert!((a - b).abs() < 1e-14, "{name}: {t_xi:?} vs {expected:?}");
    }
    assert!(r.on_m && r.residual <= ON_LEVEL_RTOL, "{name}: {r:?}");
    assert_eq!(r.rank, dm, "{name}: {r:?}");

    // Exact power-of-two rescalings far from unit scale do not change the rank or the verdict
    // (the singular values do: V is evaluated at the nearest power-of-two scale, not at 1).
    for e in [-300, -40, 40, 300] {
        let s = 2f64.powi(e);
        let scaled: Vec<f64> = t_om.iter().map(|v| v * s).chain(t_xi.to_vec()).collect();
        if g != 0.0 {
            // Omega s with xi / s keeps <Omega, xi> = c.
            let scaled: Vec<f64> = t_om
                .iter()
                .map(|v| v * s)
                .chain(t_xi.iter().map(|v| v / s))
                .collect();
            let q = rank_at::<M>(&scaled, &p, 1e-9).unwrap();
            assert_eq!((q.rank, q.on_m), (dm, true), "{name}: 2^{e}: {q:?}");
        } else {
            let q = rank_at::<M>(&scaled, &p, 1e-9).unwrap();
            assert_eq!((q.rank, q.on_m), (dm, true), "{name}: 2^{e}: {q:?}");
        }
    }
    Checked {
        dim_m: dm,
        sampled,
        off_level: r,
        cli_inertia: inertia,
        cli_constraint: constraint,
    }
}

#[test]
fn every_model_has_rank_dim_m_at_sampled_states_and_moves_a_state_onto_the_level() {
    for name in MODEL_NAMES {
        for_model(name, &mut |name, run| {
            let c = run();
            assert_eq!(c.dim_m, expected_dim_m(name), "{name}");
            let ranks: Vec<usize> = c.sampled.iter().map(|r| r.rank).collect();
            let margin = c
                .sampled
                .iter()
                .map(|r| r.sigma_dim_m)
                .fold(f64::INFINITY, f64::min);
            let next = c.sampled.iter().map(|r| r.sigma_next).fold(0.0, f64::max);
            eprintln!(
                "{name}: dim M {}, ranks {ranks:?}, min sigma_dimM/sigma_1 {margin:.3e}, max \
                 sigma_dimM+1/sigma_1 {next:.1e}; off-level state: violation {:.3e}, rank {}",
                c.dim_m, c.off_level.violation, c.off_level.rank
            );
            assert!(ranks.iter().all(|&r| r == c.dim_m), "{name}: {ranks:?}");
            assert!(margin > 1e-4 && next < 1e-12, "{name}");

            // Through the library entry of the command line, by name.
            let request = suslov::app::RankAtStates {
                model: name,
                inertia: Some(&c.cli_inertia),
                constraint: c.cli_constraint.as_deref(),
                state: None,
                omega_a: None,
                samples: 8,
                seed: 1,
                rtol: 1e-9,
            };
            let suslov::app::RankTable {
                text,
                verdict,
                json,
            } = suslov::app::run_rank_at_states(&request).unwrap();
            // The data behind the table says the same.
            assert_eq!(json["verdict"]["verdict"], "accessible", "{name}: {json}");
            assert_eq!(json["states"].as_array().map(Vec::len), Some(8), "{name}");
            assert_eq!(
                verdict,
                suslov::so3::controllability::AccessibilityVerdict::Accessible { on_m: 8 },
                "{name}: {text}"
            );
        });
    }
}

#[test]
fn the_generic_test_on_so3_equals_the_so3_layer() {
    use nalgebra::Vector3;
    use suslov::model::so3::So3;
    use suslov::so3::controllability::{rank_report, sample_states_on_m, RANK_RTOL};
    use suslov::so3::Inertia;
    let mut worst: f64 = 0.0;
    let mut count = 0;
    for (diag, seed) in [
        ([1.0, 2.0, 3.0], 1),
        ([0.7, 2.5, 1.3], 2),
        ([2.0, 2.0, 2.0], 3),
    ] {
        let inertia = Inertia::new(diag).unwrap();
        let mut p = vec![0.0; So3::N_PARAM];
        for (m, v) in So3::INERTIA_PARAMS.iter().zip(diag) {
            p[m.index] = v;
        }
        fill_derived::<So3>(&mut p).unwrap();
        let mut states =
            sample_states_on_m(&inertia, &Vector3::new(5.0, 0.0, 0.0), 50, seed).unwrap();
        states.push((Vector3::new(5.0, 0.0, 0.0), Vector3::new(0.0, 1.0, 0.0)));
        states.push((
            Vector3::new(1.0, 2.0, 3.0),
            Vector3::new(2.0, -1.0, 0.0) / 5f64.sqrt(),
        ));
        for (om, xi) in states {
            let x: Vec<f64> = om.iter().chain(xi.iter()).copied().collect();
            let generic = rank_at::<So3>(&x, &p, RANK_RTOL).unwrap();
            let layer = rank_report(&inertia, &om, &xi, RANK_RTOL).unwrap();
            assert_eq!(generic.rank, layer.rank, "{om:?} {xi:?}");
            assert_eq!(generic.rank, 4);
            let top = layer.singular_values[0];
            for (g, l) in generic.singular_values.iter().zip(layer.singular_values) {
                worst = worst.max((g / generic.singular_values[0] - l / top).abs());
            }
            assert!((generic.sigma_dim_m - layer.singular_values[3] / top).abs() <= 1e-12);
            assert!((generic.sigma_next - layer.singular_values[4] / top).abs() <= 1e-12);
            count += 1;
        }
    }
    eprintln!("so3: {count} states, worst |sigma_k/sigma_1 (generic) - (so3 layer)| {worst:e}");
    assert!(worst <= 1e-12, "{worst:e}");
}

fn run(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(BIN)
        .arg("controllability")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_command_line_runs_another_model_at_sampled_and_given_states() {
    let sleigh = ["--model", "se2", "--inertia", "m=1,Ic=0.5,c1=0.3,c2=0.1"];
    let (code, stdout, stderr) = run(&sleigh);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(stdout.contains("model se2"), "{stdout}");
    assert!(stdout.contains("dim M = 2n - 2 = 4"), "{stdout}");
    assert!(
        stdout.contains("rank V = 4 = dim M at all 8 states of M tested"),
        "{stdout}"
    );
    // A given state off the constraint level: moved onto it, and said so.
    let mut given = sleigh.to_vec();
    given.extend(["--omega", "1,0.5,0", "--xi", "0.2,0,1"]);
    let (code, stdout, stderr) = run(&given);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(
        stdout.contains("is off the constraint level (|phi|/(|Omega||xi|) = 1.754e-1"),
        "{stdout}"
    );
    assert!(
        stdout.contains("the row is the nearest state on it"),
        "{stdout}"
    );
    // A nonzero constraint value: dim M = 2n - 1.
    let (code, stdout, stderr) = run(&[
        "--model",
        "so3_inhomogeneous",
        "--inertia",
        "I1=1,I2=2,I3=3",
        "--constraint",
        "c=0.25",
        "--samples",
        "3",
    ]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(stdout.contains("dim M = 2n - 1 = 5"), "{stdout}");
    assert!(stdout.contains("one choice of states of M"), "{stdout}");
    assert!(
        stdout.contains("rank V = 5 = dim M at all 3 states"),
        "{stdout}"
    );
    // so4 at a given state on M.
    let (code, stdout, stderr) = run(&[
        "--model",
        "so4",
        "--inertia",
        "J1=1,J2=2,J3=3,J4=4",
        "--omega",
        "1,0,0,0,0,1",
        "--xi",
        "0,1,0,1,0,0",
    ]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(
        stdout.contains("rank V = 10 = dim M at all 1 states"),
        "{stdout}"
    );
    assert!(!stdout.contains("off the constraint level"), "{stdout}");
    // Along a solution with <Omega, xi> = c: the residual it quotes is <Omega, xi> - c (it
    // quoted |<Omega, xi>|/(|Omega| |xi|), "xi projected onto Omega^perp", and a 1e-10).
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/so3_inhomogeneous.toml"
    );
    let (code, stdout, stderr) = run(&["--along", file, "--points", "21"]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(stdout.contains("rank of V = 5 at all 21 times"), "{stdout}");
    assert!(
        stdout.contains("max |<Omega, xi> - gamma|/(|Omega| |xi|)"),
        "{stdout}"
    );
    assert!(!stdout.contains("Omega^perp"), "{stdout}");
}

#[test]
fn hostile_inputs_are_refused_with_the_flag_named() {
    let se2 = "m=1,Ic=0.5,c1=0.3,c2=0.1";
    let cases: Vec<(Vec<&str>, &str, &str)> = vec![
        (
            vec!["--model", "so5"],
            "--model",
            "se2, so3, so3_full, so3_inhomogeneous, so4",
        ),
        (
            vec![
                "--model",
                "se2",
                "--inertia",
                "m=1,Ic=0.5,c1=0.3,c2=0.1,d=1",
            ],
            "--inertia",
            "no parameter \"d\"",
        ),
        (
            vec!["--model", "se2", "--inertia", "m=1,Ic=0.5,c1=0.3"],
            "--inertia",
            "missing c2",
        ),
        (
            vec!["--model", "se2"],
            "--inertia",
            "m (mass of the sleigh (> 0))",
        ),
        (
            vec!["--model", "se2", "--inertia", "1,0.5,0.3,0.1"],
            "--inertia",
            "name=value",
        ),
        (
            vec![
                "--model",
                "se2",
                "--inertia",
                se2,
                "--omega",
                "1,0",
                "--xi",
                "0,1,0",
            ],
            "--omega",
            "dimension n = 3 (basis e0, e1, e2)",
        ),
        (
            vec![
                "--model",
                "so4",
                "--inertia",
                "J1=1,J2=1,J3=1,J4=1",
                "--omega-a",
                "1,0,0",
            ],
            "--omega-a",
            "dimension n = 6 (basis E12, E13, E14, E23, E24, E34)",
        ),
        (
            vec![
                "--model",
                "se2",
                "--inertia",
                se2,
                "--omega",
                "nan,0,0",
                "--xi",
                "0,1,0",
            ],
            "--omega",
            "finite",
        ),
        (
            vec!["--model", "se2", "--inertia", "m=nan,Ic=0.5,c1=0.3,c2=0.1"],
            "--inertia",
            "not a finite number",
        ),
        (
            vec!["--model", "se2", "--inertia", "m=-1,Ic=0.5,c1=0.3,c2=0.1"],
            "--inertia",
            "m = -1 is not admissible: mass of the sleigh (> 0)",
        ),
        (
            vec!["--model", "se2", "--inertia", se2, "--constraint", "c=0.25"],
            "--constraint",
            "no constraint parameters",
        ),
        (vec!["--constraint", "c=0.25"], "--constraint", "model so3"),
        (
            vec![
                "--model",
                "so3_inhomogeneous",
                "--inertia",
                "I1=1,I2=2,I3=3",
            ],
            "--constraint",
            "c=0",
        ),
        (
            vec![
                "--model",
                "so3_full",
                "--inertia",
                "I11=1,I22=1,I33=1,I12=2,I13=0,I23=0",
            ],
            "--inertia",
            "not symmetric positive definite",
        ),
        (
            vec![
                "--model",
                "se2",
                "--inertia",
                se2,
                "--omega",
                "1,0,0",
                "--xi",
                "0,0,0",
            ],
            "--xi",
            "xi = 0",
        ),
        (
            vec![
                "--model",
                "se2",
                "--inertia",
                se2,
                "--omega",
                "1,0,0",
                "--xi",
                "3,0,0",
            ],
            "--xi",
            "xi = 0",
        ),
        (
            vec!["--model", "se2", "--inertia", se2, "--omega-a", "0,0,0"],
            "--omega-a",
            "nonzero",
        ),
        (
            vec!["--model", "se2", "--inertia", se2, "--rtol", "nan"],
            "--rtol",
            "[1e-14, 1e-3]",
        ),
        (
            vec!["--model", "se2", "--inertia", se2, "--samples", "0"],
            "--samples",
            "between 1",
        ),
    ];
    for (args, flag, fix) in cases {
        let (code, stdout, stderr) = run(&args);
        assert_eq!(code, Some(1), "{args:?}: {stdout}{stderr}");
        assert!(stderr.contains(flag), "{args:?}: {stderr}");
        assert!(stderr.contains(fix), "{args:?}: {stderr}");
        assert!(stdout.is_empty(), "{args:?}: {stdout}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    // --model and --constraint belong to the state modes, not to --along (a file names its
    // model): a malformed command line.
    let (code, _, stderr) = run(&["--model", "se2", "--along", "paper"]);
    assert_eq!(code, Some(2), "{stderr}");
}
