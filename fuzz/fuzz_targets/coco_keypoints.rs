//! COCO keypoint JSON: `coco_keypoints::parse_coco` (annotations or results), then the motion
//! of the person chosen per image.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::{FrameRate, LoadNotes};
use motionlab_io::coco_keypoints::parse_coco;
use motionlab_io::pose::{PersonRule, motion_of_people};

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    match parse_coco(text, Path::new("fuzz.json")) {
        Ok(c) => {
            assert_eq!(c.frames.len(), c.image_ids.len());
            let n = c.names.len();
            assert!(c.frames.iter().flatten().all(|p| p.len() == n));
            if n == 0 || c.names.iter().collect::<std::collections::HashSet<_>>().len() != n {
                return;
            }
            let (m, _) = motion_of_people(
                "fuzz".into(),
                &c.frames,
                c.names,
                PersonRule::NearestPrevious,
                0.0,
                FrameRate::new(1.0).unwrap(),
                LoadNotes::default(),
            )
            .unwrap();
            assert_eq!(m.n_frames(), c.image_ids.len());
        }
        Err(e) => common::assert_names_file(&e, "fuzz.json"),
    }
});
