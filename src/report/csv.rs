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

/// The table as a NumPy `.npy` file (format 1.0): a C-ordered little-endian float64 array of
/// shape `(rows, 16)` with the columns of [`TRAJECTORY_CSV_HEADER`], for
/// `numpy.load("trajectory.npy")`.
///
/// # Errors
/// [`ReportError::LengthMismatch`] for inconsistent columns.
pub fn trajectory_npy_bytes(table: &TrajectoryTable) -> Result<Vec<u8>, ReportError> {
    table.validate()?;
    let rows = table.len();
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({rows}, 16), }}");
    // Magic (6) + version (2) + header length (2) + header + '\n', padded to 64 bytes.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + rows * 16 * 8);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    let len = u16::try_from(header.len()).expect("the header is short");
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for i in 0..rows {
        out.extend_from_slice(&table.t[i].to_le_bytes());
        for col in [
            &table.omega,
            &table.xi,
            &table.xi_dot,
            &table.kappa,
            &table.omega_d,
        ] {
            for v in col[i] {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    Ok(out)
}

/// Writes [`trajectory_npy_bytes`] atomically to `path`.
///
/// # Errors
/// As [`trajectory_npy_bytes`], or [`ReportError::Io`] naming `path`.
pub fn write_trajectory_npy(
    path: impl AsRef<Path>,
    table: &TrajectoryTable,
) -> Result<(), ReportError> {
    write_atomic(path, &trajectory_npy_bytes(table)?)
}

#[cfg(test)]
mod npy_tests {
    use super::*;

    #[test]
    fn npy_layout_header_and_values() {
        let table = TrajectoryTable {
            t: vec![0.0, 0.5, 1.0],
            omega: vec![[1.0, 2.0, 3.0]; 3],
            xi: vec![[4.0, 5.0, 6.0]; 3],
            xi_dot: vec![[7.0, 8.0, 9.0]; 3],
            kappa: vec![[10.0, 11.0, 12.0]; 3],
            omega_d: vec![[13.0, 14.0, -1e-300]; 3],
        };
        let b = trajectory_npy_bytes(&table).expect("valid table");
        assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
        let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0, "data must start 64-byte aligned");
        let header = std::str::from_utf8(&b[10..10 + hlen]).expect("ascii header");
        assert!(header.contains("'descr': '<f8'") && header.contains("'shape': (3, 16)"));
        assert!(header.ends_with('\n'));
        assert_eq!(b.len(), 10 + hlen + 3 * 16 * 8);
        let value = |row: usize, col: usize| {
            let at = 10 + hlen + (row * 16 + col) * 8;
            f64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
        };
        assert_eq!(value(1, 0), 0.5);
        assert_eq!(value(2, 1), 1.0);
        assert_eq!(value(2, 13), 13.0);
        assert_eq!(value(0, 15), -1e-300);
        let bad = TrajectoryTable {
            t: vec![0.0],
            ..table
        };
        assert!(trajectory_npy_bytes(&bad).is_err());
    }
}
