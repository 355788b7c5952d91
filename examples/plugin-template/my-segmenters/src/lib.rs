//! My motionlab plugins. Each plugin is one file, registered with `register_plugin!` (a
//! built-in stage kind) or `register_custom_plugin!` (a kind of my own, declared in
//! `segment_classifier.rs`); this crate only has to be named by the binary
//! (`my-motionlab/src/main.rs`) to be linked.

pub mod by_duration;
pub mod fixed_interval;
pub mod segment_classifier;
