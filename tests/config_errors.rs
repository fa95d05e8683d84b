//! Every kind of bad problem file gives an error that names the field (its TOML path) and
//! says how to fix it; none panics.

use suslov::config::{self, ConfigError};

/// The paper's η = 1 problem file, the base every test modifies.
const BASE: &str = include_str!("../examples/paper_eta1.toml");

/// `BASE` with the first line starting with `key` (after indentation) replaced by
/// `replacement` (an empty replacement drops the line).
fn with_line(key: &str, replacement: &str) -> String {
    let mut found = false;
    let out: Vec<String> = BASE
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
    assert!(found, "no line starting with {key} in the base file");
    out.join("\n")
}

/// The error of `doc`, which must not load; checks that it names `field`.
fn error(doc: &str, field: &str) -> (ConfigError, String) {
    let e = match config::from_toml_str(doc) {
        Ok(p) => panic!("expected an error naming {field}, got {p:?}"),
        Err(e) => e,
    };
    let msg = e.to_string();
    assert_eq!(e.field(), Some(field), "{msg}");
    assert!(msg.contains(field), "message does not name {field}: {msg}");
    (e, msg)
}

fn assert_contains(msg: &str, words: &[&str]) {
    for w in words {
        assert!(msg.contains(w), "message lacks {w:?}: {msg}");
    }
}

#[test]
fn the_base_file_loads() {
    let p = config::from_toml_str(BASE).unwrap();
    assert_eq!(p.name, "paper_eta1");
    p.problem.validate().unwrap();
}

#[test]
fn missing_fields_and_sections_say_what_to_add() {
    let (e, msg) = error(&with_line("beta =", ""), "cost.beta");
    assert!(matches!(e, ConfigError::Missing { .. }));
    assert_contains(&msg, &["missing", "beta = ", "[cost]"]);

    let (_, msg) = error(&with_line("omega_a =", ""), "boundary.omega_a");
    assert_contains(&msg, &["missing", "omega_a = [x, y, z]"]);

    let (_, msg) = error(&with_line("terminal_time =", ""), "boundary.terminal_time");
    assert_contains(&msg, &["missing", "fixed = ", "free = true, guess = "]);

    let (_, msg) = error(&with_line("omega_b =", ""), "boundary.omega_b");
    assert_contains(&msg, &["missing", "\"desired_end\""]);

    let (_, msg) = error(&with_line("kind =", ""), "desired.kind");
    assert_contains(&msg, &["missing", "paper-spiral", "segment", "constant"]);

    let no_cost: String = BASE
        .lines()
        .filter(|l| {
            !["[cost]", "alpha", "beta", "gamma", "eta", "delta"]
                .iter()
                .any(|k| l.starts_with(k))
        })
        .collect::<Vec<_>>()
        .join("\n");
    let (_, msg) = error(&no_cost, "cost");
    assert_contains(
        &msg,
        &["missing", "add a [cost] table", "alpha, beta, gamma"],
    );

    let (_, msg) = error(&with_line("inertia =", ""), "body.inertia");
    assert_contains(&msg, &["missing", "inertia = [I1, I2, I3]"]);
}

#[test]
fn mistyped_values_keep_the_parser_message_with_line_and_field() {
    let (e, msg) = error(&with_line("beta =", "beta = \"x\""), "cost.beta");
    assert!(matches!(e, ConfigError::Toml { .. }));
    assert_contains(
        &msg,
        &[
            "line 15",
            "invalid type",
            "string \"x\"",
            "expected a number",
        ],
    );

    let (_, msg) = error(
        &with_line("inertia =", "inertia = [1.0, 2.0]"),
        "body.inertia",
    );
    assert_contains(&msg, &["has 2 entries, expected 3 (I1, I2, I3)"]);

    let (_, msg) = error(
        &with_line("omega_b =", "omega_b = \"desired-end\""),
        "boundary.omega_b",
    );
    assert_contains(
        &msg,
        &[
            "\"desired-end\"",
            "an array of 3 numbers or the string \"desired_end\"",
        ],
    );

    let (_, msg) = error(
        &with_line("terminal_time =", "terminal_time = { fixed = \"10\" }"),
        "boundary.terminal_time.fixed",
    );
    assert_contains(&msg, &["invalid type", "expected a number"]);

    // Integers are numbers too.
    let ints = with_line("inertia =", "inertia = [1, 2, 3]");
    assert_eq!(
        config::from_toml_str(&ints).unwrap().problem.inertia.diag(),
        nalgebra::Vector3::new(1.0, 2.0, 3.0)
    );
}

#[test]
fn unknown_keys_are_rejected_with_the_valid_ones() {
    let (e, msg) = error(&with_line("beta =", "bta = 0.1"), "cost.bta");
    assert!(matches!(e, ConfigError::Toml { .. }));
    assert_contains(
        &msg,
        &[
            "unknown field `bta`",
            "expected one of",
            "`beta`",
            "line 15",
        ],
    );

    let (_, msg) = error(
        &with_line("terminal_time =", "terminal_time = { fixd = 3.0 }"),
        "boundary.terminal_time.fixd",
    );
    assert_contains(&msg, &["unknown field `fixd`", "`fixed`"]);

    let (_, msg) = error(&with_line("[solver]", "[solvr]"), "solvr");
    assert_contains(&msg, &["unknown field `solvr`", "`solver`"]);

    // A key of another desired kind.
    let (_, msg) = error(
        &with_line("width =", "value = [5.0, 0.0, 0.0]"),
        "desired.value",
    );
    assert_contains(
        &msg,
        &[
            "not a parameter of kind = \"paper-spiral\"",
            "c, width, b_d",
            "remove it",
        ],
    );
}

#[test]
fn non_positive_inertia_is_rejected() {
    for (line, field, value) in [
        ("inertia = [1.0, -2.0, 3.0]", "body.inertia[1]", "-2"),
        ("inertia = [0.0, 2.0, 3.0]", "body.inertia[0]", "= 0"),
    ] {
        let (_, msg) = error(&with_line("inertia =", line), field);
        assert_contains(&msg, &[value, "must be > 0", "principal moment"]);
    }
}

#[test]
fn singular_weights_say_why() {
    for line in ["alpha = 0.0", "alpha = -1.0"] {
        let (e, msg) = error(&with_line("alpha =", line), "cost.alpha");
        assert!(matches!(e, ConfigError::Singular { .. }));
        assert_contains(&msg, &["singular", "length of xi", "give a value > 0"]);
    }
    let (_, msg) = error(&with_line("beta =", "beta = 0.0"), "cost.beta");
    assert_contains(
        &msg,
        &["singular", "section 4.4", "give a value > 0", "beta = 0.1"],
    );

    for key in ["gamma", "eta", "delta"] {
        let (_, msg) = error(
            &with_line(&format!("{key} ="), &format!("{key} = -0.5")),
            &format!("cost.{key}"),
        );
        assert_contains(
            &msg,
            &["-0.5", "must be >= 0", "use 0 to switch the term off"],
        );
    }
}

#[test]
fn nan_and_infinity_are_rejected_everywhere() {
    let cases = [
        ("gamma =", "gamma = nan", "cost.gamma"),
        ("beta =", "beta = inf", "cost.beta"),
        ("alpha =", "alpha = -inf", "cost.alpha"),
        ("t0 =", "t0 = nan", "boundary.t0"),
        (
            "omega_a =",
            "omega_a = [5.0, nan, 0.0]",
            "boundary.omega_a[1]",
        ),
        (
            "omega_b =",
            "omega_b = [inf, 0.0, 0.0]",
            "boundary.omega_b[0]",
        ),
        ("inertia =", "inertia = [1.0, 2.0, inf]", "body.inertia[2]"),
        (
            "terminal_time =",
            "terminal_time = { free = true, guess = inf }",
            "boundary.terminal_time.guess",
        ),
        (
            "terminal_time =",
            "terminal_time = { fixed = nan }",
            "boundary.terminal_time.fixed",
        ),
        ("c =", "c = nan", "desired.c"),
        ("b_d =", "b_d = -inf", "desired.b_d"),
        ("tolerance =", "tolerance = nan", "solver.tolerance"),
    ];
    for (key, line, field) in cases {
        let (e, msg) = error(&with_line(key, line), field);
        assert!(matches!(e, ConfigError::NotFinite { .. }), "{msg}");
        assert_contains(&msg, &["not a finite number", "give a finite value"]);
    }
}

#[test]
fn omega_b_off_the_ellipsoid_says_by_how_much_and_suggests_the_projection() {
    // The paper's rounded Omega_b.
    let (e, msg) = error(
        &with_line("omega_b =", "omega_b = [2.7541, -2.3109, -1.4983]"),
        "boundary.omega_b",
    );
    assert!(matches!(e, ConfigError::OffEllipsoid { .. }));
    assert_contains(
        &msg,
        &[
            "off omega_a's energy ellipsoid by 1.172e-5",
            "radial projection onto the ellipsoid is [2.75408",
            "use that (or change omega_a)",
        ],
    );
    // The suggested projection is accepted.
    let fixed = with_line(
        "omega_b =",
        "omega_b = [2.7540838556077576, -2.310886453623313, -1.4982912170426284]",
    );
    config::from_toml_str(&fixed).unwrap();
}

#[test]
fn a_desired_path_that_does_not_start_at_omega_a_is_rejected() {
    let (e, msg) = error(
        &with_line("omega_a =", "omega_a = [0.0, 5.0, 0.0]"),
        "desired",
    );
    assert!(matches!(e, ConfigError::DesiredStart { .. }));
    assert_contains(
        &msg,
        &[
            "starts at Omega_d(t0) = [7.07",
            "boundary.omega_a",
            "differ by 8.660e0",
            "1.732e0 relative",
            "set omega_a = Omega_d(t0)",
        ],
    );
    // A constant path away from omega_a, with gamma > 0.
    let doc = BASE
        .replace(
            "kind = \"paper-spiral\"",
            "kind = \"constant\"\nvalue = [5.0, 1e-3, 0.0]",
        )
        .replace("c = 10.0\n", "")
        .replace("width = 0.01\n", "")
        .replace("b_d = 10.0\n", "")
        .replace("omega_b = \"desired_end\"", "omega_b = [5.0, 0.0, 0.0]");
    let (_, msg) = error(&doc, "desired");
    assert_contains(
        &msg,
        &[
            "kind = \"constant\"",
            "2.000e-4 relative",
            "value = omega_a",
        ],
    );
    // With gamma = 0 the path is not part of the cost and not checked.
    config::from_toml_str(&doc.replace("gamma = 1.0", "gamma = 0.0")).unwrap();
}

#[test]
fn zero_vectors_where_a_direction_is_needed() {
    let (e, msg) = error(
        &with_line("omega_a =", "omega_a = [0.0, 0.0, 0.0]"),
        "boundary.omega_a",
    );
    assert!(matches!(e, ConfigError::ZeroVector { .. }));
    assert_contains(
        &msg,
        &["[0, 0, 0]", "kinetic energy", "give a nonzero vector"],
    );
}

#[test]
fn terminal_time_must_be_after_t0_and_fixed_or_free() {
    for b in ["0.0", "-1.0"] {
        let (e, msg) = error(
            &with_line(
                "terminal_time =",
                &format!("terminal_time = {{ fixed = {b} }}"),
            ),
            "boundary.terminal_time.fixed",
        );
        assert!(matches!(e, ConfigError::TerminalTime { .. }));
        assert_contains(
            &msg,
            &["must be greater than boundary.t0 = 0", "later time"],
        );
    }
    let (_, msg) = error(
        &with_line(
            "terminal_time =",
            "terminal_time = { free = true, guess = -3.0 }",
        ),
        "boundary.terminal_time.guess",
    );
    assert_contains(&msg, &["-3 must be greater than boundary.t0"]);
    let (_, msg) = error(
        &with_line(
            "terminal_time =",
            "terminal_time = { free = true, fixed = 3.0 }",
        ),
        "boundary.terminal_time",
    );
    assert_contains(
        &msg,
        &["either { fixed = b } or { free = true, guess = b }, not both"],
    );
    let (_, msg) = error(
        &with_line("terminal_time =", "terminal_time = { free = false }"),
        "boundary.terminal_time.fixed",
    );
    assert_contains(&msg, &["free = false needs the fixed terminal time"]);
    // t0 moves the bound.
    let (_, msg) = error(
        &with_line("t0 =", "t0 = 20.0").replace("b_d = 10.0", "b_d = 25.0"),
        "boundary.terminal_time.guess",
    );
    assert_contains(&msg, &["10 must be greater than boundary.t0 = 20"]);
}

#[test]
fn desired_kinds_unknown_or_misparametrized() {
    let (_, msg) = error(&with_line("kind =", "kind = \"spiral\""), "desired.kind");
    assert_contains(
        &msg,
        &[
            "unknown kind \"spiral\"",
            "\"paper-spiral\", \"segment\", \"constant\", \"samples\" or \"expression\"",
        ],
    );

    let (_, msg) = error(&with_line("width =", "width = 0.0"), "desired.width");
    assert_contains(&msg, &["must be > 0", "sigmoid"]);
}

#[test]
fn segment_paths_check_their_end_points() {
    let segment = "[body]\ninertia = [1.0, 2.0, 3.0]\n[boundary]\nomega_a = [3.0, 0.0, 0.0]\n\
                   omega_b = [1.0, 2.0, 0.0]\nterminal_time = { fixed = 4.0 }\n\
                   [cost]\nalpha = 1.0\nbeta = 0.1\ngamma = 1.0\n[desired]\nkind = \"segment\"\n";
    let p = config::from_toml_str(segment).unwrap();
    assert_eq!(p.problem.desired.value(4.0), p.problem.omega_b);
    let (_, msg) = error(&format!("{segment}to = [1.0, 2.0, 0.1]\n"), "desired.to");
    assert_contains(
        &msg,
        &["off omega_a's energy ellipsoid", "radial projection"],
    );
    let (_, msg) = error(
        &segment.replace("omega_b = [1.0, 2.0, 0.0]", "omega_b = \"desired_end\""),
        "desired.to",
    );
    assert_contains(&msg, &["missing", "add to = [x, y, z]"]);
    let (_, msg) = error(
        &format!("{segment}interval = [2.0, 1.0]\n"),
        "desired.interval",
    );
    assert_contains(&msg, &["start < end"]);
    let (_, msg) = error(&format!("{segment}to = [-3.0, 0.0, 0.0]\n"), "desired.to");
    assert_contains(&msg, &["origin", "not opposite"]);
    // A free terminal time without a guess takes the segment's end time.
    let free = segment.replace("{ fixed = 4.0 }", "{ free = true }");
    let (_, msg) = error(&free, "desired.interval");
    assert_contains(&msg, &["missing", "interval = [t_start, t_end]"]);
    let p = config::from_toml_str(&format!("{free}interval = [0.0, 3.0]\n")).unwrap();
    assert_eq!(
        p.problem.terminal,
        suslov::so3::problem::TerminalTime::Free { guess: 3.0 }
    );
}

#[test]
fn solver_options_are_checked() {
    let (_, msg) = error(
        &with_line("tolerance =", "tolerance = 0.0"),
        "solver.tolerance",
    );
    assert_contains(&msg, &["must lie between 1e-12 and 1e-4"]);
    let (_, msg) = error(
        &with_line("tolerance =", "initial_intervals = 1"),
        "solver.initial_intervals",
    );
    assert_contains(&msg, &["must be >= 2"]);
    let (_, msg) = error(
        &with_line("tolerance =", "max_nodes = 100"),
        "solver.max_nodes",
    );
    assert_contains(&msg, &["must exceed solver.initial_intervals = 100"]);
    let (_, msg) = error(
        &with_line("tolerance =", "initial_intervals = -5"),
        "solver.initial_intervals",
    );
    assert_contains(&msg, &["invalid value: integer `-5`"]);
    let p = config::from_toml_str(&with_line(
        "tolerance =",
        "tolerance = 1e-7\ncontinuation_tolerance = 1e-5\nbeta_m = 2e-3\ninitial_intervals = 50\nmax_nodes = 5000",
    ))
    .unwrap();
    let o = p.options;
    assert_eq!(
        (
            o.tol,
            o.continuation_tol,
            o.beta_m,
            o.initial_intervals,
            o.max_nodes
        ),
        (1e-7, 1e-5, Some(2e-3), 50, 5000)
    );
}

#[test]
fn file_errors_carry_the_file_name() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("config_errors");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad_beta.toml");
    std::fs::write(&path, with_line("beta =", "beta = 0.0")).unwrap();
    let e = config::load(&path).unwrap_err();
    assert_eq!(e.field(), Some("cost.beta"));
    let msg = e.to_string();
    assert!(
        msg.starts_with(&format!("{}: `cost.beta` = 0", path.display())),
        "{msg}"
    );

    let missing = dir.join("does_not_exist.toml");
    let e = config::load(&missing).unwrap_err();
    assert!(matches!(e, ConfigError::Read { .. }));
    assert!(e.to_string().contains("cannot read"), "{e}");
    assert!(e.to_string().contains("does_not_exist.toml"), "{e}");

    // The case name defaults to the file stem.
    let good = dir.join("my_case.toml");
    std::fs::write(&good, BASE.replace("name = \"paper_eta1\"", "")).unwrap();
    assert_eq!(config::load(&good).unwrap().name, "my_case");
}

#[test]
fn the_command_line_prints_the_error_and_fails() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("config_errors_cli");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(&path, with_line("alpha =", "alpha = 0.0")).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_suslov"))
        .args(["solve", path.to_str().unwrap(), "--out"])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert!(
        stderr.contains("`cost.alpha` = 0 makes the problem singular"),
        "{stderr}"
    );
    assert!(
        !dir.join("out").exists(),
        "nothing is written for an invalid file"
    );
}

#[test]
fn an_energy_level_that_overflows_is_an_error_not_a_panic() {
    let (_, msg) = error(
        &with_line("omega_a =", "omega_a = [1e200, 0.0, 0.0]"),
        "boundary.omega_a",
    );
    assert_contains(
        &msg,
        &["kinetic energy", "inf", "rescale omega_a or body.inertia"],
    );
    let (_, msg) = error(
        &with_line("omega_a =", "omega_a = [1e-170, 0.0, 0.0]"),
        "boundary.omega_a",
    );
    assert_contains(&msg, &["0e0", "rescale"]);
    // The library's own check (it used to panic in `ellipsoid()`).
    let mut p = suslov::so3::paper::problem(1.0);
    p.omega_a = nalgebra::Vector3::new(1e200, 0.0, 0.0);
    let e = p.validate().unwrap_err();
    assert!(
        matches!(
            e,
            suslov::so3::problem::ProblemError::EnergyOutOfRange { .. }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("rescale omega_a"), "{e}");
}

/// A samples problem around `csv` (written next to the problem file).
fn samples_problem(name: &str, csv: &str) -> Result<config::LoadedProblem, ConfigError> {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("config_samples");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(format!("{name}.csv")), csv).unwrap();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, samples_doc(&format!("{name}.csv"))).unwrap();
    config::load(&path)
}

/// `BASE` with `[desired] kind = "samples", file = <file>`.
fn samples_doc(file: &str) -> String {
    BASE.replace(
        "kind = \"paper-spiral\"",
        &format!("kind = \"samples\"\nfile = \"{file}\""),
    )
    .replace("c = 10.0\n", "")
    .replace("width = 0.01\n", "")
    .replace("b_d = 10.0\n", "")
}

#[test]
fn samples_files_are_checked_line_by_line() {
    let good = "t,w1,w2,w3\n0,10,0,0\n5,10,1,2\n10,10,-1,3\n";
    let p = samples_problem("good", good).unwrap();
    // Projected onto E: starts at omega_a, ends at the projected last sample, guess = 10.
    assert!((p.problem.desired.value(0.0) - p.problem.omega_a).norm() < 1e-14);
    assert_eq!(
        p.problem.terminal,
        suslov::so3::problem::TerminalTime::Free { guess: 10.0 }
    );
    assert!(
        p.problem
            .ellipsoid()
            .relative_mismatch(&p.problem.omega_b)
            .abs()
            < 1e-14
    );

    let cases = [
        ("short", "t,a,b,c\n0,10,0,0\n", "needs at least 2 samples"),
        (
            "columns",
            "0,10,0,0\n1,10,0\n",
            "line 2: expected 4 comma-separated numbers",
        ),
        (
            "text",
            "0,10,0,0\n1,10,x,0\n",
            "line 2: invalid float literal",
        ),
        (
            "order",
            "0,10,0,0\n2,10,0,1\n1,10,1,0\n",
            "line 3: t = 1 does not increase",
        ),
        (
            "nan",
            "0,10,0,0\n1,NaN,0,0\n",
            "line 2: NaN is not a finite number",
        ),
        (
            "zero",
            "0,10,0,0\n1,0,0,0\n",
            "line 2: Omega_d = 0 cannot be projected",
        ),
        (
            "late",
            "1,10,0,0\n2,10,0,1\n",
            "cover [1, 2], which must contain boundary.t0 = 0",
        ),
    ];
    for (name, csv, words) in cases {
        let e = samples_problem(name, csv).unwrap_err();
        assert_eq!(e.field(), Some("desired.file"), "{e}");
        let msg = e.to_string();
        assert_contains(&msg, &["`desired.file`", &format!("{name}.csv"), words]);
    }
    let (_, msg) = error(&samples_doc("nope.csv"), "desired.file");
    assert_contains(&msg, &["nope.csv", "cannot read it"]);
    let (_, msg) = error(
        &samples_doc("x.csv").replace("file = \"x.csv\"", ""),
        "desired.file",
    );
    assert_contains(&msg, &["missing", "file = \"omega_d.csv\""]);
    let (_, msg) = error(
        &BASE.replace("kind = \"paper-spiral\"", "kind = \"samples\""),
        "desired.c",
    );
    assert_contains(
        &msg,
        &["not a parameter of kind = \"samples\"", "its keys: file"],
    );
    // Not starting at omega_a (the first sample's ray is not omega_a's).
    let e = samples_problem("off", "0,1,1,0\n1,10,0,0\n").unwrap_err();
    assert_eq!(e.field(), Some("desired"), "{e}");
    assert_contains(&e.to_string(), &["kind = \"samples\"", "first sample"]);
}

#[test]
fn the_start_override_is_parsed_and_checked() {
    let base = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/segment.toml"),
    )
    .expect("example");
    let with_start = |value: &str| {
        if base.contains("[solver]") {
            base.replace("[solver]", &format!("[solver]\nstart = {value}"))
        } else {
            format!("{base}\n[solver]\nstart = {value}\n")
        }
    };
    let ok = suslov::config::from_toml_str(&with_start("\"segment\"")).expect("valid start");
    assert_eq!(ok.options.start, suslov::so3::solve::StartStrategy::Segment);
    let err =
        suslov::config::from_toml_str(&with_start("\"sideways\"")).expect_err("unknown start");
    let msg = err.to_string();
    assert!(
        msg.contains("solver.start") && msg.contains("\"segment\""),
        "{msg}"
    );
}

/// A value of the wrong TOML type is reported in the file's words: no Rust type names
/// (`struct TerminalTimeSpec`, `usize`, `f64`, `a sequence`) in the message, for so(3) files and
/// for the `[solver]` table of the other models' files.
#[test]
fn wrong_types_are_named_without_rust_type_names() {
    let rust_names = [
        "struct",
        "Spec",
        "Section",
        "ProblemFile",
        "usize",
        "u64",
        "i64",
        "f64",
        "sequence",
    ];
    let cases = [
        (
            with_line("terminal_time", "terminal_time = 5.0"),
            "a table: { fixed = b }",
        ),
        (
            with_line("terminal_time", "terminal_time = \"free\""),
            "a table",
        ),
        (
            BASE.replace("[body]\ninertia = [1.0, 2.0, 3.0]", "body = 3"),
            "a table [body]",
        ),
        (
            format!(
                "solver = [1, 2]\n{}",
                BASE.replace("[solver]\ntolerance = 1e-8", "")
            ),
            "a table [solver]",
        ),
        (format!("{BASE}\nmax_nodes = -1\n"), "a whole number >= 0"),
        (format!("{BASE}\nmax_nodes = 1.5\n"), "a whole number >= 0"),
        (
            format!("{BASE}\nmax_routes = \"many\"\n"),
            "a whole number >= 0",
        ),
        (with_line("alpha", "alpha = \"one\""), "a number"),
        (with_line("c =", "c = [1.0]"), "a number"),
    ];
    for (doc, words) in cases {
        let e = config::from_toml_str(&doc).expect_err(words);
        let msg = e.to_string();
        for name in rust_names {
            assert!(!msg.contains(name), "`{name}` in: {msg}");
        }
        assert!(msg.contains(words), "`{words}` not in: {msg}");
    }
    // Another model's [solver] table, read by the same rules.
    let se2 = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/se2_sleigh.toml"),
    )
    .unwrap();
    let doc = format!("{se2}\n[solver]\ninitial_intervals = -3\n");
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("config_errors_types");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("se2.toml");
    std::fs::write(&path, doc).unwrap();
    let config::Loaded::Other(file) = config::load_any(&path).unwrap().0 else {
        panic!("an se2 file")
    };
    let msg = file
        .build::<suslov::model::se2::Se2>()
        .unwrap_err()
        .to_string();
    assert!(msg.contains("a whole number >= 0"), "{msg}");
    assert!(!msg.contains("usize"), "{msg}");
}
