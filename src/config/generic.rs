//! Problem files of the models other than `so3` (`model = "se2"`, `"so4"`, …): the same
//! layout as an so(3) file, with every name taken from the generated model.
//!
//! ```toml
//! model = "se2"                      # a generated model (codegen/models/<model>.py)
//! name = "sleigh_turn"               # optional; default: the file name without extension
//!
//! [body]                             # the model's inertia parameters, by name
//! m = 1.0                            # se2: m, Ic, c1, c2;  so4: J1, J2, J3, J4
//! Ic = 0.5
//! c1 = 0.3
//! c2 = 0.1
//!
//! [boundary]
//! t0 = 0.0                           # optional, default 0
//! omega_a = [1.0, 0.5, 0.0]          # Ω(t0): one entry per basis element (the model's DIM)
//! omega_b = [0.8, 0.2, 0.5]          # Ω(b) on Ω_a's energy level set, or "desired_end"
//! terminal_time = { fixed = 4.0 }    # or { free = true, guess = 4.0 }
//!
//! [cost]                             # the model's weights, by name (so3's: alpha, beta, gamma,
//! alpha = 1.0                        # eta, delta); a smoothing or time weight defaults to 0
//! beta = 0.1
//! gamma = 1.0
//!
//! [constraint]                       # only models with a constraint value, its parameters:
//! c = 0.5                            # so3_inhomogeneous: <Omega, xi> = c
//!
//! [desired]                          # Ω_d(t): "segment" (default), "constant", "samples" or
//!                                    # "expression" (formulas in t, as for so3)
//! kind = "segment"                   # from/to (default omega_a/omega_b), interval
//!
//! [solver]                           # as for so3 (see crate::config)
//! ```
//!
//! Every path is projected radially onto `Ω_a`'s energy level set `⟨Ω, 𝕀Ω⟩ = ⟨Ω_a, 𝕀Ω_a⟩` (𝕀
//! the model's inertia, full matrix), and `Ω_b` must lie on it, when the constraint value
//! vanishes (the energy is then conserved). With a nonzero constraint value neither holds: the
//! energy changes as `Ṫ = λγ`, `Ω_b` may be anywhere (nonzero), a `segment` runs straight from
//! `from` to `to`, and paths are used as given. `samples` reads a CSV with rows
//! `t, Ω_1, …, Ω_n`.
//! Unknown keys are errors that list the keys the model accepts.

use std::path::Path;
use std::sync::Arc;

use crate::lie::path::{
    projected_segment, Constant, LevelSet, Path as LiePath, Projected, Sampled, Segment,
};
use crate::lie::problem::Problem;
use crate::lie::problem::{TerminalTime, ENERGY_REL_TOL};
use crate::lie::solve::SolveOptions;
use crate::model::{HomotopyRole, Model};

use super::resolved::{
    floats, section, solver as resolved_solver, terminal_time, ResolvedInput, SAMPLES_FILE,
};
use super::{
    clip, decode, read_bounded, ConfigError, DefaultName, ProblemFile, ReadFailure, SolverSection,
    ENERGY_SCALE_RANGE, MAX_SAMPLES_FILE_BYTES,
};

/// A problem file of model `M`, checked.
#[derive(Debug, Clone)]
pub struct LoadedModelProblem<M: Model> {
    /// Case name.
    pub name: String,
    /// The problem (validated).
    pub problem: Problem<M>,
    /// Solver options.
    pub options: SolveOptions,
    /// The file with every default filled in ([`super::resolved`]).
    pub resolved: ResolvedInput,
}

type Table = toml::Table;

/// A desired path's end: its time (NaN for a constant) and value.
type EndPoint = (f64, Vec<f64>);

/// The path the solver tracks (after the projection onto the level set) must be finite with
/// its first three derivatives on `[t0, b]`, at [`super::PATH_CHECK_POINTS`] uniform times:
/// formulas that vanish together have no radial projection, samples too close together
/// overflow the spline's derivatives. Without this check the solver met NaN and stopped for
/// an unrelated reason (so4, formulas through zero at t = 2: "partial", gamma stage).
fn check_path_jet(path: &dyn LiePath, (t0, b): (f64, f64), kind: &str) -> Result<(), ConfigError> {
    let points = super::PATH_CHECK_POINTS;
    let mut jet = vec![0.0; 4 * path.dim()];
    for k in 0..points {
        let t = if k + 1 == points {
            b
        } else {
            t0 + (b - t0) * k as f64 / (points - 1) as f64
        };
        path.jet_into(t, &mut jet);
        if jet.iter().all(|v| v.is_finite()) {
            continue;
        }
        let (field, why) = match kind {
            "expression" => (
                "desired.components",
                "the formulas are finite there with their derivatives, so they all vanish \
                 together (no radial projection onto the level set) or the projection \
                 overflows f64: change the formulas so that they do not all vanish at once",
            ),
            "samples" => (
                "desired.file",
                "it overflows f64, as the spline's derivatives grow like (value change)/(t \
                 spacing)^3: space the samples further apart or make them smaller",
            ),
            "constant" => ("desired.value", "it overflows f64: give a smaller value"),
            _ => (
                "desired.interval",
                "it overflows f64, as the segment's derivatives grow like 1/(t_end - \
                 t_start)^3: give a longer interval",
            ),
        };
        return Err(invalid(
            field,
            format!(
                "the desired path (kind = \"{kind}\"), projected onto omega_a's energy level \
                 set, or one of its first three time derivatives is not finite at t = {}: {why}",
                crate::echo::Num(t)
            ),
        ));
    }
    Ok(())
}

fn invalid(field: &str, message: impl Into<String>) -> ConfigError {
    ConfigError::Invalid {
        field: field.into(),
        message: message.into(),
    }
}

/// Every key of `table` (at `path`) must be one of `allowed`.
fn only_keys(table: &Table, path: &str, allowed: &[&str]) -> Result<(), ConfigError> {
    for key in table.keys() {
        if !allowed.contains(&key.as_str()) {
            let field = if path.is_empty() {
                key.clone()
            } else {
                format!("{path}.{key}")
            };
            return Err(invalid(
                &clip(&field),
                format!("unknown key; this table accepts {}", allowed.join(", ")),
            ));
        }
    }
    Ok(())
}

fn number(field: &str, v: &toml::Value) -> Result<f64, ConfigError> {
    let x = match v {
        toml::Value::Float(x) => *x,
        toml::Value::Integer(i) => *i as f64,
        other => {
            return Err(invalid(
                field,
                format!("expected a number, found a {}", other.type_str()),
            ))
        }
    };
    if !x.is_finite() {
        return Err(ConfigError::NotFinite {
            field: field.into(),
            value: x,
        });
    }
    Ok(x)
}

fn vector(field: &str, v: &toml::Value, n: usize, meaning: &str) -> Result<Vec<f64>, ConfigError> {
    let toml::Value::Array(items) = v else {
        return Err(invalid(
            field,
            format!(
                "expected an array of {n} numbers [{meaning}], found a {}",
                v.type_str()
            ),
        ));
    };
    if items.len() != n {
        return Err(ConfigError::Length {
            field: field.into(),
            found: items.len(),
            expected: n,
            meaning: meaning.to_string(),
        });
    }
    items
        .iter()
        .enumerate()
        .map(|(i, x)| number(&format!("{field}[{i}]"), x))
        .collect()
}

fn table<'a>(root: &'a Table, key: &str, fix: &str) -> Result<&'a Table, ConfigError> {
    match root.get(key) {
        Some(toml::Value::Table(t)) => Ok(t),
        Some(other) => Err(invalid(
            key,
            format!("expected a table [{key}], found a {}", other.type_str()),
        )),
        None => Err(ConfigError::Missing {
            field: key.into(),
            fix: fix.into(),
        }),
    }
}

/// What a vector of the model's dimension holds (for messages).
fn basis_meaning<M: Model>() -> String {
    format!("components along {}", M::BASIS_NAMES.join(", "))
}

type Samples = (Vec<f64>, Vec<Vec<f64>>, Vec<u8>);

/// Read the samples CSV `t, Ω_1, …, Ω_n` (header optional, `#` comments): the times, the
/// values and the file's bytes.
fn samples<M: Model>(path: &Path) -> Result<Samples, ConfigError> {
    let bytes = read_bounded(path, MAX_SAMPLES_FILE_BYTES).map_err(|e| match e {
        ReadFailure::Io(source) => ConfigError::Read {
            path: path.to_path_buf(),
            source,
        },
        ReadFailure::File(problem) => ConfigError::File {
            path: path.to_path_buf(),
            problem,
        },
    })?;
    let raw = bytes.clone();
    let text = decode(bytes, false).map_err(|problem| ConfigError::File {
        path: path.to_path_buf(),
        problem,
    })?;
    let (mut times, mut values) = (Vec::new(), Vec::new());
    let mut first_content = true;
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed: Result<Vec<f64>, _> = cells.iter().map(|c| c.parse::<f64>()).collect();
        let first = std::mem::replace(&mut first_content, false);
        let Ok(row) = parsed else {
            // A header: the first line, with no number in it (a first row with a typo in one
            // field is an error, not a header).
            if first && cells.iter().all(|c| c.parse::<f64>().is_err()) {
                continue;
            }
            return Err(invalid(
                "desired.file",
                format!("line {}: {:?} is not a row of numbers", k + 1, clip(line)),
            ));
        };
        if row.len() != M::DIM + 1 {
            return Err(invalid(
                "desired.file",
                format!(
                    "line {}: {} columns; model {} needs {} (t, then one per basis element {})",
                    k + 1,
                    row.len(),
                    M::NAME,
                    M::DIM + 1,
                    M::BASIS_NAMES.join(", ")
                ),
            ));
        }
        times.push(row[0]);
        values.push(row[1..].to_vec());
    }
    Ok((times, values, raw))
}

/// Build a problem of model `M` from the parsed file `root`.
pub(crate) fn build<M: Model>(
    root: &Table,
    default_name: &DefaultName,
    base_dir: &Path,
) -> Result<LoadedModelProblem<M>, ConfigError> {
    only_keys(
        root,
        "",
        if M::CONSTRAINT_PARAMS.is_empty() {
            &[
                "model", "name", "body", "boundary", "cost", "desired", "solver",
            ]
        } else {
            &[
                "model",
                "name",
                "body",
                "boundary",
                "cost",
                "constraint",
                "desired",
                "solver",
            ]
        },
    )?;
    // The case name: the so(3) file's rules (one printable line, capped).
    let name_file = ProblemFile {
        name: match root.get("name") {
            Some(toml::Value::String(s)) => Some(s.clone()),
            Some(other) => {
                return Err(invalid(
                    "name",
                    format!("expected a string, found a {}", other.type_str()),
                ))
            }
            None => None,
        },
        ..Default::default()
    };
    let name = name_file.case_name(default_name)?;
    let n = M::DIM;
    let meaning = &basis_meaning::<M>();

    // [body]: the inertia parameters.
    let inertia_names: Vec<&str> = M::INERTIA_PARAMS.iter().map(|m| m.name).collect();
    let body = table(
        root,
        "body",
        &format!("add a [body] table with {}", inertia_names.join(", ")),
    )?;
    only_keys(body, "body", &inertia_names)?;
    let mut user = vec![0.0; M::N_USER_PARAM];
    for meta in M::INERTIA_PARAMS {
        let field = format!("body.{}", meta.name);
        let v = body.get(meta.name).ok_or_else(|| ConfigError::Missing {
            field: field.clone(),
            fix: format!("add {} = ... under [body] ({})", meta.name, meta.doc),
        })?;
        user[meta.index] = number(&field, v)?;
        if !meta.admits(user[meta.index]) {
            return Err(ConfigError::OutOfRange {
                field,
                value: user[meta.index].to_string(),
                requirement: meta.doc.to_string(),
            });
        }
    }

    // [cost]: the weights.
    let weight_names: Vec<&str> = M::WEIGHTS.iter().map(|m| m.name).collect();
    let cost = table(
        root,
        "cost",
        &format!("add a [cost] table with {}", weight_names.join(", ")),
    )?;
    only_keys(cost, "cost", &weight_names)?;
    for meta in M::WEIGHTS {
        let field = format!("cost.{}", meta.name);
        let defaults_to_zero =
            matches!(meta.role, HomotopyRole::Smoothing | HomotopyRole::Time) && meta.admits(0.0);
        let v = match cost.get(meta.name) {
            Some(v) => number(&field, v)?,
            None if defaults_to_zero => 0.0,
            None => {
                return Err(ConfigError::Missing {
                    field,
                    fix: format!("add {} = ... under [cost] ({})", meta.name, meta.doc),
                })
            }
        };
        if !meta.admits(v) {
            return Err(ConfigError::OutOfRange {
                field,
                value: v.to_string(),
                requirement: meta.doc.to_string(),
            });
        }
        user[meta.index] = v;
    }
    // [constraint]: the constraint value's parameters (models that have them).
    if !M::CONSTRAINT_PARAMS.is_empty() {
        let names: Vec<&str> = M::CONSTRAINT_PARAMS.iter().map(|m| m.name).collect();
        let constraint = table(
            root,
            "constraint",
            &format!(
                "add a [constraint] table with {} (the constraint value of model {}: {})",
                names.join(", "),
                M::NAME,
                M::TITLE
            ),
        )?;
        only_keys(constraint, "constraint", &names)?;
        for meta in M::CONSTRAINT_PARAMS {
            let field = format!("constraint.{}", meta.name);
            let v = constraint
                .get(meta.name)
                .ok_or_else(|| ConfigError::Missing {
                    field: field.clone(),
                    fix: format!("add {} = ... under [constraint] ({})", meta.name, meta.doc),
                })?;
            let v = number(&field, v)?;
            if !meta.admits(v) {
                return Err(ConfigError::OutOfRange {
                    field,
                    value: v.to_string(),
                    requirement: meta.doc.to_string(),
                });
            }
            user[meta.index] = v;
        }
    }
    let mut p = vec![0.0; M::N_PARAM];
    p[..M::N_USER_PARAM].copy_from_slice(&user);
    crate::model::fill_derived::<M>(&mut p).map_err(|e| invalid("body", e.to_string()))?;
    // With a nonzero constraint value the energy is not conserved: Ω_b may be off the level set
    // of Ω_a, and the desired paths are not projected onto it.
    let conserves_energy = crate::model::constraint_value_vanishes::<M>(&p);
    let mut inertia = vec![0.0; n * n];
    M::inertia_matrix(&p, &mut inertia);

    // [boundary]
    let boundary = table(
        root,
        "boundary",
        "add a [boundary] table with omega_a, omega_b and terminal_time",
    )?;
    only_keys(
        boundary,
        "boundary",
        &["t0", "omega_a", "omega_b", "terminal_time"],
    )?;
    let t0 = boundary
        .get("t0")
        .map(|v| number("boundary.t0", v))
        .transpose()?
        .unwrap_or(0.0);
    let omega_a = vector(
        "boundary.omega_a",
        boundary
            .get("omega_a")
            .ok_or_else(|| ConfigError::Missing {
                field: "boundary.omega_a".into(),
                fix: format!("add omega_a = [{meaning}] under [boundary] (the velocity at t0)"),
            })?,
        n,
        meaning,
    )?;
    if omega_a.iter().all(|x| *x == 0.0) {
        return Err(invalid(
            "boundary.omega_a",
            "is zero: omega_a fixes the kinetic energy, i.e. the level set every trajectory \
             stays on; give a nonzero vector",
        ));
    }
    let set = LevelSet::through(&inertia, n, &omega_a)
        .map_err(|e| invalid("boundary.omega_a", e.to_string()))?;
    // Far from 2E ~ 1 the level set's projection and the solver's absolute floors (the start's
    // Property 3 check, the SQP's regularization) lose their meaning: 2E ~ 1e-80 kept the
    // direct start of an so4 file busy for minutes, 1e-200 printed NaN, 1e200 refused a valid
    // start. The motion depends on the inertia only up to a constant factor, so the user can
    // move the scale without changing the problem.
    let energy2 = set.level();
    if !(ENERGY_SCALE_RANGE.0..=ENERGY_SCALE_RANGE.1).contains(&energy2) {
        return Err(invalid(
            "boundary.omega_a",
            format!(
                "twice the kinetic energy <omega_a, I omega_a> = {energy2:e} is outside [{:e}, \
                 {:e}], where the solver's tolerances lose their meaning; scale the inertia (the \
                 [body] parameters) by one constant so that 2E is near 1: the motion and the \
                 cost depend on the inertia only up to a constant factor",
                ENERGY_SCALE_RANGE.0, ENERGY_SCALE_RANGE.1
            ),
        ));
    }
    let tt = match boundary.get("terminal_time") {
        Some(toml::Value::Table(t)) => t,
        Some(other) => {
            return Err(ConfigError::TerminalTime {
                field: "boundary.terminal_time".into(),
                message: format!(
                    "expected {{ fixed = b }} or {{ free = true, guess = b }}, found a {}",
                    other.type_str()
                ),
            })
        }
        None => {
            return Err(ConfigError::Missing {
                field: "boundary.terminal_time".into(),
                fix: "add terminal_time = { fixed = 10.0 } or terminal_time = { free = true, \
                      guess = 10.0 } under [boundary]"
                    .into(),
            })
        }
    };
    only_keys(tt, "boundary.terminal_time", &["fixed", "free", "guess"])?;

    // [desired] (needed for the end point "desired_end" and the default guess).
    let empty = Table::new();
    let desired_t = match root.get("desired") {
        Some(toml::Value::Table(t)) => t,
        Some(other) => {
            return Err(invalid(
                "desired",
                format!("expected a table [desired], found a {}", other.type_str()),
            ))
        }
        None => &empty,
    };
    let kind = match desired_t.get("kind") {
        None => "segment".to_string(),
        Some(toml::Value::String(s)) => s.clone(),
        Some(other) => {
            return Err(invalid(
                "desired.kind",
                format!("expected a string, found a {}", other.type_str()),
            ))
        }
    };
    let omega_b_spec = boundary
        .get("omega_b")
        .ok_or_else(|| ConfigError::Missing {
            field: "boundary.omega_b".into(),
            fix: format!(
                "add omega_b = [{meaning}] (on omega_a's energy level set) or omega_b = \
             \"desired_end\" under [boundary]"
            ),
        })?;
    let desired_end = matches!(omega_b_spec, toml::Value::String(s) if s == "desired_end");
    if let toml::Value::String(s) = omega_b_spec {
        if s != "desired_end" {
            return Err(invalid(
                "boundary.omega_b",
                format!("{:?}: give a vector or \"desired_end\"", clip(s)),
            ));
        }
    }
    // The desired path (before projection) and its end time.
    let mut samples_bytes = None;
    let mut expression_keys = None;
    let mut formulas = None;
    let (raw, end): (Option<Arc<dyn LiePath>>, Option<EndPoint>) = match kind.as_str() {
        "constant" => {
            only_keys(desired_t, "desired", &["kind", "value"])?;
            let value = vector(
                "desired.value",
                desired_t.get("value").ok_or_else(|| ConfigError::Missing {
                    field: "desired.value".into(),
                    fix: format!("add value = [{meaning}] under [desired]"),
                })?,
                n,
                meaning,
            )?;
            let c = Constant::new(value.clone())
                .map_err(|e| invalid("desired.value", e.to_string()))?;
            (Some(Arc::new(c)), Some((f64::NAN, value)))
        }
        "samples" => {
            only_keys(desired_t, "desired", &["kind", "file"])?;
            let Some(toml::Value::String(file)) = desired_t.get("file") else {
                return Err(ConfigError::Missing {
                    field: "desired.file".into(),
                    fix: "add file = \"omega_d.csv\" under [desired] (rows t, Omega_1, ..., \
                          Omega_n)"
                        .into(),
                });
            };
            let (times, values, raw) = samples::<M>(&base_dir.join(file))?;
            samples_bytes = Some(raw);
            let s = Sampled::new(&times, &values)
                .map_err(|e| invalid("desired.file", e.to_string()))?;
            let last = (times[times.len() - 1], values[values.len() - 1].clone());
            (Some(Arc::new(s)), Some(last))
        }
        "expression" => {
            only_keys(
                desired_t,
                "desired",
                &["kind", "components", "constants", "end_time"],
            )?;
            let d: super::DesiredSection =
                toml::Value::Table(desired_t.clone()).try_into().map_err(
                    |e: toml::de::Error| invalid("desired", super::plain_words(e.message())),
                )?;
            let (expression, keys) = super::expression_path(&d, M::DIM)?;
            let expression = Arc::new(expression);
            formulas = Some(expression.clone());
            expression_keys = Some(keys);
            let end = match d.end_time {
                Some(t) => {
                    let t = super::expression_end_time(t, t0)?;
                    let mut v = vec![0.0; M::DIM];
                    expression.value_into(t, &mut v);
                    Some((t, v))
                }
                None => None,
            };
            (Some(expression as Arc<dyn LiePath>), end)
        }
        "segment" => (None, None),
        other => {
            return Err(invalid(
                "desired.kind",
                format!(
                    "unknown kind {:?} for model {}; use \"segment\", \"constant\", \
                     \"samples\" or \"expression\"",
                    clip(other),
                    M::NAME
                ),
            ))
        }
    };
    let omega_b = if desired_end {
        match (&kind[..], &end) {
            ("segment", _) => {
                return Err(invalid(
                    "boundary.omega_b",
                    "\"desired_end\" needs a desired path with an end point (constant, \
                     samples, or expression with end_time); for a segment give omega_b itself",
                ))
            }
            (_, Some((_, v))) if conserves_energy => set
                .project(v)
                .map_err(|e| invalid("boundary.omega_b", e.to_string()))?,
            (_, Some((_, v))) => v.clone(),
            _ => {
                return Err(ConfigError::Missing {
                    field: "desired.end_time".into(),
                    fix: "omega_b = \"desired_end\" takes the desired path's end point: add \
                          end_time = <t> under [desired], or give omega_b itself"
                        .into(),
                })
            }
        }
    } else {
        vector("boundary.omega_b", omega_b_spec, n, meaning)?
    };
    let mismatch = set.relative_mismatch(&omega_b);
    let on_level_set = mismatch.abs() <= ENERGY_REL_TOL; // false for NaN
    if conserves_energy && !on_level_set {
        let projection = set.project(&omega_b).unwrap_or_default();
        return Err(invalid(
            "boundary.omega_b",
            format!(
                "{omega_b:?} is off omega_a's energy level set <Omega, I Omega> = {:e} by \
                 {mismatch:.3e} (relative; allowed {ENERGY_REL_TOL:e}): the constrained motion \
                 conserves the kinetic energy, so no control reaches it. Its radial projection \
                 onto the level set is {projection:?}: use that (or change omega_a)",
                set.level()
            ),
        ));
    }
    let end_time = end.as_ref().map(|e| e.0).filter(|t| t.is_finite());
    let terminal = {
        let fixed = tt
            .get("fixed")
            .map(|v| number("boundary.terminal_time.fixed", v))
            .transpose()?;
        let free = match tt.get("free") {
            None => false,
            Some(toml::Value::Boolean(b)) => *b,
            Some(other) => {
                return Err(invalid(
                    "boundary.terminal_time.free",
                    format!("expected true or false, found a {}", other.type_str()),
                ))
            }
        };
        let guess = tt
            .get("guess")
            .map(|v| number("boundary.terminal_time.guess", v))
            .transpose()?;
        match (fixed, free) {
            (Some(b), false) if guess.is_none() => TerminalTime::Fixed(b),
            (None, true) => TerminalTime::Free {
                guess: guess
                    .or(end_time)
                    .ok_or_else(|| ConfigError::TerminalTime {
                        field: "boundary.terminal_time.guess".into(),
                        message: "a free terminal time needs a guess (the desired path has no \
                              end time to default to): add guess = ..."
                            .into(),
                    })?,
            },
            _ => {
                return Err(ConfigError::TerminalTime {
                    field: "boundary.terminal_time".into(),
                    message: "give either { fixed = b } or { free = true, guess = b }".into(),
                })
            }
        }
    };
    let b = terminal.initial();
    if b.partial_cmp(&t0) != Some(std::cmp::Ordering::Greater) {
        return Err(ConfigError::TerminalTime {
            field: "boundary.terminal_time".into(),
            message: format!("b = {b} must be greater than t0 = {t0}"),
        });
    }
    if let Some(formulas) = &formulas {
        super::check_formulas(formulas, (t0, b), conserves_energy)?;
    }
    let mut segment_keys = None;
    let desired: Arc<dyn LiePath> = if let Some(inner) = raw {
        if conserves_energy {
            Arc::new(Projected {
                inner,
                set: set.clone(),
            })
        } else {
            inner
        }
    } else {
        only_keys(desired_t, "desired", &["kind", "from", "to", "interval"])?;
        let from = desired_t
            .get("from")
            .map(|v| vector("desired.from", v, n, meaning))
            .transpose()?
            .unwrap_or_else(|| omega_a.clone());
        let to = desired_t
            .get("to")
            .map(|v| vector("desired.to", v, n, meaning))
            .transpose()?
            .unwrap_or_else(|| omega_b.clone());
        let interval = desired_t
            .get("interval")
            .map(|v| vector("desired.interval", v, 2, "start time, end time"))
            .transpose()?
            .unwrap_or_else(|| vec![t0, b]);
        segment_keys = Some([from.clone(), to.clone(), interval.clone()]);
        if conserves_energy {
            let from = set
                .project(&from)
                .map_err(|e| invalid("desired.from", e.to_string()))?;
            let to_p = set
                .project(&to)
                .map_err(|e| invalid("desired.to", e.to_string()))?;
            Arc::new(
                projected_segment(&set, &from, &to_p, interval[0], interval[1], ENERGY_REL_TOL)
                    .map_err(|e| invalid("desired", e.to_string()))?,
            )
        } else {
            Arc::new(
                Segment::new(from, to, interval[0], interval[1])
                    .map_err(|e| invalid("desired", e.to_string()))?,
            )
        }
    };
    check_path_jet(&*desired, (t0, b), &kind)?;
    // The so(3) file's solver section and its checks.
    let solver: Option<SolverSection> =
        match root.get("solver") {
            None => None,
            Some(v) => Some(v.clone().try_into().map_err(|e: toml::de::Error| {
                invalid("solver", super::plain_words(e.message()))
            })?),
        };
    let beta = M::WEIGHTS
        .iter()
        .find(|w| w.role == HomotopyRole::Beta)
        .map_or(f64::NAN, |w| user[w.index]);
    let gamma = M::WEIGHTS
        .iter()
        .find(|w| w.role == HomotopyRole::Tracking)
        .map_or(0.0, |w| user[w.index]);
    let start_from = solver.as_ref().and_then(|s| s.start_from.clone());
    let mut options = ProblemFile {
        solver,
        ..Default::default()
    }
    .solve_options(beta, gamma)?;
    if let Some(from) = start_from {
        options.warm_start = Some(super::read_warm_start(
            base_dir,
            &from,
            M::STATE_NAMES,
            M::KAPPA,
            t0,
        )?);
    }
    // The resolved input: the file as read, with every default filled in.
    let mut resolved = root.clone();
    resolved.insert("model".into(), toml::Value::String(M::NAME.into()));
    resolved.insert("name".into(), toml::Value::String(name.clone()));
    {
        let boundary = section(&mut resolved, "boundary");
        boundary.insert("t0".into(), toml::Value::Float(t0));
        let fixed = match terminal {
            TerminalTime::Fixed(b) => Some(b),
            TerminalTime::Free { .. } => None,
        };
        boundary.insert("terminal_time".into(), terminal_time(fixed, b));
    }
    {
        let cost = section(&mut resolved, "cost");
        for meta in M::WEIGHTS {
            cost.insert(meta.name.into(), toml::Value::Float(user[meta.index]));
        }
    }
    let mut files = Vec::new();
    {
        let d = section(&mut resolved, "desired");
        d.insert("kind".into(), toml::Value::String(kind.clone()));
        if let Some([from, to, interval]) = &segment_keys {
            d.insert("from".into(), floats(from));
            d.insert("to".into(), floats(to));
            d.insert("interval".into(), floats(interval));
        }
        if let Some(keys) = expression_keys {
            for (k, v) in keys {
                d.insert(k, v);
            }
        }
        if let Some(raw) = samples_bytes {
            d.insert("file".into(), toml::Value::String(SAMPLES_FILE.into()));
            files.push((SAMPLES_FILE.to_string(), raw));
        }
    }
    let (solver_table, start_file) = resolved_solver(&options, M::STATE_NAMES);
    resolved.insert("solver".into(), toml::Value::Table(solver_table));
    files.extend(start_file);
    let problem = Problem::<M>::new(&user, t0, omega_a, omega_b, terminal, desired)
        .map_err(|e| invalid("boundary", e.to_string()))?;
    Ok(LoadedModelProblem {
        name,
        problem,
        options,
        resolved: ResolvedInput {
            table: resolved,
            files,
        },
    })
}
