//! The output layer: files a person or a script reads after a run.
//!
//! It knows nothing about how solutions are computed: it takes plain data, a
//! [`TrajectoryTable`] per case (the solution sampled on an output grid) and a [`Summary`]
//! of all cases, and writes
//!
//! - `trajectory.csv`-style tables ([`write_trajectory_csv`]): header
//!   [`TRAJECTORY_CSV_HEADER`], shortest round-trip `f64` text, so values read back exactly;
//! - a JSON summary ([`write_summary_json`]): pretty-printed, non-finite numbers as `null`;
//! - the figures of section 5.3 of the paper ([`write_case_figures`]): `omega_3d`,
//!   `constraint`, `xi_norm`, `kappa`, `omega`, `xi` and `xi_dot`, as PNG by default (text
//!   drawn from an embedded font, so no system font library is needed) or SVG.
//!
//! # Example: a solution's trajectory as CSV and a figure
//!
//! ```
//! use suslov::model::generated::{KAPPA, OMEGA, XI, XIDOT};
//! use suslov::report::{render_figure_bytes, trajectory_csv_string, Figure, FigureOptions};
//! use suslov::report::{EnergyEllipsoid, TrajectoryTable};
//! use suslov::{paper, solve, SolveOptions};
//!
//! let solution = solve(&paper::problem(0.01), &SolveOptions::default(), &mut |_| {})?;
//! let b = solution.terminal_time();
//! let t: Vec<f64> = (0..=200).map(|i| b * i as f64 / 200.0).collect();
//! let rows = solution.states_at(&t);
//! let block = |y: &[f64], r: std::ops::Range<usize>| -> [f64; 3] { y[r].try_into().unwrap() };
//! let table = TrajectoryTable {
//!     omega: rows.iter().map(|y| block(y, OMEGA)).collect(),
//!     xi: rows.iter().map(|y| block(y, XI)).collect(),
//!     xi_dot: rows.iter().map(|y| block(y, XIDOT)).collect(),
//!     kappa: rows.iter().map(|y| block(y, KAPPA)).collect(),
//!     omega_d: t.iter().map(|&s| solution.problem.desired.value(s).into()).collect(),
//!     t,
//! };
//! let csv = trajectory_csv_string(&table)?;
//! assert!(csv.starts_with("t,omega1,omega2,omega3,xi1"));
//! assert_eq!(csv.lines().count(), 202); // header + 201 rows
//! let inertia = solution.problem.inertia.diag().into();
//! let e = EnergyEllipsoid::through(inertia, table.omega[0])?;
//! let opts = FigureOptions::new("eta_0.01", e);
//! let png = render_figure_bytes(Figure::Constraint, &table, &opts)?;
//! assert_eq!(&png[1..4], b"PNG");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Figures
//!
//! One directory per case, files `<stem>.png` or `.svg` (`suslov solve` and `paper` write
//! both, [`FigureFormat::ALL`]). Titles carry the case name, or, with
//! [`FigureOptions::subtitle`], a second line such as the paper's captions give (`suslov`
//! writes the weights and b there: `eta_1: α = 1, β = 0.1, γ = 1, η = 1, δ = 0.2, b =
//! 11.3596`, [`case_subtitle`]). With [`FigureOptions::desired_in_cost`] `false` (γ = 0),
//! Ω_d is "the reference path (not in the cost)", never "desired".
//!
//! | stem | content |
//! | --- | --- |
//! | `omega_3d` | 3-D view of Ω(t), Ω_d(t) and ξ_∥(t) (ξ projected along its ray onto `E`), wireframe of the energy ellipsoid `E`, coordinate axes through the origin, Ω₁, Ω₂, Ω₃ written at the box edges that carry the tick labels; Ω drawn last, over Ω_d (a wide grey band; thin and dashed when not in the cost); markers Ω(a) green, Ω(b) red (circles), ξ_∥(a) cyan, ξ_∥(b) magenta (triangles), Ω_d(b) yellow when [`FigureOptions::desired_extended`] is given; the legend in a column at the right; the view chosen from the data ([`choose_view_3d`]) unless [`FigureOptions::view_3d`] gives one |
//! | `constraint` | ⟨Ω, ξ⟩ against t, symmetric y range in units of a power of ten (e.g. `[×10⁻¹²]`), max \|⟨Ω, ξ⟩\| in the title |
//! | `xi_norm` | \|ξ\| against t with a dashed reference line at 1 |
//! | `kappa` | κ₁, κ₂, κ₃ against t with start / end markers and a legend |
//! | `omega` | Ω₁, Ω₂, Ω₃ (solid) and Ω_d (dashed, same colours) against t |
//! | `xi` | ξ₁, ξ₂, ξ₃ against t |
//! | `xi_dot` | the control ξ̇ = dξ/dt: its three components against t |
//!
//! **Format.** PNG is the default: `plotters`' `ab_glyph` feature rasterises text from a
//! subset of DejaVu Sans embedded in the library (`src/report/font/`, Bitstream Vera
//! licence), so neither building nor running needs fontconfig, freetype or any installed
//! font (the `ttf` feature would need fontconfig/freetype via `font-kit`). PNGs are drawn at
//! twice the size and averaged down (plotters' bitmap lines are not anti-aliased) and
//! encoded in memory by `png`. SVG ([`FigureFormat::Svg`]) is available for vector output;
//! its text is SVG `<text>` shown in the viewer's sans-serif font.
//!
//! Every file is written with [`write_atomic`] (temporary file in the same directory, fsync,
//! rename): a reader never sees a half-written file, and a failed write leaves the previous
//! file in place and no temporary behind. File writers do **not** create missing parent
//! directories (that is an [`ReportError::Io`] naming the path); only
//! [`write_case_figures`], which owns its output directory, creates it.

mod atomic;
mod certificate;
mod csv;
mod error;
mod figures;
mod npz;
mod number;
mod outdir;
mod summary;
mod table;

pub use atomic::{is_temporary_name, probe_writable, remove_in_flight, write_atomic, TEMP_PREFIX};
pub use certificate::CertificateReport;
pub use csv::{
    parse_trajectory_csv, trajectory_csv_string, trajectory_npy_bytes, trajectory_npz_bytes,
    write_trajectory_csv, write_trajectory_npy, DESIRED_COLUMN_PREFIX, TRAJECTORY_CSV_HEADER,
};
pub use error::ReportError;
pub use figures::{
    case_subtitle, choose_view_3d, render_figure_bytes, render_figure_bytes_in,
    render_planar_path_png, write_case_figures, write_figure, Figure, FigureFormat, FigureOptions,
    DEFAULT_VIEW_3D,
};
pub use npz::{npy_1d_bytes, npz_bytes};
pub use number::significant;
pub use outdir::{
    belongs_to_a_run, OutputDir, INCOMPLETE_FILE, LOCK_FILE, MANIFEST_FILE, SUMMARY_FILE,
};
pub use summary::{
    finite_or_null, opt_finite_or_null, write_summary_json, CaseStatus, CaseSummary, CheckSummary,
    StabilityRun, StageSummary, StatusCode, Summary, ToolInfo, VerificationSummary,
};
pub use table::{dot, norm, EnergyEllipsoid, TableStats, TrajectoryTable};

use std::path::{Path, PathBuf};

/// File name of the trajectory table written by [`write_case_outputs`].
pub const TRAJECTORY_CSV_NAME: &str = "trajectory.csv";

/// Writes everything about one case into `dir` (created if missing): [`TRAJECTORY_CSV_NAME`]
/// and the figures of [`write_case_figures`]. Returns the paths written, CSV first.
///
/// The data are checked before anything is written, so bad input leaves no files.
///
/// # Errors
/// As [`write_trajectory_csv`] and [`write_case_figures`].
pub fn write_case_outputs(
    dir: impl AsRef<Path>,
    table: &TrajectoryTable,
    opts: &FigureOptions,
) -> Result<Vec<PathBuf>, ReportError> {
    let dir = dir.as_ref();
    let csv = trajectory_csv_string(table)?;
    if table.is_empty() {
        return Err(ReportError::EmptyTable);
    }
    opts.ellipsoid.check()?;
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let csv_path = dir.join(TRAJECTORY_CSV_NAME);
    write_atomic(&csv_path, csv.as_bytes())?;
    let mut paths = vec![csv_path];
    paths.extend(write_case_figures(dir, table, opts)?);
    Ok(paths)
}
