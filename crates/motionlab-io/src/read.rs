//! Reading input files: transparent gzip (by the `.gz` suffix or the gzip magic bytes), a
//! UTF-8 check that names the offending line, and a leading BOM stripped.
//!
//! Every file is bounded by the input limit ([`motionlab_core::limits`]: 1024 MiB after
//! decompression unless `MOTIONLAB_MAX_INPUT_MB` says otherwise). A file beyond it is refused
//! by its size before it is read; a gzip file beyond it without ever holding its content: the
//! one-call inflate is taken only when the trailer's size is within the limit, and anything
//! else is first inflated by the streaming decoder into a counter (a 64 KiB buffer), which stops
//! at the limit, before the content is inflated for real into a buffer of the counted size.

use std::io::Read;
use std::path::Path;

use motionlab_core::limits;
use motionlab_core::{Error, ErrorKind, Location, Result};

/// The bytes of a file, decompressed when it is gzip (by suffix or magic number), refused when
/// they exceed the input limit ([`limits::max_input_bytes`]).
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    read_bytes_within(path, limits::max_input_bytes()?)
}

/// [`read_bytes`] with an explicit limit on the file's (decompressed) size in bytes.
pub fn read_bytes_within(path: &Path, limit: u64) -> Result<Vec<u8>> {
    decode_within(limits::read_input_file(path, limit)?, limit, path)
}

/// The content of a file's bytes `raw` (read from `path`, which errors name): inflated when
/// gzip, refused past `limit` (also the fuzz target `gunzip`'s entry point).
pub fn decode_within(raw: Vec<u8>, limit: u64, path: &Path) -> Result<Vec<u8>> {
    if raw.starts_with(&[0x1f, 0x8b]) {
        if let Some(out) = gunzip_single_member(&raw, limit) {
            return Ok(out);
        }
        // Not one whole member within the limit (several members, trailing bytes, a corrupt
        // stream, a trailer that lies): flate2, which reads every member and names what is
        // wrong — first only counting, so that nothing beyond the limit is ever held.
        let len = inflated_len(&raw, limit, path)?;
        let mut out = Vec::with_capacity(len);
        // `bufread` reads the input slice in place (the `read` decoder would copy it through a
        // 32 KiB buffer).
        flate2::bufread::MultiGzDecoder::new(&raw[..])
            .read_to_end(&mut out)
            .map_err(|e| gzip_error(path, &e))?;
        Ok(out)
    } else if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz")) {
        Err(Error::new(ErrorKind::Syntax, "file name ends in .gz but the content is not gzip")
            .with_location(Location::file(path)))
    } else if raw.len() as u64 > limit {
        Err(limits::too_large(path, &format!("holds {} bytes", raw.len()), limit))
    } else {
        Ok(raw)
    }
}

fn gzip_error(path: &Path, e: &std::io::Error) -> Error {
    Error::new(ErrorKind::Truncated, format!("cannot decompress gzip data: {e}"))
        .with_location(Location::file(path))
}

/// How many bytes the gzip data inflate to, counted through a small buffer; an error as soon
/// as the count passes `limit`, or when the stream is corrupt.
fn inflated_len(raw: &[u8], limit: u64, path: &Path) -> Result<usize> {
    let mut decoder = flate2::bufread::MultiGzDecoder::new(raw);
    let mut buf = vec![0u8; 64 << 10];
    let mut total: u64 = 0;
    loop {
        let n = match decoder.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(gzip_error(path, &e)),
        };
        total += n as u64;
        if total > limit {
            return Err(limits::too_large(
                path,
                &format!("gzip data of {} bytes inflate to more than {total} bytes", raw.len()),
                limit,
            ));
        }
    }
    usize::try_from(total)
        .map_err(|_| limits::too_large(path, &format!("inflates to {total} bytes"), limit))
}

/// A gzip file of exactly one member, inflated by libdeflate in one call into a buffer of the
/// size its trailer states (ISIZE); `None` when the data is not exactly that — a corrupt or
/// truncated stream, a CRC or size mismatch, several members or bytes after the member, a size
/// beyond `limit` — so the caller can fall back to the streaming decoder, which handles those
/// (or reports them). A trailer that understates the size fails here (libdeflate writes no
/// more than ISIZE bytes) and goes to the counting decoder too.
/// libdeflate checks the member's CRC-32 and ISIZE itself.
fn gunzip_single_member(raw: &[u8], limit: u64) -> Option<Vec<u8>> {
    let isize = raw.last_chunk::<4>().map(|b| u32::from_le_bytes(*b) as usize)?;
    // DEFLATE expands at most 1032:1; a larger ISIZE is a corrupt trailer (or a member of
    // 4 GiB or more, whose size ISIZE only gives mod 2³²): leave it to the streaming decoder,
    // as a size beyond the input limit, which that decoder refuses after counting.
    if isize == 0 || isize > raw.len().saturating_mul(1032) || isize as u64 > limit {
        return None;
    }
    let (mut used_in, mut used_out) = (0usize, 0usize);
    // SAFETY: the decompressor is checked non-null and freed by the guard; libdeflate reads
    // `raw.len()` bytes from `raw` and writes at most `isize` bytes into `out`'s allocation (its
    // capacity), reporting in `used_out` how many it wrote — the only ones `set_len` exposes.
    unsafe {
        struct Decompressor(*mut libdeflate_sys::libdeflate_decompressor);
        impl Drop for Decompressor {
            fn drop(&mut self) {
                // SAFETY: allocated by libdeflate_alloc_decompressor, freed once.
                unsafe { libdeflate_sys::libdeflate_free_decompressor(self.0) }
            }
        }
        let d = Decompressor(libdeflate_sys::libdeflate_alloc_decompressor());
        if d.0.is_null() {
            return None;
        }
        // Allocated after the decompressor's small block, so freeing that block does not leave
        // free memory above the output at the top of the heap (which glibc would give back to
        // the system and fault in again at the next load).
        let mut out: Vec<u8> = Vec::with_capacity(isize);
        let result = libdeflate_sys::libdeflate_gzip_decompress_ex(
            d.0,
            raw.as_ptr().cast(),
            raw.len(),
            out.as_mut_ptr().cast(),
            isize,
            &mut used_in,
            &mut used_out,
        );
        if result != libdeflate_sys::libdeflate_result_LIBDEFLATE_SUCCESS
            || used_in != raw.len()
            || used_out != isize
        {
            return None;
        }
        out.set_len(used_out);
        Some(out)
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
            Err(Error::at_line(
                ErrorKind::Syntax,
                path,
                line,
                format!("invalid UTF-8 at byte {at}; expected a text file"),
            ))
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

    /// flate2's multi-member decoder, the reference for [`gunzip_single_member`].
    fn flate2_gunzip(raw: &[u8]) -> std::io::Result<Vec<u8>> {
        let mut out = Vec::new();
        flate2::bufread::MultiGzDecoder::new(raw).read_to_end(&mut out)?;
        Ok(out)
    }

    #[test]
    fn libdeflate_inflates_every_shipped_gz_like_flate2() {
        let data = motionlab_testkit::data_path("");
        let mut gz: Vec<std::path::PathBuf> = Vec::new();
        let mut dirs = vec![data];
        while let Some(d) = dirs.pop() {
            for e in std::fs::read_dir(&d).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    dirs.push(p);
                } else if p.extension().is_some_and(|e| e == "gz") {
                    gz.push(p);
                }
            }
        }
        assert!(gz.len() >= 10, "{gz:?}");
        for p in gz {
            let raw = std::fs::read(&p).unwrap();
            let fast = gunzip_single_member(&raw, u64::MAX)
                .unwrap_or_else(|| panic!("{}: not taken", p.display()));
            assert!(fast == flate2_gunzip(&raw).unwrap(), "{}", p.display());
        }
    }

    #[test]
    fn anything_but_one_whole_member_goes_to_flate2() {
        let member = |text: &str| {
            let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
            enc.write_all(text.as_bytes()).unwrap();
            enc.finish().unwrap()
        };
        let one = member("one member\n");
        assert_eq!(gunzip_single_member(&one, u64::MAX).as_deref(), Some(&b"one member\n"[..]));
        // Two members: libdeflate would stop after the first; the fallback reads both.
        let two = [member("first\n"), member("second\n")].concat();
        assert_eq!(gunzip_single_member(&two, u64::MAX), None);
        let dir = std::env::temp_dir().join(format!("mlab-read-members-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("two.txt.gz");
        std::fs::write(&path, &two).unwrap();
        assert_eq!(read_text(&path).unwrap(), "first\nsecond\n");
        // A flipped CRC or a cut stream: not taken, and the fallback reports it.
        let mut bad_crc = one.clone();
        let n = bad_crc.len();
        bad_crc[n - 8] ^= 1;
        assert_eq!(gunzip_single_member(&bad_crc, u64::MAX), None);
        assert_eq!(gunzip_single_member(&one[..one.len() - 3], u64::MAX), None);
        std::fs::write(&path, &one[..one.len() / 2]).unwrap();
        assert_eq!(read_text(&path).unwrap_err().kind(), ErrorKind::Truncated);
        std::fs::remove_dir_all(&dir).ok();
    }

    fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(bytes).unwrap();
        enc.finish().unwrap()
    }

    /// A bomb in every shape the reader takes a different path for — an honest trailer, a
    /// trailer that understates the size, two members, a plain file — is refused at the limit
    /// with one error naming the file, and a file at the limit is read.
    #[test]
    fn input_beyond_the_limit_is_refused_in_every_shape() {
        let dir = std::env::temp_dir().join(format!("mlab-read-limit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let zeros = vec![0u8; 1 << 20];
        let honest = gzip(&zeros);
        let mut lying = honest.clone();
        let n = lying.len();
        lying[n - 4..].copy_from_slice(&1000u32.to_le_bytes());
        let two = [gzip(&zeros[..600 << 10]), gzip(&zeros[..600 << 10])].concat();
        let limit = 1 << 19;
        for (name, bytes) in [
            ("honest.tsv.gz", &honest),
            ("lying.tsv.gz", &lying),
            ("two.tsv.gz", &two),
            ("plain.tsv", &zeros),
        ] {
            let path = dir.join(name);
            std::fs::write(&path, bytes).unwrap();
            let e = read_bytes_within(&path, limit).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::TooLarge, "{name}: {e}");
            assert_eq!(e.location().file.as_deref(), Some(path.as_path()), "{name}");
            assert!(
                e.to_string().contains(
                    "more than the input limit of 524288 bytes (set MOTIONLAB_MAX_INPUT_MB"
                ),
                "{name}: {e}"
            );
            // Within the limit: read — but a trailer that lies is a corrupt file, and the two
            // members hold more than the limit.
            match name {
                "lying.tsv.gz" => assert_eq!(
                    read_bytes_within(&path, 1 << 20).unwrap_err().kind(),
                    ErrorKind::Truncated
                ),
                "two.tsv.gz" => assert_eq!(
                    read_bytes_within(&path, 1 << 20).unwrap_err().kind(),
                    ErrorKind::TooLarge
                ),
                _ => {
                    assert_eq!(read_bytes_within(&path, 1 << 20).unwrap().len(), 1 << 20, "{name}")
                }
            }
        }
        // Two members of 600 KiB: within a limit of 1200 KiB, both read.
        let path = dir.join("two.tsv.gz");
        assert_eq!(read_bytes_within(&path, 1200 << 10).unwrap().len(), 1200 << 10);
        assert_eq!(
            read_bytes_within(&path, (1200 << 10) - 1).unwrap_err().kind(),
            ErrorKind::TooLarge
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
