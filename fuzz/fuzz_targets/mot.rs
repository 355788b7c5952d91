//! OpenSim MOT/STO: `mot::parse_storage`, then the channel motion.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_io::mot::parse_storage;

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.mot");
    match parse_storage(text, origin) {
        Ok(s) => {
            assert!(!s.labels.is_empty() && s.n_rows() >= 1);
            assert_eq!(s.values.len(), s.n_rows() * s.labels.len());
            match s.into_motion(origin, None) {
                Ok(m) => assert_eq!(m.channels().n_samples(), m.n_frames()),
                Err(e) => common::assert_names_file(&e, "fuzz.mot"),
            }
        }
        Err(e) => common::assert_names_file(&e, "fuzz.mot"),
    }
});
