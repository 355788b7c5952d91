//! Qualisys TSV: `parse_qualisys_tsv`.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::Axis;
use motionlab_io::qualisys_tsv::parse_qualisys_tsv;

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    match parse_qualisys_tsv(text, Path::new("fuzz.tsv"), Axis::Z) {
        Ok(m) => {
            assert!(m.n_points() >= 1);
            assert_eq!(m.positions().len(), m.n_frames() * m.n_points());
        }
        Err(e) => common::assert_names_file(&e, "fuzz.tsv"),
    }
});
