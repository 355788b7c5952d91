//! MediaPipe protobuf text: `mediapipe::parse_pbtxt`.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_io::mediapipe::parse_pbtxt;

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    match parse_pbtxt(text, Path::new("fuzz.pbtxt")) {
        Ok(frames) => {
            assert!(!frames.is_empty() && frames.iter().all(|f| !f.is_empty()));
            for l in frames.iter().flatten() {
                assert!(l.confidence.is_finite());
            }
        }
        Err(e) => common::assert_names_file(&e, "fuzz.pbtxt"),
    }
});
