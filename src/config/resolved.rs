//! The resolved input of a run: the problem file with every default filled in and every file
//! it names copied next to it, so that `suslov solve DIR/problem.toml` repeats the run.
//!
//! A [`ResolvedInput`] is built by the problem-file readers (so(3): [`super::ProblemFile`],
//! other models: [`super::generic`]) from the values they validated, and for the paper's cases
//! by [`paper_case`]. Numbers are written as the `f64` the run used (TOML floats round-trip
//! exactly), so reading the resolved file back gives the same problem bit for bit; the tests
//! check that for every example and the paper's cases. A key whose default is chosen by the
//! solver at run time (`solver.beta_m`) is left out unless the input gave it: the solver then
//! chooses the same value again.

use std::sync::Arc;

use crate::lie::solve::{SolveOptions, StartStrategy, WarmStart};

/// The file name of a copied samples file (`desired.file`) in the resolved input.
pub const SAMPLES_FILE: &str = "desired_samples.csv";

/// The file name of a copied warm start (`solver.start_from`) in the resolved input.
pub const START_FROM_FILE: &str = "start_from.csv";

/// The spellings of `solver.start`, with the strategy each selects (the readers parse and the
/// resolved input writes them from this one list).
pub const START_KEYS: [(&str, StartStrategy); 4] = [
    ("auto", StartStrategy::Auto),
    ("desired", StartStrategy::Desired),
    (
        "desired-gamma-from-zero",
        StartStrategy::DesiredGammaFromZero,
    ),
    ("segment", StartStrategy::Segment),
];

/// The problem of a run with every default filled in.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ResolvedInput {
    /// Every key of the problem file, defaults included (a file that names another file names
    /// its copy: [`SAMPLES_FILE`], [`START_FROM_FILE`]).
    pub table: toml::Table,
    /// The files the table names, relative to it: (file name, bytes).
    pub files: Vec<(String, Vec<u8>)>,
}

impl ResolvedInput {
    /// The problem file's text: a comment naming `source` and this build, then the table.
    pub fn toml_text(&self, source: &str) -> String {
        let body = toml::to_string(&self.table)
            .unwrap_or_else(|e| format!("# the table could not be written: {e}\n"));
        let source: String = source
            .chars()
            .map(|c| if c.is_control() { ' ' } else { c })
            .collect();
        format!(
            "# The input of a run of {} {}, every default filled in (from: {}).\n\
             # `suslov solve <this file> --out DIR` repeats the run.\n\n{body}",
            env!("CARGO_PKG_NAME"),
            env!("CARGO_PKG_VERSION"),
            crate::echo::clip_to(&source, crate::echo::MAX_ECHO_CHARS)
        )
    }

    /// The table as JSON (`summary.json`'s `input`).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(&self.table).unwrap_or(serde_json::Value::Null)
    }
}

/// A TOML array of floats.
pub(crate) fn floats(v: &[f64]) -> toml::Value {
    toml::Value::Array(v.iter().map(|x| toml::Value::Float(*x)).collect())
}

/// `t[key]` as a table, inserted empty if absent (replaced if it is not a table: the readers
/// have rejected that before a table is resolved).
pub(crate) fn section<'a>(t: &'a mut toml::Table, key: &str) -> &'a mut toml::Table {
    let entry = t
        .entry(key.to_string())
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    if !entry.is_table() {
        *entry = toml::Value::Table(toml::Table::new());
    }
    match entry {
        toml::Value::Table(s) => s,
        _ => unreachable!("just made a table"),
    }
}

/// `[cost]` of an so(3) problem: every weight under its generated name
/// (`model::generated::WEIGHTS`, the keys of the so(3) file's `[cost]`).
pub(crate) fn so3_cost(weights: &crate::so3::problem::CostWeights) -> toml::Table {
    use crate::model::generated as g;
    // The inertia does not enter the weights' slots.
    let p = crate::so3::problem::model_params([1.0; crate::so3::problem::N_INERTIA], weights);
    g::WEIGHTS
        .iter()
        .map(|m| (m.name.to_string(), toml::Value::Float(p[m.index])))
        .collect()
}

/// `terminal_time = { fixed = b }` or `{ free = true, guess = b }`.
pub(crate) fn terminal_time(fixed: Option<f64>, guess: f64) -> toml::Value {
    let mut t = toml::Table::new();
    match fixed {
        Some(b) => {
            t.insert("fixed".into(), toml::Value::Float(b));
        }
        None => {
            t.insert("free".into(), toml::Value::Boolean(true));
            t.insert("guess".into(), toml::Value::Float(guess));
        }
    }
    toml::Value::Table(t)
}

fn integer(n: usize) -> toml::Value {
    toml::Value::Integer(i64::try_from(n).unwrap_or(i64::MAX))
}

/// `[solver]` with every option `o` holds (`beta_m` only when set), and the warm start as a
/// CSV (header `t` and `state_names`) named [`START_FROM_FILE`].
pub(crate) fn solver(
    o: &SolveOptions,
    state_names: &[&str],
) -> (toml::Table, Option<(String, Vec<u8>)>) {
    let mut t = toml::Table::new();
    t.insert("tolerance".into(), toml::Value::Float(o.tol));
    t.insert(
        "continuation_tolerance".into(),
        toml::Value::Float(o.continuation_tol),
    );
    if let Some(b) = o.beta_m {
        t.insert("beta_m".into(), toml::Value::Float(b));
    }
    t.insert("initial_intervals".into(), integer(o.initial_intervals));
    t.insert("max_nodes".into(), integer(o.max_nodes));
    let start = START_KEYS
        .iter()
        .find(|(_, s)| *s == o.start)
        .map_or("auto", |(k, _)| k);
    t.insert("start".into(), toml::Value::String(start.into()));
    t.insert("max_routes".into(), integer(o.max_routes));
    let file = o.warm_start.as_ref().map(|w| {
        t.insert(
            "start_from".into(),
            toml::Value::String(START_FROM_FILE.into()),
        );
        (START_FROM_FILE.to_string(), warm_start_csv(w, state_names))
    });
    (t, file)
}

/// A warm start as CSV: `t` and the state names, every number in Rust's shortest round-trip
/// form (read back bit for bit).
fn warm_start_csv(w: &Arc<WarmStart>, state_names: &[&str]) -> Vec<u8> {
    use std::fmt::Write as _;
    let mut s = String::from("t");
    for n in state_names {
        s.push(',');
        s.push_str(n);
    }
    s.push('\n');
    let n = state_names.len();
    for (t, row) in w.times.iter().zip(w.states.chunks_exact(n.max(1))) {
        let _ = write!(s, "{t:?}");
        for v in row {
            let _ = write!(s, ",{v:?}");
        }
        s.push('\n');
    }
    s.into_bytes()
}

/// The resolved input of one of the paper's cases (section 5.3): the body, end points,
/// spiral and weights of [`crate::so3::paper::problem`], the default solver options.
pub fn paper_case(case: &crate::so3::paper::PaperCase) -> ResolvedInput {
    use crate::so3::desired::PaperSpiral;
    let problem = crate::so3::paper::problem(case.eta);
    let spiral = PaperSpiral::paper();
    let mut t = toml::Table::new();
    t.insert("model".into(), toml::Value::String("so3".into()));
    t.insert("name".into(), toml::Value::String(case.name.into()));
    section(&mut t, "body").insert("inertia".into(), floats(problem.inertia.diag().as_slice()));
    let boundary = section(&mut t, "boundary");
    boundary.insert("t0".into(), toml::Value::Float(problem.t0));
    boundary.insert("omega_a".into(), floats(problem.omega_a.as_slice()));
    boundary.insert("omega_b".into(), toml::Value::String("desired_end".into()));
    boundary.insert(
        "terminal_time".into(),
        terminal_time(None, problem.terminal.initial()),
    );
    t.insert(
        "cost".into(),
        toml::Value::Table(so3_cost(&problem.weights)),
    );
    let desired = section(&mut t, "desired");
    desired.insert("kind".into(), toml::Value::String("paper-spiral".into()));
    desired.insert("c".into(), toml::Value::Float(spiral.c()));
    desired.insert("width".into(), toml::Value::Float(spiral.width()));
    desired.insert("b_d".into(), toml::Value::Float(spiral.b_d()));
    let (solver, file) = solver(
        &SolveOptions::default(),
        &crate::model::generated::STATE_NAMES,
    );
    debug_assert!(file.is_none());
    t.insert("solver".into(), toml::Value::Table(solver));
    ResolvedInput {
        table: t,
        files: Vec::new(),
    }
}
