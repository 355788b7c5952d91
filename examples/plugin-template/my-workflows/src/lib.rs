//! My motionlab workflows. Each workflow is one file that owns a section of the experiment
//! file and registers itself with `register_workflow!`; this crate only has to be named by the
//! binary (`my-motionlab/src/main.rs`) to be linked.

pub mod segment_stats;
