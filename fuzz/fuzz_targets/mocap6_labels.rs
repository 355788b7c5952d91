//! mocap6 block labels: `parse_mocap6_labels`, then the segmentation of motions of a few
//! lengths and block sizes (the input's last byte picks a length, so short ones are reached).
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::{Axis, FrameRate, Motion, PointKind};
use motionlab_io::labels::mocap6::{block_segmentation, parse_mocap6_labels};

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.txt");
    let labels = match parse_mocap6_labels(text, origin) {
        Ok(l) => l,
        Err(e) => return common::assert_names_file(&e, "fuzz.txt"),
    };
    let n_frames = usize::from(data.last().copied().unwrap_or(0)) * 13 + 1;
    let rate = FrameRate::new(120.0).expect("valid rate");
    let motion = Motion::new(
        "m",
        rate,
        Axis::Y,
        PointKind::Joint,
        vec!["root".into()],
        vec![[0.0; 3]; n_frames],
    )
    .expect("a one-point motion");
    for block_frames in [1, 12, usize::MAX] {
        match block_segmentation(&labels, origin, block_frames, &motion) {
            Ok(s) => assert!(s.segments.iter().all(|g| g.start < g.end && g.end <= n_frames)),
            Err(e) => common::assert_names_file(&e, "fuzz.txt"),
        }
    }
});
