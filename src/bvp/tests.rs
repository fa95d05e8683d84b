//! Unit tests of the internals: tableau, sparsity pattern, condensed Newton correction.
