//! BVH: `parse_bvh` with the inferred and with an explicit length unit (the inference rejects
//! most mutated skeletons, which would otherwise hide the frame scanner and forward
//! kinematics), position channels replacing and adding to the OFFSET, then a write → re-read
//! round trip of whatever parsed.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::{Axis, LengthUnit};
use motionlab_io::bvh::{BvhOptions, PositionChannels, parse_bvh, parse_bvh_channels, write_bvh};

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.bvh");
    if let Err(e) = parse_bvh(text, origin, &BvhOptions::default()) {
        common::assert_names_file(&e, "fuzz.bvh");
    }
    let explicit = BvhOptions {
        length_unit: Some(LengthUnit::Centimetre),
        up_axis: Axis::Y,
        position_channels: PositionChannels::Add,
    };
    match parse_bvh_channels(text, origin, &explicit) {
        Ok(data) => {
            // Whatever the reader accepts, the writer must write and the reader re-read with
            // the same shape (values may round at the writer's 6 decimals).
            let mut out = Vec::new();
            write_bvh(&data.motion, data.frame_rate, LengthUnit::Centimetre, &mut out)
                .expect("write_bvh of a parsed file");
            let again = std::str::from_utf8(&out).expect("write_bvh writes UTF-8");
            let back = parse_bvh_channels(again, Path::new("rewritten.bvh"), &explicit)
                .expect("re-reading written BVH");
            assert_eq!(back.motion.n_frames(), data.motion.n_frames());
            assert_eq!(back.motion.n_channels(), data.motion.n_channels());
            assert_eq!(back.motion.skeleton.joints.len(), data.motion.skeleton.joints.len());
            let _ = motionlab_io::bvh::bvh_motion(data, origin, Axis::Y);
        }
        Err(e) => common::assert_names_file(&e, "fuzz.bvh"),
    }
});
