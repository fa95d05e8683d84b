//! Generic two-point boundary value problem solver (work in progress).
