//! OpenSim TRC: `trc::parse_trc`, then the motion (units to mm) and a write–read round trip.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::{Axis, LengthUnit};
use motionlab_io::trc::{parse_trc, write_trc};

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.trc");
    match parse_trc(text, origin) {
        Ok(t) => {
            assert!(!t.labels.is_empty() && t.n_frames() >= 1);
            assert_eq!(t.positions.len(), t.n_frames() * t.labels.len());
            match t.into_motion(origin, Axis::Y) {
                Ok(m) => {
                    // What motionlab writes, it reads back with the same shape and missing mask.
                    let mut out = Vec::new();
                    write_trc(&m, LengthUnit::Millimetre, "fuzz.trc", &mut out).unwrap();
                    let back = parse_trc(std::str::from_utf8(&out).unwrap(), origin)
                        .and_then(|b| b.into_motion(origin, Axis::Y));
                    // Labels with TABs or newlines cannot be written; anything else must read.
                    if m.point_names().iter().all(|n| !n.contains(['\t', '\n', '\r'])) {
                        let back = back.unwrap();
                        assert_eq!(back.point_names(), m.point_names());
                        assert_eq!(back.missing_mask(), m.missing_mask());
                    }
                }
                Err(e) => common::assert_names_file(&e, "fuzz.trc"),
            }
        }
        Err(e) => common::assert_names_file(&e, "fuzz.trc"),
    }
});
