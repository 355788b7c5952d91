//! ASF: `parse_asf`, then the rest pose by forward kinematics and one AMC frame of zeros
//! (what the loader does with every skeleton it accepts).
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::FrameRate;
use motionlab_io::asf_amc::{amc_motion, parse_amc, parse_asf};

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.asf");
    match parse_asf(text, origin) {
        Ok(asf) => {
            let zeros = vec![0.0; asf.skeleton.n_channels()];
            let (points, _) = asf.skeleton.forward_kinematics(&zeros);
            assert_eq!(points.len(), asf.skeleton.point_names().len());
            // One frame naming every bone that has dofs, all values 0.
            let mut amc = String::from(":FULLY-SPECIFIED\n:DEGREES\n1\n");
            for j in &asf.skeleton.joints {
                if !j.channels.is_empty() {
                    amc.push_str(&j.name);
                    for _ in &j.channels {
                        amc.push_str(" 0");
                    }
                    amc.push('\n');
                }
            }
            if let Ok(channels) = parse_amc(&amc, Path::new("zeros.amc"), &asf) {
                let rate = FrameRate::new(120.0).expect("120 Hz is a valid rate");
                let _ = amc_motion(channels, Path::new("zeros.amc"), rate);
            }
        }
        Err(e) => common::assert_names_file(&e, "fuzz.asf"),
    }
});
