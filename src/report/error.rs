//! The error type of the output layer.

use std::path::PathBuf;

/// Everything that can go wrong while writing results.
///
/// Every variant that concerns a file names its path, so that a message such as
/// `cannot write out/eta1/trajectory.csv: No such file or directory (os error 2)` tells the
/// user exactly what failed.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// An operating-system error while creating, writing, syncing or renaming a file or
    /// creating a directory.
    #[error("cannot write {}: {source}", crate::echo::path(path))]
    Io {
        /// The file (or directory) that was being written.
        path: PathBuf,
        /// The underlying OS error.
        #[source]
        source: std::io::Error,
    },
    /// Another run holds the output directory's lock.
    #[error(
        "{} is in use by another suslov run ({holder}); wait for it to finish or choose another \
         --out directory",
        crate::echo::path(dir)
    )]
    Busy {
        /// The output directory.
        dir: PathBuf,
        /// What the lock file says about its holder (`pid N`), if anything.
        holder: String,
    },
    /// A path that cannot be the target of a file write (for example `/` or `..`).
    #[error(
        "not a file path: {} (a directory, a device, a FIFO or a socket, or a path without a \
         file name); give the path of a regular file, new or existing",
        crate::echo::path(path)
    )]
    NotAFile {
        /// The offending path.
        path: PathBuf,
    },
    /// The columns of a [`TrajectoryTable`](super::TrajectoryTable) do not all have the
    /// length of its time column.
    #[error("trajectory table: column `{column}` has {len} rows but `t` has {expected}")]
    LengthMismatch {
        /// Name of the offending column.
        column: &'static str,
        /// Its length.
        len: usize,
        /// The length of `t`.
        expected: usize,
    },
    /// A table with no rows was given where at least one row is needed (figures).
    #[error("trajectory table is empty")]
    EmptyTable,
    /// Invalid input data other than column lengths (for example a non-positive inertia).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// A CSV text could not be parsed back into a table.
    #[error("CSV line {line}: {message}")]
    CsvParse {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// Serialising a summary to JSON failed.
    #[error("cannot serialise {} as JSON: {source}", crate::echo::path(path))]
    Json {
        /// The file that was to be written.
        path: PathBuf,
        /// The serde_json error.
        #[source]
        source: serde_json::Error,
    },
    /// Drawing or encoding a figure failed.
    #[error("cannot draw figure {}: {message}", crate::echo::path(path))]
    Plot {
        /// The figure file.
        path: PathBuf,
        /// What the plotting or encoding library reported.
        message: String,
    },
}
