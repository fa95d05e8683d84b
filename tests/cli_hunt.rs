//! Hostile inputs found by hand (issue #10, a later round), end to end through the binary:
//! each test is one input that once hung, panicked or answered wrongly.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The binary under test; `SUSLOV_BIN` runs the suite against another build (to see a
/// test fail on the build before its fix).
fn bin() -> String {
    std::env::var("SUSLOV_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_suslov").to_string())
}

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli_hunt_{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs the binary with a deadline: a run still going after `secs` is killed and the test
/// fails (a hang is a defect, not a slow test).
fn run(args: &[&str], secs: u64) -> Output {
    let mut child = Command::new(bin())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > Duration::from_secs(secs) {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "suslov {args:?} still running after {secs} s; stderr: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn extreme_moments_of_inertia_never_hang_the_rank_test() {
    // I = 1e200 overflowed the generated fields to NaN, and the SVD of a NaN matrix never
    // returned; the fields do not depend on the scale of I, which is now divided out.
    for args in [
        &[
            "controllability",
            "--inertia",
            "1e200,1e200,1e200",
            "--omega",
            "5,0,0",
            "--xi",
            "0,1,0",
        ][..],
        &["controllability", "--inertia", "1e300,2e300,3e300"][..],
    ] {
        let o = run(args, 60);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
        let table = String::from_utf8_lossy(&o.stdout);
        assert!(
            table.contains("rank V = 4 = dim M at all"),
            "{args:?}: {table}"
        );
    }
    // Moments 1e600 apart: no state of M is representable (the sampler rejected every draw
    // forever); at one given state the fields overflow. Both are errors naming --inertia.
    for args in [
        &["controllability", "--inertia", "1e-300,1,1e300"][..],
        &[
            "controllability",
            "--inertia",
            "1e-300,1,1e300",
            "--omega",
            "5,0,0",
            "--xi",
            "0,1,0",
        ][..],
    ] {
        let o = run(args, 60);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(
            e.contains("--inertia") || e.contains("I = diag(1e-300, 1, 1e300)"),
            "{args:?}: {e}"
        );
        assert!(
            !e.contains("NaN") && !e.contains("inf") && e.len() < 1000,
            "{args:?}: {e}"
        );
    }
}

#[test]
fn a_subnormal_xi_is_not_called_zero_and_numbers_are_not_printed_in_full() {
    // xi = 5e-324 was refused as "xi != 0" (its norm underflows); and `{}` of 1e300 or
    // 5e-324 prints hundreds of digits.
    let o = run(
        &[
            "controllability",
            "--omega",
            "5e-324,0,0",
            "--xi",
            "0,5e-324,0",
        ],
        60,
    );
    // Now evaluated at the state rescaled by exact powers of two: on M, rank 4.
    let e = stderr(&o);
    let table = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{e}");
    assert!(!e.contains("xi != 0"), "{e}");
    assert!(table.contains("4.9e-324"), "{table}");
    assert!(
        table.contains("rank V = 4 = dim M at all 1 states"),
        "{table}"
    );
    let o = run(
        &["controllability", "--omega", "1e300,0,0", "--xi", "0,1,0"],
        60,
    );
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.lines().all(|l| l.len() < 400), "{table}");
}

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

#[test]
fn a_users_file_in_the_output_directory_is_never_overwritten() {
    // A `trajectory.csv` of the user's (no manifest lists it) was silently replaced by the
    // run's; now the run refuses before solving, naming the file, and leaves it as it was.
    let dir = scratch("users_file");
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("trajectory.csv"), b"mine").unwrap();
    let config = example("segment.toml");
    let args = [
        "solve",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    let o = run(&args, 120);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("trajectory.csv") && e.contains("--out"), "{e}");
    assert_eq!(std::fs::read(out.join("trajectory.csv")).unwrap(), b"mine");
    assert!(!out.join("summary.json").exists());
    // Moved away: the run goes through, and the next run replaces its own files.
    std::fs::remove_file(out.join("trajectory.csv")).unwrap();
    assert_eq!(run(&args, 120).status.code(), Some(0));
    assert_eq!(run(&args, 120).status.code(), Some(0));
}

#[test]
fn a_symbolic_link_in_the_output_directory_does_not_lead_the_run_out_of_it() {
    // `DIR/eta_1 -> ../elsewhere`: the paper's first case was written through the link,
    // outside DIR; a file `DIR/eta_1` failed only after the first case was solved.
    let dir = scratch("symlink_case_dir");
    let out = dir.join("out");
    let elsewhere = dir.join("elsewhere");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::os::unix::fs::symlink(&elsewhere, out.join("eta_1")).unwrap();
    let o = run(&["paper", "--out", out.to_str().unwrap(), "-q"], 120);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("eta_1") && e.contains("--out"), "{e}");
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0);
    let _ = std::fs::remove_file(out.join("eta_1"));
    std::fs::write(out.join("eta_1"), b"mine").unwrap();
    let start = Instant::now();
    let o = run(&["paper", "--out", out.to_str().unwrap(), "-q"], 120);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        start.elapsed() < Duration::from_secs(2),
        "refused only after solving"
    );
    assert_eq!(std::fs::read(out.join("eta_1")).unwrap(), b"mine");
}

#[test]
fn certify_help_states_the_exit_status_it_returns() {
    // The help said "2: some case is not" certified, while the binary returns 3 for that
    // (2 is clap's malformed command line; cli_faults checks the 3).
    for args in [&["certify", "--help"][..], &["--help"][..]] {
        let o = run(args, 30);
        let help = String::from_utf8_lossy(&o.stdout);
        assert!(!help.contains("2: some case is not"), "{help}");
        assert!(help.contains("3: some case is not"), "{help}");
    }
}

#[test]
fn certify_json_never_replaces_a_special_file_or_another_runs_output() {
    use std::os::unix::fs::FileTypeExt;
    // `--json /dev/null` (or `/dev/full`) was accepted and, after the work, the atomic
    // rename replaced the device with a regular file (as root). A FIFO stands in for the
    // device here, so that this test cannot break the machine it runs on.
    let dir = scratch("certify_json");
    let fifo = dir.join("fifo");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let config = example("segment.toml");
    let o = certify_json(&config, &fifo);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("fifo") && e.contains("regular file"), "{e}");
    assert!(o.stdout.is_empty(), "refused before the work");
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    // Into the output directory of a solve run: its summary.json was replaced.
    let out = dir.join("out");
    let o = run(
        &[
            "-q",
            "solve",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        120,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let summary = std::fs::read(out.join("summary.json")).unwrap();
    let target = out.join("summary.json");
    let o = certify_json(&config, &target);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("--json-file") && e.contains("output directory"),
        "{e}"
    );
    assert_eq!(std::fs::read(&target).unwrap(), summary);
    // A file of another name there is the user's: allowed, and the next run keeps it.
    let cert = out.join("certificate.json");
    let o = certify_json(&config, &cert);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = run(
        &[
            "-q",
            "solve",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        120,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(cert.exists());
}

/// A fixed-time segment problem with `omega_a = s·[3, 0, 0]`, `omega_b = s·[1, 2, 0]`.
/// `suslov -q certify CONFIG --json-file TARGET`.
fn certify_json(config: &Path, target: &Path) -> Output {
    run(
        &[
            "-q",
            "certify",
            config.to_str().unwrap(),
            "--json-file",
            target.to_str().unwrap(),
        ],
        120,
    )
}

fn scaled_segment(dir: &Path, s: &str, b: &str) -> PathBuf {
    let path = dir.join(format!("scaled_{s}_{b}.toml"));
    std::fs::write(
        &path,
        format!(
            "[body]\ninertia = [1.0, 2.0, 3.0]\n[boundary]\nomega_a = [3{s}, 0, 0]\n\
             omega_b = [1{s}, 2{s}, 0]\nterminal_time = {{ fixed = {b} }}\n[cost]\nalpha = 1\n\
             beta = 0.1\ngamma = 1\neta = 0.1\ndelta = 0.1\n[desired]\nkind = \"segment\"\n"
        ),
    )
    .unwrap();
    path
}

#[test]
fn a_tiny_omega_is_blamed_on_omega_a_not_on_the_terminal_time() {
    // |omega_a| = 3e-40 over a 4 s span: the projection onto the tiny ellipsoid overflows,
    // and the message said "`boundary.terminal_time` ... give a later terminal time".
    let dir = scratch("tiny_omega");
    for s in ["e-40", "e-150"] {
        let config = scaled_segment(&dir, s, "4.0");
        let out = dir.join("out");
        let o = run(
            &[
                "-q",
                "solve",
                config.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            60,
        );
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{e}");
        assert!(
            e.contains("`boundary.omega_a`") && e.contains("rescale"),
            "{e}"
        );
        assert!(!e.contains("`boundary.terminal_time`"), "{e}");
    }
    // A span of 1e-120 at the usual scale is still the terminal time's fault.
    let config = scaled_segment(&dir, "e0", "1e-120");
    let out = dir.join("out");
    let o = run(
        &[
            "-q",
            "solve",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        60,
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("`boundary.terminal_time`"), "{e}");
}

#[test]
fn a_samples_row_that_is_not_numbers_says_what_a_row_must_be() {
    // Tab-separated, hexadecimal, a trailing comma, a header in the middle: the message was
    // the float parser's ("invalid float literal in ...") without what was expected.
    let dir = scratch("samples_rows");
    let spiral = std::fs::read_to_string(example("spiral_samples.toml")).unwrap();
    let rows = std::fs::read_to_string(example("spiral_samples.csv")).unwrap();
    let variants = [
        (
            "tabs",
            rows.replace(',', "\t").replacen("t\tomega1", "t,omega1", 1),
        ),
        ("hex", rows.replacen("\n0.25,", "\n0x10,", 1)),
        ("trailing", rows.replacen("\n0.25,10.0", "\n0.25,10.0,", 1)),
        (
            "header",
            rows.replacen("\n0.25,", "\nt,omega1,omega2,omega3\n0.25,", 1),
        ),
    ];
    for (name, csv) in variants {
        std::fs::write(dir.join(format!("{name}.csv")), csv).unwrap();
        let config = dir.join(format!("{name}.toml"));
        std::fs::write(
            &config,
            spiral.replace("spiral_samples.csv", &format!("{name}.csv")),
        )
        .unwrap();
        let out = dir.join("out");
        let o = run(
            &[
                "-q",
                "solve",
                config.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            60,
        );
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{name}: {e}");
        assert!(
            e.contains("`desired.file`") && e.contains("separated by commas"),
            "{name}: {e}"
        );
    }
}

#[test]
fn a_long_output_path_is_not_echoed_whole() {
    // A 300-byte path component: the message quoted all of it (the cap on echoed input is
    // ~200 characters).
    let dir = scratch("long_out");
    let out = dir.join("a".repeat(300));
    let config = example("segment.toml");
    let o = run(
        &[
            "-q",
            "solve",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        60,
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("File name too long") && e.chars().count() < 320,
        "{e}"
    );
}

#[test]
fn solving_the_problem_file_of_the_output_directory_keeps_it() {
    // `solve DIR/problem.toml --out DIR` (no manifest yet): the input is its own copy; it
    // must neither stop the run nor become a file the next run removes.
    let dir = scratch("problem_in_out");
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let text = std::fs::read(example("segment.toml")).unwrap();
    let config = out.join("problem.toml");
    std::fs::write(&config, &text).unwrap();
    let args = [
        "-q",
        "solve",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    for _ in 0..2 {
        let o = run(&args, 120);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert_eq!(std::fs::read(&config).unwrap(), text);
    }
    let manifest = std::fs::read_to_string(out.join(".suslov-manifest")).unwrap();
    assert!(!manifest.contains("problem.toml"), "{manifest}");
    // The copy an earlier run wrote, solved in place: removed with that run's files, then
    // written again (never lost).
    let other = dir.join("other");
    let copy = other.join("problem.toml");
    let seg = example("segment.toml");
    let o = run(
        &[
            "-q",
            "solve",
            seg.to_str().unwrap(),
            "--out",
            other.to_str().unwrap(),
        ],
        120,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let written = std::fs::read(&copy).unwrap();
    let o = run(
        &[
            "-q",
            "solve",
            copy.to_str().unwrap(),
            "--out",
            other.to_str().unwrap(),
        ],
        120,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read(&copy).unwrap(), written);
}

/// Writes `text` to `dir/name` and returns the path as a string.
fn write_file(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

const SO4_TINY_J: &str = r#"model = "so4"
[body]
J1 = 1e-80
J2 = 2e-80
J3 = 3e-80
J4 = 4e-80
[boundary]
omega_a = [2.0, 0.0, 0.0, 0.0, 0.0, 1.0]
omega_b = [0.0, 1.3451854182690985, 0.0, 1.3451854182690985, 0.6725927091345493, 0.0]
terminal_time = { fixed = 3.0 }
[cost]
alpha = 1.0
beta = 0.1
gamma = 1.0
eta = 0.1
[desired]
kind = "segment"
"#;

#[test]
fn a_generic_model_far_from_unit_energy_is_refused_up_front_with_the_scale_named() {
    // so4 with J ~ 1e-80 kept the direct start's SQP busy for minutes (killed at 180 s);
    // Omega ~ 1e-100 printed "min |...| = NaN", Omega ~ 1e100 refused a valid start. The
    // motion depends on the inertia only up to a factor: the scale is the user's to fix.
    let dir = scratch("generic_scale");
    let tiny = write_file(&dir, "tiny_j.toml", SO4_TINY_J);
    let huge = write_file(
        &dir,
        "huge_omega.toml",
        &SO4_TINY_J
            .replace("1e-80", "1")
            .replace("2e-80", "2")
            .replace("3e-80", "3")
            .replace("4e-80", "4")
            .replace(
                "[2.0, 0.0, 0.0, 0.0, 0.0, 1.0]",
                "[2e100, 0, 0, 0, 0, 1e100]",
            ),
    );
    for file in [&tiny, &huge] {
        let out = dir.join("out");
        let o = run(&["-q", "solve", file, "--out", out.to_str().unwrap()], 60);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{file}: {e}");
        assert!(
            e.contains("boundary.omega_a") && e.contains("twice the kinetic energy"),
            "{file}: {e}"
        );
        assert!(!e.contains("NaN") && e.len() < 1500, "{file}: {e}");
        assert!(
            !out.exists(),
            "{file}: an output directory after an input error"
        );
    }
}

#[test]
fn certify_refuses_a_json_file_that_is_its_own_problem_file() {
    // `certify copy.toml --json-file copy.toml` replaced the problem with the JSON, exit 0.
    let dir = scratch("json_is_config");
    let src = std::fs::read_to_string(example("segment.toml")).unwrap();
    let file = write_file(&dir, "copy.toml", &src);
    let link = dir.join("link.toml");
    std::os::unix::fs::symlink(&file, &link).unwrap();
    for json in [file.clone(), link.display().to_string()] {
        let o = run(&["-q", "certify", &file, "--json-file", &json], 60);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{json}: {e}");
        assert!(
            e.contains("--json-file") && e.contains("problem file"),
            "{e}"
        );
        assert_eq!(std::fs::read_to_string(&file).unwrap(), src, "{json}");
    }
}

#[test]
fn controllability_along_refuses_the_options_it_would_ignore() {
    // --inertia, --omega-a, --samples and --seed were accepted with --along and ignored.
    for extra in [
        &["--inertia", "1,1,50"][..],
        &["--omega-a", "1,0,0"][..],
        &["--samples", "5"][..],
        &["--seed", "7"][..],
    ] {
        let mut args = vec!["controllability", "--along", "examples/segment.toml"];
        args.extend_from_slice(extra);
        let o = run(&args, 60);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {e}");
        assert!(
            e.contains(extra[0]) && e.contains("--along"),
            "{extra:?}: {e}"
        );
    }
}

const EXPRESSION: &str = r#"[body]
inertia = [1.0, 2.0, 3.0]
[boundary]
omega_a = [3.0, 0.0, 0.0]
omega_b = "desired_end"
terminal_time = { fixed = 4.0 }
[cost]
alpha = 1.0
beta = 0.1
gamma = 1.0
eta = 0.1
[desired]
kind = "expression"
components = ["3 cos(0.3 t)", "3 sin(0.3 t) / sqrt(2)", "0"]
end_time = 4.0
"#;

#[test]
fn expression_constants_a_formula_cannot_use_and_end_times_before_t0_are_errors() {
    // `constants = { pi = 10 }` was accepted and ignored (the built-in won), and so were
    // names no formula can spell; `end_time = -1` before t0 = 0 converged on Omega_d(-1).
    let dir = scratch("expression_names");
    let cases: [(&str, &str, &str); 7] = [
        (
            "constants = { pi = 10 }",
            "desired.constants.pi",
            "built-in",
        ),
        ("constants = { t = 1.0 }", "desired.constants.t", "built-in"),
        (
            "constants = { sin = 1 }",
            "desired.constants.sin",
            "built-in",
        ),
        (
            "constants = { \"a b\" = 1 }",
            "desired.constants.a b",
            "not a name",
        ),
        (
            "constants = { \"\" = 1 }",
            "desired.constants.",
            "not a name",
        ),
        ("end_time = -1.0", "desired.end_time", "after t0"),
        ("end_time = 0.0", "desired.end_time", "after t0"),
    ];
    for (i, (line, field, why)) in cases.iter().enumerate() {
        let text = if line.starts_with("end_time") {
            EXPRESSION.replace("end_time = 4.0", line)
        } else {
            format!("{EXPRESSION}{line}\n")
        };
        let file = write_file(&dir, &format!("e{i}.toml"), &text);
        let out = dir.join(format!("out{i}"));
        let o = run(&["-q", "solve", &file, "--out", out.to_str().unwrap()], 60);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{line}: {e}");
        assert!(e.contains(field) && e.contains(why), "{line}: {e}");
    }
    // A usable constant still works.
    let file = write_file(
        &dir,
        "ok.toml",
        &format!(
            "{}constants = {{ w = 0.3 }}\n",
            EXPRESSION.replace("0.3 t", "w t")
        ),
    );
    let out = dir.join("ok_out");
    let o = run(&["-q", "solve", &file, "--out", out.to_str().unwrap()], 120);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn a_first_sample_row_with_a_typo_is_an_error_not_a_header() {
    // "-1,3,0,O" (a letter O for a zero) was skipped as a header: the path lost a row.
    let dir = scratch("sample_typo");
    let toml = EXPRESSION
        .replace(
            "kind = \"expression\"\ncomponents = [\"3 cos(0.3 t)\", \"3 sin(0.3 t) / sqrt(2)\", \"0\"]\nend_time = 4.0\n",
            "kind = \"samples\"\nfile = \"s.csv\"\n",
        );
    let file = write_file(&dir, "typo.toml", &toml);
    write_file(&dir, "s.csv", "-1,3,0,O\n0,3,0,0\n2,2,1.5,0\n4,1,2,0\n");
    let o = run(
        &[
            "-q",
            "solve",
            &file,
            "--out",
            dir.join("o").to_str().unwrap(),
        ],
        60,
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("line 1"), "{e}");
    // A real header is still skipped.
    write_file(&dir, "s.csv", "t,w1,w2,w3\n0,3,0,0\n2,2,1.5,0\n4,1,2,0\n");
    let o = run(
        &[
            "-q",
            "solve",
            &file,
            "--out",
            dir.join("o2").to_str().unwrap(),
        ],
        120,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn a_direct_minimum_whose_xi_vanishes_is_not_called_regular() {
    // The sleigh over b - a = 1e-6: the direct minimum (min |xi| 2e-17) was called "a regular
    // minimum" because the control with |xi| = 1e-6 cost more on so short a span, and the
    // costs compared were printed as 0.000000 and 0.000000.
    let dir = scratch("xi_vanishes");
    let src = std::fs::read_to_string(example("se2_sleigh.toml")).unwrap();
    let line = src
        .lines()
        .find(|l| l.trim_start().starts_with("terminal_time"))
        .unwrap();
    let file = write_file(
        &dir,
        "short.toml",
        &src.replace(line, "terminal_time = { fixed = 1e-6 }"),
    );
    let out = dir.join("out");
    let o = run(&["-q", "solve", &file, "--out", out.to_str().unwrap()], 300);
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert_eq!(o.status.code(), Some(3), "{text}");
    assert!(
        text.contains("its xi vanishes, so it is not a regular minimum"),
        "{text}"
    );
    assert!(
        !text.contains("(a regular minimum") && !text.contains("costs 0.000000"),
        "{text}"
    );
}

#[test]
fn a_pole_of_a_formula_between_the_check_times_is_refused_up_front() {
    // `t/(t - 2.0001)` lies between the check times 2 and 2.0039 of [0, 4]: so3 "converged"
    // on it (cost 2.76, the pole stepped over); so4 had no check of its formulas at all and
    // failed after a minute in the gamma stage ("mesh passes"), or, for `log(t - 1)`, on
    // every route with NaN. Each is now an input error naming the component and the time.
    let dir = scratch("formula_pole");
    let so3 = write_file(
        &dir,
        "so3_pole.toml",
        &std::fs::read_to_string(example("expression.toml"))
            .unwrap()
            .replace(r#""0"]"#, r#""t/(t - 2.0001)"]"#),
    );
    // so4 at omega_a = [2, 0, 0, 0, 0, 1], with these six formulas.
    let so4 = |name: &str, formulas: [&str; 6]| {
        write_file(
            &dir,
            name,
            &SO4_TINY_J.replace("e-80", ".0").replace(
                "kind = \"segment\"",
                &format!(
                    "kind = \"expression\"\ncomponents = {:?}",
                    formulas.map(String::from)
                ),
            ),
        )
    };
    let cases = [
        (so3, "desired.components[2]", "unbounded near t = 2.000"),
        (
            so4("so4_pole.toml", ["2", "t/(t - 1.0001)", "0", "0", "0", "1"]),
            "desired.components[1]",
            "unbounded near t = 1.000",
        ),
        (
            so4("so4_log.toml", ["2", "log(t - 1)", "0", "0", "0", "1"]),
            "desired.components[1]",
            "not finite at t = 0",
        ),
        // Through zero at t = 1.0001: no direction to project onto the level set (formulas
        // through zero at t = 2 stopped "partial" in the gamma stage, for another reason).
        (
            so4(
                "so4_zero.toml",
                ["2 - 2 t/1.0001", "0", "0", "0", "0", "1 - t/1.0001"],
            ),
            "desired.components",
            "vanish together near t = 1.000",
        ),
    ];
    for (file, field, what) in cases {
        let out = dir.join("out");
        let o = run(&["-q", "solve", &file, "--out", out.to_str().unwrap()], 60);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{file}: {e}");
        assert!(e.contains(field) && e.contains(what), "{file}: {e}");
        assert!(
            !out.exists(),
            "{file}: an output directory after an input error"
        );
    }
}
