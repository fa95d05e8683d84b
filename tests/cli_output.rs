//! The command line's output convention, end to end through the binary: results on standard
//! output (text, or JSON with `--json` on every subcommand), progress and logs on standard
//! error; numbers with significant digits; a case without a solution says why, without NaNs;
//! no Rust names (`NoConvergence`, `Unverified {`) in what people read.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_suslov");

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli_output_{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Names of Rust items that used to reach people through `{:?}`.
fn assert_no_rust_names(s: &str) {
    for name in [
        "NoConvergence",
        "MaxNodes",
        "MaxMeshPasses",
        "SingularJacobian",
        "Unverified {",
        "Some(",
        "NaN",
    ] {
        assert!(!s.contains(name), "`{name}` in:\n{s}");
    }
}

#[test]
fn solve_prints_its_result_on_stdout_and_its_progress_on_stderr() {
    let dir = scratch("solve");
    let out = dir.join("o");
    let o = run(
        &[
            "solve",
            example("segment.toml").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    // One result line: the status and the numbers, with 8 significant digits.
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    let line = stdout.trim_end();
    assert!(line.starts_with("case segment: converged; b = "), "{line}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let case = &summary["cases"][0];
    let cost = case["cost"].as_f64().unwrap();
    let printed: f64 = line
        .split("cost = ")
        .nth(1)
        .and_then(|r| r.split(',').next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        ((printed - cost) / cost).abs() < 1e-7,
        "{printed} vs {cost}"
    );
    let grid = case["extra"]["check_grid_points"].as_u64().unwrap();
    assert!(line.contains(&format!("on {grid} points")), "{line}");
    // The progress and the log are on stderr, not the result.
    assert!(stderr.contains("stage polish"), "{stderr}");
    assert!(!stderr.contains("converged; b ="), "{stderr}");
    assert_no_rust_names(&stdout);
}

#[test]
fn json_on_stdout_is_the_summary_and_solve_has_a_default_output_directory() {
    let dir = scratch("json");
    let o = run(
        &["--json", "solve", example("segment.toml").to_str().unwrap()],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    // Without --out: out/<file stem> under the working directory.
    let written = std::fs::read(dir.join("out").join("segment").join("summary.json")).unwrap();
    let printed: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let file: serde_json::Value = serde_json::from_slice(&written).unwrap();
    assert_eq!(printed, file);
    assert_eq!(printed["cases"][0]["status"], "converged");
}

#[test]
fn certify_and_controllability_print_json_on_request() {
    let dir = scratch("certify");
    let o = run(
        &[
            "-q",
            "--json",
            "certify",
            example("segment.toml").to_str().unwrap(),
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["cases"][0]["verdict"], "certified");
    // Text: the KKT inertia in words, not `(+p, -n, 0xz)`.
    let o = run(
        &["-q", "certify", example("segment.toml").to_str().unwrap()],
        &dir,
    );
    let stdout = text(&o.stdout);
    assert!(stdout.contains("KKT matrix inertia: "), "{stdout}");
    assert!(stdout.contains(" zero eigenvalues"), "{stdout}");
    assert!(!stdout.contains("0x"), "{stdout}");

    let o = run(&["--json", "controllability", "--samples", "3"], &dir);
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["verdict"]["verdict"], "accessible");
    assert_eq!(v["states"].as_array().unwrap().len(), 3);
    assert_eq!(v["states"][0]["test"]["rank"], 4);
    let o = run(
        &[
            "--json",
            "controllability",
            "--model",
            "se2",
            "--inertia",
            "m=1,Ic=0.5,c1=0.3,c2=0.1",
            "--samples",
            "2",
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["model"], "se2");
    assert_eq!(v["states"].as_array().unwrap().len(), 2);
    let o = run(
        &[
            "-q",
            "--json",
            "controllability",
            "--along",
            example("segment.toml").to_str().unwrap(),
            "--points",
            "5",
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["all_accessible"], true);
    assert_eq!(v["cases"][0]["rank"]["points"], 5);
    assert!(v["cases"][0]["unverified"].is_null());
}

#[test]
fn a_case_without_a_solution_says_why_without_nans_or_rust_names() {
    let dir = scratch("failed");
    // Two intervals and a cap of three nodes: the start cannot meet the tolerance.
    let file = dir.join("capped.toml");
    let text_in = std::fs::read_to_string(example("segment.toml")).unwrap();
    let text_in = text_in
        .replace("name = \"segment\"", "name = \"capped\"")
        .replace("[solver]\n", "");
    std::fs::write(
        &file,
        format!("{text_in}\n[solver]\ninitial_intervals = 2\nmax_nodes = 3\nmax_routes = 1\n"),
    )
    .unwrap();
    let o = run(
        &[
            "solve",
            file.to_str().unwrap(),
            "--out",
            dir.join("o").to_str().unwrap(),
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(3), "{o:?}");
    let stdout = text(&o.stdout);
    assert!(stdout.starts_with("case capped: failed: "), "{stdout}");
    // The reason names the file key that lifts the cap.
    assert!(stdout.contains("`solver.max_nodes`"), "{stdout}");
    assert!(!stdout.contains("b = "), "{stdout}");
    assert!(!stdout.contains("other routes tried: \n"), "{stdout}");
    assert_no_rust_names(&stdout);
    assert_no_rust_names(&text(&o.stderr));
}
