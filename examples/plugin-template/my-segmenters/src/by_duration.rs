//! `by_duration`: a segment classifier (the template's own stage kind, `segment_classifier.rs`)
//! that labels a segment `short` or `long` by its duration.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Motion, Result, TimeSpan};

use crate::segment_classifier::SegmentClassifier;

/// Labels a segment "short" when it lasts less than a threshold, else "long".
///
/// The duration is `(end_frame − start_frame) / rate`; positions are not read, so missing
/// samples do not matter.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ByDurationParams {
    /// Segments shorter than this are "short" (`{ seconds = 2.0 }` or `{ frames = 240 }`), > 0.
    #[serde(default = "default_threshold")]
    pub threshold: TimeSpan,
}

fn default_threshold() -> TimeSpan {
    TimeSpan::Seconds(2.0)
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct ByDuration {
    threshold: TimeSpan,
}

impl ParamGuard for ByDurationParams {
    type Checked = ByDuration;
    fn check(self) -> Result<ByDuration> {
        Ok(ByDuration { threshold: self.threshold.check("threshold", true)? })
    }
}

impl SegmentClassifier for ByDuration {
    fn label(&self, motion: &Motion, start_frame: usize, end_frame: usize) -> Result<String> {
        let length_frames = end_frame.saturating_sub(start_frame) as f64;
        let short = length_frames < self.threshold.frames_at(motion.frame_rate());
        Ok(if short { "short" } else { "long" }.to_string())
    }
}

motionlab_core::register_custom_plugin!(
    SegmentClassifier,
    ByDurationParams,
    "by_duration",
    kind = "segment_classifier"
);

#[cfg(test)]
mod tests {
    use crate::segment_classifier::build_segment_classifier;
    use crate::test_support::still;
    use motionlab_core::ErrorKind;

    #[test]
    fn short_below_the_threshold_long_from_it_on() {
        let params: toml::Value = toml::from_str("threshold = { seconds = 1.5 }").unwrap();
        let c = build_segment_classifier("by_duration", &params).unwrap();
        let m = still(1000, 100.0);
        // 1.49 s, exactly 1.5 s, 3 s.
        assert_eq!(c.label(&m, 10, 159).unwrap(), "short");
        assert_eq!(c.label(&m, 10, 160).unwrap(), "long");
        assert_eq!(c.label(&m, 0, 300).unwrap(), "long");
    }

    #[test]
    fn bad_threshold_and_unknown_name_are_clear_errors() {
        let params: toml::Value = toml::from_str("threshold = { seconds = 0.0 }").unwrap();
        let e = build_segment_classifier("by_duration", &params).err().unwrap();
        assert_eq!(e.location().field.as_deref(), Some("threshold"));
        let e = build_segment_classifier("by_duraton", &motionlab_core::registry::default_params())
            .err()
            .unwrap();
        assert_eq!(e.kind(), ErrorKind::UnknownPlugin);
        assert!(e.to_string().contains("did you mean \"by_duration\""), "{e}");
    }
}
