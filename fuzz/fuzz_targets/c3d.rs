//! C3D: `parse_c3d` with the default options and with every option flipped (strict reading
//! included), and every analog channel of the raw reader.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::Axis;
use motionlab_io::c3d::raw::C3dFile;
use motionlab_io::c3d::{C3dOptions, parse_c3d};

fuzz_target!(|data: &[u8]| {
    let origin = Path::new("fuzz.c3d");
    match parse_c3d(data, origin, &C3dOptions::default()) {
        Ok(m) => {
            // Points, or (a file without points) its analog channels.
            assert!(m.n_frames() >= 1 && (m.n_points() >= 1 || !m.channels().is_empty()));
            assert_eq!(m.missing_count(), m.missing_mask().iter().filter(|x| **x).count());
        }
        Err(e) => common::assert_names_file(&e, "fuzz.c3d"),
    }
    let zeros = C3dOptions {
        up_axis: Axis::Y,
        zero_means_missing: true,
        strip_subject_prefix: false,
        strict: true,
        analog: false,
    };
    let _ = parse_c3d(data, origin, &zeros);
    if let Ok(m) = parse_c3d(data, origin, &C3dOptions { analog: true, ..C3dOptions::default() }) {
        assert_eq!(m.n_points(), 0);
        assert_eq!(m.channels().n_samples(), m.n_frames());
    }
    if let Ok(file) = C3dFile::parse(data, origin) {
        let _ = file.params();
        if let Ok(layout) = file.data_layout() {
            // Bounded: a mutated ANALOG:USED may claim thousands of channels.
            for channel in 0..8 {
                if file.analog_channel(&layout, channel).is_err() {
                    break;
                }
            }
        }
    }
});
