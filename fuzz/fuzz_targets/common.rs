//! Shared by the fuzz targets.

/// The bytes as the text loaders see them after `motionlab_io::read::read_text`: a leading
/// UTF-8 BOM stripped, non-UTF-8 input rejected (read_text reports it as a `Syntax` error
/// naming the line; that check is covered by the malformed corpus, not fuzzed here).
#[allow(dead_code)] // not every target reads text (c3d is binary)
pub fn text(data: &[u8]) -> Option<&str> {
    let body = data.strip_prefix(&[0xEF, 0xBB, 0xBF][..]).unwrap_or(data);
    std::str::from_utf8(body).ok()
}

/// An error must name the file it came from (every parser error does; the fuzzer checks it
/// on every rejected input, not just on the hand-written corpus).
#[allow(dead_code)]
pub fn assert_names_file(e: &motionlab_core::Error, file: &str) {
    assert!(
        e.location().file.as_deref() == Some(std::path::Path::new(file)),
        "error without the file name: {e} ({:?})",
        e.kind()
    );
}
