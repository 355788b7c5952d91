//! The bounded reader behind every motion and annotation file: `read::decode_within` (gzip by
//! its magic bytes — libdeflate for one whole member within the limit, else flate2's streaming
//! decoder, counting first) at a limit of 64 KiB. What it returns is never beyond the limit and
//! is exactly what flate2's multi-member decoder inflates; what it refuses names the file.
#![no_main]

mod common;

use std::io::Read;
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_io::read::decode_within;

const LIMIT: u64 = 64 << 10;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.tsv.gz");
    match decode_within(data.to_vec(), LIMIT, path) {
        Ok(out) => {
            assert!(out.len() as u64 <= LIMIT, "{} bytes returned past the limit", out.len());
            // The reference: flate2 on its own, read no further than just past the limit.
            let mut reference = Vec::new();
            let result = flate2::bufread::MultiGzDecoder::new(data)
                .take(LIMIT + 1)
                .read_to_end(&mut reference);
            assert!(result.is_ok(), "accepted what flate2 refuses: {result:?}");
            assert!(out == reference, "libdeflate and flate2 disagree");
        }
        Err(e) => common::assert_names_file(&e, "fuzz.tsv.gz"),
    }
});
