//! Named columns as a numpy `.npz` archive (`numpy.load("trajectory.npz")["omega1"]`).
//!
//! An `.npz` is a ZIP archive of `.npy` files, one per array, named `<name>.npy`. Each column
//! here is a one-dimensional little-endian `float64` array in `.npy` format 1.0; the archive is
//! written without compression (ZIP method 0, "stored"), which numpy reads as it reads
//! `numpy.savez`'s own files, with the CRC-32 of every member so readers can check it. The
//! archive is built in memory and written atomically like every other output. Archives above
//! 4 GiB (ZIP64) are refused: a million rows of 26 columns is about 200 MB.

use super::ReportError;

/// The `.npy` (format 1.0) bytes of a one-dimensional `float64` array.
pub fn npy_1d_bytes(values: &[f64]) -> Vec<u8> {
    let mut header = format!(
        "{{'descr': '<f8', 'fortran_order': False, 'shape': ({},), }}",
        values.len()
    );
    // Magic (6) + version (2) + header length (2) + header + '\n', padded to 64 bytes.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + 8 * values.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    let len = u16::try_from(header.len()).expect("a 1-d header is short");
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// An `.npz` archive of `columns` (name, values), every column the same length, names of
/// ASCII letters, digits and `_` (they become member names `<name>.npy`).
///
/// # Errors
/// [`ReportError::InvalidInput`] for a bad name, columns of different lengths or an archive
/// above 4 GiB.
pub fn npz_bytes(columns: &[(&str, &[f64])]) -> Result<Vec<u8>, ReportError> {
    let rows = columns.first().map_or(0, |c| c.1.len());
    for (name, values) in columns {
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(ReportError::InvalidInput(format!(
                "npz column name {name:?}: use letters, digits and _"
            )));
        }
        if values.len() != rows {
            return Err(ReportError::InvalidInput(format!(
                "npz column {name} has {} rows, the first column {rows}",
                values.len()
            )));
        }
    }
    let too_large =
        || ReportError::InvalidInput("the npz archive would exceed 4 GiB (no ZIP64)".into());
    let mut out = Vec::new();
    let mut central = Vec::new();
    for (name, values) in columns {
        let file = format!("{name}.npy");
        let data = npy_1d_bytes(values);
        let crc = crc32fast::hash(&data);
        let size = u32::try_from(data.len()).map_err(|_| too_large())?;
        let offset = u32::try_from(out.len()).map_err(|_| too_large())?;
        let name_len = u16::try_from(file.len()).expect("short names");
        // Local file header.
        out.extend_from_slice(&0x0403_4b50_u32.to_le_bytes());
        push_common(&mut out, crc, size, name_len);
        out.extend_from_slice(file.as_bytes());
        out.extend_from_slice(&data);
        // Its central directory entry.
        central.extend_from_slice(&0x0201_4b50_u32.to_le_bytes());
        central.extend_from_slice(&20u16.to_le_bytes()); // made by: version 2.0
        push_common(&mut central, crc, size, name_len);
        central.extend_from_slice(&0u16.to_le_bytes()); // comment length
        central.extend_from_slice(&0u16.to_le_bytes()); // disk number
        central.extend_from_slice(&0u16.to_le_bytes()); // internal attributes
        central.extend_from_slice(&0u32.to_le_bytes()); // external attributes
        central.extend_from_slice(&offset.to_le_bytes());
        central.extend_from_slice(file.as_bytes());
    }
    let cd_offset = u32::try_from(out.len()).map_err(|_| too_large())?;
    let cd_size = u32::try_from(central.len()).map_err(|_| too_large())?;
    out.extend_from_slice(&central);
    let n = u16::try_from(columns.len())
        .map_err(|_| ReportError::InvalidInput("more than 65535 npz columns".into()))?;
    // End of central directory.
    out.extend_from_slice(&0x0605_4b50_u32.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes()); // this disk
    out.extend_from_slice(&0u16.to_le_bytes()); // disk of the central directory
    out.extend_from_slice(&n.to_le_bytes());
    out.extend_from_slice(&n.to_le_bytes());
    out.extend_from_slice(&cd_size.to_le_bytes());
    out.extend_from_slice(&cd_offset.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes()); // comment length
    if u32::try_from(out.len()).is_err() {
        return Err(too_large());
    }
    Ok(out)
}

/// The fields a local header and a central directory entry share, from "version needed".
fn push_common(out: &mut Vec<u8>, crc: u32, size: u32, name_len: u16) {
    out.extend_from_slice(&20u16.to_le_bytes()); // version needed: 2.0
    out.extend_from_slice(&0u16.to_le_bytes()); // flags
    out.extend_from_slice(&0u16.to_le_bytes()); // method: stored
    out.extend_from_slice(&0u16.to_le_bytes()); // time 00:00:00
    out.extend_from_slice(&0x0021u16.to_le_bytes()); // date 1980-01-01 (fixed: same bytes every run)
    out.extend_from_slice(&crc.to_le_bytes());
    out.extend_from_slice(&size.to_le_bytes()); // compressed size
    out.extend_from_slice(&size.to_le_bytes()); // uncompressed size
    out.extend_from_slice(&name_len.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes()); // extra field length
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_padded_and_the_data_follow() {
        let b = npy_1d_bytes(&[1.0, -2.5]);
        assert!(b.starts_with(b"\x93NUMPY\x01\x00"));
        let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0);
        assert!(std::str::from_utf8(&b[10..10 + hlen])
            .unwrap()
            .contains("'shape': (2,)"));
        assert_eq!(&b[10 + hlen..10 + hlen + 8], &1.0f64.to_le_bytes());
        assert_eq!(b.len(), 10 + hlen + 16);
    }

    #[test]
    fn bad_names_and_ragged_columns_are_refused() {
        assert!(npz_bytes(&[("a b", &[1.0])]).is_err());
        assert!(npz_bytes(&[("../x", &[1.0])]).is_err());
        assert!(npz_bytes(&[("a", &[1.0]), ("b", &[1.0, 2.0])]).is_err());
        let z = npz_bytes(&[("a", &[1.0]), ("b", &[2.0])]).unwrap();
        assert!(z.starts_with(b"PK\x03\x04"));
        let end_record = z.len() - 22; // no archive comment
        assert!(z[end_record..].starts_with(b"PK\x05\x06"));
    }
}
