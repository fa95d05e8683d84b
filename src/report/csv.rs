//! The trajectory CSV: one row per grid point, full `f64` precision.

use super::{write_atomic, ReportError, TrajectoryTable};
use std::fmt::Write as _;
use std::path::Path;

/// The header line of [`write_trajectory_csv`], exactly.
pub const TRAJECTORY_CSV_HEADER: &str = "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3,\
kappa1,kappa2,kappa3,omegad1,omegad2,omegad3";

/// Number of columns of the trajectory CSV.
const COLUMNS: usize = 16;

/// Renders `table` as CSV text (header + one line per row, `\n` line ends).
///
/// Numbers are written with Rust's shortest round-trip exponent format (`{:e}`, e.g.
/// `1.2345678901234567e-12`, `5e0`), so parsing them back gives the identical `f64`;
/// non-finite values are written `NaN`, `inf`, `-inf` (which Python, NumPy and pandas read).
///
/// # Errors
/// [`ReportError::LengthMismatch`] if the columns have different lengths.
pub fn trajectory_csv_string(table: &TrajectoryTable) -> Result<String, ReportError> {
    table.validate()?;
    let mut s = String::with_capacity((table.len() + 1) * COLUMNS * 24);
    s.push_str(TRAJECTORY_CSV_HEADER);
    s.push('\n');
    for i in 0..table.len() {
        // Writing into a String cannot fail.
        let _ = write!(s, "{:e}", table.t[i]);
        for v in [
            table.omega[i],
            table.xi[i],
            table.xi_dot[i],
            table.kappa[i],
            table.omega_d[i],
        ] {
            let _ = write!(s, ",{:e},{:e},{:e}", v[0], v[1], v[2]);
        }
        s.push('\n');
    }
    Ok(s)
}

/// Writes `table` to `path` as CSV (see [`trajectory_csv_string`] for the format), atomically
/// (see [`write_atomic`]; the parent directory must exist).
///
/// # Errors
/// [`ReportError::LengthMismatch`] (nothing is written) or [`ReportError::Io`] naming `path`.
pub fn write_trajectory_csv(
    path: impl AsRef<Path>,
    table: &TrajectoryTable,
) -> Result<(), ReportError> {
    let text = trajectory_csv_string(table)?;
    write_atomic(path, text.as_bytes())
}

/// Parses the CSV written by [`write_trajectory_csv`] back into a table (exactly the same
/// values). The header must match [`TRAJECTORY_CSV_HEADER`]; a trailing empty line is
/// allowed.
///
/// # Errors
/// [`ReportError::CsvParse`] with the 1-based line number for a wrong header, a wrong number
/// of fields or an unparsable number.
pub fn parse_trajectory_csv(text: &str) -> Result<TrajectoryTable, ReportError> {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    if header.trim_end() != TRAJECTORY_CSV_HEADER {
        return Err(ReportError::CsvParse {
            line: 1,
            message: format!("unexpected header `{header}`"),
        });
    }
    let mut table = TrajectoryTable::default();
    for (k, line) in lines.enumerate() {
        let line_no = k + 2;
        if line.trim().is_empty() {
            continue;
        }
        let mut v = [0.0f64; COLUMNS];
        let mut n = 0;
        for field in line.trim_end().split(',') {
            if n == COLUMNS {
                n += 1;
                break;
            }
            v[n] = field
                .trim()
                .parse::<f64>()
                .map_err(|e| ReportError::CsvParse {
                    line: line_no,
                    message: format!("field {} `{field}`: {e}", n + 1),
                })?;
            n += 1;
        }
        if n != COLUMNS {
            return Err(ReportError::CsvParse {
                line: line_no,
                message: format!("expected {COLUMNS} fields"),
            });
        }
        let triple = |j: usize| [v[j], v[j + 1], v[j + 2]];
        table.t.push(v[0]);
        table.omega.push(triple(1));
        table.xi.push(triple(4));
        table.xi_dot.push(triple(7));
        table.kappa.push(triple(10));
        table.omega_d.push(triple(13));
    }
    Ok(table)
}
