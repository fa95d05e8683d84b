//! Misuse of the solver: invalid input, reported as `Err` before any computation.
//!
//! Algorithmic outcomes (no convergence, singular Jacobian, node cap, ...) are *not* errors:
//! they are a [`Status`](super::Status) inside an `Ok(`[`Solution`](super::Solution)`)`.

use thiserror::Error;

/// Invalid input to [`solve`](super::solve) and friends. Every variant names what is wrong,
/// with the expected and the actual value where that makes sense.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum BvpError {
    /// A slice or vector has the wrong length.
    #[error("{what}: expected length {expected}, found {found}")]
    DimensionMismatch {
        /// Which quantity (e.g. "guess values", "parameters").
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        found: usize,
    },
    /// The mesh has fewer than two nodes.
    #[error("mesh: expected at least 2 nodes, found {found}")]
    MeshTooShort {
        /// Number of nodes given.
        found: usize,
    },
    /// The mesh is not strictly increasing (this also covers `a >= b`).
    #[error("mesh: expected strictly increasing nodes, but x[{index}] = {left} >= x[{next}] = {right}", next = index + 1)]
    MeshNotIncreasing {
        /// Index of the first offending node.
        index: usize,
        /// `x[index]`.
        left: f64,
        /// `x[index + 1]`.
        right: f64,
    },
    /// A mesh node or an initial value is NaN or infinite.
    #[error("{what}: expected finite values, found {value} at index {index}")]
    NonFiniteInput {
        /// Which quantity.
        what: &'static str,
        /// Flat index of the offending value.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// An option is out of its allowed range.
    #[error("option `{name}` = {value}: expected {expected}")]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// Given value.
        value: f64,
        /// The allowed range, in words.
        expected: &'static str,
    },
    /// The problem declares zero states.
    #[error("problem: expected at least one state (n >= 1), found n = 0")]
    NoStates,
}
