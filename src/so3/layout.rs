//! Glue between `nalgebra` values and the generated functions' fixed-size arrays.
//!
//! The generated functions take their inputs as flat arrays of blocks of `DIM` entries (e.g.
//! `suslov_omega_dot`'s `x = [Ω, ξ, ξ̇]`, `singular_control`'s `[Ω_p, Ω̇_p, Ω̈_p]`), and the
//! state `y` in the generated layout (`N_STATE`, the blocks `OMEGA`, `XI`, `XIDOT`, `KAPPA`).
//! These helpers build and view such arrays without re-typing a size or an offset.

use crate::model::generated::N_STATE;

/// The blocks concatenated into one array, e.g. `stack::<{ 3 * DIM }>(&[ω, ξ, ξ̇])`.
///
/// # Panics
/// If the blocks do not fill exactly `N` entries (a layout bug, never data).
pub fn stack<const N: usize>(blocks: &[&[f64]]) -> [f64; N] {
    let mut out = [0.0; N];
    let mut at = 0;
    for b in blocks {
        out[at..at + b.len()].copy_from_slice(b);
        at += b.len();
    }
    assert_eq!(at, N, "the blocks have {at} entries, the array {N}");
    out
}

/// `y` as the generated functions' state array.
///
/// # Panics
/// If `y` does not have `N_STATE` entries.
pub fn as_state(y: &[f64]) -> &[f64; N_STATE] {
    y.try_into().expect("a state has N_STATE entries")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_concatenates_and_checks_the_size() {
        let a: [f64; 5] = stack(&[&[1.0, 2.0], &[3.0], &[4.0, 5.0]]);
        assert_eq!(a, [1.0, 2.0, 3.0, 4.0, 5.0]);
        assert!(std::panic::catch_unwind(|| stack::<4>(&[&[1.0, 2.0], &[3.0]])).is_err());
        assert!(std::panic::catch_unwind(|| stack::<2>(&[&[1.0, 2.0], &[3.0]])).is_err());
    }
}
