//! Xsens MVNX: `mvnx::parse_mvnx` (roxmltree), then the motion (positions, channels, events).
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_io::mvnx::parse_mvnx;

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.mvnx");
    match parse_mvnx(text, origin) {
        Ok(f) => {
            let n = f.positions.len();
            assert!(n >= 1 && f.orientations.len() == n);
            match f.into_motion(origin) {
                Ok(m) => {
                    assert_eq!(m.n_frames(), n);
                    assert!(m.events.iter().all(|e| e.frame >= 1.0 && e.frame < n as f64));
                }
                Err(e) => common::assert_names_file(&e, "fuzz.mvnx"),
            }
        }
        Err(e) => common::assert_names_file(&e, "fuzz.mvnx"),
    }
});
