//! Guard: the model-specific Rust (everything in `src/` but the model-free solvers) never
//! re-types the generated model's layout.
//!
//! Project rule: "The model file defines dimensions, names, parameters and physics; Rust uses
//! what is generated and never re-types a layout, an index or a formula." The sizes, blocks
//! and indices are in `suslov::model::generated` (`DIM`, `N_STATE`, `OMEGA`, `XI`, `XIDOT`,
//! `KAPPA`, `N_PARAM`, `idx::*`, ...). This test scans `src/**/*.rs` for the hand-typed forms
//! they replaced (a digit indexing `p`, `[f64; 12]`, `y[..9]`, `h[r * 10 + 9]`, ...) and fails
//! naming `file:line`. The model-free layers (`src/bvp`, `src/ocp`, `src/continuation`,
//! `src/reconstruct.rs`, `src/ivp.rs`, the paths of any dimension `src/lie/path.rs` and
//! `src/lie/expression.rs`) work with
//! a generic `n` and are not scanned.
//!
//! The scanner is tested on planted violations, so the guard cannot pass vacuously.

use std::path::{Path, PathBuf};

/// Model-free code (generic `n`), relative to the crate root.
const EXCLUDED: [&str; 7] = [
    "src/lie/path.rs",
    "src/lie/expression.rs",
    "src/bvp",
    "src/ocp",
    "src/continuation",
    "src/reconstruct.rs",
    "src/ivp.rs",
];

/// Names of the constant vector `p` of the generated functions.
const PARAM_NAMES: [&str; 2] = ["p", "params"];

/// Names under which a state (`y = [Ω, ξ, ξ̇, κ]`), its derivative or a generated function's
/// input or output is indexed.
const STATE_NAMES: [&str; 10] = ["y", "ya", "yb", "yp", "dy", "out", "z", "x", "res", "h"];

/// The so(3) sizes of the model's arrays: `2n = 6` (`[Ω, ξ]`, `w`, a field), `N_PARAM = 8`,
/// `3n = 9` (`z = [Ω, ξ, ξ̇]`), `N_STATE = 12`.
const SIZES: [&str; 4] = ["6", "8", "9", "12"];

/// Ends of the so(3) state blocks, as in a prefix `[..9]` (`z` of a state).
const BLOCK_ENDS: [&str; 4] = ["3", "6", "9", "12"];

/// The so(3) state blocks written as literal ranges.
const BLOCK_RANGES: [&str; 5] = ["0..12", "0..9", "3..6", "6..9", "9..12"];

/// Names of removed helpers that hard-wired a size.
const NAMES: [&str; 2] = ["arr12", "z9("];

/// One finding: the rule broken and where in the line.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Finding {
    line: usize,
    rule: &'static str,
    text: String,
}

fn is_ident_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// What follows each `name[` in `line` where `name` is a whole identifier.
fn indexings<'a>(line: &'a str, name: &str) -> Vec<&'a str> {
    let pattern = format!("{name}[");
    line.match_indices(pattern.as_str())
        .filter(|(at, _)| {
            line[..*at]
                .chars()
                .next_back()
                .is_none_or(|c| !is_ident_char(c))
        })
        .map(|(at, _)| &line[at + pattern.len()..])
        .collect()
}

/// Whether `s` starts with an integer literal that is not part of a longer token.
fn starts_with_digit(s: &str) -> bool {
    s.chars().next().is_some_and(|c| c.is_ascii_digit())
}

/// `token` occurs in `line` with no identifier or digit character right before or after.
fn occurs_as_token(line: &str, token: &str) -> bool {
    line.match_indices(token).any(|(at, _)| {
        let before = line[..at].chars().next_back();
        let after = line[at + token.len()..].chars().next();
        before.is_none_or(|c| !is_ident_char(c) && c != '.')
            && after.is_none_or(|c| !is_ident_char(c) && c != '.')
    })
}

/// The rules broken by one line of Rust.
fn line_findings(line: &str) -> Vec<&'static str> {
    let mut rules = Vec::new();
    if PARAM_NAMES
        .iter()
        .any(|n| indexings(line, n).into_iter().any(starts_with_digit))
    {
        rules.push("a literal index into the constants p (use idx::*)");
    }
    if STATE_NAMES.iter().any(|n| {
        indexings(line, n).into_iter().any(|rest| {
            starts_with_digit(rest)
                || rest.strip_prefix("..").is_some_and(starts_with_digit)
                || rest.starts_with("r * 10")
        })
    }) {
        rules.push(
            "a literal offset into a state, an input or an output (use OMEGA, XI, XIDOT, \
             KAPPA, DIM or the generated sizes)",
        );
    }
    if SIZES.iter().any(|n| line.contains(&format!("; {n}]")))
        || BLOCK_ENDS
            .iter()
            .any(|n| line.contains(&format!("[..{n}]")))
    {
        rules.push("a literal model size (use N_STATE, N_PARAM, DIM, ...)");
    }
    if BLOCK_RANGES.iter().any(|r| occurs_as_token(line, r)) {
        rules.push("a state block as a literal range (use OMEGA, XI, XIDOT, KAPPA)");
    }
    if NAMES.iter().any(|n| line.contains(n)) {
        rules.push("a helper that hard-wires a size");
    }
    rules
}

/// Every violation in a source text, by 1-based line.
fn scan(source: &str) -> Vec<Finding> {
    source
        .lines()
        .enumerate()
        .flat_map(|(k, line)| {
            line_findings(line).into_iter().map(move |rule| Finding {
                line: k + 1,
                rule,
                text: line.trim().to_string(),
            })
        })
        .collect()
}

fn rust_files(dir: &Path, root: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        let rel = path.strip_prefix(root).expect("under the root");
        let rel = rel.to_string_lossy().replace('\\', "/");
        if EXCLUDED.iter().any(|x| rel == *x) {
            continue;
        }
        if path.is_dir() {
            rust_files(&path, root, out);
        } else if rel.ends_with(".rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_hand_typed_layout_in_the_model_specific_code() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), root, &mut files);
    // The scan covers the problem layer (a wrong root would pass vacuously).
    for expected in [
        "src/so3/problem.rs",
        "src/so3/solve.rs",
        "src/so3/stability.rs",
        "src/lie/certify.rs",
        "src/app.rs",
        "src/report/csv.rs",
        "src/config.rs",
    ] {
        assert!(
            files.iter().any(|f| f.ends_with(expected)),
            "{expected} is not scanned"
        );
    }
    assert!(!files.iter().any(|f| f.starts_with(root.join("src/bvp"))));
    let mut report = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("readable source");
        let rel = file.strip_prefix(root).expect("under the root").display();
        for f in scan(&text) {
            report.push(format!("{rel}:{}: {}: `{}`", f.line, f.rule, f.text));
        }
    }
    assert!(
        report.is_empty(),
        "hand-typed layout (the generated model defines it: suslov::model::generated):\n{}",
        report.join("\n")
    );
}

#[test]
fn the_scanner_finds_planted_violations() {
    let planted = [
        "    params[4] = beta_m;",
        "        h.params[7] = w.delta;",
        "        problem.weights.alpha = p[3];",
        "            self.t_span = self.solution.p[0];",
        "    pub fn params(&self) -> [f64; 8] {",
        "    let mut dgdy = [[0.0; 12]; 12];",
        "fn z9(z: &[f64]) -> &[f64; 9] {",
        "        let mut ff = [0.0; 6];",
        "        g::ode_rhs_scaled(arr12(y), &self.params, &w, t_span, out);",
        "        v0.extend_from_slice(&y[..9]);",
        "        out[3..9].copy_from_slice(&xi);",
        "        out[..3].copy_from_slice(&om[..3]);",
        "        table.kappa.push([y[9], y[10], y[11]]);",
        "        let c = (0..3).map(|i| y[i] * y[3 + i]).sum::<f64>();",
        "            h[r * 10..r * 10 + 9].copy_from_slice(&h_zz[r]);",
        "        h[99] = tt;",
        "        res[12] = g::free_time_condition(arr12(yb), &self.params, &wb);",
        "        let xn = (yb[3] * yb[3]).sqrt();",
        "        for i in 9..12 {",
    ];
    for line in planted {
        assert!(
            !line_findings(line).is_empty(),
            "the planted violation is not found: {line}"
        );
    }
    // Line numbers are reported, 1-based.
    let source = "fn f() {}\n// fine\nlet a = [0.0; 12];\n";
    let found = scan(source);
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].line, 3);
}

#[test]
fn the_scanner_accepts_the_generated_forms() {
    for line in [
        "    params[idx::BETA] = beta_m;",
        "    pub fn params(&self) -> [f64; N_PARAM] {",
        "    let mut dgdy = [[0.0; N_STATE]; N_STATE];",
        "        let om: [f64; 3 * DIM] = stack(&[j.value.as_slice()]);",
        "        out[OMEGA].copy_from_slice(j.value.as_slice());",
        "            dp[BC_FREE_TIME * self.k() + SPAN] = 1.0;",
        "        let (rows, last) = h.split_at_mut(NZ * NH);",
        "        let h = w[1] - w[0];",
        "        let tol = 1e-12; let r = 0.3..6.0; let big = 10..120;",
        "        let xp[0] = gap[0] + step[1];",
        "    assert_eq!(&b[..8], b\"NUMPY\");",
    ] {
        assert!(
            line_findings(line).is_empty(),
            "flagged: {line}: {:?}",
            line_findings(line)
        );
    }
}
