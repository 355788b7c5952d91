//! ELAN `.eaf` annotations: `parse_eaf`, then every time-aligned tier turned into boundaries
//! (`track_segmentation`, every segment end a boundary) with milliseconds mapped to frames at
//! 120 fps, for motions of a few lengths (the input's last byte picks one).
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::FrameRate;
use motionlab_io::labels::annotations::{EndRule, track_segmentation};
use motionlab_io::labels::elan_eaf::parse_eaf;

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.eaf");
    let tiers = match parse_eaf(text, origin) {
        Ok(t) => t,
        Err(e) => return common::assert_names_file(&e, "fuzz.eaf"),
    };
    let rate = FrameRate::new(120.0).expect("valid rate");
    let n_frames = usize::from(data.last().copied().unwrap_or(0)) * 251 + 1;
    for tier in tiers.iter().filter(|t| t.time_aligned) {
        assert!(
            tier.track.items.iter().all(|i| i.end.as_ref().is_some_and(|(_, end)| i.start <= *end))
        );
        match track_segmentation(
            &tier.track,
            |ms| ms * 120.0 / 1000.0,
            EndRule::EveryEnd,
            origin,
            rate,
            n_frames,
        ) {
            Ok(s) => {
                assert!(s.boundaries.windows(2).all(|w| w[0].frame < w[1].frame));
                assert!(s.boundaries.iter().all(|b| b.frame > 0 && b.frame + 1 < n_frames));
            }
            Err(e) => common::assert_names_file(&e, "fuzz.eaf"),
        }
    }
});
