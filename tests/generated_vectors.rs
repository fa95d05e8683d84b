//! The emitted Rust equals sympy's own evaluation, for every model.
//!
//! `codegen/generate.py` evaluates every generated function at seeded random points with
//! mpmath (40 digits) straight from the derivation's expressions, and emits `check_vectors`,
//! which calls the *printed* Rust at the same points. This guards the printer (sympy 1.14's
//! Rust printer drops parentheses; ours must not) and the common-subexpression elimination.

mod vectors {
    include!(concat!(env!("OUT_DIR"), "/vectors.rs"));
}

#[test]
fn generated_functions_match_sympy_evaluation() {
    let failures = vectors::check_all(1e-12);
    assert!(
        failures.is_empty(),
        "{} mismatches:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn the_check_detects_a_wrong_value_in_every_model() {
    // A tolerance of zero must flag at least one of hundreds of outputs computed in f64
    // against 40-digit references, in every model: the comparison is live, not vacuous.
    let failures = vectors::check_all(0.0);
    for name in suslov::model::MODEL_NAMES {
        assert!(
            failures.iter().any(|m| m.starts_with(&format!("{name}: "))),
            "{name}: no mismatch at rtol = 0"
        );
    }
}
