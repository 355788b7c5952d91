//! Reading input files: transparent gzip (by the `.gz` suffix or the gzip magic bytes), a
//! UTF-8 check that names the offending line, and a leading BOM stripped.

use std::io::Read;
use std::path::Path;

use motionlab_core::{Error, ErrorKind, Location, Result};

/// The bytes of a file, decompressed when it is gzip (by suffix or magic number).
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    let raw = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if raw.starts_with(&[0x1f, 0x8b]) {
        // The gzip trailer's ISIZE is the last member's length mod 2³², so for the usual
        // one-member file it sizes the buffer exactly (no regrowth copies); it is only a hint.
        let isize = raw.last_chunk::<4>().map_or(0, |b| u32::from_le_bytes(*b) as usize);
        let mut out = Vec::with_capacity(isize.clamp(raw.len(), raw.len().saturating_mul(64)) + 1);
        // `bufread` reads the input slice in place (the `read` decoder would copy it through a
        // 32 KiB buffer).
        flate2::bufread::MultiGzDecoder::new(&raw[..]).read_to_end(&mut out).map_err(|e| {
            Error::new(ErrorKind::Truncated, format!("cannot decompress gzip data: {e}")).with_location(Location::file(path))
        })?;
        Ok(out)
    } else if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz")) {
        Err(Error::new(ErrorKind::Syntax, "file name ends in .gz but the content is not gzip").with_location(Location::file(path)))
    } else {
        Ok(raw)
    }
}

/// The text of a file (decompressed when gzip), without a leading UTF-8 BOM. Non-UTF-8 bytes
/// are an error naming the line they are on.
pub fn read_text(path: &Path) -> Result<String> {
    let mut bytes = read_bytes(path)?;
    if bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
        bytes.drain(..3);
    }
    // Validated in place: the text is the decompressed buffer itself, not a copy.
    match String::from_utf8(bytes) {
        Ok(s) => Ok(s),
        Err(e) => {
            let body = e.as_bytes();
            let e = e.utf8_error();
            let at = e.valid_up_to();
            let line = body[..at].iter().filter(|b| **b == b'\n').count() + 1;
            Err(Error::at_line(ErrorKind::Syntax, path, line, format!("invalid UTF-8 at byte {at}; expected a text file")))
        }
    }
}

pub use motionlab_core::paths::{format_extension, stem};

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn gzip_and_plain_read_the_same_text() {
        let dir = std::env::temp_dir().join(format!("mlab-read-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let plain = dir.join("a.txt");
        std::fs::write(&plain, "\u{feff}hello\n").unwrap();
        let gz = dir.join("a.txt.gz");
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all("\u{feff}hello\n".as_bytes()).unwrap();
        std::fs::write(&gz, enc.finish().unwrap()).unwrap();
        assert_eq!(read_text(&plain).unwrap(), "hello\n");
        assert_eq!(read_text(&gz).unwrap(), "hello\n");
        let bad = dir.join("b.txt");
        std::fs::write(&bad, b"ok\nline two \xff\n").unwrap();
        let e = read_text(&bad).unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::Syntax, Some(2)));
        let fake = dir.join("c.txt.gz");
        std::fs::write(&fake, "not gzip").unwrap();
        assert_eq!(read_text(&fake).unwrap_err().kind(), ErrorKind::Syntax);
        std::fs::remove_dir_all(&dir).ok();
    }
}
