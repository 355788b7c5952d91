//! An external program's stdout (motionlab-external's protocol 1): `parse_reply` into a
//! segmenter's and a feature extractor's reply, then `segmenter_output` / `feature_set` against
//! motions of a few lengths (the input's last byte picks one). What they accept is what the
//! workflows then trust: candidates and flagged frames inside the motion, strictly ascending;
//! one value per frame for every trace and label; finite thresholds naming a returned trace;
//! unique column-safe names.
#![no_main]

use libfuzzer_sys::fuzz_target;
use motionlab_external::protocol::{
    FeaturesReply, SegmenterReply, feature_set, parse_reply, segmenter_output,
};

fn column_safe(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

fuzz_target!(|data: &[u8]| {
    let n_frames = usize::from(data.last().copied().unwrap_or(0)) % 17;
    if let Ok(reply) = parse_reply::<SegmenterReply>(data)
        && let Ok(out) = segmenter_output(reply, n_frames)
    {
        for frames in [&out.candidates, &out.flagged_frames] {
            assert!(frames.iter().all(|&f| f < n_frames));
            assert!(frames.windows(2).all(|w| w[0] < w[1]));
        }
        assert!(out.traces.iter().all(|t| t.values.len() == n_frames && column_safe(&t.name)));
        for t in &out.thresholds {
            assert!(t.value.is_finite() && out.traces.iter().any(|tr| tr.name == t.trace));
        }
    }
    if let Ok(reply) = parse_reply::<FeaturesReply>(data)
        && let Ok(set) = feature_set(reply, n_frames)
    {
        assert!(!set.traces.is_empty() || !set.labels.is_empty());
        assert!(set.traces.iter().all(|t| t.values.len() == n_frames && column_safe(&t.name)));
        assert!(set.labels.iter().all(|l| l.values.len() == n_frames && column_safe(&l.name)));
        let mut names: Vec<&str> = set
            .traces
            .iter()
            .map(|t| t.name.as_str())
            .chain(set.labels.iter().map(|l| l.name.as_str()))
            .collect();
        names.sort();
        assert!(names.windows(2).all(|w| w[0] != w[1]), "a name returned twice was accepted");
    }
});
