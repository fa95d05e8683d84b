//! The resolved input (`suslov::config::resolved`): every example, every paper case and the
//! files a problem names are written with their defaults filled in, and reading that file back
//! gives the same problem bit for bit (the constants, end points, times, the desired path's jet
//! on a grid, the solver options); resolving twice gives the same table. `suslov solve
//! DIR/problem.toml` then repeats a run: the same b and J, bit for bit.

use std::path::{Path, PathBuf};

use suslov::config::{self, Loaded, ResolvedInput};
use suslov::lie::problem::TerminalTime;
use suslov::lie::solve::SolveOptions;
use suslov::lie::Problem;
use suslov::model::{
    se2::Se2, so3::So3, so3_full::So3Full, so3_inhomogeneous::So3Inhomogeneous, so4::So4, Model,
};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples")
}

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/tmp/resolved_input")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Everything that determines a solve, as bits.
fn fingerprint<M: Model>(p: &Problem<M>, o: &SolveOptions) -> Vec<u64> {
    let mut v: Vec<u64> = p.params().iter().map(|x| x.to_bits()).collect();
    v.push(p.t0.to_bits());
    v.extend(p.omega_a.iter().map(|x| x.to_bits()));
    v.extend(p.omega_b.iter().map(|x| x.to_bits()));
    let b = match p.terminal {
        TerminalTime::Fixed(b) => {
            v.push(0);
            b
        }
        TerminalTime::Free { guess } => {
            v.push(1);
            guess
        }
    };
    v.push(b.to_bits());
    let mut jet = vec![0.0; 4 * M::DIM];
    for k in 0..=64 {
        let t = p.t0 + (b - p.t0) * f64::from(k) / 64.0;
        p.desired.jet_into(t, &mut jet);
        v.extend(jet.iter().map(|x| x.to_bits()));
    }
    v.extend([
        o.tol.to_bits(),
        o.continuation_tol.to_bits(),
        o.beta_m.map_or(0, f64::to_bits),
        o.initial_intervals as u64,
        o.max_nodes as u64,
        o.max_routes as u64,
        o.start as u64,
    ]);
    if let Some(w) = &o.warm_start {
        v.extend(w.times.iter().map(|x| x.to_bits()));
        v.extend(w.states.iter().map(|x| x.to_bits()));
    }
    v
}

/// Writes `r` into `dir` as `suslov solve` does (problem.toml and the files it names).
fn write(r: &ResolvedInput, dir: &Path) -> PathBuf {
    for (name, bytes) in &r.files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let path = dir.join("problem.toml");
    std::fs::write(&path, r.toml_text("a test")).unwrap();
    path
}

/// (fingerprint, resolved input) of any problem file.
fn load(path: &Path) -> (Vec<u64>, ResolvedInput) {
    match config::load_any(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())) {
        (Loaded::So3(l), _) => {
            let p = l.problem.to_generic().unwrap();
            (fingerprint(&p, &l.options), l.resolved)
        }
        (Loaded::Other(f), _) => {
            fn go<M: Model>(f: &config::ModelFile) -> (Vec<u64>, ResolvedInput) {
                let l = f.build::<M>().unwrap();
                (fingerprint(&l.problem, &l.options), l.resolved)
            }
            match f.model.as_str() {
                "se2" => go::<Se2>(&f),
                "so3" => go::<So3>(&f),
                "so3_full" => go::<So3Full>(&f),
                "so3_inhomogeneous" => go::<So3Inhomogeneous>(&f),
                "so4" => go::<So4>(&f),
                other => panic!("no model {other}"),
            }
        }
    }
}

#[test]
fn every_example_reads_back_bit_for_bit() {
    let mut seen = 0;
    for entry in std::fs::read_dir(examples()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let (first, resolved) = load(&path);
        // Every default is written: the sections and the keys a file may leave out.
        let t = &resolved.table;
        for key in [
            "model", "name", "body", "boundary", "cost", "desired", "solver",
        ] {
            assert!(t.contains_key(key), "{stem}: no {key} in {t:#?}");
        }
        assert!(t["boundary"].get("t0").is_some(), "{stem}");
        assert!(t["desired"].get("kind").is_some(), "{stem}");
        for key in [
            "tolerance",
            "continuation_tolerance",
            "initial_intervals",
            "max_nodes",
            "start",
            "max_routes",
        ] {
            assert!(t["solver"].get(key).is_some(), "{stem}: solver.{key}");
        }
        let again = write(&resolved, &scratch(&stem));
        let (second, resolved2) = load(&again);
        assert_eq!(
            first, second,
            "{stem}: the resolved file gives another problem"
        );
        assert_eq!(
            resolved.table, resolved2.table,
            "{stem}: resolving is not idempotent"
        );
        assert_eq!(resolved.files, resolved2.files, "{stem}");
        seen += 1;
    }
    assert!(seen >= 10, "{seen} examples");
}

#[test]
fn the_samples_file_is_copied_and_named() {
    let (_, r) = load(&examples().join("spiral_samples.toml"));
    assert_eq!(
        r.table["desired"]["file"].as_str(),
        Some(config::resolved::SAMPLES_FILE)
    );
    let original = std::fs::read(examples().join("spiral_samples.csv")).unwrap();
    assert_eq!(
        r.files,
        vec![(config::resolved::SAMPLES_FILE.to_string(), original)]
    );
}

#[test]
fn defaults_are_filled_in_with_the_values_used() {
    let text = r#"
[body]
inertia = [1, 2, 3]
[boundary]
omega_a = [5.0, 0.0, 0.0]
omega_b = "desired_end"
terminal_time = { free = true }
[cost]
alpha = 1.0
beta = 0.1
gamma = 1.0
[desired]
kind = "paper-spiral"
"#;
    let l = config::from_toml_str(text).unwrap();
    let t = &l.resolved.table;
    assert_eq!(t["name"].as_str(), Some("problem"));
    assert_eq!(t["boundary"]["t0"].as_float(), Some(0.0));
    assert_eq!(
        t["boundary"]["terminal_time"]["guess"].as_float(),
        Some(10.0)
    );
    assert_eq!(t["boundary"]["terminal_time"]["free"].as_bool(), Some(true));
    assert_eq!(t["cost"]["eta"].as_float(), Some(0.0));
    assert_eq!(t["cost"]["delta"].as_float(), Some(0.0));
    assert_eq!(t["desired"]["c"].as_float(), Some(10.0));
    assert_eq!(t["desired"]["width"].as_float(), Some(0.01));
    assert_eq!(t["desired"]["b_d"].as_float(), Some(10.0));
    assert_eq!(t["solver"]["tolerance"].as_float(), Some(l.options.tol));
    assert_eq!(t["solver"]["start"].as_str(), Some("auto"));
    // beta_m is chosen by the solver when not given: left out, so it chooses again.
    assert!(t["solver"].get("beta_m").is_none());
    // The JSON of summary.json holds the same table.
    let json = l.resolved.to_json();
    assert_eq!(json["desired"]["b_d"], serde_json::json!(10.0));
    assert_eq!(json["body"]["inertia"], serde_json::json!([1.0, 2.0, 3.0]));
}

#[test]
fn the_paper_cases_resolve_to_the_paper_problem() {
    for case in &suslov::so3::paper::CASES {
        let r = config::resolved::paper_case(case);
        let l = config::from_toml_str(&r.toml_text("test")).unwrap();
        let expected = suslov::so3::paper::problem(case.eta).to_generic().unwrap();
        let got = l.problem.to_generic().unwrap();
        assert_eq!(
            fingerprint(&got, &l.options),
            fingerprint(&expected, &SolveOptions::default()),
            "{}",
            case.name
        );
        assert_eq!(l.name, case.name);
    }
}

#[test]
fn a_warm_start_is_copied_and_reads_back() {
    let dir = scratch("warm");
    let csv = "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3\n0,1,0,0,0,1,0,0,0,0\n1.5,0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9\n";
    std::fs::write(dir.join("prev.csv"), csv).unwrap();
    let text = std::fs::read_to_string(examples().join("segment.toml")).unwrap();
    let text = text.replace("[solver]", "[solver]\nstart_from = \"prev.csv\"");
    let text = if text.contains("start_from") {
        text
    } else {
        format!("{text}\n[solver]\nstart_from = \"prev.csv\"\n")
    };
    std::fs::write(dir.join("in.toml"), text).unwrap();
    let (first, r) = load(&dir.join("in.toml"));
    assert_eq!(
        r.table["solver"]["start_from"].as_str(),
        Some(config::resolved::START_FROM_FILE)
    );
    assert_eq!(r.files.len(), 1);
    let out = scratch("warm_out");
    let (second, _) = load(&write(&r, &out));
    assert_eq!(first, second);
}

/// `[desired]` may be left out when `γ = 0` (Ω_d is then not part of the cost): the projected
/// segment `Ω_a → Ω_b` stands in, and the resolved input says so; with `γ > 0` the missing
/// table is an error that names it and the rule.
#[test]
fn the_desired_table_is_optional_without_tracking() {
    let text = |gamma: f64| {
        format!(
            r#"
[body]
inertia = [1.0, 2.0, 3.0]
[boundary]
omega_a = [3.0, 0.0, 0.0]
omega_b = [1.0, 2.0, 0.0]
terminal_time = {{ fixed = 4.0 }}
[cost]
alpha = 1.0
beta = 0.1
gamma = {gamma:?}
"#
        )
    };
    let l = config::from_toml_str(&text(0.0)).unwrap();
    let d = &l.resolved.table["desired"];
    assert_eq!(d["kind"].as_str(), Some("segment"));
    assert_eq!(d["interval"].as_array().unwrap().len(), 2);
    // The same problem as with the segment written out.
    let explicit =
        config::from_toml_str(&format!("{}[desired]\nkind = \"segment\"\n", text(0.0))).unwrap();
    let (a, b) = (
        l.problem.to_generic().unwrap(),
        explicit.problem.to_generic().unwrap(),
    );
    assert_eq!(
        fingerprint(&a, &l.options),
        fingerprint(&b, &explicit.options)
    );
    let e = config::from_toml_str(&text(1.0)).unwrap_err();
    assert_eq!(e.field(), Some("desired"), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("gamma = 0"), "{msg}");
}
