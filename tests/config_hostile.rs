//! Hostile problem files (issue #10): wrong-length arrays, oversized inputs, files that are
//! no files, inconsistent tolerances, messages that blamed the wrong key or echoed too much.
//! Each test is the regression test of one defect; every error must name the field, say what
//! was expected and found, and stay short.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use suslov::config::{self, ConfigError, FileProblem};

/// The paper's η = 1 problem file, the base most tests modify.
const BASE: &str = include_str!("../examples/paper_eta1.toml");

/// A segment problem (fixed time) on `I = diag(1, 2, 3)`: `[3, 0, 0] → [1, 2, 0]`.
const SEGMENT: &str = "[body]\ninertia = [1.0, 2.0, 3.0]\n[boundary]\nomega_a = [3.0, 0.0, 0.0]\n\
                       omega_b = [1.0, 2.0, 0.0]\nterminal_time = { fixed = 4.0 }\n\
                       [cost]\nalpha = 1.0\nbeta = 0.1\ngamma = 1.0\n[desired]\nkind = \"segment\"\n";

/// Longest message any error may print (the echoed input is capped).
const MAX_MESSAGE: usize = 1000;

/// `BASE` with the first line starting with `key` replaced by `replacement`.
fn with_line(doc: &str, key: &str, replacement: &str) -> String {
    let mut found = false;
    let out: Vec<String> = doc
        .lines()
        .map(|l| {
            if !found && l.trim_start().starts_with(key) {
                found = true;
                replacement.to_string()
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(found, "no line starting with {key}");
    out.join("\n") + "\n"
}

/// `doc`'s error, which must name `field` (its TOML path) and be short.
fn error(doc: &str, field: &str) -> (ConfigError, String) {
    let e = match config::from_toml_str(doc) {
        Ok(p) => panic!("expected an error naming {field}, got {p:?}"),
        Err(e) => e,
    };
    check_error(e, field)
}

fn check_error(e: ConfigError, field: &str) -> (ConfigError, String) {
    let msg = e.to_string();
    assert_eq!(e.field(), Some(field), "{msg}");
    assert!(msg.contains(field), "message does not name {field}: {msg}");
    assert!(msg.len() <= MAX_MESSAGE, "{} characters: {msg}", msg.len());
    assert!(!msg.contains("NaN"), "{msg}");
    (e, msg)
}

fn assert_contains(msg: &str, words: &[&str]) {
    for w in words {
        assert!(msg.contains(w), "message lacks {w:?}: {msg}");
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("config_hostile")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `BASE` as a samples problem reading `file`.
fn samples_doc(file: &str) -> String {
    BASE.replace(
        "kind = \"paper-spiral\"",
        &format!("kind = \"samples\"\nfile = \"{file}\""),
    )
    .replace("c = 10.0\n", "")
    .replace("width = 0.01\n", "")
    .replace("b_d = 10.0\n", "")
}

/// Loads a samples problem whose CSV is `csv` (both written to a scratch directory).
fn samples_problem(name: &str, csv: &[u8]) -> Result<config::LoadedProblem, ConfigError> {
    let dir = scratch(name);
    std::fs::write(dir.join("samples.csv"), csv).unwrap();
    let path = dir.join("problem.toml");
    std::fs::write(&path, samples_doc("samples.csv")).unwrap();
    config::load(&path)
}

// ---------------------------------------------------------------------------------------
// Defect 1: arrays of the wrong length were truncated silently (NaN included).

#[test]
fn arrays_longer_or_shorter_than_expected_name_the_field_and_both_lengths() {
    let cases = [
        (
            BASE,
            "inertia =",
            "inertia = [1, 2, 3, 4]",
            "body.inertia",
            "has 4 entries, expected 3 (I1, I2, I3)",
        ),
        (
            BASE,
            "inertia =",
            "inertia = [1, 2]",
            "body.inertia",
            "has 2 entries, expected 3 (I1, I2, I3)",
        ),
        (
            BASE,
            "inertia =",
            "inertia = []",
            "body.inertia",
            "has 0 entries, expected 3",
        ),
        (
            BASE,
            "omega_a =",
            "omega_a = [5, 0, 0, nan]",
            "boundary.omega_a",
            "has 4 entries, expected 3",
        ),
        (
            BASE,
            "omega_a =",
            "omega_a = [5]",
            "boundary.omega_a",
            "has 1 entry, expected 3",
        ),
        (
            BASE,
            "omega_b =",
            "omega_b = [2.75, -2.31, -1.49, 0.0]",
            "boundary.omega_b",
            "has 4 entries, expected 3",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"segment\"\ninterval = [0, 4, 99]",
            "desired.interval",
            "has 3 entries, expected 2",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"segment\"\ninterval = [0]",
            "desired.interval",
            "has 1 entry, expected 2",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"segment\"\nfrom = [3, 0, 0, 1]",
            "desired.from",
            "has 4 entries, expected 3",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"segment\"\nto = [1, 2]",
            "desired.to",
            "has 2 entries, expected 3",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"constant\"\nvalue = [3, 0, 0, 0, 0]",
            "desired.value",
            "has 5 entries, expected 3",
        ),
    ];
    for (doc, key, line, field, words) in cases {
        let (e, msg) = error(&with_line(doc, key, line), field);
        assert!(matches!(e, ConfigError::Length { .. }), "{msg}");
        assert_contains(&msg, &[words]);
    }
}

#[test]
fn a_hundred_thousand_entry_array_is_counted_not_truncated() {
    let long = vec!["1"; 100_000].join(",");
    let (_, msg) = error(
        &with_line(BASE, "inertia =", &format!("inertia = [{long}]")),
        "body.inertia",
    );
    assert_contains(&msg, &["has 100000 entries, expected 3"]);
}
// ---------------------------------------------------------------------------------------
// Defect 2: unbounded resources.

#[test]
fn a_long_name_is_rejected_before_any_work() {
    let long = "x".repeat(100_000);
    let clock = Instant::now();
    let (_, msg) = error(
        &with_line(BASE, "name =", &format!("name = \"{long}\"")),
        "name",
    );
    assert!(clock.elapsed() < Duration::from_secs(1));
    assert_contains(&msg, &["100000 characters", "at most 200"]);
    for bad in ["\"a\\nb\"", "\"tab\\there\"", "\"bell\\u0007\""] {
        let (_, msg) = error(&with_line(BASE, "name =", &format!("name = {bad}")), "name");
        assert_contains(&msg, &["control character"]);
    }
    // 200 characters (not bytes) are fine.
    let ok = "é".repeat(200);
    let p = config::from_toml_str(&with_line(BASE, "name =", &format!("name = \"{ok}\""))).unwrap();
    assert_eq!(p.name.chars().count(), 200);
}

#[test]
fn a_file_name_that_is_no_usable_case_name_asks_for_a_name() {
    let dir = scratch("stem");
    let path = dir.join(format!("{}.toml", "y".repeat(250)));
    std::fs::write(&path, BASE.replace("name = \"paper_eta1\"", "")).unwrap();
    let e = config::load(&path).unwrap_err();
    let (_, msg) = check_error(e, "name");
    assert_contains(&msg, &["file name", "add name = "]);
}

#[test]
fn an_oversized_problem_file_is_rejected_without_reading_it_whole() {
    let dir = scratch("big_problem");
    let path = dir.join("big.toml");
    // A ten-million-entry array: 20 MB.
    let long = vec!["1"; 10_000_000].join(",");
    std::fs::write(
        &path,
        with_line(BASE, "inertia =", &format!("inertia = [{long}]")),
    )
    .unwrap();
    let clock = Instant::now();
    let e = config::load(&path).unwrap_err();
    assert!(clock.elapsed() < Duration::from_secs(2));
    let msg = e.to_string();
    assert!(
        matches!(
            e.inner(),
            ConfigError::File {
                problem: FileProblem::TooLarge { .. },
                ..
            }
        ),
        "{msg}"
    );
    assert_contains(&msg, &["big.toml", "larger than", "1 MiB"]);
    assert!(msg.len() <= MAX_MESSAGE);
    // The same text given as a string.
    let text = std::fs::read_to_string(&path).unwrap();
    let e = config::from_toml_str(&text).unwrap_err();
    assert!(matches!(e, ConfigError::TooLarge { .. }), "{e}");
}

#[test]
fn a_problem_path_that_is_no_regular_file_is_rejected() {
    for (path, words) in [("/dev/zero", "not a regular file"), ("/tmp", "a directory")] {
        let clock = Instant::now();
        let e = config::load(Path::new(path)).unwrap_err();
        assert!(clock.elapsed() < Duration::from_secs(1));
        assert_contains(&e.to_string(), &[path, words]);
    }
}

#[test]
fn a_samples_file_that_is_no_regular_file_or_too_large_is_rejected() {
    let dir = scratch("samples_special");
    let path = dir.join("p.toml");
    for (file, words) in [("/dev/zero", "not a regular file"), ("/tmp", "a directory")] {
        std::fs::write(&path, samples_doc(file)).unwrap();
        let clock = Instant::now();
        let e = config::load(&path).unwrap_err();
        assert!(clock.elapsed() < Duration::from_secs(1));
        let (_, msg) = check_error(e, "desired.file");
        assert_contains(&msg, &[file, words]);
    }
    // A (sparse) file one byte over the cap.
    let big = dir.join("big.csv");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(config::MAX_SAMPLES_FILE_BYTES + 1).unwrap();
    std::fs::write(&path, samples_doc("big.csv")).unwrap();
    let clock = Instant::now();
    let e = config::load(&path).unwrap_err();
    assert!(clock.elapsed() < Duration::from_secs(1));
    let (_, msg) = check_error(e, "desired.file");
    assert_contains(&msg, &["larger than", "64 MiB"]);
}

#[test]
fn the_number_of_sample_rows_is_capped() {
    let n = config::MAX_SAMPLE_ROWS + 1;
    let mut csv = String::with_capacity(n * 16);
    for k in 0..n {
        csv.push_str(&format!("{k},10,0,0\n"));
    }
    let e = samples_problem("many_rows", csv.as_bytes()).unwrap_err();
    let (_, msg) = check_error(e, "desired.file");
    assert_contains(&msg, &["more than", "rows"]);
}

// ---------------------------------------------------------------------------------------
// Defect 5 (input echo): long lines and BOMs.

#[test]
fn a_long_toml_line_is_not_echoed_whole() {
    let long = "x".repeat(900_000);
    let (_, msg) = error(
        &with_line(BASE, "beta =", &format!("beta = \"{long}\"")),
        "cost.beta",
    );
    assert_contains(&msg, &["invalid type", "…"]);
    let (_, msg) = error(
        &with_line(BASE, "kind =", &format!("kind = \"{long}\"")),
        "desired.kind",
    );
    assert_contains(&msg, &["unknown kind", "…"]);
}

#[test]
fn a_long_csv_line_is_not_echoed_whole() {
    let csv = format!("0,10,0,0\n1,10,{},0\n", "7".repeat(10_000_000) + "x");
    let e = samples_problem("long_line", csv.as_bytes()).unwrap_err();
    let (_, msg) = check_error(e, "desired.file");
    assert_contains(&msg, &["line 2", "…"]);
}

#[test]
fn a_byte_order_mark_is_skipped_in_toml_and_csv() {
    let p = config::from_toml_str(&format!("\u{feff}{BASE}")).unwrap();
    assert_eq!(p.name, "paper_eta1");
    let dir = scratch("bom_toml");
    let path = dir.join("p.toml");
    std::fs::write(&path, format!("\u{feff}{BASE}")).unwrap();
    config::load(&path).unwrap();

    let csv = "\u{feff}# the paper's spiral\nt,w1,w2,w3\n0,10,0,0\n5,10,1,2\n10,10,-1,3\n";
    let p = samples_problem("bom_csv", csv.as_bytes()).unwrap();
    assert!((p.problem.desired.value(0.0) - p.problem.omega_a).norm() < 1e-14);
}

#[test]
fn a_problem_file_that_is_not_utf8_names_the_line() {
    let dir = scratch("not_utf8");
    let path = dir.join("p.toml");
    let mut bytes = BASE.as_bytes().to_vec();
    let at = BASE.find("beta = 0.1").unwrap() + "beta = ".len();
    bytes.splice(at..at + 3, [0xff, 0xfe, b'1']);
    std::fs::write(&path, &bytes).unwrap();
    let e = config::load(&path).unwrap_err();
    let (_, msg) = check_error(e, "cost.beta");
    assert_contains(&msg, &["not valid UTF-8", "line 15, column 8"]);
    // After a byte order mark, columns count from the first character after it.
    let mut with_bom = "\u{feff}alpha = 1".as_bytes().to_vec();
    with_bom.extend_from_slice(&[0xff, b'\n']);
    std::fs::write(&path, &with_bom).unwrap();
    let e = config::load(&path).unwrap_err();
    let msg = e.to_string();
    assert_contains(
        &msg,
        &["not valid UTF-8", "line 1, column 10", "(in `alpha`)"],
    );
}

// ---------------------------------------------------------------------------------------
// Defects 2, 3 and 5 (solver options): resource caps, tolerances, beta_m, the key blamed.

/// `BASE` with `lines` under `[solver]`.
fn with_solver(lines: &str) -> String {
    BASE.replace("[solver]", &format!("[solver]\n{lines}"))
        .replace("tolerance = 1e-8\n", "")
}

#[test]
fn mesh_sizes_are_capped_and_the_cap_on_initial_intervals_comes_first() {
    let (_, msg) = error(
        &with_solver("initial_intervals = 1000000000"),
        "solver.initial_intervals",
    );
    assert_contains(&msg, &["1000000000", "at most 10000", "memory"]);
    // Even with a max_nodes that would be smaller.
    let (_, msg) = error(
        &with_solver("initial_intervals = 1000000000\nmax_nodes = 20000"),
        "solver.initial_intervals",
    );
    assert_contains(&msg, &["at most 10000"]);
    let (_, msg) = error(
        &with_solver("max_nodes = 1000000000000"),
        "solver.max_nodes",
    );
    assert_contains(&msg, &["at most 50000", "memory"]);
    // At the caps: accepted.
    let p = config::from_toml_str(&with_solver("initial_intervals = 10000\nmax_nodes = 50000"))
        .unwrap();
    assert_eq!(
        (p.options.initial_intervals, p.options.max_nodes),
        (10000, 50000)
    );
    // max_nodes not above initial_intervals: the suggestion is a value that works.
    let (_, msg) = error(
        &with_solver("initial_intervals = 9000\nmax_nodes = 9000"),
        "solver.max_nodes",
    );
    assert_contains(
        &msg,
        &["must exceed solver.initial_intervals = 9000", "e.g. 20000"],
    );
}

#[test]
fn tolerances_outside_their_sensible_range_are_rejected() {
    for (line, field, words) in [
        (
            "tolerance = 1.0",
            "solver.tolerance",
            "between 1e-12 and 1e-4",
        ),
        (
            "tolerance = 1e-2",
            "solver.tolerance",
            "between 1e-12 and 1e-4",
        ),
        (
            "tolerance = 1e-16",
            "solver.tolerance",
            "between 1e-12 and 1e-4",
        ),
        (
            "continuation_tolerance = 0.5",
            "solver.continuation_tolerance",
            "between 1e-12 and 1e-2",
        ),
        (
            "continuation_tolerance = 1e-20",
            "solver.continuation_tolerance",
            "between 1e-12 and 1e-2",
        ),
    ] {
        let (_, msg) = error(&with_solver(line), field);
        assert_contains(&msg, &[words]);
    }
    let p = config::from_toml_str(&with_solver(
        "tolerance = 1e-12\ncontinuation_tolerance = 1e-2",
    ))
    .unwrap();
    assert_eq!((p.options.tol, p.options.continuation_tol), (1e-12, 1e-2));
    let p = config::from_toml_str(&with_solver(
        "tolerance = 1e-4\ncontinuation_tolerance = 1e-12",
    ))
    .unwrap();
    assert_eq!((p.options.tol, p.options.continuation_tol), (1e-4, 1e-12));
    let (_, msg) = error(&with_solver("tolerance = 1e-3"), "solver.tolerance");
    assert_contains(&msg, &["between 1e-12 and 1e-4"]);
}

#[test]
fn beta_m_must_lie_below_beta() {
    // cost.beta = 0.1 in BASE.
    for line in ["beta_m = 10.0", "beta_m = 0.2"] {
        let (_, msg) = error(&with_solver(line), "solver.beta_m");
        assert_contains(&msg, &["cost.beta = 0.1"]);
    }
    let (_, msg) = error(&with_solver("beta_m = 1e-300"), "solver.beta_m");
    assert_contains(&msg, &["1e-300", "cost.beta = 0.1"]);
    for ok in ["beta_m = 0.1", "beta_m = 1e-9"] {
        config::from_toml_str(&with_solver(ok)).unwrap();
    }
}

// ---------------------------------------------------------------------------------------
// Defect 4: one energy tolerance everywhere (validation accepted 1e-9, the segment 1e-12).

/// `[1, 2, 0]` (on the ellipsoid of `[3, 0, 0]`, `I = diag(1, 2, 3)`) scaled by
/// `sqrt(1 + 5e-10)`: a relative energy mismatch of 5e-10, within `ENERGY_REL_TOL` = 1e-9.
const OMEGA_B_5E_10: &str = "[1.00000000025, 2.0000000005, 0.0]";

fn mismatch_of(p: &config::LoadedProblem) -> f64 {
    p.problem
        .ellipsoid()
        .relative_mismatch(&p.problem.omega_b)
        .abs()
}

#[test]
fn omega_b_within_the_energy_tolerance_goes_through_config_and_builds_the_start() {
    let off = nalgebra::Vector3::new(1.00000000025, 2.0000000005, 0.0);
    let e = suslov::so3::EnergyEllipsoid::through(
        suslov::so3::Inertia::paper(),
        &nalgebra::Vector3::new(3.0, 0.0, 0.0),
    )
    .unwrap();
    let m = e.relative_mismatch(&off);
    assert!((4e-10..6e-10).contains(&m), "{m:e}");

    // A segment path through the off point (it used to fail: "not opposite").
    let doc = SEGMENT.replace(
        "omega_b = [1.0, 2.0, 0.0]",
        &format!("omega_b = {OMEGA_B_5E_10}"),
    );
    let p = config::from_toml_str(&doc).unwrap();
    // The validated problem carries Omega_b projected onto the ellipsoid.
    assert!(mismatch_of(&p) < 1e-15, "{:e}", mismatch_of(&p));
    assert!((p.problem.omega_b - off).norm() < 1e-9);

    // gamma = 0: the solver's start is the projected segment to Omega_b (it used to fail
    // with "cannot build the analytic start: Omega_b is off ...").
    let doc = SEGMENT
        .replace(
            "omega_b = [1.0, 2.0, 0.0]",
            &format!("omega_b = {OMEGA_B_5E_10}"),
        )
        .replace("gamma = 1.0", "gamma = 0.0")
        .replace(
            "kind = \"segment\"",
            "kind = \"constant\"\nvalue = [3.0, 0.0, 0.0]",
        );
    let p = config::from_toml_str(&doc).unwrap();
    let clock = Instant::now();
    let sol = suslov::so3::solve::solve(&p.problem, &p.options, &mut |_| {}).unwrap();
    assert!(clock.elapsed() < Duration::from_secs(20));
    assert_eq!(sol.generic.start.case, 1);
    let end = nalgebra::Vector3::from_column_slice(
        &sol.generic.bvp.eval(1.0)[suslov::model::generated::OMEGA],
    );
    assert!((end - off).norm() < 1e-8, "{end}");
}

#[test]
fn a_problem_built_in_code_with_omega_b_within_the_tolerance_builds_the_segment_start() {
    use suslov::so3::problem::{CostWeights, SuslovProblem, TerminalTime};
    let off = nalgebra::Vector3::new(1.00000000025, 2.0000000005, 0.0);
    let problem = SuslovProblem {
        inertia: suslov::so3::Inertia::paper(),
        weights: CostWeights {
            alpha: 1.0,
            beta: 0.1,
            gamma: 0.0,
            eta: 0.0,
            delta: 0.0,
        },
        t0: 0.0,
        omega_a: nalgebra::Vector3::new(3.0, 0.0, 0.0),
        omega_b: off,
        terminal: TerminalTime::Fixed(4.0),
        desired: std::sync::Arc::new(suslov::so3::Constant(nalgebra::Vector3::new(3.0, 0.0, 0.0))),
    };
    problem.validate().unwrap();
    let sol = suslov::so3::solve::solve(&problem, &Default::default(), &mut |_| {}).unwrap();
    assert_eq!(sol.generic.start.omega_p, "projected segment");
}

// ---------------------------------------------------------------------------------------
// Defect 5: messages that blamed the wrong key or printed NaN.

#[test]
fn an_off_ellipsoid_omega_b_behind_a_segment_is_blamed_on_omega_b() {
    let doc = SEGMENT.replace("omega_b = [1.0, 2.0, 0.0]", "omega_b = [1.0, 2.0, 0.1]");
    let (_, msg) = error(&doc, "boundary.omega_b");
    assert_contains(
        &msg,
        &["off omega_a's energy ellipsoid", "radial projection"],
    );
    // An explicit `to` is still blamed as such.
    let (_, msg) = error(&format!("{SEGMENT}to = [1.0, 2.0, 0.1]\n"), "desired.to");
    assert_contains(&msg, &["off omega_a's energy ellipsoid"]);
}

#[test]
fn a_segment_from_omega_a_to_itself_is_the_constant_path() {
    let doc = SEGMENT.replace("omega_b = [1.0, 2.0, 0.0]", "omega_b = [3.0, 0.0, 0.0]");
    let p = config::from_toml_str(&doc).unwrap();
    for t in [0.0, 1.0, 4.0, 7.0] {
        let jet = p.problem.desired.jet(t);
        assert_eq!(jet.value, p.problem.omega_a);
        assert_eq!(jet.d1, nalgebra::Vector3::zeros());
    }
    // Antipodal end points: the message gives a distance, never NaN.
    let (_, msg) = error(&format!("{SEGMENT}to = [-3.0, 0.0, 0.0]\n"), "desired.to");
    assert_contains(&msg, &["origin", "opposite"]);
}

#[test]
fn huge_sample_values_never_suggest_nan() {
    // Finite spline, huge values: only the directions matter after the projection.
    let p = samples_problem("huge_ok", b"0,1e308,0,0\n10,1e308,1e308,0\n").unwrap();
    let end = p.problem.omega_b;
    assert!(
        mismatch_of(&p) < 1e-14 && end.iter().all(|x| x.is_finite()),
        "{end}"
    );
    // Differences that overflow: the spline cannot be built in f64.
    let e =
        samples_problem("huge_bad", b"0,1e308,0,0\n1,-1e308,1e308,0\n2,1e308,0,0\n").unwrap_err();
    let (_, msg) = check_error(e, "desired.file");
    assert_contains(&msg, &["overflows"]);
}

// ---------------------------------------------------------------------------------------
// Defect 8 (found here): paths whose values or derivatives overflow, time spans below the
// resolution of t0.

#[test]
fn a_desired_path_that_overflows_is_an_error_naming_its_keys() {
    // A sigmoid far narrower than f64 can differentiate (1/w^3 overflows).
    let (_, msg) = error(
        &with_line(BASE, "width =", "width = 1e-300"),
        "desired.width",
    );
    assert_contains(&msg, &["not finite", "t = "]);
    // Samples 1e-300 apart: the spline's slope overflows.
    let e = samples_problem("close", b"0,10,0,0\n1e-300,10,1,0\n1,10,0,1\n").unwrap_err();
    let (_, msg) = check_error(e, "desired.file");
    assert_contains(&msg, &["overflows"]);
    // A segment interval of 1e-300: its slope overflows.
    let (_, msg) = error(
        &format!("{SEGMENT}interval = [0.0, 1e-300]\n"),
        "desired.interval",
    );
    assert_contains(&msg, &["not finite"]);
}

#[test]
fn a_time_span_below_the_resolution_of_t0_is_rejected() {
    let doc = SEGMENT.replace(
        "terminal_time = { fixed = 4.0 }",
        "t0 = 1.7e9\nterminal_time = { fixed = 1700000004.0 }",
    );
    let (_, msg) = error(&doc, "boundary.t0");
    assert_contains(&msg, &["time span b - t0 = 4", "shift the time origin"]);
    // A million times the span is still resolved.
    let doc = SEGMENT.replace(
        "terminal_time = { fixed = 4.0 }",
        "t0 = 4e6\nterminal_time = { fixed = 4000010.0 }",
    );
    config::from_toml_str(&doc).unwrap();
}

// ---------------------------------------------------------------------------------------
// Defect 6: moments of inertia no rigid body has are accepted with a warning.

#[test]
fn inertias_that_violate_the_triangle_inequality_give_a_warning() {
    let p = config::from_toml_str(&with_line(BASE, "inertia =", "inertia = [1, 1, 5]")).unwrap();
    assert_eq!(
        p.warnings,
        vec![config::ConfigWarning::TriangleInequality {
            inertia: [1.0, 1.0, 5.0],
            axis: 2
        }]
    );
    let w = p.warnings[0].to_string();
    assert_eq!(p.warnings[0].field(), "body.inertia");
    assert_contains(
        &w,
        &[
            "`body.inertia`",
            "I3 = 5 exceeds I1 + I2 = 2",
            "no rigid body",
        ],
    );
    let p = config::from_toml_str(&with_line(BASE, "inertia =", "inertia = [7, 2, 3]")).unwrap();
    assert_contains(&p.warnings[0].to_string(), &["I1 = 7 exceeds I2 + I3 = 5"]);
    // Flat bodies (equality, also after rounding) and ordinary ones: no warning.
    for ok in [
        "[1, 2, 3]",
        "[0.1, 0.2, 0.3]",
        "[0.3, 0.1, 0.2]",
        "[2, 3, 4]",
    ] {
        let p = config::from_toml_str(&with_line(BASE, "inertia =", &format!("inertia = {ok}")))
            .unwrap();
        assert!(p.warnings.is_empty(), "{ok}: {:?}", p.warnings);
    }
}

#[test]
fn a_span_too_short_for_the_solvers_start_path_is_rejected() {
    // A constant desired path is finite at any span, but the solver starts from the
    // projected segment omega_a -> omega_b over [t0, b] (it used to fail later with "the
    // singular control xi_p is undefined at t = 0 (Property 3 fails there)").
    let doc = SEGMENT
        .replace(
            "terminal_time = { fixed = 4.0 }",
            "terminal_time = { fixed = 1e-300 }",
        )
        .replace("gamma = 1.0", "gamma = 0.0")
        .replace(
            "kind = \"segment\"",
            "kind = \"constant\"\nvalue = [3.0, 0.0, 0.0]",
        );
    let (_, msg) = error(&doc, "boundary.terminal_time");
    assert_contains(
        &msg,
        &[
            "the solver's start path",
            "not finite",
            "later terminal time",
        ],
    );
}

#[test]
fn an_energy_level_in_the_subnormal_range_is_rejected() {
    // <omega_a, I omega_a> = 1e-320 has ~4 significant bits: the on-ellipsoid check would
    // accept a 2e-4 mismatch.
    let doc = SEGMENT
        .replace("omega_a = [3.0, 0.0, 0.0]", "omega_a = [1e-160, 0.0, 0.0]")
        .replace(
            "omega_b = [1.0, 2.0, 0.0]",
            "omega_b = [1.0001e-160, 0.0, 0.0]",
        );
    let (_, msg) = error(&doc, "boundary.omega_a");
    assert_contains(&msg, &["kinetic energy", "rescale"]);
    let mut p = suslov::so3::paper::problem(1.0);
    p.omega_a = nalgebra::Vector3::new(1e-160, 0.0, 0.0);
    assert!(matches!(
        p.validate(),
        Err(suslov::so3::problem::ProblemError::EnergyOutOfRange { .. })
    ));
}

#[test]
fn a_start_from_the_desired_path_needs_gamma() {
    // The solver used to refuse this only once solving began.
    let doc = format!(
        "{}[solver]\nstart = \"desired\"\n",
        SEGMENT.replace("gamma = 1.0", "gamma = 0.0")
    );
    let (_, msg) = error(&doc, "solver.start");
    assert_contains(&msg, &["cost.gamma = 0", "\"segment\""]);
    config::from_toml_str(&doc.replace("\"desired\"", "\"segment\"")).unwrap();
}

#[test]
fn max_routes_is_bounded_and_reaches_the_solver() {
    for bad in [
        "max_routes = 0",
        "max_routes = 11",
        "max_routes = 100000000000",
    ] {
        let (_, msg) = error(&with_solver(bad), "solver.max_routes");
        assert!(msg.contains("[1, 10]"), "{bad}: {msg}");
    }
    let (_, msg) = error(&with_solver("max_routes = -1"), "solver.max_routes");
    assert!(!msg.is_empty());
    let loaded = suslov::config::from_toml_str(&with_solver("max_routes = 1")).expect("valid");
    assert_eq!(loaded.options.max_routes, 1);
    let loaded = suslov::config::from_toml_str(&with_solver("")).expect("valid");
    assert_eq!(
        loaded.options.max_routes,
        suslov::SolveOptions::default().max_routes
    );
}
