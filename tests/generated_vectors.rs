//! The emitted Rust equals sympy's own evaluation.
//!
//! `codegen/generate.py` evaluates every generated function at seeded random points with
//! mpmath (40 digits) straight from the derivation's expressions, and emits `check_vectors`,
//! which calls the *printed* Rust at the same points. This guards the printer (sympy 1.14's
//! Rust printer drops parentheses; ours must not) and the common-subexpression elimination.

#[allow(clippy::all, clippy::excessive_precision)]
mod vectors {
    use suslov::model::generated::*;
    include!(concat!(env!("OUT_DIR"), "/suslov_vectors.rs"));
}

#[test]
fn generated_functions_match_sympy_evaluation() {
    let failures = vectors::check_vectors(1e-12);
    assert!(
        failures.is_empty(),
        "{} mismatches:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn the_check_detects_a_wrong_value() {
    // A tolerance of zero must flag at least one of hundreds of outputs computed in f64
    // against 40-digit references: the comparison is live, not vacuous.
    assert!(!vectors::check_vectors(0.0).is_empty());
}
