//! Problem files: a user's own Suslov problem as TOML (`suslov solve problem.toml`).
//!
//! [`load`] reads a file, [`from_toml_str`] a string; both return a [`LoadedProblem`] (a
//! validated [`SuslovProblem`], the [`SolveOptions`] and a case name) or a [`ConfigError`]
//! that names the offending field by its TOML path (`cost.beta`, `boundary.omega_b`, …) and
//! says how to fix it. Nothing in here panics on bad input.
//!
//! # Schema
//!
//! ```toml
//! model = "so3"                      # optional (the default); files of the other generated
//!                                    # models (se2, so4, ...) are described in [`generic`]
//! name = "my_problem"                # optional; default: the file name without extension
//!
//! [body]
//! inertia = [1.0, 2.0, 3.0]          # principal moments I1, I2, I3: finite, > 0
//!
//! [boundary]
//! t0 = 0.0                           # optional, default 0
//! omega_a = [5.0, 0.0, 0.0]          # Ω(t0): finite, nonzero
//! omega_b = "desired_end"            # Ω(b): "desired_end" or a vector on Ω_a's energy ellipsoid
//! terminal_time = { free = true, guess = 10.0 }   # or { fixed = 12.0 } (> t0)
//!
//! [cost]                             # C = α/4(|ξ|²−1)² + β/2|ξ̇|² + γ/2|Ω−Ω_d|² + η/2|Ω̇|² + δ
//! alpha = 1.0                        # > 0
//! beta = 0.1                         # > 0
//! gamma = 1.0                        # >= 0
//! eta = 1.0                          # >= 0, optional, default 0
//! delta = 0.2                        # >= 0, optional, default 0
//!
//! [desired]                          # Ω_d(t)
//! kind = "paper-spiral"              # or "segment", "constant", "samples", "expression"
//! c = 10.0                           # paper-spiral: optional, default 10
//! width = 0.01                       # paper-spiral: optional, default 0.01 (> 0)
//! b_d = 10.0                         # paper-spiral: optional, default 10
//!
//! [solver]                           # optional; defaults of SolveOptions
//! tolerance = 1e-8
//! continuation_tolerance = 1e-4
//! beta_m = 1e-3                      # default 1e-2 · min(α, β, γ or 1)
//! initial_intervals = 100
//! max_nodes = 20000
//! start = "auto"                     # or "desired", "desired-gamma-from-zero", "segment"
//! ```
//!
//! Desired paths (`[desired] kind = …`):
//! - `"paper-spiral"`: the paper's `Ω_d = φ_∥(1 − s) + Ω_b s` (section 5.3) with parameters
//!   `c`, `width`, `b_d` ([`PaperSpiral`]); its end point is `φ_∥(b_d)`.
//! - `"segment"`: the radial projection onto the energy ellipsoid of the straight segment
//!   from `from` (default `boundary.omega_a`) at `interval[0]` to `to` (default
//!   `boundary.omega_b`) at `interval[1]` (default `[t0, terminal time]`)
//!   ([`ProjectedSegment`]); its end point is `to`.
//! - `"constant"`: `Ω_d = value`; its end point is `value`.
//! - `"samples"`: `file = "omega_d.csv"` (relative to the problem file), rows
//!   `t, omega1, omega2, omega3` ([`parse_samples`]), strictly increasing `t`, covering `t0`;
//!   the natural cubic spline through them ([`SampledPath`], C², linear beyond the last
//!   sample) projected radially onto the energy ellipsoid ([`Projected`]); its end point is
//!   the projected last sample and its end time the last `t`.
//!
//! - `"expression"`: `components = ["<formula in t>", …]` (one per component), optional
//!   `constants = { name = value, … }` and `end_time` ([`crate::lie::expression`]): exact derivatives over dual numbers, projected radially onto
//!   the energy ellipsoid; its end point is its value at `end_time`.
//!
//! `omega_b = "desired_end"` takes `Ω_b` = the desired path's end point (which must lie on
//! the energy ellipsoid). A free terminal time's `guess` defaults to the path's end time
//! (`b_d`, or `interval[1]`) when it has one.
//!
//! Checks beyond the types: no NaN or infinity anywhere (TOML has `nan` and `inf` literals);
//! every array has exactly its number of entries ([`Numbers`]; never truncated); `Ω_b` on
//! `Ω_a`'s energy ellipsoid (relative energy mismatch ≤ [`ENERGY_REL_TOL`], Suslov's
//! equations conserve it; within that, every such vector is projected onto the ellipsoid,
//! so no later check is stricter than this one); when `γ > 0`, the desired path starts at
//! `Ω_a`: `|Ω_d(t0) − Ω_a| ≤` [`DESIRED_START_REL_TOL`]` · |Ω_a|` (with `γ = 0`, `Ω_d` is
//! not part of the cost and is not checked); the desired path and the solver's fallback
//! start path are finite with three derivatives on `[t0, b]`; `b − t0` is resolved by `f64`
//! times near `t0` ([`TIME_SPAN_REL_MIN`]); solver options lie in documented ranges
//! ([`TOLERANCE_RANGE`], [`CONTINUATION_TOLERANCE_RANGE`], [`BETA_M_MIN_RATIO`]).
//!
//! # Bounded resources
//!
//! Every input is capped before the work it would cause: the problem file
//! ([`MAX_PROBLEM_FILE_BYTES`], read with at most that many bytes plus one, regular files
//! only: `/dev/zero` or a FIFO is an error, not a hang), the case name ([`MAX_NAME_CHARS`]),
//! the samples file ([`MAX_SAMPLES_FILE_BYTES`], [`MAX_SAMPLE_ROWS`]) and the meshes
//! ([`MAX_INITIAL_INTERVALS`], [`MAX_NODES`], from the measured [`MEMORY_PER_NODE_BYTES`]).
//! Messages quote at most [`MAX_ECHO_CHARS`] characters of any piece of input.
//!
//! Accepted oddities are reported as [`ConfigWarning`]s in [`LoadedProblem::warnings`].

use crate::echo::Num;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::Vector3;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

use crate::model::generated::DIM;
use crate::so3::desired::{
    Constant, DesiredPath, PaperSpiral, Projected, ProjectedPath, ProjectedSegment, SampledPath,
};
use crate::so3::ellipsoid::{EnergyEllipsoid, Inertia};
use crate::so3::problem::{
    CostWeights, ProblemError, SuslovProblem, TerminalTime, ENERGY_REL_TOL, N_INERTIA,
};
use crate::so3::solve::{SolveOptions, StartStrategy};
use crate::so3::SuslovError;

pub mod generic;
pub mod resolved;

pub use resolved::ResolvedInput;

/// Allowed `|Ω_d(t0) − Ω_a| / |Ω_a|` (when `γ > 0`).
pub const DESIRED_START_REL_TOL: f64 = 1e-6;

/// Largest problem file read, in bytes (1 MiB). A problem file is well under 1 kB; the cap
/// leaves room for any amount of comments while bounding what the `toml` crate holds in
/// memory and parses (a file is read with at most this many bytes plus one, so a larger or
/// growing file costs no more).
pub const MAX_PROBLEM_FILE_BYTES: u64 = 1 << 20;

/// Longest case name, in characters. The name labels `summary.json` and every figure title
/// (rasterised text: a 100 kB name took 8 s per figure).
pub const MAX_NAME_CHARS: usize = 200;

/// Largest samples file (`desired.file`), in bytes (64 MiB), read with a bounded reader.
pub const MAX_SAMPLES_FILE_BYTES: u64 = 64 << 20;

/// Most rows of a samples file. The spline holds ~130 bytes per row and building it ~200
/// (a million rows: ~200 MB), and a BVP mesh of at most [`MAX_NODES`] nodes cannot resolve
/// more detail than that many samples carry anyway.
pub const MAX_SAMPLE_ROWS: usize = 1_000_000;

/// Memory of one BVP mesh node, measured: peak RSS of `suslov solve examples/segment.toml`
/// with `initial_intervals` = 1000, 4000, 16000, 32000 grows by 45.7 kB per interval
/// (58 MB, 215 MB, 736 MB, 1.47 GB; release build). The tester's `initial_intervals = 1e5`
/// took 4.5 GB and 74 s, `3e5` aborted with "memory allocation failed".
pub const MEMORY_PER_NODE_BYTES: u64 = 46_000;

/// Cap on `solver.max_nodes`: ~2.3 GB at [`MEMORY_PER_NODE_BYTES`], which a common machine
/// has; the examples converge with a few hundred nodes, the default cap is 20000.
pub const MAX_NODES: usize = 50_000;

/// Cap on `solver.initial_intervals`: ~0.5 GB and ~5 s for the first solve (measured at
/// 16000: 7.6 s in all); it stays below the default `max_nodes` (20000), so a capped value
/// never needs `max_nodes` too. The default is 100.
pub const MAX_INITIAL_INTERVALS: usize = 10_000;

/// Allowed `solver.tolerance`. The BVP solver's `tol` is both the relative and the absolute
/// tolerance of a per-interval error estimate (`h |residual|` against `tol (1 + |y|)`,
/// [`crate::bvp::Options`]), and Newton stops at 1e-2 of that. Below 1e-12 this asks for
/// corrections at the round-off of the collocation system: measured, 1e-13 failed on the
/// paper's η = 1 and the segment example (Newton or mesh passes exhausted), 1e-12 converged
/// on 2 of 4 examples, 1e-11 on all. Above 1e-3 the estimate stops being an error bound on
/// a mesh that coarse (`tolerance = 1` "converged" with 4 nodes); and a solve is called
/// converged only at a tolerance of at most [`crate::lie::checks::TOL_MAX`] = 1e-4 (the
/// a-posteriori checks, docs/verification.md), so the range ends there: a file
/// that passes validation can converge. The paper uses 1e-8.
pub const TOLERANCE_RANGE: (f64, f64) = (crate::lie::checks::TOL_MIN, crate::lie::checks::TOL_MAX);

/// Allowed `solver.continuation_tolerance`: the same floor as [`TOLERANCE_RANGE`]; the
/// continuation only has to follow the path, but at 1e-1 the paper's analytic start already
/// failed to converge (measured), while 1e-2 gave the same `b` to 1e-10. Default 1e-4.
pub const CONTINUATION_TOLERANCE_RANGE: (f64, f64) = (1e-12, 1e-2);

/// `solver.beta_m` must lie in `[BETA_M_MIN_RATIO · β, β]`. The analytic start is the
/// singular (`β → 0`) solution solved at `β = β_m`, then continued `β_m → β`
/// (`suslov::solve`), so `β_m > β` defeats it (measured on the paper's η = 1: `β_m` = 1 and
/// 10 with `β` = 0.1 did not converge); `β_m` = `β` skips the β stage. Far below `β` the
/// start's system becomes singular (measured: from `β_m` = 1e-5 `β` on); the floor only
/// rejects values no start can use.
pub const BETA_M_MIN_RATIO: f64 = 1e-8;

use crate::echo::clip_to;
/// Longest piece of input echoed in a message (characters; longer ones end in `…`).
pub use crate::echo::MAX_ECHO_CHARS;

/// The parsed file, before any check beyond the TOML types. Every field is optional here so
/// that a missing one is reported with its full path by [`ProblemFile::build`].
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemFile {
    /// The model: `"so3"` (default) here; files of other models are read by [`generic`].
    pub model: Option<String>,
    /// Case name (labels the summary); default: the file stem.
    pub name: Option<String>,
    /// `[body]`.
    pub body: Option<BodySection>,
    /// `[boundary]`.
    pub boundary: Option<BoundarySection>,
    /// `[cost]`.
    pub cost: Option<CostSection>,
    /// `[desired]`.
    pub desired: Option<DesiredSection>,
    /// `[solver]`.
    pub solver: Option<SolverSection>,
}

/// `[body]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySection {
    /// Principal moments of inertia.
    pub inertia: Option<Numbers<N_INERTIA>>,
}

/// `[boundary]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundarySection {
    /// Initial time (default 0).
    pub t0: Option<f64>,
    /// `Ω(t0)`.
    pub omega_a: Option<Numbers<DIM>>,
    /// `Ω(b)`.
    pub omega_b: Option<OmegaBSpec>,
    /// Fixed or free terminal time.
    pub terminal_time: Option<TerminalTimeSpec>,
}

/// `boundary.omega_b`: an explicit vector or `"desired_end"`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OmegaBSpec {
    /// The desired path's end point.
    DesiredEnd,
    /// An explicit vector (as written: its length is checked in [`ProblemFile::build`]).
    Vector(Numbers<DIM>),
}

impl<'de> Deserialize<'de> for OmegaBSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = OmegaBSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "an array of {DIM} numbers or the string \"desired_end\"")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<OmegaBSpec, E> {
                if s == "desired_end" {
                    Ok(OmegaBSpec::DesiredEnd)
                } else {
                    Err(E::invalid_value(de::Unexpected::Str(s), &self))
                }
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<OmegaBSpec, A::Error> {
                read_numbers(seq).map(OmegaBSpec::Vector)
            }
        }
        d.deserialize_any(V)
    }
}

/// A TOML array meant to hold exactly `N` numbers, as written in the file. Reading it never
/// fails on the length (only on an entry's type): a wrong length is kept as
/// [`Numbers::WrongLength`] and turned into [`ConfigError::Length`], which names the key, by
/// [`ProblemFile::build`]. Every vector key (and the vector form of `boundary.omega_b`) is
/// read this way, so no array is ever truncated, padded or partly ignored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Numbers<const N: usize> {
    /// Exactly `N` numbers.
    Exact([f64; N]),
    /// Any other number of entries (of any type beyond the first `N`): how many.
    WrongLength(usize),
}

impl<'de, const N: usize> Deserialize<'de> for Numbers<N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for V<N> {
            type Value = Numbers<N>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "an array of {N} numbers")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Numbers<N>, A::Error> {
                read_numbers(seq)
            }
        }
        d.deserialize_seq(V::<N>)
    }
}

/// Reads up to `N` numbers, then counts (without converting) whatever else the array holds.
fn read_numbers<'de, A: SeqAccess<'de>, const N: usize>(
    mut seq: A,
) -> Result<Numbers<N>, A::Error> {
    let mut out = [0.0; N];
    for (n, slot) in out.iter_mut().enumerate() {
        match seq.next_element::<f64>()? {
            Some(x) => *slot = x,
            None => return Ok(Numbers::WrongLength(n)),
        }
    }
    let mut extra = 0usize;
    while seq.next_element::<de::IgnoredAny>()?.is_some() {
        extra += 1;
    }
    Ok(if extra == 0 {
        Numbers::Exact(out)
    } else {
        Numbers::WrongLength(N + extra)
    })
}

/// The numbers of a vector key, or [`ConfigError::Length`] naming it; `meaning` names the
/// entries (e.g. `"I1, I2, I3"`).
fn exact<const N: usize>(
    field: &str,
    v: Numbers<N>,
    meaning: &'static str,
) -> Result<[f64; N], ConfigError> {
    match v {
        Numbers::Exact(x) => Ok(x),
        Numbers::WrongLength(found) => Err(ConfigError::Length {
            field: field.to_string(),
            found,
            expected: N,
            meaning: meaning.to_string(),
        }),
    }
}

/// What the entries of a 3-vector key are.
const XYZ: &str = "x, y, z";

/// `boundary.terminal_time`: `{ fixed = b }` or `{ free = true, guess = b }`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerminalTimeSpec {
    /// `true` for a free terminal time.
    pub free: Option<bool>,
    /// Start value of a free terminal time.
    pub guess: Option<f64>,
    /// A fixed terminal time.
    pub fixed: Option<f64>,
}

/// `[cost]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostSection {
    /// `α > 0`.
    pub alpha: Option<f64>,
    /// `β > 0`.
    pub beta: Option<f64>,
    /// `γ ≥ 0`.
    pub gamma: Option<f64>,
    /// `η ≥ 0` (default 0).
    pub eta: Option<f64>,
    /// `δ ≥ 0` (default 0).
    pub delta: Option<f64>,
}

/// `[desired]`: `kind` and the parameters of that kind.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesiredSection {
    /// `"paper-spiral"`, `"segment"`, `"constant"` or `"samples"`.
    pub kind: Option<String>,
    /// paper-spiral: spiral offset (default 10).
    pub c: Option<f64>,
    /// paper-spiral: sigmoid width (default 0.01).
    pub width: Option<f64>,
    /// paper-spiral: switching time (default 10).
    pub b_d: Option<f64>,
    /// constant: the value.
    pub value: Option<Numbers<DIM>>,
    /// segment: start point (default `boundary.omega_a`).
    pub from: Option<Numbers<DIM>>,
    /// segment: end point (default `boundary.omega_b`).
    pub to: Option<Numbers<DIM>>,
    /// segment: `[start time, end time]` (default `[t0, terminal time]`).
    pub interval: Option<Numbers<2>>,
    /// samples: the CSV file (relative to the problem file).
    pub file: Option<String>,
    /// expression: one formula in `t` per component.
    pub components: Option<Vec<String>>,
    /// expression: named constants the formulas may use.
    pub constants: Option<std::collections::BTreeMap<String, f64>>,
    /// expression: the path's end time (its end point for `omega_b = "desired_end"`, the
    /// default guess of a free terminal time).
    pub end_time: Option<f64>,
}

/// `[solver]`: every key optional, defaults of [`SolveOptions`].
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverSection {
    /// Final BVP tolerance.
    pub tolerance: Option<f64>,
    /// BVP tolerance during continuation.
    pub continuation_tolerance: Option<f64>,
    /// `β_m` of the analytic start.
    pub beta_m: Option<f64>,
    /// Intervals of the initial uniform mesh.
    pub initial_intervals: Option<usize>,
    /// Node cap of every BVP solve.
    pub max_nodes: Option<usize>,
    /// Start case override: "auto" (default), "desired", "desired-gamma-from-zero", "segment".
    pub start: Option<String>,
    /// How many homotopy routes may be tried, the default included (1 to [`MAX_ROUTES`]).
    pub max_routes: Option<usize>,
    /// A previous solution to start from: a `trajectory.csv` (or the directory of a previous
    /// `suslov solve`, which holds one), relative to the problem file; read by
    /// `read_warm_start` (columns by name, costates optional).
    pub start_from: Option<String>,
}

/// `solver.start_from`: the states of a previous solution, from a CSV whose header names the
/// columns: `t` and the model's state names (`trajectory.csv` of `suslov solve`, or any CSV
/// with those columns, e.g. a direct method's; extra columns are ignored). The costate
/// columns (`kappa…` on so(3)) may be absent together (then 0: a direct method has none).
/// `value` is a file, or a directory holding `trajectory.csv`, relative to `base_dir`. The
/// times must increase strictly from `t0` (within 1e-9 relative); at least 2 rows; every
/// value finite; a regular UTF-8 file of at most [`MAX_SAMPLES_FILE_BYTES`].
pub(crate) fn read_warm_start(
    base_dir: &Path,
    value: &str,
    state_names: &[&str],
    costates: std::ops::Range<usize>,
    t0: f64,
) -> Result<std::sync::Arc<crate::lie::solve::WarmStart>, ConfigError> {
    let field = "solver.start_from";
    let bad = |message: String| ConfigError::Invalid {
        field: field.into(),
        message,
    };
    let mut path = base_dir.join(value);
    if path.is_dir() {
        path = path.join("trajectory.csv");
    }
    let shown = clip(&path.display().to_string());
    let bytes = read_bounded(&path, MAX_SAMPLES_FILE_BYTES).map_err(|e| {
        bad(match e {
            ReadFailure::Io(e) => format!(
                "cannot read {shown}: {e}; give a trajectory.csv (or the directory of a previous `suslov solve`), relative to the problem file"
            ),
            ReadFailure::File(p) => format!("{shown}: {p}"),
        })
    })?;
    let text = decode(bytes, false).map_err(|p| bad(format!("{shown}: {p}")))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, header) = lines
        .next()
        .ok_or_else(|| bad(format!("{shown} is empty; it needs a header line and rows")))?;
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |name: &str| columns.iter().position(|c| *c == name);
    let t_col = find("t").ok_or_else(|| {
        bad(format!(
            "{shown} has no column `t`; its header needs t and {}",
            state_names.join(", ")
        ))
    })?;
    let mut state_cols = Vec::with_capacity(state_names.len());
    for (k, name) in state_names.iter().enumerate() {
        state_cols.push(match find(name) {
            Some(c) => Some(c),
            None if costates.contains(&k) => None,
            None => {
                return Err(bad(format!(
                    "{shown} has no column `{name}`; its header needs t and {} (the costates {} may be left out together)",
                    state_names.join(", "),
                    state_names[costates.clone()].join(", ")
                )))
            }
        });
    }
    let given = costates
        .clone()
        .filter(|k| state_cols[*k].is_some())
        .count();
    if given != 0 && given != costates.len() {
        return Err(bad(format!(
            "{shown} has some of the costate columns {} but not all; give all or none",
            state_names[costates.clone()].join(", ")
        )));
    }
    let (mut times, mut states) = (Vec::new(), Vec::new());
    for (i, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != columns.len() {
            return Err(bad(format!(
                "{shown} line {}: {} fields, the header has {}",
                i + 1,
                cells.len(),
                columns.len()
            )));
        }
        let number = |c: usize| -> Result<f64, ConfigError> {
            match cells[c].parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(bad(format!(
                    "{shown} line {}: column `{}` is {:?}, not a finite number",
                    i + 1,
                    columns[c],
                    clip(cells[c])
                ))),
            }
        };
        times.push(number(t_col)?);
        for c in &state_cols {
            states.push(match c {
                Some(c) => number(*c)?,
                None => 0.0,
            });
        }
    }
    if times.len() < 2 {
        return Err(bad(format!(
            "{shown} has {} rows; it needs at least 2",
            times.len()
        )));
    }
    if let Some(w) = times.windows(2).position(|w| w[1] <= w[0]) {
        return Err(bad(format!(
            "{shown}: t must increase strictly (row {} has t = {}, the next {})",
            w + 1,
            times[w],
            times[w + 1]
        )));
    }
    if (times[0] - t0).abs() > 1e-9 * (1.0 + t0.abs()) {
        return Err(bad(format!(
            "{shown} starts at t = {}, the problem at boundary.t0 = {t0}; a warm start must start where the problem does",
            times[0]
        )));
    }
    Ok(std::sync::Arc::new(crate::lie::solve::WarmStart {
        times,
        states,
    }))
}

/// Cap on `solver.max_routes`: every route listed by `lie::solve::alternatives` after the
/// longest list (a failed start: 6 others) with room to spare.
pub const MAX_ROUTES: usize = 10;

/// A problem file turned into something to solve.
#[derive(Debug, Clone)]
pub struct LoadedProblem {
    /// Case name.
    pub name: String,
    /// The problem (validated).
    pub problem: SuslovProblem,
    /// Solver options.
    pub options: SolveOptions,
    /// What was accepted but deserves a word (the problem is solved as given).
    pub warnings: Vec<ConfigWarning>,
    /// The file with every default filled in ([`resolved`]).
    pub resolved: ResolvedInput,
}

/// Something in a valid problem file that is probably not what was meant; the problem is
/// solved as given.
#[derive(Debug, Clone, PartialEq)]
pub enum ConfigWarning {
    /// One principal moment exceeds the sum of the other two. Every rigid body has
    /// `I_i ≤ I_j + I_k` (`I_i + I_j − I_k = 2∫ρ x_k² ≥ 0`; equality: a flat body), so no
    /// body has these moments; Suslov's equations and the optimal control problem are still
    /// well defined for any positive moments.
    TriangleInequality {
        /// `[I1, I2, I3]`.
        inertia: [f64; 3],
        /// The moment that is too large (0-based).
        axis: usize,
    },
}

impl ConfigWarning {
    /// The TOML path of the key the warning is about.
    pub fn field(&self) -> &'static str {
        match self {
            ConfigWarning::TriangleInequality { .. } => "body.inertia",
        }
    }
}

impl fmt::Display for ConfigWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigWarning::TriangleInequality { inertia, axis } => {
                let (j, k) = ((axis + 1) % 3, (axis + 2) % 3);
                write!(
                    f,
                    "`{}` = [{}, {}, {}]: I{} = {} exceeds I{} + I{} = {}, which no rigid body \
                     has (principal moments satisfy the triangle inequality; equality is a \
                     flat body); the problem is solved as given",
                    self.field(),
                    Num(inertia[0]),
                    Num(inertia[1]),
                    Num(inertia[2]),
                    axis + 1,
                    Num(inertia[*axis]),
                    j.min(k) + 1,
                    j.max(k) + 1,
                    Num(inertia[j] + inertia[k])
                )
            }
        }
    }
}

/// [`ConfigWarning::TriangleInequality`] if a moment exceeds the sum of the others by more
/// than rounding (so that flat bodies, e.g. the paper's `diag(1, 2, 3)`, pass).
fn triangle_warning(inertia: [f64; 3]) -> Option<ConfigWarning> {
    (0..3)
        .find(|&i| {
            let others = inertia[(i + 1) % 3] + inertia[(i + 2) % 3];
            inertia[i] > others * (1.0 + 4.0 * f64::EPSILON)
        })
        .map(|axis| ConfigWarning::TriangleInequality { inertia, axis })
}

/// What is wrong with a problem file. Every variant names a field ([`ConfigError::field`])
/// by its TOML path, except those about the file as a whole ([`ConfigError::Read`],
/// [`ConfigError::File`] unless the invalid UTF-8 is inside a key, [`ConfigError::TooLarge`])
/// and TOML syntax errors outside any key (which give the line and column).
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read {}: {source}", clip(&path.display().to_string()))]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The problem file is no regular file, too large or not UTF-8.
    #[error("{}: {problem}", clip(&path.display().to_string()))]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        problem: FileProblem,
    },
    /// Problem text longer than [`MAX_PROBLEM_FILE_BYTES`] (given as a string).
    #[error(
        "the problem text is larger than {} (the cap on a problem file)",
        mebibytes(*limit)
    )]
    TooLarge {
        /// The cap, in bytes.
        limit: u64,
    },
    /// `desired.file` (the samples of `kind = "samples"`) cannot be used.
    #[error("`desired.file`: {}: {problem}", clip(&path.display().to_string()))]
    Samples {
        /// The samples file as resolved (relative to the problem file).
        path: PathBuf,
        /// What is wrong.
        problem: SamplesProblem,
    },
    /// An error in a file (wraps the others with the file name).
    #[error("{}: {source}", clip(&path.display().to_string()))]
    InFile {
        /// The file.
        path: PathBuf,
        /// The error.
        source: Box<ConfigError>,
    },
    /// TOML syntax, unknown key or wrong type (the `toml` message, with line and column).
    #[error("{}{message}", field.as_ref().map(|f| format!("in `{f}`: ")).unwrap_or_default())]
    Toml {
        /// The TOML path at the error's position, when it could be located.
        field: Option<String>,
        /// The parser's message.
        message: String,
    },
    /// An array key with the wrong number of entries.
    #[error(
        "`{field}` has {found} entr{}, expected {expected} ({meaning}): write {} = [{meaning}]",
        if *found == 1 { "y" } else { "ies" },
        field.rsplit('.').next().unwrap_or(field)
    )]
    Length {
        /// The key.
        field: String,
        /// How many entries the file gives.
        found: usize,
        /// How many the key takes.
        expected: usize,
        /// What the entries are, e.g. `"I1, I2, I3"`.
        meaning: String,
    },
    /// A required key is missing.
    #[error("`{field}` is missing: {fix}")]
    Missing {
        /// The key.
        field: String,
        /// What to add.
        fix: String,
    },
    /// NaN or infinity.
    #[error(
        "`{field}` = {value} is not a finite number (TOML accepts nan and inf, a problem \
         does not): give a finite value"
    )]
    NotFinite {
        /// The key.
        field: String,
        /// The value.
        value: f64,
    },
    /// A value out of its range.
    #[error("`{field}` = {value}: {requirement}")]
    OutOfRange {
        /// The key.
        field: String,
        /// The value, formatted.
        value: String,
        /// What is required, why, and the fix.
        requirement: String,
    },
    /// `α` or `β` not positive: the optimal control problem is singular.
    #[error(
        "`{field}` = {} makes the problem singular: {why}; give a value > 0 (e.g. {example})",
        Num(*value)
    )]
    Singular {
        /// The key.
        field: String,
        /// The value.
        value: f64,
        /// Why it is singular.
        why: &'static str,
        /// A suggested value.
        example: &'static str,
    },
    /// A vector that must be nonzero is zero.
    #[error("`{field}` = [0, 0, 0]: {why}; give a nonzero vector")]
    ZeroVector {
        /// The key.
        field: String,
        /// What the vector is needed for.
        why: &'static str,
    },
    /// A vector off `Ω_a`'s energy ellipsoid.
    #[error(
        "`{field}` = {value:?} is off omega_a's energy ellipsoid by {mismatch:.3e} (relative \
         kinetic energy; allowed {ENERGY_REL_TOL:e}): Suslov's equations conserve the kinetic \
         energy, so no motion from omega_a reaches it. Its radial projection onto the \
         ellipsoid is {projection:?}: use that (or change omega_a)"
    )]
    OffEllipsoid {
        /// The key.
        field: String,
        /// The value.
        value: [f64; 3],
        /// Relative energy mismatch.
        mismatch: f64,
        /// The radial projection onto the ellipsoid.
        projection: [f64; 3],
    },
    /// The desired path does not start at `Ω_a`.
    #[error(
        "the desired path ([desired] kind = \"{kind}\") starts at Omega_d(t0) = {start:?}, but \
         `boundary.omega_a` = {omega_a:?}: they differ by {distance:.3e} ({relative:.3e} \
         relative to |omega_a|, allowed {DESIRED_START_REL_TOL:e}). Make the desired path \
         start at omega_a ({hint}) or set omega_a = Omega_d(t0)"
    )]
    DesiredStart {
        /// The desired path's kind.
        kind: String,
        /// `Ω_d(t0)`.
        start: [f64; 3],
        /// `Ω_a`.
        omega_a: [f64; 3],
        /// `|Ω_d(t0) − Ω_a|`.
        distance: f64,
        /// `distance / |Ω_a|`.
        relative: f64,
        /// Which keys to change for this kind.
        hint: &'static str,
    },
    /// The terminal time is not after `t0`, or both/neither of fixed and free are given.
    #[error("`{field}`: {message}")]
    TerminalTime {
        /// The key.
        field: String,
        /// What is wrong and the fix.
        message: String,
    },
    /// Any other invalid value or combination (names the key and the fix).
    #[error("`{field}`: {message}")]
    Invalid {
        /// The key.
        field: String,
        /// What is wrong and the fix.
        message: String,
    },
}

impl ConfigError {
    /// The TOML path of the offending field, if the error is about one.
    pub fn field(&self) -> Option<&str> {
        match self {
            ConfigError::Read { .. } | ConfigError::TooLarge { .. } => None,
            ConfigError::File { problem, .. } => match problem {
                FileProblem::NotUtf8 { field, .. } => field.as_deref(),
                _ => None,
            },
            ConfigError::Samples { .. } => Some("desired.file"),
            ConfigError::InFile { source, .. } => source.field(),
            ConfigError::Toml { field, .. } => field.as_deref(),
            ConfigError::Missing { field, .. }
            | ConfigError::Length { field, .. }
            | ConfigError::NotFinite { field, .. }
            | ConfigError::OutOfRange { field, .. }
            | ConfigError::Singular { field, .. }
            | ConfigError::ZeroVector { field, .. }
            | ConfigError::OffEllipsoid { field, .. }
            | ConfigError::TerminalTime { field, .. }
            | ConfigError::Invalid { field, .. } => Some(field),
            ConfigError::DesiredStart { .. } => Some("desired"),
        }
    }
}

impl ConfigError {
    /// The error itself, without the [`ConfigError::InFile`] wrapper that names the file.
    pub fn inner(&self) -> &ConfigError {
        match self {
            ConfigError::InFile { source, .. } => source.inner(),
            e => e,
        }
    }
}

/// Why a file (the problem file or a samples file) was not read.
#[derive(Debug, thiserror::Error)]
pub enum FileProblem {
    /// A directory.
    #[error("it is a directory, not a file")]
    Directory,
    /// A device, FIFO or socket (e.g. `/dev/zero`, which never ends).
    #[error("it is not a regular file (a device, FIFO or socket); give a file")]
    NotRegular,
    /// Larger than the cap.
    #[error(
        "it is larger than {} (the cap on this kind of file)",
        mebibytes(*limit)
    )]
    TooLarge {
        /// The cap, in bytes.
        limit: u64,
    },
    /// Not UTF-8 text.
    #[error(
        "it is not valid UTF-8 at line {line}, column {column}{}: save it as UTF-8 text",
        field.as_ref().map(|f| format!(" (in `{f}`)")).unwrap_or_default()
    )]
    NotUtf8 {
        /// 1-based line of the first invalid byte.
        line: usize,
        /// 1-based column (characters) of the first invalid byte.
        column: usize,
        /// The TOML path there (problem files).
        field: Option<String>,
    },
}

fn mebibytes(bytes: u64) -> String {
    if bytes.is_multiple_of(1 << 20) {
        format!("{} MiB", bytes >> 20)
    } else {
        format!("{bytes} bytes")
    }
}

/// A file's bytes, read only if it is a regular file of at most `limit` bytes (and then at
/// most `limit + 1` bytes are read, whatever the file claims).
#[derive(Debug)]
enum ReadFailure {
    Io(std::io::Error),
    File(FileProblem),
}

fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, ReadFailure> {
    use std::io::Read;
    // `metadata` follows symlinks and does not open the file (opening a FIFO would block).
    let meta = std::fs::metadata(path).map_err(ReadFailure::Io)?;
    if meta.is_dir() {
        return Err(ReadFailure::File(FileProblem::Directory));
    }
    if !meta.is_file() {
        return Err(ReadFailure::File(FileProblem::NotRegular));
    }
    if meta.len() > limit {
        return Err(ReadFailure::File(FileProblem::TooLarge { limit }));
    }
    let file = std::fs::File::open(path).map_err(ReadFailure::Io)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(ReadFailure::Io)?;
    if bytes.len() as u64 > limit {
        return Err(ReadFailure::File(FileProblem::TooLarge { limit }));
    }
    Ok(bytes)
}

/// `bytes` as text without a leading byte order mark, or where the first invalid UTF-8
/// byte is (line, column, and for TOML the key there).
fn decode(bytes: Vec<u8>, toml: bool) -> Result<String, FileProblem> {
    match String::from_utf8(bytes) {
        Ok(mut text) => {
            if text.starts_with(BOM) {
                text.drain(..BOM.len_utf8());
            }
            Ok(text)
        }
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            let bytes = e.into_bytes();
            // Positions after a byte order mark, as the parser would see them.
            let skip = if bytes.starts_with("\u{feff}".as_bytes()) {
                BOM.len_utf8()
            } else {
                0
            };
            let valid = std::str::from_utf8(&bytes[skip..at]).unwrap_or_default();
            let line = valid.matches('\n').count() + 1;
            let column = valid.rsplit('\n').next().unwrap_or("").chars().count() + 1;
            let field = if toml {
                let lossy = String::from_utf8_lossy(&bytes[skip..]);
                field_at(&lossy, at - skip).map(|f| clip_to(&f, MAX_ECHO_CHARS / 2))
            } else {
                None
            };
            Err(FileProblem::NotUtf8 {
                line,
                column,
                field,
            })
        }
    }
}

const BOM: char = '\u{feff}';

/// At most [`MAX_ECHO_CHARS`] characters of a piece of input (with `…` if cut).
fn clip(s: &str) -> String {
    clip_to(s, MAX_ECHO_CHARS)
}

/// The `toml` crate's message with every echoed piece of input capped: it shows the source
/// line, a caret line as long as the offending span, and quotes keys and strings in the
/// message itself. Each quoted piece (between backticks or double quotes) keeps at most
/// half of [`MAX_ECHO_CHARS`] characters, so that what follows it (e.g. the list of valid
/// keys) survives, and each line at most `MAX_ECHO_CHARS + 50`.
/// What the TOML reader's messages name by Rust type (`expected struct TerminalTimeSpec`,
/// `expected usize`), in the words of the file.
const TYPE_WORDS: &[(&str, &str)] = &[
    (
        "struct TerminalTimeSpec",
        "a table: { fixed = b } or { free = true, guess = b }",
    ),
    ("struct ProblemFile", "a problem file (a TOML table)"),
    ("struct BodySection", "a table [body]"),
    ("struct BoundarySection", "a table [boundary]"),
    ("struct CostSection", "a table [cost]"),
    ("struct DesiredSection", "a table [desired]"),
    ("struct SolverSection", "a table [solver]"),
    ("usize", "a whole number >= 0"),
    ("u64", "a whole number >= 0"),
    ("i64", "a whole number"),
    ("f64", "a number"),
    ("a sequence", "an array"),
    ("sequence", "an array"),
    ("a map", "a table"),
    ("map", "a table"),
];

/// `s` with the Rust type names of [`TYPE_WORDS`] replaced.
pub(crate) fn plain_words(s: &str) -> String {
    let mut out = s.to_string();
    for &(rust, words) in TYPE_WORDS {
        for lead in ["expected ", "expected one of ", "invalid type: "] {
            out = out.replace(&format!("{lead}{rust}"), &format!("{lead}{words}"));
        }
    }
    out
}

fn clip_toml_message(s: &str) -> String {
    let s = &plain_words(s);
    let clip_pieces = |line: &str| {
        let mut out = String::new();
        let mut piece = String::new();
        for c in line.chars() {
            if c == '`' || c == '"' {
                out.push_str(&clip_to(&piece, MAX_ECHO_CHARS / 2));
                out.push(c);
                piece.clear();
            } else {
                piece.push(c);
            }
        }
        out.push_str(&clip_to(&piece, MAX_ECHO_CHARS / 2));
        clip_to(&out, MAX_ECHO_CHARS + 50)
    };
    s.lines().map(clip_pieces).collect::<Vec<_>>().join("\n")
}

/// Read and check a problem file; errors carry the file name. The file must be a regular
/// file of at most [`MAX_PROBLEM_FILE_BYTES`] bytes of UTF-8 (a leading byte order mark is
/// skipped).
pub fn load(path: &Path) -> Result<LoadedProblem, ConfigError> {
    load_with_text(path).map(|(loaded, _)| loaded)
}

/// [`load`], and the file's text as it was read and checked (without a byte order mark), for
/// a copy of the input next to the results: one bounded read, so the copy is what was solved.
pub fn load_with_text(path: &Path) -> Result<(LoadedProblem, String), ConfigError> {
    let text = read_problem_text(path)?;
    let loaded = parse_so3(path, &text)?;
    Ok((loaded, text))
}

/// The text of a problem file: a regular file of at most [`MAX_PROBLEM_FILE_BYTES`] bytes of
/// UTF-8 (a leading byte order mark is kept here; the parsers skip it).
fn read_problem_text(path: &Path) -> Result<String, ConfigError> {
    let file_error = |problem| ConfigError::File {
        path: path.to_path_buf(),
        problem,
    };
    let bytes = read_bounded(path, MAX_PROBLEM_FILE_BYTES).map_err(|e| match e {
        ReadFailure::Io(source) => ConfigError::Read {
            path: path.to_path_buf(),
            source,
        },
        ReadFailure::File(problem) => file_error(problem),
    })?;
    decode(bytes, true).map_err(file_error)
}

/// The case name's default for the file at `path`: its stem.
fn default_name_of(path: &Path) -> DefaultName {
    match path.file_stem() {
        Some(stem) => DefaultName::FileStem(stem.to_string_lossy().into_owned()),
        None => DefaultName::Fixed("problem".into()),
    }
}

/// Check the text of the so(3) problem file at `path` (errors carry the file name).
fn parse_so3(path: &Path, text: &str) -> Result<LoadedProblem, ConfigError> {
    let base = path.parent().unwrap_or(Path::new(""));
    parse(text, &default_name_of(path), base).map_err(|e| ConfigError::InFile {
        path: path.to_path_buf(),
        source: Box::new(e),
    })
}

/// Check a problem given as TOML text (case name default `"problem"`; a samples file is
/// looked up relative to the current directory). The same caps as [`load`] apply.
pub fn from_toml_str(text: &str) -> Result<LoadedProblem, ConfigError> {
    parse(text, &DefaultName::Fixed("problem".into()), Path::new(""))
}

/// A problem file of any model: so(3) files as [`LoadedProblem`], the others parsed and
/// waiting for their model's type ([`ModelFile::build`]).
pub enum Loaded {
    /// `model = "so3"` (or no `model` key).
    So3(LoadedProblem),
    /// Another generated model.
    Other(ModelFile),
}

/// A parsed problem file of a model other than so(3) (see [`generic`]).
pub struct ModelFile {
    /// The model's name (one of `crate::model::MODEL_NAMES`).
    pub model: String,
    table: toml::Table,
    default_name: DefaultName,
    base_dir: std::path::PathBuf,
    path: Option<std::path::PathBuf>,
}

impl ModelFile {
    /// Check every field against model `M` (whose `NAME` must be [`ModelFile::model`]).
    pub fn build<M: crate::model::Model>(
        &self,
    ) -> Result<generic::LoadedModelProblem<M>, ConfigError> {
        debug_assert_eq!(M::NAME, self.model);
        generic::build::<M>(&self.table, &self.default_name, &self.base_dir).map_err(
            |e| match &self.path {
                Some(path) => ConfigError::InFile {
                    path: path.clone(),
                    source: Box::new(e),
                },
                None => e,
            },
        )
    }
}

/// Read a problem file of any model ([`load_with_text`] for so(3) files; other models are
/// parsed here and checked by [`ModelFile::build`]), and the file's text.
pub fn load_any(path: &Path) -> Result<(Loaded, String), ConfigError> {
    let text = read_problem_text(path)?;
    match other_model(&text) {
        Ok(None) => Ok((Loaded::So3(parse_so3(path, &text)?), text)),
        Ok(Some((model, table))) => Ok((
            Loaded::Other(ModelFile {
                model,
                table,
                default_name: default_name_of(path),
                base_dir: path.parent().unwrap_or(Path::new("")).to_path_buf(),
                path: Some(path.to_path_buf()),
            }),
            text,
        )),
        Err(e) => Err(ConfigError::InFile {
            path: path.to_path_buf(),
            source: Box::new(e),
        }),
    }
}

/// The file's `model` key and its parsed table when it names another generated model than
/// so(3); `None` for so(3) (no key, or `"so3"`) and for text that is no TOML table (the so(3)
/// parser reports its errors with their field); an error naming the models there are.
fn other_model(text: &str) -> Result<Option<(String, toml::Table)>, ConfigError> {
    let text = text.strip_prefix(BOM).unwrap_or(text);
    let Ok(table) = toml::from_str::<toml::Table>(text) else {
        return Ok(None);
    };
    match table.get("model") {
        None => Ok(None),
        Some(toml::Value::String(m)) if m == "so3" => Ok(None),
        Some(toml::Value::String(m)) if crate::model::MODEL_NAMES.contains(&m.as_str()) => {
            let model = m.clone();
            Ok(Some((model, table)))
        }
        Some(other) => Err(ConfigError::Invalid {
            field: "model".into(),
            message: format!(
                "{}: not a model; use one of {} (the files codegen/models/<name>.py)",
                clip(&other.to_string()),
                crate::model::MODEL_NAMES.join(", ")
            ),
        }),
    }
}

/// Where the case name comes from when the file has no `name`.
pub(crate) enum DefaultName {
    /// The problem file's name without extension (checked like a given name).
    FileStem(String),
    /// A name given by the caller.
    Fixed(String),
}

fn parse(
    text: &str,
    default_name: &DefaultName,
    base_dir: &Path,
) -> Result<LoadedProblem, ConfigError> {
    if text.len() as u64 > MAX_PROBLEM_FILE_BYTES {
        return Err(ConfigError::TooLarge {
            limit: MAX_PROBLEM_FILE_BYTES,
        });
    }
    let text = text.strip_prefix(BOM).unwrap_or(text);
    let file: ProblemFile = toml::from_str(text).map_err(|e| ConfigError::Toml {
        field: e
            .span()
            .and_then(|span| field_at(text, span.start))
            .map(|f| clip_to(&f, MAX_ECHO_CHARS / 2)),
        message: clip_toml_message(e.to_string().trim_end()),
    })?;
    file.build_named(default_name, base_dir)
}

/// The TOML path (table header and keys) at byte offset `pos` of `src`, best effort: the
/// nearest `[table]` header above and the keys (also inside inline tables) on `pos`'s line.
fn field_at(src: &str, pos: usize) -> Option<String> {
    let pos = pos.min(src.len());
    let pos = (0..=pos).rev().find(|&p| src.is_char_boundary(p))?;
    let line_start = src[..pos].rfind('\n').map_or(0, |i| i + 1);
    let line_end = src[pos..].find('\n').map_or(src.len(), |i| pos + i);
    let line = &src[line_start..line_end];
    let header_of = |l: &str| {
        let l = l.trim();
        l.starts_with('[').then(|| {
            let end = l.find(']').unwrap_or(l.len());
            l[..end].trim_start_matches('[').trim().to_string()
        })
    };
    if let Some(h) = header_of(line) {
        return (!h.is_empty()).then_some(h);
    }
    let header = src[..line_start]
        .lines()
        .rev()
        .find_map(header_of)
        .unwrap_or_default();
    // Keys on the line before pos, by inline-table depth.
    let prefix = &src[line_start..pos];
    let mut keys: Vec<String> = Vec::new();
    let mut depth = 0usize;
    let mut token_start = 0usize;
    let mut in_string = false;
    for (i, ch) in prefix.char_indices() {
        match ch {
            '"' | '\'' => in_string = !in_string,
            _ if in_string => {}
            '{' => {
                depth += 1;
                token_start = i + 1;
            }
            '}' => depth = depth.saturating_sub(1),
            ',' | '[' => token_start = i + 1,
            '=' => {
                let key = prefix[token_start..i].trim().trim_matches(['"', '\'']);
                keys.truncate(depth);
                keys.push(key.to_string());
            }
            _ => {}
        }
    }
    keys.truncate(depth + 1);
    if keys.len() <= depth {
        // pos is at a key (e.g. an unknown one): take it.
        let rest = &line[pos - line_start..];
        let key: String = rest
            .chars()
            .take_while(|c| !c.is_whitespace() && *c != '=' && *c != ',' && *c != '}')
            .collect();
        let key = key.trim_matches(['"', '\'']).to_string();
        if !key.is_empty() {
            keys.push(key);
        }
    }
    let mut parts: Vec<String> = Vec::new();
    if !header.is_empty() {
        parts.push(header);
    }
    parts.extend(keys.into_iter().filter(|k| !k.is_empty()));
    (!parts.is_empty()).then(|| parts.join("."))
}

/// `v` projected radially onto `e` (a change of at most ~[`ENERGY_REL_TOL`]` / 2` relative),
/// or [`ConfigError::OffEllipsoid`] if it is further off than `ENERGY_REL_TOL` (relative
/// energy) or [`ConfigError::ZeroVector`] if it is 0. Every vector that must lie on the
/// ellipsoid goes through here, so the validated problem carries it on `E` to round-off and
/// no later, stricter check can reject what validation accepted.
fn onto_ellipsoid(
    field: &str,
    e: &EnergyEllipsoid,
    v: &Vector3<f64>,
) -> Result<Vector3<f64>, ConfigError> {
    if v.iter().all(|x| *x == 0.0) {
        return Err(ConfigError::ZeroVector {
            field: field.to_string(),
            why: "it must lie on omega_a's energy ellipsoid (Suslov's equations conserve the \
                  kinetic energy), which does not contain 0",
        });
    }
    let projection = e.project(v).map_err(|err| ConfigError::Invalid {
        field: field.to_string(),
        message: format!("{err}; rescale it"),
    })?;
    let mismatch = e.relative_mismatch(v);
    if mismatch.abs() <= 8.0 * f64::EPSILON {
        // On E to round-off already (e.g. a path's computed end point): keep it bit for bit.
        return Ok(*v);
    }
    if mismatch.abs() <= ENERGY_REL_TOL {
        return Ok(projection);
    }
    Err(ConfigError::OffEllipsoid {
        field: field.to_string(),
        value: [v[0], v[1], v[2]],
        mismatch,
        projection: [projection[0], projection[1], projection[2]],
    })
}

fn missing(field: &str, fix: impl Into<String>) -> ConfigError {
    ConfigError::Missing {
        field: field.to_string(),
        fix: fix.into(),
    }
}

fn finite(field: &str, value: f64) -> Result<f64, ConfigError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ConfigError::NotFinite {
            field: field.to_string(),
            value,
        })
    }
}

/// A 3-vector key: exactly 3 entries, all finite.
fn vector3(field: &str, v: Numbers<DIM>) -> Result<Vector3<f64>, ConfigError> {
    let v = exact(field, v, XYZ)?;
    for (i, x) in v.iter().enumerate() {
        finite(&format!("{field}[{i}]"), *x)?;
    }
    Ok(Vector3::from(v))
}

fn positive(field: &str, value: f64, why: &str) -> Result<f64, ConfigError> {
    finite(field, value)?;
    if value > 0.0 {
        Ok(value)
    } else {
        Err(ConfigError::OutOfRange {
            field: field.to_string(),
            value: Num(value).to_string(),
            requirement: format!("must be > 0 ({why})"),
        })
    }
}

fn non_negative(field: &str, value: f64, why: &str) -> Result<f64, ConfigError> {
    finite(field, value)?;
    if value >= 0.0 {
        Ok(value)
    } else {
        Err(ConfigError::OutOfRange {
            field: field.to_string(),
            value: Num(value).to_string(),
            requirement: format!("must be >= 0 ({why}); use 0 to switch the term off"),
        })
    }
}

/// Keys of `[desired]` that a kind does not use.
fn reject_unused(d: &DesiredSection, kind: &str, allowed: &[&str]) -> Result<(), ConfigError> {
    let present = [
        ("c", d.c.is_some()),
        ("width", d.width.is_some()),
        ("b_d", d.b_d.is_some()),
        ("value", d.value.is_some()),
        ("from", d.from.is_some()),
        ("to", d.to.is_some()),
        ("interval", d.interval.is_some()),
        ("file", d.file.is_some()),
        ("components", d.components.is_some()),
        ("constants", d.constants.is_some()),
        ("end_time", d.end_time.is_some()),
    ];
    for (key, is_set) in present {
        if is_set && !allowed.contains(&key) {
            return Err(ConfigError::Invalid {
                field: format!("desired.{key}"),
                message: format!(
                    "not a parameter of kind = \"{kind}\" (its keys: {}); remove it or change \
                     the kind",
                    if allowed.is_empty() {
                        "none".to_string()
                    } else {
                        allowed.join(", ")
                    }
                ),
            });
        }
    }
    Ok(())
}

/// `kind = "expression"` (any model): `components` (one formula in `t` per component, `n` of
/// them), `constants` (optional names for numbers) and `end_time` (optional), parsed into a
/// path with exact derivatives ([`crate::lie::expression`]); with the resolved `[desired]`
/// keys. An error names the component and the character position.
pub(crate) fn expression_path(
    d: &DesiredSection,
    n: usize,
) -> Result<(crate::lie::expression::Expression, toml::Table), ConfigError> {
    let components = d.components.as_ref().ok_or_else(|| {
        missing(
            "desired.components",
            format!(
                "add components = [\"<formula in t>\", ...] under [desired], {n} of them, e.g. \
                 components = [\"3 cos(0.5 t)\", \"3 sin(0.5 t)\", \"1\"] for n = 3"
            ),
        )
    })?;
    if components.len() != n {
        return Err(ConfigError::Length {
            field: "desired.components".into(),
            found: components.len(),
            expected: n,
            meaning: "one formula in t per component".into(),
        });
    }
    let constants: Vec<(String, f64)> = d
        .constants
        .iter()
        .flatten()
        .map(|(k, v)| {
            let field = format!("desired.constants.{}", clip(k));
            crate::lie::expression::check_constant_name(k).map_err(|why| ConfigError::Invalid {
                field: field.clone(),
                message: format!("{:?} {why}; rename the constant", clip(k)),
            })?;
            Ok((k.clone(), finite(&field, *v)?))
        })
        .collect::<Result<_, ConfigError>>()?;
    let expression =
        crate::lie::expression::Expression::parse(components, &constants).map_err(|(i, e)| {
            use crate::lie::expression::{function_names, ExpressionError};
            // An unknown name's message lists the names already.
            let grammar = match e {
                ExpressionError::UnknownName { .. } => String::new(),
                _ => format!(
                    "; a formula uses t, numbers, + - * / ^, parentheses, pi, the functions {} \
                     and the names of desired.constants",
                    function_names()
                ),
            };
            ConfigError::Invalid {
                field: format!("desired.components[{i}]"),
                message: format!("{:?}: {e}{grammar}", clip(&components[i])),
            }
        })?;
    let mut keys = toml::Table::new();
    keys.insert("kind".into(), toml::Value::String("expression".into()));
    keys.insert(
        "components".into(),
        toml::Value::Array(
            components
                .iter()
                .map(|c| toml::Value::String(c.clone()))
                .collect(),
        ),
    );
    if !constants.is_empty() {
        keys.insert(
            "constants".into(),
            toml::Value::Table(
                constants
                    .iter()
                    .map(|(k, v)| (k.clone(), toml::Value::Float(*v)))
                    .collect(),
            ),
        );
    }
    if let Some(t) = d.end_time {
        keys.insert("end_time".into(), toml::Value::Float(t));
    }
    Ok((expression, keys))
}

/// `[desired]` of the resolved input: `kind` and the given keys (scalars for one number).
fn desired_keys(kind: &str, keys: &[(&str, &[f64])]) -> toml::Table {
    let mut t = toml::Table::new();
    t.insert("kind".into(), toml::Value::String(kind.into()));
    for (k, v) in keys {
        let value = match v {
            [x] if *k != "interval" => toml::Value::Float(*x),
            v => resolved::floats(v),
        };
        t.insert((*k).into(), value);
    }
    t
}

/// A built desired path with what the rest of the file needs from it.
struct Desired {
    kind: &'static str,
    path: Arc<dyn DesiredPath + Send + Sync>,
    /// The path's end point (for `omega_b = "desired_end"`).
    end_point: Vector3<f64>,
    /// Which keys move its start (for the error message).
    start_hint: &'static str,
    /// The path's natural end time (default start value of a free terminal time).
    end_time: Option<f64>,
    /// The key to blame when the path is not finite somewhere ([`check_path_finite`]), and
    /// why it is not and what to change.
    overflow: (&'static str, &'static str),
    /// Times where the path changes fastest (checked besides a uniform grid).
    special_times: Vec<f64>,
    /// The formulas of an expression path (checked for poles between the grid's points
    /// too, [`check_formulas`]).
    formulas: Option<Arc<crate::lie::expression::Expression>>,
    /// Its keys with every default filled in (`kind` included), and the file it read.
    resolved: (toml::Table, Option<Vec<u8>>),
}

/// Points of the uniform grid on `[t0, b]` at which [`check_path_finite`] evaluates the
/// path (besides `t0`, `b`, the path's end time and its special times).
pub(crate) const PATH_CHECK_POINTS: usize = 1025;

/// The desired path's value and first three derivatives (the BVP uses the first, the
/// start's singular control up to the third) must be finite in `f64` on `[t0, b]`: a
/// sigmoid narrower than `f64` can differentiate (`1/width³` overflows), samples `1e-300`
/// apart or a segment over `1e-300` time units give infinities, which the solver would only
/// report later as an unrelated failure ("Property 3 fails"). Checked at `t0`, `b`, the
/// path's end time and special times, and on a uniform grid.
fn check_path_finite(
    path: &dyn DesiredPath,
    what: &str,
    (t0, b): (f64, f64),
    special_times: &[f64],
    (field, fix): (&str, &str),
) -> Result<(), ConfigError> {
    let grid =
        (0..PATH_CHECK_POINTS).map(|k| t0 + (b - t0) * k as f64 / (PATH_CHECK_POINTS - 1) as f64);
    let times = [t0, b]
        .into_iter()
        .chain(special_times.iter().copied())
        .chain(grid);
    for t in times {
        let jet = path.jet(t);
        let finite = [jet.value, jet.d1, jet.d2, jet.d3]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite()));
        if !finite {
            return Err(ConfigError::Invalid {
                field: field.into(),
                message: format!(
                    "{what} or one of its first three time derivatives is not finite at t = {}: \
                     {fix}",
                    Num(t)
                ),
            });
        }
    }
    Ok(())
}

/// An expression path's formulas must be finite on `[t0, b]` with their first three
/// derivatives, at the [`PATH_CHECK_POINTS`] check times and between them (a pole between two
/// check times would otherwise reach the solver, which fails on it for an unrelated reason or,
/// worse, steps over it: `t/(t - 2.0001)` tracked over [0, 4] "converged").
/// When the path is `projected` onto an energy level set, they must not vanish together
/// either ([`crate::lie::expression::Expression::vanishes_near`]).
pub(crate) fn check_formulas(
    formulas: &crate::lie::expression::Expression,
    (t0, b): (f64, f64),
    projected: bool,
) -> Result<(), ConfigError> {
    use crate::lie::expression::Undefined;
    let Some(undefined) = formulas.check_defined(t0, b, PATH_CHECK_POINTS) else {
        return match formulas.vanishes_near(t0, b, PATH_CHECK_POINTS) {
            Some(t) if projected => Err(ConfigError::Invalid {
                field: "desired.components".into(),
                message: format!(
                    "the formulas vanish together near t = {}, where the desired path has no \
                     direction to project onto the energy level set of omega_a (it would flip \
                     across it): change the formulas so that they do not all vanish at once",
                    Num(t)
                ),
            }),
            _ => Ok(()),
        };
    };
    let (component, what) = match undefined {
        Undefined::At { component, t } => (
            component,
            format!(
                "it or one of its first three time derivatives is not finite at t = {} (e.g. \
                 log or sqrt of a negative number, a division by zero, or an overflow)",
                Num(t)
            ),
        ),
        Undefined::Near { component, t } => (
            component,
            format!(
                "it is unbounded near t = {}, or cannot be evaluated accurately there in f64 \
                 (a pole between the check times, where it is finite: a division by zero, tan \
                 at an odd multiple of pi/2, log near 0; or a cancellation such as (1 - \
                 cos(x))/x^2 near x = 0, which 2 sin(x/2)^2/x^2 avoids)",
                Num(t)
            ),
        ),
        Undefined::Jump { component, t, size } => (
            component,
            format!(
                "it jumps near t = {} by about {:.3e} (a sign or a step written through a division by \
                 zero, such as u/sqrt(u^2), atan(1/u) or tanh(1/u) at u = 0; the desired path \
                 must be continuous: write a step of width w as tanh((t - c)/w))",
                Num(t),
                size
            ),
        ),
    };
    Err(ConfigError::Invalid {
        field: format!("desired.components[{component}]"),
        message: format!(
            "{:?}: {what}; the desired path must be finite and smooth on [t0, b] = [{}, {}]: \
             change the formula",
            clip(formulas.components()[component].text()),
            Num(t0),
            Num(b)
        ),
    })
}

/// An expression path's `end_time`: finite, and after `t0` by at least
/// [`TIME_SPAN_REL_MIN`] of the times' size (as the terminal time must be).
pub(crate) fn expression_end_time(t: f64, t0: f64) -> Result<f64, ConfigError> {
    let t = finite("desired.end_time", t)?;
    if t <= t0 || t - t0 < TIME_SPAN_REL_MIN * t0.abs().max(t.abs()) {
        return Err(ConfigError::OutOfRange {
            field: "desired.end_time".into(),
            value: Num(t).to_string(),
            requirement: format!(
                "the path's end must come after t0 = {} (by at least {TIME_SPAN_REL_MIN:e} of \
                 the times' size): give the time at which the desired path ends",
                Num(t0)
            ),
        });
    }
    Ok(t)
}

/// When the desired path is not finite and twice the kinetic energy of `omega_a` lies
/// outside this range, its scale is named as the cause (not the times): the projection onto
/// the energy ellipsoid overflowed at 2E ≈ 1e-80 with a 4 s span (measured), and at 1e-60
/// the segment example still loads. Files of the generic models (`config::generic`) must lie
/// inside it: there an so4 body at 2E ≈ 1e-80 kept the direct start busy for minutes.
pub const ENERGY_SCALE_RANGE: (f64, f64) = (1e-60, 1e60);

/// `b − t0` must be at least this fraction of `max(|t0|, |b|)`. The solver evaluates the
/// desired path at `t = t0 + s (b − t0)`, rounded to ~`2.2e-16 |t|`; with the bound that is
/// at most `2.2e-10` of the span, i.e. `2.2e-4` of the smallest interval of a mesh graded a
/// million to one. (`t0` = 1.7e9, Unix seconds, with a 10 s span would round every time to
/// 2.4e-7 s.)
pub const TIME_SPAN_REL_MIN: f64 = 1e-6;

/// Terminal time as given, before defaults from the desired path.
enum Terminal {
    Fixed(f64),
    Free(Option<f64>),
}

const KINDS: &str = "\"paper-spiral\", \"segment\", \"constant\", \"samples\" or \"expression\"";

/// What is wrong with the rows of a samples file ([`parse_samples`]); lines are 1-based.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SamplesError {
    /// A field that is not a number (after the header line).
    #[error(
        "line {line}: {source} in {text:?}: a row is 4 decimal numbers t, omega1, omega2, \
         omega3 separated by commas (e.g. 0.25, 10, 0.24, 0.06): no other separator (tab, \
         space), no trailing comma, no hexadecimal or digit separators, and a header only on \
         the first line"
    )]
    NotANumber {
        /// The line.
        line: usize,
        /// The parser's reason.
        source: std::num::ParseFloatError,
        /// The line's text (at most [`MAX_ECHO_CHARS`] characters).
        text: String,
    },
    /// Not four fields.
    #[error(
        "line {line}: expected 4 comma-separated numbers t, omega1, omega2, omega3, got {found}"
    )]
    Columns {
        /// The line.
        line: usize,
        /// How many fields it has.
        found: usize,
    },
    /// NaN or infinity.
    #[error("line {line}: {value} is not a finite number")]
    NotFinite {
        /// The line.
        line: usize,
        /// The value.
        value: f64,
    },
    /// `Ω_d = 0`, which has no radial projection.
    #[error("line {line}: Omega_d = 0 cannot be projected onto the energy ellipsoid")]
    Zero {
        /// The line.
        line: usize,
    },
    /// `t` not after the previous row's.
    #[error("line {line}: t = {} does not increase (previous t = {})", Num(*t), Num(*previous))]
    NotIncreasing {
        /// The line.
        line: usize,
        /// Its `t`.
        t: f64,
        /// The previous row's `t`.
        previous: f64,
    },
    /// Fewer than two rows.
    #[error("needs at least 2 samples, found {found}")]
    TooFew {
        /// How many rows there are.
        found: usize,
    },
    /// More rows than [`MAX_SAMPLE_ROWS`].
    #[error("has more than {limit} rows (the cap on a samples file); use fewer samples")]
    TooMany {
        /// The cap.
        limit: usize,
    },
}

/// Why `desired.file` cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum SamplesProblem {
    /// An I/O error.
    #[error("cannot read it ({0})")]
    Read(std::io::Error),
    /// No regular file, too large, or not UTF-8.
    #[error("{0}")]
    File(FileProblem),
    /// A bad row.
    #[error("{0}")]
    Rows(SamplesError),
    /// The samples do not cover `t0`.
    #[error(
        "the samples cover [{}, {}], which must contain boundary.t0 = {} (and reach beyond it)",
        Num(*first),
        Num(*last),
        Num(*t0)
    )]
    Coverage {
        /// First `t`.
        first: f64,
        /// Last `t`.
        last: f64,
        /// `boundary.t0`.
        t0: f64,
    },
    /// The spline through the samples cannot be built.
    #[error("{0}")]
    Spline(SuslovError),
}

/// Samples of `Ω_d` as CSV: rows `t, omega1, omega2, omega3`; a leading byte order mark,
/// blank lines, `#` comments and a first line with no number in it (a header) are skipped.
/// At most [`MAX_SAMPLE_ROWS`] rows. Errors name the line.
pub fn parse_samples(text: &str) -> Result<(Vec<f64>, Vec<[f64; DIM]>), SamplesError> {
    let text = text.strip_prefix(BOM).unwrap_or(text);
    let mut times = Vec::new();
    let mut values = Vec::new();
    let mut first_content = true;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let numbers: Result<Vec<f64>, _> =
            line.split(',').map(|f| f.trim().parse::<f64>()).collect();
        let header = std::mem::replace(&mut first_content, false);
        let numbers = match numbers {
            Ok(n) => n,
            // A header has no number in it: a first row with a typo in one field is an error.
            Err(_) if header && line.split(',').all(|f| f.trim().parse::<f64>().is_err()) => {
                continue
            }
            Err(source) => {
                return Err(SamplesError::NotANumber {
                    line: i + 1,
                    source,
                    text: clip(line),
                })
            }
        };
        if numbers.len() != 1 + DIM {
            return Err(SamplesError::Columns {
                line: i + 1,
                found: numbers.len(),
            });
        }
        if let Some(&value) = numbers.iter().find(|x| !x.is_finite()) {
            return Err(SamplesError::NotFinite { line: i + 1, value });
        }
        if numbers[1..].iter().all(|x| *x == 0.0) {
            return Err(SamplesError::Zero { line: i + 1 });
        }
        if let Some(&previous) = times.last() {
            if numbers[0] <= previous {
                return Err(SamplesError::NotIncreasing {
                    line: i + 1,
                    t: numbers[0],
                    previous,
                });
            }
        }
        if times.len() == MAX_SAMPLE_ROWS {
            return Err(SamplesError::TooMany {
                limit: MAX_SAMPLE_ROWS,
            });
        }
        let (t, omega) = numbers.split_first().expect("1 + DIM numbers");
        times.push(*t);
        values.push(omega.try_into().expect("DIM numbers"));
    }
    if times.len() < 2 {
        return Err(SamplesError::TooFew { found: times.len() });
    }
    Ok((times, values))
}

impl ProblemFile {
    /// Check every field and build the problem; `default_name` is used without `name`, and
    /// a relative `desired.file` is looked up in `base_dir`.
    pub fn build(&self, default_name: &str, base_dir: &Path) -> Result<LoadedProblem, ConfigError> {
        self.build_named(&DefaultName::Fixed(default_name.to_string()), base_dir)
    }

    /// The case name: `name`, or the default; either must be one line of printable text of
    /// at most [`MAX_NAME_CHARS`] characters.
    fn case_name(&self, default: &DefaultName) -> Result<String, ConfigError> {
        let (name, origin) = match (&self.name, default) {
            (Some(n), _) => (n.as_str(), None),
            (None, DefaultName::FileStem(n)) => (n.as_str(), Some("the file name")),
            (None, DefaultName::Fixed(n)) => (n.as_str(), Some("the default name")),
        };
        let invalid = |what: String| {
            let message = match origin {
                None => format!(
                    "{what}; give a single line of at most {MAX_NAME_CHARS} characters or \
                     remove the key"
                ),
                Some(origin) => format!(
                    "not given, and {origin} \"{}\" {what}; add name = \"my_case\" at the top \
                     of the file",
                    clip(name).escape_debug()
                ),
            };
            ConfigError::Invalid {
                field: "name".into(),
                message,
            }
        };
        if name.trim().is_empty() {
            return Err(invalid("is empty".into()));
        }
        let chars = name.chars().count();
        if chars > MAX_NAME_CHARS {
            return Err(invalid(format!(
                "has {chars} characters, at most {MAX_NAME_CHARS} (the name labels \
                 summary.json and every figure title)"
            )));
        }
        if let Some((k, c)) = name.chars().enumerate().find(|(_, c)| c.is_control()) {
            return Err(invalid(format!(
                "contains the control character U+{:04X} at character {}: a case name is one \
                 line of printable text (it labels summary.json and every figure title)",
                u32::from(c),
                k + 1
            )));
        }
        Ok(name.to_string())
    }

    fn build_named(
        &self,
        default_name: &DefaultName,
        base_dir: &Path,
    ) -> Result<LoadedProblem, ConfigError> {
        let name = self.case_name(default_name)?;
        if let Some(model) = self.model.as_deref().filter(|m| *m != "so3") {
            return Err(ConfigError::Invalid {
                field: "model".into(),
                message: format!(
                    "{:?}: this command reads so(3) problem files only (so far); files of the \
                     other models ({}) are solved by `suslov solve`",
                    clip(model),
                    crate::model::MODEL_NAMES.join(", ")
                ),
            });
        }
        // [body]
        let body = self.body.as_ref().ok_or_else(|| {
            missing(
                "body",
                "add a [body] table with inertia = [I1, I2, I3] (principal moments, > 0)",
            )
        })?;
        let inertia = exact(
            "body.inertia",
            body.inertia.ok_or_else(|| {
                missing(
                    "body.inertia",
                    "add inertia = [I1, I2, I3] under [body] (principal moments, > 0)",
                )
            })?,
            "I1, I2, I3",
        )?;
        for (i, m) in inertia.iter().enumerate() {
            positive(
                &format!("body.inertia[{i}]"),
                *m,
                "a principal moment of inertia of a rigid body is positive",
            )?;
        }
        let inertia = Inertia::new(inertia).map_err(|e| ConfigError::Invalid {
            field: "body.inertia".into(),
            message: e.to_string(),
        })?;

        // [boundary]
        let boundary = self.boundary.as_ref().ok_or_else(|| {
            missing(
                "boundary",
                "add a [boundary] table with omega_a, omega_b and terminal_time",
            )
        })?;
        let t0 = finite("boundary.t0", boundary.t0.unwrap_or(0.0))?;
        let omega_a = vector3(
            "boundary.omega_a",
            boundary.omega_a.ok_or_else(|| {
                missing(
                    "boundary.omega_a",
                    "add omega_a = [x, y, z] under [boundary] (the angular velocity at t0)",
                )
            })?,
        )?;
        if omega_a.iter().all(|x| *x == 0.0) {
            return Err(ConfigError::ZeroVector {
                field: "boundary.omega_a".into(),
                why: "omega_a fixes the kinetic energy, i.e. the ellipsoid every trajectory \
                      stays on, and the start direction of the desired paths",
            });
        }
        let ellipsoid =
            EnergyEllipsoid::through(inertia, &omega_a).map_err(|_| ConfigError::Invalid {
                field: "boundary.omega_a".into(),
                message: format!(
                    "twice its kinetic energy <omega_a, I omega_a> = {:e} is not a normal \
                     positive f64 (overflow, or below 2.2e-308: too few significant bits); \
                     rescale omega_a or body.inertia",
                    inertia.apply(&omega_a).dot(&omega_a)
                ),
            })?;
        let energy2 = inertia.apply(&omega_a).dot(&omega_a);
        // As for the generic models: far from 2E ~ 1 the tolerances lose their meaning (the
        // projection no longer overflows there to say so, since it rescales).
        if !(ENERGY_SCALE_RANGE.0..=ENERGY_SCALE_RANGE.1).contains(&energy2) {
            return Err(ConfigError::Invalid {
                field: "boundary.omega_a".into(),
                message: format!(
                    "twice the kinetic energy <omega_a, I omega_a> = {energy2:e} is outside \
                     [{:e}, {:e}], where the solver's tolerances lose their meaning; rescale \
                     omega_a, omega_b and the desired path (or body.inertia) towards 2E ~ 1: \
                     the motion and the cost depend on them only up to constant factors",
                    ENERGY_SCALE_RANGE.0, ENERGY_SCALE_RANGE.1
                ),
            });
        }
        let tt = boundary.terminal_time.as_ref().ok_or_else(|| {
            missing(
                "boundary.terminal_time",
                "add terminal_time = { fixed = 10.0 } or terminal_time = { free = true, \
                 guess = 10.0 } under [boundary]",
            )
        })?;
        let terminal = match (tt.free, tt.fixed, tt.guess) {
            (Some(true), Some(_), _) | (None, Some(_), Some(_)) => {
                return Err(ConfigError::TerminalTime {
                    field: "boundary.terminal_time".into(),
                    message: "give either { fixed = b } or { free = true, guess = b }, not both"
                        .into(),
                })
            }
            (Some(false) | None, Some(b), None) => {
                Terminal::Fixed(finite("boundary.terminal_time.fixed", b)?)
            }
            (Some(true), None, guess) => Terminal::Free(
                guess
                    .map(|g| finite("boundary.terminal_time.guess", g))
                    .transpose()?,
            ),
            (Some(false), None, _) => {
                return Err(ConfigError::TerminalTime {
                    field: "boundary.terminal_time.fixed".into(),
                    message: "free = false needs the fixed terminal time: write \
                              { fixed = b } (b > t0)"
                        .into(),
                })
            }
            (Some(false), Some(_), Some(_)) => {
                return Err(ConfigError::TerminalTime {
                    field: "boundary.terminal_time.guess".into(),
                    message: "a guess is only used with free = true; remove it".into(),
                })
            }
            (None, None, _) => {
                return Err(ConfigError::TerminalTime {
                    field: "boundary.terminal_time".into(),
                    message: "say whether b is fixed or free: { fixed = b } or \
                              { free = true, guess = b }"
                        .into(),
                })
            }
        };
        if let Terminal::Fixed(b) | Terminal::Free(Some(b)) = terminal {
            if b <= t0 {
                let key = if matches!(terminal, Terminal::Fixed(_)) {
                    "boundary.terminal_time.fixed"
                } else {
                    "boundary.terminal_time.guess"
                };
                return Err(ConfigError::TerminalTime {
                    field: key.into(),
                    message: format!(
                        "terminal time {} must be greater than boundary.t0 = {}; \
                         give a later time",
                        Num(b),
                        Num(t0)
                    ),
                });
            }
        }

        // [cost]
        let cost = self.cost.as_ref().ok_or_else(|| {
            missing(
                "cost",
                "add a [cost] table with alpha, beta, gamma (and optionally eta, delta)",
            )
        })?;
        let weight = |key: &str, v: Option<f64>, example: &str| {
            v.ok_or_else(|| {
                missing(
                    &format!("cost.{key}"),
                    format!("add {key} = <number> under [cost], e.g. {key} = {example}"),
                )
            })
        };
        let alpha = finite("cost.alpha", weight("alpha", cost.alpha, "1.0")?)?;
        let beta = finite("cost.beta", weight("beta", cost.beta, "0.1")?)?;
        let gamma = weight("gamma", cost.gamma, "1.0")?;
        if alpha <= 0.0 {
            return Err(ConfigError::Singular {
                field: "cost.alpha".into(),
                value: alpha,
                why: "the constraint <Omega, xi> = 0 does not fix the length of xi, only the \
                      term alpha/4 (|xi|^2 - 1)^2 does; without it xi -> c xi is a symmetry \
                      and the optimality system has no unique solution",
                example: "alpha = 1.0",
            });
        }
        if beta <= 0.0 {
            return Err(ConfigError::Singular {
                field: "cost.beta".into(),
                value: beta,
                why: "beta/2 |xi'|^2 is the only term with the control's derivative; with \
                      beta = 0 the Euler-Lagrange equations do not determine xi'' (paper \
                      section 4.4, a singular optimal control problem)",
                example: "beta = 0.1",
            });
        }
        let gamma = non_negative(
            "cost.gamma",
            gamma,
            "a negative weight would reward leaving the desired path",
        )?;
        let eta = non_negative(
            "cost.eta",
            cost.eta.unwrap_or(0.0),
            "a negative weight would reward large |Omega'|",
        )?;
        let delta = non_negative(
            "cost.delta",
            cost.delta.unwrap_or(0.0),
            "a negative time weight would reward long motions",
        )?;

        // [desired]
        // With gamma = 0 Omega_d is not part of the cost: the table may be left out, and the
        // projected segment omega_a -> omega_b (the solver's start path) stands in for it.
        let segment_default = DesiredSection {
            kind: Some("segment".into()),
            ..DesiredSection::default()
        };
        let desired_section = match &self.desired {
            Some(d) => d,
            None if gamma == 0.0 => &segment_default,
            None => {
                return Err(missing(
                    "desired",
                    format!(
                        "add a [desired] table with kind = {KINDS} (the path Omega_d that \
                         cost.gamma > 0 tracks; with gamma = 0 the table may be left out)"
                    ),
                ))
            }
        };
        let kind = desired_section.kind.as_deref().ok_or_else(|| {
            missing(
                "desired.kind",
                format!("add kind = {KINDS} under [desired]"),
            )
        })?;
        let desired = self.build_desired(
            base_dir,
            kind,
            desired_section,
            inertia,
            &ellipsoid,
            omega_a,
            t0,
            &terminal,
        )?;

        // Terminal time, with the desired path's default guess.
        let terminal = match terminal {
            Terminal::Fixed(b) => TerminalTime::Fixed(b),
            Terminal::Free(Some(g)) => TerminalTime::Free { guess: g },
            Terminal::Free(None) => {
                let guess = desired.end_time.ok_or_else(|| {
                    missing(
                        "boundary.terminal_time.guess",
                        format!(
                            "a free terminal time needs a start value with kind = \
                             \"{kind}\": write terminal_time = {{ free = true, guess = b }}"
                        ),
                    )
                })?;
                if guess <= t0 {
                    return Err(ConfigError::TerminalTime {
                        field: "boundary.terminal_time.guess".into(),
                        message: format!(
                            "the default guess {} (the desired path's end time) is not \
                             after boundary.t0 = {}; give guess = b > t0",
                            Num(guess),
                            Num(t0)
                        ),
                    });
                }
                TerminalTime::Free { guess }
            }
        };

        let b = terminal.initial();
        if b - t0 < TIME_SPAN_REL_MIN * t0.abs().max(b.abs()) {
            return Err(ConfigError::OutOfRange {
                field: "boundary.t0".into(),
                value: Num(t0).to_string(),
                requirement: format!(
                    "the time span b - t0 = {} is below {TIME_SPAN_REL_MIN:e} of |t0| (b = {}): \
                     times near t0 are rounded to ~{:.1e} in f64, too coarse for this span; \
                     shift the time origin (t0 = 0, and the desired path's times with it)",
                    Num(b - t0),
                    Num(b),
                    f64::EPSILON * t0.abs().max(b.abs())
                ),
            });
        }
        if let Some(formulas) = &desired.formulas {
            check_formulas(formulas, (t0, b), true)?;
        }
        check_path_finite(
            &*desired.path,
            &format!("the desired path ([desired] kind = \"{}\")", desired.kind),
            (t0, b),
            &desired.special_times,
            desired.overflow,
        )?;

        // Omega_b.
        let omega_b_spec = boundary.omega_b.ok_or_else(|| {
            missing(
                "boundary.omega_b",
                "add omega_b = [x, y, z] (on omega_a's energy ellipsoid) or omega_b = \
                 \"desired_end\" under [boundary]",
            )
        })?;
        if matches!(omega_b_spec, OmegaBSpec::DesiredEnd)
            && !desired.end_point.iter().all(|v| v.is_finite())
        {
            return Err(missing(
                "desired.end_time",
                format!(
                    "omega_b = \"desired_end\" takes the desired path's end point, and kind = \
                     \"{}\" has none: add end_time = <t> under [desired], or give omega_b = \
                     [x, y, z]",
                    desired.kind
                ),
            ));
        }
        let omega_b = match omega_b_spec {
            OmegaBSpec::DesiredEnd => desired.end_point,
            OmegaBSpec::Vector(v) => vector3("boundary.omega_b", v)?,
        };
        let field = match omega_b_spec {
            OmegaBSpec::DesiredEnd => "boundary.omega_b (= \"desired_end\")",
            OmegaBSpec::Vector(_) => "boundary.omega_b",
        };
        let omega_b = onto_ellipsoid(field, &ellipsoid, &omega_b)?;

        // The solver's fallback start (gamma = 0, start = "segment", or a desired path that
        // violates Property 1 or 3) is the projected segment omega_a -> omega_b on [t0, b]:
        // it must be finite too (a tiny b - t0 overflows its derivatives).
        if let Ok(segment) = ProjectedSegment::new(inertia, omega_a, omega_b, t0, b) {
            check_path_finite(
                &segment,
                "the solver's start path (the projected segment from omega_a to omega_b over \
                 [t0, b])",
                (t0, b),
                &[],
                (
                    "boundary.terminal_time",
                    "it overflows f64, as its derivatives grow like 1/(b - t0)^3: give a \
                     later terminal time",
                ),
            )?;
        }

        // The desired path starts at Omega_a.
        if gamma > 0.0 {
            let start = desired.path.value(t0);
            let distance = (start - omega_a).norm();
            let relative = distance / omega_a.norm();
            if relative.is_nan() || relative > DESIRED_START_REL_TOL {
                return Err(ConfigError::DesiredStart {
                    kind: desired.kind.to_string(),
                    start: start.into(),
                    omega_a: omega_a.into(),
                    distance,
                    relative,
                    hint: desired.start_hint,
                });
            }
        }

        let mut options = self.solve_options(beta, gamma)?;
        if let Some(from) = self.solver.as_ref().and_then(|s| s.start_from.as_deref()) {
            use crate::model::generated as g;
            options.warm_start = Some(read_warm_start(
                base_dir,
                from,
                &g::STATE_NAMES,
                g::KAPPA,
                t0,
            )?);
        }
        let resolved = self.resolved(
            &name,
            (t0, omega_a, omega_b_spec),
            &terminal,
            [alpha, beta, gamma, eta, delta],
            &desired,
            &options,
        );
        let problem = SuslovProblem {
            inertia,
            weights: CostWeights {
                alpha,
                beta,
                gamma,
                eta,
                delta,
            },
            t0,
            omega_a,
            omega_b,
            terminal,
            desired: desired.path,
        };
        problem.validate().map_err(problem_error)?;
        let warnings = triangle_warning(problem.inertia.diag().into())
            .into_iter()
            .collect();
        Ok(LoadedProblem {
            name,
            problem,
            options,
            warnings,
            resolved,
        })
    }

    /// The resolved input ([`resolved`]) of a file whose values were checked: the given
    /// values as read, the defaults as used.
    fn resolved(
        &self,
        name: &str,
        (t0, omega_a, omega_b): (f64, Vector3<f64>, OmegaBSpec),
        terminal: &TerminalTime,
        [alpha, beta, gamma, eta, delta]: [f64; 5],
        desired: &Desired,
        options: &SolveOptions,
    ) -> ResolvedInput {
        use resolved::{floats, section};
        let mut t = toml::Table::new();
        t.insert("model".into(), toml::Value::String("so3".into()));
        t.insert("name".into(), toml::Value::String(name.into()));
        if let Some(Numbers::Exact(i)) = self.body.as_ref().and_then(|b| b.inertia) {
            section(&mut t, "body").insert("inertia".into(), floats(&i));
        }
        let boundary = section(&mut t, "boundary");
        boundary.insert("t0".into(), toml::Value::Float(t0));
        boundary.insert("omega_a".into(), floats(omega_a.as_slice()));
        boundary.insert(
            "omega_b".into(),
            match omega_b {
                OmegaBSpec::DesiredEnd => toml::Value::String("desired_end".into()),
                OmegaBSpec::Vector(Numbers::Exact(v)) => floats(&v),
                OmegaBSpec::Vector(Numbers::WrongLength(_)) => {
                    unreachable!("checked by vector3")
                }
            },
        );
        let fixed = match terminal {
            TerminalTime::Fixed(b) => Some(*b),
            TerminalTime::Free { .. } => None,
        };
        boundary.insert(
            "terminal_time".into(),
            resolved::terminal_time(fixed, terminal.initial()),
        );
        let weights = CostWeights {
            alpha,
            beta,
            gamma,
            eta,
            delta,
        };
        t.insert(
            "cost".into(),
            toml::Value::Table(resolved::so3_cost(&weights)),
        );
        let (keys, raw) = &desired.resolved;
        t.insert("desired".into(), toml::Value::Table(keys.clone()));
        let (solver, start_file) = resolved::solver(options, &crate::model::generated::STATE_NAMES);
        t.insert("solver".into(), toml::Value::Table(solver));
        let files = raw
            .iter()
            .map(|b| (resolved::SAMPLES_FILE.to_string(), b.clone()))
            .chain(start_file)
            .collect();
        ResolvedInput { table: t, files }
    }

    #[allow(clippy::too_many_arguments)]
    fn build_desired(
        &self,
        base_dir: &Path,
        kind: &str,
        d: &DesiredSection,
        inertia: Inertia,
        ellipsoid: &EnergyEllipsoid,
        omega_a: Vector3<f64>,
        t0: f64,
        terminal: &Terminal,
    ) -> Result<Desired, ConfigError> {
        match kind {
            "paper-spiral" => {
                reject_unused(d, kind, &["c", "width", "b_d"])?;
                let paper = PaperSpiral::paper();
                let c = finite("desired.c", d.c.unwrap_or(paper.c()))?;
                let width = positive(
                    "desired.width",
                    d.width.unwrap_or(paper.width()),
                    "the time scale of the sigmoid switching to the end point",
                )?;
                let b_d = finite("desired.b_d", d.b_d.unwrap_or(paper.b_d()))?;
                if b_d <= t0 {
                    return Err(ConfigError::OutOfRange {
                        field: "desired.b_d".into(),
                        value: Num(b_d).to_string(),
                        requirement: format!(
                            "the switching time must be after boundary.t0 = {}; give a \
                             later b_d",
                            Num(t0)
                        ),
                    });
                }
                let spiral = PaperSpiral::new(c, width, b_d, inertia, omega_a).map_err(|e| {
                    ConfigError::Invalid {
                        field: "desired".into(),
                        message: format!("{e}; change c or b_d"),
                    }
                })?;
                let end_point = spiral.omega_b();
                Ok(Desired {
                    kind: "paper-spiral",
                    path: Arc::new(spiral),
                    end_point,
                    start_hint: "the spiral starts on the ray of [c, t0 cos t0, t0 sin t0]; \
                                 with t0 = 0 any omega_a = [x, 0, 0] with x > 0 and c > 0",
                    end_time: Some(b_d),
                    overflow: (
                        "desired.width",
                        "it overflows f64, as the sigmoid's derivatives grow like 1/width^3: \
                         give a larger width (or smaller c, b_d)",
                    ),
                    special_times: vec![b_d],
                    formulas: None,
                    resolved: (
                        desired_keys(kind, &[("c", &[c]), ("width", &[width]), ("b_d", &[b_d])]),
                        None,
                    ),
                })
            }
            "segment" => {
                reject_unused(d, kind, &["from", "to", "interval"])?;
                let from = match d.from {
                    Some(v) => vector3("desired.from", v)?,
                    None => omega_a,
                };
                // The key `to` comes from (the message must name a key in the file).
                let (to_key, to) = match (d.to, self.boundary.as_ref().and_then(|b| b.omega_b)) {
                    (Some(v), _) => ("desired.to", vector3("desired.to", v)?),
                    (None, Some(OmegaBSpec::Vector(v))) => {
                        ("boundary.omega_b", vector3("boundary.omega_b", v)?)
                    }
                    (None, _) => {
                        return Err(missing(
                            "desired.to",
                            "the segment's end point defaults to boundary.omega_b, which is \
                             \"desired_end\" (or missing) here: add to = [x, y, z] under \
                             [desired]",
                        ))
                    }
                };
                let from_key = if d.from.is_some() {
                    "desired.from"
                } else {
                    "boundary.omega_a"
                };
                let (a, b) = match (d.interval, terminal) {
                    (Some(interval), _) => {
                        let [a, b] = exact("desired.interval", interval, "t_start, t_end")?;
                        (
                            finite("desired.interval[0]", a)?,
                            finite("desired.interval[1]", b)?,
                        )
                    }
                    (None, Terminal::Fixed(b) | Terminal::Free(Some(b))) => (t0, *b),
                    (None, Terminal::Free(None)) => {
                        return Err(missing(
                            "desired.interval",
                            "give interval = [t_start, t_end] under [desired] or a guess in \
                             boundary.terminal_time",
                        ))
                    }
                };
                if a >= b {
                    return Err(ConfigError::OutOfRange {
                        field: "desired.interval".into(),
                        value: format!("[{}, {}]", Num(a), Num(b)),
                        requirement: "needs start < end; give interval = [t_start, t_end]".into(),
                    });
                }
                let resolved = desired_keys(
                    kind,
                    &[
                        ("from", from.as_slice()),
                        ("to", to.as_slice()),
                        ("interval", &[a, b]),
                    ],
                );
                let from = onto_ellipsoid(from_key, ellipsoid, &from)?;
                let to = onto_ellipsoid(to_key, ellipsoid, &to)?;
                let segment =
                    ProjectedSegment::new(inertia, from, to, a, b).map_err(|e| match e {
                        SuslovError::SegmentThroughOrigin { .. } => ConfigError::Invalid {
                            field: to_key.into(),
                            message: format!(
                                "{e}; choose end points that are not opposite (or go \
                                 through a point in between with a samples path)"
                            ),
                        },
                        other => ConfigError::Invalid {
                            field: "desired".into(),
                            message: other.to_string(),
                        },
                    })?;
                Ok(Desired {
                    kind: "segment",
                    path: Arc::new(segment),
                    end_point: to,
                    start_hint: "set desired.from = omega_a (the default) and \
                                 desired.interval[0] = t0",
                    end_time: Some(b),
                    overflow: if d.interval.is_some() {
                        (
                            "desired.interval",
                            "it overflows f64, as its derivatives grow like 1/(t_end - \
                             t_start)^3: give a longer interval",
                        )
                    } else {
                        (
                            "boundary.terminal_time",
                            "it overflows f64, as the segment spans [t0, b] and its \
                             derivatives grow like 1/(b - t0)^3: give a later terminal time",
                        )
                    },
                    special_times: vec![a, b],
                    formulas: None,
                    resolved: (resolved, None),
                })
            }
            "constant" => {
                reject_unused(d, kind, &["value"])?;
                let value = vector3(
                    "desired.value",
                    d.value.ok_or_else(|| {
                        missing("desired.value", "add value = [x, y, z] under [desired]")
                    })?,
                )?;
                Ok(Desired {
                    kind: "constant",
                    path: Arc::new(Constant(value)),
                    end_point: value,
                    start_hint: "value = omega_a; or set cost.gamma = 0, then Omega_d is not \
                                 part of the cost",
                    end_time: None,
                    overflow: ("desired.value", "it overflows f64: give a smaller value"),
                    special_times: vec![],
                    formulas: None,
                    resolved: (desired_keys(kind, &[("value", value.as_slice())]), None),
                })
            }
            "samples" => {
                reject_unused(d, kind, &["file"])?;
                let file = d.file.as_deref().ok_or_else(|| {
                    missing(
                        "desired.file",
                        "add file = \"omega_d.csv\" under [desired] (columns t, omega1, \
                         omega2, omega3; relative to the problem file)",
                    )
                })?;
                let path = base_dir.join(file);
                let bad = |problem| ConfigError::Samples {
                    path: path.clone(),
                    problem,
                };
                let bytes = read_bounded(&path, MAX_SAMPLES_FILE_BYTES).map_err(|e| {
                    bad(match e {
                        ReadFailure::Io(e) => SamplesProblem::Read(e),
                        ReadFailure::File(p) => SamplesProblem::File(p),
                    })
                })?;
                let raw = bytes.clone();
                let text = decode(bytes, false).map_err(|p| bad(SamplesProblem::File(p)))?;
                let (times, values) =
                    parse_samples(&text).map_err(|e| bad(SamplesProblem::Rows(e)))?;
                drop(text);
                let (first, last) = (times[0], times[times.len() - 1]);
                if !(first <= t0 && t0 < last) {
                    return Err(bad(SamplesProblem::Coverage { first, last, t0 }));
                }
                let spline = SampledPath::new(&times, &values)
                    .map_err(|e| bad(SamplesProblem::Spline(e)))?;
                let path = Projected::new(spline, *ellipsoid);
                let end_point = path.value(last);
                Ok(Desired {
                    kind: "samples",
                    path: Arc::new(path),
                    end_point,
                    start_hint: "the first sample, projected radially onto the energy \
                                 ellipsoid, must be omega_a",
                    end_time: Some(last),
                    overflow: (
                        "desired.file",
                        "it overflows f64, as the spline's derivatives grow like (value \
                         change)/(t spacing)^3: space the samples further apart or make them \
                         smaller",
                    ),
                    special_times: vec![first, last],
                    formulas: None,
                    resolved: (
                        {
                            let mut t = desired_keys(kind, &[]);
                            t.insert(
                                "file".into(),
                                toml::Value::String(resolved::SAMPLES_FILE.into()),
                            );
                            t
                        },
                        Some(raw),
                    ),
                })
            }
            "expression" => {
                reject_unused(d, kind, &["components", "constants", "end_time"])?;
                let (expression, keys) = expression_path(d, DIM)?;
                let expression = Arc::new(expression);
                let end_time = d.end_time.map(|t| expression_end_time(t, t0)).transpose()?;
                let path = ProjectedPath {
                    inner: Arc::new(crate::so3::desired::FromLiePath(expression.clone())),
                    ellipsoid: *ellipsoid,
                };
                // Without an end time there is no end point: "desired_end" says so (NaN is
                // caught there).
                let end_point = end_time.map_or(Vector3::from_element(f64::NAN), |t| path.value(t));
                Ok(Desired {
                    kind: "expression",
                    path: Arc::new(path),
                    end_point,
                    start_hint: "the formulas at t0, projected radially onto the energy \
                                 ellipsoid, must give omega_a",
                    end_time,
                    overflow: (
                        "desired.components",
                        "the formulas are finite there with their derivatives, so their vector \
                         vanishes (it has no radial projection onto the energy ellipsoid) or \
                         its projection overflows f64: change the formulas so that they do not \
                         all vanish at once",
                    ),
                    special_times: end_time.into_iter().collect(),
                    formulas: Some(expression),
                    resolved: (keys, None),
                })
            }
            other => Err(ConfigError::Invalid {
                field: "desired.kind".into(),
                message: format!("unknown kind {:?}; use {KINDS}", clip(other)),
            }),
        }
    }

    /// `[solver]`, checked against the caps and ranges above; `beta` and `gamma` are the
    /// cost weights.
    pub(crate) fn solve_options(&self, beta: f64, gamma: f64) -> Result<SolveOptions, ConfigError> {
        let mut o = SolveOptions::default();
        let Some(s) = &self.solver else {
            return Ok(o);
        };
        let in_range = |field: &str, v: f64, (lo, hi): (f64, f64), why: &str| {
            finite(field, v)?;
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(ConfigError::OutOfRange {
                    field: field.into(),
                    value: Num(v).to_string(),
                    requirement: format!("must lie between {lo:e} and {hi:e}: {why}"),
                })
            }
        };
        if let Some(v) = s.tolerance {
            o.tol = in_range(
                "solver.tolerance",
                v,
                TOLERANCE_RANGE,
                "below, f64 round-off keeps Newton from converging; above, no solution can \
                 pass its a-posteriori checks (e.g. 1e-8)",
            )?;
        }
        if let Some(v) = s.continuation_tolerance {
            o.continuation_tol = in_range(
                "solver.continuation_tolerance",
                v,
                CONTINUATION_TOLERANCE_RANGE,
                "below, f64 round-off keeps Newton from converging; above, the continuation \
                 steps lose the path (e.g. 1e-4)",
            )?;
        }
        if let Some(v) = s.beta_m {
            let (lo, hi) = (BETA_M_MIN_RATIO * beta, beta);
            finite("solver.beta_m", v)?;
            if !(lo..=hi).contains(&v) {
                return Err(ConfigError::OutOfRange {
                    field: "solver.beta_m".into(),
                    value: Num(v).to_string(),
                    requirement: format!(
                        "must lie between {} and cost.beta = {} (the analytic start solves \
                         the problem at beta = beta_m, valid for small beta, and continues \
                         beta_m -> beta; the default is 1e-2 min(alpha, beta, gamma or 1)); \
                         remove it or give e.g. {}",
                        Num(lo),
                        Num(hi),
                        Num(1e-2 * beta)
                    ),
                });
            }
            o.beta_m = Some(v);
        }
        // The caps first: a huge initial_intervals is its own error, not max_nodes'.
        let capped = |field: &str, n: usize, (lo, cap): (usize, usize), what: &str| {
            if (lo..=cap).contains(&n) {
                Ok(n)
            } else {
                Err(ConfigError::OutOfRange {
                    field: field.into(),
                    value: n.to_string(),
                    requirement: if n < lo {
                        format!("must be >= {lo} ({what})")
                    } else {
                        format!(
                            "at most {cap} ({what}); a BVP node costs ~{} kB of memory \
                             (measured), so the cap bounds a solve to ~{:.1} GB",
                            MEMORY_PER_NODE_BYTES / 1000,
                            (cap as u64 * MEMORY_PER_NODE_BYTES) as f64 / 1e9
                        )
                    },
                })
            }
        };
        if let Some(n) = s.initial_intervals {
            o.initial_intervals = capped(
                "solver.initial_intervals",
                n,
                (2, MAX_INITIAL_INTERVALS),
                "intervals of the initial mesh, e.g. 200",
            )?;
        }
        if let Some(n) = s.max_nodes {
            o.max_nodes = capped(
                "solver.max_nodes",
                n,
                (3, MAX_NODES),
                "node cap of every BVP solve, e.g. 20000",
            )?;
        }
        if let Some(n) = s.max_routes {
            if !(1..=MAX_ROUTES).contains(&n) {
                return Err(ConfigError::OutOfRange {
                    field: "solver.max_routes".into(),
                    value: n.to_string(),
                    requirement: format!(
                        "must be in [1, {MAX_ROUTES}]: the homotopy routes tried, the default \
                         included (1 tries only the default; there are at most 5 others)"
                    ),
                });
            }
            o.max_routes = n;
        }
        if let Some(start) = &s.start {
            o.start = match resolved::START_KEYS.iter().find(|(k, _)| k == start) {
                Some((_, strategy)) => *strategy,
                None => {
                    return Err(ConfigError::Invalid {
                        field: "solver.start".into(),
                        message: format!(
                            "unknown start {:?}; use \"auto\" (default), \"desired\", \
                             \"desired-gamma-from-zero\" or \"segment\"",
                            clip(start)
                        ),
                    })
                }
            };
            let from_desired = matches!(
                o.start,
                StartStrategy::Desired | StartStrategy::DesiredGammaFromZero
            );
            if from_desired && gamma == 0.0 {
                return Err(ConfigError::Invalid {
                    field: "solver.start".into(),
                    message: format!(
                        "start = {start:?} starts from the desired path, which is not part of \
                         the cost with cost.gamma = 0; use \"auto\" or \"segment\", or a \
                         gamma > 0"
                    ),
                });
            }
        }
        if o.max_nodes <= o.initial_intervals {
            // Only reachable with both keys given (the default max_nodes exceeds the cap on
            // initial_intervals); suggest a value above initial_intervals within the cap.
            let suggestion = SolveOptions::default()
                .max_nodes
                .max(2 * (o.initial_intervals + 1))
                .min(MAX_NODES);
            return Err(ConfigError::OutOfRange {
                field: "solver.max_nodes".into(),
                value: o.max_nodes.to_string(),
                requirement: format!(
                    "must exceed solver.initial_intervals = {} (the initial mesh has that \
                     many intervals plus one nodes); e.g. {suggestion}",
                    o.initial_intervals
                ),
            });
        }
        Ok(o)
    }
}

/// A [`ProblemError`] from [`SuslovProblem::validate`] with the field's TOML path (the checks
/// above catch these first; this is the safety net).
fn problem_error(e: ProblemError) -> ConfigError {
    let path = |field: &str| -> String {
        let base = field.split('[').next().unwrap_or(field);
        match base {
            "alpha" | "beta" | "gamma" | "eta" | "delta" => format!("cost.{field}"),
            "terminal_time" => "boundary.terminal_time".into(),
            _ => format!("boundary.{field}"),
        }
    };
    match e {
        ProblemError::NotFinite { field, value } => ConfigError::NotFinite {
            field: path(field),
            value,
        },
        ProblemError::Weight {
            field,
            value,
            requirement,
        } => ConfigError::OutOfRange {
            field: path(field),
            value: Num(value).to_string(),
            requirement: requirement.to_string(),
        },
        ProblemError::OffEllipsoid {
            omega_b,
            mismatch,
            projection,
        } => ConfigError::OffEllipsoid {
            field: "boundary.omega_b".into(),
            value: omega_b,
            mismatch,
            projection,
        },
        ProblemError::ZeroOmegaB => ConfigError::ZeroVector {
            field: "boundary.omega_b".into(),
            why: "Suslov's equations conserve omega_a's kinetic energy, so no motion reaches 0",
        },
        ProblemError::ZeroOmegaA => ConfigError::ZeroVector {
            field: "boundary.omega_a".into(),
            why: "it fixes the kinetic energy of the motion",
        },
        ProblemError::EnergyOutOfRange { level } => ConfigError::Invalid {
            field: "boundary.omega_a".into(),
            message: format!(
                "twice its kinetic energy <omega_a, I omega_a> = {level:e} is not a normal \
                 positive f64; rescale omega_a or body.inertia"
            ),
        },
        ProblemError::EmptyInterval { t0, b } => ConfigError::TerminalTime {
            field: "boundary.terminal_time".into(),
            message: format!(
                "terminal time {} must be greater than boundary.t0 = {}",
                Num(b),
                Num(t0)
            ),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::field_at;

    #[test]
    fn field_paths_from_positions() {
        let src = "name = \"x\"\n[cost]\nbeta = \"y\"\n[boundary]\nterminal_time = { fixd = 3 }\n";
        let at = |needle: &str| field_at(src, src.find(needle).unwrap());
        assert_eq!(at("\"y\"").as_deref(), Some("cost.beta"));
        assert_eq!(at("fixd").as_deref(), Some("boundary.terminal_time.fixd"));
        assert_eq!(at("3 }").as_deref(), Some("boundary.terminal_time.fixd"));
        assert_eq!(at("[cost]").as_deref(), Some("cost"));
        assert_eq!(at("\"x\"").as_deref(), Some("name"));
        assert_eq!(at("beta").as_deref(), Some("cost.beta"));
    }
}
