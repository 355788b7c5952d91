//! OpenPose JSON: `openpose::parse_frame` of one frame file, then the chosen person of a
//! three-frame motion made of it (the same frame thrice) under both person rules.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::{FrameRate, LoadNotes};
use motionlab_io::openpose::parse_frame;
use motionlab_io::pose::{PersonRule, motion_of_people};

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    match parse_frame(text, Path::new("fuzz.json")) {
        Ok(f) => {
            assert_eq!(f.people.len(), f.lines.len());
            let n = f.people.first().map_or(0, Vec::len);
            if n == 0 || f.people.iter().any(|p| p.len() != n) {
                return;
            }
            let frames = vec![f.people.clone(), Vec::new(), f.people];
            for rule in [PersonRule::HighestMeanConfidence, PersonRule::NearestPrevious] {
                let names = (0..n).map(|k| format!("kp{k}")).collect();
                let (m, chosen) = motion_of_people(
                    "fuzz".into(),
                    &frames,
                    names,
                    rule,
                    0.05,
                    FrameRate::new(30.0).unwrap(),
                    LoadNotes::default(),
                )
                .unwrap();
                assert_eq!((m.n_frames(), m.n_points(), chosen.len()), (3, n, 3));
                assert!(chosen[1].is_none() && (0..n).all(|k| m.is_missing(1, k)));
                assert_eq!(m.confidence().unwrap().len(), 3 * n);
            }
        }
        Err(e) => common::assert_names_file(&e, "fuzz.json"),
    }
});
