//! My motionlab plugins. Each plugin is one file, registered with `register_plugin!`; this
//! crate only has to be named by the binary (`my-motionlab/src/main.rs`) to be linked.

pub mod fixed_interval;
