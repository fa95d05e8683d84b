//! Hostile problem files (issue #10): wrong-length arrays, oversized inputs, files that are
//! no files, inconsistent tolerances, messages that blamed the wrong key or echoed too much.
//! Each test is the regression test of one defect; every error must name the field, say what
//! was expected and found, and stay short.

use suslov::config::{self, ConfigError};

/// The paper's η = 1 problem file, the base most tests modify.
const BASE: &str = include_str!("../examples/paper_eta1.toml");

/// A segment problem (fixed time) on `I = diag(1, 2, 3)`: `[3, 0, 0] → [1, 2, 0]`.
const SEGMENT: &str = "[body]\ninertia = [1.0, 2.0, 3.0]\n[boundary]\nomega_a = [3.0, 0.0, 0.0]\n\
                       omega_b = [1.0, 2.0, 0.0]\nterminal_time = { fixed = 4.0 }\n\
                       [cost]\nalpha = 1.0\nbeta = 0.1\ngamma = 1.0\n[desired]\nkind = \"segment\"\n";

/// Longest message any error may print (the echoed input is capped).
const MAX_MESSAGE: usize = 1000;

/// `BASE` with the first line starting with `key` replaced by `replacement`.
fn with_line(doc: &str, key: &str, replacement: &str) -> String {
    let mut found = false;
    let out: Vec<String> = doc
        .lines()
        .map(|l| {
            if !found && l.trim_start().starts_with(key) {
                found = true;
                replacement.to_string()
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(found, "no line starting with {key}");
    out.join("\n") + "\n"
}

/// `doc`'s error, which must name `field` (its TOML path) and be short.
fn error(doc: &str, field: &str) -> (ConfigError, String) {
    let e = match config::from_toml_str(doc) {
        Ok(p) => panic!("expected an error naming {field}, got {p:?}"),
        Err(e) => e,
    };
    check_error(e, field)
}

fn check_error(e: ConfigError, field: &str) -> (ConfigError, String) {
    let msg = e.to_string();
    assert_eq!(e.field(), Some(field), "{msg}");
    assert!(msg.contains(field), "message does not name {field}: {msg}");
    assert!(msg.len() <= MAX_MESSAGE, "{} characters: {msg}", msg.len());
    assert!(!msg.contains("NaN"), "{msg}");
    (e, msg)
}

fn assert_contains(msg: &str, words: &[&str]) {
    for w in words {
        assert!(msg.contains(w), "message lacks {w:?}: {msg}");
    }
}

// ---------------------------------------------------------------------------------------
// Defect 1: arrays of the wrong length were truncated silently (NaN included).

#[test]
fn arrays_longer_or_shorter_than_expected_name_the_field_and_both_lengths() {
    let cases = [
        (
            BASE,
            "inertia =",
            "inertia = [1, 2, 3, 4]",
            "body.inertia",
            "has 4 entries, expected 3 (I1, I2, I3)",
        ),
        (
            BASE,
            "inertia =",
            "inertia = [1, 2]",
            "body.inertia",
            "has 2 entries, expected 3 (I1, I2, I3)",
        ),
        (
            BASE,
            "inertia =",
            "inertia = []",
            "body.inertia",
            "has 0 entries, expected 3",
        ),
        (
            BASE,
            "omega_a =",
            "omega_a = [5, 0, 0, nan]",
            "boundary.omega_a",
            "has 4 entries, expected 3",
        ),
        (
            BASE,
            "omega_a =",
            "omega_a = [5]",
            "boundary.omega_a",
            "has 1 entry, expected 3",
        ),
        (
            BASE,
            "omega_b =",
            "omega_b = [2.75, -2.31, -1.49, 0.0]",
            "boundary.omega_b",
            "has 4 entries, expected 3",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"segment\"\ninterval = [0, 4, 99]",
            "desired.interval",
            "has 3 entries, expected 2",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"segment\"\ninterval = [0]",
            "desired.interval",
            "has 1 entry, expected 2",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"segment\"\nfrom = [3, 0, 0, 1]",
            "desired.from",
            "has 4 entries, expected 3",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"segment\"\nto = [1, 2]",
            "desired.to",
            "has 2 entries, expected 3",
        ),
        (
            SEGMENT,
            "kind =",
            "kind = \"constant\"\nvalue = [3, 0, 0, 0, 0]",
            "desired.value",
            "has 5 entries, expected 3",
        ),
    ];
    for (doc, key, line, field, words) in cases {
        let (e, msg) = error(&with_line(doc, key, line), field);
        assert!(matches!(e, ConfigError::Length { .. }), "{msg}");
        assert_contains(&msg, &[words]);
    }
}

#[test]
fn a_hundred_thousand_entry_array_is_counted_not_truncated() {
    let long = vec!["1"; 100_000].join(",");
    let (_, msg) = error(
        &with_line(BASE, "inertia =", &format!("inertia = [{long}]")),
        "body.inertia",
    );
    assert_contains(&msg, &["has 100000 entries, expected 3"]);
}
