//! The machine-readable run summary (`summary.json`).
//!
//! JSON has no NaN or infinity. Every `f64` here is serialised through
//! [`finite_or_null`]: a non-finite value becomes `null` (and `null` reads back as NaN), so
//! a failed or partial case still produces valid JSON that says "no number here".

use super::{write_atomic, ReportError};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The whole run: the tool that wrote it and one entry per solved case.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Which build wrote this file (empty in files written before it was recorded).
    #[serde(default)]
    pub tool: ToolInfo,
    /// The cases, in the order they were run.
    pub cases: Vec<CaseSummary>,
}

/// The build that wrote a summary: enough to tell whether two runs used the same formulas.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ToolInfo {
    /// `"suslov"`.
    pub name: String,
    /// The crate version (`Cargo.toml`).
    pub version: String,
    /// sha256 of every codegen source (`codegen/*.py`, `codegen/models/*.py`, the pinned
    /// requirements) the generated models were derived from; each case's
    /// `model_source_hash` covers its own model only.
    pub codegen_source_hash: String,
}

impl ToolInfo {
    /// This build.
    pub fn current() -> Self {
        Self {
            name: env!("CARGO_PKG_NAME").to_string(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            codegen_source_hash: crate::model::SOURCE_HASH_ALL.to_string(),
        }
    }
}

/// How a case ended, as a code next to [`CaseSummary::status`]'s message (`status_code` in
/// `summary.json`, one of the snake_case names below).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StatusCode {
    /// Solved, and every a-posteriori check passed.
    Converged,
    /// Solved, but an a-posteriori check failed (`status` names it).
    Unverified,
    /// A homotopy stage stopped; the case holds the last converged point (`status` says
    /// where and why).
    Partial,
    /// The problem has no minimizer: its infimum is approached by controls whose `ξ`
    /// vanishes, and `trajectory.infimum.csv` holds an admissible ε-optimal control, its cost
    /// in `extra.infimum_trajectory` (`status` gives the evidence and where the homotopy
    /// stopped; the case's numbers are those of the last converged point, if any).
    NoMinimizer,
    /// No solution at all (`status` says why).
    #[default]
    Failed,
}

/// The outcome of one case (for example `eta = 1`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CaseSummary {
    /// Case name, e.g. `"eta = 1"`.
    pub name: String,
    /// The generated model solved (`"so3"`, `"se2"`, …; `codegen/models/<model>.py`).
    #[serde(default)]
    pub model: String,
    /// sha256 of the codegen sources that model's formulas were derived from (the value
    /// recorded in its generated code).
    #[serde(default)]
    pub model_source_hash: String,
    /// The cost weight `η` of this case.
    #[serde(with = "finite_or_null")]
    pub eta: f64,
    /// Optimal terminal time `b`.
    #[serde(with = "finite_or_null")]
    pub terminal_time: f64,
    /// Value of the cost functional at the solution.
    #[serde(with = "finite_or_null")]
    pub cost: f64,
    /// `max_t |⟨Ω, ξ⟩ − c|` (the constraint residual; `c` is the constraint value, 0 unless the
    /// model has one) on the checks' fine grid: every mesh interval cut into
    /// `lie::checks::FINE_PER_INTERVAL` pieces, `extra.check_grid_points` points in all (not the
    /// output grid of `trajectory.csv`, whose samples can miss the largest value).
    #[serde(with = "finite_or_null")]
    pub max_abs_constraint: f64,
    /// `min_t |ξ|`.
    #[serde(with = "finite_or_null")]
    pub xi_norm_min: f64,
    /// `max_t |ξ|`.
    #[serde(with = "finite_or_null")]
    pub xi_norm_max: f64,
    /// Kinetic-energy drift `max_t |T(t) − T(a)|`, `T = ½⟨Ω, IΩ⟩` (absolute), on the fine grid.
    #[serde(with = "finite_or_null")]
    pub energy_drift: f64,
    /// `|Ω(b) − Ω_b|`.
    #[serde(with = "finite_or_null")]
    pub omega_b_error: f64,
    /// ODE residual of the solution's interpolant, `max |y'(s) − T f(y(s))|` (absolute), on a fine grid.
    #[serde(with = "finite_or_null")]
    pub max_residual: f64,
    /// Number of mesh nodes of the final solution.
    pub mesh_nodes: usize,
    /// Total number of continuation steps over all stages.
    pub continuation_steps: usize,
    /// Total number of Newton iterations over all stages.
    pub newton_iterations: usize,
    /// Wall-clock time of the case, seconds.
    #[serde(with = "finite_or_null")]
    pub wall_seconds: f64,
    /// The [`CaseStatus`]'s kind ([`CaseSummary::set_status`] sets it with `status`).
    #[serde(default)]
    pub status_code: StatusCode,
    /// The [`CaseStatus`] as text: `"converged"` (the solve succeeded and every check of
    /// `verification` passed), `"unverified: <check> = <value> exceeds <threshold> (…)"`,
    /// `"partial: <reason>"` when the case stopped early, `"no minimizer: <evidence>"` when
    /// it stopped because the problem has none (an ε-optimal control is written), or
    /// `"failed: <reason>"`.
    pub status: String,
    /// The a-posteriori checks the status rests on (absent when there was no solution).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verification: Option<VerificationSummary>,
    /// A-posteriori check: largest difference between the solution and the states obtained by
    /// re-integrating the equations of motion as an initial value problem with the computed
    /// control (absent if not done). For the generic layer's solutions this is the windowed
    /// re-integration the `reintegration` check judges (restarted from the solution every
    /// radian of rotation, `lie::checks::REINTEGRATION_WINDOW_ANGLE`); the open-loop difference is in
    /// `extra.reintegration_open_loop_max_diff`.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "opt_finite_or_null"
    )]
    pub reintegration_max_diff: Option<f64>,
    /// Stability experiment: perturbed-control re-integrations (empty if not done).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stability: Vec<StabilityRun>,
    /// The continuation stages, in order.
    #[serde(default)]
    pub stages: Vec<StageSummary>,
    /// The problem solved, every default filled in: the table of the `problem.toml` written
    /// with it (`suslov solve` reads that file back to the same problem). Absent in files
    /// written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input: Option<serde_json::Value>,
    /// Anything else worth recording (free-form; serde_json stores non-finite numbers as
    /// `null` here too).
    #[serde(default, skip_serializing_if = "serde_json::Map::is_empty")]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// One continuation stage, e.g. `β` from `β_m` to `β`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct StageSummary {
    /// Stage name, e.g. `"beta"`.
    pub name: String,
    /// The continued parameter, e.g. `"beta"` or `"delta"`.
    pub parameter: String,
    /// Start value of the parameter.
    #[serde(with = "finite_or_null")]
    pub from: f64,
    /// End value of the parameter reached (the target if the stage completed).
    #[serde(with = "finite_or_null")]
    pub to: f64,
    /// Accepted continuation steps.
    pub steps: usize,
    /// Newton iterations spent in this stage.
    pub newton_iterations: usize,
    /// Failed steps that were recovered (e.g. by halving the step or refining the mesh).
    pub failures_recovered: usize,
    /// `"completed"`, or `"stopped: <reason>"` for the stage where a partial case stopped.
    #[serde(default)]
    pub outcome: String,
}

/// What a case's `status` says, before it becomes text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CaseStatus {
    /// The solve succeeded and every a-posteriori check passed.
    Converged,
    /// The solve succeeded but some check failed (the reason names it).
    Unverified(String),
    /// A homotopy stage stopped; the case holds the last converged point.
    Partial(String),
    /// No minimizer; an ε-optimal control is written ([`StatusCode::NoMinimizer`]).
    NoMinimizer(String),
    /// No solution at all.
    Failed(String),
}

impl CaseStatus {
    /// Its kind.
    pub fn code(&self) -> StatusCode {
        match self {
            Self::Converged => StatusCode::Converged,
            Self::Unverified(_) => StatusCode::Unverified,
            Self::Partial(_) => StatusCode::Partial,
            Self::NoMinimizer(_) => StatusCode::NoMinimizer,
            Self::Failed(_) => StatusCode::Failed,
        }
    }
}

impl CaseSummary {
    /// A case that failed with `message` before any solution (no trajectory: every number
    /// NaN), solved with `model` (its source hash `model_source_hash`).
    pub fn failed(name: &str, message: &str, model: &str, model_source_hash: &str) -> Self {
        let status = CaseStatus::Failed(message.to_string());
        Self {
            name: name.to_string(),
            eta: f64::NAN,
            terminal_time: f64::NAN,
            cost: f64::NAN,
            max_abs_constraint: f64::NAN,
            xi_norm_min: f64::NAN,
            xi_norm_max: f64::NAN,
            energy_drift: f64::NAN,
            omega_b_error: f64::NAN,
            max_residual: f64::NAN,
            status_code: status.code(),
            status: status.to_string(),
            model: model.to_string(),
            model_source_hash: model_source_hash.to_string(),
            ..Default::default()
        }
    }

    /// Sets `status` (the message) and `status_code` (its kind) together.
    pub fn set_status(&mut self, status: &CaseStatus) {
        self.status_code = status.code();
        self.status = status.to_string();
    }

    /// A summary with the given status and nothing else (e.g. a case that failed).
    pub fn with_status(name: &str, status: &CaseStatus) -> Self {
        let mut c = Self {
            name: name.to_string(),
            ..Self::default()
        };
        c.set_status(status);
        c
    }
}

impl std::fmt::Display for CaseStatus {
    /// `converged`, `unverified: …`, `partial: …`, `no minimizer: …` or `failed: …`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Converged => f.write_str("converged"),
            Self::Unverified(r) => write!(f, "unverified: {r}"),
            Self::Partial(r) => write!(f, "partial: {r}"),
            Self::NoMinimizer(r) => write!(f, "no minimizer: {r}"),
            Self::Failed(r) => write!(f, "failed: {r}"),
        }
    }
}

impl From<crate::lie::checks::Verdict> for CaseStatus {
    /// The status of a solution the solver returned: converged if verified, unverified
    /// (with the failed checks) if not.
    fn from(v: crate::lie::checks::Verdict) -> Self {
        match v {
            crate::lie::checks::Verdict::Verified => Self::Converged,
            crate::lie::checks::Verdict::Unverified { reason } => Self::Unverified(reason),
        }
    }
}

/// The a-posteriori checks of a case (`crate::lie::checks::Verification` as data).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct VerificationSummary {
    /// The requested tolerance.
    #[serde(with = "finite_or_null")]
    pub tolerance: f64,
    /// The tolerance the thresholds are computed at (the requested one clamped to the
    /// measured range).
    #[serde(with = "finite_or_null")]
    pub effective_tolerance: f64,
    /// Whether every check passed.
    pub passed: bool,
    /// The checks.
    pub checks: Vec<CheckSummary>,
}

/// One a-posteriori check: `passed` ⇔ `value <= threshold`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CheckSummary {
    /// Name, e.g. `"constraint"`.
    pub name: String,
    /// What is measured (with its scale).
    pub quantity: String,
    /// The measured value (`null` if it could not be measured).
    #[serde(with = "finite_or_null")]
    pub value: f64,
    /// The threshold.
    #[serde(with = "finite_or_null")]
    pub threshold: f64,
    /// Whether the check passed.
    pub passed: bool,
    /// Why the value could not be measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

impl From<&crate::lie::checks::Verification> for VerificationSummary {
    fn from(v: &crate::lie::checks::Verification) -> Self {
        Self {
            tolerance: v.tolerance,
            effective_tolerance: v.effective_tolerance,
            passed: v.passed(),
            checks: v
                .checks
                .iter()
                .map(|c| CheckSummary {
                    name: c.name.to_string(),
                    quantity: c.quantity.to_string(),
                    value: c.value,
                    threshold: c.threshold,
                    passed: c.passed,
                    error: c.error.clone(),
                })
                .collect(),
        }
    }
}

/// One run of the stability experiment: the control `ξ̇` is perturbed and the pure equations
/// of motion are re-integrated.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct StabilityRun {
    /// Label of the perturbation, e.g. `"relative 1e-3, seed 1"`.
    pub label: String,
    /// Size of the perturbation (meaning given by `label`).
    #[serde(with = "finite_or_null")]
    pub perturbation: f64,
    /// `max_t |Ω_perturbed − Ω|`.
    #[serde(with = "finite_or_null")]
    pub max_omega_diff: f64,
    /// `max_t |ξ_perturbed − ξ|`.
    #[serde(with = "finite_or_null")]
    pub max_xi_diff: f64,
    /// `|Ω_perturbed(b) − Ω(b)|`.
    #[serde(with = "finite_or_null")]
    pub final_omega_diff: f64,
}

impl Summary {
    /// The summary of a run of this build ([`ToolInfo::current`]) with these cases.
    pub fn new(cases: Vec<CaseSummary>) -> Self {
        Self {
            tool: ToolInfo::current(),
            cases,
        }
    }

    /// Pretty-printed JSON text (two-space indent, trailing newline).
    ///
    /// # Errors
    /// The serde_json error (not expected for these types).
    pub fn to_json_string(&self) -> Result<String, serde_json::Error> {
        let mut s = serde_json::to_string_pretty(self)?;
        s.push('\n');
        Ok(s)
    }
}

/// Writes `summary` to `path` as pretty-printed JSON, atomically (see [`write_atomic`]; the
/// parent directory must exist). Non-finite numbers are written as `null`.
///
/// # Errors
/// [`ReportError::Json`] or [`ReportError::Io`], both naming `path`.
pub fn write_summary_json(path: impl AsRef<Path>, summary: &Summary) -> Result<(), ReportError> {
    let path = path.as_ref();
    let text = summary
        .to_json_string()
        .map_err(|source| ReportError::Json {
            path: path.to_path_buf(),
            source,
        })?;
    write_atomic(path, text.as_bytes())
}

/// Serde adapter for `f64`: finite values as numbers, NaN and ±infinity as `null`; `null`
/// deserialises to NaN. Use as `#[serde(with = "finite_or_null")]`.
pub mod finite_or_null {
    use serde::{Deserialize, Deserializer, Serializer};

    /// Serialises a finite value as a number and a non-finite one as `null`.
    ///
    /// # Errors
    /// Whatever the serializer reports.
    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            s.serialize_f64(*v)
        } else {
            s.serialize_none()
        }
    }

    /// Deserialises a number, or `null` as NaN.
    ///
    /// # Errors
    /// Whatever the deserializer reports for a value that is neither a number nor `null`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}

/// Serde adapter for `Option<f64>` fields that are skipped when `None`: `Some(finite)` as a
/// number, `Some(non-finite)` as `null`; `null` reads back as `Some(NaN)` and an absent field
/// (with `#[serde(default)]`) as `None`.
pub mod opt_finite_or_null {
    use serde::{Deserialize, Deserializer, Serializer};

    /// Serialises `Some(v)` like [`super::finite_or_null::serialize`], `None` as `null`.
    ///
    /// # Errors
    /// Whatever the serializer reports.
    pub fn serialize<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(x) => super::finite_or_null::serialize(x, s),
            None => s.serialize_none(),
        }
    }

    /// Deserialises a number as `Some`, `null` as `Some(NaN)`.
    ///
    /// # Errors
    /// Whatever the deserializer reports for a value that is neither a number nor `null`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        Ok(Some(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN)))
    }
}
