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

fn summary_of(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap()
}

/// `summary.json` says which build wrote it, how each case ended as a code, and the full
/// input; `DIR/problem.toml` is that input, and solving it repeats the run bit for bit (so(3)
/// and another model; the paper's cases get theirs too).
#[test]
fn a_run_records_its_input_and_solving_that_repeats_it() {
    let dir = scratch("repeat");
    for (example_file, model) in [("segment.toml", "so3"), ("se2_sleigh.toml", "se2")] {
        let first = dir.join(format!("{model}_1"));
        let o = run(
            &[
                "solve",
                example(example_file).to_str().unwrap(),
                "--out",
                first.to_str().unwrap(),
            ],
            &dir,
        );
        assert_eq!(o.status.code(), Some(0), "{o:?}");
        let s1 = summary_of(&first);
        assert_eq!(s1["tool"]["name"], "suslov");
        assert_eq!(s1["tool"]["version"], env!("CARGO_PKG_VERSION"));
        assert_eq!(
            s1["tool"]["codegen_source_hash"].as_str().unwrap().len(),
            64
        );
        let case = &s1["cases"][0];
        assert_eq!(case["status_code"], "converged");
        assert_eq!(case["model"], model);
        assert_eq!(case["model_source_hash"].as_str().unwrap().len(), 64);
        assert_eq!(case["input"]["model"], model);
        assert!(case["input"]["solver"]["tolerance"].is_number(), "{case:#}");
        let second = dir.join(format!("{model}_2"));
        let o = run(
            &[
                "solve",
                first.join("problem.toml").to_str().unwrap(),
                "--out",
                second.to_str().unwrap(),
            ],
            &dir,
        );
        assert_eq!(o.status.code(), Some(0), "{o:?}");
        let s2 = summary_of(&second);
        for key in ["terminal_time", "cost", "max_abs_constraint", "mesh_nodes"] {
            assert_eq!(s1["cases"][0][key], s2["cases"][0][key], "{model}: {key}");
        }
        assert_eq!(s1["cases"][0]["input"], s2["cases"][0]["input"], "{model}");
    }
    // The paper: each case directory holds its problem.toml; η = 0.01 solved from it gives the
    // paper run's b and J.
    let paper = dir.join("paper");
    let o = run(&["paper", "--out", paper.to_str().unwrap()], &dir);
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let sp = summary_of(&paper);
    for case in sp["cases"].as_array().unwrap() {
        assert_eq!(case["status_code"], "converged");
        assert_eq!(case["input"]["desired"]["kind"], "paper-spiral");
    }
    let again = dir.join("paper_eta_0.01");
    let o = run(
        &[
            "solve",
            paper.join("eta_0.01/problem.toml").to_str().unwrap(),
            "--out",
            again.to_str().unwrap(),
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let sa = summary_of(&again);
    let case = sp["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "eta_0.01")
        .unwrap();
    assert_eq!(case["terminal_time"], sa["cases"][0]["terminal_time"]);
    assert_eq!(case["cost"], sa["cases"][0]["cost"]);
}

fn csv_rows(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// `--points N`: N uniform rows plus the mesh nodes in trajectory.csv; collocation.csv holds
/// the collocation solution itself (3N + 1 points of the final mesh, the interior flag, values
/// and time derivatives), which agrees with the trajectory at the nodes and whose derivative
/// columns are the derivatives of the solution (checked against difference quotients of the
/// dense output on a fine grid, and against the trajectory's own rows).
#[test]
fn the_output_grid_has_the_mesh_nodes_and_the_collocation_solution_is_written() {
    let dir = scratch("points");
    let out = dir.join("o");
    let o = run(
        &[
            "solve",
            example("segment.toml").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--points",
            "11",
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let nodes = summary_of(&out)["cases"][0]["mesh_nodes"].as_u64().unwrap() as usize;
    let (th, traj) = csv_rows(&out.join("trajectory.csv"));
    let (ch, colloc) = csv_rows(&out.join("collocation.csv"));
    assert_eq!(th[0], "t");
    assert_eq!(&ch[..3], ["t", "interior", "omega1"]);
    assert_eq!(ch.len(), 2 + 2 * 12);
    assert_eq!(ch[14], "d_omega1");
    assert_eq!(colloc.len(), 3 * (nodes - 1) + 1);
    // 11 uniform times and every node (the two ends are both).
    assert!(
        traj.len() >= nodes && traj.len() <= nodes + 9,
        "{} rows",
        traj.len()
    );
    let node_rows: Vec<&Vec<f64>> = colloc.iter().filter(|r| r[1] == 0.0).collect();
    assert_eq!(node_rows.len(), nodes);
    for (k, r) in colloc.iter().enumerate() {
        assert_eq!(r[1], if k % 3 == 0 { 0.0 } else { 1.0 });
    }
    for node in &node_rows {
        let row = traj
            .iter()
            .find(|r| r[0] == node[0])
            .unwrap_or_else(|| panic!("node t = {} not in trajectory.csv", node[0]));
        for c in 0..12 {
            assert!((row[1 + c] - node[2 + c]).abs() <= 1e-12 * (1.0 + node[2 + c].abs()));
        }
    }
    // The derivative columns: central differences of the values at interior points around
    // each node are not available, so compare with the trajectory at fine resolution.
    let fine = dir.join("fine");
    let o = run(
        &[
            "solve",
            example("segment.toml").to_str().unwrap(),
            "--out",
            fine.to_str().unwrap(),
            "--points",
            "200001",
        ],
        &dir,
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let (_, f) = csv_rows(&fine.join("trajectory.csv"));
    let mut checked = 0;
    for r in colloc.iter().step_by(7) {
        let i = f.partition_point(|row| row[0] < r[0]);
        if i < 2 || i + 2 >= f.len() {
            continue;
        }
        let (a, b) = (&f[i - 2], &f[i + 2]);
        for c in 0..12 {
            let d = (b[1 + c] - a[1 + c]) / (b[0] - a[0]);
            let scale = 1.0 + r[14 + c].abs();
            assert!(
                (d - r[14 + c]).abs() < 1e-4 * scale,
                "t = {}, column {}: {} vs difference {}",
                r[0],
                ch[14 + c],
                r[14 + c],
                d
            );
        }
        checked += 1;
    }
    assert!(checked > 10, "{checked}");
}

/// `trajectory.npz` holds one named array per column of `trajectory.csv`, read here by an
/// independent reader (Python's `zipfile`, the `.npy` header parsed by `ast`, the data by
/// `array`: numpy itself is not needed), for so(3) and for another model.
#[test]
fn the_npz_archive_has_the_csv_columns_by_name() {
    let dir = scratch("npz");
    for (example_file, stem) in [("segment.toml", "so3"), ("se2_sleigh.toml", "se2")] {
        let out = dir.join(stem);
        let o = run(
            &[
                "solve",
                example(example_file).to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--points",
                "101",
            ],
            &dir,
        );
        assert_eq!(o.status.code(), Some(0), "{o:?}");
        let script = r#"
import ast, sys, zipfile, array, csv
z = zipfile.ZipFile(sys.argv[1])
assert z.testzip() is None, "CRC mismatch"
rows = list(csv.reader(open(sys.argv[2])))
header, body = rows[0], rows[1:]
assert sorted(n[:-4] for n in z.namelist()) == sorted(header), (z.namelist(), header)
for k, name in enumerate(header):
    raw = z.read(name + ".npy")
    assert raw[:8] == b"\x93NUMPY\x01\x00"
    hlen = int.from_bytes(raw[8:10], "little")
    head = ast.literal_eval(raw[10:10 + hlen].decode("latin1"))
    assert head["descr"] == "<f8" and head["shape"] == (len(body),), head
    values = array.array("d")
    values.frombytes(raw[10 + hlen:])
    for r, v in zip(body, values):
        assert float(r[k]) == v, (name, r[k], v)
print(len(header), len(body))
"#;
        let py = std::process::Command::new("python3")
            .args([
                "-c",
                script,
                out.join("trajectory.npz").to_str().unwrap(),
                out.join("trajectory.csv").to_str().unwrap(),
            ])
            .output()
            .expect("python3 (the README's test command needs it too)");
        assert!(py.status.success(), "{stem}: {}", text(&py.stderr));
        let printed = text(&py.stdout);
        let columns: usize = printed.split_whitespace().next().unwrap().parse().unwrap();
        assert_eq!(columns, 1 + 12 + 3, "{printed}"); // t, the 12 states, Ω_d (both models: n = 3)
    }
}
