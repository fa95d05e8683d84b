//! Output layer (`suslov::report`) on a synthetic trajectory shaped like the paper's case:
//! I = diag(1, 2, 3), Ω_a = (5, 0, 0) (level ⟨Ω_a, IΩ_a⟩ = 25), Ω moving along a projected
//! spiral on the energy ellipsoid, ξ = normalised (IΩ̇ − (IΩ) × Ω) (so ⟨Ω, ξ⟩ = 0 up to
//! rounding), κ made of sines.

use std::fs;
use std::path::{Path, PathBuf};
use suslov::report::{
    parse_trajectory_csv, render_figure_bytes, write_atomic, write_case_figures,
    write_case_outputs, write_summary_json, write_trajectory_csv, CaseSummary, EnergyEllipsoid,
    Figure, FigureFormat, FigureOptions, ReportError, StabilityRun, StageSummary, Summary,
    TrajectoryTable, TRAJECTORY_CSV_HEADER,
};

const INERTIA: [f64; 3] = [1.0, 2.0, 3.0];
const LEVEL: f64 = 25.0;

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn quad(v: [f64; 3], w: [f64; 3]) -> f64 {
    INERTIA[0] * v[0] * w[0] + INERTIA[1] * v[1] * w[1] + INERTIA[2] * v[2] * w[2]
}

/// A spiral `φ(t) = (10, c t cos(t − p), c t sin(t − p))` projected on E, and its exact time
/// derivative.
fn projected_spiral(t: f64, c: f64, p: f64) -> ([f64; 3], [f64; 3]) {
    let phi = [10.0, c * t * (t - p).cos(), c * t * (t - p).sin()];
    let dphi = [
        0.0,
        c * ((t - p).cos() - t * (t - p).sin()),
        c * ((t - p).sin() + t * (t - p).cos()),
    ];
    let q = quad(phi, phi);
    let dq = 2.0 * quad(phi, dphi);
    let s = (LEVEL / q).sqrt();
    let ds = -0.5 * LEVEL.sqrt() * q.powf(-1.5) * dq;
    (
        [s * phi[0], s * phi[1], s * phi[2]],
        [
            s * dphi[0] + ds * phi[0],
            s * dphi[1] + ds * phi[1],
            s * dphi[2] + ds * phi[2],
        ],
    )
}

fn synthetic(n: usize, b: f64) -> TrajectoryTable {
    let mut tab = TrajectoryTable::default();
    for i in 0..n {
        let t = b * i as f64 / (n - 1) as f64;
        let (om, dom) = projected_spiral(t, 0.75, 0.4);
        let (od, _) = projected_spiral(t.min(10.0), 1.0, 0.0);
        let iom = [INERTIA[0] * om[0], INERTIA[1] * om[1], INERTIA[2] * om[2]];
        let idom = [
            INERTIA[0] * dom[0],
            INERTIA[1] * dom[1],
            INERTIA[2] * dom[2],
        ];
        let c = cross(iom, om);
        let v = [idom[0] - c[0], idom[1] - c[1], idom[2] - c[2]];
        let nv = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        // |ξ| near 1, wobbling a little (as the α-term of the cost allows).
        let mag = 1.0 + 0.03 * (0.7 * t).sin();
        tab.t.push(t);
        tab.omega.push(om);
        tab.xi
            .push([mag * v[0] / nv, mag * v[1] / nv, mag * v[2] / nv]);
        tab.kappa.push([
            0.8 * (0.9 * t).sin(),
            0.5 * (1.3 * t + 0.5).cos() * (-0.1 * t).exp(),
            0.3 * (2.1 * t).sin() - 0.2,
        ]);
        tab.omega_d.push(od);
    }
    // ξ̇ by central differences (not plotted; only needs plausible values).
    for i in 0..n {
        let (a, c) = (i.saturating_sub(1), (i + 1).min(n - 1));
        let dt = tab.t[c] - tab.t[a];
        let d = std::array::from_fn(|k| (tab.xi[c][k] - tab.xi[a][k]) / dt);
        tab.xi_dot.push(d);
    }
    tab
}

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("report_output/{name}"));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

fn no_temp_files(dir: &Path) {
    for e in fs::read_dir(dir).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(
            !name.contains(".tmp."),
            "temporary file left behind: {name}"
        );
    }
}

#[test]
fn synthetic_trajectory_is_on_the_ellipsoid_and_feasible() {
    let tab = synthetic(2001, 11.36);
    let s = tab.stats(INERTIA);
    assert!(s.max_abs_constraint < 1e-12, "{}", s.max_abs_constraint);
    assert!(s.energy_drift < 1e-13, "{}", s.energy_drift);
    assert!(s.xi_norm_min > 0.96 && s.xi_norm_max < 1.04);
}

#[test]
fn csv_header_rows_and_exact_round_trip() {
    let d = scratch("csv");
    let mut tab = synthetic(2001, 11.36);
    tab.kappa[7][1] = 1.234_567_890_123_456_7e-300;
    tab.kappa[8][2] = f64::NAN;
    tab.kappa[9][0] = f64::NEG_INFINITY;
    let p = d.join("trajectory.csv");
    write_trajectory_csv(&p, &tab).unwrap();
    let text = fs::read_to_string(&p).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), TRAJECTORY_CSV_HEADER);
    assert_eq!(
        TRAJECTORY_CSV_HEADER,
        "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3,kappa1,kappa2,kappa3,omegad1,omegad2,omegad3"
    );
    assert_eq!(text.lines().count(), 2002);
    // A value parsed by hand from row 100 (line 101), column xi2.
    let row: Vec<&str> = text.lines().nth(101).unwrap().split(',').collect();
    assert_eq!(row.len(), 16);
    assert_eq!(row[5].parse::<f64>().unwrap(), tab.xi[100][1]);
    assert_eq!(row[0].parse::<f64>().unwrap(), tab.t[100]);
    // The whole table reads back bit for bit (NaN compared as NaN).
    let back = parse_trajectory_csv(&text).unwrap();
    assert_eq!(back.len(), tab.len());
    assert!(back.kappa[8][2].is_nan());
    assert_eq!(back.kappa[9][0], f64::NEG_INFINITY);
    assert_eq!(back.kappa[7][1], 1.234_567_890_123_456_7e-300);
    let mut a = back.clone();
    let mut b = tab.clone();
    a.kappa[8][2] = 0.0;
    b.kappa[8][2] = 0.0;
    assert_eq!(a, b);
    no_temp_files(&d);
}

#[test]
fn csv_rejects_mismatched_lengths_and_writes_nothing() {
    let d = scratch("csv_mismatch");
    let mut tab = synthetic(11, 1.0);
    tab.omega_d.push([0.0; 3]);
    let p = d.join("bad.csv");
    let err = write_trajectory_csv(&p, &tab).unwrap_err();
    assert!(
        matches!(
            err,
            ReportError::LengthMismatch {
                column: "omega_d",
                len: 12,
                expected: 11
            }
        ),
        "{err:?}"
    );
    assert!(!p.exists());
    assert!(parse_trajectory_csv("t,omega1\n1,2\n").is_err());
}

#[test]
fn csv_into_missing_directory_names_the_path() {
    let d = scratch("csv_missing");
    let p = d.join("nope/trajectory.csv");
    let err = write_trajectory_csv(&p, &synthetic(5, 1.0)).unwrap_err();
    assert!(err.to_string().contains("nope/trajectory.csv"), "{err}");
    assert!(!d.join("nope").exists());
}

fn sample_summary() -> Summary {
    let tab = synthetic(201, 11.36);
    let st = tab.stats(INERTIA);
    let mut extra = serde_json::Map::new();
    extra.insert("alpha".into(), serde_json::json!(1.0));
    Summary {
        tool: suslov::report::ToolInfo::current(),
        cases: vec![
            CaseSummary {
                name: "eta = 1".into(),
                model: "so3".into(),
                model_source_hash: "0".repeat(64),
                eta: 1.0,
                terminal_time: 11.36,
                cost: 12.5,
                max_abs_constraint: st.max_abs_constraint,
                xi_norm_min: st.xi_norm_min,
                xi_norm_max: st.xi_norm_max,
                energy_drift: st.energy_drift,
                omega_b_error: tab.terminal_error([2.7541, -2.3109, -1.4983]),
                max_residual: 3.0e-10,
                mesh_nodes: 801,
                continuation_steps: 42,
                newton_iterations: 170,
                wall_seconds: 3.25,
                status_code: suslov::report::StatusCode::Converged,
                status: "converged".into(),
                verification: None,
                reintegration_max_diff: Some(2.0e-9),
                input: Some(serde_json::json!({"model": "so3"})),
                stability: vec![StabilityRun {
                    label: "relative 1e-3".into(),
                    perturbation: 1e-3,
                    max_omega_diff: 4e-3,
                    max_xi_diff: 2e-3,
                    final_omega_diff: f64::INFINITY,
                }],
                stages: vec![StageSummary {
                    name: "beta".into(),
                    parameter: "beta".into(),
                    from: 1e-3,
                    to: 0.1,
                    steps: 12,
                    newton_iterations: 40,
                    failures_recovered: 1,
                    outcome: "completed".into(),
                }],
                extra,
            },
            CaseSummary {
                name: "eta = 0.01".into(),
                eta: 0.01,
                terminal_time: f64::NAN,
                cost: f64::NEG_INFINITY,
                status_code: suslov::report::StatusCode::Partial,
                status: "partial: delta stage stalled at 0.13".into(),
                ..CaseSummary::default()
            },
        ],
    }
}

#[test]
fn summary_json_round_trips_with_all_fields_and_null_for_non_finite() {
    let d = scratch("json");
    let s = sample_summary();
    let p = d.join("summary.json");
    write_summary_json(&p, &s).unwrap();
    let text = fs::read_to_string(&p).unwrap();
    // Valid JSON (serde_json::Value accepts no NaN), with the documented field names.
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let c0 = &v["cases"][0];
    for key in [
        "name",
        "eta",
        "terminal_time",
        "cost",
        "max_abs_constraint",
        "xi_norm_min",
        "xi_norm_max",
        "energy_drift",
        "omega_b_error",
        "max_residual",
        "mesh_nodes",
        "continuation_steps",
        "newton_iterations",
        "wall_seconds",
        "model",
        "model_source_hash",
        "status_code",
        "status",
        "input",
        "reintegration_max_diff",
        "stability",
        "stages",
        "extra",
    ] {
        assert!(c0.get(key).is_some(), "missing {key} in {c0}");
    }
    assert_eq!(c0["stages"][0]["failures_recovered"], 1);
    assert_eq!(c0["status_code"], "converged");
    assert_eq!(v["cases"][1]["status_code"], "partial");
    assert_eq!(v["tool"]["name"], "suslov");
    assert!(c0["stability"][0]["final_omega_diff"].is_null());
    let c1 = &v["cases"][1];
    assert!(c1["terminal_time"].is_null());
    assert!(c1["cost"].is_null());
    assert!(c1.get("reintegration_max_diff").is_none());
    assert!(!text.contains("NaN") && !text.contains("inf"));
    // Typed round trip: identical except that non-finite values come back as NaN.
    let back: Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(back.cases.len(), 2);
    assert_eq!(back.cases[0].stages, s.cases[0].stages);
    assert_eq!(back.cases[0].extra, s.cases[0].extra);
    assert_eq!(
        back.cases[0].max_abs_constraint,
        s.cases[0].max_abs_constraint
    );
    assert_eq!(back.cases[0].reintegration_max_diff, Some(2.0e-9));
    assert!(back.cases[0].stability[0].final_omega_diff.is_nan());
    assert!(back.cases[1].terminal_time.is_nan() && back.cases[1].cost.is_nan());
    assert_eq!(back.cases[1].reintegration_max_diff, None);
    assert_eq!(back.cases[1].status, s.cases[1].status);
    assert_eq!(back.cases[1].status_code, s.cases[1].status_code);
    assert_eq!(back.tool, s.tool);
    assert_eq!(back.cases[0].input, s.cases[0].input);
    // Replacing an existing summary leaves exactly one file.
    write_summary_json(&p, &Summary::default()).unwrap();
    let v: serde_json::Value = serde_json::from_str(&fs::read_to_string(&p).unwrap()).unwrap();
    assert_eq!(v["cases"].as_array().unwrap().len(), 0);
    assert_eq!(fs::read_dir(&d).unwrap().count(), 1);
}

/// Every status kind has its own code in `summary.json`, and the text starts with its name.
#[test]
fn status_codes_and_texts_go_together() {
    use suslov::report::{CaseStatus, CaseSummary, StatusCode};
    let cases = [
        (CaseStatus::Converged, "converged", "converged"),
        (
            CaseStatus::Unverified("x".into()),
            "unverified",
            "unverified: x",
        ),
        (CaseStatus::Partial("x".into()), "partial", "partial: x"),
        (
            CaseStatus::NoMinimizer("x".into()),
            "no_minimizer",
            "no minimizer: x",
        ),
        (CaseStatus::Failed("x".into()), "failed", "failed: x"),
    ];
    for (status, code, text) in cases {
        let mut c = CaseSummary::failed("c", "first", "so3", "");
        c.set_status(&status);
        assert_eq!(c.status, text);
        assert_eq!(serde_json::to_value(c.status_code).unwrap(), code);
        let back: StatusCode = serde_json::from_value(serde_json::json!(code)).unwrap();
        assert_eq!(back, status.code());
    }
}

#[test]
fn atomic_write_replaces_and_leaves_no_temp_file() {
    let d = scratch("atomic");
    let p = d.join("f.bin");
    fs::write(&p, b"old contents").unwrap();
    write_atomic(&p, b"new").unwrap();
    assert_eq!(fs::read(&p).unwrap(), b"new");
    assert_eq!(fs::read_dir(&d).unwrap().count(), 1);
    no_temp_files(&d);
}

fn options(title: &str, format: FigureFormat) -> FigureOptions {
    let e = EnergyEllipsoid::through(INERTIA, [5.0, 0.0, 0.0]).unwrap();
    assert_eq!(e.level, LEVEL);
    FigureOptions {
        format,
        ..FigureOptions::new(title, e)
    }
}

/// A complete PNG of the requested size that is not blank.
fn check_png(p: &Path, size: (u32, u32)) {
    let b = fs::read(p).unwrap();
    assert!(
        b.len() > 10_000,
        "{} is only {} bytes",
        p.display(),
        b.len()
    );
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{}", p.display());
    let mut reader = png::Decoder::new(std::io::Cursor::new(b))
        .read_info()
        .unwrap();
    let mut pixels = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut pixels).unwrap();
    assert_eq!((info.width, info.height), size, "{}", p.display());
    let pixels = &pixels[..info.buffer_size()];
    let dark = pixels
        .chunks(3)
        .filter(|c| c.iter().all(|&v| v < 100))
        .count();
    let colored = pixels
        .chunks(3)
        .filter(|c| c.iter().max().unwrap() - c.iter().min().unwrap() > 80)
        .count();
    assert!(
        dark > 1000,
        "{}: no text or axes drawn ({dark})",
        p.display()
    );
    assert!(
        colored > 1000,
        "{}: no coloured curves ({colored})",
        p.display()
    );
}

#[test]
fn png_figures_exist_and_are_valid() {
    let d = scratch("figures_png/eta1");
    let tab = synthetic(2001, 11.36);
    let paths = write_case_figures(&d, &tab, &options("eta = 1", FigureFormat::Png)).unwrap();
    let names: Vec<String> = paths
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "omega_3d.png",
            "constraint.png",
            "xi_norm.png",
            "kappa.png",
            "omega.png",
            "xi.png",
            "xi_dot.png"
        ]
    );
    for p in &paths {
        check_png(p, (1200, 900));
    }
    no_temp_files(&d);
    assert_eq!(fs::read_dir(&d).unwrap().count(), 7);
}

#[test]
fn png_figure_with_extended_desired_trajectory() {
    // The eta = 0.01 situation: b = 9.84 < b_d = 10, Ω_d drawn to b_d, yellow marker at b.
    let d = scratch("figures_png/eta001");
    let tab = synthetic(2001, 9.84);
    let mut opts = options("eta = 0.01", FigureFormat::Png);
    opts.desired_extended = Some(synthetic(2001, 12.0).omega_d);
    opts.size = (800, 600);
    let paths = write_case_figures(&d, &tab, &opts).unwrap();
    for p in &paths {
        check_png(p, (800, 600));
    }
}

#[test]
fn svg_figures_exist_and_are_valid() {
    let d = scratch("figures_svg");
    let tab = synthetic(401, 11.36);
    let paths = write_case_figures(&d, &tab, &options("eta = 1", FigureFormat::Svg)).unwrap();
    assert_eq!(paths.len(), 7);
    for p in &paths {
        assert_eq!(p.extension().unwrap(), "svg");
        let s = fs::read_to_string(p).unwrap();
        assert!(
            s.starts_with("<svg") || s.contains("<svg "),
            "{}",
            p.display()
        );
        assert!(s.trim_end().ends_with("</svg>"));
        assert!(s.contains("<text"), "{} has no text", p.display());
    }
    no_temp_files(&d);
}

#[test]
fn figures_survive_non_finite_samples_and_reject_bad_input() {
    let mut tab = synthetic(301, 5.0);
    tab.kappa[100][0] = f64::NAN;
    tab.omega[150] = [f64::INFINITY, 0.0, 0.0];
    tab.xi[10] = [0.0; 3];
    let opts = options("broken", FigureFormat::Png);
    for fig in Figure::ALL {
        let bytes = render_figure_bytes(fig, &tab, &opts).unwrap();
        assert_eq!(&bytes[..4], b"\x89PNG");
    }
    let empty = TrajectoryTable::default();
    assert!(matches!(
        render_figure_bytes(Figure::Kappa, &empty, &opts),
        Err(ReportError::EmptyTable)
    ));
    let mut short = synthetic(10, 1.0);
    short.xi.pop();
    let d = scratch("figures_bad");
    let err = write_case_figures(d.join("x"), &short, &opts).unwrap_err();
    assert!(matches!(
        err,
        ReportError::LengthMismatch { column: "xi", .. }
    ));
    assert!(!d.join("x").exists(), "nothing is created for bad data");
}

#[test]
fn case_outputs_write_csv_and_figures_into_a_new_directory() {
    let d = scratch("case_outputs");
    let dir = d.join("runs/eta1");
    let tab = synthetic(501, 11.36);
    let paths = write_case_outputs(&dir, &tab, &options("eta = 1", FigureFormat::Svg)).unwrap();
    assert_eq!(paths.len(), 8);
    assert_eq!(paths[0], dir.join("trajectory.csv"));
    let back = parse_trajectory_csv(&fs::read_to_string(&paths[0]).unwrap()).unwrap();
    assert_eq!(back, tab);
    for p in &paths {
        assert!(fs::metadata(p).unwrap().len() > 0);
    }
    no_temp_files(&dir);
    let mut bad = tab.clone();
    bad.t.pop();
    let err = write_case_outputs(d.join("bad"), &bad, &options("x", FigureFormat::Svg));
    assert!(matches!(err, Err(ReportError::LengthMismatch { .. })));
    assert!(!d.join("bad").exists());
}
