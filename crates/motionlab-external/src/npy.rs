//! The NumPy `.npy` format 1.0, writing only: positions as float64 `(frames, points, 3)`,
//! channels as `(samples, channels)`.
//!
//! Format (numpy.lib.format): the magic `\x93NUMPY`, version bytes `1 0`, the header length
//! as little-endian u16, an ASCII Python dict literal padded with spaces and ended by `\n` so
//! that the data start on a multiple of 64 bytes, then the values in C order.

use std::io::{self, Write};

use motionlab_core::Point3;

/// Writes `positions` (frame-major, `n_frames × n_points` points) as a `<f8` array of shape
/// `(n_frames, n_points, 3)`. NaN values are written as they are.
pub fn write_positions(
    out: &mut impl Write,
    positions: &[Point3],
    n_frames: usize,
    n_points: usize,
) -> io::Result<()> {
    if positions.len() != n_frames * n_points {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{} positions is not {n_frames} frames × {n_points} points", positions.len()),
        ));
    }
    out.write_all(&header(&[n_frames, n_points, 3])?)?;
    for p in positions {
        for c in p {
            out.write_all(&c.to_le_bytes())?;
        }
    }
    Ok(())
}

/// Writes `values` (row-major, `n_rows × n_cols`) as a `<f8` array of shape `(n_rows, n_cols)`:
/// a motion's channels, samples × channels. NaN values are written as they are.
pub fn write_matrix(
    out: &mut impl Write,
    values: &[f64],
    n_rows: usize,
    n_cols: usize,
) -> io::Result<()> {
    if values.len() != n_rows * n_cols {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{} values is not {n_rows} rows × {n_cols} columns", values.len()),
        ));
    }
    out.write_all(&header(&[n_rows, n_cols])?)?;
    for v in values {
        out.write_all(&v.to_le_bytes())?;
    }
    Ok(())
}

/// The preamble and padded header of a C-order `<f8` array of `shape`.
fn header(shape: &[usize]) -> io::Result<Vec<u8>> {
    let dims: Vec<String> = shape.iter().map(usize::to_string).collect();
    // A one-element tuple needs its trailing comma in Python: `(5,)`.
    let tuple =
        if dims.len() == 1 { format!("({},)", dims[0]) } else { format!("({})", dims.join(", ")) };
    let mut dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {tuple}, }}");
    const PREAMBLE: usize = 10; // magic (6) + version (2) + header length (2)
    let unpadded = PREAMBLE + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    dict.push('\n');
    let len = u16::try_from(dict.len()).map_err(|_| {
        io::Error::new(io::ErrorKind::InvalidInput, "npy header longer than 65535 bytes")
    })?;
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&len.to_le_bytes());
    bytes.extend_from_slice(dict.as_bytes());
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_aligned_and_data_follow_in_c_order() {
        let positions = [[1.0, 2.0, 3.0], [4.0, f64::NAN, 6.0]];
        let mut bytes = Vec::new();
        write_positions(&mut bytes, &positions, 2, 1).unwrap();
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + len) % 64, 0);
        let text = std::str::from_utf8(&bytes[10..10 + len]).unwrap();
        assert_eq!(
            text.trim_end(),
            "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 1, 3), }"
        );
        assert!(text.ends_with('\n'));
        let values: Vec<f64> = bytes[10 + len..]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(values.len(), 6);
        assert_eq!(values[..4], [1.0, 2.0, 3.0, 4.0]);
        assert!(values[4].is_nan() && values[5] == 6.0);
        assert_eq!(header(&[5]).unwrap().windows(4).filter(|w| w == b"(5,)").count(), 1);
    }

    #[test]
    fn wrong_buffer_length_is_an_error() {
        assert!(write_positions(&mut Vec::new(), &[[0.0; 3]], 2, 1).is_err());
    }
}
