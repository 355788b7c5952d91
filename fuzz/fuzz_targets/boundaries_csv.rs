//! `boundaries_csv` annotations: `parse_boundaries_csv`, then every sequence's annotator tracks
//! turned into boundaries (`track_segmentation`, the CSV end rule) for motions of a few lengths,
//! at the file's unit (frames at the motion's rate, or seconds at 120 fps). The input's last
//! byte picks a length, so short motions (where most instants are out of range) are reached.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_core::FrameRate;
use motionlab_io::labels::annotations::{EndRule, track_segmentation};
use motionlab_io::labels::boundaries_csv::{CsvUnit, parse_boundaries_csv};

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    let origin = Path::new("fuzz.csv");
    let csv = match parse_boundaries_csv(text, origin) {
        Ok(c) => c,
        Err(e) => return common::assert_names_file(&e, "fuzz.csv"),
    };
    let rate = FrameRate::new(120.0).expect("valid rate");
    let to_frame = |v: f64| match csv.unit {
        CsvUnit::Frames => v,
        CsvUnit::Seconds => v * 120.0,
    };
    let n_frames = usize::from(data.last().copied().unwrap_or(0)) * 37 + 1;
    let sequences: Vec<String> = if csv.has_sequence {
        csv.sequences().into_iter().map(String::from).collect()
    } else {
        vec![String::new()]
    };
    for sequence in &sequences {
        for track in csv.tracks(sequence) {
            assert!(!track.items.is_empty(), "a track without rows");
            match track_segmentation(&track, to_frame, EndRule::LastEndOnly, origin, rate, n_frames)
            {
                // Boundaries are strictly increasing and strictly inside the motion (the first
                // and last frames are the recording's edges, never boundaries).
                Ok(s) => {
                    assert!(s.boundaries.windows(2).all(|w| w[0].frame < w[1].frame));
                    assert!(s.boundaries.iter().all(|b| b.frame > 0 && b.frame + 1 < n_frames));
                    assert!(s.segments.iter().all(|g| g.start <= g.end && g.end <= n_frames));
                }
                Err(e) => common::assert_names_file(&e, "fuzz.csv"),
            }
        }
    }
});
