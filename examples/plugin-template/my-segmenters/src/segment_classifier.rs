//! A stage kind of my own: `segment_classifier` — labels one segment of a motion.
//!
//! motionlab's built-in kinds (segmenter, fuser, evaluator, …) are a closed table in its core;
//! a new kind needs no edit there: declare its trait here, register each implementation with
//! `register_custom_plugin!(SegmentClassifier, …, kind = "segment_classifier")` (see
//! `by_duration.rs`) and build one by name with [`build_segment_classifier`]. `motionlab list`
//! shows the kind under its name, `motionlab describe <plugin>` documents each plugin.

use motionlab_core::{Motion, Result};

/// The kind's name, as `register_custom_plugin!(…, kind = "segment_classifier")` and
/// `motionlab list` write it.
pub const KIND: &str = "segment_classifier";

/// Labels a segment of a motion (`short`/`long`, `walk`/`turn`, …).
pub trait SegmentClassifier: Send + Sync {
    /// The label of frames `start_frame..end_frame` (end exclusive) of `motion`.
    fn label(&self, motion: &Motion, start_frame: usize, end_frame: usize) -> Result<String>;
}

/// Builds the segment classifier registered as `name` from its TOML table (without `type`);
/// an unknown name is an error naming the closest registered classifiers.
pub fn build_segment_classifier(
    name: &str,
    params: &motionlab_core::toml::Value,
) -> Result<Box<dyn SegmentClassifier>> {
    motionlab_core::registry::build_custom::<dyn SegmentClassifier>(KIND, name, params)
}
