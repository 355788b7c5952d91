//! AMC: `parse_amc` against the shipped CMU subject-86 skeleton, then forward kinematics.
#![no_main]

mod common;

use std::path::Path;
use std::sync::LazyLock;

use libfuzzer_sys::fuzz_target;
use motionlab_core::FrameRate;
use motionlab_io::asf_amc::{AsfSkeleton, amc_motion, parse_amc, parse_asf};

static ASF: LazyLock<AsfSkeleton> = LazyLock::new(|| {
    parse_asf(include_str!("../../data/cmu86/86.asf"), Path::new("86.asf"))
        .expect("the shipped 86.asf parses")
});

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.amc");
    match parse_amc(text, origin, &ASF) {
        Ok(channels) => {
            let rate = FrameRate::new(120.0).expect("120 Hz is a valid rate");
            let motion =
                amc_motion(channels, origin, rate).expect("forward kinematics of parsed AMC");
            assert!(motion.n_frames() >= 1);
        }
        Err(e) => common::assert_names_file(&e, "fuzz.amc"),
    }
});
