//! How much motionlab reads from one input before it refuses it.
//!
//! Data files and experiment files come from other people. A file that claims, or inflates
//! to, far more than any recording could be (a gzip "bomb": 8.7 MB of gzip that inflates to
//! 2 GB of zeros) is refused with one error naming the file, before it is held in memory.
//!
//! **Motion and annotation files**: at most [`DEFAULT_MAX_INPUT_MB`] MiB each, after
//! decompression, unless the environment variable [`MAX_INPUT_MB_ENV`] sets another number of
//! MiB. The default is about a 30-minute capture of 100 markers at 240 Hz written as Qualisys
//! TSV (432,000 frames × 300 values × 8.2 bytes per value, the rate of `data/mct/dance1.tsv`)
//! — a long take for a marker system, and 280 times the largest take shipped in `data/`.
//!
//! **Experiment files**: at most [`MAX_EXPERIMENT_BYTES`]; the largest shipped one is a few KB.

use std::io::Read;
use std::path::Path;

use crate::{Error, ErrorKind, Location, Result};

/// The environment variable holding the input limit in MiB (a positive whole number).
pub const MAX_INPUT_MB_ENV: &str = "MOTIONLAB_MAX_INPUT_MB";

/// The input limit in MiB when [`MAX_INPUT_MB_ENV`] is not set.
pub const DEFAULT_MAX_INPUT_MB: u64 = 1024;

/// The largest experiment file read.
pub const MAX_EXPERIMENT_BYTES: u64 = 16 << 20;

const MIB: u64 = 1 << 20;

/// The most bytes one motion or annotation file may hold after decompression: the
/// [`MAX_INPUT_MB_ENV`] variable in MiB, else [`DEFAULT_MAX_INPUT_MB`]. A value that is not a
/// positive whole number is an error naming the variable.
pub fn max_input_bytes() -> Result<u64> {
    match std::env::var(MAX_INPUT_MB_ENV) {
        Err(std::env::VarError::NotPresent) => Ok(DEFAULT_MAX_INPUT_MB * MIB),
        Ok(text) if text.trim().is_empty() => Ok(DEFAULT_MAX_INPUT_MB * MIB),
        Ok(text) => text
            .trim()
            .parse::<u64>()
            .ok()
            .filter(|&mb| mb > 0)
            .and_then(|mb| mb.checked_mul(MIB))
            .ok_or_else(|| {
                Error::new(
                    ErrorKind::OutOfRange,
                    format!("{MAX_INPUT_MB_ENV}={text:?}: expected a positive whole number of MiB"),
                )
                .with_field(MAX_INPUT_MB_ENV)
            }),
        Err(e) => Err(Error::new(ErrorKind::OutOfRange, format!("{MAX_INPUT_MB_ENV}: {e}"))
            .with_field(MAX_INPUT_MB_ENV)),
    }
}

/// A limit in words: `1024 MiB` (or bytes when below one MiB).
pub fn describe_limit(limit: u64) -> String {
    if limit >= MIB && limit.is_multiple_of(MIB) {
        format!("{} MiB", limit / MIB)
    } else {
        format!("{limit} bytes")
    }
}

/// The error for a motion or annotation file beyond the input limit `limit`: `what` says how
/// it got there ("holds 3000000000 bytes", "gzip data of … inflate to more than …").
pub fn too_large(path: &Path, what: &str, limit: u64) -> Error {
    Error::new(
        ErrorKind::TooLarge,
        format!("{what}, more than the input limit of {} (set {MAX_INPUT_MB_ENV} to read a larger file)", describe_limit(limit)),
    )
    .with_location(Location::file(path))
}

/// The bytes of a motion or annotation file, refused with one error naming it when it holds
/// more than `limit` ([`read_bounded`]).
pub fn read_input_file(path: &Path, limit: u64) -> Result<Vec<u8>> {
    read_bounded(path, limit, |what| too_large(path, what, limit))
}

/// The bytes of an experiment file, refused beyond [`MAX_EXPERIMENT_BYTES`].
pub fn read_experiment_file(path: &Path) -> Result<Vec<u8>> {
    read_bounded(path, MAX_EXPERIMENT_BYTES, |what| {
        Error::new(
            ErrorKind::TooLarge,
            format!(
                "{what}, more than the {} an experiment file may hold",
                describe_limit(MAX_EXPERIMENT_BYTES)
            ),
        )
        .with_location(Location::file(path))
    })
}

/// The bytes of a file, or `too_large`'s error when it holds more than `limit`: by its size
/// before reading, and while reading (a file that grows, a device that never ends).
fn read_bounded(path: &Path, limit: u64, too_large: impl Fn(&str) -> Error) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let size = file.metadata().map_err(|e| Error::io(path, e))?.len();
    if size > limit {
        return Err(too_large(&format!("holds {size} bytes")));
    }
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0).saturating_add(1));
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes).map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(too_large("holds more bytes than its size said"));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_beyond_the_limit_is_refused_naming_it() {
        let dir = std::env::temp_dir().join(format!("mlab-limits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("ten.txt");
        std::fs::write(&path, b"0123456789").unwrap();
        assert_eq!(read_input_file(&path, 10).unwrap(), b"0123456789");
        let e = read_input_file(&path, 9).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::TooLarge);
        assert_eq!(e.location().file.as_deref(), Some(path.as_path()));
        assert!(
            e.to_string().contains("holds 10 bytes, more than the input limit of 9 bytes"),
            "{e}"
        );
        assert_eq!(describe_limit(DEFAULT_MAX_INPUT_MB * MIB), "1024 MiB");
        std::fs::remove_dir_all(&dir).ok();
    }
}
