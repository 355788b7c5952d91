//! CMU-86 labels (`mocap.txt`): `parse_cmu86_labels`, then every trial's segmentation at the
//! label rate and at a different motion rate, for the real 86_01 length and a short motion.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::FrameRate;
use motionlab_io::labels::cmu86::{parse_cmu86_labels, trial_segmentation};

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.txt");
    let trials = match parse_cmu86_labels(text, origin) {
        Ok(t) => t,
        Err(e) => return common::assert_names_file(&e, "fuzz.txt"),
    };
    let r120 = FrameRate::new(120.0).expect("valid rate");
    let r60 = FrameRate::new(60.0).expect("valid rate");
    for block in &trials {
        for (motion_rate, n_frames) in [(r120, 4579), (r60, 2290), (r120, 10)] {
            match trial_segmentation(block, origin, r120, motion_rate, n_frames) {
                Ok(s) => {
                    // Segments tile the labelled stretch in order.
                    for w in s.segments.windows(2) {
                        assert_eq!(w[0].end, w[1].start);
                    }
                    assert!(s.segments.iter().all(|g| g.start < g.end && g.end <= n_frames));
                }
                Err(e) => common::assert_names_file(&e, "fuzz.txt"),
            }
        }
    }
});
