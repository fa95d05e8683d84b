//! The trajectory CSV: one row per grid point, full `f64` precision.

use super::{write_atomic, ReportError, TrajectoryTable};
use crate::model::generated::{DIM, KAPPA, N_STATE, OMEGA, STATE_NAMES, XI, XIDOT};
use std::fmt::Write as _;
use std::ops::Range;
use std::path::Path;

/// The header line of [`write_trajectory_csv`], exactly: `t`, the generated `STATE_NAMES`
/// (`omega1, …, kappa3` on so(3)), then `Ω_d` as `omegad1, …, omegad<DIM>`.
///
/// `Ω_d` is no state, so the generated names do not name it; its columns are
/// [`DESIRED_COLUMN_PREFIX`] followed by the 1-based component, the scheme of the state names.
/// On so(3) this is `t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3,kappa1,kappa2,
/// kappa3,omegad1,omegad2,omegad3` (without spaces), as always.
pub const TRAJECTORY_CSV_HEADER: &str = match std::str::from_utf8(&HEADER_BYTES) {
    Ok(header) => header,
    Err(_) => panic!("the state names are UTF-8"),
};

/// Prefix of the column names of `Ω_d` (`omegad1`, `omegad2`, …).
pub const DESIRED_COLUMN_PREFIX: &str = "omegad";

/// Number of columns of the trajectory CSV: `t`, the states, `Ω_d`.
const COLUMNS: usize = 1 + N_STATE + DIM;

/// Column of state entry `j` is `1 + j`; `Ω_d` follows the states.
const fn columns(block: Range<usize>) -> Range<usize> {
    1 + block.start..1 + block.end
}
const DESIRED_COLUMNS: Range<usize> = 1 + N_STATE..1 + N_STATE + DIM;

// The table's columns are written in the order of the state blocks, which must be
// [Ω, ξ, ξ̇, κ], contiguous, for the header (the state names in order) to label them.
const _: () = assert!(
    OMEGA.start == 0
        && OMEGA.end == XI.start
        && XI.end == XIDOT.start
        && XIDOT.end == KAPPA.start
        && KAPPA.end == N_STATE
);

/// Decimal digits of `k > 0`.
const fn decimal_len(mut k: usize) -> usize {
    let mut n = 0;
    while k > 0 {
        n += 1;
        k /= 10;
    }
    n
}

/// Length of [`TRAJECTORY_CSV_HEADER`].
const HEADER_LEN: usize = {
    let mut len = 1; // "t"
    let mut i = 0;
    while i < STATE_NAMES.len() {
        len += 1 + STATE_NAMES[i].len();
        i += 1;
    }
    let mut k = 1;
    while k <= DIM {
        len += 1 + DESIRED_COLUMN_PREFIX.len() + decimal_len(k);
        k += 1;
    }
    len
};

/// Copies `s` into `buf` at `at`; returns the position after it.
const fn put(buf: &mut [u8; HEADER_LEN], mut at: usize, s: &[u8]) -> usize {
    let mut i = 0;
    while i < s.len() {
        buf[at] = s[i];
        at += 1;
        i += 1;
    }
    at
}

/// The bytes of [`TRAJECTORY_CSV_HEADER`].
const HEADER_BYTES: [u8; HEADER_LEN] = {
    let mut buf = [0u8; HEADER_LEN];
    let mut at = put(&mut buf, 0, b"t");
    let mut i = 0;
    while i < STATE_NAMES.len() {
        at = put(&mut buf, at, b",");
        at = put(&mut buf, at, STATE_NAMES[i].as_bytes());
        i += 1;
    }
    let mut k = 1;
    while k <= DIM {
        at = put(&mut buf, at, b",");
        at = put(&mut buf, at, DESIRED_COLUMN_PREFIX.as_bytes());
        let mut d = decimal_len(k);
        let mut v = k;
        while d > 0 {
            buf[at + d - 1] = b'0' + (v % 10) as u8;
            v /= 10;
            d -= 1;
        }
        at += decimal_len(k);
        k += 1;
    }
    assert!(at == HEADER_LEN);
    buf
};

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
            for x in v {
                let _ = write!(s, ",{x:e}");
            }
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
        let block =
            |c: Range<usize>| -> [f64; DIM] { v[c].try_into().expect("a block has DIM columns") };
        table.t.push(v[0]);
        table.omega.push(block(columns(OMEGA)));
        table.xi.push(block(columns(XI)));
        table.xi_dot.push(block(columns(XIDOT)));
        table.kappa.push(block(columns(KAPPA)));
        table.omega_d.push(block(DESIRED_COLUMNS));
    }
    Ok(table)
}

/// The table as a NumPy `.npy` file (format 1.0): a C-ordered little-endian float64 array of
/// shape `(rows, 16)` (on so(3); `1 + N_STATE + DIM` columns) with the columns of
/// [`TRAJECTORY_CSV_HEADER`], for
/// `numpy.load("trajectory.npy")`.
///
/// # Errors
/// [`ReportError::LengthMismatch`] for inconsistent columns.
pub fn trajectory_npy_bytes(table: &TrajectoryTable) -> Result<Vec<u8>, ReportError> {
    table.validate()?;
    let rows = table.len();
    let mut header =
        format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({rows}, {COLUMNS}), }}");
    // Magic (6) + version (2) + header length (2) + header + '\n', padded to 64 bytes.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + rows * COLUMNS * 8);
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

/// The table as a numpy `.npz` archive of named columns (the names of
/// [`TRAJECTORY_CSV_HEADER`]: `numpy.load("trajectory.npz")["omega1"]`).
///
/// # Errors
/// [`ReportError::LengthMismatch`] for inconsistent columns.
pub fn trajectory_npz_bytes(table: &TrajectoryTable) -> Result<Vec<u8>, ReportError> {
    table.validate()?;
    let mut columns: Vec<Vec<f64>> = vec![table.t.clone()];
    for block in [
        &table.omega,
        &table.xi,
        &table.xi_dot,
        &table.kappa,
        &table.omega_d,
    ] {
        for k in 0..block.first().map_or(0, |r| r.len()) {
            columns.push(block.iter().map(|r| r[k]).collect());
        }
    }
    let named: Vec<(&str, &[f64])> = TRAJECTORY_CSV_HEADER
        .split(',')
        .zip(&columns)
        .map(|(n, c)| (n, c.as_slice()))
        .collect();
    super::npz_bytes(&named)
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
mod header_tests {
    use super::*;

    #[test]
    fn header_is_t_the_generated_state_names_and_omega_d() {
        let names: Vec<&str> = TRAJECTORY_CSV_HEADER.split(',').collect();
        assert_eq!(names.len(), COLUMNS);
        assert_eq!(names[0], "t");
        assert_eq!(names[1..=N_STATE], STATE_NAMES);
        for (k, name) in names[DESIRED_COLUMNS].iter().enumerate() {
            assert_eq!(*name, format!("{DESIRED_COLUMN_PREFIX}{}", k + 1));
        }
        // The file format is unchanged (so(3)).
        assert_eq!(
            TRAJECTORY_CSV_HEADER,
            "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3,kappa1,kappa2,kappa3,\
             omegad1,omegad2,omegad3"
        );
        assert_eq!(decimal_len(9), 1);
        assert_eq!(decimal_len(10), 2);
        assert_eq!(decimal_len(123), 3);
    }
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
